#!/usr/bin/env bash
# Overlapping Allan deviation of 1e6 samples: allantools (Python) vs hal-sim, in one run.
#
# 1. installs allantools + numpy into a venv under the cargo target dir,
# 2. generates N samples (white + random walk, fixed seed) into a CSV,
# 3. times hal-sim (`examples/adev_speed.rs`, release build) on that file,
# 4. times allantools `oadev(data_type="freq", taus="octave")` on the same samples,
# 5. prints both medians, the ratio, and the largest relative difference of the two
#    ADEV curves over the common taus.
#
# Usage: scripts/bench_adev.sh            (N=1000000 REPEATS=7 by default)
#        N=100000 REPEATS=3 scripts/bench_adev.sh
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
TARGET=${CARGO_TARGET_DIR:-$ROOT/target}
VENV=$TARGET/bench-venv
WORK=$TARGET/bench-adev
N=${N:-1000000}
REPEATS=${REPEATS:-7}
RATE=100
mkdir -p "$WORK"

if [ ! -x "$VENV/bin/python" ]; then
    python3 -m venv "$VENV"
fi
"$VENV/bin/python" -m pip install --quiet --disable-pip-version-check allantools numpy
PY=$VENV/bin/python

SAMPLES=$WORK/samples.csv
"$PY" - "$SAMPLES" "$N" <<'EOF'
import sys
import numpy as np
path, n = sys.argv[1], int(sys.argv[2])
rng = np.random.default_rng(20261122)
# White noise (0.3 units/sample) plus a slow random walk and an offset, so that the curve
# has both slopes and the centring of the running sum matters.
x = 0.4 + 0.3 * rng.standard_normal(n) + np.cumsum(1e-4 * rng.standard_normal(n))
# %.17g round-trips every double: both programs read identical values.
np.savetxt(path, x, fmt="%.17g", header="x", comments="")
EOF

(cd "$ROOT" && cargo build --quiet --release -p hal-sim --example adev_speed)
OURS_CSV=$WORK/hal_sim_adev.csv
OURS_OUT=$("$TARGET/release/examples/adev_speed" --input "$SAMPLES" --column x \
    --rate "$RATE" --repeats "$REPEATS" --out "$OURS_CSV")
echo "$OURS_OUT"
OURS_FULL=$(echo "$OURS_OUT" | sed -n 's/^hal_sim_full_median_s=//p')
OURS_NOCI=$(echo "$OURS_OUT" | sed -n 's/^hal_sim_no_ci_median_s=//p')
OURS_FULL_MIN=$(echo "$OURS_OUT" | sed -n 's/^hal_sim_full_min_s=//p')

"$PY" - "$SAMPLES" "$OURS_CSV" "$RATE" "$REPEATS" "$OURS_FULL" "$OURS_NOCI" "$OURS_FULL_MIN" <<'EOF'
import sys, time, statistics
import numpy as np
import allantools
samples, ours_csv, rate, repeats = sys.argv[1], sys.argv[2], float(sys.argv[3]), int(sys.argv[4])
ours_full, ours_noci, ours_full_min = float(sys.argv[5]), float(sys.argv[6]), float(sys.argv[7])
x = np.loadtxt(samples, skiprows=1)
times = []
for _ in range(repeats):
    t = time.perf_counter()
    taus, adev, _, ns = allantools.oadev(x, rate=rate, data_type="freq", taus="octave")
    times.append(time.perf_counter() - t)
at = statistics.median(times)
ours = np.loadtxt(ours_csv, delimiter=",", skiprows=1)
common = {round(t * rate): a for t, a in zip(taus, adev)}
worst = 0.0
print(f"{'tau_s':>10} {'allantools':>14} {'hal_sim':>14} {'rel_diff':>10}")
for tau, a in zip(ours[:, 0], ours[:, 1]):
    m = round(tau * rate)
    if m in common:
        rel = abs(a - common[m]) / common[m]
        worst = max(worst, rel)
        print(f"{tau:10.2f} {common[m]:14.8e} {a:14.8e} {rel:10.2e}")
print(f"allantools_version={allantools.__version__} numpy_version={np.__version__}")
print(f"allantools_oadev_median_s={at:.6f} allantools_oadev_min_s={min(times):.6f}")
print(f"hal_sim_full_median_s={ours_full:.6f} hal_sim_no_ci_median_s={ours_noci:.6f} "
      f"hal_sim_full_min_s={ours_full_min:.6f}")
print(f"ratio_of_medians_full={at / ours_full:.1f}x ratio_of_medians_no_ci={at / ours_noci:.1f}x "
      f"ratio_of_minima_full={min(times) / ours_full_min:.1f}x")
print(f"taus_compared={len([1 for t in ours[:, 0] if round(t * rate) in common])} "
      f"max_rel_diff={worst:.2e}")
EOF
