//! The core's static memory, as tabulated in `docs/architecture.md` ("Memory budget"). If a
//! capacity changes, this test fails until the table is updated with the new figures.

use firmware::grid::{LidarGrid, VisualGrid};
use firmware::scan::BeamScan;
use firmware::{Controller, FrontierSet, NonMapStore, Planner};
use std::mem::size_of;

#[test]
fn static_memory_matches_the_documented_budget() {
    let sizes = [
        ("LidarGrid", size_of::<LidarGrid>()),
        ("VisualGrid", size_of::<VisualGrid>()),
        ("NonMapStore", size_of::<NonMapStore>()),
        ("FrontierSet", size_of::<FrontierSet>()),
        ("Planner", size_of::<Planner>()),
        ("BeamScan", size_of::<BeamScan>()),
        ("Classifier", size_of::<firmware::classifier::Classifier<'static>>()),
        ("ScanMatcher", size_of::<firmware::matcher::ScanMatcher>()),
        ("KnownMap", size_of::<firmware::knownmap::KnownMap>()),
        ("WindowMemory", size_of::<firmware::rolling::memory::WindowMemory>()),
        ("Controller", size_of::<Controller>()),
    ];
    for (name, bytes) in sizes {
        println!("| `{name}` | {bytes} |");
    }
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/architecture.md")).expect("docs/architecture.md");
    for (name, bytes) in sizes {
        let row = format!("| `{name}` | {bytes} |");
        assert!(doc.contains(&row), "docs/architecture.md lacks the row `{row}` (update the memory table)");
    }
    // The whole core fits the QEMU board's 4 MiB RAM with room for stack and link buffers.
    assert!(size_of::<Controller>() < 2 * 1024 * 1024);
}
