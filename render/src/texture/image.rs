//! Texture images read from PNG, JPEG or EXR files (told apart by their first bytes), within
//! bounds: the header's size is checked against the most texels rift takes and the bytes left
//! in the scene's memory budget before any texel is decoded. 8- and 16-bit images keep 8 bits a
//! channel (a 16-bit one is rounded); EXR keeps 32-bit floats. Whether 8-bit values are sRGB-
//! encoded or linear is the texture's colour space.

use std::io::Cursor;

/// The most texels one texture image may hold (2^28: a 16k × 16k map).
pub const MAX_TEXELS: u64 = 1 << 28;

/// How a texture's integer values map to linear values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ColorSpace {
    /// sRGB-encoded (colour maps of 8 or 16 bits).
    Srgb,
    /// Linear (data maps: roughness, normals, opacity; and every EXR).
    Linear,
}

/// What a texture image's texels are stored as.
#[derive(Clone, Debug)]
pub enum Texels {
    /// 8-bit values, `channels` per texel, row-major, top row first.
    Bytes(Vec<u8>),
    /// Linear floats.
    Floats(Vec<f32>),
}

/// A decoded texture image.
#[derive(Clone, Debug)]
pub struct Picture {
    pub width: usize,
    pub height: usize,
    /// 1 (grey), 2 (grey and alpha), 3 (RGB) or 4 (RGBA).
    pub channels: usize,
    pub texels: Texels,
}

impl Picture {
    /// Bytes its texels take.
    pub fn bytes(&self) -> u64 {
        match &self.texels {
            Texels::Bytes(v) => v.len() as u64,
            Texels::Floats(v) => 4 * v.len() as u64,
        }
    }
}

/// The file formats read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Png,
    Jpeg,
    Exr,
}

/// The format `bytes` start like.
fn format(bytes: &[u8]) -> Result<Format, String> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        Ok(Format::Png)
    } else if bytes.starts_with(&[0xff, 0xd8, 0xff]) {
        Ok(Format::Jpeg)
    } else if bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        Ok(Format::Exr)
    } else {
        Err("not a PNG, JPEG or EXR image".into())
    }
}

/// Bytes decoding an image of `width` × `height` × `channels` takes at its peak: the decoder's
/// buffer (up to 8 bytes a channel for 16-bit sources) and the texels kept, with a third more
/// for their mipmaps.
pub fn decode_bytes(width: u64, height: u64, channels: u64, float: bool) -> u64 {
    let texels = width.saturating_mul(height).saturating_mul(channels);
    let kept = texels.saturating_mul(if float { 4 } else { 1 });
    texels
        .saturating_mul(8)
        .saturating_add(kept.saturating_add(kept / 3))
}

/// Decodes image `bytes` taking at most `budget` bytes (see [`decode_bytes`]).
pub fn decode(bytes: &[u8], budget: u64) -> Result<Picture, String> {
    match format(bytes)? {
        Format::Exr => decode_exr(bytes, budget),
        Format::Png => decode_png(bytes, budget),
        Format::Jpeg => decode_jpeg(bytes, budget),
    }
}

/// Refuses an image whose declared size is over [`MAX_TEXELS`] or would not fit in `budget`.
fn check_size(
    width: u64,
    height: u64,
    channels: u64,
    float: bool,
    budget: u64,
) -> Result<(), String> {
    let texels = width.saturating_mul(height);
    if texels == 0 {
        return Err("the image is empty".into());
    }
    if texels > MAX_TEXELS {
        return Err(format!(
            "it declares {width} × {height} texels, more than the {MAX_TEXELS} rift reads"
        ));
    }
    let needed = decode_bytes(width, height, channels, float);
    if needed > budget {
        return Err(format!(
            "{width} × {height} texels need about {} MiB to read, more than the {} MiB left \
             (give more with --max-memory where the machine has it)",
            needed >> 20,
            budget >> 20
        ));
    }
    Ok(())
}

