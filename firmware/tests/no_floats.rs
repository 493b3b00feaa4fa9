//! The core decides with integers and fixed point only: no `f32`/`f64` in `firmware/src`
//! (code, not comments). Floats stay at the host boundary (see docs/architecture.md).

#[test]
fn firmware_sources_use_no_floats() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/src");
    let mut checked = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "rs") {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        for (n, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            for word in code.split(|c: char| !c.is_alphanumeric() && c != '_') {
                assert!(word != "f32" && word != "f64", "{}:{}: float in the core: {line}", path.display(), n + 1);
            }
        }
        checked += 1;
    }
    assert!(checked >= 8, "expected the core's modules in {dir}");
}
