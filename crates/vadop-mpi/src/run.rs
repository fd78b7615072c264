//! A run over all ranks, frame by frame: each rank builds the scene from its seed (or reads the
//! scene or saved state itself), keeps the bodies of its brick, and then, at every frame start,
//! hands the bodies that left its brick to their new owners and copies the bodies near each
//! neighbour's border to it; steps its part; and sends the contacts it keeps to rank 0, which
//! writes them in the one-process order.
//!
//! The ghost layer is wide enough that every pair that can touch within a frame is held by the
//! owner of its lower id: two bodies that touch within a frame start at most the two distances
//! they travel plus their radii apart. A body that would travel farther, or that leaves the
//! bricks next to its owner's, ends the run with an error naming it: a contact is never missed.
//! It never computes a contact itself (the parts' worlds do).

use crate::bricks::Bricks;
use crate::comm::Comm;
use crate::part::{Layout, Moves, Part, Travel};
use crate::wire::{self, Parcel, BODY_WORDS, CONTACT_WORDS};
use glam::DVec3;
use std::time::Instant;
use vadop::{BodyHandle, BoxBounds, Contact, Mode, SphereRecord, World, WorldConfig};

/// A scene or saved world as every rank reads it: the box, the settings, the clock, and every
/// body with its global id.
pub struct Start {
    pub bounds: BoxBounds,
    pub config: WorldConfig,
    pub time: f64,
    pub bodies: Vec<(BodyHandle, SphereRecord)>,
    /// Frames stepped before (a resumed run's frame numbers go on from them).
    pub frames_done: u64,
}

/// What a run is asked to do besides the scene.
pub struct Plan {
    pub frames: u64,
    pub dt: f64,
    /// Width of the ghost layer; `None`: from the bodies' speeds (see [`ghost_width`]).
    pub ghost_width: Option<f64>,
    /// Where to save the whole world after every frame, as one process saves it.
    pub save_state: Option<std::path::PathBuf>,
    /// This rank dies at the start of this frame (a fault the tests inject).
    pub fail_at: Option<(usize, u64)>,
}

/// One frame's figures, summed or maximised over the ranks at rank 0.
#[derive(Debug, Default, Clone, Copy, serde::Serialize)]
pub struct FrameFigures {
    pub frame: u64,
    pub contacts: u64,
    pub pair_contacts: u64,
    /// Wall-clock ms of the frame's step, the slowest rank's and the mean over ranks.
    pub step_ms_max: f64,
    pub step_ms_mean: f64,
    /// Wall-clock ms of the frame's exchanges (bodies, contacts), the slowest rank's.
    pub exchange_ms_max: f64,
    /// Bytes sent, per rank: the mean and the largest.
    pub bytes_mean: f64,
    pub bytes_max: u64,
    /// Bodies owned and copies held, per rank.
    pub owned_min: u64,
    pub owned_max: u64,
    pub ghosts_mean: f64,
    pub ghosts_max: u64,
    /// Bodies that changed owner at the frame's start.
    pub migrated: u64,
}

/// Why a run cannot be split over ranks, or `None`.
pub fn refusal(start: &Start) -> Option<String> {
    let config = &start.config;
    if config.mode == Mode::Simulate {
        return Some(
            "simulate mode is not split over ranks yet: bodies that collide near a border change each other's paths, \
             and the ranks would have to agree on every such event in time order (docs/mpi.md says how it will be done); \
             use --mode detect, or run `vadop simulate` on one machine"
                .to_string(),
        );
    }
    if config.contact_ends {
        return Some("contact ends are not reported across ranks yet: drop --contact-ends".to_string());
    }
    if start.bounds.is_periodic() {
        return Some(
            "periodic boxes are not split over ranks yet (a pair across a face is named by the lower id's image, \
             which another rank may not hold): use a walled box"
                .to_string(),
        );
    }
    None
}

pub fn position_at(record: &SphereRecord, t: f64, gravity: DVec3) -> DVec3 {
    vadop::motion::Motion { position: record.position, since: record.since, velocity: record.velocity }
        .at_under(t, gravity)
}

pub fn velocity_at(record: &SphereRecord, t: f64, gravity: DVec3) -> DVec3 {
    vadop::motion::Motion { position: record.position, since: record.since, velocity: record.velocity }
        .velocity_under(t, gravity)
}

