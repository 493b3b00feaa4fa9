//! Golden frames: every message type pinned to its exact bytes on the wire.
//!
//! Each case is a value and the complete frame it must become (COBS, CRC and delimiter
//! included), tested both ways: emit the value → exactly these bytes; parse these bytes → exactly
//! this value. A change to any message fails here: bump `PROTOCOL_VERSION`, then renew the arrays
//! with `cargo test -p firmware --lib protocol::golden::print_goldens -- --ignored --nocapture`
//! and update `docs/protocol.md`.

extern crate std;

use super::message::*;
use super::*;
use crate::scan::BeamLabel;
use core::fmt::Debug;
use serde::de::DeserializeOwned;
use serde::Serialize;

fn emit<M: Serialize>(msg: &M, golden: &[u8]) {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let frame = encode(msg, &mut buf).expect("encodes");
    assert_eq!(frame, golden, "emitted frame differs from the golden bytes");
}

fn parse<M: DeserializeOwned + PartialEq + Debug, const N: usize>(golden: &[u8], expected: &M) {
    let mut dec = Decoder::<M, N>::new();
    let mut out = dec.feed(golden);
    let got = out.next().expect("one frame").expect("decodes");
    assert!(out.next().is_none());
    assert_eq!(&got, expected);
    assert_eq!(dec.counters(), LinkCounters { frames_ok: 1, ..LinkCounters::default() });
}

const HTC: usize = MAX_HOST_TO_CORE_FRAME - 1;
const CTH: usize = MAX_CORE_TO_HOST_FRAME - 1;

fn labels<const N: usize>(l: &[BeamLabel]) -> heapless::Vec<BeamLabel, N> {
    heapless::Vec::from_slice(l).unwrap()
}

// ----- values ---------------------------------------------------------------------------------

fn hello() -> HostToCore {
    HostToCore::Hello(Hello { version: 9, role: Role::Simulator, want_labels: true })
}
fn host_heartbeat() -> HostToCore {
    HostToCore::Heartbeat(Heartbeat { t_us: 1_000_000, seq: 7 })
}
fn pose() -> HostToCore {
    // x 1.5 m, y −2.25 m, θ 90°.
    HostToCore::Pose(PoseMsg { t_us: 1_500_000, x: 98_304, y: -147_456, theta: 1 << 30 })
}
fn scan_labelled() -> HostToCore {
    HostToCore::Scan(labelled_scan())
}
fn labelled_scan() -> ScanMsg {
    // Three beams from −180°, 1/256 turn apart: 1 m, invalid, no return; labelled.
    ScanMsg {
        t_us: 2_000_000,
        angle_min: i32::MIN,
        angle_increment: 1 << 24,
        range_min_mm: 100,
        range_max_mm: 12_000,
        ranges_mm: heapless::Vec::from_slice(&[1000, 0, 65_535]).unwrap(),
        labels: Some(labels(&[BeamLabel::Map, BeamLabel::Unlabelled, BeamLabel::NonMap])),
    }
}
fn scan_plain() -> HostToCore {
    HostToCore::Scan(plain_scan())
}
fn plain_scan() -> ScanMsg {
    ScanMsg {
        t_us: 2_000_000,
        angle_min: 0,
        angle_increment: -(1 << 24),
        range_min_mm: 0,
        range_max_mm: 65_534,
        ranges_mm: heapless::Vec::from_slice(&[300, 16_384]).unwrap(),
        labels: None,
    }
}
/// A segment with `scan`'s time, geometry, beams and labels, as beams `first_beam ..` of a scan
/// of `total_beams`.
fn segment(scan: ScanMsg, total_beams: u16, first_beam: u16) -> HostToCore {
    let whole = scan.segments(MAX_SEGMENT_BEAMS).next().expect("a scan with beams");
    HostToCore::ScanSegment(ScanSegmentMsg { total_beams, first_beam, ..whole })
}
fn scan_segment_labelled() -> HostToCore {
    // Beams 128–130 of a 256-beam scan from −180°, 1/256 turn apart: 1 m, invalid, no return.
    segment(labelled_scan(), 256, 128)
}
fn scan_segment_plain() -> HostToCore {
    // The second and last beam of a clockwise 2-beam scan, unlabelled.
    segment(ScanMsg { ranges_mm: heapless::Vec::from_slice(&[16_384]).unwrap(), ..plain_scan() }, 2, 1)
}
fn detection_at() -> HostToCore {
    HostToCore::Detection(DetectionMsg { t_us: 2_100_000, position: Some((196_608, -65_536)) })
}
fn detection_blind() -> HostToCore {
    HostToCore::Detection(DetectionMsg { t_us: 2_100_000, position: None })
}
fn command(c: WireCommand) -> HostToCore {
    HostToCore::Command(c)
}
/// `Config::DEFAULT` as of protocol v2 with the origin at (−10 m, 0), written out: a later change
/// of the defaults is not a change of the wire.
fn config() -> HostToCore {
    HostToCore::Config(ConfigMsg {
        planner: WirePlanner::Lives,
        origin_x_m: -655_360,
        origin_y_m: 0,
        lidar_max_range_m: 1_966_080,
        lidar_min_range_m: 6_554,
        camera_fov: 1 << 30,
        camera_range_m: 262_144,
        robot_radius_m: 22_938,
        min_frontier_cells: 8,
        w_dist_per_m: 65_536,
        w_unknown_per_cell: 1_311,
        unseen_unknown_eighths: 8,
        w_surface_per_ray: 0,
        w_frontier_per_cell: 655,
        w_nonmap_per_point: 98_304,
        nonmap_block_cap: 0,
        nonmap_view_cap: 8,
        look_around_here: false,
        gaze: true,
        gaze_min_gain: 262_144,
        nonmap_viewpoints: true,
        nonmap_standoff_m: 98_304,
        frontier_near_path_blocks: 1,
        nonmap_pool_radius_m: 13_107,
        nonmap_wall_clearance_m: 16_384,
        nonmap_drop_vacated: true,
        replan_interval_us: 3_000_000,
        switch_margin: 393_216,
        goal_tolerance_m: 19_661,
        goal_heading_tolerance: 238_609_294,
        goal_timeout_us: 15_000_000,
        blocked_timeout_us: 3_000_000,
        progress_m: 16_384,
        blacklist_radius_m: 32_768,
        viewpoint_snap_radius_m: 65_536,
        watchdog_us: 1_000_000,
        budgets: BudgetsMsg {
            lidar_cells: 400_000,
            visual_cells: 40_000,
            nonmap_ops: 100_000,
            plan_ops: 12_000_000,
            classify_macs: 2_000_000,
        },
        scan_matching: true,
        live_priority_interval_us: 10_000_000,
        scan_match_field: false,
        lethal_radius_m: 16_384,
    })
}
fn base_status() -> HostToCore {
    HostToCore::BaseStatus(BaseStatus { blocked: true })
}

