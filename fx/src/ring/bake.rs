//! Baking rings for a frame: tessellation from a screen-space chord-error tolerance, a quadratic
//! motion fit across the shutter, and colour and intensity per vertex.
//!
//! Motion: each vertex is a material point of the procedural strand. Its positions at two
//! times δ₀, δ₁ inside the shutter, with the position at the frame itself, define the quadratic
//! P + vΔ + ½aΔ² that passes through all three. Rotation, the fast part of the motion, is exact at
//! every node; the noise profile is sampled at all three times only when it evolves fast enough
//! for its curvature across the shutter to matter, and is otherwise taken as linear in time
//! (a third fewer noise evaluations). With the nodes at `m ± (√3/2)·h` for a shutter of
//! centre `m` and half-length `h`, the largest error of that quadratic across the shutter is about
//! a quarter of what a Taylor expansion at the frame would give. A closed shutter fits over a
//! half-frame shutter so `v` and `accel` are still meaningful.
//!
//! Tessellation: a polyline with segment length Δs misses a curve of curvature κ by κΔs²/8. The
//! curvature is bounded by that of the ring (1/R) plus the noise's
//! (amplitude · c·Σ wᵢ fᵢ² / R², fᵢ features around the ring per octave, c calibrated for Perlin
//! noise's sharper features); the tolerance in pixels becomes local units at the ring's nearest distance
//! to the camera. The count is clamped to `[fx.min_segments, fx.max_segments]` so rings seen only
//! through portals stay smooth.

use super::curves::{RingCurves, RingFrame};
use super::strand::RingModel;
use super::timing::RingTiming;
use crate::error::FxError;
use crate::rig::Similarity;
use crate::shot::{FrameRange, Shot};
use glam::DVec3;
use std::f64::consts::TAU;

/// How much sharper Perlin noise bends than a sinusoid with as many features, in the curvature
/// estimate. Calibrated so the worst chord error lands near half the tolerance (measured by
/// `tessellation_meets_the_chord_error_tolerance`).
const PERLIN_SHARPNESS: f64 = 1.0;

/// Flares' share of a strand's curvature, per unit of flare height and of the flare channel's
/// mean squared feature frequency: calibrated so the chord-error test on `portal_pair` (the
/// rift preset's flares) stays at a fifth to a third of its tolerance.
const FLARE_SHARPNESS: f64 = 0.6;

/// Generates baked rings for the frames of a shot.
#[derive(Clone, Debug)]
pub struct RingGenerator<'a> {
    shot: &'a Shot,
    /// (opening index, model) for every opening that has a ring.
    models: Vec<(usize, RingModel)>,
    /// Fit nodes δ₀, δ₁ in seconds relative to the frame.
    nodes: [f64; 2],
}

/// Largest quadratic-motion reconstruction error found for one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct MotionError {
    /// Over every vertex of every ring, local units.
    pub max: f64,
    /// `max` divided by that ring's radius.
    pub max_relative: f64,
    /// Over the fastest-turning strand of each ring, divided by the ring's radius.
    pub fastest_strand_relative: f64,
}

impl<'a> RingGenerator<'a> {
    /// Prepares the rings of `shot` for generating any of `frames` (the shot's own range is always
    /// covered too, so results do not depend on which frames a job asks for).
    pub fn new(shot: &'a Shot, frames: FrameRange) -> Self {
        let nodes = fit_nodes(shot.shutter_seconds(), shot.fps);
        let margin = 2.0 / shot.fps;
        let start = shot.time_of(frames.first.min(shot.frames.first) as f64) - margin;
        let end = shot.time_of(frames.last.max(shot.frames.last) as f64) + margin;
        let models = shot
            .rings
            .iter()
            .enumerate()
            .filter_map(|(i, look)| {
                let look = look.as_ref()?;
                let timing = RingTiming::new(shot, i, look, start, end);
                Some((i, RingModel::new(look.clone(), timing)))
            })
            .collect();
        Self {
            shot,
            models,
            nodes,
        }
    }

    /// The most bytes one baked frame of `frames` takes while it is made and written: every
    /// strand of every ring at the vertex count its tessellation gives at that frame, each
    /// vertex's arrays (56 bytes) held once baked and once more in the writer's buffer.
    /// Commands check it against the memory they have before baking anything.
    pub fn frame_bytes_bound(&self, frames: FrameRange) -> u64 {
        const VERTEX_BYTES: u64 = 2 * 56;
        let frame_bytes = |frame: i64| -> u64 {
            let time = self.shot.time_of(frame as f64);
            self.models
                .iter()
                .map(|(i, model)| {
                    let here = self.shot.rig.here_at(*i, time);
                    let vertices = self.segments(model, &here, time) as u64;
                    (model.strands.len() as u64).saturating_mul(vertices * VERTEX_BYTES)
                })
                .fold(0u64, u64::saturating_add)
        };
        frames.iter().map(frame_bytes).max().unwrap_or(0)
    }

