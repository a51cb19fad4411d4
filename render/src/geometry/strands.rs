//! The rings' strands as render geometry: round curve segments ([`RoundCone`]) in each
//! opening's local frame, where fx baked them, under one BVH per ring.
//!
//! Two motions combine. Each vertex follows its baked quadratic P + vΔ + ½aΔ² (Δ from the frame's
//! time), which carries the curved blur of the spinning strands; the whole ring follows the
//! opening's here frame P_H(t). A ray is taken into the ring's local frame at its own time
//! (one similarity, direction not renormalised so ray parameters stay in world units) and meets
//! the segments as they are at that time. A moving ring's tree bounds them at the boundaries of
//! a few time slices and moves its boxes linearly between (see [`Tree`]); bounds over every
//! time a ray can have come in closed form from each vertex's quadratic. A ring whose vertices
//! do not move (no velocity and acceleration, or an instant of time) stores positions only and
//! evaluates nothing per test; a ring whose opening does not move keeps its frame
//! precomputed.

use super::build::wide_bvh;
use super::instance::{box_corners, swept_bounds};
use super::moving_bvh::{expected_cost, refit_slice};
use super::round_cone::RoundCone;
use super::wide_bvh::{
    BoxRay, Fixed, Swept, SweptNode, any_hit, closest_hit, worth_fetching_ahead,
};
use crate::geometry::ray::Ray;
use crate::platform::huge_pages;
use glam::{DAffine3, Vec3};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::node::CwBvhNode;
use rayon::prelude::*;
use rift_fx::rig::Similarity;
use rift_fx::ring::RingCurves;
use rift_fx::ring::curves::moved;

/// Times sampled across the ray time interval when bounding a segment under a moving frame.
const FRAME_BOUND_STEPS: usize = 8;
/// Most time slices a moving ring's segments are bounded over.
const MAX_TIME_SLICES: usize = 16;

/// How far a slice's boxes may stray from the segments, as a share of their mean length: a
/// box moves linearly over its slice while a vertex follows its quadratic, which leaves the
/// straight path by up to |a|·L²/8 over a slice of length L, and the boxes are widened by that.
const CHORD_SHARE: f32 = 0.125;

/// The shares of each segment's turn over the rays' times by which a moving ring's layout is
/// built with the segment lifted along the ring's axis (see [`Segment::grouping_box`]): each
/// is tried, and the layout whose slices the surface area heuristic expects cheapest is kept.
/// Too little lift groups strands that drift apart; too much splits a band by speed into layers
/// a ray crosses one by one. The bench's spinning ring (100k segments) visits 70, 31, 36 and 39
/// nodes a closest-hit ray at these shares, and the heuristic ranks them alike.
const LIFT_SCALES: [f32; 4] = [0.125, 0.25, 0.5, 1.0];

/// One segment in its ring's local frame: each end's position at the frame's time, velocity,
/// acceleration and radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub p: [Vec3; 2],
    pub v: [Vec3; 2],
    pub a: [Vec3; 2],
    pub radius: [f32; 2],
}

impl Segment {
    /// The segment `delta` seconds after the frame's time, in the ring's local frame.
    #[inline]
    pub fn at(&self, delta: f32, moving: bool) -> RoundCone {
        let place = |i: usize| {
            if moving {
                moved(self.p[i], self.v[i], self.a[i], delta)
            } else {
                self.p[i]
            }
        };
        RoundCone {
            a: place(0),
            b: place(1),
            radius_a: self.radius[0],
            radius_b: self.radius[1],
        }
    }

    /// Local bounds at Δ = `delta`, widened on every side by each vertex's chord deviation
    /// over a slice of `slice_length` seconds (see [`CHORD_SHARE`]) and for rounding.
    fn bounds_at(&self, delta: f32, slice_length: f32, moving: bool) -> Aabb {
        let at = self.at(delta, moving);
        let reach = |i: usize, p: Vec3, radius: f32| {
            let chord = self.a[i].abs() * (slice_length * slice_length / 8.0);
            (
                p - chord - Vec3::splat(radius),
                p + chord + Vec3::splat(radius),
            )
        };
        let (lo_a, hi_a) = reach(0, at.a, at.radius_a);
        let (lo_b, hi_b) = reach(1, at.b, at.radius_b);
        let (lo, hi) = widened_for_rounding(lo_a.min(lo_b), hi_a.max(hi_b));
        Aabb::new(lo.into(), hi.into())
    }

