//! Emitters and how next-event estimation picks them. Emitters are emissive triangles, the
//! rings' strand segments and the lights a lighter places ([`ShapeLight`]); a light BVH
//! ([`LightTree`]) picks one in proportion to what it can send to the shading point (or, for
//! comparison, an alias table in proportion to power alone), then a point on it: uniform on a
//! triangle; on a strand segment, uniform along its length and cosine-distributed around the
//! half of its circumference that faces the point; on a shape light, as its shape samples. The
//! sky (the environment and distant lights, [`Sky`]) is sampled by its own distribution; when it
//! and emitters both exist, the tree gives it a share of the samples at each point by its
//! estimate against the emitters' (see `EnvironmentSplit`), and selection by power gives it
//! half.

use crate::color::luminance;
use crate::geometry::{MovingInstance, RoundCone, STATIC, Strands, Triangle};
use crate::lights::guide::LightGuide;
use crate::lights::shapes::ShapeLight;
use crate::lights::sky::{Sky, SkyPart};
use crate::lights::strand_exposure;
use crate::lights::tree::{LightBounds, LightTree, Path, PerLane};
use crate::sampling::{AliasTable, uniform_triangle};
use glam::{Vec2, Vec3, Vec3A};
use std::f32::consts::PI;
use std::ops::Range;

/// How next-event estimation picks an emitter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightSelection {
    /// [`Self::Tree`], with the tree's first two choices reweighed per region of the scene by
    /// what training paths saw each branch bring there, shadow rays included
    /// ([`crate::lights::guide`]).
    #[default]
    Learned,
    /// By what each can send to the shading point (the light BVH), strand segments weighed by
    /// the root of their exposure ([`crate::lights::strand_exposure`]), and the environment against
    /// the emitters the same way; by power when the emitters are the few touching pieces of
    /// one lamp (a quad light's two triangles).
    Tree,
    /// By power alone, wherever the shading point is; the environment half the time.
    Power,
}

impl LightSelection {
    /// True for the selections that descend the light tree.
    fn by_tree(self) -> bool {
        matches!(self, Self::Learned | Self::Tree)
    }
}

/// The emitter a light sample or a hit lies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LightSource {
    /// A scene triangle.
    Triangle(u32),
    /// A strand segment.
    Strand(u32),
    /// A shape light (`[[light]]`), by its index among them.
    Shape(u32),
}

/// What a light sample took (see [`LightSampler::picked`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Picked {
    Environment,
    /// Emitter `i` (triangles first, then strand segments).
    Emitter(usize),
}

/// The point being lit, as emitter selection sees it.
#[derive(Clone, Copy, Debug)]
pub struct Receiver {
    pub p: Vec3,
    /// Unit normal on the side light can arrive from, when the surface only reflects.
    pub n: Option<Vec3>,
    /// The path's time (seconds).
    pub time: f64,
}

/// An emitter that a ray found (BSDF sampling), as the light-sampling pdf of the same light
/// needs it.
#[derive(Clone, Copy, Debug)]
pub enum Found {
    /// A point on a scene triangle, whose world area is `area_scale` times its stored area.
    Triangle {
        triangle: u32,
        area_scale: f32,
        /// Unit geometric normal there.
        normal: Vec3,
    },
    /// A point on a strand segment, at position `s` along it.
    Strand { segment: u32, s: f32, normal: Vec3 },
    /// A point on a shape light.
    Shape {
        light: u32,
        point: Vec3,
        normal: Vec3,
    },
    /// The sky, in the ray's direction.
    Environment,
}

/// One emissive triangle.
#[derive(Clone, Copy, Debug)]
pub struct Emitter {
    pub triangle: u32,
    /// Moving instance the triangle belongs to, or [`crate::geometry::STATIC`].
    pub instance: u32,
    /// Its radiance, or a textured one's mean over the triangle.
    pub radiance: Vec3,
    /// Its radiance comes from a texture, read where a sample lands.
    pub textured: bool,
    pub two_sided: bool,
    /// The triangle as stored (world space when static, else object space).
    pub vertices: Triangle,
    /// Unit normal of the stored triangle.
    pub normal: Vec3,
    /// Area as stored (object space for a moving object); sets the selection weight, while
    /// sampling uses the world area at the ray's time.
    pub area: f32,
}

/// Where a light sample lies. Its vectors are kept in 16-byte lanes, as a BSDF sample's
/// ([`crate::material::bsdf::BsdfSample`]): a sample is returned through memory from whichever
/// emitter drew it, and vectors stored as eight bytes and four were read back by loads that
/// straddled the stores and waited for both.
#[derive(Clone, Copy, Debug)]
pub enum LightPlace {
    /// A point on an emitter, with its unit geometric normal (front side).
    Point {
        point: Vec3A,
        normal: Vec3A,
        two_sided: bool,
        source: LightSource,
    },
    /// A point light: no surface; the sample's radiance is its intensity towards the point.
    Punctual { point: Vec3A, source: LightSource },
    /// A direction towards the sky, infinitely far, from its `part`; a `delta` one is a
    /// single direction (no ray finds it), whose radiance is the illuminance it gives.
    Direction {
        dir: Vec3A,
        part: SkyPart,
        delta: bool,
    },
}

/// A sampled light.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    pub place: LightPlace,
    pub radiance: Vec3A,
    /// Area-measure pdf for a point, solid-angle pdf for a direction.
    pub pdf: f32,
}

/// Picks emitters: the tree, or power-proportional.
#[derive(Clone, Debug)]
enum Picker {
    Tree,
    Power(AliasTable),
}

impl Default for Picker {
    fn default() -> Self {
        Picker::Power(AliasTable::default())
    }
}

/// All emitters of a scene. Emitter indices run over the triangles first, then the strand
/// segments in scene order, then the shape lights.
#[derive(Clone, Debug, Default)]
pub struct Lights {
    pub emitters: Vec<Emitter>,
    /// Strand segments that emit.
    strand_count: usize,
    picker: Picker,
    /// The light BVH: what the tree picker descends, and the estimate of what all emitters
    /// can send to a point whichever picker is used.
    tree: LightTree,
    /// Whether the tree's descent fetches nodes and emitters ahead: only when what it reads at
    /// random outgrows the cache (for a single area light, fetching ahead was a fifth of the
    /// pick's instructions).
    fetch_ahead: bool,
    /// Emitter index per scene triangle (u32::MAX: not an emitter).
    by_triangle: Vec<u32>,
    /// The lights a lighter placed, other than distant ones.
    pub shapes: Vec<ShapeLight>,
    /// Light from where rays escape (the environment and distant lights), if any.
    pub sky: Option<Sky>,
    /// How light sampling shares its samples between the environment and the emitters.
    environment_split: EnvironmentSplit,
    /// The times rays can have, which the tree's moving bounds span.
    times: [f64; 2],
    /// How the emitters are picked.
    selection: LightSelection,
    /// What a light sample costs, relative to one aimed at a lamp, in each lane of the tree's
    /// top two levels (the mean over its emitters, weighed as the tree weighs them).
    lane_costs: PerLane,
}

