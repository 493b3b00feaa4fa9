//! Scan-to-map matching: corrects the odometry's drift by finding the pose near the
//! odometry-predicted one at which the scan's returns best fall on the LiDAR grid's occupied
//! cells. A correlative matcher (Olson 2009, "Real-time correlative scan matching";
//! Cartographer's real-time correlative matcher), in integer and fixed-point arithmetic only, so
//! x86_64 and the Cortex-M find the same pose bit for bit.
//!
//! 1. **Points.** The scan's returns within the LiDAR range (no "no return", no invalid beam),
//!    at most [`MATCH_MAX_POINTS`] of them spread evenly over the beams, as points in the
//!    sensor frame ([`Meters`]).
//! 2. **Coarse search.** For each of the `2·`[`MATCH_ANGLE_STEPS`]` + 1` headings around the
//!    prediction, [`MATCH_ANGLE_STEP`] apart, the points are rotated once and put in cells; each
//!    of the `(2·`[`MATCH_WINDOW_CELLS`]` + 1)²` translations is then a shift of those cells by
//!    whole cells. A point scores [`HIT_SCORE`] in an occupied cell, [`NEAR_SCORE`] next to one
//!    (one of its 4 neighbours: a return one cell off still counts), else 0.
//! 3. **Fine search.** Around the best coarse candidate: half-cell translations and
//!    quarter-step rotations (26 candidates), each point placed anew.
//! 4. **Choice.** A candidate's value is its score less a penalty for moving away from the
//!    prediction, a Gaussian prior on the odometry's increment since the last scan
//!    (`Motion::weights`: σ = 20 mm + 5 % of the distance driven, 0.25° + 5 % of the angle
//!    turned): `8192·score − n·(w_t·(hx² + hy²) + w_r·q²)` with `hx, hy` the offset in half
//!    cells and `q` in eighths of a degree. The prediction is the first candidate and a
//!    candidate replaces the best only if strictly better, in a fixed order: ties keep the one
//!    nearer the prediction, the same on every target. The penalty also keeps a featureless
//!    direction (a corridor's length, an empty map) at the prediction.
//! 5. **Sub-cell refinement.** From the fine best, [`MATCH_REFINE_ROUNDS`] rounds of
//!    hill-climbing over the 26 neighbours (a quarter cell and a sixteenth of a degree, halved
//!    when none is better) on the map's evidence ([`Occupancy::level`]) interpolated bilinearly
//!    between cell centres, with the same prior. Without it the pose moved in half-cell steps,
//!    so odometry drift went uncorrected until it reached about 5 cm and then jumped; in the
//!    simulator (VLP-16 profile, 2 %/m slip) it lifts the walls recovered in `office hard` seed 1
//!    from 66 % to 97 % (docs/experiments/real-lidar-maps.md).
//! 6. **Acceptance.** At least [`MATCH_MIN_POINTS`] points, and a best score of at least
//!    [`MATCH_MIN_SCORE_PER_MILLE`] ‰ of the most the points could score (every point in an
//!    occupied cell); otherwise the odometry's pose stands (counted by reason in [`MatchStats`]).
//!
//! **The field matcher** (`Config::scan_match_field`; what real logs
//! and a real robot use) keeps step 2 (with the prior at 3 % of its weights: the coarse search
//! only finds the basin) and replaces steps 3–5 by a least-squares fit, as Cartographer's Ceres
//! matcher: each point scores on a smooth field, the LiDAR grid's evidence ([`Occupancy::level`])
//! convolved with a uniform cubic B-spline (the 4 × 4 cells around the point; C², so the field
//! has a gradient everywhere within two cells of a wall), and Gauss–Newton minimises
//! `Σ (1 − f)²` plus a weak Gaussian prior on the translation towards the prediction and none on
//! the heading ([`FIELD_MAX_EVALS`] evaluations at most; a step that does not lower the cost is
//! halved). The 3 × 3 normal equations are solved by Cramer's rule in `i128` after scaling to
//! 28 bits: integers only, bit-identical on every target. A real odometry's heading error
//! (2.9° over under 5 s on raw MIT CSAIL, against 0.03 m of translation) is what the
//! hill-climbing matcher's motion prior kept and this one corrects
//! (docs/experiments/real-lidar-maps.md).
//!
//! Work per scan is bounded: at most [`MATCH_WORST_CASE_WORK`] point placements (each at most 5
//! cell reads; a field evaluation's 16 reads count as [`FIELD_WORK_PER_POINT`] placements),
//! counted in [`MatchStats::last_work`].

use crate::capacity::{BEAMS, MATCH_MAX_POINTS};
use crate::grid::{beam_angle, mm_to_meters, Cell, GridGeometry, LidarGrid};
use crate::scan::{BeamScan, RANGE_INVALID, RANGE_NO_RETURN};
use fixed_point::{cos, mul_unit, sin, BinaryAngle, Meters, Pose2};

