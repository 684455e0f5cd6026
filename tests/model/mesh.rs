//! Mass properties of closed triangle meshes, and the mesh readers.
//!
//! Every numeric bound has the value measured when it was written beside it; references are
//! closed forms or formulas implemented here independently of the library (Tonon's tetrahedron
//! formulas, a naive origin-based integration, the regular-prism integrals).

use crate::common::urdfs::rel;
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use std::collections::HashMap;
use std::f64::consts::PI;
use std::path::Path;
use tumble::model::MassProperties;
use tumble::model::geometry::mesh::{MeshError, TriangleMesh};
use tumble::model::geometry::mesh_io::{self, DaeOptions, UpAxis};

// ---------------------------------------------------------------------------------------------
// Meshes built here.

/// Box `[lo, hi]`: 8 corners (index = x + 2y + 4z bits), 12 triangles wound outward.
fn box_mesh(lo: Vector3<f64>, hi: Vector3<f64>) -> TriangleMesh {
    let vertices = (0..8)
        .map(|i| {
            Vector3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            )
        })
        .collect();
    let triangles = vec![
        [0, 2, 3],
        [0, 3, 1], // -z
        [4, 5, 7],
        [4, 7, 6], // +z
        [0, 1, 5],
        [0, 5, 4], // -y
        [2, 6, 7],
        [2, 7, 3], // +y
        [0, 4, 6],
        [0, 6, 2], // -x
        [1, 3, 7],
        [1, 7, 5], // +x
    ];
    TriangleMesh {
        vertices,
        triangles,
    }
}

fn unit_cube() -> TriangleMesh {
    box_mesh(Vector3::zeros(), Vector3::repeat(1.0))
}

/// Mass properties of a solid box of sides `d` centred at `centre`, density `rho`.
fn box_closed_form(d: Vector3<f64>, centre: Vector3<f64>, rho: f64) -> MassProperties {
    let m = rho * d.x * d.y * d.z;
    MassProperties::new(
        m,
        centre,
        Matrix3::from_diagonal(&Vector3::new(
            m * (d.y * d.y + d.z * d.z) / 12.0,
            m * (d.x * d.x + d.z * d.z) / 12.0,
            m * (d.x * d.x + d.y * d.y) / 12.0,
        )),
    )
}

/// Regular `n`-gon prism of circumradius `r` and length `l` along z, centred at the origin:
/// rings of `n` vertices at z = ∓l/2 and a centre vertex on each cap.
fn prism(n: u32, r: f64, l: f64) -> TriangleMesh {
    let mut vertices = Vec::new();
    for z in [-l / 2.0, l / 2.0] {
        for i in 0..n {
            let a = 2.0 * PI * f64::from(i) / f64::from(n);
            vertices.push(Vector3::new(r * a.cos(), r * a.sin(), z));
        }
    }
    vertices.push(Vector3::new(0.0, 0.0, -l / 2.0));
    vertices.push(Vector3::new(0.0, 0.0, l / 2.0));
    let (bottom, top) = (2 * n, 2 * n + 1);
    let mut triangles = Vec::new();
    for i in 0..n {
        let j = (i + 1) % n;
        triangles.push([i, j, n + j]);
        triangles.push([i, n + j, n + i]);
        triangles.push([bottom, j, i]);
        triangles.push([top, n + i, n + j]);
    }
    TriangleMesh {
        vertices,
        triangles,
    }
}

