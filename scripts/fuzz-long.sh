#!/usr/bin/env bash
# The long, coverage-guided fuzz campaign (docs/reliability.md): each target of fuzz/ under
# libFuzzer (`cargo +nightly fuzz`), one at a time, niced, for SECONDS each (default 600).
#
#   scripts/fuzz-long.sh [SECONDS] [TARGET...]      (all targets when none is named)
#   FUZZ_RUNS=10000000 scripts/fuzz-long.sh 0 TARGET...   (a number of inputs instead of a time)
#   TRACE_COMPARES=0 scripts/fuzz-long.sh ...   (no comparison tracing: about 3x the inputs per
#                                                second on frames_to_core, coarser guidance)
#
# Needs the nightly toolchain and cargo-fuzz (installed here when missing). Works on a copy of the
# committed corpus (fuzz/corpus-run/, not committed) so new inputs do not pile up in git; a crash
# is kept in fuzz/artifacts/TARGET/ — minimise it, add it to fuzz/corpus/TARGET/, fix, commit.
# Prints one line per target (inputs run, coverage, time, crashes) and appends it to
# target/fuzz-logs/summary.tsv; the full libFuzzer log is target/fuzz-logs/TARGET.log.
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_EACH="${1:-600}"
shift || true
ALL=(frames_to_core frames_to_host world carmen vlp16 pcap mcap sqlite ros1bag cdr model adapter)
TARGETS=("$@")
[ ${#TARGETS[@]} -eq 0 ] && TARGETS=("${ALL[@]}")

rustup toolchain list | grep -q '^nightly' || rustup toolchain install nightly --profile minimal
command -v cargo-fuzz >/dev/null 2>&1 || cargo install cargo-fuzz --locked

ROOT="$PWD"
TDIR="${CARGO_TARGET_DIR:-$ROOT/target}/fuzz"
LOGS="$ROOT/target/fuzz-logs"
mkdir -p "$LOGS"
# No sanitizer: about twice the inputs per second of AddressSanitizer; the Rust code is memory
# safe, and what the campaign looks for is panics, aborts, hangs and memory use (-rss_limit_mb).
TC=()
[ "${TRACE_COMPARES:-1}" = 0 ] && { TC=(--no-trace-compares); TDIR="$TDIR-notc"; }
(cd fuzz && CARGO_BUILD_JOBS=2 nice -n 19 cargo +nightly fuzz build -s none --release "${TC[@]}" --target-dir "$TDIR")
BIN="$TDIR/x86_64-unknown-linux-gnu/release"
for t in "${TARGETS[@]}"; do
    work="fuzz/corpus-run/$t"
    mkdir -p "$work" "fuzz/artifacts/$t"
    cp -n fuzz/corpus/"$t"/* "$work"/ 2>/dev/null || true
    log="$LOGS/$t.log"
    start=$(date +%s)
    set +e
    limit=(-max_total_time="$SECONDS_EACH")
    [ -n "${FUZZ_RUNS:-}" ] && limit=(-runs="$FUZZ_RUNS")
    nice -n 19 "$BIN/$t" "$work" "${limit[@]}" -timeout=5 -rss_limit_mb=2048 -max_len=65536 \
        -print_final_stats=1 -artifact_prefix="fuzz/artifacts/$t/" >"$log" 2>&1
    rc=$?
    set -e
    took=$(( $(date +%s) - start ))
    runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
    cov=$(grep -o 'cov: [0-9]* ft: [0-9]*' "$log" | tail -1)
    crashes=$(ls "fuzz/artifacts/$t" | wc -l)
    line="$t	inputs=${runs:-?}	${cov:-cov: ?}	${took}s	exit=$rc	artifacts=$crashes	$(date -u +%FT%TZ)"
    echo "$line"
    echo "$line" >>"$LOGS/summary.tsv"
done
