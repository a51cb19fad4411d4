//! The isotropic GGX (Trowbridge–Reitz) microfacet distribution with height-correlated masking
//! and shadowing, visible-normal sampling (Heitz 2018), and the Fresnel terms. All in the local
//! shading frame, +Z the macro normal.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Below this α a surface is treated as perfectly smooth (a Dirac lobe).
pub const SMOOTH_ALPHA: f32 = 1e-3;

/// GGX with width α = roughness².
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ggx {
    pub alpha: f32,
    pub shadowing: Shadowing,
}

/// How Smith's masking of the outgoing direction and shadowing of the incident one combine.
///
/// With microsurface heights h of cumulative distribution C, a direction w leaves height h
/// unblocked with probability C(h)^Λ(w) going up and (1 − C(h))^Λ(w) going down, so averaging
/// over the height of the scattering point gives ∫ C^(Λo+Λi) dC = 1/(1 + Λo + Λi) for
/// reflection, and for refraction ∫ C^Λo (1 − C)^Λi dC = B(1 + Λo, 1 + Λi), a Beta function
/// that is smaller still. rift follows pbrt-v4 and Cycles in using the reflection form for both
/// lobes (the two agree to second order in Λ, i.e. away from grazing angles).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Shadowing {
    /// 1/(1 + Λ(wo) + Λ(wi)): a facet seen from one direction is likely high, so likely seen
    /// from the other too. Brighter at grazing angles than `Separable`, and closer to measured
    /// and simulated microsurfaces.
    #[default]
    HeightCorrelated,
    /// The product G1(wo)·G1(wi), as Mitsuba 3 uses: for matching looks made there.
    Separable,
}

impl Ggx {
    /// From the artist's roughness in [0, 1] (perceptually linear: α = roughness²).
    pub fn from_roughness(roughness: f32) -> Self {
        Self {
            alpha: (roughness * roughness).max(SMOOTH_ALPHA),
            shadowing: Shadowing::HeightCorrelated,
        }
    }

    /// The same width with another masking-shadowing term.
    pub fn with_shadowing(self, shadowing: Shadowing) -> Self {
        Self { shadowing, ..self }
    }

    /// Normal distribution D(h).
    pub fn d(&self, h: Vec3) -> f32 {
        if h.z <= 0.0 {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        let k = h.z * h.z * (a2 - 1.0) + 1.0;
        a2 / (PI * k * k)
    }

    /// Smith Λ(w).
    fn lambda(&self, w: Vec3) -> f32 {
        let cos2 = w.z * w.z;
        if cos2 <= 0.0 {
            return f32::INFINITY;
        }
        let tan2 = (1.0 - cos2).max(0.0) / cos2;
        0.5 * ((1.0 + self.alpha * self.alpha * tan2).sqrt() - 1.0)
    }

    /// Masking G1(w).
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Masking-shadowing G2(wo, wi), as `shadowing` says.
    pub fn g2(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self.shadowing {
            Shadowing::HeightCorrelated => 1.0 / (1.0 + self.lambda(wo) + self.lambda(wi)),
            Shadowing::Separable => self.g1(wo) * self.g1(wi),
        }
    }

    /// Density of visible normals seen from `wo` (wo.z > 0): G1(wo)·max(0, wo·h)·D(h)/wo.z.
    pub fn pdf_visible(&self, wo: Vec3, h: Vec3) -> f32 {
        self.g1(wo) * wo.dot(h).max(0.0) * self.d(h) / wo.z
    }

    /// Samples a visible normal from `wo` (wo.z > 0).
    pub fn sample_visible(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let a = self.alpha;
        // Stretch to the hemisphere configuration, sample the projected area there, unstretch.
        let v = Vec3::new(a * wo.x, a * wo.y, wo.z).normalize();
        let len2 = v.x * v.x + v.y * v.y;
        let t1 = if len2 > 0.0 {
            Vec3::new(-v.y, v.x, 0.0) / len2.sqrt()
        } else {
            Vec3::X
        };
        let t2 = v.cross(t1);
        let r = u.x.sqrt();
        let phi = 2.0 * PI * u.y;
        let p1 = r * phi.cos();
        let mut p2 = r * phi.sin();
        let s = 0.5 * (1.0 + v.z);
        p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2;
        let n = t1 * p1 + t2 * p2 + v * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
        Vec3::new(a * n.x, a * n.y, n.z.max(1e-6)).normalize()
    }
}

/// Mirror of `w` about `n`.
pub fn reflect(w: Vec3, n: Vec3) -> Vec3 {
    2.0 * w.dot(n) * n - w
}

/// Refraction of `w` (on the side `n` points to) into the other side, for `eta` = IOR of the
/// other side over IOR of `w`'s side; `None` under total internal reflection.
pub fn refract(w: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = w.dot(n);
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(-w / eta + (cos_i / eta - cos_t) * n)
}

/// Unpolarised Fresnel reflectance of a dielectric boundary for incidence cosine `cos_i` ≥ 0 and
/// `eta` = IOR beyond over IOR before; 1 under total internal reflection.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let parallel = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let perpendicular = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (parallel * parallel + perpendicular * perpendicular)
}