/// Icosahedron subdivided `levels` times (each triangle into 4 by its edge midpoints), every
/// vertex pushed onto the sphere of radius `r`.
fn icosphere(levels: u32, r: f64) -> TriangleMesh {
    let g = (1.0 + 5f64.sqrt()) / 2.0;
    let mut vertices: Vec<Vector3<f64>> = [
        [-1.0, g, 0.0],
        [1.0, g, 0.0],
        [-1.0, -g, 0.0],
        [1.0, -g, 0.0],
        [0.0, -1.0, g],
        [0.0, 1.0, g],
        [0.0, -1.0, -g],
        [0.0, 1.0, -g],
        [g, 0.0, -1.0],
        [g, 0.0, 1.0],
        [-g, 0.0, -1.0],
        [-g, 0.0, 1.0],
    ]
    .iter()
    .map(|v| Vector3::from(*v).normalize() * r)
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut midpoint: HashMap<(u32, u32), u32> = HashMap::new();
        let mut mid = |a: u32, b: u32, vertices: &mut Vec<Vector3<f64>>| -> u32 {
            *midpoint.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let m = (vertices[a as usize] + vertices[b as usize]).normalize() * r;
                vertices.push(m);
                (vertices.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(4 * triangles.len());
        for &[a, b, c] in &triangles {
            let ab = mid(a, b, &mut vertices);
            let bc = mid(b, c, &mut vertices);
            let ca = mid(c, a, &mut vertices);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    TriangleMesh {
        vertices,
        triangles,
    }
}

/// A tetrahedron with vertices `p`, wound outward whatever the order of `p`.
fn tetrahedron(p: [Vector3<f64>; 4]) -> TriangleMesh {
    let mut triangles = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
    if (p[1] - p[0]).cross(&(p[2] - p[0])).dot(&(p[3] - p[0])) < 0.0 {
        for t in &mut triangles {
            t.swap(1, 2);
        }
    }
    TriangleMesh {
        vertices: p.to_vec(),
        triangles,
    }
}

/// Largest entry difference of two tensors relative to the largest entry of the second.
fn rel_matrix(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    (a - b).amax() / b.amax()
}

fn mass_properties(mesh: &TriangleMesh, rho: f64) -> MassProperties {
    match mesh.mass_properties(rho) {
        Ok(mp) => mp,
        Err(e) => panic!("mass properties: {e}"),
    }
}

/// Relative distance of mass, com (relative to `scale_m`) and inertia.
fn mp_error(a: &MassProperties, b: &MassProperties, scale_m: f64) -> (f64, f64, f64) {
    (
        rel(a.mass, b.mass),
        (a.com - b.com).amax() / scale_m,
        rel_matrix(&a.inertia, &b.inertia),
    )
}

// ---------------------------------------------------------------------------------------------
// Closed forms.

#[test]
fn box_of_twelve_triangles_is_exact() {
    let lo = Vector3::new(-0.3, 0.1, 2.0);
    let d = Vector3::new(0.7, 1.3, 0.25);
    let mp = mass_properties(&box_mesh(lo, lo + d), 1000.0);
    let expected = box_closed_form(d, lo + d / 2.0, 1000.0);
    let (em, ec, ei) = mp_error(&mp, &expected, d.amax());
    // Round-off only (a dozen operations per triangle): measured mass 1.2e-16, com 0,
    // inertia 1.7e-16; bound 1e-14 (45 eps).
    assert!(
        em < 1e-14 && ec < 1e-14 && ei < 1e-14,
        "{em:e} {ec:e} {ei:e}"
    );
    // Off-diagonals vanish to round-off of the diagonal: measured 2.6e-17 kg m² against
    // 41.3 kg m²; bound 1e-14 relative.
    let off = mp.inertia - Matrix3::from_diagonal(&mp.inertia.diagonal());
    assert!(off.amax() < 1e-14 * mp.inertia.amax(), "{off}");
    assert!(mp.validate().is_empty());
}

#[test]
fn prism_is_exact_and_converges_to_the_cylinder_at_second_order() {
    let (r, l, rho): (f64, f64, f64) = (0.2, 0.9, 7800.0);
    // Exact prism integrals: polygon area A = n r² sin α / 2 and polar moment
    // J = n r⁴ sin α (2 + cos α) / 12 (α = 2π/n; each of the n triangles (O, P_i, P_i+1) has
    // J = A_t (|a|² + |b|² + a·b)/6); n-fold symmetry gives ∫x² = ∫y² = J/2.
    let exact = |n: u32| {
        let a = 2.0 * PI / f64::from(n);
        let area = f64::from(n) * r * r * a.sin() / 2.0;
        let polar = f64::from(n) * r.powi(4) * a.sin() * (2.0 + a.cos()) / 12.0;
        let m = rho * area * l;
        let ixx = rho * (l * polar / 2.0 + area * l.powi(3) / 12.0);
        MassProperties::new(
            m,
            Vector3::zeros(),
            Matrix3::from_diagonal(&Vector3::new(ixx, ixx, rho * l * polar)),
        )
    };
    let cylinder_volume = PI * r * r * l;
    let cylinder_izz = rho * cylinder_volume * r * r / 2.0;
    let mut volume_errors = Vec::new();
    let mut izz_errors = Vec::new();
    for n in [32, 64, 128, 256] {
        let mp = mass_properties(&prism(n, r, l), rho);
        let (em, ec, ei) = mp_error(&mp, &exact(n), r);
        // Against the exact prism, round-off only (growing with n, and with the rounding of
        // sin(2π/n) in the reference): measured worst mass 1.1e-14 (n = 256), com 1.6e-16 r,
        // inertia 4.6e-15 (n = 128); bound 1e-13.
        assert!(
            em < 1e-13 && ec < 1e-13 && ei < 1e-13,
            "n={n}: {em:e} {ec:e} {ei:e}"
        );
        volume_errors.push(rel(mp.mass / rho, cylinder_volume));
        izz_errors.push(rel(mp.inertia[(2, 2)], cylinder_izz));
    }
    // Against the cylinder the error is (2π/n)²/6 + O(n⁻⁴) for the volume (sin α ≈ α − α³/6)
    // and (2π/n)²/3 + O(n⁻⁴) for Izz: the observed order log2(e_n / e_2n) tends to 2 as the
    // n⁻⁴ term fades. n = 32, 64, 128, 256: measured orders 1.9979, 1.9995, 1.9999 (volume)
    // and 1.9937, 1.9984, 1.9996 (Izz); bound |order − 2| < 0.01 (the n⁻⁴ term alone moves
    // the first Izz order by 0.006).
    for errors in [&volume_errors, &izz_errors] {
        for w in errors.windows(2) {
            let order = (w[0] / w[1]).log2();
            assert!((order - 2.0).abs() < 0.01, "order {order} from {errors:?}");
        }
    }
    // n = 128: measured 4.0155e-4 below the cylinder, the leading term (2π/128)²/6 = 4.0157e-4;
    // bound 1e-6 (the next term, (2π/128)⁴/120, is 1.9e-8).
    assert!((volume_errors[2] - (2.0 * PI / 128.0).powi(2) / 6.0).abs() < 1e-6);
}

#[test]
fn icosphere_converges_to_the_ball_at_second_order() {
    let (r, rho): (f64, f64) = (0.15, 2700.0);
    let ball_mass = rho * 4.0 / 3.0 * PI * r.powi(3);
    let ball_inertia = 2.0 / 5.0 * ball_mass * r * r;
    let mut mass_errors = Vec::new();
    let mut inertia_errors = Vec::new();
    for levels in 3..=6 {
        let mesh = icosphere(levels, r);
        assert!(mesh.check().is_closed_manifold(), "{:?}", mesh.check());
        let mp = mass_properties(&mesh, rho);
        // Icosahedral symmetry leaves no preferred axis: the tensor is isotropic and the
        // centre at the origin to round-off. Measured worst off-diagonal/diagonal 4.5e-16,
        // diagonal spread 3.1e-15, |com| 4.0e-16 r (levels 3-6); bound 1e-13.
        let diagonal = mp.inertia.diagonal();
        let off = mp.inertia - Matrix3::from_diagonal(&diagonal);
        assert!(off.amax() < 1e-13 * diagonal.max(), "{}", mp.inertia);
        assert!((diagonal.max() - diagonal.min()) < 1e-13 * diagonal.max());
        assert!(mp.com.amax() < 1e-13 * r);
        mass_errors.push(rel(mp.mass, ball_mass));
        inertia_errors.push(rel(diagonal.mean(), ball_inertia));
    }
    // Inscribed polyhedron: the missing volume scales with the squared edge length, which
    // halves per level, so the error drops 4× per level. Levels 3-6: measured orders 1.9938,
    // 1.9984, 1.9996 (mass) and 1.9904, 1.9976, 1.9994 (inertia); bound |order − 2| < 0.02.
    for errors in [&mass_errors, &inertia_errors] {
        for w in errors.windows(2) {
            let order = (w[0] / w[1]).log2();
            assert!((order - 2.0).abs() < 0.02, "order {order} from {errors:?}");
        }
    }
    // 6 levels (81920 triangles): measured mass 1.35e-4 and inertia 2.25e-4 below the ball;
    // bounds 2e-4 and 3e-4.
    assert!(
        mass_errors[3] < 2e-4 && inertia_errors[3] < 3e-4,
        "{mass_errors:?} {inertia_errors:?}"
    );
}

/// Tonon (2004), "Explicit Exact Formulas for the 3-D Tetrahedron Inertia Tensor in Terms of
/// its Vertex Coordinates", J. Math. Stat. 1(1), eqs. for a, b, c (moments) and a', b', c'
/// (products), written per coordinate, with the vertices relative to the centroid:
///
/// ```text
/// a  = μ |det J| (Σ_{i≤j} y_i y_j + Σ_{i≤j} z_i z_j) / 60
/// a' = μ |det J| (Σ_i 2 y_i z_i + Σ_{i≠j} y_i z_j) / 120
/// I  = [[a, −c', −b'], [−c', b, −a'], [−b', −a', c]]   (a' = ∫yz, b' = ∫xz, c' = ∫xy)
/// ```
fn tonon(p: [Vector3<f64>; 4], mu: f64) -> MassProperties {
    let centroid = (p[0] + p[1] + p[2] + p[3]) / 4.0;
    let q: Vec<Vector3<f64>> = p.iter().map(|v| v - centroid).collect();
    let det = (q[1] - q[0])
        .cross(&(q[2] - q[0]))
        .dot(&(q[3] - q[0]))
        .abs();
    // Σ_{i≤j} u_i u_j and Σ_i 2 u_i w_i + Σ_{i≠j} u_i w_j.
    let square = |k: usize| -> f64 {
        let mut s = 0.0;
        for i in 0..4 {
            for j in i..4 {
                s += q[i][k] * q[j][k];
            }
        }
        s
    };
    let product = |k: usize, l: usize| -> f64 {
        let mut s = 0.0;
        for i in 0..4 {
            for j in 0..4 {
                s += if i == j { 2.0 } else { 1.0 } * q[i][k] * q[j][l];
            }
        }
        s
    };
    let (sx, sy, sz) = (square(0), square(1), square(2));
    let a = mu * det * (sy + sz) / 60.0;
    let b = mu * det * (sx + sz) / 60.0;
    let c = mu * det * (sx + sy) / 60.0;
    let a1 = mu * det * product(1, 2) / 120.0;
    let b1 = mu * det * product(0, 2) / 120.0;
    let c1 = mu * det * product(0, 1) / 120.0;
    MassProperties::new(
        mu * det / 6.0,
        centroid,
        Matrix3::new(a, -c1, -b1, -c1, b, -a1, -b1, -a1, c),
    )
}

#[test]
fn tetrahedron_matches_tonon() {
    // Tonon's worked example (his section 4): vertices in metres, density 1.
    let p = [
        Vector3::new(8.33220, -11.86875, 0.93355),
        Vector3::new(0.75523, 5.00000, 16.37072),
        Vector3::new(52.61236, 5.00000, -5.38580),
        Vector3::new(2.00000, 5.00000, 3.00000),
    ];
    let mp = mass_properties(&tetrahedron(p), 1.0);
    let reference = tonon(p, 1.0);
    let (em, ec, ei) = mp_error(&mp, &reference, 50.0);
    // Two independent evaluations of the same integrals: measured mass 2.4e-16, com 3.6e-17
    // (of 50 m), inertia 1.5e-16; bound 1e-12.
    assert!(
        em < 1e-12 && ec < 1e-12 && ei < 1e-12,
        "{em:e} {ec:e} {ei:e}"
    );
    // The paper's printed results, to 5 decimals: volume 1873.233236, a = 43520.33257,
    // b = 194711.28938, c = 191168.76173, a' = 4417.66150, b' = -46343.16662, c' = 11996.20119
    // (a' = ∫yz, b' = ∫xz, c' = ∫xy; placed here in the usual tensor layout).
    let printed = Matrix3::new(
        43520.33257,
        -11996.20119,
        46343.16662,
        -11996.20119,
        194711.28938,
        -4417.66150,
        46343.16662,
        -4417.66150,
        191168.76173,
    );
    let volume_error = rel(mp.mass, 1873.233236);
    let inertia_error = rel_matrix(&mp.inertia, &printed);
    // The vertices are printed to 1e-5 m, which moves results of this 20 m tetrahedron by
    // ~1e-7 relative: measured volume 6.9e-8, inertia 1.6e-8; bound 2e-7.
    assert!(volume_error < 2e-7, "{}", mp.mass);
    assert!(inertia_error < 2e-7, "{}", mp.inertia);
}

// ---------------------------------------------------------------------------------------------
// Invariances.

/// The naive integration: the same sums taken about the frame origin, then shifted to the
/// centroid (what the library avoids with its reference point).
fn naive_origin_inertia(mesh: &TriangleMesh, rho: f64) -> Matrix3<f64> {
    let (mut v6, mut first, mut cov) = (0.0, Vector3::zeros(), Matrix3::zeros());
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
        let d = a.dot(&b.cross(&c));
        let s = a + b + c;
        v6 += d;
        first += s * d;
        cov += (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose()) * d;
    }
    let volume = v6 / 6.0;
    let centroid = first / (4.0 * v6);
    let cov = cov / 120.0 - centroid * centroid.transpose() * volume;
    (Matrix3::identity() * cov.trace() - cov) * rho
}

#[test]
fn translation_by_a_kilometre_keeps_the_inertia() {
    // A 1 × 2 × 3 cm box, turned so that no coordinate is round.
    let q = UnitQuaternion::from_euler_angles(0.3, -0.5, 0.9);
    let part = box_mesh(Vector3::zeros(), Vector3::new(0.01, 0.02, 0.03))
        .transformed(&Isometry3::from_parts(Translation3::identity(), q));
    let here = mass_properties(&part, 1000.0);
    let offset = Vector3::new(1000.0, -700.0, 400.0);
    let far_mesh = part.transformed(&Isometry3::translation(offset.x, offset.y, offset.z));
    let far = mass_properties(&far_mesh, 1000.0);
    let inertia_error = rel_matrix(&far.inertia, &here.inertia);
    // Only the rounding of the moved vertices remains (ulp(1000 m) = 1.1e-13 m against 1 cm,
    // 1e-11 relative): measured inertia 2.6e-12 and mass 1.9e-12, i.e. 11-12 of 16 digits
    // kept, all lost in the input coordinates, none in the integration; bound 1e-10.
    assert!(inertia_error < 1e-10, "{inertia_error:e}");
    assert!(rel(far.mass, here.mass) < 1e-10);
    // com moved by the offset: measured 5.7e-14 m (half an ulp of 1000); bound 1e-12 m.
    assert!((far.com - here.com - offset).amax() < 1e-12);
    // The naive origin integration keeps nothing: each V_t is of order d²L (d = 1.3 km,
    // L = 2 cm) and they cancel to V ~ L³, losing (d/L)³ eps ~ 0.06 of the volume, and the
    // covariance shift loses more: measured inertia error 4.5e6 relative. Bound: > 1e-6.
    let naive_error = rel_matrix(&naive_origin_inertia(&far_mesh, 1000.0), &here.inertia);
    assert!(naive_error > 1e-6, "naive {naive_error:e}");
    // At the origin both agree to round-off: measured 1.9e-15; bound 1e-13.
    assert!(rel_matrix(&naive_origin_inertia(&part, 1000.0), &here.inertia) < 1e-13);
}

#[test]
fn rotation_rotates_the_tensor() {
    let mesh = prism(7, 0.1, 0.5).transformed(&Isometry3::translation(0.2, 0.0, -0.1));
    let mp = mass_properties(&mesh, 500.0);
    let q = UnitQuaternion::from_euler_angles(1.1, 0.4, -2.0);
    let r = q.to_rotation_matrix();
    let turned = mass_properties(
        &mesh.transformed(&Isometry3::from_parts(Translation3::identity(), q)),
        500.0,
    );
    let expected = r.matrix() * mp.inertia * r.matrix().transpose();
    // Measured inertia 5.5e-16, com 1.4e-17 m, mass 0; bound 1e-13.
    assert!(rel_matrix(&turned.inertia, &expected) < 1e-13);
    assert!((turned.com - r * mp.com).amax() < 1e-13);
    assert!(rel(turned.mass, mp.mass) < 1e-13);
}

#[test]
fn two_boxes_combined_are_the_whole_box() {
    let rho = 2500.0;
    let whole = mass_properties(
        &box_mesh(Vector3::new(0.0, 0.0, 0.0), Vector3::new(2.0, 1.0, 0.5)),
        rho,
    );
    let left = mass_properties(
        &box_mesh(Vector3::new(0.0, 0.0, 0.0), Vector3::new(0.75, 1.0, 0.5)),
        rho,
    );
    let right = mass_properties(
        &box_mesh(Vector3::new(0.75, 0.0, 0.0), Vector3::new(2.0, 1.0, 0.5)),
        rho,
    );
    let both = MassProperties::combine([&left, &right]).expect("positive mass");
    let (em, ec, ei) = mp_error(&both, &whole, 2.0);
    // Measured mass 0, com 0, inertia 1.1e-16; bound 1e-14.
    assert!(
        em < 1e-14 && ec < 1e-14 && ei < 1e-14,
        "{em:e} {ec:e} {ei:e}"
    );
}

// ---------------------------------------------------------------------------------------------
// Scaling.

#[test]
fn mirrored_mesh_keeps_its_volume_and_mirrors_the_tensor() {
    let p = [
        Vector3::new(0.1, 0.2, 0.3),
        Vector3::new(0.9, 0.1, 0.2),
        Vector3::new(0.3, 0.8, 0.1),
        Vector3::new(0.4, 0.3, 0.7),
    ];
    let mesh = tetrahedron(p);
    let mp = mass_properties(&mesh, 1000.0);
    let mirrored = mesh.scaled(&Vector3::new(-1.0, 1.0, 1.0));
    // Winding reversed by `scaled`, so the volume stays positive.
    assert_eq!(mirrored.triangles[0], [0, 1, 2]);
    let mm = mass_properties(&mirrored, 1000.0);
    let m = Matrix3::from_diagonal(&Vector3::new(-1.0, 1.0, 1.0));
    // Mass equal, com x negated, I → M I M: Ixy and Ixz change sign, Iyz and the diagonal
    // stay. Measured mass 0, com 0, inertia 1.8e-16 (the mirror is exact; the reversed
    // winding reorders the sums); bound 1e-14.
    assert!(rel(mm.mass, mp.mass) < 1e-14);
    assert!((mm.com - m * mp.com).amax() < 1e-14);
    assert!(rel_matrix(&mm.inertia, &(m * mp.inertia * m)) < 1e-14);
    assert!(mp.inertia[(0, 1)].abs() > 1e-3 && mp.inertia[(0, 2)].abs() > 1e-3);
    // Without the flip the mesh is inside-out, and says so.
    let not_flipped = TriangleMesh {
        vertices: mirrored.vertices.clone(),
        triangles: mesh.triangles.clone(),
    };
    assert!(matches!(
        not_flipped.mass_properties(1000.0),
        Err(MeshError::InsideOut { .. })
    ));
}

#[test]
fn anisotropic_scale_of_a_unit_cube_is_the_scaled_box() {
    let s = Vector3::new(2.0, 3.0, 0.5);
    let mp = mass_properties(&unit_cube().scaled(&s), 1000.0);
    let expected = box_closed_form(s, s / 2.0, 1000.0);
    let (em, ec, ei) = mp_error(&mp, &expected, 3.0);
    // Measured mass 0, com 0, inertia 0 (dyadic sizes); bound 1e-14.
    assert!(
        em < 1e-14 && ec < 1e-14 && ei < 1e-14,
        "{em:e} {ec:e} {ei:e}"
    );
    // Two negative scales: determinant positive, winding kept.
    let twice = unit_cube().scaled(&Vector3::new(-2.0, -3.0, 0.5));
    assert_eq!(twice.triangles, unit_cube().triangles);
    assert!(rel(mass_properties(&twice, 1000.0).mass, expected.mass) < 1e-14);
}

// ---------------------------------------------------------------------------------------------
// Broken meshes.

#[test]
fn open_mesh_reports_its_boundary_edges() {
    let mut mesh = unit_cube();
    mesh.triangles.remove(4);
    assert_eq!(mesh.check().boundary_edges, 3);
    let err = mesh.mass_properties(1000.0).unwrap_err();
    assert_eq!(err, MeshError::Open { boundary_edges: 3 });
    assert!(
        err.to_string().starts_with("open mesh: 3 boundary edges"),
        "{err}"
    );
    // A whole face missing: its 4 sides are boundary edges (the diagonal is not).
    let mut mesh = unit_cube();
    mesh.triangles.drain(0..2);
    assert_eq!(mesh.check().boundary_edges, 4);
}

#[test]
fn inside_out_mesh_is_reported_and_flipping_fixes_it() {
    let inverted = unit_cube().flipped();
    let report = inverted.check();
    assert!(report.is_closed_manifold(), "{report:?}");
    let err = inverted.mass_properties(1000.0).unwrap_err();
    assert_eq!(err, MeshError::InsideOut { volume_m3: -1.0 });
    assert!(err.to_string().starts_with("inside-out mesh"), "{err}");
    assert_eq!(inverted.signed_volume_properties().volume_m3, -1.0);
    assert_eq!(mass_properties(&inverted.flipped(), 1000.0).mass, 1000.0);
}

#[test]
fn non_manifold_and_misoriented_meshes_are_reported() {
    // Two cubes touching along one edge (x = 1, y = 1), vertices shared.
    let a = unit_cube();
    let b = box_mesh(Vector3::new(1.0, 1.0, 0.0), Vector3::new(2.0, 2.0, 1.0));
    let both = mesh_io::weld(
        &[a.vertices.clone(), b.vertices.clone()].concat(),
        &[
            a.triangles.clone(),
            b.triangles.iter().map(|t| t.map(|i| i + 8)).collect(),
        ]
        .concat(),
    );
    assert_eq!(both.vertices.len(), 14);
    let err = both.mass_properties(1000.0).unwrap_err();
    assert_eq!(err, MeshError::NonManifold { edges: 1 });
    assert!(
        err.to_string().starts_with("non-manifold mesh: 1 edges"),
        "{err}"
    );
    // One triangle turned over: its 3 edges run the same way as their neighbours'.
    let mut mesh = unit_cube();
    mesh.triangles[5].swap(0, 1);
    let err = mesh.mass_properties(1000.0).unwrap_err();
    assert_eq!(err, MeshError::InconsistentOrientation { edges: 3 });
    assert!(
        err.to_string()
            .contains("3 edges used twice in the same direction")
    );
}

#[test]
fn bad_vertices_indices_scales_and_densities_are_errors() {
    let mut mesh = unit_cube();
    mesh.vertices[3].y = f64::NAN;
    assert_eq!(
        mesh.mass_properties(1.0).unwrap_err(),
        MeshError::NonFiniteVertices { vertices: 1 }
    );
    let mut mesh = unit_cube();
    mesh.triangles[0][2] = 8;
    let err = mesh.mass_properties(1.0).unwrap_err();
    assert_eq!(
        err,
        MeshError::IndexOutOfRange {
            triangles: 1,
            vertices: 8
        }
    );
    let flat = unit_cube().scaled(&Vector3::new(1.0, 0.0, 1.0));
    assert!(matches!(
        flat.mass_properties(1.0),
        Err(MeshError::Degenerate { volume_m3, .. }) if volume_m3 == 0.0
    ));
    assert_eq!(
        TriangleMesh::default().mass_properties(1.0).unwrap_err(),
        MeshError::Empty
    );
    for rho in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            unit_cube().mass_properties(rho),
            Err(MeshError::InvalidDensity { .. })
        ));
    }
    // A triangle repeating an index bounds nothing: skipped, counted, harmless.
    let mut mesh = unit_cube();
    mesh.triangles.push([0, 0, 5]);
    assert_eq!(mesh.check().repeated_index_triangles, 1);
    assert_eq!(mass_properties(&mesh, 1.0).mass, 1.0);
}