    /// The models, one per opening with a ring.
    pub fn models(&self) -> impl Iterator<Item = (usize, &RingModel)> {
        self.models.iter().map(|(i, m)| (*i, m))
    }

    /// Bakes every ring at `frame`.
    /// [`Self::frame`], refused when the rings cannot be rendered or exported (values a shot
    /// within its limits could still push beyond single precision, such as a fast ring far
    /// away); the error names the shot and the ring's opening.
    pub fn checked_frame(&self, frame: i64) -> Result<RingFrame, FxError> {
        let baked = self.frame(frame);
        baked.check().map_err(|message| FxError::Rings {
            file: self.shot.source.clone(),
            frame,
            message,
        })?;
        Ok(baked)
    }

    pub fn frame(&self, frame: i64) -> RingFrame {
        let time = self.shot.time_of(frame as f64);
        RingFrame {
            frame,
            time,
            fps: self.shot.fps,
            shutter: self.shot.shutter_seconds(),
            rings: self
                .models
                .iter()
                .map(|(i, model)| self.bake(*i, model, time))
                .collect(),
        }
    }

    /// Vertices per strand of `model`'s ring, whose opening is at `here`, at time `t`.
    pub fn segments(&self, model: &RingModel, here: &Similarity, t: f64) -> u32 {
        let look = &model.look;
        let settings = &self.shot.fx;
        let camera = &self.shot.camera;
        let reach = look.max_radius() * here.scale;
        let distance = self.apparent_distance(here, reach, t);
        let nearest = (distance - reach).max(0.05 * reach);
        let tolerance =
            settings.chord_error_px * nearest / camera.projection_at(t).focal_pixels() / here.scale;
        let octaves = model.field.octaves(model.timing.lod(t));
        let r = look.min_radius();
        // Flares bend the curve as noise of FLARE_SHARPNESS times their height would, at the
        // flare channel's own feature size.
        let flares = look.instability.as_ref().map_or(0.0, |i| {
            i.flare * look.radius * FLARE_SHARPNESS * model.flare_octaves().mean_square_features()
        });
        let curvature = 1.0 / r
            + (look.noise.amplitude * octaves.mean_square_features() + flares) * PERLIN_SHARPNESS
                / (r * r);
        let step = (8.0 * tolerance / curvature).sqrt();
        let n = (TAU * look.max_radius() / step).ceil();
        (n.min(settings.max_segments as f64) as u32).max(settings.min_segments)
    }

    /// How far the camera is from a ring at `ring` (reaching `reach` from its centre) at `t`:
    /// directly, or seen through an opening, where it is as far as from the camera the solver
    /// places behind the there frame (a teleport keeps angles, so the ring looks that big). An
    /// opening counts when the camera is in front of it and the ring lies wholly beyond its
    /// there frame, where the rays it teleports go; one level of openings is followed.
    fn apparent_distance(&self, ring: &Similarity, reach: f64, t: f64) -> f64 {
        let camera = self.shot.camera.position(t);
        let rig = &self.shot.rig;
        let direct = (camera - ring.translation).length();
        (0..rig.openings.len())
            .filter_map(|i| {
                let here = rig.here_at(i, t);
                let facing = (camera - here.translation).dot(here.rotation * DVec3::Z);
                let there = rig.there_at(i, t);
                let beyond = (ring.translation - there.translation).dot(there.rotation * -DVec3::Z);
                (facing > 0.0 && beyond > reach).then(|| {
                    let seen_from = rig.teleport_at(i, t).transform_point(camera);
                    (seen_from - ring.translation).length()
                })
            })
            .fold(direct, f64::min)
    }

    /// True when the strand profile (radius, height) may be taken as linear in time across a
    /// frame's shutter. Within a shutter the profile moves through noise evolution only (the
    /// level of detail is the frame's: [`RingModel::instant`]); its departure from a straight
    /// line is estimated as 3·amplitude·(evolution·shutter)², and must stay below 2e-5 of the
    /// ring radius. Rotation, the fast part of the motion, is always exact at the fit nodes.
    fn profile_is_linear(&self, model: &RingModel) -> bool {
        let noise = &model.look.noise;
        let [d0, d1] = self.nodes;
        let reach = noise.amplitude * (1.0 + noise.depth);
        let span = noise.evolution * (d1 - d0).abs();
        3.0 * reach * span * span < 2e-5 * model.look.radius
    }

