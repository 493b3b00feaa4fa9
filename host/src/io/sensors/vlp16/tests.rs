use super::*;
use std::path::Path;

/// A strongest-return packet built by hand: block `k` at azimuth 100·k + 35950 (mod 36000), i.e.
/// 359.50°, 0.50°, 1.50°, … so block 1 wraps; channel `c` of block `k` has distance
/// `1000 + 10·k + c` (2 mm units), except channel 14 (−1°) of block 0 = 0 (no return) and
/// channel 1 (+1°) of block 2's second firing (channel 17) = 100 (0.2 m, below min range).
fn golden_packet() -> [u8; PACKET_LEN] {
    let mut p = [0u8; PACKET_LEN];
    for k in 0..BLOCKS {
        let at = k * BLOCK_LEN;
        p[at..at + 2].copy_from_slice(&BLOCK_FLAG);
        let az = ((35_950 + 100 * k) % 36_000) as u16;
        p[at + 2..at + 4].copy_from_slice(&az.to_le_bytes());
        for c in 0..CHANNELS_PER_BLOCK {
            let d: u16 = match (k, c) {
                (0, 14) => 0,
                (2, 17) => 100,
                _ => 1000 + 10 * k as u16 + c as u16,
            };
            let o = at + 4 + 3 * c;
            p[o..o + 2].copy_from_slice(&d.to_le_bytes());
            p[o + 2] = c as u8;
        }
    }
    p[1200..1204].copy_from_slice(&1_000_000u32.to_le_bytes());
    p[1204] = 0x37;
    p[1205] = 0x22;
    p
}

#[test]
fn golden_packet_fields() {
    let bytes = golden_packet();
    // The first bytes as they are on the wire: FF EE, 35950 = 0x8C6E LE, channel 0 = 1000 = 0x03E8 LE,
    // reflectivity 0, then channel 1 = 1001 = 0x03E9 LE.
    assert_eq!(&bytes[..8], &[0xFF, 0xEE, 0x6E, 0x8C, 0xE8, 0x03, 0x00, 0xE9]);
    let p = Vlp16Packet::new_checked(&bytes[..]).unwrap();
    assert_eq!(p.azimuth(0), 35_950);
    assert_eq!(p.azimuth(1), 50);
    assert_eq!(p.azimuth(11), 1_050);
    assert_eq!(p.distance(3, 5), 1035);
    assert_eq!(p.reflectivity(3, 5), 5);
    assert_eq!(p.timestamp_us(), 1_000_000);
    assert_eq!(p.return_mode(), Some(ReturnMode::Strongest));
    assert_eq!(p.product_id(), 0x22);
    // Firing azimuths in 0.005°: block 0 second firing halfway across the wrap: 359.50° + 0.50° = 0.00°.
    assert_eq!(p.firing_azimuth_half(0, 0), 71_900);
    assert_eq!(p.firing_azimuth_half(0, 1), 0);
    assert_eq!(p.firing_azimuth_half(1, 1), 200); // 0.50° + 0.50°
                                                  // The last block reuses the previous step (1°): 10.50° + 0.50°.
    assert_eq!(p.firing_azimuth_half(11, 1), 2_200);
    assert_eq!(p.firing_offset_ns(11, 1), 23 * 55_296);
}

#[test]
fn beam_grid_convention() {
    // 897 beams over 360°: beam b at −π + b·2π/897. Azimuth 0 (sensor +Y) is straight ahead
    // (yaw 0), i.e. beam 448.5 → rounds up to 449 (−π + 449·0.40134° = +0.2007°, nearer than 448 at −0.2007°? equal:
    // 0 sits exactly between; round half up gives 449).
    assert_eq!(beam_of_azimuth(0, 897), 449);
    // Azimuth 90° (clockwise: the sensor's right, +X) is yaw −90° = −π/2: beam (π/2)/(2π/897) = 224.25 → 224.
    assert_eq!(beam_of_azimuth(18_000, 897), 224);
    // Azimuth 270° (left) is yaw +90°: beam 672.75 → 673.
    assert_eq!(beam_of_azimuth(54_000, 897), 673);
    // Azimuth 180° (behind) is yaw ±π: beam 0.
    assert_eq!(beam_of_azimuth(36_000, 897), 0);
    // With 360 beams (1° each) azimuth 1° is yaw −1°: beam 179.
    assert_eq!(beam_of_azimuth(200, 360), 179);
}

