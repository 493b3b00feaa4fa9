//! `lives train-geo` and `lives classifier-eval`: the geometric classifier trained, quantised and
//! evaluated through the firmware, and any int8 classifier blob measured in the built-in
//! buildings. (Built with `--features train`.)

use super::common::{say, write_file};
use host::learn::dataset::Split;
use host::learn::train::{load_split, unseen_episodes, Confusion};
use host::learn::train_geo::{evaluate_float, evaluate_int8, quantise, rollout_samples, samples, train, GeoTrainConfig};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

/// Train the geometric classifier (per-beam shape features of the newest scan and its own
/// earlier outputs, an int8 MLP; docs/model-card-geo.md), quantise it, evaluate it through the
/// firmware on the dataset's validation split and in the built-in buildings, write the blob
/// and a model card. (Built with `--features train`.)
#[derive(clap::Args)]
pub struct TrainGeoArgs {
    /// The dataset directory (`lives dataset --out DIR`; procedural worlds only).
    #[arg(long)]
    data: PathBuf,
    /// Where to write the int8 blob.
    #[arg(long, default_value = "firmware/model/lives-geo-int8.bin")]
    out: PathBuf,
    /// Where to write the model card (Markdown).
    #[arg(long)]
    card: Option<PathBuf>,
    /// Passes over the training samples.
    #[arg(long, default_value_t = 6)]
    epochs: usize,
    /// Initial SGD learning rate (divided by 1 + epoch).
    #[arg(long, default_value_t = 0.02)]
    lr: f32,
    /// Seed of the initialisation and shuffles.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Train on every N-th step of the training split.
    #[arg(long, default_value_t = 7)]
    step_stride: usize,
    /// … and every N-th labelled beam of those steps.
    #[arg(long, default_value_t = 5)]
    beam_stride: usize,
    /// Seconds of random walk in each built-in world and scenario for the unseen-building figures.
    #[arg(long, default_value_t = 60.0)]
    unseen_seconds: f64,
    /// Train only the scan-only model (the label-history inputs stay zero).
    #[arg(long)]
    no_label_history: bool,
    /// The history model trains on every N-th training episode, rolled out through the firmware.
    #[arg(long, default_value_t = 4)]
    history_episode_stride: usize,
    /// Probability of negating each label-history input in training (the paper: 10 %).
    #[arg(long, default_value_t = 0.1)]
    flip: f64,
    /// DAgger rounds of the history model (each rolls out the current model and retrains on the pool).
    #[arg(long, default_value_t = 3)]
    dagger_rounds: usize,
    /// The tanh table's input range: the largest hidden pre-activation seen, at most this.
    #[arg(long, default_value_t = host::learn::train_geo::DEFAULT_PRE_CLIP)]
    pre_clip: f32,
}

