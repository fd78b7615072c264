//! How the grid plans a window's paths before it bins them: the paths it bins ([`BinnedPaths`]),
//! how many pieces each path is cut into and which level they fit ([`PieceRule`]), the pieces
//! per level exponent ([`PlanPass`]), and what the binning then does with each piece a worker
//! takes ([`PieceSink`]: count it in its cell, or store it in the cell's next slot).

use crate::bodies::BodyState;
use crate::broad_phase::box_columns::BoxColumnsMut;
use crate::broad_phase::candidates::Owner;
use crate::broad_phase::proxy::{CompactBox, Foreseen, Path, Proxies, RELATIVE_PADDING};
use crate::window::Window;

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

/// What a window's start bins: every proxy (path `i` of body `i`), then each foreseen path (path
/// `slots + k` of `foreseen[k]`), each a path of its own with its owner's body, stamp and state.
#[derive(Clone, Copy)]
pub(super) struct BinnedPaths<'a> {
    pub(super) proxies: Proxies<'a>,
    pub(super) foreseen: &'a [Foreseen],
}

impl<'a> BinnedPaths<'a> {
    #[inline(always)]
    pub(super) fn len(&self) -> usize {
        self.proxies.slots() + self.foreseen.len()
    }

    /// True when path `i` is a foreseen one: what each read below takes as `ahead`. A loop over
    /// the proxies alone or the foreseen paths alone passes a constant instead, and its reads
    /// then ask nothing.
    #[inline(always)]
    pub(super) fn is_ahead(&self, i: usize) -> bool {
        i >= self.proxies.slots()
    }

    /// The foreseen path `i` is, if it is one (`ahead`).
    #[inline(always)]
    pub(super) fn foreseen(&self, i: usize, ahead: bool) -> Option<&'a Foreseen> {
        ahead.then(|| &self.foreseen[i - self.proxies.slots()])
    }

    #[inline(always)]
    pub(super) fn path(&self, i: usize, ahead: bool) -> Path {
        self.path_known(i, self.proxies.pull_free(), ahead)
    }

    /// [`Self::path`] where `pull_free` is the proxies' [`Proxies::pull_free`].
    #[inline(always)]
    pub(super) fn path_known(&self, i: usize, pull_free: bool, ahead: bool) -> Path {
        match self.foreseen(i, ahead) {
            Some(f) => self.proxies.path_ahead(f.body as usize, &f.state, &f.made.0),
            None => self.proxies.path_known(i, pull_free),
        }
    }

    #[inline(always)]
    pub(super) fn bbox(&self, i: usize, ahead: bool) -> CompactBox {
        self.foreseen(i, ahead).map_or_else(|| self.proxies.bbox(i), |f| f.made.0.bbox)
    }

    #[inline(always)]
    pub(super) fn window(&self, i: usize, ahead: bool) -> Window {
        self.foreseen(i, ahead).map_or_else(|| self.proxies.window_of(i), |f| Window::new(f.made.0.start, f.made.0.end))
    }

    /// The body and stamp path `i`'s pieces are entered with.
    #[inline(always)]
    pub(super) fn owner(&self, i: usize, ahead: bool) -> (u32, u32) {
        self.foreseen(i, ahead).map_or_else(|| (i as u32, self.proxies.stamp(i)), |f| (f.body, f.stamp))
    }

    #[inline(always)]
    pub(super) fn state(&self, i: usize, ahead: bool) -> &'a BodyState {
        self.foreseen(i, ahead).map_or_else(|| self.proxies.state(i), |f| &f.state)
    }
}

/// Pass 1 of the binning over a chunk of the paths: each path's piece count and level exponent,
/// and the pieces per exponent.
pub(super) struct PlanPass<'a> {
    rule: PieceRule,
    paths: BinnedPaths<'a>,
    per_exponent: Vec<(i32, usize)>,
    /// The pieces of the paths since the exponent last changed (most paths share one), added to
    /// the list when it changes: the list is searched once a run, not once a path.
    run: Option<(i32, usize)>,
}

