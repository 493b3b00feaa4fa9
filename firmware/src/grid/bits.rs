//! [`BitGrid`]: a bit per cell of the grid (masks: the frontier cells, the traversable cells, a
//! scan's marks).

use super::{shift_2d, PackedGrid};
use crate::capacity::{GRID_AREA, GRID_CELLS};

/// A bit per cell.
#[derive(Clone)]
pub struct BitGrid {
    bits: [u32; GRID_AREA / 32],
}

impl BitGrid {
    /// All clear.
    pub const fn new() -> Self {
        Self { bits: [0; GRID_AREA / 32] }
    }
    /// Bit at `(x, y)`; false out of bounds.
    #[inline]
    pub fn get(&self, x: i32, y: i32) -> bool {
        PackedGrid::index(x, y).is_some_and(|i| self.at(i))
    }
    /// Bit `i` in row-major order (`PackedGrid::index`); `i` must be in the grid.
    #[inline]
    pub fn at(&self, i: usize) -> bool {
        self.bits[i >> 5] & (1 << (i & 31)) != 0
    }
    /// Sets or clears the bit at `(x, y)` (ignored out of bounds).
    #[inline]
    pub fn put(&mut self, x: i32, y: i32, v: bool) {
        let Some(i) = PackedGrid::index(x, y) else {
            return;
        };
        if v {
            self.bits[i >> 5] |= 1 << (i & 31);
        } else {
            self.bits[i >> 5] &= !(1 << (i & 31));
        }
    }
    /// Clears every bit.
    pub fn clear(&mut self) {
        self.bits.fill(0);
    }
    /// The words, 32 cells each, row-major.
    pub fn words(&self) -> &[u32] {
        &self.bits
    }
    /// The words, to write.
    pub fn words_mut(&mut self) -> &mut [u32] {
        &mut self.bits
    }

    /// Moves the window by `(sx, sy)` cells (see [`PackedGrid::shift`]); new cells are `fill`.
    /// `sx` must be a multiple of 32 (a word).
    pub(crate) fn shift(&mut self, sx: i32, sy: i32, fill: bool) {
        debug_assert!(sx % 32 == 0);
        shift_2d(&mut self.bits, GRID_CELLS / 32, sx as i64 / 32, sy as i64, if fill { u32::MAX } else { 0 });
    }
}

impl Default for BitGrid {
    fn default() -> Self {
        Self::new()
    }
}
