//! Checkpoints: safetensors with the `FloatModel` fields and the training log in the metadata.

use super::*;
use crate::learn::model::FloatModel;
use firmware::capacity::BEAMS;
use firmware::classifier::{Normalisation, RangeEncoding, ENC_KERNEL, HISTORY, POSE_CHANNELS, POSE_FEATURES, POSE_FLAT};
use std::collections::HashMap;
use std::path::Path;

/// The checkpoint's tensors: name, PyTorch shape, values.
pub(super) fn checkpoint_tensors(m: &FloatModel) -> Vec<(String, Vec<usize>, &[f32])> {
    let k = ENC_KERNEL;
    let mut v: Vec<(String, Vec<usize>, &[f32])> = Vec::new();
    for (name, e) in [("scan", &m.scan), ("label", &m.label)] {
        v.push((format!("{name}.conv_w"), vec![1, 1, HISTORY, k], &e.conv_w));
        v.push((format!("{name}.conv_b"), vec![1], std::slice::from_ref(&e.conv_b)));
        v.push((format!("{name}.fc_w"), vec![BEAMS, BEAMS], &e.fc_w));
        v.push((format!("{name}.fc_b"), vec![BEAMS], &e.fc_b));
    }
    v.push(("pose.conv_w".into(), vec![POSE_CHANNELS, 1, 1, POSE_FEATURES], &m.pose.conv_w));
    v.push(("pose.conv_b".into(), vec![POSE_CHANNELS], &m.pose.conv_b));
    v.push(("pose.fc_w".into(), vec![BEAMS, POSE_FLAT], &m.pose.fc_w));
    v.push(("pose.fc_b".into(), vec![BEAMS], &m.pose.fc_b));
    v
}

/// Writes `m` as safetensors (f32, little-endian; names are the [`FloatModel`] fields, shapes
/// PyTorch's: `scan.conv_w` `[1, 1, 9, 9]`, `scan.fc_w` `[897, 897]`, `pose.conv_w`
/// `[9, 1, 1, 3]`, `pose.fc_w` `[897, 81]`, …). Metadata: `format`, `range_max_mm`,
/// `pose_scale_mm`, and the training log as JSON under `train_log` when given.
pub fn save_checkpoint(m: &FloatModel, log: Option<&TrainLog>, path: &Path) -> Result<()> {
    let tensors = checkpoint_tensors(m);
    let bytes: Vec<Vec<u8>> = tensors.iter().map(|(_, _, v)| v.iter().flat_map(|x| x.to_le_bytes()).collect()).collect();
    let mut views = Vec::new();
    for ((name, shape, _), b) in tensors.iter().zip(&bytes) {
        views.push((name.clone(), safetensors::tensor::TensorView::new(safetensors::Dtype::F32, shape.clone(), b)?));
    }
    let mut meta = HashMap::new();
    meta.insert("format".to_string(), CHECKPOINT_FORMAT.to_string());
    meta.insert("range_max_mm".to_string(), m.norm.range_max_mm.to_string());
    meta.insert("pose_scale_mm".to_string(), m.norm.pose_scale_mm.to_string());
    meta.insert(
        "range_encoding".to_string(),
        match m.norm.range_encoding {
            RangeEncoding::Linear => "linear",
            RangeEncoding::Inverse => "inverse",
        }
        .to_string(),
    );
    if let Some(l) = log {
        meta.insert("train_log".to_string(), serde_json::to_string(l).map_err(|e| TrainError(e.to_string()))?);
    }
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    safetensors::serialize_to_file(views, Some(meta), path)?;
    Ok(())
}

/// Reads a checkpoint written by [`save_checkpoint`]: the model and, if stored, the training log.
pub fn load_checkpoint(path: &Path) -> Result<(FloatModel, Option<TrainLog>)> {
    let bytes = std::fs::read(path).map_err(|e| TrainError(format!("{}: {e}", path.display())))?;
    let (_, header) = safetensors::SafeTensors::read_metadata(&bytes)?;
    let meta = header.metadata().clone().unwrap_or_default();
    if meta.get("format").map(String::as_str) != Some(CHECKPOINT_FORMAT) {
        return Err(TrainError(format!("{}: not a {CHECKPOINT_FORMAT} checkpoint", path.display())));
    }
    let num = |k: &str| -> Result<u32> {
        meta.get(k).and_then(|v| v.parse().ok()).ok_or_else(|| TrainError(format!("{}: metadata `{k}` missing", path.display())))
    };
    let range_encoding = match meta.get("range_encoding").map(String::as_str) {
        None | Some("linear") => RangeEncoding::Linear,
        Some("inverse") => RangeEncoding::Inverse,
        Some(other) => return Err(TrainError(format!("{}: unknown range_encoding `{other}`", path.display()))),
    };
    let range_max_mm =
        u16::try_from(num("range_max_mm")?).map_err(|_| TrainError(format!("{}: range_max_mm out of range", path.display())))?;
    let norm = Normalisation { range_max_mm, pose_scale_mm: num("pose_scale_mm")?, range_encoding };
    let st = safetensors::SafeTensors::deserialize(&bytes)?;
    let mut m = FloatModel::random(0);
    m.norm = norm;
    let names: Vec<(String, Vec<usize>)> = checkpoint_tensors(&m).into_iter().map(|(n, s, _)| (n, s)).collect();
    let read = |name: &str, shape: &[usize]| -> Result<Vec<f32>> {
        let t = st.tensor(name)?;
        if t.dtype() != safetensors::Dtype::F32 || t.shape() != shape {
            return Err(TrainError(format!(
                "{}: tensor {name} is {:?} {:?}, expected F32 {shape:?}",
                path.display(),
                t.dtype(),
                t.shape()
            )));
        }
        Ok(t.data().chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect())
    };
    let mut get = |i: usize| read(&names[i].0, &names[i].1);
    let enc = |get: &mut dyn FnMut(usize) -> Result<Vec<f32>>, o: usize| -> Result<crate::learn::model::Encoder> {
        Ok(crate::learn::model::Encoder { conv_w: get(o)?, conv_b: get(o + 1)?[0], fc_w: get(o + 2)?, fc_b: get(o + 3)? })
    };
    m.scan = enc(&mut get, 0)?;
    m.label = enc(&mut get, 4)?;
    m.pose = crate::learn::model::PoseEncoder { conv_w: get(8)?, conv_b: get(9)?, fc_w: get(10)?, fc_b: get(11)? };
    let log = match meta.get("train_log") {
        Some(s) => Some(serde_json::from_str(s).map_err(|e| TrainError(format!("{}: train_log: {e}", path.display())))?),
        None => None,
    };
    Ok((m, log))
}
