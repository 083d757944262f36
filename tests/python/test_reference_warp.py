#!/usr/bin/env python3
"""Self-test of the WARP chunk (FORMAT.md §3.10, EVALUATION.md "Warped tables", versions 1.4 and
1.5) in spec/reference_decoder.py, without the Rust binary.

Tiny WARP files are built by hand here, byte by byte from the specification, and decoded by the
reference decoder; the checks are properties derived by hand from the text. The tables are
indexed by the viewing direction ("Whose direction the tables follow"): a query (ωi, ωo) is
answered with the roles exchanged, the tables' incidence, bracket and σ taken at the query's ωo
and the division by the cosine of the query's ωi. So with only the DC coefficient non-zero a
table is constant q·n/R, and the value at a pair is q·n/R·B_0(λ)·D(u_x)/(4σ(θo))/cos θi, the
tables blended in θo (σ recomputed here by its own loops); single non-DC coefficients give the
cosines of the inverse DCT-II in diagonal order, and in a 1.5 file with layout 17 the wavelet's
synthesis vectors worked by hand from the lifting steps, in band order; the inverse warp equals the conditional and
marginal integrals of the bilinear density, integrated numerically here; and every malformed
case the text lists is refused. A file with WARP holds no records chunk (§3.10, §2.5 rules 3
and 7): the files built here have none, and a RECS or RECD anywhere in one is refused.

    python3 tests/python/test_reference_warp.py            # the checks
    python3 tests/python/test_reference_warp.py --timing   # also: time to open larger files

Standard library only. Exit status 0 when every check passes; the last line says
'N passed, M failed'.
"""

import math
import struct
import subprocess
import sys
import tempfile
import time
import zlib
from pathlib import Path

SPEC = Path(__file__).resolve().parents[2] / "spec"
sys.path.insert(0, str(SPEC))
import reference_decoder as rd  # noqa: E402

SIG = b"\x89SBRDF\r\n\x1a\n"

# ---------------------------------------------------------------- building files by hand


def chunk(ctype, data):
    """§2.2: length, type, data, CRC-32 of type and data (§2.3), little-endian."""
    return (struct.pack("<I", len(data)) + ctype + data
            + struct.pack("<I", zlib.crc32(ctype + data) & 0xFFFFFFFF))


def head(thetas, k=1, basis=3, waves=(500.0, 600.0), flags=1, level=0, minor=4,
         lam=(500.0, 600.0), phis=None):
    """§3.1: HEAD with the given incidences (θ, φ = 0 unless phis is given)."""
    phis = phis or [0.0] * len(thetas)
    data = struct.pack("<HHIBBBBHHddII", 1, minor, flags, basis, 0, level, 1, k, 0,
                       lam[0], lam[1], len(waves), len(thetas))
    data += struct.pack("<%df" % len(waves), *waves)
    for t, p in zip(thetas, phis):
        data += struct.pack("<ff", t, p)
    return chunk(b"HEAD", data)


def sbas(values):
    """§3.2: precision 1 (f32), K·W values."""
    return chunk(b"SBAS", bytes([1, 0, 0, 0]) + struct.pack("<%df" % len(values), *values))


def varint(z):
    """§3.10: the zigzag code of z as an unsigned LEB128 varint."""
    u = 2 * z if z >= 0 else -2 * z - 1
    out = bytearray()
    while True:
        byte = u & 0x7F
        u >>= 7
        out.append(byte | (0x80 if u else 0))
        if not u:
            return bytes(out)


def diagonal_order(r):
    """§3.10: the frequency pairs (a, b) sorted by a + b, then by a."""
    return sorted(((a, b) for a in range(r) for b in range(r)), key=lambda p: (p[0] + p[1], p[0]))


def band_order_4():
    """§3.10's band order for R = 4, by hand: the bands of a = 0..3 are (0, 1, 2, 2) (two
    levels: 4 → 2 + 2, then 2 → 1 + 1); pairs by band sum, then band of a, of b, then a, b."""
    return [(0, 0), (0, 1), (1, 0), (0, 2), (0, 3), (1, 1), (2, 0), (3, 0), (1, 2), (1, 3),
            (2, 1), (3, 1), (2, 2), (2, 3), (3, 2), (3, 3)]


def payload_of(tables, r, order=None):
    """The inflated payload bytes: tables in order (i·K + k), each a dict {(a, b): n}, each in
    `order` (diagonal order by default)."""
    raw = b""
    for tab in tables:
        for ab in order or diagonal_order(r):
            raw += varint(tab.get(ab, 0))
    return raw


def warp(r, g, m, c, ndf, steps, payload, layout=1, ndf_prec=1, plen=None):
    """§3.10: the WARP chunk around an already compressed payload (NDF in f32 or f16)."""
    data = struct.pack("<BBHHHf", layout, ndf_prec, r, g, m, c)
    code = "f" if ndf_prec == 1 else "e"
    data += struct.pack("<%d%s" % (len(ndf), code), *ndf) + struct.pack("<%df" % len(steps), *steps)
    data += struct.pack("<I", len(payload) if plen is None else plen) + payload
    return chunk(b"WARP", data)


def empty_record(prec=1):
    """§3.9: one compact empty record (T = 1, L_r = 0, SH +0, no lobe), f32 or f16 (scale 1).
    Only to build files that must be refused: a file with WARP holds no records chunk."""
    rec = struct.pack("<ffffBBBH", 0.0, 0.0, 0.0, 0.0, 0, prec, 0, 1)
    if prec == 1:
        return rec + struct.pack("<f", 0.0)
    return rec + struct.pack("<f", 1.0) + struct.pack("<e", 0.0)