/// The largest speed and radius of `bodies` at `time`.
fn fastest(bodies: &[(BodyHandle, SphereRecord)], time: f64, gravity: DVec3) -> (f64, f64) {
    bodies
        .iter()
        .fold((0.0f64, 0.0f64), |(v, r), (_, b)| (v.max(velocity_at(b, time, gravity).length()), r.max(b.radius)))
}

/// The ghost layer a run needs: two bodies that touch within a frame start at most their two
/// reaches and radii apart, so a layer of twice the largest reach plus twice the largest radius
/// holds every partner an owned body can touch (with a tenth to spare, for gravity's speeding up).
pub fn ghost_width((speed, radius): (f64, f64), dt: f64, gravity: DVec3) -> f64 {
    1.1 * (2.0 * Travel { speed, gravity: gravity.length(), dt }.over(1) + 2.0 * radius)
}

/// Steps the run; `on_frame` is called at rank 0 with each frame's number, its contacts in the
/// one-process order (gathered only when `gather` is set: at scale that is rank 0's load alone)
/// and its figures. Returns the ghost layer's width, or the error that ended the run early,
/// naming the rank.
pub fn run(
    comm: &mut Comm,
    start: Start,
    plan: &Plan,
    gather: bool,
    mut on_frame: impl FnMut(u64, &[Contact], &FrameFigures) -> Result<(), String>,
) -> Result<f64, String> {
    let me = comm.rank;
    let gravity = start.config.gravity;
    let positions: Vec<DVec3> = start.bodies.iter().map(|(_, b)| position_at(b, start.time, gravity)).collect();
    let bricks = Bricks::cut(&start.bounds, &positions, comm.size);
    let (speed, radius) = fastest(&start.bodies, start.time, gravity);
    let width = plan.ghost_width.unwrap_or_else(|| ghost_width((speed, radius), plan.dt, gravity));
    // In detect mode no body speeds up but by gravity: a bound on every speed from now on.
    let travel_at =
        |t: f64| Travel { speed: speed + gravity.length() * (t - start.time), gravity: gravity.length(), dt: plan.dt };
    // A body held here is held by no rank farther than two layers from this brick.
    let near = bricks.near(me, 2.0 * width);
    let layout = Layout { bricks: &bricks, me, near: &near, width };
    let mut part = Part::new(start.bounds, start.config, start.time);
    let mine: Vec<Parcel> = start
        .bodies
        .iter()
        .zip(&positions)
        .filter(|(_, &p)| bricks.distance(me, p) <= width)
        .map(|(&(id, record), _)| Parcel { id, record })
        .collect();
    drop(positions);
    drop(start.bodies);
    let first = start.frames_done + 1;
    part.take(&mine, &layout, first + 1).map_err(|e| format!("rank {me}: {e}"))?;
    drop(mine);
    let mut outgoing = vec![Vec::new(); comm.size];
    let (mut kept, mut words, mut parcels) = (Vec::new(), Vec::new(), Vec::new());
    for frame in first..first + plan.frames {
        if plan.fail_at == Some((me, frame)) {
            std::process::abort();
        }
        let exchange_started = Instant::now();
        for words in &mut outgoing {
            words.clear();
        }
        // The first frame's bodies were placed from the scene itself.
        let moves = match frame == first {
            true => Moves::default(),
            false => part
                .frame_start(&layout, frame, &travel_at(part.time()), &mut outgoing)
                .map_err(|e| format!("rank {me}: {e}"))?,
        };
        let incoming = comm.exchange(&near, &outgoing);
        parcels.clear();
        parcels.extend(incoming.chunks_exact(BODY_WORDS).map(Parcel::decode));
        part.take(&parcels, &layout, frame + 1).map_err(|e| format!("rank {me}: {e}"))?;
        check_reaches(comm, &part, (&travel_at(part.time()), radius), frame, width)?;
        let exchange_ms = exchange_started.elapsed().as_secs_f64() * 1e3;
        let step_started = Instant::now();
        kept.clear();
        part.step(plan.dt, &mut kept).map_err(|e| format!("rank {me}: frame {frame}: {e}"))?;
        let step_ms = step_started.elapsed().as_secs_f64() * 1e3;
        let gather_started = Instant::now();
        words.clear();
        if gather {
            for contact in &kept {
                wire::encode_contact(contact, &mut words);
            }
        }
        let gathered = comm.gather(&words);
        let exchange_ms = exchange_ms + gather_started.elapsed().as_secs_f64() * 1e3;
        let (owned, ghosts) = part.counts();
        let pairs = kept.iter().filter(|c| matches!(c.touched, vadop::Touched::Body(_))).count() as u64;
        let bytes = comm.take_bytes_sent();
        let maxima = comm.max(&[step_ms, exchange_ms, bytes as f64, owned as f64, ghosts as f64, -(owned as f64)]);
        let sums = comm.sum(&[bytes, ghosts, moves.taken_over, kept.len() as u64, pairs]);
        let step_sum = comm.sum(&[step_ms])[0];
        if let Some(gathered) = gathered {
            let mut contacts: Vec<Contact> =
                gathered.iter().flat_map(|w| w.chunks_exact(CONTACT_WORDS).map(wire::decode_contact)).collect();
            contacts.sort_by(wire::contact_order);
            let ranks = comm.size as f64;
            let figures = FrameFigures {
                frame,
                contacts: sums[3],
                pair_contacts: sums[4],
                step_ms_max: maxima[0],
                step_ms_mean: step_sum / ranks,
                exchange_ms_max: maxima[1],
                bytes_mean: sums[0] as f64 / ranks,
                bytes_max: maxima[2] as u64,
                owned_min: (-maxima[5]) as u64,
                owned_max: maxima[3] as u64,
                ghosts_mean: sums[1] as f64 / ranks,
                ghosts_max: maxima[4] as u64,
                migrated: sums[2],
            };
            on_frame(frame, &contacts, &figures)?;
        }
        if let Some(path) = &plan.save_state {
            save(comm, &part, start.config, start.bounds, path)?;
        }
    }
    Ok(width)
}

