//! The SIMD lane types of the variational step: the [`Pack`] trait (`N` bodies' values of one
//! quantity, processed by the same instructions) with its portable implementation [`Lanes`]
//! (an array the compiler turns into SSE2's two-lane instructions; one body is `N = 1`) and the
//! explicit AVX and AVX-512 registers of [`super::vector`], and the generic [`V3`] (a 3-vector of
//! packs) and [`Quat`] (a quaternion of packs), gathered from and scattered to the batch's
//! storage.
//!
//! The step's arithmetic is written once over a `Pack`, and every implementation rounds each
//! lane as `f64` does (IEEE add, subtract, multiply and divide, never fused; `abs` and negation
//! by the sign bit; `max` as `if a > b { a } else { b }`; ordered comparisons, false for NaN),
//! so every path and every lane width steps the same bits.

use super::VariationalSettings;
use super::newton::{NewtonOut, newton};
use crate::sim::so3::Real;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use std::ops::{Add, Div, Mul, Neg, Sub};

/// `N` bodies' values of one quantity, with the lane-wise operations the step needs beyond
/// [`Real`]'s arithmetic. Masks are bit sets: bit `i` is lane `i`.
pub(super) trait Pack<const N: usize>: Real + std::fmt::Debug {
    /// Every bit of a mask of `N` lanes.
    const ALL: u32 = if N >= 32 { u32::MAX } else { (1u32 << N) - 1 };
    fn from_array(a: [f64; N]) -> Self;
    fn to_array(self) -> [f64; N];
    /// Lane-wise `if self > o { self } else { o }` (x86's `maxpd`).
    fn max(self, o: Self) -> Self;
    /// Lanes where `self <= o` (false for NaN).
    fn le(self, o: Self) -> u32;
    /// Lanes where `self < o` (false for NaN).
    fn lt(self, o: Self) -> u32;
    /// Lanes where `self != o` and neither is NaN.
    fn ne(self, o: Self) -> u32;
    /// Lane-wise `if mask has lane i { a } else { b }`.
    fn select(mask: u32, a: Self, b: Self) -> Self;

    /// Lanes where `self` is finite.
    #[inline(always)]
    fn finite(self) -> u32 {
        self.abs().lt(Self::splat(f64::INFINITY))
    }

    /// `N` vectors: from the batch's array of structures to a vector of packs (one pack per
    /// component). Moves bits only.
    #[inline(always)]
    fn gather3(v: &[Vector3<f64>; N]) -> V3<Self> {
        V3 {
            x: Self::from_array(v.each_ref().map(|v| v.x)),
            y: Self::from_array(v.each_ref().map(|v| v.y)),
            z: Self::from_array(v.each_ref().map(|v| v.z)),
        }
    }
    /// [`Pack::gather3`] inverted.
    #[inline(always)]
    fn scatter3(c: V3<Self>, v: &mut [Vector3<f64>; N]) {
        let [x, y, z] = c.arrays();
        for (i, v) in v.iter_mut().enumerate() {
            *v = Vector3::new(x[i], y[i], z[i]);
        }
    }
    /// `N` quaternions as a quaternion of packs.
    #[inline(always)]
    fn gather4(q: &[UnitQuaternion<f64>; N]) -> Quat<Self> {
        Quat {
            w: Self::from_array(q.each_ref().map(|q| q.w)),
            v: V3 {
                x: Self::from_array(q.each_ref().map(|q| q.i)),
                y: Self::from_array(q.each_ref().map(|q| q.j)),
                z: Self::from_array(q.each_ref().map(|q| q.k)),
            },
        }
    }
    /// [`Pack::gather4`] inverted (the quaternions stored as given, not renormalised).
    #[inline(always)]
    fn scatter4(c: Quat<Self>, q: &mut [UnitQuaternion<f64>; N]) {
        let w = c.w.to_array();
        let [x, y, z] = c.v.arrays();
        for (i, q) in q.iter_mut().enumerate() {
            *q = UnitQuaternion::new_unchecked(Quaternion::new(w[i], x[i], y[i], z[i]));
        }
    }

    /// [`newton`] out of line (the rare path of the batched step), compiled with this pack's
    /// instructions.
    fn newton(
        j_over_h: V3<Self>,
        m: V3<Self>,
        xi: V3<Self>,
        threshold: Self,
        settings: &VariationalSettings,
    ) -> NewtonOut<Self, N>;
}

/// `N` bodies' values of one quantity as an array: the portable [`Pack`]. The lane loops become
/// SSE2 packed instructions (`addpd`, `mulpd`, `divpd`: two lanes per instruction); `N = 4`
/// gives two independent dependency chains per value, which measured faster than `N = 2` and
/// `N = 8` (see `docs/variational_performance.md`).
#[derive(Debug, Clone, Copy)]
pub(super) struct Lanes<const N: usize>(pub(super) [f64; N]);

