//! Ring generation: counter-rotating, noise-modulated strands around an opening, with perceptual
//! speed control and baked motion and colour.

pub mod look;

pub use look::{ColorLook, ColorRamp, InstabilityLook, NoiseLook, RingLook, SpeedLook};
pub mod bake;
pub mod curves;
pub mod noise_field;
pub mod presets;
pub mod strand;
pub mod timing;

pub use bake::{MotionError, RingGenerator};
pub use curves::{RingCurves, RingFrame};
pub use strand::RingModel;
pub use timing::RingTiming;
