//! `lives replay FILE`: the arguments and the command.

use super::*;
use std::path::PathBuf;

/// `lives replay FILE` arguments.
#[derive(clap::Args, Debug)]
pub struct ReplayArgs {
    /// The log: a CARMEN log (plain or .gz), an MCAP or sqlite3 (.db3) ROS 2 bag (or either
    /// compressed with zstd), a ROS 1 bag, a VLP-16 capture, or a bag directory.
    pub file: PathBuf,
    /// Write a picture of the maps, labels, trajectory and goals here.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Print one JSON object instead of the summary line.
    #[arg(long)]
    pub json: bool,
    /// Do not run a classifier (no map / non-map labels).
    #[arg(long, conflicts_with = "model")]
    pub no_classifier: bool,
    /// The int8 classifier blob to run (docs/model-format.md, either format); without it the
    /// committed geometric classifier (`firmware/model/lives-geo-int8.bin`), as `lives search`.
    #[arg(long, value_name = "BLOB")]
    pub model: Option<PathBuf>,
    /// The controller's LiDAR range, metres: readings at or beyond it, and "no return" readings,
    /// clear cells up to it and mark nothing (default: 10 m for CARMEN logs, the usable range
    /// mappers give them; the core's 30 m for bags).
    #[arg(long, value_name = "METRES")]
    pub max_range: Option<f64>,
    /// Record every tick (pose, scan, labels, grids, frontiers, candidates, goals) to this MCAP
    /// file, which Foxglove opens (docs/recording.md).
    #[arg(long, value_name = "FILE.mcap")]
    pub record: Option<PathBuf>,
    /// Save the controller's LiDAR grid at the end as a map_server map, as `map_saver` saves a
    /// SLAM map: OUT.yaml and OUT.pgm beside it (occupied 0, free 254, unknown 205), in the
    /// log's frame, cropped to the known cells. `lives search --map` and `lives worlds
    /// --from-map` read it.
    #[arg(long, value_name = "OUT.yaml")]
    pub map_out: Option<PathBuf>,
    /// Override a controller parameter, e.g. `--set replan_interval_s=6` (repeatable;
    /// `lives params` lists them).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub set: Vec<String>,
}

/// Runs `lives replay`: exit status 0, 1 when the log is not clean (bad records were skipped, or
/// damage stopped reading: every good scan was replayed and is reported), `Err` (status 2) when
/// nothing could be replayed.
pub fn run_command(args: &ReplayArgs) -> Result<std::process::ExitCode, String> {
    use std::io::Write as _;
    let mut opts = options(args.model.as_deref(), args.no_classifier, &args.set, args.max_range)?;
    opts.record = args.record.clone();
    let run = replay(&args.file, &opts).map_err(|e| e.to_string())?;
    let r = &run.report;
    if let Some(path) = &args.png {
        let name = args.file.file_name().map_or_else(|| r.file.clone(), |n| n.to_string_lossy().into_owned());
        let title = format!(
            "replay {name}: {} scans, {:.0} s of log in {:.1} s, {} goals (dots: goals it would have sent), labels: {}",
            r.scans_used,
            r.duration_s,
            r.wall_s,
            r.goals.len(),
            r.labels
        );
        picture::write_png(&run, path, &title).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    if let Some(out) = &args.map_out {
        write_map(&run, out)?;
    }
    let mut stdout = std::io::stdout();
    if args.json {
        let text = serde_json::to_string_pretty(r).map_err(|e| e.to_string())?;
        let _ = writeln!(stdout, "{text}");
    } else {
        let _ = writeln!(stdout, "{}", summary_line(r));
        for w in &r.warnings {
            eprintln!("warning: {w}");
        }
    }
    let bad = &run.bad_records;
    for e in &bad.first {
        eprintln!("warning: {e} (skipped)");
    }
    if bad.total as usize > bad.first.len() {
        eprintln!("warning: … and {} more", bad_records_skipped(bad.total - bad.first.len() as u32));
    }
    let mut code = std::process::ExitCode::SUCCESS;
    if bad.total > 0 {
        let around = if bad.total == 1 { "it" } else { "them" };
        eprintln!("error: {}: {} ({}); the records around {around} were replayed", r.file, bad_records_skipped(bad.total), bad.reasons());
        code = std::process::ExitCode::from(1);
    }
    if let Some(e) = &run.error {
        eprintln!("error: {e} (reading stopped there; the {} scans before it were replayed)", r.scans_read);
        code = std::process::ExitCode::from(1);
    }
    Ok(code)
}

/// `--map-out`: the controller's LiDAR grid at the end as a map_server map.
fn write_map(run: &ReplayRun, out: &std::path::Path) -> Result<(), String> {
    use crate::io::map_file::{export, Cell3};
    use firmware::grid::Cell;
    let ctrl = &run.controller;
    let geom = ctrl.lidar.geom;
    let origin = [geom.origin_x.to_num::<f64>(), geom.origin_y.to_num::<f64>()];
    let res = 1.0 / firmware::capacity::CELLS_PER_METER as f64;
    let cell = |x: usize, y: usize| match ctrl.lidar.get(x as i32, y as i32) {
        Cell::Occupied => Cell3::Occupied,
        Cell::Free => Cell3::Free,
        Cell::Unknown => Cell3::Unknown,
    };
    let file = out.display().to_string();
    let map = export::from_grid(cell, firmware::capacity::GRID_CELLS, origin, res, &file)
        .ok_or_else(|| format!("{file}: the grid holds no known cell: no map to write"))?;
    let comment =
        format!("lives replay --map-out: the LiDAR grid after {} ({} scans), {res} m/cell", run.report.file, run.report.scans_used);
    export::write(&map, out, &comment)?;
    let n = map.counts();
    eprintln!(
        "wrote {file}: {} x {} cells at {res} m, origin ({:.2}, {:.2}); {} occupied, {} free, {} unknown",
        map.width, map.height, map.origin[0], map.origin[1], n.occupied, n.free, n.unknown
    );
    Ok(())
}