/// Bodies stepped together on the portable path.
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

/// The lanes where `pred` holds, as a mask (evaluated in all lanes, no early exit).
#[inline(always)]
fn mask<const N: usize>(pred: impl Fn(usize) -> bool) -> u32 {
    let mut m = 0;
    for i in 0..N {
        m |= u32::from(pred(i)) << i;
    }
    m
}

impl<const N: usize> Pack<N> for Lanes<N> {
    #[inline(always)]
    fn from_array(a: [f64; N]) -> Self {
        Lanes(a)
    }
    #[inline(always)]
    fn to_array(self) -> [f64; N] {
        self.0
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        Lanes(std::array::from_fn(|i| {
            if self.0[i] > o.0[i] {
                self.0[i]
            } else {
                o.0[i]
            }
        }))
    }
    #[inline(always)]
    fn le(self, o: Self) -> u32 {
        mask::<N>(|i| self.0[i] <= o.0[i])
    }
    #[inline(always)]
    fn lt(self, o: Self) -> u32 {
        mask::<N>(|i| self.0[i] < o.0[i])
    }
    #[inline(always)]
    fn ne(self, o: Self) -> u32 {
        mask::<N>(|i| (self.0[i] != o.0[i]) & !self.0[i].is_nan() & !o.0[i].is_nan())
    }
    #[inline(always)]
    fn select(mask: u32, a: Self, b: Self) -> Self {
        Lanes(std::array::from_fn(|i| {
            if mask >> i & 1 == 1 { a.0[i] } else { b.0[i] }
        }))
    }
    #[inline(never)]
    fn newton(
        j_over_h: V3<Self>,
        m: V3<Self>,
        xi: V3<Self>,
        threshold: Self,
        settings: &VariationalSettings,
    ) -> NewtonOut<Self, N> {
        newton(j_over_h, m, xi, threshold, settings)
    }
}

/// Whether lane `i` of `mask` is set.
#[inline(always)]
pub(super) fn has(mask: u32, i: usize) -> bool {
    mask >> i & 1 == 1
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

impl<L> V3<L> {
    #[inline(always)]
    pub(super) fn gather<const N: usize>(v: &[Vector3<f64>; N]) -> Self
    where
        L: Pack<N>,
    {
        L::gather3(v)
    }
    /// The three components as arrays of lanes.
    #[inline(always)]
    pub(super) fn arrays<const N: usize>(self) -> [[f64; N]; 3]
    where
        L: Pack<N>,
    {
        [self.x.to_array(), self.y.to_array(), self.z.to_array()]
    }
    #[inline(always)]
    pub(super) fn lane<const N: usize>(self, i: usize) -> Vector3<f64>
    where
        L: Pack<N>,
    {
        let [x, y, z] = self.arrays();
        Vector3::new(x[i], y[i], z[i])
    }
    #[inline(always)]
    pub(super) fn scatter<const N: usize>(self, v: &mut [Vector3<f64>; N])
    where
        L: Pack<N>,
    {
        L::scatter3(self, v);
    }
    /// `|v|_∞` per lane.
    #[inline(always)]
    pub(super) fn amax<const N: usize>(self) -> L
    where
        L: Pack<N>,
    {
        self.x.abs().max(self.y.abs()).max(self.z.abs())
    }
    /// Lanes where every `|v_i| <= threshold` (false for NaN).
    #[inline(always)]
    pub(super) fn within<const N: usize>(self, threshold: L) -> u32
    where
        L: Pack<N>,
    {
        self.x.abs().le(threshold) & self.y.abs().le(threshold) & self.z.abs().le(threshold)
    }
    /// Lanes where every component is finite.
    #[inline(always)]
    pub(super) fn finite<const N: usize>(self) -> u32
    where
        L: Pack<N>,
    {
        (self.x.abs() + self.y.abs() + self.z.abs()).finite()
    }
    /// Lane-wise `if keep has lane i { self } else { other }`.
    #[inline(always)]
    pub(super) fn select<const N: usize>(self, keep: u32, other: Self) -> Self
    where
        L: Pack<N>,
    {
        Self {
            x: L::select(keep, self.x, other.x),
            y: L::select(keep, self.y, other.y),
            z: L::select(keep, self.z, other.z),
        }
    }
}

/// A quaternion `w + v` of lanes.
#[derive(Debug, Clone, Copy)]
pub(super) struct Quat<R> {
    pub(super) w: R,
    pub(super) v: V3<R>,
}

impl<L> Quat<L> {
    #[inline(always)]
    pub(super) fn gather<const N: usize>(q: &[UnitQuaternion<f64>; N]) -> Self
    where
        L: Pack<N>,
    {
        L::gather4(q)
    }
    #[inline(always)]
    pub(super) fn scatter<const N: usize>(self, q: &mut [UnitQuaternion<f64>; N])
    where
        L: Pack<N>,
    {
        L::scatter4(self, q);
    }
}
