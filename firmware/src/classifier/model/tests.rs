//! Tests of the parent module (`model.rs`).

extern crate std;
use super::*;
use crate::classifier::testing::{random_blob, Rng};
use std::vec::Vec;

/// The header of the test blob with seed 1, byte for byte (CRC excluded: it covers the
/// random payload).
static HEADER_BYTES: [u8; 60] = [
    b'L', b'I', b'V', b'M', // magic
    1, 0, // version
    64, 0, // header length
    9, 0, // k
    0x81, 0x03, // 897 beams
    9, 9, 9, 3, 7, // kernels, pose channels, pose features, tanh tables
    0, // range encoding: linear
    0, 0, // reserved
    0x30, 0x75, 0, 0, // range_max_mm 30 000
    0x88, 0x13, 0, 0, // pose_scale_mm 5 000
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, // reserved
    0x78, 0x30, 0x1A, 0x00, // payload length 1 716 344
];

#[test]
fn layout_constants() {
    assert_eq!(layout::SCALES, 64);
    assert_eq!(layout::TANH, 96);
    assert_eq!(layout::HEAD, 1_888);
    assert_eq!(layout::CHANNELS, 1_904);
    assert_eq!(layout::WEIGHTS, 34_328);
    assert_eq!(layout::weights_of(Layer::ScanFc), 34_328 + 84);
    assert_eq!(layout::weights_of(Layer::LabelConv), 34_328 + 84 + 804_612);
    // The offsets docs/model-format.md lists.
    let channels = [1_904, 1_916, 12_680, 12_692, 23_456, 23_564];
    let weights = [34_328, 34_412, 839_024, 839_108, 1_643_720, 1_643_748];
    for (i, layer) in Layer::WEIGHTED.into_iter().enumerate() {
        assert_eq!(layout::channels_of(layer), channels[i], "{layer:?}");
        assert_eq!(layout::weights_of(layer), weights[i], "{layer:?}");
    }
    assert_eq!(layout::BLOB_LEN, 1_716_408);
    assert_eq!(layout::PAYLOAD_LEN, 1_716_344);
    assert_eq!(Layer::ScanFc.weights_len(), 897 * 897);
    assert_eq!(Layer::PoseFc.weights_len(), 897 * 81);
}

#[test]
fn crc_is_the_zlib_crc() {
    let mut d = CRC32.digest();
    d.update(b"123456789");
    assert_eq!(d.finalize(), 0xCBF4_3926);
}

#[test]
fn golden_header_and_round_trip() {
    let blob = random_blob(1);
    assert_eq!(&blob[..60], &HEADER_BYTES[..]);
    let m = ModelView::parse(&blob).unwrap();
    assert_eq!(m.normalisation(), Normalisation::DEFAULT);
    assert_eq!(m.crc(), checksum(&blob).unwrap());
    assert_eq!(m.weights(Layer::ScanFc).len(), 897 * 897);
    assert_eq!(m.weight_row(Layer::PoseFc, 896).len(), 81);
    assert!(m.weight_row(Layer::PoseFc, 897).is_empty());
    assert!(m.channel(Layer::ScanFc, 3).multiplier.is_normalised());
}

fn with_crc(mut blob: Vec<u8>) -> Vec<u8> {
    let crc = checksum(&blob).unwrap();
    blob[field::CRC..field::CRC + 4].copy_from_slice(&crc.to_le_bytes());
    blob
}

