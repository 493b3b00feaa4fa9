//! `cargo fuzz run ros1bag`: see host::measure::fuzz and docs/reliability.md.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    host::measure::fuzz::run("ros1bag", data);
});
