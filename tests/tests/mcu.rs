//! The controller on a Cortex-M under QEMU (`mps2-an386`, docs/mcu.md): the golden trace gives the
//! same digests as the host tick by tick, every stage stays within its budget in guest
//! instructions (`firmware/mcu-budgets.toml`) with identical counts on two runs, the images fit
//! `memory.x`, a panic or a hard fault reports and stops the robot, the SMLAD inner product is
//! bit-exact and fast, the real-time image ticks on SysTick, and the emulated MCU finds the target
//! over its UART (a PTY) with `lives bridge`'s code on the host side, deciding as the host does.
//!
//! These tests need `qemu-system-arm` and the MCU images, so they are `#[ignore]`d in a plain
//! `cargo test`; `scripts/test.sh` builds the images and runs them with `--ignored`:
//!
//! ```sh
//! cargo build --profile mcu --target thumbv7em-none-eabihf -p firmware --features mcu --bins
//! cargo test --release -p lives-tests --test mcu -- --ignored
//! ```
//!
//! The images are looked for in `$LIVES_MCU_DIR`, else `$CARGO_TARGET_DIR` (or `target/`)
//! `/thumbv7em-none-eabihf/mcu/`. Missing QEMU or images fail the tests with what to do.

mod common;
use firmware::mcu::trace::{Digest, Trace};
use firmware::node::{Node, NodeConfig, TimeMode};
use firmware::protocol::{CoreToHost, HostDecoder, WireMode};
use firmware::{Config, Controller};
use host::link::{mem_pair, run_bridge, BridgeOptions, NodeOptions, NodeProcess, SerialLink, Source};
use host::search::{PlannerChoice, SearchSpec};
use host::sim::{Scenario, World};
use object::{Object, ObjectSection};
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::AtomicBool;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

const WORKSPACE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
const TRACE_FIXTURE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/golden.trace");
const LIVE_FIXTURE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/golden-live.trace");
const BUDGETS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../firmware/mcu-budgets.toml");
/// Ticks in the fixture (`lives trace record --ticks 150`).
const TRACE_TICKS: u32 = 150;
/// Ticks in the known-map fixture (`--ticks 100`; its image is `mcu-trace-live`).
const LIVE_TRACE_TICKS: u32 = 100;
/// Guest instructions per SysTick count under `-icount shift=0` (25 MHz, 1 ns per instruction).
const INSTRUCTIONS_PER_COUNT: u64 = 40;
/// The stages `mcu-trace` times, in its column order.
const STAGES: [&str; 7] = ["classify", "lidar", "visual", "nonmap", "plan", "gaze", "match"];
/// Stages every tick of the golden trace must have run at least once (the issue's five).
const REQUIRED_STAGES: [&str; 5] = ["classify", "lidar", "visual", "nonmap", "plan"];
const RERECORD: &str =
    "re-record the fixture: lives trace record --world examples/worlds/apartment-easy-hallway-start.toml --seed 2 --ticks 150 --out tests/fixtures/golden.trace";
const RERECORD_LIVE: &str =
    "re-record the fixture: lives map export apartment --scenario hard /tmp/apartment.yaml && lives trace record --world apartment \
     --scenario hard --seed 2 --planner live --map /tmp/apartment.yaml --ticks 100 --out tests/fixtures/golden-live.trace";

fn image_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("LIVES_MCU_DIR") {
        return PathBuf::from(d);
    }
    let target = std::env::var_os("CARGO_TARGET_DIR").map(PathBuf::from).unwrap_or_else(|| Path::new(WORKSPACE).join("target"));
    target.join("thumbv7em-none-eabihf/mcu")
}

fn image(name: &str) -> PathBuf {
    let p = image_dir().join(name);
    assert!(
        p.is_file(),
        "{} is missing: build the MCU images with `cargo build --profile mcu --target thumbv7em-none-eabihf -p firmware --features mcu --bins` \
         (or set LIVES_MCU_DIR)",
        p.display()
    );
    p
}

fn qemu(kernel: &Path, icount: bool, serial: &str, args: &[&str]) -> Command {
    let mut c = Command::new("qemu-system-arm");
    c.args(["-cpu", "cortex-m4", "-machine", "mps2-an386", "-nographic", "-monitor", "none", "-serial", serial]);
    let mut semi = "enable=on,target=native".to_string();
    for a in args {
        semi.push_str(",arg=");
        semi.push_str(a);
    }
    c.args(["-semihosting-config", &semi]);
    if icount {
        c.args(["-icount", "shift=0"]);
    }
    c.arg("-kernel").arg(kernel);
    c.stdin(Stdio::null()).stdout(Stdio::piped()).stderr(Stdio::piped());
    c
}

