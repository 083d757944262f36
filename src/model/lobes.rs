//! Lobe shapes that need more than an angle: evaluated by the decoder (its scalar paths and
//! its batch kernel), the sampler and the encoder alike. Each formula is written once, over
//! [`Real`]: one `f64` or [`Lanes`](crate::model::lanes::Lanes) of them. Normative text:
//! `spec/EVALUATION.md`, section "Lobes".

use crate::model::angles::dot;
use crate::model::lanes::{max_or_first, min_or_first, Real};
use crate::model::material::LobeKind;

/// Cosines are kept at least this large so the grazing factors stay finite on the horizon.
pub const MIN_COS: f64 = 1e-6;

/// A cosine-power lobe's value (kind 4) at unit `wo` for exponent `n` and unit peak direction
/// `peak`: g^n for g = wo·peak capped at 1 (rounding can exceed it, and a large exponent would
/// turn 1 + ε into infinity), computed as exp(n·ln g) (powf's value to ~10⁻¹⁵ relative, a
/// little quicker); 0 where g ≤ 0, without ln 0's division-by-zero trap.
#[inline(always)]
pub fn cosine_power<R: Real>(n: R, wo: [R; 3], peak: [R; 3]) -> R {
    cosine_power_of(n, dot(wo, peak))
}

/// [`cosine_power`] for the cosine `g` of the angle to the peak (callers that hold angles).
#[inline(always)]
pub fn cosine_power_of<R: Real>(n: R, g: R) -> R {
    let one = R::splat(1.0);
    let g = g.min(one);
    let positive = g.gt(R::splat(0.0));
    let g = R::select(positive, g, one);
    R::select_with(positive, || (n * g.ln()).exp(), R::splat(0.0))
}

/// A shape parameter of a shared lobe blended geometrically over records (weight w_r, the
/// parameter's logarithm ln p_r): exp(Σ_r w_r·ln p_r), summed in record order
/// (`spec/EVALUATION.md`, "Blended coefficients": exponents, microfacet b and c); 1 for no
/// records.
#[inline(always)]
pub fn blend_geometric<R: Real>(parts: impl IntoIterator<Item = (R, f64)>) -> R {
    let mut parts = parts.into_iter();
    let Some((w, ln_p)) = parts.next() else {
        return R::splat(1.0);
    };
    let mut s = w * ln_p;
    for (w, ln_p) in parts {
        s = s + w * ln_p;
    }
    s.exp()
}

/// A shape parameter of a shared lobe blended linearly over records (weight w_r, value p_r):
/// Σ_r w_r·p_r / Σ_r w_r, each sum in record order (microfacet a); NaN for no records.
#[inline(always)]
pub fn blend_linear<R: Real>(parts: impl IntoIterator<Item = (R, f64)>) -> R {
    let mut parts = parts.into_iter();
    let Some((w, p)) = parts.next() else {
        return R::splat(f64::NAN);
    };
    let (mut wp, mut ws) = (w * p, w);
    for (w, p) in parts {
        wp = wp + w * p;
        ws = ws + w;
    }
    wp / ws
}

