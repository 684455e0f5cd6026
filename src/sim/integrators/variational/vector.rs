//! The explicit vector registers of the variational step on x86-64 ([`Pack`]s of 4 and 8
//! bodies): [`F64x4`], one AVX `ymm` register, and [`F64x8`], one AVX-512 `zmm` register.
//!
//! Each operation is one instruction that rounds every lane as `f64` does: `vaddpd`, `vsubpd`,
//! `vmulpd`, `vdivpd` (IEEE, never fused: no FMA is ever emitted, so the bits are those of the
//! portable path), `vmaxpd` (`if a > b { a } else { b }`, as [`Pack::max`] specifies), the sign
//! bit cleared or flipped for `abs` and negation, ordered non-signalling comparisons (`_OQ`:
//! false for NaN).
//!
//! # Safety
//!
//! The intrinsics need the CPU to have AVX (AVX-512F for [`F64x8`]). Code that uses these types
//! is reached only through [`crate::sim::simd`]'s dispatch, which calls it after
//! `is_x86_feature_detected!` found the unit (`Variational`'s `simd` level is at most
//! [`crate::sim::simd::detected`]); the types are private to the variational step. Every
//! operation is `#[inline(always)]` so that it is compiled inside the dispatched function, with
//! that function's `#[target_feature]`. This module and the dispatch are the crate's only
//! `unsafe` code.
#![allow(unsafe_code)]

use super::VariationalSettings;
use super::lanes::{Pack, Quat, V3};
use super::newton::{NewtonOut, newton};
use crate::sim::so3::Real;
use nalgebra::{UnitQuaternion, Vector3};
use std::arch::x86_64::*;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// 4 bodies' values in one AVX register.
#[derive(Debug, Clone, Copy)]
pub(super) struct F64x4(__m256d);

/// 8 bodies' values in one AVX-512 register.
#[derive(Debug, Clone, Copy)]
pub(super) struct F64x8(__m512d);

// The transposes read and write the batch's vectors and quaternions as runs of doubles:
// nalgebra stores a `Vector3<f64>` as `[x, y, z]` and a quaternion as `coords = [i, j, k, w]`
// (`#[repr(C)]` matrices of `ArrayStorage`, the quaternion and `Unit` transparent over them), with
// no padding, so an array of `N` of them is `3N` (`4N`) contiguous doubles.
const _: () = assert!(std::mem::size_of::<Vector3<f64>>() == 24);
const _: () = assert!(std::mem::size_of::<UnitQuaternion<f64>>() == 32);
const _: () = assert!(std::mem::align_of::<Vector3<f64>>() == 8);

macro_rules! binops {
    ($t:ident, $add:ident, $sub:ident, $mul:ident, $div:ident) => {
        impl Add for $t {
            type Output = Self;
            #[inline(always)]
            fn add(self, o: Self) -> Self {
                // SAFETY: see the module doc (the unit was detected).
                $t(unsafe { $add(self.0, o.0) })
            }
        }
        impl Sub for $t {
            type Output = Self;
            #[inline(always)]
            fn sub(self, o: Self) -> Self {
                // SAFETY: see the module doc.
                $t(unsafe { $sub(self.0, o.0) })
            }
        }
        impl Mul for $t {
            type Output = Self;
            #[inline(always)]
            fn mul(self, o: Self) -> Self {
                // SAFETY: see the module doc.
                $t(unsafe { $mul(self.0, o.0) })
            }
        }
        impl Div for $t {
            type Output = Self;
            #[inline(always)]
            fn div(self, o: Self) -> Self {
                // SAFETY: see the module doc.
                $t(unsafe { $div(self.0, o.0) })
            }
        }
    };
}
binops!(
    F64x4,
    _mm256_add_pd,
    _mm256_sub_pd,
    _mm256_mul_pd,
    _mm256_div_pd
);
binops!(
    F64x8,
    _mm512_add_pd,
    _mm512_sub_pd,
    _mm512_mul_pd,
    _mm512_div_pd
);

// ---- AVX: 4 lanes ----

impl Neg for F64x4 {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        // SAFETY: see the module doc.
        F64x4(unsafe { _mm256_xor_pd(self.0, _mm256_set1_pd(-0.0)) })
    }
}

impl Real for F64x4 {
    #[inline(always)]
    fn splat(v: f64) -> Self {
        // SAFETY: see the module doc.
        F64x4(unsafe { _mm256_set1_pd(v) })
    }
    #[inline(always)]
    fn abs(self) -> Self {
        // SAFETY: see the module doc.
        F64x4(unsafe { _mm256_andnot_pd(_mm256_set1_pd(-0.0), self.0) })
    }
}