// ---------------------------------------------------------------------------------------------
// Readers. Boxes of dyadic sizes, exact in f32, written by the tests themselves.

/// Triangles of a box as corner triples (triangle soup, as STL stores them).
fn soup(mesh: &TriangleMesh) -> Vec<[Vector3<f64>; 3]> {
    mesh.triangles
        .iter()
        .map(|t| t.map(|i| mesh.vertices[i as usize]))
        .collect()
}

/// Binary STL per the format: 80-byte header, u32 count, 50-byte records (all little-endian).
fn binary_stl(mesh: &TriangleMesh, header: &[u8]) -> Vec<u8> {
    let mut bytes = vec![0u8; 80];
    bytes[..header.len()].copy_from_slice(header);
    bytes.extend((mesh.triangles.len() as u32).to_le_bytes());
    for [a, b, c] in soup(mesh) {
        let n = (b - a).cross(&(c - a)).normalize();
        for v in [n, a, b, c] {
            for x in v.iter() {
                bytes.extend((*x as f32).to_le_bytes());
            }
        }
        bytes.extend([0u8, 0u8]);
    }
    bytes
}

fn ascii_stl(mesh: &TriangleMesh, first_line: &str) -> String {
    let mut s = format!("{first_line}\n");
    for [a, b, c] in soup(mesh) {
        let n = (b - a).cross(&(c - a)).normalize();
        s += &format!("  facet normal {} {} {}\n    outer loop\n", n.x, n.y, n.z);
        for v in [a, b, c] {
            s += &format!("      vertex {:e} {:e} {:e}\n", v.x, v.y, v.z);
        }
        s += "    endloop\n  endfacet\n";
    }
    s + "endsolid\n"
}

