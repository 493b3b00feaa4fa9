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

use crate::dataset::{self, DatasetReader, Split};
use crate::labeller::{Labeller, LabellerConfig};
use crate::model::{normalise_pose_f32, normalise_scan_f32, quantise_with, FloatHistory, FloatInputs, FloatModel, QuantiseOptions};
use crate::range::{encode_range, RangeLimits};
use crate::search::TICK_US;
use crate::sim::reach::ReachMap;
use crate::sim::{BaseStatus, Scenario, Sim, World, P2};
use candle_core::{Device, Tensor, Var};
use candle_nn::{AdamW, Optimizer, ParamsAdamW};
use firmware::capacity::BEAMS;
use firmware::classifier::{
    Classifier, ClassifierConfig, LabelFeedback, ModelView, Normalisation, RangeEncoding, ENC_KERNEL, ENC_PAD, HISTORY, LABEL_ROWS,
    LABEL_WEIGHT_SUM, POSE_CHANNELS, POSE_FEATURES, POSE_FLAT,
};
use fixed_point::Pose2;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Instant;

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

// ---------------------------------------------------------------------------------------------
// Initialisation.

/// PyTorch's default initialisation of `LabelPoseNet` (`Conv2d` / `Linear`: weights and biases
/// uniform in ±1/√fan_in), drawn from a ChaCha8 generator seeded with `seed`, in the order
/// scan conv, scan fc, label conv, label fc, pose conv, pose fc (weights then biases).
pub fn pytorch_init(seed: u64) -> FloatModel {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut uni = |n: usize, fan_in: usize| -> Vec<f32> {
        let a = 1.0 / (fan_in as f32).sqrt();
        (0..n).map(|_| rng.gen_range(-a..a)).collect()
    };
    let mut encoder = || {
        let conv_w = uni(HISTORY * ENC_KERNEL, HISTORY * ENC_KERNEL);
        let conv_b = uni(1, HISTORY * ENC_KERNEL)[0];
        let fc_w = uni(BEAMS * BEAMS, BEAMS);
        let fc_b = uni(BEAMS, BEAMS);
        crate::model::Encoder { conv_w, conv_b, fc_w, fc_b }
    };
    let scan = encoder();
    let label = encoder();
    let pose = crate::model::PoseEncoder {
        conv_w: uni(POSE_CHANNELS * POSE_FEATURES, POSE_FEATURES),
        conv_b: uni(POSE_CHANNELS, POSE_FEATURES),
        fc_w: uni(BEAMS * POSE_FLAT, POSE_FLAT),
        fc_b: uni(BEAMS, POSE_FLAT),
    };
    FloatModel { scan, label, pose, norm: Normalisation::DEFAULT }
}

// ---------------------------------------------------------------------------------------------
// The network in candle.

/// One encoder's parameters as candle variables (shapes: conv `[81]` = `[t][j]`, conv bias `[1]`,
/// fc `[897, 897]` = `[out][in]`, fc bias `[897]`).
pub struct CandleEncoder {
    /// Conv weight `[t · 9 + j]`.
    pub conv_w: Var,
    /// Conv bias `[1]`.
    pub conv_b: Var,
    /// Linear weight `[out, in]` (unused while [`CandleEncoder::circulant`] is set).
    pub fc_w: Var,
    /// Linear bias `[out]`.
    pub fc_b: Var,
    /// Training-time weight sharing: when set, the linear weight is the circulant matrix
    /// `W[o][i] = c[(i − o) mod 897]` of this `[897]` vector (the gather index is the second
    /// field), i.e. the same kernel at every beam. Exported as the full matrix.
    pub circulant: Option<(Var, Tensor)>,
}

/// The pose encoder's parameters (conv `[9, 3]` = `[c][f]`, bias `[9]`, fc `[897, 81]`, bias `[897]`).
pub struct CandlePose {
    /// Conv weight `[c, f]`.
    pub conv_w: Var,
    /// Conv bias `[c]`.
    pub conv_b: Var,
    /// Linear weight `[897, 81]`, input index `c · 9 + t`.
    pub fc_w: Var,
    /// Linear bias `[897]`.
    pub fc_b: Var,
}

/// `LabelPoseNet` in candle: trainable, exports to a [`FloatModel`].
pub struct LabelPoseNet {
    /// Scan encoder.
    pub scan: CandleEncoder,
    /// Label encoder.
    pub label: CandleEncoder,
    /// Pose encoder.
    pub pose: CandlePose,
    /// Input normalisation (carried into the exported model).
    pub norm: Normalisation,
    /// The label-average weights `(r + 1) / 36`, shape `[1, 8, 1]`.
    avg_w: Tensor,
    device: Device,
}

fn var(v: &[f32], shape: &[usize], dev: &Device) -> Result<Var> {
    Ok(Var::from_tensor(&Tensor::from_slice(v, shape, dev)?)?)
}

fn to_vec(v: &Var) -> Result<Vec<f32>> {
    Ok(v.as_tensor().flatten_all()?.to_vec1::<f32>()?)
}

impl CandleEncoder {
    fn new(e: &crate::model::Encoder, dev: &Device) -> Result<Self> {
        Ok(Self {
            conv_w: var(&e.conv_w, &[HISTORY * ENC_KERNEL], dev)?,
            conv_b: var(&[e.conv_b], &[1], dev)?,
            fc_w: var(&e.fc_w, &[BEAMS, BEAMS], dev)?,
            fc_b: var(&e.fc_b, &[BEAMS], dev)?,
            circulant: None,
        })
    }

    /// Switches to the circulant parameterisation, its kernel the mean of each wrapped diagonal
    /// of the current weight (exact for a circulant matrix).
    pub fn make_circulant(&mut self) -> Result<()> {
        let w = to_vec(&self.fc_w)?;
        let mut c = vec![0.0f32; BEAMS];
        for o in 0..BEAMS {
            for (d, cd) in c.iter_mut().enumerate() {
                *cd += w[o * BEAMS + (o + d) % BEAMS];
            }
        }
        c.iter_mut().for_each(|v| *v /= BEAMS as f32);
        let idx: Vec<u32> = (0..BEAMS * BEAMS).map(|k| ((k % BEAMS + BEAMS - k / BEAMS) % BEAMS) as u32).collect();
        let dev = self.fc_w.device().clone();
        self.circulant = Some((var(&c, &[BEAMS], &dev)?, Tensor::from_vec(idx, BEAMS * BEAMS, &dev)?));
        Ok(())
    }

    /// Back to a full weight matrix (the expanded circulant), trainable element by element.
    pub fn make_full(&mut self) -> Result<()> {
        if self.circulant.is_some() {
            let w = self.fc_weight()?;
            self.fc_w = Var::from_tensor(&w)?;
            self.circulant = None;
        }
        Ok(())
    }

    /// The linear weight `[out, in]` as a tensor.
    fn fc_weight(&self) -> Result<Tensor> {
        Ok(match &self.circulant {
            Some((c, idx)) => c.as_tensor().index_select(idx, 0)?.reshape((BEAMS, BEAMS))?,
            None => self.fc_w.as_tensor().clone(),
        })
    }

    fn to_float(&self) -> Result<crate::model::Encoder> {
        Ok(crate::model::Encoder {
            conv_w: to_vec(&self.conv_w)?,
            conv_b: to_vec(&self.conv_b)?[0],
            fc_w: self.fc_weight()?.flatten_all()?.to_vec1::<f32>()?,
            fc_b: to_vec(&self.fc_b)?,
        })
    }

    /// `rows` `[N, 9, 897]` → `[N, 897]`: circular 9 × 9 convolution (padding 4 along the beams,
    /// none in time) → tanh → linear → tanh.
    fn forward(&self, rows: &Tensor) -> Result<Tensor> {
        let (n, pad) = (rows.dim(0)?, ENC_PAD);
        // Circular padding by concatenating the wrapped columns: [N, 9, 4 + 897 + 4].
        let padded = Tensor::cat(&[&rows.narrow(2, BEAMS - pad, pad)?, rows, &rows.narrow(2, 0, pad)?], 2)?;
        let wide = BEAMS + 2 * pad;
        // z[n, b', j] = Σ_t w[t][j] · padded[n, t, b'] (one small matmul), then
        // conv[n, b] = Σ_j z[n, b + j, j] (nine shifted diagonals).
        let z = padded
            .transpose(1, 2)?
            .contiguous()?
            .reshape((n * wide, HISTORY))?
            .matmul(&self.conv_w.as_tensor().reshape((HISTORY, ENC_KERNEL))?)?
            .reshape((n, wide, ENC_KERNEL))?;
        let mut conv = z.narrow(1, 0, BEAMS)?.narrow(2, 0, 1)?;
        for j in 1..ENC_KERNEL {
            conv = (conv + z.narrow(1, j, BEAMS)?.narrow(2, j, 1)?)?;
        }
        let conv = conv.squeeze(2)?.broadcast_add(self.conv_b.as_tensor())?;
        let hidden = conv.tanh()?;
        Ok(hidden.matmul(&self.fc_weight()?.t()?)?.broadcast_add(self.fc_b.as_tensor())?.tanh()?)
    }

    fn vars(&self) -> [Var; 4] {
        let fc = match &self.circulant {
            Some((c, _)) => c.clone(),
            None => self.fc_w.clone(),
        };
        [self.conv_w.clone(), self.conv_b.clone(), fc, self.fc_b.clone()]
    }
}

