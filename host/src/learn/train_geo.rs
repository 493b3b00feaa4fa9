//! Training, quantisation and evaluation of the geometric classifier
//! (`firmware::classifier::geo`): per-beam shape features of the newest scan and a
//! `GEO_FEATURES → GEO_HIDDEN → 1` MLP (`lives train-geo`, docs/model-card-geo.md).
//!
//! The features are computed by the firmware's own integer code, so the float model trains on
//! exactly what the int8 model sees. Training is plain stochastic gradient descent on the logistic
//! loss (map = 1), in `f32`, single-threaded and seeded: the same data and seed give the same
//! blob, byte for byte. Quantisation follows the `LabelPoseNet` conventions (docs/model-format.md):
//! int8 weights per output channel, int32 biases and accumulators, a fixed-point multiplier into
//! a 256-entry tanh table whose input scale is calibrated on training features.

use crate::learn::train::{Confusion, Episode, Result, TrainError};
use firmware::capacity::BEAMS;
use firmware::classifier::geo::{
    write_geo_blob, GeoChannel, GeoScratch, GeoView, HistoryReader, GEO_BLOB_LEN, GEO_FEATURES, GEO_HIDDEN, SCAN_FEATURES,
};
use firmware::classifier::{Classifier, ClassifierConfig, Normalisation, ScanHistory};
use firmware::scan::BeamLabel;
use fixed_point::QuantizedMultiplier;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// One training sample: a beam's features and whether the labeller calls it map.
pub type Sample = ([i8; GEO_FEATURES], bool);

/// The shape features (label-history features zero) of every `beam_stride`-th labelled beam
/// (offset varying with the step) of every `step_stride`-th step.
pub fn samples(episodes: &[Episode], step_stride: usize, beam_stride: usize) -> Vec<Sample> {
    let mut out = Vec::new();
    let mut scratch = Box::new(GeoScratch::new());
    let mut k = 0usize;
    for ep in episodes {
        for st in &ep.steps {
            k += 1;
            if !k.is_multiple_of(step_stride.max(1)) {
                continue;
            }
            let Ok(ranges) = <&[u16; BEAMS]>::try_from(&st.ranges_mm[..]) else { continue };
            scratch.prepare(ranges);
            for b in (k % beam_stride.max(1)..BEAMS).step_by(beam_stride.max(1)) {
                let code = st.labels[b];
                if code == 0 || ranges[b] == 0 || ranges[b] == u16::MAX {
                    continue;
                }
                out.push((scratch.features(ranges, b), code == 1));
            }
        }
    }
    out
}

/// The float MLP: `logit = w2 · tanh(W1 · x / 127 + b1) + b2`, map when `logit ≥ 0`.
#[derive(Clone, Debug, PartialEq)]
pub struct GeoMlp {
    /// Hidden weights, `[GEO_HIDDEN][GEO_FEATURES]`.
    pub w1: Vec<[f32; GEO_FEATURES]>,
    /// Hidden biases.
    pub b1: Vec<f32>,
    /// Output weights.
    pub w2: Vec<f32>,
    /// Output bias.
    pub b2: f32,
}

impl GeoMlp {
    /// Uniform ±1/√fan-in hidden weights (zero on the label-history inputs, so a model trained
    /// without history ignores them at run time), ±0.2 output weights, zero biases.
    pub fn init(rng: &mut ChaCha8Rng) -> Self {
        let s = 1.0 / (GEO_FEATURES as f32).sqrt();
        GeoMlp {
            w1: (0..GEO_HIDDEN).map(|_| core::array::from_fn(|i| if i < SCAN_FEATURES { rng.gen_range(-s..s) } else { 0.0 })).collect(),
            b1: vec![0.0; GEO_HIDDEN],
            w2: (0..GEO_HIDDEN).map(|_| rng.gen_range(-0.2..0.2)).collect(),
            b2: 0.0,
        }
    }

    /// Hidden pre-activations of one input.
    fn pre(&self, x: &[i8; GEO_FEATURES], pre: &mut [f32; GEO_HIDDEN]) {
        for (j, p) in pre.iter_mut().enumerate() {
            let mut s = self.b1[j];
            for (w, &xi) in self.w1[j].iter().zip(x) {
                s += w * (xi as f32 / 127.0);
            }
            *p = s;
        }
    }