/// The coarse search's translations: ±3 cells (±0.3 m) in x and in y around the prediction.
pub const MATCH_WINDOW_CELLS: i32 = 3;
/// The coarse search's headings: ±12 steps of [`MATCH_ANGLE_STEP`] (±6°) around the prediction.
pub const MATCH_ANGLE_STEPS: i32 = 12;
/// The coarse search's heading step: 0.5°.
pub const MATCH_ANGLE_STEP: BinaryAngle = BinaryAngle::from_fraction(1, 720);
/// The fine search's heading step: an eighth of a degree (a quarter of [`MATCH_ANGLE_STEP`]).
pub const MATCH_FINE_ANGLE_STEP: BinaryAngle = BinaryAngle::from_fraction(1, 2880);
/// The fine search's translation step: half a cell (0.05 m).
pub const MATCH_HALF_CELL: Meters = Meters::from_bits(3277);
/// Fewest points a scan must give to be matched.
pub const MATCH_MIN_POINTS: usize = 30;
/// Rounds of the sub-cell refinement (26 candidates each).
pub const MATCH_REFINE_ROUNDS: u32 = 4;
/// The least score, in thousandths of the most the points could score, to accept a match.
pub const MATCH_MIN_SCORE_PER_MILLE: u32 = 500;
/// The controller matches no scan until this many are in the map (the first scans would be
/// matched against an empty or nearly empty grid).
pub const MATCH_WARMUP_SCANS: u32 = 3;
/// A point's score in an occupied cell.
pub const HIT_SCORE: u32 = 4;
/// A point's score next to an occupied cell (4-neighbourhood).
pub const NEAR_SCORE: u32 = 2;

/// The field refinement's translation prior, Q16 per cell² per point (a weak pull towards the
/// prediction; there is none on the heading: a real odometry's heading is what drifts).
pub const FIELD_PRIOR_T: i64 = 4096;
/// The field matcher's coarse-search prior, percent of `Motion::weights` (it only finds the
/// basin; the hill-climbing matcher uses them whole).
pub const FIELD_COARSE_PRIOR_PCT: i64 = 3;

const COARSE_TRANSLATIONS: u32 = ((2 * MATCH_WINDOW_CELLS + 1) * (2 * MATCH_WINDOW_CELLS + 1)) as u32;
const COARSE_HEADINGS: u32 = (2 * MATCH_ANGLE_STEPS + 1) as u32;
const FINE_CANDIDATES: u32 = 26;

/// Most point placements one scan's match can take: every point at every coarse and fine
/// candidate (each placement reads at most 5 cells). The field matcher's coarse search and
/// [`FIELD_MAX_EVALS`] field evaluations take less ([`FIELD_WORST_CASE_WORK`]).
pub const MATCH_WORST_CASE_WORK: u32 =
    MATCH_MAX_POINTS as u32 * (COARSE_HEADINGS * COARSE_TRANSLATIONS + FINE_CANDIDATES + 1 + 26 * MATCH_REFINE_ROUNDS);

/// Most point placements the field matcher's match can take: the coarse search, then
/// [`FIELD_MAX_EVALS`] field evaluations of every point ([`FIELD_WORK_PER_POINT`] each).
pub const FIELD_WORST_CASE_WORK: u32 =
    MATCH_MAX_POINTS as u32 * (COARSE_HEADINGS * COARSE_TRANSLATIONS + FIELD_MAX_EVALS * FIELD_WORK_PER_POINT);
const _: () = assert!(FIELD_WORST_CASE_WORK <= MATCH_WORST_CASE_WORK);

/// What the matcher reads: whether a cell holds an obstacle. Out-of-bounds cells are not
/// occupied.
pub trait Occupancy {
    /// Is cell `(x, y)` occupied?
    fn occupied(&self, x: i32, y: i32) -> bool;

    /// Which of the [`SPAN`] cells `(x + k, y)`, `k` in `0..SPAN`, are occupied, spread two bits
    /// a cell: bit `2k` is set if cell `(x + k, y)` is occupied, every odd bit is clear (the
    /// packed grid's own layout, so that a grid can answer from its bytes).
    #[inline]
    fn occupied_span(&self, x: i32, y: i32) -> u32 {
        crate::grid::spread_span(SPAN, |k| self.occupied(x.saturating_add(k), y))
    }

    /// How surely cell `(x, y)` holds an obstacle, 0 ..= [`LEVEL_MAX`] (the sub-cell refinement
    /// interpolates it): by default [`LEVEL_MAX`] if occupied, else 0.
    #[inline]
    fn level(&self, x: i32, y: i32) -> u32 {
        if self.occupied(x, y) {
            LEVEL_MAX
        } else {
            0
        }
    }
}

/// The highest [`Occupancy::level`]: the LiDAR grid's highest evidence.
pub const LEVEL_MAX: u32 = crate::grid::EVIDENCE_MAX as u32;

/// Cells a row read of [`Occupancy::occupied_span`] covers: the coarse window's translations
/// and a neighbour on either side.
pub const SPAN: usize = 2 * MATCH_WINDOW_CELLS as usize + 3;

