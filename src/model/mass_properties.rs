//! Rigid-body mass properties: mass, centre of mass and the inertia tensor about the centre of
//! mass, with the operations a URDF reader and a simulator need (change of frame, sum of parts,
//! principal axes, physical validity).
//!
//! Conventions: SI units (kg, m, kg m²). A [`MassProperties`] lives in one frame `b`: `com` is
//! expressed in `b`, and `inertia` is the tensor about the centre of mass in the axes of `b`,
//!
//! ```text
//! I = ∫ (|r|² E − r rᵀ) dm,   r = x − com,   E the 3×3 identity.
//! ```
//!
//! References: Featherstone, "Rigid Body Dynamics Algorithms" (2008), §2.13 (parallel axis,
//! change of frame); the triangle inequality on principal moments follows from
//! `I1 + I2 − I3 = 2 ∫ z² dm ≥ 0` in the principal frame (MuJoCo rejects bodies that break it).

use nalgebra::{Isometry3, Matrix3, Rotation3, SymmetricEigen, UnitQuaternion, Vector3};

/// Mass, centre of mass and inertia about the centre of mass, in one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassProperties {
    /// Mass in kg.
    pub mass: f64,
    /// Centre of mass in the frame these properties are expressed in, m.
    pub com: Vector3<f64>,
    /// Inertia tensor about the centre of mass, in the axes of the same frame, kg m².
    pub inertia: Matrix3<f64>,
}

/// Relative tolerance of the triangle-inequality rule: `I1 + I2 ≥ I3 − 1e-9 · trace(I)`, so
/// that an exactly planar body (`I1 + I2 = I3`, e.g. a thin plate) passes despite rounding.
pub const TRIANGLE_RELATIVE_TOLERANCE: f64 = 1e-9;

/// Relative tolerance of the symmetry rule: `|I − Iᵀ|max ≤ 1e-9 · |I|max`.
pub const SYMMETRY_RELATIVE_TOLERANCE: f64 = 1e-9;

/// `x` with 6 significant digits, trailing zeros dropped (`3e-1`, `4.49167e-5`): for messages.
fn sig(x: f64) -> String {
    if !x.is_finite() || x == 0.0 {
        return x.to_string();
    }
    let s = format!("{x:.5e}");
    match s.split_once('e') {
        Some((mantissa, exponent)) if mantissa.contains('.') => {
            let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
            format!("{mantissa}e{exponent}")
        }
        _ => s,
    }
}

/// The parallel-axis term `m (|d|² E − d dᵀ)`: what must be added to an inertia about the centre
/// of mass to get the inertia about a point at `−d` from it (equivalently: the inertia of a point
/// mass `m` at offset `d`).
pub fn parallel_axis(mass: f64, d: &Vector3<f64>) -> Matrix3<f64> {
    (Matrix3::identity() * d.norm_squared() - d * d.transpose()) * mass
}

impl MassProperties {
    pub fn new(mass: f64, com: Vector3<f64>, inertia: Matrix3<f64>) -> Self {
        Self { mass, com, inertia }
    }

    /// A point mass at `com` (zero inertia about its centre).
    pub fn point(mass: f64, com: Vector3<f64>) -> Self {
        Self::new(mass, com, Matrix3::zeros())
    }

    /// The same body expressed in frame `a`, given the pose of `b` (the current frame) in `a`:
    ///
    /// ```text
    /// com_a = a_from_b · com_b          (rotation then translation)
    /// I_a   = R I_b Rᵀ                   (R the rotation of a_from_b)
    /// ```
    ///
    /// The inertia stays about the centre of mass, so the translation does not enter it.
    pub fn transformed(&self, a_from_b: &Isometry3<f64>) -> Self {
        let r = a_from_b.rotation.to_rotation_matrix();
        let r = r.matrix();
        Self {
            mass: self.mass,
            com: a_from_b.transform_point(&self.com.into()).coords,
            inertia: r * self.inertia * r.transpose(),
        }
    }

    /// Inertia about an arbitrary `point` (same frame), by the parallel-axis theorem
    /// `I_o = I_c + m (|d|² E − d dᵀ)` with `d = com − point`.
    pub fn inertia_about(&self, point: &Vector3<f64>) -> Matrix3<f64> {
        self.inertia + parallel_axis(self.mass, &(self.com - point))
    }