fn load(path: &Path) -> TriangleMesh {
    match mesh_io::load_mesh(path) {
        Ok(mesh) => mesh,
        Err(e) => panic!("{e}"),
    }
}

fn assert_box(mesh: &TriangleMesh, d: Vector3<f64>, centre: Vector3<f64>, what: &str) {
    let mp = mass_properties(mesh, 1000.0);
    let (em, ec, ei) = mp_error(&mp, &box_closed_form(d, centre, 1000.0), d.amax());
    // Dyadic boxes read exactly: measured 0 for STL (binary and ASCII); mass 0, com 0,
    // inertia 1.4e-16 for OBJ; 4.3e-16, 3.5e-16, 4.8e-16 for DAE (a rotation by 90° whose
    // cosine rounds to 6e-17, and the 0.001 unit); bound 1e-14.
    assert!(
        em < 1e-14 && ec < 1e-14 && ei < 1e-14,
        "{what}: {em:e} {ec:e} {ei:e}"
    );
}

#[test]
fn stl_binary_and_ascii_read_the_box() {
    let dir = tempfile::tempdir().expect("tempdir");
    let lo = Vector3::new(-0.5, 0.25, 1.0);
    let d = Vector3::new(0.75, 0.5, 2.0);
    let mesh = box_mesh(lo, lo + d);
    let centre = lo + d / 2.0;
    // A header starting with "solid", as many binary exporters write it.
    let binary = dir.path().join("box.STL");
    std::fs::write(&binary, binary_stl(&mesh, b"solid box exported as binary")).expect("write");
    let read = load(&binary);
    // 36 corners welded into 8 vertices.
    assert_eq!((read.vertices.len(), read.triangles.len()), (8, 12));
    assert_box(&read, d, centre, "binary STL");
    for first_line in ["solid box", "solid", "SOLID Box"] {
        let ascii = dir.path().join("box_ascii.stl");
        std::fs::write(&ascii, ascii_stl(&mesh, first_line)).expect("write");
        let read = load(&ascii);
        assert_eq!((read.vertices.len(), read.triangles.len()), (8, 12));
        assert_box(&read, d, centre, first_line);
    }
    // Two solids in one ASCII file: both read (a second box beside the first).
    let other = box_mesh(
        lo + Vector3::new(5.0, 0.0, 0.0),
        lo + d + Vector3::new(5.0, 0.0, 0.0),
    );
    let two = dir.path().join("two.stl");
    let text = ascii_stl(&mesh, "solid a") + &ascii_stl(&other, "solid b");
    std::fs::write(&two, text).expect("write");
    assert_eq!(load(&two).triangles.len(), 24);
    // -0.0 and 0.0 are one vertex: the first triangle's zeros written as -0.0.
    let mut bytes = binary_stl(&unit_cube(), b"");
    for k in 0..9 {
        let at = 84 + 12 + 4 * k;
        if bytes[at..at + 4] == [0, 0, 0, 0] {
            bytes[at..at + 4].copy_from_slice(&(-0.0f32).to_le_bytes());
        }
    }
    let zero = dir.path().join("zero.stl");
    std::fs::write(&zero, bytes).expect("write");
    let read = load(&zero);
    assert_eq!(read.vertices.len(), 8);
    assert!(read.check().is_closed_manifold());
}