/// `lives train-geo`: train, quantise, evaluate through the firmware, write the blob and a card.
pub fn train_geo(args: TrainGeoArgs) -> Result<ExitCode, String> {
    let TrainGeoArgs {
        data,
        out,
        card,
        epochs,
        lr,
        seed,
        step_stride,
        beam_stride,
        unseen_seconds,
        no_label_history,
        history_episode_stride,
        flip,
        dagger_rounds,
        pre_clip,
    } = args;
    let history = (!no_label_history).then_some((history_episode_stride, flip, dagger_rounds));
    let (data, out, card) = (data.as_path(), out.as_path(), card.as_deref());
    let t0 = Instant::now();
    let e = |e: host::learn::train::TrainError| e.0;
    let train_eps = load_split(data, Split::Train).map_err(e)?;
    let val_eps = load_split(data, Split::Val).map_err(e)?;
    let unseen = unseen_episodes(unseen_seconds, 1).map_err(e)?;
    let tr = samples(&train_eps, step_stride, beam_stride);
    let va = samples(&val_eps, 10, 3);
    say!("{} training samples (every {step_stride}th step, every {beam_stride}th beam), {} validation samples", tr.len(), va.len());
    let cfg = GeoTrainConfig { epochs, lr, seed };
    let mut log = Vec::new();
    let m = train(&cfg, &tr, |ep, loss, m| {
        let v = evaluate_float(m, &va);
        say!(
            "epoch {}: loss {loss:.4}, validation (float, sampled) {:.2} % (always map {:.2} %)",
            ep + 1,
            100.0 * v.accuracy(),
            100.0 * v.always_map()
        );
        log.push((ep + 1, loss, v.accuracy()));
    })
    .map_err(e)?;
    let q = quantise(&m, &tr[..tr.len().min(200_000)], pre_clip).map_err(e)?;
    // With the label history: a second model trained on the first one's own autoregressive
    // outputs (run through the firmware) as its history; the first is the ablation.
    let (m, q, ablation, history_note) = match history {
        Some((episode_stride, flip, rounds)) => {
            // DAgger: each round rolls the current model out through the firmware (its own
            // outputs become the history), adds those samples to the pool and trains a new model
            // on the pool; the first round rolls out the scan-only model.
            let subset: Vec<host::learn::train::Episode> = train_eps.iter().step_by(episode_stride.max(1)).cloned().collect();
            let mut pool: Vec<host::learn::train_geo::Sample> = Vec::new();
            let (mut cur_m, mut cur_q) = (m.clone(), q.clone());
            for round in 0..rounds.max(1) {
                let more = rollout_samples(&cur_q.blob, &subset, 2, beam_stride, flip, seed + round as u64).map_err(e)?;
                pool.extend(more);
                say!(
                    "label history, round {}: {} samples in the pool ({} training episodes rolled out)",
                    round + 1,
                    pool.len(),
                    subset.len()
                );
                cur_m = train(&cfg, &pool, |ep, loss, _| {
                    say!("history model, round {}, epoch {}: loss {loss:.4}", round + 1, ep + 1);
                    log.push((ep + 1, loss, f64::NAN));
                })
                .map_err(e)?;
                cur_q = quantise(&cur_m, &pool[..pool.len().min(200_000)], pre_clip).map_err(e)?;
            }
            let note = format!(
                "the label history: a second model whose inputs add the model's own earlier outputs for the same direction (one step earlier, and the 8-step weighted average), trained by DAgger over {rounds} round(s): each round runs the current model autoregressively through the firmware on every {episode_stride}th training episode (every 2nd step sampled, each history input negated with probability {flip}), adds the samples to the pool ({} in the end) and trains a new model on the pool, the same epochs and learning rate",
                pool.len()
            );
            (cur_m, cur_q, Some(q.blob), note)
        }
        None => (m, q, None, "no label history (its two inputs are zero)".to_string()),
    };
    let train_s = t0.elapsed().as_secs_f64();
    let (val_int8, val_agree) = evaluate_int8(&q.blob, &val_eps, Some(&m)).map_err(e)?;
    let (un_int8, un_agree) = evaluate_int8(&q.blob, &unseen, Some(&m)).map_err(e)?;
    let ablation = match &ablation {
        Some(blob) => Some((evaluate_int8(blob, &val_eps, None).map_err(e)?.0, evaluate_int8(blob, &unseen, None).map_err(e)?.0)),
        None => None,
    };
    write_file(out, &q.blob)?;
    let crc = firmware::classifier::geo::GeoView::parse(&q.blob).map(|v| v.crc()).unwrap_or(0);
    let row = |name: &str, c: &Confusion, agree: Option<f64>| {
        format!(
            "| {name} | {} | **{:.2} %** | {} | {:.2} % |",
            c.total(),
            100.0 * c.accuracy(),
            rate_cells(c),
            100.0 * agree.unwrap_or(0.0)
        )
    };
    let table = [
        "| set | labelled beams | int8 accuracy | always map | map recall | non-map recall | float/int8 agreement |".to_string(),
        "|---|---|---|---|---|---|---|".to_string(),
        row(&format!("validation (unseen random worlds, {} episodes)", val_eps.len()), &val_int8, val_agree),
        row(&format!("built-in apartment, office, hallway ({} random walks of {unseen_seconds:.0} s)", unseen.len()), &un_int8, un_agree),
    ]
    .join("\n");
    let ablation_md = match &ablation {
        Some((v, u)) => format!(
            "\n\nWithout the label history (the scan-only model, int8, the same runs): validation {:.2} % ({:+.2} points with it), built-in buildings {:.2} % ({:+.2} points with it).",
            100.0 * v.accuracy(),
            100.0 * (val_int8.accuracy() - v.accuracy()),
            100.0 * u.accuracy(),
            100.0 * (un_int8.accuracy() - u.accuracy())
        ),
        None => String::new(),
    };
    let table = format!("{table}{ablation_md}");
    say!("{table}");
    say!("blob {} ({} bytes, CRC-32 {crc:08x}); {:.0} s in all", out.display(), q.blob.len(), t0.elapsed().as_secs_f64());
    if let Some(card) = card {
        let epochs_md: String = log
            .iter()
            .map(|(ep, l, a)| {
                if a.is_nan() {
                    format!("| {ep} (history model) | {l:.4} | |\n")
                } else {
                    format!("| {ep} | {l:.4} | {:.2} % |\n", 100.0 * a)
                }
            })
            .collect();
        let cmd = std::env::args().collect::<Vec<_>>().join(" ");
        let dataset_cmd = std::fs::read_to_string(data.join("meta.json"))
            .ok()
            .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
            .and_then(|m| m["generator"]["command"].as_str().map(str::to_string))
            .unwrap_or_else(|| "(not recorded in meta.json)".into());
        let text = format!(
            "# Model card: geometric scan classifier (`LVGM`, int8)\n\n\
             Generated by `lives train-geo`; every number below was measured by that command.\n\n\
             - command: `{cmd}`\n\
             - blob: `{}`, {} bytes, CRC-32 `{crc:08x}`\n\
             - data: `{}` ({} training episodes, {} validation episodes; split by world), made by `{dataset_cmd}`\n\
             - training: {} samples, {epochs} epochs of SGD on the logistic loss, lr {lr} / (1 + epoch), seed {seed}; then {history_note}; {train_s:.0} s\n\
             - quantisation: hidden pre-activations calibrated on {} training samples, max |pre| {:.2}, table range ±{:.2}\n\n\
             | epoch | training loss | validation accuracy (float, sampled beams) |\n|---|---|---|\n{epochs_md}\n\
             Int8, run through the firmware classifier over every step (every labelled beam with a return):\n\n{table}\n\n\
             ## Notes\n\n\
             - **What it is.** Per-beam shape features of the newest scan, computed by the firmware with integers \
             (`firmware::classifier::geo`, docs/model-format.md): how far the point stands in front of the chord through \
             its neighbours 2 to 128 beams away on either side, the length of its run without a depth jump on each side and \
             where that run ends, and its inverse range; with two label-history inputs, a 23 → 48 → 1 MLP in int8. The float \
             model trains on the firmware's own features, so quantisation changes only the weights.\n\
             - **Why not the paper's network.** `LabelPoseNet` (docs/model-card.md) sees each beam through one 9 × 9 \
             convolution channel; it stays below \"always map\" in the built-in buildings (81.50 % against 84.27 %). The \
             front of a wardrobe looks like a wall over 9 beams; over 30–250 beams it stands in front of the wall behind it.\n\
             - **Label history.** As the paper's label encoder, the model reads its own earlier outputs for the same \
             direction (one step earlier, and the 8-step weighted average; the pose history turns each earlier row to the \
             beam that pointed the same way). Trained naively on a scan-only model's outputs as history it collapsed when its \
             own outputs came back (74.70 % in the built-in buildings, one round, measured while developing this); DAgger rounds, each rolling the current model out \
             through the firmware and retraining on the growing pool, fix that. The ablation line above is the scan-only \
             model, which is also the first stage of this command. The labels are the simulator-exact labeller's (0.1 m LTF \
             gate, docs/dataset.md), not ENML's 0.7 m.\n\
             - **Reproducing.** The dataset command above, then the command above; training, rollouts and quantisation are \
             single-threaded and seeded, so the blob is byte-identical run to run.\n",
            out.display(),
            q.blob.len(),
            data.display(),
            train_eps.len(),
            val_eps.len(),
            tr.len(),
            tr.len().min(200_000),
            q.max_pre,
            q.pre_range,
        );
        std::fs::write(card, text).map_err(|e| format!("{}: {e}", card.display()))?;
        say!("card {}", card.display());
    }
    Ok(ExitCode::SUCCESS)
}

