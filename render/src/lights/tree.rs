//! A light BVH for choosing which emitter a shading point samples, so thousands of small strand
//! segments cost about as much as a few: each node keeps, for each of up to four children, its
//! emitters' bounds (over every time a ray can have), total power and a cone holding their
//! normals, and a descent picks a child in proportion to an importance that estimates what the
//! child can send to the point. Four children per node (the halves of the halves of a median
//! split) are scored in one pass of vector instructions, and each choice sees finer clusters
//! than a binary tree's would. A child of at most four emitters is a bucket, within which
//! power alone chooses. The importance follows Conty Estevez & Kulla, "Importance Sampling of
//! Many Lights with Adaptive Tree Splitting" (2018): power over the squared distance, times
//! the cosine of the smallest angle between the cone's normals and the direction to the
//! point, and a cosine at the receiver. Two changes make it find the few strands beside a
//! point out of a whole ring: the distance is taken from the emitters' power-weighted mean
//! (the middle of an arc's box lies off the arc) and is clamped at a quarter of the node's
//! radius, not the whole radius, so a point inside a big node still prefers the child whose
//! emitters are nearer.
//!
//! Below a lane of many round emitters that is far from the point (several of its radii away),
//! power alone chooses, as within a bucket: from there its members differ little in what they
//! can send, and the levels below, each a chain of square roots and divisions the next level
//! waits on, were most of the cost of a pick into a ring.
//!
//! Emitters that move (strands spinning over the shutter) are bounded twice: a box over every
//! time a ray can have, for the exact test of what lies behind a surface, and a sphere whose
//! centre follows a [`Path`] across the time range, for distance and angle. A ray at one time
//! then sees each node where it is at that time. The box alone is not enough: a fast ring's
//! strand can sweep 30 cm over the shutter, three times the distance from a wall to the strands
//! that light it.
//!
//! The probability of a chosen emitter is the product of the choices on its root path, so the
//! same product can be recomputed for multiple importance sampling by replaying the path
//! (stored as two bits per level).
//!
//! Importance is zero only where nothing in the node can reach the point (all of it behind the
//! point's surface, or every normal facing away), so no emitter that contributes is ever
//! skipped.

use crate::platform::huge_pages;
use glam::{Vec3, Vec4};

/// A lane of at least [`FAR_MEMBERS`] emitters that all send light every way (strands) is far
/// from a point its sphere lies more than this many radii from: below it, power alone chooses
/// (see [`LightTree::sample`]). From four radii away the sphere subtends less than ±15°, and
/// what its members can send differs by distance by at most (5/3)² from the nearest to the
/// farthest, while the levels below would cost most of a descent into a ring.
const FAR_RADII: f32 = 4.0;

/// The fewest emitters a lane needs to be far: below a smaller one the descent is short anyway,
/// and a few flat emitters (two-sided panels, which also send light every way) differ by their
/// orientation more than strands by their place.
const FAR_MEMBERS: usize = 64;

/// Path bits: two per level, so the deepest tree they describe has 32 levels.
const PATH_BITS: u32 = 64;

/// Times across the range at which a node's sphere is checked to hold its members' spheres.
const RADIUS_STEPS: usize = 8;

/// Levels whose children a fetching descent does not ask the cache for: every pick reads the
/// root's children and grandchildren (twenty nodes, 7 KiB), so they stay cached, and asking
/// again cost the showcase about 3% of its render time (median of twelve concurrent rounds
/// against the descent that fetched at every level; eleven of them slower).
const CACHED_LEVELS: u32 = 2;

/// Where a point is over the time range, τ from 0 at its start to 1 at its end: the parabola
/// through where it is at the start, the middle and the end. Exact for uniformly accelerated
/// motion; for a point turning a twentieth of a circle it strays 0.025% of the circle's radius
/// from the arc, where the chord strays 1.2%.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Path {
    start: Vec3,
    /// c(τ) = start + τ·(velocity + τ·acceleration).
    velocity: Vec3,
    acceleration: Vec3,
}

impl Path {
    /// A point that does not move.
    pub fn still(p: Vec3) -> Self {
        Self {
            start: p,
            velocity: Vec3::ZERO,
            acceleration: Vec3::ZERO,
        }
    }

    /// The path through `p[0]`, `p[1]`, `p[2]` at τ = 0, ½, 1.
    pub fn through(p: [Vec3; 3]) -> Self {
        Self {
            start: p[0],
            velocity: 4.0 * p[1] - 3.0 * p[0] - p[2],
            acceleration: 2.0 * (p[0] + p[2]) - 4.0 * p[1],
        }
    }

    #[inline(always)]
    pub fn at(&self, tau: f32) -> Vec3 {
        self.start + tau * (self.velocity + tau * self.acceleration)
    }

    /// The power-weighted mean of `paths` (their coefficients average like their points).
    fn mean(paths: impl Iterator<Item = (f32, Path)>) -> Option<Self> {
        let (mut sum, mut weight) = (Self::still(Vec3::ZERO), 0.0f32);
        for (w, p) in paths {
            sum.start += w * p.start;
            sum.velocity += w * p.velocity;
            sum.acceleration += w * p.acceleration;
            weight += w;
        }
        (weight > 0.0).then(|| Self {
            start: sum.start / weight,
            velocity: sum.velocity / weight,
            acceleration: sum.acceleration / weight,
        })
    }
}

/// What the tree needs of one emitter.
#[derive(Clone, Copy, Debug)]
pub struct LightBounds {
    /// Box holding the emitter at every time.
    pub min: Vec3,
    pub max: Vec3,
    /// Where the emitter's centre is over the time range.
    pub centre: Path,
    /// Radius of the sphere around that moving centre that holds the emitter at every time.
    pub reach: f32,
    /// What the emitter is weighed by, on any consistent scale: its power, or as light
    /// selection gives it, π times the most light it sends in one direction (see
    /// `lights::TWO_SIDED_PEAK_SHARE`).
    pub power: f32,
    /// Unit axis of the cone of normals.
    pub axis: Vec3,
    /// Cosine of the cone's half-angle: 1 for a flat one-sided emitter, −1 when it emits in
    /// every direction (two-sided, round, or turning over time). Each normal emits into its
    /// hemisphere.
    pub cos_spread: f32,
}

