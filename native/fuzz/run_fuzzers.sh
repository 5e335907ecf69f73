#!/usr/bin/env bash
# Runs every fuzz target for a bounded time from the seed corpus.
#   bash native/fuzz/run_fuzzers.sh BUILD_DIR [SECONDS_EACH]   (default 60)
# FUZZ_SEED=N fixes libFuzzer's random seed (setup.sh sanitize, and so CI, uses 1:
# the same inputs every run, so CI does not turn red at random); unset, each
# run explores differently.
# BUILD_DIR was configured with -DARAP_FUZZ=ON (docs/robustness.md, "Sanitizers and fuzzing").
# The seeds are copied, so the repository's corpus is never changed; new
# inputs and crash reproducers stay in a temporary folder that is named on
# failure. Exits non-zero on any crash, hang (-timeout), leak, out-of-memory
# or broken promise (a target aborts on NaN after a successful solve).
# A hang is an input over 60 s: instrumented, the solver runs about 150 times
# slower than a release build, and the slowest input found so far
# (slow/solve/found_contact_stall, a test of the build) takes about 20 s.
set -euo pipefail
build=${1:?usage: run_fuzzers.sh BUILD_DIR [SECONDS_EACH]}
seconds=${2:-60}
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d /tmp/arap-fuzz-run.XXXXXX)
status=0
for target in mesh_read scenario solve; do
  exe="$build/fuzz/fuzz_$target"
  [ -x "$exe" ] || { echo "fuzz: $exe is missing (configure with -DARAP_FUZZ=ON)" >&2; exit 2; }
  mkdir -p "$work/$target/corpus" "$work/$target/artifacts"
  cp "$here/corpus/$target/"* "$work/$target/corpus/"
  echo "== fuzz_$target for ${seconds} s"
  if ! ARAP_FUZZ_SCRATCH="$work/$target/scratch" "$exe" "$work/$target/corpus" -seed="${FUZZ_SEED:-0}" \
      -max_total_time="$seconds" -timeout=60 -rss_limit_mb=2048 \
      -max_len=4096 -print_final_stats=1 -artifact_prefix="$work/$target/artifacts/" \
      >"$work/$target/log.txt" 2>&1; then
    status=1
    echo "!! fuzz_$target found a problem: $work/$target/log.txt, reproducer in $work/$target/artifacts/"
    grep -E "ERROR|runtime error|broken promise|timeout|leak|out-of-memory" "$work/$target/log.txt" | head -5 || true
  fi
  grep -E "^stat::number_of_executed_units|^stat::peak_rss_mb" "$work/$target/log.txt" | tr '\n' ' '
  echo
done
[ "$status" -eq 0 ] && rm -rf "$work"
exit "$status"
