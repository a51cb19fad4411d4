//! Checkpoints: a render's running per-pixel sums, saved so that a killed render continues
//! where it stopped and finishes with exactly the pixels of an uninterrupted one.
//!
//! A checkpoint is an EXR any viewer opens: the partial image (beauty, AOVs and the `spp`
//! channel, means over the samples taken so far) plus `state.*` channels holding every sum
//! bit for bit (f64 sums as two u32 halves, counts as u32), and a key naming the build, the
//! shot and the settings it belongs to, so a checkpoint of anything else is refused instead
//! of being mixed in.

use crate::error::RenderError;
use crate::frame::film::{ExrExtras, Image, Window};
use crate::frame::passes::{Pixel, Sums};
use crate::scene::light_groups::MAX_LIGHT_GROUPS;
use crate::texture::exr::{MAX_EXR_PIXELS, check_exr_size, threads_for};
use exr::meta::attribute::AttributeValue;
use exr::prelude::{AnyChannel, FlatSamples, Text};
use glam::{DVec3, Vec3};
use std::collections::BTreeMap;
use std::path::Path;

/// What a checkpoint belongs to; a render continues only from a checkpoint with its own key.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Key {
    /// The program: name, version and a hash of its executable (another build may compute
    /// other pixels).
    pub build: String,
    /// The shot's name.
    pub shot: String,
    /// A hash of the shot file's bytes (an edited shot renders other pixels).
    pub shot_hash: String,
    /// Everything else that decides the pixels, as `name=value` pairs in a fixed order:
    /// frame, eye, resolution, window, sample range, seed and the overrides.
    pub settings: Vec<(String, String)>,
}

impl Key {
    /// Why a checkpoint with this key cannot continue a render with the key `wanted`, or
    /// `None` when it can.
    pub fn refusal(&self, wanted: &Key) -> Option<String> {
        if self.shot != wanted.shot {
            return Some(format!(
                "it belongs to shot `{}`, not `{}`",
                self.shot, wanted.shot
            ));
        }
        if self.shot_hash != wanted.shot_hash {
            return Some(format!(
                "the shot file `{}` has changed since it was written",
                wanted.shot
            ));
        }
        let differences: Vec<String> = self
            .settings
            .iter()
            .zip(&wanted.settings)
            .filter(|(a, b)| a != b)
            .map(|((name, was), (_, now))| format!("{name} {was} (now {now})"))
            .collect();
        if !differences.is_empty() || self.settings.len() != wanted.settings.len() {
            return Some(format!(
                "it was written for other settings: {}",
                differences.join(", ")
            ));
        }
        if self.build != wanted.build {
            return Some(format!(
                "it was written by another build of rift ({}; this is {})",
                self.build, wanted.build
            ));
        }
        None
    }

    fn attributes(&self) -> Vec<(String, AttributeValue)> {
        let settings: Vec<String> = self
            .settings
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect();
        [
            ("rift/checkpoint/build", self.build.clone()),
            ("rift/checkpoint/shot", self.shot.clone()),
            ("rift/checkpoint/shotHash", self.shot_hash.clone()),
            ("rift/checkpoint/settings", settings.join(";")),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_owned(), AttributeValue::Text(Text::from(v.as_str()))))
        .collect()
    }

    fn from_attributes(text: &BTreeMap<String, String>) -> Result<Self, String> {
        let get = |key: &str| {
            text.get(key)
                .cloned()
                .ok_or_else(|| format!("no `{key}` header: not a checkpoint rift wrote"))
        };
        let settings = get("rift/checkpoint/settings")?
            .split(';')
            .filter(|s| !s.is_empty())
            .map(|pair| {
                let (k, v) = pair.split_once('=').unwrap_or((pair, ""));
                (k.to_owned(), v.to_owned())
            })
            .collect();
        Ok(Self {
            build: get("rift/checkpoint/build")?,
            shot: get("rift/checkpoint/shot")?,
            shot_hash: get("rift/checkpoint/shotHash")?,
            settings,
        })
    }
}

/// A render's state: its key, the pixels it covers and their running sums (row-major).
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpoint {
    pub key: Key,
    pub window: Window,
    pub sums: Sums,
}

