//! Cryptomatte object IDs, as Nuke, Blender and other compositors read them: each object's
//! name hashed (MurmurHash3, 32 bits, seed 0) into a float ID, and per pixel the IDs its camera
//! samples saw first (after any teleports), ranked by coverage, as `CryptoObject00`… layers of
//! (ID, coverage) pairs with the `cryptomatte/<key>/…` header and a manifest of names.
//!
//! A pixel keeps counts for up to [`SLOTS`] IDs; samples of further IDs (rare: more than
//! eight objects in one pixel) count towards the pixel's samples but no ID. [`RANKS`] IDs are
//! written, the most covering first.

use std::collections::BTreeMap;

/// IDs counted per pixel.
pub const SLOTS: usize = 8;
/// IDs written per pixel (two per RGBA layer).
pub const RANKS: usize = 6;
/// The layer's name; its key is the first seven hex digits of its hash.
const LAYER: &str = "CryptoObject";
/// No object (the sky, a medium, an opening at the depth limit).
pub const NONE: u32 = crate::scene::NO_OBJECT;

/// MurmurHash3, x86, 32 bits.
pub fn murmur3_32(bytes: &[u8], seed: u32) -> u32 {
    const C1: u32 = 0xcc9e_2d51;
    const C2: u32 = 0x1b87_3593;
    let mut h = seed;
    let mut blocks = bytes.chunks_exact(4);
    for block in &mut blocks {
        let mut k = u32::from_le_bytes([block[0], block[1], block[2], block[3]]);
        k = k.wrapping_mul(C1).rotate_left(15).wrapping_mul(C2);
        h = (h ^ k)
            .rotate_left(13)
            .wrapping_mul(5)
            .wrapping_add(0xe654_6b64);
    }
    let tail = blocks.remainder();
    if !tail.is_empty() {
        let mut k = 0u32;
        for (i, &b) in tail.iter().enumerate() {
            k |= (b as u32) << (8 * i);
        }
        h ^= k.wrapping_mul(C1).rotate_left(15).wrapping_mul(C2);
    }
    h ^= bytes.len() as u32;
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^ (h >> 16)
}

/// The float ID of `name`: its hash with the exponent kept off 0 and 255, so the ID is never
/// denormal, infinite or NaN.
pub fn id(name: &str) -> f32 {
    let h = murmur3_32(name.as_bytes(), 0);
    let exponent = ((h >> 23) & 0xff).clamp(1, 254);
    f32::from_bits((h & 0x807f_ffff) | exponent << 23)
}

/// One pixel's counts of samples per ID.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Counts {
    ids: [u32; SLOTS],
    counts: [u32; SLOTS],
}

impl Default for Counts {
    fn default() -> Self {
        Self {
            ids: [NONE; SLOTS],
            counts: [0; SLOTS],
        }
    }
}

impl Counts {
    /// Counts one sample that saw `object` (an index into the manifest's names).
    pub fn add(&mut self, object: u32) {
        if object == NONE {
            return;
        }
        for k in 0..SLOTS {
            if self.ids[k] == object {
                self.counts[k] += 1;
                return;
            }
            if self.ids[k] == NONE {
                self.ids[k] = object;
                self.counts[k] = 1;
                return;
            }
        }
    }

    /// The [`RANKS`] most covering (object, coverage) pairs over `samples` samples, most first
    /// (ties by object), padded with (NONE, 0).
    pub fn ranked(&self, samples: u32) -> [(u32, f32); RANKS] {
        let mut pairs: Vec<(u32, u32)> = self
            .ids
            .iter()
            .zip(&self.counts)
            .filter(|(id, _)| **id != NONE)
            .map(|(&id, &n)| (id, n))
            .collect();
        pairs.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
        let mut out = [(NONE, 0.0); RANKS];
        for (slot, (id, n)) in out.iter_mut().zip(pairs) {
            *slot = (id, n as f32 / samples.max(1) as f32);
        }
        out
    }
}

/// A frame's Cryptomatte: the names IDs index, and per pixel the ranked (object, coverage).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cryptomatte {
    pub names: Vec<String>,
    pub pixels: Vec<[(u32, f32); RANKS]>,
}

