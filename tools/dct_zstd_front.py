#!/usr/bin/env python3
"""A plain transform-coding reference for RGL measured BRDFs: the size/render-difference front
of DCT + zstd coding of the warped RGB tables, rendered through Mitsuba 3's own ``measured``
plugin, to compare the sbrdf codec's bytes against at the same render difference.

    pip install zstandard mitsuba   # numpy too; scipy is not needed (see step 2)
    apt-get install libllvm19       # for llvm_ad_rgb (Dr.Jit's LLVM backend)
    nice -n 5 python tools/dct_zstd_front.py --out-json dct_front.json
    python tools/dct_zstd_front.py --materials satin_rosaline --settings 0.01 0.03 0.1
    # our codec's front (tools/rgl_front.py --out-json front.json) against this reference:
    python tools/dct_zstd_front.py --load dct_front.json --compare front.json

The reference coder, for one material X_rgb.bsdf (field ``rgb`` [phi_i, theta_i, 3, R, R],
float32; N = phi_i · theta_i incidences) and one setting s:

1. Colour decorrelation: the principal axes of the RGB values (eigenvectors of their 3 × 3
   second moment Σ x xᵀ over every node of every incidence, about 0, the tables having no
   stored offset), largest eigenvalue first, each axis' sign chosen so that its largest
   component is positive. The matrix A (rows: axes) is stored as 9 f16 = 18 bytes; the coder
   uses the f16-rounded A and its exact float64 inverse, so the round trip sees what a decoder
   would.
2. Per incidence i and rotated channel c: the 2-D orthonormal DCT-II of the R × R table
   (scipy.fft.dctn(t, norm="ortho"); computed here as D t Dᵀ with the orthonormal DCT-II matrix
   D, the same transform, so that scipy is not a dependency).
3. Uniform quantisation with one step per incidence, q_i = s · ‖Y_i‖₂ / R, where Y_i is
   incidence i's three rotated tables (so s is relative: with R² coefficients per table, a step
   of s‖Y_i‖/R is a fixed fraction of the RMS coefficient), rounded to float32 (4 bytes each,
   counted) and used as such; levels = round(coefficient / q_i) (plain rounding, no dead zone),
   int32.
4. Bytes: the levels serialised two ways, each compressed by zstd level 19, the smaller kept:
   (a) "raster": the [N, 3, R, R] array in C order as int16 little-endian (int32 if a level
   falls outside int16); (b) "diagonal": per table (incidence-major, then channel), the levels in
   diagonal order (a + b ascending, then a, for coefficient [a, b]), zigzag-mapped (0, −1, 1,
   −2, … → 0, 1, 2, 3, …) and written as LEB128 varints, all tables in one stream. Plus the
   steps (4 B × N), the colour matrix (18 B) and the NDF as f16 (2 B × each distinct row's
   values of the ``ndf`` field: its rows are per φi, and an isotropic file's two rows are
   identical, so 128 values; the warp needs them once, as the codec's files store them). Nothing else: no header, no flag saying which
   serialisation won, no sizes (a decoder would need a few bytes more). ``bytes`` is this total.
5. Decode: levels · q_i, inverse DCT, rotate back with A⁻¹, stored as float32 in a copy of the
   source tensor file with only ``rgb`` replaced. The warp fields (``ndf``, ``sigma``, ``vndf``,
   ``luminance``, ...) stay bit-exact: the render difference is the tables' alone, the NDF's f16
   rounding is counted in bytes but not rendered (sigma and vndf, which Mitsuba also reads, are
   derived from the NDF and not counted at all).
6. Render difference, with tools/rgl_render.py's harness (the same scene, seed and figures as
   tools/rgl_front.py reports for the codec): the original file through ``measured`` against
   the reconstructed file through ``measured``, per lighting case (three point lights and a
   constant environment) the relative L1 Σ|rebuilt − original| / Σ|original| over every pixel
   and channel; ``point_worst`` is the worst of the three point lights; and the worst
   directional-albedo difference over θ = 0–70° (rgl_render.albedo). Both renders trace the same
   rays (same seed, no BSDF sampling), so there is no Monte Carlo noise between them. The
   original's images are rendered once per case and reused for every setting. ``floor`` (per
   material) is the original rewritten unchanged through the same writer and rendered: the
   harness's own floor (0, or ~1e-7 where Mitsuba's measured plugin loads a file differently,
   see rgl_render.py).

Also per row: ``table_rel_l2_worst`` = the worst incidence's ‖rebuilt − original‖₂ / ‖original‖₂
over its three RGB tables (the sbrdf encoder's --max-error metric, in the tables' units).

``--compare FRONT_JSON`` reads the codec's front, either tools/rgl_front.py's JSON ({"rows":
[{"material", "bytes", "point_worst", ...}]}) or a plain list of {"material", "bytes",
"max_rel_l1_point"}, and prints for each of its points the reference's bytes at the same worst
point-light render difference (interpolate_bytes_at: log-log interpolation along the
reference's front, Pareto points only, no extrapolation) and the ratio ours / reference.
``--load REF_JSON`` takes the reference front from an earlier run instead of computing it.

As a module: ``encode(fields, s)`` (steps 1–5 on a read_tensor_file dict), ``sweep(...)`` and
``interpolate_bytes_at(front, render_diff)``.
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

import make_spec_bsdf  # noqa: E402  (tools/ on sys.path first)
import rgl_render  # noqa: E402  (imports Mitsuba only when set up)

MATERIALS = ("cc_ibiza_sunset", "paper_white", "satin_rosaline")
# Relative steps, log-spaced (×1.75): on the three shipped materials (llvm_ad_rgb, 128², 64 spp)
# they span worst point-light render differences of 0.14–0.30% (s = 0.008) to 3.2–7.9%
# (s = 0.4), so every material's front covers 0.3–3.2% without extrapolation.
SETTINGS = (0.008, 0.014, 0.024, 0.043, 0.075, 0.13, 0.23, 0.4)
REPORT_AT = (0.005, 0.01, 0.02)
ZSTD_LEVEL = 19


# ---------------------------------------------------------------------------------------------
# The coder


def ndf_values(ndf: np.ndarray) -> int:
    """The NDF values a file must hold: the ``ndf`` field's distinct rows (one per φi; an
    isotropic measurement repeats the same row)."""
    rows = np.asarray(ndf).reshape(ndf.shape[0], -1) if ndf.ndim > 1 else np.asarray(ndf)[None]
    return int(np.unique(rows, axis=0).size)


def dct_matrix(n: int) -> np.ndarray:
    """The orthonormal DCT-II matrix D: D @ x == scipy.fft.dct(x, norm="ortho")."""
    k = np.arange(n)[:, None]
    j = np.arange(n)[None, :]
    d = np.cos(np.pi * (2 * j + 1) * k / (2 * n)) * math.sqrt(2.0 / n)
    d[0] /= math.sqrt(2.0)
    return d


def colour_axes(rgb: np.ndarray) -> np.ndarray:
    """3 × 3 rows = principal axes of the RGB values (rgb [..., 3, R, R]), largest first."""
    x = np.moveaxis(rgb.astype(np.float64), -3, 0).reshape(3, -1)
    w, v = np.linalg.eigh(x @ x.T)
    a = v[:, np.argsort(w)[::-1]].T
    # eigh's signs are arbitrary; fix them so the coder is deterministic across LAPACKs
    sign = np.sign(a[np.arange(3), np.abs(a).argmax(1)])
    return a * sign[:, None]


def diagonal_order(r: int) -> np.ndarray:
    """Flat indices of an r × r table in diagonal order (a + b ascending, then a): low
    frequencies first, so the trailing zeros of each table run together."""
    a, b = np.meshgrid(np.arange(r), np.arange(r), indexing="ij")
    return np.lexsort((a.ravel(), (a + b).ravel()))


def leb128_zigzag(levels: np.ndarray) -> bytes:
    """Signed ints → zigzag → LEB128 varints (7 bits a byte, high bit = more follows)."""
    v = levels.astype(np.int64).ravel()
    z = ((v << 1) ^ (v >> 63)).astype(np.uint64)
    groups = np.stack([(z >> np.uint64(7 * k)) & np.uint64(0x7F) for k in range(10)], 1)
    # a value takes bytes up to its highest non-zero 7-bit group (at least one byte)
    nbytes = np.ones(len(z), np.int64)
    for k in range(1, 10):
        nbytes[(z >> np.uint64(7 * k)) > 0] = k + 1
    more = np.arange(10)[None, :] < (nbytes[:, None] - 1)
    out = (groups | (more.astype(np.uint64) << np.uint64(7))).astype(np.uint8)
    return out[np.arange(10)[None, :] < nbytes[:, None]].tobytes()


def _zstd(data: bytes) -> int:
    import zstandard

    return len(zstandard.ZstdCompressor(level=ZSTD_LEVEL).compress(data))


def encode(fields: dict, s: float) -> dict:
    """Steps 1–5 of the module docstring on a read_tensor_file dict: {"bytes", "parts",
    "rgb" (the rebuilt [phi_i, theta_i, 3, R, R] float32), "table_rel_l2_worst", ...}."""
    rgb = fields["rgb"]
    shape = rgb.shape
    r = shape[-1]
    x = rgb.reshape(-1, 3, r, r).astype(np.float64)  # [N, 3, R, R]
    n = len(x)

    a16 = colour_axes(rgb).astype(np.float16).astype(np.float64)
    a_inv = np.linalg.inv(a16)
    y = np.einsum("dc,ncij->ndij", a16, x)

    d = dct_matrix(r)
    coef = d @ y @ d.T  # per table: D Y Dᵀ

    norms = np.sqrt((y * y).sum(axis=(1, 2, 3)))
    q = (s * norms / r).astype(np.float32)
    safe_q = np.where(q > 0, q, 1.0).astype(np.float64)[:, None, None, None]
    levels = np.rint(coef / safe_q).astype(np.int32)  # rint: plain round-half-even, no dead zone
    levels[q == 0] = 0  # an all-zero incidence has nothing to code

    fits16 = levels.min() >= -32768 and levels.max() <= 32767
    raster = levels.astype("<i2" if fits16 else "<i4").tobytes()
    diag = leb128_zigzag(levels.reshape(n * 3, r * r)[:, diagonal_order(r)])
    by_layout = {"raster": _zstd(raster), "diagonal": _zstd(diag)}
    layout = min(by_layout, key=by_layout.get)
    parts = {"levels": by_layout[layout], "steps": 4 * n, "colour_matrix": 18,
             "ndf": 2 * ndf_values(fields["ndf"])}

    rebuilt_y = d.T @ (levels * q.astype(np.float64)[:, None, None, None]) @ d
    rebuilt = np.einsum("cd,ndij->ncij", a_inv, rebuilt_y).astype(np.float32)
    err = np.sqrt(((rebuilt.astype(np.float64) - x) ** 2).sum(axis=(1, 2, 3)))
    xn = np.sqrt((x * x).sum(axis=(1, 2, 3)))
    rel = np.where(xn > 0, err / np.where(xn > 0, xn, 1.0), 0.0)
    return {
        "bytes": sum(parts.values()), "parts": parts, "levels_layout": layout,
        "levels_bytes_by_layout": by_layout, "levels_dtype": "int16" if fits16 else "int32",
        "nonzero_levels": int(np.count_nonzero(levels)), "levels_total": int(levels.size),
        "table_rel_l2_worst": float(rel.max()), "table_rel_l2_per_incidence": rel.tolist(),
        "rgb": rebuilt.reshape(shape),
    }


def write_rebuilt(fields: dict, rgb: np.ndarray, path) -> None:
    """The source's fields in order, only ``rgb`` replaced: what Mitsuba's measured reads."""
    out = dict(fields)
    out["rgb"] = np.asarray(rgb, np.float32)
    make_spec_bsdf.write_tensor_file(path, out)


# ---------------------------------------------------------------------------------------------
# Rendering (rgl_render's harness, without its sbrdf plugin)


def setup_mitsuba(variant: str) -> None:
    """rgl_render._setup without registering the sbrdf plugin, which this tool never renders
    (so the sbrdf Python package need not be installed)."""
    import drjit as dr
    import mitsuba as mi

    if variant.startswith("llvm") and not dr.has_backend(dr.JitBackend.LLVM):
        raise RuntimeError(f"{variant}: Dr.Jit finds no LLVM backend (apt-get install libllvm19)")
    mi.set_variant(variant)
    rgl_render.mi, rgl_render.dr = mi, dr


def _measured(path) -> dict:
    return {"type": "measured", "filename": str(Path(path).resolve())}


class Reference:
    """The original file's images (one per case) and BSDF, rendered once and reused."""

    def __init__(self, path, cases, res, spp, camera_spp, seed):
        self.path, self.cases = str(path), list(cases)
        self.res, self.spp, self.camera_spp, self.seed = res, spp, camera_spp, seed
        self.images = {c: self._render(path, c) for c in self.cases}
        self.bsdf = rgl_render.mi.load_dict(_measured(path))

    def _render(self, path, case) -> np.ndarray:
        scene = rgl_render.load_scene(_measured(path), case, self.res, self.spp, self.camera_spp)
        return rgl_render.render(scene, self.seed, self.camera_spp)

    def compare(self, path, albedo_grid) -> dict:
        """Render differences of `path` (through measured) against the original."""
        per_case = {c: rgl_render.rel_l1(self._render(path, c), self.images[c])
                    for c in self.cases}
        al = rgl_render.albedo(self.bsdf, rgl_render.mi.load_dict(_measured(path)), albedo_grid)
        points = [v for c, v in per_case.items() if rgl_render.CASES[c] is not None]
        return {"render": per_case,
                "point_worst": max(points) if points else float("nan"),
                "environment": per_case.get("environment", float("nan")),
                "albedo_worst": al["worst_rel_diff"], "albedo_worst_theta_deg":
                    al["worst_theta_deg"]}


