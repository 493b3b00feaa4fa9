//! What leaves the window is kept, in a coarser form (issue 27, item 6).
//!
//! A shift ([`super::shift`]) hands every [`MEMORY_TILE_CELLS`]²-cell tile it moves out of the
//! window to [`WindowMemory::keep`], and asks [`WindowMemory::restore`] for every tile it moves
//! in. A tile is kept as the *state* of each cell — the LiDAR map's ternary cell (not its 4-bit
//! evidence) and the camera's — run-length coded, row by row; a tile neither map has observed is
//! not kept. Restored, a LiDAR cell gets the middle evidence of its side ([`RESTORED_OCCUPIED`],
//! [`RESTORED_FREE`]): a wall or free space as before, which the next scans move like any other
//! cell's; the camera's cells come back as they were, so a region searched before the window left
//! it is not searched again.
//!
//! Why tiles at full resolution rather than a coarser grid: 0.2 m cells close 0.9 m doorways once
//! inflated by the robot's radius, and a coarse block restored into fine cells is a frontier at
//! every edge. Why the state and not the evidence: the evidence's gradients at the edges of free
//! space break the runs, and a cell's side is what the planner and the picture use.
//!
//! **Memory.** [`MEMORY_BYTES`] of runs and [`MEMORY_TILES`] entries, static. Tiles restored leave
//! a hole in the byte store, closed by compaction when a new tile does not fit. When a tile does
//! not fit even then, it is not kept (counted in [`MemoryStats::dropped`]): what left the window
//! first is what stays.
//!
//! **Coding.** One code per run: the state `s = lidar + 3 · camera` (each its packed bits, as
//! [`crate::grid::PackedGrid`] stores them: `0` unknown, `1` free, `2` occupied) in the high nibble, and in the low nibble `n`: a run of `n + 1` cells for
//! `n < 15`, or, for `n = 15`, a run of `16 + b` cells with `b` the next byte (longer runs are
//! split). A tile is its cells in row-major order.

use crate::capacity::{MEMORY_BYTES, MEMORY_TILES, MEMORY_TILE_CELLS};
use crate::grid::{Cell, Evidence, LidarGrid, VisualGrid, EVIDENCE_MAX, EVIDENCE_MIN, EVIDENCE_MIN_OCCUPIED};

const T: i32 = MEMORY_TILE_CELLS as i32;
const TILE_AREA: usize = MEMORY_TILE_CELLS * MEMORY_TILE_CELLS;
/// The longest run one code covers.
const MAX_RUN: usize = 16 + 255;

/// The evidence a restored occupied cell gets: the middle of the occupied side
/// (`EVIDENCE_MIN_OCCUPIED ..= EVIDENCE_MAX`, rounded down).
pub const RESTORED_OCCUPIED: Evidence = (EVIDENCE_MIN_OCCUPIED + EVIDENCE_MAX) / 2;
/// The evidence a restored free cell gets: the middle of the free side (`EVIDENCE_MIN ..= 0`).
pub const RESTORED_FREE: Evidence = EVIDENCE_MIN / 2;

const _: () = assert!(MEMORY_BYTES <= u16::MAX as usize);
const _: () = assert!(super::WINDOW_SHIFT_CELLS % T == 0 && crate::capacity::GRID_CELLS as i32 % T == 0);

/// What the memory has done since the last [`WindowMemory::clear`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoryStats {
    /// Tiles kept as they left the window.
    pub kept: u32,
    /// Tiles restored as they came back.
    pub restored: u32,
    /// Tiles that left the window with something observed in them but did not fit.
    pub dropped: u32,
    /// Compactions of the byte store.
    pub compactions: u32,
    /// The most bytes the tiles held took at once (of [`MEMORY_BYTES`]).
    pub peak_bytes: u32,
}

#[derive(Clone, Copy)]
struct Entry {
    /// The tile, in tiles from the window's first placement
    /// ([`crate::grid::WindowStats::moved_cells`] / [`MEMORY_TILE_CELLS`] + the tile in the window).
    tile: (i32, i32),
    start: u16,
    len: u16,
}

const NO_ENTRY: Entry = Entry { tile: (0, 0), start: 0, len: 0 };

/// The tiles outside the window (see the module's docs).
#[derive(Clone)]
pub struct WindowMemory {
    entries: [Entry; MEMORY_TILES],
    used: usize,
    bytes: [u8; MEMORY_BYTES],
    /// `bytes[..top]` are written (tiles held, and holes left by tiles restored).
    top: usize,
    /// Bytes of holes in `bytes[..top]`.
    holes: usize,
    /// Counters.
    pub stats: MemoryStats,
}

/// Calls `emit(state, run)` for the runs of equal states over the tile whose lower-left cell is
/// `(x0, y0)` in the window, row by row.
fn runs(lidar: &LidarGrid, visual: &VisualGrid, (x0, y0): (i32, i32), mut emit: impl FnMut(u8, usize)) {
    let mut cur = 0u8;
    let mut n = 0usize;
    for i in 0..TILE_AREA as i32 {
        let (x, y) = (x0 + i % T, y0 + i / T);
        let s = lidar.get(x, y) as u8 + 3 * visual.get(x, y) as u8;
        if n > 0 && s != cur {
            emit(cur, n);
            n = 0;
        }
        cur = s;
        n += 1;
    }
    emit(cur, n);
}

/// Calls `code(state, take)` for the codes of one run (see the module's docs).
fn split(mut run: usize, mut code: impl FnMut(usize)) {
    while run > 0 {
        let take = run.min(MAX_RUN);
        code(take);
        run -= take;
    }
}

