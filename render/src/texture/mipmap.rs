//! A texture as the renderer looks it up: the image and its mipmap pyramid (each level a 2×2
//! box filter of the one above, averaged in linear values), built once and shared by every
//! material that uses it. A lookup takes the level whose texels match the ray's footprint,
//! bilinear within a level and linear between the two nearest levels, as pbrt does; UVs wrap,
//! and v = 0 is the image's bottom row (OBJ and USD's convention).

use super::image::{ColorSpace, Picture, Texels};
use glam::{Vec2, Vec4};
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
    /// values, stored as `level` is.
    fn halve(&self, level: &Level) -> Level {
        let (w, h) = (
            level.width.div_ceil(2).max(1),
            level.height.div_ceil(2).max(1),
        );
        let mut means = Vec::with_capacity(w * h);
        for y in 0..h {
            for x in 0..w {
                let mut sum = Vec4::ZERO;
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let sx = (2 * x + dx).min(level.width - 1);
                    let sy = (2 * y + dy).min(level.height - 1);
                    sum += self.texel(level, sx, sy);
                }
                means.push(sum * 0.25);
            }
        }
        let texels = match &level.texels {
            Texels::Floats(_) => Texels::Floats(
                means
                    .iter()
                    .flat_map(|m| m.to_array()[..self.channels].to_vec())
                    .collect(),
            ),
            Texels::Bytes(_) => Texels::Bytes(means.iter().flat_map(|m| self.encode(*m)).collect()),
        };
        Level {
            width: w,
            height: h,
            texels,
        }
    }

    /// Linear RGBA `m` as this texture's 8-bit channels.
    fn encode(&self, m: Vec4) -> Vec<u8> {
        let byte = |v: f32, alpha: bool| {
            let e = match self.color_space {
                ColorSpace::Srgb if !alpha => linear_to_srgb(v),
                _ => v,
            };
            (e.clamp(0.0, 1.0) * 255.0).round() as u8
        };
        match self.channels {
            1 => vec![byte(m.x, false)],
            2 => vec![byte(m.x, false), byte(m.w, true)],
            3 => vec![byte(m.x, false), byte(m.y, false), byte(m.z, false)],
            _ => vec![
                byte(m.x, false),
                byte(m.y, false),
                byte(m.z, false),
                byte(m.w, true),
            ],
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
