#!/usr/bin/env python3
"""Compare spec/reference_decoder.py (written from the specification alone) with `sbrdf eval`.

Usage: python3 tests/python/check_reference_decoder.py [--rel R] SBRDF_BINARY
           [--manifest MANIFEST] FILE...

--manifest adds every file a golden folder's MANIFEST lists (and fails unless the folder's .sbrdf
files are exactly those, at least one); --rel sets the agreement required (default 1e-5, the
margin spec/EVALUATION.md gives decoders that round differently; CI holds sbrdf's own decoder to
the 1e-11 that section states).

For each file, a few hundred (incident, outgoing) direction pairs are evaluated by both: the
stored incidences and incidences between, below and above them, other azimuths (with wrapping,
negative and > 360° values for anisotropic files), outgoing directions at the mirror direction,
near the pole and near the horizon, and a few pseudo-random ones; each at several wavelengths
(the ends of the range, nodes, values between nodes, and values outside the file's range). Every
value must agree to R relative (below 1e-4, to R·1e-4 absolute). One
`sbrdf eval` call per pair carries all wavelengths.

`sbrdf eval` refuses wavelengths outside the file's range, which EVALUATION.md evaluates as the
nearest end of the range ("Spectral basis", clamping). When the binary refuses them, the
reference decoder's value outside the range is compared with the binary's value at the end the
specification clamps to. Each file is also checked to be refused by both readers when a byte is
flipped or the file is cut short, and the reference decoder's own CSV output is compared with
`sbrdf eval`'s, text of the wavelength column included.

Standard library only. Exit status 0 when every file passes.
"""

import os
import random
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "spec"))
import reference_decoder as rd  # noqa: E402

REL = 1e-5
# Values below this are compared absolutely, to REL times it.
SMALL = 1e-4
DECODER = Path(rd.__file__).resolve()


def run_eval(binary, path, inc, out, lams):
    cmd = [binary, "eval", str(path), "--incident=%r,%r" % inc, "--outgoing=%r,%r" % out]
    if lams is not None:
        cmd.append("--wavelengths=" + ",".join(rd.fmt(l) for l in lams))
    p = subprocess.run(cmd, capture_output=True, text=True)
    return p.returncode, p.stdout, p.stderr


def parse_csv(text):
    lines = text.strip("\n").split("\n")
    if not lines or lines[0] != "wavelength_nm,value":
        raise ValueError("unexpected output: %r" % text[:200])
    rows = [line.split(",") for line in lines[1:]]
    return [(a, float(b)) for a, b in rows]


def rel_diff(a, b):
    """|a - b| / max(|a|, |b|, SMALL): at most REL exactly when the values agree to tolerance."""
    return abs(a - b) / max(abs(a), abs(b), SMALL)


