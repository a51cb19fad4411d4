//! Where an opening's teleport region ends: inside its ring's boundary at the ray's time, or
//! inside a disk when the opening has no ring (or the shot asks for one).
//!
//! The ring boundary is the inner envelope of the strands projected on the opening's plane:
//! at each polar angle, the smallest radius at which any strand crosses that angle. The seam
//! between teleported and untouched space then always runs along a strand's centre line, where
//! the strand's own glow covers it, and every point inside the ring teleports.
//!
//! The envelope is tabulated once per scene over polar angle × time, from the baked vertex
//! quadratics P + vΔ + ½aΔ², with as many time samples as the fastest vertex needs to move less
//! than one angular bin between them; a query interpolates the table bilinearly, so it costs
//! the same whatever the strand count.

use glam::{DVec2, Vec2};
use rift_fx::ring::RingCurves;
use std::f64::consts::TAU;

/// Angular bins of the boundary table.
const ANGLE_BINS: usize = 1024;
/// Most time samples of the boundary table.
const MAX_TIME_SAMPLES: usize = 256;

/// The teleport region of one opening.
#[derive(Clone, Debug)]
pub enum Mask {
    /// Inside a circle of this radius around the opening's centre, in its local units.
    Disk { radius: f64 },
    /// Inside the ring's boundary at the ray's time.
    Ring(RingBoundary),
}

impl Mask {
    /// True when the local point `p` (on the opening's plane) teleports at time `time`.
    #[inline]
    pub fn contains(&self, p: DVec2, time: f64) -> bool {
        match self {
            Mask::Disk { radius } => p.length_squared() <= radius * radius,
            Mask::Ring(boundary) => p.length() <= boundary.radius(p, time),
        }
    }
}

/// The inner envelope of a ring's strands, tabulated over angle and time.
#[derive(Clone, Debug)]
pub struct RingBoundary {
    /// `times.len()` rows of [`ANGLE_BINS`] radii; bin k holds the angle (k + ½)·2π/bins.
    radii: Vec<f32>,
    /// Sample times, seconds (equally spaced; one entry for an instant).
    times: Vec<f64>,
}

impl RingBoundary {
    /// The boundary of `curves` (baked at `frame_time`) for rays with times in `times`.
    pub fn new(curves: &RingCurves, frame_time: f64, times: [f64; 2]) -> Self {
        let span = (times[1] - times[0]).max(0.0);
        let samples = if span == 0.0 {
            1
        } else {
            // Fastest vertex over the interval, against the arc of one bin at its radius.
            let reach = (times[0] - frame_time)
                .abs()
                .max((times[1] - frame_time).abs());
            let (mut steps, mut radius_min) = (0.0f64, f64::INFINITY);
            for ((p, v), a) in curves
                .points
                .iter()
                .zip(&curves.velocities)
                .zip(&curves.accelerations)
            {
                let speed = v.truncate().length() as f64 + a.truncate().length() as f64 * reach;
                steps = steps.max(speed * span);
                radius_min = radius_min.min(p.truncate().length() as f64);
            }
            let bin_arc = radius_min.max(1e-6) * TAU / ANGLE_BINS as f64;
            ((steps / bin_arc).ceil() as usize + 1).clamp(2, MAX_TIME_SAMPLES)
        };
        let sample_times: Vec<f64> = (0..samples)
            .map(|k| {
                if samples == 1 {
                    times[0]
                } else {
                    times[0] + span * k as f64 / (samples - 1) as f64
                }
            })
            .collect();
        let mut radii = Vec::with_capacity(samples * ANGLE_BINS);
        for &t in &sample_times {
            radii.extend(envelope(curves, (t - frame_time) as f32));
        }
        Self {
            radii,
            times: sample_times,
        }
    }

    /// The boundary's radius in the direction of local point `p` at `time` (clamped to the
    /// tabulated times).
    #[inline]
    pub fn radius(&self, p: DVec2, time: f64) -> f64 {
        let angle = p.y.atan2(p.x).rem_euclid(TAU);
        let x = angle / TAU * ANGLE_BINS as f64 - 0.5;
        let i0 = x.floor();
        let fx = x - i0;
        let i0 = (i0 as isize).rem_euclid(ANGLE_BINS as isize) as usize;
        let i1 = (i0 + 1) % ANGLE_BINS;
        let row = |k: usize| {
            let r = &self.radii[k * ANGLE_BINS..(k + 1) * ANGLE_BINS];
            r[i0] as f64 * (1.0 - fx) + r[i1] as f64 * fx
        };
        if self.times.len() == 1 {
            return row(0);
        }
        let (first, last) = (self.times[0], self.times[self.times.len() - 1]);
        let y = ((time - first) / (last - first)).clamp(0.0, 1.0) * (self.times.len() - 1) as f64;
        let k0 = (y.floor() as usize).min(self.times.len() - 2);
        let fy = y - k0 as f64;
        row(k0) * (1.0 - fy) + row(k0 + 1) * fy
    }
}

