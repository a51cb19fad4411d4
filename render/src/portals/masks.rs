//! Where an opening's teleport region ends: inside its ring's boundary at the ray's time, or
//! inside a disk, a rectangle or a polygon (`[portal.surface] radius`, `rectangle`, `polygon`)
//! when the opening has no ring or the shot asks for one of those.
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

/// Angular bins of the boundary table. Where strands cross, the inner envelope has a peak
/// that linear interpolation between bins cuts short; at 1024 bins the rift preset's 28
/// drifting strands left the showcase's mask 0.38 px short of them, at 2048 it is within
/// 0.08 px (`render/tests/ring_edge.rs`).
const ANGLE_BINS: usize = 2048;
/// Most time samples of the boundary table.
const MAX_TIME_SAMPLES: usize = 256;

/// The teleport region of one opening.
#[derive(Clone, Debug)]
pub enum Mask {
    /// Inside a circle of this radius around the opening's centre, in its local units.
    Disk { radius: f64 },
    /// Inside the centred rectangle |x| ≤ half.x, |y| ≤ half.y.
    Rectangle { half: DVec2 },
    /// Inside a simple polygon.
    Polygon(Polygon),
    /// Inside the ring's boundary at the ray's time.
    Ring(RingBoundary),
}

impl Mask {
    /// True when the local point `p` (on the opening's plane) teleports at time `time`.
    #[inline]
    pub fn contains(&self, p: DVec2, time: f64) -> bool {
        match self {
            Mask::Disk { radius } => p.length_squared() <= radius * radius,
            Mask::Rectangle { half } => p.x.abs() <= half.x && p.y.abs() <= half.y,
            Mask::Polygon(polygon) => polygon.contains(p),
            Mask::Ring(boundary) => boundary.contains(p, time),
        }
    }

    /// The largest distance from the opening's centre at which a point can teleport.
    pub fn bounding_radius(&self) -> f64 {
        match self {
            Mask::Disk { radius } => *radius,
            Mask::Rectangle { half } => half.length(),
            Mask::Polygon(polygon) => polygon.bounding_radius,
            Mask::Ring(boundary) => boundary.max_radius,
        }
    }

    /// The region's area (a ring's averaged over its time samples), in local units.
    pub fn area(&self) -> f64 {
        match self {
            Mask::Disk { radius } => std::f64::consts::PI * radius * radius,
            Mask::Rectangle { half } => 4.0 * half.x * half.y,
            Mask::Polygon(polygon) => polygon.area,
            Mask::Ring(boundary) => boundary.area,
        }
    }
}

/// A simple polygon in an opening's local XY plane.
#[derive(Clone, Debug)]
pub struct Polygon {
    points: Vec<DVec2>,
    area: f64,
    bounding_radius: f64,
    /// Lower and upper corner of its bounding box.
    bounds: (DVec2, DVec2),
}

/// Why a list of points is not a usable polygon.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PolygonError {
    #[error("a polygon needs at least 3 points, not {0}")]
    TooFew(usize),
    #[error("point {0} is not finite")]
    NotFinite(usize),
    #[error("it encloses no area (its points are collinear or repeated)")]
    Degenerate,
    #[error("it intersects itself: edge {0} crosses edge {1}")]
    SelfIntersecting(usize, usize),
}

impl Polygon {
    /// Its corners in order.
    pub fn points(&self) -> &[DVec2] {
        &self.points
    }

