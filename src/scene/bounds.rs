//! Values the integrator and the recordings cannot handle, refused before the run (exit 2)
//! with the file, the model and the key (docs/limits.md, "Bounds on initial values").
//!
//! - **Frame times.** Recording timestamps are whole nanoseconds ([`crate::simulation::time_ns`]):
//!   recorded frames `sim.dt × sim.log_every` apart must be at least 1 ns apart, and so must
//!   the last step (recorded too) be from the frame before it ([`check_frame_times`], with
//!   the scene's other values); the run must end within `i64::MAX` ns, 292 years
//!   ([`check_end_time`], after the budget's estimate, which refuses runs of too many steps
//!   first). Before, `dt = 1e-12` with `log_every = 1` failed in the Rerun
//!   writer with "frame time 0 ns is not after 0 ns", naming neither the key nor the file.
//! - **Reach.** No body may start where, or so fast that, it would be more than
//!   [`MAX_REACH_M`] from the origin by the end of the run at its initial speed:
//!   `|c0| + |v0| · duration ≤ 1e15 m`. Beyond 2^53 · 0.125 m ≈ 1.1e15 m an `f64` position is
//!   coarser than 0.125 m, coarser than the parts of any robot, so the recorded link frames
//!   would be noise; far beyond, the state overflows to infinity (`linvel = 1e308` stopped the
//!   run with a NaN state, `linvel = -1e300` recorded an infinite energy).
//! - **Energy.** Every body's kinetic energy `½ m |v|² + ½ ωᵀ J ω`, times twice
//!   `sim.divergence_energy_ratio` (the divergence guard's threshold,
//!   [`crate::sim::guard`]), must be a finite `f64`, and so must the sum over all bodies (the
//!   run's energy report): a spin of 1e300 rad/s, from `angvel` or a joint velocity, would
//!   make it infinite, and the guard could not tell growth from it.
//!
//! These bound only initial values; what the motion does later is the divergence guard's.

use super::{ModelEntry, Scene};
use crate::budget::readable;
use crate::world::World;
use anyhow::bail;

/// Farthest from the origin a body may get at its initial speed over the run, m: where
/// consecutive `f64` values are 0.125 m apart (2^50 ≈ 1.13e15 m), rounded down.
pub const MAX_REACH_M: f64 = 1e15;

/// One nanosecond, the resolution of recording timestamps, s.
const NS: f64 = 1e-9;

/// The frame-spacing rules of the module documentation, for the `[sim]` of `file` (the
/// run-length rule is [`check_end_time`]).
pub fn check_frame_times(
    file: &str,
    dt: f64,
    duration: f64,
    log_every: u64,
    steps: u64,
) -> anyhow::Result<()> {
    // As `crate::simulation::time_ns` computes it.
    let dt_ns = dt * 1e9;
    let spacing_ns = log_every as f64 * dt_ns;
    if spacing_ns < 1.0 {
        // The smallest log_every that spaces frames 1 ns apart.
        let mut need = (1.0 / dt_ns).ceil().max(1.0);
        while need * dt_ns < 1.0 {
            need += 1.0;
        }
        bail!(
            "{file}: sim.dt = {} s with sim.log_every = {log_every} records a frame every {} s, \
             but recorded frames must be at least 1 ns apart (recording timestamps are whole \
             nanoseconds): raise sim.log_every to at least {} or sim.dt to at least {} s",
            readable(dt),
            readable(log_every as f64 * dt),
            crate::budget::human_number(need),
            readable(NS / log_every as f64)
        );
    }
    let last_gap = steps % log_every.max(1);
    if last_gap != 0 && (last_gap as f64) * dt_ns < 1.0 {
        bail!(
            "{file}: sim.duration = {} s is {steps} steps of sim.dt = {} s: the last step is \
             recorded too, {last_gap} step(s) ({} s) after the frame before it, but recorded \
             frames must be at least 1 ns apart (recording timestamps are whole nanoseconds): \
             make sim.duration a multiple of sim.dt x sim.log_every ({} s)",
            readable(duration),
            readable(dt),
            readable(last_gap as f64 * dt),
            readable(log_every as f64 * dt)
        );
    }
    Ok(())
}

/// The run-length rule of the module documentation: the last step's timestamp within
/// `i64::MAX` ns. Checked by `simulate` after the budget (`crate::budget::Estimate::check`),
/// which refuses runs of too many steps first, with its estimates.
pub fn check_end_time(file: &str, dt: f64, duration: f64, steps: u64) -> anyhow::Result<()> {
    let end_ns = if steps == 0 {
        0.0
    } else {
        steps as f64 * dt * 1e9
    };
    // NaN fails too.
    if !matches!(
        end_ns.partial_cmp(&(i64::MAX as f64)),
        Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
    ) {
        bail!(
            "{file}: sim.duration = {} s ({steps} steps of sim.dt = {} s): recording timestamps \
             are whole nanoseconds in a signed 64-bit number, which ends at 9.2e18 ns (292 years)",
            readable(duration),
            readable(dt)
        );
    }
    Ok(())
}

