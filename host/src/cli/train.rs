//! `lives train`, `lives calibrate-bias`, `lives quantise`: the map-free scan classifier
//! (LabelPoseNet) trained, its bias calibrated, quantised to the int8 blob the firmware runs.
//! (Built with `--features train`.)

use super::common::say;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

/// Train the map-free scan classifier (LabelPoseNet, f32, CPU) on a dataset; writes a safetensors checkpoint.
/// (Built with `--features train`.)
#[derive(clap::Args)]
pub struct TrainArgs {
    /// The dataset directory (`lives dataset --out DIR`).
    #[arg(long)]
    data: PathBuf,
    /// Where to write the f32 checkpoint.
    #[arg(long, default_value = host::learn::train::DEFAULT_CHECKPOINT_PATH)]
    out: PathBuf,
    /// Passes over the training samples (the paper: 20–50 on a GPU; 10 epochs took 5.5–7 min on ~43 k samples here).
    #[arg(long, default_value_t = host::learn::train::DEFAULT_EPOCHS)]
    epochs: usize,
    /// Samples per optimiser step (the paper: 4096).
    #[arg(long, default_value_t = host::learn::train::DEFAULT_BATCH)]
    batch: usize,
    /// Adam learning rate.
    #[arg(long, default_value_t = 1e-3)]
    lr: f64,
    /// Seed of the initialisation, shuffling and label flips.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Fraction of history labels sign-flipped in training.
    #[arg(long, default_value_t = 0.1)]
    flip: f64,
    /// Train without the label history (all label inputs zero): the ablation.
    #[arg(long)]
    no_label_history: bool,
    /// Fraction of samples whose label history is the model's own rollout (0 = the paper's teacher forcing).
    #[arg(long, default_value_t = 0.5)]
    self_feedback: f64,
    /// Fraction of samples whose label history is all zero.
    #[arg(long, default_value_t = 0.05)]
    history_dropout: f64,
    /// Added to the diagonal of the encoders' 897 × 897 weights at initialisation (0: PyTorch's default init).
    #[arg(long, default_value_t = 1.0)]
    init_diag: f32,
    /// Train only on steps with 8 predecessors (the paper), not on the bootstrap steps too.
    #[arg(long)]
    no_bootstrap: bool,
    /// Use at most this many training samples (a seeded subset), for quick runs.
    #[arg(long)]
    max_samples: Option<usize>,
    /// Continue from this checkpoint instead of a fresh initialisation.
    #[arg(long)]
    resume: Option<PathBuf>,
    /// The range (mm) that normalises to 1; longer ranges clamp (written into the blob).
    #[arg(long, default_value_t = 30_000)]
    range_max_mm: u32,
    /// Start the scan convolution as this weight on the newest scan's centre tap, zero elsewhere (0: PyTorch's init).
    #[arg(long, default_value_t = 0.0)]
    scan_conv_init: f32,
    /// First epoch whose self-feedback histories are a rollout of the current model (1 when resuming a trained model).
    #[arg(long, default_value_t = 2)]
    own_history_from_epoch: usize,
    /// Initial bias of the label encoder's linear layer (0: PyTorch's init; 2 starts label_enc near +1 everywhere).
    #[arg(long, default_value_t = 0.0)]
    label_bias_init: f32,
    /// Inverse-range scan inputs: min(1, range_max_mm / r), no return 0, dropouts filled from the previous beam.
    #[arg(long)]
    inverse_range: bool,
    /// Epochs with the encoders' 897 × 897 weights trained as circulant matrices (one kernel for every beam), before full training.
    #[arg(long, default_value_t = 0)]
    circulant_epochs: usize,
    /// Loss weight of non-map beams (map beams 1).
    #[arg(long, default_value_t = 1.0)]
    non_map_weight: f32,
    /// Cosine learning-rate decay to lr / 20 over the run.
    #[arg(long)]
    lr_decay: bool,
}

pub fn train(args: TrainArgs) -> Result<ExitCode, String> {
    let cfg = host::learn::train::TrainConfig {
        data: args.data,
        epochs: args.epochs,
        batch: args.batch,
        lr: args.lr,
        seed: args.seed,
        flip: args.flip,
        label_history: !args.no_label_history,
        bootstrap: !args.no_bootstrap,
        self_feedback: args.self_feedback,
        history_dropout: args.history_dropout,
        init_diag: args.init_diag,
        max_samples: args.max_samples,
        range_max_mm: args.range_max_mm,
        inverse_range: args.inverse_range,
        label_bias_init: args.label_bias_init,
        own_history_from_epoch: args.own_history_from_epoch,
        scan_conv_init: args.scan_conv_init,
        circulant_epochs: args.circulant_epochs,
        non_map_weight: args.non_map_weight,
        lr_decay: args.lr_decay,
        command: std::env::args().collect::<Vec<_>>().join(" "),
    };
    let progress = |e: &host::learn::train::EpochLog| {
        say!(
            "epoch {:3}: loss {:.4}, val accuracy teacher-forced {:.2} %, autoregressive {:.2} %, {:.0} s",
            e.epoch,
            e.train_loss,
            100.0 * e.val_accuracy,
            100.0 * e.val_ar_accuracy,
            e.train_s
        )
    };
    let (model, log) = match args.resume {
        Some(p) => {
            let (init, _) = host::learn::train::load_checkpoint(&p).map_err(|e| e.to_string())?;
            host::learn::train::train_from(&cfg, init, progress)
        }
        None => host::learn::train::train(&cfg, progress),
    }
    .map_err(|e| e.to_string())?;
    host::learn::train::save_checkpoint(&model, Some(&log), &args.out).map_err(|e| e.to_string())?;
    say!("trained {} epochs on {} samples in {:.0} s; checkpoint {}", log.epochs.len(), log.samples[0], log.total_s, args.out.display());
    Ok(ExitCode::SUCCESS)
}

