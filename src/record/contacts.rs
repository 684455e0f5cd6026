//! What the formats share of the contacts (issue 31): how the ground is drawn, how long a force
//! arrow is, and the names a contact's bodies are recorded under.
//!
//! The ground ([`super::GroundLayout`]) is drawn as a thin square slab, [`GROUND_SIZE_M`] on a
//! side and [`GROUND_THICKNESS_M`] thick, centred below [`super::GroundLayout::point`], its top
//! face the ground's surface ([`ground_pose`]). A contact force is drawn as an arrow from the
//! contact point along the force on body `a` ([`super::ContactState::force_world`]), of length
//! `|F| · scale` with the scale of [`force_scale`]: [`REFERENCE_ARROW_M`] for the weight of the
//! recording's typical model (the median over models of a model's total mass, at standard
//! gravity), so a model resting on its contacts shows arrows adding up to about 0.2 m. An arrow
//! is at most [`ARROW_MAX_M`] long ([`arrow_vector`]): an impact's impulse over one step is a
//! force of thousands of newtons (a 8 kg cube landing at 3 m/s: 25 kN at dt = 1 ms), which the
//! scale would draw tens of metres long; the recorded force keeps its value.

use super::{ContactState, GroundLayout, RecordingLayout};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

/// Side of the square the ground is drawn as, m.
pub const GROUND_SIZE_M: f64 = 20.0;
/// Thickness of the slab the ground is drawn as, m (below the surface).
pub const GROUND_THICKNESS_M: f64 = 0.01;
/// Colour of the ground (linear RGBA).
pub const GROUND_COLOR: [f64; 4] = [0.5, 0.5, 0.5, 1.0];
/// Colour of the contact points and of the force arrows (linear RGBA).
pub const POINT_COLOR: [f64; 4] = [0.9, 0.1, 0.1, 1.0];
pub const FORCE_COLOR: [f64; 4] = [1.0, 0.8, 0.0, 1.0];
/// Length of the arrow of the reference weight ([`force_scale`]), m.
pub const REFERENCE_ARROW_M: f64 = 0.2;
/// Longest force arrow drawn, m (five reference weights).
pub const ARROW_MAX_M: f64 = 1.0;
/// The gravity the reference weight is taken at, m/s² (standard gravity).
pub const STANDARD_GRAVITY: f64 = 9.80665;
/// Radius of a drawn contact point, and of an arrow's shaft, m.
pub const POINT_RADIUS_M: f64 = 0.01;
pub const SHAFT_RADIUS_M: f64 = 0.005;
/// The name a contact's `body_b` is recorded under when it is the ground.
pub const GROUND_NAME: &str = "ground";

/// The pose of the ground's slab: its centre [`GROUND_THICKNESS_M`]` / 2` below `ground.point`
/// along the normal, its z axis along the normal (its x and y axes span the surface; for a
/// level ground, the world's).
pub fn ground_pose(ground: &GroundLayout) -> Isometry3<f64> {
    let n = ground.normal.normalize();
    let rotation = UnitQuaternion::rotation_between(&Vector3::z(), &n)
        // n = −z: half a turn about x.
        .unwrap_or_else(|| {
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
        });
    let centre = ground.point - n * (GROUND_THICKNESS_M / 2.0);
    Isometry3::from_parts(Translation3::from(centre), rotation)
}

/// The size of the ground's slab in its own frame ([`ground_pose`]), m.
pub fn ground_size() -> Vector3<f64> {
    Vector3::new(GROUND_SIZE_M, GROUND_SIZE_M, GROUND_THICKNESS_M)
}

/// Metres of arrow per newton of contact force: [`REFERENCE_ARROW_M`] for the weight, at
/// [`STANDARD_GRAVITY`], of the median model's mass (the models are the layout frames'
/// `model` labels, a model's mass the sum of its bodies'; the lower median of an even count).
/// 1 kg when the layout has no body with mass.
pub fn force_scale(layout: &RecordingLayout) -> f64 {
    let mut masses: std::collections::BTreeMap<&str, f64> = std::collections::BTreeMap::new();
    for body in &layout.bodies {
        let model = layout
            .frames
            .get(body.frame)
            .map_or(body.name.as_str(), |f| f.model.as_str());
        *masses.entry(model).or_default() += body.mass;
    }
    let mut masses: Vec<f64> = masses
        .into_values()
        .filter(|m| m.is_finite() && *m > 0.0)
        .collect();
    masses.sort_by(f64::total_cmp);
    let mass = masses
        .get(masses.len().saturating_sub(1) / 2)
        .copied()
        .unwrap_or(1.0);
    REFERENCE_ARROW_M / (mass * STANDARD_GRAVITY)
}

