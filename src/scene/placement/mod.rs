//! Where each copy of a `[[model]]` starts: `copies = N`, `seed = S`, and the keys `position`,
//! `rpy` / `orientation`, `linvel`, `angvel` given as a value or as a distribution.
//!
//! ```toml
//! [[model]]
//! urdf = "box.urdf"
//! name = "box"                  # copies are named box_0000 ... box_9999 (frame ids box_0042/<link>)
//! copies = 10000                # (default 1: one model, named `name`)
//! seed = 7                      # copy i draws from streams seeded by (seed, i) alone (default 0)
//! position = { uniform = [[-10, -10, 0], [10, 10, 5]] }
//! orientation = "uniform"       # or rpy = { ... }, rpy = [r, p, y], orientation = [x, y, z, w]
//! linvel = [0.0, 0.0, 0.0]      # a value: the same for every copy
//! angvel = { normal = { mean = [0, 0, 0], std = [3, 3, 3] } }
//! ```
//!
//! Copy `i` draws exactly what run `i` of a dataset with master seed `S` and the same `[vary]`
//! distributions draws ([`crate::dataset::sample::draw`]): the same generators and key streams
//! (`position`, `orientation` or `rpy`, `linvel`, `angvel`), so a copy's values depend on
//! `(seed, i)` alone: not on the copy count, the thread count or the other tables. Two tables
//! with the same seed and the same distribution draw the same values (give them different seeds).
//!
//! Names: with `copies` present, copy `i` of a table named `n` (default: the URDF's robot name)
//! is `n_<i>`, `i` zero-padded to the width of `copies - 1` (`box_0000` .. `box_9999`), so its
//! frame ids are `n_<i>/<link>`. Without `copies` the table is one model named as before.

pub mod distribution;
pub mod orientation;
pub mod rng;

pub use distribution::Dist;
pub use orientation::Orientation;
pub use rng::{Rng, run_seed};

use nalgebra::{Isometry3, Translation3, Vector3};

/// Most copies one `[[model]]` may ask for.
pub const MAX_COPIES: u64 = 10_000_000;

/// The keys of a `[[model]]` table that may hold a distribution (the rest of the table is read
/// by serde into [`crate::scene::ModelEntry`]).
pub const DRAWN_KEYS: [&str; 4] = ["position", "rpy", "linvel", "angvel"];

/// The distributions of one `[[model]]` (what is not drawn is the entry's value).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Draws {
    pub position: Option<Dist>,
    pub orientation: Orientation,
    pub linvel: Option<Dist>,
    pub angvel: Option<Dist>,
    /// The drawn keys as the scene wrote them (for the recordings' settings).
    pub written: toml::Table,
}

impl Draws {
    /// Whether anything is drawn.
    pub fn is_empty(&self) -> bool {
        self.written.is_empty()
    }

    /// Takes the distribution-valued keys (and `orientation`) out of `table`, the `[[model]]`
    /// table number `index` of `file`, leaving plain values for serde. Errors name the file,
    /// the model and the key.
    pub fn take(file: &str, index: usize, table: &mut toml::Table) -> anyhow::Result<Self> {
        let prefix = format!("{file}: model[{index}]");
        let mut draws = Draws::default();
        let mut rpy_dist = None;
        for name in DRAWN_KEYS {
            let Some(value) = table.get(name).filter(|v| v.is_table()).cloned() else {
                continue;
            };
            table.remove(name);
            draws.written.insert(name.into(), value.clone());
            if name == "rpy" {
                rpy_dist = Some(value);
                continue;
            }
            let dist = Dist::parse(&format!("{prefix}.{name}"), &value, 3)?;
            match name {
                "position" => draws.position = Some(dist),
                "linvel" => draws.linvel = Some(dist),
                _ => draws.angvel = Some(dist),
            }
        }
        let orientation = table.remove("orientation");
        draws.orientation = Orientation::parse(
            &prefix,
            orientation.as_ref(),
            rpy_dist.as_ref(),
            table.contains_key("rpy"),
        )?;
        if let Some(value) = orientation {
            draws.written.insert("orientation".into(), value);
        }
        Ok(draws)
    }
}

/// Where one copy starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Pose of the root link frame in the world.
    pub world_from_model: Isometry3<f64>,
    /// Initial velocity of every body's centre of mass, world, m/s.
    pub linvel_world: Vector3<f64>,
    /// Initial angular velocity of every body, world, rad/s.
    pub angvel_world: Vector3<f64>,
}

