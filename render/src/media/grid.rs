//! Heterogeneous media: density grids (read from OpenVDB files) scaling a medium's absorption,
//! scattering and emission, placed in the scene by a keyed transform (or carried through an
//! opening) like an object, so they move, blur and appear through openings.
//!
//! Paths cross them by delta tracking against the grids' majorants (brick by brick, so empty
//! space costs one step per brick): at each tentative collision, drawn with the summed majorant
//! μ̄ of the grids the ray is in, the path gathers the emission ε(x)/μ̄ and then absorbs,
//! scatters or passes (a null collision) with probabilities given by the channels' mean
//! coefficients; the throughput is weighted per channel by the coefficient over its
//! probability, so a grey medium tracks analogously (all weights 1) and a colourful one stays
//! unbiased. Shadow rays use ratio tracking: T = Π (1 − σ_t(x)/μ̄) over the tentative
//! collisions, with roulette once T is small.
//!
//! Several grids may overlap: their majorants add, and a scattering event picks the grid whose
//! phase function it uses by their scattering at the point.

use crate::geometry::ObjectMotion;
use crate::media::voxels::Voxels;
use glam::{DAffine3, DVec3, Vec3};

/// At most this many grid media in a scene (the tracker keeps one brick walk per grid).
pub const MAX_GRIDS: usize = 16;

/// Once every channel of a shadow ray's transmittance falls below this, ratio tracking plays
/// roulette instead of walking on.
const ROULETTE_BELOW: f32 = 0.1;

/// A medium whose coefficients are a density grid times per-unit-density coefficients.
pub struct GridMedium {
    pub name: String,
    voxels: Voxels,
    /// Per metre at density 1.
    extinction: Vec3,
    scattering: Vec3,
    emission: Vec3,
    pub anisotropy: f32,
    /// The largest channel of `extinction`: the majorant's scale.
    extinction_max: f32,
    /// From the grid's index space to the medium's own space (the VDB file's world).
    local_from_index: DAffine3,
    placement: Placement,
}

/// Where a grid is: fixed (its map from world to index space cached), or moving.
enum Placement {
    Still(Affine),
    Moving(ObjectMotion),
}

/// A map from world to index space in single precision (a ray's parameter is kept).
#[derive(Clone, Copy)]
struct Affine {
    matrix: glam::Mat3A,
    translation: glam::Vec3A,
}

impl Affine {
    fn new(index_from_world: DAffine3) -> Self {
        Self {
            matrix: index_from_world.matrix3.as_mat3().into(),
            translation: index_from_world.translation.as_vec3().into(),
        }
    }

    fn ray(&self, origin: Vec3, dir: Vec3) -> (Vec3, Vec3) {
        let o = self.matrix * glam::Vec3A::from(origin) + self.translation;
        (o.into(), (self.matrix * glam::Vec3A::from(dir)).into())
    }
}

/// The coefficients of a grid medium, per metre at density 1, and its phase asymmetry.
#[derive(Clone, Copy, Debug)]
pub struct Coefficients {
    pub absorption: Vec3,
    pub scattering: Vec3,
    pub emission: Vec3,
    pub anisotropy: f32,
}

impl GridMedium {
    /// The grid `voxels`, mapped by `local_from_index` into the medium's space, which
    /// `motion` places in the world over time.
    pub fn new(
        name: String,
        voxels: Voxels,
        local_from_index: DAffine3,
        c: Coefficients,
        motion: ObjectMotion,
        times: [f64; 2],
    ) -> Self {
        let extinction = c.absorption + c.scattering;
        let placement = if motion.moves_during(times) {
            Placement::Moving(motion)
        } else {
            Placement::Still(Affine::new(Self::index_from_world(
                &motion,
                local_from_index,
                times[0],
            )))
        };
        Self {
            name,
            voxels,
            extinction,
            scattering: c.scattering,
            emission: c.emission,
            anisotropy: c.anisotropy,
            extinction_max: extinction.max_element(),
            local_from_index,
            placement,
        }
    }

    fn index_from_world(motion: &ObjectMotion, local_from_index: DAffine3, time: f64) -> DAffine3 {
        let s = motion.at(time);
        let world_from_local = DAffine3::from_scale_rotation_translation(
            DVec3::splat(s.scale),
            s.rotation,
            s.translation,
        );
        (world_from_local * local_from_index).inverse()
    }

    /// The ray `origin + t·dir` at `time` in index space (same parameter t).
    fn to_index(&self, origin: Vec3, dir: Vec3, time: f64) -> (Vec3, Vec3) {
        match &self.placement {
            Placement::Still(map) => map.ray(origin, dir),
            Placement::Moving(motion) => {
                Affine::new(Self::index_from_world(motion, self.local_from_index, time))
                    .ray(origin, dir)
            }
        }
    }

    /// True when a collision in it can add anything (it scatters or emits).
    fn collisions_matter(&self) -> bool {
        self.scattering.max_element() > 0.0 || self.emission.max_element() > 0.0
    }

