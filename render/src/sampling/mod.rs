//! Sampling helpers: orthonormal frames, warps from the unit square, alias tables, and the
//! per-pixel Owen-scrambled Sobol sequence.

pub mod regions;
pub mod sobol;

use crate::sampling::sobol::SobolSample;
use glam::{Vec2, Vec3, Vec4};
use std::f32::consts::FRAC_PI_4;

/// An orthonormal frame around a unit normal.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// A frame around unit `n` (Duff et al. 2017, branchless and continuous except at one sign).
    pub fn new(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        Self {
            s: Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
            t: Vec3::new(b, sign + n.y * n.y * a, -n.y),
            n,
        }
    }

    /// World → local.
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local → world.
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// Cosine-weighted direction on the +Z hemisphere. The height comes from the disk point's
/// squared radius as [`concentric_disk_and_radius2`] gives it, so its square root runs beside
/// the angle's polynomial instead of after it: a diffuse bounce waits on this before it can
/// trace.
#[inline]
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let (d, radius2) = concentric_disk_and_radius2(u);
    Vec3::new(d.x, d.y, (1.0 - radius2).max(0.0).sqrt())
}

/// Shirley–Chiu concentric map from the square to the unit disk.
#[inline]
pub fn concentric_disk(u: Vec2) -> Vec2 {
    concentric_disk_and_radius2(u).0
}

/// [`concentric_disk`], and its point's squared radius: the square's coordinate farther from
/// its centre, squared (the map keeps it as the radius), known before the angle is.
///
/// Which coordinate is farther is a coin flip for a branch predictor, so the two are ordered
/// by vector selections (in scalar code the compiler branched): the angle is π/4 times the
/// nearer over the farther, whose sine and cosine (|angle| ≤ π/4) go to the two axes in the
/// order chosen.
#[inline(always)]
fn concentric_disk_and_radius2(u: Vec2) -> (Vec2, f32) {
    let o = 2.0 * u - Vec2::ONE;
    let x_farther = Vec4::splat(o.x.abs()).cmpgt(Vec4::splat(o.y.abs()));
    let [farther, nearer, ..] = Vec4::select(
        x_farther,
        Vec4::new(o.x, o.y, 0.0, 0.0),
        Vec4::new(o.y, o.x, 0.0, 0.0),
    )
    .to_array();
    // Only the centre has a farther coordinate of zero.
    if farther == 0.0 {
        return (Vec2::ZERO, 0.0);
    }
    let (sin, cos) = sin_cos_within_quarter(FRAC_PI_4 * (nearer / farther));
    let (along, across) = (farther * cos, farther * sin);
    let [x, y, ..] = Vec4::select(
        x_farther,
        Vec4::new(along, across, 0.0, 0.0),
        Vec4::new(across, along, 0.0, 0.0),
    )
    .to_array();
    (Vec2::new(x, y), farther * farther)
}

/// sin x and cos x for |x| ≤ π/4 by their Taylor series, to x⁹ and x¹⁰: the first term left
/// out is below 2·10⁻⁹ there, under half an ulp of the results. A library call took 2% of the
/// Cornell box's time, every diffuse bounce drawing one. Horner's rule in fused multiply-adds,
/// with every coefficient a constant (a division by a constant stays a division), so each
/// step of the chain costs one instruction's latency (x86-64-v3, the build's baseline, and
/// AArch64 have the instruction).
#[inline]
fn sin_cos_within_quarter(x: f32) -> (f32, f32) {
    let x2 = x * x;
    let sin = [-1.0 / 5040.0, 1.0 / 120.0, -1.0 / 6.0, 1.0]
        .into_iter()
        .fold(1.0 / 362_880.0, |sum: f32, c| sum.mul_add(x2, c));
    let cos = [1.0 / 40_320.0, -1.0 / 720.0, 1.0 / 24.0, -0.5, 1.0]
        .into_iter()
        .fold(-1.0 / 3_628_800.0, |sum: f32, c| sum.mul_add(x2, c));
    (x * sin, cos)
}