/// Bytes a checkpoint of `pixels` pixels takes while it is written, beside the render's own
/// film: the copied sums, the partial image, and its 5 image channels and 27 state channels as
/// the EXR writer holds them (copied once more by the encoder).
pub fn checkpoint_bytes(pixels: usize) -> u64 {
    const CHANNELS: usize = 5 + 27 + 6 * MAX_LIGHT_GROUPS;
    let partial_image = 4 * std::mem::size_of::<Vec3>() + 4 * std::mem::size_of::<f32>();
    let per_pixel = std::mem::size_of::<Pixel>() + partial_image + 2 * 4 * CHANNELS;
    (pixels as u64).saturating_mul(per_pixel as u64)
}

impl Checkpoint {
    /// Samples taken so far over all pixels, from each pixel's first sample index `first`.
    pub fn samples_taken(&self, first: u32) -> u64 {
        self.sums
            .pixels
            .iter()
            .map(|p| p.samples.saturating_sub(first) as u64)
            .sum()
    }

    /// Writes the checkpoint with `image` (the partial image of the same sums: its beauty,
    /// alpha and sample counts) atomically. Uncompressed, on the calling thread: the render
    /// goes on meanwhile, and compressing a frame's sums costs it more than writing them.
    pub fn write(&self, image: &Image, path: &Path) -> Result<(), RenderError> {
        let extras = ExrExtras {
            channels: self.state_channels(),
            attributes: self.key.attributes(),
            only: Some(&["R", "G", "B", "A", "spp"]),
            fast: true,
        };
        image.write_exr_with(path, extras)
    }

    /// Reads a checkpoint `write` made; anything else is refused with the reason.
    pub fn read(path: &Path) -> Result<Self, RenderError> {
        let bytes = rift_fx::io::read(path).map_err(|e| RenderError::Image {
            path: path.to_owned(),
            message: e.to_string(),
        })?;
        Self::decode(&bytes, MAX_EXR_PIXELS).map_err(|message| RenderError::Image {
            path: path.to_owned(),
            message,
        })
    }

    /// The key and pixel window of the checkpoint at `path`, from its header alone: enough to
    /// refuse another render's checkpoint before anything is prepared or the sums are read.
    pub fn read_key(path: &Path) -> Result<(Key, Window), RenderError> {
        let error = |message: String| RenderError::Image {
            path: path.to_owned(),
            message,
        };
        // A directory, device or FIFO in its place gets an error, not a read that never ends.
        rift_fx::io::regular_file(path).map_err(|e| error(e.to_string()))?;
        let meta =
            exr::meta::MetaData::read_from_file(path, false).map_err(|e| error(e.to_string()))?;
        let header = meta
            .headers
            .first()
            .ok_or_else(|| error("it has no layer".into()))?;
        key_and_window(&header.own_attributes, header.layer_size).map_err(error)
    }

    /// A checkpoint from EXR bytes of at most `max_pixels` (the reader the fuzz target drives).
    pub fn decode(bytes: &[u8], max_pixels: usize) -> Result<Self, String> {
        use exr::prelude::*;
        check_exr_size(bytes, max_pixels)?;
        let reader = read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes();
        let reader = threads_for(reader, bytes.len());
        let image = reader
            .from_buffered(std::io::Cursor::new(bytes))
            .map_err(|e| e.to_string())?;
        let layer = &image.layer_data;
        let (key, window) = key_and_window(&layer.attributes, layer.size)?;
        let channels: BTreeMap<String, &FlatSamples> = layer
            .channel_data
            .list
            .iter()
            .map(|c| (c.name.to_string(), &c.sample_data))
            .collect();
        let state = StateChannels::read(&channels, window.area())?;
        let sums = Sums {
            pixels: state.pixels(),
            groups: state.groups()?,
            ids: Vec::new(),
        };
        Ok(Self { key, window, sums })
    }