/// The blended peak direction of records in one frame (weight w_r, unit peak p_r): Σ_r w_r·p_r
/// normalised, and where that sum neither vanishes nor overflows (nowhere for no records) (elsewhere the spec's
/// azimuth-offset rule applies: `Resident::blended_peak`). "Blended peak direction".
#[inline(always)]
pub fn blend_peak<R: Real>(parts: impl IntoIterator<Item = (R, [f64; 3])>) -> ([R; 3], R::Mask) {
    let mut parts = parts.into_iter();
    let Some((w, p)) = parts.next() else {
        return (
            [R::splat(0.0); 3],
            R::and(R::splat(0.0).gt(R::splat(0.0)), R::splat(0.0).finite()),
        );
    };
    let mut m = p.map(|p| w * p);
    for (w, p) in parts {
        for (m, p) in m.iter_mut().zip(p) {
            *m = *m + w * p;
        }
    }
    let n2 = dot(m, m);
    let ok = R::and(n2.gt(R::splat(0.0)), n2.finite());
    let s = R::splat(1.0) / R::select(ok, n2, R::splat(1.0)).sqrt();
    (m.map(|c| c * s), ok)
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
/// evaluate the geometry once. Over one `f64` (the default) or lanes of pairs.
#[derive(Debug, Clone, Copy)]
pub struct MicrofacetGeometry<R: Real = f64> {
    /// Where wi + wo does not vanish: elsewhere every variant is 0.
    ok: R::Mask,
    /// The two arguments of D: 1 − cos θh and sin²θh.
    one_minus_ch: R,
    sin2_h: R,
    /// The clamped cosines of θi and θo: the Smith term needs a², so it waits for the parameters.
    ci: R,
    co: R,
    /// V-cavity visibility and the Schlick factor (1 − cd)⁵.
    vc: R,
    f: R,
    /// The half vector's tangential components, for the anisotropic kind.
    hx: R,
    hy: R,
}

impl<R: Real> MicrofacetGeometry<R> {
    /// The geometry of unit `wi`, `wo` (local frame), every lane; where wi + wo vanishes
    /// (opposite directions) its variants are 0.
    #[inline(always)]
    pub fn at(wi: [R; 3], wo: [R; 3]) -> Self {
        let sum = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let n2 = dot(sum, sum);
        let (zero, one, min) = (R::splat(0.0), R::splat(1.0), R::splat(MIN_COS));
        let ok = R::and(n2.gt(zero), n2.finite());
        // Reciprocals where the formulas divide (equal to rounding).
        let inv = one / R::select(ok, n2, one).sqrt();
        let h = sum.map(|c| c * inv);
        let ch = h[2].max(zero).min(one);
        let cd = dot(wi, h).max(min).min(one);
        let ci = wi[2].max(min);
        let co = wo[2].max(min);
        // min(1/(ci·co), 2ch/(cd·ci), 2ch/(cd·co)) = min(1, 2ch·co/cd, 2ch·ci/cd)/(ci·co).
        let m = R::splat(2.0) * ch / cd;
        let vc = (m * co).min(m * ci).min(one) / (ci * co);
        let g = one - cd;
        let g2 = g * g;
        MicrofacetGeometry {
            ok,
            one_minus_ch: one - ch,
            sin2_h: one - ch * ch,
            ci,
            co,
            vc,
            f: g2 * g2 * g,
            hx: h[0],
            hy: h[1],
        }
    }

    /// [D·Vs, D·Vs·F, D·Vc, D·Vc·F] for parameters b, c, a, with D's argument sin²θh when
    /// `sin2`, else 1 − cos θh.
    #[inline(always)]
    pub fn variants_of(&self, b: R, c: R, a: R, sin2: bool) -> [R; 4] {
        let one = R::splat(1.0);
        // exp(−c·ln(1 + b·x)): powf's value to ~1.5e-15 relative, about 10% quicker than glibc pow.
        let d = (-c * (one + b * self.argument(sin2)).ln()).exp();
        self.variants_with_d(d, a)
    }

    /// D's argument x: sin²θh when `sin2`, else 1 − cos θh.
    #[inline(always)]
    pub fn argument(&self, sin2: bool) -> R {
        if sin2 {
            self.sin2_h
        } else {
            self.one_minus_ch
        }
    }

    /// [`MicrofacetGeometry::variants_of`] with the distribution term D given (for shape
    /// parameter a): what a caller that computes D's power its own way shares with it.
    #[inline(always)]
    pub fn variants_with_d(&self, d: R, a: R) -> [R; 4] {
        let one = R::splat(1.0);
        let (ci, co) = (self.ci, self.co);
        let a2 = a * a;
        let vs = one
            / (co * (a2 + (one - a2) * ci * ci).sqrt() + ci * (a2 + (one - a2) * co * co).sqrt());
        self.masked([d * vs, d * vs * self.f, d * self.vc, d * self.vc * self.f])
    }

    /// The four variants of the anisotropic kind for parameters `[bx, by, c, ax, ay, _]` with
    /// its axis given as (sin ψ, cos ψ), at the directions `wi`, `wo` this geometry was made
    /// from: D = (1 + bx·hu² + by·hv²)^(−c) and Vs = 1/(co·√(ci² + ax²·ui² + ay²·vi²) +
    /// ci·√(co² + ax²·uo² + ay²·vo²)), where xu, xv are the components of x along
    /// u = (cos ψ, sin ψ, 0) and v = (−sin ψ, cos ψ, 0); Vc and F as for the isotropic kinds.
    #[inline(always)]
    pub fn variants_aniso_of(
        &self,
        params: [R; 6],
        (s, k): (R, R),
        wi: [R; 3],
        wo: [R; 3],
    ) -> [R; 4] {
        let [bx, by, c, ax, ay, _] = params;
        let one = R::splat(1.0);
        let along = |x: R, y: R| (x * k + y * s, y * k - x * s);
        let (hu, hv) = along(self.hx, self.hy);
        let d = (-c * (one + bx * hu * hu + by * hv * hv).ln()).exp();
        let (ci, co) = (self.ci, self.co);
        let (ax2, ay2) = (ax * ax, ay * ay);
        let (iu, iv) = along(wi[0], wi[1]);
        let (ou, ov) = along(wo[0], wo[1]);
        let vs = one
            / (co * (ci * ci + ax2 * iu * iu + ay2 * iv * iv).sqrt()
                + ci * (co * co + ax2 * ou * ou + ay2 * ov * ov).sqrt());
        self.masked([d * vs, d * vs * self.f, d * self.vc, d * self.vc * self.f])
    }

    /// `v` where the geometry exists, 0 elsewhere.
    #[inline(always)]
    fn masked(&self, v: [R; 4]) -> [R; 4] {
        v.map(|v| R::select(self.ok, v, R::splat(0.0)))
    }
}

impl MicrofacetGeometry {
    /// None when wi + wo vanishes (opposite directions): every variant is then 0.
    #[inline(always)]
    pub fn new(wi: [f64; 3], wo: [f64; 3]) -> Option<Self> {
        let g = Self::at(wi, wo);
        g.ok.then_some(g)
    }

    /// [`MicrofacetGeometry::at`]'s quantities for unit `wi`, `wo` with one division and one
    /// square root where it takes three and one: the reciprocals of |wi + wo|², of p = wi·(wi +
    /// wo) (= |wi + wo|·cos θd) and of ci·co are read from 1/(|wi + wo|²·p·ci·co), which does
    /// not wait on the root, and sin²θh = 1 − (zi + zo)²/|wi + wo|² needs no root at all: D's
    /// argument waits on one division. Equal to `at`'s within 10⁻¹⁰ of the largest variant, not
    /// bit for bit: for views held to a tolerance (the baked view), where the divider is what a
    /// query waits on. None where wi + wo vanishes or p ≤ 0 (opposite directions; `at`'s
    /// variants are 0 there).
    #[inline(always)]
    pub fn at_one_division(wi: [f64; 3], wo: [f64; 3]) -> Option<Self> {
        let sum = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let n2 = dot(sum, sum);
        let p = dot(wi, sum);
        // For unit wi, wo, |wi + wo|² ≤ 4: no test that it is finite (the test as written
        // compiled to a dozen integer instructions).
        if !(n2 > 0.0 && p > 0.0) {
            return None;
        }
        // `max_or_first`/`min_or_first`, not `f64::max`/`min`/`clamp`: every value is a number
        // here, and the standard library's NaN rules cost several instructions each. The bound
        // goes first: that order compiles to fewer instructions here (callgrind, GGX 4 a query).
        let hi = |a: f64, bound: f64| max_or_first(bound, a);
        let lo = |a: f64, bound: f64| min_or_first(bound, a);
        let ci = hi(wi[2], MIN_COS);
        let co = hi(wo[2], MIN_COS);
        let cc = ci * co;
        let inv = 1.0 / (n2 * p * cc);
        let inv_n2 = inv * p * cc;
        let n = n2.sqrt();
        let inv_n = n * inv_n2;
        let ch = lo(hi(sum[2] * inv_n, 0.0), 1.0);
        let ch2 = lo(hi(sum[2] * sum[2] * inv_n2, 0.0), 1.0);
        let cd_raw = p * inv_n;
        let cd = lo(hi(cd_raw, MIN_COS), 1.0);
        // 1/cd: n/p where cd is its own; where clamped, the clamp's.
        let inv_cd = if cd == cd_raw {
            n * (inv * n2 * cc)
        } else {
            1.0 / cd
        };
        let m = 2.0 * ch * inv_cd;
        let vc = lo(lo(m * co, m * ci), 1.0) * (inv * n2 * p);
        let g = 1.0 - cd;
        let g2 = g * g;
        Some(MicrofacetGeometry {
            ok: true,
            one_minus_ch: 1.0 - ch,
            sin2_h: 1.0 - ch2,
            ci,
            co,
            vc,
            f: g2 * g2 * g,
            hx: sum[0] * inv_n,
            hy: sum[1] * inv_n,
        })
    }

    /// [D·Vs, D·Vs·F, D·Vc, D·Vc·F] for parameters `[b, c, a]`.
    pub fn variants(&self, params: &[f32], sin2: bool) -> [f64; 4] {
        self.variants_f64([params[0] as f64, params[1] as f64, params[2] as f64], sin2)
    }

    /// [`MicrofacetGeometry::variants`] for parameters `[b, c, a]` already widened (the decoder
    /// holds them so, rounded to f32 as the format stores or blends them).
    #[inline(always)]
    pub fn variants_f64(&self, [b, c, a]: [f64; 3], sin2: bool) -> [f64; 4] {
        self.variants_of(b, c, a, sin2)
    }

    /// The four variants of the anisotropic kind for parameters `[bx, by, c, ax, ay, ψ]` (ψ in
    /// degrees) at the directions `wi`, `wo` this geometry was made from
    /// ([`MicrofacetGeometry::variants_aniso_of`]).
    #[inline(always)]
    pub fn variants_aniso(&self, params: [f64; 6], wi: [f64; 3], wo: [f64; 3]) -> [f64; 4] {
        let axis = params[5].to_radians().sin_cos();
        self.variants_aniso_of(params, axis, wi, wo)
    }

    /// [`MicrofacetGeometry::variants_aniso`] with (sin ψ, cos ψ) given, for callers that
    /// evaluate one lobe at many directions.
    #[inline(always)]
    pub fn variants_aniso_with_axis(
        &self,
        params: [f64; 6],
        axis: (f64, f64),
        wi: [f64; 3],
        wo: [f64; 3],
    ) -> [f64; 4] {
        self.variants_aniso_of(params, axis, wi, wo)
    }
}

/// The values a lobe of any kind but the angle Gaussian (whose widths blend per term)
/// multiplies its amplitudes by at `wo`, and how many there are: the cosine power (one), or a
/// microfacet kind's four variants. `p` holds the shape as [`shape_rule`] blends it, `peak` the
/// peak direction (cosine power); the microfacet geometry is computed into `geometry` at most
/// once per pair of directions, for every lobe that needs it.
#[inline(always)]
pub fn lobe_values(
    kind: LobeKind,
    p: &[f64; 6],
    peak: [f64; 3],
    wi: [f64; 3],
    wo: [f64; 3],
    geometry: &mut Option<Option<MicrofacetGeometry>>,
) -> ([f64; 4], usize) {
    let mut geometric = || *geometry.get_or_insert_with(|| MicrofacetGeometry::new(wi, wo));
    match kind {
        LobeKind::CosinePower => ([cosine_power(p[0], wo, peak), 0.0, 0.0, 0.0], 1),
        LobeKind::Microfacet | LobeKind::MicrofacetSin2 => match geometric() {
            Some(g) => (
                g.variants_f64([p[0], p[1], p[2]], kind == LobeKind::MicrofacetSin2),
                4,
            ),
            None => ([0.0; 4], 4), // wi = −wo: every variant is 0
        },
        LobeKind::MicrofacetAniso => match geometric() {
            Some(g) => (g.variants_aniso(*p, wi, wo), 4),
            None => ([0.0; 4], 4),
        },
        LobeKind::AngleGaussian => ([0.0; 4], 0), // per term: `decode`'s Gaussian sums
    }
}

/// How one shape parameter of a lobe shared by blended records combines them
/// (`spec/EVALUATION.md`, "Blended coefficients").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamBlend {
    /// exp(Σ w_r·ln p_r): exponents, microfacet b and c ([`blend_geometric`]).
    Geometric,
    /// Σ w_r·p_r / Σ w_r: microfacet a ([`blend_linear`]).
    Linear,
    /// The weighted mean of axes ψ (`model::angles::mean_axis_deg`).
    Axis,
}

