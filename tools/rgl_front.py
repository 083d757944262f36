#!/usr/bin/env python3
"""The size/accuracy front of warped tables on RGL measurements, rendered beside Mitsuba's own
`measured` plugin: for each material and error budget, the file's bytes and the render
differences (tools/rgl_render.py), plus anchors measured on the same tables with the same error
metric: plain zfp (fixed-accuracy mode) and SZ3 (absolute error bound), the two error-bounded
float compressors, on the raw tables.

    pip install ./python zfpy pysz # the sbrdf binding (and its Mitsuba plugin); zfp, SZ3 anchors
    cargo build --release
    python tools/rgl_front.py --out-json front.json            # docs/guide/warped-tables.md's tables
    python tools/rgl_front.py --variant llvm_ad_spectral        # 41-band sources (made here)
    python tools/rgl_front.py --anchors-only                    # anchors alone: no encode, render

Each file is `sbrdf encode X_rgb.bsdf --rgb-to-spectrum jakob-hanika-2019 --max-error E`
(spectral: `sbrdf encode X_spec.bsdf --max-error E`, X_spec made by tools/make_spec_bsdf.py).
The table columns: bytes, ratio to the .bsdf, the worst per-pixel relative L1 over the three
point lights, the environment's, and the worst directional-albedo difference over 0-70°.

The zfp anchor: each stored incidence's R x R x C table (C = 3 colours, or 41 bands) compressed
by zfp in fixed-accuracy mode, the tolerance bisected per incidence so that its relative L2
error (the encoder's own metric, in the tables' units) meets the same budget; bytes = the sum
of the streams, plus the NDF the warp needs (128 f16 values), nothing else (no header, no basis,
no metadata): a lower bound on what a zfp-based file would take.

The SZ3 anchor: the same, with SZ3 (pysz, its default interpolation/Lorenzo predictor) in
absolute-error-bound mode on float32 tables (the file's own precision), the bound bisected per
incidence the same way and the error checked on the decompressed table. SZ3 predicts along the
array's axes, so it is run on two layouts of each incidence, R x R x C (colour last) and
C x R x R (the file's order), and the smaller total per material and budget is kept (both are in
the JSON, `sz3_bytes_by_layout`; the printed line names the kept one). An incidence no bound
meets (none seen) counts as its raw float32 bytes.

--anchors-only skips the encoder and the renders (no sbrdf binary, no Mitsuba needed) and
prints / records only the anchors, per material and budget.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

MATERIALS = ("cc_ibiza_sunset", "paper_white", "satin_rosaline")
BUDGETS = (0.005, 0.01, 0.02, 0.05)


def _bisected_bytes(t: np.ndarray, budget: float, roundtrip) -> int | None:
    """Bytes of one incidence `t` at the largest absolute tolerance found (geometric bisection)
    whose rebuilt table has relative L2 ≤ budget; roundtrip(tol) -> (bytes, rebuilt). None when
    no tolerance tried meets the budget (the caller then counts a lossless stream)."""
    t64 = t.astype(np.float64)
    norm = float(np.sqrt((t64 * t64).sum())) or 1.0
    lo, hi = 1e-12, float(np.abs(t64).max()) * 4 + 1e-12
    best = None
    for _ in range(50):
        tol = (lo * hi) ** 0.5
        n, rebuilt = roundtrip(tol)
        # the error of what actually came back, not the bound asked for: it is the measure
        err = float(np.sqrt(((rebuilt.astype(np.float64) - t64) ** 2).sum())) / norm
        if err <= budget:
            lo, best = tol, n
        else:
            hi = tol
        if hi / lo < 1.01:
            break
    return best


def zfp_bytes(values: np.ndarray, budget: float) -> int:
    """Bytes zfp needs per incidence for relative L2 ≤ budget (values: [N, C, R, R])."""
    import zfpy

    def roundtrip(t):
        def rt(tol):
            s = zfpy.compress_numpy(t, tolerance=tol)
            return len(s), zfpy.decompress_numpy(s)
        return rt

    total = 0
    for t in values:
        t = np.ascontiguousarray(t.astype(np.float64))
        best = _bisected_bytes(t, budget, roundtrip(t))
        total += best if best is not None else len(zfpy.compress_numpy(t, tolerance=0.0))
    return total + 2 * 128


SZ3_LAYOUTS = {"RRC": (1, 2, 0), "CRR": (0, 1, 2)}  # axis order from the tables' [C, R, R]


def sz3_bytes(values: np.ndarray, budget: float) -> dict[str, int]:
    """Bytes SZ3 needs per incidence for relative L2 ≤ budget, per layout of each incidence
    (values: [N, C, R, R]); {layout: bytes incl. the NDF}."""
    from pysz import sz, szConfig, szErrorBoundMode

    def roundtrip(t):
        def rt(tol):
            # a fresh config per call: compress() writes the dims into it
            cfg = szConfig()
            cfg.errorBoundMode = szErrorBoundMode.ABS
            cfg.absErrorBound = tol
            s, _ = sz.compress(t, cfg)
            rebuilt, _ = sz.decompress(s, t.dtype, t.shape)
            return int(s.nbytes), rebuilt
        return rt

    out = {}
    for layout, axes in SZ3_LAYOUTS.items():
        total = 0
        for t in values:
            t = np.ascontiguousarray(t.astype(np.float32).transpose(axes))
            best = _bisected_bytes(t, budget, roundtrip(t))
            total += best if best is not None else t.nbytes
        out[layout] = total + 2 * 128
    return out


def _have(module: str) -> bool:
    try:
        __import__(module)
        return True
    except ImportError:
        return False


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sbrdf-bin", default=str(ROOT / "target/release/sbrdf"))
    ap.add_argument("--data", default=str(ROOT / "tests/data/rgl"),
                    help="folder of X_rgb.bsdf files (default: tests/data/rgl)")
    ap.add_argument("--variant", default="llvm_ad_rgb",
                    choices=("llvm_ad_rgb", "llvm_ad_spectral"))
    ap.add_argument("--budgets", default=",".join(str(b) for b in BUDGETS))
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--no-zfp", action="store_true", help="skip the zfp anchor")
    ap.add_argument("--no-sz3", action="store_true", help="skip the SZ3 anchor")
    ap.add_argument("--anchors-only", action="store_true",
                    help="only the anchors (zfp, SZ3): no encoding, no renders")
    ap.add_argument("--out-json")
    a = ap.parse_args(argv)

    import make_spec_bsdf

    # optional anchors: a missing module skips its anchor with a word, not the whole front
    do_zfp = not a.no_zfp and _have("zfpy")
    do_sz3 = not a.no_sz3 and _have("pysz")
    if not a.no_zfp and not do_zfp:
        print("zfpy not installed: no zfp anchor (pip install zfpy)", file=sys.stderr)
    if not a.no_sz3 and not do_sz3:
        print("pysz not installed: no SZ3 anchor (pip install pysz)", file=sys.stderr)
    if a.anchors_only and not (do_zfp or do_sz3):
        print("--anchors-only with no anchor to compute", file=sys.stderr)
        return 1
    if not a.anchors_only:
        import rgl_render  # Mitsuba: only needed for the renders

    spectral = a.variant == "llvm_ad_spectral"
    budgets = [float(b) for b in a.budgets.split(",")]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name in MATERIALS:
            src = Path(a.data) / f"{name}_rgb.bsdf"
            if spectral:
                spec = tmp / f"{name}_spec.bsdf"
                make_spec_bsdf.main([str(src), "-o", str(spec)])
                src = spec
            tables = None
            if do_zfp or do_sz3:
                tf = make_spec_bsdf.read_tensor_file(str(src))
                key = "spectra" if spectral else "rgb"
                tables = np.asarray(tf[key][0], dtype=np.float64)
            for e in budgets:
                row = {"material": name, "budget": e, "source_bytes": src.stat().st_size}
                anchors = ""
                if do_zfp:
                    row["zfp_bytes"] = zfp_bytes(tables, e)
                    anchors += f"  zfp {row['zfp_bytes']} B"
                if do_sz3:
                    by = sz3_bytes(tables, e)
                    layout = min(by, key=by.get)
                    row.update(sz3_bytes=by[layout], sz3_layout=layout, sz3_bytes_by_layout=by)
                    anchors += f"  sz3 {row['sz3_bytes']} B ({layout})"
                if a.anchors_only:
                    rows.append(row)
                    print(f"{name:16s} {e:6.3f}:{anchors}", flush=True)
                    continue
                out = tmp / f"{name}_{e}.sbrdf"
                cmd = [a.sbrdf_bin, "encode", str(src), "-o", str(out), "--max-error", str(e)]
                if not spectral:
                    cmd += ["--rgb-to-spectrum", "jakob-hanika-2019"]
                subprocess.run(cmd, check=True, capture_output=True)
                r = rgl_render.run(src, out, variant=a.variant, res=a.res, spp=a.spp,
                                   swap_pairs=1000, log=lambda *_: None)
                points = [v["rel_l1"] for k, v in r["render"].items() if k.startswith("point")]
                row.update({
                    "bytes": out.stat().st_size,
                    "point_worst": max(points), "environment": r["render"]["environment"]["rel_l1"],
                    "albedo_worst": r["albedo"]["worst_rel_diff"],
                })
                rows.append(row)
                print(f"{name:16s} {e:6.3f}: {row['bytes']:6d} B ({row['source_bytes'] / row['bytes']:5.0f}x)"
                      f"  points ≤ {100 * row['point_worst']:.2f}%  env {100 * row['environment']:.2f}%"
                      f"  albedo ≤ {100 * row['albedo_worst']:.2f}%" + anchors,
                      flush=True)
    if a.out_json:
        doc = {"variant": a.variant, "anchors_only": a.anchors_only, "rows": rows}
        if do_sz3:
            from importlib.metadata import version
            doc["pysz_version"] = version("pysz")
        Path(a.out_json).write_text(json.dumps(doc, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
