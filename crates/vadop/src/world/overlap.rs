//! Start-of-run overlap check: finds a pair of bodies that interpenetrate, in O(n log n).
//!
//! It owns one job, validating a simulate-mode scene before its first frame: collisions can only
//! be resolved between separate bodies. It bins the moving bodies into a grid of cells one
//! largest bounding diameter wide, sorts them by cell index (an index, not a hash) and compares
//! each new body only with the bodies in its 27 neighbouring cells, and every new body with every
//! static one (level geometry is few bodies); the narrow phase decides. On a periodic axis the
//! cells tile the box and wrap around, so bodies touching across a face are compared too. It
//! never changes the bodies.

use crate::bodies::Bodies;
use crate::narrow_phase::contacts::penetration;
use glam::DVec3;

const CELL_BITS: u32 = 21;

/// First pair `(a, b, depth)` in which a body of `new_bodies` overlaps any live body by more than
/// the contact tolerance; touching is allowed.
pub fn first_overlap(bodies: &Bodies, new_bodies: &[u32], time: f64) -> Option<(u32, u32, f64)> {
    let (statics, live): (Vec<u32>, Vec<u32>) = bodies.alive_ids().partition(|&i| bodies.is_fixed(i as usize));
    let mut found: Option<(u32, u32, f64)> = None;
    // Report the lowest pair, independent of the order of checks.
    let mut note = |a: u32, b: u32, depth: f64| {
        let pair = (a.min(b), a.max(b), depth);
        if found.is_none_or(|f| (pair.0, pair.1) < (f.0, f.1)) {
            found = Some(pair);
        }
    };
    for &a in new_bodies.iter().filter(|&&a| !bodies.is_fixed(a as usize)) {
        for &s in &statics {
            if let Some(depth) = penetration(bodies, a as usize, s as usize, time) {
                note(a, s, depth);
            }
        }
    }
    for &s in new_bodies.iter().filter(|&&s| bodies.is_fixed(s as usize)) {
        for &a in &live {
            if let Some(depth) = penetration(bodies, a as usize, s as usize, time) {
                note(a, s, depth);
            }
        }
    }
    let position = |i: u32| bodies.position_at(i as usize, time);
    let max_radius = live.iter().map(|&i| bodies.radius(i as usize)).fold(0.0, f64::max);
    let (lo, hi) = live.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &i| {
        let p = position(i);
        (lo.min(p), hi.max(p))
    });
    // Cells at least one diameter wide, and few enough per axis to fit the key. On a periodic
    // axis they tile the box's side, and the neighbours of the last cell are the first ones.
    let limit = (1u64 << CELL_BITS) as f64 - 2.0;
    let cell = (2.0 * max_radius).max((hi - lo).max_element() / limit).max(f64::MIN_POSITIVE);
    let periodic = bodies.periodic;
    let axes: [(f64, f64, u64, bool); 3] = std::array::from_fn(|a| match periodic.axes[a] {
        true => {
            let count = ((periodic.side[a] / cell).floor() as u64).clamp(1, limit as u64);
            (periodic.min[a], periodic.side[a] / count as f64, count, true)
        }
        false => (lo[a], cell, u64::MAX, false),
    });
    let coords = |p: DVec3| -> [u64; 3] {
        std::array::from_fn(|a| {
            let (origin, width, count, _) = axes[a];
            (((p[a] - origin) / width).floor().max(0.0) as u64).min(count - 1)
        })
    };
    let key = |c: [u64; 3]| c[0] | (c[1] << CELL_BITS) | (c[2] << (2 * CELL_BITS));
    // The cells next to coordinate `c` on axis `a` (itself included), each once.
    let near = |a: usize, c: u64| -> ([u64; 3], usize) {
        let (_, _, count, wraps) = axes[a];
        let mut cells = [0u64; 3];
        let mut n = 0;
        for step in 0..3u64 {
            let next = match wraps {
                true => (c + count - 1 + step) % count,
                false if c + step == 0 => continue,
                false => c + step - 1,
            };
            if !cells[..n].contains(&next) {
                cells[n] = next;
                n += 1;
            }
        }
        (cells, n)
    };
    let mut by_cell: Vec<(u64, u32)> = live.iter().map(|&i| (key(coords(position(i))), i)).collect();
    by_cell.sort_unstable();
    for &a in new_bodies.iter().filter(|&&a| !bodies.is_fixed(a as usize)) {
        let c = coords(position(a));
        let ((zs, nz), (ys, ny), (xs, nx)) = (near(2, c[2]), near(1, c[1]), near(0, c[0]));
        for &z in &zs[..nz] {
            for &y in &ys[..ny] {
                for &x in &xs[..nx] {
                    let k = key([x, y, z]);
                    let start = by_cell.partition_point(|&(ck, _)| ck < k);
                    for &(_, b) in by_cell[start..].iter().take_while(|&&(ck, _)| ck == k) {
                        if b == a {
                            continue;
                        }
                        if let Some(depth) = penetration(bodies, a as usize, b as usize, time) {
                            note(a, b, depth);
                        }
                    }
                }
            }
        }
    }
    found
}
