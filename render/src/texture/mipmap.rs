//! A texture as the renderer looks it up: the image and its mipmap pyramid (each level a 2×2
//! box filter of the one above, averaged in linear values), built once and shared by every
//! material that uses it. A lookup takes the level whose texels match the ray's footprint,
//! bilinear within a level and linear between the two nearest levels, as pbrt does; UVs wrap,
//! and v = 0 is the image's bottom row (OBJ and USD's convention).

use super::image::{ColorSpace, Picture, Texels};
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

/// The linear values halfway (in the encoding) between consecutive sRGB codes: code k + 1
/// begins at midpoint k.
fn srgb_midpoints() -> &'static [f32; 255] {
    static TABLE: OnceLock<[f32; 255]> = OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|k| srgb_to_linear((k as f32 + 0.5) / 255.0)))
}

/// Buckets of the linear range in [`srgb_guesses`].
const GUESS_BUCKETS: usize = 4096;

/// The sRGB code at the bottom of each of [`GUESS_BUCKETS`] equal steps of the linear range:
/// where [`encode_srgb`] starts looking.
fn srgb_guesses() -> &'static [u8; GUESS_BUCKETS] {
    static TABLE: OnceLock<[u8; GUESS_BUCKETS]> = OnceLock::new();
    TABLE.get_or_init(|| {
        std::array::from_fn(|i| {
            let v = i as f32 / GUESS_BUCKETS as f32;
            srgb_midpoints().partition_point(|&m| m <= v) as u8
        })
    })
}

/// The sRGB code nearest (in the encoding) to linear `v`: the first code whose upper midpoint
/// lies above `v`, walked to from the bucket's guess (a step or two at most).
#[inline]
fn encode_srgb(v: f32) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let bucket = ((v * GUESS_BUCKETS as f32) as usize).min(GUESS_BUCKETS - 1);
    let midpoints = srgb_midpoints();
    let mut code = srgb_guesses()[bucket] as usize;
    while code < 255 && midpoints[code] <= v {
        code += 1;
    }
    code as u8
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
            let next = texture.halve(last);
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
    /// values, stored as `level` is; rows in parallel.
    fn halve(&self, level: &Level) -> Level {
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
        let texels = match &level.texels {
            Texels::Floats(_) => {
                let mut out = vec![0.0f32; w * h * n];
                out.par_chunks_mut(w * n).enumerate().for_each(|(y, row)| {
                    for (i, v) in row.iter_mut().enumerate() {
                        *v = mean(i / n, y, i % n);
                    }
                });
                Texels::Floats(out)
            }
            Texels::Bytes(_) => {
                let mut out = vec![0u8; w * h * n];
                out.par_chunks_mut(w * n).enumerate().for_each(|(y, row)| {
                    for (i, v) in row.iter_mut().enumerate() {
                        *v = self.encode(mean(i / n, y, i % n), i % n);
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
    /// channels by the nearest of the 256 codes (found among the codes' midpoints, which gives
    /// what rounding the encoded value gives, without its power), alpha and data linearly.
    #[inline]
    fn encode(&self, v: f32, c: usize) -> u8 {
        let alpha = c == 3 || (self.channels == 2 && c == 1);
        match self.color_space {
            ColorSpace::Srgb if !alpha => encode_srgb(v),
            _ => (v.clamp(0.0, 1.0) * 255.0).round() as u8,
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

    /// The table-guided sRGB encoding gives what rounding the encoded value gives, over the
    /// whole range and at every code's boundaries.
    #[test]
    fn srgb_encoding_rounds_as_the_transfer_function_does() {
        let exact = |v: f32| (linear_to_srgb(v.clamp(0.0, 1.0)) * 255.0).round() as u8;
        for i in 0..=200_000 {
            let v = i as f32 / 200_000.0;
            let (got, want) = (encode_srgb(v), exact(v));
            assert!(got.abs_diff(want) <= 1, "{v}: {got} against {want}");
        }
        for (k, &m) in srgb_midpoints().iter().enumerate() {
            assert_eq!(encode_srgb(m * 0.9999) as usize, k, "below midpoint {k}");
            assert_eq!(
                encode_srgb(m * 1.0001) as usize,
                k + 1,
                "above midpoint {k}"
            );
        }
        assert_eq!((encode_srgb(-1.0), encode_srgb(2.0)), (0, 255));
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