/// How a shared lobe of a kind blends: its peak direction ("Blended peak direction") or not,
/// its shape parameters in order, and whether the blended parameters are rounded to `f32`
/// before evaluation. The angle Gaussian blends its widths per term at evaluation instead.
#[derive(Debug, Clone, Copy)]
pub struct ShapeRule {
    /// Whether the kind has a peak direction to blend.
    pub peak: bool,
    /// Shape parameter i blends by `params[i]`.
    pub params: &'static [ParamBlend],
    /// Whether the blended parameters are rounded to the nearest `f32`.
    pub round_f32: bool,
    /// How importance sampling proposes directions for the kind.
    pub proposal: Proposal,
}

/// The importance-sampling proposal family of a lobe kind (`decode/sampling/` draws each
/// family, from the blended shape parameters): a new kind whose lobe one of them follows needs
/// no sampling code of its own.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Proposal {
    /// A von Mises–Fisher lobe about the peak direction, its concentration from the per-term
    /// widths (the angle Gaussian's b_k, weighted by each term's share of the amplitude).
    PeakVonMisesFisher,
    /// cosⁿ about the peak direction, n = shape parameter 0.
    PeakCosinePower,
    /// Visible normals of the isotropic microfacet D with b = parameter 0 and c = parameter 1;
    /// `sin2` selects D = (1 + b·sin²θh)^(−c) over (1 + b·(1 − cos θh))^(−c).
    VisibleNormals {
        /// D in sin²θh.
        sin2: bool,
    },
    /// Visible normals of the anisotropic D with bx, by, c = parameters 0–2 and the axis ψ.
    VisibleNormalsAniso,
}