    /// Where the BVH builder sees the segment over Δ in `window`: its box at the middle, moved
    /// along the ring's axis (local Z, across the thin ring) by `lift` times how far it turns
    /// around that axis over the window. Neighbours that turn at different speeds
    /// (counter-rotating strands, which cross one another all the time) then stand apart, and
    /// a node groups segments that stay together over the window, so its boxes at the window's
    /// two ends stay small.
    fn grouping_box(&self, window: [f32; 2], lift: f32) -> Aabb {
        let middle = 0.5 * (window[0] + window[1]);
        let at = self.at(middle, true);
        let turn = |i: usize, p: Vec3| {
            let v = self.v[i] + self.a[i] * middle;
            let round = p.truncate().length();
            if round > 0.0 {
                p.truncate().perp_dot(v.truncate()) / round
            } else {
                0.0
            }
        };
        let turned = 0.5 * (turn(0, at.a) + turn(1, at.b)) * (window[1] - window[0]);
        let (lo, hi) = at.bounds();
        let shift = Vec3::Z * (lift * turned);
        Aabb::new((lo + shift).into(), (hi + shift).into())
    }

    /// Local bounds over Δ in `deltas`: each end's quadratic per axis reaches its extremes at
    /// the interval's ends or where its derivative vanishes.
    fn bounds(&self, deltas: [f32; 2], moving: bool) -> (Vec3, Vec3) {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for i in 0..2 {
            let r = Vec3::splat(self.radius[i]);
            let mut include = |d: f32| {
                let p = if moving {
                    moved(self.p[i], self.v[i], self.a[i], d)
                } else {
                    self.p[i]
                };
                lo = lo.min(p - r);
                hi = hi.max(p + r);
            };
            include(deltas[0]);
            include(deltas[1]);
            if moving {
                for axis in 0..3 {
                    let (v, a) = (self.v[i][axis], self.a[i][axis]);
                    if a != 0.0 {
                        let d = -v / a;
                        if d > deltas[0] && d < deltas[1] {
                            let p = self.p[i][axis] + d * (v + 0.5 * d * a);
                            lo[axis] = lo[axis].min(p - self.radius[i]);
                            hi[axis] = hi[axis].max(p + self.radius[i]);
                        }
                    }
                }
            }
        }
        widened_for_rounding(lo, hi)
    }
}

/// The box `lo`..`hi` widened by a few ulps of its largest coordinate, so the rounding of a
/// segment's evaluation at a ray's time stays inside it.
fn widened_for_rounding(lo: Vec3, hi: Vec3) -> (Vec3, Vec3) {
    let pad = Vec3::splat((lo.abs().max(hi.abs())).max_element() * 4.0 * f32::EPSILON);
    (lo - pad, hi + pad)
}

/// Where a ring sits: its opening's here frame, fixed or evaluated at each ray's time.
// One a ring: boxing the fixed frame would cost every ray test a pointer chase for nothing.
#[allow(clippy::large_enum_variant)]
pub enum RingFrame {
    /// Made by [`RingFrame::fixed`].
    Fixed { to_world: Mapped, to_local: Mapped },
    /// P_H(t).
    Moving(Box<dyn Fn(f64) -> Similarity + Send + Sync>),
}

/// A similarity with its matrix and offset, which map points and vectors in fewer operations
/// than the quaternion's rotation: every ray a ring is tested against, and every point light
/// sampling draws on a strand, goes through one (the rotation took 4% of a ring's shadow-ray
/// test on the showcase).
#[derive(Clone, Copy)]
pub struct Mapped {
    pub similarity: Similarity,
    affine: DAffine3,
}

impl Mapped {
    fn new(similarity: Similarity) -> Self {
        let affine = similarity.to_affine();
        Self { similarity, affine }
    }

    #[inline]
    fn point(&self, p: Vec3) -> Vec3 {
        self.affine.transform_point3(p.as_dvec3()).as_vec3()
    }

    #[inline]
    fn vector(&self, v: Vec3) -> Vec3 {
        self.affine.transform_vector3(v.as_dvec3()).as_vec3()
    }
}

impl RingFrame {
    /// A frame that stays at `to_world`.
    pub fn fixed(to_world: Similarity) -> Self {
        RingFrame::Fixed {
            to_world: Mapped::new(to_world),
            to_local: Mapped::new(to_world.inverse()),
        }
    }

    /// Local to world at `time`.
    #[inline]
    pub fn to_world(&self, time: f64) -> Similarity {
        match self {
            RingFrame::Fixed { to_world, .. } => to_world.similarity,
            RingFrame::Moving(at) => at(time),
        }
    }

    /// Runs `map` with local to world at `time` (borrowed where the frame is fixed: a copy of
    /// the matrix cost as much as using it).
    #[inline]
    fn with_to_world<R>(&self, time: f64, map: impl FnOnce(&Mapped) -> R) -> R {
        match self {
            RingFrame::Fixed { to_world, .. } => map(to_world),
            RingFrame::Moving(at) => map(&Mapped::new(at(time))),
        }
    }

    /// Runs `map` with world to local at `time` (borrowed where the frame is fixed).
    #[inline]
    fn with_to_local<R>(&self, time: f64, map: impl FnOnce(&Mapped) -> R) -> R {
        match self {
            RingFrame::Fixed { to_local, .. } => map(to_local),
            RingFrame::Moving(at) => map(&Mapped::new(at(time).inverse())),
        }
    }
}

