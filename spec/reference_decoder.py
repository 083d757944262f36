#!/usr/bin/env python3
"""Independent reference reader and decoder of the .sbrdf format, version 1.1.

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
import math
import struct
import sys
import zlib

SIGNATURE = b"\x89SBRDF\r\n\x1a\n"
MAX_FILE_BYTES = 256 * 1024 * 1024  # §8: the reference reader's default size limit
MAX_SET_DIRECTIONS = 1 << 22


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

def microfacet_variants(kind, b, c, a, wi, w):
    """The four variants of kinds 2 and 3 ("Lobes")."""
    s = (wi[0] + w[0], wi[1] + w[1], wi[2] + w[2])
    if s == (0.0, 0.0, 0.0):
        return (0.0, 0.0, 0.0, 0.0)
    n = math.sqrt(dot(s, s))
    h = (s[0] / n, s[1] / n, s[2] / n)
    ch = min(max(h[2], 0.0), 1.0)
    cd = min(max(dot(wi, h), 1e-6), 1.0)
    ci = max(wi[2], 1e-6)
    co = max(w[2], 1e-6)
    x = 1.0 - ch if kind == 2 else 1.0 - ch * ch
    dist = (1.0 + b * x) ** (-c)
    vs = 1.0 / (co * math.sqrt(a * a + (1 - a * a) * ci * ci)
                + ci * math.sqrt(a * a + (1 - a * a) * co * co))
    vc = min(1.0 / (ci * co), 2 * ch / (cd * ci), 2 * ch / (cd * co))
    f = (1.0 - cd) ** 5
    return (dist * vs, dist * vs * f, dist * vc, dist * vc * f)


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
        var = microfacet_variants(kind, params[0], params[1], params[2], wi, w)
        for j in range(4):
            for k, q in enumerate(amps[j]):
                coef[k] += q * var[j]


# ---------------------------------------------------------------- the file

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
        seen_meta = seen_samp = False
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
            elif ctype == b"RECD":
                if self.basis == 3 and self.basis_values is None:
                    raise malformed("%s: RECD before SBAS (§2.5)" % where)
                if len(self.records) >= self.n:
                    raise malformed("%s: more than N RECD chunks (§2.5)" % where)
                self.records.append(self.parse_recd(body, where))
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
            elif ctype == b"ENDF":
                if length != 0:
                    raise malformed("%s: ENDF must be empty (§3.6)" % where)
                if len(self.records) != self.n:
                    raise malformed("%s: ENDF after %d of %d RECD chunks (§2.5)"
                                    % (where, len(self.records), self.n))
                seen_endf = True
            elif ctype[0] & 0x20 == 0:
                raise unsupported("%s: unknown critical chunk (§2.4)" % where)
            # else: unknown ancillary chunk, skipped after its CRC check (§2.4)
        if not seen_endf:
            raise malformed("file ends without ENDF (§2.5)")
        self.build_layout()

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
        if flags & ~3:
            raise unsupported("%s: unknown flag bits 0x%x (§4)" % (where, flags & ~3))
        wrange = bool(flags & 2)
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
        if len(body) != 40 + 4 * stored + 8 * n:
            raise malformed("%s: length %d, layout needs %d (§3.1)"
                            % (where, len(body), 40 + 4 * stored + 8 * n))
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
        if prec not in (1, 2):
            raise unsupported("%s: unknown precision %d (§3.2)" % (where, prec))
        if any(body[1:4]):
            raise malformed("%s: non-zero reserved byte (§3.2)" % where)
        w = len(self.wavelengths)
        s = 4 if prec == 1 else 2
        if len(body) != 4 + self.k * w * s:
            raise malformed("%s: length %d, layout needs %d (§3.2)" % (where, len(body), 4 + self.k * w * s))
        vals = struct.unpack_from("<%d%s" % (self.k * w, "f" if prec == 1 else "e"), body, 4)
        if not all(math.isfinite(v) for v in vals):
            raise malformed("%s: a basis value is not finite (§3.2)" % where)
        self.basis_values = [list(vals[i * w:(i + 1) * w]) for i in range(self.k)]

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
            if kind not in (1, 2, 3, 4):
                raise unsupported("%s: unknown lobe kind %d (§4)" % (where, kind))
            if res1:
                raise malformed("%s: lobe %d reserved byte not 0 (§3.3)" % (where, li))
            n_amp, n_par = {1: (terms, terms), 2: (4 * terms, 3), 3: (4 * terms, 3),
                            4: (terms, 1)}[kind]
            if length != n_amp * s + 4 * n_par:
                raise malformed("%s: lobe %d of kind %d has length %d, not %d (§3.3)"
                                % (where, li, kind, length, n_amp * s + 4 * n_par))
            amps = values(n_amp, "lobe amplitudes")
            params = list(r.take("%df" % n_par))
            if kind in (2, 3):
                b, c, a = params
                ok = all(math.isfinite(v) for v in params) and b > 0 and c > 0 and 0 <= a <= 1
            else:
                ok = all(math.isfinite(v) and v > 0 for v in params)
            if not ok:
                raise malformed("%s: lobe %d parameters out of range (§3.3)" % (where, li))
            rows = [amps[j * terms:(j + 1) * terms] for j in range(n_amp // terms)]
            rec.lobes.append((kind, rows, params))
        if r.left():
            raise malformed("%s: %d bytes left after the last lobe (§3.3)" % (where, r.left()))
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
        out = []
        for lam in wavelengths:
            if not math.isfinite(lam):
                out.append(0.0)
                continue
            b = self.basis_at(lam, tmax)
            # step 5: the series clamped at 0
            out.append(max(0.0, sum(c * bk for c, bk in zip(coef, b))))
        return out

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
