//! Named ring looks (`[portal.ring] preset = "…"`): complete looks scaled to the ring's radius,
//! which the shot's own keys then override one by one.
//!
//! - `rift`: an unstable rift in space: many strands in a wide band, strong counter-rotation,
//!   deep and lively noise, strands that drift apart and re-form and flare outward, warm light
//!   that flickers.
//! - `calm`: a steady, slow ring: few strands in a narrow band, gentle noise, no instability.
//! - `crackling`: an electric ring: thin fast strands, fine and fast-evolving noise, frequent
//!   small flares, cold blue-white light with strong flicker.

use super::look::{ColorRamp, InstabilityLook, RingLook};
use glam::DVec3;

/// The preset names, in the order the contact sheet shows them.
pub const NAMES: [&str; 3] = ["rift", "calm", "crackling"];

/// The look `name` for a ring of `radius`, or `None` for an unknown name.
pub fn preset(name: &str, radius: f64) -> Option<RingLook> {
    let mut look = RingLook::with_defaults(radius, 24);
    match name {
        "rift" => {
            look.strands = 28;
            look.band = 0.11 * radius;
            look.counter_rotating = 0.5;
            look.width = 0.011 * radius;
            look.width_variation = 0.7;
            look.speed_variation = 0.25;
            look.noise.amplitude = 0.05 * radius;
            look.noise.depth = 0.8;
            look.noise.frequency = 7.0;
            look.noise.octaves = 3;
            look.noise.roughness = 0.55;
            look.noise.evolution = 0.6;
            look.speed.turns_per_second = 0.28;
            look.color.intensity = 12.0;
            look.color.intensity_variation = 0.7;
            look.color.flicker = 0.25;
            look.color.flicker_rate = 7.0;
            look.instability = Some(InstabilityLook {
                separation: 1.2,
                flare: 0.2,
                rate: 0.25,
            });
        }
        "calm" => {
            look.strands = 14;
            look.band = 0.04 * radius;
            look.width = 0.01 * radius;
            look.width_variation = 0.3;
            look.speed_variation = 0.1;
            look.noise.amplitude = 0.015 * radius;
            look.noise.depth = 0.3;
            look.noise.frequency = 5.0;
            look.noise.octaves = 2;
            look.noise.evolution = 0.2;
            look.speed.turns_per_second = 0.25;
            look.color.intensity = 8.0;
            look.color.intensity_variation = 0.4;
            look.color.flicker = 0.05;
            look.color.flicker_rate = 3.0;
        }
        "crackling" => {
            look.strands = 36;
            look.band = 0.07 * radius;
            look.width = 0.007 * radius;
            look.width_variation = 0.8;
            look.speed_variation = 0.25;
            look.noise.amplitude = 0.04 * radius;
            look.noise.depth = 0.6;
            look.noise.frequency = 11.0;
            look.noise.octaves = 5;
            look.noise.roughness = 0.7;
            look.noise.evolution = 1.0;
            look.speed.turns_per_second = 0.28;
            look.color.ramp = ColorRamp {
                stops: vec![
                    (0.0, DVec3::new(0.12, 0.3, 1.0)),
                    (0.6, DVec3::new(0.45, 0.7, 1.0)),
                    (1.0, DVec3::new(0.95, 0.97, 1.0)),
                ],
            };
            look.color.intensity = 14.0;
            look.color.intensity_variation = 0.8;
            look.color.flicker = 0.45;
            look.color.flicker_rate = 16.0;
            look.instability = Some(InstabilityLook {
                separation: 0.4,
                flare: 0.1,
                rate: 0.6,
            });
        }
        _ => return None,
    }
    Some(look)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_named_preset_exists_and_scales_with_the_radius() {
        for name in NAMES {
            let (a, b) = (preset(name, 1.0).unwrap(), preset(name, 2.0).unwrap());
            assert_eq!(b.band, 2.0 * a.band, "{name}");
            assert_eq!(b.noise.amplitude, 2.0 * a.noise.amplitude, "{name}");
            assert!(a.min_radius() > 0.5, "{name}: strands reach the centre");
        }
        assert!(preset("wobbly", 1.0).is_none());
    }
}