impl LabelPoseNet {
    /// The candle twin of `m` on `device` (CPU).
    pub fn from_float(m: &FloatModel, device: &Device) -> Result<Self> {
        let p = &m.pose;
        let w: Vec<f32> = (0..LABEL_ROWS).map(|r| (r + 1) as f32 / LABEL_WEIGHT_SUM as f32).collect();
        Ok(Self {
            scan: CandleEncoder::new(&m.scan, device)?,
            label: CandleEncoder::new(&m.label, device)?,
            pose: CandlePose {
                conv_w: var(&p.conv_w, &[POSE_CHANNELS, POSE_FEATURES], device)?,
                conv_b: var(&p.conv_b, &[POSE_CHANNELS], device)?,
                fc_w: var(&p.fc_w, &[BEAMS, POSE_FLAT], device)?,
                fc_b: var(&p.fc_b, &[BEAMS], device)?,
            },
            norm: m.norm,
            avg_w: Tensor::from_vec(w, (1, LABEL_ROWS, 1), device)?,
            device: device.clone(),
        })
    }

    /// The current weights as a [`FloatModel`].
    pub fn to_float(&self) -> Result<FloatModel> {
        let p = &self.pose;
        Ok(FloatModel {
            scan: self.scan.to_float()?,
            label: self.label.to_float()?,
            pose: crate::model::PoseEncoder {
                conv_w: to_vec(&p.conv_w)?,
                conv_b: to_vec(&p.conv_b)?,
                fc_w: to_vec(&p.fc_w)?,
                fc_b: to_vec(&p.fc_b)?,
            },
            norm: self.norm,
        })
    }

    /// All trainable variables.
    pub fn vars(&self) -> Vec<Var> {
        let mut v: Vec<Var> = self.scan.vars().into();
        v.extend(self.label.vars());
        v.extend([self.pose.conv_w.clone(), self.pose.conv_b.clone(), self.pose.fc_w.clone(), self.pose.fc_b.clone()]);
        v
    }

    /// The device the variables live on.
    pub fn device(&self) -> &Device {
        &self.device
    }

    /// Forward pass: scans `[N, 9, 897]`, labels `[N, 8, 897]` (the average row is computed
    /// here), poses `[N, 9, 3]` → outputs `[N, 897]` in (−1, 1).
    pub fn forward(&self, scans: &Tensor, labels: &Tensor, poses: &Tensor) -> Result<Tensor> {
        let n = scans.dim(0)?;
        let scan_enc = self.scan.forward(scans)?;
        let avg = labels.broadcast_mul(&self.avg_w)?.sum_keepdim(1)?;
        let label_rows = Tensor::cat(&[labels, &avg], 1)?;
        let label_enc = self.label.forward(&label_rows)?;
        // Pose conv (1 × 3 kernel = a linear map of each step's x, y, θ): [N · 9, 3] → [N · 9, 9].
        let z = poses
            .reshape((n * HISTORY, POSE_FEATURES))?
            .matmul(&self.pose.conv_w.as_tensor().t()?)?
            .broadcast_add(self.pose.conv_b.as_tensor())?
            .tanh()?;
        // [N, t, c] → channel-major flatten [N, c · 9 + t].
        let flat = z.reshape((n, HISTORY, POSE_CHANNELS))?.transpose(1, 2)?.contiguous()?.reshape((n, POSE_FLAT))?;
        let pose_enc = flat.matmul(&self.pose.fc_w.as_tensor().t()?)?.broadcast_add(self.pose.fc_b.as_tensor())?.tanh()?;
        Ok(((scan_enc + pose_enc)?.tanh()? * label_enc)?)
    }

    /// Forward pass on a [`Batch`].
    pub fn forward_batch(&self, b: &Batch) -> Result<Tensor> {
        let (s, l, p) = b.input_tensors(&self.device)?;
        self.forward(&s, &l, &p)
    }
}

// ---------------------------------------------------------------------------------------------
// Data.

/// One step of an episode: what the classifier needs and what the labeller said.
#[derive(Clone, Debug)]
pub struct Step {
    /// The pose the scan was taken at (Q16.16, as the firmware sees it).
    pub pose: Pose2,
    /// Ranges in the core's millimetre encoding (0 invalid, 65 535 no return).
    pub ranges_mm: Vec<u16>,
    /// Labeller codes: 0 none, 1 LTF (map), 2 STF, 3 DF (non-map).
    pub labels: Vec<u8>,
}

/// Consecutive 5 Hz steps of one episode.
#[derive(Clone, Debug)]
pub struct Episode {
    /// `random-<seed>/<episode>`, or the built-in world and scenario.
    pub name: String,
    /// The steps, in tick order.
    pub steps: Vec<Step>,
}

/// A labeller code as a training target: map +1, non-map −1, none 0.
pub fn label_sign(code: u8) -> f32 {
    match code {
        1 => 1.0,
        2 | 3 => -1.0,
        _ => 0.0,
    }
}

/// The simulator's range limits, as the search loop encodes its scans.
fn sim_limits() -> RangeLimits {
    crate::search::sim_limits(&dataset::sim_config())
}

fn pose_of(p: [f64; 3]) -> Result<Pose2> {
    Pose2::from_f64(p[0], p[1], p[2]).ok_or_else(|| TrainError(format!("pose {p:?} out of the Q16.16 range")))
}

/// A step from a dataset record (ranges encoded as `crate::range::encode_range` does for the core).
pub fn step_of_record(r: &dataset::Record) -> Result<Step> {
    let min = sim_limits();
    Ok(Step {
        pose: pose_of([r.pose[0] as f64, r.pose[1] as f64, r.pose[2] as f64])?,
        ranges_mm: r.ranges.iter().map(|&x| encode_range(x as f64, &min)).collect(),
        labels: r.labels.clone(),
    })
}

/// Reads a split into episodes (records of one world and episode with consecutive ticks).
pub fn load_split(dir: &Path, split: Split) -> Result<Vec<Episode>> {
    let reader = DatasetReader::open(dir, split)?;
    let mut out: Vec<Episode> = Vec::new();
    let mut last: Option<(u64, u32, u32)> = None;
    for rec in reader {
        let rec = rec?;
        if rec.ranges.len() != BEAMS || rec.labels.len() != BEAMS {
            return Err(TrainError(format!("record with {} beams, expected {BEAMS}", rec.ranges.len())));
        }
        let key = (rec.world_seed, rec.episode, rec.tick);
        let continues = matches!(last, Some((w, e, t)) if w == key.0 && e == key.1 && t + 1 == key.2);
        if !continues {
            out.push(Episode { name: format!("random-{}/{}", rec.world_seed, rec.episode), steps: Vec::new() });
        }
        last = Some(key);
        out.last_mut().expect("pushed above").steps.push(step_of_record(&rec)?);
    }
    Ok(out)
}

/// `(episode, step)` of every step with k − 1 predecessors in its episode; with `bootstrap`, also
/// the first k − 1 steps (their missing history zero, as at run time).
pub fn sample_index(episodes: &[Episode], bootstrap: bool) -> Vec<(u32, u32)> {
    let mut v = Vec::new();
    for (e, ep) in episodes.iter().enumerate() {
        for s in (if bootstrap { 0 } else { LABEL_ROWS })..ep.steps.len() {
            v.push((e as u32, s as u32));
        }
    }
    v
}

