//! Checks of the MCU image's own machinery under QEMU, chosen by the semihosting command line
//! (`-semihosting-config enable=on,target=native,arg=MODE`):
//!
//! * `panic`: a panic must report and stop the robot (a `Stop` frame on UART0, exit status 1).
//! * `overflow`: an arithmetic overflow (checked in release builds) is such a panic.
//! * `hardfault`: an undefined instruction escalates to a HardFault, reported the same way.
//! * `ok`: exits with success (the harness itself works).
//! * `dot`: the int8 inner product's DSP path (SMLAD) equals the portable reference on random
//!   vectors of every length 0..=1000 (and extreme values), then both are timed on a 897 × 897
//!   matrix-vector product with SysTick (run with `-icount shift=0` for instruction counts).
//!
//! See tests/tests/mcu.rs.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod common;

firmware::mcu_main! {
    selftest()
}

/// Runs the mode the command line names.
#[cfg(target_os = "none")]
fn selftest() -> ! {
    use common::{fault, uart};
    use cortex_m_semihosting::hprintln;
    uart::init(uart::BAUD);
    let mut buf = [0u8; 128];
    let mode = common::cmdline(&mut buf);
    hprintln!("selftest {}", mode);
    match mode {
        "ok" => common::exit_ok(),
        "panic" => panic!("selftest: a deliberate panic"),
        "overflow" => {
            let x = core::hint::black_box(i32::MAX);
            let y = x + core::hint::black_box(1);
            hprintln!("not reached: {}", y);
            common::exit_ok()
        }
        "hardfault" => {
            // SAFETY: deliberately undefined (UDF): the fault path must catch it.
            unsafe { core::arch::asm!("udf #0") };
            common::exit_ok()
        }
        "dot" => {
            dot_check();
            common::exit_ok()
        }
        "geo" => {
            geo_check();
            common::exit_ok()
        }
        other => fault::stop(format_args!("unknown selftest mode `{}` (ok, panic, overflow, hardfault, dot, geo)", other)),
    }
}

/// See the `dot` mode.
#[cfg(target_os = "none")]
fn dot_check() {
    use common::{clock, fault};
    use cortex_m_semihosting::hprintln;
    use firmware::classifier::{dot, dot_reference, DotInput};
    let mut seed = 0x2545_F491u32;
    let mut next = move || firmware::rrt::xorshift32(&mut seed);
    let mut w = [0u8; 1001];
    let mut x = [0i8; 1001];
    let mut cases = 0u32;
    for len in 0..=1000usize {
        for round in 0..3 {
            for i in 0..len {
                let (a, b) = match round {
                    0 => (next() as u8, next() as i8),
                    // Extremes: the largest products and sums.
                    1 => (0x80, -128),
                    _ => (if next() & 1 == 0 { 0x7F } else { 0x80 }, if next() & 1 == 0 { 127 } else { -128 }),
                };
                w[i] = a;
                x[i] = b;
            }
            // Unaligned weight rows too (rows of 897 bytes start anywhere).
            let off = (next() % 4) as usize;
            let n = len.saturating_sub(off);
            let (ws, xs) = (&w[off..off + n], &x[..n]);
            let fast = dot(ws, &DotInput::new(xs));
            let reference = dot_reference(ws, xs);
            if fast != reference {
                fault::stop(format_args!("dot mismatch: len {} offset {} round {}: {} != {}", n, off, round, fast, reference));
            }
            cases += 1;
        }
    }
    hprintln!("DOT ok cases={}", cases);

    // Timing: a 897 × 897 int8 matrix-vector product (the classifier's largest layers).
    const N: usize = 897;
    let mut cp = cortex_m::Peripherals::take().unwrap_or_else(|| fault::stop(format_args!("peripherals taken twice")));
    clock::start(&mut cp.SYST);
    let weights = firmware::classifier::EMBEDDED_MODEL;
    if weights.len() < N * N {
        fault::stop(format_args!("the embedded model is smaller than one 897 x 897 layer"));
    }
    let input = &x[..N];
    let t0 = clock::now_counts();
    let mut s1 = 0i32;
    let prepared = DotInput::new(input);
    for r in 0..N {
        s1 = s1.wrapping_add(dot(&weights[r * N..(r + 1) * N], &prepared));
    }
    let t1 = clock::now_counts();
    let mut s2 = 0i32;
    for r in 0..N {
        s2 = s2.wrapping_add(dot_reference(&weights[r * N..(r + 1) * N], input));
    }
    let t2 = clock::now_counts();
    if s1 != s2 {
        fault::stop(format_args!("dot mismatch on the 897 x 897 product: {} != {}", s1, s2));
    }
    let macs = (N * N) as u64;
    let ipc = clock::INSTRUCTIONS_PER_COUNT;
    hprintln!("DOTBENCH macs={} dsp_instructions={} reference_instructions={}", macs, (t1 - t0) * ipc, (t2 - t1) * ipc);
}

/// The geometric classifier's state (44 KiB with `LabelPoseNet`'s rings), in `.data`.
#[cfg(target_os = "none")]
static GEO_CLASSIFIER: common::slot::Slot<firmware::classifier::Classifier<'static>> =
    common::slot::Slot::with(firmware::classifier::Classifier::new(firmware::classifier::ClassifierConfig {
        feedback: firmware::classifier::LabelFeedback::Raw,
    }));

/// See the `geo` mode.
#[cfg(target_os = "none")]
fn geo_check() {
    use common::{clock, fault};
    use cortex_m_semihosting::hprintln;
    use firmware::classifier::geo::{geo_dot_selfcheck, synthetic_digest_timed, GeoView};
    let cls = GEO_CLASSIFIER.take();
    match GeoView::parse(firmware::classifier::EMBEDDED_GEO_MODEL) {
        Ok(m) => cls.set_geo_model(m),
        Err(e) => fault::stop(format_args!("the embedded geometric model does not validate: {:?}", e)),
    }
    let mut cp = cortex_m::Peripherals::take().unwrap_or_else(|| fault::stop(format_args!("peripherals taken twice")));
    clock::start(&mut cp.SYST);
    const SCANS: u32 = 3;
    // Only the classifier's calls are counted, not the synthesis of the scans or the digest.
    let (digest, nonmap, counts) = synthetic_digest_timed(cls, SCANS, clock::now_counts);
    let per_scan = counts * clock::INSTRUCTIONS_PER_COUNT / SCANS as u64;
    let (dots, dot_mismatches) = geo_dot_selfcheck(2000);
    hprintln!(
        "GEO digest={:08x} nonmap={} instructions_per_scan={} dots={} dot_mismatches={}",
        digest,
        nonmap,
        per_scan,
        dots,
        dot_mismatches
    );
}
