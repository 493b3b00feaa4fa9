//! `lives bridge`: a source's poses, scans and detections to `lives node`, its goals back.

use super::common::{load_spec, open_serial, result_line, say, RunArgs, SetSimArgs};
use host::link::{run_bridge, BridgeOptions, Source, TimeMode};
use std::path::PathBuf;
use std::process::ExitCode;

/// The host bridge: feeds a source's poses, scans and detections to `lives node` over a
/// serial device, drives the base with the goals that come back, reports link health.
#[derive(clap::Args)]
#[command(mut_arg("set", |a| a.help("Override a controller parameter sent to the node, e.g. `--set w_dist_per_m=2`")))]
#[command(mut_arg("sim", |a| a.help(concat!(
    "Change the simulated robot (`--source sim`), e.g. `--sim speed_mps=0.3` or `--sim camera_range_m=8` ",
    "(repeatable; `lives params` lists them). The camera, the LiDAR's range and the body's ",
    "size also set the controller's model of them; a `--set` then changes the model alone"
))))]
pub struct BridgeArgs {
    /// Serial device; waited for if absent, reopened if it disappears.
    #[arg(long)]
    port: PathBuf,
    /// Baud rate (a real UART only).
    #[arg(long, default_value_t = 921_600)]
    baud: u32,
    /// Where the data comes from: `sim` (the simulator) or `robot` (a real base through the
    /// base adapter, docs/base-adapter.md; real time only).
    #[arg(long, default_value = "sim")]
    source: String,
    /// `--source robot`: where the base adapter listens (JSON lines over TCP; keep it on localhost).
    #[arg(long, default_value = "127.0.0.1:7100", value_name = "ADDR")]
    base_listen: String,
    /// `--source robot`: scans from the adapter's client (`adapter`) or a VLP-16 on UDP
    /// (`vlp16-udp`, or `vlp16-udp=ADDR`; default 0.0.0.0:2368).
    #[arg(long, default_value = "adapter")]
    lidar: String,
    /// `--source robot`: the grid's lower-left corner `X,Y` in the odometry frame, metres
    /// (default: a 51.2 m grid centred on the first odometry pose).
    #[arg(long, value_name = "X,Y", allow_hyphen_values = true)]
    origin: Option<String>,
    #[command(flatten)]
    run: RunArgs,
    // `--set` (sent to the node) and `--sim` (`--source sim`): their help is in `mut_arg` above.
    #[command(flatten)]
    set_sim: SetSimArgs,
    /// The simulator waits for the node each tick (the node must run with --lockstep too).
    #[arg(long)]
    lockstep: bool,
    /// Send each scan in segments of this many beams (1-128; protocol v2 `ScanSegment`)
    /// instead of one frame: for a noisy line, where small frames survive and a 2.7 kB scan
    /// frame does not. 0: whole scans.
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u16).range(0..=128))]
    scan_segment_beams: u16,
    /// Print one JSON object (result and link health).
    #[arg(long)]
    json: bool,
    /// Record what crosses the link (pose, scan, the node's labels, goals, detection, status)
    /// to an MCAP file that Foxglove opens (docs/recording.md).
    #[arg(long, value_name = "FILE.mcap")]
    record: Option<PathBuf>,
}

pub fn run(args: BridgeArgs) -> Result<ExitCode, String> {
    let BridgeArgs { port, baud, source, run, set_sim, lockstep, scan_segment_beams, json, record, base_listen, lidar, origin } = args;
    if source == "robot" && !set_sim.sim.is_empty() {
        return Err("--sim changes the simulated robot; it has no meaning with `--source robot`".into());
    }
    if source == "robot" {
        let opts = host::link::robot::CliOptions {
            port,
            baud,
            planner: run.planner,
            set: set_sim.set,
            lockstep,
            json,
            record,
            base_listen,
            lidar,
            origin,
        };
        return host::link::robot::run_cli(opts);
    }
    if source != "sim" {
        return Err(format!("unknown source `{source}` (`sim` or `robot`)"));
    }
    let mut spec = load_spec(&run)?;
    set_sim.configure(&mut spec)?;
    if spec.planner.uses_classifier() {
        // As `lives search`: the scans go without labels and the node's classifier (the
        // committed geometric one unless `lives node --model` says otherwise) labels
        // them; the bridge stops with a clear error if the node has none.
        spec.model = Some(firmware::classifier::EMBEDDED_GEO_MODEL);
    }
    let mode = if lockstep { TimeMode::Lockstep } else { TimeMode::RealTime };
    let mut link = open_serial(&port, baud);
    let stop = std::sync::atomic::AtomicBool::new(false);
    let recording = record.as_ref().map(|p| host::link::record::SharedRecording::create(p)).transpose().map_err(|e| e.to_string())?;
    let opts = BridgeOptions {
        scan_segment_beams: scan_segment_beams as usize,
        want_labels: recording.is_some(),
        observer: recording.as_ref().map(|r| r.observer()),
        ..BridgeOptions::new(mode)
    };
    let run = run_bridge(&mut link, Source::Sim(spec), &opts, &stop).map_err(|e| e.to_string())?;
    if let (Some(rec), Some(path)) = (recording, &record) {
        rec.finish().map_err(|e| format!("{}: {e}", path.display()))?;
    }
    let (r, st) = (&run.result, &run.stats);
    if json {
        let goals: Vec<_> = run.goals.iter().map(|((x, y), h)| serde_json::json!([x, y, h.0])).collect();
        say!("{}", serde_json::json!({ "result": r, "link": st, "goals": goals, "wall_s": run.wall_s }));
    } else {
        let ticks = r.ticks.max(1) as f64;
        say!("{}; {:.2} s wall", result_line(r), run.wall_s);
        say!(
            "link: sent {} frames / {} B ({:.0} B per tick), received {} frames / {} B, rejected {} ({})",
            st.frames_sent,
            st.bytes_sent,
            st.bytes_sent as f64 / ticks,
            st.frames_received,
            st.bytes_received,
            st.rejected,
            st.decoder
        );
        say!(
            "link: {} retries, {} hellos, {} losses, {} reopenings, {} io errors; round trip p50 {:.0} us p95 {:.0} us; batch round trip p50 {:.0} us p95 {:.0} us; scan {} B in {} frame(s)",
            st.retries,
            st.hellos_sent,
            st.link_losses,
            st.reconnects,
            st.io_errors,
            st.link_rtt_us.p50,
            st.link_rtt_us.p95,
            st.batch_rtt_us.p50,
            st.batch_rtt_us.p95,
            st.scan_frame_bytes,
            st.scan_frames
        );
        if let Some(n) = &st.node_status {
            say!("node: {:?}, {} ticks, {} scans, rejected {} ({})", n.mode, n.ticks, n.scans, n.link.dropped(), n.link);
        }
    }
    Ok(if r.found { ExitCode::SUCCESS } else { ExitCode::from(1) })
}