/// How the label history of a sample is filled.
pub enum LabelHistory<'a> {
    /// The labeller's labels of the 8 earlier steps (teacher forcing).
    True,
    /// The same with each row entry's sign flipped with probability `p` (training).
    Flipped(&'a mut ChaCha8Rng, f64),
    /// All zero (the no-label-history ablation).
    Zero,
    /// The model's own earlier outputs (int8 scale 1/127, indexed by step), as fed back at run
    /// time.
    Own(&'a [Vec<i8>]),
}

/// A batch of samples, row-major, ready for tensors.
#[derive(Clone, Debug, Default)]
pub struct Batch {
    /// Samples in the batch.
    pub n: usize,
    /// `[n, 9, 897]`.
    pub scans: Vec<f32>,
    /// `[n, 8, 897]`.
    pub labels: Vec<f32>,
    /// `[n, 9, 3]`.
    pub poses: Vec<f32>,
    /// `[n, 897]`, ±1 (0 where unlabelled).
    pub target: Vec<f32>,
    /// `[n, 897]`, 1 where labelled.
    pub mask: Vec<f32>,
}

impl Batch {
    /// An empty batch.
    pub fn new() -> Self {
        Self::default()
    }

    /// Removes all samples (keeps the allocations).
    pub fn clear(&mut self) {
        self.n = 0;
        self.scans.clear();
        self.labels.clear();
        self.poses.clear();
        self.target.clear();
        self.mask.clear();
    }

    /// The input tensors (scans, labels, poses).
    pub fn input_tensors(&self, dev: &Device) -> Result<(Tensor, Tensor, Tensor)> {
        Ok((
            Tensor::from_slice(&self.scans, (self.n, HISTORY, BEAMS), dev)?,
            Tensor::from_slice(&self.labels, (self.n, LABEL_ROWS, BEAMS), dev)?,
            Tensor::from_slice(&self.poses, (self.n, HISTORY, POSE_FEATURES), dev)?,
        ))
    }
}

/// Appends the sample ending at step `s` of `ep` to `b`. Rows before the episode's start are
/// zero (scans, poses and labels), exactly as `FloatHistory` and the firmware bootstrap.
pub fn fill_sample(ep: &Episode, s: usize, norm: &Normalisation, history: &mut LabelHistory<'_>, b: &mut Batch) {
    assert!(s < ep.steps.len(), "step {s} of an episode of {}", ep.steps.len());
    let newest = &ep.steps[s].pose;
    for t in 0..HISTORY {
        match (s + t).checked_sub(HISTORY - 1) {
            Some(i) => {
                let st = &ep.steps[i];
                normalise_scan_f32(&st.ranges_mm, norm, &mut b.scans);
                b.poses.extend(normalise_pose_f32(&st.pose, newest, norm));
            }
            None => {
                b.scans.extend(std::iter::repeat_n(0.0, BEAMS));
                b.poses.extend([0.0; POSE_FEATURES]);
            }
        }
    }
    for r in 0..LABEL_ROWS {
        let Some(i) = (s + r).checked_sub(LABEL_ROWS) else {
            b.labels.extend(std::iter::repeat_n(0.0, BEAMS));
            continue;
        };
        let st = &ep.steps[i];
        match history {
            LabelHistory::True => b.labels.extend(st.labels.iter().map(|&c| label_sign(c))),
            LabelHistory::Flipped(rng, p) => {
                let p = *p;
                b.labels.extend(st.labels.iter().map(|&c| {
                    let v = label_sign(c);
                    if rng.gen_bool(p) {
                        -v
                    } else {
                        v
                    }
                }))
            }
            LabelHistory::Zero => b.labels.extend(std::iter::repeat_n(0.0, BEAMS)),
            LabelHistory::Own(out) => b.labels.extend(out[i].iter().map(|&q| q as f32 / 127.0)),
        }
    }
    for &c in &ep.steps[s].labels {
        let t = label_sign(c);
        b.target.push(t);
        b.mask.push(if c == 0 { 0.0 } else { 1.0 });
    }
    b.n += 1;
}

/// Runs `net` autoregressively over every episode at once (batched across episodes, zero
/// bootstrap, its own outputs fed back as int8 like the firmware's raw feedback) and returns
/// each step's output, rounded to int8 (scale 1/127). `tally` (if given) counts the float
/// outputs' signs against the labeller.
pub fn rollout(net: &LabelPoseNet, episodes: &[Episode], mut tally: Option<&mut Confusion>) -> Result<Vec<Vec<Vec<i8>>>> {
    let mut out: Vec<Vec<Vec<i8>>> = episodes.iter().map(|e| Vec::with_capacity(e.steps.len())).collect();
    let longest = episodes.iter().map(|e| e.steps.len()).max().unwrap_or(0);
    let mut b = Batch::new();
    for s in 0..longest {
        b.clear();
        let live: Vec<usize> = (0..episodes.len()).filter(|&e| s < episodes[e].steps.len()).collect();
        for &e in &live {
            fill_sample(&episodes[e], s, &net.norm, &mut LabelHistory::Own(&out[e]), &mut b);
        }
        let y = net.forward_batch(&b)?.flatten_all()?.to_vec1::<f32>()?;
        for (k, &e) in live.iter().enumerate() {
            let row = &y[k * BEAMS..(k + 1) * BEAMS];
            if let Some(t) = tally.as_deref_mut() {
                t.add_row(row, &episodes[e].steps[s].labels);
            }
            out[e].push(row.iter().map(|&v| (v * 127.0).round().clamp(-127.0, 127.0) as i8).collect());
        }
    }
    Ok(out)
}

/// The teacher-forced [`FloatInputs`] of the sample ending at step `s` (same numbers as
/// [`fill_sample`] with [`LabelHistory::True`]).
pub fn sample_inputs(ep: &Episode, s: usize, norm: &Normalisation) -> FloatInputs {
    let mut b = Batch::new();
    fill_sample(ep, s, norm, &mut LabelHistory::True, &mut b);
    let mut poses = [[0.0; POSE_FEATURES]; HISTORY];
    for (t, p) in poses.iter_mut().enumerate() {
        p.copy_from_slice(&b.poses[t * POSE_FEATURES..(t + 1) * POSE_FEATURES]);
    }
    FloatInputs { scans: b.scans, labels: b.labels, poses }
}

/// Masked MSE: mean of `(out − target)²` over labelled beams.
pub fn masked_mse(out: &Tensor, target: &Tensor, mask: &Tensor) -> Result<Tensor> {
    let count = mask.sum_all()?.to_scalar::<f32>()?.max(1.0) as f64;
    Ok(((((out - target)?.sqr()? * mask)?.sum_all()?) / count)?)
}

// ---------------------------------------------------------------------------------------------
// Accuracy.

/// Labelled beams by (labeller says map, model says map).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Confusion {
    /// `counts[truth_is_map][pred_is_map]`.
    pub counts: [[u64; 2]; 2],
}

impl Confusion {
    /// Adds one beam (`truth_map`: the labeller says map; `pred_map`: output ≥ 0).
    pub fn add(&mut self, truth_map: bool, pred_map: bool) {
        self.counts[truth_map as usize][pred_map as usize] += 1;
    }

    /// Adds another tally.
    pub fn merge(&mut self, o: &Confusion) {
        for i in 0..2 {
            for j in 0..2 {
                self.counts[i][j] += o.counts[i][j];
            }
        }
    }

    /// Labelled beams counted.
    pub fn total(&self) -> u64 {
        self.counts.iter().flatten().sum()
    }

    /// Per-point accuracy (sign agreement), 0 … 1.
    pub fn accuracy(&self) -> f64 {
        (self.counts[0][0] + self.counts[1][1]) as f64 / self.total().max(1) as f64
    }

    /// Of the labeller's map beams, the fraction the model calls map.
    pub fn map_recall(&self) -> f64 {
        self.counts[1][1] as f64 / (self.counts[1][0] + self.counts[1][1]).max(1) as f64
    }

    /// Of the labeller's non-map beams, the fraction the model calls non-map.
    pub fn non_map_recall(&self) -> f64 {
        self.counts[0][0] as f64 / (self.counts[0][0] + self.counts[0][1]).max(1) as f64
    }

    /// The accuracy of always answering "map" (the majority class).
    pub fn always_map(&self) -> f64 {
        (self.counts[1][0] + self.counts[1][1]) as f64 / self.total().max(1) as f64
    }

    /// Adds a row of outputs against labeller codes (label 0 beams skipped).
    pub fn add_row(&mut self, out: &[f32], labels: &[u8]) {
        for (&o, &c) in out.iter().zip(labels) {
            if c != 0 {
                self.add(c == 1, o >= 0.0);
            }
        }
    }
}

/// Teacher-forced accuracy of `net` on every sample of `episodes` (true label history, or zeros
/// for the ablation when `zero_labels`).
pub fn evaluate_teacher_forced(net: &LabelPoseNet, episodes: &[Episode], zero_labels: bool, batch: usize) -> Result<Confusion> {
    let idx = sample_index(episodes, false);
    let mut conf = Confusion::default();
    let mut b = Batch::new();
    for chunk in idx.chunks(batch.max(1)) {
        b.clear();
        for &(e, s) in chunk {
            let mut h = if zero_labels { LabelHistory::Zero } else { LabelHistory::True };
            fill_sample(&episodes[e as usize], s as usize, &net.norm, &mut h, &mut b);
        }
        let out = net.forward_batch(&b)?.flatten_all()?.to_vec1::<f32>()?;
        for (i, &(e, s)) in chunk.iter().enumerate() {
            conf.add_row(&out[i * BEAMS..(i + 1) * BEAMS], &episodes[e as usize].steps[s as usize].labels);
        }
    }
    Ok(conf)
}

/// One candidate of [`calibrate_scan_bias`]: the shift and the accuracy it gives.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BiasCandidate {
    /// Added to every beam's bias of the scan encoder's 897 × 897 layer (before its tanh).
    pub delta: f32,
    /// Float accuracy over the episodes with that shift.
    pub accuracy: ArAccuracy,
}

/// Decision-bias calibration of a model **without label history**: the accuracy over
/// `episodes` (float, run as at run time) for each shift `delta` of the scan encoder's linear
/// bias. A positive shift moves every beam's decision towards *map*; the architecture is
/// unchanged (only `scan.fc_b` moves), so the int8 blob carries the shift. Choose the shift on
/// procedural validation episodes, never on the built-in worlds. One pass: each step's scan
/// pre-activations, pose and label encodings are computed once and every shift is scored on
/// them, which is exact because the label encoding of a model without label history does not
/// depend on its input (checked: the label convolution must be zero).
pub fn calibrate_scan_bias(model: &FloatModel, episodes: &[Episode], deltas: &[f32]) -> Result<Vec<BiasCandidate>> {
    if model.label.conv_w.iter().any(|&w| w != 0.0) {
        return Err(TrainError("calibrate_scan_bias needs a model without label history (zero label convolution)".into()));
    }
    let mut out: Vec<BiasCandidate> = deltas.iter().map(|&delta| BiasCandidate { delta, accuracy: ArAccuracy::default() }).collect();
    let mut row = vec![0.0f32; BEAMS];
    for ep in episodes {
        let mut h = FloatHistory::new(model.norm);
        for (i, st) in ep.steps.iter().enumerate() {
            h.push_scan(&st.pose, &st.ranges_mm);
            let t = model.trace(&h.inputs());
            let pre = &t.pre[1];
            for c in out.iter_mut() {
                for b in 0..BEAMS {
                    row[b] = ((pre[b] + c.delta).tanh() + t.pose_enc[b]).tanh() * t.label_enc[b];
                }
                c.accuracy.add_row(i, &row, &st.labels);
            }
            h.push_labels(&t.output);
        }
    }
    Ok(out)
}

