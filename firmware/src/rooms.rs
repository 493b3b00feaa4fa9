//! Rooms, corridors and doorways of the LiDAR map, segmented online.
//!
//! The segmentation is the distance-transform / Voronoi family of room segmentation (doorways are
//! the narrow places of free space; Gao et al.'s exploration with object proposals separates
//! rooms from corridors the same way), done with integers on a coarse lattice so that it is
//! deterministic, allocation-free and bounded:
//!
//! 1. **Coarse lattice.** 2 × 2 cells (0.2 m) make a coarse cell, [`COARSE_CELLS`]² of them: it
//!    is *blocked* if any of its cells is occupied, *free* if at least 3 of its 4 cells are free
//!    (and none occupied), else *unknown*.
//! 2. **Clearance.** A two-pass 3-4 chamfer distance transform (Borgefors) from the blocked
//!    coarse cells only, in units of a third of a coarse cell, saturated at [`CLEARANCE_MAX`]
//!    (8.4 m). Unknown cells are *not* obstacles: a frontier (free next to unknown) must not look
//!    like a doorway.
//! 3. **Room cores.** Free coarse cells with clearance ≥ [`CORE_CLEARANCE`] (4 coarse cells,
//!    0.8 m from the centre of a blocked coarse cell). The built-in worlds have doors of 1.0, 1.1
//!    and 1.2 m and corridors of 2.0 and 2.5 m (`host/sim/src/worlds/`), so the brief's 0.55 m
//!    (doors up to 1.1 m) would merge the 1.2 m doors' rooms; on the 0.2 m lattice a passage up
//!    to 1.2 m wide has at most 6 free coarse cells across, clearance ≤ 3 coarse cells, and never
//!    holds a core, while one 1.6 m wide or more has ≥ 7 and always does (1.3–1.5 m depends on
//!    how the walls fall on the lattice). 4-connected components of cores are the rooms; a
//!    component smaller than [`MIN_CORE_CELLS`] is dropped (its cells are then grown into by its
//!    neighbours, step 4).
//! 4. **Regions.** Every other free coarse cell joins the room whose core reaches it first in a
//!    multi-source 4-connected breadth-first wavefront over free coarse cells (seeds in raster
//!    order, a FIFO: deterministic). Fronts of two rooms meet in the narrow passage between them.
//!    A free area whose free component holds no core (a passage too narrow everywhere, a patch
//!    seen through a gap) is split between the rooms that reach it, or stays unlabelled.
//! 5. **Doorways.** A boundary cell is a labelled coarse cell with a 4-neighbour of another room;
//!    8-connected groups of boundary cells of the same pair of rooms are one [`Door`]: its cell is
//!    the group's centroid, its width the group's longer bounding-box side plus one coarse cell
//!    (the length of the contact, across the passage). Two doors between the same rooms are two doors. The room
//!    adjacency graph is the set of doors ([`Rooms::neighbours`]).
//! 6. **Kind.** A region is a [`RoomKind::Corridor`] if its principal axes (integer second
//!    moments) have a ratio of at least 3 (eigenvalue ratio ≥ [`CORRIDOR_EIGEN_RATIO`]) *and* its
//!    largest clearance is at most [`CORRIDOR_MAX_CLEARANCE`] (1.6 m: up to ~3.2 m wide), else a
//!    [`RoomKind::Room`]: a 2.5 × 45 m corridor is one; a 3 × 8 m bedroom is not (axis ratio
//!    8/3 < 3), nor is a 5 m wide, 20 m long hall (too wide).
//!
//! **Limits.** A corridor that opens into a room at its full width, with no narrowing (the
//! apartment's hallway into its living room), is one region with that room: there is no narrow
//! place to cut at. Two parts of one room seen with an unknown strip between them are two rooms
//! with no door until the strip is seen. Where the fronts meet depends on the distances from the
//! two cores, so a door's cell is within about a core margin (0.8 m) of the physical opening,
//! usually in it.
//!
//! **Stable ids.** Ids are `1..=MAX_ROOMS`. Each new core component takes the id of the old room
//! (the last update's labels, whole regions) it overlaps most; when several components want the
//! same old id the one with the largest overlap keeps it (ties: raster order), the others get
//! fresh ids — ids unused by the last update first, lowest first. So a room that grows, shrinks
//! or gains neighbours keeps its id; a room that splits keeps its id in its largest part; rooms
//! that merge take the id of the larger overlap. Ids are reused only when all 64 are needed.
//!
//! **Rolling window.** [`Rooms::shift`] moves the labels with the grid (the window moves by
//! multiples of 160 cells, an even number of coarse cells): ids survive a shift through the
//! overlap rule. The room and door lists are cleared until the next [`Rooms::update`].
//!
//! **Work.** [`Rooms::update`] is a full recompute: at most [`WORK_BOUND`] units (a unit is one
//! coarse cell visited by one pass, with up to 8 neighbour reads): 10 raster passes plus at most
//! one visit per cell in each of 4 floods, 14 × 65 536 = 917 504 (plus the id matching,
//! ≤ 64² comparisons, and ≤ 64 room updates per door). Measured: 681 136 on the apartment
//! world, 704 640 on the office (`tests/tests/rooms.rs`). [`Rooms::shift`] is 65 536.
//!
//! **Memory.** Two bytes per coarse cell (clearance, label: 128 KiB), the [`ROOM_QUEUE`] ring
//! (32 KiB) and the lists: `size_of::<Rooms>()` is 173 960 bytes (a test checks it).

