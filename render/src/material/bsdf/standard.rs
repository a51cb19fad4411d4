//! The standard layered material most production surfaces are (UsdPreviewSurface, an MTL's
//! Kd + Ks, Blender's Principled BSDF): a diffuse base under a dielectric specular layer, blended
//! with a metal by `metallic`, all under an optional clear coat.
//!
//! Energy is kept by albedo scaling with tabulated directional albedos ([`super::albedo`]):
//! - The base: the specular layer's GGX reflection (Fresnel of `ior`, tinted by
//!   `specular_color`) over a Lambertian lobe `base_color/π · (1 − E(μo))(1 − E(μi)) / (1 −
//!   E_avg)`, E the specular layer's directional albedo and E_avg its cosine-weighted mean. This
//!   diffuse lobe is reciprocal and reflects `base_color · (1 − E(μo))`, exactly the light the
//!   specular layer lets through, so a white base under an untinted layer reflects everything.
//! - The metal: a GGX conductor with Schlick's Fresnel from `base_color`, its inter-facet light
//!   added back ([`Multiscatter`]).
//! - The coat: a second dielectric GGX reflection (`coat_ior`, `coat_roughness`) weighted by
//!   `coat`, over the rest scaled by `1 − coat · E_coat(μo)` (the form Autodesk Standard
//!   Surface and OpenPBR use): a white surface under a coat still reflects everything.
//!
//! Sampling picks a lobe in proportion to its albedo at `wo` and weighs the sample by the whole
//! BSDF over the mixture's density; smooth layers are Dirac lobes sharing the mirror direction.

use super::albedo::{dielectric_albedo, dielectric_mean_albedo};
use super::multiscatter::Multiscatter;
use super::{BsdfSample, conductor_specular};
use crate::material::microfacet::{
    ConductorFresnel, Ggx, SMOOTH_ALPHA, fresnel_dielectric, fresnel_schlick, reflect,
};
use crate::sampling::cosine_hemisphere;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// The standard layered material's inputs, and what follows from them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Standard {
    /// The diffuse base's albedo, and the metal's colour at normal incidence.
    pub base_color: Vec3,
    /// 0: a dielectric (plastic, paint, wood); 1: a metal.
    pub metallic: f32,
    /// Tints the specular layer's reflection (white: an untinted dielectric).
    pub specular_color: Vec3,
    /// The specular layer's index of refraction, 1 to 3.
    pub ior: f32,
    /// The specular layer's and the metal's microfacets.
    pub ggx: Ggx,
    /// The clear coat's weight, 0 to 1.
    pub coat: f32,
    pub coat_ggx: Ggx,
    pub coat_ior: f32,
    /// The metal's inter-facet lobe (none when smooth).
    multiscatter: Option<Multiscatter>,
    /// 1 / (π (1 − E_avg)) of the specular layer: the diffuse lobe's normalisation.
    diffuse_scale: f32,
}

/// The probability of each lobe at one outgoing direction, and the weights the layers above
/// leave it.
struct Lobes {
    /// 1 − coat · E_coat(μo): what the coat lets through to the layers below.
    below: f32,
    /// E(μo) of the specular layer.
    specular_albedo: f32,
    /// Choice probabilities: coat, metal specular, metal inter-facet, dielectric specular,
    /// diffuse. They sum to 1.
    p: [f32; 5],
}

const COAT: usize = 0;
const METAL: usize = 1;
const METAL_MS: usize = 2;
const SPECULAR: usize = 3;
const DIFFUSE: usize = 4;

