//! A reproducible free-body workload for benchmarks: `n` differently initialised asymmetric
//! bodies (used by `tumble bench` and the criterion benches, so both measure the same thing).

use super::BodyInit;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

/// `n` asymmetric bodies with masses in 0.5..1.5 kg, principal moments within ±0.1 of
/// (1, 1.5, 2) kg m² (always distinct and physical: J1 + J2 >= 2.3 > 2.1 >= J3),
/// orientations, positions and velocities spread by a golden-ratio sequence (deterministic, no
/// random generator), angular speeds up to about 6 rad/s.
pub fn free_body_batch(n: usize) -> Vec<BodyInit> {
    (0..n)
        .map(|i| {
            let s = i as f64;
            // Fractional part of s φ + k, mapped to -1..1: well spread for every n.
            let f = |k: f64| ((s * 0.618_033_988_7 + k) % 1.0) * 2.0 - 1.0;
            BodyInit {
                mass: 1.0 + 0.5 * f(0.1),
                principal_moments: Vector3::new(
                    1.0 + 0.1 * f(0.2),
                    1.5 + 0.1 * f(0.3),
                    2.0 + 0.1 * f(0.35),
                ),
                world_from_body: Isometry3::from_parts(
                    Translation3::new(f(0.4), f(0.5), 1.0 + f(0.6)),
                    UnitQuaternion::from_euler_angles(3.0 * f(0.7), 1.5 * f(0.8), 3.0 * f(0.9)),
                ),
                linvel_world: Vector3::new(f(0.11), f(0.12), f(0.13)),
                angvel_world: Vector3::new(2.0 * f(0.14), 5.0 * f(0.15), 2.0 * f(0.16)),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bodies_differ_and_are_valid() {
        let batch = free_body_batch(1000);
        assert_eq!(batch.len(), 1000);
        for b in &batch {
            let j = b.principal_moments;
            assert!(b.mass > 0.0 && j.min() > 0.0);
            // Triangle inequality of physical inertia (every pair sums above the third).
            assert!(j.x + j.y > j.z && j.x + j.z > j.y && j.y + j.z > j.x);
        }
        // No two bodies start with the same angular velocity.
        let mut w: Vec<_> = batch.iter().map(|b| b.angvel_world.x.to_bits()).collect();
        w.sort_unstable();
        w.dedup();
        assert!(w.len() > 990, "{} distinct", w.len());
    }
}
