//! The core decides with integers and fixed point only: no `f32`/`f64` in `firmware/src`
//! (code, not comments). Floats stay at the host boundary (see docs/architecture.md).

fn rust_files(dir: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn firmware_sources_use_no_floats() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/src");
    let mut files = Vec::new();
    rust_files(std::path::Path::new(dir), &mut files);
    let mut checked = 0;
    for path in files {
        let text = std::fs::read_to_string(&path).unwrap();
        for (n, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            for word in code.split(|c: char| !c.is_alphanumeric() && c != '_') {
                assert!(word != "f32" && word != "f64", "{}:{}: float in the core: {line}", path.display(), n + 1);
            }
        }
        checked += 1;
    }
    assert!(checked >= 12, "expected the core's modules (and the classifier's) in {dir}: {checked}");
}
