//! `plain-grid`: the plainest exact continuous broad phase, a *reference* pipeline of `vadop-bench
//! peers` that stands beside the libraries so the table says what a few hundred straightforward
//! lines achieve. It is not a product method and uses nothing of vadop's engine but the closed-form
//! sphere time ([`straight_pair_contact_time`]).
//!
//! Each frame starts from nothing (only the buffers are kept, so a steady run allocates nothing):
//! every body's box around its whole path in the frame (the polyline through its start, its wall
//! bounces and its end, grown by the radius; f32 bounds rounded outward), binned by a counting sort
//! into cubic cells 1.5x the mean box edge. Each pair of boxes that overlap is tested once, in the
//! cell holding the lower corner of their intersection, with the closed form on every piece of the
//! frame in which both bodies move in a straight line (the frame split at either's bounces). A
//! contact is a touch after a piece's start, or at the start of a piece that begins at a bounce:
//! vadop's own convention, so the set is the reference's.
//!
//! It owns the grid, the pieces read back from the trajectory file and the child job that times it.

use super::trajectory::{report, Frame, Reader};
use crate::CliResult;
use std::path::Path;
use std::time::Instant;
use vadop::glam::DVec3;
use vadop::motion::Motion;
use vadop::narrow_phase::spheres::straight_pair_contact_time;

/// The cell edge over the mean box edge.
const CELL_OVER_EDGE: f32 = 1.5;

/// At most this many cells per body (and a few more): in a box far larger than its bodies' paths
/// the cells grow instead, so the cell array stays proportional to n.
const CELLS_PER_BODY: usize = 8;

/// The child job: runs the grid over every frame of `trajectory`, writes the contacts to `out`
/// and prints the per-frame times (reading the file is not timed) and the peak memory.
pub fn time(trajectory: &Path, out: &Path) -> CliResult<()> {
    let mut reader = Reader::open(trajectory)?;
    if reader.n > Entry::BODY as usize {
        return Err(format!("the plain grid takes at most {} bodies", Entry::BODY));
    }
    let mut grid = PlainGrid::new(&reader);
    let (mut frame, mut contacts, mut frame_ms) = (Frame::default(), Vec::new(), Vec::new());
    for index in 0..reader.frames {
        reader.next_frame(&mut frame)?;
        let started = Instant::now();
        grid.detect(&frame, index as u32, &mut contacts);
        frame_ms.push(started.elapsed().as_secs_f64() * 1e3);
    }
    report(out, &contacts, &frame_ms)
}

/// The cells of one frame: cubes of edge 1 / `inverse` from `origin`, `dims` along each axis.
#[derive(Clone, Copy)]
struct Cells {
    origin: [f32; 3],
    inverse: f32,
    dims: [usize; 3],
}

impl Cells {
    /// The cell coordinate of `x` on `axis`, clamped into the grid. Monotonic in `x`, so the
    /// coordinate of the lower corner of two boxes' intersection is the larger of their lower
    /// corners' coordinates.
    #[inline]
    fn coordinate(&self, x: f32, axis: usize) -> usize {
        (((x - self.origin[axis]) * self.inverse) as usize).min(self.dims[axis] - 1)
    }

    #[inline]
    fn index(&self, x: usize, y: usize, z: usize) -> usize {
        (z * self.dims[1] + y) * self.dims[0] + x
    }

    fn count(&self) -> usize {
        self.dims.iter().product()
    }

    /// Calls `visit` with every cell the box `b` covers and the axes (bits 0, 1, 2) on which that
    /// cell is the box's first.
    #[inline]
    fn each_cell(&self, b: &[f32; 6], mut visit: impl FnMut(usize, u32)) {
        let (lo, hi) = (|a| self.coordinate(b[a], a), |a| self.coordinate(b[3 + a], a));
        let (x0, y0, z0) = (lo(0), lo(1), lo(2));
        for z in z0..=hi(2) {
            for y in y0..=hi(1) {
                for x in x0..=hi(0) {
                    let first = u32::from(x == x0) | u32::from(y == y0) << 1 | u32::from(z == z0) << 2;
                    visit(self.index(x, y, z), first);
                }
            }
        }
    }
}