/// Schlick's Fresnel for a conductor with normal-incidence reflectance `f0`.
pub fn fresnel_schlick(f0: Vec3, cos_i: f32) -> Vec3 {
    let m = (1.0 - cos_i.clamp(0.0, 1.0)).powi(5);
    f0 + (Vec3::ONE - f0) * m
}

/// Exact unpolarised Fresnel reflectance of a conductor with complex index `eta` + i`k`
/// (relative to the outside), per channel, for incidence cosine `cos_i`. With k = 0 it is the
/// dielectric term; at normal incidence ((η−1)² + k²)/((η+1)² + k²).
///
/// Writing the transmitted cosine's complex square root as a + ib (with s² = sin²θ):
/// a² + b² = √((η² − k² − s²)² + 4η²k²) and a² = ½(a² + b² + η² − k² − s²); then
/// R⊥ = (a² + b² − 2a cosθ + cos²θ)/(a² + b² + 2a cosθ + cos²θ) and
/// R∥ = R⊥·(cos²θ(a² + b²) − 2a cosθ s² + s⁴)/(cos²θ(a² + b²) + 2a cosθ s² + s⁴).
pub fn fresnel_conductor(cos_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
    let c = cos_i.clamp(0.0, 1.0);
    let (c2, s2) = (c * c, (1.0 - c * c).max(0.0));
    let t = eta * eta - k * k - Vec3::splat(s2);
    let a2b2 = (t * t + 4.0 * eta * eta * k * k).powf(0.5);
    let a = (0.5 * (a2b2 + t)).max(Vec3::ZERO).powf(0.5);
    let perpendicular =
        (a2b2 - 2.0 * c * a + Vec3::splat(c2)) / (a2b2 + 2.0 * c * a + Vec3::splat(c2));
    let cross = 2.0 * c * s2 * a;
    let parallel = perpendicular * (c2 * a2b2 - cross + Vec3::splat(s2 * s2))
        / (c2 * a2b2 + cross + Vec3::splat(s2 * s2));
    (0.5 * (perpendicular + parallel)).clamp(Vec3::ZERO, Vec3::ONE)
}

/// How a conductor's reflectance varies with the angle of incidence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConductorFresnel {
    /// Schlick's approximation from the colour at normal incidence (an artist's colour).
    Schlick(Vec3),
    /// The exact term from a complex index of refraction per channel (measured metals).
    Complex { eta: Vec3, k: Vec3 },
}

