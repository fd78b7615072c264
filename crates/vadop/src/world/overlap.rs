//! Start-of-run overlap check: finds a pair of bodies that interpenetrate, in O(n log n).
//!
//! It owns one job, validating a simulate-mode scene before its first frame: collisions can only
//! be resolved between separate bodies. It bins the moving bodies into a grid of cells one
//! largest bounding diameter wide, sorts them by cell index (an index, not a hash) and compares
//! each new body only with the bodies in its 27 neighbouring cells, and every new body with every
//! static one (level geometry is few bodies); the narrow phase decides. It
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
    // Cells at least one diameter wide, and few enough per axis to fit the key.
    let limit = (1u64 << CELL_BITS) as f64 - 2.0;
    let cell = (2.0 * max_radius).max((hi - lo).max_element() / limit).max(f64::MIN_POSITIVE);
    let coords = |p: DVec3| -> [u64; 3] {
        let c = ((p - lo) / cell).floor();
        [c.x as u64, c.y as u64, c.z as u64]
    };
    let key = |c: [u64; 3]| c[0] | (c[1] << CELL_BITS) | (c[2] << (2 * CELL_BITS));
    let mut by_cell: Vec<(u64, u32)> = live.iter().map(|&i| (key(coords(position(i))), i)).collect();
    by_cell.sort_unstable();
    for &a in new_bodies.iter().filter(|&&a| !bodies.is_fixed(a as usize)) {
        let pa = position(a);
        let c = coords(pa);
        for dz in 0..3u64 {
            for dy in 0..3u64 {
                for dx in 0..3u64 {
                    if c[0] + dx < 1 || c[1] + dy < 1 || c[2] + dz < 1 {
                        continue;
                    }
                    let k = key([c[0] + dx - 1, c[1] + dy - 1, c[2] + dz - 1]);
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