def sweep(data_dir, materials, settings, variant="llvm_ad_rgb", res=128, spp=64, camera_spp=1,
          seed=0, albedo_grid=128, work_dir=None, log=None) -> dict:
    """Every (material, setting) row: bytes and render differences; the JSON's dict."""
    log = log or functools.partial(print, flush=True)  # progress as it comes, not at exit
    setup_mitsuba(variant)
    doc = {"variant": variant, "res": res, "spp": spp, "camera_spp": camera_spp, "seed": seed,
           "albedo_grid": albedo_grid, "zstd_level": ZSTD_LEVEL, "settings": list(settings),
           "cases": list(rgl_render.CASES), "materials": {}, "rows": []}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(work_dir) if work_dir else Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        for name in materials:
            src = Path(data_dir) / f"{name}_rgb.bsdf"
            fields = make_spec_bsdf.read_tensor_file(src)
            t = time.perf_counter()
            ref = Reference(src, rgl_render.CASES, res, spp, camera_spp, seed)
            t_ref = time.perf_counter() - t
            # the writer and the plugin's own load-to-load rounding, measured the same way
            same = work / f"{name}_unchanged.bsdf"
            write_rebuilt(fields, fields["rgb"], same)
            floor = ref.compare(same, albedo_grid)
            doc["materials"][name] = {
                "source": str(src), "source_bytes": src.stat().st_size,
                "rgb_shape": list(fields["rgb"].shape), "ndf_values": int(fields["ndf"].size),
                "reference_render_s": round(t_ref, 2),
                "floor": {k: floor[k] for k in ("point_worst", "environment", "albedo_worst")},
            }
            log(f"{name}: original rendered in {t_ref:.1f} s; floor: points "
                f"{floor['point_worst']:.1e}, env {floor['environment']:.1e}, albedo "
                f"{floor['albedo_worst']:.1e}")
            for s in settings:
                t = time.perf_counter()
                enc = encode(fields, s)
                out = work / f"{name}_s{s:g}.bsdf"
                write_rebuilt(fields, enc.pop("rgb"), out)
                row = {"material": name, "s": s, **enc, **ref.compare(out, albedo_grid),
                       "seconds": round(time.perf_counter() - t, 2)}
                doc["rows"].append(row)
                log(format_row(row))
    return doc


