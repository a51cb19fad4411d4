//! The openings as light sampling's strategy search visits them ([`crate::through::strategies`]): a binary
//! tree over the still openings light can be sampled through, each node bounding the openings
//! below it (a box around their bounding spheres, the largest area, the brightest exit and
//! the brightest exit a further opening beyond may lead to). The search scores a node by the most any chain through its
//! openings could bring and skips it when that could not change the strategies it keeps, so a
//! wall of windows costs the few windows that matter at a point rather than every window, and
//! the chains of two rather than every pair.
//!
//! Openings that move are visited one after another after the tree, with no bound.

use glam::DVec3;

/// Openings in a leaf.
const LEAF_SIZE: usize = 2;
/// Up to this many still openings the tree is one leaf, taken without a bound: the few
/// openings' own tests cost less than scoring nodes (a room lit through four windows, eight
/// openings, rendered in about 0.8 of the time this way).
const LIST_OPENINGS: usize = 8;
/// Deep enough for any tree of median splits over a shot's openings (at most
/// `rift_fx::shot::MAX_OPENINGS`, 13 levels).
const STACK: usize = 64;

/// What the search needs to know of one opening to place and bound it.
#[derive(Clone, Copy, Debug)]
pub struct Placed {
    pub opening: u32,
    pub centre: DVec3,
    /// Bounding radius and area of its teleport region, world units.
    pub radius: f64,
    pub area: f64,
}

/// What bounds the openings below a node.
#[derive(Clone, Copy, Debug)]
pub struct Bounds {
    /// The box around their bounding spheres.
    pub lo: DVec3,
    pub hi: DVec3,
    /// The sphere around the box.
    pub centre: DVec3,
    pub radius: f64,
    pub largest_area: f64,
    /// The largest of each opening's opacity × tint times the light its exit passes on, and
    /// times the brightest exit a further opening beyond it may lead to.
    pub brightest: f32,
    pub brightest_beyond: f32,
}

impl Bounds {
    /// Squared distance from `p` to the box (0 inside it).
    pub fn distance_squared(&self, p: DVec3) -> f64 {
        let outside = (self.lo - p).max(p - self.hi).max(DVec3::ZERO);
        outside.length_squared()
    }

    /// Nothing: the seed of a fold of [`Self::join`]s.
    fn empty() -> Self {
        Self {
            lo: DVec3::INFINITY,
            hi: DVec3::NEG_INFINITY,
            centre: DVec3::ZERO,
            radius: 0.0,
            largest_area: 0.0,
            brightest: 0.0,
            brightest_beyond: 0.0,
        }
    }

    /// Both bounded together, the sphere around their joint box.
    fn join(&self, other: &Self) -> Self {
        let (lo, hi) = (self.lo.min(other.lo), self.hi.max(other.hi));
        Self {
            lo,
            hi,
            centre: 0.5 * (lo + hi),
            radius: 0.5 * (hi - lo).length(),
            largest_area: self.largest_area.max(other.largest_area),
            brightest: self.brightest.max(other.brightest),
            brightest_beyond: self.brightest_beyond.max(other.brightest_beyond),
        }
    }

    fn of(placed: &Placed) -> Self {
        let r = DVec3::splat(placed.radius);
        Self {
            lo: placed.centre - r,
            hi: placed.centre + r,
            centre: placed.centre,
            radius: placed.radius,
            largest_area: placed.area,
            brightest: 0.0,
            brightest_beyond: 0.0,
        }
    }
}

#[derive(Clone, Debug)]
struct Node {
    bounds: Bounds,
    /// A leaf's openings are `order[first..first + count]`; an inner node (count 0) has its
    /// first child next to it and its second at `first`.
    first: u32,
    count: u32,
}

/// How a search scores and takes the openings ([`ApertureTree::visit`]).
pub trait Visitor {
    /// The most any chain through the openings under `bounds` could matter, or `None` when
    /// none could.
    fn priority(&self, bounds: &Bounds) -> Option<f32>;
    /// True while a node scored `priority` may still matter (the search's bar only rises).
    fn still_matters(&self, priority: f32) -> bool;
    /// Takes opening `i`.
    fn opening(&mut self, i: usize);
}