impl F64x4 {
    /// The lanes where comparison `P` holds, as a mask.
    #[inline(always)]
    fn cmp<const P: i32>(self, o: Self) -> u32 {
        // SAFETY: see the module doc.
        (unsafe { _mm256_movemask_pd(_mm256_cmp_pd::<P>(self.0, o.0)) }) as u32
    }
}

/// [`Pack`]'s comparisons through the pack's `cmp::<predicate>`, the ordered non-signalling forms
/// (false for NaN).
macro_rules! comparisons {
    () => {
        #[inline(always)]
        fn le(self, o: Self) -> u32 {
            self.cmp::<_CMP_LE_OQ>(o)
        }
        #[inline(always)]
        fn lt(self, o: Self) -> u32 {
            self.cmp::<_CMP_LT_OQ>(o)
        }
        #[inline(always)]
        fn ne(self, o: Self) -> u32 {
            self.cmp::<_CMP_NEQ_OQ>(o)
        }
    };
}

/// [`Pack::newton`] calling `$outlined`, and `$outlined`: [`newton`] on `$pack`, out of line and
/// compiled for `$feature`.
macro_rules! outlined_newton {
    (method $n:literal, $outlined:ident) => {
        fn newton(
            j_over_h: V3<Self>,
            m: V3<Self>,
            xi: V3<Self>,
            threshold: Self,
            settings: &VariationalSettings,
        ) -> NewtonOut<Self, $n> {
            // SAFETY: see the module doc (only the dispatched path makes this pack).
            unsafe { $outlined(j_over_h, m, xi, threshold, settings) }
        }
    };
    (function $pack:ident, $n:literal, $outlined:ident, $feature:literal) => {
        /// [`newton`] on this pack, compiled for its unit.
        #[target_feature(enable = $feature)]
        #[inline(never)]
        fn $outlined(
            j_over_h: V3<$pack>,
            m: V3<$pack>,
            xi: V3<$pack>,
            threshold: $pack,
            settings: &VariationalSettings,
        ) -> NewtonOut<$pack, $n> {
            newton(j_over_h, m, xi, threshold, settings)
        }
    };
}

