#!/usr/bin/env bash
# Runs every fuzz target (or those named after the time) for a bounded time (default 600 s
# each), seeded from fuzz/seeds/<target>/ (small files cut from the repository's data; see
# fuzz/seeds/README.md). Needs cargo-fuzz (`cargo install cargo-fuzz`) and nightly features: a
# nightly toolchain, or RUSTC_BOOTSTRAP=1 with stable (set below). The working corpus is
# fuzz/corpus/<target>/ (kept between runs, not in git). Crashes land in
# fuzz/artifacts/<target>/; keep each one as a regression (see README.md here). Prints per
# target the runs done, and any crash, timeout or slow unit (over 10 s), then a summary.
#
#   fuzz/run_all.sh 150                  # every target, 150 s each
#   fuzz/run_all.sh 60 rgl rgl_full      # some of them
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-600}"
shift || true
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  targets=(decode csv exr astm rgl decode_full rgl_full)
fi
# Earlier versions of this script seeded from the full-size data (455 kB Cornell files,
# 40 kB EXR slices, the 14 kB krylon golden file); drop those copies from old corpora, they
# slow every pass over the corpus.
rm -f fuzz/corpus/astm/acryl_blue.astm fuzz/corpus/astm/krylon_blue.astm \
  fuzz/corpus/exr/ggx_slices_ti30_pi0.exr fuzz/corpus/exr/ggx_slices_ti60_pi0.exr \
  fuzz/corpus/decode/krylon_shared_v11.sbrdf fuzz/corpus/csv/phong_3inc.csv
summary=""
for target in "${targets[@]}"; do
  seeds="fuzz/seeds/$target"
  [ "$target" = rgl_full ] && seeds="fuzz/seeds/rgl"
  [ "$target" = decode_full ] && seeds="fuzz/seeds/decode"
  mkdir -p "fuzz/corpus/$target"
  cp "$seeds"/* "fuzz/corpus/$target/"
  echo "== fuzz $target for $seconds s"
  log="$(mktemp)"
  # The heavy targets are built without comparison tracing, in their own target folder (so the
  # two builds do not replace each other): in their loops over tables (the warped tables'
  # inverse DCT and integrals, deflate, the RGL gap filling) each instrumented comparison cost
  # more than the work, ~80% of decode_full's time (perf), 6× fewer inputs. Their readers'
  # parsing, where tracing comparisons finds magic values, is fuzzed by `decode` and `rgl`.
  build=()
  case "$target" in
    decode_full | rgl_full) build=(--no-trace-compares --target-dir fuzz/target-heavy) ;;
  esac
  RUSTC_BOOTSTRAP=1 cargo fuzz run "${build[@]}" "$target" "fuzz/corpus/$target" -- \
    -max_total_time="$seconds" -rss_limit_mb=2048 >"$log" 2>&1 || true
  grep -E "^(Done|==|INFO: Seed)|Slowest unit|slow-unit|crash|timeout|ERROR|panicked" "$log" || true
  runs="$(sed -nE 's/^Done ([0-9]+) runs in ([0-9]+) second.*/\1 runs in \2 s/p' "$log" | tail -1)"
  problems="$(grep -cE "Slowest unit|crash-|timeout-|ERROR|panicked" "$log" || true)"
  summary+="$(printf '%-9s %s; %s problem line(s) (log %s)' "$target" "${runs:-no Done line}" "$problems" "$log")"$'\n'
done
echo "== summary"
printf '%s' "$summary"
