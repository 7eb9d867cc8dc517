#!/usr/bin/env bash
# Run every fuzz target for EXECS executions (default 10 M) with AFL++ through cargo-afl, one
# after the other, then print each one's totals. Usage: fuzz/run.sh [EXECS] [OUT_DIR]
# Needs: cargo install cargo-afl (once; it builds AFL++ for the installed rustc).
set -euo pipefail
cd "$(dirname "$0")"
execs=${1:-10000000}
out=${2:-/tmp/imuprep-fuzz}
export AFL_SKIP_CPUFREQ=1 AFL_I_DONT_CARE_ABOUT_MISSING_CRASHES=1 AFL_NO_UI=1
mkdir -p "$out"
cargo afl build --release
for t in native ubx mavlink ulog mcap auto csv; do
  cargo afl fuzz -i "seeds/$t" -o "$out/$t" -E "$execs" "target/release/$t" > "$out-$t.log" 2>&1 || true
  s="$out/$t/default/fuzzer_stats"
  printf '%-8s %s\n' "$t" "$(grep -E '^(execs_done|saved_crashes|saved_hangs|corpus_count)' "$s" | tr -s ' ' | tr '\n' ' ')"
done