/// `|v|` without overflow or underflow in the squares (`[1e300, 0, 0]` is 1e300 long, not
/// infinitely).
fn length(v: &nalgebra::Vector3<f64>) -> f64 {
    if v.iter().any(|x| x.is_nan()) {
        return f64::NAN;
    }
    let largest = v.amax();
    if largest == 0.0 || !largest.is_finite() {
        return largest;
    }
    largest * (v / largest).norm()
}

/// Kinetic energy of a body at the start: `½ m |v|² + ½ Σ J_k ω_k²` (ω in its principal
/// frame), J.
pub fn kinetic_energy(body: &crate::sim::BodyInit) -> f64 {
    let w = body.world_from_body.rotation.inverse() * body.angvel_world;
    0.5 * body.mass * body.linvel_world.norm_squared()
        + 0.5 * body.principal_moments.component_mul(&w).dot(&w)
}

/// `[x, y, z]` with [`readable`] numbers.
fn vector_text(v: &[f64; 3]) -> String {
    format!(
        "[{}, {}, {}]",
        readable(v[0]),
        readable(v[1]),
        readable(v[2])
    )
}

/// What in `entry` sets its bodies' initial positions and velocities, for messages:
/// `position`, `linvel`, `angvel` (given or drawn, when not zero) and the non-zero
/// `joint_velocities`, largest first.
fn sources(entry: &ModelEntry, position: bool) -> String {
    let mut keys = Vec::new();
    let given = |v: &[f64; 3], drawn: bool| drawn || v.iter().any(|x| *x != 0.0);
    if position && given(&entry.position, entry.draws.position.is_some()) {
        keys.push(format!("position = {}", vector_text(&entry.position)));
    }
    if given(&entry.linvel, entry.draws.linvel.is_some()) {
        keys.push(format!("linvel = {}", vector_text(&entry.linvel)));
    }
    if given(&entry.angvel, entry.draws.angvel.is_some()) {
        keys.push(format!("angvel = {}", vector_text(&entry.angvel)));
    }
    let mut rates: Vec<(&String, f64)> = entry
        .joint_velocities
        .iter()
        .filter(|(_, v)| **v != 0.0)
        .map(|(k, v)| (k, *v))
        .collect();
    rates.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
    keys.extend(
        rates
            .iter()
            .map(|(k, v)| format!("joint_velocities.{k} = {}", readable(*v))),
    );
    if keys.is_empty() {
        // Nothing given: the values come from the model itself (e.g. a drawn placement).
        return "the model's placement".into();
    }
    keys.join(", ")
}

/// The reach and energy rules of the module documentation for the bodies `bodies` of `world`,
/// which model table `index` (`entry`) of `scene` added.
pub fn check_initial_states(
    scene: &Scene,
    world: &World,
    index: usize,
    entry: &ModelEntry,
    bodies: std::ops::Range<usize>,
) -> anyhow::Result<()> {
    let file = scene.source.display();
    let duration = scene.steps() as f64 * scene.sim.dt;
    let guard_factor = 2.0 * scene.sim.divergence_energy_ratio;
    let name = |b: usize| {
        world
            .layout
            .bodies
            .get(b)
            .map_or_else(|| format!("#{b}"), |l| l.name.clone())
    };
    for b in bodies {
        let body = &world.bodies[b];
        let c0 = length(&body.world_from_body.translation.vector);
        let v0 = length(&body.linvel_world);
        let reach = c0 + v0 * duration;
        // NaN (a NaN component) fails too.
        if !matches!(
            reach.partial_cmp(&MAX_REACH_M),
            Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
        ) {
            bail!(
                "{file}: model[{index}]: body `{}` starts {} m from the origin at {} m/s: in \
                 the run's {} s it would get {} m away, beyond the {} m within which f64 \
                 positions resolve 0.125 m (docs/limits.md, \"Bounds on initial values\"); set \
                 by {}",
                name(b),
                readable(c0),
                readable(v0),
                readable(duration),
                readable(reach),
                readable(MAX_REACH_M),
                sources(entry, c0 > MAX_REACH_M)
            );
        }
        let energy = kinetic_energy(body);
        if !(energy * guard_factor).is_finite() {
            bail!(
                "{file}: model[{index}]: body `{}` starts with a kinetic energy of {} J ({} kg \
                 at {} m/s, turning at {} rad/s): that times twice \
                 sim.divergence_energy_ratio ({}) is beyond the largest f64 (1.8e308), so the \
                 divergence guard could not watch it (docs/limits.md, \"Bounds on initial \
                 values\"); set by {}",
                name(b),
                readable(energy),
                readable(body.mass),
                readable(v0),
                readable(length(&body.angvel_world)),
                readable(scene.sim.divergence_energy_ratio),
                sources(entry, false)
            );
        }
    }
    Ok(())
}

