//! The trace images' program (`mcu-trace`, `mcu-trace-live`): replays recorded host → core
//! streams embedded in flash through the node and the controller exactly as the host does
//! (`firmware::mcu::trace`), and prints per record the digest of the node's answer and the
//! SysTick counts of each stage (1 count = 40 guest instructions), then the stack high-water mark.
//! Output format in docs/mcu.md.

use super::{self as common, clock, fault, slot::MainCell, CONTROLLER, NODE};
use cortex_m_semihosting::hprintln;
use firmware::controller::Stage;
use firmware::mcu::{hook, trace::Trace};
use firmware::node::{Node, NodeConfig, TimeMode};

const STAGES: usize = 7;
const PAINT: u32 = 0x5AFE_C0DE;

struct Times {
    start: [u64; STAGES],
    sum: [u64; STAGES],
}

static TIMES: MainCell<Times> = MainCell::new(Times { start: [0; STAGES], sum: [0; STAGES] });

fn index(stage: Stage) -> usize {
    match stage {
        Stage::Classify => 0,
        Stage::Lidar => 1,
        Stage::Visual => 2,
        Stage::NonMap => 3,
        Stage::Plan => 4,
        Stage::Gaze => 5,
        Stage::Match => 6,
    }
}

fn on_stage(stage: Stage, begin: bool) {
    let now = clock::now_counts();
    TIMES.with(|t| {
        let i = index(stage);
        if begin {
            t.start[i] = now;
        } else {
            t.sum[i] += now - t.start[i];
        }
    });
}

extern "C" {
    static __sheap: u32;
    static _stack_start: u32;
}

/// Fills the free RAM between the statics and the stack pointer with a pattern; returns the
/// painted range.
fn paint_stack() -> (usize, usize) {
    let bottom = (&raw const __sheap) as usize;
    let top = (&raw const _stack_start) as usize;
    let sp = cortex_m::register::msp::read() as usize;
    let mut p = bottom;
    while p + 256 < sp {
        // SAFETY: free RAM below the live stack (no heap in these images).
        unsafe { core::ptr::write_volatile(p as *mut u32, PAINT) };
        p += 4;
    }
    (bottom, top)
}

/// Deepest stack use since [`paint_stack`] (bytes).
fn stack_used(bottom: usize, top: usize) -> usize {
    let mut p = bottom;
    // SAFETY: RAM inside the board's memory.
    while p < top && unsafe { core::ptr::read_volatile(p as *const u32) } == PAINT {
        p += 4;
    }
    top - p
}

/// Replays `bytes` (the trace tagged `tag` in the output) on the controller in its static (built at
/// compile time, no model installed: as the host's `Controller::new(Config::DEFAULT)`; the trace
/// installs the embedded `LabelPoseNet` if it asks for it) and a new node; prints its lines, the
/// stack high-water mark and `DONE tag ticks=N`, and exits.
pub fn run(bytes: &'static [u8], tag: &str) -> ! {
    let (bottom, top) = paint_stack();
    let mut cp = cortex_m::Peripherals::take().unwrap_or_else(|| fault::stop(format_args!("peripherals taken twice")));
    clock::start(&mut cp.SYST);
    let ctl = CONTROLLER.take();
    let node = NODE.init(|s| s.write(Node::new(NodeConfig::new(TimeMode::Lockstep))));
    let init_stack = stack_used(bottom, top);
    let trace = Trace::parse(bytes).unwrap_or_else(|e| fault::stop(format_args!("the embedded trace {}: {}", tag, e)));
    hprintln!(
        "TRACE {} records={} flags={} bytes={} counts_per_instruction=1/{}",
        tag,
        trace.len(),
        trace.flags(),
        bytes.len(),
        clock::INSTRUCTIONS_PER_COUNT
    );
    hook::install(on_stage);
    let mut last = clock::now_counts();
    let ticks = trace
        .replay_observed(node, ctl, &mut hook::Hooked, |d| {
            let now = clock::now_counts();
            let total = now - last;
            let s = TIMES.with(|t| core::mem::replace(&mut t.sum, [0; STAGES]));
            hprintln!(
                "{} {} {} {} {} {:08x} {} {} {} {} {} {} {} {}",
                tag,
                d.record,
                d.t_us,
                d.ticks,
                d.len,
                d.crc,
                total,
                s[0],
                s[1],
                s[2],
                s[3],
                s[4],
                s[5],
                s[6]
            );
            // The printing is not part of the next record's time.
            last = clock::now_counts();
        })
        .unwrap_or_else(|e| fault::stop(format_args!("replay {}: {}", tag, e)));
    hook::uninstall();
    hprintln!("STACK init={} max={}", init_stack, stack_used(bottom, top));
    hprintln!("DONE {} ticks={}", tag, ticks);
    common::exit_ok()
}