#[test]
fn each_cause_has_its_error() {
    let good = random_blob(2);
    let parse = |b: &[u8]| ModelView::parse(b).map(|_| ());
    assert_eq!(parse(&good), Ok(()));
    assert_eq!(parse(&[]), Err(ModelError::Truncated { needed: 64, got: 0 }));
    assert_eq!(parse(b"LIVMxx"), Err(ModelError::Truncated { needed: 64, got: 6 }));
    assert_eq!(parse(b"ONNX and more bytes"), Err(ModelError::BadMagic));
    assert_eq!(parse(&good[..1000]), Err(ModelError::Truncated { needed: layout::BLOB_LEN, got: 1000 }));
    assert_eq!(parse(&good[..good.len() - 1]), Err(ModelError::Truncated { needed: layout::BLOB_LEN, got: good.len() - 1 }));
    let mut long = good.clone();
    long.push(0);
    assert_eq!(parse(&long), Err(ModelError::TrailingBytes { extra: 1 }));

    let mut b = good.clone();
    b[field::VERSION] = 2;
    assert_eq!(parse(&b), Err(ModelError::UnsupportedVersion(2)));
    let mut b = good.clone();
    b[field::HEADER_LEN] = 32;
    assert_eq!(parse(&b), Err(ModelError::BadHeaderLength(32)));
    let mut b = good.clone();
    b[field::BEAMS..field::BEAMS + 2].copy_from_slice(&720u16.to_le_bytes());
    assert_eq!(parse(&b), Err(ModelError::ShapeMismatch { field: ShapeField::Beams, expected: 897, found: 720 }));
    let mut b = good.clone();
    b[field::HISTORY] = 10;
    assert_eq!(parse(&b), Err(ModelError::ShapeMismatch { field: ShapeField::History, expected: 9, found: 10 }));
    let mut b = good.clone();
    b[field::POSE_FEATURES] = 4;
    assert_eq!(parse(&b), Err(ModelError::ShapeMismatch { field: ShapeField::PoseFeatures, expected: 3, found: 4 }));
    let mut b = good.clone();
    b[40] = 1;
    assert_eq!(parse(&b), Err(ModelError::ReservedNotZero));
    let mut b = good.clone();
    b[field::PAYLOAD_LEN] ^= 1;
    assert!(matches!(parse(&b), Err(ModelError::PayloadLength { .. })));

    // One flipped weight bit: the checksum catches it.
    let mut b = good.clone();
    b[layout::weights_of(Layer::LabelFc) + 12345] ^= 0x10;
    assert!(matches!(parse(&b), Err(ModelError::ChecksumMismatch { .. })));
    let mut b = good.clone();
    b[field::CRC] ^= 0x01;
    assert!(matches!(parse(&b), Err(ModelError::ChecksumMismatch { .. })));

    // Semantically bad but correctly checksummed.
    let mut b = good.clone();
    b[field::RANGE_MAX_MM..field::RANGE_MAX_MM + 4].copy_from_slice(&0u32.to_le_bytes());
    assert_eq!(parse(&with_crc(b)), Err(ModelError::BadNormalisation));
    let mut b = good.clone();
    b[field::RANGE_ENCODING] = 2;
    assert_eq!(parse(&with_crc(b)), Err(ModelError::BadNormalisation));
    let mut b = good.clone();
    b[field::RANGE_ENCODING] = 1;
    let b = with_crc(b);
    assert_eq!(ModelView::parse(&b).map(|m| m.normalisation().range_encoding), Ok(RangeEncoding::Inverse));
    let mut b = good.clone();
    b[field::RESERVED_A] = 1;
    assert_eq!(parse(&b), Err(ModelError::ReservedNotZero));
    let mut b = good.clone();
    let off = layout::channels_of(Layer::PoseFc) + 5 * CHANNEL_RECORD_LEN + 8;
    b[off..off + 4].copy_from_slice(&40i32.to_le_bytes());
    assert_eq!(parse(&with_crc(b)), Err(ModelError::BadMultiplier { layer: Layer::PoseFc, channel: 5 }));
    let mut b = good.clone();
    let off = layout::channels_of(Layer::ScanConv) + 4;
    b[off..off + 4].copy_from_slice(&12345i32.to_le_bytes());
    assert_eq!(parse(&with_crc(b)), Err(ModelError::BadMultiplier { layer: Layer::ScanConv, channel: 0 }));
    let mut b = good.clone();
    b[layout::HEAD + 8..layout::HEAD + 12].copy_from_slice(&(-5i32).to_le_bytes());
    assert_eq!(parse(&with_crc(b)), Err(ModelError::BadMultiplier { layer: Layer::Head, channel: 1 }));
}

#[test]
fn writer_refuses_wrong_buffer_sizes() {
    let mut small = [0u8; 10];
    assert!(matches!(ModelWriter::new(&mut small), Err(ModelError::Truncated { .. })));
    let mut big = std::vec![0u8; layout::BLOB_LEN + 3];
    assert!(matches!(ModelWriter::new(&mut big), Err(ModelError::TrailingBytes { extra: 3 })));
}

/// Random bytes, truncations, bit flips (with and without a repaired checksum): parse never
/// panics, and a blob it accepts can be read everywhere.
#[test]
fn fuzz_parse_never_panics() {
    let good = random_blob(3);
    let mut rng = Rng(0xF022);
    let mut accepted = 0;
    for i in 0..3000 {
        let case: Vec<u8> = match i % 5 {
            0 => {
                let n = (rng.next() % 200) as usize;
                let mut v: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
                if n >= 4 && rng.next() & 1 == 0 {
                    v[..4].copy_from_slice(&MAGIC);
                }
                v
            }
            1 => good[..(rng.next() as usize % (good.len() + 1))].to_vec(),
            2 => {
                let mut v = good.clone();
                for _ in 0..1 + rng.next() % 4 {
                    let at = rng.next() as usize % v.len();
                    v[at] ^= 1 << (rng.next() % 8);
                }
                v
            }
            3 => {
                // Flips in the header and the small sections, checksum repaired.
                let mut v = good.clone();
                let at = rng.next() as usize % layout::WEIGHTS;
                if !(field::CRC..HEADER_LEN).contains(&at) {
                    v[at] ^= 1 << (rng.next() % 8);
                }
                with_crc(v)
            }
            _ => {
                let mut v = good.clone();
                v.truncate(rng.next() as usize % good.len());
                v.extend((0..rng.next() % 64).map(|_| rng.next() as u8));
                v
            }
        };
        if let Ok(m) = ModelView::parse(&case) {
            accepted += 1;
            for layer in Layer::ALL {
                let _ = m.tanh_table(layer);
                let _ = m.scale_bits(layer);
                for c in [0, layer.channels().saturating_sub(1), layer.channels()] {
                    let _ = m.channel(layer, c);
                    let _ = m.weight_row(layer, c);
                }
            }
        }
    }
    // Repaired header flips in scales/tanh/weights stay valid.
    assert!(accepted > 0);
}
