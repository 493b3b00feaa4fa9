//! Quantisation and evaluation: checkpoint → calibrated int8 blob → accuracies → model card.

use super::*;
use crate::learn::dataset::Split;
use crate::learn::model::{quantise_with, FloatHistory, FloatInputs, FloatModel, QuantiseOptions};
use candle_core::Device;
use firmware::capacity::BEAMS;
use firmware::classifier::{Classifier, ClassifierConfig, LabelFeedback, ModelView};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::time::Instant;

/// Calibration inputs: the float model run autoregressively (raw feedback, as the firmware) over
/// `episodes`, keeping every `stride`-th step's inputs, at most `max` of them.
pub fn calibration_inputs(model: &FloatModel, episodes: &[Episode], stride: usize, max: usize) -> Vec<FloatInputs> {
    let mut out = Vec::new();
    for ep in episodes {
        let mut h = FloatHistory::new(model.norm);
        for (i, st) in ep.steps.iter().enumerate() {
            if out.len() >= max {
                return out;
            }
            h.push_scan(&st.pose, &st.ranges_mm);
            let x = h.inputs();
            let y = model.forward(&x);
            if i % stride.max(1) == stride.max(1) - 1 {
                out.push(x);
            }
            h.push_labels(&y);
        }
    }
    out
}

/// Settings of [`quantise_and_evaluate`].
#[derive(Clone, Debug)]
pub struct QuantiseConfig {
    /// The float checkpoint.
    pub checkpoint: PathBuf,
    /// A second checkpoint trained without the label history, for the ablation (optional).
    pub ablation: Option<PathBuf>,
    /// The dataset (its validation split calibrates and evaluates); default: the one the
    /// checkpoint was trained on.
    pub data: Option<PathBuf>,
    /// Where to write the blob.
    pub out: PathBuf,
    /// Where to write the model card (`None`: no card).
    pub card: Option<PathBuf>,
    /// Calibration inputs (autoregressive validation steps).
    pub calibration: usize,
    /// Seconds of random walk per built-in world and scenario for the unseen-world evaluation
    /// (0: skip it).
    pub unseen_seconds: f64,
    /// The command line, for the card.
    pub command: String,
    /// Markdown appended to the card under "Notes" (e.g. other runs for comparison).
    pub notes: Option<String>,
}

impl QuantiseConfig {
    /// Defaults: blob at [`DEFAULT_BLOB_PATH`], card at [`DEFAULT_CARD_PATH`], 256 calibration
    /// inputs, 60 s per unseen world and scenario.
    pub fn new(checkpoint: impl Into<PathBuf>) -> Self {
        Self {
            checkpoint: checkpoint.into(),
            ablation: None,
            data: None,
            out: DEFAULT_BLOB_PATH.into(),
            card: Some(DEFAULT_CARD_PATH.into()),
            calibration: 256,
            unseen_seconds: 60.0,
            command: String::new(),
            notes: None,
        }
    }
}

/// Accuracies of one model on one set of episodes.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct SetEval {
    /// Episodes, steps.
    pub episodes: usize,
    /// Steps.
    pub steps: usize,
    /// Float, teacher-forced (true label history), steps with 8 predecessors.
    pub float_teacher_forced: Confusion,
    /// Float, label inputs zeroed (teacher-forced samples).
    pub float_zero_labels: Confusion,
    /// Float, autoregressive, raw feedback.
    pub float_ar_raw: ArAccuracy,
    /// Float, autoregressive, sign feedback.
    pub float_ar_sign: ArAccuracy,
    /// int8 blob in the firmware classifier, raw feedback (the firmware's default).
    pub int8_ar_raw: ArAccuracy,
    /// int8, sign feedback.
    pub int8_ar_sign: ArAccuracy,
    /// int8 (raw feedback) against float (raw feedback), both autoregressive, each on its own
    /// fed-back outputs: `accuracy()` is the fraction of labelled beams where their signs agree.
    #[serde(default)]
    pub int8_float_agreement: ArAccuracy,
}

