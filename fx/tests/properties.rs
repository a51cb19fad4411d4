//! Property tests of the ring effect and the rig maths, over randomly drawn shots and looks.

use glam::{DQuat, DVec3};
use proptest::prelude::*;
use rift_fx::Shot;
use rift_fx::rig::Similarity;
use rift_fx::rig::opening::{solve_here, solve_there};
use rift_fx::ring::RingGenerator;
use std::path::Path;

/// A random but sensible look and camera path, as shot text.
#[derive(Debug, Clone)]
struct Params {
    radius: f64,
    band: f64,
    amplitude: f64,
    depth: f64,
    frequency: f64,
    octaves: u32,
    evolution: f64,
    turns: f64,
    compensation: f64,
    strands: u32,
    counter: f64,
    seed: u32,
    distance: [f64; 2],
    yaw: f64,
    scale: f64,
}

fn params() -> impl Strategy<Value = Params> {
    (
        (
            0.3f64..3.0,
            0.0f64..0.1,
            0.0f64..0.06,
            0.0f64..1.0,
            1.0f64..12.0,
            1u32..5,
        ),
        (
            0.0f64..2.0,
            0.02f64..0.5,
            0.0f64..1.0,
            1u32..7,
            0.0f64..1.0,
            any::<u32>(),
        ),
        (3.0f64..30.0, 3.0f64..30.0, -70.0f64..70.0, 0.5f64..2.0),
    )
        .prop_map(|(a, b, c)| Params {
            radius: a.0,
            band: a.1 * a.0,
            amplitude: a.2 * a.0,
            depth: a.3,
            frequency: a.4,
            octaves: a.5,
            evolution: b.0,
            turns: b.1,
            compensation: b.2,
            strands: b.3,
            counter: b.4,
            seed: b.5,
            distance: [c.0, c.1],
            yaw: c.2,
            scale: c.3,
        })
}

fn shot(p: &Params) -> Shot {
    Shot::parse(&shot_text(p), Path::new("prop.toml")).expect("the generated shot is valid")
}

fn shot_text(p: &Params) -> String {
    format!(
        r#"
[shot]
name = "prop"
fps = 24.0
frames = [1, 24]
[camera]
resolution = [640, 360]
fov_degrees = 45.0
[camera.transform]
keys = [
  {{ frame = 1, position = [0.0, 0.0, {d0}], look_at = [0.0, 0.0, 0.0] }},
  {{ frame = 24, position = [1.0, 0.5, {d1}], look_at = [0.0, 0.0, 0.0] }},
]
[fx]
min_segments = 32
max_segments = 2048
[[portal]]
name = "a"
here = {{ rotation_degrees = [0.0, {yaw}, 0.0], scale = {scale} }}
there = {{ position = [10.0, 0.0, 0.0] }}
[portal.ring]
radius = {radius}
band = {band}
strands = {strands}
counter_rotating = {counter}
width = {width}
seed = {seed}
noise = {{ amplitude = {amplitude}, depth = {depth}, frequency = {frequency}, octaves = {octaves}, evolution = {evolution}, size_compensation = {compensation} }}
speed = {{ turns_per_second = {turns}, size_compensation = {compensation} }}
"#,
        d0 = p.distance[0],
        d1 = p.distance[1],
        yaw = p.yaw,
        scale = p.scale,
        radius = p.radius,
        band = p.band,
        strands = p.strands,
        counter = p.counter,
        width = 0.01 * p.radius,
        seed = p.seed,
        amplitude = p.amplitude,
        depth = p.depth,
        frequency = p.frequency,
        octaves = p.octaves,
        evolution = p.evolution,
        turns = p.turns,
        compensation = p.compensation,
    )
}

/// The same camera path and opening with a named ring preset instead of an explicit look (size
/// compensation limited as `motion_reconstruction_error_is_small` limits it).
fn preset_shot(p: &Params, preset: &str) -> Shot {
    // Dollies of at most 2x in the second: faster ones exceed the motion bound with any look
    // of many strands (see `known_fast_dolly_case`).
    let mut p = p.clone();
    p.distance[1] = p.distance[1].clamp(p.distance[0] / 2.0, p.distance[0] * 2.0);
    let p = &p;
    let text = shot_text(p);
    let ring = text
        .find("[portal.ring]")
        .expect("the generated shot has a ring");
    let text = format!(
        "{}[portal.ring]\npreset = \"{preset}\"\nradius = {}\nseed = {}\nspeed = {{ size_compensation = {c} }}\nnoise = {{ size_compensation = {c} }}\n",
        &text[..ring],
        p.radius,
        p.seed,
        c = p.compensation.min(0.5),
    );
    Shot::parse(&text, Path::new("prop.toml")).expect("the generated shot is valid")
}