/// Every pair an owned body can touch in the coming frame must be held here: two bodies that
/// touch start at most their two reaches and radii apart, which must fit in the ghost layer. The
/// speed bound settles it at once unless gravity has sped bodies up; then the bodies are checked
/// one by one, the fastest against the fastest anywhere.
fn check_reaches(
    comm: &Comm,
    part: &Part,
    (travel, radius): (&Travel, f64),
    frame: u64,
    width: f64,
) -> Result<(), String> {
    if 2.0 * travel.over(1) + 2.0 * radius <= width {
        return Ok(());
    }
    let reach = |speed: f64| Travel { speed, ..*travel }.over(1);
    let fastest = part.owned_speeds().fold(0.0f64, |v, (_, speed, _)| v.max(speed));
    let largest = comm.max(&[reach(fastest)])[0];
    for (id, speed, own_radius) in part.owned_speeds() {
        let own = reach(speed);
        let apart = own + largest + own_radius + radius;
        if apart > width {
            return Err(format!(
                "rank {}: body {id} would travel {own} in frame {frame}: with the fastest body's {largest} and the \
                 largest radius, two bodies could meet from {apart} apart, farther than the ghost layer ({width}); \
                 give --ghost-width at least {apart}, or shorter frames",
                comm.rank
            ));
        }
    }
    Ok(())
}

/// Writes the whole world, as one process would save it, from every rank's owned bodies: a file
/// `vadop simulate --resume` takes, or a run on any number of ranks.
fn save(
    comm: &mut Comm,
    part: &Part,
    config: WorldConfig,
    bounds: BoxBounds,
    path: &std::path::Path,
) -> Result<(), String> {
    let mut words = Vec::new();
    for (id, record) in part.owned() {
        Parcel { id, record }.encode(&mut words);
    }
    let Some(gathered) = comm.gather(&words) else { return Ok(()) };
    let mut bodies: Vec<Parcel> =
        gathered.iter().flat_map(|w| w.chunks_exact(BODY_WORDS).map(Parcel::decode)).collect();
    bodies.sort_unstable_by_key(|p| p.id.to_bits());
    let mut world = World::new(bounds, config).map_err(|e| e.to_string())?;
    world.start_at(part.time()).map_err(|e| e.to_string())?;
    for parcel in &bodies {
        let handle = world.add_record(&parcel.record).map_err(|e| format!("saving body {}: {e}", parcel.id))?;
        if handle != parcel.id {
            return Err(format!("saving body {}: the one-process world would name it {handle}", parcel.id));
        }
    }
    world.save(path).map_err(|e| e.to_string())
}
