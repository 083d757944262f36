//! Lanes: N binary64 numbers computed together, one operation for all of them. The decoder's
//! batch kernel is written once over `Lanes<N>`: with N = 1 it is a single pair's scalar code,
//! with N = 4 or 8 the vector code the compiler makes of it. Every operation is applied lane by
//! lane in IEEE 754 binary64 (no fused multiply-add, no reassociation), so lane i of a wide
//! computation is bit for bit the one-lane computation of the same inputs: the batch gives the
//! same values whatever the vector width.
//!
//! [`Lanes::exp`] and [`Lanes::ln`] are written here rather than called from the C library,
//! whose scalar functions cannot be vectorised: the classic reductions with fdlibm's minimax
//! coefficients (Sun Microsystems' freely distributable `e_exp.c` and `e_log.c`, as in musl),
//! branch-free, within 1 ulp of the exact value (tested against the standard library below).

use std::ops::{Add, Div, Mul, Neg, Sub};

/// N binary64 lanes.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(transparent)]
pub struct Lanes<const N: usize>(pub [f64; N]);

/// A per-lane condition.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(transparent)]
pub struct Mask<const N: usize>(pub [bool; N]);

// One macro writes all four operators with the operator as a token: `*a = *a + b` rather
// than `*a += b`, so that `-` and `/` read the same as `+` and `*`.
macro_rules! lanewise {
    ($trait:ident, $f:ident, $op:tt) => {
        impl<const N: usize> $trait for Lanes<N> {
            type Output = Self;
            #[inline(always)]
            #[allow(clippy::assign_op_pattern)]
            fn $f(self, o: Self) -> Self {
                let mut r = self.0;
                for (a, b) in r.iter_mut().zip(o.0) {
                    *a = *a $op b;
                }
                Lanes(r)
            }
        }
        impl<const N: usize> $trait<f64> for Lanes<N> {
            type Output = Self;
            #[inline(always)]
            #[allow(clippy::assign_op_pattern)]
            fn $f(self, o: f64) -> Self {
                let mut r = self.0;
                for a in r.iter_mut() {
                    *a = *a $op o;
                }
                Lanes(r)
            }
        }
        impl<const N: usize> $trait<Lanes<N>> for f64 {
            type Output = Lanes<N>;
            #[inline(always)]
            #[allow(clippy::assign_op_pattern)]
            fn $f(self, o: Lanes<N>) -> Lanes<N> {
                let mut r = o.0;
                for a in r.iter_mut() {
                    *a = self $op *a;
                }
                Lanes(r)
            }
        }
    };
}

lanewise!(Add, add, +);
lanewise!(Sub, sub, -);
lanewise!(Mul, mul, *);
lanewise!(Div, div, /);

impl<const N: usize> Neg for Lanes<N> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        self.map(|a| -a)
    }
}

impl<const N: usize> Mask<N> {
    /// Lane-wise logical and.
    #[inline(always)]
    pub fn and(self, o: Self) -> Self {
        let mut r = self.0;
        for (a, b) in r.iter_mut().zip(o.0) {
            *a &= b;
        }
        Mask(r)
    }

    /// Lane-wise logical or.
    #[inline(always)]
    pub fn or(self, o: Self) -> Self {
        let mut r = self.0;
        for (a, b) in r.iter_mut().zip(o.0) {
            *a |= b;
        }
        Mask(r)
    }

    /// Whether every lane holds.
    #[inline(always)]
    pub fn all(self) -> bool {
        self.0.iter().all(|&a| a)
    }

    /// Whether any lane holds.
    #[inline(always)]
    pub fn any(self) -> bool {
        self.0.iter().any(|&a| a)
    }
}

/// 1.5·2⁵²: adding it rounds a binary64 of magnitude below 2⁵¹ to an integer, whose value the
/// sum's low bits then hold.
const ROUNDER: f64 = 6_755_399_441_055_744.0;
/// ln 2 split so that k·LN2_HI is exact for |k| < 2¹¹ (fdlibm's constants, digits as
/// published, here and in `exp` and `ln`).
#[allow(clippy::excessive_precision)]
const LN2_HI: f64 = 6.931_471_803_691_238_164_90e-01;
#[allow(clippy::excessive_precision)]
const LN2_LO: f64 = 1.908_214_929_270_587_700_02e-10;

