//! y^c for the baked view's lobes (a microfacet lobe's D = (1 + b·x)^(−c), a cosine power's
//! g^n) as exp(c·ln y), with `ln` and `exp` written out for that use rather than called from
//! the C library: every value they meet is ordinary (y a positive normal number, |c·ln y| <
//! 700), so the library's checks for the others, its error reporting and the call itself
//! (which may overwrite every vector register, so a query's live values are stored around it)
//! are work a query need not do, and a view is held to a tolerance (10⁻⁴ at the smallest), not
//! to the last bit. The others go to the library. Both are the usual table-driven reductions,
//! with short polynomials whose terms are paired (Estrin's scheme) so that a query waits on
//! few products in a row:
//!
//! - ln y = e·ln 2 − ln c_i + ln(1 + r), y = 2^e·m with m ∈ [1, 2), c_i the centre of m's
//!   1/256th of [1, 2) held as its reciprocal's rounding (r = m/c_i − 1 from one product, |r| <
//!   2⁻⁹), ln(1 + r) by its Taylor polynomial of degree 4: within 6·10⁻¹⁵ (absolute) of ln y;
//! - exp z = 2^(k/128)·e^r, k the integer nearest 128·z/ln 2, 2^(k/128) = 2^⌊k/128⌋·2^(j/128)
//!   from a table of 128 (j = k mod 128), |r| ≤ ln 2/256, e^r by its Taylor polynomial of
//!   degree 4: within 2·10⁻¹⁵ relative of e^z, plus the |z|·2⁻⁵³ that rounding z costs.
//!
//! So y^c is within |c|·6·10⁻¹⁵ + 2·10⁻¹⁵ + |c·ln y|·2⁻⁵² relative of exp(c·ln y), what the
//! tests hold it to; for D's exponents (c of a few) and a cosine power's (n up to 10⁴, say),
//! under 10⁻¹⁰. The tables are the standard library's `ln` and `exp2` at their nodes, made once
//! per process.

use std::sync::OnceLock;

/// Bits of m's fraction that pick ln's table entry (2^8 = 256 entries).
const LN_BITS: u32 = 8;
const LN_SIZE: usize = 1 << LN_BITS;
/// Bits of k that pick exp's table entry (2^7 = 128 entries).
const EXP_BITS: u32 = 7;
const EXP_SIZE: usize = 1 << EXP_BITS;

/// 1.5·2⁵²: adding it rounds a number below 2⁵¹ in magnitude to an integer, which the low bits
/// of the sum's representation then hold (two's complement).
const ROUND_SHIFT: f64 = 6_755_399_441_055_744.0;

/// The tables of [`Power`]: for ln, each 1/256th of [1, 2)'s centre's reciprocal (rounded) and
/// minus its logarithm; for exp, 2^(j/128) as bits.
#[derive(Debug)]
pub(crate) struct Power {
    inv_centre: [f64; LN_SIZE],
    neg_ln_inv_centre: [f64; LN_SIZE],
    exp2_bits: [u64; EXP_SIZE],
}

impl Power {
    /// The process's tables (made on first use).
    pub(crate) fn tables() -> &'static Power {
        static TABLES: OnceLock<Power> = OnceLock::new();
        TABLES.get_or_init(|| {
            let mut p = Power {
                inv_centre: [0.0; LN_SIZE],
                neg_ln_inv_centre: [0.0; LN_SIZE],
                exp2_bits: [0; EXP_SIZE],
            };
            for i in 0..LN_SIZE {
                let inv = 1.0 / (1.0 + (i as f64 + 0.5) / LN_SIZE as f64);
                p.inv_centre[i] = inv;
                p.neg_ln_inv_centre[i] = -inv.ln();
            }
            for (j, bits) in p.exp2_bits.iter_mut().enumerate() {
                *bits = (j as f64 / EXP_SIZE as f64).exp2().to_bits();
            }
            p
        })
    }

    /// y^c = exp(c·ln y) (y > 0; for y ≤ 0 or not a number, what the library's exp(c·ln y)
    /// gives).
    #[inline(always)]
    pub(crate) fn pow(&self, y: f64, c: f64) -> f64 {
        self.exp(c * self.ln(y))
    }

    /// ln y: the tables' where y is a positive normal number, the library's elsewhere.
    #[inline(always)]
    pub(crate) fn ln(&self, y: f64) -> f64 {
        const MIN_NORMAL: u64 = 1 << 52;
        const INFINITY: u64 = 0x7ff0_0000_0000_0000;
        let bits = y.to_bits();
        // Sign clear, exponent field 1..=2046: one unsigned comparison.
        if bits.wrapping_sub(MIN_NORMAL) >= INFINITY - MIN_NORMAL {
            return library_ln(y);
        }
        let e = (bits >> 52) as i64 - 1023;
        let i = (bits >> (52 - LN_BITS)) as usize & (LN_SIZE - 1);
        let m = f64::from_bits((bits & (MIN_NORMAL - 1)) | (1023 << 52));
        // m·(1/c_i) within 2⁻⁹ of 1: the subtraction is exact.
        let r = m * self.inv_centre[i] - 1.0;
        // ln(1 + r) ≈ r − r²/2 + r³/3 − r⁴/4, its terms paired (Estrin) so that the sum waits
        // on three products in a row, not four.
        let r2 = r * r;
        let poly = r + r2 * ((r * (1.0 / 3.0) - 0.5) + r2 * -0.25);
        e as f64 * std::f64::consts::LN_2 + (self.neg_ln_inv_centre[i] + poly)
    }

    /// e^z: the tables' where |z| < 700, the library's elsewhere (overflow, underflow to
    /// subnormals, not a number).
    #[inline(always)]
    pub(crate) fn exp(&self, z: f64) -> f64 {
        if !(z > -700.0 && z < 700.0) {
            return library_exp(z);
        }
        let scale = EXP_SIZE as f64 / std::f64::consts::LN_2;
        let shifted = z * scale + ROUND_SHIFT;
        // |k| < 128·700/ln 2 < 2^17: its low 32 bits are k (two's complement).
        let k = shifted.to_bits() as u32 as i32;
        let kd = shifted - ROUND_SHIFT;
        // One product: its rounding, |z|·2⁻⁵³ at most, is what z's own rounding costs exp.
        let r = z - kd * (std::f64::consts::LN_2 / EXP_SIZE as f64);
        let j = k as usize & (EXP_SIZE - 1);
        // 2^⌊k/128⌋ added to 2^(j/128)'s exponent field: ⌊k/128⌋ ≥ −1010, a normal number.
        let whole = ((k >> EXP_BITS) as i64 as u64) << 52;
        let two = f64::from_bits(self.exp2_bits[j].wrapping_add(whole));
        // e^r ≈ 1 + r + r²/2 + r³/6 + r⁴/24, paired as ln's.
        let r2 = r * r;
        let poly = (1.0 + r) + r2 * ((0.5 + r * (1.0 / 6.0)) + r2 * (1.0 / 24.0));
        two * poly
    }
}