    /// The polygon through `points` in order (either winding), checked to be simple.
    pub fn new(points: Vec<DVec2>) -> Result<Self, PolygonError> {
        let n = points.len();
        if n < 3 {
            return Err(PolygonError::TooFew(n));
        }
        if let Some(i) = points.iter().position(|p| !p.is_finite()) {
            return Err(PolygonError::NotFinite(i));
        }
        let edge = |i: usize| (points[i], points[(i + 1) % n]);
        let twice_area: f64 = (0..n).map(|i| edge(i).0.perp_dot(edge(i).1)).sum();
        let extent = points.iter().fold(0.0f64, |r, p| r.max(p.length()));
        if twice_area.abs() <= 1e-12 * extent * extent.max(1e-300) || edge_is_empty(&points) {
            return Err(PolygonError::Degenerate);
        }
        for i in 0..n {
            // Neighbouring edges share a point; the others must not meet at all.
            for j in i + 2..n {
                if i == 0 && j == n - 1 {
                    continue;
                }
                if segments_meet(edge(i), edge(j)) {
                    return Err(PolygonError::SelfIntersecting(i, j));
                }
            }
        }
        let lower = points.iter().fold(DVec2::INFINITY, |m, &p| m.min(p));
        let upper = points.iter().fold(DVec2::NEG_INFINITY, |m, &p| m.max(p));
        Ok(Self {
            points,
            area: 0.5 * twice_area.abs(),
            bounding_radius: extent,
            bounds: (lower, upper),
        })
    }

    /// The smallest axis-aligned box around it: (lower corner, upper corner).
    pub fn bounds(&self) -> (DVec2, DVec2) {
        self.bounds
    }

    /// True when `p` is inside (crossing count of a ray towards +X).
    #[inline]
    pub fn contains(&self, p: DVec2) -> bool {
        let mut inside = false;
        let mut a = self.points[self.points.len() - 1];
        for &b in &self.points {
            if (a.y > p.y) != (b.y > p.y) {
                let x = a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x);
                if p.x < x {
                    inside = !inside;
                }
            }
            a = b;
        }
        inside
    }
}

/// True when two consecutive points coincide.
fn edge_is_empty(points: &[DVec2]) -> bool {
    (0..points.len()).any(|i| points[i] == points[(i + 1) % points.len()])
}

/// True when the closed segments `a` and `b` share a point.
fn segments_meet(a: (DVec2, DVec2), b: (DVec2, DVec2)) -> bool {
    let side = |p: DVec2, q: DVec2, r: DVec2| (q - p).perp_dot(r - p);
    let (d1, d2) = (side(b.0, b.1, a.0), side(b.0, b.1, a.1));
    let (d3, d4) = (side(a.0, a.1, b.0), side(a.0, a.1, b.1));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    // Touching or collinear overlap.
    let on = |p: DVec2, q: DVec2, r: DVec2, d: f64| {
        d == 0.0
            && r.x >= p.x.min(q.x)
            && r.x <= p.x.max(q.x)
            && r.y >= p.y.min(q.y)
            && r.y <= p.y.max(q.y)
    };
    on(b.0, b.1, a.0, d1) || on(b.0, b.1, a.1, d2) || on(a.0, a.1, b.0, d3) || on(a.0, a.1, b.1, d4)
}