/// A body in a cell: its box, and its index with, in the top three bits, the axes on which the
/// cell is the box's first. Two boxes' intersection starts in this cell when, on every axis, the
/// cell is the first of one of them: (the two masks OR'd) == 0b111.
#[derive(Clone, Copy, Default)]
struct Entry {
    b: [f32; 6],
    tag: u32,
}

impl Entry {
    const BODY: u32 = (1 << 29) - 1;
}

/// The grid and the buffers it reuses from frame to frame.
pub struct PlainGrid {
    dt: f64,
    radius: f64,
    /// Where a centre touches the walls: the box's corners moved in by the radius.
    low: DVec3,
    high: DVec3,
    /// Body i's straight pieces are `pieces[first[i]..first[i + 1]]`: the first from the frame
    /// start, each next from a wall bounce, its velocity the previous one reflected.
    pieces: Vec<Motion>,
    first: Vec<usize>,
    /// Per body its swept box: lower corner, then upper corner.
    boxes: Vec<[f32; 6]>,
    /// The counting sort: after binning, cell c's bodies are `entries[ends[c - 1]..ends[c]]`, in
    /// body order, their boxes copied in so a cell's pairs read contiguous memory.
    ends: Vec<u32>,
    entries: Vec<Entry>,
}

impl PlainGrid {
    pub fn new(file: &Reader) -> PlainGrid {
        let inset = DVec3::splat(file.radius);
        PlainGrid {
            dt: file.dt,
            radius: file.radius,
            low: DVec3::from_array(file.low) + inset,
            high: DVec3::from_array(file.high) - inset,
            pieces: Vec::new(),
            first: Vec::new(),
            boxes: Vec::new(),
            ends: Vec::new(),
            entries: Vec::new(),
        }
    }

    /// Appends frame `index`'s contacts, as (index, i, j) with i < j, to `contacts`.
    pub fn detect(&mut self, frame: &Frame, index: u32, contacts: &mut Vec<[u32; 3]>) {
        self.read_pieces(frame);
        let Some(cells) = self.bound(frame) else { return };
        self.bin(cells);
        self.pairs(index, contacts);
    }

    /// Every body's pieces: the file gives its start velocity and its bounce positions; a wall
    /// bounce negates the velocity along the wall's axis (restitution 1, exact).
    fn read_pieces(&mut self, frame: &Frame) {
        self.pieces.clear();
        self.first.clear();
        for (i, s) in frame.start.iter().enumerate() {
            self.first.push(self.pieces.len());
            let mut piece =
                Motion { position: DVec3::new(s[0], s[1], s[2]), since: 0.0, velocity: DVec3::new(s[3], s[4], s[5]) };
            self.pieces.push(piece);
            for k in frame.first_bounce[i]..frame.first_bounce[i + 1] {
                let at = DVec3::from_array(frame.bounce_at[k]);
                piece =
                    Motion { position: at, since: frame.bounce_time[k], velocity: self.bounced(at, piece.velocity) };
                self.pieces.push(piece);
            }
        }
        self.first.push(self.pieces.len());
    }

    /// The velocity after a bounce at `at`: `v` reflected off the nearest wall it moves towards.
    fn bounced(&self, at: DVec3, mut v: DVec3) -> DVec3 {
        let gap = |a: usize| match v[a] {
            x if x > 0.0 => self.high[a] - at[a],
            x if x < 0.0 => at[a] - self.low[a],
            _ => f64::INFINITY,
        };
        let axis = (1..3).fold(0, |best, a| if gap(a) < gap(best) { a } else { best });
        v[axis] = -v[axis];
        v
    }