impl LightBounds {
    /// An emitter that stays within the box from `min` to `max` at every time.
    pub fn still(min: Vec3, max: Vec3, power: f32, axis: Vec3, cos_spread: f32) -> Self {
        Self {
            min,
            max,
            centre: Path::still(0.5 * (min + max)),
            reach: 0.5 * (max - min).length(),
            power,
            axis,
            cos_spread,
        }
    }
}

/// A node's bounds as the descent reads them: the box for the exact behind-the-surface test,
/// and the sphere, moving over the time range, for distance and angle.
#[derive(Clone, Copy, Debug)]
struct Cluster {
    min: Vec3,
    max: Vec3,
    centre: Path,
    radius: f32,
    power: f32,
    axis: Vec3,
    cos_spread: f32,
}

impl Cluster {
    /// The cluster of `emitters[i]` for each `i` of `members`: centred on their power-weighted
    /// mean, its sphere holding every member's sphere (checked at [`RADIUS_STEPS`] + 1 times).
    fn new(emitters: &[LightBounds], members: &[u32]) -> Self {
        let each = || members.iter().map(|&i| &emitters[i as usize]);
        let first = each().next().expect("a cluster has members");
        let (mut min, mut max) = (first.min, first.max);
        let (mut axis, mut cos_spread) = (first.axis, first.cos_spread);
        for e in each().skip(1) {
            (min, max) = (min.min(e.min), max.max(e.max));
            (axis, cos_spread) = merge_cones(axis, cos_spread, e.axis, e.cos_spread);
        }
        let power: f32 = each().map(|e| e.power).sum();
        // Measured from the members' power-weighted mean, which lies among them: the middle of
        // the box of an arc of ring is off the arc, nearer the ring's centre.
        let centre = Path::mean(each().map(|e| (e.power, e.centre))).unwrap_or(first.centre);
        // Two bounds on how far the members reach from the centre, both valid at every time:
        // around every member's sphere, and to the farthest corner of the box. The first is
        // the tighter for moving members, the second for still ones.
        let (spheres, corners) = (0..=RADIUS_STEPS).fold((0.0f32, 0.0f32), |(s, b), k| {
            let tau = k as f32 / RADIUS_STEPS as f32;
            let c = centre.at(tau);
            let s = each().fold(s, |s, e| s.max(e.centre.at(tau).distance(c) + e.reach));
            (s, b.max((c - min).abs().max((max - c).abs()).length()))
        });
        let radius = spheres.min(corners);
        Self {
            min,
            max,
            centre,
            radius,
            power,
            axis,
            cos_spread,
        }
    }
}

