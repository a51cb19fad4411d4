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

/// Angles at which the boundary is compared, per ring and time.
const ANGLES: usize = 2048;

/// The `k`-th compared angle.
fn angle(k: usize) -> f64 {
    TAU * (k as f64 + 0.37) / ANGLES as f64
}

/// The strands' polyline vertices in the opening's plane, `delta` seconds after the frame.
fn polyline_points(curves: &RingCurves, delta: f32) -> Vec<DVec2> {
    (0..curves.points.len())
        .map(|i| {
            let p = curves.position_at(i, delta);
            Vec2::new(p.x, p.y).as_dvec2()
        })
        .collect()
}

/// Where the ray from the centre along `u` meets the segment from `a` to `b`: its radius, if
/// it does.
fn crossing(u: DVec2, a: DVec2, b: DVec2) -> Option<f64> {
    let e = b - a;
    let denominator = u.perp_dot(e);
    if denominator == 0.0 {
        return None;
    }
    // Where the ray meets the segment's line, and how far along the segment that is.
    let r = a.perp_dot(e) / denominator;
    let s = a.perp_dot(u) / denominator;
    (r > 0.0 && (0.0..=1.0).contains(&s)).then_some(r)
}

/// The smallest radius at which a strand's polyline crosses the angle `theta` (0 where none
/// does), every segment tried: the definition, which [`exact_envelope`] must equal.
fn envelope_by_every_segment(curves: &RingCurves, points: &[DVec2], theta: f64) -> f64 {
    let u = DVec2::new(theta.cos(), theta.sin());
    let nearest = (curves.segments())
        .filter_map(|(i, j)| crossing(u, points[i], points[j]))
        .fold(f64::INFINITY, f64::min);
    if nearest.is_finite() { nearest } else { 0.0 }
}

/// [`envelope_by_every_segment`] at each of the [`ANGLES`] angles, found segment by segment
/// without any table: each segment is tried at the angles its ends subtend from the centre
/// (and one more on each side), the only ones whose ray can meet it.
fn exact_envelope(curves: &RingCurves, points: &[DVec2]) -> Vec<f64> {
    let step = TAU / ANGLES as f64;
    let mut nearest = vec![f64::INFINITY; ANGLES];
    for (i, j) in curves.segments() {
        let (a, b) = (points[i], points[j]);
        let from = a.y.atan2(a.x);
        // The signed angle from a to b, the short way round.
        let sweep = a.perp_dot(b).atan2(a.dot(b));
        let (low, high) = if sweep.abs() > 3.0 {
            // Passing next to the centre: every angle.
            (0, ANGLES as i64 - 1)
        } else {
            let (start, end) = (from.min(from + sweep), from.max(from + sweep));
            (
                (start / step - 0.37).floor() as i64 - 1,
                (end / step - 0.37).ceil() as i64 + 1,
            )
        };
        for k in low..=high {
            let k = k.rem_euclid(ANGLES as i64) as usize;
            let theta = angle(k);
            if let Some(r) = crossing(DVec2::new(theta.cos(), theta.sin()), a, b) {
                nearest[k] = nearest[k].min(r);
            }
        }
    }
    nearest
        .into_iter()
        .map(|r| if r.is_finite() { r } else { 0.0 })
        .collect()
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
            let points = polyline_points(curves, delta as f32);
            let envelope = exact_envelope(curves, &points);
            // The pruned search finds what trying every segment finds, at a sample of angles.
            for k in (0..ANGLES).step_by(61) {
                assert_eq!(
                    envelope[k],
                    envelope_by_every_segment(curves, &points, angle(k)),
                    "{} at angle {k}",
                    curves.opening
                );
            }
            for (k, exact) in envelope.into_iter().enumerate() {
                let table = mask_radius(mask, angle(k), time);
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
