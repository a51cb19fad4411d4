//! Helpers shared by the renderer's integration tests.

use rift_render::Scene;
use rift_render::film::Image;
use rift_render::render::{RenderOptions, render};
use rift_render::rift_fx::Shot;
use std::path::Path;

/// Writes `text` as `dir/<name>.toml`, builds frame 1 and renders it at `spp`.
pub fn render_shot(dir: &Path, name: &str, text: &str, spp: u32) -> Image {
    render_shot_with(dir, name, text, spp, None)
}

/// [`render_shot`], with `seed` (if given) in place of the shot's.
pub fn render_shot_with(dir: &Path, name: &str, text: &str, spp: u32, seed: Option<u32>) -> Image {
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, text).unwrap();
    let shot = Shot::load(&path).unwrap();
    let mut scene = Scene::build(&shot, 1).unwrap();
    if let Some(seed) = seed {
        scene.settings.seed = seed;
    }
    render(&scene, &RenderOptions::new(spp))
}