    /// The logit (≥ 0: map).
    pub fn logit(&self, x: &[i8; GEO_FEATURES]) -> f32 {
        let mut pre = [0f32; GEO_HIDDEN];
        self.pre(x, &mut pre);
        self.b2 + pre.iter().zip(&self.w2).map(|(p, w)| p.tanh() * w).sum::<f32>()
    }

    /// One SGD step on the logistic loss; returns the loss.
    fn step(&mut self, x: &[i8; GEO_FEATURES], map: bool, lr: f32) -> f32 {
        let mut h = [0f32; GEO_HIDDEN];
        self.pre(x, &mut h);
        h.iter_mut().for_each(|v| *v = v.tanh());
        let o = self.b2 + h.iter().zip(&self.w2).map(|(a, w)| a * w).sum::<f32>();
        let y = if map { 1.0 } else { 0.0 };
        let p = 1.0 / (1.0 + (-o).exp());
        let g = p - y;
        for (((w1, b1), w2), &hj) in self.w1.iter_mut().zip(self.b1.iter_mut()).zip(self.w2.iter_mut()).zip(h.iter()) {
            let gh = g * *w2 * (1.0 - hj * hj);
            *w2 -= lr * g * hj;
            *b1 -= lr * gh;
            for (w, &xi) in w1.iter_mut().zip(x) {
                *w -= lr * gh * (xi as f32 / 127.0);
            }
        }
        self.b2 -= lr * g;
        let pc = if map { p } else { 1.0 - p };
        -(pc.max(1e-7)).ln()
    }
}

/// Training settings.
#[derive(Clone, Debug)]
pub struct GeoTrainConfig {
    /// Passes over the samples.
    pub epochs: usize,
    /// Initial learning rate (divided by 1 + epoch).
    pub lr: f32,
    /// Seed of the initialisation and the shuffles.
    pub seed: u64,
}

impl Default for GeoTrainConfig {
    fn default() -> Self {
        GeoTrainConfig { epochs: 6, lr: 0.02, seed: 1 }
    }
}

