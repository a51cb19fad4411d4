//! The film: per-pixel means (one-pixel box filter) and EXR / PNG output, written atomically.

use crate::error::RenderError;
use crate::texture::exr::{MAX_EXR_PIXELS, check_exr_size, read_bytes, threads_for};
use glam::Vec3;
use std::path::Path;

/// A pixel window: columns x0..x1 and rows y0..y1 (half-open), top row 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Window {
    pub x0: usize,
    pub x1: usize,
    pub y0: usize,
    pub y1: usize,
}

impl Window {
    /// The whole image.
    pub fn full(width: usize, height: usize) -> Self {
        Self {
            x0: 0,
            x1: width,
            y0: 0,
            y1: height,
        }
    }

    /// A crop window from fractions of the image `x0,x1,y0,y1` in [0, 1] (as in pbrt and
    /// Cycles' border render): the pixels whose centres it holds (x0 ≤ centre < x1), so
    /// windows that share an edge fraction tile the frame with no pixel twice or missing.
    pub fn from_fractions(text: &str, width: usize, height: usize) -> Result<Self, String> {
        let parts: Vec<&str> = text.split(',').map(str::trim).collect();
        let values: Vec<f64> = parts
            .iter()
            .map(|p| p.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("expected four numbers x0,x1,y0,y1, got {text:?}"))?;
        let [x0, x1, y0, y1] = values[..] else {
            return Err(format!("expected four numbers x0,x1,y0,y1, got {text:?}"));
        };
        if !values.iter().all(|v| (0.0..=1.0).contains(v)) {
            return Err(format!(
                "{text:?}: each value is a fraction of the image from 0 to 1"
            ));
        }
        if x0 >= x1 || y0 >= y1 {
            return Err(format!(
                "{text:?}: the window is empty (x0 must be below x1 and y0 below y1)"
            ));
        }
        let (w, h) = (width as f64, height as f64);
        // The first pixel whose centre (i + 0.5) is at or past `f · size`.
        let edge =
            |f: f64, size: f64| ((f * size - 0.5).ceil().max(0.0) as usize).min(size as usize);
        let window = Self {
            x0: edge(x0, w),
            x1: edge(x1, w),
            y0: edge(y0, h),
            y1: edge(y1, h),
        };
        if window.width() == 0 || window.height() == 0 {
            return Err(format!("{text:?}: the window holds no pixel"));
        }
        Ok(window)
    }

    pub fn width(&self) -> usize {
        self.x1 - self.x0
    }

    pub fn height(&self) -> usize {
        self.y1 - self.y0
    }

    pub fn area(&self) -> usize {
        self.width() * self.height()
    }
}

/// What an EXR records about how it was made.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Metadata {
    pub frame: i64,
    pub render_seconds: f64,
    /// Samples per pixel asked for (the most any pixel took); the end of the sample range.
    pub spp: u32,
    /// The first sample index rendered: 0 unless the image is one part of a split render.
    pub first_sample: u32,
    /// The render's seed, so parts of different renders are never merged.
    pub seed: u32,
    /// A hash of the shot's name (0: unknown), for the same reason.
    pub shot_id: u32,
    /// Row-major world-to-camera matrix at the frame (camera looks down −Z).
    pub world_to_camera: [f32; 16],
    /// Row-major world-to-NDC matrix (perspective) at the frame.
    pub world_to_ndc: [f32; 16],
    /// The stereo view ("left", "right"), if the image is one eye of a pair.
    pub view: Option<String>,
}

/// Depth written where a camera ray hit nothing (a large finite value, as compositing
/// packages expect; never infinity).
pub const BACKGROUND_DEPTH: f32 = 1e10;

/// EXR layer of the light that arrived through openings, and of the rest; the two sum to the
/// beauty, so a compositor can rebalance light spilling through a window or door.
pub const THROUGH_LAYER: &str = "throughOpenings";
pub const LOCAL_LAYER: &str = "notThroughOpenings";
/// The layer of the emission the camera sees directly.
pub const EMISSION_LAYER: &str = "emission";
/// The layer of a denoised frame's beauty as rendered.
pub const NOISY_LAYER: &str = "noisy";

/// The part of `beauty` that did not arrive through openings: the beauty less `through`, pixel
/// by pixel (the layer [`LOCAL_LAYER`]).
fn not_through(beauty: &[Vec3], through: &[Vec3]) -> Vec<Vec3> {
    beauty.iter().zip(through).map(|(c, t)| c - t).collect()
}

