//! The map-free scan classifier: `LabelPoseNet` in int8, reading its weights in place from a model
//! blob.
//!
//! The robot has no map, yet the planner wants to know which LiDAR points are permanent structure
//! (*map*: walls) and which are furniture, objects or people (*non-map*: where a target may be).
//! The LIVES paper learns this from a short history (k = 9 steps, 1.8 s at 5 Hz) of scans, poses
//! and the classifier's own earlier labels. This module owns that history ([`ScanHistory`]), the
//! checked view of the model blob ([`ModelView`]) and the integer inference ([`Classifier`]); it
//! touches no map, grid or planner state — the controller copies the labels into the scan.
//!
//! ## The network (METHOD.md §1.2; 1 684 766 parameters)
//! ```text
//! scans  [9, 897] ─ Conv2d 1→1, 9×9, circular pad 4 along beams ─ tanh ─ Linear 897→897 ─ tanh ─ scan_enc
//! labels [9, 897] ─ (same shape, own weights)                                         ─ label_enc
//! poses  [9, 3]   ─ Conv2d 1→9, 1×3 ─ tanh ─ flatten 81 ─ Linear 81→897 ─ tanh ─────── pose_enc
//! output = tanh(scan_enc + pose_enc) · label_enc ∈ (−1, 1);  ≥ 0 → map, < 0 → non-map
//! ```
//! Rows are oldest first; row 8 is the newest scan. The label input is the last 8 outputs plus, as
//! row 8, their linear-weighted average (row i of 1…8 weighted i/36, newest heaviest). Training
//! targets are **+1 for map and −1 for non-map**, so the sign of the output is the label; the exact
//! integer product decides, so a tiny negative score that rounds to int8 0 is still non-map.
//!
//! ## Arithmetic
//! int8 everywhere, TFLite / CMSIS-NN conventions: symmetric quantisation (zero point 0), weights
//! per output channel, int32 biases and accumulators, one rounding mode
//! ([`fixed_point::requantize`]), tanh as a 256-entry table per layer computed offline. Inputs and
//! every tanh output have scale 1/127. No floats anywhere: the same inputs give the same labels on
//! a PC and on a Cortex-M.
//!
//! ## Memory
//! The blob (1 716 408 bytes, `docs/model-format.md`) stays where it is (flash, or a host buffer);
//! [`Classifier`] borrows it. Its own state — the rings and the scratch activations — is about
//! 22 KiB of fixed-size arrays; nothing is allocated.
//!
//! ## Work
//! One [`Classifier::classify`] is [`WORK_PER_CLASSIFY`] multiply-accumulates (≈ 1.83 M), 88 % of
//! them in the two 897 × 897 matrices.

pub mod geo;
mod history;
mod kernels;
/// The int8 inner product (public for the MCU self-test that checks the DSP path against the reference).
#[doc(hidden)]
pub use kernels::{dot, dot_reference, DotInput};
pub mod model;
#[cfg(test)]
pub(crate) mod testing;

pub use history::{normalise_angle, normalise_distance, normalise_range, normalise_scan, ScanHistory, LABEL_ROWS, LABEL_WEIGHT_SUM};
pub use model::{checksum, ChannelParams, HeadParams, Layer, ModelError, ModelView, ModelWriter, Normalisation, RangeEncoding, ShapeField};

use crate::capacity::BEAMS;
use crate::scan::{BeamLabel, BeamScan, RANGE_INVALID, RANGE_NO_RETURN};
use fixed_point::Pose2;

/// History length k (steps).
pub const HISTORY: usize = 9;
/// Encoder kernel side (time × beams).
pub const ENC_KERNEL: usize = 9;
/// Circular padding along the beams.
pub const ENC_PAD: usize = 4;
/// Pose encoder output channels.
pub const POSE_CHANNELS: usize = 9;
/// Pose features per step: x, y, θ.
pub const POSE_FEATURES: usize = 3;
/// Flattened pose encoder width (9 channels × 9 steps).
pub const POSE_FLAT: usize = POSE_CHANNELS * HISTORY;

