//! Lobe shapes that need more than an angle: evaluated by the decoder and the encoder alike.
//! Normative text: `spec/EVALUATION.md`, section "Lobes".

use crate::model::angles::dot;

/// Cosines are kept at least this large so the grazing factors stay finite on the horizon.
const MIN_COS: f64 = 1e-6;

/// A cosine-power lobe's value (kind 4) at unit `wo` for exponent `n` and unit peak direction
/// `peak`: g^n for g = wo·peak capped at 1 (rounding can exceed it, and a large exponent would
/// turn 1 + ε into infinity), computed as exp(n·ln g) (powf's value to ~10⁻¹⁵ relative, a
/// little quicker); 0 where g ≤ 0, without ln 0's division-by-zero trap.
#[inline(always)]
pub fn cosine_power(n: f64, wo: [f64; 3], peak: [f64; 3]) -> f64 {
    let g = dot(wo, peak).min(1.0);
    if g > 0.0 {
        (n * g.ln()).exp()
    } else {
        0.0
    }
}

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
    /// The half vector's tangential components, for the anisotropic kind.
    hx: f64,
    hy: f64,
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
            hx: h[0],
            hy: h[1],
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

    /// The four variants of the anisotropic kind for parameters `[bx, by, c, ax, ay, ψ]` (ψ in
    /// degrees) at the directions `wi`, `wo` this geometry was made from: D = (1 + bx·hu² +
    /// by·hv²)^(−c) and Vs = 1/(co·√(ci² + ax²·ui² + ay²·vi²) + ci·√(co² + ax²·uo² + ay²·vo²)),
    /// where xu, xv are the components of x along u = (cos ψ, sin ψ, 0) and v = (−sin ψ, cos ψ,
    /// 0); Vc and F as for the isotropic kinds.
    #[inline(always)]
    pub fn variants_aniso(&self, params: [f64; 6], wi: [f64; 3], wo: [f64; 3]) -> [f64; 4] {
        let axis = params[5].to_radians().sin_cos();
        self.variants_aniso_with_axis(params, axis, wi, wo)
    }

    /// [`MicrofacetGeometry::variants_aniso`] with (sin ψ, cos ψ) given, for callers that
    /// evaluate one lobe at many directions.
    #[inline(always)]
    pub fn variants_aniso_with_axis(
        &self,
        params: [f64; 6],
        (s, k): (f64, f64),
        wi: [f64; 3],
        wo: [f64; 3],
    ) -> [f64; 4] {
        let [bx, by, c, ax, ay, _] = params;
        let along = |x: f64, y: f64| (x * k + y * s, y * k - x * s);
        let (hu, hv) = along(self.hx, self.hy);
        let d = (-c * (1.0 + bx * hu * hu + by * hv * hv).ln()).exp();
        let (ci, co) = (self.ci, self.co);
        let (ax2, ay2) = (ax * ax, ay * ay);
        let (iu, iv) = along(wi[0], wi[1]);
        let (ou, ov) = along(wo[0], wo[1]);
        let vs = 1.0
            / (co * (ci * ci + ax2 * iu * iu + ay2 * iv * iv).sqrt()
                + ci * (co * co + ax2 * ou * ou + ay2 * ov * ov).sqrt());
        [d * vs, d * vs * self.f, d * self.vc, d * self.vc * self.f]
    }
}

/// [`MicrofacetGeometry::variants_aniso`] from scratch, for parameters as stored.
pub fn microfacet_aniso_variants(params: &[f32], wi: [f64; 3], wo: [f64; 3]) -> [f64; 4] {
    match MicrofacetGeometry::new(wi, wo) {
        Some(g) => g.variants_aniso([0, 1, 2, 3, 4, 5].map(|i| params[i] as f64), wi, wo),
        None => [0.0; 4],
    }
}