/// cos(max(0, θ − σ − u)), lane by lane: the cosine of the smallest angle between a cone's
/// normals (σ from its axis) and a direction θ from its axis, less the half-angle u a sphere of
/// `radius` subtends at distance `dist`. θ comes as lengths, `along` = d·cos θ and `across` =
/// d·sin θ, and the sines and cosines stay scaled by d (the angle-difference formula is
/// homogeneous in them), so the square roots all start from the inputs side by side and one
/// division by d² ends the chain: this runs once a tree level, in series.
#[inline(always)]
fn cone_bound(
    along: Vec4,
    across: Vec4,
    dist: Vec4,
    [cos_spread, sin_spread]: [Vec4; 2],
    radius: Vec4,
) -> Vec4 {
    let dist2 = dist * dist;
    let within = along.cmpge(cos_spread * dist);
    // d·cos a and d·sin a, a = max(0, θ − σ).
    let cos_a = Vec4::select(within, dist, along * cos_spread + across * sin_spread);
    let sin_a = Vec4::select(
        within,
        Vec4::ZERO,
        (across * cos_spread - along * sin_spread).max(Vec4::ZERO),
    );
    // d·sin u and d·cos u (u a right angle from inside the sphere).
    let sin_u = radius.min(dist);
    let cos_u = (dist2 - radius * radius).max(Vec4::ZERO).sqrt();
    Vec4::select(
        cos_a.cmpge(cos_u),
        Vec4::ONE,
        (cos_a * cos_u + sin_a * sin_u) / dist2,
    )
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

/// Children per node.
pub const WIDTH: usize = 4;

/// Marks a lane that holds a bucket of emitters rather than a node.
const LEAF: u32 = 1 << 31;

/// Most emitters one lane holds as a bucket. Within a bucket an emitter is chosen by power
/// alone: a bucket's members lie side by side (a few centimetres of strand), where the
/// importance would hardly tell them apart, and the bottom level of nodes it replaces held
/// three quarters of the tree, so a descent reads one level fewer and the tree takes a quarter
/// of the memory (a ring-lit frame's picks waited on those nodes' cache misses).
const BUCKET: usize = 4;

/// Where a bucket lane keeps its size less one. The bits below hold its first entry in
/// `LightTree::buckets`, or for a bucket of one the emitter itself (one read fewer for
/// scenes of few emitters, such as a single area light).
const BUCKET_SIZE_SHIFT: u32 = 29;

/// The members of a bucket lane: one emitter, or several with their powers.
enum Members<'a> {
    One(usize),
    Many(&'a [(u32, f32)]),
}

/// Up to four children's bounds side by side, one lane each (per axis, a [`Vec4`] across the
/// lanes), so one pass of vector instructions computes all four importances. A descent then
/// reads one node per level and half as many levels as a binary tree would need.
///
/// Each row of fields below fills one cache line, and the cone's axis and sine come last: a
/// node of lanes that all emit every way (round strands) never reads that line, so a descent
/// into a ring waits on five lines a level rather than six.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
struct Node {
    min: [Vec4; 3],
    power: Vec4,
    max: [Vec4; 3],
    radius: Vec4,
    /// The sphere centre's [`Path`]: start + τ·(velocity + τ·acceleration).
    start: [Vec4; 3],
    /// The squared distance beyond which a lane is far ([`FAR_RADII`]); infinite for lanes
    /// that never are.
    far2: Vec4,
    velocity: [Vec4; 3],
    cos_spread: Vec4,
    acceleration: [Vec4; 3],
    /// Per lane: a node's index, or a bucket (see [`BUCKET_SIZE_SHIFT`]) with [`LEAF`] set.
    /// Unused lanes have no power.
    child: [u32; WIDTH],
    axis: [Vec4; 3],
    /// The sine of the cone's half-angle, so the descent takes no square root for it.
    sin_spread: Vec4,
}

// Six cache lines, the cone's alone in the last.
const _: () = assert!(std::mem::size_of::<Node>() == 6 * 64);
const _: () = assert!(std::mem::offset_of!(Node, axis) == 5 * 64);

impl Node {
    /// Puts `c` in lane `k`, pointing at `child`.
    fn set(&mut self, k: usize, c: &Cluster, members: usize, child: u32) {
        for a in 0..3 {
            self.min[a][k] = c.min[a];
            self.max[a][k] = c.max[a];
            self.start[a][k] = c.centre.start[a];
            self.velocity[a][k] = c.centre.velocity[a];
            self.acceleration[a][k] = c.centre.acceleration[a];
            self.axis[a][k] = c.axis[a];
        }
        self.radius[k] = c.radius;
        self.power[k] = c.power;
        self.cos_spread[k] = c.cos_spread;
        self.sin_spread[k] = (1.0 - c.cos_spread * c.cos_spread).max(0.0).sqrt();
        let every_way = c.cos_spread <= -1.0;
        self.far2[k] = if every_way && members >= FAR_MEMBERS {
            (FAR_RADII * c.radius).powi(2)
        } else {
            f32::INFINITY
        };
        self.child[k] = child;
    }

    /// What each child can send to `p` (with unit surface normal `n`, when the point only
    /// reflects) at `tau` through the time range (0 at its start, 1 at its end), up to a
    /// constant; zero only when nothing in it can reach the point at any time. Also which
    /// lanes are far (bit k for lane k; see [`FAR_RADII`]).
    #[inline(always)]
    fn importance(&self, p: Vec3, n: Option<Vec3>, tau: f32) -> ([f32; WIDTH], u32) {
        let tau = Vec4::splat(tau);
        let to_centre: [Vec4; 3] = std::array::from_fn(|a| {
            self.start[a] + tau * (self.velocity[a] + tau * self.acceleration[a])
                - Vec4::splat(p[a])
        });
        let dot = |v: &[Vec4; 3], w: &[Vec4; 3]| v[0] * w[0] + v[1] * w[1] + v[2] * w[2];
        let dist2 = dot(&to_centre, &to_centre);
        let radius2 = self.radius * self.radius;
        // Power over squared distance, the distance clamped at a quarter of the radius rather
        // than the whole radius: a point inside a big node then still prefers the child whose
        // emitters are nearer, which is what finds the few strands beside a wall point
        // (clamping at the radius made both halves of a ring look alike from anywhere near it).
        let value = self.power
            / dist2
                .max(radius2 * (1.0 / 16.0))
                .max(Vec4::splat(f32::MIN_POSITIVE));
        let dist = dist2.sqrt();
        // Emitter side: angle from the cone's nearest normal to the point, less the angle the
        // sphere subtends. Lanes that emit every way (round strands) take no angular factor:
        // a node of nothing else skips the cone's square roots altogether.
        let has_cone = self.cos_spread.cmpgt(-Vec4::ONE);
        let angular = if has_cone.any() {
            let along = -dot(&self.axis, &to_centre);
            let across = (dist2 - along * along).max(Vec4::ZERO).sqrt();
            let spread = [self.cos_spread, self.sin_spread];
            let cone = cone_bound(along, across, dist, spread, self.radius);
            Vec4::select(has_cone, cone.max(Vec4::ZERO), Vec4::ONE)
        } else {
            Vec4::ONE
        };
        let mut reaches = self.power.cmpgt(Vec4::ZERO);
        let angular = match n {
            None => angular,
            Some(n) => {
                // Nothing when the whole box lies behind the point's surface: the farthest
                // corner along n decides exactly, where the bounding sphere alone would waste
                // samples on nodes whose children all lie behind.
                let ahead = (0..3).fold(Vec4::ZERO, |sum, a| {
                    let farthest = if n[a] > 0.0 { self.max[a] } else { self.min[a] };
                    sum + (farthest - Vec4::splat(p[a])) * n[a]
                });
                reaches &= ahead.cmpgt(Vec4::ZERO);
                // Receiver side: the cosine at the sphere's point highest above the surface,
                // taken over the centre's distance. It is positive whenever some corner of the
                // box is in front and costs no more square roots.
                let normal = [n.x, n.y, n.z].map(Vec4::splat);
                let receiver = ((dot(&to_centre, &normal) + self.radius) / dist)
                    .clamp(Vec4::splat(f32::MIN_POSITIVE), Vec4::ONE);
                angular * receiver
            }
        };
        // Inside the sphere every direction is possible: no angular factors.
        let value = Vec4::select(dist2.cmple(radius2), value, value * angular);
        let far = dist2.cmpgt(self.far2);
        (
            Vec4::select(reaches, value, Vec4::ZERO).to_array(),
            far.bitmask(),
        )
    }
}

/// What a descent below a far lane reads of a node: its lanes' powers and children, as in
/// [`Node`], in half a cache line rather than six.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
struct Powers {
    power: [f32; WIDTH],
    child: [u32; WIDTH],
}

/// The tree over every emitter of a scene.
#[derive(Clone, Debug, Default)]
pub struct LightTree {
    /// The root first.
    nodes: Vec<Node>,
    /// Each node's [`Powers`], at the node's index.
    powers: Vec<Powers>,
    /// Every bucket's members, bucket after bucket: (emitter, power).
    buckets: Vec<(u32, f32)>,
    /// Per emitter: its root path, two bits per level (the lane taken) and then two for its
    /// place in its bucket, and the number of nodes on the path.
    paths: Vec<(u64, u32)>,
}

impl LightTree {
    /// Builds over `emitters` (indexed as given).
    pub fn new(emitters: &[LightBounds]) -> Self {
        Self::with_kinds(emitters, &[])
    }

    /// Builds over `emitters`, the root's lanes holding the emitters of each kind apart when
    /// `kinds` (a key per emitter) names two to four kinds; otherwise as [`Self::new`].
    pub fn with_kinds(emitters: &[LightBounds], kinds: &[u32]) -> Self {
        assert!(
            emitters.len() < 1 << BUCKET_SIZE_SHIFT,
            "too many emitters for one light tree"
        );
        let mut tree = Self {
            nodes: huge_pages::with_capacity(emitters.len() / 8 + 1),
            powers: huge_pages::with_capacity(emitters.len() / 8 + 1),
            buckets: huge_pages::with_capacity(emitters.len()),
            paths: vec![(0, 0); emitters.len()],
        };
        if !emitters.is_empty() {
            let mut order: Vec<u32> = (0..emitters.len() as u32).collect();
            let mut keys: Vec<u32> = kinds.to_vec();
            keys.sort_unstable();
            keys.dedup();
            if kinds.len() == emitters.len() && (2..=WIDTH).contains(&keys.len()) {
                order.sort_by_key(|&e| kinds[e as usize]);
                let mut runs = Vec::new();
                let mut start = 0;
                for (i, pair) in order.windows(2).enumerate() {
                    if kinds[pair[0] as usize] != kinds[pair[1] as usize] {
                        runs.push(start..i + 1);
                        start = i + 1;
                    }
                }
                runs.push(start..order.len());
                tree.build_runs(emitters, &mut order, runs, 0, 0);
            } else {
                tree.build(emitters, &mut order, 0, 0);
            }
        }
        tree
    }

    /// Appends a node over the emitters of `order` (reached by `path` at `depth`) and its
    /// descendants; returns its index. Its lanes are the halves of the halves of `order`, each
    /// a bucket when it has at most [`BUCKET`] members.
    fn build(&mut self, emitters: &[LightBounds], order: &mut [u32], path: u64, depth: u32) -> u32 {
        // Median splits keep the depth at ⌈log₄ n⌉, far inside the path bits (which end with
        // two for the place in a bucket).
        debug_assert!(2 * (depth + 2) <= PATH_BITS);
        let mut groups = Vec::with_capacity(WIDTH);
        if order.len() == 1 {
            groups.push(0..1);
        } else {
            let mid = split(emitters, order);
            for half in [0..mid, mid..order.len()] {
                if half.len() == 1 {
                    groups.push(half);
                } else {
                    let quarter = half.start + split(emitters, &mut order[half.clone()]);
                    groups.extend([half.start..quarter, quarter..half.end]);
                }
            }
        }
        self.build_runs(emitters, order, groups, path, depth)
    }

    /// Appends a node whose lanes hold the runs `groups` of `order` and their descendants.
    fn build_runs(
        &mut self,
        emitters: &[LightBounds],
        order: &mut [u32],
        groups: Vec<std::ops::Range<usize>>,
        path: u64,
        depth: u32,
    ) -> u32 {
        let slot = self.nodes.len();
        self.nodes.push(Node::default());
        self.powers.push(Powers::default());
        for (k, group) in groups.into_iter().enumerate() {
            let members = &mut order[group];
            let lane_path = path | (k as u64) << (2 * depth);
            let child = if let [e] = *members {
                self.paths[e as usize] = (lane_path, depth + 1);
                LEAF | e
            } else if members.len() <= BUCKET {
                let first = self.buckets.len() as u32;
                for (place, &e) in members.iter().enumerate() {
                    let bits = (place as u64) << (2 * (depth + 1));
                    self.paths[e as usize] = (lane_path | bits, depth + 1);
                    self.buckets.push((e, emitters[e as usize].power));
                }
                LEAF | ((members.len() as u32 - 1) << BUCKET_SIZE_SHIFT) | first
            } else {
                self.build(emitters, members, lane_path, depth + 1)
            };
            let cluster = Cluster::new(emitters, members);
            self.nodes[slot].set(k, &cluster, members.len(), child);
            self.powers[slot].power[k] = cluster.power;
            self.powers[slot].child[k] = child;
        }
        slot as u32
    }

    /// True when the tree holds no emitter.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Picks an emitter for point `p` (normal `n` when it only reflects) at `tau` through the
    /// time range (0 at its start, 1 at its end) from `u` in [0, 1); returns it, its
    /// probability and `u` rescaled for reuse. `None` when nothing can reach the point.
    ///
    /// Each level chooses a lane in proportion to its importance until the chosen lane is far
    /// (see [`FAR_RADII`]); from there power alone chooses, as within a bucket, reading half a
    /// cache line a level. The guided levels (see [`GUIDED_LEVELS`]) always weigh by
    /// importance, so a guide's factors for them always apply.
    pub fn sample(
        &self,
        u: f32,
        p: Vec3,
        n: Option<Vec3>,
        tau: f32,
        guide: Option<&PerLane>,
    ) -> Option<(usize, f32, f32)> {
        self.descend(u, p, n, tau, guide, None::<fn(usize)>)
    }

    /// [`Self::sample`], calling `fetch` with each emitter a node may pick before its
    /// importances are computed, so what the caller reads of the chosen one can be on its way
    /// into the cache meanwhile; the child nodes a level may pick are fetched the same way.
    /// Worth it only for trees too big for the cache (see [`Self::bytes`]).
    #[inline(always)]
    pub fn sample_fetching(
        &self,
        u: f32,
        p: Vec3,
        n: Option<Vec3>,
        tau: f32,
        guide: Option<&PerLane>,
        fetch: impl Fn(usize),
    ) -> Option<(usize, f32, f32)> {
        self.descend(u, p, n, tau, guide, Some(fetch))
    }

    /// The descent of [`Self::sample`], fetching ahead when `fetch` is given.
    #[inline(always)]
    fn descend(
        &self,
        u: f32,
        p: Vec3,
        n: Option<Vec3>,
        tau: f32,
        guide: Option<&PerLane>,
        fetch: Option<impl Fn(usize)>,
    ) -> Option<(usize, f32, f32)> {
        let mut node = self.nodes.first()?;
        let mut pmf = 1.0f32;
        let mut u = u;
        let mut level = 0;
        let mut lanes = [0usize; GUIDED_LEVELS];
        loop {
            if let Some(fetch) = &fetch
                && level >= CACHED_LEVELS
            {
                self.fetch_lanes(&node.child, fetch, |next| {
                    crate::platform::prefetch::prefetch(&self.nodes[next..=next])
                });
            }
            let (mut weights, far) = node.importance(p, n, tau);
            if let Some(guide) = guide
                && (level as usize) < GUIDED_LEVELS
            {
                weights = guide.apply(level as usize, &lanes, weights);
            }
            let (k, share, rest) = choose(weights, u)?;
            if (level as usize) < GUIDED_LEVELS {
                lanes[level as usize] = k;
            }
            level += 1;
            u = rest;
            pmf *= share;
            let child = node.child[k];
            if child & LEAF != 0 {
                return self.pick_member(child, pmf, u, &fetch);
            }
            if far & (1 << k) != 0 && level >= GUIDED_LEVELS as u32 {
                return self.descend_by_power(child, pmf, u, &fetch);
            }
            node = &self.nodes[child as usize];
        }
    }

    /// The rest of a descent below a far lane, from node `index`: power alone chooses.
    #[inline(always)]
    fn descend_by_power(
        &self,
        mut index: u32,
        mut pmf: f32,
        mut u: f32,
        fetch: &Option<impl Fn(usize)>,
    ) -> Option<(usize, f32, f32)> {
        loop {
            let node = self.powers.get(index as usize)?;
            if let Some(fetch) = fetch {
                self.fetch_lanes(&node.child, fetch, |next| {
                    crate::platform::prefetch::prefetch(&self.powers[next..=next])
                });
            }
            let (k, share, rest) = choose(node.power, u)?;
            pmf *= share;
            u = rest;
            let child = node.child[k];
            if child & LEAF != 0 {
                return self.pick_member(child, pmf, u, fetch);
            }
            index = child;
        }
    }

    /// The end of a descent at the bucket lane `child`: one of its members by power.
    #[inline(always)]
    fn pick_member(
        &self,
        child: u32,
        pmf: f32,
        u: f32,
        fetch: &Option<impl Fn(usize)>,
    ) -> Option<(usize, f32, f32)> {
        match self.members(child)? {
            Members::One(emitter) => Some((emitter, pmf, u)),
            Members::Many(run) => {
                let (place, share, rest) = choose(bucket_powers(run), u)?;
                let emitter = run[place].0 as usize;
                if let Some(fetch) = fetch {
                    fetch(emitter);
                }
                Some((emitter, pmf * share, rest))
            }
        }
    }

    /// Asks the cache for every child a node's lanes `children` name: nodes through
    /// `fetch_node`, emitters named directly through `fetch`, and the members of buckets.
    #[inline(always)]
    fn fetch_lanes(
        &self,
        children: &[u32; WIDTH],
        fetch: &impl Fn(usize),
        fetch_node: impl Fn(usize),
    ) {
        for &child in children {
            if child & LEAF == 0 {
                if (child as usize) < self.nodes.len() {
                    fetch_node(child as usize);
                }
            } else {
                match self.members(child) {
                    Some(Members::One(e)) => fetch(e),
                    Some(Members::Many(run)) => crate::platform::prefetch::prefetch(run),
                    None => {}
                }
            }
        }
    }

    /// The bytes a descent reads from, at random: every node and bucket.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.powers.as_slice())
            + std::mem::size_of_val(self.buckets.as_slice())
    }

    /// What all emitters together can send to `p` (normal `n`) at `tau`, in the units of the
    /// selection importance (power over squared distance, with the angular bounds): an
    /// unoccluded estimate, about π times the irradiance, used to weigh light-sampling
    /// strategies against one another.
    pub fn importance(&self, p: Vec3, n: Option<Vec3>, tau: f32) -> f32 {
        self.nodes
            .first()
            .map_or(0.0, |root| root.importance(p, n, tau).0.iter().sum())
    }

    /// The probability [`Self::sample`] picks `emitter` for point `p` (normal `n`) at `tau`.
    pub fn pmf(
        &self,
        emitter: usize,
        p: Vec3,
        n: Option<Vec3>,
        tau: f32,
        guide: Option<&PerLane>,
    ) -> f32 {
        let Some(&(path, depth)) = self.paths.get(emitter).filter(|&&(_, d)| d > 0) else {
            return 0.0;
        };
        if self.nodes.is_empty() {
            return 0.0;
        }
        let mut pmf = 1.0f32;
        let lanes = [0, 1].map(|level| (path >> (2 * level) & 3) as usize);
        // The same choices as the descent: by importance down to the first far lane on the
        // path, by power below it.
        let (mut index, mut far) = (0usize, false);
        for level in 0..depth {
            let k = (path >> (2 * level) & 3) as usize;
            let weights = if far {
                self.powers[index].power
            } else {
                let (mut weights, far_lanes) = self.nodes[index].importance(p, n, tau);
                if let Some(guide) = guide
                    && (level as usize) < GUIDED_LEVELS
                {
                    weights = guide.apply(level as usize, &lanes, weights);
                }
                far = far_lanes & (1 << k) != 0 && level + 1 >= GUIDED_LEVELS as u32;
                weights
            };
            pmf *= share(weights, k);
            if level + 1 < depth {
                index = self.powers[index].child[k] as usize;
            }
        }
        let lane = self.powers[index].child[(path >> (2 * (depth - 1)) & 3) as usize];
        match self.members(lane) {
            Some(Members::One(_)) => pmf,
            Some(Members::Many(run)) => {
                pmf * share(bucket_powers(run), (path >> (2 * depth) & 3) as usize)
            }
            None => 0.0,
        }
    }

    /// The members of the bucket lane `child` names.
    #[inline(always)]
    fn members(&self, child: u32) -> Option<Members<'_>> {
        let first = (child & ((1 << BUCKET_SIZE_SHIFT) - 1)) as usize;
        match (child & !LEAF) >> BUCKET_SIZE_SHIFT {
            0 => Some(Members::One(first)),
            less_one => {
                let run = self.buckets.get(first..=first + less_one as usize)?;
                Some(Members::Many(run))
            }
        }
    }
}

