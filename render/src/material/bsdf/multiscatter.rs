//! Energy compensation for rough conductors (Kulla & Conty 2017): single-scattering GGX drops
//! the light that bounces between facets before leaving (a white conductor keeps 88% at
//! roughness 0.5 and 41% at roughness 1; `rift bench furnace`). The missing energy is added
//! back as a second, diffuse-like lobe
//!
//!   f_ms(wo, wi) = F_ms · (1 − E(μo)) (1 − E(μi)) / (π (1 − E_avg)),
//!
//! where E(μ) is the single-scattering directional albedo with Fresnel 1 and E_avg = 2∫E(μ)μ dμ
//! its cosine-weighted mean, so that a white conductor's albedo is exactly 1 at every angle
//! (∫ f_ms μi dωi = 1 − E(μo)). The colour F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg)) sums the
//! Fresnel-weighted series of extra bounces (F_avg: the cosine-weighted mean Fresnel term), so
//! coloured metals also grow more saturated with roughness, as real ones do.
//!
//! E(μ) comes from rift's own BSDF sampling, tabulated once per masking-shadowing term on first
//! use, so the compensation matches the lobe it completes exactly.

use crate::material::bsdf::{Bsdf, Side};
use crate::material::microfacet::{ConductorFresnel, Ggx, SMOOTH_ALPHA, Shadowing};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;
use std::sync::OnceLock;

/// Table resolution in μ and in roughness.
pub(super) const N: usize = 32;
/// Strata per side of the sample square for each table entry.
const STRATA: u32 = 48;

/// The added lobe of one rough conductor: everything that does not depend on the directions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Multiscatter {
    /// F_ms / (π (1 − E_avg)).
    scale: Vec3,
}

/// E(μ) per roughness row, and E_avg per row.
struct Table {
    albedo: Vec<[f32; N]>,
    mean: [f32; N],
}

impl Multiscatter {
    /// The compensation for a conductor with this Fresnel term and distribution; `None` when
    /// smooth (a mirror loses nothing).
    pub fn new(fresnel: &ConductorFresnel, ggx: Ggx) -> Option<Self> {
        if ggx.alpha <= SMOOTH_ALPHA {
            return None;
        }
        let e_avg = table(ggx.shadowing).mean_at(ggx.alpha.sqrt());
        let f_avg = mean_fresnel(fresnel);
        let f_ms = f_avg * f_avg * e_avg / (Vec3::ONE - f_avg * (1.0 - e_avg));
        Some(Self {
            scale: f_ms * (FRAC_1_PI / (1.0 - e_avg).max(1e-4)),
        })
    }

    /// f_ms(wo, wi)·cos θi (local frame, both above the surface).
    pub fn eval(&self, ggx: Ggx, wo: Vec3, wi: Vec3) -> Vec3 {
        if wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let t = table(ggx.shadowing);
        let r = ggx.alpha.sqrt();
        self.scale * ((1.0 - t.albedo_at(wo.z, r)) * (1.0 - t.albedo_at(wi.z, r)) * wi.z)
    }

    /// The probability of sampling this lobe rather than the specular one: its share of the
    /// energy at `wo` for a white conductor.
    pub fn choice(ggx: Ggx, wo: Vec3) -> f32 {
        (1.0 - table(ggx.shadowing).albedo_at(wo.z, ggx.alpha.sqrt())).clamp(0.0, 0.95)
    }
}

/// The cosine-weighted mean Fresnel term 2∫F(μ)μ dμ (Gauss–Legendre in μ).
fn mean_fresnel(fresnel: &ConductorFresnel) -> Vec3 {
    const NODES: [(f32, f32); 4] = [
        (0.069_431_84, 0.173_927_42),
        (0.330_009_5, 0.326_072_58),
        (0.669_990_5, 0.326_072_58),
        (0.930_568_16, 0.173_927_42),
    ];
    NODES
        .iter()
        .map(|&(mu, w)| fresnel.reflectance(mu) * (2.0 * mu * w))
        .sum()
}

