//! A texture as the renderer looks it up: the image and its mipmap pyramid (each level a 2×2
//! box filter of the one above, averaged in linear values), built once and shared by every
//! material that uses it. A lookup takes the level whose texels match the ray's footprint,
//! bilinear within a level and linear between the two nearest levels, as pbrt does; UVs wrap,
//! and v = 0 is the image's bottom row (OBJ and USD's convention).

use super::image::{ColorSpace, Picture, Texels};
use crate::sampling::hash32;
use glam::{Vec2, Vec4};
use rayon::prelude::*;
use std::sync::OnceLock;

/// One level of the pyramid.
#[derive(Clone, Debug)]
struct Level {
    width: usize,
    height: usize,
    texels: Texels,
}

/// A texture image with its mipmaps.
#[derive(Clone, Debug)]
pub struct Texture {
    levels: Vec<Level>,
    channels: usize,
    color_space: ColorSpace,
}

/// sRGB-encoded 8-bit values to linear ones.
fn srgb_table() -> &'static [f32; 256] {
    static TABLE: OnceLock<[f32; 256]> = OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0)))
}

/// Levels of fewer texels are kept as floats: too few for their dither to average out (a
/// 1 × 1 level would be off by up to half a code, 0.6% at mid-grey), and too small to matter.
const FLOAT_LEVELS_BELOW: usize = 4096;

/// Buckets of the linear range in [`srgb_floors`].
const GUESS_BUCKETS: usize = 4096;

/// The highest sRGB code whose linear value is at most the bottom of each of
/// [`GUESS_BUCKETS`] equal steps of the linear range: where [`encode_srgb`] starts looking.
fn srgb_floors() -> &'static [u8; GUESS_BUCKETS] {
    static TABLE: OnceLock<[u8; GUESS_BUCKETS]> = OnceLock::new();
    TABLE.get_or_init(|| {
        std::array::from_fn(|i| {
            let v = i as f32 / GUESS_BUCKETS as f32;
            (srgb_table().partition_point(|&d| d <= v) - 1) as u8
        })
    })
}

/// Linear `v` as an sRGB code: one of the two codes whose linear values bracket it, the upper
/// with the probability that makes the expected linear value `v` (`dither`, uniform in [0, 1),
/// decides). Rounding to the nearest code instead would bias a mipmap level: its texels are
/// means of a few neighbours, which on a smooth gradient fall at the same place between codes
/// texel after texel, and each level grew 0.5% brighter (or darker) than the one above.
#[inline]
fn encode_srgb(v: f32, dither: f32) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let bucket = ((v * GUESS_BUCKETS as f32) as usize).min(GUESS_BUCKETS - 1);
    let decoded = srgb_table();
    let mut code = srgb_floors()[bucket] as usize;
    while code < 255 && decoded[code + 1] <= v {
        code += 1;
    }
    if code == 255 {
        return 255;
    }
    let t = (v - decoded[code]) / (decoded[code + 1] - decoded[code]);
    code as u8 + (dither < t) as u8
}

/// Linear `v` as a linear 8-bit code, dithered as [`encode_srgb`] is.
#[inline]
fn encode_linear(v: f32, dither: f32) -> u8 {
    let x = v.clamp(0.0, 1.0) * 255.0;
    let below = x.floor();
    (below as u8).saturating_add((dither < x - below) as u8)
}

/// A uniform number in [0, 1) for channel `c` of texel (x, y) of a level `depth` down.
#[inline]
fn dither(x: usize, y: usize, c: usize, depth: usize) -> f32 {
    let h = hash32(x as u32 ^ hash32(y as u32 ^ hash32((c + 4 * depth) as u32)));
    (h >> 8) as f32 / (1u32 << 24) as f32
}

/// The sRGB transfer function, decoding.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The sRGB transfer function, encoding.
pub fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