/// Trains on `train`; `epoch_done(epoch, mean loss, model)` after each pass.
pub fn train(cfg: &GeoTrainConfig, train: &[Sample], mut epoch_done: impl FnMut(usize, f64, &GeoMlp)) -> Result<GeoMlp> {
    if train.is_empty() {
        return Err(TrainError("no training samples (an empty dataset split?)".into()));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let mut m = GeoMlp::init(&mut rng);
    let mut order: Vec<u32> = (0..train.len() as u32).collect();
    for epoch in 0..cfg.epochs {
        for i in (1..order.len()).rev() {
            let j = rng.gen_range(0..=i);
            order.swap(i, j);
        }
        let lr = cfg.lr / (1.0 + epoch as f32);
        let mut loss = 0f64;
        for &i in &order {
            let (x, y) = &train[i as usize];
            loss += m.step(x, *y, lr) as f64;
        }
        epoch_done(epoch, loss / order.len() as f64, &m);
    }
    Ok(m)
}

/// What the quantiser chose.
#[derive(Clone, Debug)]
pub struct GeoQuantisation {
    /// The blob.
    pub blob: Vec<u8>,
    /// Largest |pre-activation| over the calibration samples, before clipping.
    pub max_pre: f32,
    /// The tanh table's input range (|pre-activation| that maps to int8 127).
    pub pre_range: f32,
}

/// The default clip of the tanh table's input range: tanh(3) ≈ 0.995, and a table step of
/// 3/127 in the pre-activation.
pub const DEFAULT_PRE_CLIP: f32 = 3.0;

/// Quantises `m`, calibrating the hidden pre-activation scale on `calibration`: the table covers
/// the largest |pre-activation| seen, at most `pre_clip` (larger values saturate).
pub fn quantise(m: &GeoMlp, calibration: &[Sample], pre_clip: f32) -> Result<GeoQuantisation> {
    let mut max_pre = 0f32;
    let mut pre = [0f32; GEO_HIDDEN];
    for (x, _) in calibration {
        m.pre(x, &mut pre);
        max_pre = pre.iter().fold(max_pre, |a, p| a.max(p.abs()));
    }
    if !max_pre.is_finite() {
        return Err(TrainError("non-finite pre-activations: the model diverged".into()));
    }
    let pre_range = max_pre.clamp(1e-3, pre_clip.max(1e-3));
    let s_pre = pre_range as f64 / 127.0;
    let mult = |real: f64| QuantizedMultiplier::from_f64(real).ok_or_else(|| TrainError(format!("multiplier {real} not representable")));
    let mut hidden = [GeoChannel { bias: 0, multiplier: QuantizedMultiplier::ZERO }; GEO_HIDDEN];
    let mut w1 = [[0i8; GEO_FEATURES]; GEO_HIDDEN];
    for j in 0..GEO_HIDDEN {
        let max_w = m.w1[j].iter().fold(0f32, |a, w| a.max(w.abs())).max(1e-8) as f64;
        let sw = max_w / 127.0;
        for (q, &w) in w1[j].iter_mut().zip(&m.w1[j]) {
            *q = (w as f64 / sw).round().clamp(-127.0, 127.0) as i8;
        }
        // Accumulator scale: sw · 1/127.
        let acc_scale = sw / 127.0;
        hidden[j] = GeoChannel { bias: (m.b1[j] as f64 / acc_scale).round() as i32, multiplier: mult(acc_scale / s_pre)? };
    }
    let tanh: [i8; 256] = core::array::from_fn(|i| ((((i as f64) - 128.0) * s_pre).tanh() * 127.0).round() as i8);
    // The output weights are int16 (one scale for the layer).
    let max_w2 = m.w2.iter().fold(0f32, |a, w| a.max(w.abs())).max(1e-8) as f64;
    let s2 = max_w2 / 32_767.0;
    let w2: [i16; GEO_HIDDEN] = core::array::from_fn(|j| (m.w2[j] as f64 / s2).round().clamp(-32_767.0, 32_767.0) as i16);
    let acc2_scale = s2 / 127.0;
    // The int8 output shows the logit over 4 (127 = a logit of 4 or more).
    let output = GeoChannel { bias: (m.b2 as f64 / acc2_scale).round() as i32, multiplier: mult(acc2_scale / (4.0 / 127.0))? };
    let mut blob = [0u8; GEO_BLOB_LEN];
    write_geo_blob(&hidden, output, &tanh, &w1, &w2, &mut blob);
    GeoView::parse(&blob).map_err(|e| TrainError(format!("the firmware refuses the quantised blob: {e:?}")))?;
    Ok(GeoQuantisation { blob: blob.to_vec(), max_pre, pre_range })
}

/// The float model against the labeller on samples.
pub fn evaluate_float(m: &GeoMlp, samples: &[Sample]) -> Confusion {
    let mut c = Confusion::default();
    for (x, map) in samples {
        c.add(*map, m.logit(x) >= 0.0);
    }
    c
}

/// Runs `blob` through the firmware's classifier over every step of `episodes` (each from the
/// bootstrap state, as on the robot), calling `visit(step, features, int8 labels)` with every
/// beam's full input — shape and label-history features exactly as the firmware built them —
/// before the step is classified, and the labels it then gave.
fn run_firmware(
    blob: &[u8],
    episodes: &[Episode],
    mut visit: impl FnMut(&crate::learn::train::Step, &dyn Fn(usize) -> [i8; GEO_FEATURES], &[BeamLabel; BEAMS]),
) -> Result<()> {
    let view = GeoView::parse(blob).map_err(|e| TrainError(format!("the firmware refuses the blob: {e:?}")))?;
    let mut cls = Box::new(Classifier::new(ClassifierConfig::default()));
    cls.set_geo_model(view);
    let mut scratch = Box::new(GeoScratch::new());
    let mut mirror = Box::new(ScanHistory::new());
    let mut out = [BeamLabel::Unlabelled; BEAMS];
    for ep in episodes {
        cls.reset();
        mirror.clear();
        for st in &ep.steps {
            let ranges = <&[u16; BEAMS]>::try_from(&st.ranges_mm[..])
                .map_err(|_| TrainError(format!("{}: a scan without {BEAMS} beams", ep.name)))?;
            // The same history the classifier reads: this scan's pose, the earlier outputs.
            mirror.push_scan(&st.pose, ranges, &Normalisation::DEFAULT);
            scratch.prepare(ranges);
            cls.classify_ranges(&st.pose, ranges, &mut out);
            let (s, h) = (&*scratch, HistoryReader::new(&mirror));
            let features = |b: usize| {
                let mut x = s.features(ranges, b);
                let [last, avg] = h.features(b);
                x[SCAN_FEATURES] = last;
                x[SCAN_FEATURES + 1] = avg;
                x
            };
            visit(st, &features, &out);
            mirror.push_labels(cls.output());
        }
    }
    Ok(())
}

/// Training samples with the label history of `blob`'s own autoregressive outputs (the firmware
/// run on `episodes`), every `step_stride`-th step and `beam_stride`-th labelled beam; each history
/// feature negated with probability `flip` (the paper corrupts 10 % of the history labels).
pub fn rollout_samples(
    blob: &[u8],
    episodes: &[Episode],
    step_stride: usize,
    beam_stride: usize,
    flip: f64,
    seed: u64,
) -> Result<Vec<Sample>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut v = Vec::new();
    let mut k = 0usize;
    run_firmware(blob, episodes, |st, features, _| {
        k += 1;
        if k % step_stride.max(1) != 0 {
            return;
        }
        for b in (k % beam_stride.max(1)..BEAMS).step_by(beam_stride.max(1)) {
            let code = st.labels[b];
            if code == 0 || st.ranges_mm[b] == 0 || st.ranges_mm[b] == u16::MAX {
                continue;
            }
            let mut x = features(b);
            for i in [SCAN_FEATURES, SCAN_FEATURES + 1] {
                if rng.gen_bool(flip.clamp(0.0, 1.0)) {
                    x[i] = x[i].saturating_neg();
                }
            }
            v.push((x, code == 1));
        }
    })?;
    Ok(v)
}

