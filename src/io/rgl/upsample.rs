//! RGB → spectrum by Jakob & Hanika 2019 ("A Low-Dimensional Function Space for Efficient
//! Spectral Upsampling", Computer Graphics Forum 38(2)): s(λ) = k·S(c0 t² + c1 t + c2) with
//! S(x) = ½ + x/(2√(1 + x²)) and t = (λ − 380)/(780 − 380), its three coefficients fitted so
//! that the spectrum's linear sRGB under D65 — computed exactly as the decoder's
//! [`crate::decode::color`] computes it (CIE 1931 2°, 380–780 nm every 5 nm) — reproduces the
//! target colour.

use super::tensor::{Result, RglError};
use super::warp::lerp;
use crate::decode::color::{spectrum_to_xyz, xyz_to_linear_srgb, Illuminant, CIE_WAVELENGTHS};

/// The number of CIE table wavelengths (380–780 nm every 5 nm).
const N: usize = CIE_WAVELENGTHS.len();

/// Linear sRGB under D65 of a spectrum given at [`CIE_WAVELENGTHS`]: the decoder's own
/// conversion ([`crate::decode::color`]), so that what the upsampler fits is exactly what
/// `Decoder::eval_linear_srgb` gives back.
pub fn spectrum_to_linear_srgb(s: &[f64]) -> [f64; 3] {
    let mut a = [0.0f32; N];
    for (x, v) in a.iter_mut().zip(s) {
        *x = *v as f32;
    }
    xyz_to_linear_srgb(spectrum_to_xyz(&a, Illuminant::D65))
}

/// s(λ) = scale · S(c0 t² + c1 t + c2), t = (λ − λ0)/(λ1 − λ0), S(x) = ½ + x/(2√(1+x²)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SigmoidSpectrum {
    /// The factor k in front of the sigmoid: 0 ≤ s(λ) ≤ k.
    pub scale: f64,
    /// The polynomial's coefficients c0, c1, c2.
    pub coeffs: [f64; 3],
    /// λ0, λ1 (nm) of the normalisation of t.
    pub range_nm: [f64; 2],
}

fn sigmoid(x: f64) -> f64 {
    if x.is_infinite() {
        return if x > 0.0 { 1.0 } else { 0.0 };
    }
    0.5 + 0.5 * x / (1.0 + x * x).sqrt()
}

impl SigmoidSpectrum {
    /// s(λ) at `nm` nanometres.
    pub fn eval(&self, nm: f64) -> f64 {
        let t = (nm - self.range_nm[0]) / (self.range_nm[1] - self.range_nm[0]);
        let [c0, c1, c2] = self.coeffs;
        self.scale * sigmoid((c0 * t + c1) * t + c2)
    }
}

/// A fitted spectrum and how well it reproduces its target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fit {
    /// The fitted spectrum.
    pub spectrum: SigmoidSpectrum,
    /// The colour fitted (the input with negative components set to 0).
    pub target: [f64; 3],
    /// The spectrum's own linear sRGB.
    pub rgb: [f64; 3],
    /// max |rgb − target| / max(target) (0 for black).
    pub rel_error: f64,
    /// True when a negative input component was set to 0.
    pub clamped: bool,
}

/// Jakob & Hanika 2019 spectral upsampling against the decoder's colour conversion: the 3
/// coefficients are found by damped Gauss–Newton (Levenberg–Marquardt) on the linear-sRGB
/// residual.
#[derive(Debug, Clone)]
pub struct Upsampler {
    /// Per wavelength: the linear-sRGB weights of a unit spectrum sample.
    w: Vec<[f64; 3]>,
    t: Vec<f64>,
    /// Per wavelength, what [`Upsampler::rgb_jac`] multiplies: the weights spread over its 12
    /// sums (the 9 Jacobian entries k·3 + j, then the 3 colours) and the polynomial's
    /// derivatives [t², t, 1] spread the same way (1 for the colours).
    lanes: Vec<([f64; 12], [f64; 12])>,
    range: [f64; 2],
    /// Largest accepted relative error.
    pub tolerance: f64,
}

fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let mut m = [[0.0; 4]; 3];
    for i in 0..3 {
        m[i][..3].copy_from_slice(&a[i]);
        m[i][3] = b[i];
    }
    for col in 0..3 {
        let piv = (col..3).max_by(|&i, &j| m[i][col].abs().total_cmp(&m[j][col].abs()))?;
        if m[piv][col].abs() <= 1e-300 || m[piv][col].is_nan() {
            return None;
        }
        m.swap(col, piv);
        let pivot_row = m[col];
        for (r, row) in m.iter_mut().enumerate() {
            if r != col {
                let f = row[col] / pivot_row[col];
                for (x, p) in row.iter_mut().zip(pivot_row.iter()).skip(col) {
                    *x -= f * p;
                }
            }
        }
    }
    let x = [m[0][3] / m[0][0], m[1][3] / m[1][1], m[2][3] / m[2][2]];
    x.iter().all(|v| v.is_finite()).then_some(x)
}

impl Default for Upsampler {
    fn default() -> Self {
        Self::new()
    }
}

impl Upsampler {
    /// The per-wavelength linear-sRGB weights are the decoder's conversion applied to a unit
    /// impulse at each CIE wavelength (the conversion is linear, so this is exact).
    pub fn new() -> Upsampler {
        let w: Vec<[f64; 3]> = (0..N)
            .map(|i| {
                let mut e = [0.0f64; N];
                e[i] = 1.0;
                spectrum_to_linear_srgb(&e)
            })
            .collect();
        let (l0, l1) = (CIE_WAVELENGTHS[0] as f64, CIE_WAVELENGTHS[N - 1] as f64);
        let t: Vec<f64> = (0..N).map(|i| i as f64 / (N - 1) as f64).collect();
        let lanes = w
            .iter()
            .zip(&t)
            .map(|(w, &t)| {
                let dp = [t * t, t, 1.0];
                let (mut wl, mut dl) = ([0.0; 12], [1.0; 12]);
                for k in 0..3 {
                    for j in 0..3 {
                        wl[3 * k + j] = w[k];
                        dl[3 * k + j] = dp[j];
                    }
                    wl[9 + k] = w[k];
                }
                (wl, dl)
            })
            .collect();
        Upsampler {
            w,
            t,
            lanes,
            range: [l0, l1],
            tolerance: 1e-3,
        }
    }

