//! Materials: a BSDF plus optional emission. BSDFs work in a local shading frame whose +Z is the
//! shading normal turned towards the outgoing direction.

use crate::sampling::cosine_hemisphere;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// How a surface scatters light.
#[derive(Clone, Debug, PartialEq)]
pub enum Bsdf {
    /// Lambertian reflection.
    Diffuse { reflectance: Vec3 },
}

/// A sampled scattering direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Incident direction, local frame.
    pub wi: Vec3,
    /// BSDF value times |cos θi| divided by pdf.
    pub weight: Vec3,
    /// Solid-angle pdf (meaningless when `delta`).
    pub pdf: f32,
    /// True for a specular (Dirac) lobe: no light sampling or MIS.
    pub delta: bool,
}

/// A surface material.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub bsdf: Bsdf,
    /// Emitted radiance.
    pub emission: Vec3,
    /// Emits from the back side too.
    pub two_sided_emission: bool,
}

impl Material {
    /// True when the material emits.
    pub fn emits(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// Emitted radiance towards a direction whose cosine with the geometric normal is `cos`.
    pub fn emitted(&self, cos: f32) -> Vec3 {
        if cos > 0.0 || (self.two_sided_emission && cos < 0.0) {
            self.emission
        } else {
            Vec3::ZERO
        }
    }
}

impl Bsdf {
    /// f(wo, wi)·|cos θi| in the local frame.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        match self {
            Bsdf::Diffuse { reflectance } => {
                if wo.z <= 0.0 || wi.z <= 0.0 {
                    Vec3::ZERO
                } else {
                    *reflectance * (FRAC_1_PI * wi.z)
                }
            }
        }
    }

    /// Solid-angle pdf of sampling `wi` given `wo`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Bsdf::Diffuse { .. } => {
                if wo.z <= 0.0 || wi.z <= 0.0 {
                    0.0
                } else {
                    wi.z * FRAC_1_PI
                }
            }
        }
    }

    /// Samples an incident direction.
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        match self {
            Bsdf::Diffuse { reflectance } => {
                if wo.z <= 0.0 {
                    return None;
                }
                let wi = cosine_hemisphere(u);
                (wi.z > 0.0).then_some(BsdfSample {
                    wi,
                    weight: *reflectance,
                    pdf: wi.z * FRAC_1_PI,
                    delta: false,
                })
            }
        }
    }
}