/// What goes back into the float model's label history in an autoregressive run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Feedback {
    /// The output itself (the firmware's `LabelFeedback::Raw`, its default).
    Raw,
    /// Its sign, ±1 (`LabelFeedback::Sign`).
    Sign,
    /// Zeros: no label history at all (the ablation).
    Zero,
}

/// Accuracy of one autoregressive pass: over all steps, and over steps with k − 1 predecessors
/// (the teacher-forced samples' steps).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ArAccuracy {
    /// Every step of every episode, from the zero bootstrap on.
    pub all: Confusion,
    /// Steps 8, 9, … only.
    pub warm: Confusion,
}

impl ArAccuracy {
    fn merge(&mut self, o: &ArAccuracy) {
        self.all.merge(&o.all);
        self.warm.merge(&o.warm);
    }

    fn add_row(&mut self, step: usize, out: &[f32], labels: &[u8]) {
        self.all.add_row(out, labels);
        if step >= LABEL_ROWS {
            self.warm.add_row(out, labels);
        }
    }
}

/// Runs `f` over `episodes` on two threads (the machine has two cores) and merges the results.
fn par_episodes(episodes: &[Episode], f: impl Fn(&Episode) -> ArAccuracy + Sync) -> ArAccuracy {
    let threads = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1).clamp(1, 4);
    let f = &f;
    let parts: Vec<ArAccuracy> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                s.spawn(move || {
                    let mut acc = ArAccuracy::default();
                    for ep in episodes.iter().skip(t).step_by(threads) {
                        acc.merge(&f(ep));
                    }
                    acc
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().expect("evaluation thread")).collect()
    });
    let mut acc = ArAccuracy::default();
    for p in &parts {
        acc.merge(p);
    }
    acc
}

/// The float model run as at run time: zero bootstrap, its own outputs fed back.
pub fn evaluate_float_autoregressive(model: &FloatModel, episodes: &[Episode], feedback: Feedback) -> ArAccuracy {
    par_episodes(episodes, |ep| {
        let mut acc = ArAccuracy::default();
        let mut h = FloatHistory::new(model.norm);
        for (i, st) in ep.steps.iter().enumerate() {
            h.push_scan(&st.pose, &st.ranges_mm);
            let out = model.forward(&h.inputs());
            acc.add_row(i, &out, &st.labels);
            match feedback {
                Feedback::Raw => h.push_labels(&out),
                Feedback::Sign => h.push_labels(&out.iter().map(|&v| if v >= 0.0 { 1.0 } else { -1.0 }).collect::<Vec<_>>()),
                Feedback::Zero => {}
            }
        }
        acc
    })
}

/// The int8 blob run through the firmware's classifier, episode by episode from a reset
/// (autoregressive, as on the robot). Only `Raw` and `Sign` feedback exist in the firmware.
pub fn evaluate_int8(blob: &[u8], episodes: &[Episode], feedback: LabelFeedback) -> Result<ArAccuracy> {
    let view = ModelView::parse(blob).map_err(|e| TrainError(format!("the firmware refuses the blob: {e:?}")))?;
    Ok(par_episodes(episodes, |ep| {
        let mut c = Box::new(Classifier::with_model(view, ClassifierConfig { feedback }));
        let mut acc = ArAccuracy::default();
        let mut out = Box::new([firmware::scan::BeamLabel::Unlabelled; BEAMS]);
        for (i, st) in ep.steps.iter().enumerate() {
            let ranges: &[u16; BEAMS] = st.ranges_mm.as_slice().try_into().expect("897 beams");
            c.classify_ranges(&st.pose, ranges, &mut out);
            let scores: Vec<f32> = c.scores().iter().map(|&s| s as f32).collect();
            acc.add_row(i, &scores, &st.labels);
        }
        acc
    }))
}

// ---------------------------------------------------------------------------------------------
// Training.

/// Training settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainConfig {
    /// The dataset directory (`lives dataset --out …`).
    pub data: PathBuf,
    /// Passes over the training samples.
    pub epochs: usize,
    /// Samples per optimiser step.
    pub batch: usize,
    /// Adam learning rate.
    pub lr: f64,
    /// Seed of the initialisation, the shuffling and the label flips.
    pub seed: u64,
    /// Probability that a history label's sign is flipped in training (paper: 10 %).
    pub flip: f64,
    /// Feed the label history (false: zeros, the no-label-history ablation; the exported model's
    /// label convolution weights are then zeroed, so the firmware's fed-back labels have no
    /// effect either).
    pub label_history: bool,
    /// Also train on the first k − 1 steps of each episode, their missing history zero (the run-time
    /// bootstrap). The paper's recipe: false.
    pub bootstrap: bool,
    /// Fraction of samples whose label history is the model's own autoregressive output (a rollout
    /// over the training episodes with the current weights before every epoch after the first),
    /// instead of the flipped true labels. The paper's recipe: 0.
    pub self_feedback: f64,
    /// Fraction of samples whose label history is all zero. The paper's recipe: 0.
    pub history_dropout: f64,
    /// Added to the diagonal of both encoders' 897 × 897 weights at initialisation (0 = PyTorch's
    /// default init). A diagonal start makes beam b's output depend on beam b's neighbourhood from
    /// the first step, which the dense layer otherwise has to discover from data.
    pub init_diag: f32,
    /// Use at most this many training samples (a fixed, seeded subset), for quick runs.
    pub max_samples: Option<usize>,
    /// The range that normalises to 1 (millimetres; written into the blob as `range_max_mm`).
    #[serde(default = "default_range_max_mm")]
    pub range_max_mm: u32,
    /// When non-zero, the scan convolution starts as this weight on the newest scan's centre tap
    /// and zero elsewhere (bias zero), so the scan encoder's hidden layer starts as
    /// `tanh(w · range input)` of each beam and the linear layer sees the scan itself.
    #[serde(default)]
    pub scan_conv_init: f32,
    /// The first epoch whose self-feedback histories come from a rollout (before it the
    /// self-feedback share uses flipped true labels): 2 for a fresh start (the first rollout is of
    /// the untrained model), 1 when continuing from a trained checkpoint.
    #[serde(default = "two")]
    pub own_history_from_epoch: usize,
    /// Initial bias of the label encoder's linear layer (0: PyTorch's default init). A positive
    /// value starts `label_enc` near +1 on every beam, so the output starts as
    /// `tanh(scan_enc + pose_enc)`: with PyTorch's init the label encoding of a zero history is
    /// a small per-beam constant of random sign (measured ±0.45 after training), which flips the
    /// sign of the scan path's gradient from beam to beam and all but stops the shared
    /// convolution (and a circulant layer) from learning.
    #[serde(default)]
    pub label_bias_init: f32,
    /// Inverse-range scan inputs (`min(1, range_max_mm / r)`, dropouts filled) instead of linear.
    #[serde(default)]
    pub inverse_range: bool,
    /// Train the encoders' 897 × 897 weights as circulant matrices (one kernel shared by every
    /// beam) for this many epochs, then as full matrices. 0: full from the start.
    #[serde(default)]
    pub circulant_epochs: usize,
    /// Loss weight of non-map beams (map beams 1); 1: the plain masked MSE.
    #[serde(default = "one")]
    pub non_map_weight: f32,
    /// Cosine learning-rate decay from `lr` to `lr / 20` over the run (per batch).
    #[serde(default)]
    pub lr_decay: bool,
    /// The command line, for the record.
    pub command: String,
}

fn default_range_max_mm() -> u32 {
    Normalisation::DEFAULT.range_max_mm as u32
}

fn one() -> f32 {
    1.0
}

fn two() -> usize {
    2
}

impl TrainConfig {
    /// Defaults for this 2-core CPU: [`DEFAULT_EPOCHS`] epochs of batch 256 (the paper trains 20–50
    /// epochs of batch 4096 on a GPU), lr 1e-3, 10 % flips, seed 1; plus what autoregressive use
    /// needs and the paper's recipe lacks (teacher forcing alone learns to copy the label history
    /// and collapses at run time): bootstrap samples, 50 % of histories from the model's own
    /// rollout, 5 % all-zero histories.
    pub fn new(data: impl Into<PathBuf>) -> Self {
        Self {
            data: data.into(),
            epochs: DEFAULT_EPOCHS,
            batch: DEFAULT_BATCH,
            lr: 1e-3,
            seed: 1,
            flip: 0.1,
            label_history: true,
            bootstrap: true,
            self_feedback: 0.5,
            history_dropout: 0.05,
            init_diag: 1.0,
            max_samples: None,
            range_max_mm: default_range_max_mm(),
            inverse_range: false,
            label_bias_init: 0.0,
            own_history_from_epoch: 2,
            scan_conv_init: 0.0,
            circulant_epochs: 0,
            non_map_weight: 1.0,
            lr_decay: false,
            command: String::new(),
        }
    }
}