use crate::capacity::{COARSE_AREA, COARSE_CELLS, GRID_CELLS, MAX_DOORS, MAX_ROOMS, ROOM_QUEUE};
use crate::grid::{Cell, LidarGrid, PackedGrid};

/// Chamfer weight of an orthogonal step (one coarse cell is 3 units).
pub const CHAMFER_ORTHO: u8 = 3;
/// Chamfer weight of a diagonal step.
pub const CHAMFER_DIAG: u8 = 4;
/// Clearance saturates here (42 coarse cells, 8.4 m); bit 7 is a scratch mark.
pub const CLEARANCE_MAX: u8 = 127;
/// Clearance (chamfer units) a free coarse cell needs to be part of a room core: 4 coarse cells,
/// 0.8 m (see the module's docs for why).
pub const CORE_CLEARANCE: u8 = 4 * CHAMFER_ORTHO;
/// Core components smaller than this (coarse cells) are dropped.
pub const MIN_CORE_CELLS: u32 = 4;
/// A corridor's principal-axis eigenvalue ratio is at least this (an axis ratio of 3).
pub const CORRIDOR_EIGEN_RATIO: i128 = 9;
/// A corridor's largest clearance is at most this (chamfer units; 8 coarse cells, 1.6 m).
pub const CORRIDOR_MAX_CLEARANCE: u8 = 8 * CHAMFER_ORTHO;
/// Most work units one [`Rooms::update`] takes.
pub const WORK_BOUND: u32 = 14 * COARSE_AREA as u32;

const VISIT: u8 = 0x80;
const N: i32 = COARSE_CELLS as i32;
const COARSE_MM: u32 = 200;

const _: () = assert!(ROOM_QUEUE.is_power_of_two() && ROOM_QUEUE <= u16::MAX as usize + 1);
const _: () = assert!(MAX_ROOMS < 128 && COARSE_AREA <= u16::MAX as usize + 1);

/// Room or corridor (see the module's docs for the rule).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RoomKind {
    /// A room, hall or open area.
    Room,
    /// Long and narrow.
    Corridor,
}

/// One room (or corridor). Cell coordinates are the LiDAR grid's (fine) cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Room {
    /// Its id, `1..=MAX_ROOMS`, kept across updates where possible (module docs).
    pub id: u8,
    /// Room or corridor.
    pub kind: RoomKind,
    /// Area in fine cells (4 per coarse cell; 100 a square metre).
    pub area_cells: u32,
    /// Centroid (may fall outside a non-convex room).
    pub centroid: (i32, i32),
    /// A free cell of the coarse cell of largest clearance (the first in raster order): a good
    /// place to look from.
    pub view: (i32, i32),
    /// Clearance there, millimetres (to the centre of the nearest blocked coarse cell).
    pub clearance_mm: u32,
    /// Bounding box, inclusive: (min x, min y, max x, max y).
    pub bbox: (i32, i32, i32, i32),
    /// Doors touching it (in [`Rooms::doors`]).
    pub doors: u8,
}

