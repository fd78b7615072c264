//! The pool of axes every body chooses its bounding axes from. This module owns the pool itself
//! (a deterministic, near-uniform set of m lines through the origin, each standing for the
//! antipodal pair of unit vectors ±a), its exact covering radius rho (the largest angle from any
//! direction to its nearest ±a, computed from the spherical Delaunay triangulation, never by
//! sampling), the caches that make a pool cheap to ask for again, and the band query that lists
//! the axes nearly orthogonal to a direction. It never knows about bodies, velocities or
//! intervals, and the band query never allocates beyond the capacity of the caller's buffer.

use crate::error::{Result, VadopError};
use delaunator::{triangulate, Point};
use glam::DVec3;
use std::collections::HashMap;
use std::f64::consts::{FRAC_PI_2, PI};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock, PoisonError};

/// Smallest supported pool: three axes are the fewest that leave no direction 90 degrees from all.
pub const MIN_AXES: usize = 3;
/// Largest supported pool.
pub const MAX_AXES: usize = 100_000;

/// Pools at least this large are kept on disk: smaller ones build faster than a file is read.
const DISK_CACHE_MIN_AXES: usize = 2000;
/// Bump whenever the optimiser changes, so a file is only ever read by the version that wrote it
/// and a pool stays bit-identical whether it was built or loaded.
const CACHE_FORMAT_VERSION: u32 = 1;
/// First bytes of a cache file.
const CACHE_MAGIC: &[u8; 8] = b"VADOPAX1";
/// How far a cached axis may be from unit length, a few roundings of a normalisation.
const CACHE_UNIT_TOLERANCE: f64 = 1e-12;
/// Relative slack when pruning a bin in `band`, far above the rounding of the dot products, so
/// a pruned bin never holds an axis that the exact comparison would accept.
const PRUNE_SLACK: f64 = 1e-12;

/// A set of axes with its exact covering radius and an index for band queries.
///
/// Axis ids are positions in [`AxisPool::axes`]. Every axis is a unit vector; its sign carries
/// no meaning.
#[derive(Debug)]
pub struct AxisPool {
    axes: Vec<DVec3>,
    covering_radius: f64,
    /// Contiguous runs of `axes` grouped around a centre, in ascending id order.
    bins: Vec<Bin>,
}

/// A run of axes `start..end` whose members, signed towards the hemisphere `z >= 0`, all lie
/// within the straight-line distance `chord` of `centre`.
#[derive(Debug)]
struct Bin {
    centre: DVec3,
    chord: f64,
    start: u32,
    end: u32,
}

impl AxisPool {
    /// The pool of `m` axes, built once per process and shared.
    ///
    /// `m = 3` is the coordinate axes and `m = 6` the six vertex axes of the icosahedron, the best
    /// coverings of their size. Any other `m` starts from a spiral and is optimised for the covering
    /// radius. Pools of 2000 axes or more are also kept on disk, in `$VADOP_CACHE_DIR`, else
    /// `$XDG_CACHE_HOME/vadop`, else `~/.cache/vadop`; a missing or damaged file is ignored and
    /// the pool is built again.
    ///
    /// ```
    /// use vadop::axis_pool::AxisPool;
    /// let pool = AxisPool::new(3).unwrap();
    /// // Every direction lies within 54.7356 degrees (the angle from a cube's corner to its
    /// // edges) of a coordinate axis.
    /// assert!((pool.covering_radius().to_degrees() - 54.7356).abs() < 1e-4);
    /// // The same pool is shared by every caller.
    /// assert!(std::sync::Arc::ptr_eq(&pool, &AxisPool::new(3).unwrap()));
    /// assert!(AxisPool::new(2).is_err());
    /// ```
    pub fn new(m: usize) -> Result<Arc<AxisPool>> {
        if !(MIN_AXES..=MAX_AXES).contains(&m) {
            return Err(VadopError::BadPoolSize { got: m, min: MIN_AXES, max: MAX_AXES });
        }
        // One slot per size: the map lock is held only to find the slot, so building one size
        // never blocks callers that ask for another.
        type Slot = Arc<OnceLock<Arc<AxisPool>>>;
        static POOLS: OnceLock<Mutex<HashMap<usize, Slot>>> = OnceLock::new();
        let slot = {
            let mut pools = POOLS.get_or_init(Default::default).lock().unwrap_or_else(PoisonError::into_inner);
            Arc::clone(pools.entry(m).or_default())
        };
        Ok(Arc::clone(slot.get_or_init(|| Arc::new(AxisPool::build(m)))))
    }