/// Per-point accuracy of an int8 classifier blob (either format) through the firmware,
/// autoregressive as on the robot, in each built-in building and scenario (never in a
/// dataset), against the ground-truth labeller. (Built with `--features train`.)
#[derive(clap::Args)]
pub struct ClassifierEvalArgs {
    /// The blob (default: the committed geometric model).
    #[arg(long, default_value = "firmware/model/lives-geo-int8.bin")]
    model: PathBuf,
    /// Seconds of random walk in each built-in world and scenario.
    #[arg(long, default_value_t = 60.0)]
    seconds: f64,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
}

pub fn classifier_eval(args: ClassifierEvalArgs) -> Result<ExitCode, String> {
    let ClassifierEvalArgs { model, seconds, json } = args;
    let blob = std::fs::read(&model).map_err(|e| format!("{}: {e}", model.display()))?;
    let eps = unseen_episodes(seconds, 1).map_err(|e| e.0)?;
    let per = host::learn::train_geo::evaluate_blob_per_episode(&blob, &eps).map_err(|e| format!("{}: {}", model.display(), e.0))?;
    let mut pooled = Confusion::default();
    per.iter().for_each(|(_, c)| pooled.merge(c));
    let mean = per.iter().map(|(_, c)| c.accuracy()).sum::<f64>() / per.len().max(1) as f64;
    let set = |name: &str, c: &Confusion| {
        serde_json::json!({
            "set": name, "beams": c.total(), "accuracy": c.accuracy(), "always_map": c.always_map(),
            "map_recall": c.map_recall(), "non_map_recall": c.non_map_recall(),
        })
    };
    let format = if firmware::classifier::geo::GeoView::is_geo(&blob) { "LVGM (geometric)" } else { "LIVM (LabelPoseNet)" };
    if json {
        let sets: Vec<_> = per.iter().map(|(n, c)| set(n, c)).collect();
        say!(
            "{}",
            serde_json::json!({
                "model": model.display().to_string(), "format": format, "random_walk_s": seconds,
                "per_world": sets, "pooled": set("pooled", &pooled), "mean_over_worlds": mean,
            })
        );
    } else {
        say!("{} ({format}), int8 through the firmware, {seconds:.0} s random walk per world:", model.display());
        say!("| world | beams | accuracy | always map | map recall | non-map recall |\n|---|---|---|---|---|---|");
        for (n, c) in per.iter().chain(std::iter::once(&("pooled".to_string(), pooled))) {
            say!("| {n} | {} | {:.2} % | {} |", c.total(), 100.0 * c.accuracy(), rate_cells(c));
        }
        say!("mean over the {} worlds: {:.2} %", per.len(), 100.0 * mean);
    }
    Ok(ExitCode::SUCCESS)
}

/// "always map | map recall | non-map recall" cells of a classifier table row, in per cent.
fn rate_cells(c: &Confusion) -> String {
    format!("{:.2} % | {:.2} % | {:.2} %", 100.0 * c.always_map(), 100.0 * c.map_recall(), 100.0 * c.non_map_recall())
}