fn spawn(mut c: Command) -> Child {
    c.spawn().unwrap_or_else(|e| panic!("cannot run qemu-system-arm ({e}): install it (apt-get install -y qemu-system-arm)"))
}

/// Runs to the end (killed after `limit`): exit code, stdout, stderr.
fn run_qemu(c: Command, limit: Duration) -> (Option<i32>, String, String) {
    let mut child = spawn(c);
    let mut out = child.stdout.take().expect("stdout");
    let mut err = child.stderr.take().expect("stderr");
    let t_out = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = out.read_to_string(&mut s);
        s
    });
    let t_err = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err.read_to_string(&mut s);
        s
    });
    let t0 = Instant::now();
    let status = loop {
        if let Some(st) = child.try_wait().expect("wait for qemu") {
            break Some(st);
        }
        if t0.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let (o, e) = (t_out.join().unwrap_or_default(), t_err.join().unwrap_or_default());
    assert!(status.is_some(), "QEMU did not finish within {limit:?}; output:\n{o}\n{e}");
    (status.and_then(|s| s.code()), o, e)
}

/// One `R` line of `mcu-trace` (or `L` line of `mcu-trace-live`): the digest, the record's SysTick
/// counts, the stages' counts.
#[derive(Clone, Debug, PartialEq, Eq)]
struct McuRecord {
    digest: Digest,
    total: u64,
    stages: [u64; STAGES.len()],
}

#[derive(Debug, PartialEq, Eq)]
struct McuTrace {
    records: Vec<McuRecord>,
    ticks: u32,
    stack_max: u64,
    /// The known-map trace's records (`L` lines) and ticks.
    live: Vec<McuRecord>,
    live_ticks: u32,
}

fn parse_trace_output(out: &str) -> McuTrace {
    let (mut records, mut live) = (Vec::new(), Vec::new());
    let (mut ticks, mut stack_max, mut live_ticks) = (None, None::<u64>, None);
    for line in out.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        match f.first() {
            Some(&tag @ ("R" | "L")) => {
                assert_eq!(f.len(), 7 + STAGES.len(), "bad line from mcu-trace: {line}");
                let n = |i: usize| f[i].parse::<u64>().unwrap_or_else(|_| panic!("bad number in: {line}"));
                let mut stages = [0; STAGES.len()];
                for (k, s) in stages.iter_mut().enumerate() {
                    *s = n(7 + k);
                }
                let into = if tag == "R" { &mut records } else { &mut live };
                into.push(McuRecord {
                    digest: Digest {
                        record: n(1) as u32,
                        t_us: n(2),
                        ticks: n(3) as u32,
                        len: n(4) as u32,
                        crc: u32::from_str_radix(f[5], 16).unwrap_or_else(|_| panic!("bad crc in: {line}")),
                    },
                    total: n(6),
                    stages,
                });
            }
            Some(&"DONE") => {
                let n = f.get(2).and_then(|s| s.strip_prefix("ticks=")).and_then(|s| s.parse().ok());
                match f.get(1) {
                    Some(&"R") => ticks = n,
                    Some(&"L") => live_ticks = n,
                    _ => panic!("bad line from a trace image: {line}"),
                }
            }
            Some(&"STACK") => {
                let m = f.get(2).and_then(|s| s.strip_prefix("max=")).and_then(|s| s.parse().ok());
                stack_max = stack_max.max(m);
            }
            _ => {}
        }
    }
    McuTrace {
        records,
        ticks: ticks.unwrap_or_else(|| panic!("mcu-trace did not finish:\n{out}")),
        stack_max: stack_max.unwrap_or_else(|| panic!("mcu-trace printed no stack figure:\n{out}")),
        live,
        live_ticks: live_ticks.unwrap_or_else(|| panic!("mcu-trace-live did not finish:\n{out}")),
    }
}