/// Levels of the tree whose choices a guide reweighs: the root's lanes and each of their
/// children's.
pub const GUIDED_LEVELS: usize = 2;

/// A number for each lane of the top [`GUIDED_LEVELS`] levels: the root's four, and for each
/// root lane the four of the node below it (unused where that lane is a bucket). Learned
/// factors, shares and costs come this way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PerLane {
    pub root: [f32; WIDTH],
    pub second: [[f32; WIDTH]; WIDTH],
}

impl Default for PerLane {
    /// Ones: the factors that change nothing.
    fn default() -> Self {
        Self::splat(1.0)
    }
}

impl PerLane {
    /// `value` in every lane.
    pub const fn splat(value: f32) -> Self {
        Self {
            root: [value; WIDTH],
            second: [[value; WIDTH]; WIDTH],
        }
    }

    /// As factors (see [`crate::lights::guide`]): `weights` of the node at `level`, reached
    /// through the root lane `lanes[0]` (below the root), multiplied lane by lane. A descent
    /// and the replay of its path multiply alike, so choices stay consistent with their
    /// probabilities.
    #[inline(always)]
    fn apply(
        &self,
        level: usize,
        lanes: &[usize; GUIDED_LEVELS],
        weights: [f32; WIDTH],
    ) -> [f32; WIDTH] {
        let f = if level == 0 {
            &self.root
        } else {
            &self.second[lanes[0] & (WIDTH - 1)]
        };
        std::array::from_fn(|k| weights[k] * f[k])
    }
}