/// The library's ln, out of the way of the common path.
#[cold]
#[inline(never)]
fn library_ln(y: f64) -> f64 {
    y.ln()
}

/// The library's exp, out of the way of the common path.
#[cold]
#[inline(never)]
fn library_exp(z: f64) -> f64 {
    z.exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Relative distance of `a` from `b`.
    fn rel(a: f64, b: f64) -> f64 {
        ((a - b) / b).abs()
    }

    #[test]
    fn ln_agrees_with_the_library_over_every_binade() {
        let p = Power::tables();
        let mut worst = 0.0f64;
        // y from 2^-1021 to 2^1023 through every table entry; near 1, where ln y is small.
        let mut y = f64::MIN_POSITIVE * 1.000_123;
        while y < f64::MAX / 1.01 {
            let (a, b) = (p.ln(y), y.ln());
            // Absolute: ln's own conditioning is absolute (ln(y(1 + ε)) = ln y + ε).
            worst = worst.max((a - b).abs() / b.abs().max(1.0));
            y *= 1.003_17;
        }
        for d in [1e-15, 1e-12, 1e-9, 1e-6, 1e-3] {
            for y in [1.0 + d, 1.0 - d, 1.0] {
                worst = worst.max((p.ln(y) - y.ln()).abs());
            }
        }
        // The polynomial's truncation, |r|⁵/5 ≤ 2⁻⁴⁵/5 = 5.7·10⁻¹⁵, and roundings.
        assert!(worst < 6e-15, "worst {worst:e}");
    }

    #[test]
    fn exp_agrees_with_the_library_over_its_range() {
        let p = Power::tables();
        let mut worst = 0.0f64;
        let mut z = -699.99;
        while z < 699.99 {
            // Truncation (ln 2/256)⁵/120 = 1.2·10⁻¹⁵, roundings, and z's own: |z|·2⁻⁵³ for
            // each of the two exps.
            let e = rel(p.exp(z), z.exp());
            assert!(e <= 2e-15 + z.abs() * f64::EPSILON, "e^{z}: {e:e}");
            worst = worst.max(e);
            z += 0.012_345_678_9;
        }
        for z in [
            0.0,
            -0.0,
            1e-300,
            -1e-20,
            1e-10,
            0.5 * std::f64::consts::LN_2,
        ] {
            worst = worst.max(rel(p.exp(z), z.exp()));
        }
        assert!(worst > 1e-16 && worst < 2e-13, "worst {worst:e}");
    }

    #[test]
    fn the_power_agrees_with_exp_of_ln_and_the_rest_go_to_the_library() {
        let p = Power::tables();
        let mut worst = 0.0f64;
        for i in 0..4000 {
            // D's arguments 1 + b·x and a cosine power's g ∈ (0, 1], exponents both signs.
            let y = 10f64.powf(-6.0 + 12.0 * (i as f64 * 0.618_033_988_749_895).fract());
            let c = -60.0 + 120.0 * (i as f64 * 0.754_877_666_246_693).fract();
            let exact = (c * y.ln()).exp();
            if exact.is_normal() && (c * y.ln()).abs() < 690.0 {
                // The bound of this module's header, twice exp's share of rounding z.
                let slack = c.abs() * 6e-15 + 2e-15 + 2.0 * (c * y.ln()).abs() * f64::EPSILON;
                let e = rel(p.pow(y, c), exact);
                assert!(e <= slack, "{y}^{c}: {e:e}");
                worst = worst.max(e);
            }
        }
        assert!(worst > 0.0);
        // A subnormal y: the library's ln, then the tables' exp.
        let e = rel(p.pow(1e-310, 0.5), (0.5 * 1e-310f64.ln()).exp());
        assert!(e < 1e-13, "{e:e}");
        // Outside: the library's values, bit for bit (NaN as NaN).
        for y in [0.0, -0.0, -1.0, f64::INFINITY, f64::NAN] {
            for c in [-2.0, 0.5, 3.0] {
                let (a, b) = (p.pow(y, c), (c * y.ln()).exp());
                assert!(a == b || (a.is_nan() && b.is_nan()), "{y}^{c}: {a} vs {b}");
            }
        }
        for z in [
            -800.0,
            -700.0,
            700.0,
            710.0,
            f64::NEG_INFINITY,
            f64::INFINITY,
        ] {
            assert_eq!(p.exp(z), z.exp());
        }
        assert!(p.exp(f64::NAN).is_nan());
    }
}