fn hello_ack() -> CoreToHost {
    CoreToHost::HelloAck(HelloAck { version: 9, accepted: true, reason: AckReason::Compatible })
}
fn hello_refused() -> CoreToHost {
    CoreToHost::HelloAck(HelloAck { version: 8, accepted: false, reason: AckReason::VersionMismatch })
}
fn core_heartbeat() -> CoreToHost {
    CoreToHost::Heartbeat(Heartbeat { t_us: 3_000_000, seq: 42 })
}
fn goal() -> CoreToHost {
    CoreToHost::Goal(GoalMsg {
        seq: 3,
        x: 98_304,
        y: -147_456,
        theta: i32::MIN,
        utility: 425_984,
        path: heapless::Vec::from_slice(&[(0, 0), (65_536, -32_768), (98_304, -147_456)]).unwrap(),
        path_length_m: 180_000,
    })
}
fn stop() -> CoreToHost {
    CoreToHost::Stop(StopMsg { mode: WireMode::TargetFound })
}
fn status() -> CoreToHost {
    CoreToHost::Status(StatusMsg {
        t_us: 5_000_000,
        mode: WireMode::Exploring,
        ticks: 50,
        scans: 48,
        scans_rejected: 1,
        poses_rejected: 0,
        last_scan_error: Some(WireScanError::LabelCountMismatch { ranges: 3, labels: 2 }),
        plans: 2,
        goals: 1,
        blacklisted: 0,
        retired: 0,
        watchdog_trips: 1,
        cost: StageCostMsg { classify: 0, lidar: 1_234, visual: 567, nonmap: 89, plan: 150_000, gaze: 300 },
        overruns: [0, 0, 0, 1, 0],
        heap_overflows: 0,
        link: LinkCounters { frames_ok: 300, crc_errors: 2, cobs_errors: 1, decode_errors: 0, overflows: 0, ignored: 3 },
        gaze: Some(1 << 30),
        search_entropy_bits: 12_345,
    })
}
fn labels_msg() -> CoreToHost {
    CoreToHost::Labels(LabelsMsg {
        t_us: 5_000_000,
        labels: labels(&[BeamLabel::Map, BeamLabel::NonMap, BeamLabel::Unlabelled, BeamLabel::Map]),
    })
}
fn error_handshake() -> CoreToHost {
    CoreToHost::Error(ErrorMsg { code: ErrorCode::HandshakeRequired })
}
fn error_version() -> CoreToHost {
    CoreToHost::Error(ErrorMsg { code: ErrorCode::VersionMismatch { peer: 2 } })
}
fn error_config() -> CoreToHost {
    CoreToHost::Error(ErrorMsg { code: ErrorCode::ConfigRefused })
}
fn error_config_invalid() -> CoreToHost {
    // `robot_radius_m`, field 7.
    CoreToHost::Error(ErrorMsg { code: ErrorCode::ConfigInvalid { field: 7 } })
}

