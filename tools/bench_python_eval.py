"""Material.eval throughput against the Rust decoder's own (examples/throughput.rs), same file,
same number of uniformly random direction pairs and wavelengths, best of three runs each.

    cargo build --release --example throughput
    python tools/bench_python_eval.py samples/golden/ggx_3inc_default.sbrdf [PAIRS]
"""

import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import sbrdf

ROOT = Path(__file__).resolve().parents[1]


def main():
    path = sys.argv[1]
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 1_000_000
    m = sbrdf.open(path)
    rng = np.random.default_rng(7)
    z = rng.random(n)
    p = 2 * np.pi * rng.random((n, 2))
    r = np.sqrt(1 - z * z)
    wi = np.stack([r * np.cos(p[:, 0]), r * np.sin(p[:, 0]), z], axis=1).astype(np.float32)
    z2 = rng.random(n)
    r2 = np.sqrt(1 - z2 * z2)
    wo = np.stack([r2 * np.cos(p[:, 1]), r2 * np.sin(p[:, 1]), z2], axis=1).astype(np.float32)
    wl = np.array([450.0, 500.0, 550.0, 600.0], np.float32)
    best = float("inf")
    for _ in range(3):
        t = time.perf_counter()
        out = m.eval(wi, wo, wl)
        best = min(best, time.perf_counter() - t)
    assert out.shape == (n, 4)
    rust = float(subprocess.run(
        [str(ROOT / "target/release/examples/throughput"), path, str(n), "4"],
        capture_output=True, text=True, check=True).stdout)
    print(f"{n} pairs x 4 wavelengths: Python {best * 1e9 / n:.0f} ns/pair, "
          f"Rust {rust * 1e9 / n:.0f} ns/pair, ratio {best / rust:.2f}")


if __name__ == "__main__":
    main()