/// One opening's strands.
pub struct Ring {
    frame: RingFrame,
    /// Seconds the baked positions belong to (Δ = ray time − this).
    frame_time: f64,
    /// False when no vertex moves over the rays' times: positions are used as stored.
    moving: bool,
    /// Δ at the start of the rays' times, and slices per second of Δ.
    slice_start: f32,
    slices_per_second: f32,
    /// The segments' BVH (see [`Tree`]).
    tree: Tree,
    /// Scene-wide index of the ring's first segment; its segments follow it in its tree's leaf
    /// order.
    first: u32,
    /// World bounds over every time a ray can have.
    pub bounds: Aabb,
}

/// A ring's segments under one BVH for every time a ray can have.
///
/// A moving ring's rays' times are cut into equal slices, and the tree's nodes are kept once
/// for each slice, refit to where the segments are at its start and at its end: a ray in the
/// slice sees the boxes moved linearly between the two (see [`super::moving_bvh`]), about as
/// tight as a still ring's, where boxes over a whole slice grew by the motion (a fast strand
/// sweeps many times its own length in a shutter). Every slice shares the one layout, so the
/// scene keeps the ring's segments in leaf order and the leaves read them with no index to
/// follow first (a hit's slot is its segment).
struct Tree {
    /// A still ring's nodes (none for a moving one).
    nodes: Vec<CwBvhNode>,
    /// A moving ring's nodes for each time slice, the first from the rays' earliest time.
    slices: Vec<Vec<SweptNode>>,
    /// Per segment of the ring in strand order, its place among the ring's segments (which
    /// follow the leaves).
    slot_of: Vec<u32>,
}

impl Tree {
    /// The bytes of nodes a query reads at random (the leaves' segments besides).
    fn node_bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice())
            + self
                .slices
                .iter()
                .map(|nodes| std::mem::size_of_val(nodes.as_slice()))
                .sum::<usize>()
    }
}

/// A ray meeting a strand.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StrandHit {
    /// Ray parameter in world units.
    pub t: f32,
    /// Scene-wide segment index.
    pub segment: u32,
    /// Position along the segment, 0 to 1 (for interpolating per-vertex data).
    pub s: f32,
    /// Unit world-space outward normal.
    pub normal: Vec3,
}

/// Every ring of a scene, with per-segment data for shading and light sampling.
#[derive(Default)]
pub struct Strands {
    pub rings: Vec<Ring>,
    /// Every segment, ring after ring, each ring's in its tree's leaf order
    /// ([`Self::strand_order`] gives them along their strands).
    pub segments: Vec<Segment>,
    /// The ring of each segment.
    pub segment_ring: Vec<u32>,
    /// Emitted radiance at each end of each segment (Cd · intensity · scale).
    pub radiance: Vec<[Vec3; 2]>,
    /// Whether queries fetch nodes and leaves ahead: decided by the nodes of every ring's
    /// every time slice and the segments together, since rays at random times and places
    /// read them all.
    fetch_ahead: bool,
}

impl Strands {
    /// Adds the strands of `curves` (closed polylines in the opening's local frame) placed by
    /// `frame`, baked at `frame_time`; rays have times in `times`; `intensity` scales the
    /// emission. Segments of zero length are skipped.
    pub fn add_ring(
        &mut self,
        curves: &RingCurves,
        frame: RingFrame,
        frame_time: f64,
        times: [f64; 2],
        intensity: f32,
    ) {
        let deltas = [
            (times[0] - frame_time) as f32,
            (times[1] - frame_time) as f32,
        ];
        let moving = deltas[0] != deltas[1]
            && curves
                .velocities
                .iter()
                .chain(&curves.accelerations)
                .any(|v| *v != Vec3::ZERO);
        let first = self.segments.len() as u32;
        let ring_index = self.rings.len() as u32;
        let (mut local, mut radiance) = (Vec::new(), Vec::new());
        for (i, j) in curves.segments() {
            let mut segment = Segment {
                p: [curves.points[i], curves.points[j]],
                v: [curves.velocities[i], curves.velocities[j]],
                a: [curves.accelerations[i], curves.accelerations[j]],
                radius: [0.5 * curves.widths[i], 0.5 * curves.widths[j]],
            };
            if !moving {
                // Positions at the one time rays have (the frame's own when no vertex moves).
                let at = segment.at(deltas[0], deltas[0] != 0.0);
                segment.p = [at.a, at.b];
            }
            if segment.p[0] == segment.p[1] && !moving {
                continue;
            }
            local.push(segment);
            let emitted = |i: usize| curves.colors[i] * (curves.intensities[i] * intensity);
            radiance.push([emitted(i), emitted(j)]);
        }
        let slice_count = if moving {
            time_slices(&local, deltas)
        } else {
            1
        };
        let slice_length = (deltas[1] - deltas[0]) / slice_count as f32;
        let (tree, leaf_order, all) = build_tree(&local, deltas, slice_count, moving);
        let bounds = if local.is_empty() {
            Aabb::empty()
        } else {
            let corners = box_corners(all.min.into(), all.max.into());
            swept_bounds(
                &corners,
                |t| frame.to_world(t),
                &[],
                times,
                FRAME_BOUND_STEPS,
            )
        };
        // Scene-wide, the ring's segments follow its tree's leaf order.
        let mut segments = huge_pages::with_capacity(self.segments.len() + local.len());
        segments.append(&mut self.segments);
        segments.extend(leaf_order.iter().map(|&i| local[i as usize]));
        self.segments = segments;
        self.radiance
            .extend(leaf_order.iter().map(|&i| radiance[i as usize]));
        self.segment_ring
            .extend(std::iter::repeat_n(ring_index, leaf_order.len()));
        self.rings.push(Ring {
            frame,
            frame_time,
            moving,
            slice_start: deltas[0],
            slices_per_second: if slice_length > 0.0 {
                1.0 / slice_length
            } else {
                0.0
            },
            tree,
            first,
            bounds,
        });
        let nodes: usize = self.rings.iter().map(|r| r.tree.node_bytes()).sum();
        self.fetch_ahead = worth_fetching_ahead(nodes + std::mem::size_of_val(&self.segments[..]));
    }

