//! Perceptual speed and detail: with full compensation a ring's rim crosses the screen equally
//! fast, and its noise features keep their screen size, whatever the distance and angle; camera
//! sync through a teleport keeps the picture.

use glam::DVec3;
use rift_fx::Shot;
use rift_fx::rig::Similarity;
use rift_fx::ring::{RingGenerator, RingTiming};
use std::path::Path;

fn shot(distance: f64, yaw: f64, speed: &str, frames: [i64; 2], camera_z_end: Option<f64>) -> Shot {
    let end = camera_z_end.unwrap_or(distance);
    let text = format!(
        r#"
[shot]
name = "p"
fps = 24.0
frames = [{f0}, {f1}]
[camera]
resolution = [1000, 500]
fov_degrees = 30.0
fov_axis = "vertical"
[camera.transform]
interpolation = "linear"
keys = [{{ frame = {f0}, position = [0.0, 0.0, {distance}] }}, {{ frame = {f1}, position = [0.0, 0.0, {end}] }}]
[[portal]]
name = "a"
here = {{ rotation_degrees = [0.0, {yaw}, 0.0] }}
there = {{ position = [5.0, 0.0, 0.0] }}
[portal.ring]
radius = 1.0
strands = 2
speed = {{ {speed} }}
"#,
        f0 = frames[0],
        f1 = frames[1],
    );
    Shot::parse(&text, Path::new("p.toml")).unwrap()
}

fn timing(shot: &Shot) -> RingTiming {
    let g = RingGenerator::new(shot, shot.frames);
    g.models().next().unwrap().1.timing.clone()
}

const FULL: &str = "turns_per_second = 0.5, size_compensation = 1.0, min_visible_turn = 0.0";

#[test]
fn farther_rings_turn_faster_so_the_rim_looks_as_fast() {
    let t = 1.0;
    let near = timing(&shot(4.0, 0.0, FULL, [1, 48], None)).angular_velocity(t);
    let far = timing(&shot(8.0, 0.0, FULL, [1, 48], None)).angular_velocity(t);
    // Apparent size halves, so ω doubles: ω·size (rim speed on screen) is the same.
    assert!((far / near - 2.0).abs() < 1e-9, "ratio {}", far / near);
    // Without compensation the world speed is fixed.
    let fixed = "turns_per_second = 0.5, size_compensation = 0.0, min_visible_turn = 0.0";
    let a = timing(&shot(4.0, 0.0, fixed, [1, 48], None)).angular_velocity(t);
    let b = timing(&shot(8.0, 0.0, fixed, [1, 48], None)).angular_velocity(t);
    assert!((a - std::f64::consts::PI).abs() < 1e-9 && (b - a).abs() < 1e-12);
}

#[test]
fn oblique_rings_are_compensated_for_foreshortening() {
    let t = 1.0;
    let facing = timing(&shot(6.0, 0.0, FULL, [1, 48], None)).angular_velocity(t);
    let oblique = timing(&shot(6.0, 60.0, FULL, [1, 48], None)).angular_velocity(t);
    // cos 60° = 0.5: the ellipse perimeter is 0.7709 of the circle's (Ramanujan).
    let b: f64 = 0.5;
    let ratio = std::f64::consts::PI * (3.0 * (1.0 + b) - ((3.0 + b) * (1.0 + 3.0 * b)).sqrt())
        / std::f64::consts::TAU;
    assert!(
        (facing / oblique - ratio).abs() < 1e-6,
        "{} vs {ratio}",
        facing / oblique
    );
}

#[test]
fn a_briefly_seen_ring_still_turns_visibly() {
    // A 12-frame shot with the ring in view throughout: half a second of screen time, and a
    // requested speed far too slow to read in that time.
    let slow = "turns_per_second = 0.001, size_compensation = 0.0, min_visible_turn = 0.25";
    let seen = timing(&shot(6.0, 0.0, slow, [1, 12], None));
    assert!((seen.screen_time - 0.5).abs() < 1e-12);
    // 0.25 turns in 0.5 s of screen time: at least π rad/s.
    assert!((seen.angular_velocity(0.2) - std::f64::consts::PI).abs() < 1e-9);
}

