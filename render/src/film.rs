//! The film: per-pixel means (one-pixel box filter) and EXR / PNG output, written atomically.

use crate::error::RenderError;
use glam::Vec3;
use std::path::Path;

/// A finished image.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: usize,
    pub height: usize,
    /// Row-major, top row first.
    pub rgb: Vec<Vec3>,
    pub alpha: Vec<f32>,
    /// Samples discarded for being NaN or infinite.
    pub discarded: u64,
}

impl Image {
    /// Mean of each channel over the image.
    pub fn mean(&self) -> Vec3 {
        let sum: glam::DVec3 = self.rgb.iter().map(|c| c.as_dvec3()).sum();
        (sum / self.rgb.len() as f64).as_vec3()
    }

    /// Writes an RGBA float EXR.
    pub fn write_exr(&self, path: &Path) -> Result<(), RenderError> {
        use exr::prelude::*;
        let err = |message: String| RenderError::Write {
            path: path.to_owned(),
            message,
        };
        let (w, h) = (self.width, self.height);
        let channels = SpecificChannels::rgba(|Vec2(x, y): Vec2<usize>| {
            let c = self.rgb[y * w + x];
            (c.x, c.y, c.z, self.alpha[y * w + x])
        });
        let image = exr::image::Image::from_channels((w, h), channels);
        let mut bytes = std::io::Cursor::new(Vec::new());
        image
            .write()
            .to_buffered(&mut bytes)
            .map_err(|e| err(e.to_string()))?;
        rift_fx::export::atomic::write(path, |out| out.write_all(bytes.get_ref()))
            .map_err(|e| err(e.to_string()))
    }
}

/// Reads the RGB channels of an EXR (for references and tests).
pub fn read_exr_rgb(path: &Path) -> Result<(usize, usize, Vec<Vec3>), RenderError> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |resolution, _| {
            (
                resolution.width(),
                vec![Vec3::ZERO; resolution.width() * resolution.height()],
            )
        },
        |(w, pixels), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            pixels[pos.y() * *w + pos.x()] = Vec3::new(r, g, b)
        },
    )
    .map_err(|e| RenderError::Image {
        path: path.to_owned(),
        message: e.to_string(),
    })?;
    let size = image.layer_data.size;
    let (_, pixels) = image.layer_data.channel_data.pixels;
    Ok((size.width(), size.height(), pixels))
}
