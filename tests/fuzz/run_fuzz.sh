#!/bin/sh
# Fuzz every target (or those named) for SECONDS each, WDR_FUZZ_JOBS at a time (default 2: CI has
# 2 cores and libFuzzer uses one), starting from the committed seeds; fails on any crash, leak,
# timeout (25 s of wall time per input) or out-of-memory (2 GiB). New inputs go to
# BUILD/fuzz-corpus/<target>, faults to BUILD/fuzz-artifacts/.
# Prints one line per target: executions, coverage (edges) and features, corpus size.
# usage: tests/fuzz/run_fuzz.sh BUILD_DIR SECONDS [TARGET ...]   (BUILD_DIR from preset fuzz)
set -eu
here=$(cd "$(dirname "$0")" && pwd)

# One target; exit 123 tells xargs it failed, so the others still run and the whole run fails.
fuzz_one() {
  build=$1 seconds=$2 t=$3
  work=$build/fuzz-corpus/$t log=$build/fuzz-artifacts/$t.log
  mkdir -p "$work"
  if [ ! -x "$build/tests/fuzz/fuzz_$t" ]; then
    echo "fuzz_$t: FAULT: $build/tests/fuzz/fuzz_$t is not built"
    exit 123
  fi
  if ! "$build/tests/fuzz/fuzz_$t" -max_total_time="$seconds" -timeout=25 -rss_limit_mb=2048 \
      -malloc_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$build/fuzz-artifacts/$t-" \
      "$work" "$here/corpus/$t" >"$log" 2>&1; then
    echo "fuzz_$t: FAULT (log $log):"; grep -E "ERROR|SUMMARY|Test unit written" "$log" | head -5
    exit 123
  fi
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")
  cov=$(grep -E '^#[0-9]+' "$log" | tail -1 | sed -n 's/.*cov: \([0-9]*\) ft: \([0-9]*\) corp: \([0-9]*\).*/\1 edges, \2 features, \3 inputs/p')
  echo "fuzz_$t: ${seconds} s, $execs executions, $cov, 0 faults"
}

if [ "${1:-}" = --one ]; then
  shift
  fuzz_one "$@"
  exit 0
fi

build=$1 seconds=$2
shift 2
targets=${*:-"fw_rx fw_update lut cal boot scene images client image fw_image linux_board capture"}
mkdir -p "$build/fuzz-artifacts"
# xargs exits 123 when any target did; each target prints its own line, whole.
printf '%s\n' $targets | xargs -P "${WDR_FUZZ_JOBS:-2}" -I{} sh "$here/run_fuzz.sh" --one "$build" "$seconds" {}
