//! Accuracy: confusion counts, teacher-forced and autoregressive evaluation (float and int8),
//! and the scan-bias calibration.

use super::*;
use crate::learn::model::{FloatHistory, FloatModel};
use firmware::capacity::BEAMS;
use firmware::classifier::{Classifier, ClassifierConfig, LabelFeedback, ModelView, LABEL_ROWS};
use serde::{Deserialize, Serialize};

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
        crate::learn::add_counts(&mut self.counts, &o.counts);
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

    pub(super) fn add_row(&mut self, step: usize, out: &[f32], labels: &[u8]) {
        self.all.add_row(out, labels);
        if step >= LABEL_ROWS {
            self.warm.add_row(out, labels);
        }
    }
}

/// Runs `f` over `episodes` on two threads (the machine has two cores) and merges the results.
pub(super) fn par_episodes(episodes: &[Episode], f: impl Fn(&Episode) -> ArAccuracy + Sync) -> ArAccuracy {
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