    /// RGB of the unit-scale sigmoid spectrum with coefficients c, and its Jacobian: per
    /// wavelength, colour k gains w_k·s and Jacobian entry (k, j) gains (w_k·s′)·∂x/∂c_j. The
    /// 12 sums are kept side by side so that the compiler runs them as vector lanes: each is
    /// the same sequence of roundings as one scalar sum (multiplying by 1 is exact), so the
    /// result is bit for bit what a scalar loop gives (`rgb_jac_matches_the_scalar_sums`);
    /// this is most of the time of a fit, and a fit per colour is most of an RGB file's read.
    fn rgb_jac(&self, c: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2 (checked just above).
            return unsafe { self.rgb_jac_avx2(c) };
        }
        self.rgb_jac_body(c)
    }

    /// [`Upsampler::rgb_jac`] with 4-wide lanes (AVX2 only: no FMA, so the same roundings).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn rgb_jac_avx2(&self, c: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        self.rgb_jac_body(c)
    }

    #[inline(always)]
    fn rgb_jac_body(&self, c: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        // The sigmoid and its derivative at every wavelength first (independent, so vector
        // lanes too), then the sums in wavelength order.
        let (mut s, mut ds) = ([0.0f64; N], [0.0f64; N]);
        for ((s, ds), &t) in s.iter_mut().zip(ds.iter_mut()).zip(&self.t) {
            let x = (c[0] * t + c[1]) * t + c[2];
            let q = 1.0 / (1.0 + x * x).sqrt();
            *s = 0.5 + 0.5 * x * q;
            *ds = 0.5 * q * q * q;
        }
        let mut acc = [0.0f64; 12];
        for ((s, ds), (wl, dl)) in s.iter().zip(&ds).zip(&self.lanes) {
            let mut f = [*ds; 12];
            f[9..].fill(*s);
            for l in 0..12 {
                acc[l] += wl[l] * f[l] * dl[l];
            }
        }
        let rgb = [acc[9], acc[10], acc[11]];
        let jac = [
            [acc[0], acc[1], acc[2]],
            [acc[3], acc[4], acc[5]],
            [acc[6], acc[7], acc[8]],
        ];
        (rgb, jac)
    }

    /// Levenberg–Marquardt from `c`; returns the coefficients and the max abs residual.
    fn solve(&self, target: [f64; 3], mut c: [f64; 3], iters: usize) -> ([f64; 3], f64) {
        let cost = |r: &[f64; 3]| r.iter().map(|v| v * v).sum::<f64>();
        let resid = |rgb: [f64; 3]| [rgb[0] - target[0], rgb[1] - target[1], rgb[2] - target[2]];
        let (rgb, mut jac) = self.rgb_jac(c);
        let mut r = resid(rgb);
        let mut f = cost(&r);
        let mut mu = 1e-3;
        for _ in 0..iters {
            if r.iter().all(|v| v.abs() < 1e-10) {
                break;
            }
            let mut a = [[0.0; 3]; 3];
            let mut g = [0.0; 3];
            for i in 0..3 {
                for j in 0..3 {
                    a[i][j] = (0..3).map(|k| jac[k][i] * jac[k][j]).sum();
                }
                g[i] = (0..3).map(|k| jac[k][i] * r[k]).sum();
            }
            let mut accepted = false;
            for _ in 0..12 {
                let mut damped = a;
                for (i, row) in damped.iter_mut().enumerate() {
                    row[i] += mu * a[i][i].max(1e-12);
                }
                if let Some(step) = solve3(damped, g) {
                    let trial = [c[0] - step[0], c[1] - step[1], c[2] - step[2]];
                    let (trgb, tjac) = self.rgb_jac(trial);
                    let tr = resid(trgb);
                    let tf = cost(&tr);
                    if tf.is_finite() && tf < f {
                        c = trial;
                        r = tr;
                        f = tf;
                        jac = tjac;
                        mu = (mu * 0.3).max(1e-12);
                        accepted = true;
                        break;
                    }
                }
                mu *= 10.0;
            }
            if !accepted {
                break;
            }
        }
        (c, r.iter().fold(0.0f64, |m, v| m.max(v.abs())))
    }

    /// Fits one linear-sRGB triplet (any magnitude: BRDF values are not reflectances).
    /// Negative components (noise) are set to 0 first. The colour is scaled so that its
    /// largest component is `brightness` (½, then lower if that fails), fitted, and the
    /// spectrum scaled back. Errs if the best fit is off by more than `tolerance`.
    pub fn fit(&self, rgb: [f64; 3]) -> Result<Fit> {
        if rgb.iter().any(|v| !v.is_finite()) {
            return Err(RglError::Upsample {
                rgb,
                rel_error: f64::INFINITY,
            });
        }
        let clamped = rgb.iter().any(|&v| v < 0.0);
        let target = rgb.map(|v| v.max(0.0));
        let k = target.iter().fold(0.0f64, |m, &v| m.max(v));
        let range = self.range;
        if k <= 0.0 {
            let spectrum = SigmoidSpectrum {
                scale: 0.0,
                coeffs: [0.0; 3],
                range_nm: range,
            };
            return Ok(Fit {
                spectrum,
                target,
                rgb: [0.0; 3],
                rel_error: 0.0,
                clamped,
            });
        }
        let mut best: Option<(f64, [f64; 3], f64)> = None; // (rel error, coeffs, brightness)
        for &brightness in &[0.5, 0.25, 0.1, 0.04] {
            let t = target.map(|v| v * brightness / k);
            let (mut c, mut err) = self.solve(t, [0.0; 3], 60);
            if err / brightness > 1e-6 {
                // Continuation from grey of the same mean toward the target.
                let g = (t[0] + t[1] + t[2]) / 3.0;
                let g = g.clamp(1e-3, 0.999);
                let mut cc = [
                    0.0,
                    0.0,
                    ((2.0 * g - 1.0) / (1.0 - (2.0 * g - 1.0).powi(2)).sqrt()),
                ];
                let steps = 24;
                for s in 1..=steps {
                    let a = s as f64 / steps as f64;
                    let ts = [lerp(g, t[0], a), lerp(g, t[1], a), lerp(g, t[2], a)];
                    cc = self.solve(ts, cc, 40).0;
                }
                let (c2, e2) = self.solve(t, cc, 100);
                if e2 < err {
                    c = c2;
                    err = e2;
                }
            }
            let rel = err / brightness;
            if best.is_none_or(|b| rel < b.0) {
                best = Some((rel, c, brightness));
            }
            if rel <= 1e-6 {
                break;
            }
        }
        let (_, c, brightness) = best.expect("at least one brightness tried");
        let spectrum = SigmoidSpectrum {
            scale: k / brightness,
            coeffs: c,
            range_nm: range,
        };
        let s: Vec<f64> = CIE_WAVELENGTHS
            .iter()
            .map(|&l| spectrum.eval(l as f64))
            .collect();
        let mut out = [0.0; 3];
        for (w, v) in self.w.iter().zip(&s) {
            for k in 0..3 {
                out[k] += w[k] * v;
            }
        }
        let rel_error = (0..3)
            .map(|i| (out[i] - target[i]).abs())
            .fold(0.0, f64::max)
            / k;
        if rel_error.is_nan() || rel_error > self.tolerance {
            return Err(RglError::Upsample { rgb, rel_error });
        }
        Ok(Fit {
            spectrum,
            target,
            rgb: out,
            rel_error,
            clamped,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Jacobian as it was first written, one scalar sum per entry.
    fn rgb_jac_scalar(up: &Upsampler, c: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        let (mut rgb, mut jac) = ([0.0; 3], [[0.0; 3]; 3]);
        for (i, w) in up.w.iter().enumerate() {
            let t = up.t[i];
            let x = (c[0] * t + c[1]) * t + c[2];
            let q = 1.0 / (1.0 + x * x).sqrt();
            let s = 0.5 + 0.5 * x * q;
            let ds = 0.5 * q * q * q;
            let dp = [t * t, t, 1.0];
            for k in 0..3 {
                rgb[k] += w[k] * s;
                for j in 0..3 {
                    jac[k][j] += w[k] * ds * dp[j];
                }
            }
        }
        (rgb, jac)
    }

    #[test]
    fn rgb_jac_matches_the_scalar_sums() {
        let up = Upsampler::new();
        // A small LCG over coefficients from tiny to huge, both signs.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..20_000 {
            let scale = 10f64.powf(next() * 12.0 - 6.0);
            let c = [0, 1, 2].map(|_| (next() * 2.0 - 1.0) * scale);
            let (a, b) = (up.rgb_jac(c), rgb_jac_scalar(&up, c));
            assert_eq!(a.0.map(f64::to_bits), b.0.map(f64::to_bits), "{c:?}");
            assert_eq!(
                a.1.map(|r| r.map(f64::to_bits)),
                b.1.map(|r| r.map(f64::to_bits)),
                "{c:?}"
            );
        }
    }
}
