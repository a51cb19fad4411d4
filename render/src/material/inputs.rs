//! A material's textured inputs: a colour or a number read from a texture at the shaded
//! point's UV, as `texture value × scale + offset`, over the footprint of the ray that found
//! it. Inputs left untextured keep the material's own constants, at no cost.

use crate::material::bsdf::Bsdf;
use crate::material::bsdf::multiscatter::Multiscatter;
use crate::material::microfacet::{ConductorFresnel, Ggx};
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// A colour input read from a texture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColorInput {
    pub texture: u32,
    pub scale: Vec3,
    pub offset: Vec3,
    /// How the texture is filtered.
    pub filter: Filter,
}

/// How a texture is filtered over a ray's footprint.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Filter {
    /// Trilinear in the mipmap, the level the footprint picks (the default: no aliasing at
    /// any distance, at the cost of a blur about twice a pixel wide).
    #[default]
    Trilinear,
    /// Bilinear in the full image whatever the footprint: sharper, and the pixel's samples
    /// do the filtering (as in renderers without mipmaps); noisier where texels are smaller
    /// than pixels.
    Bilinear,
}

impl Filter {
    /// The footprint width a lookup uses for a ray's `width`.
    #[inline]
    fn width(self, width: f32) -> f32 {
        match self {
            Filter::Trilinear => width,
            Filter::Bilinear => 0.0,
        }
    }
}

/// A number read from one channel of a texture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScalarInput {
    pub texture: u32,
    /// 0 to 3: red, green, blue, alpha.
    pub channel: usize,
    pub scale: f32,
    pub offset: f32,
    pub filter: Filter,
}

/// The inputs of a material that come from textures.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Inputs {
    /// A diffuse material's albedo, a conductor's colour at normal incidence, or a standard
    /// material's base colour.
    pub reflectance: Option<ColorInput>,
    /// A rough conductor's, dielectric's or standard material's roughness.
    pub roughness: Option<ScalarInput>,
    /// A standard material's metallic, specular colour, coat and coat roughness.
    pub metallic: Option<ScalarInput>,
    pub specular_color: Option<ColorInput>,
    pub coat: Option<ScalarInput>,
    pub coat_roughness: Option<ScalarInput>,
    /// A tangent-space normal map: the texture's linear RGB as 2·value − 1, its x and y
    /// scaled by [`NormalInput::strength`].
    pub normal: Option<NormalInput>,
    /// Opacity for cut-outs (leaves, fences): 0 lets rays through, 1 stops them.
    pub opacity: Option<ScalarInput>,
    /// Emitted radiance (a screen, a lit sign, a window's sky).
    pub emission: Option<ColorInput>,
}

/// A tangent-space normal map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalInput {
    pub texture: u32,
    /// Scales the map's slopes (0: flat, 1: as painted).
    pub strength: f32,
}

/// Where a texture is looked up: the point's UV and the ray's footprint there, in UV units.
#[derive(Clone, Copy, Debug)]
pub struct Lookup {
    pub uv: Vec2,
    pub width: f32,
}

impl ColorInput {
    /// The input's value at `at`.
    pub fn at(&self, textures: &[Texture], at: &Lookup) -> Vec3 {
        let t = textures[self.texture as usize].lookup(at.uv, self.filter.width(at.width));
        t.truncate() * self.scale + self.offset
    }
}

impl ScalarInput {
    /// The input's value at `at`.
    pub fn at(&self, textures: &[Texture], at: &Lookup) -> f32 {
        let t = textures[self.texture as usize].lookup(at.uv, self.filter.width(at.width));
        t[self.channel] * self.scale + self.offset
    }
}

impl NormalInput {
    /// The unit normal the map gives at `at`, in the tangent frame (x along +u, y along +v,
    /// z the surface's normal), never below the surface. Read from the finest level whatever
    /// the footprint: shading is not linear in the normal, so a mipmap's averaged (flatter)
    /// normals would brighten distant bumps (1% on a bumped floor against Mitsuba's
    /// supersampling), while the pixel's samples average the finest level's shading exactly.
    pub fn at(&self, textures: &[Texture], at: &Lookup) -> Vec3 {
        let t = textures[self.texture as usize].lookup(at.uv, 0.0);
        let m = t.truncate() * 2.0 - Vec3::ONE;
        let bent = Vec3::new(m.x * self.strength, m.y * self.strength, m.z.max(1e-3));
        bent.try_normalize().unwrap_or(Vec3::Z)
    }
}

impl Inputs {
    /// `bsdf` with these inputs read at `at`: colours kept within [0, 1], and numbers within
    /// [0, 1].
    pub fn apply(&self, bsdf: &Bsdf, textures: &[Texture], at: &Lookup) -> Bsdf {
        let reflectance = self
            .reflectance
            .map(|c| c.at(textures, at).clamp(Vec3::ZERO, Vec3::ONE));
        let unit = |input: Option<ScalarInput>| input.map(|r| r.at(textures, at).clamp(0.0, 1.0));
        let roughness = unit(self.roughness);
        let with_roughness = |ggx: &Ggx, roughness: Option<f32>| match roughness {
            Some(r) => Ggx::from_roughness(r).with_shadowing(ggx.shadowing),
            None => *ggx,
        };
        let rough = |ggx: &Ggx| with_roughness(ggx, roughness);
        match bsdf {
            Bsdf::Diffuse { reflectance: own } => Bsdf::Diffuse {
                reflectance: reflectance.unwrap_or(*own),
            },
            Bsdf::Conductor {
                fresnel,
                ggx,
                multiscatter,
            } => {
                let fresnel = match (reflectance, fresnel) {
                    (Some(c), ConductorFresnel::Schlick(_)) => ConductorFresnel::Schlick(c),
                    _ => *fresnel,
                };
                let ggx = rough(ggx);
                let multiscatter = multiscatter.and_then(|_| Multiscatter::new(&fresnel, ggx));
                Bsdf::Conductor {
                    fresnel,
                    ggx,
                    multiscatter,
                }
            }
            Bsdf::Dielectric { ior, ggx } => Bsdf::Dielectric {
                ior: *ior,
                ggx: rough(ggx),
            },
            Bsdf::Phase { .. } => bsdf.clone(),
            Bsdf::Standard(own) => {
                let mut s = *own;
                s.base_color = reflectance.unwrap_or(s.base_color);
                s.ggx = rough(&s.ggx);
                s.metallic = unit(self.metallic).unwrap_or(s.metallic);
                if let Some(c) = self.specular_color {
                    s.specular_color = c.at(textures, at).clamp(Vec3::ZERO, Vec3::ONE);
                }
                s.coat = unit(self.coat).unwrap_or(s.coat);
                s.coat_ggx = with_roughness(&s.coat_ggx, unit(self.coat_roughness));
                s.refresh();
                Bsdf::Standard(s)
            }
        }
    }
}
