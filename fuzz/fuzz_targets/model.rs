//! `cargo fuzz run model`: see host::fuzz and docs/reliability.md.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    host::fuzz::run("model", data);
});