#[test]
fn assembler_bins_the_golden_packet() {
    let bytes = golden_packet();
    let mut a = ScanAssembler::new(Vlp16Config { beams: 360, ..Vlp16Config::default() }).unwrap();
    assert_eq!(a.lasers(), vec![1, 14]);
    // Block 0 firing 0 at 359.50° opens the scan; its second firing at 0.00° is not a wrap
    // (359.5° → 0° drops more than half a turn: it is). The packet wraps once, inside block 0.
    let s = a.push_bytes(&bytes).unwrap().expect("the wrap inside block 0 ends a scan");
    // The scan before the wrap holds only block 0's first firing at azimuth 359.50° = yaw +0.5°:
    // with 360 beams, beam (180.5) → rounds half up to 181.
    assert_eq!(s.valid_beams(), 1);
    // Channel 14 (−1°) had no return, channel 1 (+1°) 1001 units = 2.002 m · cos 1° = 2.0016951 m.
    let r = s.ranges_m[181];
    assert!((r - 2.002 * 1f32.to_radians().cos()).abs() < 1e-6, "{r}");
    assert_eq!(s.stamp_us, 1_000_000);
    let rest = a.finish().unwrap();
    // Beam 180 (yaw −0.5°..+0.5°): block 0's second firing at 0.00° (ch 17 = 1017, ch 30 = 1030)
    // and block 1's first at 0.50° (180.5 rounds up; ch 1 = 1011, ch 14 = 1024): 1011 · 2 mm · cos 1°.
    assert!((rest.ranges_m[180] - (2.022 * 1f64.to_radians().cos()) as f32).abs() < 1e-6);
    // Its stamp is the second firing's time: 1 000 000 µs + 55.296 µs, truncated.
    assert_eq!(rest.stamp_us, 1_000_055);
    // Beam 179: block 1's second firing at 1.00° (ch 17 = 1027, ch 30 = 1040) and block 2's first
    // at 1.50° (178.5 rounds up; ch 1 = 1021, ch 14 = 1034): 1021.
    assert!((rest.ranges_m[179] - (2.042 * 1f64.to_radians().cos()) as f32).abs() < 1e-6);
    // Beam 178: block 2's second firing at 2.00° has ch 17 = 100 (0.2 m, below the 0.3 m minimum:
    // dropped, else it would win) and ch 30 = 1050; block 3's first at 2.50° has ch 1 = 1031: 1031.
    assert!((rest.ranges_m[178] - (2.062 * 1f64.to_radians().cos()) as f32).abs() < 1e-6);
    // Behind the sensor nothing fired.
    assert!(rest.ranges_m[0].is_nan());
}

#[test]
fn no_return_is_infinity_and_beyond_max_too() {
    let mut bytes = golden_packet();
    // All distances of block 5 to 0.
    for c in 0..CHANNELS_PER_BLOCK {
        let o = 5 * BLOCK_LEN + 4 + 3 * c;
        bytes[o..o + 2].copy_from_slice(&0u16.to_le_bytes());
    }
    let mut a = ScanAssembler::new(Vlp16Config { beams: 360, max_range_m: 2.05, ..Vlp16Config::default() }).unwrap();
    let _ = a.push_bytes(&bytes).unwrap();
    let s = a.finish().unwrap();
    // Block 5 at 4.50° (yaw −4.5°, beam 175.5 → 176) and 5.00° (beam 175): no returns.
    assert_eq!(s.ranges_m[176], f32::INFINITY);
    assert_eq!(s.ranges_m[175], f32::INFINITY);
    // Block 11 second firing (11.00°, beam 169): ch 17 1127 units = 2.254 m > 2.05 m → +∞.
    assert_eq!(s.ranges_m[169], f32::INFINITY);
}

