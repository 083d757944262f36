#!/usr/bin/env python3
"""Writes SBRDF_RGB_WEIGHTS into shaders/sbrdf.wgsl (between its BEGIN/END GENERATED markers)
from the tables of src/decode/cie.rs: per CIE wavelength, M E (xbar, ybar, zbar) / sum E ybar
in f64, in the order of operations of src/decode/color.rs, rounded to f32 and printed with 9
significant digits (enough to give the same f32 back). The Rust test
gpu::tests::rgb_weights_match_cie_tables checks the result, so a change to cie.rs or color.rs
without rerunning this script fails the tests."""
import re
import struct
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def table(src, name):
    m = re.search(r"pub const %s: \[f64; COUNT\] = \[(.*?)\];" % name, src, re.S)
    return [float(v) for v in m.group(1).replace("\n", " ").split(",") if v.strip()]


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def main():
    src = (ROOT / "src/decode/cie.rs").read_text()
    xb, yb, zb, e = (table(src, n) for n in ("X_BAR", "Y_BAR", "Z_BAR", "D65"))
    norm = 0.0
    for i in range(len(e)):
        norm += e[i] * yb[i]
    rows = []
    for i in range(len(e)):
        x, y, z = e[i] * xb[i] / norm, e[i] * yb[i] / norm, e[i] * zb[i] / norm
        rgb = (3.2406 * x - 1.5372 * y - 0.4986 * z,
               -0.9689 * x + 1.8758 * y + 0.0415 * z,
               0.0557 * x - 0.2040 * y + 1.0570 * z)
        rows.append("    vec3<f32>(%s)," % ", ".join("%.9e" % f32(c) for c in rgb))
    block = ("const SBRDF_RGB_WEIGHTS = array<vec3<f32>, %d>(\n%s\n);\n" % (len(e), "\n".join(rows)))
    path = ROOT / "shaders/sbrdf.wgsl"
    text = path.read_text()
    begin, end = "// BEGIN GENERATED RGB WEIGHTS\n", "// END GENERATED RGB WEIGHTS\n"
    a, b = text.index(begin) + len(begin), text.index(end)
    path.write_text(text[:a] + block + text[b:])
    return 0


if __name__ == "__main__":
    sys.exit(main())