/// EXR layers of light groups are named this followed by the group's name.
pub const LIGHT_GROUP_PREFIX: &str = "lightgroup.";

/// What [`Image::write_exr_with`] adds to or leaves out of an image's EXR.
#[derive(Default)]
pub struct ExrExtras {
    pub channels: Vec<exr::prelude::AnyChannel<exr::prelude::FlatSamples>>,
    pub attributes: Vec<(String, exr::meta::attribute::AttributeValue)>,
    /// Only these of the image's own channels; `None`: all of them.
    pub only: Option<&'static [&'static str]>,
    /// Uncompressed and encoded on the calling thread.
    pub fast: bool,
}

/// A finished image: the beauty pass and the AOVs over a data window of a full frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Full frame size (the display window).
    pub width: usize,
    pub height: usize,
    /// The pixels held (the data window); the whole frame unless cropped.
    pub window: Window,
    /// Row-major over the window, top row first.
    pub rgb: Vec<Vec3>,
    /// The part of `rgb` that arrived through openings (light that teleported between its
    /// emitter and the first surface the camera sees); `None` in scenes without openings.
    pub through: Option<Vec<Vec3>>,
    pub alpha: Vec<f32>,
    /// Reflectance of the first surface hit, averaged over the pixel's samples.
    pub albedo: Vec<Vec3>,
    /// World-space normal of the first surface hit (facing the camera), averaged.
    pub normal: Vec<Vec3>,
    /// Camera-space depth of the first hit, averaged over the samples that hit.
    pub depth: Vec<f32>,
    /// Teleports the camera paths made before their first scattering event, averaged: 0 where
    /// no opening is seen, k on the k-th nested level of a portal seen in itself.
    pub portal_depth: Vec<f32>,
    /// Each light group's part of `rgb`, by name (the default group first; empty when the
    /// shot names no group): written as `lightgroup.<name>.R/G/B`, they sum to the beauty.
    pub light_groups: Vec<(String, Vec<Vec3>)>,
    /// Object IDs ranked by coverage per pixel, when asked for: written as `CryptoObject00…`
    /// layers with the Cryptomatte header.
    pub cryptomatte: Option<crate::frame::cryptomatte::Cryptomatte>,
    /// The part of `rgb` the camera saw emitted directly (lamps, rings, the sky, through
    /// openings too): written as `emission.R/G/B`, and left out of denoising.
    pub emitted: Vec<Vec3>,
    /// The beauty as rendered, when `rgb` has been denoised ([`crate::frame::denoise`]):
    /// written as `noisy.R/G/B`.
    pub noisy: Option<Vec<Vec3>>,
    /// Samples that count in each pixel's mean (adaptive sampling and time limits make them
    /// differ; non-finite samples are dropped and not counted).
    pub spp: Vec<u32>,
    /// Samples discarded for being NaN or infinite.
    pub discarded: u64,
    /// How noisy the rendered beauty is: the median over pixels of the standard error of each
    /// pixel's mean luminance, relative to that mean (with relMSE's 0.01 floor); `None` where it
    /// was not estimated (a merged image).
    pub noise: Option<f32>,
    pub metadata: Metadata,
}

impl Image {
    /// Writes a float EXR with R, G, B, A, albedo.R/G/B, N.X/Y/Z, Z, portalDepth, spp and (in
    /// scenes with openings) the through/not-through light layers, the crop as the data
    /// window, and the metadata as header attributes.
    pub fn write_exr(&self, path: &Path) -> Result<(), RenderError> {
        self.write_exr_with(path, ExrExtras::default())
    }

    /// [`Self::write_exr`] with `extra`'s channels and attributes, keeping only its `only`
    /// channels of the image when given, and uncompressed when `extra.fast` (a checkpoint,
    /// written while rendering goes on).
    pub fn write_exr_with(&self, path: &Path, extra: ExrExtras) -> Result<(), RenderError> {
        use exr::prelude::*;
        let err = |message: String| RenderError::Write {
            path: path.to_owned(),
            message,
        };
        let mut channels = self.exr_channels();
        if let Some(only) = extra.only {
            channels.retain(|c| only.contains(&c.name.to_string().as_str()));
        }
        channels.extend(extra.channels);
        let mut attributes = self.exr_attributes();
        for (key, value) in extra.attributes {
            attributes.other.insert(Text::from(key.as_str()), value);
        }
        let encoding = match extra.fast {
            true => Encoding::UNCOMPRESSED,
            false => Encoding::SMALL_LOSSLESS,
        };
        let layer = Layer::new(
            (self.window.width(), self.window.height()),
            attributes,
            encoding,
            AnyChannels::sort(SmallVec::from_vec(channels)),
        );
        let display = IntegerBounds::from_dimensions((self.width, self.height));
        let image = exr::image::Image::new(ImageAttributes::new(display), layer);
        let mut bytes = std::io::Cursor::new(Vec::new());
        let written = match extra.fast {
            true => image.write().non_parallel().to_buffered(&mut bytes),
            false => image.write().to_buffered(&mut bytes),
        };
        written.map_err(|e| err(e.to_string()))?;
        rift_fx::export::atomic::write(path, |out| out.write_all(bytes.get_ref()))
            .map_err(|e| err(e.to_string()))
    }