#[test]
fn dual_mode_keeps_the_nearest_of_both_returns() {
    let mut bytes = golden_packet();
    // Dual: pairs (2k, 2k+1) share azimuth 2k·100 + 35950.
    for k in 0..BLOCKS {
        let az = ((35_950 + 100 * (k - k % 2)) % 36_000) as u16;
        bytes[k * BLOCK_LEN + 2..k * BLOCK_LEN + 4].copy_from_slice(&az.to_le_bytes());
    }
    bytes[1204] = 0x39;
    let p = Vlp16Packet::new_checked(&bytes[..]).unwrap();
    // The second firing is halfway to the next pair (2° on): 359.50° + 1° = 0.50°, for both blocks of the pair.
    assert_eq!(p.firing_azimuth_half(0, 1), 100);
    assert_eq!(p.firing_azimuth_half(1, 1), 100);
    assert_eq!(p.firing_offset_ns(3, 1), 3 * 55_296);
    let mut a = ScanAssembler::new(Vlp16Config { beams: 360, ..Vlp16Config::default() }).unwrap();
    let first = a.push(&p).unwrap();
    // Pair (0,1) first firing, 359.50° (beam 181): block 0 ch 1 = 1001, block 1 ch 1 = 1011 → 1001.
    assert!((first.ranges_m[181] - (2.002 * 1f64.to_radians().cos()) as f32).abs() < 1e-6);
    // In dual mode the pair azimuths must agree.
    bytes[3 * BLOCK_LEN + 2] ^= 1;
    assert_eq!(Vlp16Packet::new_checked(&bytes[..]).unwrap_err(), PacketError::DualPair { block: 2 });
}

#[test]
fn checks_reject_each_cause() {
    let good = golden_packet();
    assert_eq!(Vlp16Packet::new_checked(&good[..1205]).unwrap_err(), PacketError::Length { len: 1205 });
    let mut b = good;
    b[7 * BLOCK_LEN + 1] = 0xEF;
    assert_eq!(Vlp16Packet::new_checked(&b[..]).unwrap_err(), PacketError::BlockFlag { block: 7, found: [0xFF, 0xEF] });
    let mut b = good;
    b[4 * BLOCK_LEN + 2..4 * BLOCK_LEN + 4].copy_from_slice(&36_000u16.to_le_bytes());
    assert_eq!(Vlp16Packet::new_checked(&b[..]).unwrap_err(), PacketError::Azimuth { block: 4, azimuth: 36_000 });
    let mut b = good;
    b[1204] = 0x40;
    assert_eq!(Vlp16Packet::new_checked(&b[..]).unwrap_err(), PacketError::ReturnMode(0x40));
    let mut b = good;
    b[6 * BLOCK_LEN + 2..6 * BLOCK_LEN + 4].copy_from_slice(&2_000u16.to_le_bytes()); // 4.50° → 20.00°
    assert_eq!(Vlp16Packet::new_checked(&b[..]).unwrap_err(), PacketError::AzimuthStep { block: 6, step: 1_550 });
    // The product byte is not checked.
    let mut b = good;
    b[1205] = 0x21;
    assert!(Vlp16Packet::new_checked(&b[..]).is_ok());
}

#[test]
fn config_errors() {
    let d = Vlp16Config::default();
    assert_eq!(d.lasers(), vec![1, 14]);
    assert_eq!(
        ScanAssembler::new(Vlp16Config { elevation_min_deg: 1.5, elevation_max_deg: 2.5, ..d }).unwrap_err(),
        ConfigError::NoLaser { min_deg: 1.5, max_deg: 2.5 }
    );
    assert!(matches!(Vlp16Config { elevation_min_deg: 2.0, elevation_max_deg: -2.0, ..d }.validate(), Err(ConfigError::EmptyBand { .. })));
    assert_eq!(Vlp16Config { beams: 0, ..d }.validate(), Err(ConfigError::Beams(0)));
    assert!(matches!(Vlp16Config { min_range_m: 5.0, max_range_m: 1.0, ..d }.validate(), Err(ConfigError::Range { .. })));
    assert_eq!(Vlp16Config { elevation_min_deg: -15.0, elevation_max_deg: 15.0, ..d }.lasers().len(), 16);
}

#[test]
fn hour_clock_counts_on() {
    let mut c = HourClock::default();
    assert_eq!(c.unwrap(3_599_999_000), 3_599_999_000);
    assert_eq!(c.unwrap(500), HOUR_US + 500);
    assert_eq!(c.unwrap(400), HOUR_US + 400); // small reordering is not a new hour
}

