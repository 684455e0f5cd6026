//! `MassProperties` against closed forms: principal moments of tensors with one product of
//! inertia, the inertia about an arbitrary point, and the validity tolerances, which must scale
//! with the size of the body. Regression tests for the gaps a mutation run found
//! (docs/mutants.md).

use nalgebra::{Matrix3, Vector3};
use tumble::model::mass_properties::{
    MassProperties, SYMMETRY_RELATIVE_TOLERANCE, TRIANGLE_RELATIVE_TOLERANCE,
};

/// Eigenvalues of the symmetric 2×2 block `[[a, b], [b, c]]`, ascending:
/// `(a + c)/2 ∓ sqrt(((a − c)/2)² + b²)`.
fn block_eigenvalues(a: f64, c: f64, b: f64) -> (f64, f64) {
    let mean = 0.5 * (a + c);
    let radius = (0.25 * (a - c) * (a - c) + b * b).sqrt();
    (mean - radius, mean + radius)
}

/// `diag(1, 2, 2.5)` kg m² with one product of inertia `0.3` at `(i, j)` (and `(j, i)`).
fn with_product(i: usize, j: usize) -> MassProperties {
    let mut inertia = Matrix3::from_diagonal(&Vector3::new(1.0, 2.0, 2.5));
    inertia[(i, j)] = 0.3;
    inertia[(j, i)] = 0.3;
    MassProperties::new(1.0, Vector3::zeros(), inertia)
}

/// Asserts ascending `moments` and that each column of `frame_from_principal` is a unit
/// eigenvector of `inertia` for its moment: `|I e − λ e| ≤ 1e-14` (the symmetric eigensolver's
/// accuracy is a few eps · |I|, eps · 2.56 = 5.7e-16; measured ≤ 9.8e-16).
fn assert_eigenpairs(mp: &MassProperties, expected: Vector3<f64>) {
    let (moments, frame_from_principal) = mp.principal();
    // Closed form vs eigensolver, both rounded: measured 1.3e-15 (ixz), 4.4e-16 (iyz, ixy);
    // bound 1e-14.
    assert!(
        (moments - expected).amax() < 1e-14,
        "moments {moments} expected {expected}"
    );
    let q = frame_from_principal.to_rotation_matrix();
    for k in 0..3 {
        let e = q.matrix().column(k).into_owned();
        let residual = (mp.inertia * e - e * moments[k]).amax();
        assert!(residual < 1e-14, "axis {k}: |I e - λ e| = {residual:e}");
    }
}

/// A tensor whose only off-diagonal term is `ixz` (or `iyz`, or `ixy`): any body symmetric about
/// two coordinate planes tilted about the third axis has one. With `!=` for `==` in the test of
/// an already-diagonal tensor, it took the diagonal shortcut: `tumble inspect` printed (1, 2,
/// 2.5) for the `ixz` tensor below instead of (0.942, 2.0, 2.558), and the simulation used them.
#[test]
fn a_tensor_with_a_single_product_of_inertia_is_diagonalised() {
    // ixz: the x–z block [[1, 0.3], [0.3, 2.5]]; y (2) is already principal.
    let (lo, hi) = block_eigenvalues(1.0, 2.5, 0.3);
    assert!((lo - 0.942_22).abs() < 1e-5 && (hi - 2.557_78).abs() < 1e-5);
    assert_eigenpairs(&with_product(0, 2), Vector3::new(lo, 2.0, hi));
    // iyz: the y–z block [[2, 0.3], [0.3, 2.5]]; x (1) is principal.
    let (lo, hi) = block_eigenvalues(2.0, 2.5, 0.3);
    assert_eigenpairs(&with_product(1, 2), Vector3::new(1.0, lo, hi));
    // ixy: the x–y block [[1, 0.3], [0.3, 2]]; z (2.5) is principal.
    let (lo, hi) = block_eigenvalues(1.0, 2.0, 0.3);
    assert_eigenpairs(&with_product(0, 1), Vector3::new(lo, hi, 2.5));
}

/// Parallel axis about a point other than the origin, against the definition
/// `I_p = Σ mᵢ (|rᵢ|² E − rᵢ rᵢᵀ)`, `rᵢ = xᵢ − p`, for two point masses.
#[test]
fn inertia_about_an_arbitrary_point_is_the_definition() {
    let points = [
        (1.0, Vector3::new(1.0, 0.0, 0.0)),
        (3.0, Vector3::new(0.0, 2.0, 1.0)),
    ];
    let parts: Vec<MassProperties> = points
        .iter()
        .map(|&(m, x)| MassProperties::point(m, x))
        .collect();
    let body = MassProperties::combine(&parts).unwrap();
    for p in [
        Vector3::new(0.5, -1.0, 2.0),
        Vector3::new(-3.0, 0.25, 0.0),
        body.com,
        Vector3::zeros(),
    ] {
        let expected: Matrix3<f64> = points
            .iter()
            .map(|&(m, x)| {
                let r = x - p;
                (Matrix3::identity() * r.norm_squared() - r * r.transpose()) * m
            })
            .sum();
        // Round-off of sums of terms up to 52: measured 0 (every term is a multiple of 1/16);
        // bound 1e-13 (a few ulps of 52 is 3e-14).
        let error = (body.inertia_about(&p) - expected).amax();
        assert!(error < 1e-13, "about {p}: error {error:e}");
    }
    // A point mass about a point 1 m off along x, 2 m along z: m (|d|² E − d dᵀ) by hand.
    let mp = MassProperties::point(2.0, Vector3::new(1.0, 0.0, 2.0));
    let i = mp.inertia_about(&Vector3::new(0.0, 0.0, 0.0));
    assert_eq!(
        i,
        Matrix3::new(8.0, 0.0, -4.0, 0.0, 10.0, 0.0, -4.0, 0.0, 2.0)
    );
    let i = mp.inertia_about(&Vector3::new(1.0, 0.0, 0.0));
    assert_eq!(i, Matrix3::from_diagonal(&Vector3::new(8.0, 8.0, 0.0)));
}