/// A doorway between two rooms.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Door {
    /// The two rooms, lower id first.
    pub rooms: (u8, u8),
    /// Centroid of the boundary (fine cell).
    pub cell: (i32, i32),
    /// Length of the contact between the rooms in millimetres, in 0.2 m steps: the free coarse
    /// cells across plus one (the jambs' coarse cells are blocked though partly free). On the
    /// built-in worlds the 1.0–1.2 m doors measure 1.0–1.2 m, each within 0.1 m.
    pub width_mm: u32,
}

/// Counters of the last update (overflow is counted, never silent).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RoomStats {
    /// Work units of the last update (≤ [`WORK_BOUND`]).
    pub work: u32,
    /// Core components dropped for being smaller than [`MIN_CORE_CELLS`].
    pub small_cores: u32,
    /// Core components dropped because [`MAX_ROOMS`] were kept.
    pub rooms_dropped: u32,
    /// Doors dropped because [`MAX_DOORS`] were kept.
    pub doors_dropped: u32,
    /// Cells not queued because the [`ROOM_QUEUE`] ring was full.
    pub queue_overflow: u32,
}

#[derive(Clone, Copy)]
struct Comp {
    seed: u16,
    old: u8,
    overlap: u32,
    id: u8,
}

#[derive(Clone, Copy)]
struct Acc {
    n: u64,
    sx: u64,
    sy: u64,
    sxx: u64,
    syy: u64,
    sxy: u64,
    bbox: (i32, i32, i32, i32),
    best: u8,
    best_cell: u16,
}

const ACC0: Acc = Acc { n: 0, sx: 0, sy: 0, sxx: 0, syy: 0, sxy: 0, bbox: (N, N, -1, -1), best: 0, best_cell: 0 };

struct Ring {
    buf: [u16; ROOM_QUEUE],
    head: usize,
    len: usize,
}

impl Ring {
    const fn new() -> Self {
        Self { buf: [0; ROOM_QUEUE], head: 0, len: 0 }
    }
    #[inline]
    fn push(&mut self, i: usize) -> bool {
        if self.len == ROOM_QUEUE {
            return false;
        }
        self.buf[(self.head + self.len) & (ROOM_QUEUE - 1)] = i as u16;
        self.len += 1;
        true
    }
    #[inline]
    fn pop(&mut self) -> Option<usize> {
        if self.len == 0 {
            return None;
        }
        let v = self.buf[self.head];
        self.head = (self.head + 1) & (ROOM_QUEUE - 1);
        self.len -= 1;
        Some(v as usize)
    }
    fn clear(&mut self) {
        self.head = 0;
        self.len = 0;
    }
}

/// The segmentation (see the module's docs).
pub struct Rooms {
    clearance: [u8; COARSE_AREA],
    labels: [u8; COARSE_AREA],
    queue: Ring,
    comps: heapless::Vec<Comp, MAX_ROOMS>,
    acc: [Acc; MAX_ROOMS + 1],
    rooms: heapless::Vec<Room, MAX_ROOMS>,
    doors: heapless::Vec<Door, MAX_DOORS>,
    stale: bool,
    /// Counters of the last [`Rooms::update`].
    pub stats: RoomStats,
}

/// The coarse cell's state: 0 unknown, 1 free, 2 blocked.
#[inline]
fn coarse_state(bytes: &[u8], cx: i32, cy: i32) -> u8 {
    let x = 2 * cx as usize;
    let y = 2 * cy as usize;
    let nib = |row: usize| {
        let i = row * GRID_CELLS + x;
        (bytes[i >> 2] >> ((i & 3) * 2)) & 0xF
    };
    COARSE_STATE[(nib(y) | nib(y + 1) << 4) as usize]
}

/// [`coarse_state`] of the four 2-bit cells packed in a byte (the upper row in the high nibble):
/// 2 if any is occupied (2), else 1 if at least three are free (1), else 0.
const COARSE_STATE: [u8; 256] = {
    let mut t = [0u8; 256];
    let mut k = 0;
    while k < 256 {
        let (mut free, mut blocked, mut j) = (0, false, 0);
        while j < 4 {
            match (k >> (2 * j)) & 3 {
                2 => blocked = true,
                1 => free += 1,
                _ => {}
            }
            j += 1;
        }
        t[k] = if blocked { 2 } else { (free >= 3) as u8 };
        k += 1;
    }
    t
};

