"""The Mitsuba 3 plugin (``sbrdf.mitsuba``) in real renders, against the same analytic material
written as a plain Python ``mi.BSDF`` (``analytic.py``).

A 64×64 sphere, 16 samples per pixel, lit once by a point light and once by a constant
environment, in ``scalar_spectral`` and ``scalar_rgb`` and, where Dr.Jit's LLVM backend works,
``llvm_ad_spectral`` and ``llvm_ad_rgb``. The figures land in $SBRDF_MITSUBA_REPORT (JSON) when
it is set; CI prints them.

* Matched sampling: the plugin with ``sampling="cosine"`` and the reference (cosine-weighted)
  draw the same directions from the same seed, so the two images differ only by what the BSDFs
  return. Required: mean relative difference ≤ 1% per light.
* The file's importance sampling: unbiased (same image mean as cosine sampling, within 1%) and
  no more variance than cosine sampling (per-pixel variance over four seeds; the ratio is
  reported).
"""

import numpy as np
import pytest

mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 is not installed (pip install mitsuba)")
dr = pytest.importorskip("drjit", reason="Dr.Jit is not installed (it comes with mitsuba)")

import analytic  # noqa: E402  (python/tests, beside this file)
from support import llvm_status, record  # noqa: E402  (python/tests, beside this file)
import sbrdf  # noqa: E402

SCALAR = ["scalar_spectral", "scalar_rgb"]
LLVM = ["llvm_ad_spectral", "llvm_ad_rgb"]
RES, SPP = 64, 16


def use_variant(variant):
    if variant.startswith("llvm"):
        ok, why = llvm_status()
        if not ok:
            pytest.skip(why)
    mi.set_variant(variant)
    import sbrdf.mitsuba as plugin
    plugin.register()
    ref = analytic.reference_bsdf_class(mi, dr)
    mi.register_bsdf("analytic_reference", lambda props: ref(props))


@pytest.fixture(scope="session")
def encoded(tmp_path_factory):
    """The analytic material encoded with the defaults (19 incidences, 360–830 nm)."""
    path = tmp_path_factory.mktemp("mitsuba") / "analytic.sbrdf"
    summary = sbrdf.encode(analytic.samples(), str(path), metadata={
        "source": "python/tests/analytic.py: GGX 0.3 over Lambert"})
    record("encoded_analytic", {"bytes": summary["bytes"], "rel_error": summary["rel_error"],
                                "worst_error": summary["worst_error"]})
    # The guide's figures for this file (renderers.md): 3 013 bytes, 0.06% error, held at 1.25×.
    assert summary["bytes"] <= 1.25 * 3013, summary
    assert summary["rel_error"] <= 1.25 * 0.0006, summary
    return path


def scene(bsdf, light, spp=SPP):
    d = {
        "type": "scene",
        # camera → sphere → light: a convex sphere never sees itself, so this is all the light
        "integrator": {"type": "path", "max_depth": 3},
        "sensor": {
            "type": "perspective",
            "fov": 27,
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 5], target=[0, 0, 0],
                                                       up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": RES, "height": RES, "rfilter": {"type": "box"},
                     "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "sphere": {"type": "sphere", "bsdf": bsdf},
    }
    if light == "point":
        d["light"] = {"type": "point", "position": [2.5, 2.0, 4.0],
                      "intensity": {"type": "spectrum", "value": 25.0}}
    else:
        d["light"] = {"type": "constant", "radiance": {"type": "spectrum", "value": 1.0}}
    return mi.load_dict(d)


def render(bsdf, light, seed=0, spp=SPP):
    return np.array(mi.render(scene(bsdf, light, spp), seed=seed, spp=spp), dtype=np.float64)