fn map_row() -> HostToCore {
    // Row 3 from cell 8: 12 cells, the first occupied, the next ten free, the last unknown.
    HostToCore::MapRow(MapRowMsg {
        reset: true,
        origin_x: -655_360,
        origin_y: 65_536,
        y: 3,
        x0: 8,
        n: 12,
        occupied: heapless::Vec::from_slice(&[0b0000_0001, 0]).unwrap(),
        free: heapless::Vec::from_slice(&[0b1111_1110, 0b0000_0111]).unwrap(),
    })
}
fn route() -> HostToCore {
    HostToCore::Route(RouteMsg {
        first: 0,
        waypoints: heapless::Vec::from_slice(&[
            WireWaypoint { x: 65_536, y: 131_072, heading: 1 << 30 },
            WireWaypoint { x: -32_768, y: 0, heading: i32::MIN },
        ])
        .unwrap(),
    })
}
fn error_map_row() -> CoreToHost {
    CoreToHost::Error(ErrorMsg { code: ErrorCode::MapRowRefused { y: 600 } })
}
fn error_route() -> CoreToHost {
    CoreToHost::Error(ErrorMsg { code: ErrorCode::RouteRefused { index: 256 } })
}

// ----- golden frames (host → core) --------------------------------------------------------------

#[rustfmt::skip]
static HELLO: [u8; 10] = [0x01, 0x08, 0x09, 0x01, 0x01, 0x44, 0xe5, 0x89, 0x40, 0x00];
#[rustfmt::skip]
static HOST_HEARTBEAT: [u8; 11] = [0x0a, 0x01, 0xc0, 0x84, 0x3d, 0x07, 0xea, 0x5e, 0xbf, 0x9f, 0x00];
#[rustfmt::skip]
static POSE: [u8; 21] = [0x14, 0x02, 0xe0, 0xc6, 0x5b, 0x80, 0x80, 0x0c, 0xff, 0xff, 0x11, 0x80, 0x80, 0x80, 0x80, 0x08, 0xec, 0x18, 0xe5, 0x03, 0x00];
#[rustfmt::skip]
static SCAN_LABELLED: [u8; 34] = [0x14, 0x03, 0x80, 0x89, 0x7a, 0xff, 0xff, 0xff, 0xff, 0x0f, 0x80, 0x80, 0x80, 0x10, 0x64, 0xe0, 0x5d, 0x03, 0xe8, 0x03, 0x01, 0x06, 0xff, 0xff, 0x01, 0x03, 0x01, 0x06, 0x02, 0x9d, 0xfa, 0x9e, 0x65, 0x00];
#[rustfmt::skip]
static SCAN_PLAIN: [u8; 25] = [0x05, 0x03, 0x80, 0x89, 0x7a, 0x05, 0xff, 0xff, 0xff, 0x0f, 0x07, 0xfe, 0xff, 0x03, 0x02, 0x2c, 0x01, 0x02, 0x40, 0x05, 0x0e, 0x41, 0xf6, 0xc8, 0x00];
#[rustfmt::skip]
static DETECTION_AT: [u8; 18] = [0x11, 0x04, 0xa0, 0x96, 0x80, 0x01, 0x01, 0x80, 0x80, 0x18, 0xff, 0xff, 0x07, 0x95, 0x33, 0xb0, 0xc0, 0x00];
#[rustfmt::skip]
static DETECTION_BLIND: [u8; 12] = [0x06, 0x04, 0xa0, 0x96, 0x80, 0x01, 0x05, 0x9a, 0xe8, 0x71, 0x3a, 0x00];
#[rustfmt::skip]
static COMMAND_START: [u8; 8] = [0x02, 0x05, 0x05, 0xba, 0xe6, 0xae, 0x3c, 0x00];
#[rustfmt::skip]
static COMMAND_STOP: [u8; 8] = [0x07, 0x05, 0x01, 0x2c, 0xd6, 0xa9, 0x4b, 0x00];
#[rustfmt::skip]
static COMMAND_RESET: [u8; 8] = [0x07, 0x05, 0x02, 0x96, 0x87, 0xa0, 0xd2, 0x00];
#[rustfmt::skip]
static CONFIG: [u8; 121] = [0x02, 0x06, 0x04, 0xff, 0xff, 0x4f, 0x19, 0x80, 0x80, 0xf0, 0x01, 0xb4, 0x66, 0x80, 0x80, 0x80, 0x80, 0x08, 0x80, 0x80, 0x20, 0xb4, 0xe6, 0x02, 0x08, 0x80, 0x80, 0x08, 0xbe, 0x14, 0x08, 0x06, 0x9e, 0x0a, 0x80, 0x80, 0x0c, 0x02, 0x08, 0x49, 0x01, 0x80, 0x80, 0x20, 0x01, 0x80, 0x80, 0x0c, 0x01, 0xe6, 0xcc, 0x01, 0x80, 0x80, 0x02, 0x01, 0xc0, 0x8d, 0xb7, 0x01, 0x80, 0x80, 0x30, 0x9a, 0xb3, 0x02, 0x9c, 0x8e, 0xc7, 0xe3, 0x01, 0xc0, 0xc3, 0x93, 0x07, 0xc0, 0x8d, 0xb7, 0x01, 0x80, 0x80, 0x02, 0x80, 0x80, 0x04, 0x80, 0x80, 0x08, 0xc0, 0x84, 0x3d, 0x80, 0xb5, 0x18, 0xc0, 0xb8, 0x02, 0xa0, 0x8d, 0x06, 0x80, 0xb6, 0xdc, 0x05, 0x80, 0x89, 0x7a, 0x01, 0x80, 0xad, 0xe2, 0x04, 0x08, 0x80, 0x80, 0x02, 0xbb, 0xe0, 0x72, 0x81, 0x00];
#[rustfmt::skip]
static BASE_STATUS: [u8; 8] = [0x07, 0x07, 0x01, 0xae, 0xb4, 0x9f, 0x79, 0x00];
#[rustfmt::skip]
static SCAN_SEGMENT_LABELLED: [u8; 38] = [0x18, 0x08, 0x80, 0x89, 0x7a, 0xff, 0xff, 0xff, 0xff, 0x0f, 0x80, 0x80, 0x80, 0x10, 0x64, 0xe0, 0x5d, 0x80, 0x02, 0x80, 0x01, 0x03, 0xe8, 0x03, 0x01, 0x06, 0xff, 0xff, 0x01, 0x03, 0x01, 0x06, 0x02, 0x5d, 0xd4, 0xa0, 0x1b, 0x00];
#[rustfmt::skip]
static SCAN_SEGMENT_PLAIN: [u8; 25] = [0x05, 0x08, 0x80, 0x89, 0x7a, 0x05, 0xff, 0xff, 0xff, 0x0f, 0x07, 0xfe, 0xff, 0x03, 0x02, 0x01, 0x01, 0x02, 0x40, 0x05, 0x97, 0x31, 0x50, 0x5b, 0x00];

