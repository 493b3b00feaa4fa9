//! The classifier's float reference model and the offline int8 quantiser that writes the model
//! blob the firmware runs (`docs/model-format.md`).
//!
//! - [`FloatModel`]: `LabelPoseNet` in `f32`, weights in plain `Vec`s in PyTorch's layouts
//!   (`Conv2d` weight `[out][in][kh][kw]`, `Linear` weight `[out][in]`), with a forward pass
//!   ([`FloatModel::forward`]) that is the specification the int8 firmware is measured against.
//! - [`FloatHistory`]: the float twin of `firmware::classifier::ScanHistory` (same normalisation,
//!   same bootstrap), to run the float model autoregressively.
//! - [`quantise`]: per-output-channel symmetric int8 weights, int32 biases, pre-activation scales
//!   calibrated on example inputs (max |x|, clipped where tanh saturates), 256-entry tanh tables,
//!   all written through `firmware::classifier::ModelWriter` so the layout has one implementation.
//!
//! The blob is what the robot flashes; `firmware::classifier::ModelView::parse` checks it.

use firmware::capacity::BEAMS;
use firmware::classifier::{
    model::layout, ChannelParams, HeadParams, Layer, ModelWriter, Normalisation, RangeEncoding, ENC_KERNEL, ENC_PAD, HISTORY, LABEL_ROWS,
    POSE_CHANNELS, POSE_FEATURES, POSE_FLAT,
};
use firmware::scan::{RANGE_INVALID, RANGE_NO_RETURN};
use fixed_point::{Pose2, QuantizedMultiplier};

/// One encoder (scan or label): Conv2d(1 → 1, 9 × 9, circular padding 4 along the beams) → tanh →
/// Linear(897 → 897) → tanh.
#[derive(Clone, Debug, PartialEq)]
pub struct Encoder {
    /// Conv weight `[t][j]` (t = history row, oldest first; j = beam offset j − 4), 81 values.
    pub conv_w: Vec<f32>,
    /// Conv bias.
    pub conv_b: f32,
    /// Linear weight `[out][in]`, 897 × 897.
    pub fc_w: Vec<f32>,
    /// Linear bias, 897.
    pub fc_b: Vec<f32>,
}

/// The pose encoder: Conv2d(1 → 9, kernel 1 × 3) → tanh → flatten 81 (channel-major) →
/// Linear(81 → 897) → tanh.
#[derive(Clone, Debug, PartialEq)]
pub struct PoseEncoder {
    /// Conv weight `[c][f]` (f = x, y, θ), 9 × 3.
    pub conv_w: Vec<f32>,
    /// Conv bias, 9.
    pub conv_b: Vec<f32>,
    /// Linear weight `[out][in]`, 897 × 81, `in = c · 9 + t`.
    pub fc_w: Vec<f32>,
    /// Linear bias, 897.
    pub fc_b: Vec<f32>,
}

/// `LabelPoseNet` in `f32`.
#[derive(Clone, Debug, PartialEq)]
pub struct FloatModel {
    /// Scan encoder.
    pub scan: Encoder,
    /// Label encoder.
    pub label: Encoder,
    /// Pose encoder.
    pub pose: PoseEncoder,
    /// How raw ranges and poses were normalised in training (written into the blob).
    pub norm: Normalisation,
}

/// One step's network inputs, normalised (see `docs/model-format.md`).
#[derive(Clone, Debug, PartialEq)]
pub struct FloatInputs {
    /// Scans `[k][897]`, oldest first, in [0, 1].
    pub scans: Vec<f32>,
    /// The k − 1 earlier outputs `[8][897]`, oldest first, in [−1, 1]. The weighted-average row is
    /// computed by the forward pass.
    pub labels: Vec<f32>,
    /// Poses `[k][x, y, θ]` relative to the newest, normalised to [−1, 1].
    pub poses: [[f32; POSE_FEATURES]; HISTORY],
}

impl FloatInputs {
    /// All-zero inputs (the bootstrap state).
    pub fn zeros() -> Self {
        Self { scans: vec![0.0; HISTORY * BEAMS], labels: vec![0.0; LABEL_ROWS * BEAMS], poses: [[0.0; POSE_FEATURES]; HISTORY] }
    }
}

