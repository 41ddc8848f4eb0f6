#!/usr/bin/env bash
# THE test command: everything CI checks, in order, stopping at the first failure.
#
#   1. install missing tools          (scripts/install-tools.sh)
#   2. formatting                     (cargo fmt --check)
#   3. clippy -D warnings, host       (whole workspace, all targets)
#   4. clippy -D warnings, Cortex-M4F (the no_std library, the QEMU and the STM32F405 firmware)
#   5. host tests                     (cargo test --workspace: unit, integration and doc tests;
#                                      the QEMU tests wait for step 7)
#   6. firmware release builds        (imu-ident-qemu, imu-ident-nav-qemu, imu-ident-board and
#                                      imu-ident-nav-board for thumbv7em-none-eabihf, sizes printed;
#                                      then all four again with prove-no-panic: they link only if
#                                      no panic path is left)
#   7. QEMU tests                     (hal-sim/tests/qemu_smoke.rs against the estimator firmware,
#                                      hal-sim/tests/nav_qemu.rs against the navigation firmware)
#   8. Python package                 (pip install ./python into a venv under the target dir,
#                                      built in the dev profile at opt-level 2 to reuse step 5's
#                                      dependencies; then pytest python/tests against the CLI)
#
# Uses the default target dir unless CARGO_TARGET_DIR is set.
set -euo pipefail
cd "$(dirname "$0")/.."

# On CI (a fresh clone, built once) without incremental compilation: the host test build of a
# clean clone took 394 s against 448 s with it (BENCHMARKS.md "CI time: bit-exact kernels").
# A developer's repeated runs keep cargo's default.
if [ "${CI:-}" = true ]; then
    export CARGO_INCREMENTAL=0
fi

TARGET=thumbv7em-none-eabihf
TARGET_DIR="${CARGO_TARGET_DIR:-target}"
START=$(date +%s)
SECTION_START=""

# Prints a header with the elapsed time, and how long the previous section took.
section() {
    local now
    now=$(date +%s)
    if [ -n "$SECTION_START" ]; then
        echo "---- done in $((now - SECTION_START)) s"
    fi
    SECTION_START=$now
    printf '\n==== [%4d s] %s ====\n' "$((now - START))" "$*"
}

section "1/8 install tools"
bash scripts/install-tools.sh
cargo --version
rustc --version

section "2/8 format (cargo fmt --check)"
cargo fmt --all -- --check

section "3/8 clippy, host (workspace, all targets)"
cargo clippy --workspace --all-targets -- -D warnings

section "4/8 clippy, $TARGET (library; firmware with --features qemu, --features board)"
cargo clippy -p imu-ident --target "$TARGET" --lib -- -D warnings
# The p = 8 capacity (feature `params8`, docs/ADAPTATION.md §7.4) must keep building.
cargo clippy -p imu-ident --target "$TARGET" --lib --features params8 -- -D warnings
cargo clippy -p imu-ident --target "$TARGET" --features qemu --bins -- -D warnings
# Release, as step 6 builds it (the board's features never mix with the QEMU ones).
cargo clippy --release -p imu-ident --target "$TARGET" --features board --bins -- -D warnings

section "5/8 host tests (cargo test --workspace)"
# The QEMU tests are named qemu_firmware_*; they run in step 7 with the firmware built. Under
# CI=true they fail rather than skip without it, so they are held back here.
# The fuzz tests (tests/step_fuzz.rs, hal-sim/tests/fuzz_parsers.rs) read their case count
# from FUZZ_CASES; CI runs their default short budget (about 15 s on 2 cores). The long run with
# a large FUZZ_CASES is recorded in RELIABILITY.md.
# The examples (benchmarks) are not built here: step 3's clippy checks them, and linking 18
# benchmark binaries cost minutes of CI (BENCHMARKS.md "CI build time"). Doc tests run after.
unset FUZZ_CASES
cargo test --workspace --lib --bins --tests -- --skip qemu_firmware_
cargo test --workspace --doc

