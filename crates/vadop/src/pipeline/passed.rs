//! Pair contacts that change nothing: two spheres passing through each other in detect mode.
//!
//! It owns when their geometry (where they touch, the normal) is worked out: not in the event
//! loop, which runs on one thread, but once the step's events are done, by every worker. The
//! contact is reported in its place at once, with the two paths it happened on kept beside it; a
//! path copied outlives the bodies' later velocity changes (a wall bounce later in the step), and
//! each contact's geometry is a function of its own record alone, so the bits are those the event
//! loop would have computed, for every thread count. It never handles an event.

use crate::bodies::Bodies;
use crate::frame::Contact;
use crate::narrow_phase::contacts::{sphere_pair_geometry, SpherePath};
use crate::parallel::Workers;

/// A reported contact of spheres `i` and `j` whose geometry is still to be worked out.
#[derive(Debug, Clone, Copy)]
struct Pending {
    /// Its place in the step's contacts.
    contact: usize,
    i: u32,
    j: u32,
    /// The two spheres' paths at the contact.
    paths: [SpherePath; 2],
}

/// The step's contacts of spheres passing through each other whose geometry is pending, in the
/// order they were reported.
#[derive(Debug, Default)]
pub(super) struct PassedContacts {
    pending: Vec<Pending>,
}

impl PassedContacts {
    /// The contact of spheres `i` and `j`, reported at place `contact` of the step's contacts,
    /// gets its geometry from their paths now.
    #[inline]
    pub(super) fn defer(&mut self, bodies: &Bodies, (i, j): (u32, u32), contact: usize) {
        let paths = [SpherePath::of(bodies, i as usize), SpherePath::of(bodies, j as usize)];
        self.pending.push(Pending { contact, i, j, paths });
    }

    /// Works out the pending contacts' geometry into `contacts`, on every worker: each chunk of
    /// the contacts fills its own pending ones.
    pub(super) fn resolve(&mut self, bodies: &Bodies, contacts: &mut [Contact], workers: &Workers) {
        let Some(first) = self.pending.first().map(|p| p.contact) else { return };
        let pending = &self.pending;
        workers.chunks_mut(&mut contacts[first..], |offset, chunk| {
            let (start, end) = (first + offset, first + offset + chunk.len());
            let from = pending.partition_point(|p| p.contact < start);
            for p in pending[from..].iter().take_while(|p| p.contact < end) {
                let c = &mut chunk[p.contact - start];
                let (i, j) = ((p.i as usize, &p.paths[0]), (p.j as usize, &p.paths[1]));
                (c.point, c.normal) = sphere_pair_geometry(bodies, i, j, c.time);
            }
        });
        self.pending.clear();
    }

    /// Bytes held.
    pub(super) fn memory_bytes(&self) -> usize {
        self.pending.capacity() * std::mem::size_of::<Pending>()
    }
}