/// Calibrate the decision bias of a model without label history on a dataset's validation
/// split: scores shifts of the scan encoder's linear bias, writes the best as a checkpoint.
/// (Built with `--features train`.)
#[derive(clap::Args)]
pub struct CalibrateBiasArgs {
    /// The f32 checkpoint.
    #[arg(long)]
    checkpoint: PathBuf,
    /// The dataset whose validation split decides (procedural worlds only).
    #[arg(long)]
    data: PathBuf,
    /// Where to write the shifted checkpoint.
    #[arg(long)]
    out: PathBuf,
    /// Candidate shifts, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "-0.5,-0.25,0,0.25,0.5,0.75,1,1.25,1.5,1.75,2,2.5,3")]
    deltas: Vec<f32>,
}

pub fn calibrate_bias(args: CalibrateBiasArgs) -> Result<ExitCode, String> {
    let CalibrateBiasArgs { checkpoint, data, out, deltas } = args;
    let t0 = Instant::now();
    let (mut model, log) = host::learn::train::load_checkpoint(&checkpoint).map_err(|e| e.to_string())?;
    let eps = host::learn::train::load_split(&data, host::learn::dataset::Split::Val).map_err(|e| e.to_string())?;
    let cands = host::learn::train::calibrate_scan_bias(&model, &eps, &deltas).map_err(|e| e.to_string())?;
    say!("| delta | float accuracy, all steps | warm steps | map recall | non-map recall | always map |\n|---|---|---|---|---|---|");
    for c in &cands {
        let a = &c.accuracy;
        say!(
            "| {} | {:.2} % | {:.2} % | {:.2} % | {:.2} % | {:.2} % |",
            c.delta,
            100.0 * a.all.accuracy(),
            100.0 * a.warm.accuracy(),
            100.0 * a.all.map_recall(),
            100.0 * a.all.non_map_recall(),
            100.0 * a.all.always_map()
        );
    }
    let best = cands.iter().max_by(|a, b| a.accuracy.all.accuracy().total_cmp(&b.accuracy.all.accuracy())).ok_or("no candidate shifts")?;
    model.scan.fc_b.iter_mut().for_each(|v| *v += best.delta);
    host::learn::train::save_checkpoint(&model, log.as_ref(), &out).map_err(|e| e.to_string())?;
    say!(
        "best shift {} ({:.2} %); checkpoint {} ({:.0} s)",
        best.delta,
        100.0 * best.accuracy.all.accuracy(),
        out.display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(ExitCode::SUCCESS)
}

/// Quantise a checkpoint to the int8 blob the firmware runs, evaluate it, and write the model card.
/// (Built with `--features train`.)
#[derive(clap::Args)]
pub struct QuantiseArgs {
    /// The f32 checkpoint (`lives train --out`).
    #[arg(long, default_value = host::learn::train::DEFAULT_CHECKPOINT_PATH)]
    checkpoint: PathBuf,
    /// The dataset whose validation split calibrates and evaluates (default: the one the checkpoint was trained on).
    #[arg(long)]
    data: Option<PathBuf>,
    /// Where to write the blob.
    #[arg(long, default_value = host::learn::train::DEFAULT_BLOB_PATH)]
    out: PathBuf,
    /// Where to write the model card (`-` for none).
    #[arg(long, default_value = host::learn::train::DEFAULT_CARD_PATH)]
    card: String,
    /// A second checkpoint (trained with or without --no-label-history) for the label-history ablation.
    #[arg(long)]
    ablation: Option<PathBuf>,
    /// Calibration inputs (steps of an autoregressive float run over the validation split).
    #[arg(long, default_value_t = 256)]
    calibration: usize,
    /// Seconds of random walk per built-in world and scenario for the unseen-world accuracy (0: skip).
    #[arg(long, default_value_t = 60.0)]
    unseen_seconds: f64,
    /// A Markdown file appended to the model card under "Notes".
    #[arg(long)]
    notes: Option<PathBuf>,
}

pub fn quantise(args: QuantiseArgs) -> Result<ExitCode, String> {
    let QuantiseArgs { checkpoint, data, out, card, ablation, calibration, unseen_seconds, notes } = args;
    let mut cfg = host::learn::train::QuantiseConfig::new(checkpoint);
    cfg.data = data;
    cfg.out = out;
    cfg.card = (card != "-").then(|| PathBuf::from(card));
    cfg.ablation = ablation;
    cfg.calibration = calibration;
    cfg.unseen_seconds = unseen_seconds;
    cfg.command = std::env::args().collect::<Vec<_>>().join(" ");
    cfg.notes = match notes {
        Some(p) => Some(std::fs::read_to_string(&p).map_err(|e| format!("{}: {e}", p.display()))?),
        None => None,
    };
    let r = host::learn::train::quantise_and_evaluate(&cfg, |line| say!("{line}")).map_err(|e| e.to_string())?;
    say!(
        "int8 per-point accuracy (autoregressive, as on the robot): validation {:.2} %{}",
        100.0 * r.val.int8_ar_raw.all.accuracy(),
        r.unseen.as_ref().map(|u| format!(", built-in worlds {:.2} %", 100.0 * u.int8_ar_raw.all.accuracy())).unwrap_or_default()
    );
    Ok(ExitCode::SUCCESS)
}