/// Mass scales spanning a microgram part to a ship's hull section.
const SCALES: [f64; 7] = [1e-12, 1e-9, 1e-3, 1.0, 1e3, 1e9, 1e12];

/// The symmetry tolerance is relative to `|I|max`: a body with an asymmetry of half the
/// tolerance is accepted, one of twice the tolerance refused, at every scale (`tol / scale` in
/// place of `tol * scale` refused the heavy body and accepted the light one).
#[test]
fn the_symmetry_tolerance_scales_with_the_inertia() {
    for s in SCALES {
        let verdict = |fraction: f64| {
            let mut mp = with_product(0, 2);
            mp.mass *= s;
            mp.inertia *= s;
            // |I|max = 2.5 s; the (0, 1) entry alone is off: asymmetry = fraction · tol · |I|max.
            mp.inertia[(0, 1)] = fraction * SYMMETRY_RELATIVE_TOLERANCE * 2.5 * s;
            mp.validate()
        };
        assert_eq!(verdict(0.5), Vec::<String>::new(), "scale {s:e}");
        let refused = verdict(2.0);
        assert_eq!(refused.len(), 1, "scale {s:e}: {refused:?}");
        assert!(refused[0].contains("not symmetric"), "{refused:?}");
    }
}

/// The triangle-inequality tolerance is relative to `tr(I)`: moments `(1, 2, 3 + δ)` (a planar
/// body, then past it by `δ`) pass for `δ` at half the tolerance and are refused at twice it, at
/// every scale, for the diagonal tensor and for the same body turned about y.
#[test]
fn the_triangle_tolerance_scales_with_the_inertia() {
    let turn = nalgebra::Rotation3::from_axis_angle(&Vector3::y_axis(), 0.3);
    for s in SCALES {
        for rotated in [false, true] {
            let body = |fraction: f64| {
                // tr(I) = 6 + δ ≈ 6 (δ ≤ 1.2e-8 changes the bound by 1e-17 relative).
                let delta = fraction * TRIANGLE_RELATIVE_TOLERANCE * 6.0;
                let diagonal = Matrix3::from_diagonal(&Vector3::new(1.0, 2.0, 3.0 + delta)) * s;
                let inertia = if rotated {
                    turn.matrix() * diagonal * turn.matrix().transpose()
                } else {
                    diagonal
                };
                MassProperties::new(s, Vector3::zeros(), inertia)
            };
            let accepted = body(0.5);
            assert!(
                !accepted.breaks_triangle_inequality() && accepted.validate().is_empty(),
                "scale {s:e}, rotated {rotated}: {:?}",
                accepted.validate()
            );
            let refused = body(2.0);
            assert!(refused.breaks_triangle_inequality(), "scale {s:e}");
            let problems = refused.validate();
            assert_eq!(problems.len(), 1, "{problems:?}");
            assert!(problems[0].contains("triangle inequality"), "{problems:?}");
            // The opt-in skips exactly this rule.
            assert!(refused.validate_with(true).is_empty());
        }
    }
}

/// At exactly the tolerance a body passes: the rules are `|I − Iᵀ|max ≤ tol · |I|max` and
/// `I1 + I2 ≥ I3 − tol · tr(I)` (documented on `MassProperties::validate`), so `>=` for `>` in
/// the first or `<=` for `<` in the second would refuse it.
#[test]
fn a_body_at_exactly_the_tolerance_passes() {
    let mut mp = with_product(0, 2);
    let limit = SYMMETRY_RELATIVE_TOLERANCE * mp.inertia.amax();
    mp.inertia[(0, 1)] = limit;
    assert_eq!((mp.inertia - mp.inertia.transpose()).amax(), limit);
    assert_eq!(mp.validate(), Vec::<String>::new());
    mp.inertia[(0, 1)] = limit * (1.0 + f64::EPSILON);
    assert_eq!(mp.validate().len(), 1, "{:?}", mp.validate());

    // Moments (1, 2, c) with 1 + 2 = c − tol · (3 + c) exactly in f64: c found by stepping one
    // ulp at a time from the real solution c = 3 (1 + tol) / (1 − tol).
    let gap = |c: f64| (1.0 + 2.0) - (c - TRIANGLE_RELATIVE_TOLERANCE * (3.0 + c));
    let mut c = 3.0 * (1.0 + TRIANGLE_RELATIVE_TOLERANCE) / (1.0 - TRIANGLE_RELATIVE_TOLERANCE);
    let mut steps = 0;
    while gap(c) != 0.0 {
        c = if gap(c) < 0.0 {
            c.next_down()
        } else {
            c.next_up()
        };
        steps += 1;
        assert!(steps < 1000, "no exact boundary near {c}");
    }
    let at = |c: f64| {
        MassProperties::new(
            1.0,
            Vector3::zeros(),
            Matrix3::from_diagonal(&Vector3::new(1.0, 2.0, c)),
        )
    };
    assert!(!at(c).breaks_triangle_inequality(), "c = {c}");
    // One ulp more moment and it breaks the rule.
    assert!(gap(c.next_up()) < 0.0 && at(c.next_up()).breaks_triangle_inequality());
}
