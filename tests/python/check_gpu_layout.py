#!/usr/bin/env python3
"""Compare the flat device layout (spec/GPU_LAYOUT.md), read by spec/reference_decoder.py's
`layout_material` from the layout's words alone, with `sbrdf eval` on the file.

Usage: python3 tests/python/check_gpu_layout.py SBRDF_BINARY --manifest MANIFEST [FILE...]

For every file the golden MANIFEST lists, and every FILE, `sbrdf layout FILE -o OUT.bin` writes the layout.
A file with a factor model (FACT) or warped tables (WARP) must be refused (version 1 does not
cover them: GPU_LAYOUT.md, "Scope of version 1") and every other file laid out. Each layout is
evaluated on the stored incidences and pseudo-random (incident, outgoing) pairs at the file's
wavelengths plus wavelengths between them, and must agree with `sbrdf eval` within
1e-5 relative + 1e-7 times the largest value seen for the file (the f32 layout's precision:
λmin and λmax are rounded to f32). The layouts of all files are also concatenated into one
buffer and each read back at its base word, which must give the same values.

Standard library only. Exit status 0 when every file passes.
"""

import argparse
import random
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "spec"))
import reference_decoder as rd  # noqa: E402

REL = 1e-5
ABS_OF_MAX = 1e-7


def run_eval(binary, path, inc, out, lams):
    cmd = [binary, "eval", str(path), "--incident=%r,%r" % inc, "--outgoing=%r,%r" % out,
           "--wavelengths=" + ",".join(rd.fmt(l) for l in lams)]
    p = subprocess.run(cmd, capture_output=True, text=True, check=True)
    lines = p.stdout.strip("\n").split("\n")
    if lines[0] != "wavelength_nm,value":
        raise ValueError("unexpected output: %r" % p.stdout[:200])
    return [float(line.split(",")[1]) for line in lines[1:]]


def pairs_for(m, rng):
    """The stored incidences with the mirror and random outgoing directions, then random pairs."""
    pairs = []
    for ti, pi in m.incidences:
        pairs.append(((ti, pi), (ti, (pi + 180.0) % 360.0)))
        pairs.append(((ti, pi), (rng.uniform(0, 90), rng.uniform(0, 360))))
    for _ in range(24):
        inc = (rng.uniform(0, 90), 0.0 if m.isotropic else rng.uniform(0, 360))
        pairs.append((inc, (rng.uniform(0, 90), rng.uniform(0, 360))))
    return pairs


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("binary")
    ap.add_argument("--manifest", required=True)
    ap.add_argument("files", nargs="*")
    args = ap.parse_intermixed_args(argv)
    manifest = Path(args.manifest)
    paths = [manifest.parent / line.split(":")[0].strip()
             for line in manifest.read_text().splitlines()
             if line.strip() and not line.startswith("#")] + [Path(f) for f in args.files]
    failures, covered, buffers = 0, 0, []
    rng = random.Random(25)
    with tempfile.TemporaryDirectory() as tmp:
        for path in paths:
            name = path.name
            f = rd.open_file(str(path))
            out = Path(tmp) / (name + ".bin")
            p = subprocess.run([args.binary, "layout", str(path), "-o", str(out)],
                               capture_output=True, text=True)
            if f.fact is not None or f.warp is not None:
                chunk = "FACT" if f.fact is not None else "WARP"
                if p.returncode == 0 or chunk not in p.stderr or out.exists():
                    print("FAIL %s: has %s but was laid out (or a wrong message: %r)"
                          % (name, chunk, p.stderr))
                    failures += 1
                else:
                    print("ok   %s: not covered (%s), refused" % (name, chunk))
                continue
            if p.returncode != 0:
                print("FAIL %s: sbrdf layout failed: %s" % (name, p.stderr.strip()))
                failures += 1
                continue
            data = out.read_bytes()
            m = rd.layout_material(data)
            waves = list(m.wavelengths)
            lams = waves + [(a + b) / 2 for a, b in zip(waves, waves[1:])][:5]
            results = []
            for inc, outg in pairs_for(m, rng):
                want = run_eval(args.binary, path, inc, outg, lams)
                got = m.eval(*inc, *outg, lams)
                results.append((inc, outg, want, got))
            largest = max(abs(v) for _, _, want, _ in results for v in want)
            worst, bad = 0.0, 0
            for inc, outg, want, got in results:
                for lam, a, b in zip(lams, want, got):
                    tol = REL * abs(a) + ABS_OF_MAX * largest
                    err = abs(a - b)
                    worst = max(worst, err / tol if tol else (0.0 if err == 0 else float("inf")))
                    if err > tol:
                        if bad < 3:
                            print("     %s: wi %r wo %r λ %r: eval %r, layout %r"
                                  % (name, inc, outg, lam, a, b))
                        bad += 1
            if bad:
                print("FAIL %s: %d values disagree" % (name, bad))
                failures += 1
            else:
                print("ok   %s: %d words (%.3f× the file), %d pairs × %d wavelengths agree, "
                      "worst difference %.3g of the tolerance"
                      % (name, len(data) // 4, len(data) / path.stat().st_size, len(results),
                         len(lams), worst))
            covered += 1
            buffers.append((name, data, results[:3], lams))
    # Several materials in one buffer, each addressed by its base word.
    joined, bases = b"", []
    for name, data, _, _ in buffers:
        bases.append(len(joined) // 4)
        joined += data
    for (name, data, sample, lams), base in zip(buffers, bases):
        m = rd.layout_material(joined, base)
        alone = rd.layout_material(data)
        for inc, outg, _, _ in sample:
            if m.eval(*inc, *outg, lams) != alone.eval(*inc, *outg, lams):
                print("FAIL %s: read at base %d of the joined buffer differs" % (name, base))
                failures += 1
                break
    if covered == 0:
        print("FAIL: no file was covered")
        failures += 1
    print("%d files laid out and checked, %d failures" % (covered, failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
