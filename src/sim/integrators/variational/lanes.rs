//! The SIMD lane types of the variational step: [`Lanes`] (`N` bodies' values of one quantity),
//! [`V3`] (a 3-vector of lanes) and [`Quat`] (a quaternion of lanes), gathered from and
//! scattered to the batch's storage.
//!
//! The step's arithmetic is written once over `N` lanes (`N` bodies processed by the same
//! instructions; one body is `N = 1`), so every path rounds identically.

use crate::sim::so3::Real;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use std::ops::{Add, Div, Mul, Neg, Sub};

/// `N` bodies' values of one quantity. The lane loops become SSE2 packed instructions (`addpd`,
/// `mulpd`, `divpd`: two lanes per instruction); `N = 4` gives two independent dependency chains
/// per value, which measured faster than `N = 2` and `N = 8` (see `docs/variational_performance.md`).
#[derive(Debug, Clone, Copy)]
pub(super) struct Lanes<const N: usize>(pub(super) [f64; N]);

/// Bodies stepped together.
pub(super) const LANES: usize = 4;

macro_rules! lanes_binop {
    ($trait:ident, $method:ident, $op:tt) => {
        impl<const N: usize> $trait for Lanes<N> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, o: Self) -> Self {
                Lanes(std::array::from_fn(|i| self.0[i] $op o.0[i]))
            }
        }
    };
}
lanes_binop!(Add, add, +);
lanes_binop!(Sub, sub, -);
lanes_binop!(Mul, mul, *);
lanes_binop!(Div, div, /);

impl<const N: usize> Neg for Lanes<N> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Lanes(self.0.map(|x| -x))
    }
}

impl<const N: usize> Real for Lanes<N> {
    #[inline(always)]
    fn splat(v: f64) -> Self {
        Lanes([v; N])
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Lanes(self.0.map(f64::abs))
    }
}

impl<const N: usize> Lanes<N> {
    /// Whether `pred` holds in every lane (evaluated in all lanes, no early exit).
    #[inline(always)]
    pub(super) fn all(self, pred: impl Fn(f64) -> bool) -> bool {
        self.0.iter().fold(true, |acc, &x| acc & pred(x))
    }
    /// Lane-wise maximum (equal to `f64::max` for non-NaN lanes).
    #[inline(always)]
    pub(super) fn max(self, o: Self) -> Self {
        Lanes(std::array::from_fn(|i| {
            if self.0[i] > o.0[i] {
                self.0[i]
            } else {
                o.0[i]
            }
        }))
    }
}

/// A 3-vector of lanes.
#[derive(Debug, Clone, Copy)]
pub(super) struct V3<R> {
    pub(super) x: R,
    pub(super) y: R,
    pub(super) z: R,
}

impl<R: Real> V3<R> {
    #[inline(always)]
    pub(super) fn splat(v: R) -> Self {
        Self { x: v, y: v, z: v }
    }
    #[inline(always)]
    pub(super) fn add(self, o: Self) -> Self {
        Self {
            x: self.x + o.x,
            y: self.y + o.y,
            z: self.z + o.z,
        }
    }
    #[inline(always)]
    pub(super) fn sub(self, o: Self) -> Self {
        Self {
            x: self.x - o.x,
            y: self.y - o.y,
            z: self.z - o.z,
        }
    }
    /// Component-wise product.
    #[inline(always)]
    pub(super) fn mul(self, o: Self) -> Self {
        Self {
            x: self.x * o.x,
            y: self.y * o.y,
            z: self.z * o.z,
        }
    }
    #[inline(always)]
    pub(super) fn scale(self, s: R) -> Self {
        Self {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }
    #[inline(always)]
    pub(super) fn dot(self, o: Self) -> R {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    #[inline(always)]
    pub(super) fn cross(self, o: Self) -> Self {
        Self {
            x: self.y * o.z - self.z * o.y,
            y: self.z * o.x - self.x * o.z,
            z: self.x * o.y - self.y * o.x,
        }
    }
}

impl<const N: usize> V3<Lanes<N>> {
    #[inline(always)]
    pub(super) fn gather(v: &[Vector3<f64>; N]) -> Self {
        Self {
            x: Lanes(v.each_ref().map(|v| v.x)),
            y: Lanes(v.each_ref().map(|v| v.y)),
            z: Lanes(v.each_ref().map(|v| v.z)),
        }
    }
    #[inline(always)]
    pub(super) fn lane(self, i: usize) -> Vector3<f64> {
        Vector3::new(self.x.0[i], self.y.0[i], self.z.0[i])
    }
    #[inline(always)]
    pub(super) fn scatter(self, v: &mut [Vector3<f64>; N]) {
        for (i, v) in v.iter_mut().enumerate() {
            *v = self.lane(i);
        }
    }
    /// `|v|_∞` per lane.
    #[inline(always)]
    pub(super) fn amax(self) -> Lanes<N> {
        self.x.abs().max(self.y.abs()).max(self.z.abs())
    }
    /// Lanes where every `|v_i| <= threshold` (false for NaN).
    #[inline(always)]
    pub(super) fn within(self, threshold: Lanes<N>) -> [bool; N] {
        let (x, y, z) = (self.x.abs(), self.y.abs(), self.z.abs());
        std::array::from_fn(|i| {
            (x.0[i] <= threshold.0[i]) & (y.0[i] <= threshold.0[i]) & (z.0[i] <= threshold.0[i])
        })
    }
    /// Lanes where every component is finite.
    #[inline(always)]
    pub(super) fn finite(self) -> [bool; N] {
        let s = self.x.abs() + self.y.abs() + self.z.abs();
        s.0.map(f64::is_finite)
    }
    /// Lane-wise `if keep { self } else { other }`.
    #[inline(always)]
    pub(super) fn select(self, keep: &[bool; N], other: Self) -> Self {
        let pick = |a: Lanes<N>, b: Lanes<N>| {
            Lanes(std::array::from_fn(
                |i| if keep[i] { a.0[i] } else { b.0[i] },
            ))
        };
        Self {
            x: pick(self.x, other.x),
            y: pick(self.y, other.y),
            z: pick(self.z, other.z),
        }
    }
}

/// A quaternion `w + v` of lanes.
#[derive(Debug, Clone, Copy)]
pub(super) struct Quat<R> {
    pub(super) w: R,
    pub(super) v: V3<R>,
}

impl<const N: usize> Quat<Lanes<N>> {
    #[inline(always)]
    pub(super) fn gather(q: &[UnitQuaternion<f64>; N]) -> Self {
        Self {
            w: Lanes(q.each_ref().map(|q| q.w)),
            v: V3 {
                x: Lanes(q.each_ref().map(|q| q.i)),
                y: Lanes(q.each_ref().map(|q| q.j)),
                z: Lanes(q.each_ref().map(|q| q.k)),
            },
        }
    }
    #[inline(always)]
    pub(super) fn scatter(self, q: &mut [UnitQuaternion<f64>; N]) {
        for (i, q) in q.iter_mut().enumerate() {
            *q = UnitQuaternion::new_unchecked(Quaternion::new(
                self.w.0[i],
                self.v.x.0[i],
                self.v.y.0[i],
                self.v.z.0[i],
            ));
        }
    }
}