/// How light sampling shares its samples between the environment and the emitters.
#[derive(Clone, Copy, Debug, PartialEq)]
enum EnvironmentSplit {
    /// The environment's share, the same everywhere: all or nothing when only one of them
    /// exists, half when selection goes by power.
    Fixed(f32),
    /// In proportion to what each can send to the shaded point, as the tree estimates the
    /// emitters' light (π times their irradiance, unoccluded) against π times the
    /// environment's mean radiance, within [`LEAST_SPLIT_SHARE`] of either end. A fixed half
    /// spent samples on the sky beside a ring and on the ring under open sky: on
    /// `portal_pair` (320×180, two seeds) this split took the noise at 32 spp from 5.69% to
    /// 4.73%, for samples 25% dearer (more go to the rings).
    ByEstimate,
}

impl Default for EnvironmentSplit {
    fn default() -> Self {
        Self::Fixed(0.0)
    }
}

/// The least share of samples either side of the environment split keeps: both estimates
/// ignore occlusion, so neither may starve the other.
const LEAST_SPLIT_SHARE: f32 = 0.05;
/// The same once the split is learned (see [`crate::lights::guide`]), which sees occlusion.
const LEAST_LEARNED_SPLIT_SHARE: f32 = 0.01;

/// The selection bounds of one emissive triangle. One on a moving instance may turn, so it
/// counts as facing everywhere; its box is the instance's world bounds over `times`, and its
/// centre is followed over `times`.
fn triangle_bounds(e: &Emitter, instances: &[MovingInstance], times: [f64; 2]) -> LightBounds {
    let sides = if e.two_sided { 2.0 } else { 1.0 };
    let power = PI * luminance(e.radiance).max(1e-6) * e.area * sides;
    if e.instance == STATIC {
        let [a, b, c] = e.vertices.v;
        let cos_spread = if e.two_sided { -1.0 } else { 1.0 };
        return LightBounds::still(
            a.min(b).min(c),
            a.max(b).max(c),
            power,
            e.normal,
            cos_spread,
        );
    }
    let instance = &instances[e.instance as usize];
    let at = |tau: f32| {
        let to_world = instance.placement(time_at(times, tau)).to_world;
        e.vertices.v.map(|v| to_world.transform_point3(v))
    };
    let (centre, reach) = follow(
        at,
        |v| (v[0] + v[1] + v[2]) / 3.0,
        |v, c| v.iter().fold(0.0f32, |r, v| r.max(v.distance(c))),
    );
    LightBounds {
        min: instance.bounds.min.into(),
        max: instance.bounds.max.into(),
        centre,
        reach,
        power,
        axis: Vec3::Z,
        cos_spread: -1.0,
    }
}

/// The time a fraction `tau` of the way through `times`.
fn time_at(times: [f64; 2], tau: f32) -> f64 {
    times[0] + (times[1] - times[0]) * tau as f64
}

/// Times at which a moving emitter is placed to find how far it strays from its centre's path
/// (the ends of the range included).
const PATH_STEPS: usize = 8;

/// The light tree compares emitters by π times the most light each sends in one direction,
/// which for a flat one-sided emitter is its power. A two-sided one sends each way what a
/// one-sided one would: half its power.
const TWO_SIDED_PEAK_SHARE: f32 = 0.5;

/// What a light sample aimed at a strand costs against one aimed at a lamp, for learned
/// selection, which picks a branch in proportion to the root of its second moment over its
/// cost. Its shadow ray threads the ring's bundle of moving strands. On the showcase (640×360,
/// 4 spp, one thread, two seeds), learned selection with costs 1, 3 and 9 had efficiencies
/// (1/(noise²·s)) 2.46, 2.71 and 2.75, against 2.10 for the plain tree.
const STRAND_SAMPLE_COST: f32 = 4.0;

/// The same for a round strand, before its exposure: its side, of area A and radiance L, emits
/// πLA in all but shows at most its silhouette, A/π, to any one direction. Then each strand
/// counts by the root of its exposure q: a shadow ray finds it a share q of the time, so the
/// second moment of its contribution goes as q, and one-sample selection has the least
/// variance with weights that go as the root of the second moment.
///
/// Weighed by power and q instead, strands drew about three times their share of samples
/// against a room's lamps. Median noise at 320×180, two seeds: the showcase (32 spp) 10.75% →
/// 10.44%, with samples about 10% faster (strand shadow rays cost the most); `ring_on_wall`,
/// lit by its ring alone, 18.3% → 17.9%; `foggy_portal` unchanged and about 5% faster;
/// `lit_through`, whose two-sided lamp now counts half, 44.2% → 45.1% and a few % slower.
const ROUND_PEAK_SHARE: f32 = 1.0 / PI;

/// The path of a moving emitter's centre over the time range and the reach that holds the
/// emitter around it, from the emitter placed at τ (`at`), its centre, and its farthest
/// extent from a point.
fn follow<S>(
    at: impl Fn(f32) -> S,
    centre: impl Fn(&S) -> Vec3,
    extent: impl Fn(&S, Vec3) -> f32,
) -> (Path, f32) {
    let path = Path::through([0.0, 0.5, 1.0].map(|tau| centre(&at(tau))));
    let reach = (0..=PATH_STEPS).fold(0.0f32, |reach, k| {
        let tau = k as f32 / PATH_STEPS as f32;
        reach.max(extent(&at(tau), path.at(tau)))
    });
    (path, reach)
}

/// The selection bounds of strand segment `i`: round, so it emits every way. Besides the box
/// over `times`, its centre is followed over `times`.
fn segment_bounds(strands: &Strands, i: u32, times: [f64; 2]) -> LightBounds {
    let b = strands.segment_bounds(i, times);
    let [l0, l1] = strands.radiance[i as usize];
    let at = |tau: f32| strands.world_segment(i, time_at(times, tau));
    let (centre, reach) = follow(
        at,
        |s| 0.5 * (s.a + s.b),
        |s, c| (s.a.distance(c) + s.radius_a).max(s.b.distance(c) + s.radius_b),
    );
    LightBounds {
        min: b.min.into(),
        max: b.max.into(),
        centre,
        reach,
        power: PI * luminance(0.5 * (l0 + l1)) * lateral_area(&at(0.0)),
        axis: Vec3::Z,
        cos_spread: -1.0,
    }
}

/// The side area of a segment seen as a cylinder of its mean radius (what light sampling
/// spreads its points over).
fn lateral_area(s: &RoundCone) -> f32 {
    2.0 * PI * 0.5 * (s.radius_a + s.radius_b) * s.a.distance(s.b)
}

