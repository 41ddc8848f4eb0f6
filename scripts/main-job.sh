#!/usr/bin/env bash
# The main job: `hal-sim demo`. It hides an effect (drawn at random unless EFFECT is set) in
# 12 h of `paper` data, diagnoses the nominal model from the innovations alone, adds the named
# effect, reruns, prints the before/after table and writes out/demo/report.html.
#   bash scripts/main-job.sh                    # random effect, printed seed
#   EFFECT=gyro/exp-cosine SEED=7 bash scripts/main-job.sh
set -euo pipefail
cd "$(dirname "$0")/.."
args=(demo --out "${OUT:-out/demo}")
[ -n "${EFFECT:-}" ] && args+=(--effect "$EFFECT")
[ -n "${SEED:-}" ] && args+=(--seed "$SEED")
cargo run --release -q -p hal-sim -- "${args[@]}"
