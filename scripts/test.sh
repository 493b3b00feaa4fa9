#!/usr/bin/env bash
# The whole test suite: host tests (all crates), the Cortex-M build of the no_std core.
# Sets up what it needs (the thumbv7em-none-eabihf target) or says exactly what is missing.
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

say "host tests (cargo test --workspace --release)"
cargo test --workspace --release

say "training pipeline (host built with --features train: candle)"
cargo test --release -p host --features train --lib train

say "no_std core for $TARGET (firmware, fixed_point)"
cargo build --release --target "$TARGET" -p fixed_point -p firmware
# The core must not link an allocator or std: the build above fails if it does (no_std target).
echo "ok: firmware and fixed_point build for $TARGET"

say "all tests passed"
