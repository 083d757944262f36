"""Spectral-EXR interoperability with a second, independent reader and writer: the OpenEXR
package from PyPI (the Academy Software Foundation's C++ library underneath).

1. Slices written by `sbrdf decode --exr` open in OpenEXR with the expected channel names
   (T.<λ>nm, decimal comma), attributes (sbrdf.thetaI, sbrdf.phiI, spectralLayoutVersion) and
   values: each pixel equals `sbrdf eval` at that pixel's direction, to float precision.
2. A slice written by OpenEXR itself, with wavelengths in micrometres, a mask channel, an RGB
   preview and the incidence only in its file name, is read by `sbrdf encode`.

Usage: python3 exr_interop.py SBRDF_BINARY SAMPLE.sbrdf WORKDIR   (run by .ci/run)
"""

import json
import math
import os
import subprocess
import sys

import numpy as np
import OpenEXR


def run(*args):
    done = subprocess.run(args, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(args)} failed:\n{done.stderr}")
    return done


def main():
    sbrdf, sample, work = sys.argv[1:4]
    os.makedirs(work, exist_ok=True)
    info = json.loads(run(sbrdf, "info", "--json", sample).stdout)
    wavelengths = [float(w) for w in info["wavelengths"]]
    out = os.path.join(work, "slices")
    rows, cols = 6, 24
    run(sbrdf, "decode", sample, "--exr", "-o", out, "--resolution", f"{rows}x{cols}")
    files = sorted(f for f in os.listdir(out) if f.endswith(".exr"))
    assert len(files) == info["incident_count"], files
    checked = 0
    for name in files:
        f = OpenEXR.File(os.path.join(out, name))
        header = f.header()
        assert header["spectralLayoutVersion"] == "1.0", header
        ti, pi = float(header["sbrdf.thetaI"]), float(header["sbrdf.phiI"])
        assert name.endswith(f"_ti{ti:g}_pi{pi:g}.exr"), (name, ti, pi)
        channels = f.channels()
        expected = {"T." + f"{w:.6f}".replace(".", ",") + "nm" for w in wavelengths}
        spectral = {n for n in channels if n.startswith("T.")}
        assert spectral == expected, (sorted(spectral)[:3], sorted(expected)[:3])
        for n in spectral:
            px = channels[n].pixels
            assert px.shape == (rows, cols) and px.dtype == np.float32, (n, px.shape, px.dtype)
        # Values: a few pixels against `sbrdf eval` at the pixel centre's direction.
        for (i, j) in [(0, 0), (2, 11), (3, 12), (5, 23), (4, 3)]:
            to = (i + 0.5) * 90.0 / rows
            po = (j + 0.5) * 360.0 / cols
            text = run(
                sbrdf, "eval", sample,
                "--incident", f"{ti!r},{pi!r}",
                "--outgoing", f"{to!r},{po!r}",
            ).stdout.strip().splitlines()[1:]
            for line, w in zip(text, wavelengths):
                lam, value = (float(x) for x in line.split(","))
                assert lam == w
                name_w = "T." + f"{w:.6f}".replace(".", ",") + "nm"
                got = float(channels[name_w].pixels[i, j])
                want = float(np.float32(value))
                assert got == want or abs(got - want) <= 1e-6 * abs(want), (name, i, j, w, got, want)
                checked += 1
    print(f"OpenEXR read {len(files)} slices from sbrdf: channel names, attributes and "
          f"{checked} values agree with sbrdf eval")

    # The other way: a slice written by OpenEXR, wavelengths in µm, a mask, an RGB preview.
    h, w = 3, 8
    um = [0.45, 0.55, 0.65]
    ch = {}
    for k, l in enumerate(um):
        ch["T." + f"{l:.2f}".replace(".", ",") + "um"] = np.full((h, w), 0.1 * (k + 1), np.float32)
    mask = np.ones((h, w), np.float32)
    mask[0, 0] = 0.0
    ch["mask"] = mask
    for c in "RGB":
        ch[c] = np.zeros((h, w), np.float32)
    foreign = os.path.join(work, "foreign_ti20_pi45.exr")
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    OpenEXR.File(header, ch).write(foreign)
    dst = os.path.join(work, "foreign.sbrdf")
    done = run(sbrdf, "encode", foreign, "-o", dst, "--peak", "none", "--sh-level", "0",
               "--basis", "cosine", "--terms", "3", "--precision", "f32")
    assert "1 EXR pixels marked missing" in done.stderr, done.stderr
    back = json.loads(run(sbrdf, "info", "--json", dst).stdout)
    assert [round(float(x), 6) for x in back["wavelengths"]] == [450.0, 550.0, 650.0], back
    value = run(sbrdf, "eval", dst, "--incident", "20,45", "--outgoing", "40,100",
                "--wavelengths", "550").stdout.strip().splitlines()[1]
    got = float(value.split(",")[1])
    assert math.isclose(got, 0.2, rel_tol=1e-5), got
    print("sbrdf read a slice written by OpenEXR (µm channels, mask, RGB preview, incidence "
          "from the file name)")


if __name__ == "__main__":
    main()