/// Evaluates a float model and its blob on `episodes`.
pub fn evaluate_set(model: &FloatModel, blob: &[u8], episodes: &[Episode]) -> Result<SetEval> {
    let net = LabelPoseNet::from_float(model, &Device::Cpu)?;
    Ok(SetEval {
        episodes: episodes.len(),
        steps: episodes.iter().map(|e| e.steps.len()).sum(),
        float_teacher_forced: evaluate_teacher_forced(&net, episodes, false, 512)?,
        float_zero_labels: evaluate_teacher_forced(&net, episodes, true, 512)?,
        float_ar_raw: evaluate_float_autoregressive(model, episodes, Feedback::Raw),
        float_ar_sign: evaluate_float_autoregressive(model, episodes, Feedback::Sign),
        int8_ar_raw: evaluate_int8(blob, episodes, LabelFeedback::Raw)?,
        int8_ar_sign: evaluate_int8(blob, episodes, LabelFeedback::Sign)?,
        int8_float_agreement: int8_float_agreement(model, blob, episodes)?,
    })
}

/// Per-point sign agreement of the int8 blob (firmware classifier, raw feedback) with the float
/// model (raw feedback), both run autoregressively over `episodes` from the zero bootstrap, each fed
/// its own outputs — as they would run on the robot. Counted over beams the labeller labelled;
/// `accuracy()` of the result is the agreement (the float model's sign plays the label).
pub fn int8_float_agreement(model: &FloatModel, blob: &[u8], episodes: &[Episode]) -> Result<ArAccuracy> {
    let view = ModelView::parse(blob).map_err(|e| TrainError(format!("the firmware refuses the blob: {e:?}")))?;
    Ok(par_episodes(episodes, |ep| {
        let mut c = Box::new(Classifier::with_model(view, ClassifierConfig { feedback: LabelFeedback::Raw }));
        let mut h = FloatHistory::new(model.norm);
        let mut acc = ArAccuracy::default();
        let mut out = Box::new([firmware::scan::BeamLabel::Unlabelled; BEAMS]);
        for (i, st) in ep.steps.iter().enumerate() {
            h.push_scan(&st.pose, &st.ranges_mm);
            let y = model.forward(&h.inputs());
            h.push_labels(&y);
            let ranges: &[u16; BEAMS] = st.ranges_mm.as_slice().try_into().expect("897 beams");
            c.classify_ranges(&st.pose, ranges, &mut out);
            let scores: Vec<f32> = c.scores().iter().map(|&s| s as f32).collect();
            let float_sign: Vec<u8> = st
                .labels
                .iter()
                .zip(&y)
                .map(|(&l, &v)| {
                    if l == 0 {
                        0
                    } else if v >= 0.0 {
                        1
                    } else {
                        2
                    }
                })
                .collect();
            acc.add_row(i, &scores, &float_sign);
        }
        acc
    }))
}

/// Everything [`quantise_and_evaluate`] measured.
#[derive(Clone, Debug)]
pub struct QuantiseReport {
    /// The training log stored in the checkpoint.
    pub train_log: Option<TrainLog>,
    /// The blob's path, size and CRC.
    pub blob_path: PathBuf,
    /// Bytes.
    pub blob_len: usize,
    /// The blob's CRC-32 (header field).
    pub blob_crc: u32,
    /// Calibration inputs used.
    pub calibration: usize,
    /// The quantiser's calibrated max |pre-activation| per layer.
    pub max_abs_pre: [f32; 7],
    /// On the validation split.
    pub val: SetEval,
    /// In the built-in worlds (if run).
    pub unseen: Option<SetEval>,
    /// The no-label-history model (if given): validation and unseen, float and int8.
    pub ablation: Option<(Option<TrainLog>, SetEval, Option<SetEval>)>,
    /// Seconds spent.
    pub seconds: f64,
    /// The command line.
    pub command: String,
    /// The checkpoint path.
    pub checkpoint: PathBuf,
    /// Unseen-world random-walk seconds per world and scenario.
    pub unseen_seconds: f64,
    /// Notes for the card.
    pub notes: Option<String>,
}

