//! Reading EXR images within bounds: the header's declared size is checked before a pixel is
//! allocated, and small files decode on the calling thread.

use crate::error::RenderError;
use glam::Vec3;
use std::path::Path;

/// EXR files smaller than this are decoded on the calling thread: below it, starting the
/// decoder's own thread pool costs more than it saves (and a reader called many times, as a
/// fuzzer calls it, would start one pool per file).
const PARALLEL_DECODE_FROM: usize = 4 << 20;

/// `reader`, decoding on the calling thread when the file is smaller than
/// [`PARALLEL_DECODE_FROM`] bytes.
pub(crate) fn threads_for<F: FnMut(f64), L>(
    reader: exr::image::read::image::ReadImage<F, L>,
    bytes: usize,
) -> exr::image::read::image::ReadImage<F, L> {
    match bytes < PARALLEL_DECODE_FROM {
        true => reader.non_parallel(),
        false => reader,
    }
}

/// The most pixels an EXR rift reads may hold per layer (2^27: a 16k × 8k lat-long map, about
/// 5 GiB while it is decoded).
pub const MAX_EXR_PIXELS: usize = 1 << 27;

/// Refuses, before any pixel is allocated, an EXR whose header declares more than
/// `max_pixels` in a layer (a few bytes of header can ask for terabytes).
pub(crate) fn check_exr_size(bytes: &[u8], max_pixels: usize) -> Result<(), String> {
    let meta = exr::meta::MetaData::read_from_buffered(bytes, false).map_err(|e| e.to_string())?;
    for header in meta.headers.iter() {
        let size = header.layer_size;
        if size.width().saturating_mul(size.height()) > max_pixels {
            return Err(format!(
                "a layer of {}x{} pixels, more than the {max_pixels} rift reads",
                size.width(),
                size.height()
            ));
        }
    }
    Ok(())
}

/// The bytes of an EXR file, read within bounds (a regular file of bounded size).
pub(crate) fn read_bytes(path: &Path) -> Result<Vec<u8>, RenderError> {
    rift_fx::io::read(path).map_err(|e| RenderError::Image {
        path: path.to_owned(),
        message: e.to_string(),
    })
}

/// Reads the RGB channels of an EXR (environment maps, references and tests).
pub fn read_exr_rgb(path: &Path) -> Result<(usize, usize, Vec<Vec3>), RenderError> {
    decode_exr_rgb(&read_bytes(path)?, MAX_EXR_PIXELS).map_err(|message| RenderError::Image {
        path: path.to_owned(),
        message,
    })
}

/// The width, height and RGB pixels (row-major, top first) of EXR bytes with at most
/// `max_pixels` in a layer.
pub fn decode_exr_rgb(
    bytes: &[u8],
    max_pixels: usize,
) -> Result<(usize, usize, Vec<Vec3>), String> {
    use exr::prelude::*;
    check_exr_size(bytes, max_pixels)?;
    let reader = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
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
        .first_valid_layer()
        .all_attributes();
    let reader = threads_for(reader, bytes.len());
    let image = reader
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(|e| e.to_string())?;
    let size = image.layer_data.size;
    let (_, pixels) = image.layer_data.channel_data.pixels;
    Ok((size.width(), size.height(), pixels))
}