/// Regression: CAD exporters write round-off such as 4e-20 for a zero coordinate in some
/// triangles and 0 in their neighbours (51 meshes of example-robot-data, e.g. solo's legs);
/// exact welding left them open. A real gap, 1e-6 of the size, stays open.
#[test]
fn stl_zero_written_as_round_off_is_welded_but_a_real_gap_is_not() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("noisy.stl");
    let write = |dirty: f32| {
        // The cube's first triangle gets `dirty` for each of its zero coordinates.
        let mut bytes = binary_stl(&unit_cube(), b"");
        for k in 0..9 {
            let at = 84 + 12 + 4 * k;
            if bytes[at..at + 4] == [0, 0, 0, 0] {
                bytes[at..at + 4].copy_from_slice(&dirty.to_le_bytes());
            }
        }
        std::fs::write(&path, bytes).expect("write");
        load(&path)
    };
    let noisy = write(3.98e-20);
    assert_eq!(noisy.vertices.len(), 8);
    assert_eq!(mass_properties(&noisy, 1.0).mass, 1.0);
    let cracked = write(1e-6);
    // Its three corners moved off the cube's: 3 extra vertices, 11 in all.
    assert_eq!(cracked.vertices.len(), 11);
    assert!(matches!(
        cracked.mass_properties(1.0),
        Err(MeshError::Open { .. })
    ));
}

