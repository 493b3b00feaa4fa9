//! Frontiers of both search maps.
//!
//! **Convention.** A frontier cell is a cell that is *free* and has at least one *unknown*
//! 4-neighbour (the paper's "free cell adjacent to an unknown cell"; explore_lite marks the unknown
//! side instead). We mark the free side because that is where the robot can stand: a viewpoint on
//! a frontier cell is already in known free space, so its path distance is defined. We use the
//! 4-neighbourhood for the test so that a free cell touching unknown space only diagonally,
//! through the corner between two wall cells, is not a frontier (no frontiers leak through
//! wall corners). Frontier cells are then grouped with 8-connectivity, groups smaller than
//! `min_frontier_cells` are dropped, and each group longer than [`SPLIT_CELLS`] is cut into
//! consecutive pieces (in flood-fill order) so that a long frontier offers several viewpoints for
//! the narrow camera (an addition to the paper, which takes one centroid per group).
//!
//! For the visual map "free" means seen by the camera and free, "unknown" means never seen.
//!
//! Work is bounded: one pass over each grid plus one visit per frontier cell; memory is the
//! frontier bit mask, the flood-fill work list ([`FRONTIER_QUEUE`]) and at most
//! [`MAX_FRONTIERS_PER_GRID`] groups per grid.

use crate::capacity::{BLOCKS, BLOCK_CELLS, FRONTIER_QUEUE, GRID_CELLS, MAX_FRONTIERS_PER_GRID};
use crate::grid::{BitGrid, Cell, LidarGrid, PackedGrid, VisualGrid};

/// Frontier groups longer than this many cells are split into pieces of this size.
pub const SPLIT_CELLS: usize = 40;

/// Which map a frontier belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FrontierSource {
    /// The LiDAR map.
    Lidar,
    /// The visual (camera) map.
    Visual,
}

/// One frontier (or one piece of a long one).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Frontier {
    /// The map it belongs to.
    pub source: FrontierSource,
    /// Frontier cells in it.
    pub cells: u16,
    /// Centroid, cell coordinates (integer mean, floored).
    pub centroid: (i32, i32),
    /// The member cell nearest the centroid: a free cell, where the viewpoint goes.
    pub anchor: (i32, i32),
}

/// Counters of the last extraction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrontierStats {
    /// Frontier cells found (both maps).
    pub cells: u32,
    /// Groups dropped for being smaller than the minimum.
    pub dropped_small: u32,
    /// Groups dropped because [`MAX_FRONTIERS_PER_GRID`] were already kept.
    pub dropped_capacity: u32,
    /// Groups whose flood fill hit [`FRONTIER_QUEUE`] (the rest of the group is left for the next step).
    pub truncated: u32,
}

/// The frontiers of both maps, recomputed every planning step.
pub struct FrontierSet {
    frontiers: heapless::Vec<Frontier, { 2 * MAX_FRONTIERS_PER_GRID }>,
    mask: BitGrid,
    /// Frontier cells of either map per block of [`BLOCK_CELLS`]² cells.
    block_counts: [u16; BLOCKS * BLOCKS],
    members: [u32; FRONTIER_QUEUE],
    /// Counters of the last [`FrontierSet::compute`].
    pub stats: FrontierStats,
}

impl FrontierSet {
    /// Empty.
    pub const fn new() -> Self {
        Self {
            frontiers: heapless::Vec::new(),
            mask: BitGrid::new(),
            block_counts: [0; BLOCKS * BLOCKS],
            members: [0; FRONTIER_QUEUE],
            stats: FrontierStats { cells: 0, dropped_small: 0, dropped_capacity: 0, truncated: 0 },
        }
    }

    /// The frontiers found by the last [`FrontierSet::compute`].
    pub fn frontiers(&self) -> &[Frontier] {
        &self.frontiers
    }

    /// Frontier cells (either map) in block `(bx, by)`.
    #[inline]
    pub fn block_count(&self, bx: i32, by: i32) -> u16 {
        if (bx as u32) < BLOCKS as u32 && (by as u32) < BLOCKS as u32 {
            self.block_counts[by as usize * BLOCKS + bx as usize]
        } else {
            0
        }
    }

    /// True if `(x, y)` is a frontier cell of `grid`.
    #[inline]
    pub fn is_frontier(grid: &PackedGrid, x: i32, y: i32) -> bool {
        grid.get(x, y) == Cell::Free
            && PackedGrid::in_bounds(x, y)
            && (grid.get(x + 1, y) == Cell::Unknown && PackedGrid::in_bounds(x + 1, y)
                || grid.get(x - 1, y) == Cell::Unknown && PackedGrid::in_bounds(x - 1, y)
                || grid.get(x, y + 1) == Cell::Unknown && PackedGrid::in_bounds(x, y + 1)
                || grid.get(x, y - 1) == Cell::Unknown && PackedGrid::in_bounds(x, y - 1))
    }

