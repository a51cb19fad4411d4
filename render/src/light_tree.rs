//! A light BVH for choosing which emitter a shading point samples, so thousands of small strand
//! segments cost about as much as a few: each node keeps its emitters' bounds (over every time
//! a ray can have), total power and a cone holding their normals, and a descent picks a child in
//! proportion to an importance that bounds what the node can send to the point. The
//! importance follows Conty Estevez & Kulla, "Importance Sampling of Many Lights with Adaptive
//! Tree Splitting" (2018): power, over the squared distance to the node (no less than its
//! radius squared), times the cosine of the smallest angle between the cone's normals and the
//! direction to the point, and of the smallest angle between the point's normal and the node.
//!
//! The probability of a chosen emitter is the product of the choices on its root path, so the
//! same product can be recomputed for multiple importance sampling by replaying the path
//! (stored as one bit per level).
//!
//! Importance is zero only where nothing in the node can reach the point (all of it behind the
//! point's surface, or every normal facing away), so no emitter that contributes is ever
//! skipped.

use glam::Vec3;

/// Deepest tree the path bits can describe.
const MAX_DEPTH: u32 = 64;

/// What the tree needs of one emitter.
#[derive(Clone, Copy, Debug)]
pub struct LightBounds {
    pub min: Vec3,
    pub max: Vec3,
    /// Emitted power (any consistent scale).
    pub power: f32,
    /// Unit axis of the cone of normals.
    pub axis: Vec3,
    /// Cosine of the cone's half-angle: 1 for a flat one-sided emitter, −1 when it emits in
    /// every direction (two-sided, round, or turning over time). Each normal emits into its
    /// hemisphere.
    pub cos_spread: f32,
}

impl LightBounds {
    fn centroid(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    fn union(&self, o: &Self) -> Self {
        let (axis, cos_spread) = merge_cones(self.axis, self.cos_spread, o.axis, o.cos_spread);
        Self {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
            power: self.power + o.power,
            axis,
            cos_spread,
        }
    }

    /// An upper bound, up to a constant, of what the node can send to `p` (with unit surface
    /// normal `n`, when the point only reflects).
    #[inline]
    pub fn importance(&self, p: Vec3, n: Option<Vec3>) -> f32 {
        if self.power <= 0.0 {
            return 0.0;
        }
        // Nothing when the whole box lies behind the point's surface: the farthest corner along
        // n decides exactly, where the bounding sphere alone would waste samples on nodes
        // whose children all lie behind.
        if let Some(n) = n {
            let farthest = Vec3::select(n.cmpgt(Vec3::ZERO), self.max, self.min);
            if (farthest - p).dot(n) <= 0.0 {
                return 0.0;
            }
        }
        let centre = self.centroid();
        let to_point = p - centre;
        let dist2 = to_point.length_squared();
        let radius2 = 0.25 * (self.max - self.min).length_squared();
        if dist2 <= radius2 {
            // Inside the bounds: every direction is possible.
            return self.power / radius2.max(f32::MIN_POSITIVE);
        }
        let dist = dist2.sqrt();
        let w = to_point / dist;
        // The angle the bounding sphere subtends from the point.
        let sin_u = (radius2 / dist2).sqrt();
        let cos_u = (1.0 - sin_u * sin_u).max(0.0).sqrt();
        let mut value = self.power / dist2;
        if self.cos_spread > -1.0 {
            // Emitter side: angle from the cone's nearest normal to the point, less the
            // sphere's angle.
            let cos_theta = self.axis.dot(w).clamp(-1.0, 1.0);
            let cos_reduced = cos_minus(cos_minus(cos_theta, self.cos_spread), cos_u);
            if cos_reduced <= 0.0 {
                return 0.0;
            }
            value *= cos_reduced;
        }
        if let Some(n) = n {
            // Receiver side: the normal against the direction to the node, less the sphere's
            // angle.
            let cos_i = (-w).dot(n).clamp(-1.0, 1.0);
            let cos_reduced = cos_minus(cos_i, cos_u);
            if cos_reduced <= 0.0 {
                return 0.0;
            }
            value *= cos_reduced;
        }
        value
    }
}

/// cos(max(0, a − b)) for angles a, b in [0, π] given by their cosines.
#[inline]
fn cos_minus(cos_a: f32, cos_b: f32) -> f32 {
    if cos_a >= cos_b {
        return 1.0;
    }
    let sin_a = (1.0 - cos_a * cos_a).max(0.0).sqrt();
    let sin_b = (1.0 - cos_b * cos_b).max(0.0).sqrt();
    cos_a * cos_b + sin_a * sin_b
}

/// The smallest cone holding two cones (axis, cosine of half-angle).
fn merge_cones(a: Vec3, cos_a: f32, b: Vec3, cos_b: f32) -> (Vec3, f32) {
    if cos_a <= -1.0 || cos_b <= -1.0 {
        return (a, -1.0);
    }
    let (theta_a, theta_b) = (cos_a.clamp(-1.0, 1.0).acos(), cos_b.clamp(-1.0, 1.0).acos());
    let between = a.dot(b).clamp(-1.0, 1.0).acos();
    // One cone inside the other.
    if (between + theta_b).min(std::f32::consts::PI) <= theta_a {
        return (a, cos_a);
    }
    if (between + theta_a).min(std::f32::consts::PI) <= theta_b {
        return (b, cos_b);
    }
    let theta = 0.5 * (theta_a + between + theta_b);
    if theta >= std::f32::consts::PI {
        return (a, -1.0);
    }
    // Turn a towards b by (θ − θa), within the plane of both axes.
    let turn = theta - theta_a;
    let side = b - a * a.dot(b);
    if side.length_squared() < 1e-12 {
        return (a, -1.0);
    }
    let axis = a * turn.cos() + side.normalize() * turn.sin();
    (axis.normalize(), theta.cos())
}

#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: LightBounds,
    /// Leaf: the emitter index; inner: the second child (the first follows the node).
    index: u32,
    leaf: bool,
}

