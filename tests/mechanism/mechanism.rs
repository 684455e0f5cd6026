//! Articulated mechanisms (`bodies = "articulated"`) against closed forms and conservation laws.
//!
//! Every run goes through the library as a user's scene would: a scene text next to the bundled
//! models in `models/`, `Scene::build`, `World::integrator`, and the reported quantities of
//! `run::FrameBuilder` (projected momenta, joint coordinates, per-model totals).

use crate::common;
use crate::common::urdfs::models_scene as scene;

use nalgebra::{Matrix2, Vector3};
use tumble::record::{JointState, MechanismState};
use tumble::scene::Scene;
use tumble::sim::Loads;
use tumble::sim::integrators::{IntegratorKind, VariationalSettings};
use tumble::sim::reference::elliptic::{complete_k, jacobi_sn_cn_dn};
use tumble::sim::{Bodies, Integrator, StepStats};
use tumble::simulation::FrameBuilder;
use tumble::world::World;

const G: f64 = 9.81;

/// A running simulation with its reporter.
struct Sim {
    world: World,
    bodies: Bodies,
    integrator: Box<dyn Integrator>,
    frames: FrameBuilder,
    gravity: Vector3<f64>,
    dt: f64,
    step: u64,
    stats: StepStats,
}

impl Sim {
    fn new(scene: &Scene) -> Self {
        Self::with(
            scene,
            scene.integrator(),
            scene.sim.dt,
            &scene.variational_settings(),
        )
    }

    fn with(scene: &Scene, kind: IntegratorKind, dt: f64, settings: &VariationalSettings) -> Self {
        let world = scene.build().expect("scene builds");
        let bodies = Bodies::new(&world.bodies);
        let mut integrator = world.integrator(kind, dt, settings).expect("integrator");
        integrator.init(&bodies);
        let frames = FrameBuilder::new(&world);
        Self {
            world,
            bodies,
            integrator,
            frames,
            gravity: scene.gravity(),
            dt,
            step: 0,
            stats: StepStats::default(),
        }
    }

    fn advance(&mut self, steps: u64) {
        for _ in 0..steps {
            let s = self
                .integrator
                .step(&mut self.bodies, &Loads::uniform_gravity(self.gravity));
            self.stats = self.stats.merge(s);
            self.step += 1;
        }
    }

    /// The reported joints and model totals at the current step.
    fn report(&mut self) -> (Vec<JointState>, Vec<MechanismState>) {
        let frame = self.frames.frame(
            &self.bodies,
            &Loads::uniform_gravity(self.gravity),
            self.step,
            self.dt,
        );
        (frame.joints.to_vec(), frame.mechanisms.to_vec())
    }

    fn time(&self) -> f64 {
        self.step as f64 * self.dt
    }
}

fn energy(m: &MechanismState) -> f64 {
    m.kinetic_energy + m.potential_energy
}

/// The exact angle of a pendulum released from rest at `theta0`:
/// `sin(θ/2) = k sn(K − ω0 t | k²)`, `k = sin(θ0/2)`.
fn pendulum_angle(theta0: f64, omega0: f64, t: f64) -> f64 {
    let k = (theta0 / 2.0).sin();
    let (sn, _, _) = jacobi_sn_cn_dn(complete_k(k * k) - omega0 * t, k * k);
    2.0 * (k * sn).asin()
}

/// The double pendulum with its elbow locked: one compound pendulum, two rods of m = 1 kg,
/// L = 1 m end to end. About the pivot: mass 2 kg, centre of mass d = 1 m below it,
/// I_pivot = Σ (I_c + m r²) = 2 · 0.0834333… + 0.5² + 1.5² = 2.6668666… kg m²,
/// ω0² = M g d / I_pivot.
fn locked_pendulum(theta0: f64, dt: f64) -> (Scene, f64) {
    let text = format!(
        "[sim]\ndt = {dt}\nduration = 10.0\n[[model]]\nurdf = \"double_pendulum.urdf\"\n\
         bodies = \"articulated\"\nbase = \"fixed\"\nlocked_joints = [\"elbow\"]\n\
         joints = {{ shoulder = {theta0} }}\n"
    );
    let i_pivot = 2.0 * 0.08343333333333333 + 0.25 + 2.25;
    (scene(&text), (2.0 * G * 1.0 / i_pivot).sqrt())
}

