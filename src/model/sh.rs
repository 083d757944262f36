//! Real spherical harmonics, orthonormal on the sphere, evaluated from Cartesian coordinates.
//!
//! Convention (normative text: `spec/EVALUATION.md`, section "Spherical harmonics"):
//! index j = l(l+1) + m for level l = 0..=L and order m = −l..=l, so there are (L+1)² functions;
//! Y_l^0 = K_l^0 P_l^0(z), Y_l^m = √2 K_l^m P_l^m(z) cos(mφ) for m > 0 and
//! Y_l^m = √2 K_l^|m| P_l^|m|(z) sin(|m|φ) for m < 0, with
//! K_l^m = √((2l+1)/(4π) · (l−m)!/(l+m)!) and P_l^m the associated Legendre function *without* the
//! Condon–Shortley phase. Evaluating sin^m θ·cos(mφ) as Re((x+iy)^m) avoids angles, so the poles
//! and the horizon need no special case.

use crate::model::lanes::Lanes;

/// The highest SH level the format allows (keeps (L+1)² and the normalisation well inside f64).
pub const MAX_SH_LEVEL: usize = 20;

/// Number of coefficients for level L.
pub const fn sh_count(level: usize) -> usize {
    (level + 1) * (level + 1)
}

/// Length of the normalisation and recurrence tables for level L: one entry per (l, m ≥ 0).
pub const fn table_len(level: usize) -> usize {
    (level + 1) * (level + 2) / 2
}

/// The highest level whose functions fit in `count` values.
pub const fn level_of(count: usize) -> usize {
    let mut l = 0;
    while sh_count(l + 1) <= count {
        l += 1;
    }
    l
}

/// Y_0^0 = 1/√(4π), the one level-0 function, bit for bit the value [`ShBasis::constant`]
/// computes (a unit test checks it): a constant, so that decoders need not hold a copy.
pub const Y00: f64 = 0.282_094_791_773_878_14;

/// Precomputed normalisation constants for one maximum level.
#[derive(Debug, Clone)]
pub struct ShBasis {
    level: usize,
    /// K_l^m for m ≥ 0, times √2 where m > 0, indexed by l(l+1)/2 + m.
    norm: Vec<f64>,
    /// The recurrence's ratios (2l − 1)/(l − m) and (l + m − 1)/(l − m), same index (used for
    /// l ≥ m + 2): a multiplication where the recurrence divides, for speed.
    ratio: Vec<[f64; 2]>,
}

impl ShBasis {
    /// Panics if `level > MAX_SH_LEVEL`; callers validate levels read from files first.
    pub fn new(level: usize) -> Self {
        assert!(
            level <= MAX_SH_LEVEL,
            "SH level {level} above {MAX_SH_LEVEL}"
        );
        let mut norm = Vec::with_capacity(table_len(level));
        for l in 0..=level {
            for m in 0..=l {
                // (l−m)!/(l+m)! as a product, which cannot overflow for l ≤ 20.
                let mut ratio = 1.0f64;
                for t in (l - m + 1)..=(l + m) {
                    ratio /= t as f64;
                }
                let k = ((2 * l + 1) as f64 / (4.0 * std::f64::consts::PI) * ratio).sqrt();
                norm.push(if m == 0 {
                    k
                } else {
                    k * std::f64::consts::SQRT_2
                });
            }
        }
        let mut ratio = Vec::with_capacity(norm.len());
        for l in 0..=level {
            for m in 0..=l {
                ratio.push(if l >= m + 2 {
                    let d = (l - m) as f64;
                    [(2 * l - 1) as f64 / d, (l + m - 1) as f64 / d]
                } else {
                    [0.0; 2]
                });
            }
        }
        ShBasis { level, norm, ratio }
    }