    /// Number of axes.
    pub fn len(&self) -> usize {
        self.axes.len()
    }

    /// Always false: a pool has at least [`MIN_AXES`] axes.
    pub fn is_empty(&self) -> bool {
        self.axes.is_empty()
    }

    /// All axes, indexed by id.
    pub fn axes(&self) -> &[DVec3] {
        &self.axes
    }

    /// The unit vector of axis `id`. Panics if `id >= len()`, like slice indexing.
    pub fn axis(&self, id: u32) -> DVec3 {
        self.axes[id as usize]
    }

    /// The covering radius rho in radians: every direction lies within rho of some axis (or its
    /// negation), and some direction lies exactly rho from all of them.
    pub fn covering_radius(&self) -> f64 {
        self.covering_radius
    }

    /// Writes into `out` (cleared first) the ids, ascending, of all axes `a` with
    /// `a.dot(direction).abs() <= sin_phi`: the band of axes within phi of the plane orthogonal
    /// to the unit vector `direction`.
    ///
    /// The result is exactly that of testing every axis with this comparison, but only the
    /// groups of axes that can reach the band are tested. It allocates only when `out` lacks
    /// capacity. With `sin_phi >= sin(covering_radius())`, the bands of any two directions share
    /// an axis.
    ///
    /// ```
    /// use glam::DVec3;
    /// use vadop::axis_pool::AxisPool;
    /// let pool = AxisPool::new(3).unwrap();
    /// let mut ids = Vec::with_capacity(pool.len());
    /// pool.band(DVec3::Z, pool.covering_radius().sin(), &mut ids);
    /// // The x and y axes are orthogonal to z; the z axis itself is not in the band.
    /// assert_eq!(ids.len(), 2);
    /// assert!(ids.iter().all(|&id| pool.axis(id).z == 0.0));
    /// ```
    pub fn band(&self, direction: DVec3, sin_phi: f64, out: &mut Vec<u32>) {
        out.clear();
        let norm = direction.length();
        let prune_above = sin_phi + PRUNE_SLACK * (1.0 + norm);
        for bin in &self.bins {
            // Every member a satisfies |a.d| >= |c.d| - |a - c| |d|: skip bins whose members
            // are all provably outside the band.
            if bin.centre.dot(direction).abs() - bin.chord * norm > prune_above {
                continue;
            }
            for id in bin.start..bin.end {
                if self.axes[id as usize].dot(direction).abs() <= sin_phi {
                    out.push(id);
                }
            }
        }
    }

    fn build(m: usize) -> AxisPool {
        let axes = match m {
            3 => vec![DVec3::X, DVec3::Y, DVec3::Z],
            6 => icosahedron_axes(),
            _ => load_or_optimise(m),
        };
        let covering_radius = covering_radius(&axes);
        let (axes, bins) = index(axes);
        AxisPool { axes, covering_radius, bins }
    }
}

/// Fejes Tóth's lower bound (radians) on the covering radius of any `m` axes: `2m` points on the
/// sphere cannot do better than cos(rho) = cot(n pi / (6 (n - 2))) / sqrt(3) with n = 2m.
pub fn fejes_toth_bound(m: usize) -> f64 {
    let n = 2.0 * m as f64;
    let x = n * PI / (6.0 * (n - 2.0));
    (1.0 / x.tan() / 3f64.sqrt()).acos()
}

