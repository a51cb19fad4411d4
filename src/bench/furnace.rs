//! `rift bench furnace`: how much energy each rough BSDF keeps. A lossless BSDF (white conductor,
//! clear dielectric) in a white furnace should return all the light it receives; single-scattering
//! GGX drops the light that would bounce between facets, more the rougher the surface. The table
//! gives the directional albedo E(μ) (all lobes, refraction's 1/η² radiance compression undone)
//! at normal and grazing incidence and its cosine-weighted mean over incidence, per roughness and
//! masking-shadowing term, estimated from the BSDFs' own sampling on stratified samples; the
//! conductor also with its energy compensation (`multiscatter`), and the standard layered
//! material white (all of it should come back) and with the base colour the Mitsuba comparison
//! uses (tools/bsdf_vs_mitsuba.py compare --standard), whose red albedo is shown.

use clap::Args;
use glam::Vec3;
use rift_render::material::bsdf::multiscatter::{Multiscatter, directional_albedo, mean_albedo};
use rift_render::material::bsdf::standard::Standard;
use rift_render::material::bsdf::{Bsdf, Side};
use rift_render::material::microfacet::{ConductorFresnel, Ggx, Shadowing};

/// Arguments of `rift bench furnace`.
#[derive(Args)]
pub struct FurnaceArgs {
    /// Strata per side of the sample square (the estimate uses strata² samples per angle).
    #[arg(long, default_value_t = 96)]
    strata: u32,
}

/// A table row: its name, the BSDF at a given distribution, and the side it is seen from.
type Material = (&'static str, fn(Ggx) -> Bsdf, Side);

const ROUGHNESSES: [f32; 7] = [0.1, 0.2, 0.3, 0.5, 0.7, 0.85, 1.0];

pub fn run(args: FurnaceArgs) -> anyhow::Result<()> {
    let strata = args.strata.clamp(4, 1024);
    let materials: [Material; 10] = [
        ("white conductor", conductor, Side::Front),
        ("  + multiscatter", compensated_conductor, Side::Front),
        ("glass 1.5, outside", |ggx| glass(1.5, ggx), Side::Front),
        ("glass 1.5, inside", |ggx| glass(1.5, ggx), Side::Back),
        ("water 1.33, outside", |ggx| glass(1.33, ggx), Side::Front),
        ("water 1.33, inside", |ggx| glass(1.33, ggx), Side::Back),
        (
            "standard white",
            |ggx| standard(Vec3::ONE, 0.0, 0.0, ggx),
            Side::Front,
        ),
        (
            "  metallic 0.5, coat",
            |ggx| standard(Vec3::ONE, 0.5, 1.0, ggx),
            Side::Front,
        ),
        (
            "standard 0.7 red",
            |ggx| standard(RED, 0.0, 0.0, ggx),
            Side::Front,
        ),
        (
            "  metallic 1",
            |ggx| standard(RED, 1.0, 0.0, ggx),
            Side::Front,
        ),
    ];
    println!(
        "rift bench furnace: energy kept by lossless BSDFs ({} samples per angle)",
        strata * strata
    );
    for (what, title) in [
        ("mean", "cosine-weighted mean albedo over incidence"),
        ("normal", "albedo at normal incidence (μ = 1)"),
        ("grazing", "albedo at grazing incidence (μ = 0.2)"),
    ] {
        println!("\n{title}");
        print!("{:<22} {:<18}", "material", "shadowing");
        for r in ROUGHNESSES {
            print!(" {:>6}", format!("r {r}"));
        }
        println!();
        for (name, make, side) in materials {
            for shadowing in [Shadowing::HeightCorrelated, Shadowing::Separable] {
                let label = match shadowing {
                    Shadowing::HeightCorrelated => "height-correlated",
                    Shadowing::Separable => "separable",
                };
                print!("{name:<22} {label:<18}");
                for r in ROUGHNESSES {
                    let bsdf = make(Ggx::from_roughness(r).with_shadowing(shadowing));
                    let value = match what {
                        "mean" => mean_albedo(&bsdf, side, strata) as f64,
                        "normal" => directional_albedo(&bsdf, side, 1.0, strata) as f64,
                        _ => directional_albedo(&bsdf, side, 0.2, strata) as f64,
                    };
                    print!(" {value:>6.4}");
                }
                println!();
            }
        }
    }
    Ok(())
}

fn conductor(ggx: Ggx) -> Bsdf {
    Bsdf::Conductor {
        fresnel: ConductorFresnel::Schlick(Vec3::ONE),
        ggx,
        multiscatter: None,
    }
}

fn compensated_conductor(ggx: Ggx) -> Bsdf {
    let fresnel = ConductorFresnel::Schlick(Vec3::ONE);
    Bsdf::Conductor {
        fresnel,
        ggx,
        multiscatter: Multiscatter::new(&fresnel, ggx),
    }
}

/// The comparison's base colour, red first (the table shows red).
const RED: Vec3 = Vec3::new(0.7, 0.5, 0.3);

/// A standard material of `base` colour, `metallic`, with a coat of weight `coat` (roughness
/// 0.1); its specular layer and metal of `ggx`, ior 1.5.
fn standard(base: Vec3, metallic: f32, coat: f32, ggx: Ggx) -> Bsdf {
    let coat_ggx = Ggx::from_roughness(0.1).with_shadowing(ggx.shadowing);
    Bsdf::Standard(Standard::new(
        base,
        metallic,
        Vec3::ONE,
        1.5,
        ggx,
        coat,
        coat_ggx,
        1.5,
    ))
}

fn glass(ior: f32, ggx: Ggx) -> Bsdf {
    Bsdf::Dielectric { ior, ggx }
}