/// Uniform barycentrics (b1, b2) on a triangle.
pub fn uniform_triangle(u: Vec2) -> (f32, f32) {
    let s = u.x.sqrt();
    (s * (1.0 - u.y), s * u.y)
}

/// Power heuristic (β = 2) weight of a strategy with pdf `a` against one with pdf `b`.
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2.is_infinite() {
        1.0
    } else if a2 + b2 == 0.0 {
        0.0
    } else {
        a2 / (a2 + b2)
    }
}

/// Walker/Vose alias table: O(1) sampling of a discrete distribution.
#[derive(Clone, Debug, Default)]
pub struct AliasTable {
    prob: Vec<f32>,
    alias: Vec<u32>,
    pmf: Vec<f32>,
}

impl AliasTable {
    /// From non-negative weights (at least one positive).
    pub fn new(weights: &[f64]) -> Self {
        let n = weights.len();
        let total: f64 = weights.iter().sum();
        let pmf: Vec<f32> = weights.iter().map(|w| (w / total) as f32).collect();
        let mut scaled: Vec<f64> = weights.iter().map(|w| w / total * n as f64).collect();
        let mut prob = vec![1.0f32; n];
        let mut alias: Vec<u32> = (0..n as u32).collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) =
            (0..n).partition(|&i| scaled[i] < 1.0);
        while let (Some(s), Some(&l)) = (small.pop(), large.last()) {
            prob[s] = scaled[s] as f32;
            alias[s] = l as u32;
            scaled[l] -= 1.0 - scaled[s];
            if scaled[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        Self { prob, alias, pmf }
    }

    /// Picks an index with one uniform number and returns that number rescaled to [0, 1)
    /// within the choice, so it can be used again (it keeps its stratification).
    pub fn sample(&self, u: f32) -> (usize, f32) {
        let n = self.prob.len();
        let x = u * n as f32;
        let i = (x as usize).min(n - 1);
        let frac = x - i as f32;
        let p = self.prob[i];
        let (index, rest) = if frac < p {
            (i, frac / p)
        } else {
            (self.alias[i] as usize, (frac - p) / (1.0 - p))
        };
        (index, rest.clamp(0.0, 1.0 - f32::EPSILON))
    }

    /// Probability of index `i`.
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf[i]
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.pmf.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }
}

/// The sample stream of one pixel sample. The dimensions that matter most (film position,
/// lens, and per bounce the light point and the BSDF direction) come four at a time from
/// Owen-scrambled Sobol (sobol_burley, one SIMD scramble per set) with a per-pixel seed, for the
/// first [`SOBOL_SETS`] sets: the camera and the first bounces, where stratification reduces
/// noise. Deeper sets, and decisions that gain nothing from stratification (which light, whether
/// to continue), come from a cheap hashed uniform stream, which also keeps unlimited path depth
/// well defined.
pub const SOBOL_SETS: u32 = 4;

pub struct SampleStream {
    /// The sample's index in its pixel, and the pixel's seed.
    index: u32,
    seed: u32,
    sobol: SobolSample,
    set: u32,
    /// State of the hashed stream (SplitMix64).
    uniform: u64,
}

impl SampleStream {
    /// Sample `index` of the pixel whose decorrelation seed is `seed`.
    pub fn new(index: u32, seed: u32) -> Self {
        Self {
            index,
            seed,
            sobol: SobolSample::new(index, seed),
            set: 0,
            uniform: ((seed as u64) << 32 | index as u64) ^ 0x5bd1_e995_9e37_79b9,
        }
    }

    /// Branch `k` of the `n` a path splits into at the bounce whose set was drawn last: the
    /// stream of sample index·`n` + `k` from that set on, so the branches of a pixel's samples
    /// take the sequence's first spp·`n` points there, stratified against each other (points
    /// repeat past 2¹⁶, unbiased but no longer stratified).
    pub fn branch(&self, k: u32, n: u32) -> Self {
        Self {
            set: self.set.saturating_sub(1),
            ..Self::new(self.index.wrapping_mul(n).wrapping_add(k), self.seed)
        }
    }