/// The exact covering radius (radians) of a set of axes: the largest angle from any direction to
/// its nearest ±a. Axes need not be unit length; zero or non-finite ones are ignored. With fewer
/// than three independent axes some direction is orthogonal to all, and the result is pi/2.
///
/// It is the largest angular circumradius over the spherical Delaunay triangles of the points ±a,
/// whose circumcentres are the vertices of the Voronoi diagram, the only candidates for the
/// direction farthest from every point.
pub fn covering_radius(axes: &[DVec3]) -> f64 {
    let points = antipodal_points(axes);
    let triangles = spherical_delaunay(&points);
    if triangles.is_empty() {
        return FRAC_PI_2;
    }
    let worst = triangles.iter().map(|t| circumcap(&points, t).1).fold(0.0, f64::max);
    worst.min(FRAC_PI_2)
}

/// Where the pool of `m` axes is kept on disk, or `None` when no cache directory is known:
/// `$VADOP_CACHE_DIR`, else `$XDG_CACHE_HOME/vadop`, else `$HOME/.cache/vadop`.
///
/// The file holds `VADOPAX1`, then `m` as a little-endian u64, then the 3m coordinates as
/// little-endian f64. Only pools of 2000 axes or more are written.
pub fn cache_file(m: usize) -> Option<PathBuf> {
    let non_empty = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty()).map(PathBuf::from);
    // The XDG convention ignores relative paths.
    let absolute = |name: &str| non_empty(name).filter(|p| p.is_absolute());
    let dir = non_empty("VADOP_CACHE_DIR")
        .or_else(|| absolute("XDG_CACHE_HOME").map(|d| d.join("vadop")))
        .or_else(|| absolute("HOME").map(|h| h.join(".cache").join("vadop")))?;
    Some(dir.join(format!("axes-v{CACHE_FORMAT_VERSION}-{m}.bin")))
}

/// The six axes through opposite vertices of a regular icosahedron.
fn icosahedron_axes() -> Vec<DVec3> {
    let golden = (1.0 + 5f64.sqrt()) / 2.0;
    [
        DVec3::new(0.0, 1.0, golden),
        DVec3::new(0.0, -1.0, golden),
        DVec3::new(1.0, golden, 0.0),
        DVec3::new(-1.0, golden, 0.0),
        DVec3::new(golden, 0.0, 1.0),
        DVec3::new(golden, 0.0, -1.0),
    ]
    .iter()
    .map(|v| v.normalize())
    .collect()
}

fn load_or_optimise(m: usize) -> Vec<DVec3> {
    if m < DISK_CACHE_MIN_AXES {
        return optimised_axes(m);
    }
    let path = cache_file(m);
    if let Some(axes) = path.as_deref().and_then(|p| read_cache(p, m)) {
        return axes;
    }
    let axes = optimised_axes(m);
    if let Some(path) = path {
        // A cache that cannot be written only costs the next process a rebuild.
        let _ = write_cache(&path, &axes);
    }
    axes
}

/// The cached axes for `m`, or `None` unless the file is complete and every axis is a finite
/// unit vector.
fn read_cache(path: &Path, m: usize) -> Option<Vec<DVec3>> {
    let bytes = std::fs::read(path).ok()?;
    let header = CACHE_MAGIC.len() + 8;
    if bytes.len() != header + 24 * m || &bytes[..CACHE_MAGIC.len()] != CACHE_MAGIC {
        return None;
    }
    let count = u64::from_le_bytes(bytes[CACHE_MAGIC.len()..header].try_into().ok()?);
    if count != m as u64 {
        return None;
    }
    let coordinate = |chunk: &[u8]| chunk.try_into().ok().map(f64::from_le_bytes);
    let axes: Vec<DVec3> = bytes[header..]
        .chunks_exact(24)
        .map(|c| Some(DVec3::new(coordinate(&c[..8])?, coordinate(&c[8..16])?, coordinate(&c[16..])?)))
        .collect::<Option<_>>()?;
    let valid = |a: &DVec3| a.is_finite() && (a.length() - 1.0).abs() <= CACHE_UNIT_TOLERANCE;
    axes.iter().all(valid).then_some(axes)
}

