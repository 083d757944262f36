//! Lobe shapes that need more than an angle: evaluated by the decoder and the encoder alike.
//! Normative text: `spec/EVALUATION.md`, section "Lobes".

use crate::model::angles::dot;

/// Cosines are kept at least this large so the grazing factors stay finite on the horizon.
const MIN_COS: f64 = 1e-6;

/// The four variants of a microfacet lobe at incident `wi` and outgoing `wo` (unit vectors,
/// local frame), for parameters `[b, c, a]`: [D·Vs, D·Vs·F, D·Vc, D·Vc·F] with
/// D = (1 + b(1 − cos θh))^(−c), Vs = 1/(co·√(a² + (1−a²)ci²) + ci·√(a² + (1−a²)co²)),
/// Vc = min(1/(ci·co), 2·ch/(cd·ci), 2·ch/(cd·co)) and F = (1 − cd)⁵, where ci = wi·z,
/// co = wo·z, ch = h·z, cd = wi·h, h = normalize(wi + wo); ci, co, cd are clamped to ≥ 10⁻⁶.
pub fn microfacet_variants(params: &[f32], wi: [f64; 3], wo: [f64; 3]) -> [f64; 4] {
    microfacet_variants_with(params, wi, wo, false)
}

/// [`microfacet_variants`] with D = (1 + b·x)^(−c) for x = sin²θh when `sin2`, else
/// x = 1 − cos θh.
pub fn microfacet_variants_with(
    params: &[f32],
    wi: [f64; 3],
    wo: [f64; 3],
    sin2: bool,
) -> [f64; 4] {
    match MicrofacetGeometry::new(wi, wo) {
        Some(g) => g.variants(params, sin2),
        None => [0.0; 4],
    }
}

/// What the microfacet variants share for one pair of directions: everything but the
/// distribution term, so that neighbouring records with different lobe parameters or kinds
/// evaluate the geometry once.
#[derive(Debug, Clone, Copy)]
pub struct MicrofacetGeometry {
    /// The two arguments of D: 1 − cos θh and sin²θh.
    one_minus_ch: f64,
    sin2_h: f64,
    /// The clamped cosines of θi and θo: the Smith term needs a², so it waits for the parameters.
    ci: f64,
    co: f64,
    /// V-cavity visibility and the Schlick factor (1 − cd)⁵.
    vc: f64,
    f: f64,
}

impl MicrofacetGeometry {
    /// None when wi + wo vanishes (opposite directions): every variant is then 0.
    #[inline(always)]
    pub fn new(wi: [f64; 3], wo: [f64; 3]) -> Option<Self> {
        let sum = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let n2 = dot(sum, sum);
        if !(n2 > 0.0 && n2.is_finite()) {
            return None;
        }
        // Reciprocals where the formulas divide (equal to rounding).
        let inv = 1.0 / n2.sqrt();
        let h = [sum[0] * inv, sum[1] * inv, sum[2] * inv];
        let ch = h[2].clamp(0.0, 1.0);
        let cd = dot(wi, h).clamp(MIN_COS, 1.0);
        let ci = wi[2].max(MIN_COS);
        let co = wo[2].max(MIN_COS);
        // min(1/(ci·co), 2ch/(cd·ci), 2ch/(cd·co)) = min(1, 2ch·co/cd, 2ch·ci/cd)/(ci·co).
        let m = 2.0 * ch / cd;
        let vc = (m * co).min(m * ci).min(1.0) / (ci * co);
        let g = 1.0 - cd;
        let g2 = g * g;
        Some(MicrofacetGeometry {
            one_minus_ch: 1.0 - ch,
            sin2_h: 1.0 - ch * ch,
            ci,
            co,
            vc,
            f: g2 * g2 * g,
        })
    }

    /// [D·Vs, D·Vs·F, D·Vc, D·Vc·F] for parameters `[b, c, a]`.
    pub fn variants(&self, params: &[f32], sin2: bool) -> [f64; 4] {
        self.variants_f64([params[0] as f64, params[1] as f64, params[2] as f64], sin2)
    }

    /// [`MicrofacetGeometry::variants`] for parameters `[b, c, a]` already widened (the decoder
    /// holds them so, rounded to f32 as the format stores or blends them).
    #[inline(always)]
    pub fn variants_f64(&self, params: [f64; 3], sin2: bool) -> [f64; 4] {
        let [b, c, a] = params;
        let x = if sin2 { self.sin2_h } else { self.one_minus_ch };
        // exp(−c·ln(1 + b·x)): powf's value to ~1.5e-15 relative, about 10% quicker than glibc pow.
        let d = (-c * (1.0 + b * x).ln()).exp();
        let (ci, co) = (self.ci, self.co);
        let a2 = a * a;
        let vs = 1.0
            / (co * (a2 + (1.0 - a2) * ci * ci).sqrt() + ci * (a2 + (1.0 - a2) * co * co).sqrt());
        [d * vs, d * vs * self.f, d * self.vc, d * self.vc * self.f]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::angles::dir_from_deg;

    #[test]
    fn finite_everywhere_including_horizon_and_pole() {
        for params in [[1.0f32, 1.0, 0.0], [1e6, 3.0, 1.0], [10.0, 0.5, 0.3]] {
            for (ti, to, po) in [
                (0.0, 0.0, 0.0),
                (0.0, 90.0, 0.0),
                (89.0, 90.0, 180.0),
                (89.0, 90.0, 0.0),
                (45.0, 45.0, 180.0),
            ] {
                let v = microfacet_variants(&params, dir_from_deg(ti, 0.0), dir_from_deg(to, po));
                assert!(
                    v.iter().all(|x| x.is_finite() && *x >= 0.0),
                    "{params:?} {ti} {to} {po}: {v:?}"
                );
            }
        }
    }

    #[test]
    fn peaks_at_the_half_vector_normal() {
        // For ωo the mirror of ωi, h = z: D = 1, F = (1 − ci)⁵, and V reduces to closed forms.
        let wi = dir_from_deg(30.0, 0.0);
        let wo = dir_from_deg(30.0, 180.0);
        let v = microfacet_variants(&[50.0, 2.0, 1.0], wi, wo);
        let ci = 30f64.to_radians().cos();
        assert!((v[0] - 1.0 / (2.0 * ci)).abs() < 1e-12); // a = 1: Vs = 1/(ci + co)
        assert!((v[1] - v[0] * (1.0 - ci).powi(5)).abs() < 1e-12);
        assert!((v[2] - 1.0 / (ci * ci)).abs() < 1e-9); // V-cavity: min(1/(ci co), 2/ci, 2/co)
        let off = microfacet_variants(&[50.0, 2.0, 1.0], wi, dir_from_deg(40.0, 180.0));
        assert!(off[0] < v[0]);
    }
}