impl Occupancy for LidarGrid {
    #[inline]
    fn occupied(&self, x: i32, y: i32) -> bool {
        self.get(x, y) == Cell::Occupied
    }

    #[inline]
    fn occupied_span(&self, x: i32, y: i32) -> u32 {
        self.grid.occupied_span::<SPAN>(x, y)
    }

    /// The cell's evidence if it is occupied (a wall many scans drew counts more than one drawn
    /// once), else 0.
    #[inline]
    fn level(&self, x: i32, y: i32) -> u32 {
        self.evidence.get(x, y).filter(|&e| e >= crate::grid::EVIDENCE_MIN_OCCUPIED).map_or(0, |e| e as u32)
    }
}

/// Why a scan was not matched (the odometry's pose stands).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MatchRefusal {
    /// Fewer than [`MATCH_MIN_POINTS`] returns.
    TooFewPoints(u16),
    /// The best score is below [`MATCH_MIN_SCORE_PER_MILLE`] (‰ of the most possible): too
    /// little structure in the map where the scan looks (an empty map at the start).
    LowScore(u16),
}

/// A match: the corrected pose and how well it fits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Match {
    /// The corrected pose.
    pub pose: Pose2,
    /// Its score, ‰ of the most the points could score.
    pub score_per_mille: u16,
    /// Points matched.
    pub points: u16,
}

/// Counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MatchStats {
    /// Scans matched (a correction accepted, possibly zero).
    pub matched: u32,
    /// Scans with fewer than [`MATCH_MIN_POINTS`] returns.
    pub too_few_points: u32,
    /// Scans whose best score was below [`MATCH_MIN_SCORE_PER_MILLE`].
    pub low_score: u32,
    /// Point placements of the last match (at most [`MATCH_WORST_CASE_WORK`]).
    pub last_work: u32,
    /// The last match's score, ‰.
    pub last_score_per_mille: u16,
    /// The score of the last matched scan at the predicted pose, ‰ (what the match improved on).
    pub last_predicted_per_mille: u16,
    /// How far the last accepted match moved and turned the pose from the prediction.
    pub last_move: Motion,
}

/// The scan matcher's working memory: the points of the scan being matched and their cells.
#[derive(Clone)]
pub struct ScanMatcher {
    points: [(Meters, Meters); MATCH_MAX_POINTS],
    cells: [(i32, i32); MATCH_MAX_POINTS],
    n: usize,
    /// Refine with the field matcher (else hill-climbing).
    pub field: bool,
    /// Counters.
    pub stats: MatchStats,
}

impl Default for ScanMatcher {
    fn default() -> Self {
        Self::new()
    }
}

#[inline]
fn point_score(map: &impl Occupancy, x: i32, y: i32) -> u32 {
    if map.occupied(x, y) {
        HIT_SCORE
    } else if map.occupied(x + 1, y) || map.occupied(x - 1, y) || map.occupied(x, y + 1) || map.occupied(x, y - 1) {
        NEAR_SCORE
    } else {
        0
    }
}

/// Side of the coarse search's window of translations.
const WINDOW: usize = (2 * MATCH_WINDOW_CELLS + 1) as usize;

/// The coarse score of `cells` shifted by every translation of the window at once:
/// `scores[dy + W][dx + W] = Σ point_score(cell + (dx, dy))` (W = [`MATCH_WINDOW_CELLS`]). The
/// same sums as scoring each translation on its own, but each point reads the `(2W + 3)²` cells
/// around it once, as bit rows, instead of up to five cells per translation.
fn window_scores(map: &impl Occupancy, cells: &[(i32, i32)]) -> [[u32; WINDOW]; WINDOW] {
    const R: i32 = MATCH_WINDOW_CELLS + 1;
    let mut scores = [[0u32; WINDOW]; WINDOW];
    for &(cx, cy) in cells {
        // rows[j] bit 2i: cell (cx − R + i, cy − R + j) is occupied.
        let x0 = cx.saturating_sub(R);
        let rows: [u32; SPAN] = core::array::from_fn(|j| map.occupied_span(x0, cy.saturating_add(j as i32 - R)));
        for (j, line) in scores.iter_mut().enumerate() {
            // Row j + 1 of `rows` is the shift dy = j − W; bit 2(i + 1) the shift dx = i − W.
            let hit = rows[j + 1];
            let near = (hit << 2) | (hit >> 2) | rows[j] | rows[j + 2];
            for (i, s) in line.iter_mut().enumerate() {
                let bit = 1 << (2 * i + 2);
                *s += if hit & bit != 0 {
                    HIT_SCORE
                } else if near & bit != 0 {
                    NEAR_SCORE
                } else {
                    0
                };
            }
        }
    }
    scores
}

/// Point `(px, py)` of a frame at `(x, y)` whose heading has sine `s` and cosine `c`, in the
/// parent frame: [`Pose2::transform_point`] with the sine and cosine computed once per heading.
#[inline]
fn place_point(x: Meters, y: Meters, s: fixed_point::Unit, c: fixed_point::Unit, px: Meters, py: Meters) -> (Meters, Meters) {
    (x.saturating_add(mul_unit(px, c)).saturating_sub(mul_unit(py, s)), y.saturating_add(mul_unit(px, s)).saturating_add(mul_unit(py, c)))
}

