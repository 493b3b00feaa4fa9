//! The classifier pipeline: the labeller that makes ground-truth labels from the simulator, the
//! scan dataset, the float reference model and its quantiser, and the training of both networks
//! (`LabelPoseNet` and the geometric classifier; `--features train`). Nothing here runs on the
//! robot: it produces the int8 blobs the core loads.

pub mod dataset;
pub mod labeller;
pub mod model;
#[cfg(feature = "train")]
pub mod train;
#[cfg(feature = "train")]
pub mod train_geo;

/// Adds the tally `other` into `counts`, cell by cell.
pub(crate) fn add_counts<const R: usize, const C: usize>(counts: &mut [[u64; C]; R], other: &[[u64; C]; R]) {
    for (row, o) in counts.iter_mut().zip(other) {
        for (c, o) in row.iter_mut().zip(o) {
            *c += o;
        }
    }
}