/// Writes through a temporary file and a rename, so a reader never sees half a file.
fn write_cache(path: &Path, axes: &[DVec3]) -> std::io::Result<()> {
    let mut bytes = Vec::with_capacity(CACHE_MAGIC.len() + 8 + 24 * axes.len());
    bytes.extend_from_slice(CACHE_MAGIC);
    bytes.extend_from_slice(&(axes.len() as u64).to_le_bytes());
    for a in axes {
        for c in a.to_array() {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)?;
    }
    let temporary = path.with_extension(format!("tmp{}", std::process::id()));
    let written = std::fs::write(&temporary, &bytes).and_then(|()| std::fs::rename(&temporary, path));
    if written.is_err() {
        let _ = std::fs::remove_file(&temporary);
    }
    written
}

/// The unit points a and -a for every usable axis: point i + k is -point i, k the usable count.
fn antipodal_points(axes: &[DVec3]) -> Vec<DVec3> {
    let unit: Vec<DVec3> = axes.iter().filter_map(|a| a.try_normalize()).collect();
    unit.iter().copied().chain(unit.iter().map(|&a| -a)).collect()
}

/// Triangles (indices into `points`) of the spherical Delaunay triangulation of unit `points`,
/// or none when they all lie on one circle.
///
/// The sphere is projected stereographically from `points[0]` onto a plane, where circles stay
/// circles: the planar Delaunay triangles are the spherical ones away from the pole, and each edge
/// of the planar convex hull closes a triangle with the pole. Points within about 1e-12 rad of the
/// pole are left out; that can only enlarge a covering radius computed from the result.
fn spherical_delaunay(points: &[DVec3]) -> Vec<[u32; 3]> {
    let Some(&pole) = points.first() else {
        return Vec::new();
    };
    let (e1, e2) = pole.any_orthonormal_pair();
    let mut planar = Vec::with_capacity(points.len());
    let mut ids = Vec::with_capacity(points.len());
    for (i, p) in points.iter().enumerate().skip(1) {
        let denominator = 1.0 - p.dot(pole);
        if denominator > 1e-24 {
            planar.push(Point { x: p.dot(e1) / denominator, y: p.dot(e2) / denominator });
            ids.push(i as u32);
        }
    }
    let planar = triangulate(&planar);
    if planar.triangles.is_empty() {
        return Vec::new();
    }
    let mut triangles: Vec<[u32; 3]> =
        planar.triangles.chunks_exact(3).map(|t| [ids[t[0]], ids[t[1]], ids[t[2]]]).collect();
    let hull = &planar.hull;
    for (k, &a) in hull.iter().enumerate() {
        triangles.push([0, ids[a], ids[hull[(k + 1) % hull.len()]]]);
    }
    triangles
}

/// Centre and angular radius of the smallest cap whose boundary passes through the triangle's
/// corners. A degenerate triangle gets radius pi/2, an upper bound on any covering radius.
fn circumcap(points: &[DVec3], triangle: &[u32; 3]) -> (DVec3, f64) {
    let [a, b, c] = triangle.map(|i| points[i as usize]);
    let Some(normal) = (b - a).cross(c - a).try_normalize() else {
        return (a, FRAC_PI_2);
    };
    let centre = if normal.dot(a + b + c) < 0.0 { -normal } else { normal };
    // The largest of the three angles, so rounding cannot make the cap miss a corner.
    let radius = angle(centre, a).max(angle(centre, b)).max(angle(centre, c));
    (centre, radius)
}

/// Angle between two unit vectors, accurate even when tiny (unlike acos of the dot product).
fn angle(u: DVec3, v: DVec3) -> f64 {
    u.cross(v).length().atan2(u.dot(v))
}

