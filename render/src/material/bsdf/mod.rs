//! BSDFs: how a surface or a medium scatters light. They work in a local shading frame whose +Z is the
//! shading normal turned towards the outgoing direction, so wo.z > 0 always; which side of the
//! surface that is ([`Side`]) sets the relative index of refraction.

pub mod albedo;
pub mod multiscatter;
pub mod standard;

use crate::material::bsdf::multiscatter::Multiscatter;
use crate::material::bsdf::standard::Standard;
use crate::material::microfacet::{
    ConductorFresnel, Ggx, SMOOTH_ALPHA, fresnel_dielectric, reflect, refract,
};
use crate::media::homogeneous::{henyey_greenstein, sample_henyey_greenstein};
use crate::sampling::cosine_hemisphere;
use glam::{Vec2, Vec3, Vec3A};
use std::f32::consts::FRAC_1_PI;

/// How a surface scatters light. A plain one-byte tag (`repr(u8)`): left to itself the
/// compiler hides the variant in a niche of the conductor's fields, and every `match` in the
/// hot loops then decodes it (2% of Cornell's instructions).
#[derive(Clone, Debug, PartialEq)]
#[repr(u8)]
pub enum Bsdf {
    /// Lambertian reflection.
    Diffuse { reflectance: Vec3 },
    /// A metal: GGX reflection with Schlick's or the exact conductor Fresnel term; a mirror
    /// when smooth. `multiscatter` adds back the energy of inter-facet bounces.
    Conductor {
        fresnel: ConductorFresnel,
        ggx: Ggx,
        multiscatter: Option<Multiscatter>,
    },
    /// Glass and the like: GGX reflection and refraction with the exact dielectric Fresnel
    /// term; a perfectly smooth interface when smooth. `ior` is inside (behind the front face)
    /// over outside.
    Dielectric { ior: f32, ggx: Ggx },
    /// Not a surface: the Henyey–Greenstein phase function of a point in a medium (asymmetry
    /// `g`), so medium vertices share light sampling and MIS with surfaces. Its frame is any
    /// whose z axis is `wo`; it has no sides, and its value carries no cosine.
    Phase { g: f32 },
    /// The standard layered material: a diffuse base under a dielectric specular layer,
    /// blended with a metal, under an optional clear coat ([`Standard`]). Opaque.
    Standard(Standard),
}

/// The side of the surface the path arrived from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// The side the geometric normal points to.
    Front,
    Back,
}

/// A sampled scattering direction. Its vectors are kept in 16-byte lanes: a sample is
/// returned through memory from the arm of the BSDF that drew it, and a vector stored as eight
/// bytes and four was read back by loads that straddled the two stores and had to wait for
/// both (with [`crate::lights::emitters::LightPlace`]'s the same way, 6% of the Cornell box's
/// time).
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Incident direction, local frame.
    pub wi: Vec3A,
    /// BSDF value times |cos θi| divided by pdf.
    pub weight: Vec3A,
    /// Solid-angle pdf (the lobe's choice probability when `delta`).
    pub pdf: f32,
    /// True for a specular (Dirac) lobe: no light sampling or MIS.
    pub delta: bool,
    /// Relative index of refraction crossed (1 for reflection): the weight carries 1/η².
    pub eta: f32,
}

impl Bsdf {
    /// True when light can pass through the surface (so light from behind it matters).
    pub fn transmits(&self) -> bool {
        matches!(self, Bsdf::Dielectric { .. } | Bsdf::Phase { .. })
    }

    /// True when every lobe is a Dirac delta: light sampling cannot help and is skipped.
    pub fn is_delta(&self) -> bool {
        match self {
            Bsdf::Diffuse { .. } | Bsdf::Phase { .. } => false,
            Bsdf::Conductor { ggx, .. } | Bsdf::Dielectric { ggx, .. } => ggx.alpha <= SMOOTH_ALPHA,
            Bsdf::Standard(s) => s.is_delta(),
        }
    }

    /// The colour of the surface, for the albedo AOV.
    pub fn albedo(&self) -> Vec3 {
        match self {
            Bsdf::Diffuse { reflectance } => *reflectance,
            Bsdf::Conductor { fresnel, .. } => fresnel.reflectance(1.0),
            Bsdf::Dielectric { .. } | Bsdf::Phase { .. } => Vec3::ONE,
            Bsdf::Standard(s) => s.albedo(),
        }
    }

