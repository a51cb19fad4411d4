//! Images read as textures: environment maps and, beside rift's own output, the EXR reading
//! every part of the renderer shares.

pub mod exr;

pub use exr::{MAX_EXR_PIXELS, decode_exr_rgb, read_exr_rgb};