    fn bake(&self, opening: usize, model: &RingModel, time: f64) -> RingCurves {
        let here = self.shot.rig.here_at(opening, time);
        let n = self.segments(model, &here, time) as usize;
        let strands = model.strands.len();
        let [open, close] = self.shot.shutter_seconds();
        let mut out = RingCurves {
            opening: self.shot.rig.openings[opening].name.clone(),
            here,
            here_shutter: [
                self.shot.rig.here_at(opening, time + open),
                self.shot.rig.here_at(opening, time + close),
            ],
            vertex_counts: vec![n as u32; strands],
            directions: model.strands.iter().map(|s| s.direction as i8).collect(),
            ..Default::default()
        };
        let total = n * strands;
        out.points.reserve_exact(total);
        out.velocities.reserve_exact(total);
        out.accelerations.reserve_exact(total);
        out.widths.reserve_exact(total);
        out.colors.reserve_exact(total);
        out.intensities.reserve_exact(total);

        let angles: Vec<(f64, f64)> = (0..n)
            .map(|k| {
                let u = TAU * k as f64 / n as f64;
                (u.cos(), u.sin())
            })
            .collect();
        let fit = QuadraticFit::new(self.nodes);
        let linear_profile = self.profile_is_linear(model);
        for strand in &model.strands {
            let now = model.instant(strand, time, time);
            let before = model.instant(strand, time + self.nodes[0], time);
            let after = model.instant(strand, time + self.nodes[1], time);
            let flicker = model.flicker(strand, time);
            for &(c, s) in &angles {
                let f0 = model.profile(strand, &now, c, s);
                let f1 = model.profile(strand, &after, c, s);
                let f_before = if linear_profile {
                    let ratio = self.nodes[0] / self.nodes[1];
                    [
                        f0[0] + (f1[0] - f0[0]) * ratio,
                        f0[1] + (f1[1] - f0[1]) * ratio,
                    ]
                } else {
                    model.profile(strand, &before, c, s)
                };
                let p = now.rotate(f0, c, s);
                let (v, a) = fit.solve(p, before.rotate(f_before, c, s), after.rotate(f1, c, s));
                let (width, heat) = model.width_and_heat(strand, &now, c, s);
                let (intensity, color) = model.emission(heat, flicker);
                out.points.push(p.as_vec3());
                out.velocities.push(v.as_vec3());
                out.accelerations.push(a.as_vec3());
                out.widths.push(width as f32);
                out.colors.push(color.as_vec3());
                out.intensities.push(intensity as f32);
            }
        }
        out
    }

    /// Measures how far P + vΔ + ½aΔ² (as baked, in f32) strays from the true procedural position
    /// at `samples` times evenly across the shutter of `frame`.
    pub fn motion_error(&self, frame: i64, samples: usize) -> MotionError {
        let baked = self.frame(frame);
        let [s0, s1] = baked.shutter;
        let mut result = MotionError {
            max: 0.0,
            max_relative: 0.0,
            fastest_strand_relative: 0.0,
        };
        for (curves, (_, model)) in baked.rings.iter().zip(&self.models) {
            let fastest = (0..model.strands.len())
                .max_by(|&a, &b| model.strands[a].speed.total_cmp(&model.strands[b].speed))
                .unwrap_or(0);
            let times: Vec<f64> = (0..samples)
                .map(|i| s0 + (s1 - s0) * i as f64 / (samples.max(2) - 1) as f64)
                .collect();
            for (strand_index, (strand, range)) in
                model.strands.iter().zip(curves.strand_ranges()).enumerate()
            {
                let n = range.len();
                let instants: Vec<_> = times
                    .iter()
                    .map(|&d| (d, model.instant(strand, baked.time + d, baked.time)))
                    .collect();
                for (k, vi) in range.enumerate() {
                    let u = TAU * k as f64 / n as f64;
                    let (c, s) = (u.cos(), u.sin());
                    let p = curves.points[vi].as_dvec3();
                    let v = curves.velocities[vi].as_dvec3();
                    let a = curves.accelerations[vi].as_dvec3();
                    for (d, at) in &instants {
                        let truth = model.position(strand, at, c, s);
                        let err = (p + v * *d + 0.5 * a * d * d - truth).length();
                        result.max = result.max.max(err);
                        let rel = err / model.look.radius;
                        result.max_relative = result.max_relative.max(rel);
                        if strand_index == fastest {
                            result.fastest_strand_relative =
                                result.fastest_strand_relative.max(rel);
                        }
                    }
                }
            }
        }
        result
    }
}