impl Lights {
    /// Collects emitters: emissive triangles (`triangle_count` is the scene's triangle count;
    /// those of moving objects are placed by `instances`) and every strand segment that emits;
    /// rays have times in `times`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        emitters: Vec<Emitter>,
        triangle_count: usize,
        strands: &Strands,
        shapes: Vec<ShapeLight>,
        times: [f64; 2],
        instances: &[MovingInstance],
        sky: Option<Sky>,
        selection: LightSelection,
    ) -> Self {
        let mut bounds: Vec<LightBounds> = emitters
            .iter()
            .map(|e| triangle_bounds(e, instances, times))
            .collect();
        let strand_count = strands.segments.len();
        bounds.extend((0..strand_count as u32).map(|i| segment_bounds(strands, i, times)));
        bounds.extend(shapes.iter().map(|l| l.bounds(times)));
        if selection.by_tree() {
            // The tree weighs emitters by the most light they send one way, and strands by
            // what gets out of the rings; power alone stays the plain comparison.
            for (b, e) in bounds.iter_mut().zip(&emitters) {
                if e.two_sided {
                    b.power *= TWO_SIDED_PEAK_SHARE;
                }
            }
            let middle = 0.5 * (times[0] + times[1]);
            let exposure = strand_exposure::exposure(strands, middle);
            let segments = emitters.len()..emitters.len() + strand_count;
            for (b, e) in bounds[segments].iter_mut().zip(exposure) {
                b.power *= ROUND_PEAK_SHARE * e.sqrt();
            }
        }
        let picker = match selection {
            _ if selection.by_tree() && !one_lamp(&bounds) => Picker::Tree,
            _ if bounds.is_empty() => Picker::Power(AliasTable::default()),
            _ => Picker::Power(AliasTable::new(
                &bounds
                    .iter()
                    .map(|b| b.power.max(1e-12) as f64)
                    .collect::<Vec<_>>(),
            )),
        };
        // The root holds the lamps and each ring's strands apart (when there are at most four
        // such kinds), which a learned guide then weighs per region. Alone it took the
        // showcase's noise from 10.44% to 9.75% (320×180, 32 spp, two seeds).
        let kinds: Vec<u32> = (0..emitters.len())
            .map(|_| 0)
            .chain(strands.segment_ring.iter().map(|r| r + 1))
            .chain(shapes.iter().map(|_| 0))
            .collect();
        let tree = LightTree::with_kinds(&bounds, &kinds);
        let strand_range = emitters.len()..emitters.len() + strand_count;
        let lane_costs = lane_costs(&tree, &bounds, strand_range);
        let fetch_ahead = crate::geometry::wide_bvh::worth_fetching_ahead(
            tree.bytes()
                + std::mem::size_of_val(emitters.as_slice())
                + std::mem::size_of_val(strands.segments.as_slice()),
        );
        let mut by_triangle = vec![u32::MAX; triangle_count];
        for (i, e) in emitters.iter().enumerate() {
            by_triangle[e.triangle as usize] = i as u32;
        }
        let environment_split = match (sky.is_some(), bounds.is_empty(), selection) {
            (false, ..) => EnvironmentSplit::Fixed(0.0),
            (true, true, _) => EnvironmentSplit::Fixed(1.0),
            (true, false, LightSelection::Power) => EnvironmentSplit::Fixed(0.5),
            (true, false, _) => EnvironmentSplit::ByEstimate,
        };
        Self {
            emitters,
            strand_count,
            picker,
            tree,
            fetch_ahead,
            by_triangle,
            shapes,
            sky,
            environment_split,
            times,
            selection,
            lane_costs,
        }
    }

    /// What a light sample costs in each lane of the tree's top two levels, relative to one
    /// aimed at a lamp.
    pub fn lane_costs(&self) -> &PerLane {
        &self.lane_costs
    }

    /// How the emitters are picked.
    pub fn selection(&self) -> LightSelection {
        self.selection
    }

    /// True when light selection descends the tree (not power, not the pieces of one lamp).
    pub fn descends_tree(&self) -> bool {
        matches!(self.picker, Picker::Tree)
    }

    /// Light sampling over these lights, its selection guided by `guide` where one was
    /// learned ([`crate::lights::guide`]).
    pub fn sampler<'a>(&'a self, guide: Option<&'a LightGuide>) -> LightSampler<'a> {
        LightSampler {
            lights: self,
            guide,
        }
    }

    /// The unguided tree's shares at the top two levels at `at`.
    pub fn lane_shares(&self, at: &Receiver) -> Option<PerLane> {
        self.tree.lane_shares(at.p, at.n, self.tau(at.time))
    }

    /// The lanes emitter `i`'s path takes at the tree's top two levels.
    pub fn top_lanes(&self, i: usize) -> Option<(usize, Option<usize>)> {
        self.tree.top_lanes(i)
    }

    /// The environment's share of light samples at `at` before anything learned.
    #[inline]
    pub fn estimated_environment_share(&self, at: &Receiver) -> f32 {
        match self.environment_split {
            EnvironmentSplit::Fixed(p) => p,
            EnvironmentSplit::ByEstimate => {
                let sky = self.sky_importance();
                let emitters = self.tree.importance(at.p, at.n, self.tau(at.time));
                if emitters > 0.0 {
                    (sky / (sky + emitters)).clamp(LEAST_SPLIT_SHARE, 1.0 - LEAST_SPLIT_SHARE)
                } else {
                    1.0
                }
            }
        }
    }

    /// True when the environment's share of light samples follows estimates at each point
    /// (and so may be learned).
    pub fn splits_by_estimate(&self) -> bool {
        self.environment_split == EnvironmentSplit::ByEstimate
    }

    /// True when there is nothing to sample.
    pub fn is_empty(&self) -> bool {
        self.emitters.is_empty()
            && self.strand_count == 0
            && self.shapes.is_empty()
            && self.sky.is_none()
    }

    /// Where `time` lies through the time range, 0 at its start and 1 at its end.
    fn tau(&self, time: f64) -> f32 {
        let span = self.times[1] - self.times[0];
        if span > 0.0 {
            ((time - self.times[0]) / span).clamp(0.0, 1.0) as f32
        } else {
            0.0
        }
    }

    /// An unoccluded estimate of the light every emitter and the environment can send to `at`
    /// (about π times its irradiance; under the tree, strands count by the root of their
    /// exposure), for weighing light-sampling strategies.
    pub fn importance(&self, at: &Receiver) -> f32 {
        self.tree.importance(at.p, at.n, self.tau(at.time)) + self.sky_importance()
    }

    /// The sky's part of [`Self::importance`]: what it sends a surface open to all of it.
    fn sky_importance(&self) -> f32 {
        self.sky.as_ref().map_or(0.0, Sky::importance)
    }

    /// The index among the shape lights of emitter `i`, if it is one.
    #[inline]
    fn shape_of(&self, i: usize) -> Option<usize> {
        i.checked_sub(self.emitters.len() + self.strand_count)
    }

    /// Asks the cache for what [`LightSampler::sample`] reads of emitter `i` once it is
    /// picked.
    #[inline(always)]
    fn fetch(&self, i: usize, strands: &Strands) {
        match i.checked_sub(self.emitters.len()) {
            None => crate::platform::prefetch::prefetch(std::slice::from_ref(&self.emitters[i])),
            Some(segment) if segment < self.strand_count => strands.prefetch(segment),
            Some(_) => {}
        }
    }
}