impl Standard {
    /// The material from its inputs (each already within its range).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        base_color: Vec3,
        metallic: f32,
        specular_color: Vec3,
        ior: f32,
        ggx: Ggx,
        coat: f32,
        coat_ggx: Ggx,
        coat_ior: f32,
    ) -> Self {
        let mut s = Self {
            base_color,
            metallic,
            specular_color,
            ior,
            ggx,
            coat,
            coat_ggx,
            coat_ior,
            multiscatter: None,
            diffuse_scale: 0.0,
        };
        s.refresh();
        s
    }

    /// Works out again what follows from the inputs, after a texture changed them.
    pub fn refresh(&mut self) {
        self.multiscatter = match self.metallic > 0.0 {
            true => Multiscatter::new(&ConductorFresnel::Schlick(self.base_color), self.ggx),
            false => None,
        };
        let e_avg = dielectric_mean_albedo(self.ior, self.ggx);
        self.diffuse_scale = FRAC_1_PI / (1.0 - e_avg).max(1e-4);
    }

    /// The diffuse base's colour (for the albedo AOV): the base colour, blended to the metal's.
    pub fn albedo(&self) -> Vec3 {
        self.base_color
    }

    /// The directional albedo of a dielectric reflection at cosine `mu`: tabulated when rough,
    /// the Fresnel term itself when smooth.
    fn albedo_of(ior: f32, ggx: Ggx, mu: f32) -> f32 {
        match ggx.alpha <= SMOOTH_ALPHA {
            true => fresnel_dielectric(mu, ior),
            false => dielectric_albedo(ior, ggx, mu),
        }
    }

    fn lobes(&self, wo: Vec3) -> Lobes {
        let coat_albedo = match self.coat > 0.0 {
            true => self.coat * Self::albedo_of(self.coat_ior, self.coat_ggx, wo.z),
            false => 0.0,
        };
        let below = 1.0 - coat_albedo;
        let specular_albedo = Self::albedo_of(self.ior, self.ggx, wo.z);
        let luminance = |c: Vec3| c.dot(Vec3::new(0.2126, 0.7152, 0.0722));
        let metal = below * self.metallic * luminance(fresnel_schlick(self.base_color, wo.z));
        let ms_share = match self.multiscatter {
            Some(_) => Multiscatter::choice(self.ggx, wo),
            None => 0.0,
        };
        let dielectric = below * (1.0 - self.metallic);
        let mut p = [
            coat_albedo,
            metal * (1.0 - ms_share),
            metal * ms_share,
            dielectric * luminance(self.specular_color) * specular_albedo,
            dielectric * luminance(self.base_color) * (1.0 - specular_albedo),
        ];
        let total: f32 = p.iter().sum();
        if total > 0.0 {
            p.iter_mut().for_each(|x| *x /= total);
        } else {
            p = [0.0, 0.0, 0.0, 0.0, 1.0];
        }
        Lobes {
            below,
            specular_albedo,
            p,
        }
    }

    /// f(wo, wi)·cos θi of the rough lobes (the smooth ones are Dirac lobes, sampled only).
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let lobes = self.lobes(wo);
        self.eval_with(&lobes, wo, wi)
    }

    fn eval_with(&self, lobes: &Lobes, wo: Vec3, wi: Vec3) -> Vec3 {
        let mut f = Vec3::ZERO;
        if self.coat > 0.0 && self.coat_ggx.alpha > SMOOTH_ALPHA {
            f += Vec3::splat(
                self.coat * dielectric_reflection(self.coat_ior, self.coat_ggx, wo, wi),
            );
        }
        let below = lobes.below;
        if self.metallic > 0.0 {
            let fresnel = ConductorFresnel::Schlick(self.base_color);
            let mut metal = Vec3::ZERO;
            if self.ggx.alpha > SMOOTH_ALPHA {
                metal += conductor_specular(&fresnel, &self.ggx, wo, wi);
            }
            if let Some(ms) = self.multiscatter {
                metal += ms.eval(self.ggx, wo, wi);
            }
            f += metal * (below * self.metallic);
        }
        if self.metallic < 1.0 {
            let weight = below * (1.0 - self.metallic);
            if self.ggx.alpha > SMOOTH_ALPHA {
                let r = dielectric_reflection(self.ior, self.ggx, wo, wi);
                f += self.specular_color * (weight * r);
            }
            let e_i = Self::albedo_of(self.ior, self.ggx, wi.z);
            let diffuse = (1.0 - lobes.specular_albedo) * (1.0 - e_i) * self.diffuse_scale * wi.z;
            f += self.base_color * (weight * diffuse);
        }
        f
    }

    /// The density of sampling `wi` among the rough lobes (the smooth ones have none).
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wi.z <= 0.0 {
            return 0.0;
        }
        self.pdf_with(&self.lobes(wo), wo, wi)
    }

    fn pdf_with(&self, lobes: &Lobes, wo: Vec3, wi: Vec3) -> f32 {
        let p = &lobes.p;
        let mut pdf = (p[DIFFUSE] + p[METAL_MS]) * wi.z * FRAC_1_PI;
        let h = (wo + wi).normalize();
        let glossy = |ggx: &Ggx| match ggx.alpha > SMOOTH_ALPHA {
            true => ggx.pdf_visible(wo, h) / (4.0 * wo.dot(h)),
            false => 0.0,
        };
        if p[COAT] > 0.0 {
            pdf += p[COAT] * glossy(&self.coat_ggx);
        }
        if p[METAL] + p[SPECULAR] > 0.0 {
            pdf += (p[METAL] + p[SPECULAR]) * glossy(&self.ggx);
        }
        pdf
    }

    /// Samples a direction: a lobe chosen with `u_lobe`, its direction drawn with `u`.
    pub fn sample(&self, wo: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        let lobes = self.lobes(wo);
        let p = &lobes.p;
        let mut lobe = 0;
        let mut start = 0.0;
        while lobe < DIFFUSE && u_lobe >= start + p[lobe] {
            start += p[lobe];
            lobe += 1;
        }
        let ggx = if lobe == COAT {
            self.coat_ggx
        } else {
            self.ggx
        };
        let smooth = ggx.alpha <= SMOOTH_ALPHA;
        if smooth && matches!(lobe, COAT | METAL | SPECULAR) {
            return self.sample_mirror(&lobes, wo);
        }
        let wi = match lobe {
            METAL_MS | DIFFUSE => cosine_hemisphere(u),
            _ => reflect(wo, ggx.sample_visible(wo, u)),
        };
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf_with(&lobes, wo, wi);
        (pdf > 0.0).then(|| BsdfSample {
            wi: wi.into(),
            weight: (self.eval_with(&lobes, wo, wi) / pdf).into(),
            pdf,
            delta: false,
            eta: 1.0,
        })
    }

    /// The mirror direction, for the smooth layers: all of them reflect there, so the sample
    /// carries their sum over the probability of choosing any of them.
    fn sample_mirror(&self, lobes: &Lobes, wo: Vec3) -> Option<BsdfSample> {
        let mut value = Vec3::ZERO;
        let mut chance = 0.0;
        if self.coat > 0.0 && self.coat_ggx.alpha <= SMOOTH_ALPHA {
            value += Vec3::splat(self.coat * fresnel_dielectric(wo.z, self.coat_ior));
            chance += lobes.p[COAT];
        }
        if self.ggx.alpha <= SMOOTH_ALPHA {
            let metal = fresnel_schlick(self.base_color, wo.z) * self.metallic;
            let dielectric =
                self.specular_color * ((1.0 - self.metallic) * fresnel_dielectric(wo.z, self.ior));
            value += (metal + dielectric) * lobes.below;
            chance += lobes.p[METAL] + lobes.p[SPECULAR];
        }
        (chance > 0.0).then(|| BsdfSample {
            wi: Vec3::new(-wo.x, -wo.y, wo.z).into(),
            weight: (value / chance).into(),
            pdf: chance,
            delta: true,
            eta: 1.0,
        })
    }

    /// True when no lobe is rough and there is no diffuse base: light sampling cannot help.
    pub fn is_delta(&self) -> bool {
        let coat_smooth = self.coat <= 0.0 || self.coat_ggx.alpha <= SMOOTH_ALPHA;
        coat_smooth && self.ggx.alpha <= SMOOTH_ALPHA && self.metallic >= 1.0
    }
}

/// A dielectric interface's GGX reflection of index `ior`, f·cos θi (both directions above).
pub fn dielectric_reflection(ior: f32, ggx: Ggx, wo: Vec3, wi: Vec3) -> f32 {
    if wi.z <= 0.0 {
        return 0.0;
    }
    let h = (wo + wi).normalize();
    fresnel_dielectric(wo.dot(h), ior) * ggx.d(h) * ggx.g2(wo, wi) / (4.0 * wo.z)
}