#[test]
fn phase_stays_continuous_while_speed_changes() {
    // Camera dollies from 3 m to 30 m: ω rises tenfold; Θ must follow ∫ω exactly.
    let s = shot(3.0, 0.0, FULL, [1, 48], Some(30.0));
    let timing = timing(&s);
    let (t0, t1) = (1.0 / 24.0, 2.0);
    let steps = 20_000;
    let h = (t1 - t0) / steps as f64;
    let integral: f64 = (0..steps)
        .map(|i| {
            let a = t0 + i as f64 * h;
            h / 6.0
                * (timing.angular_velocity(a)
                    + 4.0 * timing.angular_velocity(a + 0.5 * h)
                    + timing.angular_velocity(a + h))
        })
        .sum();
    let measured = timing.angle(t1) - timing.angle(t0);
    assert!(
        (measured - integral).abs() < 1e-3 * integral,
        "{measured} vs {integral}"
    );
    assert!(timing.angular_velocity(t1) > 5.0 * timing.angular_velocity(t0));
}

#[test]
fn noise_detail_follows_apparent_size_smoothly() {
    let s = shot(3.0, 0.0, FULL, [1, 48], Some(24.0));
    let timing = timing(&s);
    // Eight times farther: three octaves less detail, with no step anywhere along the way.
    let l0 = timing.lod(1.0 / 24.0);
    let l1 = timing.lod(2.0);
    assert!((l0 - l1 - 3.0).abs() < 0.05, "{l0} → {l1}");
    let mut prev = timing.lod(1.0 / 24.0);
    for i in 1..=2000 {
        let l = timing.lod(1.0 / 24.0 + i as f64 * (2.0 - 1.0 / 24.0) / 2000.0);
        assert!((l - prev).abs() < 0.01, "LOD jumps by {}", l - prev);
        prev = l;
    }
}

#[test]
fn camera_sync_through_a_teleport_keeps_the_picture() {
    let s = shot(6.0, 0.0, FULL, [1, 48], None);
    let teleport = Similarity::new(
        glam::DQuat::from_rotation_y(1.0),
        DVec3::new(3.0, -1.0, 2.0),
        2.5,
    );
    let (frame, projection) = s.camera.frame_through(&teleport, 0.5);
    assert_eq!(projection.fov_y, s.camera.projection.fov_y);
    assert_eq!(projection.resolution, s.camera.projection.resolution);
    assert!((projection.focus_distance - 2.5 * s.camera.projection.focus_distance).abs() < 1e-12);
    // A point and its teleported copy sit at the same place in their cameras' spaces (the
    // camera frame carries the teleport's scale), so the two images are the same.
    let world = DVec3::new(0.3, -0.2, 1.0);
    let seen = s.camera.transform.at(0.5).inverse().transform_point(world);
    let seen_there = frame
        .inverse()
        .transform_point(teleport.transform_point(world));
    assert!((seen - seen_there).length() < 1e-12);
    // ... while world distances there are 2.5 times larger, as the focus distance is.
    let (c0, c1) = (s.camera.position(0.5), frame.translation);
    let d_there = (teleport.transform_point(world) - c1).length();
    assert!((d_there - 2.5 * (world - c0).length()).abs() < 1e-12);
}

/// Every ring preset keeps perceptual speed: a ring twice as far turns twice as fast, so its
/// rim crosses the screen equally fast (the presets compensate fully for size).
#[test]
fn every_preset_keeps_the_rim_speed_on_screen() {
    for preset in rift_fx::ring::presets::NAMES {
        let at = |distance: f64| {
            let text = format!(
                "[shot]\nname = \"p\"\nfps = 24.0\nframes = [1, 48]\n[camera]\n\
                 resolution = [1000, 500]\nfov_degrees = 30.0\n[camera.transform]\n\
                 position = [0.0, 0.0, {distance}]\n[[portal]]\nname = \"a\"\nhere = {{ position = [0.0, 0.0, 0.0] }}\n\
                 there = {{ position = [5.0, 0.0, 0.0] }}\n[portal.ring]\npreset = \"{preset}\"\n\
                 radius = 1.0\nspeed = {{ min_visible_turn = 0.0 }}\n"
            );
            let shot = Shot::parse(&text, Path::new("p.toml")).unwrap();
            timing(&shot).angular_velocity(1.0)
        };
        let (near, far) = (at(4.0), at(8.0));
        assert!(near > 0.0, "{preset}: the ring does not turn");
        assert!(
            (far / near - 2.0).abs() < 1e-9,
            "{preset}: ratio {}",
            far / near
        );
    }
}
