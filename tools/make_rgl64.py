#!/usr/bin/env python3
"""Makes an RGL tensor file on 64 × 64 warped grids from one on 32 × 32 (the RGL database holds
both sizes; the project ships only 32 × 32 measurements), for testing decoders on the finer grid.

Every per-node field (``rgb`` or ``spectra`` [phi_i, theta_i, C, R, R], ``luminance``
[phi_i, theta_i, R, R]) is resampled bilinearly from the nodes s = (c, r)/(R − 1) to the nodes
s = (c', r')/(2R − 1) of the same warped square (the parameterisation the file's NDF and VNDF
define does not change); ``valid`` [R²] becomes 1 where the nearest source node was valid; the
NDF, σ, VNDF, incidences and description are kept (the description gets the suffix
`` [64 × 64 test version: 32 × 32 nodes resampled bilinearly]``). The result is smoother than a
measurement on a 64 × 64 grid, but its tables have that size, which is what a decoder's memory
and speed depend on.

    python tools/make_rgl64.py tests/data/rgl/satin_rosaline_rgb.bsdf -o satin64_rgb.bsdf

Needs numpy; reads and writes with tools/make_spec_bsdf.py's tensor_file functions.
"""

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_spec_bsdf import read_tensor_file, write_tensor_file  # noqa: E402

SUFFIX = " [64 × 64 test version: 32 × 32 nodes resampled bilinearly]"


def resample(a: np.ndarray, n: int) -> np.ndarray:
    """The last two axes (R × R nodes on [0, 1]²) resampled bilinearly to n × n nodes."""
    r = a.shape[-1]
    x = np.linspace(0.0, 1.0, n) * (r - 1)
    i = np.minimum(np.floor(x).astype(int), r - 2)
    t = x - i
    # along the last axis (columns), then the one before (rows)
    a = a[..., i] * (1 - t) + a[..., i + 1] * t
    a = np.swapaxes(a, -1, -2)
    a = a[..., i] * (1 - t) + a[..., i + 1] * t
    return np.swapaxes(a, -1, -2)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("input")
    ap.add_argument("-o", "--output", required=True)
    ap.add_argument("--size", type=int, default=64)
    args = ap.parse_args(argv)
    fields = read_tensor_file(args.input)
    r = fields["luminance"].shape[-1]
    n = args.size
    out = {}
    for name, a in fields.items():
        if name in ("rgb", "spectra", "luminance"):
            a = resample(a.astype(np.float64), n).astype(np.float32)
        elif name == "valid":
            src = a.reshape(r, r)
            idx = np.rint(np.linspace(0.0, 1.0, n) * (r - 1)).astype(int)
            a = src[np.ix_(idx, idx)].reshape(-1).astype(np.uint8)
        elif name == "description":
            a = np.frombuffer(bytes(a) + SUFFIX.encode(), np.uint8)
        out[name] = a
    write_tensor_file(args.output, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
