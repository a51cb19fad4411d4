//! The directional albedo E(μ) of a dielectric interface's GGX reflection (the light a
//! specular layer or a clear coat reflects, the rest going on to the layers below), tabulated
//! once per masking-shadowing term over the cosine μ, the roughness and the index of
//! refraction, from rift's own sampling of the lobe so the layering matches what it scales.

use super::multiscatter::{N, cell, cell_of, cosine_weighted_mean, mu_at, per_shadowing};
use crate::material::microfacet::{Ggx, Shadowing, fresnel_dielectric, reflect};
use glam::{Vec2, Vec3};
use std::sync::OnceLock;

/// Table resolution in the index of refraction, over x = (ior − 1)/(ior + 1) in [0, 0.5]
/// (ior 1 to 3), in which the normal-incidence reflectance x² varies smoothly.
const IORS: usize = 16;
/// Strata per side of the sample square for each entry.
const STRATA: u32 = 32;
/// The largest index of refraction the table holds; beyond it the last row is used.
pub const MAX_IOR: f32 = 3.0;

/// The table of one masking-shadowing term, one index of refraction at a time: each is built
/// the first time a shading point needs it. A scene's materials use one or two indices, and
/// building all sixteen (16.8 M samples of the lobe) had cost every process that rendered a
/// coat 0.7 s of CPU before its first pixel.
struct Table {
    shadowing: Shadowing,
    iors: [OnceLock<IorTable>; IORS],
}

/// E(μ) per roughness for one index of refraction, and its cosine-weighted mean per roughness.
struct IorTable {
    albedo: [[f32; N]; N],
    mean: [f32; N],
}

/// E(μ) of the reflection of a dielectric of index `ior` (outside over inside is 1/ior) with
/// microfacets `ggx`.
pub fn dielectric_albedo(ior: f32, ggx: Ggx, mu: f32) -> f32 {
    table(ggx.shadowing).bilinear(ior, ggx, |t, r| {
        let (m0, m1, fm) = cell(mu * N as f32 - 0.5);
        t.albedo[r][m0] * (1.0 - fm) + t.albedo[r][m1] * fm
    })
}

/// 2∫E(μ)μ dμ, the cosine-weighted mean of [`dielectric_albedo`].
pub fn dielectric_mean_albedo(ior: f32, ggx: Ggx) -> f32 {
    table(ggx.shadowing).bilinear(ior, ggx, |t, r| t.mean[r])
}

impl Table {
    fn new(shadowing: Shadowing) -> Self {
        Self {
            shadowing,
            iors: std::array::from_fn(|_| OnceLock::new()),
        }
    }

    /// The table of index row `i`, built on first use. Built on the calling thread alone: it
    /// may be a render worker, and a parallel build there could have that worker, while it
    /// waits, take another pixel's work that needs the same row (a reentrant initialisation).
    fn ior(&self, i: usize) -> &IorTable {
        self.iors[i].get_or_init(|| {
            let ior = ior_at(i);
            let mut albedo = [[0.0; N]; N];
            for (r, row) in albedo.iter_mut().enumerate() {
                let ggx =
                    Ggx::from_roughness(r as f32 / (N - 1) as f32).with_shadowing(self.shadowing);
                *row = std::array::from_fn(|k| sampled_albedo(ior, ggx, mu_at(k)));
            }
            IorTable {
                mean: std::array::from_fn(|r| cosine_weighted_mean(&albedo[r])),
                albedo,
            }
        })
    }

    /// `at(table, roughness row)` interpolated bilinearly between the four rows around
    /// (ior, roughness).
    fn bilinear(&self, ior: f32, ggx: Ggx, at: impl Fn(&IorTable, usize) -> f32) -> f32 {
        let ior = ior.clamp(1.0, MAX_IOR);
        let x = (ior - 1.0) / (ior + 1.0);
        let (i0, i1, fi) = cell_of(x * 2.0 * (IORS - 1) as f32, IORS);
        let (r0, r1, fr) = cell(ggx.alpha.sqrt() * (N - 1) as f32);
        let at_ior = |i: usize| {
            let t = self.ior(i);
            at(t, r0) * (1.0 - fr) + at(t, r1) * fr
        };
        at_ior(i0) * (1.0 - fi) + at_ior(i1) * fi
    }
}

/// The index of refraction at table row `i`.
fn ior_at(i: usize) -> f32 {
    let x = 0.5 * i as f32 / (IORS - 1) as f32;
    (1.0 + x) / (1.0 - x)
}

/// E(μ) by stratified sampling of visible normals: the mean of F·G2/G1 over reflections that
/// stay above the surface.
fn sampled_albedo(ior: f32, ggx: Ggx, mu: f32) -> f32 {
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let mut total = 0.0f64;
    for i in 0..STRATA {
        for j in 0..STRATA {
            let u = Vec2::new(
                (i as f32 + 0.5) / STRATA as f32,
                (j as f32 + 0.5) / STRATA as f32,
            );
            let h = ggx.sample_visible(wo, u);
            let wi = reflect(wo, h);
            if wi.z > 0.0 {
                let f = fresnel_dielectric(wo.dot(h), ior);
                total += (f * ggx.g2(wo, wi) / ggx.g1(wo)) as f64;
            }
        }
    }
    (total / (STRATA * STRATA) as f64) as f32
}

fn table(shadowing: Shadowing) -> &'static Table {
    static TABLES: [OnceLock<Table>; 2] = [OnceLock::new(), OnceLock::new()];
    per_shadowing(&TABLES, shadowing, Table::new)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth interface reflects its Fresnel term; an index of 1 reflects nothing; the table
    /// agrees with fresh sampling between its rows.
    #[test]
    fn the_table_holds_the_lobes_albedo() {
        let smooth = Ggx::from_roughness(0.0);
        for mu in [0.2f32, 0.5, 0.9] {
            let e = dielectric_albedo(1.5, smooth, mu);
            let f = fresnel_dielectric(mu, 1.5);
            assert!((e - f).abs() < 0.01, "μ {mu}: {e} against Fresnel {f}");
            assert!(dielectric_albedo(1.0, Ggx::from_roughness(0.5), mu) < 1e-4);
        }
        for (ior, roughness, mu) in [
            (1.45f32, 0.37f32, 0.61f32),
            (2.2, 0.73, 0.33),
            (1.33, 0.1, 0.8),
        ] {
            let ggx = Ggx::from_roughness(roughness);
            let table = dielectric_albedo(ior, ggx, mu);
            let fresh = sampled_albedo(ior, ggx, mu);
            assert!(
                (table - fresh).abs() < 0.004 + 0.03 * fresh,
                "ior {ior} roughness {roughness} μ {mu}: table {table}, sampled {fresh}"
            );
        }
    }
}
