"""Renders the Mitsuba 3 picture of `docs/guide/renderers.md`: the RGL measurement of Rosaline satin vinyl
(tests/data/rgl/satin_rosaline_rgb.bsdf) on two spheres, left through Mitsuba's own `measured`
plugin (the RGL file itself), right through the `sbrdf` plugin on the file `sbrdf encode
--rgb-to-spectrum jakob-hanika-2019` makes of it (defaults otherwise). RGB variant, because
`measured` reads `_rgb` files only in RGB variants.

    pip install ./python mitsuba
    cargo build --release
    python tools/render_mitsuba_example.py [--spp 128] [--variant llvm_ad_rgb] [-o docs/mitsuba_rgl.png]

Writes the .sbrdf file under target/mitsuba_example/.
"""

import argparse
import subprocess
import time
from pathlib import Path

import mitsuba as mi

ROOT = Path(__file__).resolve().parents[1]
RGL = ROOT / "tests/data/rgl/satin_rosaline_rgb.bsdf"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--spp", type=int, default=128)
    ap.add_argument("--width", type=int, default=400)
    ap.add_argument("-o", "--output", default=str(ROOT / "docs/mitsuba_rgl.png"))
    ap.add_argument("--work", default=str(ROOT / "target/mitsuba_example"))
    args = ap.parse_args()
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    encoded = work / "satin_rosaline.sbrdf"
    subprocess.run([str(ROOT / "target/release/sbrdf"), "encode", str(RGL), "-o", str(encoded),
                    "--rgb-to-spectrum", "jakob-hanika-2019"], check=True)

    mi.set_variant(args.variant)
    import sbrdf.mitsuba  # noqa: F401  (registers the "sbrdf" BSDF)

    scene = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 4},
        "sensor": {
            "type": "perspective",
            "fov": 32,
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 1.6, 10], target=[0, 0.1, 0],
                                                       up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": args.width, "height": args.width // 2},
            "sampler": {"type": "independent", "sample_count": args.spp},
        },
        # A large key light from the upper left, a dim uniform fill all around.
        "key": {"type": "sphere", "center": [-6, 7, 6], "radius": 1.5,
                "emitter": {"type": "area", "radiance": {"type": "spectrum", "value": 12.0}}},
        "fill": {"type": "constant", "radiance": {"type": "spectrum", "value": 0.25}},
        "floor": {"type": "rectangle",
                  "to_world": mi.ScalarTransform4f().translate([0, -1, 0]).rotate([1, 0, 0], -90)
                  .scale(20),
                  "bsdf": {"type": "diffuse", "reflectance": {"type": "spectrum", "value": 0.18}}},
        "measured": {"type": "sphere", "center": [-1.2, 0, 0], "radius": 1.0,
                     "bsdf": {"type": "measured", "filename": str(RGL)}},
        "sbrdf": {"type": "sphere", "center": [1.2, 0, 0], "radius": 1.0,
                  "bsdf": {"type": "sbrdf", "filename": str(encoded)}},
    }
    t0 = time.time()
    img = mi.render(mi.load_dict(scene), spp=args.spp)
    mi.util.write_bitmap(args.output, img)
    print(f"wrote {args.output} in {time.time() - t0:.1f} s ({args.variant}, {args.spp} spp)")


if __name__ == "__main__":
    main()