impl Pack<4> for F64x4 {
    #[inline(always)]
    fn from_array(a: [f64; 4]) -> Self {
        // SAFETY: see the module doc; `a` holds 4 doubles (unaligned load).
        F64x4(unsafe { _mm256_loadu_pd(a.as_ptr()) })
    }
    #[inline(always)]
    fn to_array(self) -> [f64; 4] {
        let mut a = [0.0; 4];
        // SAFETY: see the module doc; `a` holds 4 doubles (unaligned store).
        unsafe { _mm256_storeu_pd(a.as_mut_ptr(), self.0) };
        a
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        // SAFETY: see the module doc. `vmaxpd a, b` is `if a > b { a } else { b }`.
        F64x4(unsafe { _mm256_max_pd(self.0, o.0) })
    }
    comparisons!();
    #[inline(always)]
    fn select(mask: u32, a: Self, b: Self) -> Self {
        let (a, b) = (a.to_array(), b.to_array());
        Self::from_array(std::array::from_fn(|i| {
            if mask >> i & 1 == 1 { a[i] } else { b[i] }
        }))
    }
    /// Loads `a = (x0 y0 z0 x1)`, `b = (y1 z1 x2 y2)`, `c = (z2 x3 y3 z3)`; crosses the 128-bit
    /// halves (`p = (x0 y0 x2 y2)`, `r = (z0 x1 z2 x3)`, `s = (y1 z1 y3 z3)`), then picks within
    /// them.
    #[inline(always)]
    fn gather3(v: &[Vector3<f64>; 4]) -> V3<Self> {
        let p = v.as_ptr().cast::<f64>();
        // SAFETY: see the module doc; `v` is 12 contiguous doubles (the layout asserts above).
        unsafe {
            let (a, b, c) = (
                _mm256_loadu_pd(p),
                _mm256_loadu_pd(p.add(4)),
                _mm256_loadu_pd(p.add(8)),
            );
            let pp = _mm256_permute2f128_pd::<0x30>(a, b);
            let r = _mm256_permute2f128_pd::<0x21>(a, c);
            let s = _mm256_permute2f128_pd::<0x30>(b, c);
            V3 {
                x: F64x4(_mm256_shuffle_pd::<0b1010>(pp, r)),
                y: F64x4(_mm256_shuffle_pd::<0b0101>(pp, s)),
                z: F64x4(_mm256_shuffle_pd::<0b1010>(r, s)),
            }
        }
    }
    #[inline(always)]
    fn scatter3(c: V3<Self>, v: &mut [Vector3<f64>; 4]) {
        let (x, y, z) = (c.x.0, c.y.0, c.z.0);
        let p = v.as_mut_ptr().cast::<f64>();
        // SAFETY: see the module doc; `v` is 12 contiguous doubles.
        unsafe {
            let pp = _mm256_shuffle_pd::<0b0000>(x, y);
            let r = _mm256_shuffle_pd::<0b1010>(z, x);
            let s = _mm256_shuffle_pd::<0b1111>(y, z);
            _mm256_storeu_pd(p, _mm256_permute2f128_pd::<0x20>(pp, r));
            _mm256_storeu_pd(p.add(4), _mm256_permute2f128_pd::<0x30>(s, pp));
            _mm256_storeu_pd(p.add(8), _mm256_permute2f128_pd::<0x31>(r, s));
        }
    }
    /// A 4x4 transpose: pairs of rows interleaved, then 128-bit halves exchanged.
    #[inline(always)]
    fn gather4(q: &[UnitQuaternion<f64>; 4]) -> Quat<Self> {
        let p = q.as_ptr().cast::<f64>();
        // SAFETY: see the module doc; `q` is 16 contiguous doubles.
        unsafe {
            let r: [__m256d; 4] = std::array::from_fn(|i| _mm256_loadu_pd(p.add(4 * i)));
            let t0 = _mm256_unpacklo_pd(r[0], r[1]);
            let t1 = _mm256_unpackhi_pd(r[0], r[1]);
            let t2 = _mm256_unpacklo_pd(r[2], r[3]);
            let t3 = _mm256_unpackhi_pd(r[2], r[3]);
            Quat {
                w: F64x4(_mm256_permute2f128_pd::<0x31>(t1, t3)),
                v: V3 {
                    x: F64x4(_mm256_permute2f128_pd::<0x20>(t0, t2)),
                    y: F64x4(_mm256_permute2f128_pd::<0x20>(t1, t3)),
                    z: F64x4(_mm256_permute2f128_pd::<0x31>(t0, t2)),
                },
            }
        }
    }
    #[inline(always)]
    fn scatter4(c: Quat<Self>, q: &mut [UnitQuaternion<f64>; 4]) {
        let (i, j, k, w) = (c.v.x.0, c.v.y.0, c.v.z.0, c.w.0);
        let p = q.as_mut_ptr().cast::<f64>();
        // SAFETY: see the module doc; `q` is 16 contiguous doubles.
        unsafe {
            let t0 = _mm256_permute2f128_pd::<0x20>(i, k);
            let t2 = _mm256_permute2f128_pd::<0x31>(i, k);
            let t1 = _mm256_permute2f128_pd::<0x20>(j, w);
            let t3 = _mm256_permute2f128_pd::<0x31>(j, w);
            _mm256_storeu_pd(p, _mm256_unpacklo_pd(t0, t1));
            _mm256_storeu_pd(p.add(4), _mm256_unpackhi_pd(t0, t1));
            _mm256_storeu_pd(p.add(8), _mm256_unpacklo_pd(t2, t3));
            _mm256_storeu_pd(p.add(12), _mm256_unpackhi_pd(t2, t3));
        }
    }
    outlined_newton!(method 4, newton_avx2);
}
outlined_newton!(function F64x4, 4, newton_avx2, "avx2");

// ---- AVX-512F: 8 lanes ----

/// The sign bit of every lane, as integers (AVX-512F has no floating-point `xor`/`andnot`;
/// those are AVX-512DQ).
#[inline(always)]
fn sign_bits_512() -> __m512i {
    // SAFETY: see the module doc.
    unsafe { _mm512_set1_epi64(i64::MIN) }
}

impl Neg for F64x8 {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        // SAFETY: see the module doc.
        F64x8(unsafe {
            _mm512_castsi512_pd(_mm512_xor_si512(
                _mm512_castpd_si512(self.0),
                sign_bits_512(),
            ))
        })
    }
}

impl Real for F64x8 {
    #[inline(always)]
    fn splat(v: f64) -> Self {
        // SAFETY: see the module doc.
        F64x8(unsafe { _mm512_set1_pd(v) })
    }
    #[inline(always)]
    fn abs(self) -> Self {
        // SAFETY: see the module doc.
        F64x8(unsafe {
            _mm512_castsi512_pd(_mm512_andnot_si512(
                sign_bits_512(),
                _mm512_castpd_si512(self.0),
            ))
        })
    }
}

