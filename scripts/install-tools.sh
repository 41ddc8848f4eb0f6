#!/usr/bin/env bash
# Installs what scripts/test.sh needs, and only what is missing (safe to run every time).
#
#   - the Cortex-M4F target for rustup's toolchain (thumbv7em-none-eabihf; rust-lld comes with
#     the toolchain, so nothing else is needed to link)
#   - clippy and rustfmt
#   - QEMU for the emulated board (Debian's qemu-system-arm), through apt
#   - `size` for the firmware sizes (Debian's binutils), through apt, unless llvm-size or size
#     is already there
#   - RTKLIB's command-line tools (Debian's rtklib: pos2kml reads the solution.pos files that
#     hal-sim writes, in hal-sim/tests/nav_io_real.rs), through apt
#   - Python 3 with venv (Debian's python3, python3-venv) for the Python package's tests
#   - Chromium (Debian's chromium) for the headless check of the HTML report
#     (hal-sim/tests/report_browser.rs)
#
# Needs rustup on PATH. apt runs as root here; elsewhere through sudo if it exists.
set -euo pipefail

TARGET=thumbv7em-none-eabihf

if ! command -v rustup >/dev/null 2>&1; then
    echo "install-tools: rustup is required (https://rustup.rs)" >&2
    exit 1
fi

if rustup target list --installed | grep -qx "$TARGET"; then
    echo "install-tools: target $TARGET present"
else
    rustup target add "$TARGET"
fi

for component in clippy rustfmt; do
    if rustup component list --installed | grep -q "^${component}-"; then
        echo "install-tools: $component present"
    else
        rustup component add "$component"
    fi
done

# Debian packages: QEMU for the emulated board, and binutils' `size` for the firmware sizes
# (skipped when LLVM's llvm-size is there instead).
packages=()
if command -v qemu-system-arm >/dev/null 2>&1; then
    echo "install-tools: $(qemu-system-arm --version | head -n 1)"
else
    packages+=(qemu-system-arm)
fi
if command -v llvm-size >/dev/null 2>&1 || command -v size >/dev/null 2>&1; then
    echo "install-tools: size present"
else
    packages+=(binutils)
fi
if command -v pos2kml >/dev/null 2>&1; then
    echo "install-tools: RTKLIB pos2kml present"
else
    packages+=(rtklib)
fi
# The Python package (python/) is built and tested in a venv: python3 with venv and ensurepip.
if command -v python3 >/dev/null 2>&1 && python3 -c 'import venv, ensurepip' >/dev/null 2>&1; then
    echo "install-tools: $(python3 --version) with venv present"
else
    packages+=(python3 python3-venv)
fi
if command -v chromium >/dev/null 2>&1; then
    echo "install-tools: chromium present"
else
    packages+=(chromium)
fi
if [ "${#packages[@]}" -gt 0 ]; then
    sudo=""
    if [ "$(id -u)" -ne 0 ]; then
        sudo="sudo"
    fi
    $sudo apt-get update
    $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "${packages[@]}"
fi
