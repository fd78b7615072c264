//! The box cut into one brick per rank, balanced by body count: recursive coordinate bisection,
//! each cut across the longest side of its part at the coordinate that splits the part's bodies
//! in proportion to the ranks on either side. Every rank computes the same cuts from the same
//! positions, so no rank has to tell another where the borders lie.
//!
//! It owns the geometry of the decomposition: which rank owns a point, how far a point lies from
//! a brick, which bricks are near each other. It never moves bodies and never talks to another
//! rank.

use glam::DVec3;
use vadop::BoxBounds;

/// One node of the cut tree: a leaf is a rank's brick, an inner node a cut across `axis` at
/// `at` (points below go to `low`, the others to `high`).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Node {
    Brick(usize),
    Cut { axis: usize, at: f64, low: usize, high: usize },
}

/// The bricks of a box cut for `ranks` ranks.
#[derive(Debug, Clone, PartialEq)]
pub struct Bricks {
    nodes: Vec<Node>,
    /// Each rank's brick, as (min, max) corners.
    boxes: Vec<(DVec3, DVec3)>,
}

impl Bricks {
    /// Cuts `bounds` into `ranks` bricks, each holding about `positions.len() / ranks` of the
    /// points (a part with fewer points than ranks is cut in halves of its longest side).
    pub fn cut(bounds: &BoxBounds, positions: &[DVec3], ranks: usize) -> Bricks {
        assert!(ranks > 0, "at least one rank");
        let mut bricks = Bricks { nodes: Vec::new(), boxes: vec![(bounds.min, bounds.max); ranks] };
        let mut points = positions.to_vec();
        bricks.split((bounds.min, bounds.max), &mut points, 0, ranks);
        // No body leaves the box (but by a rounding error), so a brick's faces on the box's faces
        // are no borders: they lie at infinity, and a body beside a wall is as deep in its brick
        // as its distance to the cuts says.
        for (min, max) in &mut bricks.boxes {
            for axis in 0..3 {
                if min[axis] == bounds.min[axis] {
                    min[axis] = f64::NEG_INFINITY;
                }
                if max[axis] == bounds.max[axis] {
                    max[axis] = f64::INFINITY;
                }
            }
        }
        bricks
    }

    /// Cuts the part `(min, max)` holding `points` among the ranks `first..first + count`;
    /// returns its node's index.
    fn split(&mut self, (min, max): (DVec3, DVec3), points: &mut [DVec3], first: usize, count: usize) -> usize {
        let node = self.nodes.len();
        if count == 1 {
            self.nodes.push(Node::Brick(first));
            self.boxes[first] = (min, max);
            return node;
        }
        self.nodes.push(Node::Brick(usize::MAX));
        let axis = (max - min).max_position();
        let low_ranks = count / 2;
        let at = if points.len() >= count {
            // Split the points in proportion to the ranks, halfway between the two neighbours.
            let k = (points.len() * low_ranks).div_ceil(count).clamp(1, points.len() - 1);
            let (below, kth, _) = points.select_nth_unstable_by(k, |a, b| a[axis].total_cmp(&b[axis]));
            let highest_below = below.iter().map(|p| p[axis]).fold(f64::NEG_INFINITY, f64::max);
            0.5 * (highest_below + kth[axis])
        } else {
            min[axis] + (max[axis] - min[axis]) * low_ranks as f64 / count as f64
        };
        let at = at.clamp(min[axis], max[axis]);
        let split = partition(points, |p| p[axis] < at);
        let (below, above) = points.split_at_mut(split);
        let (mut low_max, mut high_min) = (max, min);
        low_max[axis] = at;
        high_min[axis] = at;
        let low = self.split((min, low_max), below, first, low_ranks);
        let high = self.split((high_min, max), above, first + low_ranks, count - low_ranks);
        self.nodes[node] = Node::Cut { axis, at, low, high };
        node
    }

    /// The number of ranks.
    pub fn ranks(&self) -> usize {
        self.boxes.len()
    }

    /// Rank `rank`'s brick, as (min, max) corners; a face on the box's face lies at infinity.
    #[cfg(test)]
    pub fn brick(&self, rank: usize) -> (DVec3, DVec3) {
        self.boxes[rank]
    }

