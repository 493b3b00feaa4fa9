#!/usr/bin/env bash
# The whole test suite: host tests (all crates), the Cortex-M build of the no_std core, and the
# MCU images under QEMU (docs/mcu.md).
# Sets up what it needs (the thumbv7em-none-eabihf target, qemu-system-arm) or says exactly what is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

TARGET=thumbv7em-none-eabihf
say() { printf '\n== %s\n' "$*"; }

need() {
    command -v "$1" >/dev/null 2>&1 || { echo "missing: $1 ($2)" >&2; exit 2; }
}
need cargo "install Rust with rustup: https://rustup.rs"

say "Cortex-M target ($TARGET)"
if rustup target list --installed 2>/dev/null | grep -qx "$TARGET"; then
    echo "installed"
elif command -v rustup >/dev/null 2>&1 && rustup target add "$TARGET"; then
    echo "installed now"
else
    cat >&2 <<MSG
missing: the Rust standard library for $TARGET.
  With rustup:  rustup target add $TARGET
  Without it (Debian 12): apt-get install -y rustc-web cargo-web rust-web-src lld, then
  RUSTC_BOOTSTRAP=1 /usr/bin/cargo build --release --target $TARGET -Zbuild-std=core -p firmware
MSG
    exit 2
fi

say "Python packages: mcap readers (tests/python/check_mcap.py reads run recordings back, check_ros2_bag.py decodes exported bags), cyclonedds (the independent ROS 2 peer of tests/tests/ros2.rs)"
PYMCAP=target/py-mcap
if "$PYMCAP/bin/python" -c "import mcap, mcap_ros2, cyclonedds" 2>/dev/null; then
    echo "installed ($PYMCAP)"
else
    need python3 "apt-get install -y python3 python3-venv (Debian/Ubuntu)"
    if ! python3 -m venv "$PYMCAP" >/dev/null 2>&1; then
        rm -rf "$PYMCAP"
        if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
            echo "installing python3-venv (apt-get)"
            apt-get update -qq && apt-get install -y -qq python3-venv >/dev/null
        fi
        python3 -m venv "$PYMCAP" >/dev/null || { echo "missing: python3-venv (apt-get install -y python3-venv)" >&2; exit 2; }
    fi
    "$PYMCAP/bin/python" -m pip install -q --disable-pip-version-check mcap mcap-ros2-support cyclonedds==11.0.1 \
        || { echo "missing: the PyPI packages mcap, mcap-ros2-support and cyclonedds ($PYMCAP/bin/python -m pip install mcap mcap-ros2-support cyclonedds==11.0.1 failed)" >&2; exit 2; }
    echo "installed now ($PYMCAP)"
fi
export LIVES_PYTHON="$PWD/$PYMCAP/bin/python"

say "host tests (cargo test --workspace --release)"
cargo test --workspace --release

say "training pipeline (host built with --features train: candle), and the bag errors of a build without ros-bags"
cargo test --release -p host --features train --lib -- train replay::rosbag

say "no_std core for $TARGET (firmware, fixed_point)"
cargo build --release --target "$TARGET" -p fixed_point -p firmware
# The core must not link an allocator or std: the build above fails if it does (no_std target).
echo "ok: firmware and fixed_point build for $TARGET"

say "MCU under QEMU (mps2-an386): golden trace, stage budgets, memory, faults, SMLAD, end to end"
if ! command -v qemu-system-arm >/dev/null 2>&1; then
    if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
        echo "installing qemu-system-arm (apt-get)"
        apt-get update -qq && apt-get install -y -qq qemu-system-arm >/dev/null
    elif command -v apt-get >/dev/null 2>&1 && command -v sudo >/dev/null 2>&1; then
        echo "installing qemu-system-arm (sudo apt-get)"
        sudo apt-get update -qq && sudo apt-get install -y -qq qemu-system-arm >/dev/null
    fi
fi
need qemu-system-arm "apt-get install -y qemu-system-arm (Debian/Ubuntu), or your distribution's QEMU Arm system emulator"
qemu-system-arm --version | head -1
# The images: mcu-node (real time), mcu-lockstep, mcu-trace and mcu-trace-live (the golden and known-map traces + timing), mcu-selftest.
cargo build --profile mcu --target "$TARGET" -p firmware --features mcu --bins
LIVES_MCU_DIR="${CARGO_TARGET_DIR:-target}/$TARGET/mcu"
case "$LIVES_MCU_DIR" in /*) ;; *) LIVES_MCU_DIR="$PWD/$LIVES_MCU_DIR" ;; esac
export LIVES_MCU_DIR
# The memory report (static RAM and flash of each image against memory.x), the per-stage
# instruction counts against firmware/mcu-budgets.toml, and the rest (tests/tests/mcu.rs).
cargo test --release -p lives-tests --test mcu -- --ignored --nocapture --test-threads 2

say "all tests passed"