fn presets() -> impl Strategy<Value = &'static str> {
    prop::sample::select(rift_fx::ring::presets::NAMES.to_vec())
}

proptest! {
    // A fixed seed keeps CI deterministic; explore new cases locally with
    // PROPTEST_RNG_SEED=<n> or more PROPTEST_CASES.
    #![proptest_config(ProptestConfig {
        cases: 40,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x5249_4654),
        ..ProptestConfig::default()
    })]

    /// Strands are closed curves that stay within the ring's radial and axial bounds, with widths
    /// within the look's variation.
    #[test]
    fn strands_are_closed_and_bounded(p in params(), frame in 1i64..24) {
        let shot = shot(&p);
        let look = shot.rings[0].clone().unwrap();
        let baked = RingGenerator::new(&shot, shot.frames).frame(frame);
        let ring = &baked.rings[0];
        prop_assert_eq!(ring.vertex_counts.len(), p.strands as usize);
        let eps = 1e-5 * look.radius;
        for range in ring.strand_ranges() {
            let pts = &ring.points[range.clone()];
            let n = pts.len();
            let seg = |i: usize| (pts[(i + 1) % n] - pts[i]).length();
            let mut lengths: Vec<f32> = (0..n).map(seg).collect();
            lengths.sort_by(f32::total_cmp);
            // Closing segment (last → first) is an ordinary segment: no gap or jump.
            prop_assert!(seg(n - 1) <= 3.0 * lengths[n / 2] + 1e-6, "closing segment {} vs median {}", seg(n - 1), lengths[n / 2]);
            for i in range {
                let q = ring.points[i].as_dvec3();
                let r = q.truncate().length();
                prop_assert!(r >= look.min_radius() - eps && r <= look.max_radius() + eps, "radius {r}");
                prop_assert!(q.z.abs() <= look.noise.amplitude * look.noise.depth + eps);
                let w = ring.widths[i] as f64;
                prop_assert!(w >= look.width * (1.0 - look.width_variation) * 0.9999);
                prop_assert!(w <= look.width * (1.0 + look.width_variation) * 1.0001);
                prop_assert!(ring.intensities[i] >= 0.0 && ring.colors[i].is_finite());
            }
        }
    }

    /// The rotation angle is continuous (no phase jump) wherever the speed changes, and a frame
    /// generated alone is bit-identical to the same frame generated within a longer range.
    #[test]
    fn phase_is_continuous_and_frames_are_independent(p in params(), t in 0.0f64..1.1, frame in 1i64..24) {
        let shot = shot(&p);
        let generator = RingGenerator::new(&shot, shot.frames);
        let (_, model) = generator.models().next().unwrap();
        let max_omega = (0..=400)
            .map(|i| model.timing.angular_velocity(i as f64 * 0.003).abs())
            .fold(0.0, f64::max);
        let h = 1e-6;
        let jump = (model.timing.angle(t + h) - model.timing.angle(t)).abs();
        prop_assert!(jump <= max_omega * h * 1.5 + 1e-12, "phase step {jump} over {h} s, max ω {max_omega}");

        let alone = RingGenerator::new(&shot, rift_fx::FrameRange { first: frame, last: frame }).frame(frame);
        let wide = RingGenerator::new(&shot, rift_fx::FrameRange { first: -30, last: 80 }).frame(frame);
        prop_assert!(alone == wide, "frame {frame} differs when generated alone");
    }

    /// P + vΔ + ½aΔ² reproduces the procedural motion across the shutter to 1e-4 of the radius
    /// (for looks whose rim moves less than ~0.1 radian per half shutter, i.e. anything that
    /// does not strobe). Frames whose shutter straddles the first or last camera key are left
    /// out: the camera holds outside its keys, so speed and detail have a kink there that no
    /// quadratic can follow (a property of the animation, not of the baking).
    #[test]
    fn motion_reconstruction_error_is_small(p in params(), frame in 2i64..24) {
        let mut p = p;
        p.turns = p.turns.min(0.35);
        p.compensation = p.compensation.min(0.5);
        let shot = shot(&p);
        let generator = RingGenerator::new(&shot, shot.frames);
        let e = generator.motion_error(frame, 7);
        prop_assert!(e.max_relative <= 1e-4, "error {e:?}");
    }

    /// Constraint solver: the there-side copy of a here-side frame maps back exactly, and paired
    /// teleports undo each other.
    #[test]
    fn solver_round_trips(
        angles in prop::array::uniform3(-3.2f64..3.2),
        offset in prop::array::uniform3(-1e3f64..1e3),
        scale in 0.01f64..100.0,
        m_angles in prop::array::uniform3(-3.2f64..3.2),
        m_offset in prop::array::uniform3(-1e3f64..1e3),
    ) {
        let rot = |a: [f64; 3]| DQuat::from_euler(glam::EulerRot::ZYX, a[0], a[1], a[2]);
        let teleport = Similarity::new(rot(angles), DVec3::from_array(offset), scale);
        let m = Similarity::new(rot(m_angles), DVec3::from_array(m_offset), 1.0);
        let back = solve_here(&teleport, &solve_there(&teleport, &m));
        let size = 1e3 * (1.0 + scale);
        prop_assert!(back.distance(&m, 1.0) <= 1e-12 * size * (1.0 + 1.0 / scale));
        let forth = solve_there(&teleport, &solve_here(&teleport, &m));
        prop_assert!(forth.distance(&m, 1.0) <= 1e-12 * size * (1.0 + scale));
    }
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 24,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x5052_4553),
        ..ProptestConfig::default()
    })]

    /// Every preset keeps the effect's promises: closed strands within the look's bounds
    /// (drift and flares included), a continuous phase, frames independent of the range they
    /// are generated in, and baked motion within 1e-4 of the radius across the shutter.
    #[test]
    fn presets_keep_bounds_continuity_and_motion(p in params(), preset in presets(), frame in 2i64..24) {
        let shot = preset_shot(&p, preset);
        let look = shot.rings[0].clone().unwrap();
        let generator = RingGenerator::new(&shot, shot.frames);
        let ring = &generator.frame(frame).rings[0];
        let eps = 1e-5 * look.radius;
        for i in 0..ring.points.len() {
            let r = ring.points[i].as_dvec3().truncate().length();
            prop_assert!(r >= look.min_radius() - eps && r <= look.max_radius() + eps, "{preset}: radius {r}");
        }
        let (_, model) = generator.models().next().unwrap();
        let h = 1e-6;
        let t = frame as f64 / shot.fps;
        let max_omega = (0..=400)
            .map(|i| model.timing.angular_velocity(i as f64 * 0.003).abs())
            .fold(0.0, f64::max);
        let jump = (model.timing.angle(t + h) - model.timing.angle(t)).abs();
        prop_assert!(jump <= max_omega * h * 1.5 + 1e-12, "{preset}: phase step {jump}");
        let alone = RingGenerator::new(&shot, rift_fx::FrameRange { first: frame, last: frame }).frame(frame);
        prop_assert!(alone == generator.frame(frame), "{preset}: frame {frame} differs alone");
        let e = generator.motion_error(frame, 7);
        prop_assert!(e.max_relative <= 1e-4, "{preset}: motion error {e:?}");
    }
}

/// A case the random search found: a 4.8× camera dolly over one second starting 4.6 m away,
/// frame 3. With the noise's level of detail following the camera within the shutter, its
/// motion bent more than a quadratic follows (1.4e-4 × R against the 1e-4 target); it is now
/// the frame's across the shutter.
#[test]
fn fast_dolly_case() {
    let p = Params {
        radius: 1.7042624251520921,
        band: 0.0,
        amplitude: 0.047937096029246916,
        depth: 0.0,
        frequency: 1.0,
        octaves: 1,
        evolution: 0.0,
        turns: 0.02,
        compensation: 0.5,
        strands: 1,
        counter: 0.0,
        seed: 28964865,
        distance: [4.604184692678663, 22.15104379139374],
        yaw: -15.704704075763694,
        scale: 1.7318688859501399,
    };
    let shot = shot(&p);
    let generator = RingGenerator::new(&shot, shot.frames);
    let e = generator.motion_error(3, 7);
    assert!(e.max_relative <= 1e-4, "error {e:?}");
}