impl LightTree {
    /// The unguided descent's shares of the top two levels' lanes at `p` (normal `n`) at
    /// `tau` (zero below a root lane that is a bucket or has no share).
    pub fn lane_shares(&self, p: Vec3, n: Option<Vec3>, tau: f32) -> Option<PerLane> {
        let root = self.nodes.first()?;
        let (weights, _) = root.importance(p, n, tau);
        let mut shares = PerLane {
            root: std::array::from_fn(|k| share(weights, k)),
            ..PerLane::splat(0.0)
        };
        for (k, &child) in root.child.iter().enumerate() {
            if child & LEAF == 0 && shares.root[k] > 0.0 {
                let (w, _) = self.nodes[child as usize].importance(p, n, tau);
                shares.second[k] = std::array::from_fn(|j| share(w, j));
            }
        }
        Some(shares)
    }

    /// The lanes `emitter`'s path takes at the top two levels (the second `None` when the
    /// root lane is a bucket).
    pub fn top_lanes(&self, emitter: usize) -> Option<(usize, Option<usize>)> {
        let &(path, depth) = self.paths.get(emitter).filter(|&&(_, d)| d > 0)?;
        let first = (path & 3) as usize;
        Some((first, (depth >= 2).then_some((path >> 2 & 3) as usize)))
    }
}