#[test]
fn raw_file_cut_mid_packet_keeps_earlier_packets() {
    let mut bytes = golden_packet().to_vec();
    bytes.extend_from_slice(&golden_packet()[..300]);
    let r = CaptureFormat::Raw.decode_bytes(Path::new("x.bin"), &bytes, &Vlp16Config::default()).unwrap();
    assert_eq!(r.counts.data, 1);
    assert_eq!(r.scans.len(), 1);
    match r.error {
        Some(Vlp16Error::TruncatedPayload { offset: 1206, len: 300, .. }) => {}
        e => panic!("{e:?}"),
    }
    assert_eq!(r.error.unwrap().to_string(), "x.bin: byte 1206: the file ends 300 bytes into a 1206-byte packet");
}

#[test]
fn framing_is_the_twelve_flags_and_the_return_mode() {
    let good = golden_packet();
    assert!(frames_packet(&good));
    // Whatever follows the packet is not looked at; a packet's first bytes frame one (cut by the end of a file).
    assert!(frames_packet(&[&good[..], &[0u8; 7][..]].concat()));
    assert!(frames_packet(&good[..2]));
    assert!(frames_packet(&good[..1_205]));
    assert!(!frames_packet(&good[..1]));
    assert!(!frames_packet(&good[1..]));
    let mut b = good;
    b[11 * BLOCK_LEN] = 0xFE;
    assert!(!frames_packet(&b));
    assert!(frames_packet(&b[..11 * BLOCK_LEN + 1])); // the broken flag is not within these bytes
    let mut b = good;
    b[field::RETURN_MODE] = 0x22;
    assert!(!frames_packet(&b));
    // Azimuths and the product byte are the check's business, not the framing's.
    let mut b = good;
    b[4 * BLOCK_LEN + 2..4 * BLOCK_LEN + 4].copy_from_slice(&36_000u16.to_le_bytes());
    b[field::PRODUCT] = 0x99;
    assert!(frames_packet(&b) && Vlp16Packet::new_checked(&b[..]).is_err());
}

/// Golden packets back to back with `edit` applied; each one ends a scan (its block 0 wraps).
fn raw(packets: usize, edit: impl FnOnce(&mut Vec<u8>)) -> PcapScans {
    let mut bytes: Vec<u8> = (0..packets).flat_map(|_| golden_packet()).collect();
    edit(&mut bytes);
    CaptureFormat::Raw.decode_bytes(Path::new("r.bin"), &bytes, &Vlp16Config::default()).unwrap()
}

fn fates(r: &PcapScans) -> (u64, u64, u64, Vec<Skipped>) {
    (r.counts.data, r.counts.rejected, r.skipped_bytes, r.skips.clone())
}

#[test]
fn raw_stream_resynchronises_after_bytes_inserted_or_lost() {
    let skip = |offset, len| Skipped { offset, len };
    // One byte inserted into packet 2 (of 6): packet 2 and the byte are skipped, 3..6 decode.
    let r = raw(6, |b| b.insert(2 * PACKET_LEN + 321, 0));
    assert_eq!(fates(&r), (5, 0, 1_207, vec![skip(2_412, 1_207)]));
    assert!(r.error.is_none());
    // One byte lost from packet 2: the rest of it (1205 bytes) is skipped.
    let r = raw(6, |b| {
        b.remove(2 * PACKET_LEN + 321);
    });
    assert_eq!(fates(&r), (5, 0, 1_205, vec![skip(2_412, 1_205)]));
    // Garbage between packets 3 and 4 (with a lone FF EE in it): nothing good is lost.
    let r = raw(6, |b| {
        let mut junk = vec![0x20u8; 700];
        junk[100..102].copy_from_slice(&BLOCK_FLAG);
        b.splice(3 * PACKET_LEN..3 * PACKET_LEN, junk);
    });
    assert_eq!(fates(&r), (6, 0, 700, vec![skip(3_618, 700)]));
    assert_eq!(r.scans.len(), 6);
    // Garbage at the start and the end of the file.
    let r = raw(2, |b| {
        b.splice(0..0, *b"hello");
        b.extend_from_slice(&[0x20; 1_300]);
    });
    assert_eq!(fates(&r), (2, 0, 1_305, vec![skip(0, 5), skip(2_417, 1_300)]));
    assert!(r.error.is_none());
}

