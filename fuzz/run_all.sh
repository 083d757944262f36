#!/usr/bin/env bash
# Runs every fuzz target for a bounded time (default 600 s each), seeded from samples/.
# Needs cargo-fuzz (`cargo install cargo-fuzz`) and nightly features: a nightly toolchain, or
# RUSTC_BOOTSTRAP=1 with stable (set below). Crashes land in fuzz/artifacts/<target>/; keep each
# one as a regression test (see README.md here).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-600}"
mkdir -p fuzz/corpus/decode fuzz/corpus/csv fuzz/corpus/exr fuzz/corpus/astm fuzz/corpus/rgl
cp samples/golden/*.sbrdf samples/ggx_slices.sbrdf fuzz/corpus/decode/
cp samples/golden/*.csv fuzz/corpus/csv/
cp samples/ggx_slices/*.exr fuzz/corpus/exr/
cp tests/data/cornell/*.astm fuzz/corpus/astm/
cp tests/data/rgl/tiny_rgb.bsdf fuzz/corpus/rgl/
for target in decode csv exr astm rgl; do
  echo "== fuzz $target for $seconds s"
  RUSTC_BOOTSTRAP=1 cargo fuzz run "$target" "fuzz/corpus/$target" -- \
    -max_total_time="$seconds" -rss_limit_mb=2048 2>&1 | grep -E "^(Done|==|INFO: Seed)|crash|ERROR" || true
done