def recs(n, prec=1):
    """§3.9: a RECS chunk of n empty records (refused in a file with WARP)."""
    return chunk(b"RECS", b"".join(empty_record(prec) for _ in range(n)))


def recd(index, theta, prec=1, scale=1.0):
    """§3.3: an empty RECD record of incidence (θ, 0) (T = 1, L_r = 0, SH +0), in either
    precision (refused in a file with WARP)."""
    data = struct.pack("<I7f", index, theta, 0.0, 0.0, 0.0, 0.0, 0.0, scale)
    data += struct.pack("<BBBBHH", 0, prec, 0, 0, 1, 0)
    data += struct.pack("<f", 0.0) if prec == 1 else struct.pack("<e", 0.0)
    return chunk(b"RECD", data)


def fact(w):
    """§3.7: a minimal valid FACT: one component, rank 1, feature 2 (θd, 10 nodes), f32."""
    data = struct.pack("<BBH", 1, 1, 0)
    data += struct.pack("<10f", 0, 90, 0, 90, 0, 90, 0, 90, -1, 1)
    data += bytes([1, 1, 2]) + struct.pack("<%df" % (w + 10), *([0.0] * (w + 10)))
    return chunk(b"FACT", data)


ENDF = chunk(b"ENDF", b"")

# The base file: N = 2 incidences (10°, 40°), K = 1 tabulated term B_0 = 0.5 at 500 nm, 1.5 at
# 600 nm, R = G = M = 4, σ scale 0.5, NDF 2, 1.5, 1, 0.5 (D(x) = 2 − 1.5x), steps 0.5 and 0.25,
# DC integers 8 and 12: tables 0.5·8/4 = 1 and 0.25·12/4 = 0.75.
THETAS = [10.0, 40.0]
R = G = M = 4
C_SCALE = 0.5
NDF = [2.0, 1.5, 1.0, 0.5]
STEPS = [0.5, 0.25]
DC = [8, 12]
BASIS = [0.5, 1.5]


def base_payload(tables=None, r=R):
    tables = tables if tables is not None else [{(0, 0): n} for n in DC]
    return zlib.compress(payload_of(tables, r), 9)


def build(warp_chunk=None, head_chunk=None, sbas_chunk=None, records=None, extra=(),
          order=None, tail=b""):
    """A WARP file, with no records chunk (§3.10); `records` (bytes: RECS or RECD chunks) adds
    them, after WARP unless `order` says otherwise; `order` lists the chunks by name to reorder
    or repeat them."""
    parts = {
        "HEAD": head_chunk or head(THETAS),
        "SBAS": sbas_chunk or sbas(BASIS),
        "WARP": warp_chunk or warp(R, G, M, C_SCALE, NDF, STEPS, base_payload()),
        "RECS": records or b"",
        "ENDF": ENDF,
    }
    parts.update(dict(extra))
    if order is None:
        order = ["HEAD", "SBAS", "WARP"] + (["RECS"] if records else []) + ["ENDF"]
    return SIG + b"".join(parts[name] for name in order) + tail


# ---------------------------------------------------------------- independent formulas


def lerp_nodes(values, x):
    """Linear interpolation at the nodes j/(n − 1) (written here again, from the text)."""
    x = min(max(x, 0.0), 1.0)
    n = len(values)
    for j in range(n - 1):
        lo, hi = j / (n - 1), (j + 1) / (n - 1)
        if x <= hi or j == n - 2:
            return values[j] + (x - lo) / (hi - lo) * (values[j + 1] - values[j])


def vndf_node(theta, ndf, g, a, b):
    """p[b][a] of "The VNDF of stored incidence i" for ωi = (sin θ, 0, cos θ), θ in radians."""
    x, y = a / (g - 1), b / (g - 1)
    tm, pm = x * x * math.pi / 2, 2 * math.pi * y - math.pi
    m = (math.sin(tm) * math.cos(pm), math.sin(tm) * math.sin(pm), math.cos(tm))
    cosine = math.sin(theta) * m[0] + math.cos(theta) * m[2]
    return lerp_nodes(ndf, x) * max(0.0, cosine) * math.sin(tm) * math.pi * x * 2 * math.pi


def vndf_total(theta, ndf, g):
    """I(θ): the trapezoid rule over the G × G nodes."""
    w = [0.5 if a in (0, g - 1) else 1.0 for a in range(g)]
    return sum(w[a] * w[b] * vndf_node(theta, ndf, g, a, b)
               for a in range(g) for b in range(g)) / (g - 1) ** 2


def sigma_at(theta, ndf, g, m, c):
    """σ(θ): c·I at the M nodes (j/(M−1))²·π/2, linear in x = √(θ/(π/2))."""
    nodes = [c * vndf_total((j / (m - 1)) ** 2 * math.pi / 2, ndf, g) for j in range(m)]
    return lerp_nodes(nodes, math.sqrt(theta / (math.pi / 2)))


def half_u(ti, pi_, to, po):
    """For a query ωi = d(θi, φi) (toward the light), ωo = d(θo, φo) (toward the viewer), in
    degrees, with the roles exchanged ("Whose direction the tables follow"): the viewing
    direction turned to d(θo, 0) is the tables' incidence and the light's direction turned with
    it, d(θi, φi − φo), the other one. Returns u of their half vector and cos θi (the cosine
    the value divides by, at least 2⁻¹⁰: "Value", step 5). A viewing direction on the pole is not
    turned; a half vector within 10⁻⁹ of the pole is the pole, u = (0, 1/2) (step 1)."""
    wv = rd.d(to, 0.0)
    wl = rd.d(ti, pi_ - (po if to > 0 else 0.0))
    h = [wv[j] + wl[j] for j in range(3)]
    cos_i = max(wl[2], 1.0 / 1024.0)
    if math.hypot(h[0], h[1]) <= 1e-9:
        return 0.0, 0.5, cos_i
    n = math.sqrt(sum(v * v for v in h))
    m = [v / n for v in h]
    tm = math.atan2(math.hypot(m[0], m[1]), m[2])
    uy = (math.atan2(m[1], m[0]) + math.pi) / (2 * math.pi) % 1.0
    return math.sqrt(tm / (math.pi / 2)), uy, cos_i