impl<'a> PlanPass<'a> {
    /// A pass over `paths` cut by `rule`, no path planned yet.
    pub(super) fn new(rule: PieceRule, paths: BinnedPaths<'a>) -> PlanPass<'a> {
        PlanPass { rule, paths, per_exponent: Vec::new(), run: None }
    }

    /// Plans the paths `offset..offset + chunk.len()` into `chunk`: all foreseen ones when
    /// `AHEAD`, all proxies when not, under no pull when `PULL_FREE` (the proxies' own answer).
    #[inline(always)]
    pub(super) fn plan<const PULL_FREE: bool, const AHEAD: bool>(&mut self, offset: usize, chunk: &mut [(u32, u32)]) {
        let (rule, paths) = (self.rule, self.paths);
        for (k, plan) in chunk.iter_mut().enumerate() {
            let i = offset + k;
            if !AHEAD && !paths.proxies.is_live(i) {
                continue;
            }
            let (count, exponent) = rule.plan(&paths.path_known(i, PULL_FREE, AHEAD));
            *plan = (count, exponent as u32);
            match &mut self.run {
                Some((e, n)) if *e == exponent => *n += count as usize,
                _ => {
                    if let Some(ended) = self.run {
                        add_pieces(&mut self.per_exponent, ended);
                    }
                    self.run = Some((exponent, count as usize));
                }
            }
        }
    }

    /// The pieces per exponent of the paths planned.
    pub(super) fn per_exponent(mut self) -> Vec<(i32, usize)> {
        if let Some(ended) = self.run {
            add_pieces(&mut self.per_exponent, ended);
        }
        self.per_exponent
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

/// What the binning does with each piece a worker owns: count it in its cell, or store it in
/// the cell's next slot. A trait with always-inline methods rather than a closure: the store,
/// a closure called from the single-piece and the cut paths' loops, stayed a call (about 80
/// instructions a piece, its captures read back from memory each time). `ahead` says whether the
/// path is a foreseen one, a constant in each of the binning's loops, so no read asks.
pub(super) trait PieceSink {
    /// The one piece of path `path`: its box and window are the path's, read only if needed (the
    /// count needs neither).
    fn whole(&mut self, path: usize, cell: usize, ahead: bool);
    /// One of the pieces path `path` is cut into.
    fn piece(&mut self, path: usize, cell: usize, bbox: CompactBox, window: Window, ahead: bool);
}

/// Counts the pieces of the cells from `lowest` on.
pub(super) struct CountPieces<'a> {
    pub(super) counts: &'a mut [u32],
    pub(super) lowest: usize,
}

impl PieceSink for CountPieces<'_> {
    #[inline(always)]
    fn whole(&mut self, _: usize, cell: usize, _: bool) {
        self.counts[cell - self.lowest] += 1;
    }

    #[inline(always)]
    fn piece(&mut self, _: usize, cell: usize, _: CompactBox, _: Window, _: bool) {
        self.counts[cell - self.lowest] += 1;
    }
}

/// Stores each piece of the cells from `lowest` on in its cell's next slot (`next_slot`, from
/// `first_slot` on), with its owner and its path's motion.
pub(super) struct StorePieces<'a, 'p> {
    pub(super) paths: BinnedPaths<'p>,
    pub(super) next_slot: &'a mut [u32],
    pub(super) lowest: usize,
    pub(super) first_slot: usize,
    pub(super) owners: &'a mut [Owner],
    pub(super) boxes: BoxColumnsMut<'a>,
    pub(super) motions: &'a mut [BodyState],
}

impl PieceSink for StorePieces<'_, '_> {
    #[inline(always)]
    fn whole(&mut self, path: usize, cell: usize, ahead: bool) {
        let (bbox, window) = (self.paths.bbox(path, ahead), self.paths.window(path, ahead));
        self.piece(path, cell, bbox, window, ahead);
    }

    #[inline(always)]
    fn piece(&mut self, path: usize, cell: usize, bbox: CompactBox, window: Window, ahead: bool) {
        // Every read of the path before the first store: a store could be to the table the
        // reads go through, as far as the compiler knows, and it read the proxies' length and
        // checked the index again after each.
        let (body, stamp) = self.paths.owner(path, ahead);
        let state = self.paths.state(path, ahead);
        let next = &mut self.next_slot[cell - self.lowest];
        let slot = *next as usize;
        *next += 1;
        let k = slot - self.first_slot;
        self.owners[k] = Owner { body, stamp, window };
        self.boxes.set(k, bbox);
        self.motions[k] = *state;
    }
}
