//! A recorded log as a run's source ([`LogSource`]): its scans at their poses, in order.

use super::error::{compact, BAD_RECORDS_KEPT};
use super::ScanRecord;
use crate::run::range::{EncodedScan, RangeLimits};
use crate::run::{Answer, Frame, Source, TICK_US};
use firmware::Pose2;

/// The scans of a log that can be mapped, at their time stamps (or one per [`TICK_US`] when the
/// stamps do not advance). Strays, non-finite poses and non-finite beam angles are skipped and
/// counted (`Rejected`). Nobody drives: the brain's goals are what it would have sent.
pub(super) struct LogSource<'a> {
    scans: &'a [ScanRecord],
    stray: &'a [bool],
    next: usize,
    /// The scan of the last frame.
    pub(super) current: usize,
    t0: f64,
    synthetic_time: bool,
    last_us: u64,
    /// Scans skipped: the laser's pose strays from the trajectory, is not finite, or the beam
    /// angles are not.
    pub(super) stray_pose: u32,
    pub(super) no_pose: u32,
    pub(super) bad_angles: u32,
    /// Scans of more beams than the core takes, combined to fit ([`EncodedScan::fitted`]), and
    /// the most beams combined into one.
    pub(super) combined_scans: u32,
    pub(super) combined_most: u16,
    /// The first few strays, for the warning.
    pub(super) strays: Vec<String>,
}

impl<'a> LogSource<'a> {
    /// `scans` (not empty), `stray` one per scan; `synthetic_time`: one scan per tick.
    pub(super) fn new(scans: &'a [ScanRecord], stray: &'a [bool], synthetic_time: bool) -> Self {
        let t0 = scans[0].t_s;
        LogSource {
            scans,
            stray,
            next: 0,
            current: 0,
            t0,
            synthetic_time,
            last_us: 0,
            stray_pose: 0,
            no_pose: 0,
            bad_angles: 0,
            combined_scans: 0,
            combined_most: 1,
            strays: Vec::new(),
        }
    }

    /// The scan of the last frame.
    pub(super) fn record(&self) -> &ScanRecord {
        &self.scans[self.current]
    }
}

impl Source for LogSource<'_> {
    fn sense(&mut self, _tick: u32) -> Option<Frame> {
        while self.next < self.scans.len() {
            let i = self.next;
            self.next += 1;
            let s = &self.scans[i];
            let t_us = if self.synthetic_time { i as u64 * TICK_US } else { ((s.t_s - self.t0) * 1e6).round().max(0.0) as u64 };
            let now_us = self.last_us.max(t_us);
            self.last_us = now_us;
            if self.stray[i] {
                self.stray_pose += 1;
                if self.strays.len() < BAD_RECORDS_KEPT {
                    self.strays.push(format!("{} at ({}, {})", s.at, compact(s.pose[0]), compact(s.pose[1])));
                }
                continue;
            }
            // A non-finite pose: no pose to map the scan at; non-finite beam angles: no beams.
            let Some(pose) = Pose2::from_f64(s.pose[0], s.pose[1], s.pose[2]) else {
                self.no_pose += 1;
                continue;
            };
            let limits = RangeLimits::new(s.range_limits_m[0], s.range_limits_m[1]);
            let Some(scan) = EncodedScan::new(s.angle_min, s.angle_increment, s.ranges_m.iter().map(|&r| r as f64), &limits) else {
                self.bad_angles += 1;
                continue;
            };
            if scan.combined > 1 {
                self.combined_scans += 1;
                self.combined_most = self.combined_most.max(scan.combined);
            }
            self.current = i;
            return Some(Frame {
                t_us: now_us,
                pose: Some(pose),
                base_pose: s.pose,
                time_s: s.t_s,
                scan,
                labels: false,
                detection: false,
                base_blocked: false,
            });
        }
        None
    }

    fn act(&mut self, _answer: &Answer) -> bool {
        true
    }
}