    /// The swept boxes and the cells they are binned into; `None` without bodies.
    fn bound(&mut self, frame: &Frame) -> Option<Cells> {
        let r = self.radius;
        let (mut low, mut high, mut edges) = ([f32::MAX; 3], [f32::MIN; 3], 0.0f64);
        self.boxes.clear();
        for (i, end) in frame.end.iter().enumerate() {
            let (mut lo, mut hi) = (*end, *end);
            for piece in &self.pieces[self.first[i]..self.first[i + 1]] {
                for a in 0..3 {
                    lo[a] = lo[a].min(piece.position[a]);
                    hi[a] = hi[a].max(piece.position[a]);
                }
            }
            // Rounded to nearest, then one f32 step out: always outside the f64 bound.
            let b: [f32; 6] = std::array::from_fn(|k| {
                if k < 3 {
                    ((lo[k] - r) as f32).next_down()
                } else {
                    ((hi[k - 3] + r) as f32).next_up()
                }
            });
            for a in 0..3 {
                low[a] = low[a].min(b[a]);
                high[a] = high[a].max(b[3 + a]);
                edges += f64::from(b[3 + a] - b[a]);
            }
            self.boxes.push(b);
        }
        let n = self.boxes.len();
        if n == 0 {
            return None;
        }
        let mut edge = CELL_OVER_EDGE * (edges / (3 * n) as f64) as f32;
        loop {
            let dims = std::array::from_fn(|a| ((high[a] - low[a]) / edge) as usize + 1);
            let cells = Cells { origin: low, inverse: 1.0 / edge, dims };
            if cells.count() <= CELLS_PER_BODY * n + 64 {
                return Some(cells);
            }
            edge *= 1.25;
        }
    }

    /// The counting sort of the bodies into the cells they cover, in body order within a cell.
    fn bin(&mut self, cells: Cells) {
        let ends = &mut self.ends;
        ends.clear();
        ends.resize(cells.count(), 0);
        for b in &self.boxes {
            cells.each_cell(b, |c, _| ends[c] += 1);
        }
        let mut total = 0;
        for end in ends.iter_mut() {
            (*end, total) = (total, total + *end);
        }
        self.entries.clear();
        self.entries.resize(total as usize, Entry::default());
        for (i, b) in self.boxes.iter().enumerate() {
            cells.each_cell(b, |c, first| {
                self.entries[ends[c] as usize] = Entry { b: *b, tag: i as u32 | first << 29 };
                ends[c] += 1;
            });
        }
    }

    /// Every pair whose boxes overlap, tested in the one cell that holds the lower corner of the
    /// boxes' intersection.
    fn pairs(&self, index: u32, contacts: &mut Vec<[u32; 3]>) {
        let mut begin = 0;
        for &end in &self.ends {
            let members = &self.entries[begin..end as usize];
            begin = end as usize;
            for (k, e) in members.iter().enumerate() {
                let (p, i) = (&e.b, e.tag & Entry::BODY);
                for f in &members[k + 1..] {
                    let q = &f.b;
                    // Without branches between the six comparisons: most pairs fail one of them.
                    let overlap = (p[0] <= q[3]) & (q[0] <= p[3]) & (p[1] <= q[4]) & (q[1] <= p[4]);
                    if (e.tag | f.tag) >> 29 == 7 && overlap & (p[2] <= q[5]) & (q[2] <= p[5]) {
                        let j = f.tag & Entry::BODY;
                        if self.touch(i as usize, j as usize, index == 0) {
                            contacts.push([index, i, j]);
                        }
                    }
                }
            }
        }
    }

