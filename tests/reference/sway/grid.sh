#!/bin/bash
# All 76 sway benches (README): grid.sh IMUPREP_BINARY WORKDIR > results.txt; then
# python3 summary.py results.txt. Benches are written into WORKDIR once and reused.
set -e
here=$(cd "$(dirname "$0")" && pwd); bin=$1; work=$2; mkdir -p "$work"
# CASES (A,P,axis,seed ...) replaces the 76 (seeds.sh).
cases="$CASES"
[ -n "$cases" ] || for ax in x z; do
  for A in 0.3 1 3 10 20; do for P in 5 20 60; do cases="$cases $A,$P,$ax,1"; done; done
  for c in 2,5 5,20 6,20 3,10 1.5,5 1,120 3,120 10,120 10,2 30,20 0.5,120; do cases="$cases $c,$ax,1"; done
  for seed in 2 3; do for A in 3 10; do for P in 10 20 60; do cases="$cases $A,$P,$ax,$seed"; done; done; done
done
for c in $cases; do
  IFS=, read -r A P ax seed <<< "$c"; f="$work/sway_${A}_${P}_${ax}_${seed}.csv"
  [ -f "$f" ] || python3 "$here/sway.py" "$f" "$A" "$P" 300 "$ax" "$seed" > /dev/null
  "$bin" replay "$f" --out "csv:$work/out.csv" > /dev/null 2>&1
  echo "$A $P $ax $seed $(python3 "$here/eval.py" "$f" "$work/out.csv" "$ax")"
done