/// The smaller of `a` and `b`, `a` where they compare unordered (NaN): one `minsd`. Where both
/// are numbers, `f64::min`'s value, without the NaN rules that cost it several instructions.
#[inline(always)]
pub fn min_or_first(a: f64, b: f64) -> f64 {
    if b < a {
        b
    } else {
        a
    }
}

/// The larger of `a` and `b`, `a` where they compare unordered (NaN): one `maxsd`.
#[inline(always)]
pub fn max_or_first(a: f64, b: f64) -> f64 {
    if b > a {
        b
    } else {
        a
    }
}

impl<const N: usize> Lanes<N> {
    /// Every lane set to `v`.
    #[inline(always)]
    pub fn splat(v: f64) -> Self {
        Lanes([v; N])
    }

    /// `f` applied to each lane.
    #[inline(always)]
    pub fn map(self, f: impl Fn(f64) -> f64) -> Self {
        let mut r = self.0;
        for a in r.iter_mut() {
            *a = f(*a);
        }
        Lanes(r)
    }

    #[inline(always)]
    fn zip(self, o: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        let mut r = self.0;
        for (a, b) in r.iter_mut().zip(o.0) {
            *a = f(*a, b);
        }
        Lanes(r)
    }

    #[inline(always)]
    fn test(self, o: Self, f: impl Fn(f64, f64) -> bool) -> Mask<N> {
        let mut r = [false; N];
        for ((m, a), b) in r.iter_mut().zip(self.0).zip(o.0) {
            *m = f(a, b);
        }
        Mask(r)
    }

    /// The square root of each lane (IEEE, correctly rounded).
    #[inline(always)]
    pub fn sqrt(self) -> Self {
        self.map(f64::sqrt)
    }

    /// The smaller per lane, `self` where they compare unordered (NaN): x86's `minpd`.
    #[inline(always)]
    pub fn min(self, o: Self) -> Self {
        self.zip(o, min_or_first)
    }

    /// The larger per lane, `self` where they compare unordered (NaN).
    #[inline(always)]
    pub fn max(self, o: Self) -> Self {
        self.zip(o, max_or_first)
    }

    /// Lanes where `self < o` (false where either is NaN).
    #[inline(always)]
    pub fn lt(self, o: Self) -> Mask<N> {
        self.test(o, |a, b| a < b)
    }

    /// Lanes where `self <= o` (false where either is NaN).
    #[inline(always)]
    pub fn le(self, o: Self) -> Mask<N> {
        self.test(o, |a, b| a <= b)
    }

    /// Lanes where `self > o` (false where either is NaN).
    #[inline(always)]
    pub fn gt(self, o: Self) -> Mask<N> {
        self.test(o, |a, b| a > b)
    }

    /// Lanes where `self >= o` (false where either is NaN).
    #[inline(always)]
    pub fn ge(self, o: Self) -> Mask<N> {
        self.test(o, |a, b| a >= b)
    }

    /// Lanes that are finite (neither infinite nor NaN).
    #[inline(always)]
    pub fn finite(self) -> Mask<N> {
        let mut r = [false; N];
        for (m, a) in r.iter_mut().zip(self.0) {
            *m = a.is_finite();
        }
        Mask(r)
    }

    /// `a` where `m` holds, else `b`.
    #[inline(always)]
    pub fn select(m: Mask<N>, a: Self, b: Self) -> Self {
        let mut r = b.0;
        for ((x, &c), y) in r.iter_mut().zip(&m.0).zip(a.0) {
            if c {
                *x = y;
            }
        }
        Lanes(r)
    }

    /// Lane-wise bits as an integer computation (`f` on the bits of each lane).
    #[inline(always)]
    fn bits(self, f: impl Fn(u64) -> u64) -> Self {
        self.map(|a| f64::from_bits(f(a.to_bits())))
    }

