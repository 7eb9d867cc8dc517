#!/bin/bash
# The size of a short AR(1) component `imuprep diagnose` finds (docs/model-health.md, the
# whiteness test): the wander ladder's white background (tests/fixtures/wander_ladder.toml without
# its Gauss-Markov term) plus an AR(1) of pole PHI per sample and stationary sd K x the white
# per-sample sd on each axis pair (gx/ax, gy/ay, gz/az: three sizes), seeds 1-4, 20 min, 100 Hz.
# Prints diagnose's held-out one-step MSE gain over the open-loop MSE per channel.
# Run from the repository root after `cargo build --release`:
#   tests/reference/whiteness_ar_ladder.sh 0.8 0 0.1 0.2
#   tests/reference/whiteness_ar_ladder.sh 0.8 0.15 0.3 0.5
set -e
phi=$1; shift
dir=$(mktemp -d)
for seed in 1 2 3 4; do
python3 - "$phi" "$@" > "$dir/l.toml" <<'PY'
import sys, math
phi = float(sys.argv[1]); ks = [float(x) for x in sys.argv[2:]]
t = open('tests/fixtures/wander_ladder.toml').read().split('[[errors.gauss_markov]]')[0]
f = math.sqrt(1 - phi * phi)
# White per-sample sd at 100 Hz: 0.05 deg/s = 180 deg/h (gyro), 3.995 mg (accelerometer).
g = [k * 180.0 * f for k in ks]; a = [k * 3.995 * f for k in ks]
print(t)
print('[errors.ar_bias]')
print('gyro_coeffs = [%r]' % phi)
print('gyro_innovation_sd_deg_h = [%s]' % ', '.join(repr(x) for x in g))
print('accel_coeffs = [%r]' % phi)
print('accel_innovation_sd_mg = [%s]' % ', '.join(repr(x) for x in a))
print('[errors.quantisation]\ngyro_lsb_deg_s = 0.007633587786259542\naccel_lsb_mg = 0.244140625')
PY
./target/release/imuprep simulate "$dir/l.toml" -o "$dir/l.log" --seed $seed >/dev/null 2>&1
./target/release/imuprep diagnose "$dir/l.log" --out-dir "$dir/diag" 2>&1 | grep "one-step" \
  | sed -e 's/held-out open-loop MSE \([^ ]*\) → [^,]*, one-step \([^ ]*\) .*/\1 \2/' \
  | awk -v s=$seed '{printf "seed %s %s gain %.2f%%\n", s, $1, 100 * (1 - $3 / $2)}'
done
rm -rf "$dir"