/// The int8 blob run through the firmware's classifier (`Controller`'s own path, autoregressive)
/// over every step of `episodes`, against the labeller; with the float model's agreement with it
/// (sign per labelled beam, on the same inputs) when `float` is given.
pub fn evaluate_int8(blob: &[u8], episodes: &[Episode], float: Option<&GeoMlp>) -> Result<(Confusion, Option<f64>)> {
    let mut c = Confusion::default();
    let (mut agree, mut total) = (0u64, 0u64);
    run_firmware(blob, episodes, |st, features, out| {
        for b in 0..BEAMS {
            let code = st.labels[b];
            if code == 0 || out[b] == BeamLabel::Unlabelled {
                continue;
            }
            let int8_map = out[b] == BeamLabel::Map;
            c.add(code == 1, int8_map);
            if let Some(f) = float {
                total += 1;
                agree += ((f.logit(&features(b)) >= 0.0) == int8_map) as u64;
            }
        }
    })?;
    Ok((c, float.map(|_| agree as f64 / total.max(1) as f64)))
}

/// Per-point accuracy of an int8 blob of either format (`LVGM` geometric, `LIVM` `LabelPoseNet`)
/// through the firmware, autoregressive from a reset, for each episode: `(episode name, tally)`.
pub fn evaluate_blob_per_episode(blob: &[u8], episodes: &[Episode]) -> Result<Vec<(String, Confusion)>> {
    let mut out = Vec::new();
    for ep in episodes {
        let one = std::slice::from_ref(ep);
        let c = if GeoView::is_geo(blob) {
            evaluate_int8(blob, one, None)?.0
        } else {
            crate::learn::train::evaluate_int8(blob, one, firmware::classifier::LabelFeedback::Raw)?.all
        };
        out.push((ep.name.clone(), c));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::train::Step;
    use fixed_point::Pose2;

    /// A square room 8 m across seen from its centre, with a 1 m box standing 1.5 m in front of
    /// one wall: walls are map (1), the box's beams non-map (2).
    fn room_episode(steps: usize) -> Episode {
        let mut out = Vec::new();
        for s in 0..steps {
            let yaw = s as f64 * 0.05;
            let mut ranges = vec![0u16; BEAMS];
            let mut labels = vec![0u8; BEAMS];
            for b in 0..BEAMS {
                let a = yaw - std::f64::consts::PI + b as f64 * std::f64::consts::TAU / BEAMS as f64;
                let (c, sn) = (a.cos(), a.sin());
                // Walls at |x| = 4, |y| = 4.
                let tx = if c.abs() > 1e-9 { 4.0 / c.abs() } else { f64::INFINITY };
                let ty = if sn.abs() > 1e-9 { 4.0 / sn.abs() } else { f64::INFINITY };
                let mut r = tx.min(ty);
                let mut label = 1u8;
                // Box face at x = 2.5, y in [-0.5, 0.5].
                if c > 0.0 {
                    let t = 2.5 / c;
                    let y = t * sn;
                    if (-0.5..=0.5).contains(&y) && t < r {
                        r = t;
                        label = 2;
                    }
                }
                ranges[b] = (r * 1000.0).round() as u16;
                labels[b] = label;
            }
            out.push(Step { pose: Pose2::default(), ranges_mm: ranges, labels });
        }
        Episode { name: "room".into(), steps: out }
    }

    #[test]
    fn train_geo_learns_a_box_against_walls_quantises_and_the_firmware_agrees() {
        let ep = vec![room_episode(20)];
        let data = samples(&ep, 1, 1);
        assert!(data.iter().any(|s| !s.1) && data.iter().any(|s| s.1));
        let mut losses = Vec::new();
        let m = train(&GeoTrainConfig { epochs: 4, lr: 0.05, seed: 3 }, &data, |_, l, _| losses.push(l)).unwrap();
        assert!(losses.last().unwrap() < &(losses[0] * 0.8), "loss fell: {losses:?}");
        let fl = evaluate_float(&m, &data);
        assert!(fl.accuracy() > fl.always_map() + 0.05, "float {} vs always map {}", fl.accuracy(), fl.always_map());
        let q = quantise(&m, &data, DEFAULT_PRE_CLIP).unwrap();
        let (int8, agree) = evaluate_int8(&q.blob, &ep, Some(&m)).unwrap();
        assert!(int8.accuracy() > int8.always_map() + 0.05, "int8 {} vs always map {}", int8.accuracy(), int8.always_map());
        assert!(agree.unwrap() > 0.98, "float/int8 agreement {agree:?}");
        // Same data, same seed: the same blob.
        let m2 = train(&GeoTrainConfig { epochs: 4, lr: 0.05, seed: 3 }, &data, |_, _, _| {}).unwrap();
        assert_eq!(quantise(&m2, &data, DEFAULT_PRE_CLIP).unwrap().blob, q.blob);
        // Trained without history, the model ignores its history inputs.
        assert!(m.w1.iter().all(|row| row[SCAN_FEATURES..].iter().all(|&w| w == 0.0)));
        // A DAgger round: the history comes from the model's own outputs through the firmware,
        // and the history model still classifies the room and agrees with its int8 self.
        let hist = rollout_samples(&q.blob, &ep, 1, 1, 0.1, 5).unwrap();
        assert_eq!(hist.len(), data.len());
        assert!(hist.iter().skip(BEAMS).any(|(x, _)| x[SCAN_FEATURES] != 0), "no history after the first scan");
        let mh = train(&GeoTrainConfig { epochs: 4, lr: 0.05, seed: 3 }, &hist, |_, _, _| {}).unwrap();
        let qh = quantise(&mh, &hist, DEFAULT_PRE_CLIP).unwrap();
        let (int8, agree) = evaluate_int8(&qh.blob, &ep, Some(&mh)).unwrap();
        assert!(int8.accuracy() > int8.always_map() + 0.05, "history model int8 {} vs always map {}", int8.accuracy(), int8.always_map());
        assert!(agree.unwrap() > 0.98, "history model float/int8 agreement {agree:?}");
    }

    #[test]
    fn train_geo_per_episode_evaluation_reads_both_formats_and_refuses_garbage() {
        let eps = vec![room_episode(3), Episode { name: "again".into(), ..room_episode(2) }];
        let data = samples(&eps, 1, 1);
        let m = train(&GeoTrainConfig { epochs: 1, lr: 0.05, seed: 1 }, &data, |_, _, _| {}).unwrap();
        let q = quantise(&m, &data, DEFAULT_PRE_CLIP).unwrap();
        let per = evaluate_blob_per_episode(&q.blob, &eps).unwrap();
        assert_eq!(per.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>(), ["room", "again"]);
        let pooled = evaluate_int8(&q.blob, &eps, None).unwrap().0;
        assert_eq!(per.iter().map(|(_, c)| c.total()).sum::<u64>(), pooled.total());
        // A LabelPoseNet blob goes through its own path.
        let lpn = evaluate_blob_per_episode(firmware::classifier::EMBEDDED_MODEL, &eps).unwrap();
        assert_eq!(lpn.len(), 2);
        assert!(evaluate_blob_per_episode(b"garbage", &eps).is_err());
    }

    #[test]
    fn train_geo_refuses_an_empty_split() {
        assert!(train(&GeoTrainConfig::default(), &[], |_, _, _| {}).is_err());
    }
}