/// The inner envelope of a ring's strands, tabulated over angle and time.
#[derive(Clone, Debug)]
pub struct RingBoundary {
    /// `times.len()` rows of [`ANGLE_BINS`] radii; bin k holds the angle (k + ½)·2π/bins.
    radii: Vec<f32>,
    /// Sample times, seconds (equally spaced; one entry for an instant).
    times: Vec<f64>,
    /// The smallest and largest tabulated radius: the interpolated boundary stays between them.
    min_radius: f64,
    max_radius: f64,
    /// Area inside the boundary, averaged over the time samples.
    area: f64,
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
        let max_radius = radii.iter().fold(0.0f32, |m, &r| m.max(r)) as f64;
        let min_radius = radii
            .iter()
            .fold(f32::INFINITY, |m, &r| m.min(r))
            .min(max_radius as f32);
        let mean_square =
            radii.iter().map(|&r| (r as f64).powi(2)).sum::<f64>() / radii.len().max(1) as f64;
        Self {
            radii,
            times: sample_times,
            min_radius: min_radius as f64,
            max_radius,
            area: std::f64::consts::PI * mean_square,
        }
    }

    /// True when local point `p` lies within the boundary at `time`. Points clearly inside the
    /// smallest tabulated radius or beyond the largest are decided without the table (no
    /// arctangent, no table read): an interpolated radius leaves that range only by rounding,
    /// a few parts in 10¹⁶, far inside the margin.
    #[inline]
    pub fn contains(&self, p: DVec2, time: f64) -> bool {
        const MARGIN: f64 = 1e-12;
        let distance = p.length();
        if distance < self.min_radius * (1.0 - MARGIN) {
            return true;
        }
        if distance > self.max_radius * (1.0 + MARGIN) {
            return false;
        }
        distance <= self.radius(p, time)
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
/// does, so an open gap never teleports). Kept out of line: it is a frame's set-up, and the
/// render crate's hot code is laid out as if it were not there.
#[inline(never)]
fn envelope(curves: &RingCurves, delta: f32) -> Vec<f32> {
    let mut radii = vec![f32::INFINITY; ANGLE_BINS];
    let at = |i: usize| {
        let p = curves.position_at(i, delta);
        Vec2::new(p.x, p.y).as_dvec2()
    };
    let bin = TAU / ANGLE_BINS as f64;
    let directions = bin_directions();
    for (i, j) in curves.segments() {
        let (a, b) = (at(i), at(j));
        let from = a.y.atan2(a.x);
        let sweep = wrap(b.y.atan2(b.x) - from);
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
            let k = k.rem_euclid(ANGLE_BINS as i64) as usize;
            let denominator = directions[k].perp_dot(e);
            if denominator == 0.0 {
                continue;
            }
            let r = a.perp_dot(e) / denominator;
            let slot = &mut radii[k];
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

/// The unit direction of each bin's central angle, (k + ½)·2π/bins, made once: every segment
/// of every time sample reads them, and made per crossing they were ten million sines and
/// cosines a frame of the showcase.
fn bin_directions() -> &'static [DVec2] {
    static DIRECTIONS: std::sync::OnceLock<Vec<DVec2>> = std::sync::OnceLock::new();
    DIRECTIONS.get_or_init(|| {
        let bin = TAU / ANGLE_BINS as f64;
        (0..ANGLE_BINS)
            .map(|k| DVec2::from_angle((k as f64 + 0.5) * bin))
            .collect()
    })
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
    fn a_ring_decides_without_its_table_only_where_the_table_agrees() {
        let omega = 3.0;
        let boundary = RingBoundary::new(&wavy_ring(omega), 0.0, [-0.1, 0.1]);
        let (lo, hi) = (boundary.min_radius, boundary.max_radius);
        assert!(
            0.0 < lo && lo < hi,
            "a wavy ring's radii vary: {lo} to {hi}"
        );
        let mut shortcuts = 0;
        for k in 0..20_000 {
            let angle = k as f64 * 2.399_963;
            // Distances across the whole range, with many within rounding of either bound.
            let distance = match k % 4 {
                0 => lo * (1.0 + (k as f64 * 1e-17)),
                1 => hi * (1.0 - (k as f64 * 1e-17)),
                _ => (lo * 0.5) + (hi * 1.5 - lo * 0.5) * ((k as f64 * 0.618_034).fract()),
            };
            let p = DVec2::new(angle.cos(), angle.sin()) * distance;
            let time = -0.1 + 0.2 * (k as f64 * 0.414_213).fract();
            let table = p.length() <= boundary.radius(p, time);
            assert_eq!(boundary.contains(p, time), table, "point {k}");
            shortcuts += (p.length() < lo * 0.999 || p.length() > hi * 1.001) as u32;
        }
        assert!(
            shortcuts > 5_000,
            "{shortcuts} points decided by the bounds alone"
        );
        // Where the boundary is at its narrowest and widest: at a bin's centre and a sample
        // time the table gives that radius exactly, so points a hair either side of it must
        // come out as the table says.
        for extreme in [lo, hi] {
            let at = boundary
                .radii
                .iter()
                .position(|&r| r as f64 == extreme)
                .unwrap();
            let (row, bin) = (at / ANGLE_BINS, at % ANGLE_BINS);
            let angle = (bin as f64 + 0.5) * TAU / ANGLE_BINS as f64;
            let time = boundary.times[row];
            for scale in [1.0 - 1e-4, 1.0 - 1e-9, 1.0 + 1e-9, 1.0 + 1e-4] {
                let p = DVec2::new(angle.cos(), angle.sin()) * extreme * scale;
                let table = p.length() <= boundary.radius(p, time);
                assert_eq!(boundary.contains(p, time), table, "{extreme} × {scale}");
            }
        }
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
        assert!((disk.area() - std::f64::consts::PI * 4.0).abs() < 1e-12);
        let widest = (0..1024)
            .map(|k| analytic_envelope(TAU * k as f64 / 1024.0, 0.0, 0.0))
            .fold(0.0, f64::max);
        assert!((boundary.max_radius - widest).abs() < 2e-3);
        // A ring with no strands teleports nothing.
        let empty = Mask::Ring(RingBoundary::new(&RingCurves::default(), 0.0, [0.0, 1.0]));
        assert!(!empty.contains(DVec2::new(0.01, 0.0), 0.5));
    }

    #[test]
    fn rectangles_and_polygons_contain_their_inside_only() {
        let rect = Mask::Rectangle {
            half: DVec2::new(0.5, 1.0),
        };
        assert!(rect.contains(DVec2::new(0.499, -0.999), 0.0));
        assert!(!rect.contains(DVec2::new(0.501, 0.0), 0.0));
        assert!(!rect.contains(DVec2::new(0.0, 1.001), 0.0));
        assert_eq!(rect.area(), 2.0);
        // An L shape (concave), clockwise.
        let l = Polygon::new(
            [
                [0.0, 0.0],
                [0.0, 2.0],
                [1.0, 2.0],
                [1.0, 1.0],
                [2.0, 1.0],
                [2.0, 0.0],
            ]
            .map(|[x, y]| DVec2::new(x, y))
            .to_vec(),
        )
        .unwrap();
        let mask = Mask::Polygon(l);
        assert!(mask.contains(DVec2::new(0.5, 1.5), 0.0));
        assert!(mask.contains(DVec2::new(1.5, 0.5), 0.0));
        assert!(!mask.contains(DVec2::new(1.5, 1.5), 0.0));
        assert!(!mask.contains(DVec2::new(-0.01, 0.5), 0.0));
        assert!((mask.area() - 3.0).abs() < 1e-12);
        assert!((mask.bounding_radius() - 5f64.sqrt()).abs() < 1e-12);
        // Monte Carlo area agrees with the shoelace area.
        let inside = (0..40_000)
            .filter(|k| {
                let p = DVec2::new((k % 200) as f64 + 0.5, (k / 200) as f64 + 0.5) / 100.0;
                mask.contains(p, 0.0)
            })
            .count();
        assert!((inside as f64 / 10_000.0 - 3.0).abs() < 0.01);
    }

    #[test]
    fn bad_polygons_are_refused() {
        let poly =
            |pts: &[[f64; 2]]| Polygon::new(pts.iter().map(|&[x, y]| DVec2::new(x, y)).collect());
        assert_eq!(
            poly(&[[0.0, 0.0], [1.0, 0.0]]).unwrap_err(),
            PolygonError::TooFew(2)
        );
        assert_eq!(
            poly(&[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]).unwrap_err(),
            PolygonError::Degenerate
        );
        assert_eq!(
            poly(&[[0.0, 0.0], [2.0, 2.0], [2.0, 0.0], [0.0, 1.0]]).unwrap_err(),
            PolygonError::SelfIntersecting(0, 2)
        );
        assert_eq!(
            poly(&[[0.0, 0.0], [1.0, 0.0], [1.0, f64::NAN]]).unwrap_err(),
            PolygonError::NotFinite(2)
        );
        assert_eq!(
            poly(&[[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 1.0]]).unwrap_err(),
            PolygonError::Degenerate
        );
        assert!(poly(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]).is_ok());
    }
}