#[test]
fn stl_truncated_or_lying_is_a_clear_error() {
    let dir = tempfile::tempdir().expect("tempdir");
    let bytes = binary_stl(&unit_cube(), b"binary");
    let path = dir.path().join("cut.stl");
    std::fs::write(&path, &bytes[..bytes.len() - 30]).expect("write");
    let err = mesh_io::load_mesh(&path).unwrap_err().to_string();
    assert!(err.contains("cut.stl"), "{err}");
    assert!(
        err.contains("header says 12 triangles (684 bytes) but the file has 654 bytes"),
        "{err}"
    );
    // Same, with a header that starts like ASCII.
    let bytes = binary_stl(&unit_cube(), b"solid cube");
    std::fs::write(&path, &bytes[..600]).expect("write");
    let err = mesh_io::load_mesh(&path).unwrap_err().to_string();
    assert!(
        err.contains("neither ASCII STL") && err.contains("600 bytes"),
        "{err}"
    );
    // Too short for any header, an empty file, an ASCII file cut mid-facet.
    for (content, expect) in [
        (&b"abc"[..], "too short"),
        (&b""[..], "too short"),
        (
            &b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"[..],
            "EOF",
        ),
    ] {
        std::fs::write(&path, content).expect("write");
        let err = mesh_io::load_mesh(&path).unwrap_err().to_string();
        assert!(err.contains(expect) && err.contains("cut.stl"), "{err}");
    }
    // A geometry error in a file names the file.
    let mut open = unit_cube();
    open.triangles.pop();
    std::fs::write(&path, binary_stl(&open, b"")).expect("write");
    let err = mesh_io::load_mass_properties(&path, &Vector3::repeat(1.0), 1000.0).unwrap_err();
    assert_eq!(err.root(), &MeshError::Open { boundary_edges: 3 });
    assert!(
        err.to_string()
            .contains("cut.stl: open mesh: 3 boundary edges"),
        "{err}"
    );
    // A valid binary STL with no triangles: an empty mesh, named.
    std::fs::write(&path, binary_stl(&TriangleMesh::default(), b"")).expect("write");
    let err = mesh_io::load_mesh(&path).unwrap_err();
    assert_eq!(err.root(), &MeshError::Empty);
    assert!(err.to_string().contains("cut.stl: empty mesh"), "{err}");
}

#[test]
fn obj_quads_in_two_groups_read_the_box() {
    let dir = tempfile::tempdir().expect("tempdir");
    // Box [0, 2] × [0, 1] × [0, 0.5], faces as quads split over two groups that share
    // positions by value but not by index (the second group repeats its vertices).
    let obj = "\
# box in two groups
mtllib missing.mtl
v 0 0 0\nv 2 0 0\nv 0 1 0\nv 2 1 0\nv 0 0 0.5\nv 2 0 0.5\nv 0 1 0.5\nv 2 1 0.5
o bottom_and_sides
f 1 3 4 2
f 1 2 6 5
f 3 7 8 4
g ends
v 0 0 0\nv 2 0 0\nv 0 1 0\nv 2 1 0\nv 0 0 0.5\nv 2 0 0.5\nv 0 1 0.5\nv 2 1 0.5
f -4 -3 -1 -2
f -8 -4 -2 -6
f -7 -5 -1 -3
";
    let path = dir.path().join("box.Obj");
    std::fs::write(&path, obj).expect("write");
    let mesh = load(&path);
    assert_eq!((mesh.vertices.len(), mesh.triangles.len()), (8, 12));
    assert_box(
        &mesh,
        Vector3::new(2.0, 1.0, 0.5),
        Vector3::new(1.0, 0.5, 0.25),
        "OBJ",
    );
}

/// A DAE of a box `[0, 40] × [0, 20] × [0, 10]` mm as quads (`<polylist>`), placed by a node
/// `translate(100, 0, 0) rotate(z, 90°)`, in a Y_UP file in millimetres; a second node places
/// a `<triangles>` copy of the same box mirrored by `scale(-1, 1, 1)` at x = −300 mm.
fn box_dae(second_instance: bool) -> String {
    let second = if second_instance {
        r##"<node id="mirror"><translate>-300 0 0</translate><scale>-1 1 1</scale>
             <instance_geometry url="#tri"/></node>"##
    } else {
        ""
    };
    format!(
        r##"<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.0">
  <asset><unit name="millimetre" meter="0.001"/><up_axis>Y_UP</up_axis></asset>
  <library_geometries>
    <geometry id="quad" name="quad"><mesh>
      <source id="quad-pos">
        <float_array id="quad-pos-array" count="24">
          0 0 0  40 0 0  0 20 0  40 20 0  0 0 10  40 0 10  0 20 10  40 20 10</float_array>
        <technique_common><accessor source="#quad-pos-array" count="8" stride="3">
          <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
        </accessor></technique_common>
      </source>
      <source id="quad-nrm"><float_array id="quad-nrm-array" count="3">0 0 1</float_array>
        <technique_common><accessor source="#quad-nrm-array" count="1" stride="3"/></technique_common>
      </source>
      <vertices id="quad-vtx"><input semantic="POSITION" source="#quad-pos"/></vertices>
      <polylist count="6">
        <input semantic="VERTEX" source="#quad-vtx" offset="0"/>
        <input semantic="NORMAL" source="#quad-nrm" offset="1"/>
        <vcount>4 4 4 4 4 4</vcount>
        <p>0 0 2 0 3 0 1 0  4 0 5 0 7 0 6 0  0 0 1 0 5 0 4 0  2 0 6 0 7 0 3 0
           0 0 4 0 6 0 2 0  1 0 3 0 7 0 5 0</p>
      </polylist>
    </mesh></geometry>
    <geometry id="tri"><mesh>
      <source id="tri-pos"><float_array id="tri-pos-array" count="24">
          0 0 0  40 0 0  0 20 0  40 20 0  0 0 10  40 0 10  0 20 10  40 20 10</float_array>
        <technique_common><accessor source="#tri-pos-array" count="8" stride="3"/></technique_common>
      </source>
      <vertices id="tri-vtx"><input semantic="POSITION" source="#tri-pos"/></vertices>
      <triangles count="12"><input semantic="VERTEX" source="#tri-vtx" offset="0"/>
        <p>0 2 3 0 3 1 4 5 7 4 7 6 0 1 5 0 5 4 2 6 7 2 7 3 0 4 6 0 6 2 1 3 7 1 7 5</p>
      </triangles>
      <lines count="1"><input semantic="VERTEX" source="#tri-vtx" offset="0"/><p>0 1</p></lines>
    </mesh></geometry>
  </library_geometries>
  <library_visual_scenes>
    <visual_scene id="scene">
      <node id="placed"><translate>100 0 0</translate><rotate>0 0 1 90</rotate>
        <instance_geometry url="#quad"/></node>
      {second}
    </visual_scene>
  </library_visual_scenes>
  <scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>"##
    )
}

