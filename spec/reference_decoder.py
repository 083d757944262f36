#!/usr/bin/env python3
"""Independent reference reader and decoder of the .sbrdf format, version 1.7.

Version 1.1 adds to version 1.0 the wavelength range (HEAD flag bit 1, §3.1), the critical `FACT`
chunk (the factor model, §3.7, EVALUATION.md "Factor model") and the ancillary `xval` chunk
(held-out errors, §3.8); version 1.2 adds lobe kind 5, the anisotropic microfacet lobe
(EVALUATION.md "Lobes", its blending in "Lobes by position"); version 1.3 the compact records
(`RECS`, §3.9); version 1.4 the warped tables (`WARP`, §3.10, EVALUATION.md "Warped tables"),
version 1.5 their wavelet transform (`WARP` layout 17), version 1.6 their range-coded payload
(`WARP` layout bit 3), version 1.7 their prediction flags (`WARP` arrangement 2),
whose tables, warps and σ nodes are computed once when the file is opened. Files without them
(every 1.0 file) are read and evaluated exactly as before.

Written from spec/FORMAT.md and spec/EVALUATION.md alone, without looking at the Rust
implementation, to show that those two documents are enough to decode a file. Standard library
only (Python 3.9+). Section references (§ for FORMAT.md, quoted headings for EVALUATION.md) say
which rule each piece implements.

Command line (prints the same CSV as `sbrdf eval`):

    python3 spec/reference_decoder.py FILE --incident THETA,PHI --outgoing THETA,PHI \
        [--wavelengths L1,L2,...]

Angles in degrees, wavelengths in nm (default: the file's wavelengths). A file that breaks the
format is refused with a message on stderr and exit status 3 (malformed), 4 (unsupported) or
5 (limit exceeded), §6.

From Python:

    import reference_decoder
    f = reference_decoder.open_file("m.sbrdf")
    values = f.eval(theta_i, phi_i, theta_o, phi_o, [450.0, 550.0])   # degrees, nm -> 1/sr
"""

import argparse
import bisect
from array import array
import math
import struct
import sys
import zlib

SIGNATURE = b"\x89SBRDF\r\n\x1a\n"
MAX_FILE_BYTES = 256 * 1024 * 1024  # §8: the reference reader's default size limit
MAX_SET_DIRECTIONS = 1 << 22
MAX_WARP_VALUES = 1 << 24  # §3.10: N·K·R² and N·G² are each at most 2^24

# EVALUATION.md, "Factor model", Tables: the fixed nodes of each FACT feature code (§4).
FACT_THETA_I_NODES = (0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 75.0, 80.0, 85.0, 88.0)
FACT_X_NODES = tuple(-1.0 + 0.25 * i for i in range(9))
FACT_NODES = {
    1: (0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.5, 8.0, 10.0, 13.0, 16.0, 20.0,
        25.0, 30.0, 40.0, 50.0, 60.0, 75.0, 90.0),  # θh
    2: tuple(10.0 * i for i in range(10)),  # θd
    3: FACT_THETA_I_NODES,  # θi, in 1/cos θi
    4: FACT_THETA_I_NODES,  # θo, in 1/cos θo
    5: FACT_X_NODES,  # x
}
FACT_6_THETA_NODES = (0.0, 20.0, 40.0, 60.0, 70.0, 80.0, 88.0)  # code 6: θi axis (× x axis)
FACT_NODE_COUNT = {1: 23, 2: 10, 3: 12, 4: 12, 5: 9, 6: 63}  # n(k), §3.7


class Refused(Exception):
    """The file is refused (§6); kind is 'malformed', 'unsupported' or 'limit exceeded'."""

    EXIT = {"malformed": 3, "unsupported": 4, "limit exceeded": 5}

    def __init__(self, kind, message):
        super().__init__("%s: %s" % (kind, message))
        self.kind = kind


def malformed(msg):
    return Refused("malformed", msg)


def unsupported(msg):
    return Refused("unsupported", msg)


def is_neg_zero(x):
    return x == 0.0 and math.copysign(1.0, x) < 0


def to_f32(x):
    """Round a binary64 value to the nearest binary32 (ties to even); inf when it overflows."""
    try:
        return struct.unpack("<f", struct.pack("<f", x))[0]
    except OverflowError:
        return math.copysign(math.inf, x)


class Reader:
    """Little-endian field reader over one chunk's data (§1: no padding)."""

    def __init__(self, data, where):
        self.data, self.pos, self.where = data, 0, where

    def left(self):
        return len(self.data) - self.pos

    def take(self, fmt, what="field"):
        size = struct.calcsize("<" + fmt)
        if size > self.left():
            raise malformed("%s: %s runs past the end of the chunk" % (self.where, what))
        values = struct.unpack_from("<" + fmt, self.data, self.pos)
        self.pos += size
        return values


def d(theta, phi):
    """Unit vector of (θ, φ) in degrees ("Directions")."""
    t, p = math.radians(theta), math.radians(phi)
    return (math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t))


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def wrap360(x):
    """x modulo 360 into [0, 360)."""
    r = math.fmod(x, 360.0)
    if r < 0.0:
        r += 360.0
    return 0.0 if r >= 360.0 else r


def bracket(xs, x):
    """"Between stored incidences", Bracketing: (i, t) for a strictly increasing list."""
    n = len(xs)
    if n == 1 or x <= xs[0]:
        return 0, 0.0
    if x >= xs[-1]:
        return n - 2, 1.0
    i = bisect.bisect_right(xs, x) - 1  # xs[i] <= x < xs[i+1]
    return i, (x - xs[i]) / (xs[i + 1] - xs[i])


def lerp_nodes(values, x):
    """Linear interpolation of values given at the nodes j/(n−1), j = 0..n−1, at x clamped to
    [0, 1] (the last cell at x = 1): D(x) and σ of "Warped tables"."""
    n = len(values)
    pos = min(max(x, 0.0), 1.0) * (n - 1)
    j = min(int(pos), n - 2)
    f = pos - j
    return (1.0 - f) * values[j] + f * values[j + 1]


def wavelet_levels(n):
    """"Warped tables": the lengths m the levels of the 1-D wavelet work on: n, then ⌈m/2⌉,
    at most 3 levels, each while m ≥ 2."""
    out, m = [], n
    while len(out) < 3 and m >= 2:
        out.append(m)
        m = (m + 1) // 2
    return out


def wavelet_inverse(x):
    """"Warped tables": the inverse 1-D CDF 5/3 wavelet transform of x (a list), levels undone
    in reverse order, each: low band to the even places and high band to the odd ones, the
    update undone, then the prediction, with whole-sample symmetric extension."""
    x = list(x)
    for m in reversed(wavelet_levels(len(x))):
        half = (m + 1) // 2
        y = [0.0] * m
        y[0::2] = x[:half]
        y[1::2] = x[half:m]

        def at(j):
            return y[-j] if j < 0 else (y[2 * (m - 1) - j] if j >= m else y[j])
        for j in range(0, m, 2):
            y[j] -= (at(j - 1) + at(j + 1)) / 4
        for j in range(1, m, 2):
            y[j] += (at(j - 1) + at(j + 1)) / 2
        x[:m] = y
    return x