impl Texture {
    /// The texture of `picture`, whose 8-bit values are in `color_space`.
    pub fn new(picture: Picture, color_space: ColorSpace) -> Self {
        let channels = picture.channels;
        let mut levels = vec![Level {
            width: picture.width,
            height: picture.height,
            texels: picture.texels,
        }];
        let mut texture = Self {
            levels: Vec::new(),
            channels,
            color_space,
        };
        while let Some(last) = levels.last()
            && (last.width > 1 || last.height > 1)
        {
            let next = texture.halve(last, levels.len());
            levels.push(next);
        }
        texture.levels = levels;
        texture
    }

    /// Bytes its texels take, every level.
    pub fn bytes(&self) -> u64 {
        self.levels
            .iter()
            .map(|l| match &l.texels {
                Texels::Bytes(v) => v.len() as u64,
                Texels::Floats(v) => 4 * v.len() as u64,
            })
            .sum()
    }

    /// Channels per texel: 1 grey, 2 grey and alpha, 3 RGB, 4 RGBA.
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// The full image's size.
    pub fn size(&self) -> (usize, usize) {
        (self.levels[0].width, self.levels[0].height)
    }

    /// Channel `c` of texel (x, y) of `level` as a linear value.
    #[inline]
    fn channel(&self, level: &Level, x: usize, y: usize, c: usize) -> f32 {
        let i = (y * level.width + x) * self.channels + c;
        match &level.texels {
            Texels::Floats(v) => v[i],
            Texels::Bytes(v) => {
                let alpha = c == 3 || (self.channels == 2 && c == 1);
                match self.color_space {
                    ColorSpace::Srgb if !alpha => srgb_table()[v[i] as usize],
                    _ => v[i] as f32 / 255.0,
                }
            }
        }
    }

    /// Texel (x, y) of `level` as linear RGBA (grey spread over RGB; alpha 1 where absent).
    #[inline]
    fn texel(&self, level: &Level, x: usize, y: usize) -> Vec4 {
        let c = |k| self.channel(level, x, y, k);
        match self.channels {
            1 => Vec4::new(c(0), c(0), c(0), 1.0),
            2 => Vec4::new(c(0), c(0), c(0), c(1)),
            3 => Vec4::new(c(0), c(1), c(2), 1.0),
            _ => Vec4::new(c(0), c(1), c(2), c(3)),
        }
    }

    /// The level below `level`: each texel the mean of (up to) four of its texels, in linear
    /// values, stored as `level` is (the new level lies `depth` below the image); rows in
    /// parallel.
    fn halve(&self, level: &Level, depth: usize) -> Level {
        let (w, h) = (
            level.width.div_ceil(2).max(1),
            level.height.div_ceil(2).max(1),
        );
        let n = self.channels;
        // Channel `c` of the mean of the (up to) four texels under texel (x, y) of the new level.
        let mean = |x: usize, y: usize, c: usize| {
            let (x0, x1) = (2 * x, (2 * x + 1).min(level.width - 1));
            let (y0, y1) = (2 * y, (2 * y + 1).min(level.height - 1));
            let at = |sx, sy| self.channel(level, sx, sy, c);
            0.25 * (at(x0, y0) + at(x1, y0) + at(x0, y1) + at(x1, y1))
        };
        let exact = matches!(level.texels, Texels::Floats(_)) || w * h < FLOAT_LEVELS_BELOW;
        let texels = match exact {
            true => {
                let mut out = vec![0.0f32; w * h * n];
                out.par_chunks_mut(w * n).enumerate().for_each(|(y, row)| {
                    for (i, v) in row.iter_mut().enumerate() {
                        *v = mean(i / n, y, i % n);
                    }
                });
                Texels::Floats(out)
            }
            false => {
                let mut out = vec![0u8; w * h * n];
                out.par_chunks_mut(w * n).enumerate().for_each(|(y, row)| {
                    for (i, v) in row.iter_mut().enumerate() {
                        let (x, c) = (i / n, i % n);
                        *v = self.encode(mean(x, y, c), c, dither(x, y, c, depth));
                    }
                });
                Texels::Bytes(out)
            }
        };
        Level {
            width: w,
            height: h,
            texels,
        }
    }