    /// The basis of every level the format allows, built once per process and shared: what the
    /// decoder evaluates with (a per-material copy would cost more than many a record).
    pub fn shared() -> &'static ShBasis {
        static ALL: std::sync::OnceLock<ShBasis> = std::sync::OnceLock::new();
        ALL.get_or_init(|| ShBasis::new(MAX_SH_LEVEL))
    }

    /// The highest SH level this basis evaluates.
    pub fn level(&self) -> usize {
        self.level
    }

    /// The number of functions it evaluates, (level + 1)².
    pub fn count(&self) -> usize {
        sh_count(self.level)
    }

    /// Evaluates every Y_j at the unit vector `d` into `out[..count()]`. `d` must be unit length
    /// (callers normalise); a non-unit vector gives a scaled, meaningless result.
    pub fn eval(&self, d: [f64; 3], out: &mut [f64]) {
        self.eval_to_level(self.level, d, out)
    }

    /// Y_0^0, the one level-0 function (a constant), exactly as [`ShBasis::eval_to_level`]
    /// gives it.
    #[inline(always)]
    pub fn constant(&self) -> f64 {
        self.norm[0]
    }

    /// [`ShBasis::eval`] for the functions up to `level` (≤ the basis's level) only.
    #[inline(always)]
    pub fn eval_to_level(&self, level: usize, d: [f64; 3], out: &mut [f64]) {
        let level = level.min(self.level);
        let out = &mut out[..sh_count(level)];
        self.eval_lanes(level, d.map(|c| Lanes([c])), |j, v| out[j] = v.0[0]);
    }

    /// The functions up to `level` (≤ the basis's level) at N unit vectors at once (lane i of
    /// each coordinate is vector i): `put(j, Y_j)` for j < (level + 1)². Lane i is bit for bit
    /// what [`ShBasis::eval_to_level`] gives for vector i (it is this computation, one lane).
    #[inline(always)]
    pub fn eval_lanes<const N: usize>(
        &self,
        level: usize,
        d: [Lanes<N>; 3],
        put: impl FnMut(usize, Lanes<N>),
    ) {
        let level = level.min(self.level);
        recurrence(&self.norm, &self.ratio, level, d, put)
    }

    /// [`ShBasis::eval_lanes`] at the level `L` fixed when compiling (≤ the basis's level;
    /// a higher one gives nothing): the same operations, so the same bits, with the loops'
    /// bounds and the tables' indices known, so that the compiler unrolls them. `NT` must be
    /// [`table_len`]`(L)`. The decoder's kernel evaluates its
    /// groups through this.
    #[inline(always)]
    pub fn eval_lanes_fixed<const N: usize, const L: usize, const NT: usize>(
        &self,
        d: [Lanes<N>; 3],
        put: impl FnMut(usize, Lanes<N>),
    ) {
        debug_assert_eq!(NT, table_len(L));
        let norm: Option<&[f64; NT]> = self.norm.get(..NT).and_then(|t| t.try_into().ok());
        let ratio: Option<&[[f64; 2]; NT]> = self.ratio.get(..NT).and_then(|t| t.try_into().ok());
        if let (Some(norm), Some(ratio)) = (norm, ratio) {
            recurrence(norm, ratio, L, d, put)
        }
    }
}

