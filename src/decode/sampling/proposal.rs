//! The closed-form proposal densities importance sampling mixes ([`super`]), each over
//! the whole sphere in the records' frame: the cosine, Phong's cosine power about a peak, a von
//! Mises–Fisher distribution, and GGX's distribution of visible normals reflecting the incident
//! direction (Heitz 2018); each draws a direction and gives its density.

use crate::model::angles::{dot, normalize};
use std::f64::consts::PI;

/// One proposal density over the whole sphere, in the records' frame.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Shape {
    /// max(0, cos θ)/π.
    Cosine,
    /// (n + 1)/(2π)·max(0, ω·p)ⁿ.
    CosinePower { p: [f64; 3], n: f64 },
    /// κ/(2π(1 − e^(−2κ)))·exp(κ(ω·p − 1)); `m` = 1 − e^(−2κ).
    VonMisesFisher { p: [f64; 3], kappa: f64, m: f64 },
    /// ωo = the incident vector reflected about a normal h drawn from GGX's distribution of
    /// visible normals for roughness `ax` along the surface axis u = `axis` = (cos ψ, sin ψ) and
    /// `ay` along v = (−sin ψ, cos ψ) (equal for the isotropic kinds): density G1(ωi)·D(h)/(4
    /// cos θi) over ωo, with `k` = G1(ωi)/(4 cos θi) = 1/(2(cos θi + √(cos²θi + ax²·ωu² +
    /// ay²·ωv²))) for the incident vector the shape was made for.
    VisibleNormals {
        ax: f64,
        ay: f64,
        axis: [f64; 2],
        k: f64,
    },
}

/// The components of `w` along the surface axes u = (axis[0], axis[1], 0) and v = (−axis[1],
/// axis[0], 0).
#[inline(always)]
fn along(axis: [f64; 2], w: [f64; 3]) -> (f64, f64) {
    (
        w[0] * axis[0] + w[1] * axis[1],
        w[1] * axis[0] - w[0] * axis[1],
    )
}

/// An orthonormal pair perpendicular to the unit vector `n` (Duff et al. 2017).
fn basis_about(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let sign = 1f64.copysign(n[2]);
    let a = -1.0 / (sign + n[2]);
    let b = n[0] * n[1] * a;
    (
        [1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]],
        [b, sign + n[1] * n[1] * a, -n[1]],
    )
}

/// The unit vector at angle (cos α, sin α) from `p`, at azimuth 2π·u about it.
fn around(p: [f64; 3], cos_a: f64, sin_a: f64, u: f64) -> [f64; 3] {
    let (t, b) = basis_about(p);
    let (sp, cp) = (2.0 * PI * u).sin_cos();
    let (x, y) = (sin_a * cp, sin_a * sp);
    [
        x * t[0] + y * b[0] + cos_a * p[0],
        x * t[1] + y * b[1] + cos_a * p[1],
        x * t[2] + y * b[2] + cos_a * p[2],
    ]
}

impl Shape {
    /// GGX visible normals for a microfacet lobe of distribution (1 + b·s)^(−c), s = sin²θh
    /// (`sin2`) or 1 − cos θh, at the incident vector `wi`. GGX is (1 + b′ sin²θh)^(−2) with
    /// α² = 1/(1 + b′); b′ is chosen so that both fall to half their peak at the same θh (for
    /// a sin² lobe with c = 2, b′ = b: the lobe's own D). A lobe that stays above half its peak
    /// over the whole hemisphere gets b′ = √2 − 1, the broadest GGX with a half width.
    pub(crate) fn visible_normals(sin2: bool, b: f64, c: f64, wi: [f64; 3]) -> Self {
        let alpha = Self::ggx_alpha(sin2, b, c);
        Self::ggx(alpha, alpha, [1.0, 0.0], wi)
    }

    /// The GGX roughness whose distribution falls to half its peak where (1 + b·s)^(−c) does.
    pub(crate) fn ggx_alpha(sin2: bool, b: f64, c: f64) -> f64 {
        // s at half the peak: (1 + b·s)^(−c) = 1/2.
        let half = (std::f64::consts::LN_2 / c).exp_m1() / b;
        let s2 = if sin2 {
            half.min(1.0)
        } else {
            let x = half.min(1.0);
            x * (2.0 - x) // sin²θ = (1 − cos θ)(1 + cos θ)
        };
        let b_ggx = (std::f64::consts::SQRT_2 - 1.0) / s2;
        (1.0 / (1.0 + b_ggx)).sqrt().clamp(1e-6, 1.0)
    }

    /// Anisotropic GGX visible normals for the anisotropic kind's (1 + bx·hu² + by·hv²)^(−c)
    /// with axis angle `psi_deg`: each axis's roughness matched at half the peak, as
    /// [`Shape::visible_normals`] matches the isotropic kinds'.
    pub(crate) fn visible_normals_aniso(
        bx: f64,
        by: f64,
        c: f64,
        psi_deg: f64,
        wi: [f64; 3],
    ) -> Self {
        let (s, k) = psi_deg.to_radians().sin_cos();
        Self::ggx(
            Self::ggx_alpha(true, bx, c),
            Self::ggx_alpha(true, by, c),
            [k, s],
            wi,
        )
    }

    pub(crate) fn ggx(ax: f64, ay: f64, axis: [f64; 2], wi: [f64; 3]) -> Self {
        let cz = wi[2].max(0.0);
        let (wu, wv) = along(axis, wi);
        let t = (ax * ax * wu * wu + ay * ay * wv * wv).min(1.0);
        let k = 0.5 / (cz + (cz * cz + t).sqrt());
        Shape::VisibleNormals { ax, ay, axis, k }
    }