impl Cryptomatte {
    /// The RGBA channels: `CryptoObject00.R` = first ID, `.G` its coverage, `.B`/`.A` the
    /// second, and so on.
    pub fn channels(&self) -> Vec<(String, Vec<f32>)> {
        let ids: Vec<f32> = self.names.iter().map(|n| id(n)).collect();
        let mut out = Vec::new();
        for layer in 0..RANKS / 2 {
            for (c, suffix) in ["R", "G", "B", "A"].iter().enumerate() {
                let rank = 2 * layer + c / 2;
                let values = self
                    .pixels
                    .iter()
                    .map(|p| {
                        let (object, coverage) = p[rank];
                        match (c % 2, object) {
                            (1, _) => coverage,
                            (_, NONE) => 0.0,
                            (_, o) => ids[o as usize],
                        }
                    })
                    .collect();
                out.push((format!("{LAYER}{layer:02}.{suffix}"), values));
            }
        }
        out
    }

    /// The header attributes: the layer's name, hash, conversion and manifest (name → the ID's
    /// bits as eight hex digits, for the objects some pixel shows: a scatter of a million
    /// instances, each with an ID of its own, would otherwise put them all in the header),
    /// under `cryptomatte/<key>/`.
    pub fn attributes(&self) -> Vec<(String, String)> {
        let key = format!("{:08x}", murmur3_32(LAYER.as_bytes(), 0));
        let prefix = format!("cryptomatte/{}/", &key[..7]);
        let mut shown = vec![false; self.names.len()];
        for &(object, _) in self.pixels.iter().flatten() {
            if let Some(seen) = shown.get_mut(object as usize) {
                *seen = true;
            }
        }
        let manifest: BTreeMap<&str, String> = (self.names.iter().zip(shown))
            .filter(|(_, shown)| *shown)
            .map(|(n, _)| (n.as_str(), format!("{:08x}", id(n).to_bits())))
            .collect();
        let entries: Vec<String> = manifest
            .iter()
            .map(|(name, hex)| format!("{}:\"{hex}\"", json_string(name)))
            .collect();
        vec![
            (format!("{prefix}name"), LAYER.to_owned()),
            (format!("{prefix}hash"), "MurmurHash3_32".to_owned()),
            (
                format!("{prefix}conversion"),
                "uint32_to_float32".to_owned(),
            ),
            (
                format!("{prefix}manifest"),
                format!("{{{}}}", entries.join(",")),
            ),
        ]
    }
}

/// `s` as a JSON string literal.
fn json_string(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 => out.push_str(&format!("\\u{:04x}", c as u32)),
            c => out.push(c),
        }
    }
    out + "\""
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn murmur3_matches_its_published_values() {
        assert_eq!(murmur3_32(b"", 0), 0);
        assert_eq!(murmur3_32(b"", 1), 0x514e_28b7);
        assert_eq!(murmur3_32(b"hello", 0), 0x248b_fa47);
        assert_eq!(
            murmur3_32(b"The quick brown fox jumps over the lazy dog", 0),
            0x2e4f_f723
        );
    }

    #[test]
    fn ids_are_normal_floats_and_the_manifest_names_them() {
        for name in ["", "a", "wall", "gallery/ring", "\"quoted\""] {
            assert!(id(name).is_normal(), "{name}");
        }
        let c = Cryptomatte {
            names: vec!["wall".into(), "say \"hi\"".into()],
            pixels: vec![[
                (1, 0.75),
                (0, 0.25),
                (NONE, 0.0),
                (NONE, 0.0),
                (NONE, 0.0),
                (NONE, 0.0),
            ]],
        };
        let attributes = c.attributes();
        let manifest = &attributes[3].1;
        assert!(manifest.contains(&format!("\"wall\":\"{:08x}\"", id("wall").to_bits())));
        assert!(manifest.contains("\"say \\\"hi\\\"\""), "{manifest}");
        let channels = c.channels();
        assert_eq!(channels[0].0, "CryptoObject00.R");
        assert_eq!(channels[0].1, vec![id("say \"hi\"")]);
        assert_eq!(channels[1].1, vec![0.75]);
        assert_eq!(channels[2].1, vec![id("wall")]);
        assert_eq!(channels[4].0, "CryptoObject01.R");
        assert_eq!(channels[4].1, vec![0.0]);
    }

    #[test]
    fn counts_rank_by_coverage() {
        let mut c = Counts::default();
        for object in [3, 1, 3, NONE, 3, 1, 2] {
            c.add(object);
        }
        let ranked = c.ranked(7);
        assert_eq!(ranked[0], (3, 3.0 / 7.0));
        assert_eq!(ranked[1], (1, 2.0 / 7.0));
        assert_eq!(ranked[2], (2, 1.0 / 7.0));
        assert_eq!(ranked[3], (NONE, 0.0));
    }
}