/// The recurrence of [`ShBasis::eval_lanes`] over the tables `norm` and `ratio` (at least
/// (level + 1)(level + 2)/2 each).
#[inline(always)]
fn recurrence<const N: usize>(
    norm: &[f64],
    ratio: &[[f64; 2]],
    level: usize,
    d: [Lanes<N>; 3],
    mut put: impl FnMut(usize, Lanes<N>),
) {
    let [x, y, z] = d;
    // Y_l^{±m} from Q_l^m: K·Q for m = 0, K·Q·Re, K·Q·Im of (x + iy)^m otherwise.
    let mut put = |m: usize, tri: usize, centre: usize, q: Lanes<N>, cm, sm| {
        let kq = norm[tri] * q;
        if m == 0 {
            put(centre, kq);
        } else {
            put(centre + m, kq * cm);
            put(centre - m, kq * sm);
        }
    };
    // (x + iy)^m, advanced one m at a time.
    let (mut cm, mut sm) = (Lanes::splat(1.0), Lanes::splat(0.0));
    // Q_m^m = (2m−1)!!, the polynomial part of P_m^m / sin^m θ.
    let mut qmm = 1.0f64;
    for m in 0..level + 1 {
        if m > 0 {
            let (c, s) = (cm * x - sm * y, cm * y + sm * x);
            cm = c;
            sm = s;
            qmm *= (2 * m - 1) as f64;
        }
        // Indices advanced by addition: l(l+1)/2 + m into the tables, l(l+1) into `out`.
        let (mut tri, mut centre) = (m * (m + 1) / 2 + m, m * (m + 1));
        put(m, tri, centre, Lanes::splat(qmm), cm, sm);
        if m == level {
            break;
        }
        // Q_{m+1}^m = (2m+1)·z·Q_m^m, then the upward recurrence in l.
        let mut q_prev = Lanes::splat(qmm);
        let mut q = (2 * m + 1) as f64 * z * qmm;
        tri += m + 1;
        centre += 2 * (m + 1);
        put(m, tri, centre, q, cm, sm);
        for l in m + 2..level + 1 {
            tri += l;
            centre += 2 * l;
            let [a, b] = ratio[tri];
            let next = a * z * q - b * q_prev;
            q_prev = q;
            q = next;
            put(m, tri, centre, q, cm, sm);
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn y00_is_the_computed_constant_bit_for_bit() {
        assert_eq!(
            super::Y00.to_bits(),
            super::ShBasis::shared().constant().to_bits()
        );
        assert_eq!(
            super::Y00.to_bits(),
            super::ShBasis::new(0).constant().to_bits()
        );
    }

    use super::*;

    /// The recurrence with its indices computed from (l, m) at every step, as first written:
    /// `eval_to_level` advances them by addition and must give the same bits.
    fn eval_indexed(b: &ShBasis, level: usize, d: [f64; 3], out: &mut [f64]) {
        let [x, y, z] = d;
        let (mut cm, mut sm) = (1.0f64, 0.0f64);
        let mut qmm = 1.0f64;
        for m in 0..=level {
            if m > 0 {
                let (c, s) = (cm * x - sm * y, cm * y + sm * x);
                cm = c;
                sm = s;
                qmm *= (2 * m - 1) as f64;
            }
            let mut q_prev = 0.0f64;
            let mut q = qmm;
            for l in m..=level {
                if l == m + 1 {
                    q_prev = q;
                    q = (2 * m + 1) as f64 * z * qmm;
                } else if l > m + 1 {
                    let [a, bb] = b.ratio[l * (l + 1) / 2 + m];
                    let next = a * z * q - bb * q_prev;
                    q_prev = q;
                    q = next;
                }
                let k = b.norm[l * (l + 1) / 2 + m];
                let centre = l * (l + 1);
                if m == 0 {
                    out[centre] = k * q;
                } else {
                    out[centre + m] = k * q * cm;
                    out[centre - m] = k * q * sm;
                }
            }
        }
    }

    #[test]
    fn eval_to_level_is_the_indexed_recurrence_bit_for_bit() {
        let b = ShBasis::shared();
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..2000 {
            let d = dir_from_deg(90.0 * next(), 360.0 * next());
            for level in 0..=MAX_SH_LEVEL {
                let n = sh_count(level);
                let (mut got, mut want) = (vec![f64::NAN; n], vec![f64::NAN; n]);
                b.eval_to_level(level, d, &mut got);
                eval_indexed(b, level, d, &mut want);
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&got), bits(&want), "level {level} at {d:?}");
            }
        }
    }
    use crate::model::angles::dir_from_deg;
    use std::f64::consts::PI;

    /// Closed forms for l ≤ 2 written out independently of the recurrence.
    fn closed_form(d: [f64; 3]) -> [f64; 9] {
        let [x, y, z] = d;
        let c0 = 0.5 * (1.0 / PI).sqrt();
        let c1 = (3.0 / (4.0 * PI)).sqrt();
        let c2 = 0.5 * (15.0 / PI).sqrt();
        let c20 = 0.25 * (5.0 / PI).sqrt();
        [
            c0,
            c1 * y,
            c1 * z,
            c1 * x,
            c2 * x * y,
            c2 * y * z,
            c20 * (3.0 * z * z - 1.0),
            c2 * x * z,
            0.5 * c2 * (x * x - y * y),
        ]
    }

    #[test]
    fn matches_closed_forms() {
        let b = ShBasis::new(2);
        let mut out = [0.0; 9];
        for &(t, p) in &[(0.0, 0.0), (37.0, 12.0), (90.0, 200.0), (63.0, 300.0)] {
            let d = dir_from_deg(t, p);
            b.eval(d, &mut out);
            let want = closed_form(d);
            for j in 0..9 {
                assert!(
                    (out[j] - want[j]).abs() < 1e-14,
                    "j={j} {} {}",
                    out[j],
                    want[j]
                );
            }
        }
    }

    #[test]
    fn orthonormal_on_the_sphere() {
        // Gauss–Legendre would be exact; a fine midpoint grid is accurate to ~1e-6 here.
        let level = 6;
        let b = ShBasis::new(level);
        let n = b.count();
        let mut gram = vec![0.0; n * n];
        let (nt, np) = (400, 800);
        let mut y = vec![0.0; n];
        for i in 0..nt {
            let t = (i as f64 + 0.5) * PI / nt as f64;
            let w = t.sin() * (PI / nt as f64) * (2.0 * PI / np as f64);
            for k in 0..np {
                let p = (k as f64 + 0.5) * 2.0 * PI / np as f64;
                b.eval([t.sin() * p.cos(), t.sin() * p.sin(), t.cos()], &mut y);
                for a in 0..n {
                    for c in 0..n {
                        gram[a * n + c] += w * y[a] * y[c];
                    }
                }
            }
        }
        for a in 0..n {
            for c in 0..n {
                let want = if a == c { 1.0 } else { 0.0 };
                assert!(
                    (gram[a * n + c] - want).abs() < 1e-4,
                    "{a},{c}: {}",
                    gram[a * n + c]
                );
            }
        }
    }

    #[test]
    fn finite_at_highest_level_everywhere() {
        let b = ShBasis::new(MAX_SH_LEVEL);
        let mut out = vec![0.0; b.count()];
        for &(t, p) in &[(0.0, 0.0), (90.0, 0.0), (180.0, 0.0), (45.0, 45.0)] {
            b.eval(dir_from_deg(t, p), &mut out);
            assert!(out.iter().all(|v| v.is_finite()));
        }
    }
}
