//! Samples: episodes read from the dataset, the label histories, batches, rollouts and the loss.

use super::*;
use crate::learn::dataset::{self, DatasetReader, Split};
use crate::learn::model::{normalise_pose_f32, normalise_scan_f32, FloatInputs};
use crate::run::range::{encode_range, RangeLimits};
use candle_core::{Device, Tensor};
use firmware::capacity::BEAMS;
use firmware::classifier::{Normalisation, HISTORY, LABEL_ROWS, POSE_FEATURES};
use fixed_point::Pose2;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use std::path::Path;

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
pub(super) fn sim_limits() -> RangeLimits {
    crate::run::sim_limits(&dataset::sim_config())
}

pub(super) fn pose_of(p: [f64; 3]) -> Result<Pose2> {
    Pose2::from_f64(p[0], p[1], p[2]).ok_or_else(|| TrainError(format!("pose {p:?} out of the Q16.16 range")))
}

/// A step from a dataset record (ranges encoded as `crate::run::range::encode_range` does for the core).
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