    /// True when there are no segments.
    pub fn is_empty(&self) -> bool {
        self.segments.is_empty()
    }

    /// The first strand along `ray` (t in (0, t_max)), among the rings `admit(ring)` accepts.
    pub fn intersect(&self, ray: &Ray, admit: impl Fn(usize) -> bool) -> Option<StrandHit> {
        debug_assert!(ray.t_min == 0.0);
        let mut best: Option<StrandHit> = None;
        for (index, ring) in self.rings.iter().enumerate() {
            let limit = best.map_or(ray.t_max, |b| b.t);
            if !admit(index) || !meets(&ring.bounds, ray.origin, ray.dir, limit) {
                continue;
            }
            let (leaves, ahead) = (self.segments_of(ring), self.fetch_ahead);
            if let Some(hit) = ring.intersect(leaves, ray.origin, ray.dir, limit, ray.time, ahead) {
                best = Some(hit);
            }
        }
        best
    }

    /// True when a strand of an admitted ring lies along `ray` (t in (0, t_max)), other than
    /// segment `except` (scene-wide index).
    pub fn occluded(&self, ray: &Ray, except: Option<u32>, admit: impl Fn(usize) -> bool) -> bool {
        debug_assert!(ray.t_min == 0.0);
        self.rings.iter().enumerate().any(|(index, ring)| {
            admit(index)
                && meets(&ring.bounds, ray.origin, ray.dir, ray.t_max)
                && ring.occluded(
                    self.segments_of(ring),
                    ray.origin,
                    ray.dir,
                    ray.t_max,
                    ray.time,
                    except,
                    self.fetch_ahead,
                )
        })
    }

    /// The segments of `ring`, in its tree's leaf order.
    #[inline]
    fn segments_of(&self, ring: &Ring) -> &[Segment] {
        let first = ring.first as usize;
        &self.segments[first..first + ring.tree.slot_of.len()]
    }

    /// Every segment's scene-wide index, ring after ring, each ring's in strand order (each
    /// segment starting where the one before ends, within a strand).
    pub fn strand_order(&self) -> impl Iterator<Item = u32> + '_ {
        self.rings
            .iter()
            .flat_map(|ring| ring.tree.slot_of.iter().map(move |&slot| ring.first + slot))
    }

    /// Segment `i` in world space at `time`.
    pub fn world_segment(&self, i: u32, time: f64) -> RoundCone {
        let ring = &self.rings[self.segment_ring[i as usize] as usize];
        let local = self.segments[i as usize].at(ring.delta(time), ring.moving);
        ring.frame.with_to_world(time, |to_world| {
            let scale = to_world.similarity.scale as f32;
            RoundCone {
                a: to_world.point(local.a),
                b: to_world.point(local.b),
                radius_a: local.radius_a * scale,
                radius_b: local.radius_b * scale,
            }
        })
    }

    /// Asks the cache for what light sampling reads of segment `i`.
    #[inline(always)]
    pub fn prefetch(&self, i: usize) {
        use crate::platform::prefetch::prefetch;
        if let (Some(segment), Some(ring), Some(radiance)) = (
            self.segments.get(i..=i),
            self.segment_ring.get(i..=i),
            self.radiance.get(i..=i),
        ) {
            prefetch(segment);
            prefetch(ring);
            prefetch(radiance);
        }
    }

    /// World bounds of segment `i` over every time a ray can have.
    pub fn segment_bounds(&self, i: u32, times: [f64; 2]) -> Aabb {
        let ring = &self.rings[self.segment_ring[i as usize] as usize];
        let deltas = [ring.delta(times[0]), ring.delta(times[1])];
        let (lo, hi) = self.segments[i as usize].bounds(deltas, ring.moving);
        let corners = box_corners(lo, hi);
        match &ring.frame {
            RingFrame::Fixed { to_world, .. } => {
                let mut b = Aabb::empty();
                for c in corners {
                    b.extend(to_world.point(c).into());
                }
                b
            }
            RingFrame::Moving(_) => swept_bounds(
                &corners,
                |t| ring.frame.to_world(t),
                &[],
                times,
                FRAME_BOUND_STEPS,
            ),
        }
    }

    /// Radiance emitted at position `s` along segment `i`.
    #[inline]
    pub fn radiance(&self, i: u32, s: f32) -> Vec3 {
        let [a, b] = self.radiance[i as usize];
        a.lerp(b, s)
    }
}