    /// The rank that owns a body centred at `p`: the brick that holds it, a point on a cut going
    /// to the brick above it (points outside the box, by a rounding error, to the nearest brick).
    pub fn owner(&self, p: DVec3) -> usize {
        let mut node = 0;
        loop {
            match self.nodes[node] {
                Node::Brick(rank) => return rank,
                Node::Cut { axis, at, low, high } => node = if p[axis] < at { low } else { high },
            }
        }
    }

    /// How far `p` lies from rank `rank`'s brick (0 inside it).
    pub fn distance(&self, rank: usize, p: DVec3) -> f64 {
        let (min, max) = self.boxes[rank];
        (min - p).max(p - max).max(DVec3::ZERO).length()
    }

    /// How deep `p` lies in rank `rank`'s brick: its distance to the nearest cut (infinite in a
    /// brick that is the whole box; 0 outside the brick).
    pub fn depth(&self, rank: usize, p: DVec3) -> f64 {
        let (min, max) = self.boxes[rank];
        (p - min).min(max - p).min_element().max(0.0)
    }

    /// The ranks other than `rank` whose bricks lie within `reach` of its brick, ascending.
    pub fn near(&self, rank: usize, reach: f64) -> Vec<usize> {
        let (min, max) = self.boxes[rank];
        (0..self.ranks())
            .filter(|&other| other != rank)
            .filter(|&other| {
                let (low, high) = self.boxes[other];
                (low - max).max(min - high).max(DVec3::ZERO).length() <= reach
            })
            .collect()
    }
}

/// Moves the points for which `below` holds to the front; returns how many there are.
fn partition(points: &mut [DVec3], below: impl Fn(DVec3) -> bool) -> usize {
    let mut split = 0;
    for k in 0..points.len() {
        if below(points[k]) {
            points.swap(split, k);
            split += 1;
        }
    }
    split
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cloud(n: usize) -> Vec<DVec3> {
        // A deterministic, lopsided cloud: denser towards the low corner.
        let mut seed = 11u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n).map(|_| DVec3::new(next().powi(2), next(), next().sqrt()) * 10.0).collect()
    }

    #[test]
    fn bricks_cover_the_box_and_balance_the_bodies() {
        let bounds = BoxBounds::cube(10.0).unwrap();
        let points = cloud(10_000);
        for ranks in 1..=9 {
            let bricks = Bricks::cut(&bounds, &points, ranks);
            let mut counts = vec![0usize; ranks];
            for &p in &points {
                let owner = bricks.owner(p);
                assert_eq!(bricks.distance(owner, p), 0.0, "{ranks} ranks: {p} outside its brick");
                counts[owner] += 1;
            }
            let inside = |r: usize| {
                let (min, max) = bricks.brick(r);
                (max.min(bounds.max) - min.max(bounds.min)).element_product()
            };
            let volume: f64 = (0..ranks).map(inside).sum();
            assert!((volume - 1000.0).abs() < 1e-9, "{ranks} ranks cover {volume}");
            let (least, most) = (*counts.iter().min().unwrap(), *counts.iter().max().unwrap());
            assert!(most - least <= ranks.max(2), "{ranks} ranks: {counts:?}");
        }
    }

    #[test]
    fn near_bricks_are_the_ones_within_reach() {
        let bounds = BoxBounds::cube(10.0).unwrap();
        let bricks = Bricks::cut(&bounds, &cloud(1000), 4);
        for rank in 0..4 {
            // Every brick touches at least one other, and all of them lie within the box's diagonal.
            assert!(!bricks.near(rank, 0.0).is_empty());
            assert_eq!(bricks.near(rank, 20.0).len(), 3);
        }
    }

    #[test]
    fn a_crowd_too_small_to_share_is_cut_into_halves() {
        let bounds = BoxBounds::cube(8.0).unwrap();
        let bricks = Bricks::cut(&bounds, &[DVec3::splat(1.0)], 4);
        let inside = |r: usize| {
            let (min, max) = bricks.brick(r);
            (max.min(bounds.max) - min.max(bounds.min)).element_product()
        };
        let volumes: Vec<f64> = (0..4).map(inside).collect();
        assert_eq!(volumes, vec![128.0; 4]);
    }
}