/// The trained int8 model committed with the repository (`firmware/model/lives-int8.bin`, its
/// model card in `docs/model-card.md`), embedded at build time. Install it with
/// `Controller::set_model(EMBEDDED_MODEL)`, which validates it first.
pub static EMBEDDED_MODEL: &[u8] = include_bytes!("../../model/lives-int8.bin");

/// The trained geometric model (`firmware/model/lives-geo-int8.bin`, [`geo`], its card in
/// `docs/model-card-geo.md`), embedded at build time: the model `lives` runs by default (about
/// 90 % per point in the built-in buildings, where `LabelPoseNet` stays below "always map").
/// `Controller::set_model` tells the two formats apart by their magic.
pub static EMBEDDED_GEO_MODEL: &[u8] = include_bytes!("../../model/lives-geo-int8.bin");

/// Multiply-accumulates per [`Classifier::classify`]: two encoder convolutions, two 897 × 897
/// layers, the pose convolution, the 81 → 897 layer and the output products.
pub const WORK_PER_CLASSIFY: u32 =
    (2 * BEAMS * HISTORY * ENC_KERNEL + 2 * BEAMS * BEAMS + POSE_CHANNELS * HISTORY * POSE_FEATURES + BEAMS * POSE_FLAT + BEAMS) as u32;

/// What goes back into the label history after each step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum LabelFeedback {
    /// The network's int8 output itself (scale 1/127): the paper's "previous estimates".
    #[default]
    Raw,
    /// Its sign only, ±127 (like the ±1 labels of training).
    Sign,
}

/// Classifier settings.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct ClassifierConfig {
    /// What the label history is filled with.
    pub feedback: LabelFeedback,
}

/// Activations of one forward pass.
#[derive(Clone)]
struct Scratch {
    /// Output of an encoder convolution (reused by both encoders).
    hidden: [i8; BEAMS],
    scan_enc: [i8; BEAMS],
    label_enc: [i8; BEAMS],
    pose_enc: [i8; BEAMS],
    /// The weighted-average label row.
    label_avg: [i8; BEAMS],
    pose_flat: [i8; POSE_FLAT],
}

impl Scratch {
    const fn new() -> Self {
        Self {
            hidden: [0; BEAMS],
            scan_enc: [0; BEAMS],
            label_enc: [0; BEAMS],
            pose_enc: [0; BEAMS],
            label_avg: [0; BEAMS],
            pose_flat: [0; POSE_FLAT],
        }
    }
}

/// The map-free scan classifier: a borrowed model, the history rings and scratch activations.
/// About 22 KiB; `const fn new` so it can live in a `static`.
#[derive(Clone)]
pub struct Classifier<'m> {
    model: Option<ModelView<'m>>,
    /// The geometric model, when installed instead of `LabelPoseNet` ([`geo`]).
    geo: Option<geo::GeoView<'m>>,
    geo_scratch: geo::GeoScratch,
    cfg: ClassifierConfig,
    history: ScanHistory,
    scratch: Scratch,
    scores: [i16; BEAMS],
    output: [i8; BEAMS],
}

impl<'m> Classifier<'m> {
    /// A classifier with no model: [`Classifier::classify`] labels nothing until
    /// [`Classifier::set_model`].
    pub const fn new(cfg: ClassifierConfig) -> Self {
        Self {
            model: None,
            geo: None,
            geo_scratch: geo::GeoScratch::new(),
            cfg,
            history: ScanHistory::new(),
            scratch: Scratch::new(),
            scores: [0; BEAMS],
            output: [0; BEAMS],
        }
    }

    /// A classifier with `model`.
    pub const fn with_model(model: ModelView<'m>, cfg: ClassifierConfig) -> Self {
        let mut c = Self::new(cfg);
        c.model = Some(model);
        c
    }

    /// Installs `model` and clears the history (a different network must not read another's labels).
    pub fn set_model(&mut self, model: ModelView<'m>) {
        self.model = Some(model);
        self.geo = None;
        self.reset();
    }

    /// Installs a geometric model ([`geo`]) in place of any `LabelPoseNet`, and clears the history.
    pub fn set_geo_model(&mut self, model: geo::GeoView<'m>) {
        self.geo = Some(model);
        self.model = None;
        self.reset();
    }