#[test]
fn dae_applies_unit_and_node_transforms_and_ignores_up_axis() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("box.DAE");
    std::fs::write(&path, box_dae(false)).expect("write");
    let mesh = load(&path);
    assert_eq!((mesh.vertices.len(), mesh.triangles.len()), (8, 12));
    // rotate(z, 90°) maps the 40 × 20 × 10 mm box to x ∈ [−20, 0], y ∈ [0, 40]; translate
    // adds 100 mm in x; unit 0.001 gives metres; Y_UP is not applied.
    let d = Vector3::new(0.020, 0.040, 0.010);
    let centre = Vector3::new(0.090, 0.020, 0.005);
    assert_box(&mesh, d, centre, "DAE");
    // The specification's reading, on request: Y_UP maps (x, y, z) to (x, −z, y).
    let spec = mesh_io::dae::read_dae(
        box_dae(false).as_bytes(),
        &DaeOptions {
            up_axis: UpAxis::RotateToZUp,
        },
    )
    .expect("read");
    assert_box(
        &spec,
        Vector3::new(d.x, d.z, d.y),
        Vector3::new(centre.x, -centre.z, centre.y),
        "DAE rotated to Z up",
    );
    // A second, mirrored instance: winding reversed for it, so the two boxes add up.
    std::fs::write(&path, box_dae(true)).expect("write");
    let both = load(&path);
    let mp = mass_properties(&both, 1000.0);
    let one = box_closed_form(d, centre, 1000.0);
    // The mirror of [0, 40] mm at x = −300 mm is x ∈ [−340, −300] mm, the box unturned.
    let mirrored = box_closed_form(
        Vector3::new(0.040, 0.020, 0.010),
        Vector3::new(-0.320, 0.010, 0.005),
        1000.0,
    );
    let expected = MassProperties::combine([&one, &mirrored]).expect("mass");
    let (em, ec, ei) = mp_error(&mp, &expected, 0.4);
    // Measured mass 6.5e-16, com 1.4e-16 (of 0.4 m), inertia 8.0e-16; bound 1e-13.
    assert!(
        em < 1e-13 && ec < 1e-13 && ei < 1e-13,
        "{em:e} {ec:e} {ei:e}"
    );
}

