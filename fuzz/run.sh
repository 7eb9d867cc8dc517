#!/usr/bin/env bash
# Run every fuzz target for EXECS executions (default 10 M) with AFL++ through cargo-afl, one
# after the other, then print each one's totals. Usage: fuzz/run.sh [EXECS] [OUT_DIR]
# PARALLEL=1 runs the targets at once (no CPU pinning) instead; TARGETS="native csv" picks some;
# SKIP_BUILD=1 reuses target/release. Stopping a run early (kill -INT the fuzzers) keeps their
# stats: fuzz/run.sh then prints the totals of what ran.
# Needs: cargo install cargo-afl (once; it builds AFL++ for the installed rustc).
set -euo pipefail
cd "$(dirname "$0")"
execs=${1:-10000000}
out=${2:-/tmp/imuprep-fuzz}
export AFL_SKIP_CPUFREQ=1 AFL_I_DONT_CARE_ABOUT_MISSING_CRASHES=1 AFL_NO_UI=1
mkdir -p "$out"
targets=${TARGETS:-native ubx mavlink ulog mcap auto csv}
[ "${SKIP_BUILD:-0}" = 1 ] || cargo afl build --release
fuzz() {
  cargo afl fuzz -i "seeds/$1" -o "$out/$1" -E "$execs" "target/release/$1" > "$out-$1.log" 2>&1 || true
}
if [ "${PARALLEL:-0}" = 1 ]; then
  export AFL_NO_AFFINITY=1
  for t in $targets; do fuzz "$t" & done
  wait
else
  for t in $targets; do fuzz "$t"; done
fi
for t in $targets; do
  s="$out/$t/default/fuzzer_stats"
  printf '%-8s %s\n' "$t" "$(grep -E '^(execs_done|saved_crashes|saved_hangs|corpus_count)' "$s" | tr -s ' ' | tr '\n' ' ')"
done
