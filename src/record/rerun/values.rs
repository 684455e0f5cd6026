//! Numbers as the recording stores them: f32 with a positive zero (bit-identical to what MCAP
//! replays), quaternions `[x, y, z, w]`, linear colours, the reference of a relative change.

use nalgebra::Isometry3;

/// `x` as f32 with a negative zero made positive. A zero's sign carries no meaning here, and
/// MCAP's protobuf drops it (proto3 omits a field equal to its default, and `-0.0 == 0.0`), so
/// without this a recording replayed from MCAP would differ in a bit.
pub fn f32c(x: f64) -> f32 {
    x as f32 + 0.0
}

/// `x` with a negative zero made positive (see [`f32c`]).
pub fn f64c(x: f64) -> f64 {
    x + 0.0
}

pub fn f32x3(v: &nalgebra::Vector3<f64>) -> [f32; 3] {
    [f32c(v.x), f32c(v.y), f32c(v.z)]
}

/// Quaternion as `[x, y, z, w]` in f32.
pub fn quat_xyzw(iso: &Isometry3<f64>) -> [f32; 4] {
    let q = iso.rotation.quaternion();
    [f32c(q.i), f32c(q.j), f32c(q.k), f32c(q.w)]
}

pub fn color(rgba: Option<[f32; 4]>) -> rerun::Rgba32 {
    match rgba {
        Some([r, g, b, a]) => rerun::Rgba32::from_linear_unmultiplied_rgba_f32(r, g, b, a),
        None => rerun::Rgba32::WHITE,
    }
}

/// `x`, or 1 when it is zero (the reference of a relative change that has none).
pub fn nonzero(x: f64) -> f64 {
    if x == 0.0 { 1.0 } else { x }
}