def basis0(lam):
    """B_0 of the base file: 0.5 at 500 nm, 1.5 at 600 nm, linear, constant beyond."""
    lam = min(max(lam, 500.0), 600.0)
    return 0.5 + (lam - 500.0) / 100.0


def expected_value(ti, pi_, to, po, lam):
    """The base file's ρ(ωi, ωo) by the hand formula, roles exchanged: the tables (constant 1
    and 0.75) blended in the viewing θo clamped to [10°, 40°], σ at the unclamped θo, the
    division by cos θi of the light's direction."""
    t = (min(max(to, 10.0), 40.0) - 10.0) / 30.0
    table = (1 - t) * 1.0 + t * 0.75
    ux, _, cos_i = half_u(ti, pi_, to, po)
    sigma = sigma_at(math.radians(to), NDF, G, M, C_SCALE)
    value = table * basis0(lam) * lerp_nodes(NDF, ux) / (4 * sigma) / cos_i
    return max(0.0, value)


# ---------------------------------------------------------------- the checks

RESULTS = []


def check(name, ok, detail=""):
    RESULTS.append(bool(ok))
    print("%s: %s%s" % ("ok" if ok else "FAIL", name, "" if ok else "  " + detail))


def close(a, b, rel=1e-12, floor=1e-300):
    return abs(a - b) <= rel * max(abs(a), abs(b), floor)


def decode(data):
    return rd.SbrdfFile(bytes(data))


def refused(name, data, kind="malformed", contains=None):
    try:
        decode(data)
    except rd.Refused as e:
        ok = e.kind == kind and (contains is None or contains in str(e))
        check("refuses " + name, ok, "refused as %s: %s" % (e.kind, e))
        return
    check("refuses " + name, False, "accepted")


def accepted(name, data):
    try:
        decode(data)
        check("accepts " + name, True)
    except rd.Refused as e:
        check("accepts " + name, False, str(e))


def test_values():
    f = decode(build())
    tabs = f.warp_tables
    check("DC-only tables are constant q·n/R",
          all(close(v, 1.0) for v in tabs[0][0]) and all(close(v, 0.75) for v in tabs[1][0]),
          "%r %r" % (list(tabs[0][0]), list(tabs[1][0])))
    nodes = [C_SCALE * vndf_total((j / (M - 1)) ** 2 * math.pi / 2, NDF, G) for j in range(M)]
    check("σ nodes = c·I(θ_j) by the trapezoid rule",
          all(close(a, b, 1e-13) for a, b in zip(f.warp_sigma, nodes)),
          "%r vs %r" % (f.warp_sigma, nodes))
    totals = [vndf_total(math.radians(t), NDF, G) for t in THETAS]
    marg_ok = all(close(w[3][-1], 1.0, 1e-13) for w in f.warp_warps)
    check("each stored warp is normalised (marg ends at 1)", marg_ok and all(t > 0 for t in totals))
    worst, cases = 0.0, 0
    for ti in (10.0, 40.0, 25.0, 17.3, 3.0, 0.0, 55.0, 90.0):
        for pi_ in (0.0, 123.0):
            for to, po in ((ti, 180.0), (30.0, 20.0), (70.0, 250.0), (5.0, 90.0), (89.0, 181.0),
                           (0.0, 0.0), (45.0, 300.5)):
                lams = [450.0, 500.0, 537.5, 600.0, 650.0]
                got = f.eval(ti, pi_, to, po + pi_, lams)
                for lam, g in zip(lams, got):
                    want = expected_value(ti, pi_, to, po + pi_, lam)
                    cases += 1
                    worst = max(worst, abs(g - want) / max(abs(want), 1e-300))
    check("value = q·n/R·B_0(λ)·D(u_x)/(4σ(θo))/cos θi at %d (pair, λ), blended in θo" % cases,
          worst < 1e-11, "worst relative difference %g" % worst)
    # the exchange itself: tables 1 (θv = 10°) and 0.75 (θv = 40°) follow the viewing θo, σ
    # follows θo, the value divides by cos θi; exchanging the two directions changes the value
    a = f.eval(10.0, 0.0, 40.0, 180.0, [550.0])[0]
    b = f.eval(40.0, 0.0, 10.0, 180.0, [550.0])[0]
    ux, _, _ = half_u(10.0, 0.0, 40.0, 180.0)
    dd = lerp_nodes(NDF, ux) * basis0(550.0) / 4
    want_a = 0.75 * dd / sigma_at(math.radians(40.0), NDF, G, M, C_SCALE) / math.cos(
        math.radians(10.0))
    want_b = 1.0 * dd / sigma_at(math.radians(10.0), NDF, G, M, C_SCALE) / math.cos(
        math.radians(40.0))
    check("roles exchanged: table, σ at the query's θo, 1/cos of the query's θi",
          close(a, want_a, 1e-12) and close(b, want_b, 1e-12) and not close(a, b, 1e-3),
          "%r vs %r, %r vs %r" % (a, want_a, b, want_b))
    # the horizon rule, exchanged: θi = 90° (the light at the horizon) divides by 2⁻¹⁰, not by
    # cos(π/2) = 6.1e-17 (issue 43: 10¹³ before); θo = 90° (the viewer at the horizon) is ordinary
    hi = f.eval(90.0, 0.0, 30.0, 180.0, [550.0])[0]
    lo = f.eval(30.0, 0.0, 90.0, 180.0, [550.0])[0]
    check("θi = 90° gives a bounded value (divisor 2⁻¹⁰), θo = 90° an ordinary one",
          math.isfinite(hi) and 0 < hi < 1e4 and 0 < lo < 1e3
          and close(hi, expected_value(90.0, 0.0, 30.0, 180.0, 550.0), 1e-12)
          and close(lo, expected_value(30.0, 0.0, 90.0, 180.0, 550.0), 1e-12), "%r %r" % (hi, lo))
    v = f.eval(20.0, 0.0, 30.0, 180.0, [float("nan"), 550.0])
    check("a non-finite wavelength gives 0", v[0] == 0.0 and v[1] > 0)
    check("outgoing below the horizon or θ outside [0, 90] gives 0",
          f.eval(20.0, 0.0, 95.0, 180.0, [550.0]) == [0.0]
          and f.eval(91.0, 0.0, 30.0, 180.0, [550.0]) == [0.0])
    check("azimuth invariance (isotropic rotation)",
          close(f.eval(25.0, 0.0, 35.0, 170.0, [550.0])[0],
                f.eval(25.0, 77.0, 35.0, 247.0, [550.0])[0], 1e-12))
    # a negative table: the clamp at 0
    neg = build(warp_chunk=warp(R, G, M, C_SCALE, NDF, STEPS,
                                base_payload([{(0, 0): -8}, {(0, 0): -12}])))
    check("negative tables are clamped to 0",
          decode(neg).eval(20.0, 0.0, 30.0, 180.0, [550.0]) == [0.0])


