//! A ring look: everything an artist sets about one opening's ring, validated and with defaults
//! filled in (see the shot-file syntax in [`crate::shot::schema`]).

use glam::DVec3;

/// The look of one ring. Lengths are in the opening's local frame.
#[derive(Clone, Debug, PartialEq)]
pub struct RingLook {
    pub radius: f64,
    pub band: f64,
    pub strands: u32,
    pub counter_rotating: f64,
    pub width: f64,
    pub width_variation: f64,
    pub speed_variation: f64,
    pub seed: u32,
    pub noise: NoiseLook,
    pub speed: SpeedLook,
    pub color: ColorLook,
    /// Strands drifting apart and flaring; `None`: a steady ring.
    pub instability: Option<InstabilityLook>,
}

/// How unstable a ring is: each strand drifts from its place in the band and back on a slow
/// signal of its own (strands separate and re-form), and flares burst outward along strands
/// where a noise channel peaks (kinks in the curve that come and go).
#[derive(Clone, Debug, PartialEq)]
pub struct InstabilityLook {
    /// Largest drift of a strand, in units of the band's width.
    pub separation: f64,
    /// Height of the tallest flares, in units of the radius.
    pub flare: f64,
    /// How fast drift and flares change, in cycles per second.
    pub rate: f64,
}

/// Shape noise: radial and axial displacement, its frequency and how it evolves.
#[derive(Clone, Debug, PartialEq)]
pub struct NoiseLook {
    pub amplitude: f64,
    pub depth: f64,
    pub frequency: f64,
    pub octaves: u32,
    pub roughness: f64,
    pub evolution: f64,
    pub size_compensation: f64,
}

/// Perceived rotation speed.
#[derive(Clone, Debug, PartialEq)]
pub struct SpeedLook {
    pub turns_per_second: f64,
    pub reference_size: f64,
    pub size_compensation: f64,
    pub min_visible_turn: f64,
}

/// Colour and emission.
#[derive(Clone, Debug, PartialEq)]
pub struct ColorLook {
    pub ramp: ColorRamp,
    pub intensity: f64,
    pub intensity_variation: f64,
    pub flicker: f64,
    pub flicker_rate: f64,
}

/// A piecewise-linear colour ramp over [0, 1] in linear Rec.709.
#[derive(Clone, Debug, PartialEq)]
pub struct ColorRamp {
    /// (position, colour), positions strictly increasing.
    pub stops: Vec<(f64, DVec3)>,
}

impl ColorRamp {
    /// The default: deep orange at the cool end to warm white at the hot end.
    pub fn ember() -> Self {
        Self {
            stops: vec![
                (0.0, DVec3::new(1.0, 0.22, 0.02)),
                (0.6, DVec3::new(1.0, 0.55, 0.12)),
                (1.0, DVec3::new(1.0, 0.92, 0.75)),
            ],
        }
    }

    /// The colour at `x`, clamped to the end stops.
    pub fn at(&self, x: f64) -> DVec3 {
        let stops = &self.stops;
        if x <= stops[0].0 {
            return stops[0].1;
        }
        for w in stops.windows(2) {
            let ((a, ca), (b, cb)) = (w[0], w[1]);
            if x <= b {
                return ca.lerp(cb, (x - a) / (b - a));
            }
        }
        stops[stops.len() - 1].1
    }
}

impl RingLook {
    /// The defaults for a ring of `radius` with `strands` strands.
    pub fn with_defaults(radius: f64, strands: u32) -> Self {
        Self {
            radius,
            band: 0.06 * radius,
            strands,
            counter_rotating: 0.5,
            width: 0.012 * radius,
            width_variation: 0.5,
            speed_variation: 0.2,
            seed: 0,
            noise: NoiseLook {
                amplitude: 0.035 * radius,
                depth: 0.5,
                frequency: 7.0,
                octaves: 3,
                roughness: 0.5,
                evolution: 0.5,
                size_compensation: 1.0,
            },
            speed: SpeedLook {
                turns_per_second: 0.4,
                reference_size: 0.25,
                size_compensation: 1.0,
                min_visible_turn: 0.1,
            },
            color: ColorLook {
                ramp: ColorRamp::ember(),
                intensity: 10.0,
                intensity_variation: 0.6,
                flicker: 0.15,
                flicker_rate: 9.0,
            },
            instability: None,
        }
    }

    /// Largest distance of any strand centreline from the ring centre in the opening plane.
    pub fn max_radius(&self) -> f64 {
        let (drift, flare) = self.instability_reach();
        self.radius + 0.5 * self.band + self.noise.amplitude + drift + flare
    }

    /// Smallest distance of any strand centreline from the ring centre.
    pub fn min_radius(&self) -> f64 {
        let (drift, _) = self.instability_reach();
        self.radius - 0.5 * self.band - self.noise.amplitude - drift
    }

    /// How far instability moves a strand: its drift either way and its flares outward.
    fn instability_reach(&self) -> (f64, f64) {
        self.instability.as_ref().map_or((0.0, 0.0), |i| {
            (i.separation * self.band, i.flare * self.radius)
        })
    }
}