    /// f(wo, wi)·|cos θi| in the local frame; zero for Dirac lobes.
    pub fn eval(&self, wo: Vec3, wi: Vec3, side: Side) -> Vec3 {
        if wo.z <= 0.0 || self.is_delta() {
            return Vec3::ZERO;
        }
        match self {
            Bsdf::Diffuse { reflectance } => {
                if wi.z <= 0.0 {
                    Vec3::ZERO
                } else {
                    *reflectance * (FRAC_1_PI * wi.z)
                }
            }
            Bsdf::Conductor {
                fresnel,
                ggx,
                multiscatter,
            } => {
                let specular = conductor_specular(fresnel, ggx, wo, wi);
                match multiscatter {
                    Some(ms) => specular + ms.eval(*ggx, wo, wi),
                    None => specular,
                }
            }
            Bsdf::Dielectric { ior, ggx } => {
                let eta = relative_ior(*ior, side);
                let Some(h) = half_vector(wo, wi, eta) else {
                    return Vec3::ZERO;
                };
                let (oh, ih) = (wo.dot(h), wi.dot(h));
                let r = fresnel_dielectric(oh, eta);
                let value = if wi.z > 0.0 {
                    r * ggx.d(h) * ggx.g2(wo, wi) / (4.0 * wo.z)
                } else {
                    // Walter et al. 2007; radiance is compressed by 1/η² on refraction.
                    let denom = (ih + oh / eta).powi(2) * wo.z;
                    (1.0 - r) * ggx.d(h) * ggx.g2(wo, wi) * (ih * oh / denom).abs() / (eta * eta)
                };
                Vec3::splat(value)
            }
            Bsdf::Phase { g } => Vec3::splat(henyey_greenstein(*g, wo, wi)),
            Bsdf::Standard(s) => s.eval(wo, wi),
        }
    }

    /// Solid-angle pdf of sampling `wi` given `wo`; zero for Dirac lobes.
    pub fn pdf(&self, wo: Vec3, wi: Vec3, side: Side) -> f32 {
        if wo.z <= 0.0 || self.is_delta() {
            return 0.0;
        }
        match self {
            Bsdf::Diffuse { .. } => {
                if wi.z <= 0.0 {
                    0.0
                } else {
                    wi.z * FRAC_1_PI
                }
            }
            Bsdf::Conductor {
                ggx, multiscatter, ..
            } => {
                if wi.z <= 0.0 {
                    return 0.0;
                }
                let h = (wo + wi).normalize();
                let specular = ggx.pdf_visible(wo, h) / (4.0 * wo.dot(h));
                if multiscatter.is_none() {
                    return specular;
                }
                let p = Multiscatter::choice(*ggx, wo);
                (1.0 - p) * specular + p * wi.z * FRAC_1_PI
            }
            Bsdf::Dielectric { ior, ggx } => {
                let eta = relative_ior(*ior, side);
                let Some(h) = half_vector(wo, wi, eta) else {
                    return 0.0;
                };
                let (oh, ih) = (wo.dot(h), wi.dot(h));
                let r = fresnel_dielectric(oh, eta);
                if wi.z > 0.0 {
                    ggx.pdf_visible(wo, h) / (4.0 * oh) * r
                } else {
                    ggx.pdf_visible(wo, h) * refraction_jacobian(oh, ih, eta) * (1.0 - r)
                }
            }
            Bsdf::Phase { g } => henyey_greenstein(*g, wo, wi),
            Bsdf::Standard(s) => s.pdf(wo, wi),
        }
    }

