//! Real sensors: decoders from a sensor's own wire format to the planar scans the controller takes.
//!
//! Owns the Velodyne VLP-16 (`vlp16`: data packets, scan assembly, captures, live UDP), the pcap
//! reading it needs (`pcap`) and the `lives lidar` command. Must not decide anything the robot
//! does or talk to the core: the bridge feeds [`vlp16::PlanarScan`]s onwards. See `docs/vlp16.md`.

pub mod pcap;
pub mod vlp16;

use std::io::Write as _;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};
use vlp16::{CaptureFormat, PcapScans, PlanarScan, Vlp16Config, ELEVATION_DEG};

/// `lives lidar …`: decode a VLP-16 capture or listen to a live one.
#[derive(clap::Subcommand, Debug)]
pub enum LidarCmd {
    /// Decode a VLP-16 capture (.pcap, or raw 1206-byte payloads back to back) into planar scans
    /// and summarise them.
    Decode {
        /// The capture.
        file: PathBuf,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        opts: ScanOpts,
    },
    /// Receive VLP-16 data packets on UDP and print one line per scan (rotation).
    Listen {
        /// Address to bind (a sensor broadcasts to port 2368: bind 0.0.0.0:2368 to hear it).
        #[arg(long, default_value = "127.0.0.1:2368")]
        bind: SocketAddr,
        /// Stop after this many scans (default: run until interrupted).
        #[arg(long)]
        scans: Option<u64>,
        /// Give up when no scan completes for this many seconds.
        #[arg(long, default_value_t = 5.0)]
        timeout_s: f64,
        #[command(flatten)]
        opts: ScanOpts,
    },
}

/// How packets become a scan.
#[derive(clap::Args, Debug)]
pub struct ScanOpts {
    /// Laser elevation band in degrees, inclusive (lasers at ±1, ±3, …, ±15°).
    #[arg(long, value_name = "MIN,MAX", default_value = "-1,1", allow_hyphen_values = true)]
    elevation: String,
    /// Beams over 360°.
    #[arg(long, default_value_t = firmware::capacity::BEAMS)]
    beams: usize,
    /// Drop returns nearer than this (metres, horizontal).
    #[arg(long, default_value_t = 0.3)]
    min_range_m: f64,
    /// Returns beyond this count as none (metres, horizontal).
    #[arg(long, default_value_t = 100.0)]
    max_range_m: f64,
}

impl ScanOpts {
    fn config(&self) -> Result<Vlp16Config, String> {
        let bad = || format!("--elevation `{}`: expected MIN,MAX in degrees, e.g. -1,1", self.elevation);
        let (lo, hi) = self.elevation.split_once(',').ok_or_else(bad)?;
        let lo: f64 = lo.trim().parse().map_err(|_| bad())?;
        let hi: f64 = hi.trim().parse().map_err(|_| bad())?;
        let cfg = Vlp16Config {
            elevation_min_deg: lo,
            elevation_max_deg: hi,
            beams: self.beams,
            min_range_m: self.min_range_m,
            max_range_m: self.max_range_m,
        };
        cfg.validate().map_err(|e| e.to_string())?;
        Ok(cfg)
    }
}

/// Ignores a closed stdout (`lives lidar decode … | head -1`).
macro_rules! out {
    ($($t:tt)*) => {{
        let _ = writeln!(std::io::stdout(), $($t)*);
    }};
}

/// Valid beams, beams without return, and the min / median of the valid ranges.
fn summary(s: &PlanarScan) -> (usize, usize, Option<f32>, Option<f32>) {
    let mut v: Vec<f32> = s.ranges_m.iter().copied().filter(|r| r.is_finite()).collect();
    v.sort_by(f32::total_cmp);
    (v.len(), s.no_return_beams(), v.first().copied(), v.get(v.len() / 2).copied())
}

fn scan_line(label: &str, s: &PlanarScan) -> String {
    let (valid, none, min, med) = summary(s);
    let m = |x: Option<f32>| x.map_or("-".to_string(), |x| format!("{x:.3}"));
    format!(
        "{label} stamp_us {:>13}  valid {valid:>3}/{}  no-return {none:>3}  min {} m  median {} m",
        s.stamp_us,
        s.ranges_m.len(),
        m(min),
        m(med)
    )
}

fn scan_json(s: &PlanarScan) -> serde_json::Value {
    let (valid, none, min, med) = summary(s);
    serde_json::json!({
        "stamp_us": s.stamp_us,
        "valid_beams": valid,
        "no_return_beams": none,
        "unseen_beams": s.unseen_beams(),
        "min_m": min,
        "median_m": med,
    })
}

fn lasers_deg(lasers: &[usize]) -> Vec<i8> {
    lasers.iter().map(|&c| ELEVATION_DEG[c]).collect()
}

/// At most this many rejected packets and skipped runs of bytes are named on stderr; the rest are
/// counted in one line.
const WARNINGS_SHOWN: usize = 5;

