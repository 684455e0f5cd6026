//! The Newton matrix's elimination ([`super::aba`]) against the residual's own derivative by
//! central differences: `K(q)⁻¹ (h ∂r/∂q_k)` must be the unit vector `e_k`.

use super::model::TreeModel;
use super::step::TreeState;
use crate::scene::Scene;
use crate::sim::Bodies;
use nalgebra::Vector3;

/// The bundled scene `name`'s first mechanism, its tree state at the start, and its batch,
/// with momenta set on every body (the matrix does not depend on them; the residual does).
fn setup(
    name: &str,
) -> (
    std::sync::Arc<crate::sim::mechanism::Mechanism>,
    TreeState,
    Bodies,
) {
    let path = format!("{}/models/{name}.toml", env!("CARGO_MANIFEST_DIR"));
    let scene = Scene::load(std::path::Path::new(&path)).unwrap();
    let world = scene.build().unwrap();
    let mechanism = world.mechanisms[0].clone();
    let mut bodies = Bodies::new(&world.bodies);
    for (k, i) in mechanism.bodies().enumerate() {
        let s = k as f64;
        bodies.angmom_body[i] = Vector3::new(0.01 * s, -0.02, 0.015 * s);
        bodies.linvel_world[i] = Vector3::new(0.1, -0.05 * s, 0.2);
    }
    let tree = TreeModel::of(&mechanism).unwrap();
    let mut state = TreeState::new(&mechanism, tree);
    state.init(&mechanism, &bodies);
    (mechanism, state, bodies)
}

/// The largest `|K⁻¹ (h ∂r/∂q_k) − e_k|` over `k`, at the iterate `θ_k + offsets` (and the
/// root at `ξ_0 = (0.2, −0.1, 0.15)`, `Δc_0 = (0.01, 0.02, −0.01)` m, times `offset / 0.3`).
fn worst_column(name: &str, h: f64, offset: f64) -> f64 {
    let (mechanism, mut state, bodies) = setup(name);
    let g = Vector3::new(0.0, 0.0, -9.81);
    let n = state.dofs();
    let nb = n - state.theta.len();
    let mut q: Vec<f64> = (0..n)
        .map(|k| {
            if k >= nb {
                state.theta[k - nb] + offset * (1.0 + 0.3 * (k as f64).sin())
            } else {
                [0.2, -0.1, 0.15, 0.01, 0.02, -0.01][k] * (offset / 0.3)
            }
        })
        .collect();
    let eps = 1e-6;
    let mut worst: f64 = 0.0;
    for k in 0..n {
        let q0 = q[k];
        q[k] = q0 + eps;
        let plus = state.scaled_residual_at(&mechanism, &bodies, h, &g, &q);
        q[k] = q0 - eps;
        let minus = state.scaled_residual_at(&mechanism, &bodies, h, &g, &q);
        q[k] = q0;
        let column: Vec<f64> = plus
            .iter()
            .zip(&minus)
            .map(|(p, m)| (p - m) / (2.0 * eps))
            .collect();
        state.scaled_residual_at(&mechanism, &bodies, h, &g, &q);
        let x = state.solve_at_iterate(&mechanism, &bodies, &column);
        for (i, xi) in x.iter().enumerate() {
            let expected = if i == k { 1.0 } else { 0.0 };
            worst = worst.max((xi - expected).abs());
        }
    }
    worst
}

/// Central differences of step `ε = 1e-6` err by `ε² |r'''| ≈ 1e-12` and by round-off
/// `ε_mach |h r| / ε ≈ 1e-10` of the column; a missing term of the matrix (any of `G`'s, the
/// right twists at the iterate, the root's maps) errs by its own size, 1e-3 or more at these
/// offsets (0.3 rad per joint, a root turned by 0.27 rad).
#[test]
fn the_newton_matrix_is_the_residuals_derivative() {
    for (name, h) in [
        ("double_pendulum", 0.01),
        ("chain7", 0.001),
        ("chain7_driven", 0.01),
        ("chain3_free", 0.01),
        ("cart_pole", 0.01),
        ("arm_servo", 0.01),
    ] {
        let worst = worst_column(name, h, 0.3);
        eprintln!("{name}: {worst:e}");
        // measured: 1.1e-10 … 1.2e-7 (round-off of the difference quotient; the largest on
        // chain7 at h = 1 ms, where h r is smallest against its round-off)
        assert!(worst < 1e-6, "{name}: {worst:e}");
    }
}

/// At `q' = q_k` (no motion) the matrix is the mass matrix plus the drives' diagonal, whose
/// elimination is the articulated-body factorisation; the same check at zero offset.
#[test]
fn at_the_start_the_newton_matrix_is_the_mass_matrix() {
    for name in ["chain7", "chain3_free"] {
        let worst = worst_column(name, 0.001, 0.0);
        eprintln!("{name} at rest: {worst:e}");
        // measured: 1.9e-10 … 1.0e-9
        assert!(worst < 1e-8, "{name}: {worst:e}");
    }
}

/// Forward kinematics at the coordinates read from the batch places every body where the batch
/// has it (the tree's rest rotations and anchors are the maximal model's): hinges, a slider
/// under a hinge (the cart pole, whose slider rest rotation was once the lock rows' pairs
/// summed cyclically shifted: the cart turned by 120° about (1, 1, 1), the pole swinging in
/// the wrong plane), a floating root.
#[test]
fn forward_kinematics_places_the_bodies_where_the_batch_has_them() {
    for name in ["double_pendulum", "chain7", "chain3_free", "cart_pole"] {
        let (mechanism, state, bodies) = setup(name);
        let mut worst: f64 = 0.0;
        for (k, (q, c)) in state.poses_at_k().iter().enumerate() {
            let i = mechanism.first_body + k;
            worst = worst
                .max(q.angle_to(&bodies.world_from_body[i]))
                .max((c - bodies.com_world[i]).amax());
        }
        eprintln!("{name}: {worst:e}");
        // measured: 0 … 2.2e-16 (round-off of the rest rotations)
        assert!(worst < 1e-12, "{name}: {worst:e}");
    }
}