def test_command_line():
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "warp.sbrdf"
        path.write_bytes(build())
        p = subprocess.run([sys.executable, str(SPEC / "reference_decoder.py"), str(path),
                            "--incident=25,0", "--outgoing=30,170", "--wavelengths=500,550,600"],
                           capture_output=True, text=True)
        lines = p.stdout.strip().split("\n")
        ok = p.returncode == 0 and lines[0] == "wavelength_nm,value" and len(lines) == 4
        if ok:
            got = [float(line.split(",")[1]) for line in lines[1:]]
            want = [expected_value(25.0, 0.0, 30.0, 170.0, lam) for lam in (500.0, 550.0, 600.0)]
            ok = all(close(a, b, 1e-11) for a, b in zip(got, want))
        check("command line prints the CSV of sbrdf eval", ok, p.stdout + p.stderr)
        bad = Path(tmp) / "bad.sbrdf"
        bad.write_bytes(build(records=recs(2)))
        p = subprocess.run([sys.executable, str(SPEC / "reference_decoder.py"), str(bad),
                            "--incident=25,0", "--outgoing=30,170"], capture_output=True, text=True)
        check("command line exits 3 on a malformed WARP file (a RECS chunk)", p.returncode == 3,
              p.stderr)


def test_dct_and_order():
    """Single non-DC coefficients: T[r][c] = q·n·α(a)α(b)cos(π(2r+1)a/2R)cos(π(2c+1)b/2R)."""
    order = diagonal_order(R)
    check("diagonal order starts (0,0) (0,1) (1,0) (0,2) (1,1) (2,0)",
          order[:6] == [(0, 0), (0, 1), (1, 0), (0, 2), (1, 1), (2, 0)])

    def alpha(a):
        return math.sqrt((1.0 if a == 0 else 2.0) / R)

    for (a, b) in ((0, 1), (1, 0), (1, 1), (3, 2), (0, 3)):
        f = decode(build(warp_chunk=warp(R, G, M, C_SCALE, NDF, STEPS,
                                         base_payload([{(a, b): 5}, {}]))))
        tab = f.warp_tables[0][0]
        want = [0.5 * 5 * alpha(a) * alpha(b) * math.cos(math.pi * (2 * r + 1) * a / (2 * R))
                * math.cos(math.pi * (2 * c + 1) * b / (2 * R)) for r in range(R) for c in range(R)]
        ok = all(abs(x - y) < 1e-14 for x, y in zip(tab, want)) and not any(f.warp_tables[1][0])
        check("coefficient (a=%d, b=%d): rows along s_y, columns along s_x" % (a, b), ok)
    # K = 2 (cosine basis: B_0 = 1, B_1 = cos πt): table (i, k) at position i·K + k
    hd = head(THETAS, k=2, basis=2, waves=(500.0, 600.0), lam=(500.0, 600.0))
    steps = [1.0, 2.0, 4.0, 8.0]
    tables = [{(0, 0): 4}, {(0, 0): 4}, {(0, 0): 4}, {(0, 0): 4}]
    f = decode(SIG + hd + warp(R, G, M, C_SCALE, NDF, steps, base_payload(tables)) + ENDF)
    consts = [f.warp_tables[i][k][5] for i in range(2) for k in range(2)]
    check("K = 2: table (i, k) uses step q(i·K + k)",
          all(close(x, q * 4 / R) for x, q in zip(consts, steps)), repr(consts))
    # the viewing θo = 10° is stored incidence 0: v = (q(0, 0), q(0, 1)) = (1, 2); σ at θo,
    # divided by cos θi = cos 30°
    ux, _, cos_i = half_u(30.0, 0.0, 10.0, 180.0)
    sig = sigma_at(math.radians(10.0), NDF, G, M, C_SCALE)
    got = f.eval(30.0, 0.0, 10.0, 180.0, [500.0, 550.0, 600.0])
    want = [(1.0 + 2.0 * math.cos(math.pi * t)) * lerp_nodes(NDF, ux) / (4 * sig) / cos_i
            for t in (0.0, 0.5, 1.0)]
    want = [max(0.0, v) for v in want]
    check("K = 2: Σ_k v_k B_k(λ)", all(close(a, b, 1e-11) for a, b in zip(got, want)),
          "%r vs %r" % (got, want))