/// Why a capture in which no data packet could be decoded is refused (status 2): the error that
/// ended it, or what was found instead.
fn nothing_decoded(file: &Path, format: CaptureFormat, r: &PcapScans) -> String {
    if let Some(e) = &r.error {
        return format!("{e} (no VLP-16 data packet before it)");
    }
    let first = r.rejects.first().map(|x| format!(", the first at byte {}: {}", x.offset, x.reason)).unwrap_or_default();
    match format {
        CaptureFormat::Pcap => format!(
            "{}: no VLP-16 data packet among its {} pcap records ({} other traffic, {} rejected{first})",
            file.display(),
            r.counts.other + r.counts.rejected,
            r.counts.other,
            r.counts.rejected
        ),
        CaptureFormat::Raw => format!(
            "{}: no valid VLP-16 data packet: {} rejected{first}{}",
            file.display(),
            r.counts.rejected,
            skipped_bytes(r.skipped_bytes).map(|s| format!("; {s}")).unwrap_or_default()
        ),
    }
}

fn skipped_bytes(n: u64) -> Option<String> {
    (n > 0).then(|| format!("{n} byte{} skipped", if n == 1 { "" } else { "s" }))
}

fn packets(n: u64) -> String {
    format!("{n} packet{}", if n == 1 { "" } else { "s" })
}

/// The first [`WARNINGS_SHOWN`] rejected packets and skipped runs on stderr, in file order, and a
/// count of the rest.
fn warn_damage(r: &PcapScans) {
    // (offset, bytes skipped or `None` for a rejected packet, warning)
    let mut events: Vec<(u64, Option<u64>, String)> = r
        .rejects
        .iter()
        .map(|x| (x.offset, None, format!("byte {}: {} (packet rejected)", x.offset, x.reason)))
        .chain(r.skips.iter().map(|s| {
            (s.offset, Some(s.len), format!("byte {}: {} bytes skipped to the next packet (none starts in them)", s.offset, s.len))
        }))
        .collect();
    events.sort_by_key(|e| e.0);
    events.truncate(WARNINGS_SHOWN);
    for (_, _, w) in &events {
        eprintln!("warning: {w}");
    }
    let shown_rejects = events.iter().filter(|e| e.1.is_none()).count() as u64;
    let shown_bytes: u64 = events.iter().filter_map(|e| e.1).sum();
    let more: Vec<String> = [
        (r.counts.rejected > shown_rejects).then(|| {
            let n = r.counts.rejected - shown_rejects;
            format!("{n} more packet{} rejected", if n == 1 { "" } else { "s" })
        }),
        (r.skipped_bytes > shown_bytes).then(|| format!("{} more bytes skipped", r.skipped_bytes - shown_bytes)),
    ]
    .into_iter()
    .flatten()
    .collect();
    if !more.is_empty() {
        eprintln!("warning: … and {}", more.join(", "));
    }
}

