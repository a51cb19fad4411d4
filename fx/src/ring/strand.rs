//! The procedural strand: a closed curve around the opening's centre, evaluated at any material
//! angle `u` and time `t` in the opening's local frame.
//!
//! ```text
//! α(u, t) = u + φ_s + d_s · m_s · Θ(t)                 (Θ from RingTiming; d_s = ±1)
//! r(u, t) = r_s + amplitude · N_radial(u, t)
//! z(u, t) = amplitude · depth · N_axial(u, t)
//! P(u, t) = (r cos α, r sin α, z)
//! heat    = ½ + ½ · N_heat(u, t)                       (indexes the colour ramp)
//! width   = width · (1 + width_variation · N_heat(u, t))
//! ```
//!
//! An unstable look adds to r a drift of the whole strand, separation · band · S_s(rate · t) (a
//! slow 1-D signal per strand: strands separate and re-form), and flares,
//! flare · radius · x³ / (1 + x³) with x = max(0, (N_flare(u, rate · t) − 0.15) / 0.3) (sparse outward bursts that kink the
//! curve and fall back).
//!
//! Width and heat share one noise channel: hotter parts of a strand are thicker, as a glowing
//! filament looks, and the effect costs a quarter less to evaluate.
//!
//! Each strand has its own base radius r_s within the band, phase φ_s, speed factor m_s and noise
//! channels; a strand's pattern rides with its rotation, so a vertex is a material point whose
//! motion is the real motion of the effect. Strands are counter-rotating when their index falls on
//! the `counter_rotating` fraction (spread evenly through the ring, not bunched).

use super::look::RingLook;
use super::noise_field::{NoiseField, Octaves};
use super::timing::RingTiming;
use glam::DVec3;
use std::f64::consts::TAU;

/// Per-strand constants.
#[derive(Clone, Debug)]
pub struct Strand {
    /// +1 or −1.
    pub direction: f64,
    /// Multiplier of the ring's angular speed.
    pub speed: f64,
    base_radius: f64,
    phase: f64,
    /// Noise-space offsets of the radial, axial, heat, flicker, drift and flare channels.
    channels: [[f64; 3]; 6],
}

/// What a strand shares across its vertices at one instant.
#[derive(Clone, Copy, Debug)]
pub struct StrandInstant {
    cos_angle: f64,
    sin_angle: f64,
    tau: f64,
    octaves: Octaves,
    /// Instability: the strand's drift from its place (a length), and where its flares are in
    /// their evolution.
    drift: f64,
    flare_tau: f64,
}

impl StrandInstant {
    /// Places a profile (radius, height) at material angle u, turned by the strand's rotation.
    #[inline]
    pub fn rotate(&self, [r, z]: [f64; 2], cos_u: f64, sin_u: f64) -> DVec3 {
        let ca = cos_u * self.cos_angle - sin_u * self.sin_angle;
        let sa = sin_u * self.cos_angle + cos_u * self.sin_angle;
        DVec3::new(r * ca, r * sa, z)
    }
}

/// A ring's strands, noise and timing: evaluates the effect anywhere in space and time.
#[derive(Clone, Debug)]
pub struct RingModel {
    pub look: RingLook,
    pub timing: RingTiming,
    pub field: NoiseField,
    pub strands: Vec<Strand>,
    /// The octaves flares are drawn with: fixed, so that a flare changes only with time and
    /// not with the ring's size on screen (its steep rise would turn a level-of-detail change
    /// into a jump the baked motion cannot follow).
    flare_octaves: Octaves,
}