/// How far the odometry moved since the last scan: what the prediction's uncertainty grows
/// with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Motion {
    /// Distance driven, millimetres.
    pub dist_mm: u32,
    /// Angle turned, thousandths of a degree.
    pub turn_mdeg: u32,
}

/// The least motion since the last match for a scan to be matched (either one): 50 mm or 1°.
pub const MATCH_MIN_MOTION: Motion = Motion { dist_mm: 50, turn_mdeg: 1_000 };

impl Motion {
    /// The motion of a step `(dx, dy, dθ)` (a pose relative to another): its length and the
    /// absolute turn.
    pub fn of_step(dx: Meters, dy: Meters, turn: BinaryAngle) -> Motion {
        let dist = fixed_point::hypot(dx, dy);
        Motion {
            dist_mm: ((dist.to_bits().max(0) as i64 * 1000) >> 16) as u32,
            turn_mdeg: (((turn.0 as i64).unsigned_abs() * 360_000) >> 32) as u32,
        }
    }

    /// Nothing known about the motion (the first matched scan): a weak prior, as after 5 m and
    /// 90°.
    pub const UNKNOWN: Motion = Motion { dist_mm: 5_000, turn_mdeg: 90_000 };

    /// The penalty weights `(w_t, w_r)` per point, per half cell² and per eighth of a degree²:
    /// a Gaussian prior on the odometry's increment with σ_t = 20 mm + 5 % of the distance and
    /// σ_r = 0.25° + 5 % of the turn, scaled so that at σ_t = 25 mm a one-cell move costs half
    /// a hit per point and at σ_r = 0.5° one degree costs half a hit per point.
    fn weights(&self) -> (i64, i64) {
        let st = 20 + self.dist_mm.min(100_000) as i64 / 20;
        let sr = 250 + self.turn_mdeg.min(360_000) as i64 / 20;
        ((1024 * 625 / (st * st)).max(1), (64 * 250_000 / (sr * sr)).max(1))
    }
}

/// A candidate's value: `8192·score − n·(w_t·(hx² + hy²) + w_r·q²)` (offsets in half cells and
/// eighths of a degree; the weights from `Motion::weights`).
#[inline]
fn value(score: u32, n: usize, hx: i32, hy: i32, q: i32, w: (i64, i64)) -> i64 {
    8192 * score as i64 - n as i64 * (w.0 * (hx * hx + hy * hy) as i64 + w.1 * (q * q) as i64)
}

/// The field refinement's rotation unit: 1/`FIELD_RHO_CELLS` rad (a point this many cells away
/// moves a cell per unit), so that the normal matrix's rotation entries are of the translation
/// entries' size.
pub const FIELD_RHO_CELLS: i64 = 64;
/// Most field evaluations of the Gauss–Newton refinement (each places every point once and
/// reads 16 cells per point).
pub const FIELD_MAX_EVALS: u32 = 10;
/// A field evaluation's work per point in point placements (16 cell reads against 5, and the
/// B-spline weights).
pub const FIELD_WORK_PER_POINT: u32 = 4;

/// The uniform cubic B-spline's weights and derivatives (Q16) for the 4 cells `i0 − 1 ..= i0 + 2`
/// around a point at fraction `t` (Q16) past cell centre `i0`.
#[inline]
fn bspline(t: i64) -> ([i64; 4], [i64; 4]) {
    let one = 1i64 << 16;
    let t2 = (t * t) >> 16;
    let t3 = (t2 * t) >> 16;
    let s = one - t;
    let s2 = (s * s) >> 16;
    let s3 = (s2 * s) >> 16;
    (
        [s3 / 6, (3 * t3 - 6 * t2 + 4 * one) / 6, (-3 * t3 + 3 * t2 + 3 * t + one) / 6, t3 / 6],
        [-s2 / 2, (3 * t2 - 4 * t) / 2, (-3 * t2 + 2 * t + one) / 2, t2 / 2],
    )
}