    /// Moves the window by `(sx, sy)` cells ([`crate::rolling::shift`]): the last step's
    /// frontiers are translated (those leaving the window dropped) and the per-block counts move
    /// by whole blocks. `sx` and `sy` must be multiples of [`BLOCK_CELLS`]. Returns the work
    /// (entries touched) and the frontiers dropped.
    pub(crate) fn shift(&mut self, sx: i32, sy: i32) -> (u32, u32) {
        debug_assert!(sx % BLOCK_CELLS as i32 == 0 && sy % BLOCK_CELLS as i32 == 0);
        let b = BLOCK_CELLS as i64;
        crate::grid::shift_2d(&mut self.block_counts, BLOCKS, sx as i64 / b, sy as i64 / b, 0);
        let n = self.frontiers.len();
        self.frontiers.retain_mut(|f| {
            f.centroid = (f.centroid.0 - sx, f.centroid.1 - sy);
            f.anchor = (f.anchor.0 - sx, f.anchor.1 - sy);
            PackedGrid::in_bounds(f.anchor.0, f.anchor.1) && PackedGrid::in_bounds(f.centroid.0, f.centroid.1)
        });
        ((BLOCKS * BLOCKS + n) as u32, (n - self.frontiers.len()) as u32)
    }

    /// Recomputes the frontiers of both maps. Returns the work done (cells visited).
    pub fn compute(&mut self, lidar: &LidarGrid, visual: &VisualGrid, min_cells: u16) -> u32 {
        self.frontiers.clear();
        self.block_counts.fill(0);
        self.stats = FrontierStats::default();
        let mut work = 0;
        work += self.extract(&lidar.grid, FrontierSource::Lidar, min_cells);
        work += self.extract(&visual.grid, FrontierSource::Visual, min_cells);
        work
    }