// ----- golden frames (core → host) --------------------------------------------------------------

#[rustfmt::skip]
static HELLO_ACK: [u8; 10] = [0x01, 0x03, 0x09, 0x01, 0x05, 0xd2, 0xd5, 0x8e, 0x37, 0x00];
#[rustfmt::skip]
static HELLO_REFUSED: [u8; 10] = [0x01, 0x02, 0x08, 0x06, 0x01, 0x32, 0xbe, 0x50, 0x58, 0x00];
#[rustfmt::skip]
static CORE_HEARTBEAT: [u8; 12] = [0x0b, 0x01, 0xc0, 0x8d, 0xb7, 0x01, 0x2a, 0x39, 0xe4, 0x09, 0x8e, 0x00];
#[rustfmt::skip]
static GOAL: [u8; 40] = [0x12, 0x02, 0x03, 0x80, 0x80, 0x0c, 0xff, 0xff, 0x11, 0xff, 0xff, 0xff, 0xff, 0x0f, 0x80, 0x80, 0x34, 0x03, 0x01, 0x14, 0x80, 0x80, 0x08, 0xff, 0xff, 0x03, 0x80, 0x80, 0x0c, 0xff, 0xff, 0x11, 0xc0, 0xfc, 0x15, 0xac, 0x06, 0xa3, 0x99, 0x00];
#[rustfmt::skip]
static STOP: [u8; 8] = [0x07, 0x03, 0x02, 0x10, 0x20, 0xfa, 0x84, 0x00];
#[rustfmt::skip]
static STATUS: [u8; 57] = [0x0a, 0x04, 0xc0, 0x96, 0xb1, 0x02, 0x01, 0x32, 0x30, 0x01, 0x07, 0x01, 0x03, 0x03, 0x02, 0x02, 0x01, 0x01, 0x02, 0x01, 0x0b, 0xd2, 0x09, 0xb7, 0x04, 0x59, 0xf0, 0x93, 0x09, 0xac, 0x02, 0x01, 0x01, 0x02, 0x01, 0x01, 0x05, 0xac, 0x02, 0x02, 0x01, 0x01, 0x0e, 0x03, 0x01, 0x80, 0x80, 0x80, 0x80, 0x08, 0xb9, 0x60, 0x79, 0xc0, 0x88, 0x3c, 0x00];
#[rustfmt::skip]
static LABELS: [u8; 16] = [0x09, 0x05, 0xc0, 0x96, 0xb1, 0x02, 0x04, 0x01, 0x02, 0x06, 0x01, 0x4e, 0xdd, 0xfe, 0xa6, 0x00];
#[rustfmt::skip]
static ERROR_HANDSHAKE: [u8; 8] = [0x02, 0x06, 0x05, 0x79, 0xb5, 0x83, 0x17, 0x00];
#[rustfmt::skip]
static ERROR_VERSION: [u8; 9] = [0x08, 0x06, 0x01, 0x02, 0xcd, 0xf5, 0xd9, 0x0c, 0x00];
#[rustfmt::skip]
static ERROR_CONFIG: [u8; 8] = [0x07, 0x06, 0x02, 0x55, 0xd4, 0x8d, 0xf9, 0x00];
#[rustfmt::skip]
static MAP_ROW: [u8; 23] = [0x0e, 0x09, 0x01, 0xff, 0xff, 0x4f, 0x80, 0x80, 0x08, 0x03, 0x08, 0x0c, 0x02, 0x01, 0x08, 0x02, 0xfe, 0x07, 0x7e, 0xf3, 0x59, 0xf1, 0x00];
#[rustfmt::skip]
static ROUTE: [u8; 29] = [0x02, 0x0a, 0x10, 0x02, 0x80, 0x80, 0x08, 0x80, 0x80, 0x10, 0x80, 0x80, 0x80, 0x80, 0x08, 0xff, 0xff, 0x03, 0x0a, 0xff, 0xff, 0xff, 0xff, 0x0f, 0xe8, 0xef, 0x8f, 0xef, 0x00];
#[rustfmt::skip]
static ERROR_MAP_ROW: [u8; 10] = [0x09, 0x06, 0x04, 0xd8, 0x04, 0x12, 0xa3, 0xaa, 0x4d, 0x00];
#[rustfmt::skip]
static ERROR_ROUTE: [u8; 10] = [0x09, 0x06, 0x05, 0x80, 0x02, 0x4c, 0xbb, 0x69, 0xd7, 0x00];
#[rustfmt::skip]
static ERROR_CONFIG_INVALID: [u8; 9] = [0x08, 0x06, 0x03, 0x07, 0xc0, 0x63, 0x85, 0x4e, 0x00];