/// The tree over every emitter of a scene.
#[derive(Clone, Debug, Default)]
pub struct LightTree {
    nodes: Vec<Node>,
    /// Per emitter: its root path, one bit per level (1: second child), and its depth.
    paths: Vec<(u64, u32)>,
}

impl LightTree {
    /// Builds over `emitters` (indexed as given).
    pub fn new(emitters: &[LightBounds]) -> Self {
        let mut tree = Self {
            nodes: Vec::with_capacity(2 * emitters.len()),
            paths: vec![(0, 0); emitters.len()],
        };
        if !emitters.is_empty() {
            let mut order: Vec<u32> = (0..emitters.len() as u32).collect();
            tree.build(emitters, &mut order, 0, 0);
        }
        tree
    }

    fn build(
        &mut self,
        emitters: &[LightBounds],
        order: &mut [u32],
        path: u64,
        depth: u32,
    ) -> usize {
        let at = self.nodes.len();
        if order.len() == 1 {
            let e = order[0] as usize;
            self.nodes.push(Node {
                bounds: emitters[e],
                index: e as u32,
                leaf: true,
            });
            self.paths[e] = (path, depth);
            return at;
        }
        // Median splits keep the depth at ⌈log₂ n⌉, far inside the path bits.
        debug_assert!(depth < MAX_DEPTH);
        let mut bounds = emitters[order[0] as usize];
        for &i in &order[1..] {
            bounds = bounds.union(&emitters[i as usize]);
        }
        self.nodes.push(Node {
            bounds,
            index: 0,
            leaf: false,
        });
        // Split at the median centroid along the centroids' widest axis.
        let (lo, hi) = order.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), &i| {
                let c = emitters[i as usize].centroid();
                (lo.min(c), hi.max(c))
            },
        );
        let extent = hi - lo;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let mid = order.len() / 2;
        order.select_nth_unstable_by(mid, |&a, &b| {
            emitters[a as usize].centroid()[axis].total_cmp(&emitters[b as usize].centroid()[axis])
        });
        let (left, right) = order.split_at_mut(mid);
        self.build(emitters, left, path, depth + 1);
        let second = self.build(emitters, right, path | 1 << depth, depth + 1);
        self.nodes[at].index = second as u32;
        at
    }

    /// True when the tree holds no emitter.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Picks an emitter for point `p` (normal `n` when it only reflects) from `u` in [0, 1);
    /// returns it, its probability and `u` rescaled for reuse. `None` when nothing can reach
    /// the point.
    pub fn sample(&self, u: f32, p: Vec3, n: Option<Vec3>) -> Option<(usize, f32, f32)> {
        let mut node = 0usize;
        let mut pmf = 1.0f32;
        let mut u = u;
        if self.nodes.is_empty() {
            return None;
        }
        while !self.nodes[node].leaf {
            let (first, second) = (node + 1, self.nodes[node].index as usize);
            let a = self.nodes[first].bounds.importance(p, n);
            let b = self.nodes[second].bounds.importance(p, n);
            if a + b <= 0.0 {
                return None;
            }
            let p_first = a / (a + b);
            if u < p_first {
                u /= p_first;
                pmf *= p_first;
                node = first;
            } else {
                u = ((u - p_first) / (1.0 - p_first)).min(1.0 - f32::EPSILON);
                pmf *= 1.0 - p_first;
                node = second;
            }
        }
        Some((self.nodes[node].index as usize, pmf, u))
    }

    /// The probability [`Self::sample`] picks `emitter` for point `p` (normal `n`).
    pub fn pmf(&self, emitter: usize, p: Vec3, n: Option<Vec3>) -> f32 {
        let Some(&(path, depth)) = self.paths.get(emitter) else {
            return 0.0;
        };
        let mut node = 0usize;
        let mut pmf = 1.0f32;
        for level in 0..depth {
            let (first, second) = (node + 1, self.nodes[node].index as usize);
            let a = self.nodes[first].bounds.importance(p, n);
            let b = self.nodes[second].bounds.importance(p, n);
            if a + b <= 0.0 {
                return 0.0;
            }
            if path >> level & 1 == 0 {
                pmf *= a / (a + b);
                node = first;
            } else {
                pmf *= b / (a + b);
                node = second;
            }
        }
        pmf
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mix of one-sided panels facing different ways and round (omnidirectional) segments.
    fn emitters() -> Vec<LightBounds> {
        (0..300)
            .map(|i| {
                let f = i as f32;
                let c = Vec3::new(
                    (f * 0.37).sin() * 4.0,
                    (f * 0.11).cos() * 2.0,
                    (f * 0.23).sin() * 3.0,
                );
                let h = Vec3::splat(0.05 + 0.1 * (f * 0.7).sin().abs());
                let one_sided = i % 3 != 0;
                LightBounds {
                    min: c - h,
                    max: c + h,
                    power: 0.5 + (f * 1.3).sin().abs(),
                    axis: Vec3::new((f * 0.9).sin(), (f * 0.4).cos(), 0.3).normalize(),
                    cos_spread: if one_sided { 1.0 } else { -1.0 },
                }
            })
            .collect()
    }

    /// True when some point of the emitter's box lies in front of the receiver and some normal
    /// of its cone faces that point: then it can contribute and must be pickable.
    fn can_contribute(e: &LightBounds, p: Vec3, n: Vec3) -> bool {
        (0..8).any(|k| {
            let q = Vec3::new(
                if k & 1 == 0 { e.min.x } else { e.max.x },
                if k & 2 == 0 { e.min.y } else { e.max.y },
                if k & 4 == 0 { e.min.z } else { e.max.z },
            );
            (q - p).dot(n) > 1e-3 && (e.cos_spread < 0.0 || e.axis.dot(p - q) > 1e-3)
        })
    }

    #[test]
    fn probabilities_sum_to_one_match_sampling_and_skip_nothing_that_contributes() {
        let lights = emitters();
        let tree = LightTree::new(&lights);
        for k in 0..40 {
            let f = k as f32;
            let p = Vec3::new(
                (f * 0.7).sin() * 5.0,
                (f * 1.1).cos() * 3.0,
                (f * 0.3).cos() * 4.0,
            );
            let n = Vec3::new((f * 0.5).cos(), (f * 0.9).sin(), 0.4).normalize();
            let receiver = if k % 4 == 0 { None } else { Some(n) };
            let pmf: Vec<f32> = (0..lights.len())
                .map(|i| tree.pmf(i, p, receiver))
                .collect();
            // A node whose children both turn out unreachable (their union reaches corners or
            // directions neither does) loses its share: the sample is then empty, which is
            // unbiased since nothing below can contribute.
            let total: f32 = pmf.iter().sum();
            assert!(
                total <= 1.0 + 1e-4,
                "point {k}: probabilities sum to {total}"
            );
            if let Some(n) = receiver {
                for (i, e) in lights.iter().enumerate() {
                    if can_contribute(e, p, n) {
                        assert!(
                            pmf[i] > 0.0,
                            "point {k}: emitter {i} contributes but is never picked"
                        );
                    }
                }
            }
            // Sampling frequencies follow the probabilities.
            let draws = 200_000;
            let mut counts = vec![0u32; lights.len()];
            let mut empty = 0u32;
            for j in 0..draws {
                let u = (j as f32 + 0.5) / draws as f32;
                let Some((i, prob, rest)) = tree.sample(u, p, receiver) else {
                    empty += 1;
                    continue;
                };
                assert!(
                    (prob - pmf[i]).abs() <= 1e-5 * pmf[i].max(1e-3),
                    "point {k} emitter {i}"
                );
                assert!((0.0..1.0).contains(&rest));
                counts[i] += 1;
            }
            let lost = (1.0 - total) * draws as f32;
            assert!(
                (empty as f32 - lost).abs() <= 2.0 + 1e-3 * draws as f32,
                "point {k}"
            );
            for (i, &c) in counts.iter().enumerate() {
                let expected = pmf[i] * draws as f32;
                assert!(
                    (c as f32 - expected).abs() <= 2.0 + 1e-3 * draws as f32,
                    "point {k} emitter {i}: drawn {c} times, expected {expected}"
                );
            }
        }
    }

    #[test]
    fn nearer_and_brighter_emitters_are_picked_more() {
        let at = |x: f32, power: f32| LightBounds {
            min: Vec3::new(x, 0.0, 0.0) - 0.01,
            max: Vec3::new(x, 0.0, 0.0) + 0.01,
            power,
            axis: Vec3::Z,
            cos_spread: -1.0,
        };
        let tree = LightTree::new(&[at(1.0, 1.0), at(4.0, 1.0), at(-2.0, 8.0)]);
        let p = Vec3::ZERO;
        let pmf: Vec<f32> = (0..3).map(|i| tree.pmf(i, p, None)).collect();
        // Power over distance squared is 1, 1/16 and 2; inner nodes blur it but keep the order.
        assert!(pmf[2] > pmf[0] && pmf[0] > 4.0 * pmf[1], "{pmf:?}");
        assert!((pmf.iter().sum::<f32>() - 1.0).abs() < 1e-5);
        // Behind the receiver's surface: never picked.
        assert_eq!(tree.pmf(0, p, Some(-Vec3::X)), 0.0);
    }
}