impl Table {
    fn build(shadowing: Shadowing) -> Self {
        let mut albedo = Vec::with_capacity(N);
        let mut mean = [0.0; N];
        for (row, m) in mean.iter_mut().enumerate() {
            let ggx = Ggx::from_roughness(row as f32 / (N - 1) as f32).with_shadowing(shadowing);
            let white = Bsdf::Conductor {
                fresnel: ConductorFresnel::Schlick(Vec3::ONE),
                ggx,
                multiscatter: None,
            };
            let e = albedo_row(&white, Side::Front, STRATA);
            *m = cosine_weighted_mean(&e);
            albedo.push(e);
        }
        Self { albedo, mean }
    }

    /// E(μ) at roughness `r`, bilinear between table entries.
    fn albedo_at(&self, mu: f32, r: f32) -> f32 {
        let (r0, r1, fr) = cell(r * (N - 1) as f32);
        let (m0, m1, fm) = cell(mu * N as f32 - 0.5);
        let row = |i: usize| self.albedo[i][m0] * (1.0 - fm) + self.albedo[i][m1] * fm;
        row(r0) * (1.0 - fr) + row(r1) * fr
    }

    /// E_avg at roughness `r`.
    fn mean_at(&self, r: f32) -> f32 {
        let (r0, r1, fr) = cell(r * (N - 1) as f32);
        self.mean[r0] * (1.0 - fr) + self.mean[r1] * fr
    }
}

/// The table cosine at column `k` (cell centres: μ = 0 itself has no albedo).
pub(super) fn mu_at(k: usize) -> f32 {
    (k as f32 + 0.5) / N as f32
}

/// The two table indices around a continuous coordinate, and the weight of the second.
pub(super) fn cell(x: f32) -> (usize, usize, f32) {
    cell_of(x, N)
}

/// [`cell`] over `count` entries.
pub(super) fn cell_of(x: f32, count: usize) -> (usize, usize, f32) {
    let x = x.clamp(0.0, (count - 1) as f32);
    let i = (x as usize).min(count - 2);
    (i, i + 1, x - i as f32)
}

/// E(μ) of `bsdf` from `side` at the table's cosines.
fn albedo_row(bsdf: &Bsdf, side: Side, strata: u32) -> [f32; N] {
    std::array::from_fn(|k| directional_albedo(bsdf, side, mu_at(k), strata))
}

/// 2∫E(μ)μ dμ from E at the table's cosines (the midpoint rule).
pub(super) fn cosine_weighted_mean(row: &[f32; N]) -> f32 {
    row.iter()
        .enumerate()
        .map(|(k, e)| 2.0 * e * mu_at(k))
        .sum::<f32>()
        / N as f32
}

/// The cosine-weighted mean albedo of `bsdf` seen from `side` (what a white furnace keeps
/// under uniform light), on `strata`² samples per angle.
pub fn mean_albedo(bsdf: &Bsdf, side: Side, strata: u32) -> f32 {
    cosine_weighted_mean(&albedo_row(bsdf, side, strata))
}

/// Directional albedo of `bsdf` from `side` at cosine `mu`: the mean of its sampled weights
/// on `strata`² stratified samples (times η² after refraction, undoing radiance compression).
pub fn directional_albedo(bsdf: &Bsdf, side: Side, mu: f32, strata: u32) -> f32 {
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let mut total = 0.0f64;
    for i in 0..strata {
        for j in 0..strata {
            let u = Vec2::new(
                (i as f32 + 0.5) / strata as f32,
                (j as f32 + 0.5) / strata as f32,
            );
            // The lobe choice runs on its own low-discrepancy sequence.
            let u_lobe = ((i * strata + j) as f32 * 0.618_034).fract();
            if let Some(s) = bsdf.sample(wo, u, u_lobe, side) {
                total += (s.weight.x * s.eta * s.eta) as f64;
            }
        }
    }
    (total / (strata * strata) as f64) as f32
}

fn table(shadowing: Shadowing) -> &'static Table {
    static TABLES: [OnceLock<Table>; 2] = [OnceLock::new(), OnceLock::new()];
    per_shadowing(&TABLES, shadowing, Table::build)
}

/// The table of `tables` for `shadowing`, built with `build` the first time it is asked for.
pub(super) fn per_shadowing<T>(
    tables: &'static [OnceLock<T>; 2],
    shadowing: Shadowing,
    build: fn(Shadowing) -> T,
) -> &'static T {
    let slot = match shadowing {
        Shadowing::HeightCorrelated => &tables[0],
        Shadowing::Separable => &tables[1],
    };
    slot.get_or_init(|| build(shadowing))
}