    /// eˣ within 1 ulp: x = k·ln 2 + r, |r| ≤ ln 2 / 2, eʳ from fdlibm's rational form, times 2ᵏ
    /// applied in two halves so that results down to the subnormal range round once. Below
    /// −745.2 it is 0, above 709.78 the largest finite value's neighbourhood (the decoder's
    /// arguments are far inside); NaN stays NaN.
    #[inline(always)]
    #[allow(clippy::excessive_precision)]
    pub fn exp(self) -> Self {
        const P1: f64 = 1.666_666_666_666_660_190_37e-01;
        const P2: f64 = -2.777_777_777_701_559_338_42e-03;
        const P3: f64 = 6.613_756_321_437_934_361_17e-05;
        const P4: f64 = -1.653_390_220_546_525_153_90e-06;
        const P5: f64 = 4.138_136_797_057_238_460_39e-08;
        let x = self.max(Lanes::splat(-745.2)).min(Lanes::splat(709.78));
        // k = round(x / ln 2): the rounder's sum holds k in its low bits.
        let t = x * std::f64::consts::LOG2_E + ROUNDER;
        let k = t - ROUNDER;
        let hi = x - k * LN2_HI;
        let lo = k * LN2_LO;
        let r = hi - lo;
        let z = r * r;
        let c = r - z * (P1 + z * (P2 + z * (P3 + z * (P4 + z * P5))));
        let y = 1.0 - ((lo - (r * c) / (2.0 - c)) - hi);
        // 2^k as 2^k1 · 2^k2, k1 = round(k/2) (each factor normal for |k| ≤ 1075).
        let t1 = k * 0.5 + ROUNDER;
        let bias = 1023u64.wrapping_sub(ROUNDER.to_bits());
        let s1 = t1.bits(|b| b.wrapping_add(bias) << 52);
        // k2 = k − k1, formed from the two sums' bits: t − t1 = k − k1 exactly.
        let t2 = t - (t1 - ROUNDER);
        let s2 = t2.bits(|b| b.wrapping_add(bias) << 52);
        let e = y * s1 * s2;
        Lanes::select(self.eq_self(), e, self)
    }

    /// ln x within 1 ulp for x > 0: x = 2ᵏ·m, √2/2 ≤ m < √2, ln m from fdlibm's series in
    /// s = (m − 1)/(m + 1). ln 0 = −∞, ln of a negative number or NaN is NaN, ln ∞ = ∞.
    #[inline(always)]
    #[allow(clippy::excessive_precision)]
    pub fn ln(self) -> Self {
        const LG1: f64 = 6.666_666_666_666_735_130e-01;
        const LG2: f64 = 3.999_999_999_940_941_908e-01;
        const LG3: f64 = 2.857_142_874_366_239_149e-01;
        const LG4: f64 = 2.222_219_843_214_978_396e-01;
        const LG5: f64 = 1.818_357_216_161_805_012e-01;
        const LG6: f64 = 1.531_383_769_920_937_332e-01;
        const LG7: f64 = 1.479_819_860_511_658_591e-01;
        /// The bits of √2/2 (rounded): mantissas from it upwards stay in the exponent below 1's.
        const SQRT_HALF: u64 = 0x3fe6_a09e_667f_3bcd;
        let normal = self.ge(Lanes::splat(f64::MIN_POSITIVE));
        // Subnormals scaled into the normal range first (2^54), their exponent corrected.
        let x = Lanes::select(normal, self, self * 18_014_398_509_481_984.0);
        let adjust = Lanes::select(normal, Lanes::splat(0.0), Lanes::splat(-54.0));
        let shifted = x.bits(|b| b.wrapping_add(0x3ff0_0000_0000_0000 - SQRT_HALF));
        // k: the shifted exponent as a binary64, through the bits of 2^52 + e (no integer
        // conversion instruction needed).
        let e = shifted.bits(|b| 0x4330_0000_0000_0000 | (b >> 52));
        let k = e - (4_503_599_627_370_496.0 + 1023.0) + adjust;
        let m = shifted.bits(|b| (b & 0x000f_ffff_ffff_ffff).wrapping_add(SQRT_HALF));
        let f = m - 1.0;
        let s = f / (2.0 + f);
        let z = s * s;
        let w = z * z;
        let t1 = w * (LG2 + w * (LG4 + w * LG6));
        let t2 = z * (LG1 + w * (LG3 + w * (LG5 + w * LG7)));
        let r = t2 + t1;
        let hfsq = 0.5 * f * f;
        let v = k * LN2_HI - ((hfsq - (s * (hfsq + r) + k * LN2_LO)) - f);
        // Outside (0, ∞): −∞ at 0, the input itself at ∞ and NaN, NaN below 0.
        let positive = self.gt(Lanes::splat(0.0)).and(self.finite());
        let zero = self.eq(Lanes::splat(0.0));
        let special = Lanes::select(
            zero,
            Lanes::splat(f64::NEG_INFINITY),
            Lanes::select(self.lt(Lanes::splat(0.0)), Lanes::splat(f64::NAN), self),
        );
        Lanes::select(positive, v, special)
    }

