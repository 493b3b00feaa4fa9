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

/// `Σ w[i] · x[i]` over the shorter of the two slices (weights as raw bytes): the portable
/// reference, and the kernel on targets without the DSP extension.
#[inline(always)]
pub fn dot_reference(w: &[u8], x: &[i8]) -> i32 {
    w.iter().zip(x.iter()).map(|(&w, &x)| (w as i8 as i32) * (x as i32)).sum()
}

/// The right-hand side of [`dot`], prepared once for many rows (a layer's input).
///
/// On a Cortex-M with the DSP extension (`thumbv7em`) the first `16·⌊n/16⌋` values (n ≤
/// [`DotInput::WIDE`]) are widened to int16 and interleaved `[x0, x2, x1, x3]` per 4, so that
/// one `SXTB16` of a word of 4 weights lines up with one word of inputs for `SMLAD` (CMSIS-NN's
/// technique). Elsewhere it is the slice itself.
pub struct DotInput<'a> {
    x: &'a [i8],
    #[cfg(lives_dsp)]
    wide: Wide,
}

#[cfg(lives_dsp)]
#[repr(C, align(4))]
struct Wide([i16; DotInput::WIDE]);

impl<'a> DotInput<'a> {
    /// Inputs widened for the DSP kernel (longer inputs use it for their first values too).
    pub const WIDE: usize = 912;

    /// Prepares `x`.
    #[inline]
    pub fn new(x: &'a [i8]) -> Self {
        #[cfg(lives_dsp)]
        {
            let mut wide = Wide([0; Self::WIDE]);
            let n = x.len().min(Self::WIDE) / 16 * 16;
            for (q, d) in x[..n].chunks_exact(4).zip(wide.0.chunks_exact_mut(4)) {
                d[0] = q[0] as i16;
                d[1] = q[2] as i16;
                d[2] = q[1] as i16;
                d[3] = q[3] as i16;
            }
            DotInput { x, wide }
        }
        #[cfg(not(lives_dsp))]
        DotInput { x }
    }
}

/// Eight multiply-accumulates of [`dot`]'s loop (two per pass): eight widened inputs into r2–r5
/// (`LDM`), and twice a word of four weights (`LDR`) sign-extended in pairs (`SXTB16`: bytes 0
/// and 2, then 1 and 3, matching [`DotInput`]'s interleave) and multiplied-accumulated two at a
/// time (`SMLAD`).
#[cfg(lives_dsp)]
macro_rules! smlad8 {
    () => {
        concat!(
            "ldm {x}!, {{r2, r3, r4, r5}}\n",
            "ldr {a}, [{w}], #4\n",
            "sxtb16 {t}, {a}\n",
            "sxtb16 {a}, {a}, ror #8\n",
            "smlad {acc}, {t}, r2, {acc}\n",
            "smlad {acc}, {a}, r3, {acc}\n",
            "ldr {a}, [{w}], #4\n",
            "sxtb16 {t}, {a}\n",
            "sxtb16 {a}, {a}, ror #8\n",
            "smlad {acc}, {t}, r4, {acc}\n",
            "smlad {acc}, {a}, r5, {acc}",
        )
    };
}

/// `Σ w[i] · x[i]` over the shorter of `w` and the input (weights as raw bytes), bit-exact with
/// [`dot_reference`] (no accumulator can overflow, see the module documentation).
///
/// Cortex-M with DSP: 16 multiply-accumulates per loop pass in 24 instructions (2 `LDM` of
/// inputs, 4 `LDR` of weights, 8 `SXTB16`, 8 `SMLAD`, the loop) = 1.5 per MAC; the rest
/// (< 16 values) by the reference.
#[inline]
#[allow(unsafe_code)]
pub fn dot(w: &[u8], x: &DotInput<'_>) -> i32 {
    #[cfg(lives_dsp)]
    {
        let n = w.len().min(x.x.len());
        let blocks = n.min(DotInput::WIDE) / 16;
        let done = blocks * 16;
        let mut acc: i32 = 0;
        if blocks > 0 {
            // SAFETY: reads `done` bytes of `w` (≤ n ≤ w.len()) and `done` int16 of the aligned
            // widened buffer (≤ WIDE); writes only the declared registers; the stack is untouched.
            // LDR of the weights may be unaligned: the Cortex-M4 allows it (CCR.UNALIGN_TRP is 0).
            unsafe {
                core::arch::asm!(
                    "2:",
                    smlad8!(),
                    smlad8!(),
                    "subs {n}, {n}, #1",
                    "bne 2b",
                    w = inout(reg) w.as_ptr() => _,
                    x = inout(reg) x.wide.0.as_ptr() => _,
                    n = inout(reg) blocks => _,
                    acc = inout(reg) acc,
                    a = out(reg) _,
                    t = out(reg) _,
                    out("r2") _,
                    out("r3") _,
                    out("r4") _,
                    out("r5") _,
                    options(readonly, nostack),
                );
            }
        }
        acc + dot_reference(&w[done..n], &x.x[done..n])
    }
    #[cfg(not(lives_dsp))]
    dot_reference(w, x.x)
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
    let input = DotInput::new(input);
    for (c, y) in out.iter_mut().enumerate().take(layer.channels()) {
        let p = model.channel(layer, c);
        let acc = dot(model.weight_row(layer, c), &input);
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
            let acc = dot_reference(w, pose);
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