/// Every intermediate of a forward pass.
#[derive(Clone, Debug, PartialEq)]
pub struct Trace {
    /// Pre-activations (tanh inputs) per [`Layer`], in `Layer::ALL` order.
    pub pre: [Vec<f32>; 7],
    /// The scan encoding.
    pub scan_enc: Vec<f32>,
    /// The label encoding.
    pub label_enc: Vec<f32>,
    /// The pose encoding.
    pub pose_enc: Vec<f32>,
    /// `tanh(scan_enc + pose_enc) · label_enc`.
    pub output: Vec<f32>,
}

/// splitmix64: the tiny seeded generator behind [`FloatModel::random`].
pub use fixed_point::SplitMix64;

fn linear_tanh(w: &[f32], b: &[f32], x: &[f32], pre: &mut Vec<f32>) -> Vec<f32> {
    let n = x.len();
    pre.clear();
    pre.extend(b.iter().enumerate().map(|(o, &bo)| bo + w[o * n..o * n + n].iter().zip(x).map(|(w, x)| w * x).sum::<f32>()));
    pre.iter().map(|v| v.tanh()).collect()
}

fn encoder_forward(e: &Encoder, rows: &[f32], conv_pre: &mut Vec<f32>, fc_pre: &mut Vec<f32>) -> Vec<f32> {
    conv_pre.clear();
    for b in 0..BEAMS {
        let mut acc = e.conv_b;
        for t in 0..HISTORY {
            for j in 0..ENC_KERNEL {
                acc += e.conv_w[t * ENC_KERNEL + j] * rows[t * BEAMS + (b + BEAMS + j - ENC_PAD) % BEAMS];
            }
        }
        conv_pre.push(acc);
    }
    let hidden: Vec<f32> = conv_pre.iter().map(|v| v.tanh()).collect();
    linear_tanh(&e.fc_w, &e.fc_b, &hidden, fc_pre)
}

impl Encoder {
    fn random(rng: &mut SplitMix64, gain: f64) -> Self {
        let a_conv = gain * (3.0 / (HISTORY * ENC_KERNEL) as f64).sqrt();
        let a_fc = gain * (3.0 / BEAMS as f64).sqrt();
        Self {
            conv_w: (0..HISTORY * ENC_KERNEL).map(|_| rng.symmetric(a_conv)).collect(),
            conv_b: rng.symmetric(0.2),
            fc_w: (0..BEAMS * BEAMS).map(|_| rng.symmetric(a_fc)).collect(),
            fc_b: (0..BEAMS).map(|_| rng.symmetric(0.2)).collect(),
        }
    }
}

impl FloatModel {
    /// Random weights from `seed` (for tests): uniform, variance-preserving for tanh
    /// (`±gain·√(3 / fan_in)`, gain 1.5), biases uniform in ±0.2, default normalisation.
    pub fn random(seed: u64) -> Self {
        let mut rng = SplitMix64(seed);
        let gain = 1.5;
        let scan = Encoder::random(&mut rng, gain);
        let label = Encoder::random(&mut rng, gain);
        let a_pc = gain * (3.0 / POSE_FEATURES as f64).sqrt();
        let a_pf = gain * (3.0 / POSE_FLAT as f64).sqrt();
        let pose = PoseEncoder {
            conv_w: (0..POSE_CHANNELS * POSE_FEATURES).map(|_| rng.symmetric(a_pc)).collect(),
            conv_b: (0..POSE_CHANNELS).map(|_| rng.symmetric(0.2)).collect(),
            fc_w: (0..BEAMS * POSE_FLAT).map(|_| rng.symmetric(a_pf)).collect(),
            fc_b: (0..BEAMS).map(|_| rng.symmetric(0.2)).collect(),
        };
        Self { scan, label, pose, norm: Normalisation::DEFAULT }
    }

    /// Trainable parameters (the paper's network has 1 684 766).
    pub fn parameter_count(&self) -> usize {
        let enc = |e: &Encoder| e.conv_w.len() + 1 + e.fc_w.len() + e.fc_b.len();
        enc(&self.scan) + enc(&self.label) + self.pose.conv_w.len() + self.pose.conv_b.len() + self.pose.fc_w.len() + self.pose.fc_b.len()
    }

