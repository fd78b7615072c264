//! One rank's part of the world: a `vadop::World` over the whole box holding every body within
//! the ghost layer of this rank's brick — the bodies it owns (centred in its brick) and copies of
//! its neighbours' bodies near its border (its ghosts) — each named by its global id, the number
//! of its handle in the one-process world.
//!
//! Which ranks hold a body is a function of its position at the frame start alone: the ranks
//! whose bricks lie within the ghost layer of it. Every rank that holds a body moves it alike (in
//! detect mode a body's path depends on nothing else), so all of them agree on its position to
//! the bit and on who holds it: a body changes owner without a message (the new owner holds it
//! already), a rank drops a copy that left its layer by itself, and the owner sends a body only
//! to the ranks whose layers it has just entered. Bodies come in between frames, as records on
//! the very motions the other ranks hold, so every rank that holds a pair computes the same
//! canonical contact for it. A pair's contact is kept by the rank that owns the pair's lower id,
//! a wall contact by the body's owner: each contact of the whole world is kept exactly once. It
//! never talks to another rank.

use crate::bricks::Bricks;
use crate::wire::Parcel;
use glam::DVec3;
use vadop::{BodyHandle, BoxBounds, Contact, Result, SphereRecord, Touched, World, WorldConfig};

pub struct Part {
    bounds: BoxBounds,
    config: WorldConfig,
    /// `None` while the part holds no body: a world steps only with bodies in it.
    world: Option<World>,
    /// The time the whole world has reached, added up frame by frame as a world adds it.
    time: f64,
    held: Vec<Held>,
    /// Per local slot: the global id of the body there and whether this rank owns it, to name
    /// and keep contacts.
    by_slot: Vec<Option<(BodyHandle, bool)>>,
}

#[derive(Debug, Clone, Copy)]
struct Held {
    global: BodyHandle,
    local: BodyHandle,
    /// Its centre at the last frame start it was looked at, which says which ranks held it since.
    start: DVec3,
    owned: bool,
    /// The first frame at whose start it may have come near a border (see [`Layout::margin`]):
    /// before that nothing about it can change, so it is not looked at.
    check_at: u64,
}

/// The farthest any body can travel from a frame start on: at most its speed bound (which grows
/// only under gravity: in detect mode pairs do not touch velocities and walls do not speed bodies
/// up) for the time, plus gravity's bend.
#[derive(Debug, Clone, Copy)]
pub struct Travel {
    pub speed: f64,
    pub gravity: f64,
    pub dt: f64,
}

impl Travel {
    /// How far a body may go in `frames` frames.
    pub fn over(&self, frames: u64) -> f64 {
        let t = frames as f64 * self.dt;
        self.speed * t + 0.5 * self.gravity * t * t
    }

    /// The frames after which a body `margin` from every border may have crossed one.
    fn frames_within(&self, margin: f64) -> u64 {
        // Rounding in the margin's arithmetic is far below this share of it.
        let margin = margin * (1.0 - 1e-9);
        let mut frames = 0;
        while frames < MAX_SKIPPED_FRAMES && self.over(frames + 1) < margin {
            frames += 1;
        }
        frames
    }
}

/// A body is looked at at least this often, so the search for its next look stays short.
const MAX_SKIPPED_FRAMES: u64 = 64;

/// The layout of the run: the bricks, this rank, the ranks near it and the ghost layer's width.
pub struct Layout<'a> {
    pub bricks: &'a Bricks,
    pub me: usize,
    /// The other ranks a body held here may go to.
    pub near: &'a [usize],
    pub width: f64,
}

impl Layout<'_> {
    /// Whether rank `rank` holds a body centred at `p` (its brick lies within the layer of it).
    fn holds(&self, rank: usize, p: DVec3) -> bool {
        self.bricks.distance(rank, p) <= self.width
    }

    /// How far a body centred at `p` must move before anything this rank decides about it can
    /// change: who owns it (the cuts around its owner's brick), and whether this rank and each
    /// near rank holds it (the edges of their ghost layers, a brick's depth or distance away). Each
    /// is a distance, which moves no faster than the body.
    fn margin(&self, p: DVec3) -> f64 {
        let mut margin = self.bricks.depth(self.bricks.owner(p), p);
        for rank in std::iter::once(self.me).chain(self.near.iter().copied()) {
            let edge = self.bricks.depth(rank, p) + self.width - self.bricks.distance(rank, p);
            margin = margin.min(edge.abs());
        }
        margin
    }
}

/// What a frame start did to the bodies held.
#[derive(Debug, Default, Clone, Copy)]
pub struct Moves {
    /// Bodies this rank took over from another, and copies it dropped.
    pub taken_over: u64,
    pub dropped: u64,
}

impl Part {
    pub fn new(bounds: BoxBounds, config: WorldConfig, time: f64) -> Part {
        Part { bounds, config, world: None, time, held: Vec::new(), by_slot: Vec::new() }
    }

    pub fn time(&self) -> f64 {
        self.time
    }

