//! `lives trace`: golden traces of the serial link, recorded from a simulated search or replayed
//! through the core.

use super::common::{load_spec, say, RunArgs};
use clap::Subcommand;
use std::path::PathBuf;
use std::process::ExitCode;

/// Golden traces of the serial link: record the host → core stream of a simulated search,
/// or replay one through the core and print a digest of every answer (docs/mcu.md).
#[derive(Subcommand)]
pub enum TraceCmd {
    /// Record the first --ticks lockstep batches of a simulated search (bridge ↔ node in memory).
    Record {
        #[command(flatten)]
        run: RunArgs,
        /// Where to write the trace.
        #[arg(long)]
        out: PathBuf,
        /// Ticks (lockstep batches) to record.
        #[arg(long, default_value_t = 150)]
        ticks: u32,
        /// Send the simulator's labels with the scans instead of running the core's classifier
        /// (embedded model) on them.
        #[arg(long)]
        labels: bool,
    },
    /// Replay a trace through a fresh lockstep node and print `R record t_us ticks len crc32` per
    /// record. A damaged trace replays as far as its records are good, then the error goes to
    /// stderr: exit status 1 (2 when no record is good).
    Replay {
        /// The trace file.
        file: PathBuf,
        /// Also print every message of the trace and of the node's answers.
        #[arg(long)]
        decode: bool,
    },
}

pub fn run(cmd: TraceCmd) -> Result<ExitCode, String> {
    match cmd {
        TraceCmd::Record { run, out, ticks, labels } => {
            let mut spec = load_spec(&run)?;
            if !labels {
                spec.model = Some(firmware::classifier::EMBEDDED_MODEL);
            }
            let bytes = host::measure::trace::record(spec, ticks)?;
            std::fs::write(&out, &bytes).map_err(|e| format!("{}: {e}", out.display()))?;
            say!("{}: {} bytes, {} ticks", out.display(), bytes.len(), ticks);
            Ok(ExitCode::SUCCESS)
        }
        TraceCmd::Replay { file, decode } => {
            let bytes = std::fs::read(&file).map_err(|e| format!("{}: {e}", file.display()))?;
            // A damaged trace: its good records are printed, then the error (status 1; 2 when
            // not even the first record is good).
            let (printed, error) = if decode {
                let r = host::measure::trace::decode(&bytes).map_err(|e| format!("{}: {e}", file.display()))?;
                for line in &r.records {
                    say!("{line}");
                }
                (!r.records.is_empty(), r.error)
            } else {
                let r = host::measure::trace::replay(&bytes).map_err(|e| format!("{}: {e}", file.display()))?;
                for d in &r.records {
                    say!("{}", host::measure::trace::digest_line(d));
                }
                (!r.records.is_empty(), r.error)
            };
            match error {
                Some(e) if printed => {
                    eprintln!("error: {}: {e}", file.display());
                    Ok(ExitCode::from(1))
                }
                Some(e) => Err(format!("{}: {e}", file.display())),
                None => Ok(ExitCode::SUCCESS),
            }
        }
    }
}
