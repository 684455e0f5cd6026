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
use super::lanes::{Pack, V3};
use super::newton::{NewtonOut, newton};
use crate::sim::so3::Real;
use std::arch::x86_64::*;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// 4 bodies' values in one AVX register.
#[derive(Debug, Clone, Copy)]
pub(super) struct F64x4(__m256d);

/// 8 bodies' values in one AVX-512 register.
#[derive(Debug, Clone, Copy)]
pub(super) struct F64x8(__m512d);

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
    /// The lanes of a comparison's result as a mask.
    #[inline(always)]
    fn bits(v: __m256d) -> u32 {
        // SAFETY: see the module doc.
        (unsafe { _mm256_movemask_pd(v) }) as u32
    }
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
    #[inline(always)]
    fn le(self, o: Self) -> u32 {
        // SAFETY: see the module doc.
        Self::bits(unsafe { _mm256_cmp_pd::<_CMP_LE_OQ>(self.0, o.0) })
    }
    #[inline(always)]
    fn lt(self, o: Self) -> u32 {
        // SAFETY: see the module doc.
        Self::bits(unsafe { _mm256_cmp_pd::<_CMP_LT_OQ>(self.0, o.0) })
    }
    #[inline(always)]
    fn ne(self, o: Self) -> u32 {
        // SAFETY: see the module doc.
        Self::bits(unsafe { _mm256_cmp_pd::<_CMP_NEQ_OQ>(self.0, o.0) })
    }
    #[inline(always)]
    fn select(mask: u32, a: Self, b: Self) -> Self {
        let (a, b) = (a.to_array(), b.to_array());
        Self::from_array(std::array::from_fn(|i| {
            if mask >> i & 1 == 1 { a[i] } else { b[i] }
        }))
    }
    fn newton(
        j_over_h: V3<Self>,
        m: V3<Self>,
        xi: V3<Self>,
        threshold: Self,
        settings: &VariationalSettings,
    ) -> NewtonOut<Self, 4> {
        // SAFETY: see the module doc (only the AVX2 path makes an `F64x4`).
        unsafe { newton_avx2(j_over_h, m, xi, threshold, settings) }
    }
}

/// [`newton`] on 4 lanes, compiled for AVX2.
#[target_feature(enable = "avx2")]
#[inline(never)]
fn newton_avx2(
    j_over_h: V3<F64x4>,
    m: V3<F64x4>,
    xi: V3<F64x4>,
    threshold: F64x4,
    settings: &VariationalSettings,
) -> NewtonOut<F64x4, 4> {
    newton(j_over_h, m, xi, threshold, settings)
}

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
    #[inline(always)]
    fn le(self, o: Self) -> u32 {
        // SAFETY: see the module doc.
        u32::from(unsafe { _mm512_cmp_pd_mask::<_CMP_LE_OQ>(self.0, o.0) })
    }
    #[inline(always)]
    fn lt(self, o: Self) -> u32 {
        // SAFETY: see the module doc.
        u32::from(unsafe { _mm512_cmp_pd_mask::<_CMP_LT_OQ>(self.0, o.0) })
    }
    #[inline(always)]
    fn ne(self, o: Self) -> u32 {
        // SAFETY: see the module doc.
        u32::from(unsafe { _mm512_cmp_pd_mask::<_CMP_NEQ_OQ>(self.0, o.0) })
    }
    #[inline(always)]
    fn select(mask: u32, a: Self, b: Self) -> Self {
        // SAFETY: see the module doc. The blend takes its second operand where the mask is set.
        F64x8(unsafe { _mm512_mask_blend_pd(mask as u8, b.0, a.0) })
    }
    fn newton(
        j_over_h: V3<Self>,
        m: V3<Self>,
        xi: V3<Self>,
        threshold: Self,
        settings: &VariationalSettings,
    ) -> NewtonOut<Self, 8> {
        // SAFETY: see the module doc (only the AVX-512 path makes an `F64x8`).
        unsafe { newton_avx512(j_over_h, m, xi, threshold, settings) }
    }
}

/// [`newton`] on 8 lanes, compiled for AVX-512F.
#[target_feature(enable = "avx512f")]
#[inline(never)]
fn newton_avx512(
    j_over_h: V3<F64x8>,
    m: V3<F64x8>,
    xi: V3<F64x8>,
    threshold: F64x8,
    settings: &VariationalSettings,
) -> NewtonOut<F64x8, 8> {
    newton(j_over_h, m, xi, threshold, settings)
}

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
            fn newton(
                j_over_h: V3<Self>,
                m: V3<Self>,
                xi: V3<Self>,
                threshold: Self,
                settings: &VariationalSettings,
            ) -> NewtonOut<Self, $n> {
                // SAFETY: see the module doc (only the dispatched path makes this pack).
                unsafe { $newton(j_over_h, m, xi, threshold, settings) }
            }
        }

        /// [`newton`] on this pack, compiled for its unit.
        #[target_feature(enable = $feature)]
        #[inline(never)]
        fn $newton(
            j_over_h: V3<$name>,
            m: V3<$name>,
            xi: V3<$name>,
            threshold: $name,
            settings: &VariationalSettings,
        ) -> NewtonOut<$name, $n> {
            newton(j_over_h, m, xi, threshold, settings)
        }
    };
}
pair!(F64x4x2, F64x4, 8, 4, newton_avx2_pair, "avx2");
pair!(F64x8x2, F64x8, 16, 8, newton_avx512_pair, "avx512f");
