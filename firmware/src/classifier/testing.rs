//! Test helpers: a tiny generator and model blobs built without the host's quantiser.

extern crate std;
use super::model::{layout, ChannelParams, HeadParams, Layer, ModelWriter};
use fixed_point::QuantizedMultiplier;
use std::vec::Vec;

/// splitmix64.
pub(crate) struct Rng(pub u64);

impl Rng {
    pub(crate) fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}

/// A writer over `buf` with every table zero, every channel multiplier zero, the head's sum
/// multiplier 1.0 and its product multiplier 1/127.
pub(crate) fn blank_writer(buf: &mut [u8]) -> ModelWriter<'_> {
    let mut w = ModelWriter::new(buf).unwrap();
    w.set_head(HeadParams { sum: QuantizedMultiplier::from_raw(1 << 30, 1), product: QuantizedMultiplier::from_raw(1_082_196_484, -6) });
    w
}

/// A valid blob with random weights, biases, multipliers and monotone saturating tables, and the
/// default normalisation.
pub(crate) fn random_blob(seed: u64) -> Vec<u8> {
    let mut rng = Rng(seed);
    let mut blob = std::vec![0u8; layout::BLOB_LEN];
    let mut w = blank_writer(&mut blob);
    for (i, layer) in Layer::ALL.into_iter().enumerate() {
        // A steep odd saturating curve, slope 1 … 3 depending on the layer.
        let slope = 1 + (i as i32 % 3);
        let table: [i8; 256] = core::array::from_fn(|q| ((q as i32 - 128) * slope).clamp(-127, 127) as i8);
        w.set_tanh_table(layer, &table);
        w.set_scale_bits(layer, 0x3C00_0000 + i as u32);
    }
    for layer in Layer::WEIGHTED {
        // Shifts so a typical accumulator lands in int8 range.
        let shift = match layer {
            Layer::ScanFc | Layer::LabelFc => -12,
            Layer::PoseFc => -10,
            _ => -7,
        };
        for c in 0..layer.channels() {
            let m = QuantizedMultiplier::from_raw((1 << 30) + (rng.next() % (1 << 30)) as i32, shift);
            let bias = (rng.next() % 4001) as i32 - 2000;
            w.set_channel(layer, c, ChannelParams { bias, multiplier: m });
        }
        for x in w.weights_mut(layer).iter_mut() {
            *x = rng.next() as u8;
        }
    }
    w.finish();
    blob
}