    fn extract(&mut self, grid: &PackedGrid, source: FrontierSource, min_cells: u16) -> u32 {
        self.mask.clear();
        let mut work = GRID_CELLS as u32 * GRID_CELLS as u32;
        // Sixteen cells a word ([`Self::is_frontier`] word-wise): a free cell with an unknown
        // 4-neighbour inside the grid. `LOW` marks each cell's low bit.
        const LOW: u32 = 0x5555_5555;
        const ROW_WORDS: usize = GRID_CELLS / 16;
        let bytes = grid.as_bytes();
        let word = |y: usize, w: usize| {
            let i = (y * ROW_WORDS + w) * 4;
            u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]])
        };
        // Free = 0b01; unknown = 0b00 or 0b11 ([`Cell::from_bits`]): at each cell's low bit.
        let free = |v: u32| v & LOW & !(v >> 1);
        let unknown = |v: u32| !(v ^ (v >> 1)) & LOW;
        for y in 0..GRID_CELLS {
            for w in 0..ROW_WORDS {
                let f = free(word(y, w));
                if f == 0 {
                    continue;
                }
                let here = unknown(word(y, w));
                let mut near = (here << 2) | (here >> 2);
                if w > 0 {
                    near |= unknown(word(y, w - 1)) >> 30;
                }
                if w + 1 < ROW_WORDS {
                    near |= (unknown(word(y, w + 1)) & 1) << 30;
                }
                if y > 0 {
                    near |= unknown(word(y - 1, w));
                }
                if y + 1 < GRID_CELLS {
                    near |= unknown(word(y + 1, w));
                }
                let mut hits = f & near;
                while hits != 0 {
                    let slot = hits.trailing_zeros() as usize / 2;
                    hits &= hits - 1;
                    let (x, yi) = ((w * 16 + slot) as i32, y as i32);
                    debug_assert!(Self::is_frontier(grid, x, yi));
                    self.mask.put(x, yi, true);
                    self.stats.cells += 1;
                    let bi = (y / BLOCK_CELLS) * BLOCKS + x as usize / BLOCK_CELLS;
                    self.block_counts[bi] = self.block_counts[bi].saturating_add(1);
                }
            }
        }
        let mut kept = 0usize;
        // The frontier cells in row-major order, a mask word (32 cells) at a time: each flood
        // clears its cells, so re-reading the word gives the next cell no flood has taken yet,
        // exactly as a cell-by-cell scan would.
        let mut w = 0;
        while w < self.mask.words().len() {
            let word = self.mask.words()[w];
            if word == 0 {
                w += 1;
                continue;
            }
            let i = w * 32 + word.trailing_zeros() as usize;
            let (x, y) = ((i % GRID_CELLS) as i32, (i / GRID_CELLS) as i32);
            let n = self.flood(x, y);
            work += n as u32 * 9;
            if n < min_cells as usize {
                self.stats.dropped_small += 1;
                continue;
            }
            // Split long groups into consecutive pieces; a short tail joins the last piece.
            let pieces = (n / SPLIT_CELLS).max(1);
            for p in 0..pieces {
                let lo = p * n / pieces;
                let hi = (p + 1) * n / pieces;
                let f = self.summarise(source, lo, hi);
                if kept < MAX_FRONTIERS_PER_GRID && self.frontiers.push(f).is_ok() {
                    kept += 1;
                } else {
                    self.stats.dropped_capacity += 1;
                }
            }
        }
        work
    }

    /// 8-connected flood fill from a frontier cell, clearing the mask as it goes; the members end
    /// up in `self.members[..n]` in breadth-first order. Returns `n`.
    fn flood(&mut self, x0: i32, y0: i32) -> usize {
        let mut head = 0;
        let mut tail = 0;
        self.mask.put(x0, y0, false);
        self.members[tail] = (y0 as u32) << 16 | x0 as u32;
        tail += 1;
        while head < tail {
            let m = self.members[head];
            head += 1;
            let (x, y) = ((m & 0xFFFF) as i32, (m >> 16) as i32);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (nx, ny) = (x + dx, y + dy);
                    if (dx != 0 || dy != 0) && self.mask.get(nx, ny) {
                        if tail == FRONTIER_QUEUE {
                            self.stats.truncated += 1;
                            return tail;
                        }
                        self.mask.put(nx, ny, false);
                        self.members[tail] = (ny as u32) << 16 | nx as u32;
                        tail += 1;
                    }
                }
            }
        }
        tail
    }

    fn summarise(&self, source: FrontierSource, lo: usize, hi: usize) -> Frontier {
        let (mut sx, mut sy) = (0i64, 0i64);
        for &m in &self.members[lo..hi] {
            sx += (m & 0xFFFF) as i64;
            sy += (m >> 16) as i64;
        }
        let n = (hi - lo) as i64;
        let c = ((sx / n) as i32, (sy / n) as i32);
        let mut best = (i64::MAX, (0, 0));
        for &m in &self.members[lo..hi] {
            let (x, y) = ((m & 0xFFFF) as i32, (m >> 16) as i32);
            let d = ((x - c.0) as i64).pow(2) + ((y - c.1) as i64).pow(2);
            if d < best.0 {
                best = (d, (x, y));
            }
        }
        Frontier { source, cells: (hi - lo) as u16, centroid: c, anchor: best.1 }
    }
}

impl Default for FrontierSet {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::boxed::Box;

    /// The word-wise scan finds exactly the cells [`FrontierSet::is_frontier`] calls frontier
    /// cells, block by block, on grids of every mix of free, unknown and occupied cells,
    /// the grid's edges and the words' edges included.
    #[test]
    fn the_word_wise_scan_finds_exactly_the_frontier_cells() {
        let mut rng = fixed_point::SplitMix64(1);
        for (free_pct, occupied_pct) in [(50, 10), (90, 5), (30, 30), (98, 1)] {
            let mut grid = Box::new(PackedGrid::new());
            for y in 0..GRID_CELLS as i32 {
                for x in 0..GRID_CELLS as i32 {
                    let r = rng.below(100) as u32;
                    let c = if r < free_pct {
                        Cell::Free
                    } else if r < free_pct + occupied_pct {
                        Cell::Occupied
                    } else {
                        Cell::Unknown
                    };
                    grid.set(x, y, c);
                }
            }
            let mut expected = std::vec![0u16; BLOCKS * BLOCKS];
            let mut cells = 0;
            for y in 0..GRID_CELLS as i32 {
                for x in 0..GRID_CELLS as i32 {
                    if FrontierSet::is_frontier(&grid, x, y) {
                        cells += 1;
                        expected[(y as usize / BLOCK_CELLS) * BLOCKS + x as usize / BLOCK_CELLS] += 1;
                    }
                }
            }
            let mut f = Box::new(FrontierSet::new());
            f.extract(&grid, FrontierSource::Lidar, 1);
            assert!(cells > 1000, "{cells} frontier cells: the grid does not test much");
            assert_eq!(f.stats.cells, cells, "free {free_pct} %, occupied {occupied_pct} %");
            assert!(f.block_counts[..] == expected[..], "free {free_pct} %, occupied {occupied_pct} %: block counts differ");
        }
    }
}