/// The energy rule for the sum over all bodies of `world` (each checked already).
pub fn check_total_energy(scene: &Scene, world: &World) -> anyhow::Result<()> {
    let total: f64 = world.bodies.iter().map(kinetic_energy).sum();
    if !(total * 2.0 * scene.sim.divergence_energy_ratio).is_finite() {
        bail!(
            "{}: the bodies' kinetic energies add up to {} J, which times twice \
             sim.divergence_energy_ratio ({}) is beyond the largest f64 (1.8e308): the run's \
             energy report could not be computed (docs/limits.md, \"Bounds on initial values\")",
            scene.source.display(),
            readable(total),
            readable(scene.sim.divergence_energy_ratio)
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `dt = 1e-12` with `log_every = 1` (the case) is refused naming both keys and
    /// the smallest `log_every` that works; 1 ns apart exactly passes.
    #[test]
    fn frames_must_be_a_nanosecond_apart() {
        let e = check_frame_times("s.toml", 1e-12, 1e-10, 1, 100)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "s.toml: sim.dt = 1e-12 s with sim.log_every = 1 records a frame every 1e-12 s, \
             but recorded frames must be at least 1 ns apart (recording timestamps are whole \
             nanoseconds): raise sim.log_every to at least 1000 or sim.dt to at least 1e-9 s"
        );
        assert!(check_frame_times("s.toml", 1e-12, 1e-9, 1000, 1000).is_ok());
        assert!(check_frame_times("s.toml", 1e-9, 1.0, 1, 1_000_000_000).is_ok());
        assert!(check_frame_times("s.toml", 0.5e-9, 1e-9, 2, 2).is_ok());
        assert!(check_frame_times("s.toml", 0.5e-9, 1e-9, 1, 2).is_err());
    }

    /// The last step is recorded too: 1 001 steps of 1e-12 s with log_every = 1000 put it
    /// 1e-12 s after the frame of step 1000.
    #[test]
    fn the_last_frame_must_be_a_nanosecond_after_the_one_before() {
        let e = check_frame_times("s.toml", 1e-12, 1.001e-9, 1000, 1001)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("the last step is recorded too, 1 step(s) (1e-12 s) after"),
            "{e}"
        );
        assert!(
            e.contains("a multiple of sim.dt x sim.log_every (1e-9 s)"),
            "{e}"
        );
        // A whole number of frames: fine. With dt >= 1 ns any last gap is fine.
        assert!(check_frame_times("s.toml", 1e-12, 2e-9, 1000, 2000).is_ok());
        assert!(check_frame_times("s.toml", 1e-3, 1.0005, 10, 1001).is_ok());
    }

    /// Timestamps end at i64::MAX ns: a run of 292 years passes, 300 do not; 0 steps of any
    /// length have no timestamp past 0.
    #[test]
    fn runs_end_within_the_timestamps() {
        let year = 365.25 * 86_400.0;
        let steps = |t: f64| (t / 1e3).round() as u64;
        assert!(check_end_time("s.toml", 1e3, 292.0 * year, steps(292.0 * year)).is_ok());
        let e = check_end_time("s.toml", 1e3, 300.0 * year, steps(300.0 * year))
            .unwrap_err()
            .to_string();
        assert!(e.contains("292 years"), "{e}");
        assert!(check_end_time("s.toml", 1e300, 0.1, 0).is_ok());
        assert!(check_end_time("s.toml", 1e300, 1e300, 1).is_err());
    }

    /// A step of 1e300 s in a run of 0.1 s is 0 steps: no timestamp past the first.
    #[test]
    fn no_steps_no_timestamps() {
        assert!(check_frame_times("s.toml", 1e300, 0.1, 1, 0).is_ok());
    }

    #[test]
    fn lengths_neither_overflow_nor_underflow() {
        use nalgebra::Vector3;
        assert_eq!(length(&Vector3::new(1e300, 0.0, 0.0)), 1e300);
        assert_eq!(length(&Vector3::new(0.0, -3e-320, 0.0)), 3e-320);
        assert_eq!(length(&Vector3::new(3.0, 0.0, 4.0)), 5.0);
        assert_eq!(length(&Vector3::zeros()), 0.0);
        assert!(length(&Vector3::new(1.0, f64::NAN, 0.0)).is_nan());
        assert_eq!(
            length(&Vector3::new(f64::INFINITY, 0.0, 0.0)),
            f64::INFINITY
        );
    }

    #[test]
    fn kinetic_energy_of_a_body() {
        use nalgebra::{Isometry3, UnitQuaternion, Vector3};
        // 2 kg at 3 m/s: 9 J; J = (1, 2, 4) turning at 1 rad/s about its body y axis: 1 J,
        // given in the world as the body turned 90° about z (body y = world -x).
        let body = crate::sim::BodyInit {
            mass: 2.0,
            principal_moments: Vector3::new(1.0, 2.0, 4.0),
            world_from_body: Isometry3::from_parts(
                Vector3::new(5.0, 0.0, 0.0).into(),
                UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2),
            ),
            linvel_world: Vector3::new(0.0, 3.0, 0.0),
            angvel_world: Vector3::new(-1.0, 0.0, 0.0),
        };
        // Rotation round-off: measured 0, bound 1e-15 J.
        assert!((kinetic_energy(&body) - 10.0).abs() < 1e-15);
    }
}