/// The fixed values of a `[[model]]` (those [`Draws`] does not replace).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fixed {
    pub position: [f64; 3],
    pub rpy: [f64; 3],
    pub linvel: [f64; 3],
    pub angvel: [f64; 3],
}

/// Copy `copy` of a table with `seed`, its fixed values and its draws: each drawn key from its
/// own stream `Rng::for_key(run_seed(seed, copy), key)`, as a dataset's run draws
/// (`crate::dataset::sample::draw`).
pub fn place(fixed: &Fixed, draws: &Draws, seed: u64, copy: u64) -> Placement {
    let stream_seed = run_seed(seed, copy);
    let vec3 = |key: &str, d: &Option<Dist>, value: [f64; 3]| -> Vector3<f64> {
        Vector3::from(draw_vec3(stream_seed, key, d, value))
    };
    Placement {
        world_from_model: Isometry3::from_parts(
            Translation3::from(vec3("position", &draws.position, fixed.position)),
            draws.orientation.rotation(stream_seed, fixed.rpy),
        ),
        linvel_world: vec3("linvel", &draws.linvel, fixed.linvel),
        angvel_world: vec3("angvel", &draws.angvel, fixed.angvel),
    }
}

/// A 3-vector key: drawn from `dist` with the key's stream of `seed` (a run's or a copy's
/// [`run_seed`]), else `value`.
pub fn draw_vec3(seed: u64, key: &str, dist: &Option<Dist>, value: [f64; 3]) -> [f64; 3] {
    match dist {
        Some(d) => {
            let v = d.sample(&mut Rng::for_key(seed, key));
            [v[0], v[1], v[2]]
        }
        None => value,
    }
}

/// The name of copy `copy` of `copies` copies of `base`: `base_<copy>`, zero-padded to the
/// width of `copies - 1`.
pub fn copy_name(base: &str, copy: u64, copies: u64) -> String {
    let width = copies.saturating_sub(1).max(1).ilog10() as usize + 1;
    format!("{base}_{copy:0width$}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn copy_names_are_zero_padded_to_the_last_index() {
        assert_eq!(copy_name("box", 0, 1), "box_0");
        assert_eq!(copy_name("box", 7, 10), "box_7");
        assert_eq!(copy_name("box", 7, 11), "box_07");
        assert_eq!(copy_name("box", 42, 10_000), "box_0042");
        assert_eq!(copy_name("box", 9_999, 10_000), "box_9999");
        assert_eq!(copy_name("b", 3, 100_001), "b_000003");
    }

    fn table(text: &str) -> toml::Table {
        toml::from_str(text).unwrap()
    }

    #[test]
    fn drawn_keys_leave_the_table_and_plain_values_stay() {
        let mut t = table(
            "urdf = \"a.urdf\"\nposition = { uniform = [[0, 0, 0], [1, 1, 1]] }\nlinvel = [1, 2, 3]\norientation = \"uniform\"",
        );
        let d = Draws::take("s.toml", 0, &mut t).unwrap();
        assert!(d.position.is_some() && d.linvel.is_none());
        assert_eq!(d.orientation, Orientation::Uniform);
        assert!(!t.contains_key("position") && !t.contains_key("orientation"));
        assert!(t.contains_key("linvel"));
        assert_eq!(d.written.len(), 2);
    }

    #[test]
    fn bad_draws_name_file_model_and_key() {
        for (text, needle) in [
            (
                "position = { uniform = [[1, 0, 0], [0, 1, 1]] }",
                "s.toml: model[3].position.uniform: lower bound 1",
            ),
            (
                "orientation = \"random\"",
                "s.toml: model[3].orientation: expected \"uniform\"",
            ),
            (
                "orientation = [0, 0, 0, 2]",
                "s.toml: model[3].orientation: the quaternion [x, y, z, w] must have norm 1",
            ),
            (
                "orientation = \"uniform\"\nrpy = [0, 0, 1]",
                "s.toml: model[3].orientation: give orientation or rpy, not both",
            ),
            (
                "angvel = { gauss = [0, 1] }",
                "s.toml: model[3].angvel.gauss: unknown distribution",
            ),
        ] {
            let err = format!(
                "{:#}",
                Draws::take("s.toml", 3, &mut table(text)).unwrap_err()
            );
            assert!(err.contains(needle), "{text}: {err}");
        }
    }
}
