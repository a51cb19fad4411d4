//! A frame: render passes over tiles of pixels, the film they fill and write, checkpoints of
//! their running sums, Cryptomatte object IDs, and denoising the finished frame.

pub mod checkpoint;
pub mod cryptomatte;
pub mod denoise;
pub mod film;
pub mod passes;
pub mod reveal;

pub use film::{Image, Metadata, Window};
pub use passes::{RenderOptions, Rendered, Sums, render, render_resumable};