/// The golden trace (`mcu-trace`) and the known-map trace (`mcu-trace-live`) on the MCU, each
/// twice (two at a time), under `-icount shift=0`; shared by the tests.
fn mcu_runs() -> &'static (McuTrace, McuTrace) {
    static RUNS: OnceLock<(McuTrace, McuTrace)> = OnceLock::new();
    RUNS.get_or_init(|| {
        let run = |name: &'static str| {
            let img = image(name);
            std::thread::spawn(move || {
                let (code, out, err) = run_qemu(qemu(&img, true, "null", &[]), Duration::from_secs(600));
                assert_eq!(code, Some(0), "{name} failed:\n{out}\n{err}");
                out
            })
        };
        let mut outs = Vec::new();
        for name in ["mcu-trace", "mcu-trace-live"] {
            let (a, b) = (run(name), run(name));
            outs.push((a.join().expect("first QEMU run"), b.join().expect("second QEMU run")));
        }
        let ((r1, r2), (l1, l2)) = (&outs[0], &outs[1]);
        (parse_trace_output(&format!("{r1}{l1}")), parse_trace_output(&format!("{r2}{l2}")))
    })
}

/// Both fixtures replayed on the host as `mcu-trace` and `mcu-trace-live` replay them: each on a
/// new controller (the default configuration, no model until the trace asks for one) and a new
/// node. Digests and ticks of each.
fn host_digests() -> &'static [(Vec<Digest>, u32); 2] {
    static HOST: OnceLock<[(Vec<Digest>, u32); 2]> = OnceLock::new();
    HOST.get_or_init(|| {
        [(TRACE_FIXTURE, RERECORD), (LIVE_FIXTURE, RERECORD_LIVE)].map(|(file, rerecord)| {
            let mut ctl = Box::new(Controller::new(Config::DEFAULT));
            let bytes = std::fs::read(file).unwrap_or_else(|e| panic!("{file}: {e}"));
            let t = Trace::parse(&bytes).unwrap_or_else(|e| panic!("the fixture {file}: {e}; {rerecord}"));
            let mut node = Box::new(Node::new(NodeConfig::new(TimeMode::Lockstep)));
            let mut out = Vec::new();
            let ticks = t.replay(&mut node, &mut ctl, |d| out.push(*d)).unwrap_or_else(|e| panic!("host replay of {file}: {e}"));
            (out, ticks)
        })
    })
}

#[test]
#[ignore = "needs qemu-system-arm and the MCU images (scripts/test.sh)"]
fn golden_trace_digests_are_identical_on_host_and_mcu_for_every_tick() {
    let (host, host_ticks) = &host_digests()[0];
    let host_ticks = *host_ticks;
    assert_eq!(host_ticks, TRACE_TICKS, "the host replay ran {host_ticks} ticks, not {TRACE_TICKS} (the protocol changed?); {RERECORD}");
    let mcu = &mcu_runs().0;
    assert_eq!(mcu.ticks, host_ticks);
    assert_eq!(mcu.records.len(), host.len(), "records replayed");
    for (h, m) in host.iter().zip(&mcu.records) {
        assert_eq!(*h, m.digest, "record {} (t = {} µs): the MCU's answer differs from the host's", h.record, h.t_us);
    }
    // Digests that change from tick to tick: a digest blind to the content would fail here.
    let ticked: Vec<u32> = host.iter().filter(|d| d.ticks == 1).map(|d| d.crc).collect();
    let distinct: std::collections::HashSet<_> = ticked.iter().collect();
    assert_eq!(distinct.len(), ticked.len(), "every tick's answer is different (time is in it)");
}