    /// The beauty, AOV and light-layer channels, unsorted.
    fn exr_channels(&self) -> Vec<exr::prelude::AnyChannel<exr::prelude::FlatSamples>> {
        use exr::prelude::*;
        let channel =
            |name: &str, values: Vec<f32>| AnyChannel::new(name, FlatSamples::F32(values));
        let split = |v: &[Vec3], k: usize| v.iter().map(|c| c[k]).collect::<Vec<f32>>();
        let mut channels = vec![
            channel("R", split(&self.rgb, 0)),
            channel("G", split(&self.rgb, 1)),
            channel("B", split(&self.rgb, 2)),
            channel("A", self.alpha.clone()),
            channel("Z", self.depth.clone()),
            channel("spp", self.spp.iter().map(|&n| n as f32).collect()),
            channel("portalDepth", self.portal_depth.clone()),
        ];
        // A layer of three channels: `{name}.R/G/B` (or the `suffixes` given).
        let layer = |name: &str, values: &[Vec3], suffixes: [&str; 3]| {
            (0..3)
                .map(|k| channel(&format!("{name}.{}", suffixes[k]), split(values, k)))
                .collect::<Vec<_>>()
        };
        const RGB: [&str; 3] = ["R", "G", "B"];
        channels.extend(layer("albedo", &self.albedo, RGB));
        channels.extend(layer("N", &self.normal, ["X", "Y", "Z"]));
        for (name, light) in &self.light_groups {
            channels.extend(layer(&format!("{LIGHT_GROUP_PREFIX}{name}"), light, RGB));
        }
        if let Some(crypto) = &self.cryptomatte {
            for (name, values) in crypto.channels() {
                channels.push(channel(&name, values));
            }
        }
        channels.extend(layer(EMISSION_LAYER, &self.emitted, RGB));
        if let Some(noisy) = &self.noisy {
            channels.extend(layer(NOISY_LAYER, noisy, RGB));
        }
        if let Some(through) = &self.through {
            channels.extend(layer(THROUGH_LAYER, through, RGB));
            channels.extend(layer(LOCAL_LAYER, &not_through(&self.rgb, through), RGB));
        }
        channels
    }

    /// The data window's position, the camera matrices, the view and the `rift/...` numbers.
    fn exr_attributes(&self) -> exr::meta::header::LayerAttributes {
        use exr::prelude::*;
        let mut attributes = LayerAttributes {
            layer_position: Vec2(self.window.x0 as i32, self.window.y0 as i32),
            software_name: Some(Text::from(concat!("rift ", env!("CARGO_PKG_VERSION")))),
            world_to_camera: Some(self.metadata.world_to_camera),
            world_to_normalized_device: Some(self.metadata.world_to_ndc),
            view_name: self.metadata.view.as_deref().map(Text::from),
            ..Default::default()
        };
        let m = &self.metadata;
        for (key, value) in [
            ("rift/frame", AttributeValue::I32(m.frame as i32)),
            ("rift/renderSeconds", AttributeValue::F64(m.render_seconds)),
            ("rift/spp", AttributeValue::I32(m.spp as i32)),
            (
                "rift/sampleStart",
                AttributeValue::F64(m.first_sample as f64),
            ),
            ("rift/seed", AttributeValue::F64(m.seed as f64)),
            ("rift/shotId", AttributeValue::F64(m.shot_id as f64)),
            (
                "rift/discardedSamples",
                AttributeValue::F64(self.discarded as f64),
            ),
        ] {
            attributes.other.insert(Text::from(key), value);
        }
        for (key, value) in self.cryptomatte.iter().flat_map(|c| c.attributes()) {
            attributes.other.insert(
                Text::from(key.as_str()),
                AttributeValue::Text(Text::from(value.as_str())),
            );
        }
        attributes
    }