/// One epoch's numbers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpochLog {
    /// 1-based.
    pub epoch: usize,
    /// Mean training loss over the epoch's batches.
    pub train_loss: f64,
    /// Teacher-forced validation accuracy after the epoch (zero labels when training without
    /// the label history).
    pub val_accuracy: f64,
    /// Autoregressive validation accuracy after the epoch (float, batched rollout with int8-rounded
    /// raw feedback; every step from the bootstrap on). Checkpoints written before this was fixed
    /// scored the int8-rounded outputs, so an output that rounded to 0 counted as map.
    pub val_ar_accuracy: f64,
    /// Wall-clock seconds of the epoch (training only).
    pub train_s: f64,
}

/// What a training run did (stored in the checkpoint's metadata).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainLog {
    /// The settings.
    pub config: TrainConfig,
    /// The dataset's generator command line (from its `meta.json`).
    pub dataset_command: String,
    /// Worlds in the training / validation split.
    pub worlds: [usize; 2],
    /// Records in the training / validation split.
    pub records: [usize; 2],
    /// Samples (steps with k − 1 predecessors) used for training / in validation.
    pub samples: [usize; 2],
    /// Per epoch.
    pub epochs: Vec<EpochLog>,
    /// Total wall-clock seconds (loading, training and the per-epoch validation).
    pub total_s: f64,
    /// Trainable parameters.
    pub parameters: usize,
    /// Threads available.
    pub threads: usize,
}

/// Keeps freed memory in the process (glibc only): candle allocates and frees megabyte-sized
/// buffers at every operation, and glibc's default hands each back to the kernel (`mmap` /
/// `munmap`), which doubled the training time here in page faults. Process-wide; called by
/// [`train_from`].
pub fn tune_allocator() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only changes allocator thresholds; it is safe to call at any time.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 64 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 1 << 30);
        libc::mallopt(libc::M_TOP_PAD, 64 << 20);
    }
}

/// Trains from [`pytorch_init`]`(cfg.seed)` (plus [`TrainConfig::init_diag`]); calls `progress` after every epoch. Returns the
/// trained model and the log.
pub fn train(cfg: &TrainConfig, progress: impl FnMut(&EpochLog)) -> Result<(FloatModel, TrainLog)> {
    let mut init = pytorch_init(cfg.seed);
    for e in [&mut init.scan, &mut init.label] {
        for b in 0..BEAMS {
            e.fc_w[b * BEAMS + b] += cfg.init_diag;
        }
    }
    if cfg.label_bias_init != 0.0 {
        init.label.fc_b.iter_mut().for_each(|v| *v = cfg.label_bias_init);
    }
    if cfg.scan_conv_init != 0.0 {
        init.scan.conv_w.iter_mut().for_each(|v| *v = 0.0);
        init.scan.conv_w[(HISTORY - 1) * ENC_KERNEL + ENC_PAD] = cfg.scan_conv_init;
        init.scan.conv_b = 0.0;
    }
    train_from(cfg, init, progress)
}

/// [`train`] starting from `init` (e.g. a checkpoint, to continue training).
pub fn train_from(cfg: &TrainConfig, mut init: FloatModel, mut progress: impl FnMut(&EpochLog)) -> Result<(FloatModel, TrainLog)> {
    tune_allocator();
    init.norm.range_max_mm = u16::try_from(cfg.range_max_mm).unwrap_or(0);
    init.norm.range_encoding = if cfg.inverse_range { RangeEncoding::Inverse } else { RangeEncoding::Linear };
    if !init.norm.is_valid() {
        return Err(TrainError(format!("range_max_mm {} out of range (1 … 65 534)", cfg.range_max_mm)));
    }
    let t0 = Instant::now();
    let meta = dataset::read_meta(&cfg.data)?;
    let train_eps = load_split(&cfg.data, Split::Train)?;
    let val_eps = load_split(&cfg.data, Split::Val)?;
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed ^ 0x7452_4149_4E00);
    let mut idx = sample_index(&train_eps, cfg.bootstrap);
    if let Some(m) = cfg.max_samples {
        idx.shuffle(&mut rng);
        idx.truncate(m);
        idx.sort_unstable();
    }
    if idx.is_empty() {
        return Err(TrainError("no training samples (episodes shorter than k steps?)".into()));
    }
    let dev = Device::Cpu;
    let mut net = LabelPoseNet::from_float(&init, &dev)?;
    if cfg.circulant_epochs > 0 {
        net.scan.make_circulant()?;
        net.label.make_circulant()?;
    }
    let adam = |net: &LabelPoseNet| AdamW::new(net.vars(), ParamsAdamW { lr: cfg.lr, weight_decay: 0.0, ..ParamsAdamW::default() });
    let mut opt = adam(&net)?;
    let total_batches = (cfg.epochs * idx.len().div_ceil(cfg.batch.max(1))).max(1);
    let mut batch_no = 0usize;
    let split_count = |name: &str| meta.splits.get(name).map(|s| (s.world_seeds.len(), s.records as usize)).unwrap_or((0, 0));
    let (tw, tr) = split_count("train");
    let (vw, vr) = split_count("val");
    let mut log = TrainLog {
        config: cfg.clone(),
        dataset_command: meta.generator.command.clone(),
        worlds: [tw, vw],
        records: [tr, vr],
        samples: [idx.len(), sample_index(&val_eps, false).len()],
        epochs: Vec::new(),
        total_s: 0.0,
        parameters: init.parameter_count(),
        threads: std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
    };
    let mut b = Batch::new();
    let mut own: Option<Vec<Vec<Vec<i8>>>> = None;
    for epoch in 1..=cfg.epochs {
        let te = Instant::now();
        if cfg.circulant_epochs > 0 && epoch == cfg.circulant_epochs + 1 {
            net.scan.make_full()?;
            net.label.make_full()?;
            opt = adam(&net)?;
        }
        if cfg.label_history && cfg.self_feedback > 0.0 && epoch >= cfg.own_history_from_epoch.max(1) {
            own = Some(rollout(&net, &train_eps, None)?);
        }
        idx.shuffle(&mut rng);
        let (mut loss_sum, mut batches) = (0.0f64, 0usize);
        for chunk in idx.chunks(cfg.batch.max(1)) {
            b.clear();
            for &(e, s) in chunk {
                let r: f64 = rng.gen();
                let ep = &train_eps[e as usize];
                let mut h = match &own {
                    _ if !cfg.label_history || r < cfg.history_dropout => LabelHistory::Zero,
                    Some(o) if r < cfg.history_dropout + cfg.self_feedback => LabelHistory::Own(&o[e as usize]),
                    _ => LabelHistory::Flipped(&mut rng, cfg.flip),
                };
                fill_sample(ep, s as usize, &net.norm, &mut h, &mut b);
            }
            let out = net.forward_batch(&b)?;
            let target = Tensor::from_slice(&b.target, (b.n, BEAMS), &dev)?;
            if cfg.non_map_weight != 1.0 {
                for (m, &t) in b.mask.iter_mut().zip(&b.target) {
                    if t < 0.0 {
                        *m *= cfg.non_map_weight;
                    }
                }
            }
            let mask = Tensor::from_slice(&b.mask, (b.n, BEAMS), &dev)?;
            let loss = masked_mse(&out, &target, &mask)?;
            if cfg.lr_decay {
                let f = batch_no as f64 / total_batches as f64;
                opt.set_learning_rate(cfg.lr * (0.05 + 0.95 * 0.5 * (1.0 + (std::f64::consts::PI * f).cos())));
            }
            batch_no += 1;
            opt.backward_step(&loss)?;
            loss_sum += loss.to_scalar::<f32>()? as f64;
            batches += 1;
        }
        let train_s = te.elapsed().as_secs_f64();
        let val = evaluate_teacher_forced(&net, &val_eps, !cfg.label_history, 512)?;
        let val_ar = if cfg.label_history { rollout_accuracy(&net, &val_eps)? } else { val };
        let e = EpochLog {
            epoch,
            train_loss: loss_sum / batches.max(1) as f64,
            val_accuracy: val.accuracy(),
            val_ar_accuracy: val_ar.accuracy(),
            train_s,
        };
        progress(&e);
        log.epochs.push(e);
    }
    log.total_s = t0.elapsed().as_secs_f64();
    let mut m = net.to_float()?;
    if !cfg.label_history {
        m.label.conv_w.iter_mut().for_each(|w| *w = 0.0);
    }
    Ok((m, log))
}

/// Accuracy of a batched [`rollout`] (every step; the float output's sign decides).
pub fn rollout_accuracy(net: &LabelPoseNet, episodes: &[Episode]) -> Result<Confusion> {
    let mut c = Confusion::default();
    rollout(net, episodes, Some(&mut c))?;
    Ok(c)
}

// ---------------------------------------------------------------------------------------------
// Checkpoints.

/// The checkpoint's tensors: name, PyTorch shape, values.
fn checkpoint_tensors(m: &FloatModel) -> Vec<(String, Vec<usize>, &[f32])> {
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
    let enc = |get: &mut dyn FnMut(usize) -> Result<Vec<f32>>, o: usize| -> Result<crate::model::Encoder> {
        Ok(crate::model::Encoder { conv_w: get(o)?, conv_b: get(o + 1)?[0], fc_w: get(o + 2)?, fc_b: get(o + 3)? })
    };
    m.scan = enc(&mut get, 0)?;
    m.label = enc(&mut get, 4)?;
    m.pose = crate::model::PoseEncoder { conv_w: get(8)?, conv_b: get(9)?, fc_w: get(10)?, fc_b: get(11)? };
    let log = match meta.get("train_log") {
        Some(s) => Some(serde_json::from_str(s).map_err(|e| TrainError(format!("{}: train_log: {e}", path.display())))?),
        None => None,
    };
    Ok((m, log))
}