    /// Lanes where `self == o` (false where either is NaN).
    #[inline(always)]
    pub fn eq(self, o: Self) -> Mask<N> {
        self.test(o, |a, b| a == b)
    }

    /// Lanes that are not NaN.
    #[inline(always)]
    pub fn eq_self(self) -> Mask<N> {
        self.test(self, |a, b| a == b)
    }

    /// Each lane rounded to binary32 and back (what the format stores blended shapes as).
    #[inline(always)]
    pub fn round_f32(self) -> Self {
        self.map(|a| a as f32 as f64)
    }
}

/// What the lobe formulas (`model::lobes`) and the frame step need of a number: written once
/// over this trait, they are the scalar formulas for `f64` (the C library's `exp` and `ln`, the
/// standard `min` and `max`) and the batch kernel's for [`Lanes`] (this module's `exp` and `ln`,
/// x86's `minpd`), so the scalar paths and the kernel share one text of each formula while each
/// keeps the bits it had.
pub trait Real:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Add<f64, Output = Self>
    + Sub<f64, Output = Self>
    + Mul<f64, Output = Self>
    + Div<f64, Output = Self>
{
    /// A condition per lane (`bool` for one number).
    type Mask: Copy;
    /// `v` in every lane.
    fn splat(v: f64) -> Self;
    /// The square root (IEEE, correctly rounded).
    fn sqrt(self) -> Self;
    /// The smaller of the two.
    fn min(self, o: Self) -> Self;
    /// The larger of the two.
    fn max(self, o: Self) -> Self;
    /// eˣ.
    fn exp(self) -> Self;
    /// ln x.
    fn ln(self) -> Self;
    /// Where `self > o`.
    fn gt(self, o: Self) -> Self::Mask;
    /// Where `self >= o`.
    fn ge(self, o: Self) -> Self::Mask;
    /// Where finite.
    fn finite(self) -> Self::Mask;
    /// Where both hold.
    fn and(a: Self::Mask, b: Self::Mask) -> Self::Mask;
    /// `a` where `m` holds, else `b`.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// `a()` where `m` holds, else `b`: one number computes `a()` only where it is needed (a
    /// scalar `exp` and `ln` are calls worth skipping), lanes compute it for all and select.
    fn select_with(m: Self::Mask, a: impl FnOnce() -> Self, b: Self) -> Self;
    /// Rounded to the nearest binary32 and back (what the format stores blended shapes as).
    fn round_f32(self) -> Self;
}