/// Period of the large-amplitude pendulum: 4 K(sin²(θ0/2)) / ω0, from the times the angle
/// crosses zero downwards (linear interpolation between steps: error O(h²) per crossing).
#[test]
fn pendulum_period_matches_the_elliptic_integral() {
    let theta0 = 2.5;
    let (scene, omega0) = locked_pendulum(theta0, 1e-3);
    let mut sim = Sim::new(&scene);
    let period = 4.0 * complete_k((theta0 / 2.0).sin().powi(2)) / omega0;
    let mut crossings = Vec::new();
    let mut prev = sim.report().0[0].position;
    while sim.time() < 6.0 * period {
        sim.advance(1);
        let theta = sim.report().0[0].position;
        if prev > 0.0 && theta <= 0.0 {
            let frac = prev / (prev - theta);
            crossings.push(sim.time() - sim.dt + frac * sim.dt);
        }
        prev = theta;
    }
    assert!(crossings.len() >= 5, "{crossings:?}");
    let measured = (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
    let rel = (measured - period).abs() / period;
    eprintln!("pendulum period {measured} s vs {period} s: relative {rel:e}");
    // Second order in h (the crossing interpolation is O(h²) too, and averages out over five
    // periods). Measured 9.6e-7 (T = 3.806 s, θ0 = 2.5 rad, h = 1 ms).
    assert!(rel < 2e-6, "period {measured} s vs {period} s: {rel:e}");
    assert_eq!(sim.stats.newton_failures, 0);
}

/// The pendulum's angle against the exact elliptic solution converges with order 2.
#[test]
fn pendulum_angle_converges_with_order_two() {
    let theta0 = 2.0;
    let mut errors = Vec::new();
    for dt in [4e-3, 2e-3, 1e-3] {
        let (scene, omega0) = locked_pendulum(theta0, dt);
        let mut sim = Sim::new(&scene);
        let mut worst: f64 = 0.0;
        let steps = (2.0 / dt).round() as u64;
        for _ in 0..steps {
            sim.advance(1);
            let theta = sim.report().0[0].position;
            worst = worst.max((theta - pendulum_angle(theta0, omega0, sim.time())).abs());
        }
        errors.push(worst);
    }
    let orders: Vec<f64> = errors.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
    eprintln!("pendulum angle errors {errors:?}, orders {orders:?}");
    // Measured orders 2.00009, 2.00002 (errors 8.6e-5, 2.1e-5, 5.3e-6 rad over 2 s).
    for p in &orders {
        assert!(
            (p - 2.0).abs() < 0.05,
            "orders {orders:?}, errors {errors:?}"
        );
    }
}

/// The linearised double pendulum (absolute angles α1, α2; models/double_pendulum.urdf):
/// `M q̈ + K q = 0`, `M = [[I + m a² + m L², m L a], [m L a, I + m a²]]`, `K = g diag(m a + m L,
/// m a)`, `a = L/2`. Returns the two (ω², eigenvector in (α1, α2)).
fn double_pendulum_modes() -> [(f64, [f64; 2]); 2] {
    let (m, l, a, i) = (1.0, 1.0, 0.5, 0.08343333333333333);
    let mm = Matrix2::new(
        i + m * a * a + m * l * l,
        m * l * a,
        m * l * a,
        i + m * a * a,
    );
    let kk = Matrix2::new(G * (m * a + m * l), 0.0, 0.0, G * m * a);
    // det(K − w M) = 0: a quadratic in w = ω².
    let qa = mm.determinant();
    let qb = -(kk[(0, 0)] * mm[(1, 1)] + kk[(1, 1)] * mm[(0, 0)]);
    let qc = kk.determinant();
    let disc = (qb * qb - 4.0 * qa * qc).sqrt();
    [(-qb - disc) / (2.0 * qa), (-qb + disc) / (2.0 * qa)].map(|w| {
        // (K − w M) v = 0: v = (−(K − wM)₀₁, (K − wM)₀₀).
        let r = kk - mm * w;
        (w, [-r[(0, 1)], r[(0, 0)]])
    })
}

/// Released along a normal mode at small amplitude, the double pendulum oscillates at that
/// mode's frequency, and the joint angles keep the mode's shape.
#[test]
fn double_pendulum_oscillates_at_its_normal_modes() {
    for (omega_sq, v) in double_pendulum_modes() {
        let amp = 1e-3;
        let scale = amp / v[0].abs().max(v[1].abs());
        let (a1, a2) = (v[0] * scale, v[1] * scale);
        // URDF joints: shoulder = α1, elbow = α2 − α1.
        let text = format!(
            "[sim]\ndt = 1e-3\n[[model]]\nurdf = \"double_pendulum.urdf\"\n\
             bodies = \"articulated\"\nbase = \"fixed\"\n\
             joints = {{ shoulder = {a1}, elbow = {} }}\n",
            a2 - a1
        );
        let mut sim = Sim::new(&scene(&text));
        let period = 2.0 * std::f64::consts::PI / omega_sq.sqrt();
        // Crossings of α1 through zero (both directions): half periods.
        let mut crossings = Vec::new();
        let mut shape_error: f64 = 0.0;
        let mut prev = sim.report().0[0].position;
        while sim.time() < 10.0 * period {
            sim.advance(1);
            let j = sim.report().0;
            let (q1, q2) = (j[0].position, j[0].position + j[1].position);
            if prev.signum() != q1.signum() && q1 != 0.0 {
                let frac = prev / (prev - q1);
                crossings.push(sim.time() - sim.dt + frac * sim.dt);
            }
            prev = q1;
            // The mode's shape: α2 / α1 = v2 / v1, i.e. α2 v1 − α1 v2 = 0.
            shape_error = shape_error
                .max((q2 * v[0] - q1 * v[1]).abs() / (scale * (v[0] * v[0] + v[1] * v[1])));
        }
        let n = crossings.len();
        let measured = 2.0 * (crossings[n - 1] - crossings[0]) / (n - 1) as f64;
        let rel = (measured - period).abs() / period;
        eprintln!(
            "mode ω² = {omega_sq}: period {measured} vs {period} ({rel:e}), shape {shape_error:e}"
        );
        // Discretisation O((h ω)²) (ω ≤ 7.2 rad/s) and the amplitude shift O(amp²) ~ 1e-7.
        // Measured 2.6e-7 (slow mode, T = 2.344 s) and 1.29e-6 (fast mode, T = 0.874 s).
        assert!(
            rel < 3e-6,
            "mode ω² = {omega_sq}: period {measured} vs {period} ({rel:e})"
        );
        // Shape kept to O(amp²) and O(h²): measured 2.7e-7 (slow) and 1.3e-8 (fast) relative.
        assert!(
            shape_error < 1e-5,
            "mode ω² = {omega_sq}: shape error {shape_error:e}"
        );
    }
}

/// Cart on a prismatic rail with a hanging pole: the rail pushes only across x, so the
/// momentum along the rail stays constant (gravity along −z) and grows as `M g_x t` under a
/// tilted gravity; the system's centre of mass follows `x0 + (P_x0/M) t + g_x t²/2`.
#[test]
fn cart_rail_momentum_is_constant_and_grows_under_tilted_gravity() {
    let total_mass = 2.5;
    for gx in [0.0, 1.5] {
        let text = format!(
            "[sim]\ndt = 1e-3\ngravity = [{gx}, 0.0, -9.81]\n[[model]]\nurdf = \"cart_pole.urdf\"\n\
             bodies = \"articulated\"\nbase = \"fixed\"\njoints = {{ hinge = 1.2 }}\n\
             joint_velocities = {{ slide = 0.5, hinge = -2.0 }}\n"
        );
        let mut sim = Sim::new(&scene(&text));
        let m0 = sim.report().1[0];
        let (p0, x0) = (m0.linear_momentum.x, m0.com.x);
        let (mut worst_p, mut worst_x): (f64, f64) = (0.0, 0.0);
        for _ in 0..1000 {
            sim.advance(10);
            let t = sim.time();
            let m = sim.report().1[0];
            worst_p = worst_p.max((m.linear_momentum.x - (p0 + total_mass * gx * t)).abs());
            let x = x0 + p0 / total_mass * t + 0.5 * gx * t * t;
            worst_x = worst_x.max((m.com.x - x).abs());
        }
        eprintln!("rail g_x = {gx}: |ΔP_x| max {worst_p:e} kg m/s, |Δx_com| max {worst_x:e} m");
        // Round-off only (the rail's impulses have no x component): at most one rounding of
        // the largest value per step, accumulated over the 10 000 steps. Measured 1.1e-14 and
        // 1.2e-12 kg m/s (P up to 39 kg m/s), 2.4e-14 and 3.7e-12 m (x up to 80 m).
        let (p_max, x_max) = (1.25 + total_mass * gx * 10.0, 5.0 + 0.5 * gx * 100.0);
        let n = 1e4 * f64::EPSILON;
        assert!(
            worst_p < n * p_max,
            "g_x = {gx}: momentum along the rail off by {worst_p:e}"
        );
        assert!(
            worst_x < n * x_max,
            "g_x = {gx}: centre of mass off the rail law by {worst_x:e}"
        );
        assert_eq!(sim.stats.newton_failures, 0);
    }
}

/// A free-floating 3-link chain: the total linear momentum, the angular momentum about the
/// centre of mass and the centre of mass's straight line (its parabola under gravity) are
/// exact to round-off at any step size and at a loose Newton tolerance.
#[test]
fn free_chain_momenta_and_centre_of_mass_are_exact_at_any_step_and_tolerance() {
    for (dt, tol, g) in [
        (1e-3, 1e-12, 0.0),
        (2e-2, 1e-12, 0.0),
        (2e-2, 1e-6, 0.0),
        (1e-2, 1e-6, -9.81),
    ] {
        let text = format!(
            "[sim]\ndt = {dt}\nnewton_tol = {tol}\ngravity = [0.0, 0.0, {g}]\n[[model]]\n\
             urdf = \"chain3_free.urdf\"\nbodies = \"articulated\"\nposition = [1.0, -2.0, 3.0]\n\
             linvel = [0.1, 0.0, 0.05]\nangvel = [0.0, 0.3, 0.5]\njoints = {{ j1 = 0.4, j2 = -0.3 }}\n\
             joint_velocities = {{ j1 = 2.0, j2 = -3.0 }}\n"
        );
        let mut sim = Sim::new(&scene(&text));
        let gravity = Vector3::new(0.0, 0.0, g);
        let total_mass = 3.0;
        let m0 = sim.report().1[0];
        let (mut dp, mut dl, mut dc): (f64, f64, f64) = (0.0, 0.0, 0.0);
        let steps = (10.0 / dt) as u64;
        for _ in 0..steps / 10 {
            sim.advance(10);
            let t = sim.time();
            let m = sim.report().1[0];
            dp = dp
                .max((m.linear_momentum - (m0.linear_momentum + gravity * total_mass * t)).amax());
            dl = dl.max((m.angular_momentum - m0.angular_momentum).amax());
            let c = m0.com + m0.linear_momentum / total_mass * t + gravity * (0.5 * t * t);
            dc = dc.max((m.com - c).amax());
        }
        let l = m0.angular_momentum.norm();
        eprintln!(
            "free chain dt {dt} tol {tol} g {g}: ΔP {dp:e} kg m/s, ΔL {dl:e} (|L| {l:.3}), Δc {dc:e} m"
        );
        // Round-off only, whatever dt and the tolerance: at most one rounding of the largest
        // value per step (n = steps · ε), plus for L the rounding of the lever arms far from the
        // origin (ε |c| |p|). Measured without gravity ΔP ≤ 1.2e-14 kg m/s, ΔL ≤ 5.9e-14
        // kg m²/s (|L| = 1.57), Δc ≤ 3.2e-14 m; under gravity (P to 294 kg m/s, c to 490 m)
        // 4.0e-12, 7.5e-13, 9.3e-12.
        let n = steps as f64 * f64::EPSILON;
        let (p_max, c_max) = (
            1.0 + total_mass * g.abs() * 10.0,
            5.0 + 0.5 * g.abs() * 100.0,
        );
        assert!(dp < n * p_max, "dt {dt} tol {tol}: ΔP {dp:e}");
        assert!(
            dl < n * l + 10.0 * f64::EPSILON * c_max * p_max,
            "dt {dt} tol {tol}: ΔL {dl:e}"
        );
        assert!(dc < n * c_max, "dt {dt} tol {tol}: Δc {dc:e}");
        assert_eq!(sim.stats.newton_failures, 0);
    }
}

/// The joints hold to the Newton tolerance at every step, with no accumulation, on the whip
/// of a 7-link chain released from the horizontal.
#[test]
fn constraint_residual_stays_at_the_newton_tolerance() {
    let text = "[sim]\ndt = 1e-3\n[[model]]\nurdf = \"chain7.urdf\"\nbodies = \"articulated\"\n\
                base = \"fixed\"\njoints = { j1 = 1.5707963267948966 }\n";
    let mut sim = Sim::new(&scene(text));
    // Per half of the run: the largest gap (m) and misalignment (rad).
    let mut worst = [[0.0f64; 2]; 2];
    for k in 0..2000 {
        sim.advance(10);
        let m = sim.report().1[0];
        let half = &mut worst[k / 1000];
        half[0] = half[0].max(m.residual_m);
        half[1] = half[1].max(m.residual_rad);
    }
    eprintln!("chain7 residual max per half (m, rad): {worst:?} over 20 s");
    // The stopping rule: gaps <= newton_tol · L + 8 ε |c|max (L = 0.25 m, |c| <= 4.5 m),
    // misalignments <= newton_tol. Measured 2.5e-13 m, 7.4e-16 rad (first half) and 9.4e-14 m,
    // 6.1e-16 rad (second half) of the 20 000 steps: no accumulation.
    let gap_tol = 1e-12 * 0.25 + 8.0 * f64::EPSILON * 4.5;
    for half in worst {
        assert!(half[0] <= gap_tol, "{worst:?}");
        assert!(half[1] <= 1e-12, "{worst:?}");
    }
    assert_eq!(sim.stats.newton_failures, 0);
}

/// The chaotic double pendulum over 1e6 steps (1000 s at h = 1 ms): the energy error is
/// bounded and does not drift (the largest error in the last 100 s is no larger than in the
/// first 100 s, up to the spread of a bounded oscillation).
#[test]
fn energy_does_not_drift_over_a_million_steps() {
    let text = "[sim]\ndt = 1e-3\n[[model]]\nurdf = \"double_pendulum.urdf\"\n\
                bodies = \"articulated\"\nbase = \"fixed\"\njoints = { shoulder = 2.0, elbow = 0.5 }\n";
    let mut sim = Sim::new(&scene(text));
    let e0 = energy(&sim.report().1[0]);
    let mut window_max = vec![0.0f64; 10];
    for k in 0..100_000u64 {
        sim.advance(10);
        let e = energy(&sim.report().1[0]);
        let w = (k / 10_000) as usize;
        window_max[w] = window_max[w].max((e - e0).abs() / e0.abs());
    }
    eprintln!("double pendulum relative energy error max per 100 s window: {window_max:?}");
    // Bounded, O(h²) (measured 1.23e-3, 2.96e-4, 8.0e-5 over 100 s at h = 2, 1, 0.5 ms):
    // measured 2.8e-4 to 3.3e-4 in every window (first 2.96e-4, last 3.03e-4).
    let (first, last) = (window_max[0], window_max[9]);
    assert!(window_max.iter().all(|&w| w < 1e-3), "{window_max:?}");
    assert!(
        last < 1.5 * first,
        "drift: first window {first:e}, last {last:e}"
    );
    assert_eq!(sim.stats.newton_failures, 0);
    assert_eq!(sim.stats.substepped, 0);
}

/// Final joint angles of the double pendulum after 1 s (moderate swing), at `dt`.
fn pendulum_state(kind: IntegratorKind, dt: f64, tol: f64) -> [f64; 4] {
    let text = "[sim]\n[[model]]\nurdf = \"double_pendulum.urdf\"\nbodies = \"articulated\"\n\
                base = \"fixed\"\njoints = { shoulder = 1.0, elbow = 0.5 }\n";
    let settings = VariationalSettings {
        newton_tol: tol,
        ..Default::default()
    };
    let mut sim = Sim::with(&scene(text), kind, dt, &settings);
    sim.advance((1.0 / dt).round() as u64);
    assert_eq!(sim.stats.newton_failures, 0);
    let j = sim.report().0;
    [j[0].position, j[1].position, j[0].velocity, j[1].velocity]
}

/// `variational`, `variational4` and `variational6` on the articulated step converge with
/// orders 2, 4 and 6 (the constrained step is symmetric, so Yoshida's compositions apply).
#[test]
fn compositions_of_the_constrained_step_have_orders_two_four_and_six() {
    let reference = pendulum_state(IntegratorKind::Variational6, 1e-3, 1e-15);
    for (kind, dts, order) in [
        (IntegratorKind::Variational, [0.02, 0.01, 0.005], 2.0),
        (IntegratorKind::Variational4, [0.02, 0.01, 0.005], 4.0),
        (IntegratorKind::Variational6, [0.05, 0.025, 0.0125], 6.0),
    ] {
        let errors: Vec<f64> = dts
            .iter()
            .map(|&dt| {
                let s = pendulum_state(kind, dt, 1e-15);
                (0..4)
                    .map(|k| (s[k] - reference[k]).abs())
                    .fold(0.0, f64::max)
            })
            .collect();
        let orders: Vec<f64> = errors.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
        eprintln!("{}: errors {errors:?}, orders {orders:?}", kind.name());
        // Measured: variational 2.003, 2.001; variational4 4.04, 4.01; variational6 6.11, 6.03.
        for p in &orders {
            assert!(
                (p - order).abs() < 0.15,
                "{}: orders {orders:?}",
                kind.name()
            );
        }
    }
}

/// Other integrators have no constrained form: one clear error naming the model and the
/// supported ones.
#[test]
fn unsupported_integrators_are_refused_naming_the_model() {
    let text = "[sim]\n[[model]]\nurdf = \"double_pendulum.urdf\"\nname = \"dp\"\n\
                bodies = \"articulated\"\nbase = \"fixed\"\n";
    let world = scene(text).build().unwrap();
    for kind in [
        IntegratorKind::Rk4,
        IntegratorKind::Euler,
        IntegratorKind::SemiImplicit,
        IntegratorKind::MoserVeselov,
    ] {
        let err = world
            .integrator(kind, 1e-3, &VariationalSettings::default())
            .err()
            .expect("refused")
            .to_string();
        assert!(err.contains("`dp`") && err.contains(kind.name()), "{err}");
        assert!(
            err.contains("`variational`, `variational4`, `variational6`"),
            "{err}"
        );
    }
}

/// A model whose joints are all fixed or locked is one rigid body, exactly as
/// `bodies = "rigid"`: the same body and the same attachments, and no mechanism.
#[test]
fn all_joints_locked_is_exactly_rigid_mode() {
    let common = "[sim]\n[[model]]\nurdf = \"arm.urdf\"\nlinvel = [0.1, 0.2, 0.3]\n\
                  angvel = [1.0, -2.0, 0.5]\njoints = { shoulder = 0.4, elbow = -0.7 }\n";
    let rigid = scene(&format!("{common}bodies = \"rigid\"\n"))
        .build()
        .unwrap();
    let locked = scene(&format!(
        "{common}bodies = \"articulated\"\nlocked_joints = [\"shoulder\", \"elbow\"]\n"
    ))
    .build()
    .unwrap();
    assert!(locked.mechanisms.is_empty());
    assert_eq!(locked.bodies, rigid.bodies);
    assert_eq!(locked.attachments, rigid.attachments);
    let ids = |w: &World| {
        w.layout
            .frames
            .iter()
            .map(|f| f.frame_id.clone())
            .collect::<Vec<_>>()
    };
    assert_eq!(ids(&locked), ids(&rigid));
}

/// A fixed joint inside a mechanism merges its links into the rigid-mode composite: the
/// satellite's bus (200 kg box at the origin) and panel (10 kg at (0, −1.5, 0)) make one
/// body of 210 kg, centre of mass (0, −1.5 · 10/210, 0), inertia by the parallel-axis rule.
#[test]
fn fixed_joint_merges_into_the_rigid_composite() {
    let text = "[sim]\n[[model]]\nurdf = \"satellite_arm.urdf\"\nbodies = \"articulated\"\n";
    let world = scene(text).build().unwrap();
    let body = &world.bodies[0];
    assert!((body.mass - 210.0).abs() < 1e-12);
    let y = -1.5 * 10.0 / 210.0;
    let com = body.world_from_body.translation.vector;
    // Measured 0 and 1.4e-17.
    assert!((com - Vector3::new(0.0, y, 0.0)).amax() < 1e-15, "{com}");
    // I = I_bus + m_bus d_bus² + I_panel + m_panel d_panel² (parallel axis along y moves x, z).
    let (d_bus, d_panel) = (y, -1.5 - y);
    let ixx =
        27.333333333333332 + 0.8336666666666667 + 200.0 * d_bus * d_bus + 10.0 * d_panel * d_panel;
    let iyy = 34.666666666666664 + 4.166666666666667;
    let izz = 40.666666666666664
        + 3.333_666_666_666_667
        + 200.0 * d_bus * d_bus
        + 10.0 * d_panel * d_panel;
    let mut expected = [ixx, iyy, izz];
    expected.sort_by(f64::total_cmp);
    let mut got: Vec<f64> = body.principal_moments.iter().copied().collect();
    got.sort_by(f64::total_cmp);
    for k in 0..3 {
        // Eigen-decomposition round-off: measured ≤ 7e-15 relative.
        assert!(
            (got[k] - expected[k]).abs() < 1e-12 * expected[k],
            "{got:?} vs {expected:?}"
        );
    }
    // Bodies: bus + panel, upper_arm, forearm, gripper + camera + tool0 (the massless
    // shoulder_link is inside the compound shoulder joint).
    assert_eq!(world.bodies.len(), 4);
    assert_eq!(world.layout.frames.len(), 8);
}

/// A locked joint is merged: the double pendulum with its elbow locked at 0.3 rad moves as a
/// single-link pendulum whose link carries, by hand, the composite of the two rods.
#[test]
fn locked_joint_equals_the_hand_merged_model() {
    use nalgebra::{Matrix3, Rotation3};
    let elbow = 0.3;
    // Rod inertia about its centre (link axes), and the lower rod turned by Ry(elbow) about
    // the elbow at (0, 0, −1).
    let i_rod = Matrix3::from_diagonal(&Vector3::new(
        0.08343333333333333,
        0.08343333333333333,
        0.0002,
    ));
    let r = Rotation3::from_axis_angle(&Vector3::y_axis(), elbow);
    let c1 = Vector3::new(0.0, 0.0, -0.5);
    let c2 = Vector3::new(0.0, 0.0, -1.0) + r * Vector3::new(0.0, 0.0, -0.5);
    let com = (c1 + c2) / 2.0;
    let pa = |d: Vector3<f64>| Matrix3::identity() * d.norm_squared() - d * d.transpose();
    let inertia = i_rod + pa(c1 - com) + r.matrix() * i_rod * r.matrix().transpose() + pa(c2 - com);
    let dir = tempfile::tempdir().unwrap();
    let urdf = format!(
        "<robot name=\"merged\"><link name=\"base\"/>\
         <joint name=\"shoulder\" type=\"continuous\"><parent link=\"base\"/><child link=\"upper\"/>\
         <axis xyz=\"0 1 0\"/></joint>\
         <link name=\"upper\"><inertial><origin xyz=\"{} {} {}\"/><mass value=\"2\"/>\
         <inertia ixx=\"{}\" ixy=\"{}\" ixz=\"{}\" iyy=\"{}\" iyz=\"{}\" izz=\"{}\"/></inertial></link></robot>",
        com.x,
        com.y,
        com.z,
        inertia[(0, 0)],
        inertia[(0, 1)],
        inertia[(0, 2)],
        inertia[(1, 1)],
        inertia[(1, 2)],
        inertia[(2, 2)]
    );
    std::fs::write(dir.path().join("merged.urdf"), urdf).unwrap();
    std::fs::copy(
        common::root().join("models/double_pendulum.urdf"),
        dir.path().join("dp.urdf"),
    )
    .unwrap();
    let run = |text: String| {
        let scene = Scene::parse(&text, &dir.path().join("s.toml")).unwrap();
        let mut sim = Sim::new(&scene);
        let mut angles = Vec::new();
        for _ in 0..200 {
            sim.advance(10);
            angles.push(sim.report().0[0].position);
        }
        angles
    };
    let base = "[sim]\ndt = 1e-3\n[[model]]\nbodies = \"articulated\"\nbase = \"fixed\"\n";
    let locked = run(format!(
        "{base}urdf = \"dp.urdf\"\nlocked_joints = [\"elbow\"]\njoints = {{ shoulder = 1.2, elbow = {elbow} }}\n"
    ));
    let merged = run(format!(
        "{base}urdf = \"merged.urdf\"\njoints = {{ shoulder = 1.2 }}\n"
    ));
    let worst = locked
        .iter()
        .zip(&merged)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    eprintln!("locked vs hand-merged: shoulder angles differ by {worst:e} rad over 2 s");
    // The two composites differ by round-off (summation order): measured 2.2e-15 rad.
    assert!(worst < 1e-12, "{worst:e}");
}

/// A mimic joint follows its rule as a constraint (`elbow = −0.5 shoulder + 0.2`), and the
/// one-degree-of-freedom motion conserves the energy written independently from the recorded
/// joint coordinates (absolute angles α1 = θ1, α2 = θ1 + θ2, α̇2 = (1 + k) θ̇1), with a bounded
/// O(h²) error.
#[test]
fn mimic_joint_follows_its_rule_and_keeps_the_energy() {
    let (k, b, m, l, a, i) = (-0.5, 0.2, 1.0, 1.0, 0.5, 0.08343333333333333);
    let reduced_energy = |t1: f64, w1: f64| {
        let (a1, a2) = (t1, (1.0 + k) * t1 + b);
        let (w2, dir) = ((1.0 + k) * w1, |x: f64| {
            Vector3::new(-x.cos(), 0.0, x.sin())
        });
        let v1 = dir(a1) * (a * w1);
        let v2 = dir(a1) * (l * w1) + dir(a2) * (a * w2);
        let z1 = -a * a1.cos();
        let z2 = -l * a1.cos() - a * a2.cos();
        0.5 * m * (v1.norm_squared() + v2.norm_squared())
            + 0.5 * i * (w1 * w1 + w2 * w2)
            + m * G * (z1 + z2)
    };
    let mut drifts = Vec::new();
    for dt in [1e-3f64, 5e-4] {
        let text = format!(
            "[sim]\ndt = {dt}\n[[model]]\nurdf = \"../tests/data/mechanism/mimic_pendulum.urdf\"\n\
             bodies = \"articulated\"\nbase = \"fixed\"\njoints = {{ shoulder = 1.5 }}\n\
             joint_velocities = {{ shoulder = 1.0 }}\n"
        );
        let mut sim = Sim::new(&scene(&text));
        let (j0, m0) = sim.report();
        let e0 = energy(&m0[0]);
        assert!((reduced_energy(j0[0].position, j0[0].velocity) - e0).abs() < 1e-12);
        let (mut rule, mut agree, mut drift): (f64, f64, f64) = (0.0, 0.0, 0.0);
        let every = (0.01 / dt).round() as u64;
        for _ in 0..1000 {
            sim.advance(every);
            let (j, mm) = sim.report();
            rule = rule.max((j[1].position - (k * j[0].position + b)).abs());
            let e = energy(&mm[0]);
            agree = agree.max((reduced_energy(j[0].position, j[0].velocity) - e).abs());
            drift = drift.max((e - e0).abs() / e0.abs());
            // The follower's rate follows too.
            assert!((j[1].velocity - k * j[0].velocity).abs() < 1e-9);
        }
        eprintln!(
            "mimic dt {dt}: rule residual {rule:e} rad, energy formulas agree to {agree:e} J, \
             energy error {drift:e}"
        );
        // The rule holds to the Newton tolerance (1e-12 rad): measured 7.8e-16. The reported
        // energy is the reduced system's to the tolerances (measured 5.2e-12 J).
        assert!(rule < 1e-12, "{rule:e}");
        assert!(agree < 1e-10, "{agree:e}");
        drifts.push(drift);
    }
    // Bounded and O(h²): measured 1.62e-5 and 4.05e-6 relative over 10 s (ratio 4.0).
    let ratio = drifts[0] / drifts[1];
    assert!(
        drifts[0] < 1e-4 && (3.6..4.4).contains(&ratio),
        "{drifts:?}"
    );
}

/// A compound joint (the satellite's shoulder: yaw then pitch through one point, a massless
/// link between) records both angles, and the massless link and the upper arm sit where
/// forward kinematics puts them from those angles.
#[test]
fn compound_joint_records_both_angles_and_places_the_massless_link() {
    use nalgebra::{Isometry3, Translation3, UnitQuaternion};
    let text = "[sim]\ndt = 1e-3\ngravity = [0.0, 0.0, 0.0]\n[[model]]\nurdf = \"satellite_arm.urdf\"\n\
                bodies = \"articulated\"\nangvel = [0.0, 0.0, 0.02]\n\
                joints = { shoulder_pitch = 0.3, elbow = -0.8 }\n\
                joint_velocities = { shoulder_yaw = 0.5, shoulder_pitch = -0.4, elbow = 1.0, wrist = 2.0 }\n";
    let mut sim = Sim::new(&scene(text));
    let names: Vec<&str> = sim
        .world
        .layout
        .joints
        .iter()
        .map(|j| j.name.as_str())
        .collect();
    assert_eq!(names, ["shoulder_yaw", "shoulder_pitch", "elbow", "wrist"]);
    let frame = |sim: &Sim, link: &str| {
        sim.world
            .layout
            .frames
            .iter()
            .position(|f| f.link == link)
            .unwrap()
    };
    let (bus, shoulder, upper) = (
        frame(&sim, "bus"),
        frame(&sim, "shoulder_link"),
        frame(&sim, "upper_arm"),
    );
    let (mut worst, mut dl): (f64, f64) = (0.0, 0.0);
    let l0 = sim.report().1[0].angular_momentum;
    let mut yaw_moved: f64 = 0.0;
    for _ in 0..500 {
        sim.advance(10);
        let g = sim.gravity;
        let frame_data =
            sim.frames
                .frame(&sim.bodies, &Loads::uniform_gravity(g), sim.step, sim.dt);
        let poses = frame_data.world_from_link.to_vec();
        let (yaw, pitch) = (frame_data.joints[0].position, frame_data.joints[1].position);
        let l = frame_data.mechanisms[0].angular_momentum;
        yaw_moved = yaw_moved.max(yaw.abs());
        let at_shoulder = poses[bus]
            * Isometry3::from_parts(Translation3::new(0.6, 0.0, 0.0), UnitQuaternion::identity());
        let expect_link = at_shoulder * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw);
        let expect_upper = expect_link * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), pitch);
        for (got, want) in [(poses[shoulder], expect_link), (poses[upper], expect_upper)] {
            worst = worst.max((got.translation.vector - want.translation.vector).amax());
            worst = worst.max(got.rotation.angle_to(&want.rotation));
        }
        dl = dl.max((l - l0).amax());
    }
    eprintln!("compound: poses agree to {worst:e}, ΔL {dl:e}, yaw reached {yaw_moved}");
    // The joint holds to the tolerance (gaps 1e-12 · L, L = 1 m): measured 1.3e-15 (m, rad).
    assert!(worst < 1e-11, "{worst:e}");
    // Momentum exact to round-off: measured 2.8e-14 kg m²/s.
    assert!(dl < 1e-12, "{dl:e}");
    assert!(yaw_moved > 1.0, "the shoulder turned: {yaw_moved}");
}

