#!/usr/bin/env python3
"""Compare the flat device layout (spec/GPU_LAYOUT.md), read by spec/reference_decoder.py's
`layout_material` from the layout's words alone, with `sbrdf eval` on the file.

Usage: python3 tests/python/check_gpu_layout.py SBRDF_BINARY --manifest MANIFEST [FILE...]

For every file the golden MANIFEST lists, and every FILE, `sbrdf layout FILE -o OUT.bin` writes the layout.
Every file is laid out: a file with a factor model (FACT) must carry it as the model section of
kind 1 (header word 19), a file with warped tables (WARP) as the section of kind 2 (layout
version 4), which the reference decoder reads and evaluates. Each layout is evaluated on the
stored incidences and pseudo-random (incident, outgoing) pairs at the file's wavelengths plus
wavelengths between them, and must agree with `sbrdf eval` within 1e-5 relative + 1e-7 times the
largest value seen for the file (the f32 layout's precision: λmin and λmax are rounded to f32).
Warped tables are compared with `sbrdf eval --compact`, which evaluates the same packed numbers
in binary64, within 1e-9 relative + 1e-11 of the largest value; their difference to the exact
`sbrdf eval` (the packing's rounding) is printed. The layouts of all files are also concatenated into one
buffer and each read back at its base word, which must give the same values. The sampling
section (GPU_LAYOUT.md, "Sampling section") is read with `layout_sampling_weights`: each
record's background energy must equal the reference decoder's own integral of its SH background
(spectrum-averaged) times cos θ, and each angle Gaussian's ln b the amplitude-weighted mean of
its widths' logarithms; the lobe energies (a 4 × 4 stratified estimate) must be finite and ≥ 0.

Standard library only. Exit status 0 when every file passes.
"""

import argparse
import math
import random
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "spec"))
import reference_decoder as rd  # noqa: E402

REL = 1e-5
ABS_OF_MAX = 1e-7


REL_WARP = 1e-9
ABS_OF_MAX_WARP = 1e-11


def run_eval(binary, path, inc, out, lams, compact=False):
    cmd = [binary, "eval", str(path), "--incident=%r,%r" % inc, "--outgoing=%r,%r" % out,
           "--wavelengths=" + ",".join(rd.fmt(l) for l in lams)] + (["--compact"] if compact else [])
    p = subprocess.run(cmd, capture_output=True, text=True, check=True)
    lines = p.stdout.strip("\n").split("\n")
    if lines[0] != "wavelength_nm,value":
        raise ValueError("unexpected output: %r" % p.stdout[:200])
    return [float(line.split(",")[1]) for line in lines[1:]]


def pairs_for(m, rng, mirror=True):
    """The stored incidences with the mirror (unless `mirror` is False) and random outgoing
    directions, then random pairs."""
    pairs = []
    for ti, pi in m.incidences:
        if mirror:
            pairs.append(((ti, pi), (ti, (pi + 180.0) % 360.0)))
        pairs.append(((ti, pi), (rng.uniform(0, 90), rng.uniform(0, 360))))
    for _ in range(24):
        inc = (rng.uniform(0, 90), 0.0 if m.isotropic else rng.uniform(0, 360))
        pairs.append((inc, (rng.uniform(0, 90), rng.uniform(0, 360))))
    return pairs


def gauss_legendre01(n):
    """Nodes and weights of n-point Gauss-Legendre quadrature on [0, 1] (Newton on P_n)."""
    nodes, weights = [], []
    for i in range(n):
        x = math.cos(math.pi * (i + 0.75) / (n + 0.5))
        for _ in range(100):
            p0, p1 = 1.0, x
            for k in range(2, n + 1):
                p0, p1 = p1, ((2 * k - 1) * x * p1 - (k - 1) * p0) / k
            dp = n * (x * p1 - p0) / (x * x - 1.0)
            dx = p1 / dp
            x -= dx
            if abs(dx) < 1e-16:
                break
        nodes.append(0.5 * (x + 1.0))
        weights.append(1.0 / ((1.0 - x * x) * dp * dp))
    return nodes, weights


def cosine_sh_integrals(level):
    """I_j = ∫ Y_j(ω) cos θ dω over the upper hemisphere for every SH function up to `level`, by
    Gauss-Legendre in cos θ (24 nodes: exact for the m = 0 functions, polynomials of degree
    ≤ 21 times cos θ) and 64 equal steps in φ (exact for |m| < 64, whose integrals are 0)."""
    mus, ws = gauss_legendre01(24)
    nphi = 64
    total = [0.0] * ((level + 1) ** 2)
    for mu, w in zip(mus, ws):
        st = math.sqrt(max(0.0, 1.0 - mu * mu))
        for j in range(nphi):
            phi = 2.0 * math.pi * (j + 0.5) / nphi
            y = rd.sh_eval(level, (st * math.cos(phi), st * math.sin(phi), mu))
            for i, v in enumerate(y):
                total[i] += v * mu * w * (2.0 * math.pi / nphi)
    return total