impl Pack<8> for F64x8 {
    #[inline(always)]
    fn from_array(a: [f64; 8]) -> Self {
        // SAFETY: see the module doc; `a` holds 8 doubles (unaligned load).
        F64x8(unsafe { _mm512_loadu_pd(a.as_ptr()) })
    }
    #[inline(always)]
    fn to_array(self) -> [f64; 8] {
        let mut a = [0.0; 8];
        // SAFETY: see the module doc; `a` holds 8 doubles (unaligned store).
        unsafe { _mm512_storeu_pd(a.as_mut_ptr(), self.0) };
        a
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        // SAFETY: see the module doc. `vmaxpd a, b` is `if a > b { a } else { b }`.
        F64x8(unsafe { _mm512_max_pd(self.0, o.0) })
    }
    comparisons!();
    #[inline(always)]
    fn select(mask: u32, a: Self, b: Self) -> Self {
        // SAFETY: see the module doc. The blend takes its second operand where the mask is set.
        F64x8(unsafe { _mm512_mask_blend_pd(mask as u8, b.0, a.0) })
    }
    /// Three loads of 8 doubles; each component picked by two two-source permutes (the first
    /// from the first two registers, the second adding the third's).
    #[inline(always)]
    fn gather3(v: &[Vector3<f64>; 8]) -> V3<Self> {
        let p = v.as_ptr().cast::<f64>();
        // SAFETY: see the module doc; `v` is 24 contiguous doubles.
        unsafe {
            let (a, b, c) = (
                _mm512_loadu_pd(p),
                _mm512_loadu_pd(p.add(8)),
                _mm512_loadu_pd(p.add(16)),
            );
            let component = |k: usize| {
                let ab = _mm512_permutex2var_pd(a, index(&GATHER3[k][0]), b);
                F64x8(_mm512_permutex2var_pd(ab, index(&GATHER3[k][1]), c))
            };
            V3 {
                x: component(0),
                y: component(1),
                z: component(2),
            }
        }
    }
    #[inline(always)]
    fn scatter3(c: V3<Self>, v: &mut [Vector3<f64>; 8]) {
        let (x, y, z) = (c.x.0, c.y.0, c.z.0);
        let p = v.as_mut_ptr().cast::<f64>();
        // SAFETY: see the module doc; `v` is 24 contiguous doubles.
        unsafe {
            for r in 0..3 {
                let xy = _mm512_permutex2var_pd(x, index(&SCATTER3[r][0]), y);
                let out = _mm512_permutex2var_pd(xy, index(&SCATTER3[r][1]), z);
                _mm512_storeu_pd(p.add(8 * r), out);
            }
        }
    }
    /// Four loads (two quaternions each); components 0-1 and 2-3 of bodies 0-3 and 4-7 picked
    /// first, then the halves joined.
    #[inline(always)]
    fn gather4(q: &[UnitQuaternion<f64>; 8]) -> Quat<Self> {
        let p = q.as_ptr().cast::<f64>();
        // SAFETY: see the module doc; `q` is 32 contiguous doubles.
        unsafe {
            let r: [__m512d; 4] = std::array::from_fn(|i| _mm512_loadu_pd(p.add(8 * i)));
            let (lo, hi) = (index(&QUAT_PAIRS[0]), index(&QUAT_PAIRS[1]));
            let a = _mm512_permutex2var_pd(r[0], lo, r[1]);
            let b = _mm512_permutex2var_pd(r[0], hi, r[1]);
            let c = _mm512_permutex2var_pd(r[2], lo, r[3]);
            let d = _mm512_permutex2var_pd(r[2], hi, r[3]);
            let (first, second) = (index(&HALVES[0]), index(&HALVES[1]));
            Quat {
                w: F64x8(_mm512_permutex2var_pd(b, second, d)),
                v: V3 {
                    x: F64x8(_mm512_permutex2var_pd(a, first, c)),
                    y: F64x8(_mm512_permutex2var_pd(a, second, c)),
                    z: F64x8(_mm512_permutex2var_pd(b, first, d)),
                },
            }
        }
    }
    #[inline(always)]
    fn scatter4(c: Quat<Self>, q: &mut [UnitQuaternion<f64>; 8]) {
        let (i, j, k, w) = (c.v.x.0, c.v.y.0, c.v.z.0, c.w.0);
        let p = q.as_mut_ptr().cast::<f64>();
        // SAFETY: see the module doc; `q` is 32 contiguous doubles.
        unsafe {
            let (first, second) = (index(&HALVES[0]), index(&HALVES[1]));
            // Components 0-1 (2-3) of bodies 0-3, then of bodies 4-7.
            let a = _mm512_permutex2var_pd(i, first, j);
            let c = _mm512_permutex2var_pd(i, second, j);
            let b = _mm512_permutex2var_pd(k, first, w);
            let d = _mm512_permutex2var_pd(k, second, w);
            let (lo, hi) = (index(&QUAT_ROWS[0]), index(&QUAT_ROWS[1]));
            _mm512_storeu_pd(p, _mm512_permutex2var_pd(a, lo, b));
            _mm512_storeu_pd(p.add(8), _mm512_permutex2var_pd(a, hi, b));
            _mm512_storeu_pd(p.add(16), _mm512_permutex2var_pd(c, lo, d));
            _mm512_storeu_pd(p.add(24), _mm512_permutex2var_pd(c, hi, d));
        }
    }
    outlined_newton!(method 8, newton_avx512);
}
outlined_newton!(function F64x8, 8, newton_avx512, "avx512f");

