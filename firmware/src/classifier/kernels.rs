//! The int8 kernels of `LabelPoseNet`: weights read in place from the blob, int32 accumulators,
//! requantisation with [`fixed_point::requantize_i8`], tanh by table.
//!
//! Every kernel computes, per output channel `c`:
//! `y = tanh_table[ requantize_i8(Σ w[c][i] · x[i] + bias[c], M[c]) + 128 ]`.
//! Accumulators cannot overflow: the longest dot product is 897 terms of at most 128 · 128, i.e.
//! |Σ| ≤ 14 696 448 < 2³¹; the bias is added saturating.

use super::model::{Layer, ModelView, TANH_TABLE_LEN};
use super::{ENC_KERNEL, ENC_PAD, HISTORY, POSE_CHANNELS, POSE_FEATURES, POSE_FLAT};
use crate::capacity::BEAMS;
use fixed_point::requantize_i8;

/// Looks `q` up in a tanh table (entry `q + 128`).
#[inline(always)]
pub(crate) fn tanh_lut(table: &[u8; TANH_TABLE_LEN], q: i8) -> i8 {
    table[(q as u8 ^ 0x80) as usize] as i8
}

/// `Σ w[i] · x[i]` over the shorter of the two slices (weights as raw bytes).
#[inline(always)]
fn dot(w: &[u8], x: &[i8]) -> i32 {
    w.iter().zip(x.iter()).map(|(&w, &x)| (w as i8 as i32) * (x as i32)).sum()
}

/// The encoders' Conv2d(1 → 1, 9 × 9) over `rows` (oldest first), no padding in time, circular
/// padding of 4 along the beams, then tanh: `out[b] = tanh(Σ_t Σ_j w[t][j] · rows[t][(b + j − 4)
/// mod 897] + bias)`. MACs: 897 · 81.
pub(crate) fn encoder_conv(model: &ModelView<'_>, layer: Layer, rows: &[&[i8; BEAMS]; HISTORY], out: &mut [i8; BEAMS]) {
    let mut w = [[0i8; ENC_KERNEL]; HISTORY];
    for (i, &b) in model.weight_row(layer, 0).iter().enumerate().take(HISTORY * ENC_KERNEL) {
        w[i / ENC_KERNEL][i % ENC_KERNEL] = b as i8;
    }
    let p = model.channel(layer, 0);
    let table = model.tanh_table(layer);
    for (b, y) in out.iter_mut().enumerate() {
        let mut acc = 0i32;
        for (row, wr) in rows.iter().zip(w.iter()) {
            // Beam b + j − 4 for j = 0..9, wrapped; split into the two contiguous runs.
            let start = (b + BEAMS - ENC_PAD) % BEAMS;
            let first = (BEAMS - start).min(ENC_KERNEL);
            for j in 0..first {
                acc += wr[j] as i32 * row[start + j] as i32;
            }
            for j in first..ENC_KERNEL {
                acc += wr[j] as i32 * row[j - first] as i32;
            }
        }
        *y = tanh_lut(table, requantize_i8(acc.saturating_add(p.bias), p.multiplier));
    }
}

/// A Linear layer `out[c] = tanh(Σ_i W[c][i] · input[i] + bias[c])`, `W` row-major in the blob.
/// MACs: channels · fan_in.
pub(crate) fn linear(model: &ModelView<'_>, layer: Layer, input: &[i8], out: &mut [i8]) {
    let table = model.tanh_table(layer);
    for (c, y) in out.iter_mut().enumerate().take(layer.channels()) {
        let p = model.channel(layer, c);
        let acc = dot(model.weight_row(layer, c), input);
        *y = tanh_lut(table, requantize_i8(acc.saturating_add(p.bias), p.multiplier));
    }
}

/// The pose encoder's Conv2d(1 → 9, kernel 1 × 3) over `[k][x, y, θ]`, tanh, flattened channel-major
/// (`out[c · k + t]`, PyTorch's `flatten` of `[C, k, 1]`). MACs: 9 · 9 · 3.
pub(crate) fn pose_conv(model: &ModelView<'_>, poses: &[[i8; POSE_FEATURES]; HISTORY], out: &mut [i8; POSE_FLAT]) {
    let table = model.tanh_table(Layer::PoseConv);
    for c in 0..POSE_CHANNELS {
        let p = model.channel(Layer::PoseConv, c);
        let w = model.weight_row(Layer::PoseConv, c);
        for (t, pose) in poses.iter().enumerate() {
            let acc = dot(w, pose);
            out[c * HISTORY + t] = tanh_lut(table, requantize_i8(acc.saturating_add(p.bias), p.multiplier));
        }
    }
}

/// The output stage: `score[b] = tanh(scan_enc[b] + pose_enc[b]) · label_enc[b]` as the exact int
/// product (scale 1/127², |score| ≤ 16 384), and `output[b]` the same requantised to int8 (scale
/// 1/127). MACs: 897.
pub(crate) fn head(
    model: &ModelView<'_>,
    scan_enc: &[i8; BEAMS],
    pose_enc: &[i8; BEAMS],
    label_enc: &[i8; BEAMS],
    scores: &mut [i16; BEAMS],
    output: &mut [i8; BEAMS],
) {
    let hp = model.head();
    let table = model.tanh_table(Layer::Head);
    for b in 0..BEAMS {
        let sum = scan_enc[b] as i32 + pose_enc[b] as i32;
        let t = tanh_lut(table, requantize_i8(sum, hp.sum));
        let prod = t as i32 * label_enc[b] as i32;
        scores[b] = prod as i16;
        output[b] = requantize_i8(prod, hp.product);
    }
}