def wavelength_sets(f):
    """(in-range wavelengths, [(out-of-range wavelength, end the spec clamps it to)])."""
    nodes = f.wavelengths
    lo, hi = (nodes[0], nodes[-1]) if f.basis == 3 else (f.lambda_min, f.lambda_max)
    inside = {nodes[0], nodes[-1], nodes[len(nodes) // 2], lo, hi}
    if len(nodes) > 1:
        i = len(nodes) // 3
        inside |= {(nodes[i] + nodes[i + 1]) / 2, nodes[i] + 0.3 * (nodes[i + 1] - nodes[i])}
        inside.add(nodes[-2] + 0.9 * (nodes[-1] - nodes[-2]))
    if hi > lo:
        inside |= {lo + 0.123456789 * (hi - lo), lo + 0.77 * (hi - lo)}
    outside = [(lo * 0.8, lo), (lo - 1e-3, lo), (hi + 1e-3, hi), (hi * 1.25, hi)]
    return sorted(inside), outside


def direction_pairs(f, rng):
    thetas = f.thetas
    inc_t = set(thetas) | {0.0, 90.0, (thetas[-1] + 90.0) / 2, min(thetas[-1] + 0.5, 90.0)}
    if thetas[0] > 0:
        inc_t |= {thetas[0] / 2, max(thetas[0] - 0.5, 0.0)}
    for a, b in zip(thetas, thetas[1:]):
        inc_t |= {(a + b) / 2, a + 0.2 * (b - a), a + 0.97 * (b - a)}
    if f.isotropic:
        inc_p = [0.0, 33.5, 137.0, 290.25]
    else:
        phis = f.phis
        inc_p = set(phis) | {p + 40.0 for p in phis} | {-20.0, 400.0}
        for a, b in zip(phis, phis[1:]):
            inc_p |= {(a + b) / 2, a + 0.1 * (b - a)}
        if len(phis) > 1:  # the cell that wraps from the last φ to the first + 360°
            gap = phis[0] + 360.0 - phis[-1]
            inc_p |= {phis[-1] + 0.5 * gap, phis[-1] + 0.9 * gap - 360.0, phis[-1] + 0.05 * gap}
        inc_p = sorted(inc_p)
    incidences = sorted({(t, p) for t in inc_t for p in inc_p})
    stored = [inc for inc in incidences if inc in set(f.incidences)]
    others = [inc for inc in incidences if inc not in set(f.incidences)]
    incidences = stored + rng.sample(others, min(len(others), max(0, 34 - len(stored))))
    pairs = []
    for ti, pi in incidences:
        m = (pi + 180.0) % 360.0
        outs = [(ti, m), (min(ti + 2.0, 90.0), m - 3.0), (0.0, 0.0), (0.3, pi + 90.0),
                (0.001, m), (90.0, m), (89.7, pi + 60.0), (89.99, pi), (45.0, pi + 270.0)]
        outs += [(rng.uniform(0, 90), rng.uniform(0, 360)) for _ in range(2)]
        # The hard points of issue 43, compared like every other pair: the exact mirror
        # direction (above), both directions on the pole, and θ of 89.9999° and 90° on either
        # side and both (a warped table's half vector on the pole, its divisor at the horizon).
        outs += [(89.9999, m), (89.9999, pi + 30.0), (90.0, pi + 150.0)]
        pairs += [((ti, pi), out) for out in outs]
    for phi in (0.0, 47.0):
        pairs += [((0.0, phi), (0.0, 0.0)), ((0.0, phi), (0.0, 200.0)), ((0.0, phi), (10.0, 30.0)),
                  ((10.0, phi), (0.0, 75.0)), ((89.9999, phi), (89.9999, phi + 180.0)),
                  ((90.0, phi), (90.0, phi + 180.0)), ((90.0, phi), (90.0, phi)),
                  ((89.9999, phi), (90.0, phi + 180.0)), ((90.0, phi), (30.0, phi + 180.0)),
                  ((30.0, phi), (90.0, phi + 180.0))]
    # outgoing directions below the horizon (θ > 90°) give 0 (sbrdf eval refuses θi > 90°)
    pairs += [((thetas[0], 0.0), (95.0, 180.0)), ((thetas[-1], 0.0), (180.0, 0.0))]
    return pairs


def refusal_checks(binary, path):
    """A flipped byte and a truncated file must be refused by both readers."""
    data = Path(path).read_bytes()
    problems = []
    with tempfile.TemporaryDirectory() as tmp:
        cases = {"flipped byte": bytearray(data), "truncated": data[:-5]}
        cases["flipped byte"][len(data) // 2] ^= 0x10
        for name, bad in cases.items():
            p = Path(tmp) / "bad.sbrdf"
            p.write_bytes(bytes(bad))
            try:
                rd.open_file(p)
                problems.append("reference decoder accepted the file with a %s" % name)
            except rd.Refused:
                pass
            if subprocess.run([binary, "verify", str(p)], capture_output=True).returncode == 0:
                problems.append("%s verify accepted the file with a %s" % (binary, name))
    return problems


def check_file(binary, path):
    f = rd.open_file(path)
    rng = random.Random(20261123)
    inside, outside = wavelength_sets(f)
    problems = refusal_checks(binary, path)
    # Does the binary evaluate wavelengths outside the file's range?
    rc, _, err = run_eval(binary, path, f.incidences[0], (30.0, 180.0), [outside[0][0]])
    cli_clamps = rc == 0
    lams = inside + [lam for lam, _ in outside]
    cli_lams = lams if cli_clamps else inside
    pairs = direction_pairs(f, rng)
    worst, worst_at, nvalues = 0.0, None, 0
    for inc, out in pairs:
        rc, stdout, stderr = run_eval(binary, path, inc, out, cli_lams)
        if rc != 0:
            problems.append("sbrdf eval failed at %r %r: %s" % (inc, out, stderr.strip()))
            continue
        rows = parse_csv(stdout)
        cli = {}
        for lam, (text, value) in zip(cli_lams, rows):
            if text != rd.fmt(lam):
                problems.append("wavelength printed as %r, expected %r" % (text, rd.fmt(lam)))
            cli[lam] = value
        for lam, end in outside:  # the spec clamps: compare with the value at the end
            cli.setdefault(lam, cli[end])
        ref = f.eval(inc[0], inc[1], out[0], out[1], lams)
        for lam, value in zip(lams, ref):
            nvalues += 1
            r = rel_diff(value, cli[lam])
            if r > worst:
                worst, worst_at = r, (inc, out, lam, value, cli[lam])
            if r > REL:
                problems.append("mismatch at incident %r outgoing %r λ %r: reference %r, sbrdf %r"
                                % (inc, out, lam, value, cli[lam]))
    # The reference decoder's own command line, default wavelengths: same CSV text form.
    inc, out = f.incidences[-1], (f.incidences[-1][0], (f.incidences[-1][1] + 180.0) % 360.0)
    mine = subprocess.run([sys.executable, str(DECODER), str(path), "--incident=%r,%r" % inc,
                           "--outgoing=%r,%r" % out], capture_output=True, text=True)
    _, theirs, _ = run_eval(binary, path, inc, out, None)
    a, b = parse_csv(mine.stdout), parse_csv(theirs)
    if [t for t, _ in a] != [t for t, _ in b] or any(rel_diff(x, y) > REL for (_, x), (_, y)
                                                      in zip(a, b)):
        problems.append("reference_decoder.py CSV differs from sbrdf eval's")
    for p in problems[:10]:
        print("  " + p)
    note = "" if cli_clamps else " (sbrdf eval refuses out-of-range λ: %d of them compared " \
        "with its value at the clamped end)" % len(outside)
    print("%s: %s: %d pairs, %d values, worst relative difference %.3g%s"
          % ("PASS" if not problems else "FAIL", path, len(pairs), nvalues, worst, note))
    if worst_at and problems:
        print("  worst at incident %r outgoing %r λ %r: reference %r, sbrdf %r" % worst_at)
    return not problems


def manifest_files(manifest):
    """The files a golden MANIFEST lists, checked against its folder's .sbrdf files."""
    manifest = Path(manifest)
    listed = []
    for line in manifest.read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            listed.append(line.split(":", 1)[0].strip())
    present = sorted(p.name for p in manifest.parent.glob("*.sbrdf"))
    if not listed or sorted(listed) != present:
        raise ValueError("%s lists %s; the folder holds %s" % (manifest, sorted(listed), present))
    return [str(manifest.parent / name) for name in listed]


def main(argv):
    global REL
    args = argv[1:]
    if len(args) >= 2 and args[0] == "--rel":
        REL = float(args[1])
        args = args[2:]
    if len(args) < 2:
        print(__doc__.strip().split("\n\n")[1], file=sys.stderr)
        return 2
    binary, paths = args[0], []
    rest = iter(args[1:])
    for a in rest:
        if a == "--manifest":
            m = next(rest, None)
            if m is None:
                print("--manifest needs a file", file=sys.stderr)
                return 2
            try:
                listed = manifest_files(m)
            except (ValueError, OSError) as e:
                print("FAIL: %s" % e)
                return 1
            print("%s: %d files" % (m, len(listed)))
            paths += listed
        else:
            paths.append(a)
    ok = True
    for path in paths:
        try:
            ok &= check_file(binary, path)
        except (rd.Refused, ValueError, OSError) as e:
            print("FAIL: %s: %s" % (path, e))
            ok = False
    print("%d files, required agreement %g relative" % (len(paths), REL))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