/// Reported joint rates come from the projected momenta: they match the central difference
/// of the recorded positions to O(h²) (the carried momenta alone are O(h) off).
#[test]
fn reported_joint_rates_match_the_positions() {
    let mut worst = Vec::new();
    for dt in [1e-3f64, 5e-4] {
        let text = format!(
            "[sim]\ndt = {dt}\n[[model]]\nurdf = \"double_pendulum.urdf\"\n\
             bodies = \"articulated\"\nbase = \"fixed\"\njoints = {{ shoulder = 2.0, elbow = 0.5 }}\n"
        );
        let mut sim = Sim::new(&scene(&text));
        let mut history = Vec::new();
        for _ in 0..(3.0 / dt) as u64 {
            sim.advance(1);
            history.push(sim.report().0);
        }
        let mut w: f64 = 0.0;
        for k in 1..history.len() - 1 {
            for j in 0..2 {
                let fd = (history[k + 1][j].position - history[k - 1][j].position) / (2.0 * dt);
                w = w.max((fd - history[k][j].velocity).abs());
            }
        }
        worst.push(w);
    }
    eprintln!("rates vs central differences: {worst:?} rad/s at dt = 1, 0.5 ms");
    // O(h²) (rates up to 25 rad/s): measured 1.55e-3 and 3.9e-4 rad/s (ratio 4.0).
    let ratio = worst[0] / worst[1];
    assert!(worst[0] < 5e-3 && (3.6..4.4).contains(&ratio), "{worst:?}");
}