    fn state_channels(&self) -> Vec<AnyChannel<FlatSamples>> {
        let p = &self.sums.pixels;
        let mut out = Vec::new();
        let n = self.sums.group_count();
        for g in 0..n {
            for (k, c) in RGB.iter().enumerate() {
                let values: Vec<f64> = (0..p.len())
                    .map(|i| self.sums.groups[i * n + g][k])
                    .collect();
                out.extend(wide_channels(&format!("group{g}{c}"), &values));
            }
        }
        let mut wide = |name: &str, value: &dyn Fn(&Pixel) -> f64| {
            let values: Vec<f64> = p.iter().map(value).collect();
            out.extend(wide_channels(name, &values));
        };
        for (k, c) in RGB.iter().enumerate() {
            wide(&format!("sum{c}"), &|px| px.sum[k]);
            wide(&format!("through{c}"), &|px| px.through[k]);
            wide(&format!("emitted{c}"), &|px| px.emitted[k]);
        }
        wide("lumSq", &|px| px.lum_sq);
        wide("depth", &|px| px.depth);
        for (k, c) in RGB.iter().enumerate() {
            let albedo = p.iter().map(|px| px.albedo[k]).collect();
            let normal = p.iter().map(|px| px.normal[k]).collect();
            out.push(AnyChannel::new(
                format!("state.albedo{c}").as_str(),
                FlatSamples::F32(albedo),
            ));
            out.push(AnyChannel::new(
                format!("state.normal{c}").as_str(),
                FlatSamples::F32(normal),
            ));
        }
        for (name, value) in COUNTS {
            let values = p.iter().map(value).collect();
            out.push(AnyChannel::new(name, FlatSamples::U32(values)));
        }
        out
    }
}

const RGB: [&str; 3] = ["R", "G", "B"];

/// `state.<name>.hi` and `.lo`: each f64 of `values` as its two 32-bit halves.
fn wide_channels(name: &str, values: &[f64]) -> [AnyChannel<FlatSamples>; 2] {
    let bits: Vec<u64> = values.iter().map(|v| v.to_bits()).collect();
    let hi = bits.iter().map(|b| (b >> 32) as u32).collect();
    let lo = bits.iter().map(|&b| b as u32).collect();
    [
        AnyChannel::new(format!("state.{name}.hi").as_str(), FlatSamples::U32(hi)),
        AnyChannel::new(format!("state.{name}.lo").as_str(), FlatSamples::U32(lo)),
    ]
}

/// Reads one count of a pixel.
type Count = fn(&Pixel) -> u32;

/// The counting channels and the field each holds.
const COUNTS: [(&str, Count); 5] = [
    ("state.hits", |p| p.hits),
    ("state.portalDepth", |p| p.portal_depth),
    ("state.samples", |p| p.samples),
    ("state.discarded", |p| p.discarded),
    ("state.converged", |p| p.converged as u32),
];

/// The `state.*` channels of a checkpoint, found and checked.
struct StateChannels<'a> {
    channels: &'a BTreeMap<String, &'a FlatSamples>,
    len: usize,
}

impl<'a> StateChannels<'a> {
    fn read(channels: &'a BTreeMap<String, &'a FlatSamples>, len: usize) -> Result<Self, String> {
        let state = Self { channels, len };
        // Every channel is looked up once here, so `pixels` cannot fail.
        for c in RGB {
            state.wide(&format!("sum{c}"))?;
            state.wide(&format!("through{c}"))?;
            state.wide(&format!("emitted{c}"))?;
            state.floats(&format!("state.albedo{c}"))?;
            state.floats(&format!("state.normal{c}"))?;
        }
        state.wide("lumSq")?;
        state.wide("depth")?;
        for (name, _) in COUNTS {
            state.words(name)?;
        }
        Ok(state)
    }

