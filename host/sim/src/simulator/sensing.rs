//! What the robot senses: LiDAR scans (surfaces, glass, no-returns, mixed pixels, noise) and the
//! camera detector's sightlines.

use std::f64::consts::PI;

use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::geometry::{norm, ray_circle, sub, wrap_angle, NO_OWNER, TARGET_OWNER_BASE};
use crate::{HitKind, Material, P2};

impl Sim {
    /// First hit of a ray against the scene and the people, within `max_t`.
    fn cast(&self, o: P2, d: P2, max_t: f64, ignore_owner: u32) -> Option<(f64, HitKind)> {
        let mut best = self.scene.raycast(o, d, max_t, ignore_owner).map(|h| (h.t, h.kind));
        for w in &self.walkers {
            if let Some(t) = ray_circle(o, d, w.position(), w.radius) {
                if t <= max_t && best.is_none_or(|(bt, _)| t < bt) {
                    best = Some((t, HitKind::Person));
                }
            }
        }
        best
    }

    /// One LiDAR sweep from the laser's current pose ([`Sim::laser_pose`]) with people where they
    /// are now, in the laser frame. With a clean LiDAR ([`SimConfig::clean_lidar`]) each beam
    /// draws one dropout uniform and one Gaussian from the sensor stream, hit or not, so the
    /// stream does not depend on the scene (the simulator's sensor before the profiles, bit for
    /// bit). Otherwise [`Sim::physical_scan`].
    pub fn scan(&mut self) -> Scan {
        let lp = self.laser_pose();
        let c = &self.config;
        let n = c.beams;
        let (angle_min, inc) = (c.angle_min_rad, c.angle_increment_rad);
        let (range_min_m, range_max_m) = (c.lidar_min_range_m, c.lidar_max_range_m);
        if !c.clean_lidar() {
            let (ranges_m, hits) = self.physical_scan(lp);
            return Scan { angle_min, angle_increment: inc, range_min_m, range_max_m, ranges_m, hits };
        }
        let mut ranges_m = Vec::with_capacity(n);
        let mut hits = Vec::with_capacity(n);
        let o = [lp[0], lp[1]];
        let max_r = c.lidar_max_range_m;
        let (noise_std, dropout, min_r) = (c.range_noise_std_m, c.dropout_prob, c.lidar_min_range_m);
        // Generous cast limit so that noise cannot pull a return from beyond the max range.
        let cast_max = max_r + 6.0 * noise_std.abs().min(1.0);
        let people: Vec<(P2, f64)> = self.people();
        for i in 0..n {
            let a = lp[2] + angle_min + i as f64 * inc;
            let d = [a.cos(), a.sin()];
            let u: f64 = self.sensor_rng.gen();
            let g = gaussian(&mut self.sensor_rng);
            let mut best = self.scene.raycast(o, d, cast_max, NO_OWNER).map(|h| (h.t, h.kind));
            for &(pc, pr) in &people {
                if let Some(t) = ray_circle(o, d, pc, pr) {
                    if t <= cast_max && best.is_none_or(|(bt, _)| t < bt) {
                        best = Some((t, HitKind::Person));
                    }
                }
            }
            let measured = best.map(|(t, k)| (t + noise_std * g, k));
            // ROS LaserScan conventions: a dropout or a reading below the minimum range is NaN
            // (no usable reading: it must not clear anything), nothing within range is +inf.
            match measured {
                _ if u < dropout => {
                    ranges_m.push(f32::NAN);
                    hits.push(HitKind::None);
                }
                Some((r, k)) if r >= min_r && r <= max_r => {
                    ranges_m.push(r as f32);
                    hits.push(k);
                }
                Some((r, _)) if r < min_r => {
                    ranges_m.push(f32::NAN);
                    hits.push(HitKind::None);
                }
                _ => {
                    ranges_m.push(f32::INFINITY);
                    hits.push(HitKind::None);
                }
            }
        }
        Scan { angle_min, angle_increment: inc, range_min_m, range_max_m, ranges_m, hits }
    }