    /// Samples an incident direction; `u_lobe` chooses between reflection and refraction.
    pub fn sample(&self, wo: Vec3, u: Vec2, u_lobe: f32, side: Side) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        match self {
            Bsdf::Diffuse { reflectance } => {
                let wi = cosine_hemisphere(u);
                (wi.z > 0.0).then_some(BsdfSample {
                    wi: wi.into(),
                    weight: (*reflectance).into(),
                    pdf: wi.z * FRAC_1_PI,
                    delta: false,
                    eta: 1.0,
                })
            }
            Bsdf::Conductor {
                fresnel,
                ggx,
                multiscatter,
            } => {
                if multiscatter.is_some() {
                    return self.sample_mixture(wo, u, u_lobe, Multiscatter::choice(*ggx, wo));
                }
                if ggx.alpha <= SMOOTH_ALPHA {
                    return Some(BsdfSample {
                        wi: Vec3::new(-wo.x, -wo.y, wo.z).into(),
                        weight: fresnel.reflectance(wo.z).into(),
                        pdf: 1.0,
                        delta: true,
                        eta: 1.0,
                    });
                }
                let h = ggx.sample_visible(wo, u);
                let wi = reflect(wo, h);
                if wi.z <= 0.0 {
                    return None;
                }
                let oh = wo.dot(h);
                Some(BsdfSample {
                    wi: wi.into(),
                    weight: (fresnel.reflectance(oh) * (ggx.g2(wo, wi) / ggx.g1(wo))).into(),
                    pdf: ggx.pdf_visible(wo, h) / (4.0 * oh),
                    delta: false,
                    eta: 1.0,
                })
            }
            Bsdf::Dielectric { ior, ggx } => {
                let eta = relative_ior(*ior, side);
                let smooth = ggx.alpha <= SMOOTH_ALPHA;
                let h = if smooth {
                    Vec3::Z
                } else {
                    ggx.sample_visible(wo, u)
                };
                let oh = wo.dot(h);
                let r = fresnel_dielectric(oh, eta);
                // Choose the lobe in proportion to the Fresnel terms, so they cancel.
                let (wi, lobe_pdf, transmitted) = if u_lobe < r {
                    (reflect(wo, h), r, false)
                } else {
                    (refract(wo, h, eta)?, 1.0 - r, true)
                };
                if wi.z == 0.0 || transmitted == (wi.z > 0.0) {
                    return None;
                }
                let crossed = if transmitted { eta } else { 1.0 };
                let radiance_scale = 1.0 / (crossed * crossed);
                if smooth {
                    return Some(BsdfSample {
                        wi: wi.into(),
                        weight: Vec3A::splat(radiance_scale),
                        pdf: lobe_pdf,
                        delta: true,
                        eta: crossed,
                    });
                }
                let pdf_h = ggx.pdf_visible(wo, h);
                let pdf = if transmitted {
                    pdf_h * refraction_jacobian(oh, wi.dot(h), eta) * lobe_pdf
                } else {
                    pdf_h / (4.0 * oh) * lobe_pdf
                };
                Some(BsdfSample {
                    wi: wi.into(),
                    weight: Vec3A::splat(radiance_scale * ggx.g2(wo, wi) / ggx.g1(wo)),
                    pdf,
                    delta: false,
                    eta: crossed,
                })
            }
            Bsdf::Phase { g } => {
                let wi = sample_henyey_greenstein(*g, wo, u);
                Some(BsdfSample {
                    wi: wi.into(),
                    weight: Vec3A::ONE,
                    pdf: henyey_greenstein(*g, wo, wi),
                    delta: false,
                    eta: 1.0,
                })
            }
            Bsdf::Standard(s) => s.sample(wo, u, u_lobe),
        }
    }
}

impl Bsdf {
    /// A conductor with its inter-facet lobe: that lobe (cosine-distributed) with probability
    /// `p`, else the specular one; the weight is the whole BSDF over the mixture's pdf.
    fn sample_mixture(&self, wo: Vec3, u: Vec2, u_lobe: f32, p: f32) -> Option<BsdfSample> {
        let Bsdf::Conductor { ggx, .. } = self else {
            return None;
        };
        let wi = if u_lobe < p {
            cosine_hemisphere(u)
        } else {
            reflect(wo, ggx.sample_visible(wo, u))
        };
        let pdf = self.pdf(wo, wi, Side::Front);
        (wi.z > 0.0 && pdf > 0.0).then(|| BsdfSample {
            wi: wi.into(),
            weight: (self.eval(wo, wi, Side::Front) / pdf).into(),
            pdf,
            delta: false,
            eta: 1.0,
        })
    }
}

