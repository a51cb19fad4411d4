//! The edge of a ringed opening follows its strands: at the showcase's frame 12, the tabulated
//! teleport boundary of both openings agrees with the exact inner envelope of the strands'
//! polylines (every angle, every time in the shutter) to a fraction of a pixel at 1280×720.
//!
//! The bright straight-edged patch at the top of the back opening in that frame is not a gap
//! in the mask: it is the ceiling light, seen through the opening (it goes when the light is
//! removed); `boundary_matches_the_exact_envelope` is what rules the gap out.

use glam::{DVec2, Vec2};
use rift_render::Scene;
use rift_render::portals::masks::Mask;
use rift_render::rift_fx::ring::{RingCurves, RingGenerator};
use rift_render::rift_fx::{FrameRange, Shot};
use std::f64::consts::TAU;
use std::path::Path;

const FRAME: i64 = 12;

/// The smallest radius at which a strand's polyline crosses the angle `theta`, `delta` seconds
/// after the frame (0 where none does), found segment by segment without any table.
fn exact_envelope(curves: &RingCurves, theta: f64, delta: f32) -> f64 {
    let u = DVec2::new(theta.cos(), theta.sin());
    let at = |i: usize| {
        let p = curves.position_at(i, delta);
        Vec2::new(p.x, p.y).as_dvec2()
    };
    let mut nearest = f64::INFINITY;
    for (i, j) in curves.segments() {
        let (a, b) = (at(i), at(j));
        let e = b - a;
        let denominator = u.perp_dot(e);
        if denominator == 0.0 {
            continue;
        }
        // Where the ray from the centre along u meets the segment's line, and how far along
        // the segment that is.
        let r = a.perp_dot(e) / denominator;
        let s = a.perp_dot(u) / denominator;
        if r > 0.0 && (0.0..=1.0).contains(&s) {
            nearest = nearest.min(r);
        }
    }
    if nearest.is_finite() { nearest } else { 0.0 }
}

/// The mask's radius along `theta` at `time`, by bisection on `Mask::contains` (what rays see).
fn mask_radius(mask: &Mask, theta: f64, time: f64) -> f64 {
    let u = DVec2::new(theta.cos(), theta.sin());
    let (mut inside, mut outside) = (0.0, 2.0 * mask.bounding_radius() + 1.0);
    for _ in 0..48 {
        let mid = 0.5 * (inside + outside);
        if mask.contains(u * mid, time) {
            inside = mid;
        } else {
            outside = mid;
        }
    }
    inside
}

#[test]
fn boundary_matches_the_exact_envelope() {
    let shot = Shot::load(Path::new("../examples/shots/showcase.toml")).unwrap();
    let scene = Scene::load(&shot, FRAME).unwrap();
    let rings = RingGenerator::new(
        &shot,
        FrameRange {
            first: FRAME,
            last: FRAME,
        },
    )
    .frame(FRAME);
    let [open, close] = rings.shutter;
    // Pixels per metre at the opening: the lens's focal length in pixels over the distance.
    let focal_pixels = shot.camera.projection.focal_pixels();
    assert_eq!(shot.camera.projection.resolution, [1280, 720]);
    for curves in &rings.rings {
        let opening = (shot.rig.openings.iter())
            .position(|o| o.name == curves.opening)
            .expect("ring of a known opening");
        let mask = scene.portals.mask(opening);
        assert!(
            matches!(mask, Mask::Ring(_)),
            "{} has a ring mask",
            curves.opening
        );
        let mut worst_px = 0.0f64;
        let mut gaps = 0;
        for step in 0..5 {
            let delta = open + (close - open) * step as f64 / 4.0;
            let time = rings.time + delta;
            let here = scene.portals.here(opening, time);
            let distance = (shot.camera.position(time) - here.translation).length();
            let px_per_local = focal_pixels * here.scale / distance;
            for k in 0..2048 {
                let theta = TAU * (k as f64 + 0.37) / 2048.0;
                let exact = exact_envelope(curves, theta, delta as f32);
                let table = mask_radius(mask, theta, time);
                let px = (table - exact) * px_per_local;
                worst_px = worst_px.max(px.abs());
                gaps += usize::from(px < -0.25);
            }
        }
        println!("{}: worst edge error {worst_px:.3} px", curves.opening);
        assert!(
            worst_px < 0.5,
            "{}: edge off by {worst_px} px",
            curves.opening
        );
        assert_eq!(
            gaps, 0,
            "{}: the mask stops short of the strands",
            curves.opening
        );
    }
}