/// The blending rule of each lobe kind.
pub fn shape_rule(kind: LobeKind) -> ShapeRule {
    use ParamBlend::{Axis, Geometric, Linear};
    match kind {
        LobeKind::AngleGaussian => ShapeRule {
            peak: true,
            params: &[],
            round_f32: false,
            proposal: Proposal::PeakVonMisesFisher,
        },
        LobeKind::CosinePower => ShapeRule {
            peak: true,
            params: &[Geometric],
            round_f32: false,
            proposal: Proposal::PeakCosinePower,
        },
        LobeKind::Microfacet | LobeKind::MicrofacetSin2 => ShapeRule {
            peak: false,
            params: &[Geometric, Geometric, Linear],
            round_f32: true,
            proposal: Proposal::VisibleNormals {
                sin2: kind == LobeKind::MicrofacetSin2,
            },
        },
        LobeKind::MicrofacetAniso => ShapeRule {
            peak: false,
            params: &[Geometric, Geometric, Geometric, Linear, Linear, Axis],
            round_f32: true,
            proposal: Proposal::VisibleNormalsAniso,
        },
    }
}

/// The shape parameters of a lobe shared by blended records, as its kind's [`shape_rule`]
/// blends them (`spec/EVALUATION.md`, "Lobes by position"): record i's weight `w[i]`, its
/// stored parameter j `stored(i, j)` and that parameter's logarithm `ln_stored(i, j)`; `axis`
/// the blended axis ψ (kind 5, `model::angles::mean_axis_deg`). One record keeps its own
/// values. Written once over [`Real`]: every route of the decoder (one query, its batch
/// kernel's lanes) and the sampler blend through it. The peak direction blends by
/// [`blend_peak`]; the angle Gaussian's widths per term at evaluation.
#[inline(always)]
pub fn blend_shape<R: Real>(
    kind: LobeKind,
    w: &[R],
    stored: impl Fn(usize, usize) -> f64,
    ln_stored: impl Fn(usize, usize) -> f64,
    axis: impl Fn() -> f64,
) -> [R; 6] {
    let rule = shape_rule(kind);
    let mut p = [R::splat(0.0); 6];
    for (j, (p, how)) in p.iter_mut().zip(rule.params).enumerate() {
        if w.len() == 1 {
            *p = R::splat(stored(0, j));
            continue;
        }
        let v = match how {
            ParamBlend::Geometric => {
                blend_geometric(w.iter().enumerate().map(|(i, &w)| (w, ln_stored(i, j))))
            }
            ParamBlend::Linear => {
                blend_linear(w.iter().enumerate().map(|(i, &w)| (w, stored(i, j))))
            }
            ParamBlend::Axis => R::splat(axis()),
        };
        *p = if rule.round_f32 { v.round_f32() } else { v };
    }
    p
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
    kind: LobeKind,
    params: &[f32],
    wi: [f64; 3],
    wo: [f64; 3],
) -> [f64; 4] {
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

    /// The one-division geometry (the baked view's) against `at`'s, variant by variant, on a
    /// grid of pairs down to the horizon and at the mirror and the pole: within 10⁻¹⁰ of the
    /// largest variant (10⁻¹¹ measured, where a grazing cosine's rounding is amplified); None
    /// only where `at`'s variants are all 0.
    #[test]
    fn one_division_geometry_agrees_with_at() {
        let mut worst = 0.0f64;
        for ti in [0.0, 1e-4, 10.0, 45.0, 80.0, 89.9, 90.0] {
            for to in [0.0, 1e-4, 10.0, 45.0, 80.0, 89.9, 90.0] {
                for po in [0.0, 30.0, 90.0, 179.9, 180.0] {
                    let (wi, wo) = (dir_from_deg(ti, 0.0), dir_from_deg(to, po));
                    let exact = MicrofacetGeometry::<f64>::at(wi, wo);
                    let Some(quick) = MicrofacetGeometry::at_one_division(wi, wo) else {
                        assert!(!exact.ok, "({ti}, {to}, {po}): None where at is not 0");
                        continue;
                    };
                    for (b, c, a, sin2) in [(10.0, 2.0, 0.3, false), (1e4, 1.5, 0.05, true)] {
                        let e = exact.variants_of(b, c, a, sin2);
                        let q = quick.variants_of(b, c, a, sin2);
                        let m = e.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                        for (e, q) in e.iter().zip(q) {
                            worst = worst.max((e - q).abs() / m.max(f64::MIN_POSITIVE));
                        }
                    }
                }
            }
        }
        assert!(worst <= 1e-10, "worst {worst:e} of the largest variant");
    }

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