def check_sampling_section(name, data, m):
    """The sampling section (GPU_LAYOUT.md, "Sampling section") read by the reference decoder:
    present, finite, lobe energies ≥ 0, ln b 0 except for angle Gaussians, where it must be the
    amplitude-weighted mean of the widths' logarithms; and each background energy equal to this
    decoder's own integral of its SH background, spectrum-averaged, times cos θ. Returns a
    list of problems."""
    weights = rd.layout_sampling_weights(data)
    if weights is None:
        return ["no sampling section"]
    problems = []
    bmean = [0.0] * m.k
    for lam in m.wavelengths:
        for i, v in enumerate(m.basis_at(lam, m.k)):
            bmean[i] += v / len(m.wavelengths)
    integrals = cosine_sh_integrals(m.sh_level)
    for r, (rec, (e_bg, lobes)) in enumerate(zip(m.records, weights)):
        terms = [bmean[k] * c * integrals[j]
                 for k in range(rec.terms) for j, c in enumerate(rec.sh[k])]
        want, scale = math.fsum(terms), math.fsum(abs(t) for t in terms)
        if not abs(e_bg - want) <= 1e-6 * scale + 1e-7 * abs(want):
            problems.append("record %d: background energy %r, integral %r" % (r, e_bg, want))
        if len(lobes) != len(rec.lobes):
            problems.append("record %d: %d lobe weights for %d lobes" % (r, len(lobes), len(rec.lobes)))
            continue
        for li, ((energy, ln_b), (kind, rows, params)) in enumerate(zip(lobes, rec.lobes)):
            if not (math.isfinite(energy) and energy >= 0.0):
                problems.append("record %d lobe %d: energy %r" % (r, li, energy))
            if kind != 1:
                if ln_b != 0.0:
                    problems.append("record %d lobe %d (kind %d): ln b %r" % (r, li, kind, ln_b))
                continue
            shares = [abs(a * bmean[k]) for k, a in enumerate(rows[0])]
            den = math.fsum(shares)
            want_b = (math.fsum(s * math.log(b) for s, b in zip(shares, params)) / den
                      if den > 0 else math.log(params[0]))
            if not abs(ln_b - want_b) <= 1e-6 * max(1.0, abs(want_b)):
                problems.append("record %d lobe %d: ln b %r, want %r" % (r, li, ln_b, want_b))
    return problems


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
            if p.returncode != 0:
                print("FAIL %s: sbrdf layout failed: %s" % (name, p.stderr.strip()))
                failures += 1
                continue
            data = out.read_bytes()
            m = rd.layout_material(data)
            if (m.fact is None) != (f.fact is None) or (m.warp_layout is None) != (f.warp is None):
                print("FAIL %s: the layout's model section does not match the file's FACT or WARP"
                      % name)
                failures += 1
                continue
            warped = f.warp is not None
            waves = list(m.wavelengths)
            lams = waves + [(a + b) / 2 for a, b in zip(waves, waves[1:])][:5]
            results, packing = [], [0.0, 0.0]
            # Warped tables: not at the exact mirror direction, where the value depends on the
            # azimuth atan2 gives the rounding residue of the half vector (EVALUATION.md, "Warped
            # tables": comparisons of decoders SHOULD avoid those pairs).
            for inc, outg in pairs_for(m, rng, mirror=not warped):
                want = run_eval(args.binary, path, inc, outg, lams, compact=warped)
                got = m.eval(*inc, *outg, lams)
                results.append((inc, outg, want, got))
                if warped:
                    exact = run_eval(args.binary, path, inc, outg, lams)
                    packing[0] += sum((a - b) ** 2 for a, b in zip(got, exact))
                    packing[1] += sum(b * b for b in exact)
            largest = max(abs(v) for _, _, want, _ in results for v in want)
            rel, abs_of_max = (REL_WARP, ABS_OF_MAX_WARP) if warped else (REL, ABS_OF_MAX)
            worst, bad = 0.0, 0
            for inc, outg, want, got in results:
                for lam, a, b in zip(lams, want, got):
                    tol = rel * abs(a) + abs_of_max * largest
                    err = abs(a - b)
                    worst = max(worst, err / tol if tol else (0.0 if err == 0 else float("inf")))
                    if err > tol:
                        if bad < 3:
                            print("     %s: wi %r wo %r λ %r: eval %r, layout %r"
                                  % (name, inc, outg, lam, a, b))
                        bad += 1
            # Warped tables sample themselves: their layout has no sampling section.
            sampling = [] if warped else check_sampling_section(name, data, m)
            if warped:
                print("     %s: the packed tables against the exact values: relative L2 %.3g"
                      % (name, math.sqrt(packing[0] / packing[1]) if packing[1] else 0.0))
            for problem in sampling[:3]:
                print("     %s: sampling section: %s" % (name, problem))
            if sampling:
                print("FAIL %s: sampling section: %d problems" % (name, len(sampling)))
                failures += 1
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
