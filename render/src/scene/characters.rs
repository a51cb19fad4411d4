//! A shot's deforming objects (mesh sequences, and their copies through openings) sampled at
//! given times in world space, for the pipeline's USD stage: the character beside the rings,
//! shaped and placed as the renderer shapes and places it. One read of each sequence serves
//! every time asked for.

use super::light_groups::LightGroups;
use super::objects::{self, Loader};
use super::settings::{Overrides, Settings};
use super::{media, portals, sequence};
use crate::error::RenderError;
use glam::Vec3;
use rift_fx::Shot;
use rift_fx::export::usd_stage::StageMesh;
use std::path::Path;
use std::sync::Arc;

/// The deforming objects of `shot` at each of `frames` (fractional frame numbers, in order):
/// none when it has none, at the cost of parsing its objects.
pub fn sampled(shot: &Shot, frames: &[f64]) -> Result<Vec<StageMesh>, RenderError> {
    let file = &shot.source;
    let sections = objects::object_sections(file, &shot.render.objects, Vec::new())?;
    let deforming =
        |o: &super::schema::ObjectSection| o.mesh.as_deref().is_some_and(sequence::is_sequence);
    let (Some(first), Some(last)) = (frames.first(), frames.last()) else {
        return Ok(Vec::new());
    };
    if !sections.iter().any(deforming) {
        return Ok(Vec::new());
    }
    let settings = Settings::read(shot, &Overrides::default())?;
    let span = [shot.time_of(*first), shot.time_of(*last)];
    let mut groups = LightGroups::new();
    let (portals, _) = portals::portals(shot, span, settings.max_portal_depth, None, &mut groups)?;
    let media = media::sections(file, &shot.render.media)?;
    let loader = Loader {
        shot,
        base: file.parent().unwrap_or(Path::new(".")),
        times: portals.times(),
        rig: &Arc::new(shot.rig.clone()),
        portals: &portals,
        media: &media,
        imported: 0,
    };
    let motions = loader.motions(&sections)?;
    let sequences = loader.sequences(&sections, &motions, None)?;
    let mut out = Vec::new();
    for (o, motion) in sections.iter().zip(&motions) {
        let Some(mesh) = o.mesh.as_ref().filter(|_| deforming(o)) else {
            continue;
        };
        let deformation = &sequences[&loader.base.join(mesh)].mesh;
        let triangles = 0..deformation.triangle_count() as u32;
        let (mut points, mut normals) = (Vec::new(), Vec::new());
        for &f in frames {
            let t = shot.time_of(f);
            let (placed, own) = (motion.at(t), motion.source_time(t));
            let corners = triangles
                .clone()
                .flat_map(|i| deformation.triangle(i, own).v);
            points.push(
                corners
                    .map(|p| placed.transform_point(p.as_dvec3()).as_vec3().to_array())
                    .collect(),
            );
            if deformation.has_normals() {
                let corner_normals = triangles.clone().flat_map(|i| {
                    [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)]
                        .map(|(b1, b2)| deformation.normal(i, own, b1, b2).unwrap_or(Vec3::Y))
                });
                let turned = corner_normals
                    .map(|n| placed.transform_vector(n.as_dvec3()).normalize().as_vec3());
                normals.push(turned.map(|n| n.to_array()).collect());
            }
        }
        out.push(StageMesh {
            name: o.name.clone(),
            points,
            normals,
        });
    }
    Ok(out)
}

/// Where no object deforms, nothing is read but the objects' sections.
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_shot_without_sequences_samples_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.toml");
        let text = "[shot]\nname = \"s\"\nfps = 24.0\nframes = [1, 2]\n[camera]\n\
                    resolution = [8, 8]\nfov_degrees = 40.0\n\
                    transform = { position = [0.0, 0.0, 0.0] }\n[[object]]\nname = \"a\"\n\
                    mesh = \"missing.obj\"\n";
        std::fs::write(&path, text).unwrap();
        let shot = Shot::load(&path).unwrap();
        assert!(sampled(&shot, &[1.0, 2.0]).unwrap().is_empty());
    }
}