impl F64x8 {
    /// The lanes where comparison `P` holds, as a mask.
    #[inline(always)]
    fn cmp<const P: i32>(self, o: Self) -> u32 {
        // SAFETY: see the module doc.
        u32::from(unsafe { _mm512_cmp_pd_mask::<P>(self.0, o.0) })
    }
}

/// A permute's index register.
#[inline(always)]
fn index(i: &[i64; 8]) -> __m512i {
    // SAFETY: see the module doc; `i` is 8 integers.
    unsafe { _mm512_loadu_epi64(i.as_ptr()) }
}

/// The two-source permute indices of [`F64x8::gather3`]: for component `k`, lane `b` (body `b`)
/// takes the double at `3b + k` of the 24 loaded, first from registers 0-1 (indices 0-15),
/// then the third register's (`8 +` its index) replaces the lanes beyond.
const GATHER3: [[[i64; 8]; 2]; 3] = {
    let mut t = [[[0; 8]; 2]; 3];
    let mut k = 0;
    while k < 3 {
        let mut b = 0;
        while b < 8 {
            let f = 3 * b + k;
            if f < 16 {
                t[k][0][b] = f as i64;
                t[k][1][b] = b as i64;
            } else {
                t[k][1][b] = 8 + (f - 16) as i64;
            }
            b += 1;
        }
        k += 1;
    }
    t
};

/// [`F64x8::scatter3`]'s indices: output register `r` holds the doubles `8r..8r+8` of the 24,
/// double `f` being component `f % 3` of body `f / 3`: from `x` and `y` first, then `z`.
const SCATTER3: [[[i64; 8]; 2]; 3] = {
    let mut t = [[[0; 8]; 2]; 3];
    let mut r = 0;
    while r < 3 {
        let mut p = 0;
        while p < 8 {
            let f = 8 * r + p;
            let (body, comp) = ((f / 3) as i64, f % 3);
            t[r][0][p] = if comp == 1 { 8 + body } else { body };
            t[r][1][p] = if comp == 2 { 8 + body } else { p as i64 };
            p += 1;
        }
        r += 1;
    }
    t
};

/// From two loaded registers (quaternions `2r..2r+4`, 4 doubles each): lane `p` takes component
/// `p / 4` (`2 + p / 4` for the second table) of quaternion `p % 4`.
const QUAT_PAIRS: [[i64; 8]; 2] = {
    let mut t = [[0; 8]; 2];
    let mut p = 0;
    while p < 8 {
        t[0][p] = (4 * (p % 4) + p / 4) as i64;
        t[1][p] = (4 * (p % 4) + 2 + p / 4) as i64;
        p += 1;
    }
    t
};

/// The low halves of two registers (`[0..4, 8..12]`), and the high halves (`[4..8, 12..16]`).
const HALVES: [[i64; 8]; 2] = [[0, 1, 2, 3, 8, 9, 10, 11], [4, 5, 6, 7, 12, 13, 14, 15]];

/// [`F64x8::scatter4`]'s last step: from `a` (components 0-1 of 4 quaternions, `4c + q`) and `b`
/// (components 2-3), the doubles of quaternions 0-1 (first table) or 2-3 (second) in storage
/// order.
const QUAT_ROWS: [[i64; 8]; 2] = {
    let mut t = [[0; 8]; 2];
    let mut h = 0;
    while h < 2 {
        let mut f = 0;
        while f < 8 {
            let (quat, comp) = (2 * h + f / 4, f % 4);
            t[h][f] = if comp < 2 {
                (4 * comp + quat) as i64
            } else {
                (8 + 4 * (comp - 2) + quat) as i64
            };
            f += 1;
        }
        h += 1;
    }
    t
};