#[test]
fn raw_stream_in_step_rejects_a_damaged_packet_and_skips_a_damaged_run() {
    let skip = |offset, len| Skipped { offset, len };
    // A broken flag in packet 1, the next packet where it should be: rejected, by its check's reason.
    let r = raw(4, |b| b[PACKET_LEN + 7 * BLOCK_LEN + 1] = 0xEF);
    assert_eq!(fates(&r), (3, 1, 0, vec![]));
    assert_eq!(
        r.rejects[0],
        Rejected { offset: 1_206, reason: RejectReason::Packet(PacketError::BlockFlag { block: 7, found: [0xFF, 0xEF] }) }
    );
    // The same in the last packet: the end of the file is where the next one should be.
    let r = raw(4, |b| b[3 * PACKET_LEN + field::RETURN_MODE] = 0);
    assert_eq!(fates(&r), (3, 1, 0, vec![]));
    assert_eq!(r.rejects[0].reason, RejectReason::Packet(PacketError::ReturnMode(0)));
    // Two damaged packets in a row: one run of 2412 bytes skipped; every byte is accounted for.
    let r = raw(5, |b| {
        b[PACKET_LEN] = 0;
        b[2 * PACKET_LEN] = 0;
    });
    assert_eq!(fates(&r), (3, 0, 2_412, vec![skip(1_206, 2_412)]));
    // A file cut inside a packet after garbage: the cut packet is still named.
    let r = raw(2, |b| {
        b.extend_from_slice(&[1, 2, 3]);
        b.extend_from_slice(&golden_packet()[..300]);
    });
    assert_eq!(fates(&r), (2, 0, 3, vec![skip(2_412, 3)]));
    assert!(matches!(r.error, Some(Vlp16Error::TruncatedPayload { offset: 2_415, len: 300, .. })), "{:?}", r.error);
}

#[test]
fn raw_file_without_a_packet_is_an_error() {
    let cfg = Vlp16Config::default();
    let e = CaptureFormat::Raw.decode_bytes(Path::new("empty.bin"), &[], &cfg).unwrap_err();
    assert!(matches!(e, Vlp16Error::Empty { .. }), "{e:?}");
    assert_eq!(e.to_string(), "empty.bin is not a VLP-16 capture: the file is empty");
    // Text, and text as long as a few packets: no offset frames a packet.
    let text = "# LIVES\\nA robot looks for things.\\n".repeat(200);
    for bytes in [&b"hi"[..], &text.as_bytes()[..3 * PACKET_LEN], text.as_bytes()] {
        let e = CaptureFormat::Raw.decode_bytes(Path::new("README.md"), bytes, &cfg).unwrap_err();
        assert_eq!(
            e.to_string(),
            "README.md is not a VLP-16 capture: no packet found (neither pcap nor raw 1206-byte payloads)",
            "{} bytes",
            bytes.len()
        );
    }
    // The first bytes of a packet are one, cut short.
    let r = CaptureFormat::Raw.decode_bytes(Path::new("cut.bin"), &golden_packet()[..500], &cfg).unwrap();
    assert!(matches!(r.error, Some(Vlp16Error::TruncatedPayload { offset: 0, len: 500, .. })));
}

#[test]
fn resync_search_crosses_read_chunks() {
    // A run of 300 050 garbage bytes (longer than a read chunk) with FF EE every 100 bytes, all
    // but the twelfth flag of a packet: framing is lost for the whole run, then found again.
    let r = raw(3, |b| {
        let mut junk = vec![0u8; 300_050];
        for at in (0..junk.len()).step_by(BLOCK_LEN) {
            if at % (12 * BLOCK_LEN) != 11 * BLOCK_LEN {
                junk[at..at + 2].copy_from_slice(&BLOCK_FLAG);
            }
        }
        b.splice(PACKET_LEN..PACKET_LEN, junk);
    });
    assert_eq!(fates(&r), (3, 0, 300_050, vec![Skipped { offset: 1_206, len: 300_050 }]));
    assert_eq!(r.scans.len(), 3);
}