    /// The geometric model, if one is installed.
    pub fn geo_model(&self) -> Option<&geo::GeoView<'m>> {
        self.geo.as_ref()
    }

    /// The model, if one is installed.
    pub fn model(&self) -> Option<&ModelView<'m>> {
        self.model.as_ref()
    }

    /// The settings.
    pub fn config(&self) -> &ClassifierConfig {
        &self.cfg
    }

    /// Back to the bootstrap state (zero history), keeping the model.
    pub fn reset(&mut self) {
        self.history.clear();
        self.scores = [0; BEAMS];
        self.output = [0; BEAMS];
    }

    /// The history the next forward pass reads.
    pub fn history(&self) -> &ScanHistory {
        &self.history
    }

    /// The history, to seed or replay (tests, offline evaluation).
    pub fn history_mut(&mut self) -> &mut ScanHistory {
        &mut self.history
    }

    /// The last output per beam, int8 at scale 1/127 (≥ 0 map, < 0 non-map up to rounding; the
    /// exact sign is in [`Classifier::scores`]).
    pub fn output(&self) -> &[i8; BEAMS] {
        &self.output
    }

    /// The last exact output products `tanh(scan_enc + pose_enc) · label_enc` at scale 1/127²
    /// (|score| ≤ 16 384): `≥ 0` is map.
    pub fn scores(&self) -> &[i16; BEAMS] {
        &self.scores
    }

    /// Runs the network on the current history, without pushing anything: fills
    /// [`Classifier::scores`] and [`Classifier::output`]. Returns the work done
    /// ([`WORK_PER_CLASSIFY`], or 0 without a model).
    pub fn forward(&mut self) -> u32 {
        let Some(model) = self.model else {
            return 0;
        };
        let h = &self.history;
        let s = &mut self.scratch;

        // Scan encoder.
        let rows: [&[i8; BEAMS]; HISTORY] = core::array::from_fn(|r| h.scan_row(r));
        kernels::encoder_conv(&model, Layer::ScanConv, &rows, &mut s.hidden);
        kernels::linear(&model, Layer::ScanFc, &s.hidden, &mut s.scan_enc);

        // Label encoder: the 8 earlier outputs, then their weighted average.
        h.label_average(&mut s.label_avg);
        let rows: [&[i8; BEAMS]; HISTORY] = core::array::from_fn(|r| if r < LABEL_ROWS { h.label_row(r) } else { &s.label_avg });
        kernels::encoder_conv(&model, Layer::LabelConv, &rows, &mut s.hidden);
        kernels::linear(&model, Layer::LabelFc, &s.hidden, &mut s.label_enc);

        // Pose encoder.
        let poses = h.pose_input(&model.normalisation());
        kernels::pose_conv(&model, &poses, &mut s.pose_flat);
        kernels::linear(&model, Layer::PoseFc, &s.pose_flat, &mut s.pose_enc);

        kernels::head(&model, &s.scan_enc, &s.pose_enc, &s.label_enc, &mut self.scores, &mut self.output);
        WORK_PER_CLASSIFY
    }

    /// One step: pushes the scan (ranges of `scan`, taken at `pose`) into the history, runs the
    /// network, feeds its output back into the label history and writes a label per beam into
    /// `out` — [`BeamLabel::Map`] for a score ≥ 0, [`BeamLabel::NonMap`] below, and
    /// [`BeamLabel::Unlabelled`] for beams with no return or no usable reading (and for every beam
    /// when no model is installed). `scan.labels` is not read. Returns the work done
    /// ([`WORK_PER_CLASSIFY`], or 0 without a model).
    pub fn classify(&mut self, pose: &Pose2, scan: &BeamScan, out: &mut [BeamLabel; BEAMS]) -> u32 {
        self.classify_ranges(pose, &scan.ranges_mm, out)
    }

    /// [`Classifier::classify`] writing into the scan's own labels.
    pub fn label_scan(&mut self, pose: &Pose2, scan: &mut BeamScan) -> u32 {
        self.classify_ranges(pose, &scan.ranges_mm, &mut scan.labels)
    }

    /// [`Classifier::classify`] on bare ranges.
    pub fn classify_ranges(&mut self, pose: &Pose2, ranges_mm: &[u16; BEAMS], out: &mut [BeamLabel; BEAMS]) -> u32 {
        let work = if let Some(g) = self.geo {
            self.geo_step(&g, pose, ranges_mm)
        } else if let Some(model) = self.model {
            self.history.push_scan(pose, ranges_mm, &model.normalisation());
            let work = self.forward();
            let feedback: [i8; BEAMS] = match self.cfg.feedback {
                LabelFeedback::Raw => self.output,
                LabelFeedback::Sign => core::array::from_fn(|b| if self.scores[b] >= 0 { 127 } else { -127 }),
            };
            self.history.push_labels(&feedback);
            work
        } else {
            *out = [BeamLabel::Unlabelled; BEAMS];
            return 0;
        };
        for ((o, &s), &r) in out.iter_mut().zip(self.scores.iter()).zip(ranges_mm.iter()) {
            *o = match r {
                RANGE_INVALID | RANGE_NO_RETURN => BeamLabel::Unlabelled,
                _ if s >= 0 => BeamLabel::Map,
                _ => BeamLabel::NonMap,
            };
        }
        work
    }

    /// One step of the geometric model: fills [`Classifier::scores`] (the int32 score clamped
    /// to `i16`, sign kept) and [`Classifier::output`], and feeds the output back into the label
    /// history (raw, as `LabelFeedback::Raw`).
    fn geo_step(&mut self, g: &geo::GeoView<'m>, pose: &Pose2, ranges_mm: &[u16; BEAMS]) -> u32 {
        self.history.push_scan(pose, ranges_mm, &Normalisation::DEFAULT);
        self.geo_scratch.prepare(ranges_mm);
        let history = geo::HistoryReader::new(&self.history);
        for b in 0..BEAMS {
            let mut x = self.geo_scratch.features(ranges_mm, b);
            let [last, avg] = history.features(b);
            x[geo::SCAN_FEATURES] = last;
            x[geo::SCAN_FEATURES + 1] = avg;
            let (score, o) = geo::geo_forward(g, &x);
            self.scores[b] = score.clamp(i16::MIN as i32, i16::MAX as i32) as i16;
            self.output[b] = o;
        }
        self.history.push_labels(&self.output);
        geo::WORK_PER_GEO_CLASSIFY
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // the reference is index loops on purpose
mod tests {
    extern crate std;
    use super::testing::{blank_writer, random_blob, Rng};
    use super::*;
    use fixed_point::{requantize_i8, BinaryAngle, Meters, QuantizedMultiplier};
    use std::boxed::Box;
    use std::vec::Vec;

    /// A straightforward reference of the whole forward pass: i64 sums, `%` for the circular
    /// padding, index loops, nothing shared with the kernels but the blob accessors.
    fn reference(m: &ModelView<'_>, h: &ScanHistory) -> (Vec<i16>, Vec<i8>) {
        let lut = |layer: Layer, q: i8| m.tanh_table(layer)[(q as i32 + 128) as usize] as i8;
        let act = |layer: Layer, c: usize, acc: i64| {
            let p = m.channel(layer, c);
            lut(layer, requantize_i8((acc + p.bias as i64).clamp(i32::MIN as i64, i32::MAX as i64) as i32, p.multiplier))
        };
        let w = |layer: Layer, c: usize, i: usize| m.weights(layer)[c * layer.fan_in() + i] as i8 as i64;
        let encoder = |conv: Layer, fc: Layer, rows: &[Vec<i8>]| -> Vec<i8> {
            let hidden: Vec<i8> = (0..BEAMS)
                .map(|b| {
                    let mut acc = 0i64;
                    for t in 0..9 {
                        for j in 0..9 {
                            let x = rows[t][(b + BEAMS + j - 4) % BEAMS] as i64;
                            acc += w(conv, 0, t * 9 + j) * x;
                        }
                    }
                    act(conv, 0, acc)
                })
                .collect();
            (0..BEAMS).map(|o| act(fc, o, (0..BEAMS).map(|i| w(fc, o, i) * hidden[i] as i64).sum())).collect()
        };
        let scan_rows: Vec<Vec<i8>> = (0..9).map(|r| h.scan_row(r).to_vec()).collect();
        let mut label_rows: Vec<Vec<i8>> = (0..8).map(|r| h.label_row(r).to_vec()).collect();
        label_rows.push(
            (0..BEAMS)
                .map(|b| {
                    let s: i64 = (0..8).map(|r| (r as i64 + 1) * label_rows[r][b] as i64).sum();
                    let q = (s.abs() * 2 + 36) / 72;
                    (if s < 0 { -q } else { q }) as i8
                })
                .collect(),
        );
        let scan_enc = encoder(Layer::ScanConv, Layer::ScanFc, &scan_rows);
        let label_enc = encoder(Layer::LabelConv, Layer::LabelFc, &label_rows);
        let poses = h.pose_input(&m.normalisation());
        let mut flat = [0i8; 81];
        for c in 0..9 {
            for t in 0..9 {
                flat[c * 9 + t] = act(Layer::PoseConv, c, (0..3).map(|f| w(Layer::PoseConv, c, f) * poses[t][f] as i64).sum());
            }
        }
        let pose_enc: Vec<i8> =
            (0..BEAMS).map(|o| act(Layer::PoseFc, o, (0..81).map(|i| w(Layer::PoseFc, o, i) * flat[i] as i64).sum())).collect();
        let hp = m.head();
        let mut scores = Vec::new();
        let mut out = Vec::new();
        for b in 0..BEAMS {
            let t = lut(Layer::Head, requantize_i8(scan_enc[b] as i32 + pose_enc[b] as i32, hp.sum));
            let p = t as i32 * label_enc[b] as i32;
            scores.push(p as i16);
            out.push(requantize_i8(p, hp.product));
        }
        (scores, out)
    }

    fn random_scan(rng: &mut Rng) -> [u16; BEAMS] {
        core::array::from_fn(|_| match rng.next() % 20 {
            0 => RANGE_INVALID,
            1 => RANGE_NO_RETURN,
            _ => (rng.next() % 40_000) as u16 + 1,
        })
    }

    fn random_pose(rng: &mut Rng) -> Pose2 {
        Pose2::new(
            Meters::from_bits((rng.next() % (20 << 16)) as i32 - (10 << 16)),
            Meters::from_bits((rng.next() % (20 << 16)) as i32 - (10 << 16)),
            BinaryAngle(rng.next() as i32),
        )
    }

    #[test]
    fn matches_the_reference_step_by_step() {
        let blob = random_blob(11);
        let model = ModelView::parse(&blob).unwrap();
        let mut c = Box::new(Classifier::with_model(model, ClassifierConfig::default()));
        let mut rng = Rng(5);
        // The bootstrap state first, then 11 autoregressive steps (the rings wrap).
        assert_eq!(c.forward(), WORK_PER_CLASSIFY);
        let (s, o) = reference(&model, c.history());
        assert_eq!(&c.scores()[..], &s[..]);
        assert_eq!(&c.output()[..], &o[..]);
        let mut out = [BeamLabel::Unlabelled; BEAMS];
        for _ in 0..11 {
            let ranges = random_scan(&mut rng);
            let pose = random_pose(&mut rng);
            let mut probe = c.clone();
            probe.history_mut().push_scan(&pose, &ranges, &model.normalisation());
            let (s, o) = reference(&model, probe.history());
            let scan = BeamScan { ranges_mm: ranges, ..BeamScan::new() };
            assert_eq!(c.classify(&pose, &scan, &mut out), WORK_PER_CLASSIFY);
            assert_eq!(&c.scores()[..], &s[..]);
            assert_eq!(&c.output()[..], &o[..]);
            // The output went into the newest label row.
            assert_eq!(c.history().label_row(LABEL_ROWS - 1), c.output());
            for b in 0..BEAMS {
                let want = match ranges[b] {
                    RANGE_INVALID | RANGE_NO_RETURN => BeamLabel::Unlabelled,
                    _ if s[b] >= 0 => BeamLabel::Map,
                    _ => BeamLabel::NonMap,
                };
                assert_eq!(out[b], want, "beam {b}");
            }
        }
        assert!(out.contains(&BeamLabel::Map) && out.contains(&BeamLabel::NonMap));
    }

    #[test]
    fn same_inputs_same_labels_and_reset_restarts() {
        let blob = random_blob(12);
        let model = ModelView::parse(&blob).unwrap();
        let mut a = Box::new(Classifier::with_model(model, ClassifierConfig { feedback: LabelFeedback::Sign }));
        let mut b = Box::new(Classifier::new(ClassifierConfig { feedback: LabelFeedback::Sign }));
        b.set_model(model);
        let mut rng = Rng(9);
        let steps: Vec<([u16; BEAMS], Pose2)> = (0..6).map(|_| (random_scan(&mut rng), random_pose(&mut rng))).collect();
        let mut first = Vec::new();
        let (mut la, mut lb) = ([BeamLabel::Unlabelled; BEAMS], [BeamLabel::Unlabelled; BEAMS]);
        for (r, p) in &steps {
            a.classify_ranges(p, r, &mut la);
            b.classify_ranges(p, r, &mut lb);
            assert_eq!(la, lb);
            assert_eq!(a.scores(), b.scores());
            // Sign feedback: only ±127 in the label history.
            assert!(a.history().label_row(7).iter().all(|&q| q == 127 || q == -127));
            first.push(la);
        }
        a.reset();
        for ((r, p), want) in steps.iter().zip(&first) {
            a.classify_ranges(p, r, &mut la);
            assert_eq!(&la, want);
        }
    }

    #[test]
    fn without_a_model_nothing_is_labelled() {
        let mut c = Box::new(Classifier::new(ClassifierConfig::default()));
        let mut scan = BeamScan::new();
        scan.ranges_mm = [1234; BEAMS];
        scan.labels = [BeamLabel::Map; BEAMS];
        assert_eq!(c.label_scan(&Pose2::IDENTITY, &mut scan), 0);
        assert!(scan.labels.iter().all(|&l| l == BeamLabel::Unlabelled));
        assert!(c.history().is_empty());
        assert_eq!(c.forward(), 0);
    }

    /// Hand-computed: all weights zero, so each encoder is tanh of its bias. The label encoder's
    /// sign alone decides map or non-map.
    #[test]
    fn label_encoder_sign_decides() {
        let one = QuantizedMultiplier::from_raw(1 << 30, 1); // 1.0
        let ident: [i8; 256] = core::array::from_fn(|i| (i as i32 - 128).clamp(-127, 127) as i8);
        for (label_bias, want, want_out) in [(100, BeamLabel::Map, 24), (-100, BeamLabel::NonMap, -24), (0, BeamLabel::Map, 0)] {
            let mut blob = std::vec![0u8; model::layout::BLOB_LEN];
            let mut w = blank_writer(&mut blob);
            for layer in Layer::ALL {
                w.set_tanh_table(layer, &ident);
            }
            for c in 0..BEAMS {
                w.set_channel(Layer::ScanFc, c, ChannelParams { bias: 50, multiplier: one });
                w.set_channel(Layer::PoseFc, c, ChannelParams { bias: -20, multiplier: one });
                w.set_channel(Layer::LabelFc, c, ChannelParams { bias: label_bias, multiplier: one });
            }
            w.finish();
            let m = ModelView::parse(&blob).unwrap();
            let mut c = Box::new(Classifier::with_model(m, ClassifierConfig::default()));
            let mut scan = BeamScan::new();
            scan.ranges_mm = [5000; BEAMS];
            scan.ranges_mm[7] = RANGE_NO_RETURN;
            c.label_scan(&Pose2::IDENTITY, &mut scan);
            // tanh(50 − 20) = 30 (identity table), times the label bias.
            assert_eq!(c.scores()[0], 30 * label_bias as i16);
            // 30 · ±100 / 127 = ±23.6 → ±24.
            assert_eq!(c.output()[0], want_out);
            assert_eq!(scan.labels[0], want);
            assert_eq!(scan.labels[7], BeamLabel::Unlabelled);
        }
    }

    /// Circular padding: a single kernel tap at (newest row, offset −4) makes the convolution a
    /// rotation of the newest scan by 4 beams, wrapping at beam 0.
    #[test]
    fn convolution_wraps_around_the_beams() {
        let ident: [i8; 256] = core::array::from_fn(|i| (i as i32 - 128).clamp(-127, 127) as i8);
        let mut blob = std::vec![0u8; model::layout::BLOB_LEN];
        let mut w = blank_writer(&mut blob);
        w.set_tanh_table(Layer::ScanConv, &ident);
        w.set_channel(Layer::ScanConv, 0, ChannelParams { bias: 0, multiplier: QuantizedMultiplier::from_raw(1 << 30, 1) });
        w.weights_mut(Layer::ScanConv)[8 * 9] = 1; // row 8 (newest), j = 0 → beam b − 4
        w.finish();
        let m = ModelView::parse(&blob).unwrap();
        let mut h = ScanHistory::new();
        let ranges: [u16; BEAMS] = core::array::from_fn(|b| (b as u16 % 120) * 250 + 1);
        h.push_scan(&Pose2::IDENTITY, &ranges, &m.normalisation());
        let rows: [&[i8; BEAMS]; HISTORY] = core::array::from_fn(|r| h.scan_row(r));
        let mut out = [0i8; BEAMS];
        kernels::encoder_conv(&m, Layer::ScanConv, &rows, &mut out);
        for b in 0..BEAMS {
            assert_eq!(out[b], h.scan_row(8)[(b + BEAMS - 4) % BEAMS], "beam {b}");
        }
        assert_eq!(out[0], normalise_range(ranges[893], &m.normalisation()));
    }

    /// Blobs that pass the checks but carry hostile numbers (extreme biases, multipliers, tables)
    /// classify without panicking.
    #[test]
    fn hostile_but_valid_blobs_do_not_panic() {
        let mut rng = Rng(77);
        let mut blob = std::vec![0u8; model::layout::BLOB_LEN];
        let mut w = blank_writer(&mut blob);
        for layer in Layer::WEIGHTED {
            for c in 0..layer.channels() {
                let bias = [i32::MIN, i32::MAX, 0][c % 3];
                let m = QuantizedMultiplier::from_raw(i32::MAX, [30, -31, 0][(c / 3) % 3]);
                w.set_channel(layer, c, ChannelParams { bias, multiplier: m });
            }
            for x in w.weights_mut(layer).iter_mut() {
                *x = [0x80, 0x7F][rng.next() as usize % 2];
            }
        }
        w.set_head(HeadParams { sum: QuantizedMultiplier::from_raw(i32::MAX, 30), product: QuantizedMultiplier::from_raw(1 << 30, -31) });
        w.finish();
        let m = ModelView::parse(&blob).unwrap();
        let mut c = Box::new(Classifier::with_model(m, ClassifierConfig::default()));
        let mut out = [BeamLabel::Unlabelled; BEAMS];
        let scan = [RANGE_NO_RETURN; BEAMS];
        let far = Pose2::new(Meters::MAX, Meters::MIN, BinaryAngle::HALF);
        c.classify_ranges(&far, &scan, &mut out);
        c.classify_ranges(&Pose2::new(Meters::MIN, Meters::MAX, BinaryAngle::ZERO), &[1; BEAMS], &mut out);
        assert!(out.iter().all(|&l| l != BeamLabel::Unlabelled));
    }

    #[test]
    fn state_is_small_and_fixed() {
        let size = core::mem::size_of::<Classifier<'static>>();
        std::println!("size_of::<Classifier>() = {size} bytes, ScanHistory {}", core::mem::size_of::<ScanHistory>());
        // ≈ 22 KiB of rings and activations, ≈ 21 KiB of the geometric model's scratch.
        assert!(size < 48 * 1024, "{size}");
        assert_eq!(WORK_PER_CLASSIFY, 1_828_329);
    }
}