    /// The first surface a ray meets beyond `min_t` (scene or people): range, kind, material and
    /// the cosine of the angle of incidence.
    fn surface(&self, o: P2, d: P2, min_t: f64, max_t: f64, people: &[(P2, f64)]) -> Option<(f64, HitKind, Material, f64)> {
        let mut best = self.scene.raycast_beyond(o, d, min_t, max_t, NO_OWNER).map(|h| (h.t, h.kind, h.material, h.normal));
        for &(pc, pr) in people {
            if let Some(t) = ray_circle(o, d, pc, pr) {
                if t > min_t && t <= max_t && best.is_none_or(|(bt, ..)| t < bt) {
                    let p = [o[0] + d[0] * t - pc[0], o[1] + d[1] * t - pc[1]];
                    let n = norm(p).max(1e-12);
                    best = Some((t, HitKind::Person, Material::Default, [p[0] / n, p[1] / n]));
                }
            }
        }
        best.map(|(t, k, m, n)| (t, k, m, (d[0] * n[0] + d[1] * n[1]).abs()))
    }

    /// One firing from `o` along angle `a`: through glass, then the no-return model.
    fn fire(&mut self, o: P2, a: f64, cast_max: f64, people: &[(P2, f64)]) -> Firing {
        let c = &self.config;
        if self.beam_rng.gen::<f64>() < c.dropout_prob {
            return Firing::Dropout;
        }
        let physical = c.white_range_m > 0.0;
        let white = c.white_range_m;
        let d = [a.cos(), a.sin()];
        let mut from = f64::NEG_INFINITY;
        for _ in 0..=MAX_GLASS_PANES {
            let Some((t, kind, material, cos_i)) = self.surface(o, d, from, cast_max, people) else {
                return Firing::Nothing;
            };
            if !physical {
                return Firing::Return(t, kind);
            }
            if material == Material::Glass {
                if cos_i >= GLASS_SPECULAR_RAD.cos() {
                    return Firing::Return(t, kind);
                }
                if self.beam_rng.gen::<f64>() < GLASS_TRANSMITTANCE {
                    from = t + 1e-6;
                    continue;
                }
                return Firing::Nothing;
            }
            let r_eff = white * (material.reflectance() * cos_i / WHITE_REFLECTANCE).sqrt();
            let p_miss = if r_eff > 0.0 { 1.0 / (1.0 + (-(t - r_eff) / (NO_RETURN_RAMP * r_eff)).exp()) } else { 1.0 };
            return if self.beam_rng.gen::<f64>() < p_miss { Firing::Nothing } else { Firing::Return(t, kind) };
        }
        Firing::Nothing
    }

    /// A realistic sweep: every beam fires [`SimConfig::samples_per_beam`] times across its
    /// angular bin, each firing off its nominal direction by the angular jitter, through glass
    /// and the no-return model ([`Sim::fire`]); a firing next to a depth edge (a neighbouring
    /// firing's surface [`MIXED_PIXEL_MIN_GAP_M`] or more away) whose footprint reaches the edge
    /// returns a mixed pixel between the two surfaces; then range noise; then each beam reports
    /// its nearest valid firing (`+inf` if none returned within range, NaN if none was usable).
    /// Labels: the surface the beam's reported firing came off (for a mixed pixel, its own
    /// surface: it lies nearer to it).
    fn physical_scan(&mut self, lp: [f64; 3]) -> (Vec<f32>, Vec<HitKind>) {
        let c = self.config.clone();
        let n = c.beams;
        let k = c.samples_per_beam.max(1);
        let o = [lp[0], lp[1]];
        let people = self.people();
        let max_noise = c.range_noise_std_m.abs() + c.range_noise_per_m.abs() * c.lidar_max_range_m;
        let cast_max = c.lidar_max_range_m + 6.0 * max_noise.min(1.0);
        let spacing = c.angle_increment_rad / k as f64;
        let mut firings = Vec::with_capacity(n * k);
        for i in 0..n {
            for j in 0..k {
                let nominal = lp[2] + c.angle_min_rad + i as f64 * c.angle_increment_rad + (j as f64 + 0.5 - k as f64 / 2.0) * spacing;
                let jitter = if c.angular_jitter_rad > 0.0 { c.angular_jitter_rad * gaussian(&mut self.beam_rng) } else { 0.0 };
                firings.push(self.fire(o, nominal + jitter, cast_max, &people));
            }
        }
        // Mixed pixels: the edge lies somewhere between two neighbouring firings; this firing's
        // footprint (half-width divergence / 2) reaches it with probability (divergence / 2) /
        // spacing, and then covers the far surface by a share f in (0, ½).
        let reach = if spacing > 0.0 { (c.beam_divergence_rad / 2.0 / spacing).min(1.0) } else { 0.0 };
        let mut ranges: Vec<Option<(f64, HitKind)>> = Vec::with_capacity(firings.len());
        let mut states = Vec::with_capacity(firings.len());
        for (idx, f) in firings.iter().enumerate() {
            let mut out = match *f {
                Firing::Return(t, kind) => Some((t, kind)),
                _ => None,
            };
            if let (Some((t, kind)), true) = (out, reach > 0.0) {
                for nb in [idx.wrapping_sub(1), idx + 1] {
                    let Some(Firing::Return(tn, _)) = firings.get(nb) else { continue };
                    if (tn - t).abs() >= MIXED_PIXEL_MIN_GAP_M && self.beam_rng.gen::<f64>() < reach {
                        let share: f64 = self.beam_rng.gen_range(0.0..0.5);
                        out = Some((t + share * (tn - t), kind));
                        break;
                    }
                }
            }
            ranges.push(out);
            states.push(*f);
        }
        let mut ranges_m = Vec::with_capacity(n);
        let mut hits = Vec::with_capacity(n);
        for i in 0..n {
            let mut best: Option<(f64, HitKind)> = None;
            let mut nothing = false;
            for j in 0..k {
                let idx = i * k + j;
                match ranges[idx] {
                    Some((t, kind)) => {
                        let sigma = c.range_noise_std_m + c.range_noise_per_m * t;
                        let r = t + sigma * gaussian(&mut self.beam_rng);
                        if r > c.lidar_max_range_m {
                            nothing = true;
                        } else if r >= c.lidar_min_range_m && best.is_none_or(|(b, _)| r < b) {
                            best = Some((r, kind));
                        }
                    }
                    None => nothing |= matches!(states[idx], Firing::Nothing),
                }
            }
            match best {
                Some((r, kind)) => {
                    ranges_m.push(r as f32);
                    hits.push(kind);
                }
                None => {
                    ranges_m.push(if nothing { f32::INFINITY } else { f32::NAN });
                    hits.push(HitKind::None);
                }
            }
        }
        (ranges_m, hits)
    }