/// The unit cube as `<polygons>` (quads), `<tristrips>` and `<trifans>`, one geometry each.
fn primitives_dae(scene: &str) -> String {
    let geometry = |id: &str, body: &str| {
        format!(
            r##"<geometry id="{id}"><mesh>
      <source id="{id}-pos"><float_array id="{id}-arr" count="24">
        0 0 0 1 0 0 0 1 0 1 1 0 0 0 1 1 0 1 0 1 1 1 1 1</float_array>
        <technique_common><accessor source="#{id}-arr" count="8" stride="3"/></technique_common>
      </source>
      <vertices id="{id}-vtx"><input semantic="POSITION" source="#{id}-pos"/></vertices>
      {body}
    </mesh></geometry>"##
        )
    };
    let input = |id: &str| format!(r##"<input semantic="VERTEX" source="#{id}-vtx" offset="0"/>"##);
    // Quads (q0 q1 q2 q3) wound outward; as a strip (q1 q2 q0 q3); as a fan (q0 q1 q2 q3).
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let p = |order: [usize; 4]| -> String {
        quads
            .iter()
            .map(|q| {
                format!(
                    "<p>{} {} {} {}</p>",
                    q[order[0]], q[order[1]], q[order[2]], q[order[3]]
                )
            })
            .collect()
    };
    format!(
        r##"<COLLADA version="1.5.0"><library_geometries>
    {}
    {}
    {}
  </library_geometries>{scene}</COLLADA>"##,
        geometry(
            "poly",
            &format!(
                "<polygons count=\"6\">{}{}</polygons>",
                input("poly"),
                p([0, 1, 2, 3])
            )
        ),
        geometry(
            "strip",
            &format!(
                "<tristrips count=\"6\">{}{}</tristrips>",
                input("strip"),
                p([1, 2, 0, 3])
            )
        ),
        geometry(
            "fan",
            &format!(
                "<trifans count=\"6\">{}{}</trifans>",
                input("fan"),
                p([0, 1, 2, 3])
            )
        ),
    )
}

#[test]
fn dae_polygons_strips_fans_and_library_nodes() {
    let read = |text: String| match mesh_io::dae::read_dae(text.as_bytes(), &DaeOptions::default())
    {
        Ok(mesh) => mesh,
        Err(e) => panic!("{e}"),
    };
    let cube = |centre: Vector3<f64>| box_closed_form(Vector3::repeat(1.0), centre, 1000.0);
    // No visual scene: every geometry at the origin. Three coincident cubes, welded into one
    // vertex set, share all 18 edges: non-manifold (they bound no single solid).
    let mesh = read(primitives_dae(""));
    assert_eq!((mesh.vertices.len(), mesh.triangles.len()), (8, 36));
    assert_eq!(
        mesh.mass_properties(1000.0).unwrap_err(),
        MeshError::NonManifold { edges: 18 }
    );
    // Placed through a library node instantiated twice, with different parent translations.
    let scene = r##"<library_nodes><node id="lib"><translate>0 0 2</translate>
        <instance_geometry url="#poly"/><node><translate>2 0 0</translate>
        <instance_geometry url="#strip"/></node></node></library_nodes>
      <library_visual_scenes><visual_scene id="s">
        <node><instance_node url="#lib"/></node>
        <node><translate>0 4 0</translate><instance_node url="#lib"/></node>
        <node><matrix>1 0 0 -3  0 1 0 0  0 0 1 0  0 0 0 1</matrix><instance_geometry url="#fan"/></node>
      </visual_scene></library_visual_scenes>
      <scene><instance_visual_scene url="#s"/></scene>"##;
    let mesh = read(primitives_dae(scene));
    assert_eq!(mesh.triangles.len(), 60);
    let parts: Vec<MassProperties> = [
        Vector3::new(0.5, 0.5, 2.5),
        Vector3::new(2.5, 0.5, 2.5),
        Vector3::new(0.5, 4.5, 2.5),
        Vector3::new(2.5, 4.5, 2.5),
        Vector3::new(-2.5, 0.5, 0.5),
    ]
    .into_iter()
    .map(cube)
    .collect();
    let expected = MassProperties::combine(&parts).expect("mass");
    let (em, ec, ei) = mp_error(&mass_properties(&mesh, 1000.0), &expected, 5.0);
    // Measured mass 0, com 0, inertia 2.0e-16; bound 1e-14.
    assert!(
        em < 1e-14 && ec < 1e-14 && ei < 1e-14,
        "{em:e} {ec:e} {ei:e}"
    );
    // A cycle of library nodes is an error, not a stack overflow.
    let cycle = r##"<library_nodes><node id="a"><instance_node url="#b"/></node>
        <node id="b"><instance_node url="#a"/></node></library_nodes>
      <library_visual_scenes><visual_scene id="s"><node><instance_node url="#a"/></node>
      </visual_scene></library_visual_scenes>"##;
    let err = mesh_io::dae::read_dae(primitives_dae(cycle).as_bytes(), &DaeOptions::default())
        .unwrap_err();
    assert!(err.contains("nested deeper than 64"), "{err}");
}

#[test]
fn unknown_missing_and_garbage_files_are_errors_not_panics() {
    let dir = tempfile::tempdir().expect("tempdir");
    let ply = dir.path().join("mesh.ply");
    std::fs::write(&ply, "ply").expect("write");
    let err = mesh_io::load_mesh(&ply).unwrap_err();
    assert!(matches!(err, MeshError::UnknownFormat { .. }), "{err}");
    assert!(
        err.to_string().contains("mesh.ply: unknown mesh format"),
        "{err}"
    );
    let missing = dir.path().join("missing.stl");
    let err = mesh_io::load_mesh(&missing).unwrap_err();
    assert!(matches!(err, MeshError::Read { .. }), "{err}");
    // Pseudo-random bytes, XML-ish and OBJ-ish junk: every reader returns an error or a mesh,
    // never panics.
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut junk = Vec::new();
    for _ in 0..4000 {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        junk.push((state >> 24) as u8);
    }
    let dae = box_dae(true);
    let samples: Vec<Vec<u8>> = vec![
        junk.clone(),
        b"<COLLADA><library_geometries><geometry id='g'><mesh><triangles><input semantic='VERTEX' source='#v' offset='0'/><p>0 1 2</p></triangles></mesh></geometry></library_geometries></COLLADA>".to_vec(),
        b"<notcollada/>".to_vec(),
        dae.replace("count=\"8\"", "count=\"80\"").into_bytes(),
        dae.replace("<vcount>4 4", "<vcount>9 4").into_bytes(),
        dae.replace("1 7 5</p>", "1 7 50</p>").into_bytes(),
        dae.replace("meter=\"0.001\"", "meter=\"-1\"").into_bytes(),
        dae.replace("<rotate>0 0 1 90</rotate>", "<skew>1 0 0 0 1 0 0</skew>").into_bytes(),
        dae.as_bytes()[..dae.len() / 2].to_vec(),
        b"v 0 0 0\nf 1 2 3\n".to_vec(),
        b"v 0 0 0\nv x y z\n".to_vec(),
        b"solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 nan\n".to_vec(),
    ];
    for (k, bytes) in samples.iter().enumerate() {
        for ext in ["stl", "obj", "dae"] {
            let path = dir.path().join(format!("junk{k}.{ext}"));
            std::fs::write(&path, bytes).expect("write");
            if let Err(e) = mesh_io::load_mesh(&path) {
                assert!(e.to_string().contains(&format!("junk{k}.{ext}")), "{e}");
            }
        }
    }
    // The broken DAE variants are errors with a reason.
    for (k, expect) in [
        (3, "accessor wants 80 positions"),
        (4, "<vcount> adds up to"),
        (5, "index 50 past the 8 positions"),
        (6, "not a positive number"),
        (7, "<skew> transforms are not supported"),
        (8, "XML"),
    ] {
        let err = mesh_io::dae::read_dae(&samples[k], &DaeOptions::default()).unwrap_err();
        assert!(err.contains(expect), "sample {k}: {err}");
    }
}

#[test]
fn rotation_of_a_mesh_helper_is_consistent() {
    // `transformed` moves vertices by rotation then translation (checked against nalgebra).
    let q = UnitQuaternion::from_euler_angles(0.2, 0.3, 0.4);
    let iso = Isometry3::from_parts(Translation3::new(1.0, 2.0, 3.0), q);
    let moved = unit_cube().transformed(&iso);
    let r: Rotation3<f64> = q.to_rotation_matrix();
    let expected = r * Vector3::new(1.0, 1.0, 1.0) + Vector3::new(1.0, 2.0, 3.0);
    assert!((moved.vertices[7] - expected).amax() < 1e-15);
}

/// `box_mesh(lo, hi)` as OBJ text, its vertices numbered from `first` (1-based).
fn box_obj(lo: Vector3<f64>, hi: Vector3<f64>, first: u32) -> String {
    let mesh = box_mesh(lo, hi);
    let mut text = String::new();
    for v in &mesh.vertices {
        text += &format!("v {} {} {}\n", v.x, v.y, v.z);
    }
    for t in &mesh.triangles {
        text += &format!("f {} {} {}\n", t[0] + first, t[1] + first, t[2] + first);
    }
    text
}

/// Issue 32: an OBJ whose surface touches itself, each sheet with its own vertices (pybullet's
/// V-HACD laikago chassis, 28 of its `random_urdfs`), was refused as non-manifold once welding
/// by position joined the sheets. The file's indexing closes it, and that is kept: two unit
/// cubes touching along an edge weigh two cubes, and touching along a face (wound oppositely,
/// as the hulls of a decomposition) too; the same cube written twice (coincident faces wound
/// the same way: stacked solids) is still refused, as is the welded pair from one vertex list.
#[test]
fn an_obj_touching_itself_keeps_its_own_indexing_stacked_copies_do_not() {
    let read = |text: String| mesh_io::obj::read_obj(text.as_bytes()).unwrap();
    let unit = Vector3::repeat(1.0);
    let edge = box_obj(Vector3::zeros(), unit, 1)
        + &box_obj(Vector3::new(1.0, 1.0, 0.0), Vector3::new(2.0, 2.0, 1.0), 9);
    let mp = read(edge).mass_properties(1000.0).unwrap();
    assert!((mp.mass - 2000.0).abs() < 1e-9, "{}", mp.mass);
    assert!(
        (mp.com - Vector3::new(1.0, 1.0, 0.5)).norm() < 1e-12,
        "{}",
        mp.com
    );
    let face = box_obj(Vector3::zeros(), unit, 1)
        + &box_obj(Vector3::new(1.0, 0.0, 0.0), Vector3::new(2.0, 1.0, 1.0), 9);
    let mp = read(face).mass_properties(1000.0).unwrap();
    assert!((mp.mass - 2000.0).abs() < 1e-9, "{}", mp.mass);
    // Two cubes side by side are one 2 x 1 x 1 box: I_xx = m (1 + 1) / 12.
    assert!((mp.inertia[(0, 0)] - 2000.0 * 2.0 / 12.0).abs() < 1e-9);
    let stacked = box_obj(Vector3::zeros(), unit, 1) + &box_obj(Vector3::zeros(), unit, 9);
    assert_eq!(
        read(stacked).mass_properties(1000.0).unwrap_err(),
        MeshError::NonManifold { edges: 18 }
    );
}
