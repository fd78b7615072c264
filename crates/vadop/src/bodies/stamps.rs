//! The bodies' velocity stamps: a body's stamp changes whenever its motion does (or its proxy is
//! renewed), so a prediction carrying an older stamp is void, and a record of the stamps bumped
//! since a mark tells the predictions made before it still current.
//!
//! It owns how a stamp moves on: one step for every change, and for a wall bounce foreseen at a
//! window's start (see `pipeline::foreseen`) [`FORESEEN_STEP`] in all, a stamp no run of ordinary
//! changes within a window reaches. It never decides what a change is.

use super::Bodies;

/// How far a foreseen bounce moves a body's stamp on: a quarter turn of the stamps, so no run of
/// ordinary changes (one step each) reaches a foreseen stamp, nor does a foreseen bounce bring
/// back one of the window's earlier stamps.
pub(crate) const FORESEEN_STEP: u32 = 1 << 30;

impl Bodies {
    /// Body `i`'s stamp (see [`super::BodyTag::stamp`]).
    #[inline]
    pub fn stamp(&self, i: usize) -> u32 {
        self.tags[i].stamp
    }

    /// True when body `i` is live with `stamp`: a prediction stamped so was made from its
    /// present motion. The stamp alone tells: predictions are made of live bodies only, and a
    /// removal renews the stamp, so no prediction holds a removed body's stamp; `alive` (a line
    /// of its own) is not read on the event loop's every check.
    #[inline]
    pub fn has_stamp(&self, i: usize, stamp: u32) -> bool {
        let current = self.stamp(i) == stamp;
        debug_assert!(!current || self.alive[i], "a prediction holds removed body {i}'s stamp");
        current
    }

    /// Voids body `i`'s predictions without changing its motion (its proxy is being renewed).
    /// Every change of a stamp comes through here (a foreseen bounce then steps on, see
    /// [`Self::take_foreseen`]).
    #[inline]
    pub(crate) fn renew(&mut self, i: usize) {
        self.tags[i].stamp = self.tags[i].stamp.wrapping_add(1);
        if let Some(word) = self.bumped.get_mut(i / 64) {
            *word |= 1 << (i % 64);
        }
    }

    /// Body `i`'s velocity change, just made (its stamp bumped once), is the bounce foreseen at
    /// the window's start: its stamp moves on to the one the foreseen path's predictions carry,
    /// [`FORESEEN_STEP`] past its stamp before the bounce, which no other change gives it.
    #[inline]
    pub(crate) fn take_foreseen(&mut self, i: usize) {
        let stamp = &mut self.tags[i].stamp;
        *stamp = stamp.wrapping_add(FORESEEN_STEP - 1);
    }

    /// Starts a record of the stamps bumped from now on (see [`Self::bumped_since_mark`]).
    pub(crate) fn mark_stamps(&mut self) {
        self.bumped.clear();
        self.bumped.resize(self.slots().div_ceil(64), 0);
    }

    /// True when the stamp of body `i` (present at the last [`Self::mark_stamps`]) was bumped
    /// since: a prediction current at the mark is current now exactly when neither of its bodies'
    /// stamps was bumped (a stamp comes back to a value only after 2^32 bumps). One bit a body, so the
    /// record of 10^5 bodies stays in cache where their stamps lie in as many random lines.
    #[inline]
    pub(crate) fn bumped_since_mark(&self, i: usize) -> bool {
        self.bumped[i / 64] >> (i % 64) & 1 == 1
    }
}