def format_row(row) -> str:
    return (f"{row['material']:16s} s={row['s']:<6g} {row['bytes']:6d} B"
            f"  points ≤ {100 * row['point_worst']:.2f}%  env {100 * row['environment']:.2f}%"
            f"  albedo ≤ {100 * row['albedo_worst']:.2f}%  tables ≤ "
            f"{100 * row['table_rel_l2_worst']:.2f}%  ({row['levels_layout']}, "
            f"{row['seconds']:.0f} s)")


# ---------------------------------------------------------------------------------------------
# Interpolation and comparison


def _pairs(front):
    """(render_diff, bytes) from rows (dicts with point_worst or max_rel_l1_point) or pairs."""
    out = []
    for p in front:
        if isinstance(p, dict):
            d = p.get("point_worst", p.get("max_rel_l1_point"))
            out.append((float(d), float(p["bytes"])))
        else:
            out.append((float(p[0]), float(p[1])))
    return out


def interpolate_bytes_at(front, render_diff: float):
    """Bytes along `front` (one material's rows, or (render_diff, bytes) pairs) at a worst
    point-light relative L1 of `render_diff`: linear in log(bytes) against log(diff) between
    the neighbouring points of the front's Pareto set (a point is dropped if one with no larger
    difference takes no more bytes). None outside the front's range: no extrapolation."""
    pts = sorted(p for p in _pairs(front) if p[0] > 0 and p[1] > 0)
    pareto = []
    for d, b in pts:
        if not pareto or b < pareto[-1][1]:
            pareto.append((d, b))
    if not pareto or not pareto[0][0] <= render_diff <= pareto[-1][0]:
        return None
    for (d0, b0), (d1, b1) in zip(pareto, pareto[1:] + pareto[-1:]):
        if d0 <= render_diff <= d1:
            if d1 == d0:
                return b0
            t = math.log(render_diff / d0) / math.log(d1 / d0)
            return math.exp(math.log(b0) + t * math.log(b1 / b0))
    return pareto[-1][1]  # render_diff == the last point's