/// Loads the checkpoint, calibrates on autoregressive validation inputs, writes the blob, checks
/// that the firmware parses it, evaluates float and int8 on the validation split and in the
/// unseen built-in worlds (and the ablation checkpoint, if given), and writes the model card.
/// `progress` gets a line per stage.
pub fn quantise_and_evaluate(cfg: &QuantiseConfig, mut progress: impl FnMut(&str)) -> Result<QuantiseReport> {
    let t0 = Instant::now();
    let (model, log) = load_checkpoint(&cfg.checkpoint)?;
    let data = cfg
        .data
        .clone()
        .or_else(|| log.as_ref().map(|l| l.config.data.clone()))
        .ok_or_else(|| TrainError("no dataset: pass --data (the checkpoint does not say which dataset it was trained on)".into()))?;
    let val_eps = load_split(&data, Split::Val)?;
    let steps: usize = val_eps.iter().map(|e| e.steps.len()).sum();
    let stride = (steps / cfg.calibration.max(1)).max(1);
    let calib = calibration_inputs(&model, &val_eps, stride, cfg.calibration);
    let (blob, qrep) = quantise_with(&model, &calib, &QuantiseOptions::default());
    let view = ModelView::parse(&blob).map_err(|e| TrainError(format!("the firmware refuses the blob: {e:?}")))?;
    let crc = view.crc();
    if let Some(dir) = cfg.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    std::fs::write(&cfg.out, &blob)?;
    progress(&format!("wrote {} ({} bytes, CRC {crc:08x}), calibrated on {} inputs", cfg.out.display(), blob.len(), calib.len()));
    let val = evaluate_set(&model, &blob, &val_eps)?;
    progress(&format!(
        "validation: float teacher-forced {:.2} %, float AR {:.2} %, int8 AR {:.2} %",
        100.0 * val.float_teacher_forced.accuracy(),
        100.0 * val.float_ar_raw.all.accuracy(),
        100.0 * val.int8_ar_raw.all.accuracy()
    ));
    let unseen_eps = if cfg.unseen_seconds > 0.0 { Some(unseen_episodes(cfg.unseen_seconds, 1)?) } else { None };
    let unseen = match &unseen_eps {
        Some(eps) => {
            let u = evaluate_set(&model, &blob, eps)?;
            progress(&format!("unseen worlds: int8 AR {:.2} %", 100.0 * u.int8_ar_raw.all.accuracy()));
            Some(u)
        }
        None => None,
    };
    let ablation = match &cfg.ablation {
        Some(p) => {
            let (am, alog) = load_checkpoint(p)?;
            let acalib = calibration_inputs(&am, &val_eps, stride, cfg.calibration);
            let ablob = crate::learn::model::quantise(&am, &acalib);
            let av = evaluate_set(&am, &ablob, &val_eps)?;
            let au = match &unseen_eps {
                Some(eps) => Some(evaluate_set(&am, &ablob, eps)?),
                None => None,
            };
            progress(&format!("ablation (no label history): float {:.2} %", 100.0 * av.float_zero_labels.accuracy()));
            Some((alog, av, au))
        }
        None => None,
    };
    let report = QuantiseReport {
        train_log: log,
        blob_path: cfg.out.clone(),
        blob_len: blob.len(),
        blob_crc: crc,
        calibration: calib.len(),
        max_abs_pre: qrep.max_abs_pre,
        val,
        unseen,
        ablation,
        seconds: t0.elapsed().as_secs_f64(),
        command: cfg.command.clone(),
        checkpoint: cfg.checkpoint.clone(),
        unseen_seconds: cfg.unseen_seconds,
        notes: cfg.notes.clone(),
    };
    if let Some(card) = &cfg.card {
        if let Some(dir) = card.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir)?;
        }
        std::fs::write(card, model_card(&report))?;
        progress(&format!("wrote {}", card.display()));
    }
    Ok(report)
}
