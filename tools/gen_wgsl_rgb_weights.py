#!/usr/bin/env python3
"""Writes the colour weights into shaders/sbrdf.wgsl (between its BEGIN/END GENERATED RGB WEIGHTS
markers) from the tables of src/decode/color/cie.rs: per CIE wavelength, M E (xbar, ybar, zbar) / sum E
ybar in f64, in the order of operations of src/decode/color/mod.rs, rounded to f32 and printed with 9
significant digits (enough to give the same f32 back). They are the columns of
sbrdf_rgb_weights4(g), four wavelengths a group, a `switch` of constants (a `const` array indexed
at run time would be copied into each invocation's private memory by a SPIR-V writer). The Rust test
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
    src = (ROOT / "src/decode/color/cie.rs").read_text()
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
        rows.append("vec3<f32>(%s)" % ", ".join("%.9e" % f32(c) for c in rgb))
    groups = (len(rows) + 3) // 4
    cases = []
    for g in range(groups):
        cols = rows[4 * g:4 * g + 4]
        cols += ["vec3<f32>(0.0)"] * (4 - len(cols))
        nm = 380 + 20 * g
        span = "%d to %d nm" % (nm, nm + 15) if len(rows[4 * g:4 * g + 4]) == 4 else "%d nm" % nm
        body = ",\n".join("                %s" % c for c in cols)
        cases.append("        case %du: { // %s\n            return mat4x3<f32>(\n%s);\n        }"
                     % (g, span, body))
    block = ("fn sbrdf_rgb_weights4(g: u32) -> mat4x3<f32> {\n    switch (g) {\n%s\n"
             "        default: {\n            return mat4x3<f32>();\n        }\n    }\n}\n"
             % "\n".join(cases))
    assert len(rows) == 81 and groups == 21
    path = ROOT / "shaders/sbrdf.wgsl"
    text = path.read_text()
    begin, end = "// BEGIN GENERATED RGB WEIGHTS\n", "// END GENERATED RGB WEIGHTS\n"
    a, b = text.index(begin) + len(begin), text.index(end)
    path.write_text(text[:a] + block + text[b:])
    return 0


if __name__ == "__main__":
    sys.exit(main())