def load_codec_front(path) -> list:
    """[{material, bytes, point_worst, budget?}] from tools/rgl_front.py's JSON or a plain list
    of {material, bytes, max_rel_l1_point}; rows without bytes (anchors only) are skipped."""
    doc = json.loads(Path(path).read_text())
    rows = doc["rows"] if isinstance(doc, dict) else doc
    out = []
    for r in rows:
        d = r.get("point_worst", r.get("max_rel_l1_point"))
        if "bytes" in r and d is not None:
            out.append({"material": r["material"], "bytes": r["bytes"], "point_worst": d,
                        "budget": r.get("budget")})
    return out


def compare(reference: dict, codec_rows: list, log=print) -> list:
    out = []
    for r in codec_rows:
        front = [x for x in reference["rows"] if x["material"] == r["material"]]
        ref = interpolate_bytes_at(front, r["point_worst"]) if front else None
        row = {**r, "reference_bytes": ref,
               "ratio": r["bytes"] / ref if ref else None}
        out.append(row)
        budget = f" (budget {r['budget']:g})" if r.get("budget") is not None else ""
        log(f"{r['material']:16s}{budget}: ours {r['bytes']:6d} B at points ≤ "
            f"{100 * r['point_worst']:.2f}%; reference "
            + (f"{ref:6.0f} B, ours/reference {row['ratio']:.2f}" if ref else
               "outside its front (no extrapolation)"))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", default=str(ROOT / "tests/data/rgl"),
                    help="folder of X_rgb.bsdf files (default: tests/data/rgl)")
    ap.add_argument("--materials", nargs="+", default=list(MATERIALS))
    ap.add_argument("--settings", nargs="+", type=float, default=list(SETTINGS),
                    help="relative quantisation steps s (default: %(default)s)")
    ap.add_argument("--variant", default="llvm_ad_rgb", choices=("llvm_ad_rgb", "scalar_rgb"))
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--camera-spp", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--albedo-grid", type=int, default=128)
    ap.add_argument("--report-at", nargs="+", type=float, default=list(REPORT_AT),
                    help="worst point-light render differences at which each material's "
                         "interpolated bytes are printed (default: %(default)s)")
    ap.add_argument("--work-dir", help="keep the rebuilt .bsdf files here (default: a "
                                       "temporary folder, removed)")
    ap.add_argument("--load", metavar="REF_JSON",
                    help="take the reference front from this earlier --out-json: no renders")
    ap.add_argument("--compare", metavar="FRONT_JSON",
                    help="our codec's front (tools/rgl_front.py --out-json, or a list of "
                         "{material, bytes, max_rel_l1_point}) against the reference")
    ap.add_argument("--out-json")
    a = ap.parse_args(argv)

    t = time.perf_counter()
    if a.load:
        doc = json.loads(Path(a.load).read_text())
    else:
        print(f"DCT + zstd reference, {a.variant}, {a.res}², {a.spp} emitter samples × "
              f"{a.camera_spp} camera rays, seed {a.seed}", flush=True)
        doc = sweep(a.data, a.materials, a.settings, a.variant, a.res, a.spp, a.camera_spp,
                    a.seed, a.albedo_grid, a.work_dir)
        doc["timings_s"] = {"total": round(time.perf_counter() - t, 2)}
        print(f"total {doc['timings_s']['total']:.0f} s")

    doc["interpolated_bytes"] = {}
    for name in dict.fromkeys(r["material"] for r in doc["rows"]):
        front = [r for r in doc["rows"] if r["material"] == name]
        at = {f"{d:g}": interpolate_bytes_at(front, d) for d in a.report_at}
        doc["interpolated_bytes"][name] = at
        print(f"{name:16s} bytes at points ≤ " + ", ".join(
            f"{100 * float(d):g}%: " + (f"{b:.0f}" if b else "—") for d, b in at.items()))

    if a.compare:
        doc["compare"] = {"front": str(a.compare),
                          "rows": compare(doc, load_codec_front(a.compare))}
    if a.out_json:
        Path(a.out_json).write_text(json.dumps(doc, indent=1))
        print(f"wrote {a.out_json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