#[inline]
fn xy(i: usize) -> (i32, i32) {
    ((i % COARSE_CELLS) as i32, (i / COARSE_CELLS) as i32)
}

#[inline]
fn idx(x: i32, y: i32) -> Option<usize> {
    ((x as u32) < N as u32 && (y as u32) < N as u32).then(|| y as usize * COARSE_CELLS + x as usize)
}

const N4: [(i32, i32); 4] = [(1, 0), (-1, 0), (0, 1), (0, -1)];

impl Rooms {
    /// Nothing segmented yet.
    pub const fn new() -> Self {
        Self {
            clearance: [0; COARSE_AREA],
            labels: [0; COARSE_AREA],
            queue: Ring::new(),
            comps: heapless::Vec::new(),
            acc: [ACC0; MAX_ROOMS + 1],
            rooms: heapless::Vec::new(),
            doors: heapless::Vec::new(),
            stale: true,
            stats: RoomStats { work: 0, small_cores: 0, rooms_dropped: 0, doors_dropped: 0, queue_overflow: 0 },
        }
    }

    /// The rooms of the last update, by increasing id.
    pub fn rooms(&self) -> &[Room] {
        &self.rooms
    }

    /// The doors of the last update.
    pub fn doors(&self) -> &[Door] {
        &self.doors
    }

    /// The room with id `id`.
    pub fn room(&self, id: u8) -> Option<&Room> {
        self.rooms.iter().find(|r| r.id == id)
    }

