//! `cargo fuzz run map`: see host::measure::fuzz and docs/reliability.md.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    host::measure::fuzz::run("map", data);
});