/// LIVE (issue 32): a search of a known building — the map rows and the route over the link,
/// the known-map classification, the seeded LiDAR grid, the search map (its entropy is in every
/// `Status`) and the waypoint manager — answers the same on the MCU as on the host, tick by tick.
#[test]
#[ignore = "needs qemu-system-arm and the MCU images (scripts/test.sh)"]
fn known_map_trace_digests_are_identical_on_host_and_mcu_for_every_tick() {
    let (host, host_ticks) = &host_digests()[1];
    assert_eq!(*host_ticks, LIVE_TRACE_TICKS, "the host replay ran {host_ticks} ticks; {RERECORD_LIVE}");
    let mcu = &mcu_runs().0;
    assert_eq!(mcu.live_ticks, *host_ticks);
    assert_eq!(mcu.live.len(), host.len(), "records replayed");
    for (h, m) in host.iter().zip(&mcu.live) {
        assert_eq!(*h, m.digest, "known-map record {} (t = {} µs): the MCU's answer differs from the host's", h.record, h.t_us);
    }
    // The search map works on both: its entropy falls over the trace (it is in the digests).
    let bytes = std::fs::read(LIVE_FIXTURE).unwrap();
    let t = Trace::parse(&bytes).unwrap();
    let mut ctl = Box::new(Controller::new(Config::DEFAULT));
    let mut node = Box::new(Node::new(NodeConfig::new(TimeMode::Lockstep)));
    t.replay(&mut node, &mut ctl, |_| {}).unwrap();
    assert!(ctl.search.cells() > 10_000, "the prior's free space was counted: {}", ctl.search.cells());
    assert!(ctl.search.entropy_bits() < ctl.search.cells(), "the camera lowered the entropy");
    let ltf = ctl.known.counts[0];
    assert!(ltf > 1000, "the known-map classifier labelled LTFs: {:?}", ctl.known.counts);
    let mcu_stages = stage_table_of(&mcu.live);
    println!("known-map trace, per stage (ticks, median, worst instructions): {mcu_stages:?}");
}

/// Per stage: median and worst case over the ticks that ran it, in guest instructions.
fn stage_table(t: &McuTrace) -> Vec<(&'static str, usize, u64, u64)> {
    stage_table_of(&t.records)
}

/// [`stage_table`] of any records.
fn stage_table_of(records: &[McuRecord]) -> Vec<(&'static str, usize, u64, u64)> {
    STAGES
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let mut v: Vec<u64> =
                records.iter().filter(|r| r.digest.ticks > 0 && r.stages[k] > 0).map(|r| r.stages[k] * INSTRUCTIONS_PER_COUNT).collect();
            v.sort_unstable();
            let median = v.get(v.len().saturating_sub(1) / 2).copied().unwrap_or(0);
            (*name, v.len(), median, v.last().copied().unwrap_or(0))
        })
        .collect()
}

#[test]
#[ignore = "needs qemu-system-arm and the MCU images (scripts/test.sh)"]
fn every_stage_stays_within_its_budget_and_two_runs_count_the_same() {
    let (a, b) = mcu_runs();
    // Determinism: every record's counts, not just the summaries.
    assert_eq!(a.records.len(), b.records.len());
    for (x, y) in a.records.iter().zip(&b.records) {
        assert_eq!(x, y, "two QEMU runs counted differently at record {}", x.digest.record);
    }
    let budgets: toml::Table = std::fs::read_to_string(BUDGETS).expect("firmware/mcu-budgets.toml").parse().expect("valid TOML");
    let stages = budgets.get("stages").and_then(|s| s.as_table()).expect("a [stages] table in firmware/mcu-budgets.toml");
    println!("| stage | ticks | median (instructions) | worst (instructions) | budget median | budget worst |");
    println!("|---|---|---|---|---|---|");
    let mut over = Vec::new();
    for (name, n, median, worst) in stage_table(a) {
        let b =
            stages.get(name).and_then(|t| t.as_table()).unwrap_or_else(|| panic!("no budget for `{name}` in firmware/mcu-budgets.toml"));
        let get = |k: &str| b.get(k).and_then(|v| v.as_integer()).unwrap_or_else(|| panic!("`{name}.{k}` missing in the budgets")) as u64;
        let (bm, bw) = (get("median"), get("worst"));
        println!("| {name} | {n} | {median} | {worst} | {bm} | {bw} |");
        if REQUIRED_STAGES.contains(&name) {
            assert!(n > 0, "stage `{name}` never ran in the golden trace");
        }
        if median > bm {
            over.push(format!("{name}: median {median} > budget {bm}"));
        }
        if worst > bw {
            over.push(format!("{name}: worst {worst} > budget {bw}"));
        }
    }
    println!("stack high-water mark: {} bytes", a.stack_max);
    assert!(over.is_empty(), "stages over budget (firmware/mcu-budgets.toml): {over:?}");
}

