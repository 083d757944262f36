"""The analytic material the Mitsuba tests render twice: encoded as .sbrdf through the plugin,
and written here as a plain Python ``mi.BSDF`` with Dr.Jit math (no sbrdf code, no numpy in the
render path), so that the plugin's conventions (direction naming, cosine factor, wavelengths,
RGB conversion) are checked against an independent implementation.

The material: GGX (α = 0.3, height-correlated Smith shadowing, Schlick Fresnel with a
spectral F0) over a Lambert base with a spectral albedo. Both spectra are smooth Gaussians, so
10 nm samples lose nothing. In sbrdf's naming (wi toward the light):

    ρ(wi, wo, λ) = kd(λ)/π + D(h)·G2(wi, wo)·F(wi·h, λ) / (4 cos θi cos θo)
"""

from pathlib import Path

import numpy as np

ALPHA = 0.3
ROOT = Path(__file__).resolve().parents[2]

# The spectra (λ in nm): a reddish base and a bluish coat.
KD = (0.15, 0.45, 610.0, 110.0)  # kd = a + b·exp(−((λ − c)/d)²)
F0 = (0.04, 0.35, 450.0, 120.0)

#: Incidences (degrees) and wavelengths (nm) the material is sampled at for encoding:
#: every 5° to 85° and 88°, Mitsuba's whole 360–830 nm every 10 nm.
INCIDENCES = [float(t) for t in range(0, 90, 5)] + [88.0]
WAVELENGTHS = np.arange(360.0, 831.0, 10.0)


def gauss(params, lam, exp=np.exp):
    a, b, c, d = params
    return a + b * exp(-(((lam - c) / d) ** 2))


def value_np(wi, wo, lam):
    """ρ in 1/sr for unit vectors wi (toward the light), wo (N, 3) and wavelengths (M,):
    shape (N, M). numpy; used to make the samples that get encoded."""
    ci, co = wi[:, 2], wo[:, 2]
    h = wi + wo
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    ch = h[:, 2]
    a2 = ALPHA * ALPHA
    d = a2 / (np.pi * (ch * ch * (a2 - 1.0) + 1.0) ** 2)

    def lam_smith(c):
        t2 = np.maximum(1.0 - c * c, 0.0) / (c * c)
        return 0.5 * (-1.0 + np.sqrt(1.0 + a2 * t2))

    g = 1.0 / (1.0 + lam_smith(ci) + lam_smith(co))
    x = (1.0 - np.sum(wi * h, axis=1)) ** 5
    spec = d * g / (4.0 * ci * co)
    f0 = gauss(F0, lam)[None, :]
    f = f0 * (1.0 - x[:, None]) + x[:, None]
    out = gauss(KD, lam)[None, :] / np.pi + spec[:, None] * f
    return np.where(((ci > 0) & (co > 0))[:, None], out, 0.0)


def direction(theta_deg, phi_deg):
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)


def samples():
    """The long-layout columns for ``sbrdf.encode``: every incidence in INCIDENCES at φi = 0,
    outgoing θo = 2.5…87.5° × φo = 0…355° every 5°, WAVELENGTHS."""
    to, po = np.meshgrid(np.arange(2.5, 90.0, 5.0), np.arange(0.0, 360.0, 5.0), indexing="ij")
    to, po = to.ravel(), po.ravel()
    wo = direction(to, po)
    cols = {k: [] for k in ("theta_i", "phi_i", "theta_o", "phi_o", "wavelength_nm", "value")}
    m = len(WAVELENGTHS)
    for ti in INCIDENCES:
        wi = np.repeat(direction(ti, 0.0)[None, :], len(to), axis=0)
        v = value_np(wi, wo, WAVELENGTHS)
        cols["theta_i"].append(np.full(v.size, ti))
        cols["phi_i"].append(np.zeros(v.size))
        cols["theta_o"].append(np.repeat(to, m))
        cols["phi_o"].append(np.repeat(po, m))
        cols["wavelength_nm"].append(np.tile(WAVELENGTHS, len(to)))
        cols["value"].append(v.ravel())
    return {k: np.concatenate(v) for k, v in cols.items()}