/// The arrow drawn for `force` (N) at `scale` m per N ([`force_scale`]): `force · scale`,
/// shortened to [`ARROW_MAX_M`] when longer (same direction).
pub fn arrow_vector(force: &Vector3<f64>, scale: f64) -> Vector3<f64> {
    let v = force * scale;
    let length = v.norm();
    if length > ARROW_MAX_M {
        v * (ARROW_MAX_M / length)
    } else {
        v
    }
}

/// The name of a contact's body `b`: the layout's body name, or [`GROUND_NAME`].
pub fn body_b_name<'a>(names: &'a [String], contact: &ContactState) -> &'a str {
    contact.body_b.map_or(GROUND_NAME, |b| names[b].as_str())
}

/// Fails when a contact names a body beyond the layout's `bodies` (a sink's check of a frame
/// it did not build).
pub fn check(contacts: &[ContactState], bodies: usize) -> anyhow::Result<()> {
    for c in contacts {
        let b = c.body_b.unwrap_or(0);
        if c.body_a >= bodies || b >= bodies {
            anyhow::bail!(
                "a contact between bodies {} and {:?}, the layout has {bodies}",
                c.body_a,
                c.body_b
            );
        }
    }
    Ok(())
}

/// The contacts of `contacts` whose body `a` is in `bodies` (a topic group's), in order.
pub fn in_group<'a>(
    contacts: &'a [ContactState],
    bodies: &'a std::ops::Range<usize>,
) -> impl Iterator<Item = &'a ContactState> + Clone + 'a {
    contacts.iter().filter(move |c| bodies.contains(&c.body_a))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::{BodyLayout, FrameLayout};

    /// The slab's top face is the ground's surface, for a level ground and a tilted one, and
    /// for the normal pointing down (the rotation's degenerate case).
    #[test]
    fn the_ground_slab_has_its_top_face_on_the_surface() {
        for normal in [
            Vector3::z(),
            Vector3::new(0.0, -0.5, 1.0).normalize(),
            -Vector3::z(),
        ] {
            let ground = GroundLayout {
                normal,
                point: Vector3::new(1.0, 2.0, -0.5),
            };
            let pose = ground_pose(&ground);
            // The centre of the top face, in the world: the ground's point.
            let top = pose * nalgebra::Point3::new(0.0, 0.0, GROUND_THICKNESS_M / 2.0);
            assert!((top.coords - ground.point).norm() < 1e-15, "{normal}");
            // The slab's z axis is the normal.
            assert!(
                (pose.rotation * Vector3::z() - normal).norm() < 1e-15,
                "{normal}"
            );
        }
    }

    fn body(name: &str, frame: usize, mass: f64) -> BodyLayout {
        BodyLayout {
            name: name.into(),
            frame,
            mass,
            link_from_principal: Isometry3::identity(),
            principal_moments: Vector3::repeat(1.0),
        }
    }

    fn frame(model: &str) -> FrameLayout {
        FrameLayout {
            frame_id: model.into(),
            model: model.into(),
            link: "l".into(),
            visuals: std::sync::Arc::from(Vec::new()),
        }
    }

    /// The scale puts the median model's weight at 0.2 m: models of 1 kg, 2 + 3 = 5 kg (two
    /// bodies of one model) and 10 kg give 5 kg; no body gives 1 kg.
    #[test]
    fn the_force_scale_draws_the_median_models_weight_at_the_reference_length() {
        let layout = RecordingLayout {
            frames: vec![frame("a"), frame("b"), frame("b"), frame("c")],
            bodies: vec![
                body("a", 0, 1.0),
                body("b1", 1, 2.0),
                body("b2", 2, 3.0),
                body("c", 3, 10.0),
            ],
            ..Default::default()
        };
        let scale = force_scale(&layout);
        assert!((scale * 5.0 * STANDARD_GRAVITY - REFERENCE_ARROW_M).abs() < 1e-15);
        let empty = force_scale(&RecordingLayout::default());
        assert!((empty * STANDARD_GRAVITY - REFERENCE_ARROW_M).abs() < 1e-15);
    }

    /// An arrow is the force times the scale up to 1 m, then 1 m along the force.
    #[test]
    fn arrows_are_capped_at_their_longest() {
        let f = Vector3::new(3.0, 0.0, 4.0);
        assert_eq!(arrow_vector(&f, 0.1), f * 0.1);
        let long = arrow_vector(&f, 1.0);
        assert!(
            (long - Vector3::new(0.6, 0.0, 0.8)).norm() < 1e-15,
            "{long}"
        );
        assert_eq!(arrow_vector(&Vector3::zeros(), 1.0), Vector3::zeros());
    }
}