    fn words(&self, name: &str) -> Result<&'a [u32], String> {
        match self.channels.get(name) {
            Some(FlatSamples::U32(v)) if v.len() == self.len => Ok(v),
            Some(_) => Err(format!("channel `{name}` is not {} u32 values", self.len)),
            None => Err(format!(
                "no `{name}` channel: not a checkpoint rift wrote (an image is not a checkpoint)"
            )),
        }
    }

    fn floats(&self, name: &str) -> Result<&'a [f32], String> {
        match self.channels.get(name) {
            Some(FlatSamples::F32(v)) if v.len() == self.len => Ok(v),
            Some(_) => Err(format!("channel `{name}` is not {} f32 values", self.len)),
            None => Err(format!("no `{name}` channel: not a checkpoint rift wrote")),
        }
    }

    fn wide(&self, name: &str) -> Result<Vec<f64>, String> {
        let hi = self.words(&format!("state.{name}.hi"))?;
        let lo = self.words(&format!("state.{name}.lo"))?;
        Ok(hi
            .iter()
            .zip(lo)
            .map(|(&h, &l)| f64::from_bits((h as u64) << 32 | l as u64))
            .collect())
    }

    /// The light-group sums, pixel after pixel: `state.group<g><C>` for g = 0, 1, … while
    /// present.
    fn groups(&self) -> Result<Vec<DVec3>, String> {
        let mut groups: Vec<[Vec<f64>; 3]> = Vec::new();
        while self
            .channels
            .contains_key(&format!("state.group{}R.hi", groups.len()))
        {
            let g = groups.len();
            if g == MAX_LIGHT_GROUPS {
                return Err(format!("more than {MAX_LIGHT_GROUPS} light groups"));
            }
            let [r, gr, b] = RGB.map(|c| self.wide(&format!("group{g}{c}")));
            groups.push([r?, gr?, b?]);
        }
        let n = groups.len();
        Ok((0..self.len * n)
            .map(|k| {
                let (i, g) = (k / n, k % n);
                DVec3::new(groups[g][0][i], groups[g][1][i], groups[g][2][i])
            })
            .collect())
    }

    fn pixels(&self) -> Vec<Pixel> {
        let wide = |name: &str| self.wide(name).unwrap_or_default();
        let floats = |name: &str| self.floats(name).unwrap_or_default();
        let words = |name: &str| self.words(name).unwrap_or_default();
        let dvec3 = |prefix: &str| {
            let [r, g, b] = RGB.map(|c| wide(&format!("{prefix}{c}")));
            move |i: usize| DVec3::new(r[i], g[i], b[i])
        };
        let vec3 = |prefix: &str| {
            let [r, g, b] = RGB.map(|c| floats(&format!("state.{prefix}{c}")));
            move |i: usize| Vec3::new(r[i], g[i], b[i])
        };
        let (sum, through, emitted, albedo, normal) = (
            dvec3("sum"),
            dvec3("through"),
            dvec3("emitted"),
            vec3("albedo"),
            vec3("normal"),
        );
        let (lum_sq, depth) = (wide("lumSq"), wide("depth"));
        let [hits, portal_depth, samples, discarded, converged] =
            COUNTS.map(|(name, _)| words(name));
        (0..self.len)
            .map(|i| Pixel {
                sum: sum(i),
                through: through(i),
                emitted: emitted(i),
                lum_sq: lum_sq[i],
                hits: hits[i],
                albedo: albedo(i),
                normal: normal(i),
                depth: depth[i],
                portal_depth: portal_depth[i],
                samples: samples[i],
                discarded: discarded[i],
                converged: converged[i] != 0,
            })
            .collect()
    }
}

/// A checkpoint layer's key (its text attributes) and the pixels it covers (its data window).
fn key_and_window(
    attributes: &exr::meta::header::LayerAttributes,
    size: exr::math::Vec2<usize>,
) -> Result<(Key, Window), String> {
    let text: BTreeMap<String, String> = attributes
        .other
        .iter()
        .filter_map(|(k, v)| match v {
            AttributeValue::Text(t) => Some((k.to_string(), t.to_string())),
            _ => None,
        })
        .collect();
    let key = Key::from_attributes(&text)?;
    let (x0, y0) = (attributes.layer_position.x(), attributes.layer_position.y());
    if x0 < 0 || y0 < 0 {
        return Err("its data window starts outside the frame".into());
    }
    let window = Window {
        x0: x0 as usize,
        x1: x0 as usize + size.width(),
        y0: y0 as usize,
        y1: y0 as usize + size.height(),
    };
    Ok((key, window))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key() -> Key {
        Key {
            build: "rift 0.1.0 00ff".into(),
            shot: "room".into(),
            shot_hash: "1234".into(),
            settings: vec![
                ("frame".into(), "1".into()),
                ("res".into(), "8x4".into()),
                ("seed".into(), "7".into()),
            ],
        }
    }

    #[test]
    fn a_key_refuses_every_other_key_and_names_the_difference() {
        let k = key();
        assert_eq!(k.refusal(&k), None);
        let mut other = key();
        other.shot = "hall".into();
        assert!(other.refusal(&k).unwrap().contains("shot `hall`"));
        let mut other = key();
        other.shot_hash = "99".into();
        assert!(other.refusal(&k).unwrap().contains("changed"));
        let mut other = key();
        other.settings[1].1 = "16x8".into();
        other.settings[2].1 = "3".into();
        let why = other.refusal(&k).unwrap();
        assert!(
            why.contains("res 16x8 (now 8x4)") && why.contains("seed 3 (now 7)"),
            "{why}"
        );
        let mut other = key();
        other.build = "rift 0.1.0 abcd".into();
        assert!(other.refusal(&k).unwrap().contains("another build"));
    }
}