def linear_srgb(spectrum_fn):
    """Linear sRGB of a spectrum under D65, computed as sbrdf's decoder does (CIE 1931 2°,
    380–780 nm every 5 nm, from the shipped table; Σ s·E·x̄ / Σ E·ȳ, then the IEC matrix)."""
    t = np.loadtxt(ROOT / "samples/cie1931_2deg_d65_380_780_5nm.csv", delimiter=",",
                   comments="#", skiprows=3)
    lam, xb, yb, zb, e = t.T
    s = spectrum_fn(lam)
    xyz = np.array([np.sum(s * e * xb), np.sum(s * e * yb), np.sum(s * e * zb)]) / np.sum(e * yb)
    m = np.array([[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]])
    return m @ xyz


def reference_bsdf_class(mi, dr):
    """The material as a plain ``mi.BSDF`` for the current variant, sampling the cosine-weighted
    hemisphere. Mitsuba's names: si.wi toward the camera, wo toward the light."""
    spectral = bool(mi.is_spectral)
    if not spectral:
        kd_rgb = linear_srgb(lambda lam: gauss(KD, lam))
        f0_rgb = linear_srgb(lambda lam: gauss(F0, lam))
        one_rgb = linear_srgb(lambda lam: np.ones_like(lam))

    class Reference(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            self.m_flags = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide
            self.m_components = [self.m_flags]

        def value(self, si, wo):
            ci = mi.Frame3f.cos_theta(wo)      # the light side: sbrdf's wi
            co = mi.Frame3f.cos_theta(si.wi)   # the camera side: sbrdf's wo
            h = dr.normalize(wo + si.wi)
            ch = mi.Frame3f.cos_theta(h)
            a2 = ALPHA * ALPHA
            d = a2 / (dr.pi * dr.square(ch * ch * (a2 - 1.0) + 1.0))

            def lam_smith(c):
                t2 = dr.maximum(1.0 - c * c, 0.0) / (c * c)
                return 0.5 * (-1.0 + dr.sqrt(1.0 + a2 * t2))

            g = 1.0 / (1.0 + lam_smith(ci) + lam_smith(co))
            x = dr.power(1.0 - dr.dot(wo, h), 5)
            spec = d * g / (4.0 * ci * co)
            if spectral:
                lam = si.wavelengths
                kd = gauss(KD, lam, dr.exp)
                f0 = gauss(F0, lam, dr.exp)
                f = kd / dr.pi + spec * (f0 * (1.0 - x) + x)
            else:
                kd = mi.Color3f(*[float(v) for v in kd_rgb])
                f0 = mi.Color3f(*[float(v) for v in f0_rgb])
                one = mi.Color3f(*[float(v) for v in one_rgb])
                f = kd / dr.pi + spec * (f0 * (1.0 - x) + one * x)
            ok = (ci > 0) & (co > 0)
            return dr.select(ok, f * ci, 0.0)

        def eval(self, ctx, si, wo, active=True):
            return dr.select(active, self.value(si, wo), 0.0)

        def pdf(self, ctx, si, wo, active=True):
            p = mi.warp.square_to_cosine_hemisphere_pdf(wo)
            return dr.select(active & (mi.Frame3f.cos_theta(si.wi) > 0), p, 0.0)

        def eval_pdf(self, ctx, si, wo, active=True):
            return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

        def sample(self, ctx, si, sample1, sample2, active=True):
            wo = mi.warp.square_to_cosine_hemisphere(sample2)
            pdf = mi.warp.square_to_cosine_hemisphere_pdf(wo)
            active = active & (mi.Frame3f.cos_theta(si.wi) > 0) & (pdf > 0)
            bs = mi.BSDFSample3f()
            bs.wo = wo
            bs.pdf = pdf
            bs.eta = 1.0
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
            bs.sampled_component = mi.UInt32(0)
            w = self.value(si, wo) / dr.select(active, pdf, 1.0)
            return bs, dr.select(active, w, 0.0)

        def to_string(self):
            return "AnalyticReference[GGX 0.3 over Lambert]"

    return Reference