    /// The output per beam, `tanh(scan_enc + pose_enc) · label_enc` ∈ (−1, 1): ≥ 0 map, < 0 non-map.
    pub fn forward(&self, x: &FloatInputs) -> Vec<f32> {
        self.trace(x).output
    }

    /// The forward pass with every intermediate (what the quantiser calibrates on).
    pub fn trace(&self, x: &FloatInputs) -> Trace {
        let mut pre: [Vec<f32>; 7] = Default::default();
        let [p_sc, p_sf, p_lc, p_lf, p_pc, p_pf, p_head] = &mut pre;
        let scan_enc = encoder_forward(&self.scan, &x.scans, p_sc, p_sf);

        let mut label_rows = x.labels.clone();
        let wsum = (LABEL_ROWS * (LABEL_ROWS + 1) / 2) as f32;
        label_rows.extend((0..BEAMS).map(|b| (0..LABEL_ROWS).map(|r| (r + 1) as f32 * x.labels[r * BEAMS + b]).sum::<f32>() / wsum));
        let label_enc = encoder_forward(&self.label, &label_rows, p_lc, p_lf);

        let p = &self.pose;
        let mut flat = vec![0.0f32; POSE_FLAT];
        for c in 0..POSE_CHANNELS {
            for t in 0..HISTORY {
                let v = p.conv_b[c] + (0..POSE_FEATURES).map(|f| p.conv_w[c * POSE_FEATURES + f] * x.poses[t][f]).sum::<f32>();
                p_pc.push(v);
                flat[c * HISTORY + t] = v.tanh();
            }
        }
        let pose_enc = linear_tanh(&p.fc_w, &p.fc_b, &flat, p_pf);

        let mut output = Vec::with_capacity(BEAMS);
        for b in 0..BEAMS {
            let s = scan_enc[b] + pose_enc[b];
            p_head.push(s);
            output.push(s.tanh() * label_enc[b]);
        }
        Trace { pre, scan_enc, label_enc, pose_enc, output }
    }
}

/// One range (mm) normalised in floating point, as the firmware does in integers. Linear: invalid
/// → 0, no return → 1, otherwise `min(r, max) / max` (not rounded). Inverse: exactly the
/// firmware's int8 value over 127 (invalid beams are filled by [`normalise_scan_f32`]; here they
/// give −1/127).
pub fn normalise_range_f32(r_mm: u16, norm: &Normalisation) -> f32 {
    match norm.range_encoding {
        RangeEncoding::Inverse => firmware::classifier::normalise_range(r_mm, norm) as f32 / 127.0,
        RangeEncoding::Linear => match r_mm {
            RANGE_INVALID => 0.0,
            RANGE_NO_RETURN => 1.0,
            r => (r as f32).min(norm.range_max_mm as f32) / norm.range_max_mm as f32,
        },
    }
}

/// A whole scan normalised as the firmware's `normalise_scan` does (in the inverse encoding,
/// invalid beams take the nearest valid value before them), appended to `out`.
pub fn normalise_scan_f32(ranges_mm: &[u16], norm: &Normalisation, out: &mut Vec<f32>) {
    match norm.range_encoding {
        RangeEncoding::Linear => out.extend(ranges_mm.iter().map(|&r| normalise_range_f32(r, norm))),
        RangeEncoding::Inverse => {
            let mut row = [0i8; BEAMS];
            let ranges: &[u16; BEAMS] = ranges_mm.try_into().expect("897 beams");
            firmware::classifier::normalise_scan(ranges, norm, &mut row);
            out.extend(row.iter().map(|&q| q as f32 / 127.0));
        }
    }
}

/// `pose` relative to `newest` (`newest⁻¹ ∘ pose`), normalised: x, y over the pose scale clamped to
/// ±1, θ wrapped to [−π, π) over π.
pub fn normalise_pose_f32(pose: &Pose2, newest: &Pose2, norm: &Normalisation) -> [f32; 3] {
    let (x, y, _) = pose.to_f64();
    let (nx, ny, nt) = newest.to_f64();
    let (dx, dy) = (x - nx, y - ny);
    let (s, c) = nt.sin_cos();
    let scale = norm.pose_scale_mm as f64 / 1000.0;
    let rx = (c * dx + s * dy) / scale;
    let ry = (-s * dx + c * dy) / scale;
    let dt = (pose.theta - newest.theta).to_radians();
    let dt = if dt >= std::f64::consts::PI { dt - std::f64::consts::TAU } else { dt };
    [rx.clamp(-1.0, 1.0) as f32, ry.clamp(-1.0, 1.0) as f32, (dt / std::f64::consts::PI) as f32]
}

