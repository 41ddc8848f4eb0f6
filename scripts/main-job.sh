#!/usr/bin/env bash
# The main job: simulate the `paper` scenario (12 h), run the filter with the true model over
# it, and print the summary. Outputs go to out/paper/ (override with OUT=dir, SEED=n).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT="${OUT:-out/paper}"
SEED="${SEED:-1}"
mkdir -p "$OUT"
cargo build --release -q -p hal-sim
HS=target/release/hal-sim
$HS simulate --scenario paper --hours 12 --seed "$SEED" --out "$OUT/log.csv"
$HS run --log "$OUT/log.csv" --model hal-sim/scenarios/paper.toml --out "$OUT/run"
echo "estimates: $OUT/run/estimates.csv   summary: $OUT/run/summary.json" >&2