/// Light sampling as a shading point calls it: the scene's [`Lights`], with the tree's first
/// choices reweighed by a learned guide where there is one. Without a guide (training paths,
/// `--light-selection tree`) it picks as the tree alone does.
#[derive(Clone, Copy)]
pub struct LightSampler<'a> {
    pub lights: &'a Lights,
    guide: Option<&'a LightGuide>,
}

impl LightSampler<'_> {
    /// The guide's factors at `at`, if guided.
    #[inline(always)]
    fn factors(&self, at: &Receiver) -> Option<&crate::lights::guide::RegionFactors> {
        self.guide.and_then(|guide| guide.at(at.p))
    }

    /// The guide's factors for the tree's lanes at `at`, if guided.
    #[inline(always)]
    fn lane_factors(&self, at: &Receiver) -> Option<&PerLane> {
        self.factors(at).map(|f| &f.lanes)
    }

    /// Probability that light sampling at `at` takes the environment rather than an emitter:
    /// the estimate's share, moved by the guide's learned factor where there is one.
    #[inline]
    fn environment_probability(&self, at: &Receiver) -> f32 {
        let estimated = self.lights.estimated_environment_share(at);
        // Only a split by estimate is learned: a fixed one needs no guide lookup.
        if self.lights.environment_split != EnvironmentSplit::ByEstimate {
            return estimated;
        }
        match self.factors(at) {
            Some(factors) => {
                let sky = factors.sky * estimated;
                (sky / (sky + 1.0 - estimated))
                    .clamp(LEAST_LEARNED_SPLIT_SHARE, 1.0 - LEAST_LEARNED_SPLIT_SHARE)
            }
            None => estimated,
        }
    }

    /// Picks an emitter for `at`: (index, probability, `u` rescaled for reuse).
    pub fn pick(&self, u: f32, at: &Receiver, strands: &Strands) -> Option<(usize, f32, f32)> {
        match &self.lights.picker {
            Picker::Tree if self.lights.fetch_ahead => self.lights.tree.sample_fetching(
                u,
                at.p,
                at.n,
                self.lights.tau(at.time),
                self.lane_factors(at),
                |i| self.lights.fetch(i, strands),
            ),
            Picker::Tree => self.lights.tree.sample(
                u,
                at.p,
                at.n,
                self.lights.tau(at.time),
                self.lane_factors(at),
            ),
            Picker::Power(table) if table.is_empty() => None,
            Picker::Power(table) => {
                let (i, rest) = table.sample(u.clamp(0.0, 1.0 - f32::EPSILON));
                Some((i, table.pmf(i), rest))
            }
        }
    }

    /// Probability that [`Self::pick`] chooses emitter `i` for `at`.
    pub fn pick_pmf(&self, i: usize, at: &Receiver) -> f32 {
        match &self.lights.picker {
            Picker::Tree => self.lights.tree.pmf(
                i,
                at.p,
                at.n,
                self.lights.tau(at.time),
                self.lane_factors(at),
            ),
            Picker::Power(table) => table.pmf(i),
        }
    }

    /// How [`Self::sample`] splits `u` between the environment and the emitters at `at`: the
    /// environment's probability, whether `u` takes it, and `u` rescaled within the choice.
    #[inline(always)]
    fn split(&self, u: Vec2, at: &Receiver) -> (f32, bool, Vec2) {
        let p_env = self.environment_probability(at);
        let on_environment = u.x < p_env;
        let u_point = if on_environment {
            Vec2::new(u.x / p_env, u.y)
        } else {
            Vec2::new((u.x - p_env) / (1.0 - p_env), u.y)
        };
        (p_env, on_environment, u_point)
    }

    /// What [`Self::sample`] takes with `u` at `at`: the environment, an emitter, or nothing
    /// (`None`). For training, which records `u` rather than have every light sample carry its
    /// emitter (that cost the Cornell box 2.5%).
    pub fn picked(&self, u: Vec2, at: &Receiver, strands: &Strands) -> Option<Picked> {
        let (_, on_environment, u_point) = self.split(u, at);
        if on_environment && self.lights.sky.is_some() {
            return Some(Picked::Environment);
        }
        self.pick(u_point.x, at, strands)
            .map(|(i, _, _)| Picked::Emitter(i))
    }

    /// Picks a light and a point (or direction) on it for the point `at`, from one stratified
    /// 2-D sample: `u.x` chooses the light and is then rescaled to be reused for the point, so
    /// the light samples of a pixel stay stratified across the emitters' surface. `moving`
    /// gives the world-space triangle of an emitter on a moving object at the receiver's time;
    /// `textured` the radiance of a textured emitter's triangle at barycentrics `(b1, b2)`;
    /// strands are taken at that time too.
    #[inline(always)]
    pub fn sample(
        &self,
        u: Vec2,
        at: &Receiver,
        moving: impl Fn(&Emitter) -> Triangle,
        textured: impl Fn(u32, f32, f32) -> Vec3,
        strands: &Strands,
    ) -> Option<LightSample> {
        let (p_env, on_environment, u_point) = self.split(u, at);
        if let Some(sky) = self.lights.sky.as_ref().filter(|_| on_environment) {
            let s = sky.sample(u_point, at.time)?;
            return (s.pdf > 0.0).then_some(LightSample {
                place: LightPlace::Direction {
                    dir: s.direction.into(),
                    part: s.part,
                    delta: s.delta,
                },
                radiance: s.radiance.into(),
                pdf: p_env * s.pdf,
            });
        }
        let (i, pmf, u_rest) = self.pick(u_point.x, at, strands)?;
        let u_point = Vec2::new(u_rest, u_point.y);
        let pick = (1.0 - p_env) * pmf;
        if i >= self.lights.emitters.len() {
            if let Some(k) = self.lights.shape_of(i) {
                return sample_shape(&self.lights.shapes[k], k as u32, at, u_point, pick);
            }
            let segment = (i - self.lights.emitters.len()) as u32;
            return sample_segment(strands, segment, at, u_point, pick);
        }
        let e = &self.lights.emitters[i];
        let (b1, b2) = uniform_triangle(u_point);
        // The point rather than the triangle out of each branch: a triangle copied out of the
        // emitter was read back in pieces that straddled the copy's stores.
        let (point, normal, area) = if e.instance == STATIC {
            (e.vertices.point(b1, b2), e.normal, e.area)
        } else {
            let tri = moving(e);
            let n = tri.normal();
            let area = 0.5 * n.length();
            (tri.point(b1, b2), n / (2.0 * area), area)
        };
        let radiance = match e.textured {
            false => e.radiance,
            true => textured(e.triangle, b1, b2),
        };
        (area > 0.0).then(|| LightSample {
            place: LightPlace::Point {
                point: point.into(),
                normal: normal.into(),
                two_sided: e.two_sided,
                source: LightSource::Triangle(e.triangle),
            },
            radiance: radiance.into(),
            pdf: pick / area,
        })
    }

    /// Solid-angle pdf with which [`LightSampler::sample`], called for `at`, would have picked the
    /// emitter point `found` that lies `distance` away along unit `dir` (the one conversion
    /// from each emitter kind's own measure that MIS needs).
    pub fn pdf_found(
        &self,
        found: Found,
        at: &Receiver,
        dir: Vec3,
        distance: f32,
        strands: &Strands,
    ) -> f32 {
        let (pdf_area, normal) = match found {
            Found::Environment => return self.pdf_environment(dir, at),
            Found::Triangle {
                triangle,
                area_scale,
                normal,
            } => (self.pdf_triangle(triangle, area_scale, at), normal),
            Found::Strand { segment, s, normal } => {
                (self.pdf_strand(segment, s, normal, at, strands), normal)
            }
            Found::Shape {
                light,
                point,
                normal,
            } => (self.pdf_shape(light, point, normal, at), normal),
        };
        pdf_area * distance * distance / normal.dot(dir).abs()
    }

    /// Solid-angle pdf with which [`LightSampler::sample`], called for `at`, picks environment
    /// direction `dir`.
    pub fn pdf_environment(&self, dir: Vec3, at: &Receiver) -> f32 {
        self.lights.sky.as_ref().map_or(0.0, |sky| {
            self.environment_probability(at) * sky.pdf(dir, at.time)
        })
    }

    /// Area-measure pdf with which [`LightSampler::sample`] picks `point` (with unit `normal`)
    /// on shape light `light` for `at`.
    pub fn pdf_shape(&self, light: u32, point: Vec3, normal: Vec3, at: &Receiver) -> f32 {
        let lights = self.lights;
        let Some(shape) = lights.shapes.get(light as usize) else {
            return 0.0;
        };
        let i = lights.emitters.len() + lights.strand_count + light as usize;
        let pick = (1.0 - self.environment_probability(at)) * self.pick_pmf(i, at);
        if pick == 0.0 {
            return 0.0;
        }
        pick * shape.pdf(at.p, point, normal, at.time)
    }

    /// Area-measure pdf with which [`LightSampler::sample`] picks a point on `triangle` for `at`,
    /// when the triangle's world area is `area_scale` times its stored area.
    pub fn pdf_triangle(&self, triangle: u32, area_scale: f32, at: &Receiver) -> f32 {
        match self.lights.by_triangle.get(triangle as usize) {
            Some(&i) if i != u32::MAX => {
                let e = &self.lights.emitters[i as usize];
                (1.0 - self.environment_probability(at)) * self.pick_pmf(i as usize, at)
                    / (e.area * area_scale)
            }
            _ => 0.0,
        }
    }

    /// Area-measure pdf with which [`LightSampler::sample`] picks the point of strand `segment` at
    /// position `s` with outward `normal`, for `at` (at its time).
    pub fn pdf_strand(
        &self,
        segment: u32,
        s: f32,
        normal: Vec3,
        at: &Receiver,
        strands: &Strands,
    ) -> f32 {
        if segment as usize >= self.lights.strand_count {
            return 0.0;
        }
        let pick = (1.0 - self.environment_probability(at))
            * self.pick_pmf(self.lights.emitters.len() + segment as usize, at);
        if pick == 0.0 {
            return 0.0;
        }
        let seg = strands.world_segment(segment, at.time);
        let Some(cylinder) = Cylinder::new(&seg, s, at.p) else {
            return 0.0;
        };
        pick * cylinder.area_pdf(normal)
    }
}

