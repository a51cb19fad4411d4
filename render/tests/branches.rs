//! Paths split where they first scatter (`[render] indirect_samples`): the same image in
//! expectation, through openings, media and light sampling through openings as in the plain
//! box (whose mean against the reference tests/cornell.rs checks).

use crate::common;

use common::assert_statistically_equal;
use rift_render::Scene;
use rift_render::frame::{RenderOptions, render};
use rift_render::prepare::Prepared;
use rift_render::rift_fx::Shot;
use std::path::Path;

#[test]
fn split_paths_render_the_through_portal_example_as_whole_ones_do() {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/shots/through_portal.toml");
    let mut shot = Shot::load(&file).unwrap();
    shot.camera.projection.resolution = [96, 54];
    let render_with = |branches: u32, seed: u32| {
        let mut scene = Scene::load(&shot, 12).unwrap();
        assert!(
            !scene.only_surfaces_and_lamps(),
            "the full loop is the one tested"
        );
        scene.settings.seed = seed;
        scene.settings.indirect_samples = branches;
        render(&Prepared::new(scene), &RenderOptions::new(16)).rgb
    };
    // Three branches: a count that is not a power of two, whose branch indices still cover
    // the sequence.
    let (whole, whole_again) = (render_with(1, 1), render_with(1, 2));
    let (split, split_again) = (render_with(3, 3), render_with(3, 4));
    assert_statistically_equal(
        [&split, &split_again],
        [&whole, &whole_again],
        "three branches against whole paths",
    );
}
