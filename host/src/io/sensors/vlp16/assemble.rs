//! From packets to planar scans: the configuration (the laser band, beams), the scan and the
//! assembler that cuts rotations ([`ScanAssembler`]).

use super::*;
use std::fmt;

/// What the scan assembler keeps: which lasers, how many beams, which ranges.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vlp16Config {
    /// Lowest laser elevation used, degrees (inclusive).
    pub elevation_min_deg: f64,
    /// Highest laser elevation used, degrees (inclusive).
    pub elevation_max_deg: f64,
    /// Beams over 360° (the classifier's grid: 897).
    pub beams: usize,
    /// Returns with a horizontal range below this are dropped (the robot's own body), metres.
    pub min_range_m: f64,
    /// Returns with a horizontal range above this count as no return, metres (VLP-16: 100 m).
    pub max_range_m: f64,
}

impl Default for Vlp16Config {
    /// The two near-horizontal lasers (−1° and +1°) onto 897 beams, 0.3–100 m.
    fn default() -> Self {
        Self { elevation_min_deg: -1.0, elevation_max_deg: 1.0, beams: firmware::capacity::BEAMS, min_range_m: 0.3, max_range_m: 100.0 }
    }
}

impl Vlp16Config {
    /// Channels 0–15 whose laser lies in the elevation band.
    pub fn lasers(&self) -> Vec<usize> {
        (0..LASERS)
            .filter(|&c| {
                let e = ELEVATION_DEG[c] as f64;
                e >= self.elevation_min_deg && e <= self.elevation_max_deg
            })
            .collect()
    }

    /// Checks the band selects a laser, the beam count and the range limits.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let (lo, hi) = (self.elevation_min_deg, self.elevation_max_deg);
        if lo.is_nan() || hi.is_nan() || lo > hi {
            return Err(ConfigError::EmptyBand { min_deg: self.elevation_min_deg, max_deg: self.elevation_max_deg });
        }
        if self.lasers().is_empty() {
            return Err(ConfigError::NoLaser { min_deg: self.elevation_min_deg, max_deg: self.elevation_max_deg });
        }
        if self.beams == 0 || self.beams > 36_000 {
            return Err(ConfigError::Beams(self.beams));
        }
        if !(self.min_range_m >= 0.0 && self.min_range_m < self.max_range_m && self.max_range_m.is_finite()) {
            return Err(ConfigError::Range { min_m: self.min_range_m, max_m: self.max_range_m });
        }
        Ok(())
    }
}

/// A [`Vlp16Config`] that cannot work.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum ConfigError {
    /// The band's minimum is above its maximum (or not a number).
    EmptyBand { min_deg: f64, max_deg: f64 },
    /// No laser's elevation lies in the band.
    NoLaser { min_deg: f64, max_deg: f64 },
    /// The beam count is 0 or above 36000 (one per 0.01°).
    Beams(usize),
    /// The range limits are negative, unordered or infinite.
    Range { min_m: f64, max_m: f64 },
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::EmptyBand { min_deg, max_deg } => write!(f, "elevation band {min_deg}..{max_deg}° is empty"),
            Self::NoLaser { min_deg, max_deg } => {
                write!(f, "no VLP-16 laser lies in the elevation band {min_deg}..{max_deg}° (lasers are at ±1, ±3, …, ±15°)")
            }
            Self::Beams(n) => write!(f, "{n} beams: expected 1 to 36000"),
            Self::Range { min_m, max_m } => write!(f, "range limits {min_m}..{max_m} m: need 0 ≤ min < max < ∞"),
        }
    }
}

impl std::error::Error for ConfigError {}

/// One rotation on a beam grid, in the sensor frame (REP-103, see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct PlanarScan {
    /// Sensor time of the scan's first firing: µs past the top of the hour of the stream's first
    /// packet, counting on across hours.
    pub stamp_us: u64,
    /// Angle of beam 0 (−π), radians.
    pub angle_min_rad: f64,
    /// Angle between beams (2π / beams), radians.
    pub angle_increment_rad: f64,
    /// One per beam: nearest horizontal range in metres; `+∞` fired but no return; `NaN` nothing fired.
    pub ranges_m: Vec<f32>,
    /// The configured minimum and maximum range ([`Vlp16Config`]), metres: the scan's `range_min`
    /// and `range_max`.
    pub range_limits_m: [f64; 2],
}

impl PlanarScan {
    /// Beams with a finite range.
    pub fn valid_beams(&self) -> usize {
        self.ranges_m.iter().filter(|r| r.is_finite()).count()
    }

    /// Beams where lasers fired without a return within range (`+∞`).
    pub fn no_return_beams(&self) -> usize {
        self.ranges_m.iter().filter(|r| r.is_infinite()).count()
    }

    /// Beams nothing fired into (`NaN`).
    pub fn unseen_beams(&self) -> usize {
        self.ranges_m.iter().filter(|r| r.is_nan()).count()
    }

    /// Yaw of beam `b` in the sensor frame, radians.
    pub fn beam_angle_rad(&self, b: usize) -> f64 {
        self.angle_min_rad + b as f64 * self.angle_increment_rad
    }
}

/// Beam of a firing at `azimuth_half` (0.005° units, clockwise from the sensor's +Y) on a grid of
/// `beams` beams starting at −π in the REP-103 frame (yaw = −azimuth). Rounds to the nearest beam.
pub fn beam_of_azimuth(azimuth_half: u32, beams: usize) -> usize {
    let turn = 2 * AZIMUTH_TURN as u64; // 72000 units
                                        // Yaw + π in units: (−a + 180°) mod 360°.
    let u = (turn / 2 + turn - azimuth_half as u64 % turn) % turn;
    ((u * beams as u64 + turn / 2) / turn) as usize % beams
}