macro_rules! golden {
    ($test:ident, $n:expr, $value:expr, $bytes:expr) => {
        mod $test {
            use super::*;

            #[test]
            fn emit() {
                super::emit(&$value, &$bytes);
            }

            #[test]
            fn parse() {
                super::parse::<_, { $n }>(&$bytes, &$value);
            }
        }
    };
}

/// The cases of one direction, each written once as `test: value => FRAME`: `$cases()` lists them
/// all (for the checks over every case) and each gets its own `emit` and `parse` tests
/// ([`golden!`]).
macro_rules! goldens {
    ($cases:ident: $msg:ty, $n:expr; $($test:ident: $value:expr => $bytes:ident,)*) => {
        fn $cases() -> std::vec::Vec<(&'static str, $msg, &'static [u8])> {
            std::vec![$((stringify!($bytes), $value, &$bytes)),*]
        }

        $(golden!($test, $n, $value, $bytes);)*
    };
}

goldens! {
    host_cases: HostToCore, HTC;
    hello: hello() => HELLO,
    host_heartbeat: host_heartbeat() => HOST_HEARTBEAT,
    pose: pose() => POSE,
    scan_labelled: scan_labelled() => SCAN_LABELLED,
    scan_plain: scan_plain() => SCAN_PLAIN,
    detection_at: detection_at() => DETECTION_AT,
    detection_blind: detection_blind() => DETECTION_BLIND,
    command_start: command(WireCommand::Start) => COMMAND_START,
    command_stop: command(WireCommand::Stop) => COMMAND_STOP,
    command_reset: command(WireCommand::Reset) => COMMAND_RESET,
    config: config() => CONFIG,
    base_status: base_status() => BASE_STATUS,
    scan_segment_labelled: scan_segment_labelled() => SCAN_SEGMENT_LABELLED,
    scan_segment_plain: scan_segment_plain() => SCAN_SEGMENT_PLAIN,
    map_row: map_row() => MAP_ROW,
    route: route() => ROUTE,
}