    /// The rigid union of several bodies expressed in the same frame.
    ///
    /// ```text
    /// M   = Σ mᵢ
    /// c   = p + Σ mᵢ (cᵢ − p) / M            (p: the first part's com, a reference point)
    /// I_c = Σ [ Iᵢ + mᵢ (|dᵢ|² E − dᵢ dᵢᵀ) ],  dᵢ = cᵢ − c
    /// ```
    ///
    /// Offsets are taken from a reference point near the parts rather than from the frame
    /// origin: summing `mᵢ cᵢ` and `I about the origin` of parts 1 km away, then shifting back,
    /// cancels digits (2e-4 relative error at 1 km for centimetre parts).
    ///
    /// Returns `None` when there are no parts or the total mass is not a positive finite number
    /// (the centre of mass would be undefined). Parts with zero mass contribute nothing.
    pub fn combine<'a>(parts: impl IntoIterator<Item = &'a MassProperties>) -> Option<Self> {
        let parts: Vec<&MassProperties> = parts.into_iter().collect();
        let reference = parts.first()?.com;
        let mass: f64 = parts.iter().map(|p| p.mass).sum();
        if !(mass.is_finite() && mass > 0.0) {
            return None;
        }
        let weighted: Vector3<f64> = parts
            .iter()
            .map(|p| (p.com - reference) * p.mass)
            .fold(Vector3::zeros(), |acc, v| acc + v);
        let com = reference + weighted / mass;
        let inertia = parts
            .iter()
            .map(|p| p.inertia + parallel_axis(p.mass, &(p.com - com)))
            .fold(Matrix3::zeros(), |acc, i| acc + i);
        Some(Self { mass, com, inertia })
    }

    /// Principal moments and axes: `I = Q diag(moments) Qᵀ`, with `moments` ascending and
    /// `Q = frame_from_principal` a proper rotation (det +1): its columns are the principal axes.
    ///
    /// Computed from nalgebra's symmetric eigendecomposition of `(I + Iᵀ)/2`, then sorted and
    /// re-orthonormalised (Gram–Schmidt, third axis = first × second) so that repeated
    /// eigenvalues, where any basis of the eigenspace is valid, still give a right-handed
    /// orthonormal frame. For determinism each of the first two axes is signed so that its
    /// largest component is positive; a tensor that is already diagonal gets an axis permutation
    /// (no spurious rotation, e.g. identity for a sphere).
    ///
    /// Non-finite tensors have no decomposition: the moments come back NaN and the rotation is
    /// the identity (never a panic, never an endless iteration).
    pub fn principal(&self) -> (Vector3<f64>, UnitQuaternion<f64>) {
        let nan = Vector3::repeat(f64::NAN);
        if !self.inertia.iter().all(|x| x.is_finite()) {
            return (nan, UnitQuaternion::identity());
        }
        let sym = (self.inertia + self.inertia.transpose()) * 0.5;
        let off_diagonal_zero = sym[(0, 1)] == 0.0 && sym[(0, 2)] == 0.0 && sym[(1, 2)] == 0.0;
        let (values, vectors) = if off_diagonal_zero {
            (sym.diagonal(), Matrix3::identity())
        } else {
            match SymmetricEigen::try_new(sym, f64::EPSILON, 1000) {
                Some(eig) => (eig.eigenvalues, eig.eigenvectors),
                None => return (nan, UnitQuaternion::identity()),
            }
        };
        // Sort ascending (stable: equal moments keep the frame's axis order).
        let mut order = [0usize, 1, 2];
        order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
        let moments = Vector3::new(values[order[0]], values[order[1]], values[order[2]]);
        let signed = |v: Vector3<f64>| -> Vector3<f64> {
            let imax = v.iamax();
            if v[imax] < 0.0 { -v } else { v }
        };
        let e0 = signed(vectors.column(order[0]).normalize());
        let e1 = vectors.column(order[1]).into_owned();
        let e1 = signed((e1 - e0 * e0.dot(&e1)).normalize());
        let e2 = e0.cross(&e1);
        let q = Matrix3::from_columns(&[e0, e1, e2]);
        let rotation = Rotation3::from_matrix_unchecked(q);
        (moments, UnitQuaternion::from_rotation_matrix(&rotation))
    }

    /// Principal moments only, ascending (see [`MassProperties::principal`]).
    pub fn principal_moments(&self) -> Vector3<f64> {
        self.principal().0
    }

    /// Checks the rules a physical rigid body obeys and returns each broken one in words
    /// (empty when the body is valid). Rules, in order:
    ///
    /// 1. mass, centre of mass and inertia are finite;
    /// 2. mass > 0 (zero: "massless"; negative: impossible);
    /// 3. inertia symmetric: `|I − Iᵀ|max ≤ 1e-9 |I|max`;
    /// 4. positive definite: every principal moment > 0;
    /// 5. triangle inequality: `I1 + I2 ≥ I3 − 1e-9 tr(I)` for ascending moments `I1 ≤ I2 ≤ I3`
    ///    (`I1 + I2 − I3 = 2 ∫ z² dm ≥ 0`; equality is a planar body and passes).
    ///
    /// A zero mass with an all-zero inertia (a placeholder "massless" body) reports only the
    /// zero-mass rule.
    pub fn validate(&self) -> Vec<String> {
        self.validate_with(false)
    }

    /// [`MassProperties::validate`], with rule 5 (triangle inequality) skipped when
    /// `allow_triangle_violation` is set: the user's explicit opt-in to simulate a body no mass
    /// distribution has (the equations of motion are still well defined for any positive
    /// definite inertia).
    pub fn validate_with(&self, allow_triangle_violation: bool) -> Vec<String> {
        let mut problems = Vec::new();
        if !self.mass.is_finite() {
            problems.push(format!("mass is not finite: {}", self.mass));
        }
        if !self.com.iter().all(|x| x.is_finite()) {
            problems.push(format!(
                "centre of mass is not finite: [{}, {}, {}]",
                self.com.x, self.com.y, self.com.z
            ));
        }
        let inertia_finite = self.inertia.iter().all(|x| x.is_finite());
        if !inertia_finite {
            problems.push("inertia is not finite (NaN or infinite entries)".to_string());
        }
        if self.mass == 0.0 {
            problems.push("mass is zero: the link is massless and will not be simulated".into());
            if self.inertia.iter().all(|&x| x == 0.0) {
                return problems;
            }
        } else if self.mass < 0.0 {
            problems.push(format!("mass is negative: {} kg", self.mass));
        }
        if !inertia_finite {
            return problems;
        }
        let scale = self.inertia.amax();
        let asymmetry = (self.inertia - self.inertia.transpose()).amax();
        if asymmetry > SYMMETRY_RELATIVE_TOLERANCE * scale {
            problems.push(format!(
                "inertia is not symmetric: largest |I - I^T| entry {} kg m^2",
                sig(asymmetry)
            ));
        }
        let m = self.principal_moments();
        if m[0].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            problems.push(format!(
                "inertia is not positive definite: principal moments {}, {}, {} kg m^2 \
                 (all must be > 0)",
                sig(m[0]),
                sig(m[1]),
                sig(m[2])
            ));
        }
        if !allow_triangle_violation && self.breaks_triangle_inequality() {
            problems.push(format!(
                "inertia breaks the triangle inequality: principal moments {} + {} < {} \
                 kg m^2 (no mass distribution has these moments)",
                sig(m[0]),
                sig(m[1]),
                sig(m[2])
            ));
        }
        problems
    }

    /// Whether the ascending principal moments break `I1 + I2 >= I3 - 1e-9 tr(I)` (rule 5).
    pub fn breaks_triangle_inequality(&self) -> bool {
        let m = self.principal_moments();
        m[0] + m[1] < m[2] - TRIANGLE_RELATIVE_TOLERANCE * self.inertia.trace().abs()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Translation3;

    fn box_inertia(m: f64, a: f64, b: f64, c: f64) -> Matrix3<f64> {
        Matrix3::from_diagonal(&Vector3::new(
            m * (b * b + c * c) / 12.0,
            m * (a * a + c * c) / 12.0,
            m * (a * a + b * b) / 12.0,
        ))
    }

    #[test]
    fn transformed_rotates_inertia_and_moves_com() {
        // Rz(90°): x -> y, y -> -x. diag(1, 2, 3) becomes diag(2, 1, 3) exactly (up to rounding).
        let mp = MassProperties::new(
            2.0,
            Vector3::new(1.0, 0.0, 0.0),
            Matrix3::from_diagonal(&Vector3::new(1.0, 2.0, 3.0)),
        );
        let a_from_b = Isometry3::from_parts(
            Translation3::new(0.0, 0.0, 5.0),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2),
        );
        let t = mp.transformed(&a_from_b);
        // Rounding of cos(pi/2) = 6.1e-17 only: measured 2.2e-16 (com and inertia), bound 1e-14.
        assert!((t.com - Vector3::new(0.0, 1.0, 5.0)).amax() < 1e-14);
        let expected = Matrix3::from_diagonal(&Vector3::new(2.0, 1.0, 3.0));
        assert!((t.inertia - expected).amax() < 1e-14);
        assert_eq!(t.mass, 2.0);
    }

    #[test]
    fn combine_two_boxes_is_one_box() {
        // Two 1x1x1 cubes of 1 kg side by side along x = one 2x1x1 box of 2 kg.
        let cube = box_inertia(1.0, 1.0, 1.0, 1.0);
        let far = Vector3::new(1000.0, -2000.0, 3000.0);
        let left = MassProperties::new(1.0, far + Vector3::new(-0.5, 0.0, 0.0), cube);
        let right = MassProperties::new(1.0, far + Vector3::new(0.5, 0.0, 0.0), cube);
        let both = MassProperties::combine([&left, &right]).expect("positive mass");
        assert_eq!(both.mass, 2.0);
        // Centre at `far`: offsets of 0.5 from 1e3-sized coordinates, error at most
        // ulp(3000) = 4.5e-13; measured 0, bound 1e-12.
        assert!((both.com - far).amax() < 1e-12);
        let expected = box_inertia(2.0, 2.0, 1.0, 1.0);
        // Measured 1.1e-16 (1/12 is inexact); bound 1e-13.
        assert!((both.inertia - expected).amax() < 1e-13);
    }

    #[test]
    fn combine_rejects_empty_and_massless() {
        assert!(MassProperties::combine([]).is_none());
        let z = MassProperties::point(0.0, Vector3::zeros());
        assert!(MassProperties::combine([&z]).is_none());
    }

    #[test]
    fn inertia_about_point_is_parallel_axis() {
        let mp = MassProperties::point(3.0, Vector3::new(0.0, 2.0, 0.0));
        let i = mp.inertia_about(&Vector3::zeros());
        assert_eq!(i, Matrix3::from_diagonal(&Vector3::new(12.0, 0.0, 12.0)));
    }

    #[test]
    fn principal_recovers_rotation_of_diagonal_tensor() {
        let moments = Vector3::new(1.0, 2.0, 3.5);
        let q = UnitQuaternion::from_euler_angles(0.3, -0.7, 1.1);
        let r = q.to_rotation_matrix();
        let mp = MassProperties::new(
            1.0,
            Vector3::zeros(),
            r.matrix() * Matrix3::from_diagonal(&moments) * r.matrix().transpose(),
        );
        let (m, p) = mp.principal();
        // Eigen solver accuracy ~ eps * |I| = 8e-16: measured 8.9e-16 on the moments and 2.2e-15
        // on the reconstruction below; bound 1e-12.
        assert!((m - moments).amax() < 1e-12);
        let pm = p.to_rotation_matrix();
        assert!((pm.matrix().determinant() - 1.0).abs() < 1e-12);
        // Each principal axis equals the rotated frame axis up to sign.
        for k in 0..3 {
            let dot = pm.matrix().column(k).dot(&r.matrix().column(k));
            assert!((dot.abs() - 1.0).abs() < 1e-10, "axis {k}: dot {dot}");
        }
        // Reconstruction.
        let back = pm.matrix() * Matrix3::from_diagonal(&m) * pm.matrix().transpose();
        assert!((back - mp.inertia).amax() < 1e-12);
    }

    #[test]
    fn principal_of_repeated_moments_is_a_proper_rotation() {
        // Rotated axisymmetric tensor (two equal moments) and an isotropic one.
        let q = UnitQuaternion::from_euler_angles(0.4, 0.2, -0.9);
        let r = q.to_rotation_matrix();
        for d in [Vector3::new(2.0, 2.0, 1.0), Vector3::new(1.0, 1.0, 1.0)] {
            let i = r.matrix() * Matrix3::from_diagonal(&d) * r.matrix().transpose();
            let mp = MassProperties::new(1.0, Vector3::zeros(), i);
            let (m, p) = mp.principal();
            let pm = p.to_rotation_matrix();
            assert!((pm.matrix().determinant() - 1.0).abs() < 1e-12);
            let back = pm.matrix() * Matrix3::from_diagonal(&m) * pm.matrix().transpose();
            // Measured 1.3e-15; bound 1e-12.
            assert!((back - i).amax() < 1e-12, "{d}: {back} vs {i}");
        }
        // Already diagonal: a pure permutation, proper, ascending.
        let mp = MassProperties::new(
            1.0,
            Vector3::zeros(),
            Matrix3::from_diagonal(&Vector3::new(3.0, 1.0, 2.0)),
        );
        let (m, p) = mp.principal();
        assert_eq!(m, Vector3::new(1.0, 2.0, 3.0));
        let pm = p.to_rotation_matrix();
        assert!((pm.matrix().determinant() - 1.0).abs() < 1e-12);
        assert!((pm.matrix().column(0) - Vector3::y()).amax() < 1e-12);
    }

    #[test]
    fn principal_of_nan_does_not_panic() {
        let mp = MassProperties::new(1.0, Vector3::zeros(), Matrix3::repeat(f64::NAN));
        let (m, p) = mp.principal();
        assert!(m.iter().all(|x| x.is_nan()));
        assert_eq!(p, UnitQuaternion::identity());
    }

    #[test]
    fn message_numbers_are_short() {
        assert_eq!(sig(0.30000000000000004), "3e-1");
        assert_eq!(sig(-0.1), "-1e-1");
        assert_eq!(sig(4.491666666666667e-5), "4.49167e-5");
        assert_eq!(sig(0.0), "0");
    }

    #[test]
    fn validate_rules() {
        let good = MassProperties::new(1.0, Vector3::zeros(), box_inertia(1.0, 0.1, 0.2, 0.3));
        assert!(good.validate().is_empty());
        // Thin plate: I3 = I1 + I2 exactly; passes thanks to the tolerance.
        let plate = MassProperties::new(1.0, Vector3::zeros(), box_inertia(1.0, 0.1, 0.2, 0.0));
        assert!(plate.validate().is_empty(), "{:?}", plate.validate());
        let has = |mp: MassProperties, rule: &str| {
            let p = mp.validate();
            assert!(p.iter().any(|s| s.contains(rule)), "{rule} not in {p:?}");
        };
        has(
            MassProperties {
                mass: f64::NAN,
                ..good
            },
            "mass is not finite",
        );
        has(MassProperties { mass: -1.0, ..good }, "mass is negative");
        has(MassProperties { mass: 0.0, ..good }, "mass is zero");
        has(
            MassProperties {
                com: Vector3::new(f64::INFINITY, 0.0, 0.0),
                ..good
            },
            "centre of mass is not finite",
        );
        let mut asym = good.inertia;
        asym[(0, 1)] = 1e-3;
        has(
            MassProperties {
                inertia: asym,
                ..good
            },
            "not symmetric",
        );
        has(
            MassProperties {
                inertia: Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, 1.0)),
                ..good
            },
            "not positive definite",
        );
        has(
            MassProperties {
                inertia: Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 3.0)),
                ..good
            },
            "triangle inequality",
        );
        // Massless placeholder: only the zero-mass rule.
        let massless = MassProperties::point(0.0, Vector3::zeros());
        assert_eq!(massless.validate().len(), 1);
    }
}