section "6/8 firmware release builds ($TARGET: imu-ident-qemu, imu-ident-nav-qemu, the two boards)"
# Prints an ELF's text/data/bss sizes (and, with -A, every section's).
print_size() {
    if command -v llvm-size >/dev/null 2>&1; then
        llvm-size "$@"
    elif command -v size >/dev/null 2>&1; then
        size "$@"
    else
        ls -l "${@: -1}"
    fi
}
cargo build --release -p imu-ident --target "$TARGET" --features qemu --bin imu-ident-qemu
ELF="$TARGET_DIR/$TARGET/release/imu-ident-qemu"
case "$ELF" in /*) ;; *) ELF="$PWD/$ELF" ;; esac
print_size "$ELF"
# The INS/GNSS navigation firmware on the same emulated board (issue 16).
cargo build --release -p imu-ident --target "$TARGET" --features qemu --bin imu-ident-nav-qemu
NAV_ELF="$TARGET_DIR/$TARGET/release/imu-ident-nav-qemu"
case "$NAV_ELF" in /*) ;; *) NAV_ELF="$PWD/$NAV_ELF" ;; esac
print_size "$NAV_ELF"
# The STM32F405 board (built only: running it needs a probe and a board, see README).
cargo build --release -p imu-ident --target "$TARGET" --features board --bin imu-ident-board
BOARD_ELF="$TARGET_DIR/$TARGET/release/imu-ident-board"
print_size "$BOARD_ELF"
print_size -A "$BOARD_ELF" | grep -E '^(section|\.vector_table|\.text|\.rodata|\.data|\.bss|\.uninit) '
# The navigation computer: IMU frames and a u-blox receiver into the live loop (built only).
cargo build --release -p imu-ident --target "$TARGET" --features board --bin imu-ident-nav-board
print_size -A "$TARGET_DIR/$TARGET/release/imu-ident-nav-board" |
    grep -E '^(section|\.text|\.rodata|\.ccmram|\.data|\.bss|\.uninit) '
# Link-time proof that no panic path survives optimisation in either firmware (RELIABILITY.md,
# "Panic-free firmware, proved at link time"): with `prove-no-panic` the panic handler calls
# `imu_ident_panic_path_is_linked`, which is defined nowhere. A link error "undefined symbol:
# imu_ident_panic_path_is_linked" here means some code in that binary can still panic (an index,
# a division, an unwrap, a logger's assertion...): find it with `llvm-objdump -d` on the normal
# build above (callers of core::panicking::*) and remove it at its source. These builds write
# the same ELF names, so the normal QEMU ELF is copied aside first for step 7.
cp "$ELF" "$ELF-smoke"
ELF="$ELF-smoke"
cp "$NAV_ELF" "$NAV_ELF-test"
NAV_ELF="$NAV_ELF-test"
cargo build --release -p imu-ident --target "$TARGET" --features qemu,prove-no-panic --bin imu-ident-qemu
cargo build --release -p imu-ident --target "$TARGET" --features qemu,prove-no-panic --bin imu-ident-nav-qemu
cargo build --release -p imu-ident --target "$TARGET" --features board,prove-no-panic --bin imu-ident-board
cargo build --release -p imu-ident --target "$TARGET" --features board,prove-no-panic --bin imu-ident-nav-board

section "7/8 QEMU tests (mps2-an386: estimator and navigation firmware)"
# --workspace keeps the feature set of step 5, so nothing is rebuilt.
# qemu_firmware_built_on_demand deletes the firmware in the target dir it is given and has
# `hal-sim qemu` build it again: here the one step 6 built it in with the same command, so the
# build is a relink from warm artifacts, not a second compile from scratch (the ELFs the other
# tests run were copied aside above).
IMU_IDENT_AUTOBUILD_TARGET_DIR="$(cd "$TARGET_DIR" && pwd)" IMU_IDENT_FIRMWARE_ELF="$ELF" \
    cargo test --workspace --test qemu_smoke -- --nocapture
# About 15 s: a 10-min simulated drive through the firmware and the host navigator.
IMU_IDENT_NAV_FIRMWARE_ELF="$NAV_ELF" cargo test --workspace --test nav_qemu -- --nocapture

section "8/8 Python package (pip install ./python; pytest python/tests)"
# A venv under the target dir (PyPI for maturin, numpy and pytest). pip builds the extension
# with maturin in the workspace's target dir; the tests compare it with the hal-sim CLI built in
# step 5.
VENV="$TARGET_DIR/pyvenv"
case "$VENV" in /*) ;; *) VENV="$PWD/$VENV" ;; esac
if [ ! -x "$VENV/bin/python" ]; then
    python3 -m venv "$VENV"
fi
"$VENV/bin/python" -m pip install --quiet --upgrade pip
# The wheel is built in the dev profile with the test profile's settings (opt-level 2; the test
# profile inherits the rest from dev), so cargo reuses the dependencies step 5 compiled instead
# of compiling them all again in [profile.python] (BENCHMARKS.md, "CI time" under "Sparse
# products in the discretisation"). `--profile test` would not do: maturin's `cargo rustc --profile
# test` builds the test harness, which Python cannot load. A user's `pip install ./python`
# still builds [profile.python].
CARGO_PROFILE_DEV_OPT_LEVEL=2 MATURIN_PEP517_ARGS="--profile dev" \
    "$VENV/bin/python" -m pip install --quiet ./python pytest
# The CLI that step 5 built for hal-sim's integration tests (CARGO_BIN_EXE_hal-sim).
HAL_SIM_BIN="$TARGET_DIR/debug/hal-sim"
case "$HAL_SIM_BIN" in /*) ;; *) HAL_SIM_BIN="$PWD/$HAL_SIM_BIN" ;; esac
[ -x "$HAL_SIM_BIN" ] || cargo build -p hal-sim --bin hal-sim
# pytest exits 5 when it collected no tests: a missing test suite is a failure here too.
set +e
HAL_SIM_BIN="$HAL_SIM_BIN" "$VENV/bin/python" -m pytest -q python/tests
rc=$?
set -e
if [ "$rc" -eq 5 ]; then
    echo "pytest collected no tests in python/tests" >&2
    exit 1
elif [ "$rc" -ne 0 ]; then
    exit "$rc"
fi

section "all checks passed"
echo "total $(( $(date +%s) - START )) s"