    /// Bytes held (for memory estimates).
    pub fn bytes(&self) -> usize {
        self.voxels.bytes()
    }

    /// The density at world point `p` at `time`.
    pub fn density_at(&self, p: Vec3, time: f64) -> f32 {
        let (i, _) = self.to_index(p, Vec3::X, time);
        self.voxels.density(i)
    }
}

/// Every grid medium of a scene.
#[derive(Default)]
pub struct GridMedia {
    pub grids: Vec<GridMedium>,
}

/// How delta tracking along a stretch ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tracked {
    /// No real collision before the stretch's end.
    Passed,
    /// The path scatters at `at` with the phase function of asymmetry `anisotropy`;
    /// `albedo` is σ_s/σ_t there (for the albedo AOV).
    Scattered {
        at: f32,
        anisotropy: f32,
        albedo: Vec3,
    },
    /// The path is absorbed at `at`.
    Absorbed { at: f32 },
}

/// A small random number generator for the tracking's variable number of draws, seeded once
/// per stretch from the path's sample stream (or from the ray, for shadow rays).
#[derive(Clone, Copy)]
pub struct Rng(u32);

impl Rng {
    pub fn new(seed: u32) -> Self {
        Self(seed)
    }

    /// Seeded by a ray's origin and direction: shadow rays have no stream of their own.
    pub fn from_ray(origin: Vec3, dir: Vec3) -> Self {
        let mut h = 0x9e37_79b9u32;
        for x in origin.to_array().into_iter().chain(dir.to_array()) {
            h = crate::sampling::hash32(h ^ x.to_bits());
        }
        Self(h)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9e37_79b9);
        (crate::sampling::hash32(self.0) >> 8) as f32 / (1u32 << 24) as f32
    }

    /// An exponential distance for rate `mu`.
    fn exponential(&mut self, mu: f32) -> f32 {
        -(1.0 - self.uniform()).ln() / mu
    }
}

/// Per grid, the brick walk along the current ray and the brick it is in.
struct Walk<'a> {
    grid: &'a GridMedium,
    origin: Vec3,
    dir: Vec3,
    segments: crate::media::voxels::Segments<'a>,
    /// (start, end, majorant × largest extinction) of the current brick; `None`: done.
    current: Option<(f32, f32, f32)>,
}

impl<'a> Walk<'a> {
    fn next_segment(&mut self) {
        self.current = self
            .segments
            .next()
            .map(|(a, b, m)| (a, b, m * self.grid.extinction_max));
    }
}

/// The majorant and coefficients of all grids along one ray, walked together.
struct Walks<'a> {
    walks: [Option<Walk<'a>>; MAX_GRIDS],
}

impl<'a> Walks<'a> {
    fn new(media: &'a GridMedia, origin: Vec3, dir: Vec3, time: f64, from: f32, to: f32) -> Self {
        let mut walks: [Option<Walk<'a>>; MAX_GRIDS] = Default::default();
        for (slot, grid) in walks.iter_mut().zip(&media.grids) {
            let (o, d) = grid.to_index(origin, dir, time);
            let segments = grid.voxels.segments(o, d, from, to);
            if segments.start().is_some() {
                let mut walk = Walk {
                    grid,
                    origin: o,
                    dir: d,
                    segments,
                    current: None,
                };
                walk.next_segment();
                *slot = Some(walk);
            }
        }
        Self { walks }
    }

    /// The summed majorant at `t` and where it next changes (at most `to`).
    fn majorant(&mut self, t: f32, to: f32) -> (f32, f32) {
        let (mut mu, mut change) = (0.0, to);
        for slot in &mut self.walks {
            let Some(walk) = slot else { continue };
            while let Some((_, end, _)) = walk.current
                && end <= t
            {
                walk.next_segment();
            }
            match walk.current {
                None => *slot = None,
                Some((start, _, _)) if start > t => change = change.min(start),
                Some((_, end, m)) => {
                    mu += m;
                    change = change.min(end);
                }
            }
        }
        (mu, change)
    }

    /// The next tentative collision after `*t` (moved there) before `to`, drawn against the
    /// summed majorant brick by brick, and the majorant there; `None` past `to`.
    fn tentative(&mut self, t: &mut f32, to: f32, rng: &mut Rng) -> Option<(f32, f32)> {
        while *t < to {
            let (mu, change) = self.majorant(*t, to);
            if mu <= 0.0 {
                if change <= *t {
                    return None;
                }
                *t = change;
                continue;
            }
            let next = *t + rng.exponential(mu);
            if next >= change {
                *t = change;
                continue;
            }
            *t = next;
            return Some((next, mu));
        }
        None
    }

    /// Per channel: absorption, scattering and emission at `t`, summed over the grids.
    fn coefficients(&self, t: f32) -> [Vec3; 3] {
        let mut sum = [Vec3::ZERO; 3];
        for walk in self.walks.iter().flatten() {
            let d = walk.grid.voxels.density(walk.origin + walk.dir * t);
            if d > 0.0 {
                let g = walk.grid;
                sum[0] += d * (g.extinction - g.scattering);
                sum[1] += d * g.scattering;
                sum[2] += d * g.emission;
            }
        }
        sum
    }

    /// The grid whose phase function a scattering at `t` uses, picked by `u` in proportion to
    /// their scattering there.
    fn scatterer(&self, t: f32, u: f32) -> &'a GridMedium {
        let mut weights = [0.0f32; MAX_GRIDS];
        let mut total = 0.0;
        for (w, walk) in weights.iter_mut().zip(&self.walks) {
            if let Some(walk) = walk {
                let d = walk.grid.voxels.density(walk.origin + walk.dir * t);
                *w = d * walk.grid.scattering.element_sum();
                total += *w;
            }
        }
        let mut target = u * total;
        let mut last = None;
        for (w, walk) in weights.iter().zip(&self.walks) {
            if let Some(walk) = walk {
                last = Some(walk.grid);
                if *w > 0.0 && target < *w {
                    return walk.grid;
                }
                target -= w;
            }
        }
        last.expect("a scattering event happens inside some grid")
    }
}