def sphere_mask():
    """Pixels whose whole footprint sees the sphere (its four corners hit it): background and
    silhouette pixels, where both renders see the same environment, are left out."""
    fov = np.radians(27.0)
    t = np.tan(fov / 2)
    c = np.linspace(-t, t, RES + 1)
    x, y = np.meshgrid(c, c)
    # Ray from (0, 0, 5) toward (x, y, -1): distance of the line from the centre < 1.
    d = np.stack([x, y, -np.ones_like(x)], -1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    o = np.array([0.0, 0.0, 5.0])
    b = d @ o
    hit = b * b - (o @ o - 1.0) > 0
    return hit[:-1, :-1] & hit[1:, :-1] & hit[:-1, 1:] & hit[1:, 1:]


def mean_rel_diff(a, b, mask):
    """Σ|a − b| / Σ|b| over the masked pixels and the three channels."""
    a, b = a[mask], b[mask]
    return float(np.abs(a - b).sum() / np.abs(b).sum())


def pixel_rel_diff(a, b, mask):
    """Mean over lit masked pixels (luminance above 1% of the brightest) of |a − b| / b."""
    la, lb = a[mask].mean(-1), b[mask].mean(-1)
    lit = lb > 0.01 * lb.max()
    return float(np.mean(np.abs(la[lit] - lb[lit]) / lb[lit]))


# Mean relative difference from the reference, as docs/guide/renderers.md's table states it.
STATED_RENDER_DIFF = {
    ("scalar_spectral", "point"): 0.0013, ("scalar_spectral", "environment"): 0.00088,
    ("scalar_rgb", "point"): 0.0012, ("scalar_rgb", "environment"): 0.00080,
    ("llvm_ad_spectral", "point"): 0.0013, ("llvm_ad_spectral", "environment"): 0.00087,
    ("llvm_ad_rgb", "point"): 0.0012, ("llvm_ad_rgb", "environment"): 0.00079,
}


@pytest.mark.parametrize("light", ["point", "environment"])
@pytest.mark.parametrize("variant", SCALAR + LLVM)
def test_plugin_renders_like_the_reference(variant, light, encoded):
    use_variant(variant)
    mask = sphere_mask()
    ours = render({"type": "sbrdf", "filename": str(encoded), "sampling": "cosine"}, light)
    ref = render({"type": "analytic_reference"}, light)
    assert np.all(np.isfinite(ours)) and ours[mask].mean() > 0.05
    d, p = mean_rel_diff(ours, ref, mask), pixel_rel_diff(ours, ref, mask)
    record(f"render/{variant}/{light}", {"mean_rel_diff": d, "mean_pixel_rel_diff": p,
                                         "sphere_pixels": int(mask.sum())})
    # The acceptance target is 1%; the guide's table, held at 1.25×, is tighter.
    stated = STATED_RENDER_DIFF[(variant, light)]
    assert d <= 0.01 and d <= 1.25 * stated, (
        f"{variant}, {light} light: mean relative difference {d:.5f}, the guide states {stated}")
    if light == "point":
        # Emitter sampling only: the image does not depend on the BSDF's sampling at all.
        ours_is = render({"type": "sbrdf", "filename": str(encoded)}, light)
        np.testing.assert_allclose(ours_is, ours, rtol=1e-5, atol=1e-6)


INTEGRATORS = {
    # What renders use: emitter sampling and BSDF sampling combined by MIS.
    "path_mis": {"type": "path", "max_depth": 3},
    # BSDF sampling alone: how well the sampling follows the integrand.
    "bsdf_only": {"type": "direct", "emitter_samples": 0, "bsdf_samples": 1},
}


# Cosine sampling's per-pixel variance over the file's, as docs/guide/renderers.md states it
# (None: any other variant).
STATED_VARIANCE_RATIO = {
    "bsdf_only": {"scalar_spectral": 3.1, "llvm_ad_spectral": 3.5, "llvm_ad_rgb": 5.0, None: 3.1},
    "path_mis": {None: 1.9},
}


@pytest.mark.parametrize("integrator", list(INTEGRATORS))
@pytest.mark.parametrize("variant", ["scalar_spectral", "llvm_ad_spectral", "llvm_ad_rgb"])
def test_importance_sampling_beats_cosine(variant, integrator, encoded):
    """Under the constant environment, per-pixel variance over four seeds (16 spp each) with
    the file's sampling and with cosine sampling; both must give the same image mean."""
    use_variant(variant)
    mask = sphere_mask()

    def renders(sampling):
        bsdf = {"type": "sbrdf", "filename": str(encoded), "sampling": sampling}
        out = []
        for seed in range(4):
            sc = scene(bsdf, "environment")
            integ = mi.load_dict(INTEGRATORS[integrator])
            out.append(np.array(mi.render(sc, integrator=integ, seed=seed, spp=SPP)))
        return np.stack(out).astype(np.float64)

    file_, cos_ = renders("file"), renders("cosine")
    var_file = file_.var(axis=0, ddof=1)[mask].mean()
    var_cos = cos_.var(axis=0, ddof=1)[mask].mean()
    ratio = float(var_cos / var_file)
    mean_file, mean_cos = file_.mean(0)[mask].mean(), cos_.mean(0)[mask].mean()
    bias = float(abs(mean_file - mean_cos) / mean_cos)
    record(f"sampling/{variant}/{integrator}", {"variance_cosine_over_file": ratio,
                                                "image_mean_rel_diff": bias})
    # The guide's figures (renderers.md): means within 0.07–0.2%, variance ratios 3.1× / 3.5× /
    # 5.0× with BSDF sampling alone and 1.9–2.2× with MIS, each held at 1.25× (the seeds are
    # fixed, so a run repeats them).
    stated = STATED_VARIANCE_RATIO[integrator].get(variant, STATED_VARIANCE_RATIO[integrator][None])
    assert bias <= 1.25 * 0.002, f"importance-sampled image mean off by {bias:.4f}"
    assert ratio >= stated / 1.25, (
        f"cosine sampling's variance is {ratio:.2f}× the file's; the guide states {stated}×")


def test_plugin_conventions_at_single_directions(encoded):
    """eval, pdf, eval_pdf and sample called directly, scalar_spectral: Mitsuba's wo is the
    light side; eval includes cos θ(wo); sample's weight is eval/pdf at its own direction."""
    use_variant("scalar_spectral")
    bsdf = mi.load_dict({"type": "sbrdf", "filename": str(encoded)})
    assert "GlossyReflection" in str(bsdf.flags()) or bsdf.flags() & int(
        mi.BSDFFlags.GlossyReflection)
    ctx = mi.BSDFContext()
    si = mi.SurfaceInteraction3f()
    si.wavelengths = mi.Spectrum(400.0, 500.0, 600.0, 700.0)
    view = analytic.direction(50.0, 0.0)
    light = analytic.direction(35.0, 170.0)
    si.wi = mi.Vector3f(*view)
    got = np.array(bsdf.eval(ctx, si, mi.Vector3f(*light)))
    want = analytic.value_np(light[None], view[None], np.array([400.0, 500.0, 600.0, 700.0]))[0]
    np.testing.assert_allclose(got, want * light[2], rtol=0.02)
    pdf = bsdf.pdf(ctx, si, mi.Vector3f(*light))
    value, pdf2 = bsdf.eval_pdf(ctx, si, mi.Vector3f(*light))
    assert pdf > 0 and abs(pdf2 - pdf) <= 1e-6 * pdf
    np.testing.assert_allclose(np.array(value), got, rtol=1e-6)
    bs, weight = bsdf.sample(ctx, si, 0.5, mi.Point2f(0.3, 0.7))
    assert bs.pdf > 0 and bs.wo.z > 0
    np.testing.assert_allclose(bs.pdf, bsdf.pdf(ctx, si, bs.wo), rtol=1e-5)
    np.testing.assert_allclose(np.array(weight),
                               np.array(bsdf.eval(ctx, si, bs.wo)) / bs.pdf, rtol=1e-5)
    # Below the horizon on either side: nothing.
    assert np.all(np.array(bsdf.eval(ctx, si, mi.Vector3f(0.3, 0.0, -0.95))) == 0)
    si.wi = mi.Vector3f(0.3, 0.0, -0.95)
    assert bsdf.pdf(ctx, si, mi.Vector3f(*light)) == 0
    # Wavelengths outside the file's 360–830 nm hold its end values.
    si.wi = mi.Vector3f(*view)
    si.wavelengths = mi.Spectrum(300.0, 360.0, 830.0, 900.0)
    v = np.array(bsdf.eval(ctx, si, mi.Vector3f(*light)))
    assert v[0] == v[1] and v[2] == v[3]


def test_bad_parameters_are_refused(encoded, tmp_path):
    use_variant("scalar_spectral")
    with pytest.raises(Exception, match="filename"):
        mi.load_dict({"type": "sbrdf"})
    with pytest.raises(Exception, match="sampling"):
        mi.load_dict({"type": "sbrdf", "filename": str(encoded), "sampling": "uniform"})
    with pytest.raises(Exception, match="not found"):
        mi.load_dict({"type": "sbrdf", "filename": str(tmp_path / "missing.sbrdf")})
    junk = tmp_path / "junk.sbrdf"
    junk.write_bytes(b"not an sbrdf file")
    with pytest.raises(Exception, match="sbrdf"):
        mi.load_dict({"type": "sbrdf", "filename": str(junk)})
    mi.set_variant("scalar_spectral_polarized")
    import sbrdf.mitsuba as plugin
    with pytest.raises(RuntimeError, match="not supported"):
        plugin.register()