/// The float twin of `firmware::classifier::ScanHistory`: raw scans and poses of the last k steps
/// and the last k − 1 outputs, zero-bootstrapped, oldest first.
#[derive(Clone, Debug)]
pub struct FloatHistory {
    norm: Normalisation,
    scans: Vec<Vec<f32>>,
    poses: Vec<Option<Pose2>>,
    labels: Vec<Vec<f32>>,
}

impl FloatHistory {
    /// An empty (all-zero) history.
    pub fn new(norm: Normalisation) -> Self {
        Self { norm, scans: vec![vec![0.0; BEAMS]; HISTORY], poses: vec![None; HISTORY], labels: vec![vec![0.0; BEAMS]; LABEL_ROWS] }
    }

    /// Appends a scan taken at `pose`.
    pub fn push_scan(&mut self, pose: &Pose2, ranges_mm: &[u16]) {
        self.scans.remove(0);
        let mut row = Vec::with_capacity(BEAMS);
        normalise_scan_f32(ranges_mm, &self.norm, &mut row);
        self.scans.push(row);
        self.poses.remove(0);
        self.poses.push(Some(*pose));
    }

    /// Appends an output row.
    pub fn push_labels(&mut self, row: &[f32]) {
        self.labels.remove(0);
        self.labels.push(row.to_vec());
    }

    /// The network inputs for the current history.
    pub fn inputs(&self) -> FloatInputs {
        let mut poses = [[0.0; POSE_FEATURES]; HISTORY];
        if let Some(newest) = self.poses[HISTORY - 1] {
            for (o, p) in poses.iter_mut().zip(&self.poses) {
                if let Some(p) = p {
                    *o = normalise_pose_f32(p, &newest, &self.norm);
                }
            }
        }
        FloatInputs { scans: self.scans.concat(), labels: self.labels.concat(), poses }
    }
}

/// Quantiser settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuantiseOptions {
    /// Largest |pre-activation| a tanh table covers; calibrated ranges beyond it are clipped
    /// (tanh(3) = 0.995, so clipping there costs at most 1 output LSB and buys input resolution).
    pub tanh_clip: f32,
}

impl Default for QuantiseOptions {
    fn default() -> Self {
        Self { tanh_clip: 3.0 }
    }
}

/// What the quantiser chose, for reports and tests.
#[derive(Clone, Debug, PartialEq)]
pub struct QuantisationReport {
    /// Calibrated max |pre-activation| per [`Layer`] (before clipping).
    pub max_abs_pre: [f32; 7],
    /// The pre-activation scale per [`Layer`] (the tanh table's input scale).
    pub pre_scale: [f32; 7],
}

/// Activation (input and tanh output) scale everywhere: 1/127.
pub const ACT_SCALE: f64 = 1.0 / 127.0;

/// The model blob for `model`, calibrated on `calibration` (an empty slice calibrates every
/// pre-activation to the clip), with default options.
pub fn quantise(model: &FloatModel, calibration: &[FloatInputs]) -> Vec<u8> {
    quantise_with(model, calibration, &QuantiseOptions::default()).0
}

fn round_i32(v: f64) -> i32 {
    v.round().clamp(i32::MIN as f64, i32::MAX as f64) as i32
}

/// Per-channel symmetric int8 quantisation of a weight matrix `[channels][fan_in]` into `dst`;
/// returns each channel's scale.
fn quantise_weights(w: &[f32], channels: usize, dst: &mut [u8]) -> Vec<f64> {
    let fan_in = w.len() / channels;
    (0..channels)
        .map(|c| {
            let row = &w[c * fan_in..(c + 1) * fan_in];
            let max = row.iter().fold(0.0f64, |m, &v| m.max(v.abs() as f64));
            let s = if max > 0.0 { max / 127.0 } else { 1.0 };
            for (d, &v) in dst[c * fan_in..(c + 1) * fan_in].iter_mut().zip(row) {
                *d = (v as f64 / s).round().clamp(-127.0, 127.0) as i8 as u8;
            }
            s
        })
        .collect()
}

