//! Baked ring curves: what fx hands to exporters and the renderer.

use crate::rig::Similarity;
use crate::shot::check::MAX_LENGTH;
use glam::Vec3;

/// One opening's strands at one frame, in the opening's local frame (the opening lies in local
/// XY, front along +Z). Vertex arrays are concatenated strand after strand; each strand is a
/// closed (periodic) polyline whose last vertex connects back to its first.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RingCurves {
    /// The opening's name.
    pub opening: String,
    /// P_H at the frame's time.
    pub here: Similarity,
    /// P_H at shutter open and close (equal to `here` for a static opening).
    pub here_shutter: [Similarity; 2],
    /// Vertices of each strand.
    pub vertex_counts: Vec<u32>,
    /// +1 or −1 per strand: the way it turns about local +Z.
    pub directions: Vec<i8>,
    /// Positions at the frame's time.
    pub points: Vec<Vec3>,
    /// Per second: P(t+Δ) ≈ P + vΔ + ½aΔ² across the shutter.
    pub velocities: Vec<Vec3>,
    /// Per second squared.
    pub accelerations: Vec<Vec3>,
    /// Curve width (diameter).
    pub widths: Vec<f32>,
    /// Linear Rec.709 colour.
    pub colors: Vec<Vec3>,
    /// Radiance scale: the strand emits `colors · intensities`.
    pub intensities: Vec<f32>,
}

impl RingCurves {
    /// Total vertex count.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when there are no vertices.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Checks what a file written by another tool (or damaged on the way) could get wrong:
    /// per-vertex arrays of one length, strands that use exactly the vertices, ±1 turns,
    /// finite values with coordinates and widths within [`MAX_LENGTH`], and widths, colours
    /// and intensities ≥ 0. The message names the first bad vertex or strand.
    pub fn check(&self) -> Result<(), String> {
        let n = self.points.len();
        let lengths = [
            ("velocities", self.velocities.len()),
            ("accelerations", self.accelerations.len()),
            ("widths", self.widths.len()),
            ("colors", self.colors.len()),
            ("intensities", self.intensities.len()),
        ];
        if let Some((name, len)) = lengths.iter().find(|(_, len)| *len != n) {
            return Err(format!("{len} {name} for {n} points"));
        }
        if self.directions.len() != self.vertex_counts.len() {
            return Err(format!(
                "{} directions for {} strands",
                self.directions.len(),
                self.vertex_counts.len()
            ));
        }
        if self
            .vertex_counts
            .iter()
            .map(|&c| c as usize)
            .sum::<usize>()
            != n
        {
            return Err(format!("strand vertex counts do not add up to {n}"));
        }
        // Not `d.abs()`: the absolute value of −128 overflows an i8.
        if let Some(i) = self.directions.iter().position(|d| !matches!(d, -1 | 1)) {
            return Err(format!(
                "strand {i} turns {}, not +1 or -1",
                self.directions[i]
            ));
        }
        for frame in [&self.here, &self.here_shutter[0], &self.here_shutter[1]] {
            let ok = frame.rotation.is_finite()
                && frame.translation.abs().max_element() <= MAX_LENGTH
                && frame.scale > 0.0
                && frame.scale <= MAX_LENGTH;
            if !ok {
                return Err("the opening's frame is not finite, or beyond single precision".into());
            }
        }
        let limit = MAX_LENGTH as f32;
        let within = |v: Vec3| v.is_finite() && v.abs().max_element() <= limit;
        for (name, values) in [
            ("position", &self.points),
            ("velocity", &self.velocities),
            ("acceleration", &self.accelerations),
        ] {
            if let Some(i) = values.iter().position(|&v| !within(v)) {
                return Err(format!(
                    "vertex {i}: {name} {} is not finite or beyond ±{MAX_LENGTH:e}",
                    values[i]
                ));
            }
        }
        let colour_ok = |c: &Vec3| c.is_finite() && c.min_element() >= 0.0;
        if let Some(i) = self.colors.iter().position(|c| !colour_ok(c)) {
            return Err(format!(
                "vertex {i}: colour {} is not finite and ≥ 0",
                self.colors[i]
            ));
        }
        for (name, values, most) in [
            ("width", &self.widths, limit),
            ("intensity", &self.intensities, f32::MAX),
        ] {
            if let Some(i) = values
                .iter()
                .position(|&v| !(v.is_finite() && v >= 0.0 && v <= most))
            {
                return Err(format!(
                    "vertex {i}: {name} {} is not finite and ≥ 0",
                    values[i]
                ));
            }
        }
        Ok(())
    }

    /// Index ranges of each strand's vertices.
    pub fn strand_ranges(&self) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
        self.vertex_counts.iter().scan(0usize, |start, &n| {
            let r = *start..*start + n as usize;
            *start += n as usize;
            Some(r)
        })
    }

    /// Vertex `i` `delta` seconds after the frame, by its baked motion.
    #[inline]
    pub fn position_at(&self, i: usize, delta: f32) -> Vec3 {
        moved(
            self.points[i],
            self.velocities[i],
            self.accelerations[i],
            delta,
        )
    }

    /// The vertex index pairs of every strand's segments, each strand closed back to its first
    /// vertex; a two-vertex strand is one segment, and a lone vertex none.
    pub fn segments(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.strand_ranges().flat_map(|range| {
            let n = range.len();
            let count = match n {
                0 | 1 => 0,
                2 => 1,
                _ => n,
            };
            (0..count).map(move |k| (range.start + k, range.start + (k + 1) % n))
        })
    }

    /// Axis-aligned bounds of the positions grown by half the largest width, as USD computes the
    /// extent of curves: (min, max).
    pub fn extent(&self) -> (Vec3, Vec3) {
        if self.points.is_empty() {
            return (Vec3::ZERO, Vec3::ZERO);
        }
        let pad = Vec3::splat(0.5 * self.widths.iter().copied().fold(0.0, f32::max));
        let (lo, hi) = self.points.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        (lo - pad, hi + pad)
    }
}

/// Where a baked vertex (position `p`, velocity `v`, acceleration `a` at the frame) is `delta`
/// seconds after the frame: P + vΔ + ½aΔ².
#[inline]
pub fn moved(p: Vec3, v: Vec3, a: Vec3, delta: f32) -> Vec3 {
    p + delta * (v + 0.5 * delta * a)
}

/// Every opening's rings at one frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RingFrame {
    pub frame: i64,
    /// Seconds.
    pub time: f64,
    pub fps: f64,
    /// Shutter open and close relative to `time`, seconds.
    pub shutter: [f64; 2],
    pub rings: Vec<RingCurves>,
}

impl RingFrame {
    /// [`RingCurves::check`] for every ring, the message naming its opening.
    pub fn check(&self) -> Result<(), String> {
        for ring in &self.rings {
            ring.check()
                .map_err(|message| format!("ring of {:?}: {message}", ring.opening))?;
        }
        Ok(())
    }

    /// Total vertex count of all rings.
    pub fn vertex_count(&self) -> usize {
        self.rings.iter().map(RingCurves::len).sum()
    }
}
