"""Makes a spectral RGL tensor file (X_spec.bsdf) from an RGB one (X_rgb.bsdf), for rendering
with Mitsuba 3's ``measured`` plugin in its spectral variants (which refuse ``rgb`` files).

It is the recipe /work/shared/data/measured/rgl/README.md states for the shared ``*_spec.bsdf``
files, and it reproduces them byte for byte:

* every field kept, in order, except ``rgb`` [phi_i, theta_i, 3, R, R], which is dropped;
* ``spectra`` [phi_i, theta_i, 41, R, R] = R·red + G·green + B·blue, where red, green and blue
  are the ColorChecker patch spectra of samples/colorchecker_ohta_380_780_5nm.csv (N. Ohta),
  each scaled to peak 1, taken at 380–780 nm every 10 nm (computed in float64, stored float32);
* ``wavelengths`` [41] (float32, nm) appended after ``spectra``;
* ``description`` gets the suffix `` [spectral test version: RGB mixed into ColorChecker
  red/green/blue spectra]`` (``--suffix`` changes it).

The real angular data stays; the spectra are a stand-in (genuine RGL spectral files cover
360–1000 nm).

    python tools/make_spec_bsdf.py tests/data/rgl/satin_rosaline_rgb.bsdf -o satin_rosaline_spec.bsdf
    python tools/make_spec_bsdf.py IN_rgb.bsdf -o OUT_spec.bsdf --compare /work/shared/data/measured/rgl/satin_rosaline_spec.bsdf

The module also holds a minimal reader/writer of Mitsuba's ``tensor_file`` format (v1.0):
magic ``tensor_file\\0``, u8 version major, u8 minor, u32 field count, then per field u16 name
length, name (UTF-8), u16 ndim, u8 dtype (Mitsuba's Struct::Type: 1 u8, 2 i8, 3 u16, 4 i16,
5 u32, 6 i32, 7 u64, 8 i64, 9 f16, 10 f32, 11 f64), u64 byte offset, u64 shape[ndim]; then
the data, each field starting at a multiple of 8 bytes (zero padding), all little-endian.
"""

from __future__ import annotations

import argparse
import csv
import struct
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
COLORCHECKER = ROOT / "samples/colorchecker_ohta_380_780_5nm.csv"
SUFFIX = " [spectral test version: RGB mixed into ColorChecker red/green/blue spectra]"
MAGIC = b"tensor_file\0"

DTYPES = {1: np.uint8, 2: np.int8, 3: np.uint16, 4: np.int16, 5: np.uint32, 6: np.int32,
          7: np.uint64, 8: np.int64, 9: np.float16, 10: np.float32, 11: np.float64}
CODES = {np.dtype(v).newbyteorder("<"): k for k, v in DTYPES.items()}


def read_tensor_file(path) -> dict:
    """{name: ndarray} in the file's field order (arrays are little-endian, read-only views
    copied into fresh arrays)."""
    b = Path(path).read_bytes()
    if b[:12] != MAGIC:
        raise ValueError(f"{path}: not a Mitsuba tensor_file (bad magic)")
    major, minor = b[12], b[13]
    if (major, minor) != (1, 0):
        raise ValueError(f"{path}: tensor_file version {major}.{minor}, expected 1.0")
    (count,) = struct.unpack_from("<I", b, 14)
    pos, fields = 18, {}
    for _ in range(count):
        (n,) = struct.unpack_from("<H", b, pos)
        pos += 2
        name = b[pos:pos + n].decode("utf-8")
        pos += n
        (ndim,) = struct.unpack_from("<H", b, pos)
        code = b[pos + 2]
        (offset,) = struct.unpack_from("<Q", b, pos + 3)
        pos += 11
        shape = struct.unpack_from(f"<{ndim}Q", b, pos)
        pos += 8 * ndim
        if code not in DTYPES:
            raise ValueError(f"{path}: field {name}: unknown dtype code {code}")
        dt = np.dtype(DTYPES[code]).newbyteorder("<")
        size = int(np.prod(shape, dtype=np.int64))
        fields[name] = np.frombuffer(b, dt, size, offset).reshape(shape).copy()
    return fields


