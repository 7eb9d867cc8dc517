#!/usr/bin/env bash
# Gross-error detection on a static bench that carries a vibration line.
#
# replay/static_bench.toml (MPU-6050-like, 100 Hz, 10 min; white σ per sample 0.05 °/s gyro,
# about 2.83 mg accelerometer) with one 22-Hz line on every channel whose amplitude is R times
# that white σ, R = 0 1 2 4 10, and dense gross errors (2e-3 events per channel-sample, 6–30 σ,
# a third of them runs): `imuprep compare --detectors`, the online stage against the classical
# detectors on the same samples and truth. Then, at R = 4 and 10, the same line switched on at
# 300 s (after the warm-up) and one whose frequency drifts by 0.005 Hz/s (22 -> 25 Hz).
#
# Usage: tests/reference/vibration/line_bench.sh [BIN]   (default target/release/imuprep)
set -euo pipefail
BIN=${1:-target/release/imuprep}
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
# bench R [KEY]: the bench with a line of R x the white sigma (none for 0), KEY one more key of
# the line; prints the stage's and the classical detectors' rows.
bench() {
  local R=$1 KEY=${2:-}
  local S="$W/line.toml"
  cp replay/static_bench.toml "$S"
  if [ "$R" != 0 ]; then
    local G A
    G=$(python3 -c "print(0.05 * $R)")
    A=$(python3 -c "print(round(2.83 * $R, 2))")
    cat >> "$S" <<TOML

[[errors.vibration_lines]]
freq_hz = 22.0
phase_deg = 10.0
gyro_amp_deg_s = [$G, $G, $G]
accel_amp_mg = [$A, $A, $A]
$KEY
TOML
  fi
  echo "== line amplitude ${R} x the white sigma${KEY:+, $KEY}"
  "$BIN" compare --detectors --scenario "$S" --set errors.gross.rate_per_sample=2e-3 2>/dev/null |
    sed -n '/^detector/p;/online ARIMA gate/p;/global 3-sigma/p;/Hampel/p'
}
for R in 0 1 2 4 10; do
  bench "$R"
done
for R in 4 10; do
  bench "$R" "start_s = 300.0"
  bench "$R" "drift_hz_per_s = 0.005"
done
