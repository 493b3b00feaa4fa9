//! Training: the configuration, the epoch log and the Adam loop.

use super::*;
use crate::learn::dataset::{self, Split};
use crate::learn::model::FloatModel;
use candle_core::{Device, Tensor};
use candle_nn::{AdamW, Optimizer, ParamsAdamW};
use firmware::capacity::BEAMS;
use firmware::classifier::{Normalisation, RangeEncoding, ENC_KERNEL, ENC_PAD, HISTORY};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::time::Instant;

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

pub(super) fn default_range_max_mm() -> u32 {
    Normalisation::DEFAULT.range_max_mm as u32
}

pub(super) fn one() -> f32 {
    1.0
}

pub(super) fn two() -> usize {
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