def normalised_densities():
    """The base file's p_i / I_i on the G × G nodes, rows b of columns a, recomputed here."""
    out = []
    for th in (math.radians(t) for t in THETAS):
        tot = vndf_total(th, NDF, G)
        out.append([[vndf_node(th, NDF, G, a, b) / tot for a in range(G)] for b in range(G)])
    return out


def bilinear_grid(p, x, y):
    """Bilinear interpolation of a square grid p[row][column] over [0, 1]² (x along columns)."""
    n = len(p)
    px, py = x * (n - 1), y * (n - 1)
    a, b = min(int(px), n - 2), min(int(py), n - 2)
    fx, fy = px - a, py - b
    return ((1 - fy) * ((1 - fx) * p[b][a] + fx * p[b][a + 1])
            + fy * ((1 - fx) * p[b + 1][a] + fx * p[b + 1][a + 1]))


def integral(fn, lo, hi, n=600):
    """Simpson's rule on each of the G − 1 cells (exact for the quadratics met here)."""
    total, cells = 0.0, G - 1
    for cidx in range(cells):
        a0, a1 = max(lo, cidx / cells), min(hi, (cidx + 1) / cells)
        if a1 <= a0:
            continue
        k = 2 * max(1, n // cells)
        h = (a1 - a0) / k
        s = fn(a0) + fn(a1) + sum((4 if j % 2 else 2) * fn(a0 + j * h) for j in range(1, k))
        total += s * h / 3
    return total


def numeric_warp(dens, t, ux, uy):
    """s of u for the density (1 − t)·p_0 + t·p_1: its conditional CDF in x at y = u_y over its
    marginal CDF in y, integrated numerically (not the closed form of the text)."""
    p = [[(1 - t) * dens[0][b][a] + t * dens[1][b][a] for a in range(G)] for b in range(G)]
    sy = integral(lambda y: integral(lambda x: bilinear_grid(p, x, y), 0, 1, 60), 0, uy, 60)
    row = integral(lambda x: bilinear_grid(p, x, uy), 0, 1)
    sx = integral(lambda x: bilinear_grid(p, x, uy), 0, ux) / row if row else 0.0
    return sx, sy


def test_warp_inverse():
    """s = the conditional/marginal integrals of the bilinear density, computed numerically."""
    f = decode(build())
    dens = normalised_densities()
    worst = 0.0
    for t in (0.0, 0.3, 1.0):
        for ux, uy in ((0.0, 0.0), (0.2, 0.1), (0.5, 0.5), (0.77, 0.42), (0.95, 0.9),
                       (1.0, 0.999), (0.34, 0.66)):
            sx, sy = f.warp_inverse(0, t, ux, uy)
            want_x, want_y = numeric_warp(dens, t, ux, uy)
            worst = max(worst, abs(sx - want_x), abs(sy - want_y))
    check("inverse warp = conditional and marginal integrals (t = 0, 0.3, 1)", worst < 1e-9,
          "worst %g" % worst)
    sx, sy = f.warp_inverse(0, 0.0, 1.0, 0.9999999)
    check("inverse warp maps the corners of the square to the corners",
          f.warp_inverse(0, 0.0, 0.0, 0.0) == (0.0, 0.0) and close(sx, 1.0, 1e-12)
          and close(sy, 1.0, 1e-6))
    # End to end with tables that vary: coefficient (0, 1) in table 0 (along s_x), (1, 0) in
    # table 1 (along s_y), plus DC; the value is read at the numerically warped point.
    tabs = [{(0, 0): 40, (0, 1): 9}, {(0, 0): 60, (1, 0): -11}]
    f = decode(build(warp_chunk=warp(R, G, M, C_SCALE, NDF, STEPS, base_payload(tabs))))

    def alpha(a):
        return math.sqrt((1.0 if a == 0 else 2.0) / R)

    def grid(i):
        q = STEPS[i]
        return [[sum(q * n * alpha(a) * alpha(b) * math.cos(math.pi * (2 * r + 1) * a / (2 * R))
                     * math.cos(math.pi * (2 * c + 1) * b / (2 * R))
                     for (a, b), n in tabs[i].items())
                 for c in range(R)] for r in range(R)]

    grids = [grid(0), grid(1)]
    worst = 0.0
    # (θi, φi, θo, φo): the warp and the tables follow the viewing θo, the half vector's
    # azimuth is that of the light's direction turned by −φo (u_y matters: table 1 varies
    # along s_y, and the warp's s_y follows u_y)
    for ti, pi_, to, po in ((30.0, 200.0, 10.0, 0.0), (60.0, 150.0, 40.0, 0.0),
                            (45.0, 100.0, 22.0, 0.0), (12.0, 300.0, 31.0, 0.0),
                            (40.0, 180.0, 40.0, 0.0), (50.0, 20.0, 28.0, 95.0),
                            (25.0, 310.0, 17.0, 200.0)):
        t = (to - 10.0) / 30.0
        ux, uy, cos_i = half_u(ti, pi_, to, po)
        sx, sy = numeric_warp(dens, t, ux, uy)
        v = (1 - t) * bilinear_grid(grids[0], sx, sy) + t * bilinear_grid(grids[1], sx, sy)
        want = max(0.0, v * basis0(550.0) * lerp_nodes(NDF, ux)
                   / (4 * sigma_at(math.radians(to), NDF, G, M, C_SCALE)) / cos_i)
        got = f.eval(ti, pi_, to, po, [550.0])[0]
        worst = max(worst, abs(got - want) / max(want, 1e-300))
    check("value with varying tables at the warped point (7 pairs)", worst < 1e-8,
          "worst relative difference %g" % worst)


def test_refusals():
    good = build()
    accepted("the base file", good)
    payload = base_payload()
    wc = lambda pl, **kw: warp(R, G, M, C_SCALE, NDF, STEPS, pl, **kw)  # noqa: E731
    refused("a truncated zlib stream", build(warp_chunk=wc(payload[:-3])), contains="truncated")
    bad_adler = payload[:-1] + bytes([payload[-1] ^ 1])
    refused("a wrong Adler-32", build(warp_chunk=wc(bad_adler)), contains="zlib")
    refused("a payload that is not zlib", build(warp_chunk=wc(b"\x00\x01\x02\x03")),
            contains="zlib")
    dict_stream = zlib.compressobj(9, zlib.DEFLATED, 15, 9, zlib.Z_DEFAULT_STRATEGY, zdict=b"x")
    fdict = dict_stream.compress(payload_of([{(0, 0): n} for n in DC], R)) + dict_stream.flush()
    refused("a zlib stream that needs a preset dictionary (FDICT)",
            build(warp_chunk=wc(fdict)), contains="FDICT")
    # FDICT set on an otherwise ordinary stream (FCHECK recomputed): refused, not inflated
    flg = (payload[1] | 0x20) & 0xE0
    flg |= 31 - (payload[0] * 256 + flg) % 31 if (payload[0] * 256 + flg) % 31 else 0
    refused("the FDICT bit set in a stream's header", build(warp_chunk=wc(
        payload[:1] + bytes([flg]) + b"\0\0\0\1" + payload[2:])), contains="FDICT")
    refused("bytes after the zlib stream", build(warp_chunk=wc(payload + b"\x00")),
            contains="after the payload")
    raw = payload_of([{(0, 0): n} for n in DC], R)
    refused("an integer after the last one", build(warp_chunk=wc(zlib.compress(raw + b"\x00"))),
            contains="after its")
    refused("a payload with fewer integers", build(warp_chunk=wc(zlib.compress(raw[:-1]))),
            contains="integers")
    refused("a payload ending inside a varint",
            build(warp_chunk=wc(zlib.compress(raw[:-1] + b"\x80"))), contains="inside a varint")
    six = b"\x80\x80\x80\x80\x80\x00"
    refused("a varint longer than 5 bytes",
            build(warp_chunk=wc(zlib.compress(raw[:-1] + six))), contains="longer than 5")
    five = b"\x80\x80\x80\x80\x00"
    accepted("a 5-byte (overlong) varint of 0 (allowed up to 5 bytes by §3.10)",
             build(warp_chunk=wc(zlib.compress(raw[:-1] + five))))
    over = b"\x90\x80\x00"  # 16 = DC integer 8, in 3 bytes instead of 1
    f = decode(build(warp_chunk=wc(zlib.compress(over + raw[1:]))))
    check("an overlong varint has its value (DC 8 in 3 bytes: the table is still 1)",
          all(close(v, 1.0) for v in f.warp_tables[0][0]))
    big = b"\x80\x80\x80\x80\x08"  # u = 2^31: z = 2^30, one above the range
    refused("an integer outside [-2^30, 2^30 - 1]",
            build(warp_chunk=wc(zlib.compress(raw[:-1] + big))), contains="outside")
    low = b"\xff\xff\xff\xff\x07"  # u = 2^31 - 1: z = -2^30, the lowest allowed
    accepted("z = -2^30", build(warp_chunk=wc(zlib.compress(raw[:-1] + low))))
    bomb = zlib.compress(b"\x00" * (5 * 2 * R * R + 1))
    refused("a payload inflating past 5·N·K·R² bytes", build(warp_chunk=wc(bomb)),
            contains="more than")
    refused("payload_length 0", build(warp_chunk=wc(b"", plen=0)))
    refused("payload_length past the chunk", build(warp_chunk=wc(payload, plen=len(payload) + 1)))
    refused("payload_length short of the chunk",
            build(warp_chunk=wc(payload + b"\x00", plen=len(payload))))
    # §3.10, §2.5 rules 3 and 7: a file with WARP holds no records chunk; its N records are
    # implied and empty, and ENDF follows WARP
    check("the base file holds no RECS or RECD chunk",
          b"RECS" not in good and b"RECD" not in good)
    f = decode(good)
    got = f.eval(25.0, 0.0, 30.0, 170.0, [500.0, 550.0, 600.0])
    want = [expected_value(25.0, 0.0, 30.0, 170.0, lam) for lam in (500.0, 550.0, 600.0)]
    check("a WARP file with no records chunk decodes as before (hand formula)",
          f.warp is not None and all(close(a, b, 1e-11) for a, b in zip(got, want)),
          "%r vs %r" % (got, want))
    accepted("a WARP file with no records chunk and an unknown ancillary chunk after WARP",
             build(extra={"abcd": chunk(b"abcd", b"xyz")},
                   order=["HEAD", "SBAS", "WARP", "abcd", "ENDF"]))
    in_warp = "records chunk in a file with WARP"
    refused("a RECS of empty records after WARP", build(records=recs(2)), contains=in_warp)
    refused("a RECS of empty f16 records after WARP", build(records=recs(2, prec=2)),
            contains=in_warp)
    refused("a RECS of empty records after WARP and meta",
            build(records=recs(2), extra={"meta": chunk(b"meta", b"m")},
                  order=["HEAD", "SBAS", "WARP", "meta", "RECS", "ENDF"]), contains=in_warp)
    refused("an empty RECD after WARP", build(records=recd(0, 10.0)), contains=in_warp)
    refused("N empty RECD chunks after WARP", build(records=recd(0, 10.0) + recd(1, 40.0)),
            contains=in_warp)
    refused("N empty RECD chunks of precision 2 after WARP",
            build(records=recd(0, 10.0, prec=2) + recd(1, 40.0, prec=2, scale=4.0)),
            contains=in_warp)
    with_records = "WARP in a file with records"
    refused("RECS (empty records) before WARP",
            build(records=recs(2), order=["HEAD", "SBAS", "RECS", "WARP", "ENDF"]),
            contains=with_records)
    refused("N empty RECD chunks before WARP",
            build(records=recd(0, 10.0) + recd(1, 40.0),
                  order=["HEAD", "SBAS", "RECS", "WARP", "ENDF"]), contains=with_records)
    refused("bytes after ENDF", build(tail=b"\x00"), contains="after ENDF")
    refused("WARP without the isotropic flag", build(head_chunk=head(THETAS, flags=0)),
            contains="isotropic")
    facts = {"FACT": fact(2)}
    refused("WARP with FACT before it",
            build(extra=facts, order=["HEAD", "SBAS", "FACT", "WARP", "ENDF"]), contains="FACT")
    refused("WARP with FACT after it",
            build(extra=facts, order=["HEAD", "SBAS", "WARP", "FACT", "ENDF"]), contains="FACT")
    refused("WARP before SBAS", build(order=["HEAD", "WARP", "SBAS", "ENDF"]))
    refused("a second WARP", build(order=["HEAD", "SBAS", "WARP", "WARP", "ENDF"]))
    refused("an unknown layout (as unsupported)", build(warp_chunk=wc(payload, layout=2)),
            kind="unsupported")
    refused("an unknown NDF precision (as unsupported)", build(warp_chunk=wc(payload, ndf_prec=3)),
            kind="unsupported")
    refused("NDF precision 0 (as unsupported)", build(warp_chunk=wc(payload, ndf_prec=0)),
            kind="unsupported")
    accepted("an NDF in f16", build(warp_chunk=wc(payload, ndf_prec=2)))
    f32_file, f16_file = decode(build(warp_chunk=wc(payload))), decode(
        build(warp_chunk=wc(payload, ndf_prec=2)))
    check("an NDF in f16 decodes to the same values (exactly representable NDF)",
          f32_file.eval(30.0, 0.0, 20.0, 180.0, [500.0]) == f16_file.eval(30.0, 0.0, 20.0, 180.0,
                                                                           [500.0]))
    refused("R = 1", build(warp_chunk=warp(1, G, M, C_SCALE, NDF, STEPS,
                                           base_payload([{}, {}], r=1))))
    refused("R = 65", build(warp_chunk=warp(65, G, M, C_SCALE, NDF, STEPS, payload)))
    refused("G = 1", build(warp_chunk=warp(R, 1, M, C_SCALE, NDF, STEPS, payload)))
    refused("G = 2 (the minimum is 3)", build(warp_chunk=warp(R, 2, M, C_SCALE, NDF, STEPS,
                                                              payload)), contains="out of range")
    accepted("G = 3", build(warp_chunk=warp(R, 3, M, C_SCALE, NDF, STEPS, payload)))
    refused("G = 257", build(warp_chunk=warp(R, 257, M, C_SCALE, NDF, STEPS, payload)))
    refused("M = 1", build(warp_chunk=warp(R, G, 1, C_SCALE, NDF[:1], STEPS, payload)))
    refused("sigma_scale 0", build(warp_chunk=warp(R, G, M, 0.0, NDF, STEPS, payload)))
    refused("sigma_scale NaN", build(warp_chunk=warp(R, G, M, math.nan, NDF, STEPS, payload)))
    refused("an NDF of zeros", build(warp_chunk=warp(R, G, M, C_SCALE, [0.0] * 4, STEPS, payload)))
    refused("a negative NDF value",
            build(warp_chunk=warp(R, G, M, C_SCALE, [1.0, -1.0, 1.0, 1.0], STEPS, payload)))
    refused("an infinite NDF value",
            build(warp_chunk=warp(R, G, M, C_SCALE, [1.0, math.inf, 1.0, 1.0], STEPS, payload)))
    refused("a negative step", build(warp_chunk=warp(R, G, M, C_SCALE, NDF, [0.5, -0.25], payload)))
    refused("a NaN step", build(warp_chunk=warp(R, G, M, C_SCALE, NDF, [math.nan, 1.0], payload)))
    accepted("-0 NDF values and steps (equal to +0)",
             build(warp_chunk=warp(R, G, M, C_SCALE, [2.0, 1.5, 1.0, -0.0], [-0.0, 0.25],
                                   payload)))
    refused("an NDF positive only at x = 0 (VNDF total 0)",
            build(warp_chunk=warp(R, G, M, C_SCALE, [1.0, 0.0, 0.0, 0.0], STEPS, payload)),
            contains="total 0")
    # With G ≥ 3 every total I(θ), θ in [0, π/2], is > 0 exactly when D is > 0 at some node
    # x_a, a ≥ 1 (a row φm with cos φm > 0 sees it), so a σ node of 0 cannot arise without a
    # stored total of 0 first (the G = 2 case that made it possible is now out of range). The
    # NDF positive only at x = 0 above is refused by the stored totals; likewise with G = 3 and
    # a single stored incidence at the normal:
    hd = head([0.0], basis=1, waves=(500.0,), lam=(500.0, 500.0))
    refused("a VNDF total of 0 (G = 3, NDF zero at x = 0.5 and 1)",
            SIG + hd + warp(R, 3, 3, C_SCALE, [1.0, 0.0, 0.0], [0.5], base_payload([{(0, 0): 8}]))
            + ENDF, contains="total 0")
    # N·G² > 2^24 is refused before anything is allocated (257 incidences, G = 256)
    many = [i * 0.25 for i in range(257)]
    hd = head(many, basis=1, waves=(500.0,), lam=(500.0, 500.0))
    start = time.time()
    refused("N·G² above 2^24", SIG + hd + warp(R, 256, M, C_SCALE, NDF, [1.0] * 257, payload)
            + ENDF, contains="2^24")
    many = [i * 0.25 for i in range(17)]
    hd = head(many, k=256, basis=1, waves=(500.0, 600.0))
    refused("N·K·R² above 2^24", SIG + hd + warp(64, G, M, C_SCALE, NDF, [1.0] * 17 * 256,
                                                 payload) + ENDF, contains="2^24")
    check("size limits are checked before allocating (fast)", time.time() - start < 2.0)
    flipped = bytearray(good)
    flipped[len(good) // 2] ^= 0x10
    refused("a flipped byte (CRC)", flipped, contains="CRC")
    refused("a truncated file", good[:-5])


def timing():
    """Time to open larger WARP files (build_warp: tables, warps, σ nodes)."""
    import random
    rng = random.Random(5)
    for n, k, r, g, m in ((9, 4, 32, 128, 128), (9, 8, 64, 128, 128), (9, 4, 32, 256, 256)):
        thetas = [i * 10.0 for i in range(n)]
        hd = head(thetas, k=k, basis=1, waves=(400.0, 700.0), lam=(400.0, 700.0))
        ndf = [math.exp(-((j / (m - 1)) ** 2) * 8) * 5 for j in range(m)]
        tables = []
        for _ in range(n * k):  # a decaying spectrum, about a third of it non-zero
            tab = {}
            for a in range(r):
                for b in range(r):
                    if a + b < r // 2 and rng.random() < 0.6:
                        tab[(a, b)] = rng.randint(-200, 200) // (1 + a + b)
            tables.append(tab)
        data = SIG + hd + warp(r, g, m, 1.0, ndf, [0.01] * (n * k),
                               zlib.compress(payload_of(tables, r), 9)) + ENDF
        start = time.time()
        f = decode(data)
        opened = time.time() - start
        start = time.time()
        for i in range(200):
            f.eval(i * 0.4, 0.0, (i * 7.3) % 90, (i * 31.0) % 360, [450.0, 550.0, 650.0])
        per = (time.time() - start) / 200
        print("timing: N=%d K=%d R=%d G=%d M=%d, %d bytes: open %.2f s, eval %.0f µs per pair "
              "(3 λ)" % (n, k, r, g, m, len(data), opened, per * 1e6))


def test_wavelet():
    """Layout 17 (1.5): T[r][c] = q·n·w_a(r)·w_b(c) with w_a = v_a/|v_a|, v_a the inverse 5/3
    transform of e_a. For R = 4, by hand from the lifting steps: v_0 = (1, 1, 1, 1), |v_0| = 2;
    v_1 = (−½, 0, ½, ½), |v_1|² = ¾; v_2 = (−½, ⅝, −¼, −¼), |v_2| = ⅞."""
    v = {0: [1.0, 1.0, 1.0, 1.0], 1: [-0.5, 0.0, 0.5, 0.5], 2: [-0.5, 0.625, -0.25, -0.25]}
    w = {a: [x / math.sqrt(sum(y * y for y in vec)) for x in vec] for a, vec in v.items()}
    hd5 = head(THETAS, minor=5)

    def wavelet_file(tables, layout=17, hd=None):
        pl = zlib.compress(payload_of(tables, R, band_order_4()), 9)
        return build(head_chunk=hd or hd5,
                     warp_chunk=warp(R, G, M, C_SCALE, NDF, STEPS, pl, layout=layout))

    check("the wavelet's bands for R = 4 are (0, 1, 2, 2)", rd.wavelet_bands(4) == [0, 1, 2, 2])
    # Only (0, 0): a constant table q·n/4, the base file's values (the same tables as its DCT).
    f = decode(wavelet_file([{(0, 0): n} for n in DC]))
    worst = 0.0
    for ti, pi_, to, po in ((20.0, 0.0, 30.0, 170.0), (60.0, 45.0, 25.0, 300.0),
                            (5.0, 10.0, 40.0, 200.0)):
        got = f.eval(ti, pi_, to, po, [550.0])[0]
        want = expected_value(ti, pi_, to, po, 550.0)
        worst = max(worst, abs(got - want) / want)
    check("layout 17, (0, 0) only: the base file's values", worst < 1e-12, "worst %g" % worst)
    for (a, b) in ((1, 0), (2, 1), (0, 2), (1, 1)):
        f = decode(wavelet_file([{(a, b): 5}, {}]))
        tab = f.warp_tables[0][0]
        want = [0.5 * 5 * w[a][r] * w[b][c] for r in range(R) for c in range(R)]
        check("layout 17, coefficient (%d, %d) alone: q·n·w_a(r)·w_b(c), band order" % (a, b),
              all(close(x, y, 1e-12, 1e-15) for x, y in zip(tab, want)),
              "%r vs %r" % (list(tab), want))
    refused("layout 17 in a 1.4 file", wavelet_file([{(0, 0): 8}, {(0, 0): 12}],
                                                     hd=head(THETAS, minor=4)))
    refused("layout 33 (transform 2, unknown; as unsupported)",
            wavelet_file([{(0, 0): 8}, {(0, 0): 12}], layout=33), kind="unsupported")


def main():
    test_values()
    test_command_line()
    test_dct_and_order()
    test_wavelet()
    test_warp_inverse()
    test_refusals()
    if "--timing" in sys.argv[1:]:
        timing()
    failed = RESULTS.count(False)
    print("%d passed, %d failed" % (RESULTS.count(True), failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
