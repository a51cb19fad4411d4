//! A surface material: a BSDF, its emission, its sides, and the inputs it reads from textures.

use crate::material::bsdf::Bsdf;
use crate::material::inputs::{ColorInput, Inputs, Lookup};
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// A surface material.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub bsdf: Bsdf,
    /// Emitted radiance (where no texture gives it: [`Inputs::emission`]).
    pub emission: Vec3,
    /// Emits from the back side too.
    pub two_sided_emission: bool,
    /// The back side (against the geometric normal) is black: a path that meets it ends there.
    /// Mitsuba's BSDFs are all one-sided; rift's reflect on both sides unless asked.
    pub one_sided: bool,
    /// Inputs read from textures (`None`: the constants of `bsdf` everywhere).
    pub inputs: Option<Box<Inputs>>,
    /// The share of rays the surface stops where no opacity texture says otherwise: below 1
    /// the surface is a cut-out, and rays pass it with the rest of the probability.
    pub opacity: f32,
    /// True when the surface, where it touches another, is in optical contact with it (no air
    /// between them) instead of the limit of a closing gap (see [`crate::geometry::Contacts`]).
    pub optical_contact: bool,
}

impl Material {
    /// True when some input comes from a texture (its meshes must give UVs).
    pub fn textured(&self) -> bool {
        self.inputs.is_some()
    }

    /// The BSDF at a point looked up at `at` in `textures` (the constant one when nothing is
    /// textured).
    pub fn bsdf_at(&self, textures: &[Texture], at: &Lookup) -> Bsdf {
        match &self.inputs {
            Some(inputs) => inputs.apply(&self.bsdf, textures, at),
            None => self.bsdf.clone(),
        }
    }

    /// True when the material has a normal map.
    pub fn normal_mapped(&self) -> bool {
        self.inputs.as_ref().is_some_and(|i| i.normal.is_some())
    }

    /// The normal map's normal at `at` in the tangent frame, when the material has one.
    pub fn normal_at(&self, textures: &[Texture], at: &Lookup) -> Option<Vec3> {
        let map = self.inputs.as_ref()?.normal?;
        Some(map.at(textures, at))
    }

    /// True when the material lets some rays through without meeting it (an opacity below
    /// 1, or an opacity texture).
    pub fn cuts_out(&self) -> bool {
        self.opacity < 1.0 || self.inputs.as_ref().is_some_and(|i| i.opacity.is_some())
    }

    /// The opacity at UV `uv` (its texture read in the full image: a cut-out's edge should be
    /// as sharp as the texture), or the constant one without UVs.
    pub fn opacity_at(&self, textures: &[Texture], uv: Option<Vec2>) -> f32 {
        let map = self.inputs.as_ref().and_then(|i| i.opacity);
        match (map, uv) {
            (Some(map), Some(uv)) => map.at(textures, &Lookup { uv, width: 0.0 }).clamp(0.0, 1.0),
            _ => self.opacity,
        }
    }

    /// True when the material emits.
    pub fn emits(&self) -> bool {
        self.emission.max_element() > 0.0 || self.emission_map().is_some()
    }

    /// The texture the emission is read from, when it has one.
    pub fn emission_map(&self) -> Option<&ColorInput> {
        self.inputs.as_ref()?.emission.as_ref()
    }

    /// The radiance emitted at UV `uv` (on its front, or on both sides when two-sided). A
    /// texture is read in the full image, as light sampling reads it, so the two estimates
    /// MIS weighs agree; never below zero.
    pub fn radiance_at(&self, textures: &[Texture], uv: Option<Vec2>) -> Vec3 {
        match (self.emission_map(), uv) {
            (Some(map), Some(uv)) => map.at(textures, &Lookup { uv, width: 0.0 }).max(Vec3::ZERO),
            _ => self.emission,
        }
    }

    /// True when a path arriving from the side whose cosine with the geometric normal is
    /// `cos` meets a black back side ([`Self::one_sided`]).
    #[inline]
    pub fn black_from(&self, cos: f32) -> bool {
        self.one_sided && cos < 0.0
    }

    /// True when light leaves towards a direction whose cosine with the geometric normal is
    /// `cos`.
    #[inline]
    pub fn emits_towards(&self, cos: f32) -> bool {
        cos > 0.0 || (self.two_sided_emission && cos < 0.0)
    }
}