    /// Linear value `v` of channel `c` as this texture's 8-bit value: sRGB-encoded colour
    /// channels as sRGB codes ([`encode_srgb`]), alpha and data linearly, both dithered by
    /// `dither` so the level keeps its mean.
    #[inline]
    fn encode(&self, v: f32, c: usize, dither: f32) -> u8 {
        let alpha = c == 3 || (self.channels == 2 && c == 1);
        match self.color_space {
            ColorSpace::Srgb if !alpha => encode_srgb(v, dither),
            _ => encode_linear(v, dither),
        }
    }

    /// The texture at `uv` over a footprint `width` wide in UV units (0: the finest level),
    /// linear RGBA.
    pub fn lookup(&self, uv: Vec2, width: f32) -> Vec4 {
        let (w, h) = self.size();
        let texels = width * w.max(h) as f32;
        let last = (self.levels.len() - 1) as f32;
        let level = if texels > 1.0 {
            texels.log2().min(last)
        } else {
            0.0
        };
        let below = level.floor();
        let blend = level - below;
        let fine = self.bilinear(&self.levels[below as usize], uv);
        if blend <= 0.0 {
            return fine;
        }
        let coarse = self.bilinear(&self.levels[(below as usize + 1).min(last as usize)], uv);
        fine * (1.0 - blend) + coarse * blend
    }

    /// Bilinear between the four texel centres around `uv` in `level`, wrapping round.
    fn bilinear(&self, level: &Level, uv: Vec2) -> Vec4 {
        let (w, h) = (level.width, level.height);
        let x = uv.x * w as f32 - 0.5;
        let y = (1.0 - uv.y) * h as f32 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return self.texel(level, 0, 0);
        }
        let (fx, fy) = (x - x.floor(), y - y.floor());
        let wrap = |v: f32, n: usize| (v as i64).rem_euclid(n as i64) as usize;
        let (x0, y0) = (wrap(x.floor(), w), wrap(y.floor(), h));
        let (x1, y1) = ((x0 + 1) % w, (y0 + 1) % h);
        let top = self.texel(level, x0, y0) * (1.0 - fx) + self.texel(level, x1, y0) * fx;
        let bottom = self.texel(level, x0, y1) * (1.0 - fx) + self.texel(level, x1, y1) * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The dithered encodings pick one of the two codes around a value, in proportions whose
    /// mean is the value, over the whole range; and a smooth gradient keeps its mean through
    /// the mipmap levels.
    #[test]
    fn dithered_encoding_keeps_values_and_level_means() {
        let decoded: Vec<f32> = (0..256).map(|k| srgb_to_linear(k as f32 / 255.0)).collect();
        for i in 0..=2000 {
            let v = i as f32 / 2000.0;
            let (mut srgb, mut linear) = (0.0f64, 0.0f64);
            let n = 1000;
            for k in 0..n {
                let d = (k as f32 + 0.5) / n as f32;
                let code = encode_srgb(v, d) as usize;
                assert!(decoded[code.saturating_sub(1)] <= v && decoded[code.min(254) + 1] >= v);
                srgb += decoded[code] as f64;
                linear += encode_linear(v, d) as f64 / 255.0;
            }
            assert!(
                (srgb / n as f64 - v as f64).abs() < 2e-5,
                "{v}: sRGB mean {srgb}"
            );
            assert!(
                (linear / n as f64 - v as f64).abs() < 2e-5,
                "{v}: linear mean {linear}"
            );
        }
        assert_eq!((encode_srgb(-1.0, 0.5), encode_srgb(2.0, 0.5)), (0, 255));
        // A gradient under a coarse checker: each level's mean within 0.1% of the image's (nearest-
        // code rounding drifted 0.5% a level).
        let n = 128;
        let bytes: Vec<u8> = (0..n * n * 3)
            .map(|i| {
                let (x, y, c) = ((i / 3) % n, i / 3 / n, i % 3);
                let shade = if (x / 32 + y / 32) % 2 == 0 {
                    0.55
                } else {
                    1.0
                };
                let ramp = [0.2 + 0.7 * x as f32 / 127.0, 0.3 + 0.5 * y as f32 / 127.0][c.min(1)];
                (ramp * shade * 255.0).round() as u8
            })
            .collect();
        let picture = Picture {
            width: n,
            height: n,
            channels: 3,
            texels: Texels::Bytes(bytes),
        };
        let texture = Texture::new(picture, ColorSpace::Srgb);
        let mean = |level: &Level| {
            let mut sum = Vec4::ZERO;
            for y in 0..level.height {
                for x in 0..level.width {
                    sum += texture.texel(level, x, y);
                }
            }
            sum / (level.width * level.height) as f32
        };
        let full = mean(&texture.levels[0]);
        // Levels of 16 × 16 texels and more: smaller ones hold too few for their dither to
        // average out.
        for (k, level) in texture.levels.iter().enumerate().skip(1).take(3) {
            let m = mean(level);
            let off = ((m - full) / full).abs().max_element();
            assert!(off < 1e-3, "level {k}: mean {m} against {full}");
        }
    }