impl Real for f64 {
    type Mask = bool;
    #[inline(always)]
    fn splat(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        f64::min(self, o)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        f64::max(self, o)
    }
    #[inline(always)]
    fn exp(self) -> Self {
        f64::exp(self)
    }
    #[inline(always)]
    fn ln(self) -> Self {
        f64::ln(self)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> bool {
        self > o
    }
    #[inline(always)]
    fn ge(self, o: Self) -> bool {
        self >= o
    }
    #[inline(always)]
    fn finite(self) -> bool {
        self.is_finite()
    }
    #[inline(always)]
    fn and(a: bool, b: bool) -> bool {
        a && b
    }
    #[inline(always)]
    fn select(m: bool, a: Self, b: Self) -> Self {
        if m {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn select_with(m: bool, a: impl FnOnce() -> Self, b: Self) -> Self {
        if m {
            a()
        } else {
            b
        }
    }
    #[inline(always)]
    fn round_f32(self) -> Self {
        self as f32 as f64
    }
}

impl<const N: usize> Real for Lanes<N> {
    type Mask = Mask<N>;
    #[inline(always)]
    fn splat(v: f64) -> Self {
        Lanes::splat(v)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        Lanes::sqrt(self)
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        Lanes::min(self, o)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        Lanes::max(self, o)
    }
    #[inline(always)]
    fn exp(self) -> Self {
        Lanes::exp(self)
    }
    #[inline(always)]
    fn ln(self) -> Self {
        Lanes::ln(self)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Mask<N> {
        Lanes::gt(self, o)
    }
    #[inline(always)]
    fn ge(self, o: Self) -> Mask<N> {
        Lanes::ge(self, o)
    }
    #[inline(always)]
    fn finite(self) -> Mask<N> {
        Lanes::finite(self)
    }
    #[inline(always)]
    fn and(a: Mask<N>, b: Mask<N>) -> Mask<N> {
        a.and(b)
    }
    #[inline(always)]
    fn select(m: Mask<N>, a: Self, b: Self) -> Self {
        Lanes::select(m, a, b)
    }
    #[inline(always)]
    fn select_with(m: Mask<N>, a: impl FnOnce() -> Self, b: Self) -> Self {
        Lanes::select(m, a(), b)
    }
    #[inline(always)]
    fn round_f32(self) -> Self {
        Lanes::round_f32(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in units in the last place between two finite binary64 values of one sign.
    fn ulps(a: f64, b: f64) -> u64 {
        (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs()
    }

    /// A deterministic spread of test points: xorshift bits mapped into [lo, hi].
    fn points(lo: f64, hi: f64, n: usize) -> Vec<f64> {
        let mut s = 0x9E37_79B9_7F4A_7C15u64;
        (0..n)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                lo + (hi - lo) * ((s >> 11) as f64 / (1u64 << 53) as f64)
            })
            .collect()
    }

    #[test]
    fn exp_is_within_one_ulp_of_the_standard_library() {
        let mut worst = 0;
        for range in [(-1.0, 1.0), (-40.0, 40.0), (-700.0, 700.0), (-1e-6, 1e-6)] {
            for x in points(range.0, range.1, 200_000) {
                let got = Lanes([x]).exp().0[0];
                worst = worst.max(ulps(got, x.exp()));
            }
        }
        assert!(worst <= 1, "exp: {worst} ulp");
        assert_eq!(Lanes([0.0]).exp().0[0], 1.0);
        assert_eq!(Lanes([-800.0]).exp().0[0], 0.0);
        assert!(Lanes([f64::NAN]).exp().0[0].is_nan());
        // The subnormal range rounds once: within 1 ulp of a subnormal is absolute 5e-324.
        for x in points(-745.0, -708.5, 20_000) {
            let (got, want) = (Lanes([x]).exp().0[0], x.exp());
            assert!((got - want).abs() <= 5e-324, "{x}: {got:e} {want:e}");
        }
    }

    #[test]
    fn ln_is_within_one_ulp_of_the_standard_library() {
        let mut worst = 0;
        for range in [(0.5, 2.0), (1e-300, 1e-290), (1.0, 1e7), (0.999, 1.001)] {
            for x in points(range.0, range.1, 200_000) {
                let got = Lanes([x]).ln().0[0];
                worst = worst.max(ulps(got, x.ln()));
            }
        }
        assert!(worst <= 1, "ln: {worst} ulp");
        for x in [1e-310, 4.9e-324, f64::MIN_POSITIVE, f64::MAX] {
            let got = Lanes([x]).ln().0[0];
            assert!(ulps(got, x.ln()) <= 1, "{x:e}: {got} {}", x.ln());
        }
        assert_eq!(Lanes([1.0]).ln().0[0], 0.0);
        assert_eq!(Lanes([0.0]).ln().0[0], f64::NEG_INFINITY);
        assert_eq!(Lanes([f64::INFINITY]).ln().0[0], f64::INFINITY);
        assert!(Lanes([-1.0]).ln().0[0].is_nan());
        assert!(Lanes([f64::NAN]).ln().0[0].is_nan());
    }

    /// Lane i of a four-lane computation is the one-lane computation, bit for bit.
    #[test]
    fn wide_lanes_are_the_narrow_computation() {
        let xs = points(-30.0, 30.0, 4000);
        for c in xs.chunks_exact(4) {
            let wide = Lanes([c[0], c[1], c[2], c[3]]);
            let e = wide.exp();
            let l = (wide * wide + 1e-3).ln();
            for (i, &x) in c.iter().enumerate() {
                assert_eq!(e.0[i].to_bits(), Lanes([x]).exp().0[0].to_bits());
                let one = (Lanes([x]) * Lanes([x]) + 1e-3).ln();
                assert_eq!(l.0[i].to_bits(), one.0[0].to_bits());
            }
        }
    }
}