/// Whether every index of a two-source permute (`vpermt2pd`) names one of its 16 lanes. The
/// instruction reads only an index's low 4 bits, so an index off by a multiple of 16 would still
/// pick the intended lane: checked here, at compile time, so that the tables say what they mean.
const fn lanes_in_range(row: &[i64; 8]) -> bool {
    let mut i = 0;
    while i < 8 {
        if row[i] < 0 || row[i] >= 16 {
            return false;
        }
        i += 1;
    }
    true
}

const _: () = {
    let mut k = 0;
    while k < 3 {
        let mut s = 0;
        while s < 2 {
            assert!(lanes_in_range(&GATHER3[k][s]));
            assert!(lanes_in_range(&SCATTER3[k][s]));
            s += 1;
        }
        k += 1;
    }
    let mut h = 0;
    while h < 2 {
        assert!(lanes_in_range(&QUAT_PAIRS[h]));
        assert!(lanes_in_range(&HALVES[h]));
        assert!(lanes_in_range(&QUAT_ROWS[h]));
        h += 1;
    }
};

// ---- Two registers per value: two independent dependency chains ----

/// Two registers of a unit stepped as one pack of twice the lanes: each operation is two
/// independent instructions, so the core overlaps two groups' long chains (the Newton solve is a
/// sequence of dependent operations with a division in the middle; one register's chain alone
/// leaves the units waiting on latency).
macro_rules! pair {
    ($name:ident, $inner:ident, $n:literal, $half:literal, $newton:ident, $feature:literal) => {
        #[derive(Debug, Clone, Copy)]
        pub(super) struct $name($inner, $inner);

        impl Add for $name {
            type Output = Self;
            #[inline(always)]
            fn add(self, o: Self) -> Self {
                $name(self.0 + o.0, self.1 + o.1)
            }
        }
        impl Sub for $name {
            type Output = Self;
            #[inline(always)]
            fn sub(self, o: Self) -> Self {
                $name(self.0 - o.0, self.1 - o.1)
            }
        }
        impl Mul for $name {
            type Output = Self;
            #[inline(always)]
            fn mul(self, o: Self) -> Self {
                $name(self.0 * o.0, self.1 * o.1)
            }
        }
        impl Div for $name {
            type Output = Self;
            #[inline(always)]
            fn div(self, o: Self) -> Self {
                $name(self.0 / o.0, self.1 / o.1)
            }
        }
        impl Neg for $name {
            type Output = Self;
            #[inline(always)]
            fn neg(self) -> Self {
                $name(-self.0, -self.1)
            }
        }
        impl Real for $name {
            #[inline(always)]
            fn splat(v: f64) -> Self {
                $name($inner::splat(v), $inner::splat(v))
            }
            #[inline(always)]
            fn abs(self) -> Self {
                $name(self.0.abs(), self.1.abs())
            }
        }
        impl Pack<$n> for $name {
            #[inline(always)]
            fn from_array(a: [f64; $n]) -> Self {
                let (lo, hi) = a.split_at($half);
                $name(
                    $inner::from_array(lo.try_into().unwrap()),
                    $inner::from_array(hi.try_into().unwrap()),
                )
            }
            #[inline(always)]
            fn to_array(self) -> [f64; $n] {
                let mut a = [0.0; $n];
                a[..$half].copy_from_slice(&self.0.to_array());
                a[$half..].copy_from_slice(&self.1.to_array());
                a
            }
            #[inline(always)]
            fn max(self, o: Self) -> Self {
                $name(self.0.max(o.0), self.1.max(o.1))
            }
            #[inline(always)]
            fn gather3(v: &[Vector3<f64>; $n]) -> V3<Self> {
                let (lo, hi) = v.split_at($half);
                let lo = $inner::gather3(lo.try_into().unwrap());
                let hi = $inner::gather3(hi.try_into().unwrap());
                V3 {
                    x: $name(lo.x, hi.x),
                    y: $name(lo.y, hi.y),
                    z: $name(lo.z, hi.z),
                }
            }
            #[inline(always)]
            fn scatter3(c: V3<Self>, v: &mut [Vector3<f64>; $n]) {
                let (lo, hi) = v.split_at_mut($half);
                let half = |pick: fn(Self) -> $inner| V3 {
                    x: pick(c.x),
                    y: pick(c.y),
                    z: pick(c.z),
                };
                $inner::scatter3(half(|p| p.0), lo.try_into().unwrap());
                $inner::scatter3(half(|p| p.1), hi.try_into().unwrap());
            }
            #[inline(always)]
            fn gather4(q: &[UnitQuaternion<f64>; $n]) -> Quat<Self> {
                let (lo, hi) = q.split_at($half);
                let lo = $inner::gather4(lo.try_into().unwrap());
                let hi = $inner::gather4(hi.try_into().unwrap());
                Quat {
                    w: $name(lo.w, hi.w),
                    v: V3 {
                        x: $name(lo.v.x, hi.v.x),
                        y: $name(lo.v.y, hi.v.y),
                        z: $name(lo.v.z, hi.v.z),
                    },
                }
            }
            #[inline(always)]
            fn scatter4(c: Quat<Self>, q: &mut [UnitQuaternion<f64>; $n]) {
                let (lo, hi) = q.split_at_mut($half);
                let half = |pick: fn(Self) -> $inner| Quat {
                    w: pick(c.w),
                    v: V3 {
                        x: pick(c.v.x),
                        y: pick(c.v.y),
                        z: pick(c.v.z),
                    },
                };
                $inner::scatter4(half(|p| p.0), lo.try_into().unwrap());
                $inner::scatter4(half(|p| p.1), hi.try_into().unwrap());
            }
            #[inline(always)]
            fn le(self, o: Self) -> u32 {
                self.0.le(o.0) | self.1.le(o.1) << $half
            }
            #[inline(always)]
            fn lt(self, o: Self) -> u32 {
                self.0.lt(o.0) | self.1.lt(o.1) << $half
            }
            #[inline(always)]
            fn ne(self, o: Self) -> u32 {
                self.0.ne(o.0) | self.1.ne(o.1) << $half
            }
            #[inline(always)]
            fn select(mask: u32, a: Self, b: Self) -> Self {
                $name(
                    $inner::select(mask, a.0, b.0),
                    $inner::select(mask >> $half, a.1, b.1),
                )
            }
            outlined_newton!(method $n, $newton);
        }
        outlined_newton!(function $name, $n, $newton, $feature);
    };
}
pair!(F64x8x2, F64x8, 16, 8, newton_avx512_pair, "avx512f");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::simd::{Level, available};
    use nalgebra::Quaternion;

    /// Distinct values for every component of every body: a transpose that swaps two lanes or two
    /// components is seen.
    fn vectors<const N: usize>() -> [Vector3<f64>; N] {
        std::array::from_fn(|b| Vector3::new(b as f64, 100.0 + b as f64, 200.0 + b as f64))
    }
    fn quaternions<const N: usize>() -> [UnitQuaternion<f64>; N] {
        std::array::from_fn(|b| {
            let b = b as f64;
            UnitQuaternion::new_unchecked(Quaternion::new(300.0 + b, b, 100.0 + b, 200.0 + b))
        })
    }

    /// Gathers and scatters `N` vectors and quaternions through pack `L` and checks every lane
    /// against the batch's values, then that scattering gives the batch back.
    fn round_trip<L: Pack<N>, const N: usize>() {
        let v = vectors::<N>();
        let g = L::gather3(&v);
        let (x, y, z) = (g.x.to_array(), g.y.to_array(), g.z.to_array());
        for b in 0..N {
            assert_eq!(
                [x[b], y[b], z[b]],
                [v[b].x, v[b].y, v[b].z],
                "vector lane {b}"
            );
        }
        let mut back = [Vector3::zeros(); N];
        L::scatter3(g, &mut back);
        assert_eq!(back, v);
        let q = quaternions::<N>();
        let g = L::gather4(&q);
        let (w, i, j, k) = (
            g.w.to_array(),
            g.v.x.to_array(),
            g.v.y.to_array(),
            g.v.z.to_array(),
        );
        for b in 0..N {
            assert_eq!(
                [w[b], i[b], j[b], k[b]],
                [q[b].w, q[b].i, q[b].j, q[b].k],
                "quaternion lane {b}"
            );
        }
        let mut back = [UnitQuaternion::identity(); N];
        L::scatter4(g, &mut back);
        assert_eq!(back.map(|q| q.coords), q.map(|q| q.coords));
    }

    /// Each operation against `f64`'s, lane by lane, on values that tell the cases apart: signed
    /// zeros (abs, negation, max's tie), NaN (comparisons false, max takes the second), infinities.
    fn operations<L: Pack<N>, const N: usize>() {
        let pool = [
            0.0,
            -0.0,
            1.5,
            -2.25,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            3.0e-300,
            -7.0,
            1.5,
        ];
        for shift in 0..pool.len() {
            let a: [f64; N] = std::array::from_fn(|i| pool[(i + shift) % pool.len()]);
            let b: [f64; N] = std::array::from_fn(|i| pool[(3 * i + 2 * shift + 1) % pool.len()]);
            let (pa, pb) = (L::from_array(a), L::from_array(b));
            let bits = |x: [f64; N]| x.map(f64::to_bits);
            let lanes = |f: &dyn Fn(f64, f64) -> f64| bits(std::array::from_fn(|i| f(a[i], b[i])));
            assert_eq!(bits((pa + pb).to_array()), lanes(&|x, y| x + y));
            assert_eq!(bits((pa - pb).to_array()), lanes(&|x, y| x - y));
            assert_eq!(bits((pa * pb).to_array()), lanes(&|x, y| x * y));
            assert_eq!(bits((pa / pb).to_array()), lanes(&|x, y| x / y));
            assert_eq!(bits((-pa).to_array()), lanes(&|x, _| -x));
            assert_eq!(bits(pa.abs().to_array()), lanes(&|x, _| x.abs()));
            assert_eq!(
                bits(pa.max(pb).to_array()),
                lanes(&|x, y| if x > y { x } else { y })
            );
            assert_eq!(bits(L::splat(a[0]).to_array()), bits([a[0]; N]));
            let mask = |f: &dyn Fn(f64, f64) -> bool| {
                (0..N).fold(0u32, |m, i| m | u32::from(f(a[i], b[i])) << i)
            };
            assert_eq!(pa.le(pb), mask(&|x, y| x <= y));
            assert_eq!(pa.lt(pb), mask(&|x, y| x < y));
            assert_eq!(
                pa.ne(pb),
                mask(&|x, y| (x != y) & !x.is_nan() & !y.is_nan())
            );
            assert_eq!(pa.finite(), mask(&|x, _| x.is_finite()));
            let pick = 0b1011_0110_1001_1010u32 >> shift;
            let chosen: [f64; N] =
                std::array::from_fn(|i| if pick >> i & 1 == 1 { a[i] } else { b[i] });
            assert_eq!(bits(L::select(pick, pa, pb).to_array()), bits(chosen));
        }
    }

    /// The permute tables' compile-time check accepts the 16 lanes and refuses an index off by
    /// 16 either way (what `vpermt2pd` alone would not notice), wherever it sits in the row.
    #[test]
    fn lanes_in_range_refuses_indices_outside_the_16_lanes() {
        assert!(lanes_in_range(&[0, 1, 2, 3, 12, 13, 14, 15]));
        for at in 0..8 {
            for bad in [16, 17, -1, -16] {
                let mut row = [3; 8];
                row[at] = bad;
                assert!(!lanes_in_range(&row), "{row:?}");
            }
        }
    }

    #[test]
    fn packs_move_and_round_as_the_portable_lanes() {
        let levels = available();
        if levels.contains(&Level::Avx2) {
            // SAFETY: the CPU has AVX2 (detected).
            unsafe { avx2_checks() };
        }
        if levels.contains(&Level::Avx512) {
            // SAFETY: the CPU has AVX-512F (detected).
            unsafe { avx512_checks() };
        }
        // The masks' full sets (a wrong one only slows the step: every group would leave the
        // one-update path for the full Newton loop, whose bits are the same).
        use super::super::lanes::Lanes;
        assert_eq!(<Lanes<1> as Pack<1>>::ALL, 0b1);
        assert_eq!(<Lanes<4> as Pack<4>>::ALL, 0b1111);
        assert_eq!(<F64x8x2 as Pack<16>>::ALL, 0xffff);
        assert_eq!(<Lanes<32> as Pack<32>>::ALL, u32::MAX);
        // The portable lanes against the same checks.
        round_trip::<super::super::lanes::Lanes<4>, 4>();
        operations::<super::super::lanes::Lanes<4>, 4>();
    }

    #[target_feature(enable = "avx2")]
    fn avx2_checks() {
        round_trip::<F64x4, 4>();
        operations::<F64x4, 4>();
    }

    #[target_feature(enable = "avx512f")]
    fn avx512_checks() {
        round_trip::<F64x8, 8>();
        operations::<F64x8, 8>();
        round_trip::<F64x8x2, 16>();
        operations::<F64x8x2, 16>();
    }
}