    /// Writes an 8-bit sRGB PNG preview (values clipped to [0, 1], alpha dropped).
    pub fn write_png(&self, path: &Path) -> Result<(), RenderError> {
        write_srgb_png(path, self.window.width(), self.window.height(), &self.rgb)
    }
}

/// Writes linear RGB pixels (row-major, top first) as an 8-bit sRGB PNG, values clipped to
/// [0, 1], atomically.
pub fn write_srgb_png(
    path: &Path,
    width: usize,
    height: usize,
    rgb: &[Vec3],
) -> Result<(), RenderError> {
    let err = |message: String| RenderError::Write {
        path: path.to_owned(),
        message,
    };
    let encoded = encode_srgb_png(width, height, rgb).map_err(err)?;
    rift_fx::export::atomic::write(path, |out| out.write_all(&encoded))
        .map_err(|e| err(e.to_string()))
}

/// An 8-bit sRGB PNG of `rgb` (`width` x `height`, rows top first), in memory.
pub fn encode_srgb_png(width: usize, height: usize, rgb: &[Vec3]) -> Result<Vec<u8>, String> {
    let mut bytes = Vec::with_capacity(rgb.len() * 3);
    for c in rgb {
        bytes.extend(c.to_array().map(|v| (srgb_encode(v) * 255.0 + 0.5) as u8));
    }
    let mut encoded = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut encoded, width as u32, height as u32);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
        writer.write_image_data(&bytes).map_err(|e| e.to_string())?;
    }
    Ok(encoded)
}

/// The sRGB transfer function, for values clipped to [0, 1] (anything not finite is black).
fn srgb_encode(linear: f32) -> f32 {
    let v = if linear.is_finite() {
        linear.clamp(0.0, 1.0)
    } else {
        0.0
    };
    crate::texture::mipmap::linear_to_srgb(v)
}

/// Mean of each channel over an image, in f64.
pub fn channel_mean(pixels: &[Vec3]) -> glam::DVec3 {
    pixels.iter().map(|c| c.as_dvec3()).sum::<glam::DVec3>() / pixels.len() as f64
}

/// Relative MSE against a reference: the mean over pixels and channels of
/// (v − ref)² / (ref² + 0.01), the error measure of `rift bench convergence`.
pub fn relative_mse(image: &[Vec3], reference: &[Vec3]) -> f64 {
    mean_regularised_square(image, reference, reference)
}

/// The variance of an unbiased renderer's image, from two renders with different seeds and
/// measured as [`relative_mse`] is: half the mean of (a − b)² / (ref² + 0.01). A reference's
/// own noise adds to every relMSE measured against it (the Cornell box's, 16,384 samples, adds
/// about 1.7·10⁻⁵, a sixth of rift's error at 256 samples); it does not enter this, and bias
/// does not either, so the mean against the reference still has to be checked beside it.
pub fn relative_variance(a: &[Vec3], b: &[Vec3], reference: &[Vec3]) -> f64 {
    mean_regularised_square(a, b, reference) / 2.0
}

/// The mean over pixels and channels of (a − b)² / (scale² + 0.01).
fn mean_regularised_square(a: &[Vec3], b: &[Vec3], scale: &[Vec3]) -> f64 {
    let sum: f64 = a
        .iter()
        .zip(b)
        .zip(scale)
        .map(|((a, b), r)| {
            let (d, r) = ((a.as_dvec3() - b.as_dvec3()), r.as_dvec3());
            (d * d / (r * r + glam::DVec3::splat(0.01))).element_sum()
        })
        .sum();
    sum / (3 * a.len()) as f64
}

/// Every channel of an EXR's first layer, with where it sits in the frame (for tests and
/// tools that check what rift wrote).
#[derive(Clone, Debug)]
pub struct ExrLayer {
    /// Display window size.
    pub display: (usize, usize),
    /// Data window position and size.
    pub position: (i32, i32),
    pub size: (usize, usize),
    /// Samples per channel name, row-major over the data window.
    pub channels: std::collections::BTreeMap<String, Vec<f32>>,
    /// Custom header attributes rift writes (`rift/...`), as numbers.
    pub numbers: std::collections::BTreeMap<String, f64>,
    /// The standard camera matrices and view name, when present.
    pub world_to_camera: Option<[f32; 16]>,
    pub world_to_ndc: Option<[f32; 16]>,
    pub view: Option<String>,
}

