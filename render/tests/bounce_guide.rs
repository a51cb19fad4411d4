//! Bounces aimed at openings: on the example whose dark room is lit only by light that bounced
//! in the room beyond its window, aiming must keep the estimate (the same means as BSDF
//! sampling alone), lower the noise, learn the same guide whatever the thread count, and stay
//! away from scenes it cannot help.

use crate::common;

use common::assert_statistically_equal;
use glam::Vec3;
use rift_render::frame::film::relative_mse;
use rift_render::frame::{RenderOptions, render};
use rift_render::prepare::Prepared;
use rift_render::rift_fx::Shot;
use rift_render::scene::Overrides;
use rift_render::through::bounce_guide::LEAST_SHARE;
use std::path::Path;

/// The example shot at `width`×(9/16 of it) with aiming `on` or off and `seed`.
fn bounce_through(width: u32, on: bool, seed: u32) -> Prepared {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/shots/bounce_through.toml");
    let mut shot = Shot::load(&file).unwrap();
    shot.camera.projection.resolution = [width, width * 9 / 16];
    let overrides = Overrides {
        guide_through_openings: Some(on),
        seed: Some(seed),
        ..Default::default()
    };
    Prepared::build(&shot, 1, &overrides).unwrap()
}

#[test]
fn aiming_keeps_the_estimate_and_lowers_the_noise() {
    let images = |on: bool| {
        [1, 2].map(|seed| render(&bounce_through(64, on, seed), &RenderOptions::new(256)).rgb)
    };
    let (aimed, plain) = (images(true), images(false));
    assert_statistically_equal(
        [&aimed[0], &aimed[1]],
        [&plain[0], &plain[1]],
        "aimed against BSDF sampling alone",
    );
    let noise = |pair: &[Vec<Vec3>; 2]| relative_mse(&pair[0], &pair[1]);
    let (with, without) = (noise(&aimed), noise(&plain));
    eprintln!("noise {with:e} aimed against {without:e}");
    // Measured 45× less (in about twice the time; 32× when shares below 5% did not aim and
    // shares went up to 0.8). A guide that aimed nowhere, or a roulette that killed the paths
    // reaching the bright room, would not come near a sixteenth.
    assert!(
        with < without / 16.0,
        "noise {with:e} aimed against {without:e}"
    );
}

#[test]
fn the_dark_room_aims_at_its_window_and_the_far_room_no_more_than_the_least() {
    let prepared = bounce_through(64, true, 1);
    let guide = prepared.bounce_guide.as_ref().expect("a guide");
    // The dark room's floor in front of the window: aims at the window (opening 0).
    let floor = guide.at(Vec3::new(-1.5, 0.0, 0.3)).expect("learned there");
    let aim = floor.aim.expect("the floor aims");
    assert!(aim.share > 0.3, "share {}", aim.share);
    assert_eq!(aim.openings().next().map(|(o, _)| o), Some(0));
    // The far room's far wall: what comes back through its window is the dark room's light, a
    // small part of what it sees, so it aims at most the least share; and a bounce there
    // brings back far more than in the dark room.
    let far_wall = guide.at(Vec3::new(37.0, 1.5, 0.0)).expect("learned there");
    assert!(
        far_wall.aim.is_none_or(|a| a.share <= LEAST_SHARE),
        "{:?}",
        far_wall.aim
    );
    assert!(far_wall.brought > 10.0 * floor.brought);
    // Switched off: no guide; and off is the default for a shot that does not ask.
    assert!(bounce_through(64, false, 1).bounce_guide.is_none());
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/shots/lit_through.toml");
    let shot = Shot::load(&file).unwrap();
    let default = Prepared::build(&shot, 1, &Overrides::default()).unwrap();
    assert!(default.bounce_guide.is_none());
}

#[test]
fn the_guide_and_the_image_are_the_same_for_any_thread_count() {
    let run = |threads| {
        common::on_threads(threads, || {
            let prepared = bounce_through(48, true, 3);
            let image = render(&prepared, &RenderOptions::new(4)).rgb;
            (prepared.bounce_guide, image)
        })
    };
    let (one, three) = (run(1), run(3));
    assert!(one.0.is_some());
    assert!(
        one == three,
        "the guide or the image depends on the thread count"
    );
}

#[test]
fn scenes_without_openings_learn_no_guide() {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/cornell.toml");
    let shot = Shot::load(&file).unwrap();
    let asked = Overrides {
        guide_through_openings: Some(true),
        ..Default::default()
    };
    let prepared = Prepared::build(&shot, shot.frames.first, &asked).unwrap();
    assert!(prepared.bounce_guide.is_none());
}