/// Real time (issue 28): a planning step is spread over ticks, so no tick of the golden trace
/// takes more than twice the median tick, in guest instructions (the whole tick: every stage and
/// the node around them, the record's SysTick count).
#[test]
#[ignore = "needs qemu-system-arm and the MCU images (scripts/test.sh)"]
fn no_tick_takes_more_than_twice_the_median_tick() {
    let (a, _) = mcu_runs();
    let mut totals: Vec<u64> = a.records.iter().filter(|r| r.digest.ticks > 0).map(|r| r.total * INSTRUCTIONS_PER_COUNT).collect();
    assert!(totals.len() > 100, "{} ticks", totals.len());
    totals.sort_unstable();
    let median = totals[(totals.len() - 1) / 2];
    let worst = *totals.last().unwrap();
    println!("ticks: {}, median {median} instructions, worst {worst} ({:.2}× the median)", totals.len(), worst as f64 / median as f64);
    assert!(worst <= 2 * median, "the worst tick takes {worst} instructions, more than twice the median {median}");
}

/// Sizes of an image's sections (bytes) and the regions of `memory.x`.
struct Footprint {
    ram: u64,
    flash: u64,
    data: u64,
}

fn footprint(elf: &Path) -> Footprint {
    let bytes = std::fs::read(elf).unwrap_or_else(|e| panic!("{}: {e}", elf.display()));
    let f = object::File::parse(&*bytes).unwrap_or_else(|e| panic!("{}: not an ELF: {e}", elf.display()));
    let size = |n: &str| f.section_by_name(n).map_or(0, |s| s.size());
    let data = size(".data");
    Footprint {
        ram: data + size(".bss") + size(".uninit"),
        // `.data`'s initial image is stored in flash too.
        flash: size(".vector_table") + size(".text") + size(".rodata") + data,
        data,
    }
}

/// `LENGTH` of a region of `memory.x` (bytes).
fn region_length(memory_x: &str, region: &str) -> u64 {
    let line = memory_x
        .lines()
        .find(|l| l.trim_start().starts_with(region) && l.contains("LENGTH"))
        .unwrap_or_else(|| panic!("memory.x has no {region} region"));
    let v = line.split("LENGTH").nth(1).and_then(|s| s.split('=').nth(1)).map(|s| s.trim().trim_end_matches(',')).expect("LENGTH = value");
    let (num, mult) = match v.chars().last() {
        Some('K') => (&v[..v.len() - 1], 1024),
        Some('M') => (&v[..v.len() - 1], 1024 * 1024),
        _ => (v, 1),
    };
    let n = match num.strip_prefix("0x") {
        Some(h) => u64::from_str_radix(h, 16),
        None => num.parse(),
    };
    n.unwrap_or_else(|_| panic!("memory.x: bad LENGTH `{v}`")) * mult
}

#[test]
#[ignore = "needs the MCU images (scripts/test.sh)"]
fn the_images_fit_memory_x_with_room_for_the_stack() {
    let mem = std::fs::read_to_string(Path::new(WORKSPACE).join("memory.x")).expect("memory.x");
    let (ram_len, flash_len) = (region_length(&mem, "RAM"), region_length(&mem, "FLASH"));
    println!("| image | static RAM (.data + .bss) | flash (.text + .rodata + .data image) |");
    println!("|---|---|---|");
    for name in ["mcu-node", "mcu-lockstep", "mcu-trace", "mcu-trace-live", "mcu-selftest"] {
        let f = footprint(&image(name));
        println!(
            "| {name} | {} B ({:.1} % of {} KiB) | {} B ({:.1} % of {} KiB) |",
            f.ram,
            100.0 * f.ram as f64 / ram_len as f64,
            ram_len / 1024,
            f.flash,
            100.0 * f.flash as f64 / flash_len as f64,
            flash_len / 1024
        );
        assert!(f.flash <= flash_len, "{name}: flash {} > {flash_len}", f.flash);
        assert!(f.ram <= ram_len, "{name}: RAM {} > {ram_len}", f.ram);
        if name != "mcu-selftest" {
            // The controller is in `.data`, built at compile time (not on the stack).
            assert!(f.data >= std::mem::size_of::<Controller>() as u64 / 2, "{name}: the controller is not in .data");
        }
    }
    // The stack the traces needed (the deeper of the two), on top of the statics of the larger image.
    let trace = footprint(&image("mcu-trace")).ram.max(footprint(&image("mcu-trace-live")).ram);
    let stack = mcu_runs().0.stack_max;
    println!("trace images: stack high-water mark {stack} B; statics + stack {} B of {ram_len}", trace + stack);
    assert!(stack < 64 * 1024, "the stack grew to {stack} bytes: something large is built on the stack");
    assert!(trace + stack <= ram_len);
}