fn mean(v: Vec3) -> f32 {
    v.element_sum() / 3.0
}

impl GridMedia {
    pub fn is_empty(&self) -> bool {
        self.grids.is_empty()
    }

    /// Bytes their voxels hold.
    pub fn bytes(&self) -> usize {
        self.grids.iter().map(GridMedium::bytes).sum()
    }

    /// True when some grid scatters or emits, so camera paths must track collisions; grids
    /// that only absorb weight paths by their transmittance instead.
    pub fn collisions_matter(&self) -> bool {
        self.grids.iter().any(GridMedium::collisions_matter)
    }

    /// Delta tracking along `origin + t·dir` at `time` for t in [`from`, `to`]: updates the
    /// path's throughput `beta`, adds the emission gathered (already weighted by `beta`) to
    /// `emitted`, and tells how the stretch ended.
    #[allow(clippy::too_many_arguments)]
    pub fn track(
        &self,
        origin: Vec3,
        dir: Vec3,
        time: f64,
        from: f32,
        to: f32,
        rng: &mut Rng,
        beta: &mut Vec3,
        emitted: &mut Vec3,
    ) -> Tracked {
        if !self.collisions_matter() {
            *beta *= self.transmittance(origin, dir, time, from, to, rng);
            return Tracked::Passed;
        }
        let mut walks = Walks::new(self, origin, dir, time, from, to);
        let mut cursor = from;
        while let Some((t, mu)) = walks.tentative(&mut cursor, to, rng) {
            let [absorption, scattering, emission] = walks.coefficients(t);
            *emitted += *beta * emission / mu;
            let null = Vec3::splat(mu) - absorption - scattering;
            let (p_absorb, p_scatter) = (mean(absorption) / mu, mean(scattering) / mu);
            let u = rng.uniform();
            if u < p_absorb {
                return Tracked::Absorbed { at: t };
            }
            if u < p_absorb + p_scatter {
                *beta *= scattering / mean(scattering);
                let grid = walks.scatterer(t, rng.uniform());
                let extinction = absorption + scattering;
                let albedo = Vec3::select(
                    extinction.cmpgt(Vec3::ZERO),
                    scattering / extinction,
                    Vec3::ZERO,
                );
                return Tracked::Scattered {
                    at: t,
                    anisotropy: grid.anisotropy,
                    albedo,
                };
            }
            // A null collision; its probability can round to zero only where the majorant
            // is tight, and then it carries no weight change.
            let p_null = mean(null);
            if p_null > 0.0 {
                *beta *= null.max(Vec3::ZERO) / p_null;
            }
        }
        Tracked::Passed
    }

    /// The transmittance along `origin + t·dir` at `time` for t in [`from`, `to`], by ratio
    /// tracking (unbiased; exact where the grids are empty).
    pub fn transmittance(
        &self,
        origin: Vec3,
        dir: Vec3,
        time: f64,
        from: f32,
        to: f32,
        rng: &mut Rng,
    ) -> Vec3 {
        let mut walks = Walks::new(self, origin, dir, time, from, to);
        let mut transmittance = Vec3::ONE;
        let mut cursor = from;
        while let Some((t, mu)) = walks.tentative(&mut cursor, to, rng) {
            let [absorption, scattering, _] = walks.coefficients(t);
            transmittance *= (Vec3::ONE - (absorption + scattering) / mu).max(Vec3::ZERO);
            let largest = transmittance.max_element();
            if largest < ROULETTE_BELOW {
                let survive = largest / ROULETTE_BELOW;
                if rng.uniform() >= survive {
                    return Vec3::ZERO;
                }
                transmittance /= survive;
            }
        }
        transmittance
    }
}