impl Ring {
    #[inline]
    fn delta(&self, time: f64) -> f32 {
        (time - self.frame_time) as f32
    }

    /// The time slice holding Δ = `delta` (a moving ring's: still ones have none), and how
    /// far through it Δ lies (0 to 1).
    #[inline]
    fn slice(&self, delta: f32) -> (usize, f32) {
        let slices = (delta - self.slice_start) * self.slices_per_second;
        let last = self.tree.slices.len().saturating_sub(1);
        let k = (slices as usize).min(last);
        (k, (slices - k as f32).clamp(0.0, 1.0))
    }

    /// The ray in the ring's local frame at `time`; parameters stay in world units.
    #[inline]
    fn local_ray(&self, origin: Vec3, dir: Vec3, time: f64) -> (Vec3, Vec3, Similarity) {
        self.frame.with_to_local(time, |to_local| {
            (
                to_local.point(origin),
                to_local.vector(dir),
                to_local.similarity,
            )
        })
    }

    /// The first of `leaves` (the ring's segments) along `origin + t·dir`, t in (0, t_max), at
    /// `time` (fetching ahead as `fetch_ahead` says).
    fn intersect(
        &self,
        leaves: &[Segment],
        origin: Vec3,
        dir: Vec3,
        t_max: f32,
        time: f64,
        fetch_ahead: bool,
    ) -> Option<StrandHit> {
        let delta = self.delta(time);
        let (o, d, to_local) = self.local_ray(origin, dir, time);
        let ray = BoxRay::new(o, d);
        let mut found = None;
        let test = |slot: usize, range: f32| {
            let h = leaves[slot]
                .at(delta, self.moving)
                .intersect(o, d, 0.0, range)?;
            found = Some((h, slot));
            Some(h.t)
        };
        if self.moving {
            let (k, at) = self.slice(delta);
            let nodes = self.tree.slices.get(k)?;
            closest_hit(nodes, &Swept { at }, &ray, t_max, leaves, fetch_ahead, test);
        } else {
            let nodes = &self.tree.nodes;
            closest_hit(nodes, &Fixed, &ray, t_max, leaves, fetch_ahead, test);
        }
        let (h, slot) = found?;
        // Normals are covectors: under a similarity the inverse's rotation maps them back.
        let normal = to_local
            .inverse()
            .transform_direction(h.normal.as_dvec3())
            .normalize()
            .as_vec3();
        Some(StrandHit {
            t: h.t,
            segment: self.first + slot as u32,
            s: h.s,
            normal,
        })
    }

    /// True when one of `leaves` (the ring's segments) other than `except` (scene-wide index)
    /// lies along `origin + t·dir`, t in (0, t_max), at `time` (fetching ahead as
    /// `fetch_ahead` says).
    #[allow(clippy::too_many_arguments)]
    fn occluded(
        &self,
        leaves: &[Segment],
        origin: Vec3,
        dir: Vec3,
        t_max: f32,
        time: f64,
        except: Option<u32>,
        fetch_ahead: bool,
    ) -> bool {
        let delta = self.delta(time);
        let (o, d, _) = self.local_ray(origin, dir, time);
        let ray = BoxRay::new(o, d);
        let skip = except
            .and_then(|e| e.checked_sub(self.first))
            .map_or(usize::MAX, |slot| slot as usize);
        let test = |slot: usize| {
            slot != skip
                && leaves[slot]
                    .at(delta, self.moving)
                    .occludes(o, d, 0.0, t_max)
        };
        if self.moving {
            let (k, at) = self.slice(delta);
            let Some(nodes) = self.tree.slices.get(k) else {
                return false;
            };
            any_hit(nodes, &Swept { at }, &ray, t_max, leaves, fetch_ahead, test)
        } else {
            let nodes = &self.tree.nodes;
            any_hit(nodes, &Fixed, &ray, t_max, leaves, fetch_ahead, test)
        }
    }
}