/// A strand segment as light sampling models it: a cylinder of the radius at one position
/// along it, and the frame around its axis that faces the shading point.
struct Cylinder {
    centre: Vec3,
    radius: f32,
    length: f32,
    axis: Vec3,
    /// Unit vector from the axis towards the shading point, perpendicular to the axis.
    facing: Vec3,
}

impl Cylinder {
    fn new(seg: &RoundCone, s: f32, p: Vec3) -> Option<Self> {
        let along = seg.b - seg.a;
        let length = along.length();
        if length.is_nan() || length <= 0.0 {
            return None;
        }
        let axis = along / length;
        let centre = seg.a + along * s;
        let radius = seg.radius_a + (seg.radius_b - seg.radius_a) * s;
        let off = p - centre;
        let facing = (off - axis * off.dot(axis))
            .try_normalize()
            .unwrap_or_else(|| axis.any_orthonormal_vector());
        Some(Self {
            centre,
            radius,
            length,
            axis,
            facing,
        })
    }

    /// Density per unit area of a point with outward `normal`: 1/length along the axis, and
    /// cos φ / 2 around it (φ from the facing direction), per radius.
    fn area_pdf(&self, normal: Vec3) -> f32 {
        let radial = (normal - self.axis * normal.dot(self.axis)).normalize_or_zero();
        let cos_phi = radial.dot(self.facing);
        if cos_phi <= 0.0 || self.radius <= 0.0 {
            return 0.0;
        }
        cos_phi / (2.0 * self.radius * self.length)
    }
}

/// The mean cost of a light sample in each lane of `tree`'s top two levels over `bounds` (the
/// strand segments among them at `strands`, every other one a lamp), weighed as the tree
/// weighs emitters.
fn lane_costs(tree: &LightTree, bounds: &[LightBounds], strands: Range<usize>) -> PerLane {
    let (mut cost, mut weight) = (PerLane::splat(0.0), PerLane::splat(0.0));
    for (i, b) in bounds.iter().enumerate() {
        let Some((j, second)) = tree.top_lanes(i) else {
            continue;
        };
        let c = if strands.contains(&i) {
            STRAND_SAMPLE_COST
        } else {
            1.0
        };
        cost.root[j] += b.power * c;
        weight.root[j] += b.power;
        if let Some(k) = second {
            cost.second[j][k] += b.power * c;
            weight.second[j][k] += b.power;
        }
    }
    let mean = |c: f32, w: f32| if w > 0.0 { c / w } else { 1.0 };
    PerLane {
        root: std::array::from_fn(|j| mean(cost.root[j], weight.root[j])),
        second: std::array::from_fn(|j| {
            std::array::from_fn(|k| mean(cost.second[j][k], weight.second[j][k]))
        }),
    }
}