    /// The bodies this rank owns, with their global ids and records.
    pub fn owned(&self) -> impl Iterator<Item = (BodyHandle, SphereRecord)> + '_ {
        self.held.iter().filter(|h| h.owned).map(|h| {
            let world = self.world.as_ref().expect("a part holding bodies has a world");
            (h.global, world.record(h.local).expect("a held body"))
        })
    }

    /// Counts of the bodies held: (owned, ghosts).
    pub fn counts(&self) -> (u64, u64) {
        let owned = self.held.iter().filter(|h| h.owned).count() as u64;
        (owned, self.held.len() as u64 - owned)
    }

    /// Takes in `parcels` (bodies that entered this rank's layer, or a whole scene's bodies at
    /// the start) on their records, to be looked at next at frame `frame`; the caller sends a
    /// body only to the ranks that hold it.
    pub fn take(&mut self, parcels: &[Parcel], layout: &Layout, frame: u64) -> Result<()> {
        for parcel in parcels {
            let world = match &mut self.world {
                Some(world) => world,
                None => {
                    let mut world = World::new(self.bounds, self.config)?;
                    world.start_at(self.time)?;
                    self.world.insert(world)
                }
            };
            let local = world.add_record(&parcel.record)?;
            let start = world.sphere(local)?.position;
            let owned = layout.bricks.owner(start) == layout.me;
            self.held.push(Held { global: parcel.id, local, start, owned, check_at: frame });
            name_slot(&mut self.by_slot, local, Some((parcel.id, owned)));
        }
        Ok(())
    }

    /// The start of frame `frame`: each body near a border takes the owner its position gives, a
    /// copy that left this rank's layer is dropped, and each owned body that entered another
    /// rank's layer is written into `outgoing[rank]`. Bodies far from every border are not looked
    /// at until they may have come near one (`travel` bounds how fast). Fails, naming it, on a
    /// body that went beyond the ranks that held it.
    pub fn frame_start(
        &mut self,
        layout: &Layout,
        frame: u64,
        travel: &Travel,
        outgoing: &mut [Vec<u64>],
    ) -> std::result::Result<Moves, String> {
        let Some(world) = &mut self.world else { return Ok(Moves::default()) };
        let mut moves = Moves::default();
        let mut failure = None;
        let by_slot = &mut self.by_slot;
        self.held.retain_mut(|held| {
            if held.check_at > frame {
                return true;
            }
            let p = world.sphere(held.local).expect("a held body").position;
            let (before, owner) = (held.start, layout.bricks.owner(p));
            held.start = p;
            held.check_at = frame + 1 + travel.frames_within(layout.margin(p));
            if !layout.holds(owner, before) {
                // Its new owner did not hold it: it crossed more than the layer in a frame.
                failure.get_or_insert(format!(
                    "body {} at {p} went into rank {owner}'s brick from {before}, farther than the ghost layer ({}) \
                     in a frame; give --ghost-width more, or shorter frames",
                    held.global, layout.width
                ));
            }
            moves.taken_over += (owner == layout.me && !held.owned) as u64;
            held.owned = owner == layout.me;
            name_slot(by_slot, held.local, Some((held.global, held.owned)));
            if held.owned {
                for &rank in layout.near {
                    if layout.holds(rank, p) && !layout.holds(rank, before) {
                        let record = world.record(held.local).expect("a held body");
                        Parcel { id: held.global, record }.encode(&mut outgoing[rank]);
                    }
                }
            }
            let keep = layout.holds(layout.me, p);
            if !keep {
                world.remove_sphere(held.local).expect("a held body");
                name_slot(by_slot, held.local, None);
                moves.dropped += 1;
            }
            keep
        });
        if let Some(failure) = failure {
            return Err(failure);
        }
        if world.is_empty() {
            // A part emptied starts afresh when bodies come again.
            self.world = None;
        }
        Ok(moves)
    }

    /// Steps the part by `dt` and appends the contacts this rank keeps, named by global ids, to
    /// `kept`: a pair's when it owns the lower id, a wall's when it owns the body.
    pub fn step(&mut self, dt: f64, kept: &mut Vec<Contact>) -> Result<()> {
        let Some(world) = &mut self.world else {
            self.time += dt;
            return Ok(());
        };
        let by_slot = &self.by_slot;
        let global = |local: BodyHandle| by_slot[local.index() as usize].expect("a held body");
        for contact in world.step(dt)? {
            let (body, body_owned) = global(contact.body);
            match contact.touched {
                Touched::Wall(_) => {
                    if body_owned {
                        kept.push(Contact { body, ..*contact });
                    }
                }
                Touched::Body(other) => {
                    let (other, other_owned) = global(other);
                    // Named by the lower id, as the one-process world names it: the point is the
                    // same bits either way round (see vadop's pair geometry), the normal turns.
                    let (low, high, normal, owned) = match body.index() < other.index() {
                        true => (body, other, contact.normal, body_owned),
                        false => (other, body, -contact.normal, other_owned),
                    };
                    if owned {
                        kept.push(Contact { body: low, touched: Touched::Body(high), normal, ..*contact });
                    }
                }
            }
        }
        self.time = world.time();
        Ok(())
    }

    /// Each owned body's id, speed and radius now.
    pub fn owned_speeds(&self) -> impl Iterator<Item = (BodyHandle, f64, f64)> + '_ {
        self.held.iter().filter(|h| h.owned).map(|h| {
            let s =
                self.world.as_ref().expect("a part holding bodies has a world").sphere(h.local).expect("a held body");
            (h.global, s.velocity.length(), s.radius)
        })
    }
}

/// Names the body in local slot `local`'s slot (its global id and whether this rank owns it), or
/// clears it.
fn name_slot(by_slot: &mut Vec<Option<(BodyHandle, bool)>>, local: BodyHandle, name: Option<(BodyHandle, bool)>) {
    let slot = local.index() as usize;
    if by_slot.len() <= slot {
        by_slot.resize(slot + 1, None);
    }
    by_slot[slot] = name;
}