/// Near-uniform axes for `m`, optimised for the covering radius.
///
/// Large pools start from a subdivided, already optimised pool of a quarter the size: its
/// triangles are near-equilateral from the start, where a spiral would need hundreds of slow
/// iterations to become so.
fn optimised_axes(m: usize) -> Vec<DVec3> {
    if m >= SUBDIVIDE_MIN_AXES {
        let mut axes = subdivided(&optimised_axes((m + 3).div_ceil(4)), m);
        minimise_covering_radius(&mut axes, REFINE_ITERATIONS, REFINE_STEP);
        return axes;
    }
    let mut best = spiral_axes(m);
    let mut best_radius = minimise_covering_radius(&mut best, MAX_ITERATIONS, 1.0);
    // Small pools are cheap and prone to poor local optima: also try seeded random starts.
    let restarts = RESTART_BUDGET / m;
    let mut random = SplitMix64(m as u64);
    for _ in 0..restarts {
        let mut axes: Vec<DVec3> = (0..m).map(|_| random.unit_vector()).collect();
        let radius = minimise_covering_radius(&mut axes, MAX_ITERATIONS, 1.0);
        if radius < best_radius {
            best_radius = radius;
            best = axes;
        }
    }
    best
}

/// The `coarse` axes plus the midpoints of the edges of their spherical Delaunay triangulation
/// (one per antipodal pair of edges), which is 4 k - 3 axes for k coarse ones, cut to `m`.
fn subdivided(coarse: &[DVec3], m: usize) -> Vec<DVec3> {
    let k = coarse.len() as u32;
    let points = antipodal_points(coarse);
    let mut edges: Vec<(u32, u32)> = spherical_delaunay(&points)
        .iter()
        .flat_map(|&[a, b, c]| [(a, b), (b, c), (c, a)])
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect();
    edges.sort_unstable();
    edges.dedup();
    let antipode = |i: u32| if i < k { i + k } else { i - k };
    let mut axes = coarse.to_vec();
    for &(a, b) in &edges {
        let (x, y) = (antipode(a), antipode(b));
        // Keep one edge of each antipodal pair: the smaller of the two.
        if (a, b) < (x.min(y), x.max(y)) {
            if let Some(midpoint) = (points[a as usize] + points[b as usize]).try_normalize() {
                axes.push(midpoint);
            }
        }
    }
    if axes.len() < m {
        return spiral_axes(m);
    }
    axes.truncate(m);
    axes
}

/// Pools this large are grown from a coarser pool rather than from a spiral.
const SUBDIVIDE_MIN_AXES: usize = 600;
/// Total axes over all random restarts: bounds the time spent on a small pool.
const RESTART_BUDGET: usize = 1000;
/// Iterations of the Voronoi step without a better covering radius before the search stops.
const PATIENCE: usize = 40;
/// Upper bound on the iterations of a search from a spiral or a random start.
const MAX_ITERATIONS: usize = 600;
/// Iterations that relax a subdivided pool.
const REFINE_ITERATIONS: usize = 40;
/// Over-relaxation of the Voronoi step on a subdivided pool: moving past the cap centre speeds
/// up the slow, long-range part of the relaxation that a few iterations must finish.
const REFINE_STEP: f64 = 1.5;

/// The generalised-spiral points of the upper hemisphere, evenly spread in area.
fn spiral_axes(m: usize) -> Vec<DVec3> {
    let golden_angle = PI * (3.0 - 5f64.sqrt());
    (0..m)
        .map(|i| {
            let z = 1.0 - (i as f64 + 0.5) / m as f64;
            let r = (1.0 - z * z).sqrt();
            let longitude = golden_angle * i as f64;
            DVec3::new(r * longitude.cos(), r * longitude.sin(), z)
        })
        .collect()
}