/// Most emitters that [`one_lamp`] takes for the pieces of one lamp.
const LAMP_PIECES: usize = 4;

/// True when `emitters` are the few pieces of one lamp: at most [`LAMP_PIECES`], whose boxes
/// touch one another (a quad light's two triangles). The tree then gives way to choosing by
/// power, which for an even lamp is by area, as renderers sample an area light: the tree's
/// scores could hardly tell the pieces apart, and on the Cornell box (a ceiling light of two
/// triangles) scoring them took a tenth of the render time for an error no lower.
fn one_lamp(emitters: &[LightBounds]) -> bool {
    if emitters.is_empty() || emitters.len() > LAMP_PIECES {
        return false;
    }
    let touch =
        |a: &LightBounds, b: &LightBounds| a.min.cmple(b.max).all() && b.min.cmple(a.max).all();
    // Grow the set of pieces reached from the first one through touching boxes.
    let mut reached = 1u32;
    loop {
        let grown = (0..emitters.len()).fold(reached, |set, i| {
            let joins = (0..emitters.len())
                .any(|j| reached & 1 << j != 0 && touch(&emitters[i], &emitters[j]));
            if joins { set | 1 << i } else { set }
        });
        if grown == reached {
            return reached == (1 << emitters.len()) - 1;
        }
        reached = grown;
    }
}

/// A point on shape light `light` (index `k`) for the shading point `at`, picked with
/// probability `pick`.
fn sample_shape(
    light: &ShapeLight,
    k: u32,
    at: &Receiver,
    u: Vec2,
    pick: f32,
) -> Option<LightSample> {
    let s = light.sample(at.p, at.time, u)?;
    let source = LightSource::Shape(k);
    let place = if light.is_point() {
        LightPlace::Punctual {
            point: s.point.into(),
            source,
        }
    } else {
        LightPlace::Point {
            point: s.point.into(),
            normal: s.normal.into(),
            two_sided: false,
            source,
        }
    };
    Some(LightSample {
        place,
        radiance: s.radiance.into(),
        pdf: pick * s.pdf,
    })
}