/// Runs `lives lidar …`. Exit status 0; 1 when a capture was damaged (packets rejected, bytes
/// skipped or the read cut short: its good part is still reported) or `listen` timed out; `Err`
/// (status 2) when nothing could be read, or no data packet could be decoded.
pub fn run(cmd: LidarCmd) -> Result<ExitCode, String> {
    match cmd {
        LidarCmd::Decode { file, json, opts } => {
            let cfg = opts.config()?;
            // Scans are printed (or summarised) as they complete, never all kept.
            let mut lines = Vec::new();
            let mut n = 0usize;
            let (format, r) = vlp16::stream_capture(&file, &cfg, &mut |s| {
                if json {
                    lines.push(scan_json(&s));
                } else {
                    out!("{}", scan_line(&format!("scan {n:>4}"), &s));
                }
                n += 1;
            })
            .map_err(|e| e.to_string())?;
            if r.counts.data == 0 {
                return Err(nothing_decoded(&file, format, &r));
            }
            let format = match format {
                CaptureFormat::Pcap => "pcap",
                CaptureFormat::Raw => "raw",
            };
            if json {
                let v = serde_json::json!({
                    "file": file.display().to_string(),
                    "format": format,
                    "lasers_deg": lasers_deg(&r.lasers),
                    "beams": cfg.beams,
                    "packets": { "data": r.counts.data, "rejected": r.counts.rejected, "other": r.counts.other },
                    "rejects": r.rejects.iter().map(|x| serde_json::json!({"offset": x.offset, "reason": x.reason.to_string()})).collect::<Vec<_>>(),
                    "skipped_bytes": r.skipped_bytes,
                    "skips": r.skips.iter().map(|s| serde_json::json!({"offset": s.offset, "bytes": s.len})).collect::<Vec<_>>(),
                    "scans": lines,
                    "partial": r.partial.as_ref().map(scan_json),
                    "error": r.error.as_ref().map(|e| e.to_string()),
                });
                out!("{v}");
            } else {
                if let Some(s) = &r.partial {
                    out!("{}", scan_line("partial  ", s));
                }
                out!(
                    "{} ({format}): {} data packets, {} rejected, {} other{}; scans: {n}{}; lasers {:?}°, {} beams",
                    file.display(),
                    r.counts.data,
                    r.counts.rejected,
                    r.counts.other,
                    skipped_bytes(r.skipped_bytes).map(|s| format!(", {s}")).unwrap_or_default(),
                    if r.partial.is_some() { " + 1 partial" } else { "" },
                    lasers_deg(&r.lasers),
                    cfg.beams
                );
            }
            warn_damage(&r);
            let mut code = ExitCode::SUCCESS;
            if r.counts.rejected > 0 || r.skipped_bytes > 0 {
                let damage =
                    [(r.counts.rejected > 0).then(|| format!("{} rejected", packets(r.counts.rejected))), skipped_bytes(r.skipped_bytes)];
                let damage: Vec<String> = damage.into_iter().flatten().collect();
                let around = if r.counts.rejected + r.skips.len() as u64 == 1 { "it" } else { "them" };
                eprintln!("error: {}: {}; the {} around {around} were decoded", file.display(), damage.join(", "), packets(r.counts.data));
                code = ExitCode::from(1);
            }
            if let Some(e) = &r.error {
                eprintln!("error: {e} (the {n} scans before it are above)");
                code = ExitCode::from(1);
            }
            Ok(code)
        }
        LidarCmd::Listen { bind, scans, timeout_s, opts } => {
            let cfg = opts.config()?;
            let mut udp = vlp16::Vlp16Udp::bind(bind, cfg).map_err(|e| format!("binding {bind}: {e}"))?;
            let addr = udp.local_addr().map_err(|e| e.to_string())?;
            eprintln!("listening on {addr} (VLP-16 data packets)");
            let timeout = Duration::try_from_secs_f64(timeout_s).map_err(|_| format!("--timeout-s {timeout_s}: not a duration"))?;
            let mut n = 0u64;
            let t0 = Instant::now();
            while scans.is_none_or(|max| n < max) {
                match udp.recv_scan(timeout).map_err(|e| e.to_string())? {
                    Some(s) => {
                        out!("{}", scan_line(&format!("scan {n:>5}"), &s));
                        n += 1;
                    }
                    None => {
                        let c = udp.counts();
                        eprintln!(
                            "no scan within {timeout_s} s ({} data packets, {} rejected so far{})",
                            c.data,
                            c.rejected,
                            udp.rejects().last().map(|r| format!("; last rejected: {}", r.reason)).unwrap_or_default()
                        );
                        return Ok(ExitCode::from(1));
                    }
                }
            }
            let c = udp.counts();
            eprintln!("{n} scans, {} data packets, {} rejected in {:.2} s", c.data, c.rejected, t0.elapsed().as_secs_f64());
            Ok(ExitCode::SUCCESS)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(subcommand)]
        cmd: LidarCmd,
    }

    fn parse(args: &[&str]) -> Result<LidarCmd, clap::Error> {
        Cli::try_parse_from(std::iter::once("lidar").chain(args.iter().copied())).map(|c| c.cmd)
    }

    #[test]
    fn elevation_band_from_the_command_line() {
        // A negative first bound parses as a value, not as a flag.
        let LidarCmd::Decode { opts, .. } = parse(&["decode", "f.pcap", "--elevation", "-3,3"]).unwrap() else { panic!() };
        let cfg = opts.config().unwrap();
        assert_eq!((cfg.elevation_min_deg, cfg.elevation_max_deg), (-3.0, 3.0));
        assert_eq!(cfg.lasers().iter().map(|&c| ELEVATION_DEG[c]).collect::<Vec<_>>(), vec![1, 3, -3, -1]);
        // Defaults: the two near-horizontal lasers on 897 beams.
        let LidarCmd::Decode { opts, .. } = parse(&["decode", "f.pcap"]).unwrap() else { panic!() };
        assert_eq!(opts.config().unwrap(), Vlp16Config::default());
        let LidarCmd::Listen { bind, .. } = parse(&["listen"]).unwrap() else { panic!() };
        assert_eq!(bind, "127.0.0.1:2368".parse::<SocketAddr>().unwrap());
        // Malformed bands and bands without a laser are clear errors.
        let LidarCmd::Decode { opts, .. } = parse(&["decode", "f", "--elevation", "3"]).unwrap() else { panic!() };
        assert_eq!(opts.config().unwrap_err(), "--elevation `3`: expected MIN,MAX in degrees, e.g. -1,1");
        let LidarCmd::Decode { opts, .. } = parse(&["decode", "f", "--elevation=2,2.5"]).unwrap() else { panic!() };
        assert!(opts.config().unwrap_err().starts_with("no VLP-16 laser lies in the elevation band 2..2.5°"));
    }
}