/// Time slices for `segments` moving over Δ in `deltas`: enough that no vertex strays from the
/// straight path its boxes take across a slice by more than [`CHORD_SHARE`] of the mean
/// segment length (between 1 and [`MAX_TIME_SLICES`]).
fn time_slices(segments: &[Segment], deltas: [f32; 2]) -> usize {
    if segments.is_empty() {
        return 1;
    }
    let (mut bend, mut length) = (0.0f32, 0.0f32);
    for s in segments {
        bend = bend.max(s.a[0].abs().max(s.a[1].abs()).max_element());
        length += s.p[0].distance(s.p[1]);
    }
    let mean = length / segments.len() as f32;
    if !(mean > 0.0 && bend > 0.0) {
        return 1;
    }
    // |a|·L²/8 ≤ CHORD_SHARE · mean.
    let longest = (8.0 * CHORD_SHARE * mean / bend).sqrt();
    (((deltas[1] - deltas[0]) / longest).ceil() as usize).clamp(1, MAX_TIME_SLICES)
}

/// The [`Tree`] of `segments` for Δ in `deltas` cut into `slices` (a moving ring's), the order
/// its leaves take them in (indices into `segments`), and the bounds of all of them over it.
/// The layout comes from obvhs' build over each segment's bounds, still, or where the builder
/// sees it moving (see [`build_moving`]).
fn build_tree(
    segments: &[Segment],
    deltas: [f32; 2],
    slices: usize,
    moving: bool,
) -> (Tree, Vec<u32>, Aabb) {
    let swept: Vec<Aabb> = segments
        .iter()
        .map(|s| {
            let (lo, hi) = s.bounds(deltas, moving);
            Aabb::new(lo.into(), hi.into())
        })
        .collect();
    let all = swept.iter().fold(Aabb::empty(), |all, b| all.union(b));
    let (bvh, slice_nodes) = if moving && !segments.is_empty() {
        build_moving(segments, deltas, slices, &all)
    } else {
        let bvh = wide_bvh(&swept, BvhBuildParams::medium_build());
        (bvh, Vec::new())
    };
    let nodes = if moving {
        Vec::new()
    } else {
        huge_pages::adopt(bvh.nodes)
    };
    let leaf_order = bvh.primitive_indices;
    let mut slot_of = vec![0u32; segments.len()];
    for (slot, &i) in leaf_order.iter().enumerate() {
        slot_of[i as usize] = slot as u32;
    }
    let tree = Tree {
        nodes,
        slices: slice_nodes,
        slot_of,
    };
    (tree, leaf_order, all)
}

/// A moving ring's layout and its nodes for each of `slices` time slices over Δ in `deltas`:
/// built over the segments' grouping boxes with each of [`LIFT_SCALES`] (in parallel), each
/// refit to every slice, and the one [`expected_cost`] finds cheapest over `all` (the bounds
/// of every segment over the slices) kept; the first of equals. Candidates are compared as
/// they finish, so no more than a few are held at once.
fn build_moving(
    segments: &[Segment],
    deltas: [f32; 2],
    slices: usize,
    all: &Aabb,
) -> (CwBvh, Vec<Vec<SweptNode>>) {
    let length = (deltas[1] - deltas[0]) / slices as f32;
    let boundaries: Vec<Vec<Aabb>> = (0..=slices)
        .map(|k| {
            let delta = if k == slices {
                deltas[1]
            } else {
                deltas[0] + length * k as f32
            };
            segments
                .iter()
                .map(|s| s.bounds_at(delta, length, true))
                .collect()
        })
        .collect();
    let (_, bvh, nodes) = LIFT_SCALES
        .par_iter()
        .map(|&lift| {
            let grouping: Vec<Aabb> = segments
                .iter()
                .map(|s| s.grouping_box(deltas, lift))
                .collect();
            let bvh = wide_bvh(&grouping, BvhBuildParams::medium_build());
            let nodes: Vec<Vec<SweptNode>> = boundaries
                .windows(2)
                .map(|ends| refit_slice(&bvh, &ends[0], &ends[1]))
                .collect();
            let cost: f64 = nodes.iter().map(|n| expected_cost(n, all)).sum();
            (cost, bvh, nodes)
        })
        .reduce_with(|first, second| if second.0 < first.0 { second } else { first })
        .expect("LIFT_SCALES is not empty");
    (bvh, nodes.into_iter().map(huge_pages::adopt).collect())
}