    /// The doors of room `id`.
    pub fn doors_of(&self, id: u8) -> impl Iterator<Item = &Door> + '_ {
        self.doors.iter().filter(move |d| d.rooms.0 == id || d.rooms.1 == id)
    }

    /// The rooms sharing a door with room `id` (once per door: two doors, twice).
    pub fn neighbours(&self, id: u8) -> impl Iterator<Item = u8> + '_ {
        self.doors_of(id).map(move |d| if d.rooms.0 == id { d.rooms.1 } else { d.rooms.0 })
    }

    /// True when the lists describe an older map than the labels (after a [`Rooms::shift`],
    /// before the next update) or nothing was segmented yet.
    pub fn stale(&self) -> bool {
        self.stale
    }

    /// The room holding fine cell `(x, y)` (the coarse cell it lies in), if any: `None` for
    /// blocked, unknown and unassigned coarse cells and outside the grid.
    pub fn room_at(&self, x: i32, y: i32) -> Option<u8> {
        if !PackedGrid::in_bounds(x, y) {
            return None;
        }
        let l = self.labels[(y as usize >> 1) * COARSE_CELLS + (x as usize >> 1)];
        (l != 0).then_some(l)
    }

    /// Clearance of the coarse cell holding fine cell `(x, y)` in millimetres (as of the last
    /// update; 0 when blocked or outside).
    pub fn clearance_mm(&self, x: i32, y: i32) -> u32 {
        if !PackedGrid::in_bounds(x, y) {
            return 0;
        }
        let c = self.clearance[(y as usize >> 1) * COARSE_CELLS + (x as usize >> 1)] & !VISIT;
        c as u32 * COARSE_MM / CHAMFER_ORTHO as u32
    }

    /// Moves with the grid's window ([`crate::rolling::shift`]): the new fine cell `(x, y)` is
    /// the old `(x + sx, y + sy)`. With even shifts (the window's are) the labels move, so the
    /// next update keeps the ids; an odd shift forgets them. The lists are cleared and
    /// [`Rooms::stale`] is true until the next update. Returns the work (coarse cells written).
    pub fn shift(&mut self, sx: i32, sy: i32) -> u32 {
        if sx % 2 == 0 && sy % 2 == 0 {
            crate::grid::shift_2d(&mut self.labels, COARSE_CELLS, sx as i64 / 2, sy as i64 / 2, 0);
        } else {
            self.labels.fill(0);
        }
        self.rooms.clear();
        self.doors.clear();
        self.stale = true;
        COARSE_AREA as u32
    }

    /// Segments `lidar` (a full recompute, see the module's docs). Returns the work units
    /// (≤ [`WORK_BOUND`]).
    pub fn update(&mut self, lidar: &LidarGrid) -> u32 {
        let bytes = lidar.grid.as_bytes();
        self.stats = RoomStats::default();
        let mut work = 0u32;
        self.distance_transform(bytes);
        work += 3 * COARSE_AREA as u32;
        work += self.find_cores(bytes);
        self.assign_ids();
        work += self.label_cores();
        work += self.grow(bytes);
        work += self.measure(lidar);
        work += self.find_doors();
        self.stale = false;
        self.stats.work = work;
        work
    }

    /// Step 2 (3 passes: the coarse states, forward, backward).
    fn distance_transform(&mut self, bytes: &[u8]) {
        for i in 0..COARSE_AREA {
            let (x, y) = xy(i);
            self.clearance[i] = if coarse_state(bytes, x, y) == 2 { 0 } else { CLEARANCE_MAX };
        }
        // Each cell takes the least of itself and its four causal neighbours plus the step's
        // weight (a minimum, so the order within a cell does not matter).
        let c = &mut self.clearance;
        const W: usize = COARSE_CELLS;
        let (o, d) = (CHAMFER_ORTHO, CHAMFER_DIAG);
        for y in 0..W {
            for x in 0..W {
                let i = y * W + x;
                let mut v = c[i];
                if x > 0 {
                    v = v.min(c[i - 1].saturating_add(o));
                }
                if y > 0 {
                    v = v.min(c[i - W].saturating_add(o));
                    if x > 0 {
                        v = v.min(c[i - W - 1].saturating_add(d));
                    }
                    if x + 1 < W {
                        v = v.min(c[i - W + 1].saturating_add(d));
                    }
                }
                c[i] = v;
            }
        }
        for y in (0..W).rev() {
            for x in (0..W).rev() {
                let i = y * W + x;
                let mut v = c[i];
                if x + 1 < W {
                    v = v.min(c[i + 1].saturating_add(o));
                }
                if y + 1 < W {
                    v = v.min(c[i + W].saturating_add(o));
                    if x + 1 < W {
                        v = v.min(c[i + W + 1].saturating_add(d));
                    }
                    if x > 0 {
                        v = v.min(c[i + W - 1].saturating_add(d));
                    }
                }
                c[i] = v;
            }
        }
    }

    #[inline]
    fn is_core(&self, bytes: &[u8], i: usize) -> bool {
        let c = self.clearance[i];
        c & VISIT == 0 && c >= CORE_CLEARANCE && {
            let (x, y) = xy(i);
            coarse_state(bytes, x, y) == 1
        }
    }

    /// Step 3: core components (marked with [`VISIT`]), each with the old id it overlaps most.
    /// One raster pass plus one visit per core cell.
    fn find_cores(&mut self, bytes: &[u8]) -> u32 {
        self.comps.clear();
        let mut work = COARSE_AREA as u32;
        for s in 0..COARSE_AREA {
            if !self.is_core(bytes, s) {
                continue;
            }
            let mut hist = [0u32; MAX_ROOMS + 1];
            let mut area = 0u32;
            self.queue.clear();
            self.clearance[s] |= VISIT;
            self.queue.push(s);
            while let Some(i) = self.queue.pop() {
                area += 1;
                let old = self.labels[i] as usize;
                if old <= MAX_ROOMS {
                    hist[old] += 1;
                }
                let (x, y) = xy(i);
                for (dx, dy) in N4 {
                    if let Some(j) = idx(x + dx, y + dy) {
                        if self.is_core(bytes, j) {
                            if self.queue.push(j) {
                                self.clearance[j] |= VISIT;
                            } else {
                                self.stats.queue_overflow += 1;
                            }
                        }
                    }
                }
            }
            work += area;
            if area < MIN_CORE_CELLS {
                self.stats.small_cores += 1;
                continue;
            }
            let (mut old, mut overlap) = (0u8, 0u32);
            for (k, &h) in hist.iter().enumerate().skip(1) {
                if h > overlap {
                    (old, overlap) = (k as u8, h);
                }
            }
            if self.comps.push(Comp { seed: s as u16, old, overlap, id: 0 }).is_err() {
                self.stats.rooms_dropped += 1;
            }
        }
        work
    }

    /// Stable ids (module docs).
    fn assign_ids(&mut self) {
        let mut prev = 0u128;
        for r in self.rooms.iter() {
            prev |= 1 << r.id;
        }
        // After a shift the lists are empty but the labels hold the ids: count those too.
        for c in self.comps.iter() {
            prev |= 1 << c.old;
        }
        let mut taken = 1u128; // id 0 is "none"
        let n = self.comps.len();
        for k in 0..n {
            let c = self.comps[k];
            if c.old == 0 {
                continue;
            }
            let wins = (0..n).all(|j| {
                let o = self.comps[j];
                j == k || o.old != c.old || o.overlap < c.overlap || (o.overlap == c.overlap && j > k)
            });
            if wins {
                self.comps[k].id = c.old;
                taken |= 1 << c.old;
            }
        }
        for k in 0..n {
            if self.comps[k].id != 0 {
                continue;
            }
            let pick = |mask: u128| (1..=MAX_ROOMS as u8).find(|&id| mask & (1 << id) == 0);
            // There are at most MAX_ROOMS components, so an id is always free.
            let id = pick(taken | prev).or_else(|| pick(taken)).unwrap_or(0);
            self.comps[k].id = id;
            taken |= 1 << id;
        }
    }

    /// Writes the kept cores' ids and clears the marks: one raster pass (clearing labels and
    /// marks) plus one visit per kept core cell.
    fn label_cores(&mut self) -> u32 {
        self.labels.fill(0);
        let mut work = 2 * COARSE_AREA as u32;
        for k in 0..self.comps.len() {
            let Comp { seed, id, .. } = self.comps[k];
            self.queue.clear();
            self.labels[seed as usize] = id;
            self.queue.push(seed as usize);
            while let Some(i) = self.queue.pop() {
                work += 1;
                let (x, y) = xy(i);
                for (dx, dy) in N4 {
                    if let Some(j) = idx(x + dx, y + dy) {
                        if self.clearance[j] & VISIT != 0 && self.labels[j] == 0 {
                            if self.queue.push(j) {
                                self.labels[j] = id;
                            } else {
                                self.stats.queue_overflow += 1;
                            }
                        }
                    }
                }
            }
        }
        for c in self.clearance.iter_mut() {
            *c &= !VISIT;
        }
        work
    }

    /// Step 4: the wavefront. One raster pass for the seeds (core cells next to unlabelled free
    /// ones) plus one visit per cell labelled.
    fn grow(&mut self, bytes: &[u8]) -> u32 {
        let mut work = COARSE_AREA as u32;
        self.queue.clear();
        let open = |labels: &[u8; COARSE_AREA], j: usize| {
            let (x, y) = xy(j);
            labels[j] == 0 && coarse_state(bytes, x, y) == 1
        };
        for i in 0..COARSE_AREA {
            if self.labels[i] == 0 {
                continue;
            }
            let (x, y) = xy(i);
            if N4.iter().any(|&(dx, dy)| idx(x + dx, y + dy).is_some_and(|j| open(&self.labels, j))) && !self.queue.push(i) {
                self.stats.queue_overflow += 1;
            }
        }
        while let Some(i) = self.queue.pop() {
            work += 1;
            let (x, y) = xy(i);
            let id = self.labels[i];
            for (dx, dy) in N4 {
                if let Some(j) = idx(x + dx, y + dy) {
                    if open(&self.labels, j) {
                        if self.queue.push(j) {
                            self.labels[j] = id;
                        } else {
                            self.stats.queue_overflow += 1;
                        }
                    }
                }
            }
        }
        work
    }

    /// Per-room statistics and kinds: one raster pass.
    fn measure(&mut self, lidar: &LidarGrid) -> u32 {
        self.acc = [ACC0; MAX_ROOMS + 1];
        for i in 0..COARSE_AREA {
            let l = self.labels[i] as usize;
            if l == 0 {
                continue;
            }
            let (x, y) = xy(i);
            let a = &mut self.acc[l];
            let (ux, uy) = (x as u64, y as u64);
            a.n += 1;
            a.sx += ux;
            a.sy += uy;
            a.sxx += ux * ux;
            a.syy += uy * uy;
            a.sxy += ux * uy;
            a.bbox = (a.bbox.0.min(x), a.bbox.1.min(y), a.bbox.2.max(x), a.bbox.3.max(y));
            if self.clearance[i] > a.best || a.n == 1 {
                a.best = self.clearance[i];
                a.best_cell = i as u16;
            }
        }
        self.rooms.clear();
        for id in 1..=MAX_ROOMS {
            let a = self.acc[id];
            if a.n == 0 {
                continue;
            }
            let n = a.n as i128;
            let (sx, sy) = (a.sx as i128, a.sy as i128);
            let va = n * a.sxx as i128 - sx * sx;
            let vc = n * a.syy as i128 - sy * sy;
            let vb = n * a.sxy as i128 - sx * sy;
            let t = va + vc;
            let d2 = (va - vc) * (va - vc) + 4 * vb * vb;
            let k = CORRIDOR_EIGEN_RATIO;
            let elongated = d2 * (1 + k) * (1 + k) >= t * t * (k - 1) * (k - 1) && t > 0;
            let kind = if elongated && a.best <= CORRIDOR_MAX_CLEARANCE { RoomKind::Corridor } else { RoomKind::Room };
            let (bx, by) = xy(a.best_cell as usize);
            let view = [(0, 0), (1, 0), (0, 1), (1, 1)]
                .into_iter()
                .map(|(dx, dy)| (2 * bx + dx, 2 * by + dy))
                .find(|&(fx, fy)| lidar.get(fx, fy) == Cell::Free)
                .unwrap_or((2 * bx, 2 * by));
            let centre = |s: u64| ((2 * s + a.n) / a.n) as i32;
            let room = Room {
                id: id as u8,
                kind,
                area_cells: (a.n * 4) as u32,
                centroid: (centre(a.sx), centre(a.sy)),
                view,
                clearance_mm: a.best as u32 * COARSE_MM / CHAMFER_ORTHO as u32,
                bbox: (2 * a.bbox.0, 2 * a.bbox.1, 2 * a.bbox.2 + 1, 2 * a.bbox.3 + 1),
                doors: 0,
            };
            // At most MAX_ROOMS ids: always fits.
            let _ = self.rooms.push(room);
        }
        COARSE_AREA as u32
    }

    /// The pair of rooms a boundary cell separates (lower id first), if it is one.
    #[inline]
    fn boundary_key(&self, i: usize) -> Option<(u8, u8)> {
        let a = self.labels[i];
        if a == 0 {
            return None;
        }
        let (x, y) = xy(i);
        let b = N4.iter().filter_map(|&(dx, dy)| idx(x + dx, y + dy).map(|j| self.labels[j])).filter(|&l| l != 0 && l != a).min()?;
        Some((a.min(b), a.max(b)))
    }

    /// Step 5: one raster pass, one visit per boundary cell, one pass clearing the marks.
    fn find_doors(&mut self) -> u32 {
        self.doors.clear();
        let mut work = 2 * COARSE_AREA as u32;
        for s in 0..COARSE_AREA {
            if self.clearance[s] & VISIT != 0 {
                continue;
            }
            let Some(key) = self.boundary_key(s) else { continue };
            self.queue.clear();
            self.clearance[s] |= VISIT;
            self.queue.push(s);
            let (mut n, mut sx, mut sy) = (0u32, 0u32, 0u32);
            let mut bb = (N, N, -1, -1);
            while let Some(i) = self.queue.pop() {
                work += 1;
                let (x, y) = xy(i);
                n += 1;
                sx += x as u32;
                sy += y as u32;
                bb = (bb.0.min(x), bb.1.min(y), bb.2.max(x), bb.3.max(y));
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let Some(j) = idx(x + dx, y + dy) else { continue };
                        if self.clearance[j] & VISIT == 0 && self.boundary_key(j) == Some(key) {
                            if self.queue.push(j) {
                                self.clearance[j] |= VISIT;
                            } else {
                                self.stats.queue_overflow += 1;
                            }
                        }
                    }
                }
            }
            // The free coarse cells across, plus one for the jambs' partly free coarse cells.
            let width = (bb.2 - bb.0).max(bb.3 - bb.1) as u32 + 2;
            let door = Door { rooms: key, cell: (((2 * sx + n) / n) as i32, ((2 * sy + n) / n) as i32), width_mm: width * COARSE_MM };
            if self.doors.push(door).is_err() {
                self.stats.doors_dropped += 1;
                continue;
            }
            for r in self.rooms.iter_mut() {
                if r.id == key.0 || r.id == key.1 {
                    r.doors = r.doors.saturating_add(1);
                }
            }
        }
        for c in self.clearance.iter_mut() {
            *c &= !VISIT;
        }
        work
    }
}

impl Default for Rooms {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests;