/// Moves every point to the centre of the smallest cap enclosing its Voronoi cell, a minimax
/// counterpart of Lloyd's iteration: it shrinks each cell's own covering radius. Antipodal
/// symmetry is kept by moving a to the mean of its own target and the negated target of -a.
/// Each point moves the fraction `step` of the way to its target.
/// Leaves in `axes` the best configuration seen and returns its exact covering radius.
fn minimise_covering_radius(axes: &mut [DVec3], max_iterations: usize, step: f64) -> f64 {
    let m = axes.len();
    let mut best_axes = axes.to_vec();
    let mut best_radius = f64::INFINITY;
    let mut since_best = 0;
    let mut centres = Vec::new();
    let mut cell = Vec::new();
    let mut first_triangle = Vec::new();
    let mut incident = Vec::new();
    for _ in 0..max_iterations {
        let points = antipodal_points(axes);
        if points.len() != 2 * m {
            break;
        }
        let triangles = spherical_delaunay(&points);
        centres.clear();
        let mut radius: f64 = 0.0;
        for t in &triangles {
            let (centre, r) = circumcap(&points, t);
            centres.push(centre);
            radius = radius.max(r);
        }
        if triangles.is_empty() {
            radius = FRAC_PI_2;
        }
        if radius < best_radius {
            if radius < best_radius * (1.0 - 1e-9) {
                since_best = 0;
            }
            best_radius = radius;
            best_axes.copy_from_slice(axes);
        }
        since_best += 1;
        if since_best > PATIENCE || triangles.is_empty() {
            break;
        }
        incidence(&triangles, points.len(), &mut first_triangle, &mut incident);
        let cell_centre = |p: usize, cell: &mut Vec<DVec3>| {
            cell.clear();
            cell.extend(incident[first_triangle[p]..first_triangle[p + 1]].iter().map(|&t| centres[t as usize]));
            smallest_enclosing_cap(cell).map(|(c, _)| c)
        };
        for (i, axis) in axes.iter_mut().enumerate() {
            let (Some(plus), Some(minus)) = (cell_centre(i, &mut cell), cell_centre(i + m, &mut cell)) else {
                continue;
            };
            let target = (plus - minus).normalize_or(*axis);
            if let Some(moved) = (*axis + step * (target - *axis)).try_normalize() {
                *axis = moved;
            }
        }
    }
    axes.copy_from_slice(&best_axes);
    best_radius
}

/// Compressed lists of the triangles around each point: those of point p are
/// `incident[first[p]..first[p + 1]]`.
fn incidence(triangles: &[[u32; 3]], point_count: usize, first: &mut Vec<usize>, incident: &mut Vec<u32>) {
    first.clear();
    first.resize(point_count + 1, 0);
    for t in triangles {
        for &p in t {
            first[p as usize + 1] += 1;
        }
    }
    for p in 0..point_count {
        first[p + 1] += first[p];
    }
    incident.clear();
    incident.resize(first[point_count], 0);
    let mut next = first[..point_count].to_vec();
    for (k, t) in triangles.iter().enumerate() {
        for &p in t {
            incident[next[p as usize]] = k as u32;
            next[p as usize] += 1;
        }
    }
}

/// Centre and cosine of the radius of the smallest cap containing unit `points`, which must lie
/// in an open hemisphere (Welzl's incremental construction; its result does not depend on order).
fn smallest_enclosing_cap(points: &[DVec3]) -> Option<(DVec3, f64)> {
    const INSIDE_TOLERANCE: f64 = 1e-14;
    let inside = |cap: (DVec3, f64), p: DVec3| cap.0.dot(p) >= cap.1 - INSIDE_TOLERANCE;
    let mut cap = (*points.first()?, 1.0);
    for i in 1..points.len() {
        if inside(cap, points[i]) {
            continue;
        }
        cap = (points[i], 1.0);
        for j in 0..i {
            if inside(cap, points[j]) {
                continue;
            }
            cap = cap_through_two(points[i], points[j]);
            for k in 0..j {
                if !inside(cap, points[k]) {
                    cap = cap_through_three(points[i], points[j], points[k]);
                }
            }
        }
    }
    Some(cap)
}

