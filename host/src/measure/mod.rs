//! Measuring the controller: the evaluation table and the tuning search (`eval`), benchmarks
//! (`bench`), map and pose scores (`mapcheck`), the soak (`soak`), the fuzz targets (`fuzz`) and
//! the golden trace (`trace`).

pub mod bench;
pub mod eval;
pub mod fuzz;
pub mod mapcheck;
pub mod soak;
pub mod trace;
