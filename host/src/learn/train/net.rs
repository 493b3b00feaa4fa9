//! The network in candle (`LabelPoseNet`), its parameters one-to-one with `FloatModel`'s, and
//! PyTorch's default initialisation.

use super::*;
use crate::learn::model::FloatModel;
use candle_core::{Device, Tensor, Var};
use firmware::capacity::BEAMS;
use firmware::classifier::{
    Normalisation, ENC_KERNEL, ENC_PAD, HISTORY, LABEL_ROWS, LABEL_WEIGHT_SUM, POSE_CHANNELS, POSE_FEATURES, POSE_FLAT,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// PyTorch's default initialisation of `LabelPoseNet` (`Conv2d` / `Linear`: weights and biases
/// uniform in ±1/√fan_in), drawn from a ChaCha8 generator seeded with `seed`, in the order
/// scan conv, scan fc, label conv, label fc, pose conv, pose fc (weights then biases).
pub fn pytorch_init(seed: u64) -> FloatModel {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut uni = |n: usize, fan_in: usize| -> Vec<f32> {
        let a = 1.0 / (fan_in as f32).sqrt();
        (0..n).map(|_| rng.gen_range(-a..a)).collect()
    };
    let mut encoder = || {
        let conv_w = uni(HISTORY * ENC_KERNEL, HISTORY * ENC_KERNEL);
        let conv_b = uni(1, HISTORY * ENC_KERNEL)[0];
        let fc_w = uni(BEAMS * BEAMS, BEAMS);
        let fc_b = uni(BEAMS, BEAMS);
        crate::learn::model::Encoder { conv_w, conv_b, fc_w, fc_b }
    };
    let scan = encoder();
    let label = encoder();
    let pose = crate::learn::model::PoseEncoder {
        conv_w: uni(POSE_CHANNELS * POSE_FEATURES, POSE_FEATURES),
        conv_b: uni(POSE_CHANNELS, POSE_FEATURES),
        fc_w: uni(BEAMS * POSE_FLAT, POSE_FLAT),
        fc_b: uni(BEAMS, POSE_FLAT),
    };
    FloatModel { scan, label, pose, norm: Normalisation::DEFAULT }
}

// ---------------------------------------------------------------------------------------------
// The network in candle.

/// One encoder's parameters as candle variables (shapes: conv `[81]` = `[t][j]`, conv bias `[1]`,
/// fc `[897, 897]` = `[out][in]`, fc bias `[897]`).
pub struct CandleEncoder {
    /// Conv weight `[t · 9 + j]`.
    pub conv_w: Var,
    /// Conv bias `[1]`.
    pub conv_b: Var,
    /// Linear weight `[out, in]` (unused while [`CandleEncoder::circulant`] is set).
    pub fc_w: Var,
    /// Linear bias `[out]`.
    pub fc_b: Var,
    /// Training-time weight sharing: when set, the linear weight is the circulant matrix
    /// `W[o][i] = c[(i − o) mod 897]` of this `[897]` vector (the gather index is the second
    /// field), i.e. the same kernel at every beam. Exported as the full matrix.
    pub circulant: Option<(Var, Tensor)>,
}

/// The pose encoder's parameters (conv `[9, 3]` = `[c][f]`, bias `[9]`, fc `[897, 81]`, bias `[897]`).
pub struct CandlePose {
    /// Conv weight `[c, f]`.
    pub conv_w: Var,
    /// Conv bias `[c]`.
    pub conv_b: Var,
    /// Linear weight `[897, 81]`, input index `c · 9 + t`.
    pub fc_w: Var,
    /// Linear bias `[897]`.
    pub fc_b: Var,
}

/// `LabelPoseNet` in candle: trainable, exports to a [`FloatModel`].
pub struct LabelPoseNet {
    /// Scan encoder.
    pub scan: CandleEncoder,
    /// Label encoder.
    pub label: CandleEncoder,
    /// Pose encoder.
    pub pose: CandlePose,
    /// Input normalisation (carried into the exported model).
    pub norm: Normalisation,
    /// The label-average weights `(r + 1) / 36`, shape `[1, 8, 1]`.
    avg_w: Tensor,
    device: Device,
}

pub(super) fn var(v: &[f32], shape: &[usize], dev: &Device) -> Result<Var> {
    Ok(Var::from_tensor(&Tensor::from_slice(v, shape, dev)?)?)
}

pub(super) fn to_vec(v: &Var) -> Result<Vec<f32>> {
    Ok(v.as_tensor().flatten_all()?.to_vec1::<f32>()?)
}

impl CandleEncoder {
    fn new(e: &crate::learn::model::Encoder, dev: &Device) -> Result<Self> {
        Ok(Self {
            conv_w: var(&e.conv_w, &[HISTORY * ENC_KERNEL], dev)?,
            conv_b: var(&[e.conv_b], &[1], dev)?,
            fc_w: var(&e.fc_w, &[BEAMS, BEAMS], dev)?,
            fc_b: var(&e.fc_b, &[BEAMS], dev)?,
            circulant: None,
        })
    }

    /// Switches to the circulant parameterisation, its kernel the mean of each wrapped diagonal
    /// of the current weight (exact for a circulant matrix).
    pub fn make_circulant(&mut self) -> Result<()> {
        let w = to_vec(&self.fc_w)?;
        let mut c = vec![0.0f32; BEAMS];
        for o in 0..BEAMS {
            for (d, cd) in c.iter_mut().enumerate() {
                *cd += w[o * BEAMS + (o + d) % BEAMS];
            }
        }
        c.iter_mut().for_each(|v| *v /= BEAMS as f32);
        let idx: Vec<u32> = (0..BEAMS * BEAMS).map(|k| ((k % BEAMS + BEAMS - k / BEAMS) % BEAMS) as u32).collect();
        let dev = self.fc_w.device().clone();
        self.circulant = Some((var(&c, &[BEAMS], &dev)?, Tensor::from_vec(idx, BEAMS * BEAMS, &dev)?));
        Ok(())
    }

    /// Back to a full weight matrix (the expanded circulant), trainable element by element.
    pub fn make_full(&mut self) -> Result<()> {
        if self.circulant.is_some() {
            let w = self.fc_weight()?;
            self.fc_w = Var::from_tensor(&w)?;
            self.circulant = None;
        }
        Ok(())
    }

    /// The linear weight `[out, in]` as a tensor.
    fn fc_weight(&self) -> Result<Tensor> {
        Ok(match &self.circulant {
            Some((c, idx)) => c.as_tensor().index_select(idx, 0)?.reshape((BEAMS, BEAMS))?,
            None => self.fc_w.as_tensor().clone(),
        })
    }

    fn to_float(&self) -> Result<crate::learn::model::Encoder> {
        Ok(crate::learn::model::Encoder {
            conv_w: to_vec(&self.conv_w)?,
            conv_b: to_vec(&self.conv_b)?[0],
            fc_w: self.fc_weight()?.flatten_all()?.to_vec1::<f32>()?,
            fc_b: to_vec(&self.fc_b)?,
        })
    }

    /// `rows` `[N, 9, 897]` → `[N, 897]`: circular 9 × 9 convolution (padding 4 along the beams,
    /// none in time) → tanh → linear → tanh.
    fn forward(&self, rows: &Tensor) -> Result<Tensor> {
        let (n, pad) = (rows.dim(0)?, ENC_PAD);
        // Circular padding by concatenating the wrapped columns: [N, 9, 4 + 897 + 4].
        let padded = Tensor::cat(&[&rows.narrow(2, BEAMS - pad, pad)?, rows, &rows.narrow(2, 0, pad)?], 2)?;
        let wide = BEAMS + 2 * pad;
        // z[n, b', j] = Σ_t w[t][j] · padded[n, t, b'] (one small matmul), then
        // conv[n, b] = Σ_j z[n, b + j, j] (nine shifted diagonals).
        let z = padded
            .transpose(1, 2)?
            .contiguous()?
            .reshape((n * wide, HISTORY))?
            .matmul(&self.conv_w.as_tensor().reshape((HISTORY, ENC_KERNEL))?)?
            .reshape((n, wide, ENC_KERNEL))?;
        let mut conv = z.narrow(1, 0, BEAMS)?.narrow(2, 0, 1)?;
        for j in 1..ENC_KERNEL {
            conv = (conv + z.narrow(1, j, BEAMS)?.narrow(2, j, 1)?)?;
        }
        let conv = conv.squeeze(2)?.broadcast_add(self.conv_b.as_tensor())?;
        let hidden = conv.tanh()?;
        Ok(hidden.matmul(&self.fc_weight()?.t()?)?.broadcast_add(self.fc_b.as_tensor())?.tanh()?)
    }

    fn vars(&self) -> [Var; 4] {
        let fc = match &self.circulant {
            Some((c, _)) => c.clone(),
            None => self.fc_w.clone(),
        };
        [self.conv_w.clone(), self.conv_b.clone(), fc, self.fc_b.clone()]
    }
}

impl LabelPoseNet {
    /// The candle twin of `m` on `device` (CPU).
    pub fn from_float(m: &FloatModel, device: &Device) -> Result<Self> {
        let p = &m.pose;
        let w: Vec<f32> = (0..LABEL_ROWS).map(|r| (r + 1) as f32 / LABEL_WEIGHT_SUM as f32).collect();
        Ok(Self {
            scan: CandleEncoder::new(&m.scan, device)?,
            label: CandleEncoder::new(&m.label, device)?,
            pose: CandlePose {
                conv_w: var(&p.conv_w, &[POSE_CHANNELS, POSE_FEATURES], device)?,
                conv_b: var(&p.conv_b, &[POSE_CHANNELS], device)?,
                fc_w: var(&p.fc_w, &[BEAMS, POSE_FLAT], device)?,
                fc_b: var(&p.fc_b, &[BEAMS], device)?,
            },
            norm: m.norm,
            avg_w: Tensor::from_vec(w, (1, LABEL_ROWS, 1), device)?,
            device: device.clone(),
        })
    }

    /// The current weights as a [`FloatModel`].
    pub fn to_float(&self) -> Result<FloatModel> {
        let p = &self.pose;
        Ok(FloatModel {
            scan: self.scan.to_float()?,
            label: self.label.to_float()?,
            pose: crate::learn::model::PoseEncoder {
                conv_w: to_vec(&p.conv_w)?,
                conv_b: to_vec(&p.conv_b)?,
                fc_w: to_vec(&p.fc_w)?,
                fc_b: to_vec(&p.fc_b)?,
            },
            norm: self.norm,
        })
    }

    /// All trainable variables.
    pub fn vars(&self) -> Vec<Var> {
        let mut v: Vec<Var> = self.scan.vars().into();
        v.extend(self.label.vars());
        v.extend([self.pose.conv_w.clone(), self.pose.conv_b.clone(), self.pose.fc_w.clone(), self.pose.fc_b.clone()]);
        v
    }

    /// The device the variables live on.
    pub fn device(&self) -> &Device {
        &self.device
    }

    /// Forward pass: scans `[N, 9, 897]`, labels `[N, 8, 897]` (the average row is computed
    /// here), poses `[N, 9, 3]` → outputs `[N, 897]` in (−1, 1).
    pub fn forward(&self, scans: &Tensor, labels: &Tensor, poses: &Tensor) -> Result<Tensor> {
        let n = scans.dim(0)?;
        let scan_enc = self.scan.forward(scans)?;
        let avg = labels.broadcast_mul(&self.avg_w)?.sum_keepdim(1)?;
        let label_rows = Tensor::cat(&[labels, &avg], 1)?;
        let label_enc = self.label.forward(&label_rows)?;
        // Pose conv (1 × 3 kernel = a linear map of each step's x, y, θ): [N · 9, 3] → [N · 9, 9].
        let z = poses
            .reshape((n * HISTORY, POSE_FEATURES))?
            .matmul(&self.pose.conv_w.as_tensor().t()?)?
            .broadcast_add(self.pose.conv_b.as_tensor())?
            .tanh()?;
        // [N, t, c] → channel-major flatten [N, c · 9 + t].
        let flat = z.reshape((n, HISTORY, POSE_CHANNELS))?.transpose(1, 2)?.contiguous()?.reshape((n, POSE_FLAT))?;
        let pose_enc = flat.matmul(&self.pose.fc_w.as_tensor().t()?)?.broadcast_add(self.pose.fc_b.as_tensor())?.tanh()?;
        Ok(((scan_enc + pose_enc)?.tanh()? * label_enc)?)
    }

    /// Forward pass on a [`Batch`].
    pub fn forward_batch(&self, b: &Batch) -> Result<Tensor> {
        let (s, l, p) = b.input_tensors(&self.device)?;
        self.forward(&s, &l, &p)
    }
}
