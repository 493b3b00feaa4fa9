use super::*;
use crate::learn::model::SplitMix64;
use crate::learn::model::{FloatHistory, FloatInputs, FloatModel};
use candle_core::{Device, Tensor};
use candle_nn::{AdamW, Optimizer, ParamsAdamW};
use firmware::capacity::BEAMS;
use firmware::classifier::{LabelFeedback, Normalisation, RangeEncoding, HISTORY, LABEL_ROWS};
use fixed_point::Pose2;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

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
    let blob = crate::learn::model::quantise(&m, &calibration_inputs(&m, std::slice::from_ref(&ep), 2, 4));
    let acc = evaluate_int8(&blob, std::slice::from_ref(&ep), LabelFeedback::Raw).unwrap();
    assert_eq!(acc.all.total() as usize, 10 * (BEAMS - unlabelled()));
    assert_eq!(acc.warm.total() as usize, 2 * (BEAMS - unlabelled()));
    let fl = evaluate_float_autoregressive(&m, std::slice::from_ref(&ep), Feedback::Raw);
    assert_eq!(fl.all.total(), acc.all.total());
}