/// [`quantise`] with options; also returns what was chosen.
pub fn quantise_with(model: &FloatModel, calibration: &[FloatInputs], opts: &QuantiseOptions) -> (Vec<u8>, QuantisationReport) {
    let mut max_abs = [0.0f32; 7];
    for x in calibration {
        let t = model.trace(x);
        for (m, pre) in max_abs.iter_mut().zip(&t.pre) {
            *m = pre.iter().fold(*m, |m, v| m.max(v.abs()));
        }
    }
    let clip = opts.tanh_clip.max(1e-3);
    let pre_scale: [f32; 7] =
        std::array::from_fn(|l| if calibration.is_empty() { clip / 127.0 } else { max_abs[l].clamp(1e-3, clip) / 127.0 });

    let mut blob = vec![0u8; layout::BLOB_LEN];
    let mut w = ModelWriter::new(&mut blob).expect("buffer is BLOB_LEN long");
    w.set_normalisation(model.norm);
    for (l, layer) in Layer::ALL.into_iter().enumerate() {
        let s = pre_scale[l] as f64;
        let table: [i8; 256] = std::array::from_fn(|i| (127.0 * (s * (i as f64 - 128.0)).tanh()).round().clamp(-127.0, 127.0) as i8);
        w.set_tanh_table(layer, &table);
        w.set_scale_bits(layer, (s as f32).to_bits());
    }
    let params: [(Layer, &[f32], &[f32]); 6] = [
        (Layer::ScanConv, &model.scan.conv_w, std::slice::from_ref(&model.scan.conv_b)),
        (Layer::ScanFc, &model.scan.fc_w, &model.scan.fc_b),
        (Layer::LabelConv, &model.label.conv_w, std::slice::from_ref(&model.label.conv_b)),
        (Layer::LabelFc, &model.label.fc_w, &model.label.fc_b),
        (Layer::PoseConv, &model.pose.conv_w, &model.pose.conv_b),
        (Layer::PoseFc, &model.pose.fc_w, &model.pose.fc_b),
    ];
    for (l, (layer, weights, bias)) in params.into_iter().enumerate() {
        assert_eq!(weights.len(), layer.weights_len(), "{layer:?} weights");
        assert_eq!(bias.len(), layer.channels(), "{layer:?} biases");
        let scales = quantise_weights(weights, layer.channels(), w.weights_mut(layer));
        for (c, &s_w) in scales.iter().enumerate() {
            let acc_scale = ACT_SCALE * s_w;
            let multiplier = QuantizedMultiplier::from_f64(acc_scale / pre_scale[l] as f64).unwrap_or(QuantizedMultiplier::ZERO);
            w.set_channel(layer, c, ChannelParams { bias: round_i32(bias[c] as f64 / acc_scale), multiplier });
        }
    }
    let head = HeadParams {
        sum: QuantizedMultiplier::from_f64(ACT_SCALE / pre_scale[Layer::Head as usize] as f64).unwrap_or(QuantizedMultiplier::ZERO),
        product: QuantizedMultiplier::from_f64(ACT_SCALE).unwrap_or(QuantizedMultiplier::ZERO),
    };
    w.set_head(head);
    w.finish();
    (blob, QuantisationReport { max_abs_pre: max_abs, pre_scale })
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops compare beam by beam
mod tests {
    use super::*;
    use firmware::classifier::{Classifier, ClassifierConfig, ModelError, ModelView};
    use firmware::scan::BeamLabel;
    use fixed_point::{BinaryAngle, Meters};

    /// A scan of a random room: piecewise-smooth walls, some clutter, a few invalid and no-return
    /// beams; `prev` makes consecutive scans similar, as at 5 Hz.
    fn room_scan(rng: &mut SplitMix64, prev: Option<&[u16; BEAMS]>) -> [u16; BEAMS] {
        if let Some(p) = prev {
            return std::array::from_fn(|b| match p[b] {
                RANGE_INVALID | RANGE_NO_RETURN => p[b],
                r => (r as f64 * (1.0 + 0.02 * (rng.unit() - 0.5))).clamp(100.0, 65_000.0) as u16,
            });
        }
        let mut out = [0u16; BEAMS];
        let mut b = 0;
        while b < BEAMS {
            let len = 20 + (rng.next_u64() % 120) as usize;
            let base = 500.0 + rng.unit() * 12_000.0;
            let slope = (rng.unit() - 0.5) * 40.0;
            for i in 0..len.min(BEAMS - b) {
                let r = base + slope * i as f64 + (rng.unit() - 0.5) * 30.0;
                out[b + i] = match rng.next_u64() % 50 {
                    0 => RANGE_INVALID,
                    1 => RANGE_NO_RETURN,
                    _ => r.clamp(100.0, 60_000.0) as u16,
                };
            }
            b += len;
        }
        out
    }

    fn walk(rng: &mut SplitMix64, p: &Pose2) -> Pose2 {
        let (x, y, t) = p.to_f64();
        let t2 = t + (rng.unit() - 0.5) * 0.3;
        Pose2::from_f64(x + 0.3 * t2.cos(), y + 0.3 * t2.sin(), t2).unwrap()
    }

    fn random_label_row(rng: &mut SplitMix64) -> Vec<i8> {
        (0..BEAMS)
            .map(|_| match rng.next_u64() % 4 {
                0 => ((rng.unit() * 2.0 - 1.0) * 127.0).round() as i8,
                1 | 2 => 127,
                _ => -127,
            })
            .collect()
    }

    /// A random k-step history, raw: scans, poses, label rows (int8).
    struct RawHistory {
        scans: Vec<[u16; BEAMS]>,
        poses: Vec<Pose2>,
        labels: Vec<Vec<i8>>,
    }

    fn raw_history(rng: &mut SplitMix64) -> RawHistory {
        let mut scans = vec![room_scan(rng, None)];
        let mut poses = vec![Pose2::from_f64(rng.unit() * 10.0 - 5.0, rng.unit() * 10.0 - 5.0, rng.unit() * 6.0 - 3.0).unwrap()];
        for _ in 1..HISTORY {
            let s = room_scan(rng, scans.last());
            scans.push(s);
            poses.push(walk(rng, poses.last().unwrap()));
        }
        RawHistory { scans, poses, labels: (0..LABEL_ROWS).map(|_| random_label_row(rng)).collect() }
    }

    fn float_inputs(h: &RawHistory, norm: Normalisation) -> FloatInputs {
        let mut f = FloatHistory::new(norm);
        for (s, p) in h.scans.iter().zip(&h.poses) {
            f.push_scan(p, s);
        }
        for l in &h.labels {
            f.push_labels(&l.iter().map(|&q| q as f32 / 127.0).collect::<Vec<_>>());
        }
        f.inputs()
    }

    fn load(c: &mut Classifier<'_>, h: &RawHistory) {
        let norm = c.model().unwrap().normalisation();
        c.reset();
        for (s, p) in h.scans.iter().zip(&h.poses) {
            c.history_mut().push_scan(p, s, &norm);
        }
        for l in &h.labels {
            c.history_mut().push_labels(&l.as_slice().try_into().unwrap());
        }
    }

    fn calibration(model: &FloatModel, seed: u64, n: usize) -> Vec<FloatInputs> {
        let mut rng = SplitMix64(seed);
        (0..n).map(|_| float_inputs(&raw_history(&mut rng), model.norm)).collect()
    }

    #[test]
    fn random_model_has_the_papers_parameter_count() {
        assert_eq!(FloatModel::random(1).parameter_count(), 1_684_766);
    }

    #[test]
    fn float_history_matches_the_firmware_normalisation() {
        let norm = Normalisation::DEFAULT;
        let mut rng = SplitMix64(3);
        let h = raw_history(&mut rng);
        let x = float_inputs(&h, norm);
        let mut fh = firmware::classifier::ScanHistory::new();
        for (s, p) in h.scans.iter().zip(&h.poses) {
            fh.push_scan(p, s, &norm);
        }
        for r in 0..HISTORY {
            for b in 0..BEAMS {
                let q = fh.scan_row(r)[b] as f32;
                assert!((q - 127.0 * x.scans[r * BEAMS + b]).abs() <= 0.5 + 1e-3, "scan {r} {b}");
            }
        }
        let pq = fh.pose_input(&norm);
        for t in 0..HISTORY {
            for f in 0..3 {
                assert!((pq[t][f] as f32 - 127.0 * x.poses[t][f]).abs() <= 0.51, "pose {t} {f}: {} vs {}", pq[t][f], x.poses[t][f]);
            }
        }
    }

    /// In the inverse encoding the float history sees exactly the firmware's int8 scan rows
    /// (dropouts filled the same way), and the blob carries the encoding.
    #[test]
    fn inverse_range_inputs_are_the_firmwares() {
        let norm = Normalisation { range_max_mm: 500, range_encoding: RangeEncoding::Inverse, ..Normalisation::DEFAULT };
        let mut rng = SplitMix64(9);
        let h = raw_history(&mut rng);
        let mut model = FloatModel::random(5);
        model.norm = norm;
        let x = float_inputs(&h, norm);
        let mut fh = firmware::classifier::ScanHistory::new();
        for (s, p) in h.scans.iter().zip(&h.poses) {
            fh.push_scan(p, s, &norm);
        }
        let mut invalid = 0;
        for r in 0..HISTORY {
            for b in 0..BEAMS {
                assert_eq!(fh.scan_row(r)[b] as f32 / 127.0, x.scans[r * BEAMS + b], "scan {r} {b}");
                invalid += (h.scans[r][b] == RANGE_INVALID) as usize;
            }
            assert!(fh.scan_row(r).iter().all(|&q| q >= 0));
        }
        assert!(invalid > 0, "the test history has dropouts");
        let blob = quantise(&model, &[x]);
        let view = firmware::classifier::ModelView::parse(&blob).unwrap();
        assert_eq!(view.normalisation(), norm);
    }

    /// The blob parses in the firmware; quantising twice gives the same bytes; and on random
    /// histories the int8 labels agree in sign with the float model on ≥ 97 % of beams.
    #[test]
    fn int8_agrees_with_float() {
        let model = FloatModel::random(42);
        let calib = calibration(&model, 100, 8);
        let (blob, report) = quantise_with(&model, &calib, &QuantiseOptions::default());
        assert_eq!(blob.len(), layout::BLOB_LEN);
        assert_eq!(quantise(&model, &calib), blob, "quantising is deterministic");
        let view = ModelView::parse(&blob).expect("the firmware accepts the blob");
        assert_eq!(view.scale_bits(Layer::ScanFc), report.pre_scale[1].to_bits());
        let mut c = Box::new(Classifier::with_model(view, ClassifierConfig::default()));

        let mut rng = SplitMix64(7);
        let (mut agree, mut total, mut max_err) = (0usize, 0usize, 0.0f32);
        let (mut agree_confident, mut confident) = (0usize, 0usize);
        for _ in 0..12 {
            let h = raw_history(&mut rng);
            let want = model.forward(&float_inputs(&h, model.norm));
            load(&mut c, &h);
            c.forward();
            let first = c.scores().to_vec();
            c.forward();
            assert_eq!(c.scores().to_vec(), first, "same history, same int8 outputs");
            for b in 0..BEAMS {
                total += 1;
                let same = (c.scores()[b] >= 0) == (want[b] >= 0.0);
                agree += same as usize;
                if want[b].abs() >= 0.05 {
                    confident += 1;
                    agree_confident += same as usize;
                }
                max_err = max_err.max((c.output()[b] as f32 / 127.0 - want[b]).abs());
            }
        }
        let rate = agree as f64 / total as f64;
        let rate_confident = agree_confident as f64 / confident as f64;
        println!(
            "single-step sign agreement {:.2} % over {total} beams ({:.2} % over the {confident} with |float| ≥ 0.05), \
             max |int8 − float| {max_err:.3}",
            100.0 * rate,
            100.0 * rate_confident
        );
        println!("calibrated max |pre|: {:?}", report.max_abs_pre);
        assert!(rate >= 0.97, "sign agreement {rate}");
        assert!(rate_confident >= 0.995, "sign agreement where the float model is confident {rate_confident}");
    }

    /// Calibration inputs the way a deployment sees them: a float autoregressive run.
    fn autoregressive_calibration(model: &FloatModel, seed: u64, steps: usize) -> Vec<FloatInputs> {
        let mut rng = SplitMix64(seed);
        let mut f = FloatHistory::new(model.norm);
        let mut pose = Pose2::IDENTITY;
        let mut scan = room_scan(&mut rng, None);
        let mut out = Vec::new();
        for _ in 0..steps {
            f.push_scan(&pose, &scan);
            let x = f.inputs();
            f.push_labels(&model.forward(&x));
            out.push(x);
            pose = walk(&mut rng, &pose);
            scan = room_scan(&mut rng, Some(&scan));
        }
        out
    }

    /// Both models run autoregressively on the same 30-step sequence, each feeding back its own
    /// outputs: the labels still agree.
    #[test]
    fn int8_agrees_with_float_autoregressively() {
        let model = FloatModel::random(5);
        let blob = quantise(&model, &autoregressive_calibration(&model, 200, 12));
        let view = ModelView::parse(&blob).unwrap();
        let run = || {
            let mut c = Box::new(Classifier::with_model(view, ClassifierConfig::default()));
            let mut f = FloatHistory::new(model.norm);
            let mut rng = SplitMix64(11);
            let mut pose = Pose2::new(Meters::from_num(1), Meters::from_num(-2), BinaryAngle::from_degrees(30));
            let mut scan = room_scan(&mut rng, None);
            let mut labels = [BeamLabel::Unlabelled; BEAMS];
            let (mut agree, mut total) = (0usize, 0usize);
            let (mut agree_confident, mut confident) = (0usize, 0usize);
            let mut all = Vec::new();
            for _ in 0..30 {
                c.classify_ranges(&pose, &scan, &mut labels);
                f.push_scan(&pose, &scan);
                let out = model.forward(&f.inputs());
                f.push_labels(&out);
                for b in 0..BEAMS {
                    if labels[b] != BeamLabel::Unlabelled {
                        total += 1;
                        let same = (labels[b] == BeamLabel::Map) == (out[b] >= 0.0);
                        agree += same as usize;
                        if out[b].abs() >= 0.05 {
                            confident += 1;
                            agree_confident += same as usize;
                        }
                    }
                }
                all.extend_from_slice(&labels);
                pose = walk(&mut rng, &pose);
                scan = room_scan(&mut rng, Some(&scan));
            }
            (agree as f64 / total as f64, agree_confident as f64 / confident as f64, all)
        };
        let (rate, rate_confident, first) = run();
        let (_, _, second) = run();
        assert_eq!(first, second, "repeated runs give the same labels");
        println!("autoregressive sign agreement {:.2} % ({:.2} % where |float| ≥ 0.05)", 100.0 * rate, 100.0 * rate_confident);
        assert!(rate >= 0.97, "sign agreement {rate}");
        assert!(rate_confident >= 0.99, "sign agreement where the float model is confident {rate_confident}");
    }

    #[test]
    fn corrupt_blobs_are_refused() {
        let model = FloatModel::random(9);
        let blob = quantise(&model, &[]);
        assert!(ModelView::parse(&blob).is_ok());
        let mut bad = blob.clone();
        bad[layout::weights_of(Layer::ScanFc) + 1000] ^= 0x01;
        assert!(matches!(ModelView::parse(&bad), Err(ModelError::ChecksumMismatch { .. })));
        assert_eq!(
            ModelView::parse(&blob[..blob.len() / 2]).unwrap_err(),
            ModelError::Truncated { needed: layout::BLOB_LEN, got: blob.len() / 2 }
        );
        let mut bad = blob.clone();
        bad[0] = b'X';
        assert_eq!(ModelView::parse(&bad).unwrap_err(), ModelError::BadMagic);
    }

    #[test]
    fn tanh_tables_are_odd_and_monotone() {
        let model = FloatModel::random(2);
        let blob = quantise(&model, &calibration(&model, 1, 2));
        let view = ModelView::parse(&blob).unwrap();
        for layer in Layer::ALL {
            let t = view.tanh_table(layer);
            let at = |q: i32| t[(q + 128) as usize] as i8 as i32;
            assert_eq!(at(0), 0);
            for q in -127..=127 {
                assert_eq!(at(q), -at(-q), "{layer:?} {q}");
                if q > -127 {
                    assert!(at(q) >= at(q - 1));
                }
            }
        }
    }
}
