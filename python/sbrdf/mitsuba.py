"""Mitsuba 3 plugin: render .sbrdf files with the BSDF type ``sbrdf``.

    import mitsuba as mi
    mi.set_variant("scalar_spectral")   # or scalar_rgb, llvm_ad_spectral, llvm_ad_rgb
    import sbrdf.mitsuba                 # registers "sbrdf" for the variant set now
    bsdf = {"type": "sbrdf", "filename": "gold.sbrdf"}          # in a scene dict, or in XML:
    # <bsdf type="sbrdf"><string name="filename" value="gold.sbrdf"/></bsdf>

After ``mi.set_variant`` switches to another variant, call ``sbrdf.mitsuba.register()`` again
(a Mitsuba BSDF class belongs to one variant).

Parameters
    ``filename``  the .sbrdf file, found through Mitsuba's file resolver like any scene file.
    ``sampling``  ``"file"`` (default): the file's own importance sampling (``Material.sample``,
                  a density following the spectrum-averaged ρ·cos); ``"cosine"``: cosine-weighted
                  hemisphere sampling (Mitsuba's warp), for comparisons.

What it computes (``si.wi`` points toward the camera and ``wo`` toward the light in Mitsuba,
the opposite naming of sbrdf, whose ``wi`` points toward the light):

* ``eval`` = ρ(wi = Mitsuba's wo, wo = Mitsuba's si.wi, λ) · cos θ(Mitsuba's wo), 0 when either
  direction is below the horizon (one-sided, as Mitsuba's own BSDFs; wrap it in ``twosided``
  for sheets);
* ``sample`` draws the light-side direction for the camera-side one, ``Material.sample(si.wi)``,
  and returns eval/pdf; ``pdf`` is ``Material.pdf(si.wi, wo)``, the density of exactly that
  draw. Drawing from the camera side relies on reciprocity as every path tracer does (sbrdf's
  `docs/guide/library.md` ("Importance sampling") measures |ρ(wi, wo) − ρ(wo, wi)| at 0.06–0.11% for reciprocal inputs); the estimate
  stays unbiased either way, since weight and pdf are consistent;
* spectral variants: the file is evaluated at the path's own four wavelengths
  (``si.wavelengths``). Outside the file's wavelength range the values at its ends are held
  (the decoder's rule, ``spec/EVALUATION.md``), so a file measured over 380–780 nm keeps its
  end colours in Mitsuba's 360–830 nm;
* RGB variants: ρ is evaluated at 380–780 nm every 5 nm and integrated against the CIE 1931 2°
  observer under D65, then the sRGB matrix (``Material.eval_rgb``, the decoder's
  ``eval_linear_srgb``): a spectrum constant at 1 gives (1, 1, 1), as an RGB reflectance of
  white would. Out-of-gamut components are passed on unclamped. It costs 81 wavelengths per
  evaluation instead of 4;
* flags: ``GlossyReflection | FrontSide``, one component, so integrators treat it as a glossy
  reflection (MIS with emitter sampling, no delta handling).

Variants: ``scalar_spectral`` and ``scalar_rgb`` call the binding once per direction; the JIT
variants (``llvm_ad_spectral``, ``llvm_ad_rgb``) need Dr.Jit's symbolic calls and loops
switched off, which ``register`` does, so that ``eval``, ``pdf`` and ``sample`` receive whole
wavefronts as arrays and hand them to the vectorised, GIL-releasing ``Material`` methods in one
call each. Polarised and monochromatic variants are refused with a message. Gradients do not
flow through the file (it is a fixed measurement).
"""

from __future__ import annotations

import os

import numpy as np

import drjit as dr
import mitsuba as mi

from . import open as _open

SAMPLING = ("file", "cosine")
SUPPORTED = ("scalar_spectral", "scalar_rgb", "llvm_ad_spectral", "llvm_ad_rgb")


def _check_variant() -> str:
    v = mi.variant()
    if v is None:
        raise RuntimeError(
            "sbrdf.mitsuba: no Mitsuba variant is set; call mi.set_variant('scalar_spectral') "
            "(or scalar_rgb, llvm_ad_spectral, llvm_ad_rgb) first"
        )
    if mi.is_polarized or mi.is_monochromatic:
        raise RuntimeError(
            f"sbrdf.mitsuba: variant {v} is not supported (polarised or monochromatic); "
            f"supported: {', '.join(SUPPORTED)}"
        )
    return v


