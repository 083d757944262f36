#!/usr/bin/env python3
"""The size/accuracy front of warped tables on RGL measurements, rendered beside Mitsuba's own
`measured` plugin: for each material and error budget, the file's bytes and the render
differences (tools/rgl_render.py), plus anchors measured on the same tables with the same error
metric: plain zfp (fixed-accuracy mode, the error-bounded float compressor) on the raw tables.

    pip install ./python zfpy      # the sbrdf binding (and its Mitsuba plugin); zfp for the anchor
    cargo build --release
    python tools/rgl_front.py --out-json front.json            # README "Warped tables" tables
    python tools/rgl_front.py --variant llvm_ad_spectral        # 41-band sources (made here)

Each file is `sbrdf encode X_rgb.bsdf --rgb-to-spectrum jakob-hanika-2019 --max-error E`
(spectral: `sbrdf encode X_spec.bsdf --max-error E`, X_spec made by tools/make_spec_bsdf.py).
The table columns: bytes, ratio to the .bsdf, the worst per-pixel relative L1 over the three
point lights, the environment's, and the worst directional-albedo difference over 0-70°.

The zfp anchor: each stored incidence's R x R x C table (C = 3 colours, or 41 bands) compressed
by zfp in fixed-accuracy mode, the tolerance bisected per incidence so that its relative L2
error (the encoder's own metric, in the tables' units) meets the same budget; bytes = the sum
of the streams, plus the NDF the warp needs (128 f16 values), nothing else (no header, no basis,
no metadata): a lower bound on what a zfp-based file would take.
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


def zfp_bytes(values: np.ndarray, budget: float) -> int:
    """Bytes zfp needs per incidence for relative L2 ≤ budget (values: [N, C, R, R])."""
    import zfpy

    total = 0
    for t in values:
        t = np.ascontiguousarray(t.astype(np.float64))
        norm = float(np.sqrt((t * t).sum())) or 1.0
        lo, hi = 1e-12, float(np.abs(t).max()) * 4 + 1e-12
        best = None
        for _ in range(50):
            tol = (lo * hi) ** 0.5
            s = zfpy.compress_numpy(t, tolerance=tol)
            err = float(np.sqrt(((zfpy.decompress_numpy(s) - t) ** 2).sum())) / norm
            if err <= budget:
                lo, best = tol, len(s)
            else:
                hi = tol
            if hi / lo < 1.01:
                break
        total += best if best is not None else len(zfpy.compress_numpy(t, tolerance=0.0))
    return total + 2 * 128


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
    ap.add_argument("--out-json")
    a = ap.parse_args(argv)

    import make_spec_bsdf
    import rgl_render

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
            if not a.no_zfp:
                tf = make_spec_bsdf.read_tensor_file(str(src))
                key = "spectra" if spectral else "rgb"
                tables = np.asarray(tf[key][0], dtype=np.float64)
            for e in budgets:
                out = tmp / f"{name}_{e}.sbrdf"
                cmd = [a.sbrdf_bin, "encode", str(src), "-o", str(out), "--max-error", str(e)]
                if not spectral:
                    cmd += ["--rgb-to-spectrum", "jakob-hanika-2019"]
                subprocess.run(cmd, check=True, capture_output=True)
                r = rgl_render.run(src, out, variant=a.variant, res=a.res, spp=a.spp,
                                   swap_pairs=1000, log=lambda *_: None)
                points = [v["rel_l1"] for k, v in r["render"].items() if k.startswith("point")]
                row = {
                    "material": name, "budget": e, "bytes": out.stat().st_size,
                    "source_bytes": src.stat().st_size,
                    "point_worst": max(points), "environment": r["render"]["environment"]["rel_l1"],
                    "albedo_worst": r["albedo"]["worst_rel_diff"],
                }
                if tables is not None:
                    row["zfp_bytes"] = zfp_bytes(tables, e)
                rows.append(row)
                print(f"{name:16s} {e:6.3f}: {row['bytes']:6d} B ({row['source_bytes'] / row['bytes']:5.0f}x)"
                      f"  points ≤ {100 * row['point_worst']:.2f}%  env {100 * row['environment']:.2f}%"
                      f"  albedo ≤ {100 * row['albedo_worst']:.2f}%"
                      + (f"  zfp {row['zfp_bytes']} B" if 'zfp_bytes' in row else ""),
                      flush=True)
    if a.out_json:
        Path(a.out_json).write_text(json.dumps({"variant": a.variant, "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