// ---------------------------------------------------------------------------------------------
// Unseen worlds.

/// Drives a random walk (random reachable waypoints 1–8 m away on clear straight lines, or a turn
/// on the spot) through `world` for `seconds` at 5 Hz and labels every scan with the default
/// labeller — an evaluation episode in a world no dataset contains.
pub fn drive_random_walk(world: &World, name: &str, sim_seed: u64, seconds: f64) -> Result<Episode> {
    let cfg = dataset::sim_config();
    let min = crate::search::sim_limits(&cfg);
    let start = [world.start.pose[0], world.start.pose[1]];
    let reach = ReachMap::new(world, start, cfg.robot_radius_m + 0.1);
    let [lo, hi] = world.bounds;
    let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
    let free = reach.reached_near(centre, crate::sim::geometry::dist(lo, hi) / 2.0 + 1.0);
    let mut sim = Sim::new(world.clone(), cfg, sim_seed);
    let mut lab = Labeller::for_world(world, LabellerConfig::default());
    let mut rng = ChaCha8Rng::seed_from_u64(sim_seed ^ 0x554E_5345_454E);
    let ticks = (seconds * dataset::SCAN_HZ).round() as u32;
    let (mut deadline, mut blocked_ticks, mut blocked) = (0u32, 0u32, false);
    let mut steps = Vec::with_capacity(ticks as usize);
    const SUBSTEPS: u32 = 4;
    for tick in 0..ticks {
        let p = sim.pose();
        let scan = sim.scan();
        let labels = lab.label_scan(p, &scan);
        steps.push(Step {
            pose: pose_of(p)?,
            ranges_mm: scan.ranges_m.iter().map(|&r| encode_range(r as f64, &min)).collect(),
            labels: labels.iter().map(|l| l.code()).collect(),
        });
        blocked_ticks = if blocked { blocked_ticks + 1 } else { 0 };
        let idle = matches!(sim.base_status(), BaseStatus::Idle | BaseStatus::Arrived);
        if idle || blocked_ticks >= 5 || tick >= deadline {
            blocked_ticks = 0;
            let here: P2 = [p[0], p[1]];
            let mut chosen = false;
            if !free.is_empty() && rng.gen_bool(0.85) {
                for _ in 0..60 {
                    let q = free[rng.gen_range(0..free.len())];
                    let d = crate::sim::geometry::dist(here, q);
                    let n = (d / 0.05).ceil().max(1.0) as usize;
                    let clear = (1..=n).all(|i| {
                        let t = i as f64 / n as f64;
                        !sim.collides([here[0] + (q[0] - here[0]) * t, here[1] + (q[1] - here[1]) * t])
                    });
                    if (1.0..=8.0).contains(&d) && clear {
                        sim.set_path(&[q], None);
                        deadline = tick + ((d / sim.config().speed_mps.max(0.05) + 10.0) * dataset::SCAN_HZ) as u32;
                        chosen = true;
                        break;
                    }
                }
            }
            if !chosen {
                sim.set_path(&[], Some(rng.gen_range(-std::f64::consts::PI..std::f64::consts::PI)));
                deadline = tick + (8.0 * dataset::SCAN_HZ) as u32;
            }
        }
        blocked = false;
        for _ in 0..SUBSTEPS {
            if sim.step(TICK_US as f64 / 1e6 / SUBSTEPS as f64) == BaseStatus::Blocked {
                blocked = true;
            }
        }
    }
    Ok(Episode { name: name.to_string(), steps })
}