    /// Whether bodies i and j begin touching in the frame: the closed form on each piece in which
    /// both move straight, from the later of the two pieces' starts (the canonical reference, as
    /// vadop computes it) to the earlier of their ends. A touch at a piece's start is new only
    /// when one of the two pieces began with a bounce in this frame, or the motion began with the
    /// frame (`fresh`, the first); otherwise the pair overlaps from before.
    fn touch(&self, i: usize, j: usize, fresh: bool) -> bool {
        let (a_pieces, b_pieces) =
            (&self.pieces[self.first[i]..self.first[i + 1]], &self.pieces[self.first[j]..self.first[j + 1]]);
        let next = |pieces: &[Motion], k: usize| pieces.get(k + 1).map_or(self.dt, |m| m.since);
        let (mut a, mut b) = (0, 0);
        loop {
            let (end_a, end_b) = (next(a_pieces, a), next(b_pieces, b));
            let end = end_a.min(end_b);
            if let Some(t) = straight_pair_contact_time(&a_pieces[a], &b_pieces[b], 2.0 * self.radius) {
                if t < end && (t > 0.0 || a > 0 || b > 0 || fresh) {
                    return true;
                }
            }
            if end >= self.dt {
                return false;
            }
            // `end` is a bounce of a or of b (or of both at once): step past it.
            a += usize::from(end_a == end);
            b += usize::from(end_b == end);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::trajectory::{export, export_scene, read_contacts};
    use super::*;
    use rand::{Rng, SeedableRng};
    use vadop::{BoxBounds, Sphere};

    /// Exports `write`'s scene into a folder of its own, runs the grid over it and returns (its
    /// contacts, the brute-force reference).
    fn grid_and_reference(name: &str, write: impl FnOnce(&Path) -> CliResult<()>) -> (Vec<[u32; 3]>, Vec<[u32; 3]>) {
        let dir = std::env::temp_dir().join(format!("vadop-plain-grid-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        write(&dir).unwrap();
        let mut reader = Reader::open(&dir.join("trajectory.bin")).unwrap();
        let (mut grid, mut frame, mut found) = (PlainGrid::new(&reader), Frame::default(), Vec::new());
        for index in 0..reader.frames {
            reader.next_frame(&mut frame).unwrap();
            grid.detect(&frame, index as u32, &mut found);
        }
        let reference = read_contacts(&dir.join("reference.bin")).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        let sorted = found.len();
        found.sort_unstable();
        found.dedup();
        assert_eq!(found.len(), sorted, "a pair reported twice in a frame");
        (found, reference)
    }

    /// Random bodies at up to 25 diameters per frame (several bounces a frame), and pairs that
    /// graze: a mover passing a body at rest at 1 - 1e-8 of the contact distance (a contact, the
    /// boxes overlapping by far less than an f32 step) or 1 + 1e-8 (none).
    #[test]
    fn finds_exactly_the_brute_force_contacts_of_fast_and_grazing_bodies() {
        let per_frame = 30.0; // units per second of one diameter per frame
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut sites: Vec<[f64; 3]> =
            (0..729).map(|k| [k % 9, k / 9 % 9, k / 81].map(|c| 1.0 + 1.6 * c as f64)).collect();
        let mut spheres = Vec::new();
        for _ in 0..120 {
            let site = sites.swap_remove(rng.random_range(0..sites.len()));
            let direction = DVec3::from_array(std::array::from_fn(|_| rng.random_range(-1.0..1.0))).normalize();
            let top = [0.5, 5.0, 25.0][rng.random_range(0..3)];
            let velocity = direction * rng.random_range(0.0..top) * per_frame;
            spheres.push(Sphere { position: DVec3::from_array(site), velocity, radius: 0.5, mass: 1.0 });
        }
        let mut grazers = Vec::new();
        for (k, (offset, speed)) in
            [(1.0 - 1e-8, 6.0), (1.0 + 1e-8, 6.0), (1.0 - 1e-8, 20.0), (1.0 + 1e-8, 20.0)].into_iter().enumerate()
        {
            let rest = DVec3::new(8.0, 2.0 + 3.5 * k as f64, 15.0);
            grazers.push((spheres.len() as u32, offset < 1.0));
            spheres.push(Sphere { position: rest, velocity: DVec3::ZERO, radius: 0.5, mass: 1.0 });
            let mover = Sphere {
                position: rest + DVec3::new(-3.0, offset, 0.0),
                velocity: DVec3::X * speed * per_frame,
                radius: 0.5,
                mass: 1.0,
            };
            spheres.push(mover);
        }
        let bounds = BoxBounds::cube(16.0).unwrap();
        let scene = vadop::scene::Scene { bounds, spheres, shapes: vec![], bodies: vec![], static_bodies: vec![] };
        let (found, reference) = grid_and_reference("grazing", |dir| export_scene(&scene, 8, true, dir));
        for (rest, touches) in grazers {
            assert_eq!(reference.contains(&[0, rest, rest + 1]), touches, "the reference's graze of body {rest}");
        }
        assert!(reference.len() > 100, "only {} contacts", reference.len());
        assert_eq!(found, reference);
    }

    /// The paper scene the peers run, at the three speeds of the table.
    #[test]
    fn finds_exactly_the_brute_force_contacts_of_the_paper_scene() {
        for (speed, least) in [(0.05, 0), (0.5, 100), (5.0, 1000)] {
            let (found, reference) =
                grid_and_reference(&format!("paper-{speed}"), |dir| export(1000, speed, 10, true, dir));
            assert!(reference.len() >= least, "speed {speed}: only {} contacts", reference.len());
            assert_eq!(found, reference, "speed {speed}");
        }
    }
}