goldens! {
    core_cases: CoreToHost, CTH;
    hello_ack: hello_ack() => HELLO_ACK,
    hello_refused: hello_refused() => HELLO_REFUSED,
    core_heartbeat: core_heartbeat() => CORE_HEARTBEAT,
    goal: goal() => GOAL,
    stop: stop() => STOP,
    status: status() => STATUS,
    labels: labels_msg() => LABELS,
    error_handshake: error_handshake() => ERROR_HANDSHAKE,
    error_version: error_version() => ERROR_VERSION,
    error_config: error_config() => ERROR_CONFIG,
    error_config_invalid: error_config_invalid() => ERROR_CONFIG_INVALID,
    error_map_row: error_map_row() => ERROR_MAP_ROW,
    error_route: error_route() => ERROR_ROUTE,
}

/// Every variant of both enums has a golden frame (a new variant without one fails here), and
/// every listed case matches its frame.
#[test]
fn every_message_type_has_a_golden_frame() {
    for (_, m, g) in host_cases() {
        emit(&m, g);
        parse::<_, HTC>(g, &m);
    }
    for (_, m, g) in core_cases() {
        emit(&m, g);
        parse::<_, CTH>(g, &m);
    }
    let host_tags: std::collections::BTreeSet<u8> = host_cases().iter().map(|(_, m, _)| tag(m)).collect();
    let core_tags: std::collections::BTreeSet<u8> = core_cases().iter().map(|(_, m, _)| tag(m)).collect();
    assert_eq!(host_tags.into_iter().collect::<std::vec::Vec<_>>(), (0..11).collect::<std::vec::Vec<_>>());
    assert_eq!(core_tags.into_iter().collect::<std::vec::Vec<_>>(), (0..7).collect::<std::vec::Vec<_>>());
}

/// The golden frames are for this version (the frozen `Hello`/`HelloAck` carry it).
#[test]
fn the_goldens_are_of_the_current_version() {
    assert_eq!(PROTOCOL_VERSION, 9);
    assert!(matches!(hello(), HostToCore::Hello(h) if h.version == PROTOCOL_VERSION));
    assert!(matches!(hello_ack(), CoreToHost::HelloAck(a) if a.version == PROTOCOL_VERSION));
}

/// Prints every case as a Rust array, to renew the goldens after a deliberate change (see the
/// module docs). Not a check: ignored.
#[test]
#[ignore]
fn print_goldens() {
    fn print(name: &str, frame: &[u8]) {
        let bytes: std::vec::Vec<std::string::String> = frame.iter().map(|b| std::format!("0x{b:02x}")).collect();
        std::println!("#[rustfmt::skip]\nstatic {name}: [u8; {}] = [{}];", frame.len(), bytes.join(", "));
    }
    let mut buf = [0u8; MAX_FRAME_LEN];
    for (name, m, _) in host_cases() {
        print(name, encode(&m, &mut buf).unwrap());
    }
    for (name, m, _) in core_cases() {
        print(name, encode(&m, &mut buf).unwrap());
    }
}

/// The variant tag: the first postcard byte (one byte while there are fewer than 128 variants).
fn tag<M: Serialize>(m: &M) -> u8 {
    let mut buf = [0u8; MAX_FRAME_LEN];
    postcard::to_slice(m, &mut buf).unwrap()[0]
}