fn cap_through_two(a: DVec3, b: DVec3) -> (DVec3, f64) {
    let centre = (a + b).normalize_or(a);
    (centre, centre.dot(a).min(centre.dot(b)))
}

fn cap_through_three(a: DVec3, b: DVec3, c: DVec3) -> (DVec3, f64) {
    match (b - a).cross(c - a).try_normalize() {
        Some(normal) => {
            let centre = if normal.dot(a + b + c) < 0.0 { -normal } else { normal };
            (centre, centre.dot(a).min(centre.dot(b)).min(centre.dot(c)))
        }
        // Three points on one great circle: the cap through the farthest pair holds the third.
        None => [cap_through_two(a, b), cap_through_two(a, c), cap_through_two(b, c)]
            .into_iter()
            .fold((a, 1.0), |widest, cap| if cap.1 < widest.1 { cap } else { widest }),
    }
}

/// Groups the axes into bins of a latitude-longitude grid over the hemisphere z >= 0 (an axis
/// below it is counted as its negation), reorders the axes bin by bin so that every bin is a run
/// of ascending ids, and records each bin's centre and extent.
fn index(axes: Vec<DVec3>) -> (Vec<DVec3>, Vec<Bin>) {
    let upper = |a: DVec3| if a.z < 0.0 { -a } else { a };
    // Scanning k bin centres plus the members of the bins within ~1.9/sqrt(k) of the band
    // costs k + 1.9 m / sqrt(k) dot products, least near k = (0.95 m)^(2/3).
    let target_bins = (0.95 * axes.len() as f64).powf(2.0 / 3.0);
    let rings = ((target_bins * PI / 8.0).sqrt().round() as usize).max(1);
    let ring_height = FRAC_PI_2 / rings as f64;
    // Rings of near-square cells; the first ring is a single polar cap.
    let sectors: Vec<usize> = (0..rings)
        .map(|j| {
            let middle = (j as f64 + 0.5) * ring_height;
            if j == 0 {
                1
            } else {
                ((2.0 * PI * middle.sin() / ring_height).round() as usize).max(1)
            }
        })
        .collect();
    let ring_start: Vec<usize> =
        sectors.iter().scan(0, |start, &s| Some(std::mem::replace(start, *start + s))).collect();
    let bin_of = |a: DVec3| {
        let a = upper(a);
        let ring = ((a.z.clamp(-1.0, 1.0).acos() / ring_height) as usize).min(rings - 1);
        let fraction = (a.y.atan2(a.x) + PI) / (2.0 * PI);
        let sector = ((fraction * sectors[ring] as f64) as usize).min(sectors[ring] - 1);
        ring_start[ring] + sector
    };
    let mut order: Vec<(usize, DVec3)> = axes.into_iter().map(|a| (bin_of(a), a)).collect();
    order.sort_by_key(|&(bin, _)| bin);
    let axes: Vec<DVec3> = order.iter().map(|&(_, a)| a).collect();
    let mut bins = Vec::new();
    let mut start = 0;
    while start < order.len() {
        let bin = order[start].0;
        let end = start + order[start..].iter().take_while(|&&(b, _)| b == bin).count();
        let members = || axes[start..end].iter().map(|&a| upper(a));
        let centre = members().sum::<DVec3>().normalize_or(upper(axes[start]));
        let chord = members().map(|a| (a - centre).length()).fold(0.0, f64::max);
        bins.push(Bin { centre, chord, start: start as u32, end: end as u32 });
        start = end;
    }
    (axes, bins)
}

/// A tiny fixed-seed generator, so random restarts give the same pool on every run.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_unit_interval(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A uniformly distributed unit vector.
    fn unit_vector(&mut self) -> DVec3 {
        let z = 2.0 * self.next_unit_interval() - 1.0;
        let longitude = 2.0 * PI * self.next_unit_interval();
        let r = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(r * longitude.cos(), r * longitude.sin(), z)
    }
}