/// Uniform number in [0, 1) from a seed, a strand and a channel (SplitMix64 finaliser).
fn unit_hash(seed: u32, strand: u32, channel: u32) -> f64 {
    let mut z = ((seed as u64) << 40) ^ ((strand as u64) << 8) ^ channel as u64;
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

impl RingModel {
    /// Builds the strands of `look`, timed by `timing`.
    pub fn new(look: RingLook, timing: RingTiming) -> Self {
        let q = look.counter_rotating;
        let strands = (0..look.strands)
            .map(|s| {
                let h = |c: u32| unit_hash(look.seed, s, c);
                let counter = ((s + 1) as f64 * q).floor() > (s as f64 * q).floor();
                let mut channels = [[0.0; 3]; 6];
                for (c, ch) in channels.iter_mut().enumerate() {
                    let c = 10 + 3 * c as u32;
                    *ch = [1e3 * h(c), 1e3 * h(c + 1), 1e3 * h(c + 2)];
                }
                Strand {
                    direction: if counter { -1.0 } else { 1.0 },
                    speed: 1.0 + look.speed_variation * (2.0 * h(1) - 1.0),
                    base_radius: look.radius + look.band * (h(2) - 0.5),
                    phase: TAU * h(3),
                    channels,
                }
            })
            .collect();
        let field = NoiseField::new(
            look.seed,
            look.noise.frequency,
            look.noise.octaves,
            look.noise.roughness,
        );
        let flare_octaves = field.octaves(0.0);
        Self {
            look,
            timing,
            field,
            strands,
            flare_octaves,
        }
    }

    /// The per-instant state of strand `s` at time `t` within the shutter of the frame at
    /// `frame_time`. The noise's level of detail is the frame's: it follows the camera from
    /// frame to frame, but motion blur shows the ring's own motion only. (Taken at `t`, a fast
    /// dolly bent the motion across one shutter more than a quadratic can follow.)
    pub fn instant(&self, s: &Strand, t: f64, frame_time: f64) -> StrandInstant {
        let angle = s.phase + s.direction * s.speed * self.timing.angle(t);
        let (drift, flare_tau) = match &self.look.instability {
            Some(i) => (
                i.separation * self.look.band * self.field.signal(i.rate * t, s.channels[4]),
                i.rate * t,
            ),
            None => (0.0, 0.0),
        };
        StrandInstant {
            cos_angle: angle.cos(),
            sin_angle: angle.sin(),
            tau: self.look.noise.evolution * t,
            octaves: self.field.octaves(self.timing.lod(frame_time)),
            drift,
            flare_tau,
        }
    }

    /// Position of material angle (cos u, sin u) of strand `s`, local frame.
    #[inline]
    pub fn position(&self, s: &Strand, at: &StrandInstant, cos_u: f64, sin_u: f64) -> DVec3 {
        at.rotate(self.profile(s, at, cos_u, sin_u), cos_u, sin_u)
    }

    /// The strand's cross-section before rotation: (radius, height) at material angle u.
    #[inline]
    pub fn profile(&self, s: &Strand, at: &StrandInstant, cos_u: f64, sin_u: f64) -> [f64; 2] {
        let n = &self.look.noise;
        let radial = self
            .field
            .sample(&at.octaves, cos_u, sin_u, at.tau, s.channels[0]);
        let z = if n.depth > 0.0 {
            n.amplitude
                * n.depth
                * self
                    .field
                    .sample(&at.octaves, cos_u, sin_u, at.tau, s.channels[1])
        } else {
            0.0
        };
        let mut r = s.base_radius + n.amplitude * radial;
        if let Some(i) = &self.look.instability {
            r += at.drift + i.flare * self.look.radius * self.flare(s, at, cos_u, sin_u);
        }
        [r, z]
    }

    /// The octaves flares are drawn with (fixed: flares do not follow the level of detail).
    pub fn flare_octaves(&self) -> &Octaves {
        &self.flare_octaves
    }

    /// A flare's height in [0, 1) at material angle u: zero where the strand's flare channel is
    /// below a threshold, then x³ / (1 + x³) of how far above it: smooth (to the second
    /// derivative at the threshold, everywhere else beyond), steep, and saturating, so flares
    /// are sparse bursts rather than a swell of the whole strand, and the baked quadratic motion
    /// can follow them.
    #[inline]
    fn flare(&self, s: &Strand, at: &StrandInstant, cos_u: f64, sin_u: f64) -> f64 {
        // The channel's octave sums exceed 0.15 a fifth of the time and 0.45 about one time in
        // a hundred, where a flare is at half its height.
        const THRESHOLD: f64 = 0.15;
        const HALF: f64 = 0.45;
        let v = self.field.sample(
            &self.flare_octaves,
            cos_u,
            sin_u,
            at.flare_tau,
            s.channels[5],
        );
        let x = ((v - THRESHOLD) / (HALF - THRESHOLD)).max(0.0);
        let x3 = x * x * x;
        x3 / (1.0 + x3)
    }

    /// Width and heat (0..1) of material angle (cos u, sin u) of strand `s`.
    #[inline]
    pub fn width_and_heat(
        &self,
        s: &Strand,
        at: &StrandInstant,
        cos_u: f64,
        sin_u: f64,
    ) -> (f64, f64) {
        let h = self
            .field
            .sample(&at.octaves, cos_u, sin_u, at.tau, s.channels[2]);
        (
            self.look.width * (1.0 + self.look.width_variation * h),
            0.5 + 0.5 * h,
        )
    }

    /// Emission multiplier of strand `s` at time `t` from flicker, in [1 − flicker, 1 + flicker].
    pub fn flicker(&self, s: &Strand, t: f64) -> f64 {
        let c = &self.look.color;
        1.0 + c.flicker * self.field.signal(c.flicker_rate * t, s.channels[3])
    }

    /// Emitted radiance scale and colour for a given heat and flicker.
    pub fn emission(&self, heat: f64, flicker: f64) -> (f64, DVec3) {
        let c = &self.look.color;
        let intensity =
            c.intensity * (1.0 - c.intensity_variation + c.intensity_variation * heat) * flicker;
        (intensity, c.ramp.at(heat))
    }
}
