//! Recording a bridge's traffic as it happens ([`SharedRecording`], a [`BridgeObserver`]): the
//! protocol messages the bridge sends and receives, into an MCAP file ([`crate::io::record`]).

use super::bridge::{BridgeObserver, SharedObserver};
use crate::io::record::{RecordError, RecordOptions, RecordSummary, Recorder};
use firmware::protocol::{CoreToHost, DetectionMsg, PoseMsg, ScanMsg};
use std::path::Path;
use std::sync::{Arc, Mutex};

/// The bridge's recording: protocol messages only (see the module docs). Hand
/// [`SharedRecording::observer`] to [`crate::link::BridgeOptions::observer`] and call
/// [`SharedRecording::finish`] after the run. The first recording error stops the recording (not
/// the run) and is returned by `finish`.
#[derive(Clone, Debug)]
pub struct SharedRecording(Arc<Mutex<BridgeRecording>>);

#[derive(Debug)]
pub struct BridgeRecording {
    recorder: Option<Recorder>,
    error: Option<RecordError>,
}

impl SharedRecording {
    /// Creates the recording at `path` (default [`RecordOptions`]).
    pub fn create(path: &Path) -> Result<Self, RecordError> {
        Ok(Self::new(Recorder::create(path, RecordOptions::default())?))
    }

    /// Records into `recorder`.
    pub fn new(recorder: Recorder) -> Self {
        SharedRecording(Arc::new(Mutex::new(BridgeRecording { recorder: Some(recorder), error: None })))
    }

    /// The observer to give the bridge.
    pub fn observer(&self) -> SharedObserver {
        SharedObserver(self.0.clone())
    }

    /// Finishes the file; the summary, or the first error of the recording.
    pub fn finish(&self) -> Result<RecordSummary, RecordError> {
        let mut r = self.0.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(e) = r.error.take() {
            return Err(e);
        }
        r.recorder.take().ok_or(RecordError::Finished)?.finish()
    }
}

impl BridgeRecording {
    fn attempt(&mut self, f: impl FnOnce(&mut Recorder) -> Result<(), RecordError>) {
        if let (Some(rec), None) = (self.recorder.as_mut(), &self.error) {
            if let Err(e) = f(rec) {
                self.error = Some(e);
            }
        }
    }
}

impl BridgeObserver for BridgeRecording {
    fn tick(&mut self, pose: &PoseMsg, scan: &ScanMsg, detection: Option<&DetectionMsg>) {
        self.attempt(|r| {
            r.record_pose(pose.t_us, &pose.pose())?;
            r.record_scan_input(scan.t_us, &scan.scan_input())?;
            match detection {
                Some(d) => r.record_detection(d.t_us, d),
                None => Ok(()),
            }
        });
    }

    fn received(&mut self, m: &CoreToHost) {
        self.attempt(|r| match m {
            CoreToHost::Status(s) => r.record_status(s),
            CoreToHost::Goal(g) => {
                let t = r.last_t_us();
                r.record_goal(t, g)
            }
            CoreToHost::Labels(l) => r.record_node_labels(l.t_us, &l.labels),
            _ => Ok(()),
        });
    }
}
