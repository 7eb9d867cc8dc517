#!/bin/bash
# 40 sways about AXIS (z: yaw, the default; x: roll) on seeds the grid does not use (README):
# seeds.sh IMUPREP_BINARY WORKDIR [AXIS] > results.txt; then python3 summary.py results.txt.
# The cases are handed to grid.sh, which writes, replays and scores them.
here=$(cd "$(dirname "$0")" && pwd); ax=${3:-z}; cases=""
for seed in 2 3; do for A in 0.3 0.5 1 3 10; do for P in 5 20 60 120; do
  cases="$cases $A,$P,$ax,$seed"
done; done; done
CASES=$cases exec "$here/grid.sh" "$1" "$2"