/// Pixels and channels of an EXR's first layer, from its header alone (to size work before
/// reading the pixels).
pub fn exr_layer_shape(path: &Path) -> Result<(usize, usize), RenderError> {
    let fail = |message: String| RenderError::Image {
        path: path.to_owned(),
        message,
    };
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| fail(e.to_string()))?;
    let header = meta
        .headers
        .first()
        .ok_or_else(|| fail("the file has no layer".into()))?;
    let size = header.layer_size;
    Ok((
        size.width().saturating_mul(size.height()),
        header.channels.list.len(),
    ))
}

/// Reads the first layer of an EXR with all its channels.
pub fn read_exr_layer(path: &Path) -> Result<ExrLayer, RenderError> {
    decode_exr_layer(&read_bytes(path)?, MAX_EXR_PIXELS).map_err(|message| RenderError::Image {
        path: path.to_owned(),
        message,
    })
}

/// The first layer of EXR bytes with at most `max_pixels` in a layer, with all its channels.
pub fn decode_exr_layer(bytes: &[u8], max_pixels: usize) -> Result<ExrLayer, String> {
    use exr::prelude::*;
    check_exr_size(bytes, max_pixels)?;
    let reader = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes();
    let reader = threads_for(reader, bytes.len());
    let image = reader
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(|e| e.to_string())?;
    let display = image.attributes.display_window.size;
    let layer = image
        .layer_data
        .first()
        .ok_or_else(|| "the file has no layer".to_owned())?;
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|c| {
            let values = c.sample_data.values_as_f32().collect();
            (c.name.to_string(), values)
        })
        .collect();
    let numbers = layer
        .attributes
        .other
        .iter()
        .filter_map(|(k, v)| {
            let n = match v {
                AttributeValue::F64(x) => *x,
                AttributeValue::F32(x) => *x as f64,
                AttributeValue::I32(x) => *x as f64,
                _ => return None,
            };
            Some((k.to_string(), n))
        })
        .collect();
    Ok(ExrLayer {
        display: (display.width(), display.height()),
        position: (
            layer.attributes.layer_position.x(),
            layer.attributes.layer_position.y(),
        ),
        size: (layer.size.width(), layer.size.height()),
        channels,
        numbers,
        world_to_camera: layer.attributes.world_to_camera,
        world_to_ndc: layer.attributes.world_to_normalized_device,
        view: layer.attributes.view_name.as_ref().map(|t| t.to_string()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniform noise in [−h, h] per channel, from a hashed counter (deterministic).
    fn noisy(truth: &[Vec3], h: f32, stream: u32) -> Vec<Vec3> {
        let mut k = stream.wrapping_mul(0x9e37_79b9);
        let mut u = || {
            k = k.wrapping_add(1);
            crate::sampling::hash32(k) as f32 / u32::MAX as f32 * 2.0 - 1.0
        };
        truth
            .iter()
            .map(|&t| t + h * Vec3::new(u(), u(), u()))
            .collect()
    }

    #[test]
    fn two_seeds_measure_the_error_against_the_truth_that_a_noisy_reference_overstates() {
        let truth: Vec<Vec3> = (0..40_000)
            .map(|i| Vec3::splat(0.05 + (i % 200) as f32 / 200.0))
            .collect();
        // Uniform noise of half-width h has variance h²/3.
        let (h, h_reference) = (0.03f32, 0.02f32);
        let expected: f64 = truth
            .iter()
            .map(|t| (h * h / 3.0) as f64 / (t.x as f64 * t.x as f64 + 0.01))
            .sum::<f64>()
            / truth.len() as f64;
        let (a, b) = (noisy(&truth, h, 1), noisy(&truth, h, 2));
        let reference = noisy(&truth, h_reference, 3);
        let variance = relative_variance(&a, &b, &truth);
        assert!(
            (variance / expected - 1.0).abs() < 0.02,
            "{variance} {expected}"
        );
        // Against the truth relMSE agrees; against a noisy reference it grows by that
        // reference's own error (h_reference² / h² = 4/9 of it), which the two seeds leave out.
        let against_truth = relative_mse(&a, &truth);
        assert!((against_truth / expected - 1.0).abs() < 0.02);
        let against_noisy = relative_mse(&a, &reference);
        assert!(
            (against_noisy / expected - 13.0 / 9.0).abs() < 0.04,
            "{against_noisy}"
        );
        assert_eq!(relative_variance(&a, &a, &truth), 0.0);
    }
}
