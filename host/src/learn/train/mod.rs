//! Training, evaluation and quantisation of the map-free scan classifier (`LabelPoseNet`,
//! METHOD.md §1.2) on the scan dataset (`docs/dataset.md`).
//!
//! - [`LabelPoseNet`]: the network in `candle` (CPU), its parameters one-to-one with
//!   [`FloatModel`]'s fields ([`LabelPoseNet::from_float`], [`LabelPoseNet::to_float`]); its forward
//!   pass equals [`FloatModel::forward`] (a test checks it to 1e-5).
//! - Samples ([`Episode`], [`fill_sample`]): for each record with k − 1 = 8 predecessors in its
//!   episode, the 9 scans (normalised exactly as the firmware does from millimetres), the 9 poses
//!   relative to the newest, and the 8 earlier label rows as ±1 (map +1, STF/DF −1, none 0), 10 % of
//!   them sign-flipped in training; the target is the newest record's labels as ±1, label-0 beams
//!   masked out of the MSE loss.
//! - [`train`]: Adam (AdamW with weight decay 0), lr 1e-3, seeded init (PyTorch's default
//!   initialisation), shuffling and flips — deterministic for a given seed and thread count.
//!   Beyond the paper's recipe (teacher forcing with 10 % flips), by default: samples for the first
//!   k − 1 steps with the run-time zero bootstrap, 50 % of label histories taken from the model's
//!   own autoregressive rollout (refreshed every epoch) and 5 % all-zero histories. Teacher
//!   forcing alone learns to copy the label history: 85–87 % teacher-forced, but run
//!   autoregressively from the zero bootstrap it locks into one class (measured: 34 %).
//! - Evaluation ([`evaluate_teacher_forced`], [`evaluate_float_autoregressive`],
//!   [`evaluate_int8`]): per-point accuracy (sign agreement with the labeller over labelled beams),
//!   teacher-forced and autoregressive (own outputs fed back, zero bootstrap, as at run time), and
//!   for the int8 blob through `firmware::classifier::Classifier`.
//! - Checkpoints ([`save_checkpoint`], [`load_checkpoint`]): safetensors, tensor names
//!   `scan.conv_w`, `scan.conv_b`, `scan.fc_w`, `scan.fc_b`, `label.*`, `pose.*` (the
//!   [`FloatModel`] fields) in PyTorch's shapes, the normalisation and the training log in the
//!   metadata.
//! - [`quantise_and_evaluate`]: checkpoint → calibrated int8 blob → accuracies on the validation
//!   split and in the built-in (unseen) worlds ([`unseen_episodes`]) → `docs/model-card.md`
//!   ([`model_card`]).

use crate::learn::dataset;
use std::fmt;

mod accuracy;
mod card;
mod checkpoint;
mod data;
mod fit;
mod net;
mod quantise;
mod unseen;
pub use accuracy::*;
pub use card::*;
pub use checkpoint::*;
pub use data::*;
pub use fit::*;
pub use net::*;
pub use quantise::*;
pub use unseen::*;

/// Default training epochs on this 2-core CPU (see [`TrainConfig::default`]).
pub const DEFAULT_EPOCHS: usize = 10;
/// Default batch size on CPU (the paper: 4096 on a GPU).
pub const DEFAULT_BATCH: usize = 256;
/// Where `lives quantise` writes the blob by default.
pub const DEFAULT_BLOB_PATH: &str = "firmware/model/lives-int8.bin";
/// Where `lives train` writes the float checkpoint by default.
pub const DEFAULT_CHECKPOINT_PATH: &str = "out/lives-f32.safetensors";
/// Where `lives quantise` writes the model card by default.
pub const DEFAULT_CARD_PATH: &str = "docs/model-card.md";
/// The `format` value in a checkpoint's metadata.
pub const CHECKPOINT_FORMAT: &str = "lives-labelposenet-f32";

/// Anything that can go wrong here, as a message.
#[derive(Debug)]
pub struct TrainError(pub String);

impl fmt::Display for TrainError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for TrainError {}

impl From<candle_core::Error> for TrainError {
    fn from(e: candle_core::Error) -> Self {
        TrainError(format!("candle: {e}"))
    }
}

impl From<dataset::DatasetError> for TrainError {
    fn from(e: dataset::DatasetError) -> Self {
        TrainError(format!("dataset: {e}"))
    }
}

impl From<safetensors::SafeTensorError> for TrainError {
    fn from(e: safetensors::SafeTensorError) -> Self {
        TrainError(format!("safetensors: {e}"))
    }
}

impl From<std::io::Error> for TrainError {
    fn from(e: std::io::Error) -> Self {
        TrainError(format!("io: {e}"))
    }
}

/// Result with a [`TrainError`].
pub type Result<T> = std::result::Result<T, TrainError>;

#[cfg(test)]
mod tests;