def wavelet_bands(n):
    """"Warped tables": β(a) for a = 0..n−1: L − l in the high band of level l (L levels),
    0 in the last low band."""
    levels = wavelet_levels(n)
    band = [0] * n
    for l, m in enumerate(levels):
        for a in range((m + 1) // 2, m):
            band[a] = len(levels) - l
    return band


def table_bilinear(table, size, sx, sy):
    """"Warped tables": a size × size table (node (r, c) at s = (c, r)/(size − 1), row-major) at
    s clamped to [0, 1]², bilinear; the last cell at s = 1."""
    px = min(max(sx, 0.0), 1.0) * (size - 1)
    py = min(max(sy, 0.0), 1.0) * (size - 1)
    c = min(int(px), size - 2)
    r = min(int(py), size - 2)
    fx, fy = px - c, py - r
    o = r * size + c
    return ((1.0 - fy) * ((1.0 - fx) * table[o] + fx * table[o + 1])
            + fy * ((1.0 - fx) * table[o + size] + fx * table[o + size + 1]))


# ---------------------------------------------------------------- spherical harmonics

def sh_eval(level, w):
    """Real SH Y_0..Y_{(level+1)^2-1} at unit vector w ("Spherical harmonics", Cartesian)."""
    x, y, z = w
    out = [0.0] * ((level + 1) ** 2)
    c, s = 1.0, 0.0  # C_m, S_m
    qmm = 1.0  # Q_m^m = (2m-1)!!
    for m in range(level + 1):
        if m > 0:
            c, s = x * c - y * s, y * c + x * s
            qmm *= 2 * m - 1
        q_prev2, q_prev = None, qmm  # Q_{l-2}^m, Q_{l-1}^m
        for l in range(m, level + 1):
            if l == m:
                q = qmm
            elif l == m + 1:
                q = (2 * m + 1) * z * qmm
            else:
                q = ((2 * l - 1) * z * q_prev - (l + m - 1) * q_prev2) / (l - m)
            if l > m:
                q_prev2, q_prev = q_prev, q
            k = math.sqrt((2 * l + 1) / (4 * math.pi)
                          * (math.factorial(l - m) / math.factorial(l + m)))
            if m == 0:
                out[l * (l + 1)] = k * q
            else:
                out[l * (l + 1) + m] = math.sqrt(2.0) * k * q * c
                out[l * (l + 1) - m] = math.sqrt(2.0) * k * q * s
    return out


# ---------------------------------------------------------------- lobes

def microfacet_geometry(wi, w):
    """What the variants of kinds 2, 3 and 5 share ("Lobes"): h, ch, cd, ci, co, Vc and F, or
    None when s = ωi + ω is (0, 0, 0) (every variant is then 0)."""
    s = (wi[0] + w[0], wi[1] + w[1], wi[2] + w[2])
    if s == (0.0, 0.0, 0.0):
        return None
    n = math.sqrt(dot(s, s))
    h = (s[0] / n, s[1] / n, s[2] / n)
    ch = min(max(h[2], 0.0), 1.0)
    cd = min(max(dot(wi, h), 1e-6), 1.0)
    ci = max(wi[2], 1e-6)
    co = max(w[2], 1e-6)
    vc = min(1.0 / (ci * co), 2 * ch / (cd * ci), 2 * ch / (cd * co))
    f = (1.0 - cd) ** 5
    return h, ch, ci, co, vc, f


def microfacet_variants(kind, b, c, a, wi, w):
    """The four variants of kinds 2 and 3 ("Lobes")."""
    g = microfacet_geometry(wi, w)
    if g is None:
        return (0.0, 0.0, 0.0, 0.0)
    h, ch, ci, co, vc, f = g
    x = 1.0 - ch if kind == 2 else 1.0 - ch * ch
    dist = (1.0 + b * x) ** (-c)
    vs = 1.0 / (co * math.sqrt(a * a + (1 - a * a) * ci * ci)
                + ci * math.sqrt(a * a + (1 - a * a) * co * co))
    return (dist * vs, dist * vs * f, dist * vc, dist * vc * f)


def microfacet_aniso_variants(params, wi, w):
    """The four variants of kind 5 ("Lobes", version 1.2)."""
    bx, by, c, ax, ay, psi = params
    g = microfacet_geometry(wi, w)
    if g is None:
        return (0.0, 0.0, 0.0, 0.0)
    h, ch, ci, co, vc, f = g
    cp, sp = math.cos(math.radians(psi)), math.sin(math.radians(psi))

    def along(x):
        return (x[0] * cp + x[1] * sp, x[1] * cp - x[0] * sp)

    hu, hv = along(h)
    iu, iv = along(wi)
    ou, ov = along(w)
    dist = (1.0 + bx * hu * hu + by * hv * hv) ** (-c)
    vs = 1.0 / (co * math.sqrt(ci * ci + ax * ax * iu * iu + ay * ay * iv * iv)
                + ci * math.sqrt(co * co + ax * ax * ou * ou + ay * ay * ov * ov))
    return (dist * vs, dist * vs * f, dist * vc, dist * vc * f)


def mean_axis(pairs):
    """ψ blended as an axis ("Lobes by position"): pairs of (weight, ψ in degrees); None when
    the doubled angles' mean vanishes."""
    x = sum(wgt * math.cos(math.radians(2 * psi)) for wgt, psi in pairs)
    y = sum(wgt * math.sin(math.radians(2 * psi)) for wgt, psi in pairs)
    if math.hypot(x, y) <= 1e-9 * sum(abs(wgt) for wgt, _ in pairs):
        return None
    psi = 0.5 * math.degrees(math.atan2(y, x))
    if psi < 0:
        psi += 180.0
    return 0.0 if psi >= 180.0 else psi


def lobe_add(coef, lobe, peak, wi, w):
    """Add ℓ(k, w) of one lobe to coef[k]; lobe = (kind, amps, params), amps[j][k]."""
    kind, amps, params = lobe
    if kind in (1, 4):
        cos_a = dot(w, peak)
        if kind == 1:
            cx = (w[1] * peak[2] - w[2] * peak[1], w[2] * peak[0] - w[0] * peak[2],
                  w[0] * peak[1] - w[1] * peak[0])
            alpha = math.atan2(math.sqrt(dot(cx, cx)), cos_a)
            for k, p in enumerate(amps[0]):
                coef[k] += p * math.exp(-alpha * alpha / params[k])
        else:
            f = min(1.0, max(0.0, cos_a)) ** params[0]
            for k, p in enumerate(amps[0]):
                coef[k] += p * f
    else:
        if kind == 5:
            var = microfacet_aniso_variants(params, wi, w)
        else:
            var = microfacet_variants(kind, params[0], params[1], params[2], wi, w)
        for j in range(4):
            for k, q in enumerate(amps[j]):
                coef[k] += q * var[j]


# ---------------------------------------------------------------- factor model (1.1)

def inv_cos_deg(v):
    """U of feature codes 3 and 4 (and of code 6's θi axis): 1/cos(min(max(v, 0), 88)°)."""
    return 1.0 / math.cos(math.radians(min(max(v, 0.0), 88.0)))


def table_pos(nodes, v, u=None):
    """"Factor model", Tables: (j, a) of v on the nodes, linear in U (u; None: U(v) = v)."""
    m = len(nodes)
    v = min(max(v, nodes[0]), nodes[-1])
    j = min(bisect.bisect_right(nodes, v) - 1, m - 2)  # the largest j with n_j <= v, <= m-2
    if u is None:
        a = (v - nodes[j]) / (nodes[j + 1] - nodes[j])
    else:
        a = (u(v) - u(nodes[j])) / (u(nodes[j + 1]) - u(nodes[j]))
    return j, min(max(a, 0.0), 1.0)


def table_value(code, t, feat):
    """t(u_f) of one table t of feature code `code`; feat = the clamped (θh, θd, θi, θo, x)."""
    if code == 6:  # (θi, x), bilinear; value at (θi-node p, x-node q) at index 9p + q
        j, a = table_pos(FACT_6_THETA_NODES, feat[2], inv_cos_deg)
        i, b = table_pos(FACT_X_NODES, feat[4])
        return ((1 - a) * (1 - b) * t[9 * j + i] + (1 - a) * b * t[9 * j + i + 1]
                + a * (1 - b) * t[9 * (j + 1) + i] + a * b * t[9 * (j + 1) + i + 1])
    j, a = table_pos(FACT_NODES[code], feat[code - 1], inv_cos_deg if code in (3, 4) else None)
    return (1 - a) * t[j] + a * t[j + 1]


def fact_features(wi, wo, ranges):
    """"Factor model", Features: (θh, θd, θi, θo, x) of unit vectors wi, wo (z >= 0), each
    clamped to its stored range (a NaN becomes the range's minimum)."""
    xi, yi, zi = wi
    xo, yo, zo = wo
    ri = math.sqrt(xi * xi + yi * yi)
    c, s = (xi / ri, yi / ri) if ri > 0 else (1.0, 0.0)
    wi2 = (ri, 0.0, zi)  # ωi turned about z to azimuth 0, ωo with it
    wo2 = (c * xo + s * yo, -s * xo + c * yo, zo)
    m = (wi2[0] + wo2[0], wi2[1] + wo2[1], wi2[2] + wo2[2])
    mn = math.sqrt(dot(m, m))
    if math.sqrt(m[0] * m[0] + m[1] * m[1]) <= WARP_POLE_HALF_XY:
        # the mirror direction (m = 0 too): the half vector is the pole
        theta_h, theta_d = 0.0, math.degrees(math.atan2(ri, zi))
    elif mn > 0:
        h = (m[0] / mn, m[1] / mn, m[2] / mn)
        theta_h = math.degrees(math.atan2(math.sqrt(h[0] * h[0] + h[1] * h[1]), h[2]))
        cx = (wi2[1] * h[2] - wi2[2] * h[1], wi2[2] * h[0] - wi2[0] * h[2],
              wi2[0] * h[1] - wi2[1] * h[0])
        theta_d = math.degrees(math.atan2(math.sqrt(dot(cx, cx)), dot(wi2, h)))
    else:
        theta_h = theta_d = 90.0
    theta_i = math.degrees(math.atan2(ri, zi))
    theta_o = math.degrees(math.atan2(math.sqrt(wo2[0] * wo2[0] + wo2[1] * wo2[1]), wo2[2]))
    out = []
    for v, (lo, hi) in zip((theta_h, theta_d, theta_i, theta_o, wo2[0]), ranges):
        out.append(lo if math.isnan(v) else min(max(v, lo), hi))
    return out


# ---------------------------------------------------------------- the file

class RangeDecoder:
    """§3.10, "Range-coded payload": the binary range decoder (LZMA's, 12-bit probabilities)."""

    def __init__(self, data, where):
        self.data, self.where = data, where
        if len(data) < 5:
            raise malformed("%s: range-coded payload shorter than 5 bytes (§3.10)" % where)
        if data[0] != 0:
            raise malformed("%s: range-coded payload's first byte is %d, not 0 (§3.10)"
                            % (where, data[0]))
        self.code = int.from_bytes(data[1:5], "big")
        self.range = 0xFFFFFFFF
        self.pos = 5

    def normalise(self):
        while self.range < (1 << 24):
            if self.pos >= len(self.data):
                raise malformed("%s: range-coded payload ends early (§3.10)" % self.where)
            self.range = (self.range << 8) & 0xFFFFFFFF
            self.code = ((self.code << 8) | self.data[self.pos]) & 0xFFFFFFFF
            self.pos += 1

    def bit(self, models, i):
        """An adaptive bit with the probability models[i] (of a 0, in units of 2^-12)."""
        p = models[i]
        bound = (self.range >> 12) * p
        if self.code < bound:
            self.range = bound
            models[i] = p + ((4096 - p) >> 4)
            b = 0
        else:
            self.code -= bound
            self.range -= bound
            models[i] = p - (p >> 4)
            b = 1
        self.normalise()
        return b

    def direct(self):
        self.range >>= 1
        if self.code >= self.range:
            self.code -= self.range
            b = 1
        else:
            b = 0
        self.normalise()
        return b


class RangeIntegers:
    """§3.10: one sequence's U[u][q] and E[e][q] models, and its integers."""

    def __init__(self):
        self.u = [[2048] * 5 for _ in range(4)]
        self.e = [[2048] * 5 for _ in range(35)]

    def get(self, dec, zero, zi, q):
        if not dec.bit(zero, zi):
            return 0
        negative = dec.direct()
        m = 0
        while m < 4 and dec.bit(self.u[m], q):
            m += 1
        if m == 4:
            n = 1
            while dec.bit(self.e[n - 1], q):
                n += 1
                if n > 35:
                    raise malformed("%s: range-coded integer longer than 35 Exp-Golomb bits "
                                    "(§3.10)" % dec.where)
            x = 1
            for _ in range(n - 1):
                x = 2 * x + dec.direct()
            m = x + 3
        return -(m + 1) if negative else m + 1


def context_class(s):
    """§3.10: 0 for 0, 1 for 1, 2 for 2–3, 3 for 4–7, 4 from 8."""
    return 0 if s == 0 else 1 if s == 1 else 2 if s <= 3 else 3 if s <= 7 else 4


def decode_range_payload(data, m, ndf_prec, tables, k, grid, transform, where, flags=None):
    """§3.10, "Range-coded payload": the M NDF values, the N·K steps, (arrangement 2, 1.7) the
    prediction flags of incidences 1 … N − 1 (`flags` = N), and the N·K·R² integers (each table
    in the transform's order, as the zlib payload holds them)."""
    dec = RangeDecoder(data, where)
    # 1. NDF: bit patterns, predicted linearly from the two before
    seq, zero, q, pats = RangeIntegers(), [2048] * 5, 0, []
    top = 0xFFFF if ndf_prec == 2 else 0xFFFFFFFF
    for j in range(m):
        res = seq.get(dec, zero, q, q)
        q = context_class(abs(res))
        pred = 0 if j == 0 else pats[0] if j == 1 else 2 * pats[j - 1] - pats[j - 2]
        v = pred + res
        if not 0 <= v <= top:
            raise malformed("%s: NDF bit pattern %d out of range (§3.10)" % (where, v))
        pats.append(v)
    fmt = "<H" if ndf_prec == 2 else "<I"
    ndf = [struct.unpack("<e" if ndf_prec == 2 else "<f", struct.pack(fmt, v))[0] for v in pats]
    # 2. steps: binary32 patterns, each from the one before
    seq, zero, q, last, steps = RangeIntegers(), [2048] * 5, 0, 0, []
    for t in range(tables):
        res = seq.get(dec, zero, q, q)
        q = context_class(abs(res))
        last += res
        if not 0 <= last <= 0xFFFFFFFF:
            raise malformed("%s: step bit pattern %d out of range (§3.10)" % (where, last))
        steps.append(struct.unpack("<f", struct.pack("<I", last))[0])
    # 3. (1.7, arrangement 2) one adaptive bit per incidence after the first, one model
    predicted = [False] * (tables // k)  # arrangement 1: no incidence predicted
    model = [2048]
    for i in range(1, flags or 0):
        predicted[i] = dec.bit(model, 0) == 1
    # 4. tables, in the transform's order; contexts by frequency class and neighbours
    R = grid
    if transform == 0:
        order = sorted(((a, b) for a in range(R) for b in range(R)),
                       key=lambda ab: (ab[0] + ab[1], ab[0]))
        bounds = (0, 1, 2, 3, 5, 8, 12, 18, 26)

        def cls(a, b):
            for j, t in enumerate(bounds):
                if a + b <= t:
                    return j
            return 9
    else:
        band = wavelet_bands(R)
        order = sorted(((a, b) for a in range(R) for b in range(R)),
                       key=lambda ab: (band[ab[0]] + band[ab[1]], band[ab[0]],
                                       band[ab[1]], ab[0], ab[1]))

        def cls(a, b):
            return band[a] + band[b]
    classes = [cls(a, b) for a, b in order]
    seq = RangeIntegers()
    zero = [[2048] * 5 for _ in range(16)]
    nat = [dict() for _ in range(tables)]  # (a, b) -> n, per table
    ints = array("l")
    for t in range(tables):
        cur = nat[t]
        prev_i = nat[t - k] if t >= k else None
        prev_k = nat[t - 1] if t % k else None
        for j, (a, b) in enumerate(order):
            s = 0
            if a >= 1:
                s += abs(cur[(a - 1, b)])
            if b >= 1:
                s += abs(cur[(a, b - 1)])
            if prev_i is not None:
                s += abs(prev_i[(a, b)])
            if prev_k is not None:
                s += abs(prev_k[(a, b)])
            q = context_class(s)
            v = seq.get(dec, zero[classes[j]], q, q)
            if not -(1 << 30) <= v < (1 << 30):
                raise malformed("%s: payload integer outside [-2^30, 2^30-1] (§3.10)" % where)
            cur[(a, b)] = v
            ints.append(v)
    if dec.pos != len(data):
        raise malformed("%s: %d bytes after the range-coded payload (§3.10)"
                        % (where, len(data) - dec.pos))
    return ndf, steps, ints, predicted


class Record:
    __slots__ = ("theta_i", "phi_i", "theta_p", "phi_p", "level", "terms", "sh", "lobes")


class SbrdfFile:
    def __init__(self, data):
        self.parse(data)

    # ------------------------------------------------ parsing (FORMAT.md)

    def parse(self, data):
        if len(data) > MAX_FILE_BYTES:
            raise Refused("limit exceeded", "file larger than %d bytes" % MAX_FILE_BYTES)
        if data[:10] != SIGNATURE:
            if data[:6] == SIGNATURE[:6]:
                raise malformed("bad signature: line endings were translated (§2.1)")
            raise malformed("not an sbrdf file (bad signature, §2.1)")
        pos, seen_endf = 10, False
        self.head = None
        self.basis_values = None
        self.records = []
        self.fact = None  # the factor model (§3.7), when the file has a FACT chunk
        self.warp = None  # the warped tables (§3.10), when the file has a WARP chunk
        self.xval = None  # held-out errors (§3.8), when kept
        seen_meta = seen_samp = seen_xval = seen_recs = False
        while pos < len(data):
            if seen_endf:
                raise malformed("bytes after ENDF at offset %d (§2.5)" % pos)
            if len(data) - pos < 12:
                raise malformed("truncated chunk header at offset %d (§2.2)" % pos)
            length = struct.unpack_from("<I", data, pos)[0]
            ctype = data[pos + 4:pos + 8]
            where = "chunk %r at offset %d" % (ctype.decode("latin-1"), pos)
            if not all(0x41 <= b <= 0x5A or 0x61 <= b <= 0x7A for b in ctype):
                raise malformed("%s: type is not four ASCII letters (§2.2)" % where)
            if length > 0x7FFFFFFF:
                raise malformed("%s: length above 2^31-1 (§2.2)" % where)
            if len(data) - pos < 12 + length:
                raise malformed("%s: truncated, %d data bytes announced (§2.2)" % (where, length))
            body = data[pos + 8:pos + 8 + length]
            crc = struct.unpack_from("<I", data, pos + 8 + length)[0]
            if zlib.crc32(ctype + body) & 0xFFFFFFFF != crc:
                raise malformed("%s: CRC mismatch (§2.3)" % where)
            pos += 12 + length
            if self.head is None and ctype != b"HEAD":
                raise malformed("%s: the first chunk must be HEAD (§2.5)" % where)
            if ctype == b"HEAD":
                if self.head is not None:
                    raise malformed("%s: second HEAD (§2.5)" % where)
                self.parse_head(body, where)
            elif ctype == b"SBAS":
                if self.basis != 3 or self.basis_values is not None or self.records:
                    raise malformed("%s: SBAS out of place (§2.5)" % where)
                self.parse_sbas(body, where)
            elif ctype == b"FACT":
                # §2.5 rule 5: at most once, after HEAD (and SBAS), before the first RECD;
                # §3.7: only in an isotropic file
                if self.fact is not None:
                    raise malformed("%s: second FACT chunk (§2.5)" % where)
                if self.records:
                    raise malformed("%s: FACT after a RECD (§2.5)" % where)
                if self.basis == 3 and self.basis_values is None:
                    raise malformed("%s: FACT before SBAS (§2.5)" % where)
                if not self.isotropic:
                    raise malformed("%s: FACT in a file without the isotropic flag (§3.7)" % where)
                if self.warp is not None:
                    raise malformed("%s: FACT in a file with WARP (§3.10)" % where)
                self.fact = self.parse_fact(body, where)
            elif ctype == b"WARP":
                # §3.10 (version 1.4): at most once, after HEAD and SBAS, before the records;
                # only in an isotropic file without FACT
                if self.warp is not None:
                    raise malformed("%s: second WARP chunk (§3.10)" % where)
                if self.records:
                    raise malformed("%s: WARP in a file with records (§3.10)" % where)
                if self.basis == 3 and self.basis_values is None:
                    raise malformed("%s: WARP before SBAS (§3.10)" % where)
                if not self.isotropic:
                    raise malformed("%s: WARP in a file without the isotropic flag (§3.10)"
                                    % where)
                if self.fact is not None:
                    raise malformed("%s: WARP in a file with FACT (§3.10)" % where)
                self.warp = self.parse_warp(body, where)
            elif ctype in (b"RECD", b"RECS") and self.warp is not None:
                # §3.10: a file with WARP holds no records chunk (its records are implied)
                raise malformed("%s: a records chunk in a file with WARP (§3.10)" % where)
            elif ctype == b"RECD":
                if self.basis == 3 and self.basis_values is None:
                    raise malformed("%s: RECD before SBAS (§2.5)" % where)
                if seen_recs:
                    raise malformed("%s: RECD in a file with RECS (§2.5)" % where)
                if len(self.records) >= self.n:
                    raise malformed("%s: more than N RECD chunks (§2.5)" % where)
                self.records.append(self.parse_recd(body, where))
            elif ctype == b"RECS":
                # §2.5 rule 3: one RECS instead of the N RECD chunks (version 1.3)
                if self.basis == 3 and self.basis_values is None:
                    raise malformed("%s: RECS before SBAS (§2.5)" % where)
                if seen_recs or self.records:
                    raise malformed("%s: a second RECS, or RECS beside RECD (§2.5)" % where)
                seen_recs = True
                self.records = self.parse_recs(body, where)
            elif ctype == b"meta":
                if seen_meta:
                    raise malformed("%s: second meta chunk (§2.5)" % where)
                seen_meta = True
                try:
                    self.meta = body.decode("utf-8")
                except UnicodeDecodeError:
                    raise malformed("%s: not UTF-8 (§3.4)" % where)
            elif ctype == b"samp":
                if seen_samp:
                    raise malformed("%s: second samp chunk (§2.5)" % where)
                seen_samp = True
                self.parse_samp(body, where)
            elif ctype == b"xval":
                if seen_xval:
                    raise malformed("%s: second xval chunk (§2.5)" % where)
                seen_xval = True  # a skipped xval still counts as the file's one (§2.5, §3.8)
                self.parse_xval(body, where)
            elif ctype == b"ENDF":
                if length != 0:
                    raise malformed("%s: ENDF must be empty (§3.6)" % where)
                if self.warp is None and len(self.records) != self.n:
                    raise malformed("%s: ENDF after %d of %d RECD chunks (§2.5)"
                                    % (where, len(self.records), self.n))
                seen_endf = True
            elif ctype[0] & 0x20 == 0:
                raise unsupported("%s: unknown critical chunk (§2.4)" % where)
            # else: unknown ancillary chunk, skipped after its CRC check (§2.4)
        if not seen_endf:
            raise malformed("file ends without ENDF (§2.5)")
        self.build_layout()  # from HEAD's incidences
        if self.warp is not None:
            # §3.10: the records are implied and empty; the tables answer every query
            self.build_warp()

    def parse_head(self, body, where):
        r = Reader(body, where)
        if len(body) < 2:
            raise malformed("%s: too short (§3.1)" % where)
        (major,) = r.take("H")
        if major != 1:
            raise unsupported("%s: version %d.x, this reader knows 1.x (§7)" % (where, major))
        if len(body) < 40:
            raise malformed("%s: shorter than its 40-byte fixed part (§3.1)" % where)
        self.minor, flags, basis, res9, level, conv, k, res14 = r.take("HIBBBBHH")
        lmin, lmax, w, n = r.take("ddII")
        # §6: flags before the length (a flag may change HEAD's layout: bit 1, §3.1).
        if flags & ~7:
            raise unsupported("%s: unknown flag bits 0x%x (§4)" % (where, flags & ~7))
        wrange = bool(flags & 2)
        theta_only = bool(flags & 4)  # 1.7: incidences as θi alone, isotropic files only
        if theta_only and not flags & 1:
            raise malformed("%s: flag bit 2 without the isotropic flag (§3.1)" % where)
        if theta_only and self.minor < 7:
            raise malformed("%s: flag bit 2 (1.7) in a 1.%d file (§3.1)" % (where, self.minor))
        per = 4 if theta_only else 8
        if basis not in (1, 2, 3):
            raise unsupported("%s: unknown spectral basis %d (§4)" % (where, basis))
        if conv != 1:
            raise unsupported("%s: unknown angle convention %d (§4)" % (where, conv))
        if res9 or res14:
            raise malformed("%s: non-zero reserved byte (§3.1)" % where)
        if level > 20 or not 1 <= k <= 256:
            raise malformed("%s: sh_level %d or terms %d out of range (§3.1)" % (where, level, k))
        if not (math.isfinite(lmin) and lmin > 0 and math.isfinite(lmax) and lmax >= lmin):
            raise malformed("%s: bad lambda_min/lambda_max (§3.1)" % where)
        if lmax == lmin and k != 1:
            raise malformed("%s: lambda_max = lambda_min needs K = 1 (§3.1)" % where)
        if not (1 <= w <= 65536 and 1 <= n <= 1 << 20):
            raise malformed("%s: W = %d or N = %d out of range (§3.1)" % (where, w, n))
        if wrange and w < 2:
            raise malformed("%s: wavelength range with W = %d < 2 (§3.1)" % (where, w))
        stored = 2 if wrange else w
        if len(body) != 40 + 4 * stored + per * n:
            raise malformed("%s: length %d, layout needs %d (§3.1)"
                            % (where, len(body), 40 + 4 * stored + per * n))
        if wrange:
            # §3.1: λ_i = f32(λ_0 + (i·(λ_{W−1} − λ_0))/(W − 1)), binary64, in that order.
            first, last = r.take("2f")
            waves = [to_f32(first + (i * (last - first)) / (w - 1)) for i in range(w)]
        else:
            waves = list(r.take("%df" % w))
        for i, lam in enumerate(waves):
            if not (math.isfinite(lam) and lam > 0) or (i and lam <= waves[i - 1]):
                raise malformed("%s: wavelengths must be finite, > 0, increasing (§3.1)" % where)
        raw = body[40 + 4 * stored:]
        inc = []
        for i in range(n):
            if theta_only:
                (th,), ph = struct.unpack_from("<f", raw, 4 * i), 0.0
            else:
                th, ph = struct.unpack_from("<ff", raw, 8 * i)
            if not (0 <= th <= 90 and 0 <= ph < 360) or is_neg_zero(th) or is_neg_zero(ph):
                raise malformed("%s: incidence %d (%r, %r) out of range (§3.1)" % (where, i, th, ph))
            if inc and (th, ph) <= inc[-1]:
                raise malformed("%s: incidences not strictly increasing at %d (§3.1)" % (where, i))
            if flags & 1 and ph != 0:
                raise malformed("%s: isotropic file with phi_i != 0 (§3.1)" % where)
            inc.append((th, ph))
        self.head = True
        self.isotropic = bool(flags & 1)
        self.basis, self.sh_level, self.k = basis, level, k
        self.lambda_min, self.lambda_max = lmin, lmax
        self.wavelengths, self.incidences, self.n = waves, inc, n
        self.incidence_bytes = [raw[8 * i:8 * i + 8] for i in range(n)]

    def parse_sbas(self, body, where):
        if len(body) < 4:
            raise malformed("%s: too short (§3.2)" % where)
        prec = body[0]
        if prec not in (1, 2, 3):
            raise unsupported("%s: unknown precision %d (§3.2)" % (where, prec))
        if any(body[1:4]):
            raise malformed("%s: non-zero reserved byte (§3.2)" % where)
        w = len(self.wavelengths)
        if prec == 3:
            self.basis_values = self.parse_quantised_basis(body, w, where)
            return
        s = 4 if prec == 1 else 2
        if len(body) != 4 + self.k * w * s:
            raise malformed("%s: length %d, layout needs %d (§3.2)" % (where, len(body), 4 + self.k * w * s))
        vals = struct.unpack_from("<%d%s" % (self.k * w, "f" if prec == 1 else "e"), body, 4)
        if not all(math.isfinite(v) for v in vals):
            raise malformed("%s: a basis value is not finite (§3.2)" % where)
        self.basis_values = [list(vals[i * w:(i + 1) * w]) for i in range(self.k)]

    def parse_quantised_basis(self, body, w, where):
        """§3.2, precision 3 (version 1.6): K exponents, then the range-coded integers of
        each function along the wavelengths, each predicted from the two before it in its row
        (0, then the first, then linearly), the residuals one sequence as §3.10 codes the NDF's."""
        if self.minor < 6:
            raise malformed("%s: a quantised basis in a 1.%d file (§3.2)" % (where, self.minor))
        k = self.k
        if len(body) < 4 + k:
            raise malformed("%s: too short for %d exponents (§3.2)" % (where, k))
        exps = struct.unpack_from("<%db" % k, body, 4)
        if any(e > 103 for e in exps):
            raise malformed("%s: a basis exponent above 103 (§3.2)" % where)
        stream = body[4 + k:]
        if k * w > 1600 * len(stream):
            raise malformed("%s: %d integers cannot be coded in %d bytes (§3.2, §8)"
                            % (where, k * w, len(stream)))
        dec = RangeDecoder(stream, where)
        seq, zero, q, rows = RangeIntegers(), [2048] * 5, 0, []
        for e in exps:
            n = []
            for j in range(w):
                res = seq.get(dec, zero, q, q)
                q = context_class(abs(res))
                pred = 0 if j == 0 else n[0] if j == 1 else 2 * n[j - 1] - n[j - 2]
                v = pred + res
                if abs(v) >= 1 << 24:
                    raise malformed("%s: basis integer %d beyond 2^24 - 1 (§3.2)" % (where, v))
                n.append(v)
            rows.append([math.ldexp(v, e) for v in n])
        if dec.pos != len(stream):
            raise malformed("%s: %d bytes after the basis stream (§3.2)"
                            % (where, len(stream) - dec.pos))
        return rows

    def parse_recd(self, body, where):
        r = Reader(body, where)
        if len(body) < 40:
            raise malformed("%s: shorter than its 40-byte fixed part (§3.3)" % where)
        (index,) = r.take("I")
        th, ph, tp, pp, rel, crit = r.take("6f")
        scale_bytes = body[28:32]
        (scale,) = r.take("f")
        m, prec, level, res35, terms, res38 = r.take("BBBBHH")
        if index != len(self.records):
            raise malformed("%s: index %d out of sequence (§2.5)" % (where, index))
        if prec not in (1, 2):
            raise unsupported("%s: unknown precision %d (§4)" % (where, prec))
        if res35 or res38:
            raise malformed("%s: non-zero reserved byte (§3.3)" % where)
        if body[4:12] != self.incidence_bytes[index]:
            raise malformed("%s: (theta_i, phi_i) differ from HEAD (§3.3)" % where)
        rec = self.parse_record_values(r, where, th, ph, tp, pp, rel, crit, scale_bytes,
                                       m, prec, level, terms)
        if r.left():
            raise malformed("%s: %d bytes left after the last lobe (§3.3)" % (where, r.left()))
        return rec

    def parse_recs(self, body, where):
        """RECS (§3.9, version 1.3): the N records back to back, each without index,
        incidence and reserved bytes, its scale only with precision 2."""
        r = Reader(body, where)
        records = []
        for index in range(self.n):
            th, ph = struct.unpack("<ff", self.incidence_bytes[index])
            tp, pp, rel, crit = r.take("4f", "compact record")
            m, prec, level, terms = r.take("BBBH", "compact record")
            if prec not in (1, 2):
                raise unsupported("%s: record %d: unknown precision %d (§4)" % (where, index, prec))
            if prec == 2:
                scale_bytes = bytes(r.data[r.pos:r.pos + 4])
                r.take("f", "scale")
            else:
                scale_bytes = b"\x00\x00\x80\x3f"
            where_i = "%s, record %d" % (where, index)
            records.append(self.parse_record_values(r, where_i, th, ph, tp, pp, rel, crit,
                                                    scale_bytes, m, prec, level, terms))
        if r.left():
            raise malformed("%s: %d bytes left after the last record (§3.9)" % (where, r.left()))
        return records

    def parse_record_values(self, r, where, th, ph, tp, pp, rel, crit, scale_bytes, m, prec,
                            level, terms):
        """The rules of §3.3 on a record's header fields, then its SH coefficients and lobes
        (the same bytes in RECD and RECS)."""
        (scale,) = struct.unpack("<f", scale_bytes)
        if not (0 <= tp <= 180 and 0 <= pp < 360 and 0 <= crit <= 180):
            raise malformed("%s: peak or critical angle out of range (§3.3)" % where)
        if any(is_neg_zero(v) for v in (tp, pp, crit)):
            raise malformed("%s: -0 angle (§3.3)" % where)
        if not (math.isfinite(rel) and rel >= 0):
            raise malformed("%s: rel_error negative or not finite (§3.3)" % where)
        if prec == 1 and scale_bytes != b"\x00\x00\x80\x3f":
            raise malformed("%s: f32 record with scale != 1.0 (§5)" % where)
        if prec == 2:
            bits = struct.unpack("<I", scale_bytes)[0]
            expo, frac = bits >> 23, bits & 0x7FFFFF  # sign bit must be 0 (part of expo)
            ok = (1 <= expo <= 254 and frac == 0) or (expo == 0 and frac and frac & (frac - 1) == 0)
            if not ok:
                raise malformed("%s: scale %r is not a positive power of two (§5)" % (where, scale))
        if m > 8 or level > self.sh_level or not 1 <= terms <= self.k:
            raise malformed("%s: lobe_count, sh_level or terms out of range (§3.3)" % where)
        s = 4 if prec == 1 else 2
        p_r = (level + 1) ** 2

        def values(count, what):
            if count * s > r.left():
                raise malformed("%s: %s do not fit in the record (§3.3)" % (where, what))
            raw = r.take("%d%s" % (count, "f" if prec == 1 else "e"), what)
            out = [v if prec == 1 or not math.isfinite(v) else to_f32(v * scale) for v in raw]
            if not all(math.isfinite(v) for v in out):
                raise malformed("%s: %s not finite (after scaling, §5)" % (where, what))
            return out

        sh = values(terms * p_r, "SH coefficients")
        rec = Record()
        rec.theta_i, rec.phi_i, rec.theta_p, rec.phi_p = th, ph, tp, pp
        rec.level, rec.terms = level, terms
        rec.sh = [sh[k * p_r:(k + 1) * p_r] for k in range(terms)]
        rec.lobes = []
        for li in range(m):
            kind, res1, length = r.take("BBH", "lobe header")
            if length > r.left():
                raise malformed("%s: lobe %d length runs past the record (§3.3)" % (where, li))
            if kind not in (1, 2, 3, 4, 5):
                raise unsupported("%s: unknown lobe kind %d (§4)" % (where, kind))
            if res1:
                raise malformed("%s: lobe %d reserved byte not 0 (§3.3)" % (where, li))
            n_amp, n_par = {1: (terms, terms), 2: (4 * terms, 3), 3: (4 * terms, 3),
                            4: (terms, 1), 5: (4 * terms, 6)}[kind]
            if length != n_amp * s + 4 * n_par:
                raise malformed("%s: lobe %d of kind %d has length %d, not %d (§3.3)"
                                % (where, li, kind, length, n_amp * s + 4 * n_par))
            amps = values(n_amp, "lobe amplitudes")
            params = list(r.take("%df" % n_par))
            if kind in (2, 3):
                b, c, a = params
                ok = all(math.isfinite(v) for v in params) and b > 0 and c > 0 and 0 <= a <= 1
            elif kind == 5:
                bx, by, c, ax, ay, psi = params
                ok = (all(math.isfinite(v) for v in params) and bx > 0 and by > 0 and c > 0
                      and 0 <= ax <= 1 and 0 <= ay <= 1 and 0 <= psi < 180
                      and not is_neg_zero(psi))
            else:
                ok = all(math.isfinite(v) and v > 0 for v in params)
            if not ok:
                raise malformed("%s: lobe %d parameters out of range (§3.3)" % (where, li))
            rows = [amps[j * terms:(j + 1) * terms] for j in range(n_amp // terms)]
            rec.lobes.append((kind, rows, params))
        return rec

    def parse_samp(self, body, where):
        """§3.5. Validated, then dropped: sample positions play no part in evaluation."""
        r = Reader(body, where)
        (count,) = r.take("I", "set_count")
        if count == 0 or 5 * count + 4 * self.n > len(body) - 4:
            raise malformed("%s: set_count %d cannot fit (§3.5)" % (where, count))
        end_sets = len(body) - 4 * self.n
        angles = []
        for _ in range(count):
            (kind,) = r.take("B", "set kind")
            if kind == 0:
                t0, dt, nt, p0, dp, nphi = r.take("ffIffI", "grid set")
                if nt * nphi > MAX_SET_DIRECTIONS:
                    raise malformed("%s: grid of %d directions (§3.5)" % (where, nt * nphi))
                angles += [t0, dt, p0, dp]
            elif kind == 1:
                (n,) = r.take("I", "list set")
                if n > MAX_SET_DIRECTIONS or 8 * n > end_sets - r.pos:
                    raise malformed("%s: list of %d directions does not fit (§3.5)" % (where, n))
                angles += struct.unpack_from("<%df" % (2 * n), body, r.pos)
                r.pos += 8 * n
            else:
                return  # unknown set kind: skip the whole chunk (§3.5)
        if r.pos != end_sets:
            raise malformed("%s: sets do not fill the chunk exactly (§3.5)" % where)
        if not all(math.isfinite(a) for a in angles):
            raise malformed("%s: non-finite angle (§3.5)" % where)
        idx = struct.unpack_from("<%dI" % self.n, body, end_sets)
        if any(i >= count for i in idx):
            raise malformed("%s: set index >= set_count (§3.5)" % where)

    def parse_fact(self, body, where):
        """§3.7: the factor model, as [(codes, spectra, tables)] per component, where
        spectra = [s_c, w_c1, …, w_c(R-1)] (W values each) and tables[r][f] the table of
        feature codes[f] at rank r. Placement is checked by the caller (§2.5)."""
        r = Reader(body, where)
        if len(body) < 44:
            raise malformed("%s: shorter than its 44-byte fixed part (§3.7)" % where)
        count, prec, reserved = r.take("BBH")
        if prec not in (1, 2):
            raise unsupported("%s: unknown precision %d (§4)" % (where, prec))
        if reserved:
            raise malformed("%s: non-zero reserved byte (§3.7)" % where)
        if not 1 <= count <= 8:
            raise malformed("%s: component_count %d out of range (§3.7)" % (where, count))
        rng = r.take("10f", "ranges")
        ranges = [(rng[2 * i], rng[2 * i + 1]) for i in range(5)]
        descriptors = []
        for c in range(count):
            rank, nfeat = r.take("BB", "component descriptor")
            if not (1 <= rank <= 8 and 1 <= nfeat <= 6):
                raise malformed("%s: component %d: rank %d or feature_count %d out of range (§3.7)"
                                % (where, c, rank, nfeat))
            codes = r.take("%dB" % nfeat, "feature codes")
            for code in codes:
                if code not in FACT_NODE_COUNT:
                    raise unsupported("%s: component %d: unknown feature code %d (§4)"
                                      % (where, c, code))
            if len(set(codes)) != nfeat:
                raise malformed("%s: component %d: a feature repeated (§3.7)" % (where, c))
            descriptors.append((rank, codes))
        # the exact length, from the descriptors, before allocating for the values (§3.7, §8)
        w = len(self.wavelengths)
        s = 4 if prec == 1 else 2
        nvals = sum(rank * w + rank * sum(FACT_NODE_COUNT[k] for k in codes)
                    for rank, codes in descriptors)
        if len(body) != r.pos + s * nvals:
            raise malformed("%s: length %d, layout needs %d (§3.7)"
                            % (where, len(body), r.pos + s * nvals))
        # f16 values are the binary16 numbers themselves, widened exactly, no scale (§3.7)
        vals = r.take("%d%s" % (nvals, "f" if prec == 1 else "e"), "values")
        if not all(math.isfinite(v) for v in vals):
            raise malformed("%s: a value is not finite (§3.7)" % where)
        for i, (lo, hi) in enumerate(ranges):
            bound = 90.0 if i < 4 else 1.0
            low = 0.0 if i < 4 else -1.0
            if not (math.isfinite(lo) and math.isfinite(hi) and low <= lo <= hi <= bound):
                raise malformed("%s: range %d (%r, %r) not finite, min > max or outside [%g, %g] "
                                "(§3.7)" % (where, i, lo, hi, low, bound))
        components, pos = [], 0

        def take(n):
            nonlocal pos
            pos += n
            return list(vals[pos - n:pos])

        for rank, codes in descriptors:
            spectra, tables = [take(w)], []
            for rk in range(rank):
                if rk >= 1:
                    spectra.append(take(w))
                tables.append([take(FACT_NODE_COUNT[k]) for k in codes])
            components.append((codes, spectra, tables))
        self.fact_ranges = ranges
        return components

    def parse_xval(self, body, where):
        """§3.8. Validated, then kept as [(rel, log)] per record; no part in evaluation."""
        if len(body) < 1:
            raise malformed("%s: length 0, layout needs %d (§3.8)" % (where, 4 + 8 * self.n))
        protocol = body[0]
        if protocol not in (1, 2):
            return  # unknown protocol: skip the chunk like an unknown ancillary one (§3.8)
        if len(body) < 4:
            raise malformed("%s: shorter than its 4-byte fixed part (§3.8)" % where)
        folds, reserved = struct.unpack_from("<BH", body, 1)
        if reserved:
            raise malformed("%s: non-zero reserved byte (§3.8)" % where)
        if (protocol == 1 and folds < 2) or (protocol == 2 and folds != 0):
            raise malformed("%s: folds k = %d with protocol %d (§3.8)" % (where, folds, protocol))
        if len(body) != 4 + 8 * self.n:
            raise malformed("%s: length %d, layout needs %d (§3.8)"
                            % (where, len(body), 4 + 8 * self.n))
        errors = struct.unpack_from("<%df" % (2 * self.n), body, 4)
        if not all(math.isfinite(e) and e >= 0 for e in errors):
            raise malformed("%s: an error is negative or not finite (§3.8)" % where)
        self.xval = [errors[2 * i:2 * i + 2] for i in range(self.n)]

    def build_layout(self):
        """Classify the incidences ("The lattice of stored incidences")."""
        self.thetas = sorted({t for t, _ in self.incidences})
        self.phis = sorted({p for _, p in self.incidences})
        if self.isotropic:
            self.layout = "isotropic"
        elif len(self.thetas) * len(self.phis) == self.n:
            self.layout = "lattice"
        else:
            self.layout = "scattered"

    # ------------------------------------------------ warped tables (§3.10, version 1.4)

    def parse_warp(self, body, where):
        """§3.10: the fields of WARP, checked, and its payload inflated to the N·K·R² integers
        (kept in an array, table (i, k) at position (i·K + k)·R², each in diagonal order).
        Placement, the isotropic flag and FACT are checked by the caller, the records once
        ENDF has been read; tables, warps and σ by build_warp."""
        r = Reader(body, where)
        if len(body) < 12:
            raise malformed("%s: shorter than its 12-byte fixed part (§3.10)" % where)
        layout, ndf_prec, grid, warp_grid, ndf_count = r.take("BBHHH")
        (sigma_scale,) = r.take("f")
        if layout not in (1, 17, 9, 25, 10, 26):
            # §3.10 and §6: an unknown WARP layout makes the file unsupported
            raise unsupported("%s: unknown layout %d (§3.10)" % (where, layout))
        if layout & 16 and self.minor < 5:
            raise malformed("%s: layout %d (the wavelet, 1.5) in a 1.%d file (§3.10)"
                            % (where, layout, self.minor))
        ranged = bool(layout & 8)
        if ranged and self.minor < 6:
            raise malformed("%s: layout %d (range-coded, 1.6) in a 1.%d file (§3.10)"
                            % (where, layout, self.minor))
        predicting = layout & 7 == 2  # arrangement 2: prediction flags (1.7, range-coded only)
        if predicting and self.minor < 7:
            raise malformed("%s: layout %d (prediction flags, 1.7) in a 1.%d file (§3.10)"
                            % (where, layout, self.minor))
        if ndf_prec not in (1, 2):
            # §3.10 and §6: an unknown NDF precision makes the file unsupported
            raise unsupported("%s: unknown NDF precision %d (§3.10)" % (where, ndf_prec))
        ndf_size = 4 if ndf_prec == 1 else 2
        if not (2 <= grid <= 64 and 3 <= warp_grid <= 256 and 2 <= ndf_count <= 4096):
            raise malformed("%s: grid R = %d, warp_grid G = %d or ndf_count M = %d out of range "
                            "(§3.10)" % (where, grid, warp_grid, ndf_count))
        n, k = self.n, self.k
        count = n * k * grid * grid  # Python integers: no overflow (§3.10 asks for 64 bits)
        if count > MAX_WARP_VALUES or n * warp_grid * warp_grid > MAX_WARP_VALUES:
            raise malformed("%s: N·K·R² = %d or N·G² = %d above 2^24 (§3.10)"
                            % (where, count, n * warp_grid * warp_grid))
        # §3.10: with a range-coded payload the NDF and steps are in the payload
        fixed = 16 if ranged else 16 + ndf_size * ndf_count + 4 * n * k
        if len(body) < fixed:
            raise malformed("%s: length %d, shorter than the %d bytes before the payload (§3.10)"
                            % (where, len(body), fixed))
        (plen,) = struct.unpack_from("<I", body, fixed - 4)
        if not 1 <= plen <= len(body) - fixed or len(body) != fixed + plen:
            raise malformed("%s: payload_length %d, the chunk has %d bytes after it (§3.10)"
                            % (where, plen, len(body) - fixed))
        if not (math.isfinite(sigma_scale) and sigma_scale > 0):
            raise malformed("%s: sigma_scale %r not finite and > 0 (§3.10)" % (where, sigma_scale))
        if ranged:
            total = ndf_count + n * k + count + (n - 1 if predicting else 0)
            if total > 1600 * plen:
                raise malformed("%s: a range-coded payload of %d bytes cannot code %d integers "
                                "(§3.10)" % (where, plen, total))
            ndf, steps, ints, predicted = decode_range_payload(
                body[fixed:], ndf_count, ndf_prec, n * k, k, grid, layout >> 4, where,
                n if predicting else None)
        else:
            ndf = r.take("%d%s" % (ndf_count, "f" if ndf_prec == 1 else "e"), "ndf")
            steps = r.take("%df" % (n * k), "steps")
            ints, predicted = None, [False] * n
        # −0 is allowed (equal to +0) for NDF values and steps: −0.0 >= 0 holds
        if not all(math.isfinite(v) and v >= 0 for v in ndf) or not any(v > 0 for v in ndf):
            raise malformed("%s: an NDF value not finite or < 0, or none > 0 (§3.10)" % where)
        if not all(math.isfinite(v) and v >= 0 for v in steps):
            raise malformed("%s: a step not finite or < 0 (§3.10)" % where)
        if ints is None:
            ints = self.inflate_warp(body[fixed:], count, where)
        return {"R": grid, "G": warp_grid, "M": ndf_count, "c": sigma_scale,
                "transform": layout >> 4, "predicted": predicted,
                "ndf": list(ndf), "steps": list(steps), "ints": ints}

    @staticmethod
    def inflate_warp(payload, count, where):
        """§3.10, Payload: zlib → `count` zigzag LEB128 varints, with the 5·count inflate bound."""
        bound = 5 * count  # a varint has at most 5 bytes: more output cannot be valid
        # RFC 1950: FDICT (bit 5 of FLG) asks for a preset dictionary, which §3.10 refuses
        # (zlib would refuse it too, lacking the dictionary; this says why)
        if (len(payload) >= 2 and payload[0] & 0x0F == 8 and payload[1] & 0x20
                and (payload[0] * 256 + payload[1]) % 31 == 0):
            raise malformed("%s: payload zlib stream asks for a preset dictionary (FDICT), not a "
                            "valid stream here (§3.10)" % where)
        d = zlib.decompressobj()
        try:
            raw = d.decompress(payload, bound + 1)  # stops once more than `bound` came out
        except zlib.error as e:
            raise malformed("%s: payload is not a valid zlib stream: %s (§3.10)" % (where, e))
        if len(raw) > bound:
            raise malformed("%s: payload inflates to more than 5·N·K·R² = %d bytes (§3.10)"
                            % (where, bound))
        if not d.eof:
            raise malformed("%s: payload zlib stream is truncated (§3.10)" % where)
        if d.unused_data:
            raise malformed("%s: %d bytes after the payload's zlib stream (§3.10)"
                            % (where, len(d.unused_data)))
        ints, pos, end = [], 0, len(raw)
        append = ints.append
        while pos < end:
            byte = raw[pos]
            pos += 1
            u = byte & 0x7F
            shift = 7
            while byte & 0x80:
                if shift == 35:
                    raise malformed("%s: payload varint longer than 5 bytes (§3.10)" % where)
                if pos == end:
                    raise malformed("%s: payload ends inside a varint (§3.10)" % where)
                byte = raw[pos]
                pos += 1
                u |= (byte & 0x7F) << shift
                shift += 7
            if u > 0x7FFFFFFF:  # zigzag codes of [−2^30, 2^30 − 1] are 0 … 2^31 − 1
                raise malformed("%s: payload integer outside [-2^30, 2^30-1] (§3.10)" % where)
            append((u >> 1) ^ -(u & 1))
        if len(ints) < count:
            raise malformed("%s: payload holds %d integers, N·K·R² = %d (§3.10)"
                            % (where, len(ints), count))
        if len(ints) > count:
            raise malformed("%s: payload has bytes after its %d-th integer (§3.10)"
                            % (where, count))
        return array("l", ints)

    def build_warp(self):
        """EVALUATION.md, "Warped tables": decode the N·K tables (inverse DCT-II), the VNDF warp
        of each stored incidence and the M σ nodes, once. Refuses a total or σ node of 0."""
        w = self.warp
        R, G, M, K = w["R"], w["G"], w["M"], self.k
        ndf = w["ndf"]

        def ndf_at(x):
            """D(x): linear between the M nodes j/(M−1), x clamped to [0, 1]."""
            return lerp_nodes(ndf, x)

        self.warp_ndf = ndf_at
        # -- tables: T[r][c] = Σ_a Σ_b C(a, b) w_a(r) w_b(c), w the synthesis vectors
        if w["transform"] == 0:
            # DCT-II: w_a(r) = α(a) cos(π(2r + 1)a / 2R)
            cosine = [[(math.sqrt(1.0 / R) if a == 0 else math.sqrt(2.0 / R))
                       * math.cos(math.pi * (2 * r + 1) * a / (2 * R)) for r in range(R)]
                      for a in range(R)]
            order = sorted(((a, b) for a in range(R) for b in range(R)),
                           key=lambda ab: (ab[0] + ab[1], ab[0]))  # diagonal order (§3.10)
        else:
            # wavelet: w_a = v_a/|v_a|, v_a the inverse transform of e_a; band order (§3.10)
            cosine = []
            for a in range(R):
                v = wavelet_inverse([1.0 if j == a else 0.0 for j in range(R)])
                norm = math.sqrt(sum(x * x for x in v))
                cosine.append([x / norm for x in v])
            band = wavelet_bands(R)
            order = sorted(((a, b) for a in range(R) for b in range(R)),
                           key=lambda ab: (band[ab[0]] + band[ab[1]], band[ab[0]],
                                           band[ab[1]], ab[0], ab[1]))
        ints, steps = w["ints"], w["steps"]
        tables = []
        coefs = [None] * K  # the previous incidence's coefficients C, per term (file order)
        for i in range(self.n):
            per_term = []
            for k in range(K):
                q = steps[i * K + k]
                base = (i * K + k) * R * R
                # C = q·n, plus the previous incidence's C when incidence i is predicted (§3.10)
                own = [q * ints[base + j] for j in range(R * R)]
                if w["predicted"][i]:
                    own = [c + p for c, p in zip(own, coefs[k])]
                coefs[k] = own
                partial = {}  # a -> Σ_b α(b) C(a, b) cos(π(2c+1)b/2R), per column c
                for j, (a, b) in enumerate(order):
                    coef = own[j]
                    if coef:
                        row = partial.setdefault(a, [0.0] * R)
                        cb = cosine[b]
                        for c in range(R):
                            row[c] += coef * cb[c]
                rows = [[0.0] * R for _ in range(R)]
                for a in sorted(partial):
                    pa, ca = partial[a], cosine[a]
                    for r in range(R):
                        f = ca[r]
                        rows[r] = [t + f * x for t, x in zip(rows[r], pa)]
                per_term.append(array("d", [v for row in rows for v in row]))
            tables.append(per_term)
        self.warp_tables = tables  # tables[i][k][r·R + c]
        # -- the VNDF's node geometry over u (x_a, y_b) = (a/(G−1), b/(G−1))
        g1 = G - 1
        xs = [a / g1 for a in range(G)]
        theta_m = [x * x * (math.pi / 2) for x in xs]
        sin_m = [math.sin(t) for t in theta_m]
        cos_m = [math.cos(t) for t in theta_m]
        jac = [sin_m[a] * math.pi * xs[a] * (2 * math.pi) for a in range(G)]  # sinθm·πx·2π
        d_nodes = [ndf_at(x) for x in xs]
        phi_m = [2 * math.pi * (b / g1) - math.pi for b in range(G)]
        cos_phi = [math.cos(p) for p in phi_m]
        weight = [1.0 / (2 * g1) if a in (0, g1) else 1.0 / g1 for a in range(G)]  # trapezoid
        # m_x at node (a, b), b-major; m_z depends on a only (ωi has no y component)
        mx = [[sin_m[a] * cos_phi[b] for a in range(G)] for b in range(G)]

        def density(theta):
            """p[b][a] = D(x_a)·max(0, ωi·m)·sinθm·πx_a·2π for ωi = (sin θ, 0, cos θ)."""
            st, ct = math.sin(theta), math.cos(theta)
            out = []
            for b in range(G):
                mxb = mx[b]
                for a in range(G):
                    v = st * mxb[a] + ct * cos_m[a]
                    out.append(d_nodes[a] * v * jac[a] if v > 0 else 0.0)
            return out

        def total(p):
            """I = Σ_b w_b Σ_a w_a p[b][a] (trapezoid rule, in that order)."""
            return sum(weight[b] * sum(weight[a] * p[b * G + a] for a in range(G))
                       for b in range(G))

        # -- the warp of each stored incidence: normalised p, cond, row, marg
        self.warp_thetas = [math.radians(th) for th, _ in self.incidences]
        warps = []
        half = 1.0 / (2 * g1)
        for i, theta in enumerate(self.warp_thetas):
            p = density(theta)
            tot = total(p)
            if not tot > 0:
                raise malformed("WARP: the VNDF of stored incidence %d (θi = %r°) has total 0 "
                                "(EVALUATION.md, \"Warped tables\")" % (i, self.incidences[i][0]))
            p = [v / tot for v in p]
            cond = [0.0] * (G * G)
            row = [0.0] * G
            for b in range(G):
                acc, o = 0.0, b * G
                for a in range(g1):
                    acc += (p[o + a] + p[o + a + 1]) * half
                    cond[o + a + 1] = acc
                row[b] = acc
            marg = [0.0] * G
            for b in range(g1):
                marg[b + 1] = marg[b] + (row[b] + row[b + 1]) * half
            warps.append((array("d", p), array("d", cond), row, marg))
        self.warp_warps = warps
        # -- σ at the M nodes θ_j = (j/(M−1))²·π/2: σ_j = c·I(θ_j). Each total as one sum over
        # the nodes whose factor w_a·w_b·D(x_a)·sinθm·πx_a·2π is not 0 (another summation order
        # than the rows-then-columns of the warps' totals: the same value to rounding).
        fac, fmx, fmz = [], [], []
        for b in range(G):
            for a in range(G):
                f = weight[b] * weight[a] * d_nodes[a] * jac[a]
                if f != 0:
                    fac.append(f)
                    fmx.append(mx[b][a])
                    fmz.append(cos_m[a])
        sigma = []
        c_scale = w["c"]
        for j in range(M):
            theta = (j / (M - 1)) ** 2 * (math.pi / 2)
            st, ct = math.sin(theta), math.cos(theta)
            tot = 0.0
            for f, x, z in zip(fac, fmx, fmz):
                v = st * x + ct * z
                if v > 0:
                    tot += f * v
            s = c_scale * tot
            if s == 0:
                raise malformed("WARP: σ node %d (θ = %r rad) is 0 (EVALUATION.md, "
                                "\"Warped tables\")" % (j, theta))
            sigma.append(s)
        self.warp_sigma = sigma

    # ------------------------------------------------ evaluation (EVALUATION.md)

    def basis_at(self, lam, count):
        """B_0..B_{count-1}(λ) ("Spectral basis")."""
        if self.basis == 3:
            nodes, w = self.wavelengths, len(self.wavelengths)
            if w == 1 or lam <= nodes[0]:
                return [row[0] for row in self.basis_values[:count]]
            if lam >= nodes[-1]:
                i, f = w - 2, 1.0
            else:
                i = bisect.bisect_right(nodes, lam) - 1
                f = (lam - nodes[i]) / (nodes[i + 1] - nodes[i])
            return [row[i] + f * (row[i + 1] - row[i]) for row in self.basis_values[:count]]
        lo, hi = self.lambda_min, self.lambda_max
        lc = min(max(lam, lo), hi)
        if self.basis == 1:
            out = [0.5]
            if count > 1:
                t = 2 * math.pi * (lc - lo) / (hi - lo)
                for k in range(1, count):
                    j = (k + 1) // 2
                    out.append(math.cos(j * t) if k % 2 else math.sin(j * t))
            return out
        t = 0.0 if hi == lo else (lc - lo) / (hi - lo)
        return [math.cos(math.pi * k * t) for k in range(count)]

    def blend(self, tq, pq):
        """Step 4: [(record index, weight)] and the evaluation incidence (θ*, φ*)."""
        if self.layout == "scattered":
            q = d(tq, pq)
            best = max(range(self.n), key=lambda i: (dot(d(*self.incidences[i]), q), -i))
            return [(best, 1.0)], self.incidences[best]
        theta_star = min(max(tq, self.thetas[0]), self.thetas[-1])
        i, t = bracket(self.thetas, tq)
        i2 = min(i + 1, len(self.thetas) - 1)
        nphi = len(self.phis)
        if self.layout == "isotropic":
            cells = [(i, 1 - t), (i2, t)]
        else:
            p = wrap360(pq)
            if nphi == 1:
                j = j2 = 0
                u = 0.0
            elif p < self.phis[0] or p >= self.phis[-1]:
                j, j2 = nphi - 1, 0
                u = wrap360(p - self.phis[-1]) / (self.phis[0] + 360.0 - self.phis[-1])
            else:
                j, u = bracket(self.phis, p)
                j2 = j + 1
            cells = [(i * nphi + j, (1 - t) * (1 - u)), (i * nphi + j2, (1 - t) * u),
                     (i2 * nphi + j, t * (1 - u)), (i2 * nphi + j2, t * u)]
        weights = {}
        for rec, wgt in cells:
            weights[rec] = weights.get(rec, 0.0) + wgt
        blended = [(rec, wgt) for rec, wgt in sorted(weights.items()) if wgt > 0]
        if self.isotropic:
            phi_star = 0.0
        elif nphi == 1:
            phi_star = self.phis[0]  # a single stored azimuth is clamped to, like θ
        else:
            phi_star = pq
        return blended, (theta_star, phi_star)

    def blended_peak(self, recs, theta_star, phi_star):
        """"Blended peak direction" for a shared lobe of kind 1 or 4."""
        if self.isotropic:
            v = [0.0, 0.0, 0.0]
            for r, wgt in recs:
                pv = d(r.theta_p, r.phi_p)
                v = [v[a] + wgt * pv[a] for a in range(3)]
            n = math.sqrt(dot(v, v))
            if n != 0 and math.isfinite(n):
                return (v[0] / n, v[1] / n, v[2] / n)
        dt = dp = 0.0
        for r, wgt in recs:
            dt += wgt * (r.theta_p - r.theta_i)
            if r.theta_p != 0:
                off = math.fmod(r.phi_p - (r.phi_i + 180.0), 360.0)
                off = off - 360.0 if off > 180.0 else off + 360.0 if off <= -180.0 else off
                dp += wgt * off
        return d(theta_star + dt, wrap360(phi_star + 180.0) + dp)

    def eval(self, theta_i, phi_i, theta_o, phi_o, wavelengths):
        """ρ(ωi, ωo, λ) in 1/sr for each wavelength; angles in degrees ("Reconstruction")."""
        wavelengths = list(wavelengths)
        zero = [0.0] * len(wavelengths)
        angles = (theta_i, phi_i, theta_o, phi_o)
        if not all(math.isfinite(a) for a in angles):
            return zero
        if not (0 <= theta_i <= 90 and 0 <= theta_o <= 90):  # steps 1 and 2
            return zero
        # The tables' direction (the query's ωo) is turned to azimuth 0, except on the pole,
        # where its vector d(0, φo) has r = 0 and there is no rotation ("Warped tables", Value).
        psi_o = phi_o if theta_o > 0 else 0.0
        if getattr(self, "warp_layout", None) is not None:  # a layout's warped tables
            c = self.warp_layout.coefficients(d(theta_i, phi_i - psi_o), d(theta_o, 0.0))
            out = []
            for lam in wavelengths:
                if c is None or not math.isfinite(lam):
                    out.append(0.0)
                    continue
                b = self.basis_at(lam, self.k)
                out.append(max(0.0, sum(ck * bk for ck, bk in zip(c, b))))
            return out
        if self.warp is not None:  # a file with WARP: "Warped tables" alone (§3.10)
            # "Whose direction the tables follow": the tables are indexed by the viewing
            # direction, so steps 1–3 and the Value are applied with the roles exchanged: the
            # query's ωo is turned to azimuth 0 and plays the tables' incidence, the query's ωi
            # (rotated by −φo) the other direction.
            return self.warp_eval(theta_o, d(theta_o, 0.0), d(theta_i, phi_i - psi_o),
                                  wavelengths)
        psi = phi_i if self.isotropic else 0.0  # step 3
        w = d(theta_o, phi_o - psi)
        blended, (ts, ps) = self.blend(theta_i, phi_i)  # step 4
        recs = [(self.records[i], wgt) for i, wgt in blended]
        wi = d(ts, ps)
        tmax = max(r.terms for r, _ in recs)
        coef = [0.0] * tmax
        for r, wgt in recs:
            y = sh_eval(r.level, w)
            for k in range(r.terms):
                coef[k] += wgt * sum(a * yj for a, yj in zip(r.sh[k], y))
        for li in range(max(len(r.lobes) for r, _ in recs)):
            kinds = {r.lobes[li][0] if li < len(r.lobes) else None for r, _ in recs}
            if len(recs) > 1 and len(kinds) == 1 and None not in kinds:
                kind = kinds.pop()
                self.add_shared_lobe(coef, kind, li, recs, tmax, wi, w, ts, ps)
            else:
                for r, wgt in recs:
                    if li < len(r.lobes):
                        part = [0.0] * r.terms
                        lobe_add(part, r.lobes[li], d(r.theta_p, r.phi_p), wi, w)
                        for k in range(r.terms):
                            coef[k] += wgt * part[k]
        # step 5: F at the query's own directions after step 3's rotation (not at ωi*): the
        # incident vector turned to azimuth 0 (FACT requires the isotropic flag, §3.7) and ω
        fact = None
        if self.fact is not None:
            fact = self.fact_tables(d(theta_i, 0.0), w)
        out = []
        for lam in wavelengths:
            if not math.isfinite(lam):
                out.append(0.0)
                continue
            b = self.basis_at(lam, tmax)
            value = sum(c * bk for c, bk in zip(coef, b))
            if fact is not None:
                value += self.fact_at(fact, lam)
            # step 5: the series (plus F) clamped at 0
            out.append(max(0.0, value))
        return out

    def warp_inverse(self, i, t, ux, uy):
        """"Warped tables", The warp: the inverse warp u -> s of the tables of stored incidence
        i blended with those of i + 1 by weight t (p, cond, row and marg each blended)."""
        G = self.warp["G"]
        g1 = G - 1
        px, py = ux * g1, uy * g1
        a = min(int(px), G - 2)
        b = min(int(py), G - 2)
        tx, ty = px - a, py - b
        p0, cond0, row0, marg0 = self.warp_warps[i]
        if t != 0.0:
            p1, cond1, row1, marg1 = self.warp_warps[i + 1]

            def bl(x0, x1, j):
                return (1.0 - t) * x0[j] + t * x1[j]
        else:
            p1, cond1, row1, marg1 = p0, cond0, row0, marg0

            def bl(x0, x1, j):
                return x0[j]

        def lerp(x, y, f):
            return (1.0 - f) * x + f * y

        o0, o1 = b * G + a, (b + 1) * G + a
        c0 = lerp(bl(p0, p1, o0), bl(p0, p1, o1), ty)
        c1 = lerp(bl(p0, p1, o0 + 1), bl(p0, p1, o1 + 1), ty)
        row_b, row_b1 = bl(row0, row1, b), bl(row0, row1, b + 1)
        rows = lerp(row_b, row_b1, ty)
        if rows == 0:
            sx = 0.0
        else:
            sx = (lerp(bl(cond0, cond1, o0), bl(cond0, cond1, o1), ty)
                  + tx * (c0 + (c1 - c0) * tx / 2) / g1) / rows
        sy = bl(marg0, marg1, b) + ty * (row_b + (row_b1 - row_b) * ty / 2) / g1
        return min(max(sx, 0.0), 1.0), min(max(sy, 0.0), 1.0)

    def warp_eval(self, theta_i, wi, wo, wavelengths):
        """"Warped tables", Value, in that section's names, which exchange the query's roles
        ("Whose direction the tables follow"): θi in degrees and ωi = (sin θi, 0, cos θi) are
        the query's viewing direction ωo (the tables' incidence), and ωo is the query's
        incident direction ωi (toward the light), both after steps 1–3 of "Reconstruction"
        (unit vectors, above the horizon, rotated so that the viewing azimuth is 0). The
        incidence weights and σ follow the query's θo; the division is by the cosine of the
        query's θi."""
        zero = [0.0] * len(wavelengths)
        # step 1: the half vector and its u (the pole within 10⁻⁹ of it)
        ux, uy = warp_half_parameter((wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]))
        # step 2: incidence weights, θi clamped to the stored range
        ths = self.warp_thetas
        th = math.radians(theta_i)
        if len(ths) == 1:
            i, t = 0, 0.0
        else:
            tc = min(max(th, ths[0]), ths[-1])
            i = min(bisect.bisect_right(ths, tc) - 1, len(ths) - 2)
            t = (tc - ths[i]) / (ths[i + 1] - ths[i])
        # step 3: the warped point; step 4: the tables there
        sx, sy = self.warp_inverse(i, t, ux, uy)
        R = self.warp["R"]
        v = [table_bilinear(tab, R, sx, sy) for tab in self.warp_tables[i]]
        if t != 0.0:
            v = [(1.0 - t) * a + t * table_bilinear(tab, R, sx, sy)
                 for a, tab in zip(v, self.warp_tables[i + 1])]
        # step 5: ρ = max(0, Σ_k v_k B_k(λ) · D(u_x) / (4 σ(θi)) / cos θo), unclamped θi in σ
        # (in the query's names: σ at the viewing θo, divided by the cosine of the light's θi)
        cos_o = wo[2]
        if not cos_o >= 0:
            return zero
        cos_o = max(cos_o, WARP_HORIZON_COS)
        ndf = self.warp_ndf(ux)
        sigma = lerp_nodes(self.warp_sigma, math.sqrt(th / (math.pi / 2)))
        out = []
        for lam in wavelengths:
            if not math.isfinite(lam):
                out.append(0.0)
                continue
            b = self.basis_at(lam, self.k)
            series = sum(vk * bk for vk, bk in zip(v, b))
            out.append(max(0.0, series * ndf / (4 * sigma) / cos_o))
        return out

    def fact_tables(self, wi, wo):
        """"Factor model": per component, its spectra and T_c0 … T_c(R-1) at the query's
        features (the parts of η_c that do not depend on λ)."""
        feat = fact_features(wi, wo, self.fact_ranges)
        out = []
        for codes, spectra, tables in self.fact:
            t_r = [sum(table_value(k, t, feat) for k, t in zip(codes, per_rank))
                   for per_rank in tables]  # T_cr = Σ_f t_crf(u_f)
            out.append((spectra, t_r))
        return out

    def fact_at(self, fact, lam):
        """F(ωi, ωo, λ) = Σ_c exp(min(η_c, 60)) for a finite λ ("Factor model", Spectra)."""
        waves = self.wavelengths
        if len(waves) == 1 or lam <= waves[0]:
            j, a = 0, 0.0
        elif lam >= waves[-1]:
            j, a = len(waves) - 1, 0.0
        else:
            j = bisect.bisect_right(waves, lam) - 1  # λ_j <= λ < λ_(j+1)
            a = (lam - waves[j]) / (waves[j + 1] - waves[j])

        def spectrum(v):
            return v[j] if a == 0 else v[j] + a * (v[j + 1] - v[j])

        total = 0.0
        for spectra, t_r in fact:
            eta = spectrum(spectra[0]) + t_r[0]
            for r in range(1, len(t_r)):
                eta += spectrum(spectra[r]) * t_r[r]
            total += math.exp(min(eta, 60.0))
        return total

    def add_shared_lobe(self, coef, kind, li, recs, tmax, wi, w, ts, ps):
        """A lobe present, of one kind, in every blended record ("Lobes by position")."""
        rows = 1 if kind in (1, 4) else 4
        amps = [[0.0] * tmax for _ in range(rows)]
        for r, wgt in recs:
            for j in range(rows):
                for k, q in enumerate(r.lobes[li][1][j]):
                    amps[j][k] += wgt * q
        if kind == 1:
            params = []
            for k in range(tmax):
                have = [(r.lobes[li][2][k], wgt) for r, wgt in recs if k < r.terms]
                params.append(math.exp(sum(wgt * math.log(b) for b, wgt in have)
                                       / sum(wgt for _, wgt in have)))
        elif kind == 4:
            params = [math.exp(sum(wgt * math.log(r.lobes[li][2][0]) for r, wgt in recs))]
        elif kind == 5:
            geo = [math.exp(sum(wgt * math.log(r.lobes[li][2][i]) for r, wgt in recs))
                   for i in range(3)]
            lin = [sum(wgt * r.lobes[li][2][i] for r, wgt in recs) for i in (3, 4)]
            psi = mean_axis([(wgt, r.lobes[li][2][5]) for r, wgt in recs])
            if psi is None:
                psi = recs[0][0].lobes[li][2][5]
            params = [to_f32(v) for v in geo + lin + [psi]]
        else:
            b = math.exp(sum(wgt * math.log(r.lobes[li][2][0]) for r, wgt in recs))
            c = math.exp(sum(wgt * math.log(r.lobes[li][2][1]) for r, wgt in recs))
            a = sum(wgt * r.lobes[li][2][2] for r, wgt in recs)
            params = [to_f32(b), to_f32(c), to_f32(a)]
        peak = self.blended_peak([(r, wgt) for r, wgt in recs], ts, ps) if kind in (1, 4) else None
        lobe_add(coef, (kind, amps, params), peak, wi, w)


def open_file(path):
    """Read and validate an .sbrdf file; raises Refused when the file is refused."""
    with open(path, "rb") as fh:
        head = fh.read(MAX_FILE_BYTES + 1)
    return SbrdfFile(head)


# ---------------------------------------------------- the flat device layout (GPU_LAYOUT.md)

GPU_LAYOUT_MAGIC = 0x4C474253  # the bytes "SBGL"


def layout_material(data, base=0):
    """A material read from a flat device layout (spec/GPU_LAYOUT.md, version 1 to 4): `data` is the
    layout buffer's bytes (32-bit little-endian words, several materials possibly concatenated),
    `base` the word offset where this material's layout starts. Only the layout's words are
    read; the result evaluates with the same rules as a file (`.eval`), warped tables (version 4)
    from the section's packed values. Raises Refused when the words are not a version 1 to 4
    layout or an offset points outside it."""
    nwords = len(data) // 4

    def words(off, count, fmt="I"):
        if off < 0 or count < 0 or base + off + count > nwords:
            raise malformed("layout: %d words at offset %d run past the buffer" % (count, off))
        return list(struct.unpack_from("<%d%s" % (count, fmt), data, 4 * (base + off)))

    head = words(0, 20)
    if head[0] != GPU_LAYOUT_MAGIC:
        raise malformed("layout: bad magic 0x%08x (GPU_LAYOUT.md, Header)" % head[0])
    # Version 2 adds the sampling section (header word 18, GPU_LAYOUT.md "Sampling section"),
    # which this reader, an evaluator, ignores; version 3 the model section (word 19, read
    # below); the rest is version 1's.
    if head[1] not in (1, 2, 3, 4):
        raise unsupported("layout: version %d, this reader knows 1 to 4" % head[1])
    (total, inc_layout, basis, k, level, w, n, t, p) = head[2:11]
    lmin, lmax = struct.unpack("<2f", struct.pack("<2I", head[11], head[12]))
    off_waves, off_table, off_thetas, off_phis, off_recs = head[13:18]
    words(0, total)  # the whole layout lies in the buffer
    if inc_layout not in (0, 1, 2) or basis not in (1, 2, 3):
        raise malformed("layout: incidence layout %d or basis %d unknown" % (inc_layout, basis))
    m = SbrdfFile.__new__(SbrdfFile)
    m.head = True
    m.isotropic = inc_layout == 0
    m.layout = ("isotropic", "lattice", "scattered")[inc_layout]
    m.basis, m.k, m.sh_level, m.n = basis, k, level, n
    m.lambda_min, m.lambda_max = lmin, lmax
    m.wavelengths = words(off_waves, w, "f")
    m.basis_values = None
    if basis == 3:
        table = words(off_table, k * w, "f")
        m.basis_values = [table[i * w:(i + 1) * w] for i in range(k)]
    m.thetas = words(off_thetas, t, "f")
    m.phis = words(off_phis, p, "f")
    m.fact = m.warp = m.xval = None
    m.records = []

    def values(off, count, encoding, scale):
        """Encoding 1: f32 words; 2: f16 pairs, low half first, times the scale (rounded to f32)."""
        if encoding == 1:
            return words(off, count, "f")
        raw = struct.pack("<%dI" % ((count + 1) // 2), *words(off, (count + 1) // 2))
        return [to_f32(h * scale) for h in struct.unpack_from("<%de" % count, raw)]

    for i in range(n):
        e = words(off_recs + 12 * i, 12)
        r = Record()
        r.theta_i, r.phi_i, r.theta_p, r.phi_p = struct.unpack("<4f", struct.pack("<4I", *e[:4]))
        r.level, r.terms, lobe_count, encoding = e[4:8]
        (scale,) = struct.unpack("<f", struct.pack("<I", e[8]))
        if encoding not in (1, 2):
            raise malformed("layout: record %d: encoding %d unknown" % (i, encoding))
        p_r = (r.level + 1) ** 2
        sh = values(e[9], r.terms * p_r, encoding, scale)
        r.sh = [sh[j * p_r:(j + 1) * p_r] for j in range(r.terms)]
        r.lobes = []
        for li in range(lobe_count):
            kind, off_amp, off_par = words(e[10] + 3 * li, 3)
            if kind not in (1, 2, 3, 4, 5):
                raise malformed("layout: record %d lobe %d: kind %d" % (i, li, kind))
            variants = 1 if kind in (1, 4) else 4
            n_par = {1: r.terms, 2: 3, 3: 3, 4: 1, 5: 6}[kind]
            amps = values(off_amp, variants * r.terms, encoding, scale)
            rows = [amps[j * r.terms:(j + 1) * r.terms] for j in range(variants)]
            r.lobes.append((kind, rows, words(off_par, n_par, "f")))
        m.records.append(r)
    m.incidences = [(r.theta_i, r.phi_i) for r in m.records]
    m.warp_layout = None
    if head[1] >= 3 and head[19] != 0:
        # Version 4 adds kind 2, the warped tables, which answer every query.
        if head[1] >= 4 and words(head[19], 1)[0] == 2:
            m.warp_layout = LayoutWarp(words, head[19])
        else:
            m.fact, m.fact_ranges = layout_factor_model(words, values, head[19], w)
    return m


# "Warped tables", Value steps 1 and 5: a half vector within this of the pole is the pole, and
# the least cosine of the light's direction the tables divide by.
WARP_POLE_HALF_XY = 1e-9
WARP_HORIZON_COS = 1.0 / 1024.0


def warp_half_parameter(h):
    """u = (u_x, u_y) of the half vector of h = ωi + ωo (Value step 1): (0, 1/2), the pole, when
    √(h_x² + h_y²) ≤ 10⁻⁹ (the mirror direction, or opposite directions on the horizon);
    otherwise from m = h/|h|, u_y reduced to [0, 1)."""
    hxy = math.sqrt(h[0] * h[0] + h[1] * h[1])
    if hxy <= WARP_POLE_HALF_XY:
        return 0.0, 0.5
    hn = math.sqrt(hxy * hxy + h[2] * h[2])
    m = (h[0] / hn, h[1] / hn, h[2] / hn)
    ux = math.sqrt(math.atan2(math.sqrt(m[0] * m[0] + m[1] * m[1]), m[2]) / (math.pi / 2))
    uy = (math.atan2(m[1], m[0]) + math.pi) / (2 * math.pi)
    uy -= math.floor(uy)
    return ux, uy


class LayoutWarp:
    """The warped-tables section of a flat device layout (GPU_LAYOUT.md, "Warped tables
    section", model section kind 2), evaluated as that section says: EVALUATION.md's "Warped
    tables" with the tables' packed values and the section's VNDF rows, columns and σ nodes in
    place of their binary64 definitions. Reads only the section's words."""

    def __init__(self, words, at):
        head = words(at, 16)
        if head[0] != 2:
            raise unsupported("layout: model section kind %d" % head[0])
        self.n, self.k, self.r, self.g, self.m = head[1:6]
        (o_inc, o_ndf, o_sig, o_col, o_cos, o_rows, o_tab, o_val, o_mean) = head[6:15]
        n, k, r, g, m = self.n, self.k, self.r, self.g, self.m
        if not (n >= 1 and k >= 1 and 2 <= r <= 64 and 3 <= g <= 256 and m >= 2):
            raise malformed("layout: warped tables of N %d, K %d, R %d, G %d, M %d"
                            % (n, k, r, g, m))

        def fs(off, count):
            return words(at + off, count, "f")

        inc = fs(o_inc, 6 * n)
        self.incidences = [inc[6 * i:6 * i + 6] for i in range(n)]  # θ, sin, cos, 1/I, scale, floor
        self.ndf = fs(o_ndf, m)
        self.sigma = fs(o_sig, m)
        col = fs(o_col, 5 * g)
        self.columns = [col[5 * a:5 * a + 5] for a in range(g)]  # f, sin θm, cos θm, U, V
        self.cos_phi = fs(o_cos, g)
        rows = words(at + o_rows, n * g)
        # A VNDF row: positive run in the low 9 bits, the marginal in 2^-23 units above.
        self.vndf_rows = [((v >> 9) * 2.0 ** -23, v & 511) for v in rows]
        self.tables = []
        for t in range(n * k):
            off, bits, lo_bits, step_bits = words(at + o_tab + 4 * t, 4)
            lo, step = struct.unpack("<2f", struct.pack("<2I", lo_bits, step_bits))
            count = (r * r * bits + 31) // 32
            packed = words(at + off, count) if count else []
            big = sum(w << (32 * i) for i, w in enumerate(packed))
            mask = (1 << bits) - 1
            self.tables.append([lo + ((big >> (j * bits)) & mask) * step for j in range(r * r)])
        val = fs(o_val, 5 * n * r)
        self.values_rows = [val[5 * j:5 * j + 5] for j in range(n * r)]  # total, marg, marks
        self.means = fs(o_mean, k)

    # -- the formulas of "Warped tables" over the section's quantities (src/decode/warped/query.rs)

    def slices(self, theta):
        ths = [inc[0] for inc in self.incidences]
        if self.n == 1:
            return 0, 0, 0.0
        th = min(max(theta, ths[0]), ths[-1])
        i = 0
        while i + 2 < self.n and ths[i + 1] <= th:
            i += 1
        return i, i + 1, min(max((th - ths[i]) / (ths[i + 1] - ths[i]), 0.0), 1.0)

    def row(self, i, b):
        """Row b of incidence i: (α, cos θ, positive run, 1/I, normalised total)."""
        _, sin_t, cos_t, scale, _, _ = self.incidences[i]
        alpha = sin_t * self.cos_phi[b]
        positive = self.vndf_rows[i * self.g + b][1]
        total = 0.0
        if positive > 0:
            f, st, ct, u, v = self.columns[positive - 1]
            total = alpha * u + cos_t * v
            if positive < self.g:
                total += 0.5 / (self.g - 1) * (f * max(0.0, alpha * st + cos_t * ct))
        return alpha, cos_t, positive, scale, scale * total

    def density(self, row, a):
        alpha, cos_t, positive, scale, _ = row
        if a >= positive:
            return 0.0
        f, st, ct, _, _ = self.columns[a]
        return scale * (f * max(0.0, alpha * st + cos_t * ct))

    def cond(self, row, a):
        alpha, cos_t, positive, scale, total = row
        if a >= positive:
            return total
        _, _, _, u, v = self.columns[a]
        return scale * (alpha * u + cos_t * v)

    @staticmethod
    def cell(x, n):
        f = min(max(x, 0.0), 1.0) * (n - 1)
        i = min(int(f), n - 2)
        return i, f - i

    def invert(self, sl, ux, uy):
        """The inverse VNDF warp of u and the blended density there: (sx, sy, p)."""
        ia, ib, t = sl

        def mix(x, y):
            return x + (y - x) * t

        def lerp(x, y, f):
            return x + (y - x) * f

        n1 = self.g - 1
        a, tx = self.cell(ux, self.g)
        b, ty = self.cell(uy, self.g)
        lo = (self.row(ia, b), self.row(ib, b))
        hi = (self.row(ia, b + 1), self.row(ib, b + 1))

        def both(fn, x):
            return (mix(fn(lo[0], x), fn(lo[1], x)), mix(fn(hi[0], x), fn(hi[1], x)))

        d0, d1 = both(self.density, a), both(self.density, a + 1)
        c0, c1 = lerp(d0[0], d0[1], ty), lerp(d1[0], d1[1], ty)
        b0, b1 = both(self.cond, a)
        before = lerp(b0, b1, ty)
        within = tx * (c0 + 0.5 * (c1 - c0) * tx) / n1
        r0, r1 = mix(lo[0][4], lo[1][4]), mix(hi[0][4], hi[1][4])
        total = lerp(r0, r1, ty)
        sx = (before + within) / total if total > 0 else 0.0
        marg = mix(self.vndf_rows[ia * self.g + b][0], self.vndf_rows[ib * self.g + b][0])
        sy = marg + ty * (r0 + 0.5 * (r1 - r0) * ty) / n1
        return min(max(sx, 0.0), 1.0), min(max(sy, 0.0), 1.0), lerp(c0, c1, tx)

    @staticmethod
    def nodes(values, x):
        f = min(max(x, 0.0), 1.0) * (len(values) - 1)
        i = min(int(f), len(values) - 2)
        return values[i] + (values[i + 1] - values[i]) * (f - i)

    def coefficients(self, wi, wo):
        """The K coefficients of ρ for unit wi (toward the light), wo (toward the viewer), z ≥ 0,
        the tables following wo ("Whose direction the tables follow"); None below the horizon."""
        r = math.sqrt(wo[0] * wo[0] + wo[1] * wo[1])
        c, s = (wo[0] / r, wo[1] / r) if r > 0 else (1.0, 0.0)
        theta = math.atan2(r, wo[2])
        a = (r, 0.0, wo[2])
        b = (c * wi[0] + s * wi[1], -s * wi[0] + c * wi[1], wi[2])
        if not b[2] >= 0:
            return None
        ux, uy = warp_half_parameter((a[0] + b[0], a[1] + b[1], a[2] + b[2]))
        sl = self.slices(theta)
        sx, sy, _ = self.invert(sl, ux, uy)
        sigma = self.nodes(self.sigma, math.sqrt(max(theta, 0.0) / (math.pi / 2)))
        f = self.nodes(self.ndf, ux) / (4 * sigma) / max(b[2], WARP_HORIZON_COS)
        ia, ib, t = sl
        out = []
        for k in range(self.k):
            va = table_bilinear(self.tables[ia * self.k + k], self.r, sx, sy)
            vb = table_bilinear(self.tables[ib * self.k + k], self.r, sx, sy)
            out.append((va + (vb - va) * t) * f)
        return out


def layout_factor_model(words, values, at, w):
    """The model section of kind 1 (GPU_LAYOUT.md, "Model section"): the factor model as
    `SbrdfFile.parse_fact` gives it ([(codes, spectra, tables)] per component) and its ranges."""
    kind, encoding, count, _ = words(at, 4)
    if kind != 1:
        raise unsupported("layout: model section kind %d, this reader knows 1" % kind)
    if encoding not in (1, 2) or not 1 <= count <= 8:
        raise malformed("layout: model encoding %d or %d components" % (encoding, count))
    rng = words(at + 4, 10, "f")
    ranges = [(rng[2 * i], rng[2 * i + 1]) for i in range(5)]
    components = []
    for c in range(count):
        rank, nfeat, packed, off = words(at + 14 + 4 * c, 4)
        codes = [(packed >> (4 * k)) & 15 for k in range(nfeat)]
        if not (1 <= rank <= 8 and 1 <= nfeat <= 6) or any(k not in FACT_NODE_COUNT for k in codes):
            raise malformed("layout: model component %d: rank %d, features %r" % (c, rank, codes))
        n = sum(FACT_NODE_COUNT[k] for k in codes)
        # The file's order (§3.7): s_c, then per rank r its w_cr (r >= 1) and its tables, so
        # w_cr starts at value r(W + n) and rank r's tables at r(W + n) + W. Scale 1.
        vals = values(off, rank * (w + n), encoding, 1.0)
        spectra, tables = [vals[:w]], []
        for r in range(rank):
            if r >= 1:
                spectra.append(vals[r * (w + n):r * (w + n) + w])
            pos = r * (w + n) + w
            per_rank = []
            for k in codes:
                per_rank.append(vals[pos:pos + FACT_NODE_COUNT[k]])
                pos += FACT_NODE_COUNT[k]
            tables.append(per_rank)
        components.append((codes, spectra, tables))
    return components, ranges


def layout_sampling_weights(data, base=0):
    """The sampling section of a flat device layout (spec/GPU_LAYOUT.md, "Sampling section",
    versions 2 and 3): per record (E_bg, [(E_l, ln b_l) per lobe]), or None when the layout has none
    (header word 18 = 0). The evaluator (`layout_material`) does not use it; this reads it so
    that a test can check it against this decoder's own integrals."""
    nwords = len(data) // 4

    def words(off, count, fmt="I"):
        if off < 0 or count < 0 or base + off + count > nwords:
            raise malformed("layout: %d words at offset %d run past the buffer" % (count, off))
        return list(struct.unpack_from("<%d%s" % (count, fmt), data, 4 * (base + off)))

    head = words(0, 20)
    if head[0] != GPU_LAYOUT_MAGIC or head[1] not in (1, 2, 3, 4):
        raise malformed("layout: not a version 1 to 4 layout")
    s, n, off_recs = head[18], head[8], head[17]
    if s == 0:
        return None
    out = []
    for r, at in enumerate(words(s, n)):
        lobes = words(off_recs + 12 * r, 12)[6]
        v = words(at, 1 + 2 * lobes, "f")
        out.append((v[0], [(v[1 + 2 * l], v[2 + 2 * l]) for l in range(lobes)]))
    return out


def fmt(x):
    """A float as Rust's `{}` prints an f64: shortest round-trip digits, no exponent."""
    if math.isnan(x):
        return "NaN"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    from decimal import Decimal
    s = format(Decimal(repr(x)), "f")
    if "." in s:
        s = s.rstrip("0").rstrip(".")
    return s


def pair(text):
    parts = text.split(",")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError("expected θ,φ in degrees, got %r" % text)
    return float(parts[0]), float(parts[1])


def main(argv=None):
    ap = argparse.ArgumentParser(description="Reference decoder of .sbrdf files (spec/FORMAT.md, "
                                 "spec/EVALUATION.md): print wavelength_nm,value CSV.")
    ap.add_argument("file")
    ap.add_argument("--incident", type=pair, required=True, metavar="θ,φ")
    ap.add_argument("--outgoing", type=pair, required=True, metavar="θ,φ")
    ap.add_argument("--wavelengths", metavar="λ1,λ2,...",
                    type=lambda s: [float(v) for v in s.split(",")])
    args = ap.parse_args(argv)
    try:
        f = open_file(args.file)
    except Refused as e:
        print("reference_decoder: %s: %s" % (args.file, e), file=sys.stderr)
        return Refused.EXIT[e.kind]
    except OSError as e:
        print("reference_decoder: %s" % e, file=sys.stderr)
        return 1
    lams = args.wavelengths if args.wavelengths is not None else f.wavelengths
    values = f.eval(*args.incident, *args.outgoing, lams)
    lines = ["wavelength_nm,value"] + ["%s,%s" % (fmt(l), fmt(v)) for l, v in zip(lams, values)]
    sys.stdout.write("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