/// Decodes what the MCU sent on its UART.
fn uart_messages(path: &Path) -> Vec<CoreToHost> {
    let bytes = std::fs::read(path).unwrap_or_default();
    HostDecoder::new().feed(&bytes).map(|m| m.expect("valid frames on the UART")).collect()
}

#[test]
#[ignore = "needs qemu-system-arm and the MCU images (scripts/test.sh)"]
fn a_panic_or_a_hard_fault_reports_and_stops_the_robot() {
    let img = image("mcu-selftest");
    let dir = std::env::temp_dir().join(format!("lives-mcu-selftest-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let (code, out, err) = run_qemu(qemu(&img, false, &format!("file:{}", dir.join("ok.bin").display()), &["ok"]), Duration::from_secs(60));
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(uart_messages(&dir.join("ok.bin")).is_empty(), "no fault, no Stop");
    for (mode, expect) in [("panic", "a deliberate panic"), ("overflow", "attempt to add with overflow"), ("hardfault", "HardFault at pc=")]
    {
        let uart = dir.join(format!("{mode}.bin"));
        let (code, out, err) = run_qemu(qemu(&img, false, &format!("file:{}", uart.display()), &[mode]), Duration::from_secs(60));
        assert_eq!(code, Some(1), "{mode}: QEMU must exit with failure\n{out}{err}");
        assert!(out.contains("LIVES FAULT") && out.contains(expect), "{mode}: the report is missing:\n{out}{err}");
        let msgs = uart_messages(&uart);
        assert!(
            msgs.iter().any(|m| matches!(m, CoreToHost::Stop(s) if s.mode == WireMode::Stopped)),
            "{mode}: no Stop frame on the UART: {msgs:?}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
#[ignore = "needs qemu-system-arm and the MCU images (scripts/test.sh)"]
fn the_smlad_inner_product_is_bit_exact_and_needs_at_most_1_6_instructions_per_mac() {
    let (code, out, err) = run_qemu(qemu(&image("mcu-selftest"), true, "null", &["dot"]), Duration::from_secs(120));
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(out.contains("DOT ok cases=3003"), "{out}");
    let line = out.lines().find(|l| l.starts_with("DOTBENCH")).unwrap_or_else(|| panic!("no DOTBENCH line:\n{out}"));
    let field = |k: &str| -> f64 {
        line.split_whitespace().find_map(|f| f.strip_prefix(k)).and_then(|v| v.parse().ok()).unwrap_or_else(|| panic!("{k} in {line}"))
    };
    let (macs, dsp, reference) = (field("macs="), field("dsp_instructions="), field("reference_instructions="));
    println!("897 x 897 int8 product: SMLAD {:.2} instructions per MAC, portable {:.2}", dsp / macs, reference / macs);
    // The issue asks for ~1.5 (CMSIS-NN); the loop itself is 1.5, row set-up and the tail add the rest.
    assert!(dsp / macs <= 1.6, "{line}");
    assert!(reference / dsp >= 2.5, "the SMLAD path is not much faster: {line}");
}

/// Kills QEMU when dropped.
struct Qemu(Child);

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts `image` with UART0 on a PTY; returns QEMU (killed when dropped) and the PTY's path.
fn start_on_pty(image_name: &str) -> (Qemu, String) {
    let mut child = spawn(qemu(&image(image_name), false, "pty", &[]));
    let stderr = child.stderr.take().expect("stderr");
    let stdout = child.stdout.take().expect("stdout");
    let mut q = Qemu(child);
    // QEMU names the PTY (on stdout): "char device redirected to /dev/pts/N (label serial0)".
    let (tx, rx) = std::sync::mpsc::channel();
    for stream in [Box::new(stdout) as Box<dyn Read + Send>, Box::new(stderr)] {
        let tx = tx.clone();
        std::thread::spawn(move || {
            for line in BufReader::new(stream).lines().map_while(Result::ok) {
                if let Some(rest) = line.strip_prefix("char device redirected to ") {
                    let _ = tx.send(rest.split_whitespace().next().unwrap_or("").to_string());
                }
            }
        });
    }
    let pty = rx.recv_timeout(Duration::from_secs(20)).unwrap_or_else(|_| {
        let _ = q.0.kill();
        panic!("QEMU did not say which PTY it opened")
    });
    (q, pty)
}

#[test]
#[ignore = "needs qemu-system-arm and the MCU images (scripts/test.sh)"]
fn the_real_time_image_ticks_every_200_ms_on_systick() {
    use firmware::protocol::{encode, Hello, HostToCore, Role, MAX_FRAME_LEN};
    use host::link::Link;
    let (_q, pty) = start_on_pty("mcu-node");
    let mut link = SerialLink::open(Path::new(&pty), 921_600).unwrap_or_else(|e| panic!("{pty}: {e}"));
    let mut buf = [0u8; MAX_FRAME_LEN];
    let hello = encode(&HostToCore::Hello(Hello::new(Role::Simulator, false)), &mut buf).expect("a Hello frame").to_vec();
    let mut dec = HostDecoder::new();
    let mut statuses = Vec::new();
    let mut acked = false;
    let t0 = Instant::now();
    let mut rx = [0u8; 4096];
    while statuses.len() < 6 && t0.elapsed() < Duration::from_secs(30) {
        if !acked {
            link.write_all(&hello).expect("write to the PTY");
        }
        let n = link.read(&mut rx, Duration::from_millis(200)).expect("read from the PTY");
        for m in dec.feed(&rx[..n]) {
            match m.expect("valid frames") {
                CoreToHost::HelloAck(a) => acked = a.accepted,
                CoreToHost::Status(s) => statuses.push((s, Instant::now())),
                _ => {}
            }
        }
    }
    assert!(acked, "no HelloAck from the MCU");
    assert!(statuses.len() >= 6, "the MCU sent {} statuses in 30 s", statuses.len());
    // One tick per SysTick period, stamped with the period (200 ms of virtual time each; a period
    // QEMU could not run in time on a loaded machine is skipped, not caught up), idle.
    let mut exact = 0;
    for w in statuses.windows(2) {
        let (a, b) = (&w[0].0, &w[1].0);
        let dt = b.t_us - a.t_us;
        assert!(dt > 0 && dt % 200_000 == 0, "ticks must be whole periods apart: {a:?} then {b:?}");
        assert_eq!(b.ticks, a.ticks + 1);
        exact += usize::from(dt == 200_000);
    }
    assert!(exact * 2 >= statuses.len() - 1, "most ticks are one period apart");
    assert!(statuses.iter().all(|(s, _)| s.mode == WireMode::Idle));
    // Without -icount QEMU's virtual clock follows the host's: the period is about 200 ms of wall time.
    let (first, last) = (&statuses[0], &statuses[statuses.len() - 1]);
    let wall = last.1.duration_since(first.1).as_secs_f64();
    let virt = (last.0.t_us - first.0.t_us) as f64 / 1e6;
    assert!(wall > 0.5 * virt && wall < 2.0 * virt, "{virt} s of ticks took {wall} s of wall time");
}

#[test]
#[ignore = "needs qemu-system-arm and the MCU images (scripts/test.sh)"]
fn the_emulated_mcu_searches_over_its_uart_exactly_as_the_host_node() {
    let (_q, pty) = start_on_pty("mcu-lockstep");
    // The apartment from the hallway's junction (the built-in `apartment easy` until
    // 2026-11-25): a search of 279 ticks and 5 goals, where the built-in one takes 40 ticks.
    let world = World::load(&Path::new(WORKSPACE).join("examples/worlds/apartment-easy-hallway-start.toml")).expect("the example world");
    // `lives` as deployed: the scans go without labels and the image's embedded geometric
    // classifier labels them. Seed 2 found the target in 55.6 s on the clean sensor and the
    // ternary grid; on the default robot since issue 27 (VLP-16 profile, odometry drift, the
    // evidence grid and the scan matcher) it runs to the 120 s limit, as `lives search --world
    // examples/worlds/apartment-easy-hallway-start.toml --seed 2` does: what this test checks is
    // that the MCU over its UART makes the host node's decisions through a whole search.
    let mut spec = SearchSpec::new("apartment-easy-hallway-start", world, Scenario::Easy, PlannerChoice::Lives, 2);
    spec.scenario = None; // a world file, as `--world FILE` runs it
    spec.model = Some(firmware::classifier::EMBEDDED_GEO_MODEL);
    let mut link = SerialLink::open(Path::new(&pty), 921_600).unwrap_or_else(|e| panic!("{pty}: {e}"));
    // As `lives bridge --lockstep`, with more patience for a loaded CI machine.
    let opts = BridgeOptions {
        watchdog: Duration::from_secs(10),
        retry_timeout: Duration::from_secs(5),
        max_wall: Some(Duration::from_secs(900)),
        ..BridgeOptions::new(TimeMode::Lockstep)
    };
    let run = run_bridge(&mut link, Source::Sim(spec.clone()), &opts, &AtomicBool::new(false)).expect("a session with the MCU");
    let r = &run.result;
    println!(
        "MCU over UART: {} in {} s sim, {} ticks, {:.1} s wall, {} retries",
        r.outcome, r.time_s, r.ticks, run.wall_s, run.stats.retries
    );
    assert!(r.goals > 3 && r.path_m > 10.0 && r.ticks > 100, "the MCU's search went nowhere: {r:?}");
    assert_eq!(run.stats.rejected, 0, "damaged frames on a clean line");
    // The same run with the node on the host (same bridge code, in-memory line): the MCU made
    // exactly the host's decisions.
    let (node_end, mut bridge_end) = mem_pair();
    let stop_node = AtomicBool::new(false);
    let local = std::thread::scope(|s| {
        let _stop = common::StopOnDrop(&[&stop_node]);
        let node = s.spawn(|| {
            let mut node_end = node_end;
            let opts = NodeOptions { model: spec.model, ..NodeOptions::new(TimeMode::Lockstep) };
            let mut p = NodeProcess::new(Config::DEFAULT, opts).expect("the committed model validates");
            p.run(&mut node_end, &stop_node);
        });
        let r =
            run_bridge(&mut bridge_end, Source::Sim(spec.clone()), &opts, &AtomicBool::new(false)).expect("a session with the host node");
        stop_node.store(true, std::sync::atomic::Ordering::Relaxed);
        node.join().expect("host node thread");
        r
    });
    assert_eq!(run.goals, local.goals, "the MCU chose other goals than the host node");
    assert_eq!(r.ticks, local.result.ticks);
    assert_eq!((&r.outcome, r.found), (&local.result.outcome, local.result.found));
    assert_eq!(r.labels, "int8-classifier", "the MCU labelled the scans with its embedded classifier");
}

#[test]
#[ignore = "needs qemu-system-arm and the MCU images (scripts/test.sh)"]
fn the_geometric_classifier_labels_bit_identically_on_the_cortex_m() {
    use firmware::classifier::geo::{synthetic_digest, GeoView};
    use firmware::classifier::{Classifier, ClassifierConfig, EMBEDDED_GEO_MODEL};
    let mut cls = Box::new(Classifier::new(ClassifierConfig::default()));
    cls.set_geo_model(GeoView::parse(EMBEDDED_GEO_MODEL).expect("the committed geometric model validates"));
    let (digest, nonmap) = synthetic_digest(&mut cls, 3);
    assert!(nonmap > 0, "the synthetic scans' box and post should have non-map beams");
    let (code, out, err) = run_qemu(qemu(&image("mcu-selftest"), true, "null", &["geo"]), Duration::from_secs(120));
    assert_eq!(code, Some(0), "{out}{err}");
    let line = out.lines().find(|l| l.starts_with("GEO ")).unwrap_or_else(|| panic!("no GEO line:\n{out}"));
    assert!(
        line.contains(&format!("digest={digest:08x} nonmap={nonmap} ")),
        "x86_64: digest={digest:08x} nonmap={nonmap}; Cortex-M: {line}"
    );
    // The hidden layer's DSP dot product against the plain sum, random and extreme rows.
    assert!(line.contains("dots=2003 dot_mismatches=0"), "{line}");
    let per_scan: u64 = line
        .split_whitespace()
        .find_map(|f| f.strip_prefix("instructions_per_scan="))
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    println!("geometric classifier on the Cortex-M4F: {per_scan} instructions per scan (QEMU -icount); digest {digest:08x}, {nonmap} non-map beams");
    // 897 beams × (23 · 48 + 48) MACs plus the features and the label history, the classifier
    // calls alone (7.64 M instructions measured with the committed model, averaged over three
    // scans, the first of which computes the beam directions: ≈ 8 ms on a 1 GHz Cortex-M7,
    // against the 200 ms tick). A deterministic count, not a time; the bound leaves 5 % for
    // toolchain drift.
    assert!(per_scan < 8_050_000, "{line}");
}