/// The variants of any microfacet kind (2, 3 or 5) for its parameters as stored.
pub fn microfacet_kind_variants(
    kind: crate::model::material::LobeKind,
    params: &[f32],
    wi: [f64; 3],
    wo: [f64; 3],
) -> [f64; 4] {
    use crate::model::material::LobeKind;
    match kind {
        LobeKind::MicrofacetAniso => microfacet_aniso_variants(params, wi, wo),
        LobeKind::MicrofacetSin2 => microfacet_variants_with(params, wi, wo, true),
        _ => microfacet_variants_with(params, wi, wo, false),
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
    fn the_anisotropic_kind_with_equal_axes_is_the_sin2_kind_and_turns_with_its_axis() {
        for (ti, pi, to, po) in [
            (0.0, 0.0, 20.0, 30.0),
            (40.0, 10.0, 35.0, 200.0),
            (70.0, 300.0, 89.0, 100.0),
            (89.0, 45.0, 5.0, 225.0),
        ] {
            let (wi, wo) = (dir_from_deg(ti, pi), dir_from_deg(to, po));
            let iso = microfacet_variants_with(&[30.0, 2.0, 0.3], wi, wo, true);
            let aniso = microfacet_aniso_variants(&[30.0, 30.0, 2.0, 0.3, 0.3, 77.0], wi, wo);
            for j in 0..4 {
                assert!(
                    (iso[j] - aniso[j]).abs() <= 1e-12 * iso[j].max(1e-300),
                    "{iso:?} {aniso:?}"
                );
            }
            // Swapping the axes' parameters is turning the axis by 90°.
            let a = microfacet_aniso_variants(&[300.0, 5.0, 1.5, 0.1, 0.6, 20.0], wi, wo);
            let b = microfacet_aniso_variants(&[5.0, 300.0, 1.5, 0.6, 0.1, 110.0], wi, wo);
            for j in 0..4 {
                assert!(
                    (a[j] - b[j]).abs() <= 1e-12 * a[j].max(1e-300),
                    "{a:?} {b:?}"
                );
            }
        }
    }

    #[test]
    fn the_anisotropic_kind_holds_anisotropic_ggx() {
        // D·Vs with bx = 1/αx² − 1, by = 1/αy² − 1, c = 2, ax = αx, ay = αy is GGX's D·G2/(4 ci
        // co) times 2π·αx·αy: D_GGX = 1/(π αx αy t²) with t = 1 + bx hu² + by hv² (hz² = 1 −
        // hu² − hv²), and G2/(4 ci co) = Vs/2.
        let (ax, ay, psi) = (0.08f64, 0.35f64, 30.0f64);
        // Heitz 2014, eq. 80 and 86, written out in the frame (u, v, z).
        let (s, k) = psi.to_radians().sin_cos();
        let along = |w: [f64; 3]| (w[0] * k + w[1] * s, w[1] * k - w[0] * s);
        let ggx = |wi: [f64; 3], wo: [f64; 3]| {
            let h = crate::model::angles::normalize([wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]])
                .unwrap();
            let (hu, hv) = along(h);
            let t = hu * hu / (ax * ax) + hv * hv / (ay * ay) + h[2] * h[2];
            let d = 1.0 / (std::f64::consts::PI * ax * ay * t * t);
            let lambda = |w: [f64; 3]| {
                let (wu, wv) = along(w);
                0.5 * (-1.0
                    + (1.0 + (ax * ax * wu * wu + ay * ay * wv * wv) / (w[2] * w[2])).sqrt())
            };
            d / (1.0 + lambda(wi) + lambda(wo)) / (4.0 * wi[2] * wo[2])
        };
        let params = [
            (1.0 / (ax * ax) - 1.0) as f32,
            (1.0 / (ay * ay) - 1.0) as f32,
            2.0,
            ax as f32,
            ay as f32,
            psi as f32,
        ];
        let k = 2.0 * std::f64::consts::PI * ax * ay;
        for (ti, pi, to, po) in [
            (30.0, 0.0, 30.0, 180.0),
            (50.0, 70.0, 40.0, 230.0),
            (10.0, 0.0, 60.0, 90.0),
        ] {
            let (wi, wo) = (dir_from_deg(ti, pi), dir_from_deg(to, po));
            let want = ggx(wi, wo);
            let got = microfacet_aniso_variants(&params, wi, wo)[0] / k;
            assert!((got - want).abs() <= 1e-5 * want, "{got} vs {want}");
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