/// A bucket's powers as lanes (the missing ones empty).
#[inline(always)]
fn bucket_powers(run: &[(u32, f32)]) -> [f32; WIDTH] {
    std::array::from_fn(|k| run.get(k).map_or(0.0, |&(_, power)| power))
}

/// A positive, finite total of weights (NaN fails both comparisons). Two comparisons:
/// `is_finite` compiled to a classification of the bits, paid at every level of a descent.
#[inline(always)]
fn usable_total(total: f32) -> bool {
    total > 0.0 && total < f32::INFINITY
}

/// Lane `k`'s share of `weights` in all, as a descent computes it; 0 when none has weight.
#[inline(always)]
fn share(weights: [f32; WIDTH], k: usize) -> f32 {
    let total = running_totals(weights)[WIDTH - 1];
    if usable_total(total) {
        weights[k] / total
    } else {
        0.0
    }
}

/// The sums of `weights` up to and including each lane, added in lane order (what a descent
/// and the replay of its path must agree on bit for bit).
#[inline(always)]
fn running_totals(weights: [f32; WIDTH]) -> [f32; WIDTH] {
    let [w0, w1, w2, w3] = weights;
    let (c1, c2) = (w0 + w1, w0 + w1 + w2);
    [w0, c1, c2, c2 + w3]
}

/// The lane whose share of the weights' total holds `u` in [0, 1): its index, its share, and
/// `u` rescaled within it; `None` when no lane has weight. The lane is a count of comparisons,
/// not a search: which lane a descent takes is a coin flip no branch predictor learns. Rounding
/// that puts `u` at the very end falls to the last lane with any weight.
#[inline(always)]
fn choose(weights: [f32; WIDTH], u: f32) -> Option<(usize, f32, f32)> {
    let ends = running_totals(weights);
    let total = ends[WIDTH - 1];
    if !usable_total(total) {
        return None;
    }
    let target = u * total;
    let mut k = ends[..WIDTH - 1]
        .iter()
        .map(|&end| (end <= target) as usize)
        .sum::<usize>();
    if weights[k] <= 0.0 {
        k = weights.iter().rposition(|&w| w > 0.0)?;
    }
    let below = if k == 0 { 0.0 } else { ends[k - 1] };
    let rest = ((target - below) / weights[k]).clamp(0.0, 1.0 - f32::EPSILON);
    Some((k, weights[k] / total, rest))
}

