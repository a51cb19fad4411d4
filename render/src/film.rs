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

    /// Writes an 8-bit sRGB PNG preview (values clipped to [0, 1], alpha dropped).
    pub fn write_png(&self, path: &Path) -> Result<(), RenderError> {
        let err = |message: String| RenderError::Write {
            path: path.to_owned(),
            message,
        };
        let mut bytes = Vec::with_capacity(self.rgb.len() * 3);
        for c in &self.rgb {
            bytes.extend(c.to_array().map(|v| (srgb_encode(v) * 255.0 + 0.5) as u8));
        }
        let mut encoded = Vec::new();
        {
            let mut encoder =
                png::Encoder::new(&mut encoded, self.width as u32, self.height as u32);
            encoder.set_color(png::ColorType::Rgb);
            encoder.set_depth(png::BitDepth::Eight);
            encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
            let mut writer = encoder.write_header().map_err(|e| err(e.to_string()))?;
            writer
                .write_image_data(&bytes)
                .map_err(|e| err(e.to_string()))?;
        }
        rift_fx::export::atomic::write(path, |out| out.write_all(&encoded))
            .map_err(|e| err(e.to_string()))
    }
}

/// The sRGB transfer function, for values clipped to [0, 1].
fn srgb_encode(linear: f32) -> f32 {
    let v = if linear.is_finite() {
        linear.clamp(0.0, 1.0)
    } else {
        0.0
    };
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Mean of each channel over an image, in f64.
pub fn channel_mean(pixels: &[Vec3]) -> glam::DVec3 {
    pixels.iter().map(|c| c.as_dvec3()).sum::<glam::DVec3>() / pixels.len() as f64
}

/// Relative MSE against a reference: the mean over pixels and channels of
/// (v − ref)² / (ref² + 0.01), the error measure of `rift bench convergence`.
pub fn relative_mse(image: &[Vec3], reference: &[Vec3]) -> f64 {
    let sum: f64 = image
        .iter()
        .zip(reference)
        .map(|(v, r)| {
            let (v, r) = (v.as_dvec3(), r.as_dvec3());
            ((v - r) * (v - r) / (r * r + glam::DVec3::splat(0.01))).element_sum()
        })
        .sum();
    sum / (3 * image.len()) as f64
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