/// Turns "µs past the hour" timestamps into a count that goes on across hours.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct HourClock {
    hours: u64,
    last_us: Option<u32>,
}

pub(super) const HOUR_US: u64 = 3_600_000_000;

impl HourClock {
    pub(super) fn unwrap(&mut self, us: u32) -> u64 {
        if let Some(last) = self.last_us {
            // A drop of more than half an hour is the top of the hour, not jitter or reordering.
            if (last as u64) > us as u64 + HOUR_US / 2 {
                self.hours += 1;
            }
        }
        self.last_us = Some(us);
        self.hours * HOUR_US + us as u64
    }
}

/// Gathers the firings of successive packets into one [`PlanarScan`] per rotation.
#[derive(Debug, Clone)]
pub struct ScanAssembler {
    cfg: Vlp16Config,
    /// Selected channels (0–15) and cos(elevation).
    lasers: Vec<(usize, f64)>,
    /// The rotation in progress: nearest range per beam (NaN until something fires into it).
    ranges: Vec<f32>,
    /// Whether any firing has gone into the current scan.
    open: bool,
    stamp_us: u64,
    last_azimuth_half: Option<u32>,
    clock: HourClock,
}

impl ScanAssembler {
    /// A new assembler; the configuration is validated.
    pub fn new(cfg: Vlp16Config) -> Result<Self, ConfigError> {
        cfg.validate()?;
        let lasers = cfg.lasers().into_iter().map(|c| (c, (ELEVATION_DEG[c] as f64).to_radians().cos())).collect();
        Ok(Self {
            cfg,
            lasers,
            ranges: vec![f32::NAN; cfg.beams],
            open: false,
            stamp_us: 0,
            last_azimuth_half: None,
            clock: HourClock::default(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &Vlp16Config {
        &self.cfg
    }

    /// Channels (0–15) of the lasers in use.
    pub fn lasers(&self) -> Vec<usize> {
        self.lasers.iter().map(|&(c, _)| c).collect()
    }

    /// Checks and adds one packet's bytes; returns the scan completed by an azimuth wrap in it.
    pub fn push_bytes(&mut self, bytes: &[u8]) -> Result<Option<PlanarScan>, PacketError> {
        let p = Vlp16Packet::new_checked(bytes)?;
        Ok(self.push(&p))
    }

    /// Adds the firings of a checked packet in order; when the azimuth wraps (one rotation ends),
    /// the finished scan is returned and the packet's remaining firings start the next one.
    /// Checked packets move less than 60° and so wrap at most once.
    pub fn push<T: AsRef<[u8]>>(&mut self, p: &Vlp16Packet<T>) -> Option<PlanarScan> {
        let t0_us = self.clock.unwrap(p.timestamp_us());
        let mut done = None;
        let half_turn = AZIMUTH_TURN; // 180° in 0.005° units
        let stride = p.return_mode().map_or(1, ReturnMode::block_stride);
        // In time order: in dual mode both blocks of a pair hold the same firing.
        for group in (0..BLOCKS).step_by(stride) {
            for firing in 0..2 {
                for block in group..group + stride {
                    let az = p.firing_azimuth_half(block, firing);
                    // A drop of more than half a turn is the wrap past 360°.
                    if self.open && self.last_azimuth_half.is_some_and(|last| last > az + half_turn) {
                        done = done.or(Some(self.take()));
                    }
                    self.last_azimuth_half = Some(az);
                    if !self.open {
                        self.open = true;
                        self.stamp_us = t0_us + p.firing_offset_ns(block, firing) / 1000;
                    }
                    self.bin(p, block, firing, az);
                }
            }
        }
        done
    }

    /// Puts one firing's selected lasers into the beam of `az`, keeping the nearest range.
    fn bin<T: AsRef<[u8]>>(&mut self, p: &Vlp16Packet<T>, block: usize, firing: usize, az: u32) {
        let slot = &mut self.ranges[beam_of_azimuth(az, self.cfg.beams)];
        for &(laser, cos_el) in &self.lasers {
            let d = p.distance(block, firing * LASERS + laser);
            let r = d as f64 * DISTANCE_UNIT_M * cos_el;
            if d != 0 && r < self.cfg.min_range_m {
                continue; // The robot's own body: as if the laser had not fired.
            }
            let r = if d == 0 || r > self.cfg.max_range_m { f32::INFINITY } else { r as f32 };
            // Keep the nearest: NaN (unseen) and +∞ (no return) yield to anything smaller.
            if slot.is_nan() || r < *slot {
                *slot = r;
            }
        }
    }

    /// The rotation in progress, if any firing went into it (e.g. at the end of a capture); the
    /// assembler starts afresh.
    pub fn finish(&mut self) -> Option<PlanarScan> {
        if self.open {
            Some(self.take())
        } else {
            None
        }
    }

    fn take(&mut self) -> PlanarScan {
        let n = self.cfg.beams;
        let ranges_m = std::mem::replace(&mut self.ranges, vec![f32::NAN; n]);
        self.open = false;
        PlanarScan {
            stamp_us: self.stamp_us,
            angle_min_rad: -std::f64::consts::PI,
            angle_increment_rad: std::f64::consts::TAU / n as f64,
            ranges_m,
            range_limits_m: [self.cfg.min_range_m, self.cfg.max_range_m],
        }
    }
}