/// Splits `order` at its median centre along the widest of nine coordinates, the centres'
/// three axes at the middle, start and end of the time range; returns where the second half
/// starts. Emitters that meet halfway but move apart (a ring's counter-rotating strands) part
/// by where they are at the ends, so each cluster stays small at every time. Still emitters,
/// and ties, split by the middle of the range.
fn split(emitters: &[LightBounds], order: &mut [u32]) -> usize {
    const TIMES: [f32; 3] = [0.5, 0.0, 1.0];
    let key = |i: u32, c: usize| emitters[i as usize].centre.at(TIMES[c / 3])[c % 3];
    let extents = TIMES.map(|tau| {
        let (lo, hi) = order.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), &i| {
                let c = emitters[i as usize].centre.at(tau);
                (lo.min(c), hi.max(c))
            },
        );
        (hi - lo).to_array()
    });
    let extent = |c: usize| extents[c / 3][c % 3];
    let widest = (1..9).fold(0, |best, c| if extent(c) > extent(best) { c } else { best });
    let mid = order.len() / 2;
    order.select_nth_unstable_by(mid, |&a, &b| key(a, widest).total_cmp(&key(b, widest)));
    mid
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
                LightBounds::still(
                    c - h,
                    c + h,
                    0.5 + (f * 1.3).sin().abs(),
                    Vec3::new((f * 0.9).sin(), (f * 0.4).cos(), 0.3).normalize(),
                    if one_sided { 1.0 } else { -1.0 },
                )
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
        check_probabilities(&lights, &LightTree::new(&lights), None);
    }

    #[test]
    fn a_guided_descent_of_a_tree_of_kinds_matches_its_probabilities_too() {
        let lights = emitters();
        let kinds: Vec<u32> = (0..lights.len() as u32).map(|i| i % 3).collect();
        let tree = LightTree::with_kinds(&lights, &kinds);
        // The root's lanes are the kinds.
        for (i, &kind) in kinds.iter().enumerate() {
            let (lane, _) = tree.top_lanes(i).unwrap();
            assert_eq!(lane, kind as usize, "emitter {i}");
        }
        let factor = |k: usize| 0.2 + 4.8 * ((k as f32 * 0.77).sin() * 0.5 + 0.5);
        let guide = PerLane {
            root: std::array::from_fn(factor),
            second: std::array::from_fn(|j| std::array::from_fn(|k| factor(4 + 4 * j + k))),
        };
        check_probabilities(&lights, &tree, Some(&guide));
        // The factors move the choices: the root's shares are no longer the tree's.
        let p = Vec3::new(0.5, 0.2, -0.3);
        let shares = tree.lane_shares(p, None, 0.5).unwrap().root;
        let guided: [f32; 3] = std::array::from_fn(|lane| {
            (0..lights.len())
                .filter(|&i| kinds[i] as usize == lane)
                .map(|i| tree.pmf(i, p, None, 0.5, Some(&guide)))
                .sum()
        });
        let total: f32 = (0..3).map(|j| guide.root[j] * shares[j]).sum();
        for j in 0..3 {
            let expected = guide.root[j] * shares[j] / total;
            assert!(
                (guided[j] - expected).abs() < 1e-4,
                "lane {j}: {guided:?} {shares:?}"
            );
        }
    }

    /// A ring of round segments (radius 1 around the origin, in the xy plane), as strands are.
    fn ring() -> Vec<LightBounds> {
        (0..1024)
            .map(|i| {
                let f = i as f32;
                let angle = f * std::f32::consts::TAU / 1024.0;
                let c = Vec3::new(angle.cos(), angle.sin(), 0.02 * (f * 0.7).sin());
                LightBounds::still(
                    c - 0.004,
                    c + 0.004,
                    0.5 + (f * 1.3).sin().abs(),
                    Vec3::Z,
                    -1.0,
                )
            })
            .collect()
    }

    #[test]
    fn below_a_far_lane_power_alone_chooses_and_probabilities_still_match() {
        let lights = ring();
        let tree = LightTree::new(&lights);
        check_probabilities(&lights, &tree, None);
        // pmf / power for the emitters under each of the second level's lanes: equal within a
        // lane seen from far away, not from beside the ring.
        let spread = |p: Vec3| {
            let mut ratios = std::collections::HashMap::<(usize, usize), Vec<f32>>::new();
            for (i, e) in lights.iter().enumerate() {
                let (first, second) = tree.top_lanes(i).unwrap();
                let pmf = tree.pmf(i, p, Some(-p.normalize()), 0.5, None);
                ratios
                    .entry((first, second.unwrap()))
                    .or_default()
                    .push(pmf / e.power);
            }
            ratios
                .values()
                .map(|r| {
                    let (lo, hi) = r
                        .iter()
                        .fold((f32::MAX, 0.0f32), |(lo, hi), &x| (lo.min(x), hi.max(x)));
                    hi / lo
                })
                .fold(1.0f32, f32::max)
        };
        let far = spread(Vec3::new(0.5, 0.3, 6.0));
        assert!(far < 1.0 + 1e-4, "far: pmf / power varies {far}x in a lane");
        let near = spread(Vec3::new(1.05, 0.0, 0.05));
        assert!(
            near > 2.0,
            "near: pmf / power varies only {near}x in a lane"
        );
    }

    /// The checks of `probabilities_sum_to_one_match_sampling_and_skip_nothing_that_contributes`,
    /// for `tree` over `lights` descended with `guide`.
    fn check_probabilities(lights: &[LightBounds], tree: &LightTree, guide: Option<&PerLane>) {
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
                .map(|i| tree.pmf(i, p, receiver, 0.5, guide))
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
                let Some((i, prob, rest)) = tree.sample(u, p, receiver, 0.5, guide) else {
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
        let at = |x: f32, power: f32| {
            let c = Vec3::new(x, 0.0, 0.0);
            LightBounds::still(c - 0.01, c + 0.01, power, Vec3::Z, -1.0)
        };
        let tree = LightTree::new(&[at(1.0, 1.0), at(4.0, 1.0), at(-2.0, 8.0)]);
        let p = Vec3::ZERO;
        let pmf: Vec<f32> = (0..3).map(|i| tree.pmf(i, p, None, 0.0, None)).collect();
        // Power over distance squared is 1, 1/16 and 2; inner nodes blur it but keep the order.
        assert!(pmf[2] > pmf[0] && pmf[0] > 4.0 * pmf[1], "{pmf:?}");
        assert!((pmf.iter().sum::<f32>() - 1.0).abs() < 1e-5);
        // Behind the receiver's surface: never picked.
        assert_eq!(tree.pmf(0, p, Some(-Vec3::X), 0.0, None), 0.0);
    }

    /// Second moment of (contribution / probability) over the squared mean: 1 for a pmf
    /// proportional to the contributions, larger the worse the pmf matches.
    fn relative_second_moment(f: &[f64], pmf: impl Fn(usize) -> f64) -> f64 {
        let total: f64 = f.iter().sum();
        let second: f64 = f
            .iter()
            .enumerate()
            .filter(|&(_, &f)| f > 0.0)
            .map(|(i, &f)| f * f / pmf(i))
            .sum();
        second / (total * total)
    }

    #[test]
    fn a_point_beside_a_ring_picks_the_strands_near_it() {
        // 2000 round segments on a ring of radius 0.9 in the plane z = 0.1, a wall at z = 0.
        let count = 2000;
        let radius = 0.9f32;
        let half = 0.004;
        let centres: Vec<Vec3> = (0..count)
            .map(|i| {
                let a = std::f32::consts::TAU * i as f32 / count as f32;
                Vec3::new(radius * a.cos(), radius * a.sin(), 0.1)
            })
            .collect();
        let lights: Vec<LightBounds> = centres
            .iter()
            .enumerate()
            .map(|(i, &c)| {
                LightBounds::still(
                    c - Vec3::splat(half),
                    c + Vec3::splat(half),
                    1.0 + 0.5 * (i as f32 * 0.37).sin(),
                    Vec3::Z,
                    -1.0,
                )
            })
            .collect();
        let tree = LightTree::new(&lights);
        let n = Vec3::Z;
        for p in [
            Vec3::new(0.9, 0.0, 0.0),
            Vec3::new(0.0, -1.05, 0.0),
            Vec3::new(0.6, 0.6, 0.0),
            Vec3::new(0.1, 0.2, 0.0),
        ] {
            // What each segment sends to the wall point: power · cos at the wall / distance².
            let f: Vec<f64> = lights
                .iter()
                .zip(&centres)
                .map(|(e, &c)| {
                    let d = c - p;
                    (e.power * d.dot(n).max(0.0) / d.length().powi(3)) as f64
                })
                .collect();
            let tree_moment =
                relative_second_moment(&f, |i| tree.pmf(i, p, Some(n), 0.0, None) as f64);
            let total_power: f64 = lights.iter().map(|e| e.power as f64).sum();
            let power_moment = relative_second_moment(&f, |i| lights[i].power as f64 / total_power);
            // Beside the ring, choosing by power alone has several times the variance; the tree
            // stays within a small factor of the ideal pmf everywhere.
            assert!(tree_moment < 1.4, "{p}: tree {tree_moment}");
            let near = (p.truncate().length() - radius).abs() < 0.2;
            if near {
                assert!(
                    power_moment > 5.0 * tree_moment,
                    "{p}: power {power_moment}, tree {tree_moment}"
                );
            }
        }
    }

    #[test]
    fn a_path_passes_its_three_points_and_follows_uniform_acceleration() {
        let motion = |tau: f32| {
            Vec3::new(1.0, -2.0, 0.5) + tau * Vec3::new(0.3, 4.0, -1.0) + tau * tau * Vec3::Y
        };
        let path = Path::through([0.0, 0.5, 1.0].map(motion));
        for tau in [0.0, 0.25, 0.5, 0.8, 1.0] {
            assert!(path.at(tau).distance(motion(tau)) < 1e-5, "{tau}");
        }
        let mean = Path::mean([(1.0, path), (3.0, Path::still(Vec3::ONE))].into_iter()).unwrap();
        assert!(mean.at(0.7).distance(0.25 * motion(0.7) + 0.75 * Vec3::ONE) < 1e-5);
        assert_eq!(Path::mean(std::iter::empty()), None);
    }

    #[test]
    fn a_point_beside_a_spinning_ring_picks_the_strands_near_it_at_its_time() {
        // 2000 segments on a ring of radius 0.9 in the plane z = 0.1, half turning a twentieth
        // of a circle one way over the time range and half the other way (strands 30 cm
        // apart at the ends of the range that pass each other halfway); a wall at z = 0.
        let count = 2000;
        let radius = 0.9f32;
        let turn = std::f32::consts::TAU / 20.0;
        let place = |i: usize, tau: f32| {
            let spin = if i.is_multiple_of(2) { 1.0 } else { -1.0 };
            let a = std::f32::consts::TAU * i as f32 / count as f32 + spin * turn * (tau - 0.5);
            Vec3::new(radius * a.cos(), radius * a.sin(), 0.1)
        };
        let half = 0.004;
        let steps = 16;
        let moving: Vec<LightBounds> = (0..count)
            .map(|i| {
                let (min, max) = (0..=steps).fold(
                    (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                    |(lo, hi), k| {
                        let c = place(i, k as f32 / steps as f32);
                        (lo.min(c - half), hi.max(c + half))
                    },
                );
                LightBounds {
                    min,
                    max,
                    centre: Path::through([0.0, 0.5, 1.0].map(|tau| place(i, tau))),
                    reach: half * 3f32.sqrt(),
                    power: 1.0 + 0.5 * (i as f32 * 0.37).sin(),
                    axis: Vec3::Z,
                    cos_spread: -1.0,
                }
            })
            .collect();
        // The same emitters known only by their boxes over the whole range.
        let swept: Vec<LightBounds> = moving
            .iter()
            .map(|e| LightBounds::still(e.min, e.max, e.power, e.axis, e.cos_spread))
            .collect();
        let (tree, swept_tree) = (LightTree::new(&moving), LightTree::new(&swept));
        let n = Vec3::Z;
        for p in [
            Vec3::new(0.9, 0.0, 0.0),
            Vec3::new(0.0, -1.05, 0.0),
            Vec3::new(0.6, 0.6, 0.0),
        ] {
            for tau in [0.0, 0.3, 0.5, 1.0] {
                let f: Vec<f64> = moving
                    .iter()
                    .enumerate()
                    .map(|(i, e)| {
                        let d = place(i, tau) - p;
                        (e.power * d.dot(n).max(0.0) / d.length().powi(3)) as f64
                    })
                    .collect();
                let moment =
                    relative_second_moment(&f, |i| tree.pmf(i, p, Some(n), tau, None) as f64);
                let swept_moment =
                    relative_second_moment(&f, |i| swept_tree.pmf(i, p, Some(n), tau, None) as f64);
                // Within a small factor of the ideal pmf at every time; at the ends of the range,
                // where the strands are farthest from the middle of their boxes, the boxes alone
                // do markedly worse (1.5 to 1.8 times the second moment here).
                assert!(moment < 2.0, "{p} at {tau}: {moment}");
                if tau == 0.0 || tau == 1.0 {
                    assert!(
                        swept_moment > 1.4 * moment,
                        "{p} at {tau}: {moment}, boxes alone {swept_moment}"
                    );
                }
            }
        }
    }
}
