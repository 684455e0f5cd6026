//! The convex shapes colliders are made of, and their parry3d-f64 forms.

use nalgebra::{Point3, Vector3};
use parry3d_f64::shape::SharedShape;
use std::sync::Arc;

/// A convex shape in its own frame (URDF conventions: a box centred on its origin, a cylinder
/// and a capsule along their `z` axis).
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    Sphere {
        radius: f64,
    },
    Box {
        half_extents: Vector3<f64>,
    },
    Cylinder {
        radius: f64,
        half_length: f64,
    },
    Capsule {
        radius: f64,
        half_length: f64,
    },
    /// The convex hull of these points (a mesh's vertices, scaled).
    ConvexHull {
        points: Arc<[Point3<f64>]>,
    },
}

impl Shape {
    /// Radius of a sphere about the shape's origin that holds it, m.
    pub fn bounding_radius(&self) -> f64 {
        match self {
            Shape::Sphere { radius } => *radius,
            Shape::Box { half_extents } => half_extents.norm(),
            Shape::Cylinder {
                radius,
                half_length,
            } => radius.hypot(*half_length),
            Shape::Capsule {
                radius,
                half_length,
            } => radius + half_length,
            Shape::ConvexHull { points } => {
                points.iter().map(|p| p.coords.norm()).fold(0.0, f64::max)
            }
        }
    }

    /// The shape as parry3d-f64 builds it (a cylinder's and a capsule's axis turned from parry's
    /// `y` to URDF's `z` is the caller's [`Shape::parry_from_shape`]). `None` for a hull parry
    /// cannot build (fewer than four points not all in a plane).
    pub fn to_parry(&self) -> Option<SharedShape> {
        Some(match self {
            Shape::Sphere { radius } => SharedShape::ball(*radius),
            Shape::Box { half_extents } => {
                SharedShape::cuboid(half_extents.x, half_extents.y, half_extents.z)
            }
            Shape::Cylinder {
                radius,
                half_length,
            } => SharedShape::cylinder(*half_length, *radius),
            Shape::Capsule {
                radius,
                half_length,
            } => SharedShape::capsule_y(*half_length, *radius),
            Shape::ConvexHull { points } => {
                let pts: Vec<parry3d_f64::math::Vector> = points
                    .iter()
                    .map(|p| parry3d_f64::math::Vector::new(p.x, p.y, p.z))
                    .collect();
                SharedShape::convex_hull(&pts)?
            }
        })
    }

    /// The rotation from the parry shape's frame to this shape's frame: parry's cylinders and
    /// capsules lie along `y`, URDF's along `z` (a quarter turn about `x` takes `y` to `z`).
    pub fn shape_from_parry(&self) -> nalgebra::UnitQuaternion<f64> {
        match self {
            Shape::Cylinder { .. } | Shape::Capsule { .. } => {
                nalgebra::UnitQuaternion::from_axis_angle(
                    &Vector3::x_axis(),
                    std::f64::consts::FRAC_PI_2,
                )
            }
            _ => nalgebra::UnitQuaternion::identity(),
        }
    }
}