/// A point on strand `segment` (world, at the receiver's time) for the shading point `at`,
/// picked with probability `pick`.
fn sample_segment(
    strands: &Strands,
    segment: u32,
    at: &Receiver,
    u: Vec2,
    pick: f32,
) -> Option<LightSample> {
    let seg = strands.world_segment(segment, at.time);
    let s = u.x.min(1.0 - f32::EPSILON);
    let cylinder = Cylinder::new(&seg, s, at.p)?;
    // sin φ uniform in [−1, 1]: cos φ-distributed over the facing half.
    let sin_phi = 2.0 * u.y - 1.0;
    let cos_phi = (1.0 - sin_phi * sin_phi).max(0.0).sqrt();
    let side = cylinder.axis.cross(cylinder.facing);
    let normal = cylinder.facing * cos_phi + side * sin_phi;
    let pdf = pick * cylinder.area_pdf(normal);
    (pdf > 0.0).then(|| LightSample {
        place: LightPlace::Point {
            point: (cylinder.centre + normal * cylinder.radius).into(),
            normal: normal.into(),
            two_sided: false,
            source: LightSource::Strand(segment),
        },
        radiance: strands.radiance(segment, s).into(),
        pdf,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{ObjectMotion, RingFrame};
    use crate::lights::environment::Environment;
    use crate::lights::shapes::Shape;
    use glam::{DQuat, DVec3};
    use rift_fx::rig::{AnimatedTransform, Interpolation, Similarity, TransformKey};
    use rift_fx::ring::RingCurves;

    const SAMPLES: u32 = 200_000;

    /// Hammersley point k of [`SAMPLES`], so picks follow their pmf without counting noise.
    fn hammersley(k: u32) -> Vec2 {
        Vec2::new(
            (k as f32 + 0.5) / SAMPLES as f32,
            k.reverse_bits() as f32 / 2f32.powi(32),
        )
    }

    fn emitter(triangle: u32, instance: u32, v: [Vec3; 3]) -> Emitter {
        let tri = Triangle { v };
        Emitter {
            triangle,
            instance,
            radiance: Vec3::splat(3.0),
            textured: false,
            two_sided: true,
            vertices: tri,
            normal: tri.normal().normalize(),
            area: tri.area(),
        }
    }

    /// One closed strand: a still square of side 2 (half-width 0.05) around the origin of a
    /// frame placed at z = −3.
    fn square_ring() -> Strands {
        let mut c = RingCurves::default();
        c.vertex_counts.push(4);
        c.directions.push(1);
        for p in [[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]] {
            c.points.push(Vec3::new(p[0], p[1], 0.0));
            c.velocities.push(Vec3::ZERO);
            c.accelerations.push(Vec3::ZERO);
            c.widths.push(0.1);
            c.colors.push(Vec3::ONE);
            c.intensities.push(1.0);
        }
        let mut strands = Strands::default();
        let to_world = Similarity::new(DQuat::IDENTITY, DVec3::new(0.0, 0.0, -3.0), 1.0);
        let frame = RingFrame::fixed(to_world);
        strands.add_ring(&c, frame, 0.0, [0.0, 1.0], 1.0);
        strands
    }

    /// A moving instance that grows from scale 1 to 3 over [0, 1].
    fn growing() -> MovingInstance {
        let key = |time, scale| TransformKey {
            time,
            value: Similarity::new(DQuat::IDENTITY, DVec3::new(0.0, 2.0, 0.0), scale),
        };
        let motion = ObjectMotion::new(AnimatedTransform::new(
            vec![key(0.0, 1.0), key(1.0, 3.0)],
            Interpolation::Linear,
        ));
        let tri = Triangle {
            v: [Vec3::ZERO, Vec3::X, Vec3::Z],
        };
        MovingInstance::new(&[tri], 2, motion, [0.0, 1.0])
    }

    /// Shape lights facing the receiver of the test below: a 1 × 0.5 rectangle, a disk of
    /// radius 0.4, and a sphere of radius 0.3 (whose samples cover the cap the receiver sees).
    fn shape_lights() -> Vec<ShapeLight> {
        let at = |p: DVec3| AnimatedTransform::constant(Similarity::from_translation(p));
        let light = |shape, p| ShapeLight {
            name: String::new(),
            shape,
            base: Vec3::splat(2.0),
            normalize: false,
            cone: None,
            placement: at(p).into(),
            flags: crate::portals::Flags::ALL,
            group: 0,
        };
        vec![
            light(
                Shape::Rect {
                    width: 1.0,
                    height: 0.5,
                },
                DVec3::new(0.0, 1.0, 6.0),
            ),
            light(Shape::Disk { radius: 0.4 }, DVec3::new(-1.0, 0.0, 7.0)),
            light(Shape::Sphere { radius: 0.3 }, DVec3::new(1.5, 0.5, 5.5)),
        ]
    }

    /// Every emitter kind; for each sample, the pdf the sampler reports must equal the pdf
    /// evaluated at the sampled point, and Σ g/pdf over the samples that land on an emitter,
    /// divided by the sample count, must integrate g over its area. g is 1 on triangles and
    /// shape lights (the area itself; for a sphere, the cap the receiver sees); on a strand,
    /// whose points are cos φ-distributed around the facing half, 1/pdf has unbounded
    /// variance, so g is cos²φ there, which integrates to π·r·length/2.
    #[test]
    fn sampled_pdfs_match_evaluated_pdfs_and_integrate_each_area() {
        let strands = square_ring();
        let instance = growing();
        let still_a = emitter(0, STATIC, [Vec3::new(-1.0, 0.0, 0.0), Vec3::X, Vec3::Y]);
        let still_b = emitter(
            1,
            STATIC,
            [
                Vec3::new(0.0, 0.0, 1.0),
                Vec3::new(2.0, 0.0, 1.0),
                Vec3::new(0.0, 0.5, 1.0),
            ],
        );
        let moving = emitter(2, 0, [Vec3::ZERO, Vec3::X, Vec3::Z]);
        let instances = [instance];
        for selection in [LightSelection::Tree, LightSelection::Power] {
            let lights = Lights::new(
                vec![still_a, still_b, moving],
                3,
                &strands,
                shape_lights(),
                [0.0, 1.0],
                &instances,
                None,
                selection,
            );
            let time = 0.5;
            let at = Receiver {
                p: Vec3::new(0.3, 0.8, 4.0),
                n: None,
                time,
            };
            let placement = instances[0].placement(time);
            let world = |e: &Emitter| Triangle {
                v: e.vertices.v.map(|v| placement.to_world.transform_point3(v)),
            };
            let mut integral = std::collections::HashMap::<LightSource, f64>::new();
            for k in 0..SAMPLES {
                let u = hammersley(k);
                let Some(sample) =
                    lights
                        .sampler(None)
                        .sample(u, &at, world, |_, _, _| unreachable!(), &strands)
                else {
                    continue;
                };
                let LightPlace::Point {
                    point,
                    normal,
                    source,
                    ..
                } = sample.place
                else {
                    panic!("no environment here");
                };
                let (point, normal) = (Vec3::from(point), Vec3::from(normal));
                let (evaluated, g) = match source {
                    LightSource::Triangle(t) => {
                        let scale = if t == 2 { placement.scale.powi(2) } else { 1.0 };
                        (lights.sampler(None).pdf_triangle(t, scale, &at), 1.0)
                    }
                    LightSource::Strand(segment) => {
                        let seg = strands.world_segment(segment, time);
                        let s = (point - seg.a).dot(seg.b - seg.a) / seg.a.distance_squared(seg.b);
                        let cos_phi = Cylinder::new(&seg, s, at.p).unwrap().facing.dot(normal);
                        (
                            lights
                                .sampler(None)
                                .pdf_strand(segment, s, normal, &at, &strands),
                            (cos_phi * cos_phi) as f64,
                        )
                    }
                    LightSource::Shape(k) => {
                        let pdf = lights.sampler(None).pdf_shape(k, point, normal, &at);
                        (pdf, 1.0)
                    }
                };
                assert!(
                    (evaluated - sample.pdf).abs() <= 2e-3 * sample.pdf,
                    "{selection:?} {source:?}: sampled pdf {} evaluated {evaluated}",
                    sample.pdf
                );
                *integral.entry(source).or_default() += g / sample.pdf as f64;
            }
            let area = |source: LightSource| -> f64 {
                match source {
                    LightSource::Triangle(2) => world(&moving).area() as f64,
                    LightSource::Triangle(0) => still_a.area as f64,
                    LightSource::Triangle(_) => still_b.area as f64,
                    LightSource::Strand(segment) => {
                        let seg = strands.world_segment(segment, time);
                        std::f64::consts::PI / 2.0
                            * 0.5
                            * (seg.radius_a + seg.radius_b) as f64
                            * seg.a.distance(seg.b) as f64
                    }
                    LightSource::Shape(0) => 0.5,
                    LightSource::Shape(1) => std::f64::consts::PI * 0.16,
                    LightSource::Shape(_) => {
                        // The cap a point d away sees of a sphere of radius r: 2πr²(1 − r/d).
                        let d = Vec3::new(1.5, 0.5, 5.5).distance(at.p) as f64;
                        2.0 * std::f64::consts::PI * 0.09 * (1.0 - 0.3 / d)
                    }
                }
            };
            assert_eq!(integral.len(), 6 + strands.segments.len(), "{selection:?}");
            for (source, sum) in integral {
                let (got, want) = (sum / SAMPLES as f64, area(source));
                assert!(
                    (got - want).abs() < 0.01 * want,
                    "{selection:?} {source:?}: Σ1/pdf gives {got}, area {want}"
                );
            }
            // The moving triangle is integrated at its size at the receiver's time.
            let grown = 0.5 * placement.scale * placement.scale;
            assert!(
                placement.scale > 1.5
                    && (area(LightSource::Triangle(2)) - grown as f64).abs() < 1e-4
            );
        }
    }

    /// A lamp and a ring that send a far point the same light are picked about equally, however
    /// many sides the lamp emits from: the tree weighs both by their intensity toward it.
    #[test]
    fn a_lamp_and_a_ring_that_send_a_point_the_same_light_are_picked_alike() {
        // The square ring's four segments (radius 0.05, length 2, radiance 1) each show the
        // point, far along the ring's axis, a silhouette of 0.1 x 2: 0.8 in all. The lamp, a
        // 0.4 x 0.4 square of radiance 5 in the ring's plane facing the point, shows 0.16 x 5.
        let strands = square_ring();
        let lamp = |two_sided: bool| {
            let c = |x: f32, y: f32| Vec3::new(x, y, -3.0);
            [
                [c(-0.2, -0.2), c(0.2, -0.2), c(0.2, 0.2)],
                [c(-0.2, -0.2), c(0.2, 0.2), c(-0.2, 0.2)],
            ]
            .into_iter()
            .enumerate()
            .map(|(i, v)| Emitter {
                radiance: Vec3::splat(5.0),
                textured: false,
                two_sided,
                ..emitter(i as u32, STATIC, v)
            })
            .collect::<Vec<_>>()
        };
        let at = Receiver {
            p: Vec3::new(0.0, 0.0, 7.0),
            n: Some(-Vec3::Z),
            time: 0.5,
        };
        for two_sided in [false, true] {
            let lights = Lights::new(
                lamp(two_sided),
                2,
                &strands,
                Vec::new(),
                [0.0, 1.0],
                &[],
                None,
                LightSelection::Tree,
            );
            let share =
                lights.sampler(None).pick_pmf(0, &at) + lights.sampler(None).pick_pmf(1, &at);
            // Weighed by power, the ring would take π times the lamp's share (a quarter for the
            // lamp, or two fifths when it emits both ways).
            assert!(
                (0.45..0.6).contains(&share),
                "two-sided {two_sided}: the lamp gets {share}"
            );
        }
    }

    /// With a sky and a lamp, light sampling leans to the lamp beneath it and to the sky far
    /// from it, and the pdf of every sample is the one MIS evaluates for what it found.
    #[test]
    fn the_sky_and_the_lamps_share_samples_by_what_each_sends() {
        // A 1 x 1 lamp of radiance 10 facing down at y = 2, under a sky of radiance 1.
        let c = |x: f32, z: f32| Vec3::new(x, 2.0, z);
        let lamp = [
            [c(0.0, 0.0), c(1.0, 0.0), c(1.0, 1.0)],
            [c(0.0, 0.0), c(1.0, 1.0), c(0.0, 1.0)],
        ]
        .into_iter()
        .enumerate()
        .map(|(i, v)| Emitter {
            radiance: Vec3::splat(10.0),
            textured: false,
            two_sided: false,
            ..emitter(i as u32, STATIC, v)
        })
        .collect::<Vec<_>>();
        assert!(lamp.iter().all(|e| e.normal.y < 0.0));
        let none = Strands::default();
        let build = |selection| {
            Lights::new(
                lamp.clone(),
                2,
                &none,
                Vec::new(),
                [0.0, 1.0],
                &[],
                Sky::new(Some(Environment::Constant(Vec3::ONE)), Vec::new()),
                selection,
            )
        };
        let lights = build(LightSelection::Tree);
        let under = Receiver {
            p: Vec3::new(0.5, 1.9, 0.5),
            n: Some(Vec3::Y),
            time: 0.0,
        };
        let far = Receiver {
            p: Vec3::new(200.0, 0.0, 0.0),
            n: Some(Vec3::Y),
            time: 0.0,
        };
        let share = |at: &Receiver| lights.sampler(None).environment_probability(at);
        assert!(
            share(&under) < 0.1,
            "under the lamp the sky gets {}",
            share(&under)
        );
        assert!(share(&far) > 0.9, "far away the sky gets {}", share(&far));
        assert_eq!(
            build(LightSelection::Power)
                .sampler(None)
                .environment_probability(&under),
            0.5
        );
        for at in [under, far] {
            let (mut sky, mut lamps) = (0, 0);
            for k in 0..2000 {
                let u = hammersley(k * (SAMPLES / 2000));
                let s = lights
                    .sampler(None)
                    .sample(u, &at, |e| e.vertices, |_, _, _| unreachable!(), &none)
                    .unwrap();
                let evaluated = match s.place {
                    LightPlace::Direction { dir, .. } => {
                        sky += 1;
                        lights.sampler(None).pdf_environment(dir.into(), &at)
                    }
                    LightPlace::Point {
                        source: LightSource::Triangle(t),
                        ..
                    } => {
                        lamps += 1;
                        lights.sampler(None).pdf_triangle(t, 1.0, &at)
                    }
                    other => panic!("{other:?}"),
                };
                assert!(
                    (s.pdf - evaluated).abs() <= 1e-5 * s.pdf,
                    "sampled {} against evaluated {evaluated}",
                    s.pdf
                );
            }
            let expected = share(&at) * 2000.0;
            assert!(
                (sky as f32 - expected).abs() <= 2.0,
                "{sky} sky, {lamps} lamp samples"
            );
        }
    }

    #[test]
    fn the_pieces_of_one_lamp_are_picked_by_area_and_separate_lamps_by_the_tree() {
        // A 2 x 1 quad light facing down, cut along its diagonal, and the same quad moved away.
        let quad = |x: f32| {
            let c = |dx: f32, dz: f32| Vec3::new(x + dx, 2.0, dz);
            [
                emitter(0, STATIC, [c(0.0, 0.0), c(2.0, 0.0), c(2.0, 1.0)]),
                emitter(1, STATIC, [c(0.0, 0.0), c(2.0, 1.0), c(0.0, 1.0)]),
            ]
        };
        let none = Strands::default();
        let build = |emitters: Vec<Emitter>| {
            let count = emitters.len();
            Lights::new(
                emitters,
                count,
                &none,
                Vec::new(),
                [0.0, 1.0],
                &[],
                None,
                LightSelection::Tree,
            )
        };
        let one = build(quad(0.0).to_vec());
        let under_first = |x: f32| Receiver {
            p: Vec3::new(x, 0.0, 0.1),
            n: Some(Vec3::Y),
            time: 0.0,
        };
        for x in [0.1, 1.9, -5.0] {
            let at = under_first(x);
            assert_eq!(
                [0, 1].map(|i| one.sampler(None).pick_pmf(i, &at)),
                [0.5, 0.5],
                "at x = {x}"
            );
            let picked = (0..1000)
                .filter_map(|k| {
                    one.sampler(None)
                        .pick((k as f32 + 0.5) / 1000.0, &at, &none)
                })
                .filter(|&(i, pmf, _)| i == 0 && pmf == 0.5)
                .count();
            assert_eq!(picked, 500);
        }
        // Two quads 10 apart: a point under one mostly samples it.
        let mut two = quad(0.0).to_vec();
        two.extend(quad(10.0).map(|e| Emitter {
            triangle: e.triangle + 2,
            ..e
        }));
        let two = build(two);
        let at = under_first(11.0);
        let far: f32 = (0..2).map(|i| two.sampler(None).pick_pmf(i, &at)).sum();
        assert!(far < 0.1, "the far quad gets {far}");
        // Touching is what joins pieces, up to four of them.
        let strip: Vec<LightBounds> = (0..5)
            .map(|i| {
                let x = i as f32;
                LightBounds::still(
                    Vec3::new(x, 2.0, 0.0),
                    Vec3::new(x + 1.0, 2.0, 1.0),
                    1.0,
                    -Vec3::Y,
                    1.0,
                )
            })
            .collect();
        assert!(one_lamp(&strip[..4]));
        assert!(!one_lamp(&strip));
        assert!(!one_lamp(&[strip[0], strip[2]]));
        assert!(!one_lamp(&[]));
    }
}
