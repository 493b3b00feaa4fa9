//! The short, deterministic fuzz campaign (issue 29; `docs/reliability.md`): every committed
//! input of `fuzz/corpus/<target>/` (seeds from the real fixtures, and every input a long
//! campaign found a crash with), then a fixed number of seeded mutations of them, through the
//! same functions the coverage-guided targets in `fuzz/` call (`host::measure::fuzz`). No nightly
//! toolchain; the same bytes on every run. A panic names the target, the input and the
//! mutation, and writes the failing bytes to `target/fuzz-failures/` for `cargo fuzz run`.

use host::measure::fuzz::{run, Mutator, TARGETS};
use std::path::PathBuf;

/// The repository's root.
fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Mutations per target (after the corpus itself).
const MUTATIONS: usize = 20_000;
/// Inputs longer than this are cut for mutation (the corpus holds small files only).
const MAX_LEN: usize = 64 * 1024;

fn corpus(target: &str) -> Vec<(String, Vec<u8>)> {
    let dir = root().join("fuzz/corpus").join(target);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files.into_iter().map(|p| (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap())).collect()
}

fn keep_failure(target: &str, what: &str, data: &[u8]) -> PathBuf {
    let dir = root().join("target/fuzz-failures").join(target);
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(what.replace(['/', ' '], "_"));
    std::fs::write(&path, data).unwrap();
    path
}

fn campaign(target: &str) -> usize {
    let inputs = corpus(target);
    assert!(!inputs.is_empty(), "fuzz/corpus/{target}/ is empty");
    let check = |what: &str, data: &[u8]| {
        if let Err(e) = std::panic::catch_unwind(|| run(target, data)) {
            let path = keep_failure(target, what, data);
            let msg = e.downcast_ref::<String>().cloned().or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()));
            panic!("fuzz target {target}: {what} ({} bytes, kept as {}) panicked: {msg:?}", data.len(), path.display());
        }
    };
    for (name, data) in &inputs {
        check(name, data);
    }
    let mut m = Mutator::new(0x1175_2026 ^ target.len() as u64 ^ (target.as_bytes()[0] as u64) << 32);
    for k in 0..MUTATIONS {
        let (name, a) = &inputs[k % inputs.len()];
        let (_, b) = &inputs[(k * 7 + 3) % inputs.len()];
        let data = m.mutate(&a[..a.len().min(MAX_LEN)], &b[..b.len().min(MAX_LEN)]);
        check(&format!("mutation {k} of {name}"), &data);
    }
    inputs.len() + MUTATIONS
}

#[test]
fn every_target_has_a_corpus_and_a_libfuzzer_binary() {
    for t in TARGETS {
        assert!(!corpus(t).is_empty(), "{t}");
        let bin = root().join("fuzz/fuzz_targets").join(format!("{t}.rs"));
        let text = std::fs::read_to_string(&bin).unwrap_or_else(|e| panic!("{}: {e}", bin.display()));
        assert!(text.contains(&format!("host::measure::fuzz::run(\"{t}\", data)")), "{}", bin.display());
    }
}

macro_rules! campaigns {
    ($($t:ident),*) => {$(
        #[test]
        fn $t() {
            let n = campaign(stringify!($t));
            assert!(n > MUTATIONS);
        }
    )*
    #[test]
    fn the_list_is_every_target() {
        assert_eq!(TARGETS, &[$(stringify!($t)),*]);
    }
    };
}

campaigns!(frames_to_core, frames_to_host, world, carmen, vlp16, pcap, mcap, sqlite, ros1bag, cdr, model, adapter, map);