/// A conductor's single-scattering GGX lobe, f·cos θi.
pub(super) fn conductor_specular(
    fresnel: &ConductorFresnel,
    ggx: &Ggx,
    wo: Vec3,
    wi: Vec3,
) -> Vec3 {
    if wi.z <= 0.0 {
        return Vec3::ZERO;
    }
    let h = (wo + wi).normalize();
    fresnel.reflectance(wo.dot(h)) * (ggx.d(h) * ggx.g2(wo, wi) / (4.0 * wo.z))
}

/// IOR of the far side over IOR of the side the path arrived from.
fn relative_ior(ior: f32, side: Side) -> f32 {
    match side {
        Side::Front => ior,
        Side::Back => 1.0 / ior,
    }
}

/// dω_h/dω_i for refraction through a facet with cosines `oh` = wo·h and `ih` = wi·h.
fn refraction_jacobian(oh: f32, ih: f32, eta: f32) -> f32 {
    ih.abs() / (ih + oh / eta).powi(2)
}

/// The microfacet normal that scatters `wo` into `wi` (reflection when on the same side,
/// refraction otherwise), turned to +Z; `None` for degenerate or back-facing configurations.
fn half_vector(wo: Vec3, wi: Vec3, eta: f32) -> Option<Vec3> {
    let reflection = wi.z > 0.0;
    let h = if reflection { wo + wi } else { wo + wi * eta };
    let h = h.try_normalize()?;
    let h = if h.z < 0.0 { -h } else { h };
    // wo must see the facet's front; wi its front for reflection and its back for refraction.
    let ok = wo.dot(h) > 0.0 && (wi.dot(h) > 0.0) == reflection;
    (ok && h.z > 0.0).then_some(h)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::hash32;
    use std::f32::consts::PI;

    fn uniform(i: u32, k: u32) -> f32 {
        (hash32(hash32(i) ^ k) >> 8) as f32 / (1u32 << 24) as f32
    }

    fn rough_bsdfs() -> Vec<(&'static str, Bsdf)> {
        vec![
            (
                "diffuse",
                Bsdf::Diffuse {
                    reflectance: Vec3::new(0.9, 0.5, 0.2),
                },
            ),
            (
                "conductor 0.3",
                Bsdf::Conductor {
                    fresnel: ConductorFresnel::Schlick(Vec3::new(1.0, 0.8, 0.4)),
                    ggx: Ggx::from_roughness(0.3),
                    multiscatter: None,
                },
            ),
            (
                "conductor 0.8",
                Bsdf::Conductor {
                    fresnel: ConductorFresnel::Schlick(Vec3::ONE),
                    ggx: Ggx::from_roughness(0.8),
                    multiscatter: None,
                },
            ),
            (
                "gold 0.2",
                Bsdf::Conductor {
                    fresnel: ConductorFresnel::Complex {
                        eta: Vec3::new(0.18, 0.42, 1.37),
                        k: Vec3::new(3.42, 2.35, 1.77),
                    },
                    ggx: Ggx::from_roughness(0.2),
                    multiscatter: None,
                },
            ),
            ("copper 0.6, compensated", copper_compensated()),
            (
                "dielectric 0.4",
                Bsdf::Dielectric {
                    ior: 1.5,
                    ggx: Ggx::from_roughness(0.4),
                },
            ),
            (
                "dielectric 0.25",
                Bsdf::Dielectric {
                    ior: 1.33,
                    ggx: Ggx::from_roughness(0.25),
                },
            ),
            (
                "standard plastic 0.4",
                standard(Vec3::new(0.8, 0.3, 0.1), 0.0, 0.4, 0.0, 0.0),
            ),
            (
                "standard half metal under a rough coat",
                standard(Vec3::new(0.9, 0.7, 0.4), 0.5, 0.3, 0.8, 0.25),
            ),
        ]
    }

    /// A standard material: `base_color`, `metallic`, `roughness`, a coat of weight `coat` and
    /// roughness `coat_roughness` (ior 1.6), an ior of 1.5 and a light tint.
    fn standard(base: Vec3, metallic: f32, roughness: f32, coat: f32, coat_roughness: f32) -> Bsdf {
        Bsdf::Standard(Standard::new(
            base,
            metallic,
            Vec3::new(1.0, 0.95, 0.9),
            1.5,
            Ggx::from_roughness(roughness),
            coat,
            Ggx::from_roughness(coat_roughness),
            1.6,
        ))
    }

    /// The standard material reflects all the light when white, whatever its roughness,
    /// metallic and coat, smooth or rough (the furnace test); a coloured one reflects less.
    #[test]
    fn a_white_standard_material_keeps_all_the_light() {
        use crate::material::bsdf::multiscatter::directional_albedo;
        let white = |metallic: f32, roughness: f32, coat: f32, coat_roughness: f32, ior: f32| {
            Bsdf::Standard(Standard::new(
                Vec3::ONE,
                metallic,
                Vec3::ONE,
                ior,
                Ggx::from_roughness(roughness),
                coat,
                Ggx::from_roughness(coat_roughness),
                ior,
            ))
        };
        for (metallic, roughness, coat, coat_roughness, ior) in [
            (0.0, 0.0, 0.0, 0.0, 1.5),
            (0.0, 0.2, 0.0, 0.0, 1.5),
            (0.0, 0.5, 0.0, 0.0, 1.33),
            (0.0, 1.0, 0.0, 0.0, 2.4),
            (0.5, 0.4, 0.0, 0.0, 1.5),
            (1.0, 0.7, 0.0, 0.0, 1.5),
            (0.0, 0.5, 1.0, 0.0, 1.5),
            (0.3, 0.6, 0.7, 0.2, 1.8),
        ] {
            let bsdf = white(metallic, roughness, coat, coat_roughness, ior);
            for mu in [0.1f32, 0.4, 0.7, 1.0] {
                let kept = directional_albedo(&bsdf, Side::Front, mu, 96);
                assert!(
                    (kept - 1.0).abs() < 0.015,
                    "metallic {metallic} roughness {roughness} coat {coat}/{coat_roughness} \
                     ior {ior}, μ {mu}: keeps {kept}"
                );
            }
        }
        let grey = standard(Vec3::splat(0.5), 0.0, 0.5, 0.5, 0.1);
        let kept = directional_albedo(&grey, Side::Front, 0.7, 96);
        assert!(kept > 0.5 && kept < 0.75, "grey keeps {kept}");
    }

    fn directions() -> Vec<Vec3> {
        [
            (0.0, 0.0, 1.0),
            (0.5, 0.1, 0.8),
            (0.9, -0.2, 0.3),
            (0.97, 0.0, 0.1),
        ]
        .iter()
        .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
        .collect()
    }

    /// Sampling agrees with `eval` and `pdf` sample by sample; the throughput found by sampling
    /// equals the integral of `eval` over the sphere found by quadrature; no lobe creates energy.
    #[test]
    fn sampling_matches_evaluation() {
        let n = 200_000;
        for (name, bsdf) in rough_bsdfs() {
            for side in [Side::Front, Side::Back] {
                for wo in directions() {
                    let mut by_sampling = Vec3::ZERO;
                    // Without the radiance compression at refraction: energy, at most 1.
                    let mut energy = Vec3::ZERO;
                    for i in 0..n {
                        let u = Vec2::new(uniform(i, 1), uniform(i, 2));
                        let Some(s) = bsdf.sample(wo, u, uniform(i, 3), side) else {
                            continue;
                        };
                        assert!(!s.delta);
                        let (wi, weight) = (Vec3::from(s.wi), Vec3::from(s.weight));
                        let pdf = bsdf.pdf(wo, wi, side);
                        let f = bsdf.eval(wo, wi, side);
                        assert!(
                            (pdf - s.pdf).abs() <= 2e-3 * s.pdf.max(1.0),
                            "{name} {side:?} wo {wo}: pdf {pdf} vs sampled {}",
                            s.pdf
                        );
                        let expected = f / s.pdf;
                        assert!(
                            (expected - weight).abs().max_element()
                                <= 2e-3 * expected.max_element().max(1.0),
                            "{name} {side:?} wo {wo}: weight {weight} vs f/pdf {expected}",
                        );
                        by_sampling += weight;
                        energy += weight * s.eta * s.eta;
                    }
                    by_sampling /= n as f32;
                    energy /= n as f32;
                    // Midpoint quadrature over the sphere in θ and φ (fine near the poles,
                    // where lobes around the normal peak).
                    let (ntheta, nphi) = (900, 900);
                    let (dtheta, dphi) = (PI / ntheta as f32, 2.0 * PI / nphi as f32);
                    let mut by_integration = Vec3::ZERO;
                    let mut pdf_integral = 0.0;
                    for i in 0..ntheta {
                        let theta = (i as f32 + 0.5) * dtheta;
                        let (r, z) = theta.sin_cos();
                        let cell = r * dtheta * dphi;
                        let mut row = Vec3::ZERO;
                        for j in 0..nphi {
                            let phi = (j as f32 + 0.5) * dphi;
                            let wi = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                            row += bsdf.eval(wo, wi, side);
                            pdf_integral += bsdf.pdf(wo, wi, side) * cell;
                        }
                        by_integration += row * cell;
                    }
                    assert!(
                        (by_sampling - by_integration).abs().max_element()
                            < 0.02 * by_integration.max_element().max(0.2),
                        "{name} {side:?} wo {wo}: sampled {by_sampling} vs integrated {by_integration}"
                    );
                    assert!(
                        energy.max_element() <= 1.0 + 1e-3,
                        "{name} {side:?} wo {wo}: creates energy ({energy})"
                    );
                    assert!(
                        pdf_integral < 1.02,
                        "{name} {side:?} wo {wo}: pdf integrates to {pdf_integral}"
                    );
                }
            }
        }
    }

    fn copper_compensated() -> Bsdf {
        let fresnel = ConductorFresnel::Complex {
            eta: Vec3::new(0.17, 0.98, 1.21),
            k: Vec3::new(3.64, 2.62, 2.37),
        };
        let ggx = Ggx::from_roughness(0.6);
        Bsdf::Conductor {
            fresnel,
            ggx,
            multiscatter: Multiscatter::new(&fresnel, ggx),
        }
    }

    /// With the inter-facet lobe a white conductor keeps all the light at every angle and
    /// roughness, and a coloured one keeps more than without it.
    #[test]
    fn compensated_conductors_keep_their_energy() {
        use crate::material::bsdf::multiscatter::directional_albedo;
        for roughness in [0.2f32, 0.5, 0.8, 1.0] {
            let fresnel = ConductorFresnel::Schlick(Vec3::ONE);
            let ggx = Ggx::from_roughness(roughness);
            let white = Bsdf::Conductor {
                fresnel,
                ggx,
                multiscatter: Multiscatter::new(&fresnel, ggx),
            };
            let plain = Bsdf::Conductor {
                fresnel,
                ggx,
                multiscatter: None,
            };
            for mu in [0.1f32, 0.4, 0.7, 1.0] {
                let kept = directional_albedo(&white, Side::Front, mu, 96);
                let single = directional_albedo(&plain, Side::Front, mu, 96);
                assert!(
                    (kept - 1.0).abs() < 0.01,
                    "roughness {roughness}, μ {mu}: {kept} (single scattering {single})"
                );
            }
        }
    }

    #[test]
    fn smooth_lobes_conserve_energy() {
        let mirror = Bsdf::Conductor {
            fresnel: ConductorFresnel::Schlick(Vec3::ONE),
            ggx: Ggx::from_roughness(0.0),
            multiscatter: None,
        };
        let glass = Bsdf::Dielectric {
            ior: 1.5,
            ggx: Ggx::from_roughness(0.0),
        };
        for wo in directions() {
            let s = mirror
                .sample(wo, Vec2::splat(0.5), 0.5, Side::Front)
                .unwrap();
            assert!(s.delta && s.weight == Vec3A::ONE);
            assert!((Vec3::from(s.wi) - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
            for side in [Side::Front, Side::Back] {
                // Throughput times η² (undoing the radiance compression) over both lobes is 1.
                let n = 20_000;
                let mut total = 0.0;
                for i in 0..n {
                    let u_lobe = (i as f32 + 0.5) / n as f32;
                    let s = glass.sample(wo, Vec2::ZERO, u_lobe, side).unwrap();
                    assert!(s.delta);
                    total += s.weight.x * s.eta * s.eta;
                }
                assert!(
                    (total / n as f32 - 1.0).abs() < 1e-4,
                    "glass {side:?} wo {wo}"
                );
            }
        }
    }
}
