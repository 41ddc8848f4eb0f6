#!/usr/bin/env bash
# Firmware budget on the emulated Cortex-M4F (issue 5): instructions per tick under QEMU with
# -icount shift=0, stack high-water marks (painted stack), and the ELF sizes of both firmware
# binaries. Figures go to BENCHMARKS.md ("Firmware on Cortex-M4").
#
#   bash scripts/bench_firmware.sh [OUT_DIR]
#
# Runs the QEMU firmware on a 12 h `paper` log (seed 1) with the online identification, from
# the true model and from a model whose correlation times are 10x too long, plus the fixed model.
# Then the INS/GNSS navigation firmware (imu-ident-nav-qemu, issue 16) on a simulated 20-min
# drive (hal-sim/examples/nav_firmware_bench.rs): instructions per IMU sample, per 1 Hz filter
# step and per GNSS fusion, stack, and parity with the host navigator.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT="${1:-out/bench-firmware}"
TARGET=thumbv7em-none-eabihf
TARGET_DIR="${CARGO_TARGET_DIR:-target}"
mkdir -p "$OUT"
cargo build --release -p imu-ident --target "$TARGET" --features qemu --bin imu-ident-qemu
cargo build --release -p imu-ident --target "$TARGET" --features qemu --bin imu-ident-nav-qemu
cargo build --release -p imu-ident --target "$TARGET" --features board --bin imu-ident-board
cargo build --release -p hal-sim
HS="$TARGET_DIR/release/hal-sim"
ELF="$TARGET_DIR/$TARGET/release/imu-ident-qemu"
"$HS" simulate --scenario paper --seed 1 --out "$OUT/paper.csv"
sed -e 's/^tau = 100.0$/tau = 1000.0/' -e 's/^tau = 1200.0$/tau = 12000.0/' \
    hal-sim/scenarios/paper.toml > "$OUT/tau10x.toml"
for run in "fixed:hal-sim/scenarios/paper.toml:" "adapt-true:hal-sim/scenarios/paper.toml:--adapt" \
           "adapt-tau10x:$OUT/tau10x.toml:--adapt"; do
    IFS=: read -r name model flag <<<"$run"
    # shellcheck disable=SC2086
    "$HS" qemu --log "$OUT/paper.csv" --model "$model" $flag --out "$OUT/$name" --elf "$ELF" >/dev/null
    echo "== $name"
    python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print(json.dumps({'icount': d['icount'], 'stack': d['stack']}))" \
        "$OUT/$name/firmware.json"
done
NAV_ELF="$TARGET_DIR/$TARGET/release/imu-ident-nav-qemu"
echo "== nav (20-min drive)"
cargo run --release -p hal-sim --example nav_firmware_bench -- "$NAV_ELF" 20 | tee "$OUT/nav.json"
for elf in "$ELF" "$NAV_ELF" "$TARGET_DIR/$TARGET/release/imu-ident-board"; do
    echo "== $elf"
    llvm-size -A "$elf" | grep -E '^(\.vector_table|\.text|\.rodata|\.data|\.bss|\.uninit) '
done