/// The tree over the still usable openings, and the moving ones.
#[derive(Clone, Debug, Default)]
pub struct ApertureTree {
    nodes: Vec<Node>,
    /// Openings in leaf order.
    order: Vec<u32>,
    /// Usable openings that move: visited in turn.
    moving: Vec<u32>,
}

impl ApertureTree {
    /// Over `still` (placed at their one time) and the `moving` openings.
    pub fn new(mut still: Vec<Placed>, moving: Vec<u32>) -> Self {
        let mut tree = Self {
            nodes: Vec::with_capacity(2 * still.len()),
            order: Vec::with_capacity(still.len()),
            moving,
        };
        if !still.is_empty() {
            tree.split(&mut still);
        }
        tree
    }

    /// The same openings as one leaf, which the search walks without bounds: what the tree's
    /// bounds must not change (for tests).
    pub fn flattened(&self) -> Self {
        let mut flat = self.clone();
        if let Some(root) = self.nodes.first() {
            flat.nodes = vec![Node {
                bounds: root.bounds,
                first: 0,
                count: self.order.len() as u32,
            }];
        }
        flat
    }

    /// Adds the node over `placed` and, below it, its children (median splits along the
    /// longest axis of the centres); returns its index.
    fn split(&mut self, placed: &mut [Placed]) -> usize {
        let at = self.nodes.len();
        let bounds = placed
            .iter()
            .fold(Bounds::empty(), |b, p| b.join(&Bounds::of(p)));
        self.nodes.push(Node {
            bounds,
            first: self.order.len() as u32,
            count: placed.len() as u32,
        });
        let leaf_size = if at == 0 { LIST_OPENINGS } else { LEAF_SIZE };
        if placed.len() <= leaf_size {
            self.order.extend(placed.iter().map(|p| p.opening));
            return at;
        }
        let (lo, hi) = placed
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p.centre), hi.max(p.centre))
            });
        let axis = (hi - lo).max_position();
        let middle = placed.len() / 2;
        placed.select_nth_unstable_by(middle, |a, b| {
            a.centre[axis]
                .total_cmp(&b.centre[axis])
                .then(a.opening.cmp(&b.opening))
        });
        let (left, right) = placed.split_at_mut(middle);
        self.split(left);
        let second = self.split(right);
        self.nodes[at].first = second as u32;
        self.nodes[at].count = 0;
        at
    }

    /// Sets each node's [`Bounds::brightest`] and [`Bounds::brightest_beyond`] from
    /// `light(i)`, which gives them for opening i.
    pub fn set_light(&mut self, light: impl Fn(usize) -> (f32, f32)) {
        // Children come after their parent, so a backward pass sees them first.
        for k in (0..self.nodes.len()).rev() {
            let node = &self.nodes[k];
            let (brightest, beyond) = if node.count > 0 {
                let leaf = &self.order[node.first as usize..(node.first + node.count) as usize];
                leaf.iter()
                    .map(|&i| light(i as usize))
                    .fold((0.0, 0.0), |(a, b), (x, y)| {
                        (f32::max(a, x), f32::max(b, y))
                    })
            } else {
                let (a, b) = (
                    &self.nodes[k + 1].bounds,
                    &self.nodes[node.first as usize].bounds,
                );
                (
                    a.brightest.max(b.brightest),
                    a.brightest_beyond.max(b.brightest_beyond),
                )
            };
            self.nodes[k].bounds.brightest = brightest;
            self.nodes[k].bounds.brightest_beyond = beyond;
        }
    }

    /// Walks the tree, the higher priority child first, skipping what `visitor` says cannot
    /// matter, then takes the moving openings.
    pub fn visit(&self, visitor: &mut impl Visitor) {
        if let Some(root) = self.nodes.first()
            && root.count > 0
        {
            for &i in &self.order {
                visitor.opening(i as usize);
            }
        } else if let Some(priority) =
            (self.nodes.first()).and_then(|n| visitor.priority(&n.bounds))
        {
            let mut stack = [(0u32, 0f32); STACK];
            stack[0] = (0, priority);
            let mut len = 1;
            while len > 0 {
                len -= 1;
                let (k, priority) = stack[len];
                if !visitor.still_matters(priority) {
                    continue;
                }
                let node = &self.nodes[k as usize];
                if node.count > 0 {
                    let leaf = node.first as usize..(node.first + node.count) as usize;
                    for &i in &self.order[leaf] {
                        visitor.opening(i as usize);
                    }
                    continue;
                }
                let children = [k + 1, node.first];
                let scores = children.map(|c| visitor.priority(&self.nodes[c as usize].bounds));
                // The better child goes on the stack last, so it is taken first.
                let order = if scores[0] >= scores[1] {
                    [1, 0]
                } else {
                    [0, 1]
                };
                for c in order {
                    if let Some(priority) = scores[c] {
                        stack[len] = (children[c], priority);
                        len += 1;
                    }
                }
            }
        }
        self.visit_moving(visitor);
    }

    /// Takes the still openings `listed` (a shading point's candidates,
    /// [`crate::through::candidates`]) without bounds, then the moving ones.
    pub fn visit_listed(&self, listed: &[u16], visitor: &mut impl Visitor) {
        for &i in listed {
            visitor.opening(i as usize);
        }
        self.visit_moving(visitor);
    }

    fn visit_moving(&self, visitor: &mut impl Visitor) {
        for &i in &self.moving {
            visitor.opening(i as usize);
        }
    }

    /// How many still openings the tree holds.
    pub fn still_count(&self) -> usize {
        self.order.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Takes every opening whose box lies within `reach` of `from`, counting the ones it
    /// looked at.
    struct Near {
        placed: Vec<Placed>,
        from: DVec3,
        reach: f64,
        taken: Vec<usize>,
        looked_at: usize,
    }

    impl Visitor for Near {
        fn priority(&self, bounds: &Bounds) -> Option<f32> {
            let d = bounds.distance_squared(self.from).sqrt();
            (d <= self.reach).then_some(-d as f32)
        }
        fn still_matters(&self, _: f32) -> bool {
            true
        }
        fn opening(&mut self, i: usize) {
            self.looked_at += 1;
            let within = self
                .placed
                .get(i)
                .is_none_or(|p| Bounds::of(p).distance_squared(self.from).sqrt() <= self.reach);
            if within {
                self.taken.push(i);
            }
        }
    }

    #[test]
    fn the_walk_takes_what_the_bounds_admit_and_every_moving_opening() {
        let placed: Vec<Placed> = (0..100u32)
            .map(|i| Placed {
                opening: i,
                centre: DVec3::new((i % 10) as f64, (i / 10) as f64, 0.0),
                radius: 0.25,
                area: 0.2,
            })
            .collect();
        let mut tree = ApertureTree::new(placed.clone(), vec![100, 101]);
        tree.set_light(|i| (i as f32, 200.0 - i as f32));
        assert_eq!(tree.nodes[0].bounds.brightest, 99.0);
        assert_eq!(tree.nodes[0].bounds.brightest_beyond, 200.0);
        let from = DVec3::new(3.2, 4.9, 0.5);
        let mut near = Near {
            placed: placed.clone(),
            from,
            reach: 1.6,
            taken: Vec::new(),
            looked_at: 0,
        };
        tree.visit(&mut near);
        let mut want: Vec<usize> = placed
            .iter()
            .filter(|p| Bounds::of(p).distance_squared(from).sqrt() <= 1.6)
            .map(|p| p.opening as usize)
            .chain([100, 101])
            .collect();
        near.taken.sort();
        want.sort();
        assert_eq!(near.taken, want);
        // The bounds kept the walk to the openings near the point.
        assert!(near.looked_at < 30, "looked at {}", near.looked_at);
    }
}
