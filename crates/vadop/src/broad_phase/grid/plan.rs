//! How the grid plans a window's paths before it bins them: how many pieces each path is cut into
//! and which level they fit ([`PieceRule`]), and the pieces per level exponent.

use crate::broad_phase::proxy::{Path, RELATIVE_PADDING};

/// What cutting a path into pieces reads of the grid: its base cell and the largest side of the
/// box. Copied out of it, so a pass over every path keeps them in registers rather than reading
/// them again for each path (a call in the pass's loop keeps the compiler from hoisting them).
#[derive(Debug, Clone, Copy)]
pub(super) struct PieceRule {
    pub(super) base_cell: f64,
    pub(super) largest_side: f64,
}

impl PieceRule {
    /// How many pieces `path` is cut into, and the exponent of the level they all fit.
    ///
    /// A piece's box is its diameter plus its stretch of path, widened by the padding of the
    /// swept box and by the single-precision rounding of the compact box (a few ulps of its
    /// coordinates, which reach across the whole box). The stretch is chosen so this widened box
    /// still fits a base cell: were the widening left out, every cut piece would land one level
    /// up, in cells of eight times the volume.
    #[inline(always)]
    pub(super) fn plan(&self, path: &Path) -> (u32, i32) {
        let Path { origin, velocity, radius, window, .. } = *path;
        let length = velocity.length() * window.duration();
        let scale = 1.0 + 4.0 * RELATIVE_PADDING;
        let widening = 4.0 * RELATIVE_PADDING * origin.abs().max_element()
            + 4.0 * f32::EPSILON as f64 * (self.largest_side + 2.0 * radius + length);
        // A hair shorter than the room left in a base cell, so rounding never pushes a piece up.
        let room = ((self.base_cell - widening) / scale - 2.0 * radius) * (1.0 - 1e-6);
        // `room.max(2r)` by one comparison, the same bits without `max`'s NaN fix-up: `room`
        // holds `-2r`, so it is NaN whenever `2r` is, and a NaN `room` gives `2r` either way; a
        // radius is positive, so no tie of zeros of two signs.
        let two_radii = 2.0 * radius;
        let limit = if room > two_radii { room } else { two_radii };
        // Most paths fit one piece: then the quotient is at most 1 (division rounds monotonically)
        // and its ceiling clamps to 1, so the division and the ceiling (a library call on the
        // baseline target) are skipped, and `length.min(limit)` is `length` (neither is NaN).
        if length <= limit && limit > 0.0 {
            return (1, self.exponent_for((two_radii + length) * scale + widening));
        }
        let count = (length / limit).ceil().clamp(1.0, u32::MAX as f64) as u32;
        (count, self.exponent_for((two_radii + length.min(limit)) * scale + widening))
    }

    /// The exponent of the level whose nominal cells hold a box of `extent`.
    #[inline(always)]
    fn exponent_for(&self, extent: f64) -> i32 {
        let mut exponent = 0;
        let mut cell = self.base_cell;
        while cell < extent && exponent < 1100 {
            cell *= 2.0;
            exponent += 1;
        }
        exponent
    }
}

/// Adds `count` pieces of level exponent `exponent` to the pieces per exponent.
#[inline]
pub(super) fn add_pieces(per_exponent: &mut Vec<(i32, usize)>, (exponent, count): (i32, usize)) {
    match per_exponent.iter_mut().find(|(e, _)| *e == exponent) {
        Some((_, n)) => *n += count,
        None => per_exponent.push((exponent, count)),
    }
}
