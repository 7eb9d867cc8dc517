#!/bin/bash
# 40 sways about AXIS (z: yaw, the default; x: roll) on seeds the grid does not use (README):
# seeds.sh IMUPREP_BINARY WORKDIR [AXIS] > results.txt; then python3 summary.py results.txt.
# Benches are written into WORKDIR once and reused.
set -e
here=$(cd "$(dirname "$0")" && pwd); bin=$1; work=$2; ax=${3:-z}; mkdir -p "$work"
for seed in 2 3; do for A in 0.3 0.5 1 3 10; do for P in 5 20 60 120; do
  f="$work/sway_${A}_${P}_${ax}_${seed}.csv"
  [ -f "$f" ] || python3 "$here/sway.py" "$f" "$A" "$P" 300 "$ax" "$seed" > /dev/null
  "$bin" replay "$f" --out "csv:$work/out.csv" > /dev/null 2>&1
  echo "$A $P $ax $seed $(python3 "$here/eval.py" "$f" "$work/out.csv" "$ax")"
done; done; done