impl ConductorFresnel {
    /// Reflectance for incidence cosine `cos_i`.
    pub fn reflectance(&self, cos_i: f32) -> Vec3 {
        match *self {
            ConductorFresnel::Schlick(f0) => fresnel_schlick(f0, cos_i),
            ConductorFresnel::Complex { eta, k } => fresnel_conductor(cos_i, eta, k),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distribution_projects_to_one() {
        // ∫ D(h) cos θh dh = 1 over the hemisphere, for several widths.
        for alpha in [0.05f32, 0.3, 0.8] {
            let g = Ggx {
                alpha,
                shadowing: Shadowing::default(),
            };
            let n = 4000;
            let mut sum = 0.0f64;
            for i in 0..n {
                // Midpoint rule in θ over the hemisphere; φ integrates to 2π.
                let dtheta = std::f64::consts::FRAC_PI_2 / n as f64;
                let theta = (i as f64 + 0.5) * dtheta;
                let (s, c) = theta.sin_cos();
                let d = g.d(glam::DVec3::new(s, 0.0, c).as_vec3()) as f64;
                sum += d * c * s * dtheta * 2.0 * std::f64::consts::PI;
            }
            assert!((sum - 1.0).abs() < 0.01, "alpha {alpha}: {sum}");
        }
    }

    #[test]
    fn visible_normals_follow_their_density() {
        // `pdf_visible` integrates to 1 (by quadrature), and the sampler's mean normal equals
        // the mean under that density, so a sampler that draws from another density is caught.
        for (alpha, wo) in [
            (0.4, Vec3::new(0.6, 0.1, 0.79)),
            (0.1, Vec3::new(0.0, 0.2, 0.98)),
            (0.9, Vec3::new(0.95, 0.0, 0.3)),
        ] {
            let g = Ggx {
                alpha,
                shadowing: Shadowing::default(),
            };
            let wo = wo.normalize();
            let n = 600;
            let (mut total, mut mean_pdf) = (0.0f64, glam::DVec3::ZERO);
            for i in 0..n {
                for j in 0..n {
                    let c = (i as f64 + 0.5) / n as f64;
                    let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / n as f64;
                    let s = (1.0 - c * c).sqrt();
                    let h = glam::DVec3::new(s * phi.cos(), s * phi.sin(), c);
                    let w = g.pdf_visible(wo, h.as_vec3()) as f64 * 2.0 * std::f64::consts::PI
                        / (n * n) as f64;
                    total += w;
                    mean_pdf += h * w;
                }
            }
            assert!((total - 1.0).abs() < 0.01, "alpha {alpha}: ∫pdf = {total}");
            let m = 256;
            let mut mean_sampled = glam::DVec3::ZERO;
            for i in 0..m {
                for j in 0..m {
                    let u = Vec2::new((i as f32 + 0.5) / m as f32, (j as f32 + 0.5) / m as f32);
                    let h = g.sample_visible(wo, u);
                    assert!(h.z > 0.0 && (h.length() - 1.0).abs() < 1e-4);
                    mean_sampled += h.as_dvec3() / (m * m) as f64;
                }
            }
            assert!(
                (mean_sampled - mean_pdf).abs().max_element() < 0.01,
                "alpha {alpha}: sampled mean {mean_sampled}, density mean {mean_pdf}"
            );
        }
    }

    #[test]
    fn fresnel_limits() {
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-4);
        assert_eq!(
            fresnel_dielectric(0.1, 1.0 / 1.5),
            1.0,
            "total internal reflection"
        );
        assert!((fresnel_dielectric(0.0, 1.5) - 1.0).abs() < 1e-4);
        let t = refract(Vec3::new(0.6, 0.0, 0.8), Vec3::Z, 1.5).unwrap();
        assert!((t.length() - 1.0).abs() < 1e-5 && t.z < 0.0);
        assert!((0.6f32 / t.x.abs() - 1.5).abs() < 1e-4, "Snell's law");
    }

    #[test]
    fn conductor_fresnel_limits() {
        let (eta, k) = (Vec3::new(0.2, 0.9, 1.5), Vec3::new(3.0, 2.4, 0.0));
        let normal = fresnel_conductor(1.0, eta, k);
        let expected = ((eta - 1.0) * (eta - 1.0) + k * k) / ((eta + 1.0) * (eta + 1.0) + k * k);
        assert!(
            (normal - expected).abs().max_element() < 1e-5,
            "{normal} vs {expected}"
        );
        assert!(
            (fresnel_conductor(0.0, eta, k) - Vec3::ONE)
                .abs()
                .max_element()
                < 1e-5
        );
        // k = 0 is a dielectric seen from outside, at every angle.
        for cos in [0.05f32, 0.3, 0.7, 0.95] {
            let c = fresnel_conductor(cos, Vec3::splat(1.5), Vec3::ZERO);
            let d = fresnel_dielectric(cos, 1.5);
            assert!(
                (c - Vec3::splat(d)).abs().max_element() < 1e-5,
                "cos {cos}: {c} vs {d}"
            );
        }
    }
}