def _make_class():
    """The BSDF class for the current variant (it derives from that variant's mi.BSDF)."""
    scalar = mi.variant().startswith("scalar")
    spectral = bool(mi.is_spectral)
    Float = mi.Float

    def rows3(v) -> np.ndarray:
        """A Mitsuba 3-vector (one, or a wavefront) as an (N, 3) float32 array."""
        if scalar:
            return np.array([[v[0], v[1], v[2]]], dtype=np.float32)
        return np.stack(
            [np.asarray(v.x, dtype=np.float32), np.asarray(v.y, dtype=np.float32),
             np.asarray(v.z, dtype=np.float32)],
            axis=1,
        )

    def rows2(v) -> np.ndarray:
        if scalar:
            return np.array([[v[0], v[1]]], dtype=np.float32)
        return np.stack(
            [np.asarray(v.x, dtype=np.float32), np.asarray(v.y, dtype=np.float32)], axis=1
        )

    def wavelength_rows(si) -> np.ndarray:
        w = si.wavelengths
        if scalar:
            return np.array([[w[k] for k in range(len(w))]], dtype=np.float32)
        return np.stack([np.asarray(w[k], dtype=np.float32) for k in range(4)], axis=1)

    def to_spectrum(a: np.ndarray):
        """(N, C) values as a Mitsuba Spectrum (C = 4 spectral, 3 RGB)."""
        if scalar:
            return mi.Spectrum(*[float(x) for x in a[0]])
        return mi.Spectrum(*[Float(np.ascontiguousarray(a[:, k])) for k in range(a.shape[1])])

    def to_float(a: np.ndarray):
        return float(a[0]) if scalar else Float(np.ascontiguousarray(a))

    def to_vector(a: np.ndarray):
        if scalar:
            return mi.Vector3f(float(a[0, 0]), float(a[0, 1]), float(a[0, 2]))
        return mi.Vector3f(*[Float(np.ascontiguousarray(a[:, k])) for k in range(3)])

    class SbrdfBSDF(mi.BSDF):
        """An .sbrdf file as a glossy reflection (see the module documentation)."""

        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            if "filename" not in props:
                raise ValueError("sbrdf BSDF: the 'filename' parameter is required")
            name = str(props["filename"])
            path = str(mi.file_resolver().resolve(name))
            if not os.path.exists(path):
                raise ValueError(f"sbrdf BSDF: {name}: file not found")
            self.filename = path
            self.material = _open(path)
            self.sampling = str(props["sampling"]) if "sampling" in props else "file"
            if self.sampling not in SAMPLING:
                raise ValueError(
                    f"sbrdf BSDF: sampling '{self.sampling}': expected one of {', '.join(SAMPLING)}"
                )
            flags = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide
            self.m_flags = flags
            self.m_components = [flags]

        def _value(self, si, wo):
            """Mitsuba's eval without masks: f(light = wo, view = si.wi) · cos θ(wo)."""
            light, view = rows3(wo), rows3(si.wi)
            if spectral:
                f = self.material.eval(light, view, wavelength_rows(si))
            else:
                f = self.material.eval_rgb(light, view)
            f *= np.maximum(light[:, 2], 0.0)[:, None]
            return to_spectrum(f)

        def _pdf(self, si, wo):
            if self.sampling == "cosine":
                p = mi.warp.square_to_cosine_hemisphere_pdf(wo)
                return dr.select(mi.Frame3f.cos_theta(si.wi) > 0, p, 0.0)
            return to_float(self.material.pdf(rows3(si.wi), rows3(wo)))

        def eval(self, ctx, si, wo, active=True):
            if not ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 0):
                return mi.Spectrum(0.0)
            return dr.select(active, self._value(si, wo), 0.0)

        def pdf(self, ctx, si, wo, active=True):
            if not ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 0):
                return Float(0.0)
            return dr.select(active, self._pdf(si, wo), 0.0)

        def eval_pdf(self, ctx, si, wo, active=True):
            if not ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 0):
                return mi.Spectrum(0.0), Float(0.0)
            value = dr.select(active, self._value(si, wo), 0.0)
            return value, dr.select(active, self._pdf(si, wo), 0.0)

        def sample(self, ctx, si, sample1, sample2, active=True):
            bs = dr.zeros(mi.BSDFSample3f) if scalar else dr.zeros(
                mi.BSDFSample3f, dr.width(sample2))
            if not ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 0):
                return bs, mi.Spectrum(0.0)
            if self.sampling == "cosine":
                wo = mi.warp.square_to_cosine_hemisphere(sample2)
                pdf = mi.warp.square_to_cosine_hemisphere_pdf(wo)
                pdf = dr.select(mi.Frame3f.cos_theta(si.wi) > 0, pdf, 0.0)
            else:
                wo_np, pdf_np = self.material.sample(rows3(si.wi), rows2(sample2))
                wo, pdf = to_vector(wo_np), to_float(pdf_np)
            active = active & (pdf > 0)
            value = self._value(si, wo)
            bs.wo = wo
            bs.pdf = pdf
            bs.eta = 1.0
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
            bs.sampled_component = mi.UInt32(0)
            weight = dr.select(active, value / dr.select(active, pdf, 1.0), 0.0)
            return bs, weight

        def to_string(self):
            m = self.material
            wl = m.wavelengths
            return (
                f"SbrdfBSDF[filename={self.filename!r}, sampling={self.sampling}, "
                f"{len(m.info['records'])} incidences, {wl[0]:g}–{wl[-1]:g} nm]"
            )

    return SbrdfBSDF


def register() -> None:
    """Registers the BSDF type ``sbrdf`` for the current Mitsuba variant. In the JIT variants
    it switches Dr.Jit's symbolic calls and loops off (the plugin computes on concrete
    wavefronts, outside the JIT)."""
    variant = _check_variant()
    if not variant.startswith("scalar"):
        dr.set_flag(dr.JitFlag.SymbolicCalls, False)
        dr.set_flag(dr.JitFlag.SymbolicLoops, False)
    cls = _make_class()
    mi.register_bsdf("sbrdf", lambda props: cls(props))


try:
    register()
except RuntimeError as e:  # no variant yet, or one the plugin cannot serve
    raise ImportError(str(e)) from None
