//! `lives node`: the controller core as a process on a serial device.

use super::common::{open_serial, say};
use host::link::{run_node, NodeOptions, TimeMode};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

/// The controller core as a process on a serial device (the deployment on the onboard
/// computer, or a workstation for testing): sensor frames in, goals out.
#[derive(clap::Args)]
pub struct NodeArgs {
    /// Serial device (/dev/ttyUSB0, /dev/ttyACM0, a pseudo-terminal); waited for if absent.
    #[arg(long)]
    port: PathBuf,
    /// Baud rate (a real UART only; USB CDC and ptys ignore it).
    #[arg(long, default_value_t = 921_600)]
    baud: u32,
    /// Tick when the host's batch for time t is complete, at t (simulation, tests) instead of
    /// every 200 ms on this process's clock.
    #[arg(long)]
    lockstep: bool,
    /// Stop after this many seconds and print the node's counters as JSON (default: run
    /// until killed).
    #[arg(long)]
    seconds: Option<f64>,
    /// The int8 classifier the node runs on scans that arrive without labels (the robot's;
    /// docs/model-format.md, either format). Default: the committed geometric classifier, as
    /// `lives search --planner lives` and the Cortex-M images run.
    #[arg(long, value_name = "BLOB")]
    model: Option<PathBuf>,
    /// Run no classifier: scans without labels then give `lives` no non-map points (it
    /// behaves as `multisensor`).
    #[arg(long, conflicts_with = "model")]
    no_model: bool,
}

pub fn run(args: NodeArgs) -> Result<ExitCode, String> {
    let NodeArgs { port, baud, lockstep, seconds, model, no_model } = args;
    let blob = host::io::model_file::model_option(model.as_deref(), no_model)?;
    let classifier = match (&model, blob) {
        (Some(p), _) => p.display().to_string(),
        (None, Some(_)) => "geometric (embedded)".to_string(),
        (None, None) => "none".to_string(),
    };
    let mode = if lockstep { TimeMode::Lockstep } else { TimeMode::RealTime };
    let mut link = open_serial(&port, baud);
    let stop = AtomicBool::new(false);
    let report = std::thread::scope(|s| {
        if let Some(secs) = seconds {
            let stop = &stop;
            s.spawn(move || {
                std::thread::sleep(std::time::Duration::from_secs_f64(secs.max(0.0)));
                stop.store(true, Ordering::Relaxed);
            });
        }
        run_node(&mut link, firmware::Config::DEFAULT, NodeOptions { model: blob, ..NodeOptions::new(mode) }, &stop)
    })
    .map_err(|e| format!("the classifier model: {e}"))?;
    let c = &report.counters;
    say!(
        "{}",
        serde_json::json!({
            "mode": format!("{:?}", report.mode),
            "classifier": classifier,
            "ticks": c.ticks,
            "frames_in": report.link.frames_ok,
            "rejected": report.link.dropped(),
            "link": report.link,
            "frames_sent": c.frames_sent,
            "bytes_sent": c.bytes_sent,
            "bytes_received": c.bytes_received,
            "goals_sent": c.goals_sent,
            "configs_applied": c.configs_applied,
            "configs_invalid": c.configs_invalid,
            "resets": c.resets,
            "config_error": report.config_error.map(|e| e.to_string()),
            "lockstep_incomplete": c.lockstep_incomplete,
            "lockstep_repeats": c.lockstep_repeats,
            "tick_us": report.tick_us,
            "overruns": report.overruns,
            "io_errors": report.io_errors,
            "reconnects": report.reconnects,
            "wall_s": report.wall_s,
        })
    );
    Ok(ExitCode::SUCCESS)
}