/// The two non-zero fit times (seconds from the frame) for a shutter given in seconds.
fn fit_nodes(shutter: [f64; 2], fps: f64) -> [f64; 2] {
    let [mut s0, mut s1] = shutter;
    if s1 - s0 < 1e-9 / fps {
        s0 = -0.25 / fps;
        s1 = 0.25 / fps;
    }
    let (m, h) = (0.5 * (s0 + s1), 0.5 * (s1 - s0));
    let c = 0.75f64.sqrt();
    let (d0, d1) = (m - c * h, m + c * h);
    if d0.abs() < 1e-6 * h || d1.abs() < 1e-6 * h {
        [s0, s1]
    } else {
        [d0, d1]
    }
}

/// Solves P(δ) = P₀ + vδ + ½aδ² through P(δ₀) and P(δ₁).
struct QuadraticFit {
    nodes: [f64; 2],
    inv_det: f64,
}

impl QuadraticFit {
    fn new(nodes: [f64; 2]) -> Self {
        let [d0, d1] = nodes;
        Self {
            nodes,
            inv_det: 1.0 / (0.5 * d0 * d1 * (d1 - d0)),
        }
    }

    /// (v, a) from the positions at the frame, at δ₀ and at δ₁.
    #[inline]
    fn solve(&self, p: DVec3, p0: DVec3, p1: DVec3) -> (DVec3, DVec3) {
        let [d0, d1] = self.nodes;
        let (e0, e1) = (p0 - p, p1 - p);
        let v = (e0 * (0.5 * d1 * d1) - e1 * (0.5 * d0 * d0)) * self.inv_det;
        let a = (e1 * d0 - e0 * d1) * self.inv_det;
        (v, a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quadratic_fit_is_exact_for_quadratics() {
        for shutter in [
            [-0.01, 0.01],
            [0.0, 0.02],
            [-0.03, 0.0],
            [-0.005, 0.015],
            [0.0, 0.0],
        ] {
            let nodes = fit_nodes(shutter, 24.0);
            assert!(nodes[0] != 0.0 && nodes[1] != 0.0 && nodes[0] != nodes[1]);
            let fit = QuadraticFit::new(nodes);
            let (v, a) = (DVec3::new(1.0, -2.0, 3.0), DVec3::new(-40.0, 5.0, 0.5));
            let p = DVec3::new(0.3, 0.1, -0.2);
            let at = |d: f64| p + v * d + 0.5 * a * d * d;
            let (fv, fa) = fit.solve(p, at(nodes[0]), at(nodes[1]));
            assert!((fv - v).length() < 1e-9 && (fa - a).length() < 1e-6);
        }
    }
}

#[cfg(test)]
mod tessellation_tests {
    use super::*;
    use std::path::Path;

    /// Largest distance, in pixels at the ring's nearest distance to camera, between the true
    /// strand and its polyline (checked at segment quarter- and mid-points), over every strand.
    fn worst_chord_error_px(shot: &Shot, frame: i64) -> (f64, u32) {
        worst_chord_error_px_at(shot, frame, &|here, t| {
            (shot.camera.position(t) - here.translation).length()
        })
    }

    /// [`worst_chord_error_px`] with the camera as far from a ring at `here` as `distance`
    /// says (as it looks through an opening).
    fn worst_chord_error_px_at(
        shot: &Shot,
        frame: i64,
        distance: &dyn Fn(&Similarity, f64) -> f64,
    ) -> (f64, u32) {
        let generator = RingGenerator::new(shot, shot.frames);
        let t = shot.time_of(frame as f64);
        let mut worst = (0.0f64, 0);
        for (i, model) in generator.models() {
            let here = shot.rig.here_at(i, t);
            let n = generator.segments(model, &here, t);
            let reach = model.look.max_radius() * here.scale;
            let nearest = (distance(&here, t) - reach).max(0.05 * reach);
            let px_per_local = shot.camera.projection_at(t).focal_pixels() / nearest * here.scale;
            for strand in &model.strands {
                let at = model.instant(strand, t, t);
                let point = |u: f64| model.position(strand, &at, u.cos(), u.sin());
                for k in 0..n {
                    let (u0, u1) = (TAU * k as f64 / n as f64, TAU * (k + 1) as f64 / n as f64);
                    let (a, b) = (point(u0), point(u1));
                    for f in [0.25, 0.5, 0.75] {
                        let on_curve = point(u0 + f * (u1 - u0));
                        // Distance from the curve point to the chord segment.
                        let ab = b - a;
                        let s = ((on_curve - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
                        let d = (on_curve - (a + ab * s)).length() * px_per_local;
                        worst.0 = worst.0.max(d);
                    }
                }
                worst.1 = worst.1.max(n);
            }
        }
        worst
    }

    /// The segments per strand of ring "B" at the shot's first frame.
    fn segments_of_b(text: &str) -> u32 {
        let shot = Shot::parse(text, Path::new("through.toml")).unwrap();
        let generator = RingGenerator::new(&shot, shot.frames);
        let t = shot.time_of(shot.frames.first as f64);
        let (i, model) = generator
            .models()
            .find(|(i, _)| shot.rig.openings[*i].name == "B")
            .unwrap();
        generator.segments(model, &shot.rig.here_at(i, t), t)
    }

    #[test]
    fn a_ring_seen_through_an_opening_is_tessellated_for_its_size_there() {
        let head = "[shot]\nname = \"through\"\nfps = 24.0\nframes = [1, 1]\n\
                    [camera]\nresolution = [1280, 720]\nfov_degrees = 40.0\n\
                    [camera.transform]\nposition = [0.0, 0.0, 0.0]\n\
                    [fx]\nmin_segments = 3\nchord_error_px = 0.25\n";
        let ring = |x: f64, z: f64| {
            format!(
                "[[portal]]\nname = \"B\"\nhere = {{ position = [{x}, 0.0, {z}] }}\n\
                 there = {{ position = [{x}, 50.0, 0.0] }}\n[portal.ring]\npreset = \"rift\"\n\
                 radius = 1.0\nseed = 7\n"
            )
        };
        // 6 m ahead of the camera, directly; 100 m away to the side, directly; and there again,
        // but seen through an opening 2 m ahead whose there side is 4 m in front of it.
        let direct = segments_of_b(&(head.to_owned() + &ring(0.0, -6.0)));
        let far = segments_of_b(&(head.to_owned() + &ring(100.0, -6.0)));
        let opening = "[[portal]]\nname = \"A\"\nhere = { position = [0.0, 0.0, -2.0] }\n\
                       there = { position = [100.0, 0.0, -2.0] }\n";
        let through = segments_of_b(&(head.to_owned() + opening + &ring(100.0, -6.0)));
        assert!(far < direct / 4, "{far} segments at 100 m, {direct} at 6 m");
        assert!(
            through > 4 * far,
            "{through} segments through the opening, {far} without"
        );
        // Through the opening its polylines keep the chord error seen from 6 m (its detail, which
        // follows its direct distance as its look asks, is that of a far ring).
        let text = head.to_owned() + opening + &ring(100.0, -6.0);
        let shot = Shot::parse(&text, Path::new("through.toml")).unwrap();
        let (err, n) = worst_chord_error_px_at(&shot, 1, &|_, _| 6.0);
        assert!(
            (0.025..=0.25).contains(&err),
            "{err:.3} px with {n} segments"
        );
        // Behind the there frame, where no teleported ray goes, the opening does not count.
        let behind = "[[portal]]\nname = \"A\"\nhere = { position = [0.0, 0.0, -2.0] }\n\
                      there = { position = [100.0, 0.0, -10.0] }\n";
        assert_eq!(
            segments_of_b(&(head.to_owned() + behind + &ring(100.0, -6.0))),
            far
        );
    }

    #[test]
    fn tessellation_meets_the_chord_error_tolerance() {
        let text = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/shots/portal_pair.toml"),
        )
        .unwrap();
        // Let the tolerance, not the minimum, decide the count.
        let text = text.replace("min_segments = 96", "min_segments = 3");
        for tolerance in [0.1, 0.25, 1.0] {
            let text = text.replace(
                "chord_error_px = 0.25",
                &format!("chord_error_px = {tolerance}"),
            );
            let shot = Shot::parse(&text, Path::new("portal_pair.toml")).unwrap();
            for frame in [1001, 1050, 1096] {
                let (err, n) = worst_chord_error_px(&shot, frame);
                eprintln!(
                    "tolerance {tolerance} px, frame {frame}: worst chord error {err:.3} px, {n} segments"
                );
                assert!(n < shot.fx.max_segments, "count clamped");
                assert!(
                    err <= tolerance,
                    "frame {frame}: chord error {err:.3} px > {tolerance} px with {n} segments"
                );
                // Not wastefully fine either: within a factor of ten of the tolerance.
                assert!(
                    err >= 0.1 * tolerance,
                    "frame {frame}: {err:.4} px is far below {tolerance} px ({n} segments)"
                );
            }
        }
    }
}
