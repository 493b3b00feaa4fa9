//! Classifier blobs from files: `--model FILE` read, bounded and checked as the firmware will
//! check it before anything runs, and the default when none is given (docs/model-format.md).

/// The largest classifier blob `--model` reads: 4 MiB, more than twice `LabelPoseNet`'s
/// (1 716 408 bytes; the geometric model is 2 076).
pub const MAX_BLOB_BYTES: u64 = 4 << 20;

/// Reads a classifier blob of either format (docs/model-format.md) for a `--model FILE` option
/// and checks it as the firmware will (`firmware::Controller::set_model`), so a bad file is a
/// clear error before anything runs. The bytes live for the rest of the process, as the models
/// embedded in the firmware do.
pub fn read_blob(path: &std::path::Path) -> Result<&'static [u8], String> {
    let bytes = crate::sim::read_at_most(path, MAX_BLOB_BYTES)
        .map_err(|e| format!("{}: {e}", path.display()))?
        .ok_or_else(|| format!("{}: larger than any classifier blob ({MAX_BLOB_BYTES} bytes at most)", path.display()))?;
    validate_blob(&bytes).map_err(|e| format!("{}: the model does not validate: {e}", path.display()))?;
    Ok(Box::leak(bytes.into_boxed_slice()))
}

/// The classifier a command runs for `--model FILE` and its "none" flag (`--no-model`,
/// `--no-classifier`): `None` for none, the file's blob ([`read_blob`]) if given, else the
/// committed geometric classifier, the default everywhere the controller labels scans itself.
pub fn model_option(path: Option<&std::path::Path>, none: bool) -> Result<Option<&'static [u8]>, String> {
    match (path, none) {
        (_, true) => Ok(None),
        (Some(path), false) => read_blob(path).map(Some),
        (None, false) => Ok(Some(firmware::classifier::EMBEDDED_GEO_MODEL)),
    }
}

/// `Ok` if `blob` is a classifier the firmware accepts, geometric or `LabelPoseNet`.
pub fn validate_blob(blob: &[u8]) -> Result<(), firmware::classifier::ModelError> {
    use firmware::classifier::{geo::GeoView, ModelView};
    if GeoView::is_geo(blob) {
        GeoView::parse(blob).map(|_| ())
    } else {
        ModelView::parse(blob).map(|_| ())
    }
}