/// A PNG as 8-bit texels: palettes, bit depths under 8 and transparency chunks expanded;
/// 16-bit values rounded to 8.
fn decode_png(bytes: &[u8], budget: u64) -> Result<Picture, String> {
    let limits = png::Limits {
        bytes: usize::try_from(budget).unwrap_or(usize::MAX),
    };
    let mut decoder = png::Decoder::new_with_limits(Cursor::new(bytes), limits);
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(|e| e.to_string())?;
    let (width, height) = (reader.info().width as usize, reader.info().height as usize);
    // Channels are known only once the transformations are: four is the most.
    check_size(width as u64, height as u64, 4, false, budget)?;
    let (color, depth) = reader.output_color_type();
    let size = reader
        .output_buffer_size()
        .ok_or("its decoded size does not fit in memory")?;
    let mut decoded = vec![0; size];
    let frame = reader.next_frame(&mut decoded).map_err(|e| e.to_string())?;
    decoded.truncate(frame.buffer_size());
    let texels = if depth == png::BitDepth::Sixteen {
        decoded
            .chunks_exact(2)
            .map(|pair| sixteen_to_eight(u16::from_be_bytes([pair[0], pair[1]])))
            .collect()
    } else {
        decoded
    };
    Ok(Picture {
        width,
        height,
        channels: color.samples(),
        texels: Texels::Bytes(texels),
    })
}

/// A 16-bit value rounded to the nearest of 8 bits (65535 to 255).
fn sixteen_to_eight(value: u16) -> u8 {
    ((u32::from(value) + 128) / 257) as u8
}

/// A JPEG as 8-bit texels: grey stays grey, every other colour model becomes RGB.
fn decode_jpeg(bytes: &[u8], budget: u64) -> Result<Picture, String> {
    use zune_jpeg::zune_core::{bytestream::ZCursor, colorspace::ColorSpace, options};
    let options = options::DecoderOptions::default()
        .set_strict_mode(false)
        .set_max_width(usize::MAX)
        .set_max_height(usize::MAX);
    let mut decoder = zune_jpeg::JpegDecoder::new_with_options(ZCursor::new(bytes), options);
    decoder.decode_headers().map_err(|e| e.to_string())?;
    let (width, height) = decoder.dimensions().ok_or("it has no frame header")?;
    let wanted = match decoder.input_colorspace() {
        Some(ColorSpace::Luma) => ColorSpace::Luma,
        _ => ColorSpace::RGB,
    };
    check_size(
        width as u64,
        height as u64,
        wanted.num_components() as u64,
        false,
        budget,
    )?;
    decoder.set_options(decoder.options().jpeg_set_out_colorspace(wanted));
    let texels = decoder.decode().map_err(|e| e.to_string())?;
    Ok(Picture {
        width,
        height,
        channels: wanted.num_components(),
        texels: Texels::Bytes(texels),
    })
}

/// An EXR's RGBA (first valid layer, largest level) as linear floats.
fn decode_exr(bytes: &[u8], budget: u64) -> Result<Picture, String> {
    let meta = exr::meta::MetaData::read_from_buffered(bytes, false).map_err(|e| e.to_string())?;
    let size = meta
        .headers
        .first()
        .ok_or("the file has no layer")?
        .layer_size;
    check_size(size.width() as u64, size.height() as u64, 4, true, budget)?;
    let (w, h, rgb) = super::exr::decode_exr_rgb(bytes, MAX_TEXELS as usize)?;
    let texels = rgb.iter().flat_map(|c| c.to_array()).collect();
    Ok(Picture {
        width: w,
        height: h,
        channels: 3,
        texels: Texels::Floats(texels),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seed(name: &str) -> Vec<u8> {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../fuzz/corpus/texture/");
        std::fs::read(format!("{path}{name}")).unwrap()
    }

    #[test]
    fn each_format_decodes_with_its_size_and_channels() {
        for (name, size, channels, float) in [
            ("rgb_3x2.png", (3, 2), 3, false),
            ("grey_alpha_2x2.png", (2, 2), 2, false),
            ("grey16_1x3.png", (1, 3), 1, false),
            ("gradient_8x4.jpg", (8, 4), 3, false),
            ("tiny.exr", (4, 4), 3, true),
        ] {
            let p = decode(&seed(name), 1 << 30).unwrap();
            assert_eq!((p.width, p.height), size, "{name}");
            assert_eq!(p.channels, channels, "{name}");
            assert_eq!(matches!(p.texels, Texels::Floats(_)), float, "{name}");
        }
        // 16 bits kept to 8: 0, 128·256 and 65535 become 0, 128 and 255.
        let Texels::Bytes(grey) = decode(&seed("grey16_1x3.png"), 1 << 30).unwrap().texels else {
            panic!("8-bit texels expected");
        };
        assert_eq!(grey, [0, 128, 255]);
    }

    #[test]
    fn too_little_budget_or_a_foreign_format_is_refused() {
        let e = decode(&seed("rgb_3x2.png"), 10).unwrap_err();
        assert!(e.contains("more than the 0 MiB left"), "{e}");
        assert!(
            decode(b"GIF89a", 1 << 30)
                .unwrap_err()
                .contains("not a PNG, JPEG or EXR")
        );
    }
}