    fn checker(n: usize, color_space: ColorSpace) -> Texture {
        let texels = (0..n * n)
            .flat_map(|i| {
                let on = (i % n + i / n).is_multiple_of(2);
                [if on { 255 } else { 0 }; 3]
            })
            .collect();
        let picture = Picture {
            width: n,
            height: n,
            channels: 3,
            texels: Texels::Bytes(texels),
        };
        Texture::new(picture, color_space)
    }

    #[test]
    fn the_pyramid_halves_to_one_texel_holding_the_mean() {
        let t = checker(8, ColorSpace::Linear);
        assert_eq!(t.levels.len(), 4);
        assert_eq!((t.levels[3].width, t.levels[3].height), (1, 1));
        // A checker averages to half, in linear values; sRGB keeps that mean in linear too.
        let mean = t.lookup(Vec2::splat(0.3), 1.0);
        assert!((mean.x - 0.5).abs() < 2.0 / 255.0, "{mean}");
        let srgb = checker(8, ColorSpace::Srgb).lookup(Vec2::splat(0.3), 1.0);
        assert!((srgb.x - 0.5).abs() < 0.01, "{srgb}");
        // A non-square, odd-sized image still ends at one texel.
        let odd = Texture::new(
            Picture {
                width: 5,
                height: 3,
                channels: 1,
                texels: Texels::Floats(vec![1.0; 15]),
            },
            ColorSpace::Linear,
        );
        assert_eq!(odd.levels.last().map(|l| (l.width, l.height)), Some((1, 1)));
        assert_eq!(odd.lookup(Vec2::new(0.2, 0.7), 10.0), Vec4::ONE);
    }

    #[test]
    fn the_finest_level_is_bilinear_between_texel_centres_with_v_up() {
        // Two texels side by side, black then white; one row.
        let t = Texture::new(
            Picture {
                width: 2,
                height: 2,
                channels: 1,
                // Top row black-white, bottom row white-white.
                texels: Texels::Floats(vec![0.0, 1.0, 1.0, 1.0]),
            },
            ColorSpace::Linear,
        );
        // v near 1 is the top row; at the first texel's centre, black.
        assert!(t.lookup(Vec2::new(0.25, 0.75), 0.0).x.abs() < 1e-6);
        assert!((t.lookup(Vec2::new(0.5, 0.75), 0.0).x - 0.5).abs() < 1e-6);
        // v near 0 is the bottom row: white.
        assert!((t.lookup(Vec2::new(0.25, 0.25), 0.0).x - 1.0).abs() < 1e-6);
        // UVs wrap.
        assert_eq!(
            t.lookup(Vec2::new(1.25, 1.75), 0.0),
            t.lookup(Vec2::new(0.25, 0.75), 0.0)
        );
    }

    #[test]
    fn srgb_values_decode_and_encode_back() {
        for i in 0..=255u8 {
            let linear = srgb_table()[i as usize];
            let back = (linear_to_srgb(linear) * 255.0).round() as u8;
            assert_eq!(back, i);
        }
        assert!((srgb_to_linear(0.5) - 0.2140).abs() < 1e-4);
    }
}
