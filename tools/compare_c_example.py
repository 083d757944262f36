#!/usr/bin/env python3
"""CI check: the C example's values (stdin) agree with `sbrdf eval` to 1e-6 relative.

Usage: eval_c FILE | compare_c_example.py SBRDF_BINARY FILE
"""
import subprocess
import sys

binary, path = sys.argv[1], sys.argv[2]
worst, count = 0.0, 0
for line in sys.stdin:
    ti, pi, to, po, wl, value = line.split()
    out = subprocess.run(
        [binary, "eval", path, "--incident", f"{ti},{pi}", "--outgoing", f"{to},{po}",
         "--wavelengths", wl],
        check=True, capture_output=True, text=True).stdout.splitlines()
    ref = float(out[1].split(",")[1])
    c = float(value)
    rel = abs(c - ref) / max(abs(ref), 1e-30)
    worst = max(worst, rel)
    count += 1
    if rel > 1e-6:
        sys.exit(f"C {c} vs Rust {ref} at {line.strip()}: relative difference {rel:.2e}")
if count < 10:
    sys.exit(f"only {count} values compared")
print(f"C example agrees with sbrdf eval on {count} values (worst relative difference {worst:.1e})")