/// One random-walk episode of `seconds` in each built-in world and scenario (apartment, office,
/// hallway × easy, hard), simulator seed `seed + i`. These worlds are never in a dataset.
pub fn unseen_episodes(seconds: f64, seed: u64) -> Result<Vec<Episode>> {
    let mut out = Vec::new();
    for name in World::builtin_names() {
        for sc in Scenario::ALL {
            let w = World::builtin(name, sc).ok_or_else(|| TrainError(format!("no built-in world {name} {sc}")))?;
            out.push(drive_random_walk(&w, &format!("{name}-{sc}"), seed + out.len() as u64, seconds)?);
        }
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------------
// Quantisation, evaluation, model card.

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
            let ablob = crate::model::quantise(&am, &acalib);
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

/// A command line as `lives …` (whatever binary ran it).
fn as_lives(cmd: &str) -> String {
    match cmd.split_once(' ') {
        Some((_, rest)) => format!("lives {rest}"),
        None if cmd.is_empty() => String::new(),
        None => "lives".to_string(),
    }
}

fn pct(c: &Confusion) -> String {
    format!("{:.2} %", 100.0 * c.accuracy())
}

/// The model card (Markdown) for a [`QuantiseReport`].
pub fn model_card(r: &QuantiseReport) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(s, "# Model card: LIVES map-free scan classifier (`LabelPoseNet`, int8)\n");
    let _ = writeln!(
        s,
        "The network that labels each of the 897 LiDAR beams *map* (walls) or *non-map* (furniture, \
         objects, people) without a map (METHOD.md §1.2; format: `docs/model-format.md`). Trained in \
         `f32` with `host::train` (candle, CPU), quantised to int8 with `host::model::quantise`, run by \
         `firmware::classifier::Classifier`. Generated by `lives quantise`; every number below was \
         measured by that command.\n"
    );
    let _ = writeln!(s, "## Files\n");
    let _ = writeln!(s, "| file | what |\n|---|---|");
    let _ =
        writeln!(s, "| `{}` | the int8 blob the firmware runs: {} bytes, CRC-32 `{:08x}` |", r.blob_path.display(), r.blob_len, r.blob_crc);
    let _ = writeln!(s, "| `{}` | the f32 checkpoint it was quantised from (safetensors) |\n", r.checkpoint.display());
    if let Some(l) = &r.train_log {
        let c = &l.config;
        let _ = writeln!(s, "## Data\n");
        let _ = writeln!(
            s,
            "Procedural buildings (`World::random`), labelled by the map-based labeller (`host/src/labeller.rs`, \
             default 0.1 m LTF gate; `docs/dataset.md`). Split by world (seed % 5 == 0 → validation).\n"
        );
        let _ = writeln!(s, "- dataset command: `{}`", as_lives(&l.dataset_command));
        let _ = writeln!(s, "- worlds: {} train, {} validation", l.worlds[0], l.worlds[1]);
        let _ = writeln!(s, "- records (5 Hz scans): {} train, {} validation", l.records[0], l.records[1]);
        let _ = writeln!(
            s,
            "- samples: {} train ({}), {} validation (steps with k − 1 = 8 predecessors)\n",
            l.samples[0],
            if c.bootstrap { "every step, the first 8 of an episode with the zero bootstrap" } else { "steps with 8 predecessors" },
            l.samples[1]
        );
        let _ = writeln!(s, "## Training\n");
        let _ = writeln!(s, "- command: `{}`", as_lives(&c.command));
        let _ = writeln!(
            s,
            "- {} epochs, batch {}, Adam lr {} (AdamW, weight decay 0), masked MSE against ±1 (map +1, label-0 beams \
             masked), seed {} (initialisation = PyTorch's default plus {} on the encoders' 897 × 897 diagonals; shuffling; flips)",
            c.epochs, c.batch, c.lr, c.seed, c.init_diag
        );
        let _ = writeln!(
            s,
            "- scan input: {}; label encoder's linear bias initialised to {} ({}){}; encoders' 897 × 897 weights \
             trained as circulant matrices (one kernel shared by all beams) for the first {} epochs, then as full \
             matrices; learning rate {}; non-map beams weighted {} in the loss",
            if c.inverse_range {
                format!("inverse range `min(1, {} mm / r)`, no return 0, dropouts filled from the previous beam", c.range_max_mm)
            } else {
                format!("linear `min(r, {} mm) / {} mm`, no return 1, dropouts 0", c.range_max_mm, c.range_max_mm)
            },
            c.label_bias_init,
            if c.label_bias_init == 0.0 { "PyTorch's default" } else { "label_enc starts near +1 on every beam" },
            if c.scan_conv_init == 0.0 {
                String::new()
            } else {
                format!("; scan convolution initialised to {} on the newest scan's centre tap, 0 elsewhere", c.scan_conv_init)
            },
            c.circulant_epochs,
            if c.lr_decay { "cosine-decayed to lr / 20 over the run" } else { "constant" },
            c.non_map_weight
        );
        if c.label_history {
            let _ = writeln!(
                s,
                "- label history per sample: {:.0} % the model's own autoregressive outputs (a rollout over the training \
                 episodes with the current weights, before every epoch after the first; int8-rounded, as the firmware \
                 feeds back), {:.0} % all zero, the rest the labeller's labels with {:.0} % of signs flipped (the paper's \
                 recipe); {} the first 8 steps of each episode with the run-time zero bootstrap",
                100.0 * c.self_feedback,
                100.0 * c.history_dropout,
                100.0 * c.flip,
                if c.bootstrap { "samples include" } else { "samples exclude" }
            );
        } else {
            let _ = writeln!(s, "- **no label history** (label inputs zero; the exported label convolution weights are zero)");
        }
        let _ = writeln!(
            s,
            "- {} parameters; {:.0} s wall clock on {} CPU threads ({:.1} min); the paper trains 20–50 epochs \
             of batch 4096 on a GPU — this run is CPU-sized\n",
            l.parameters,
            l.total_s,
            l.threads,
            l.total_s / 60.0
        );
        let _ = writeln!(
            s,
            "| epoch | train loss | val accuracy, teacher-forced | val accuracy, autoregressive (float) | seconds |\n|---|---|---|---|---|"
        );
        for e in &l.epochs {
            let _ = writeln!(
                s,
                "| {} | {:.4} | {:.2} % | {:.2} % | {:.0} |",
                e.epoch,
                e.train_loss,
                100.0 * e.val_accuracy,
                100.0 * e.val_ar_accuracy,
                e.train_s
            );
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(s, "## Quantisation\n");
    let _ = writeln!(s, "- command: `{}`", as_lives(&r.command));
    let _ = writeln!(
        s,
        "- calibrated on {} inputs of an autoregressive float run over the validation split (max |pre-activation| \
         per layer, clipped at 3.0): {:?}\n",
        r.calibration,
        r.max_abs_pre.map(|v| (v * 100.0).round() / 100.0)
    );
    let _ = writeln!(s, "## Accuracy\n");
    let _ = writeln!(
        s,
        "Per-point accuracy = sign agreement with the labeller over beams with a return. *Teacher-forced*: \
         the true labels of the 8 earlier scans as the label history. *Autoregressive*: as on the robot, \
         the model's own outputs fed back, everything zero at the episode's start; \"all\" counts every \
         step from the bootstrap on, \"warm\" only steps with 8 predecessors. *Raw* feeds back the output \
         itself (the firmware's default, `LabelFeedback::Raw`), *sign* its sign. The int8 rows run the \
         blob through the firmware classifier.\n"
    );
    let row = |name: &str, e: &SetEval| -> String {
        format!(
            "| {name} | {} / {} | {} | {} | {} ({} warm) | {} | **{}** ({} warm) | {} | {:.2} % |",
            e.episodes,
            e.steps,
            pct(&e.float_teacher_forced),
            pct(&e.float_zero_labels),
            pct(&e.float_ar_raw.all),
            pct(&e.float_ar_raw.warm),
            pct(&e.float_ar_sign.all),
            pct(&e.int8_ar_raw.all),
            pct(&e.int8_ar_raw.warm),
            pct(&e.int8_ar_sign.all),
            100.0 * e.float_teacher_forced.always_map(),
        )
    };
    let _ = writeln!(
        s,
        "| set | episodes / steps | float teacher-forced | float, label input zeroed | float AR raw | float AR sign | \
         **int8 AR raw** | int8 AR sign | \"always map\" |\n|---|---|---|---|---|---|---|---|---|"
    );
    let _ = writeln!(s, "{}", row("validation (unseen random worlds)", &r.val));
    if let Some(u) = &r.unseen {
        let _ = writeln!(s, "{}", row("built-in apartment, office, hallway (never in a dataset)", u));
    }
    let _ = writeln!(s);
    let cls = |name: &str, c: &Confusion| format!("| {name} | {:.2} % | {:.2} % |", 100.0 * c.map_recall(), 100.0 * c.non_map_recall());
    let _ = writeln!(
        s,
        "Per class, int8 autoregressive (raw):\n\n| set | map beams called map | non-map beams called non-map |\n|---|---|---|"
    );
    let _ = writeln!(s, "{}", cls("validation", &r.val.int8_ar_raw.all));
    if let Some(u) = &r.unseen {
        let _ = writeln!(s, "{}", cls("built-in worlds", &u.int8_ar_raw.all));
    }
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "int8 against float, both autoregressive (raw feedback, each fed its own outputs), sign agreement per \
         labelled beam: **{}** on validation{}.\n",
        pct(&r.val.int8_float_agreement.all),
        r.unseen.as_ref().map(|u| format!(", **{}** in the built-in worlds", pct(&u.int8_float_agreement.all))).unwrap_or_default()
    );
    if let Some(u) = &r.unseen {
        let _ = writeln!(
            s,
            "The built-in worlds (apartment, office, hallway, easy and hard) were driven by a random walk, \
             {:.0} s each ({} steps in all), and labelled by the same labeller; no dataset contains them \
             (`docs/dataset.md`).\n",
            r.unseen_seconds, u.steps
        );
    }
    let _ = writeln!(s, "### Label history ablation\n");
    let this_has_history = r.train_log.as_ref().is_none_or(|l| l.config.label_history);
    match &r.ablation {
        Some((alog, av, au)) => {
            let (what, other) = if this_has_history { ("without", "with") } else { ("with", "without") };
            let ep =
                alog.as_ref().map(|l| format!("{} epochs, command `{}`", l.config.epochs, as_lives(&l.config.command))).unwrap_or_default();
            let _ = writeln!(s, "The model above was trained {other} the label history; a second model {what} it ({ep}):\n");
            let _ = writeln!(
                s,
                "| set | with label history: int8 AR raw (float AR raw) | without: int8 (float) | difference (int8) |\n|---|---|---|---|"
            );
            let line = |name: &str, this: &SetEval, second: &SetEval| {
                let (with, without) = if this_has_history { (this, second) } else { (second, this) };
                format!(
                    "| {name} | {} ({}) | {} ({}) | {:+.2} points |",
                    pct(&with.int8_ar_raw.all),
                    pct(&with.float_ar_raw.all),
                    pct(&without.int8_ar_raw.all),
                    pct(&without.float_zero_labels),
                    100.0 * (with.int8_ar_raw.all.accuracy() - without.int8_ar_raw.all.accuracy())
                )
            };
            let _ = writeln!(s, "{}", line("validation", &r.val, av));
            if let (Some(u), Some(au)) = (&r.unseen, au) {
                let _ = writeln!(s, "{}", line("built-in worlds", u, au));
            }
            let _ = writeln!(
                s,
                "\nThe model with the label history, teacher-forced: {} on validation{}.\n",
                pct(if this_has_history { &r.val.float_teacher_forced } else { &av.float_teacher_forced }),
                match (&r.unseen, au) {
                    (Some(u), Some(au)) => format!(
                        ", {} in the built-in worlds",
                        pct(if this_has_history { &u.float_teacher_forced } else { &au.float_teacher_forced })
                    ),
                    _ => String::new(),
                }
            );
        }
        None => {
            let _ = writeln!(
                s,
                "No separately trained model; the \"label input zeroed\" column above is the trained model with \
                 its label history replaced by zeros ({:+.2} points teacher-forced on validation), which \
                 overstates what a model trained without the history would lose.\n",
                100.0 * (r.val.float_teacher_forced.accuracy() - r.val.float_zero_labels.accuracy())
            );
        }
    }
    let _ = writeln!(s, "### The paper, for comparison\n");
    let _ = writeln!(
        s,
        "LIVES reports **86.19 % ± 0.03 %** per-point test accuracy against its ground-truth classifier \
         (ENML, Spot's 0.7 m LTF gate, real data), **+11.63 points** from the label history, and 84.0 % and \
         84.9 % in two unseen buildings. Our labels come from a simulator-exact labeller (0.1 m gate, 99.9 % \
         agreement with the simulator's truth) on procedural buildings, so the numbers are not directly \
         comparable: the task here is cleaner, the training far shorter.\n"
    );
    if let Some(n) = &r.notes {
        let _ = writeln!(s, "## Notes\n\n{}\n", n.trim_end());
    }
    let _ = writeln!(s, "## Limits\n");
    let _ = writeln!(
        s,
        "- Simulated 2D LiDAR (1 cm noise, 1 % dropout, exact poses); no real-robot data.\n\
         - CPU-sized training (see above), one seed; no error bars.\n\
         - The unseen-world episodes are random walks, not searches.\n\
         - Beams with no return are never scored (the firmware leaves them unlabelled)."
    );
    let _ = writeln!(s, "\nQuantisation and evaluation took {:.0} s.", r.seconds);
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::SplitMix64;

    fn random_inputs(rng: &mut SplitMix64) -> FloatInputs {
        FloatInputs {
            scans: (0..HISTORY * BEAMS).map(|_| rng.unit() as f32).collect(),
            labels: (0..LABEL_ROWS * BEAMS)
                .map(|_| match rng.next_u64() % 3 {
                    0 => 1.0,
                    1 => -1.0,
                    _ => rng.symmetric(1.0),
                })
                .collect(),
            poses: std::array::from_fn(|_| std::array::from_fn(|_| rng.symmetric(1.0))),
        }
    }

    fn batch_of(xs: &[FloatInputs]) -> Batch {
        let mut b = Batch::new();
        for x in xs {
            b.scans.extend_from_slice(&x.scans);
            b.labels.extend_from_slice(&x.labels);
            b.poses.extend(x.poses.iter().flatten());
            b.n += 1;
        }
        b
    }

    /// The candle network and `FloatModel::forward` agree (random weights, random inputs).
    #[test]
    fn candle_forward_matches_float_model() {
        for seed in [3u64, 4] {
            let m = if seed == 3 { FloatModel::random(seed) } else { pytorch_init(seed) };
            let net = LabelPoseNet::from_float(&m, &Device::Cpu).unwrap();
            let mut rng = SplitMix64(seed + 100);
            let xs: Vec<FloatInputs> = (0..3).map(|_| random_inputs(&mut rng)).collect();
            let out = net.forward_batch(&batch_of(&xs)).unwrap().to_vec2::<f32>().unwrap();
            let mut max_err = 0.0f32;
            for (x, o) in xs.iter().zip(&out) {
                let want = m.forward(x);
                for (a, b) in want.iter().zip(o) {
                    max_err = max_err.max((a - b).abs());
                }
            }
            assert!(max_err < 1e-5, "max |candle − float| = {max_err}");
        }
    }

    #[test]
    fn export_round_trips_and_checkpoint_loads() {
        let m = pytorch_init(7);
        let net = LabelPoseNet::from_float(&m, &Device::Cpu).unwrap();
        assert_eq!(net.to_float().unwrap(), m);
        assert_eq!(m.parameter_count(), 1_684_766);
        let dir = std::env::temp_dir().join(format!("lives-train-test-{}", std::process::id()));
        let path = dir.join("ckpt.safetensors");
        let mut cfg = TrainConfig::new("nowhere");
        cfg.command = "lives train --test".into();
        let log = TrainLog {
            config: cfg,
            dataset_command: "lives dataset".into(),
            worlds: [1, 2],
            records: [3, 4],
            samples: [5, 6],
            epochs: vec![EpochLog { epoch: 1, train_loss: 0.5, val_accuracy: 0.8, val_ar_accuracy: 0.7, train_s: 1.0 }],
            total_s: 2.0,
            parameters: 1_684_766,
            threads: 2,
        };
        save_checkpoint(&m, Some(&log), &path).unwrap();
        let (back, back_log) = load_checkpoint(&path).unwrap();
        assert_eq!(back, m);
        assert_eq!(back_log, Some(log));
        // The shapes are PyTorch's.
        let bytes = std::fs::read(&path).unwrap();
        let st = safetensors::SafeTensors::deserialize(&bytes).unwrap();
        assert_eq!(st.tensor("scan.conv_w").unwrap().shape(), &[1, 1, 9, 9]);
        assert_eq!(st.tensor("pose.conv_w").unwrap().shape(), &[9, 1, 1, 3]);
        assert_eq!(st.tensor("label.fc_w").unwrap().shape(), &[897, 897]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    fn toy_episode(len: usize) -> Episode {
        let mut rng = SplitMix64(5);
        let steps = (0..len)
            .map(|i| Step {
                pose: Pose2::from_f64(1.0 + 0.1 * i as f64, -2.0, 0.05 * i as f64).unwrap(),
                ranges_mm: (0..BEAMS)
                    .map(|b| match b % 50 {
                        0 => 0,
                        1 => u16::MAX,
                        _ => 500 + (rng.next_u64() % 20_000) as u16,
                    })
                    .collect(),
                labels: (0..BEAMS).map(|b| if b % 50 < 2 { 0 } else { 1 + (b % 3) as u8 }).collect(),
            })
            .collect();
        Episode { name: "toy".into(), steps }
    }

    /// Beams of a toy scan without a label.
    fn unlabelled() -> usize {
        (0..BEAMS).filter(|b| b % 50 < 2).count()
    }

    #[test]
    fn samples_follow_the_firmware_conventions() {
        let ep = toy_episode(12);
        let norm = Normalisation::DEFAULT;
        assert_eq!(sample_index(std::slice::from_ref(&ep), false).len(), 12 - 8);
        assert_eq!(sample_index(std::slice::from_ref(&ep), true).len(), 12);
        let x = sample_inputs(&ep, 10, &norm);
        // The same as FloatHistory fed with the true labels.
        let mut h = FloatHistory::new(norm);
        for s in 2..=10 {
            h.push_scan(&ep.steps[s].pose, &ep.steps[s].ranges_mm);
        }
        for s in 2..10 {
            h.push_labels(&ep.steps[s].labels.iter().map(|&c| label_sign(c)).collect::<Vec<_>>());
        }
        assert_eq!(h.inputs(), x);
        assert_eq!(x.poses[HISTORY - 1], [0.0, 0.0, 0.0]);
        assert_eq!(x.scans[8 * BEAMS], 0.0, "invalid → 0");
        assert_eq!(x.scans[8 * BEAMS + 1], 1.0, "no return → 1");
        // Flips: about 10 % of the non-zero history entries change sign; zeros stay zero.
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut b = Batch::new();
        fill_sample(&ep, 10, &norm, &mut LabelHistory::Flipped(&mut rng, 0.1), &mut b);
        let (mut flipped, mut nonzero) = (0, 0);
        for (a, t) in b.labels.iter().zip(&x.labels) {
            if *t == 0.0 {
                assert_eq!(*a, 0.0);
            } else {
                nonzero += 1;
                flipped += (a != t) as usize;
            }
        }
        let rate = flipped as f64 / nonzero as f64;
        assert!((0.08..0.12).contains(&rate), "flip rate {rate}");
        assert_eq!(b.mask.iter().filter(|&&m| m == 0.0).count(), unlabelled());
    }

    /// A few optimiser steps on one batch lower the loss, and two runs give the same weights.
    #[test]
    fn training_steps_lower_the_loss_deterministically() {
        let ep = toy_episode(10);
        let run = || {
            let net = LabelPoseNet::from_float(&pytorch_init(2), &Device::Cpu).unwrap();
            let mut opt = AdamW::new(net.vars(), ParamsAdamW { lr: 1e-3, weight_decay: 0.0, ..ParamsAdamW::default() }).unwrap();
            let mut b = Batch::new();
            fill_sample(&ep, 8, &net.norm, &mut LabelHistory::True, &mut b);
            fill_sample(&ep, 9, &net.norm, &mut LabelHistory::True, &mut b);
            let target = Tensor::from_slice(&b.target, (b.n, BEAMS), &Device::Cpu).unwrap();
            let mask = Tensor::from_slice(&b.mask, (b.n, BEAMS), &Device::Cpu).unwrap();
            let mut losses = Vec::new();
            for _ in 0..5 {
                let loss = masked_mse(&net.forward_batch(&b).unwrap(), &target, &mask).unwrap();
                losses.push(loss.to_scalar::<f32>().unwrap());
                opt.backward_step(&loss).unwrap();
            }
            (losses, net.to_float().unwrap())
        };
        let (l1, m1) = run();
        let (l2, m2) = run();
        assert!(l1[4] < l1[0], "loss {l1:?}");
        assert_eq!(l1, l2);
        assert!(m1 == m2, "same seed, same weights");
    }

    /// The circulant parameterisation: the exported weight is circulant (row o is row 0 shifted
    /// by o), training steps keep it so, and switching back to full matrices changes nothing.
    #[test]
    fn circulant_training_exports_a_circulant_matrix() {
        let ep = toy_episode(10);
        let mut init = pytorch_init(4);
        init.norm.range_encoding = RangeEncoding::Inverse;
        init.norm.range_max_mm = 500;
        let mut net = LabelPoseNet::from_float(&init, &Device::Cpu).unwrap();
        net.scan.make_circulant().unwrap();
        net.label.make_circulant().unwrap();
        let mut opt = AdamW::new(net.vars(), ParamsAdamW { lr: 1e-3, weight_decay: 0.0, ..ParamsAdamW::default() }).unwrap();
        let mut b = Batch::new();
        fill_sample(&ep, 9, &net.norm, &mut LabelHistory::True, &mut b);
        let target = Tensor::from_slice(&b.target, (b.n, BEAMS), &Device::Cpu).unwrap();
        let mask = Tensor::from_slice(&b.mask, (b.n, BEAMS), &Device::Cpu).unwrap();
        for _ in 0..2 {
            let loss = masked_mse(&net.forward_batch(&b).unwrap(), &target, &mask).unwrap();
            opt.backward_step(&loss).unwrap();
        }
        let m = net.to_float().unwrap();
        for o in [1usize, 100, 896] {
            for i in [0usize, 5, 450, 896] {
                assert_eq!(m.scan.fc_w[o * BEAMS + i], m.scan.fc_w[(i + BEAMS - o) % BEAMS], "W[{o}][{i}] = c[(i − o) mod 897]");
            }
        }
        let before = net.forward_batch(&b).unwrap().flatten_all().unwrap().to_vec1::<f32>().unwrap();
        net.scan.make_full().unwrap();
        net.label.make_full().unwrap();
        let after = net.forward_batch(&b).unwrap().flatten_all().unwrap().to_vec1::<f32>().unwrap();
        assert_eq!(before, after);
        assert_eq!(net.to_float().unwrap(), m);
        // The inverse range encoding survives a checkpoint.
        let path = std::env::temp_dir().join(format!("lives-train-circ-{}.safetensors", std::process::id()));
        save_checkpoint(&m, None, &path).unwrap();
        let (back, _) = load_checkpoint(&path).unwrap();
        assert_eq!(back.norm, m.norm);
        let _ = std::fs::remove_file(&path);
    }

    #[test]
    fn int8_evaluation_runs_on_a_blob() {
        let m = pytorch_init(3);
        let ep = toy_episode(10);
        let blob = crate::model::quantise(&m, &calibration_inputs(&m, std::slice::from_ref(&ep), 2, 4));
        let acc = evaluate_int8(&blob, std::slice::from_ref(&ep), LabelFeedback::Raw).unwrap();
        assert_eq!(acc.all.total() as usize, 10 * (BEAMS - unlabelled()));
        assert_eq!(acc.warm.total() as usize, 2 * (BEAMS - unlabelled()));
        let fl = evaluate_float_autoregressive(&m, std::slice::from_ref(&ep), Feedback::Raw);
        assert_eq!(fl.all.total(), acc.all.total());
    }
}
