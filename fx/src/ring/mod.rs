//! Ring generation: counter-rotating, noise-modulated strands around an opening, with perceptual
//! speed control and baked motion and colour.

pub mod look;

pub use look::{ColorLook, ColorRamp, NoiseLook, RingLook, SpeedLook};