def write_tensor_file(path, fields: dict) -> bytes:
    """Writes {name: ndarray} in the dict's order (the layout Mitsuba's own writer uses: header,
    then each field's data at the next multiple of 8). Returns the bytes written."""
    arrays = []
    for name, a in fields.items():
        a = np.asarray(a)
        dt = a.dtype.newbyteorder("<")
        if dt not in CODES:
            raise ValueError(f"field {name}: dtype {a.dtype} has no tensor_file code")
        arrays.append((name, np.ascontiguousarray(a, dtype=dt)))
    header_size = 18 + sum(2 + len(n.encode()) + 2 + 1 + 8 + 8 * a.ndim for n, a in arrays)
    align = lambda x: (x + 7) // 8 * 8  # noqa: E731
    offsets, pos = [], align(header_size)
    for _, a in arrays:
        offsets.append(pos)
        pos = align(pos + a.nbytes)
    end = offsets[-1] + arrays[-1][1].nbytes if arrays else header_size
    out = bytearray(end)
    out[:12] = MAGIC
    out[12:14] = bytes([1, 0])
    struct.pack_into("<I", out, 14, len(arrays))
    p = 18
    for (name, a), off in zip(arrays, offsets):
        nb = name.encode()
        struct.pack_into(f"<H{len(nb)}sHBQ", out, p, len(nb), nb, a.ndim, CODES[a.dtype], off)
        p += 2 + len(nb) + 2 + 1 + 8
        struct.pack_into(f"<{a.ndim}Q", out, p, *a.shape)
        p += 8 * a.ndim
        out[off:off + a.nbytes] = a.tobytes()
    Path(path).write_bytes(bytes(out))
    return bytes(out)


def colorchecker_primaries(step_nm: int = 10):
    """(wavelengths [nm], (3, n) red/green/blue patch spectra each scaled to peak 1), at
    380–780 nm every step_nm."""
    with open(COLORCHECKER, newline="") as f:
        rows = [r for r in csv.reader(f) if r and not r[0].startswith("#")]
    head, body = rows[0], np.array(rows[1:], dtype=np.float64)
    wl = body[:, 0]
    keep = (wl % step_nm) == 0
    spectra = np.stack([body[keep, head.index(c)] for c in ("red", "green", "blue")])
    spectra /= spectra.max(axis=1, keepdims=True)
    return wl[keep], spectra


def make_spec(fields: dict, suffix: str = SUFFIX) -> dict:
    if "rgb" not in fields:
        raise ValueError("no 'rgb' field: not an RGB RGL file (already spectral?)")
    wl, prim = colorchecker_primaries()
    rgb = fields["rgb"].astype(np.float64)  # [phi_i, theta_i, 3, R, R]
    spectra = np.einsum("ptcxy,cl->ptlxy", rgb, prim).astype(np.float32)
    out = {}
    for name, a in fields.items():
        if name == "rgb":
            continue
        if name == "description" and suffix:
            a = np.frombuffer(bytes(a) + suffix.encode(), np.uint8)
        out[name] = a
    out["spectra"] = spectra
    out["wavelengths"] = wl.astype(np.float32)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        epilog="Recipe: /work/shared/data/measured/rgl/README.md; see the module docstring.",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("input", help="an RGB RGL tensor file (X_rgb.bsdf)")
    ap.add_argument("-o", "--output", required=True, help="the spectral file to write (X_spec.bsdf)")
    ap.add_argument("--suffix", default=SUFFIX, help="appended to the description field "
                    "(default: the shared files' suffix; '' keeps the description)")
    ap.add_argument("--compare", metavar="REF_spec.bsdf",
                    help="report whether the output is byte-identical to REF, else the max abs "
                         "difference per field")
    args = ap.parse_args(argv)
    fields = read_tensor_file(args.input)
    data = write_tensor_file(args.output, make_spec(fields, args.suffix))
    print(f"wrote {args.output} ({len(data)} bytes)")
    if args.compare:
        ref = Path(args.compare).read_bytes()
        if ref == data:
            print(f"byte-identical to {args.compare}")
            return 0
        a, b = read_tensor_file(args.output), read_tensor_file(args.compare)
        print(f"NOT byte-identical to {args.compare}; fields: ours {list(a)}, ref {list(b)}")
        for name in b:
            if name not in a or a[name].shape != b[name].shape:
                print(f"  {name}: missing or shape differs")
                continue
            d = np.abs(a[name].astype(np.float64) - b[name].astype(np.float64)).max()
            print(f"  {name}: max abs diff {d:.3g}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