/// Solves the 3 × 3 system `h·δ = g` (Cramer's rule in `i128`, after scaling both down to 28
/// bits): `δ` in Q16, or `None` if `h` is singular.
fn solve3(h: &[[i64; 3]; 3], g: &[i64; 3]) -> Option<[i64; 3]> {
    let big = h.iter().flatten().chain(g.iter()).map(|v| v.unsigned_abs()).max().unwrap_or(0);
    let shift = (64 - big.leading_zeros()).saturating_sub(28);
    let m: [[i128; 3]; 3] = core::array::from_fn(|a| core::array::from_fn(|b| (h[a][b] >> shift) as i128));
    let r: [i128; 3] = core::array::from_fn(|a| (g[a] >> shift) as i128);
    let det3 = |m: &[[i128; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det3(&m);
    if d <= 0 {
        return None;
    }
    let mut out = [0i64; 3];
    for k in 0..3 {
        let mut mk = m;
        for a in 0..3 {
            mk[a][k] = r[a];
        }
        out[k] = ((det3(&mk) << 16) / d).clamp(i64::MIN as i128, i64::MAX as i128) as i64;
    }
    Some(out)
}

impl ScanMatcher {
    /// An empty matcher.
    pub const fn new() -> Self {
        Self {
            points: [(Meters::ZERO, Meters::ZERO); MATCH_MAX_POINTS],
            cells: [(0, 0); MATCH_MAX_POINTS],
            n: 0,
            field: false,
            stats: MatchStats {
                matched: 0,
                too_few_points: 0,
                low_score: 0,
                last_work: 0,
                last_score_per_mille: 0,
                last_predicted_per_mille: 0,
                last_move: Motion { dist_mm: 0, turn_mdeg: 0 },
            },
        }
    }

    /// Forgets the counters.
    pub fn reset(&mut self) {
        self.n = 0;
        self.stats = MatchStats::default();
    }

    /// Takes the returns of `scan` within `max_range` as sensor-frame points, subsampled to at
    /// most [`MATCH_MAX_POINTS`].
    fn take_points(&mut self, scan: &BeamScan, max_range: Meters) -> usize {
        let usable = |r: u16| r != RANGE_INVALID && r != RANGE_NO_RETURN && mm_to_meters(r) < max_range;
        let total = scan.ranges_mm.iter().filter(|&&r| usable(r)).count();
        self.n = 0;
        // Evenly spread: `min(total, MATCH_MAX_POINTS)` of the `total` returns (Bresenham).
        let mut acc = 0usize;
        for b in 0..BEAMS {
            let r = scan.ranges_mm[b];
            if !usable(r) {
                continue;
            }
            acc += MATCH_MAX_POINTS;
            if acc >= total && self.n < MATCH_MAX_POINTS {
                acc -= total;
                let a = beam_angle(b);
                // Where the grid puts the return's hit (`grid::HIT_DEPTH_MM` behind the surface):
                // at the measured range, a wall face on a cell boundary would pull every match
                // a cell towards the walls.
                let len = mm_to_meters(r).saturating_add(Meters::from_bits(((crate::grid::HIT_DEPTH_MM << 16) / 1000) as i32));
                self.points[self.n] = (mul_unit(len, cos(a)), mul_unit(len, sin(a)));
                self.n += 1;
            }
        }
        self.n
    }

    /// The score of the points placed at `(x, y, theta)`, each point placed anew.
    fn score_at(&self, map: &impl Occupancy, geom: &GridGeometry, x: Meters, y: Meters, theta: BinaryAngle) -> u32 {
        let (sn, cs) = (sin(theta), cos(theta));
        let mut s = 0;
        for &(px, py) in &self.points[..self.n] {
            let (wx, wy) = place_point(x, y, sn, cs, px, py);
            let (cx, cy) = geom.cell_of(wx, wy);
            s += point_score(map, cx, cy);
        }
        s
    }

    /// The points placed at `(x, y, theta)` scored on the map's [`Occupancy::level`] interpolated
    /// bilinearly between cell centres (Q16 levels summed): smooth below a cell, so that a
    /// pose can be refined by less than a cell.
    fn smooth_at(&self, map: &impl Occupancy, geom: &GridGeometry, x: Meters, y: Meters, theta: BinaryAngle) -> u64 {
        let (sn, cs) = (sin(theta), cos(theta));
        let mut s = 0u64;
        for &(px, py) in &self.points[..self.n] {
            let (wx, wy) = place_point(x, y, sn, cs, px, py);
            // Cell coordinates in Q16 with cell centres on whole numbers.
            let u = (wx.to_bits() as i64 - geom.origin_x.to_bits() as i64) * crate::capacity::CELLS_PER_METER - (1 << 15);
            let v = (wy.to_bits() as i64 - geom.origin_y.to_bits() as i64) * crate::capacity::CELLS_PER_METER - (1 << 15);
            let (x0, y0) = (u.div_euclid(1 << 16), v.div_euclid(1 << 16));
            let (fx, fy) = (u.rem_euclid(1 << 16) as u64, v.rem_euclid(1 << 16) as u64);
            let (Ok(x0), Ok(y0)) = (i32::try_from(x0), i32::try_from(y0)) else { continue };
            let m = |dx: i32, dy: i32| map.level(x0.saturating_add(dx), y0.saturating_add(dy)) as u64;
            let top = (65_536 - fx) * m(0, 0) + fx * m(1, 0);
            let bottom = (65_536 - fx) * m(0, 1) + fx * m(1, 1);
            s += ((65_536 - fy) * top + fy * bottom) >> 16;
        }
        s
    }

    /// Gauss–Newton on the smooth field from `start`, with a Gaussian prior towards `predicted`
    /// (weight [`FIELD_PRIOR_T`] per point on the translation): at most [`FIELD_MAX_EVALS`]
    /// evaluations; a step that does not lower the cost is halved. Returns the pose and the work.
    fn refine_on_field(
        &self,
        map: &impl Occupancy,
        geom: &GridGeometry,
        predicted: &Pose2,
        start: (Meters, Meters, BinaryAngle),
    ) -> ((Meters, Meters, BinaryAngle), u32) {
        let n = self.n as i64;
        // Offsets from the prediction: Q16 cells and Q16 ρ.
        let offsets = |p: &(Meters, Meters, BinaryAngle)| -> [i64; 3] {
            [
                (p.0.to_bits() as i64 - predicted.x.to_bits() as i64) * crate::capacity::CELLS_PER_METER,
                (p.1.to_bits() as i64 - predicted.y.to_bits() as i64) * crate::capacity::CELLS_PER_METER,
                // Binary angle (2³² a turn) to Q16 radians times FIELD_RHO_CELLS.
                ((p.2 - predicted.theta).0 as i64 * FIELD_RHO_CELLS * 411_775) >> 32,
            ]
        };
        let eval = |p: &(Meters, Meters, BinaryAngle)| {
            let (mut cost, mut h, mut g) = self.field_at(map, geom, p.0, p.1, p.2);
            let e = offsets(p);
            let wts = [FIELD_PRIOR_T, FIELD_PRIOR_T, 0];
            for a in 0..3 {
                // cost + n·w·e² (Q32), H + n·w, g − n·w·e.
                cost += n * wts[a] * ((e[a] * e[a]) >> 16);
                h[a][a] += (n * wts[a]) << 16;
                g[a] -= n * wts[a] * e[a];
            }
            (cost, h, g)
        };
        let mut work = 0u32;
        let step_of = |h: &[[i64; 3]; 3], g: &[i64; 3]| -> [i64; 3] {
            let d = solve3(h, g).unwrap_or([0; 3]);
            // At most a cell and half a ρ unit (≈ 0.45°) per step.
            [d[0].clamp(-65_536, 65_536), d[1].clamp(-65_536, 65_536), d[2].clamp(-32_768, 32_768)]
        };
        let mut at = start;
        let (mut cost, h, g) = eval(&at);
        work += self.n as u32 * FIELD_WORK_PER_POINT;
        let mut delta = step_of(&h, &g);
        let mut halvings = 0u32;
        for _ in 1..FIELD_MAX_EVALS {
            let d = delta.map(|v| v >> halvings);
            // Below 1/256 cell and 1/256 ρ unit: converged.
            if d.iter().all(|v| v.abs() < 256) {
                break;
            }
            let cand = (
                at.0.saturating_add(Meters::from_bits((d[0] / crate::capacity::CELLS_PER_METER) as i32)),
                at.1.saturating_add(Meters::from_bits((d[1] / crate::capacity::CELLS_PER_METER) as i32)),
                // Q16 ρ to binary angle: × 2³² / (2π · 2¹⁶ · FIELD_RHO_CELLS).
                at.2 + BinaryAngle(((d[2] * 683_565_276) >> 16) as i32 / FIELD_RHO_CELLS as i32),
            );
            let (c, h, g) = eval(&cand);
            work += self.n as u32 * FIELD_WORK_PER_POINT;
            if c < cost {
                (at, cost, halvings) = (cand, c, 0);
                delta = step_of(&h, &g);
            } else {
                halvings += 1;
            }
        }
        (at, work)
    }

    /// The points placed at `(x, y, theta)` on the smooth field (the map's levels convolved with
    /// a cubic B-spline, 4 × 4 cells around each point): the cost `Σ (1 − f)²` (Q32), the normal
    /// matrix `H = Σ J Jᵀ` and `g = Σ J (1 − f)` (Q32) of the Gauss–Newton step in
    /// `(x, y)` cells and `ρ` = 1/[`FIELD_RHO_CELLS`] rad.
    fn field_at(
        &self,
        map: &impl Occupancy,
        geom: &GridGeometry,
        x: Meters,
        y: Meters,
        theta: BinaryAngle,
    ) -> (i64, [[i64; 3]; 3], [i64; 3]) {
        let (sn, cs) = (sin(theta), cos(theta));
        let mut cost = 0i64;
        let mut h = [[0i64; 3]; 3];
        let mut g = [0i64; 3];
        for &(px, py) in &self.points[..self.n] {
            let (wx, wy) = place_point(x, y, sn, cs, px, py);
            // Cell coordinates in Q16 with cell centres on whole numbers.
            let u = (wx.to_bits() as i64 - geom.origin_x.to_bits() as i64) * crate::capacity::CELLS_PER_METER - (1 << 15);
            let v = (wy.to_bits() as i64 - geom.origin_y.to_bits() as i64) * crate::capacity::CELLS_PER_METER - (1 << 15);
            let (x0, y0) = (u.div_euclid(1 << 16), v.div_euclid(1 << 16));
            let (Ok(x0), Ok(y0)) = (i32::try_from(x0), i32::try_from(y0)) else { continue };
            let (wxs, dxs) = bspline(u.rem_euclid(1 << 16));
            let (wys, dys) = bspline(v.rem_euclid(1 << 16));
            let (mut f, mut fu, mut fv) = (0i64, 0i64, 0i64);
            for j in 0..4 {
                let (mut a, mut b) = (0i64, 0i64);
                for i in 0..4 {
                    let l = map.level(x0.saturating_add(i as i32 - 1), y0.saturating_add(j as i32 - 1));
                    let l = l as i64;
                    a += wxs[i] * l;
                    b += dxs[i] * l;
                }
                f += wys[j] * a;
                fu += wys[j] * b;
                fv += dys[j] * a;
            }
            // Q16, 1 = every cell of the support at LEVEL_MAX.
            let scale = LEVEL_MAX as i64 * 65_536;
            let (f, fu, fv) = (f / scale, fu / scale, fv / scale);
            let r = (65_536 - f).max(0);
            // The point's offset from the pose, Q16 cells.
            let rx = (wx.to_bits() as i64 - x.to_bits() as i64) * crate::capacity::CELLS_PER_METER;
            let ry = (wy.to_bits() as i64 - y.to_bits() as i64) * crate::capacity::CELLS_PER_METER;
            let fr = ((fv * rx - fu * ry) >> 16) / FIELD_RHO_CELLS;
            let jac = [fu, fv, fr];
            cost += r * r;
            for a in 0..3 {
                g[a] += jac[a] * r;
                for b in a..3 {
                    h[a][b] += jac[a] * jac[b];
                }
            }
        }
        h[1][0] = h[0][1];
        h[2][0] = h[0][2];
        h[2][1] = h[1][2];
        (cost, h, g)
    }

    /// Matches `scan`, taken at `predicted` (the odometry's pose, corrected by the matches so
    /// far), against `map`. Returns the corrected pose, or why the odometry's stands.
    pub fn match_scan(
        &mut self,
        map: &impl Occupancy,
        geom: &GridGeometry,
        predicted: &Pose2,
        scan: &BeamScan,
        max_range: Meters,
        motion: Motion,
    ) -> Result<Match, MatchRefusal> {
        let w = motion.weights();
        let w = if self.field { ((w.0 * FIELD_COARSE_PRIOR_PCT / 100).max(1), (w.1 * FIELD_COARSE_PRIOR_PCT / 100).max(1)) } else { w };
        let n = self.take_points(scan, max_range);
        self.stats.last_work = 0;
        if n < MATCH_MIN_POINTS {
            self.stats.too_few_points += 1;
            return Err(MatchRefusal::TooFewPoints(n as u16));
        }
        let mut work = 0u32;
        // Coarse: (value, score, k, dx, dy); the prediction first.
        let mut best: Option<(i64, u32, i32, i32, i32)> = None;
        let mut predicted_score = 0u32;
        for step in 0..COARSE_HEADINGS as i32 {
            // 0, −1, +1, −2, +2, …: nearer headings first.
            let k = if step % 2 == 0 { step / 2 } else { -(step + 1) / 2 };
            let theta = predicted.theta + BinaryAngle(MATCH_ANGLE_STEP.0.wrapping_mul(k));
            let (sn, cs) = (sin(theta), cos(theta));
            for i in 0..n {
                let (wx, wy) = place_point(predicted.x, predicted.y, sn, cs, self.points[i].0, self.points[i].1);
                self.cells[i] = geom.cell_of(wx, wy);
            }
            let scores = window_scores(map, &self.cells[..n]);
            for ty in 0..(2 * MATCH_WINDOW_CELLS + 1) {
                for tx in 0..(2 * MATCH_WINDOW_CELLS + 1) {
                    let dx = if tx % 2 == 0 { tx / 2 } else { -(tx + 1) / 2 };
                    let dy = if ty % 2 == 0 { ty / 2 } else { -(ty + 1) / 2 };
                    let s = scores[(dy + MATCH_WINDOW_CELLS) as usize][(dx + MATCH_WINDOW_CELLS) as usize];
                    work += n as u32;
                    let v = value(s, n, 2 * dx, 2 * dy, 4 * k, w);
                    if best.is_none() {
                        predicted_score = s;
                    }
                    if best.is_none_or(|b| v > b.0) {
                        best = Some((v, s, k, dx, dy));
                    }
                }
            }
        }
        let (_, coarse_score, k, dx, dy) = best.expect("at least one candidate");
        if self.field {
            let start = (
                predicted.x.saturating_add(Meters::from_bits(MATCH_HALF_CELL.to_bits().wrapping_mul(2 * dx))),
                predicted.y.saturating_add(Meters::from_bits(MATCH_HALF_CELL.to_bits().wrapping_mul(2 * dy))),
                predicted.theta + BinaryAngle(MATCH_ANGLE_STEP.0.wrapping_mul(k)),
            );
            let (at, w_field) = self.refine_on_field(map, geom, predicted, start);
            work += w_field;
            return self.finish(predicted, at, coarse_score, predicted_score, n, work);
        }
        // Fine: half cells and eighth degrees around the coarse best.
        let (hx0, hy0, q0) = (2 * dx, 2 * dy, 4 * k);
        let mut fine = (value(coarse_score, n, hx0, hy0, q0, w), coarse_score, hx0, hy0, q0);
        let place = |h: i32| Meters::from_bits(MATCH_HALF_CELL.to_bits().wrapping_mul(h));
        for fq in [0, -1, 1] {
            for fy in [0, -1, 1] {
                for fx in [0, -1, 1] {
                    if fx == 0 && fy == 0 && fq == 0 {
                        continue;
                    }
                    let (hx, hy, q) = (hx0 + fx, hy0 + fy, q0 + 2 * fq);
                    let theta = predicted.theta + BinaryAngle(MATCH_FINE_ANGLE_STEP.0.wrapping_mul(q));
                    let s = self.score_at(map, geom, predicted.x.saturating_add(place(hx)), predicted.y.saturating_add(place(hy)), theta);
                    work += n as u32;
                    let v = value(s, n, hx, hy, q, w);
                    if v > fine.0 {
                        fine = (v, s, hx, hy, q);
                    }
                }
            }
        }
        let (_, score, hx, hy, q) = fine;
        // Sub-cell refinement: hill-climbing on the interpolated levels from the fine best, in
        // steps of a quarter cell and a sixteenth of a degree, halved when no neighbour is better.
        let mut at = (
            predicted.x.saturating_add(place(hx)),
            predicted.y.saturating_add(place(hy)),
            predicted.theta + BinaryAngle(MATCH_FINE_ANGLE_STEP.0.wrapping_mul(q)),
        );
        let smooth_value = |s: u64, p: &(Meters, Meters, BinaryAngle)| -> i64 {
            // Offsets in 1/1024 half cells and 1/1024 eighths of a degree, as `value` weighs them.
            let hx = (p.0.to_bits() as i64 - predicted.x.to_bits() as i64) * 1024 / MATCH_HALF_CELL.to_bits() as i64;
            let hy = (p.1.to_bits() as i64 - predicted.y.to_bits() as i64) * 1024 / MATCH_HALF_CELL.to_bits() as i64;
            let q = (p.2 - predicted.theta).0 as i64 * 1024 / MATCH_FINE_ANGLE_STEP.0 as i64;
            // A level-LEVEL_MAX point (Q16) is worth a hit's 8192·HIT_SCORE.
            (s as i64 * 8192 * HIT_SCORE as i64) / (LEVEL_MAX as i64 * 65_536)
                - n as i64 * ((w.0 * (hx * hx + hy * hy) + w.1 * q * q) >> 20)
        };
        let mut best_v = smooth_value(self.smooth_at(map, geom, at.0, at.1, at.2), &at);
        work += n as u32;
        let (mut step_t, mut step_q) = (MATCH_HALF_CELL.to_bits() / 2, MATCH_FINE_ANGLE_STEP.0 / 2);
        for _ in 0..MATCH_REFINE_ROUNDS {
            let mut moved = false;
            let centre = at;
            for fq in [0, -1, 1] {
                for fy in [0, -1, 1] {
                    for fx in [0, -1, 1] {
                        if fx == 0 && fy == 0 && fq == 0 {
                            continue;
                        }
                        let p = (
                            centre.0.saturating_add(Meters::from_bits(step_t * fx)),
                            centre.1.saturating_add(Meters::from_bits(step_t * fy)),
                            centre.2 + BinaryAngle(step_q * fq),
                        );
                        let v = smooth_value(self.smooth_at(map, geom, p.0, p.1, p.2), &p);
                        work += n as u32;
                        if v > best_v {
                            (best_v, at, moved) = (v, p, true);
                        }
                    }
                }
            }
            if !moved {
                (step_t, step_q) = (step_t / 2, step_q / 2);
            }
        }
        self.finish(predicted, at, score, predicted_score, n, work)
    }

    /// Accepts or refuses the match at `at` whose (coarse or fine) score is `score`.
    fn finish(
        &mut self,
        predicted: &Pose2,
        at: (Meters, Meters, BinaryAngle),
        score: u32,
        predicted_score: u32,
        n: usize,
        work: u32,
    ) -> Result<Match, MatchRefusal> {
        self.stats.last_work = work;
        let per_mille = (score as u64 * 1000 / (HIT_SCORE as u64 * n as u64)) as u16;
        self.stats.last_score_per_mille = per_mille;
        self.stats.last_predicted_per_mille = (predicted_score as u64 * 1000 / (HIT_SCORE as u64 * n as u64)) as u16;
        if (per_mille as u32) < MATCH_MIN_SCORE_PER_MILLE {
            self.stats.low_score += 1;
            return Err(MatchRefusal::LowScore(per_mille));
        }
        self.stats.matched += 1;
        let pose = Pose2::new(at.0, at.1, at.2);
        self.stats.last_move = Motion::of_step(at.0.saturating_sub(predicted.x), at.1.saturating_sub(predicted.y), at.2 - predicted.theta);
        Ok(Match { pose, score_per_mille: per_mille, points: n as u16 })
    }
}

#[cfg(test)]
mod tests;