/// True when `origin + t·dir`, t in [0, t_max], meets `bounds`.
#[inline]
fn meets(bounds: &Aabb, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
    BoxRay::new(origin, dir)
        .enters(bounds.min.into(), bounds.max.into(), t_max)
        .is_some()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DQuat, DVec3};
    use std::f32::consts::TAU;

    /// A ring of `strands` circles spinning about +Z at `omega` rad/s, baked as fx bakes them:
    /// velocity ω×p, acceleration ω×(ω×p).
    pub(crate) fn spinning_ring(strands: usize, vertices: usize, omega: f32) -> RingCurves {
        let mut c = RingCurves {
            opening: "a".into(),
            ..Default::default()
        };
        let w = Vec3::Z * omega;
        for s in 0..strands {
            let radius = 1.0 + 0.02 * s as f32;
            c.vertex_counts.push(vertices as u32);
            c.directions.push(1);
            for k in 0..vertices {
                let u = TAU * k as f32 / vertices as f32 + s as f32;
                let p = Vec3::new(radius * u.cos(), radius * u.sin(), 0.01 * (3.0 * u).sin());
                c.points.push(p);
                c.velocities.push(w.cross(p));
                c.accelerations.push(w.cross(w.cross(p)));
                c.widths.push(0.01 + 0.004 * (k % 3) as f32);
                c.colors.push(Vec3::new(1.0, 0.5, 0.25));
                c.intensities.push(2.0);
            }
        }
        c
    }

    fn sliding_frame() -> RingFrame {
        RingFrame::Moving(Box::new(|t| {
            Similarity::new(
                DQuat::from_rotation_y(0.3 + t),
                DVec3::new(2.0 + 3.0 * t, 1.0, -4.0),
                1.5,
            )
        }))
    }

    fn brute_force(strands: &Strands, o: Vec3, d: Vec3, time: f64) -> Option<(f32, u32)> {
        (0..strands.segments.len() as u32)
            .filter_map(|i| {
                strands
                    .world_segment(i, time)
                    .intersect(o, d, 0.0, f32::INFINITY)
                    .map(|h| (h.t, i))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0))
    }

    /// Ray `k` of a sequence aimed at points near `ring` (of unit radius in its frame), so
    /// many graze strands: (origin, unit direction, time in `times`).
    fn aimed_ray(ring: &Ring, times: [f64; 2], k: usize) -> (Vec3, Vec3, f64) {
        let f = k as f32;
        let time = times[0] + (times[1] - times[0]) * ((f * 0.618).fract() as f64);
        let frame = ring.frame.to_world(time);
        let angle = f * 2.39;
        let target = Vec3::new(angle.cos(), angle.sin(), 0.0) * (1.0 + 0.12 * (f * 0.77).sin());
        let target = frame.transform_point(target.as_dvec3()).as_vec3();
        let origin =
            target + Vec3::new((f * 1.3).sin(), (f * 0.7).cos(), (f * 0.31).sin() + 0.2) * 3.0;
        (origin, (target - origin).normalize(), time)
    }

    /// `ring` with every other strand spinning the other way (velocities turned round; the
    /// centripetal accelerations stay).
    fn counter_rotating(mut ring: RingCurves) -> RingCurves {
        let mut start = 0;
        for (s, &count) in ring.vertex_counts.iter().enumerate() {
            let end = start + count as usize;
            if s % 2 == 1 {
                ring.velocities[start..end]
                    .iter_mut()
                    .for_each(|v| *v = -*v);
            }
            start = end;
        }
        ring
    }

    #[test]
    fn the_bvh_finds_what_testing_every_segment_at_the_ray_time_finds() {
        // A ring spinning slowly under a moving frame (two time slices), and strands crossing
        // one another fast enough to need the most slices.
        the_bvh_finds_what_testing_every_segment_finds(spinning_ring(6, 64, 2.0), 2);
        let fast = counter_rotating(spinning_ring(6, 64, 40.0));
        the_bvh_finds_what_testing_every_segment_finds(fast.clone(), MAX_TIME_SLICES);
        // And as a processor without AVX2 runs them (the swept nodes' portable slab tests).
        crate::platform::cpu::with_baseline(|| {
            the_bvh_finds_what_testing_every_segment_finds(fast, MAX_TIME_SLICES)
        });
    }

    /// Nearest hits and occlusion of rays at many times through `ring` (under the sliding
    /// frame) agree with testing every segment, its tree cut into `slices` time slices.
    fn the_bvh_finds_what_testing_every_segment_finds(ring: RingCurves, slices: usize) {
        let times = [-0.1, 0.1];
        let mut strands = Strands::default();
        strands.add_ring(&ring, sliding_frame(), 0.0, times, 1.0);
        assert!(strands.rings[0].moving);
        assert_eq!(strands.rings[0].tree.slices.len(), slices);
        let mut hits = 0;
        for k in 0..3000 {
            let (origin, dir, time) = aimed_ray(&strands.rings[0], times, k);
            let got = strands.intersect(&Ray::new(origin, dir, f32::INFINITY, time), |_| true);
            let want = brute_force(&strands, origin, dir, time);
            // Neighbours share the sphere at their joint, so a tie may go either way.
            assert_eq!(got.is_some(), want.is_some(), "ray {k}");
            if let (Some(g), Some(w)) = (got, want) {
                hits += 1;
                assert!((g.t - w.0).abs() <= 1e-5 * w.0.max(1.0), "ray {k}");
                assert!(g.normal.dot(dir) < 0.0, "ray {k}: the normal faces the ray");
                assert!(
                    strands.occluded(&Ray::new(origin, dir, g.t * 1.0001, time), None, |_| true)
                );
                assert!(!strands.occluded(
                    &Ray::new(origin, dir, g.t * 0.9999, time),
                    None,
                    |_| true
                ));
                assert!(
                    strands
                        .intersect(&Ray::new(origin, dir, f32::INFINITY, time), |_| false)
                        .is_none()
                );
            }
        }
        assert!(hits > 300, "only {hits} rays met a strand");
    }

    #[test]
    fn a_shadow_ray_skips_only_the_segment_it_names() {
        // Two rings, so the second's segments have scene-wide indices past the first's.
        let times = [-0.1, 0.1];
        let mut strands = Strands::default();
        let place = Similarity::new(DQuat::IDENTITY, DVec3::new(0.3, -0.2, 0.5), 1.0);
        let fixed = RingFrame::fixed(place);
        strands.add_ring(&spinning_ring(3, 32, 2.0), fixed, 0.0, times, 1.0);
        strands.add_ring(&spinning_ring(6, 64, 2.0), sliding_frame(), 0.0, times, 1.0);
        let count = strands.segments.len() as u32;
        let second = strands.rings[1].first;
        let (mut checked, mut freed) = (0, 0);
        for k in 0..3000 {
            let (origin, dir, time) = aimed_ray(&strands.rings[1], times, k);
            let Some((t, hit)) = brute_force(&strands, origin, dir, time) else {
                continue;
            };
            // Other segments' distances along the ray; rays where one lies within rounding of
            // the end are left out (neighbours share the sphere at their joint).
            let others: Vec<f32> = (0..count)
                .filter(|&i| i != hit)
                .filter_map(|i| {
                    let cone = strands.world_segment(i, time);
                    cone.intersect(origin, dir, 0.0, f32::INFINITY).map(|h| h.t)
                })
                .collect();
            let end = t * 1.0001;
            if others.iter().any(|&o| (o - end).abs() < 1e-3 * end) {
                continue;
            }
            let ray = Ray::new(origin, dir, end, time);
            let blocked_by_others = others.iter().any(|&o| o < end);
            assert_eq!(
                strands.occluded(&ray, Some(hit), |_| true),
                blocked_by_others,
                "ray {k} skipping segment {hit}"
            );
            let elsewhere = if hit >= second { 0 } else { count - 1 };
            assert!(strands.occluded(&ray, Some(elsewhere), |_| true), "ray {k}");
            checked += 1;
            freed += !blocked_by_others as usize;
        }
        assert!(
            checked > 300 && freed > 100,
            "{checked} rays checked, {freed} freed"
        );
    }

    #[test]
    fn bounds_hold_every_segment_at_every_time() {
        let times = [-0.05, 0.2];
        let mut strands = Strands::default();
        strands.add_ring(
            &spinning_ring(3, 24, 9.0),
            sliding_frame(),
            0.02,
            times,
            1.0,
        );
        let ring_bounds = strands.rings[0].bounds;
        for i in 0..strands.segments.len() as u32 {
            let b = strands.segment_bounds(i, times);
            for k in 0..=40 {
                let time = times[0] + (times[1] - times[0]) * k as f64 / 40.0;
                let (lo, hi) = strands.world_segment(i, time).bounds();
                for (box_, name) in [(b, "segment"), (ring_bounds, "ring")] {
                    assert!(
                        box_.contains_point(lo.into()) && box_.contains_point(hi.into()),
                        "{name} bounds miss segment {i} at {time}"
                    );
                }
            }
        }
    }

    #[test]
    fn still_strands_store_positions_only() {
        let mut curves = spinning_ring(2, 16, 0.0);
        let fixed = Similarity::new(DQuat::IDENTITY, DVec3::new(0.0, 0.0, 5.0), 1.0);
        let frame = || RingFrame::fixed(fixed);
        let mut strands = Strands::default();
        strands.add_ring(&curves, frame(), 0.0, [-0.1, 0.1], 1.0);
        assert!(!strands.rings[0].moving);
        // Spinning strands seen at one instant only are still too, baked at that instant.
        curves = spinning_ring(2, 16, 3.0);
        strands.add_ring(&curves, frame(), 0.0, [0.05, 0.05], 1.0);
        assert!(!strands.rings[1].moving);
        let mut spinning = Strands::default();
        spinning.add_ring(&curves, frame(), 0.0, [-0.1, 0.1], 1.0);
        // Segment by segment along the strands (each ring's tree orders its own).
        let first = strands.rings[1].first;
        let still = strands.strand_order().filter(|&i| i >= first);
        for (i, j) in still.zip(spinning.strand_order()) {
            let a = strands.world_segment(i, 0.05);
            let b = spinning.world_segment(j, 0.05);
            assert!(a.a.distance(b.a) < 1e-6 && a.b.distance(b.b) < 1e-6);
        }
        assert_eq!(spinning.strand_order().count(), spinning.segments.len());
        // Emission is Cd · intensity · scale, interpolated along the segment.
        assert_eq!(strands.radiance(0, 0.5), Vec3::new(2.0, 1.0, 0.5));
    }
}