    /// Fraction of target `i`'s outline samples the camera sees now (0 when out of the cone).
    pub fn visible_fraction(&self, i: usize) -> f64 {
        let Some(shape) = self.target_shapes.get(i) else {
            return 0.0;
        };
        let c = &self.config;
        let o = [self.pose[0], self.pose[1]];
        let samples = shape.outline_samples(DETECT_SAMPLES);
        let owner = TARGET_OWNER_BASE + i as u32;
        let mut visible = 0usize;
        for p in &samples {
            let v = sub(*p, o);
            let r = norm(v);
            if r.is_nan() || r > c.camera_range_m {
                continue;
            }
            if r > 1e-9 {
                let bearing = wrap_angle(v[1].atan2(v[0]) - self.pose[2]);
                if bearing.abs() > c.camera_fov_rad / 2.0 {
                    continue;
                }
                let d = [v[0] / r, v[1] / r];
                if self.cast(o, d, r - 1e-6, owner).is_some() {
                    continue;
                }
            }
            visible += 1;
        }
        visible as f64 / samples.len().max(1) as f64
    }

    /// The world bearings (radians) of target `i`'s outline samples ([`DETECT_SAMPLES`] of them)
    /// that a camera at `from` would see if it faced them: within the camera's range and in line
    /// of sight through the walls, obstacles and other targets, as [`Sim::visible_fraction`]
    /// checks them, but without the people (who move). The detector fires at a heading that has
    /// at least `detect_min_visible_fraction` of the samples within half the field of view
    /// ([`crate::oracle`]). A sample at `from` itself has bearing NaN (seen at every heading).
    pub fn static_sightlines(&self, i: usize, from: P2) -> Vec<f64> {
        let Some(shape) = self.target_shapes.get(i) else {
            return Vec::new();
        };
        let owner = TARGET_OWNER_BASE + i as u32;
        let mut out = Vec::new();
        for p in &shape.outline_samples(DETECT_SAMPLES) {
            let v = sub(*p, from);
            let r = norm(v);
            if r.is_nan() || r > self.config.camera_range_m {
                continue;
            }
            if r > 1e-9 {
                let d = [v[0] / r, v[1] / r];
                if self.scene.raycast(from, d, r - 1e-6, owner).is_some() {
                    continue;
                }
                out.push(v[1].atan2(v[0]));
            } else {
                out.push(f64::NAN);
            }
        }
        out
    }
}

/// A standard normal draw (Box–Muller, one of the pair).
pub(super) fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = 1.0 - rng.gen::<f64>(); // (0, 1]
    let u2: f64 = rng.gen();
    (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
}