    /// The next four stratified numbers in [0, 1).
    pub fn next_4d(&mut self) -> [f32; 4] {
        let d = self.set;
        self.set += 1;
        if d < SOBOL_SETS {
            self.sobol.dimensions_4d(d as usize)
        } else {
            self.uniform_4d()
        }
    }

    /// The sample's time within the shutter, in [0, 1): a Sobol dimension of its own (the
    /// first one the bounces never reach), so motion blur is stratified too.
    pub fn time(&self) -> f32 {
        self.sobol.dimensions_4d(SOBOL_SETS as usize)[0]
    }

    /// Four independent uniform numbers in [0, 1) from the hashed stream: two SplitMix64
    /// outputs, 24 bits per number.
    pub fn uniform_4d(&mut self) -> [f32; 4] {
        let (a, b) = (self.next_u64(), self.next_u64());
        [unit(a), unit(a >> 32), unit(b), unit(b >> 32)]
    }

    /// One uniform number in [0, 1) from the hashed stream (its top 24 bits).
    pub fn uniform(&mut self) -> f32 {
        unit(self.next_u64() >> 40)
    }

    fn next_u64(&mut self) -> u64 {
        self.uniform = self.uniform.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.uniform;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
}

/// The low 24 bits of `bits` as a number in [0, 1).
fn unit(bits: u64) -> f32 {
    (bits & 0xff_ffff) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// A 32-bit integer hash (lowbias32).
pub fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alias_table_reproduces_weights() {
        let w = [1.0, 0.0, 3.0, 6.0];
        let t = AliasTable::new(&w);
        let mut counts = [0usize; 4];
        let n = 100_000;
        for i in 0..n {
            counts[t.sample((i as f32 + 0.5) / n as f32).0] += 1;
        }
        for (c, w) in counts.iter().zip(w) {
            assert!(
                (*c as f64 / n as f64 - w / 10.0).abs() < 0.002,
                "{counts:?}"
            );
        }
    }

    #[test]
    fn quarter_sines_and_cosines_match_the_library() {
        for k in -1000..=1000 {
            let x = FRAC_PI_4 * k as f32 / 1000.0;
            let (sin, cos) = sin_cos_within_quarter(x);
            assert!(
                (sin - x.sin()).abs() <= 1.5 * f32::EPSILON * x.sin().abs().max(0.5),
                "{x}"
            );
            assert!((cos - x.cos()).abs() <= 1.5 * f32::EPSILON, "{x}");
        }
    }

    #[test]
    fn the_concentric_map_is_shirley_and_chius() {
        // Their map as written: radius from the nearer axis, angle π/4 times the ratio.
        let reference = |u: Vec2| {
            let o = 2.0 * u - Vec2::ONE;
            let (r, theta) = if o == Vec2::ZERO {
                (0.0, 0.0)
            } else if o.x.abs() > o.y.abs() {
                (o.x, FRAC_PI_4 * (o.y / o.x))
            } else {
                (o.y, 2.0 * FRAC_PI_4 - FRAC_PI_4 * (o.x / o.y))
            };
            Vec2::new(r * theta.cos(), r * theta.sin())
        };
        for i in 0..=64 {
            for j in 0..=64 {
                let u = Vec2::new(i as f32 / 64.0, j as f32 / 64.0).min(Vec2::splat(0.999));
                let (got, want) = (concentric_disk(u), reference(u));
                assert!(
                    got.distance(want) <= 4.0 * f32::EPSILON,
                    "{u}: {got} against {want}"
                );
            }
        }
    }

    #[test]
    fn frames_are_orthonormal() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(0.3, -0.4, 0.866).normalize(),
            Vec3::new(0.0, 0.0, -1.0),
        ] {
            let f = Frame::new(n);
            assert!(
                f.s.dot(f.t).abs() < 1e-6
                    && f.s.dot(n).abs() < 1e-6
                    && (f.s.cross(f.t) - n).length() < 1e-5
            );
        }
    }
}