/// Bytes of a code covering `take` cells.
const fn code_len(take: usize) -> usize {
    if take <= 15 {
        1
    } else {
        2
    }
}

impl WindowMemory {
    /// Empty.
    pub const fn new() -> Self {
        Self {
            entries: [NO_ENTRY; MEMORY_TILES],
            used: 0,
            bytes: [0; MEMORY_BYTES],
            top: 0,
            holes: 0,
            stats: MemoryStats { kept: 0, restored: 0, dropped: 0, compactions: 0, peak_bytes: 0 },
        }
    }

    /// Forgets every tile and the counters.
    pub fn clear(&mut self) {
        self.used = 0;
        self.top = 0;
        self.holes = 0;
        self.stats = MemoryStats::default();
    }

    /// Tiles held.
    pub fn tiles(&self) -> usize {
        self.used
    }

    /// Bytes the tiles held take (holes excluded).
    pub fn bytes_used(&self) -> usize {
        self.top - self.holes
    }

    /// True if world tile `tile` is held.
    pub fn holds(&self, tile: (i32, i32)) -> bool {
        self.find(tile).is_some()
    }

    fn find(&self, tile: (i32, i32)) -> Option<usize> {
        self.entries[..self.used].iter().position(|e| e.tile == tile)
    }

    /// Lets entry `i` go; the others keep their order (that of their bytes). Returns the work.
    fn remove(&mut self, i: usize) -> u32 {
        self.holes += self.entries[i].len as usize;
        self.entries.copy_within(i + 1..self.used, i);
        self.used -= 1;
        (self.used - i) as u32
    }

    /// Moves the tiles' bytes down over the holes (the entries are in the order of their bytes).
    /// Returns the work.
    fn compact(&mut self) -> u32 {
        self.stats.compactions += 1;
        let mut top = 0usize;
        for e in self.entries[..self.used].iter_mut() {
            let (s, l) = (e.start as usize, e.len as usize);
            self.bytes.copy_within(s..s + l, top);
            e.start = top as u16;
            top += l;
        }
        self.top = top;
        self.holes = 0;
        (self.used + top) as u32
    }

    /// Keeps the window's tile whose lower-left cell is `(x0, y0)`, world tile `tile`, if either
    /// map has observed a cell of it. Returns the work (cells read, entries and bytes touched).
    pub fn keep(&mut self, lidar: &LidarGrid, visual: &VisualGrid, (x0, y0): (i32, i32), tile: (i32, i32)) -> u32 {
        let mut len = 0usize;
        let mut observed = false;
        runs(lidar, visual, (x0, y0), |s, n| {
            split(n, |take| len += code_len(take));
            observed |= s != 0;
        });
        let mut work = (TILE_AREA + self.used) as u32;
        if let Some(i) = self.find(tile) {
            // A tile coming in is restored and let go, so a shift never finds one here; but a
            // tile is never held twice.
            work += self.remove(i);
        }
        if !observed {
            return work;
        }
        // Compact only if that makes room.
        if self.top + len > MEMORY_BYTES && self.top - self.holes + len <= MEMORY_BYTES && self.used < MEMORY_TILES {
            work += self.compact();
        }
        if self.used == MEMORY_TILES || self.top + len > MEMORY_BYTES {
            self.stats.dropped += 1;
            return work;
        }
        let start = self.top;
        let mut at = start;
        let bytes = &mut self.bytes;
        runs(lidar, visual, (x0, y0), |s, n| {
            split(n, |take| {
                if take <= 15 {
                    bytes[at] = (s << 4) | (take - 1) as u8;
                } else {
                    bytes[at] = (s << 4) | 15;
                    bytes[at + 1] = (take - 16) as u8;
                }
                at += code_len(take);
            })
        });
        work += TILE_AREA as u32;
        self.top = at;
        self.entries[self.used] = Entry { tile, start: start as u16, len: (at - start) as u16 };
        self.used += 1;
        self.stats.kept += 1;
        self.stats.peak_bytes = self.stats.peak_bytes.max(self.bytes_used() as u32);
        work
    }

    /// Restores world tile `tile`, if held, into the window's tile whose lower-left cell is
    /// `(x0, y0)` (cells just moved in: never observed), and lets it go. Returns the work.
    pub fn restore(&mut self, lidar: &mut LidarGrid, visual: &mut VisualGrid, (x0, y0): (i32, i32), tile: (i32, i32)) -> u32 {
        let mut work = self.used as u32;
        let Some(i) = self.find(tile) else {
            return work;
        };
        let Entry { start, len, .. } = self.entries[i];
        let (mut at, end) = (start as usize, start as usize + len as usize);
        let mut cell = 0usize;
        while at < end && cell < TILE_AREA {
            let code = self.bytes[at];
            let (s, n) = (code >> 4, (code & 15) as usize);
            let run = if n < 15 { n + 1 } else { 16 + self.bytes.get(at + 1).copied().unwrap_or(0) as usize };
            at += code_len(run);
            let (l, v) = (Cell::from_bits(s % 3), Cell::from_bits(s / 3));
            for c in cell..(cell + run).min(TILE_AREA) {
                let (x, y) = (x0 + c as i32 % T, y0 + c as i32 / T);
                match l {
                    Cell::Occupied => lidar.seed(x, y, RESTORED_OCCUPIED),
                    Cell::Free => lidar.seed(x, y, RESTORED_FREE),
                    Cell::Unknown => {}
                }
                if v != Cell::Unknown {
                    visual.grid.set(x, y, v);
                }
            }
            cell += run;
        }
        work += TILE_AREA as u32 + self.remove(i);
        self.stats.restored += 1;
        work
    }
}

impl Default for WindowMemory {
    fn default() -> Self {
        Self::new()
    }
}
