"""Rebuilds the text seeds of fuzz/seeds/ (astm/, csv/) by cutting the repository's own data,
and copies the small binary files used as they are (decode/, rgl/tiny_rgb.bsdf,
exr/ggx_slices_ti0_pi0.exr). The synthetic binary seeds (exr/tiny_*.exr, rgl/tiny_spec.bsdf)
come from `cargo run --manifest-path fuzz/seeds/gen/Cargo.toml -- fuzz/seeds`. Standard
library only; run from the repository root: `python3 fuzz/seeds/make_seeds.py`.
"""

from __future__ import annotations

import shutil
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SEEDS = ROOT / "fuzz" / "seeds"


def astm_cut(src: Path, rows_per_incidence: int, incidences: list[int],
             keep_wavelengths: list[str] | None = None, keep_header: bool = True,
             degrees: bool = False) -> str:
    """Header (NUM_POINTS set to the rows kept) + the first rows of some incidences, in file
    order. keep_wavelengths: only these value columns (e.g. ["400nm", "550nm", "700nm"]).
    degrees: angles rewritten in degrees under ANGLE_UNITS DEGREES."""
    lines = src.read_text().splitlines()
    vars_at = next(i for i, l in enumerate(lines) if l.startswith("VARS "))
    header = lines[:vars_at]
    cols = lines[vars_at][5:].split(",")
    keep = list(range(len(cols)))
    if keep_wavelengths is not None:
        keep = [0, 1, 2, 3] + [cols.index(w) for w in keep_wavelengths]
    data = [l for l in lines[vars_at + 1:] if l.strip()]
    by_inc: dict[str, list[str]] = {}
    for l in data:
        by_inc.setdefault(l.split(",")[0], []).append(l)
    thetas = list(by_inc)
    rows = []
    for k in incidences:
        rows += by_inc[thetas[k]][:rows_per_incidence]
    out = []
    for l in header:
        if l.startswith("NUM_POINTS"):
            l = f"NUM_POINTS {len(rows)}"
        elif not keep_header and l.strip() and not l.startswith(("SAMPLE_NAME", "MEAS_NAME")):
            continue
        out.append(l)
    if not keep_header:
        out = [l for l in out if l.strip()]
    if degrees:
        out.append("ANGLE_UNITS DEGREES")
    out.append("VARS " + ",".join(cols[i] for i in keep))
    import math
    for r in rows:
        f = r.split(",")
        if degrees:
            f[:4] = [f"{math.degrees(float(x)):.4f}" for x in f[:4]]
        out.append(",".join(f[i] for i in keep))
    return "\n".join(out) + "\n"


def csv_cut(src: Path, rows: list[int]) -> str:
    lines = src.read_text().splitlines()
    head = [l for l in lines[:2]]
    data = lines[2:]
    return "\n".join(head + [data[i] for i in rows]) + "\n"


def main() -> None:
    for d in ["decode", "csv", "exr", "astm", "rgl"]:
        (SEEDS / d).mkdir(parents=True, exist_ok=True)
    # decode: the golden files up to 4 kB, as they are.
    for f in sorted((ROOT / "samples" / "golden").glob("*.sbrdf")):
        if f.stat().st_size <= 4096:
            shutil.copy(f, SEEDS / "decode" / f.name)
    shutil.copy(ROOT / "samples" / "ggx_slices.sbrdf", SEEDS / "decode" / "ggx_slices.sbrdf")
    # csv: tiny.csv as it is; cuts of phong_3inc.csv (comment, header, rows of each incidence);
    # the same cut in the long layout.
    shutil.copy(ROOT / "samples" / "golden" / "tiny.csv", SEEDS / "csv" / "tiny.csv")
    phong = ROOT / "samples" / "golden" / "phong_3inc.csv"
    (SEEDS / "csv" / "phong_3inc_cut.csv").write_text(csv_cut(phong, [0, 324, 648]))
    lines = phong.read_text().splitlines()
    names = lines[1].split(",")
    long = ["theta_i,phi_i,theta_o,phi_o,wavelength_nm,value"]
    for i in [0, 324 + 40, 648 + 100]:
        f = lines[2 + i].split(",")
        for j in (4, 19, 34):
            long.append(",".join(f[:4] + [names[j], f"{float(f[j]):.6g}"]))
    (SEEDS / "csv" / "phong_3inc_long_cut.csv").write_text("\n".join(long) + "\n")
    # astm: Cornell files cut to their header and a few rows of some incidences.
    cornell = ROOT / "tests" / "data" / "cornell"
    for name in ["acryl_blue", "krylon_blue"]:
        src = cornell / f"{name}.astm"
        (SEEDS / "astm" / f"{name}_cut.astm").write_text(astm_cut(src, 2, [0, 4]))
        (SEEDS / "astm" / f"{name}_3wl.astm").write_text(
            astm_cut(src, 4, [0, 3, 7], ["400nm", "550nm", "700nm"], keep_header=False))
    (SEEDS / "astm" / "acryl_blue_deg.astm").write_text(
        astm_cut(cornell / "acryl_blue.astm", 3, [1, 5], ["450nm", "600nm"],
                 keep_header=False, degrees=True))
    # exr: the one small slice of samples/ggx_slices/ (3.4 kB), as it is.
    shutil.copy(ROOT / "samples" / "ggx_slices" / "ggx_slices_ti0_pi0.exr", SEEDS / "exr")
    # rgl: the unit tests' tiny RGB file (1.6 kB), as it is.
    shutil.copy(ROOT / "tests" / "data" / "rgl" / "tiny_rgb.bsdf", SEEDS / "rgl")


if __name__ == "__main__":
    main()