    /// A direction over the whole sphere from u ∈ [0, 1)²; `wi` is the incident vector (used
    /// by half-vector proposals). None in degenerate cases (a half vector at right angles to
    /// `wi`).
    pub(crate) fn draw(&self, u: [f64; 2], wi: [f64; 3]) -> Option<[f64; 3]> {
        match *self {
            Shape::Cosine => {
                let r = u[0].sqrt();
                let (s, c) = (2.0 * PI * u[1]).sin_cos();
                Some([r * c, r * s, (1.0 - u[0]).sqrt()])
            }
            Shape::CosinePower { p, n } => {
                // cos α = u^(1/(n+1)); sin α from 1 − cos²α = −expm1(2 ln u/(n+1)), exact for
                // the tiny angles of large exponents.
                let e = u[0].ln() / (n + 1.0);
                let cos_a = e.exp();
                let sin_a = (-(2.0 * e).exp_m1()).max(0.0).sqrt();
                Some(around(p, cos_a, sin_a, u[1]))
            }
            Shape::VonMisesFisher { p, kappa, m } => {
                // 1 − cos α = −ln(1 − (1 − u)·m)/κ, by inverting the CDF in cos α.
                let t = (-(-(1.0 - u[0]) * m).ln_1p() / kappa).clamp(0.0, 2.0);
                let sin_a = (t * (2.0 - t)).sqrt();
                Some(around(p, 1.0 - t, sin_a, u[1]))
            }
            Shape::VisibleNormals { ax, ay, axis, .. } => {
                // Heitz 2018, "Sampling the GGX Distribution of Visible Normals" (JCGT 7(4)):
                // the incident vector in the hemisphere configuration, a point on the projected
                // disk warped toward it, back to the ellipsoid configuration; all in the frame
                // of the axes (u, v, z), the normal turned back at the end.
                let (iu, iv) = along(axis, wi);
                let vh = normalize([ax * iu, ay * iv, wi[2].max(0.0)])?;
                let len2 = vh[0] * vh[0] + vh[1] * vh[1];
                let t1 = if len2 > 0.0 {
                    let inv = 1.0 / len2.sqrt();
                    [-vh[1] * inv, vh[0] * inv, 0.0]
                } else {
                    [1.0, 0.0, 0.0]
                };
                let t2 = [
                    vh[1] * t1[2] - vh[2] * t1[1],
                    vh[2] * t1[0] - vh[0] * t1[2],
                    vh[0] * t1[1] - vh[1] * t1[0],
                ];
                let r = u[0].sqrt();
                let (sp, cp) = (2.0 * PI * u[1]).sin_cos();
                let p1 = r * cp;
                let sw = 0.5 * (1.0 + vh[2]);
                let p2 = (1.0 - sw) * (1.0 - p1 * p1).max(0.0).sqrt() + sw * r * sp;
                let pz = (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
                let nh = [
                    p1 * t1[0] + p2 * t2[0] + pz * vh[0],
                    p1 * t1[1] + p2 * t2[1] + pz * vh[1],
                    p1 * t1[2] + p2 * t2[2] + pz * vh[2],
                ];
                let hl = normalize([ax * nh[0], ay * nh[1], nh[2].max(0.0)])?;
                let h = [
                    hl[0] * axis[0] - hl[1] * axis[1],
                    hl[0] * axis[1] + hl[1] * axis[0],
                    hl[2],
                ];
                let d = dot(wi, h);
                if d <= 0.0 {
                    return None;
                }
                normalize([
                    2.0 * d * h[0] - wi[0],
                    2.0 * d * h[1] - wi[1],
                    2.0 * d * h[2] - wi[2],
                ])
            }
        }
    }

    /// The density over the sphere (1/sr) at the unit vector `wo`.
    pub(crate) fn density(&self, wo: [f64; 3], wi: [f64; 3]) -> f64 {
        match *self {
            Shape::Cosine => wo[2].max(0.0) / PI,
            Shape::CosinePower { p, n } => {
                let g = dot(wo, p).min(1.0);
                if g <= 0.0 {
                    return 0.0; // the mirrored direction usually lies here
                }
                (n + 1.0) / (2.0 * PI) * (n * g.ln()).exp()
            }
            Shape::VonMisesFisher { p, kappa, m } => {
                let g = dot(wo, p).clamp(-1.0, 1.0);
                kappa / (2.0 * PI * m) * (kappa * (g - 1.0)).exp()
            }
            Shape::VisibleNormals { ax, ay, axis, k } => {
                // The normal that reflects wi into wo; only normals above the surface that face
                // wi are drawn.
                let Some(h) = normalize([wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]]) else {
                    return 0.0;
                };
                if h[2] <= 0.0 || dot(wi, h) <= 0.0 {
                    return 0.0;
                }
                // D = 1/(π·ax·ay·t²), t = hu²/ax² + hv²/ay² + hz² (for ax = ay = α, α²/(π(α²
                // cos²θh + sin²θh)²)), sin²θh from the tangential part (exact near the pole).
                let (hu, hv) = along(axis, h);
                let t = hu * hu / (ax * ax) + hv * hv / (ay * ay) + h[2] * h[2];
                k / (PI * ax * ay * t * t)
            }
        }
    }
}
