#!/usr/bin/env bash
# Cargo's runner for thumbv7em-none-eabihf (.cargo/config.toml): `cargo run` calls it with the
# firmware ELF and any arguments after `--`, and it runs that firmware where it belongs, chosen
# by the ELF's file name:
#
#   imu-ident-qemu   QEMU's mps2-an386 (Cortex-M4F) with semihosting, in the current directory
#                    (the firmware reads replay.bin there, or the file given with
#                    `-- -append LOG`); extra arguments go to QEMU. QEMU's exit status is the
#                    firmware's.
#   imu-ident-nav-qemu  the same, for the INS/GNSS navigation firmware (it reads nav.bin, or
#                    the file given with `-- -append REPLAY`; write one with hal_sim::nav_qemu).
#   imu-ident-board  `probe-rs run --chip STM32F405RGTx` (a probe must be attached): flashes the
#                    ELF, resets the chip and decodes the defmt telemetry from RTT. Extra
#                    arguments go to probe-rs (e.g. --probe VID:PID). PROBE_RS_CHIP overrides
#                    the chip.
#   imu-ident-nav-board  the same probe-rs run, for the STM32F405 navigation computer.
#
#   scripts/run-target.sh ELF [ARGS...]
set -euo pipefail

if [ "$#" -lt 1 ]; then
    echo "usage: $0 ELF [ARGS...]" >&2
    exit 2
fi
elf=$1
shift

case "$(basename -- "$elf")" in
    imu-ident-qemu | imu-ident-nav-qemu)
        # Extra arguments go to QEMU after the kernel, as with the plain QEMU runner, e.g.
        # `-append log.bin` (the firmware's log name) or `-icount shift=0`.
        exec qemu-system-arm -cpu cortex-m4 -machine mps2-an386 -nographic \
            -semihosting-config enable=on,target=native -kernel "$elf" "$@"
        ;;
    imu-ident-board | imu-ident-nav-board)
        if ! command -v probe-rs >/dev/null 2>&1; then
            echo "run-target: probe-rs not found; install it with: cargo install probe-rs-tools --locked" >&2
            exit 127
        fi
        exec probe-rs run --chip "${PROBE_RS_CHIP:-STM32F405RGTx}" "$@" "$elf"
        ;;
    *)
        echo "run-target: do not know where to run $elf (expected imu-ident-qemu, imu-ident-nav-qemu, imu-ident-board or imu-ident-nav-board)" >&2
        exit 2
        ;;
esac
