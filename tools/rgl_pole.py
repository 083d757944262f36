"""sbrdf's Mitsuba plugin beside Mitsuba 3's own ``measured`` plugin with the viewer exactly on
the normal and a hair off it (issue 39, item 6: the normal-incidence rule of
``spec/EVALUATION.md``, "Warped tables", Value). Prints relative L1 of f·cos θ over 200² light
directions (Mitsuba's cosine warp) per material.

    pip install ./python && apt-get install libllvm19
    python tools/rgl_pole.py [material ...]     # RGL *_rgb.bsdf names under tests/data/rgl

The tables of an RGL measurement at θv = 0 are not symmetric about the normal, so both plugins
take the viewer's azimuth from the viewing vector: with a residue (±1e-7, 0) or (0, ±1e-7) the
two agree as elsewhere; at exactly (0, 0, 1) sbrdf does not rotate (φv = 0) while `measured`
answers as at (−1e-7, 0, 1), φv = 180°.
"""
import importlib.util
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("rgl_render", ROOT / "tools/rgl_render.py")
rr = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rr)


def main(materials):
    rr._setup("llvm_ad_rgb")
    import mitsuba as mi
    lights = rr.cosine_grid(200)

    def at(v):
        return np.repeat(np.array([v], dtype=np.float64), len(lights), 0)

    def l1(a, b):
        return float(np.abs(a - b).sum() / np.abs(a).sum())

    tmp = Path(tempfile.mkdtemp())
    for mat in materials:
        src = ROOT / f"tests/data/rgl/{mat}_rgb.bsdf"
        out = tmp / f"{mat}.sbrdf"
        subprocess.run([str(ROOT / "target/release/sbrdf"), "encode", str(src), "-o", str(out),
                        "--rgb-to-spectrum", "jakob-hanika-2019"], check=True,
                       capture_output=True)
        meas = mi.load_dict({"type": "measured", "filename": str(src)})
        ours = mi.load_dict({"type": "sbrdf", "filename": str(out)})
        m0, s0 = rr.eval_bsdf(meas, at([0, 0, 1]), lights), rr.eval_bsdf(ours, at([0, 0, 1]), lights)
        print(f"{mat}: viewer at exactly (0, 0, 1): sbrdf vs measured {l1(m0, s0):.4f}")
        for r in ([1e-7, 0, 1], [-1e-7, 0, 1], [0, 1e-7, 1], [0, -1e-7, 1]):
            mr, sr = rr.eval_bsdf(meas, at(r), lights), rr.eval_bsdf(ours, at(r), lights)
            print(f"  viewer at ({r[0]:g}, {r[1]:g}, 1): sbrdf vs measured {l1(mr, sr):.4f}; "
                  f"measured vs its own value at (0, 0, 1) {l1(mr, m0):.4f}")
        for tv in (0.5, 2.0, 10.0):
            v = at(list(rr.direction(tv, 0.0)))
            print(f"  viewer at θ {tv}°: sbrdf vs measured "
                  f"{l1(rr.eval_bsdf(meas, v, lights), rr.eval_bsdf(ours, v, lights)):.4f}")


if __name__ == "__main__":
    main(sys.argv[1:] or ["paper_white", "satin_rosaline", "cc_ibiza_sunset"])