/// The inner envelope of the strands `delta` seconds after their frame: per angular bin, the
/// smallest radius at which a strand's polyline crosses the bin's central angle (0 where none
/// does, so an open gap never teleports).
fn envelope(curves: &RingCurves, delta: f32) -> Vec<f32> {
    let mut radii = vec![f32::INFINITY; ANGLE_BINS];
    let at = |i: usize| {
        let p = curves.position_at(i, delta);
        Vec2::new(p.x, p.y).as_dvec2()
    };
    let bin = TAU / ANGLE_BINS as f64;
    for (i, j) in curves.segments() {
        let (a, b) = (at(i), at(j));
        let (from, sweep) = (a.y.atan2(a.x), wrap(b.y.atan2(b.x) - a.y.atan2(a.x)));
        // Bins whose central angle the segment's angular span covers.
        let (lo, hi) = if sweep >= 0.0 {
            (from, from + sweep)
        } else {
            (from + sweep, from)
        };
        let first = (lo / bin - 0.5).ceil() as i64;
        let last = (hi / bin - 0.5).floor() as i64;
        let e = b - a;
        for k in first..=last {
            let theta = (k as f64 + 0.5) * bin;
            let u = DVec2::new(theta.cos(), theta.sin());
            let denominator = u.perp_dot(e);
            if denominator == 0.0 {
                continue;
            }
            let r = a.perp_dot(e) / denominator;
            let slot = &mut radii[k.rem_euclid(ANGLE_BINS as i64) as usize];
            if r > 0.0 {
                *slot = slot.min(r as f32);
            }
        }
    }
    for r in &mut radii {
        if !r.is_finite() {
            *r = 0.0;
        }
    }
    radii
}

/// An angle difference brought into (−π, π].
fn wrap(a: f64) -> f64 {
    let a = a.rem_euclid(TAU);
    if a > TAU / 2.0 { a - TAU } else { a }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    const WAVES: f32 = 5.0;
    const AMPLITUDE: f32 = 0.05;

    /// Strand s: r(φ) = 1 + 0.03·s + A·sin(5φ + s) in its own frame, turning at ±ω, so the
    /// envelope at angle θ and time t is min over s of 1 + 0.03·s + A·sin(5(θ − ω_s·t) + s).
    fn wavy_ring(omega: f32) -> RingCurves {
        let mut c = RingCurves::default();
        for s in 0..4 {
            let w = Vec3::Z * if s % 2 == 0 { omega } else { -omega };
            c.vertex_counts.push(256);
            c.directions.push(1);
            for k in 0..256 {
                let u = TAU as f32 * k as f32 / 256.0;
                let r = 1.0 + 0.03 * s as f32 + AMPLITUDE * (WAVES * u + s as f32).sin();
                let p = Vec3::new(r * u.cos(), r * u.sin(), 0.02);
                c.points.push(p);
                c.velocities.push(w.cross(p));
                c.accelerations.push(w.cross(w.cross(p)));
                c.widths.push(0.01);
                c.colors.push(Vec3::ONE);
                c.intensities.push(1.0);
            }
        }
        c
    }

    fn analytic_envelope(theta: f64, t: f64, omega: f64) -> f64 {
        (0..4)
            .map(|s| {
                let w = if s % 2 == 0 { omega } else { -omega };
                let s = s as f64;
                1.0 + 0.03 * s + AMPLITUDE as f64 * (WAVES as f64 * (theta - w * t) + s).sin()
            })
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn rays_just_inside_teleport_and_just_outside_do_not_as_the_boundary_moves() {
        let omega = 3.0;
        let (t0, t1) = (-0.04, 0.04);
        let mask = Mask::Ring(RingBoundary::new(&wavy_ring(omega as f32), 0.0, [t0, t1]));
        let mut flips = 0;
        for k in 0..2000 {
            let theta = TAU * ((k as f64 * 0.618_034).fract());
            let direction = DVec2::new(theta.cos(), theta.sin());
            let (r0, r1) = (
                analytic_envelope(theta, t0, omega),
                analytic_envelope(theta, t1, omega),
            );
            for (r, t) in [(r0, t0), (r1, t1)] {
                assert!(
                    mask.contains(direction * r * 0.995, t),
                    "angle {theta} time {t}"
                );
                assert!(
                    !mask.contains(direction * r * 1.005, t),
                    "angle {theta} time {t}"
                );
            }
            // Where the boundary moved by more than the tolerance, a point between its two
            // positions changes sides.
            if (r0 - r1).abs() > 0.02 * r0 {
                let between = direction * 0.5 * (r0 + r1);
                assert_ne!(mask.contains(between, t0), mask.contains(between, t1));
                flips += 1;
            }
        }
        assert!(flips > 400, "the boundary hardly moved ({flips} angles)");
    }

    #[test]
    fn a_still_ring_needs_one_time_sample_and_a_disk_is_a_disk() {
        let boundary = RingBoundary::new(&wavy_ring(0.0), 0.0, [0.0, 0.0]);
        assert_eq!(boundary.times.len(), 1);
        let r = boundary.radius(DVec2::new(0.0, 1.0), 7.0);
        let want = analytic_envelope(TAU / 4.0, 0.0, 0.0);
        assert!((r - want).abs() < 1e-3, "{r} against {want}");
        let disk = Mask::Disk { radius: 2.0 };
        assert!(disk.contains(DVec2::new(1.99, 0.0), 0.0));
        assert!(!disk.contains(DVec2::new(1.5, 1.5), 0.0));
        // A ring with no strands teleports nothing.
        let empty = Mask::Ring(RingBoundary::new(&RingCurves::default(), 0.0, [0.0, 1.0]));
        assert!(!empty.contains(DVec2::new(0.01, 0.0), 0.5));
    }
}
