//! Images read as textures: PNG, JPEG and EXR files decoded within bounds ([`image`]), their
//! mipmaps and footprint-filtered lookups ([`mipmap`]), each file read once for every
//! material that uses it ([`Textures`]); and the EXR reading every part of the renderer shares
//! ([`exr`]).

pub mod exr;
pub mod image;
pub mod mipmap;

pub use exr::{MAX_EXR_PIXELS, decode_exr_rgb, read_exr_rgb};
pub use image::ColorSpace;
pub use mipmap::Texture;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The scene's textures, each file (in each colour space) read once.
#[derive(Clone, Debug, Default)]
pub struct Textures {
    list: Vec<Texture>,
    index: HashMap<(PathBuf, ColorSpace), u32>,
    /// Bytes they take, mipmaps included.
    bytes: u64,
}

impl Textures {
    /// The index of the texture of the file at `path` read in `color_space`, reading it the
    /// first time within `budget` bytes (`None`: no limit beyond the texel count's); the error
    /// says what is wrong with the file.
    pub fn load(
        &mut self,
        path: &Path,
        color_space: ColorSpace,
        budget: Option<u64>,
    ) -> Result<u32, String> {
        let key = (path.to_owned(), color_space);
        if let Some(&i) = self.index.get(&key) {
            return Ok(i);
        }
        let left = budget.map_or(u64::MAX, |b| b.saturating_sub(self.bytes));
        let bytes = read_file(path, left).map_err(|e| format!("cannot read: {e}"))?;
        let picture = image::decode(&bytes, left)?;
        let texture = Texture::new(picture, color_space);
        self.bytes += texture.bytes();
        self.list.push(texture);
        let i = self.list.len() as u32 - 1;
        self.index.insert(key, i);
        Ok(i)
    }

    /// True when the scene has any texture (paths then track their footprints).
    #[inline]
    pub fn has_any(&self) -> bool {
        !self.list.is_empty()
    }

    /// The textures, by index.
    pub fn list(&self) -> &[Texture] {
        &self.list
    }

    /// Bytes they take, mipmaps included.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }
}

/// The bytes of the image at `path`: a file, or one packed in a USDZ package, named as USD
/// names it (`/set/room.usdz[textures/wood.png]`); a packed one larger than `budget` bytes is
/// refused before it is read.
fn read_file(path: &Path, budget: u64) -> std::io::Result<Vec<u8>> {
    let text = path.to_string_lossy();
    let packed = text.ends_with(']') && text.contains(".usdz[");
    if !packed {
        return rift_fx::io::read(path);
    }
    use openusd::ar::{Asset, DefaultResolver, ResolvedPath, Resolver};
    let package = &text[..text.find(".usdz[").map_or(0, |i| i + 5)];
    rift_fx::io::regular_file(Path::new(package))?;
    let mut asset: Box<dyn Asset> =
        DefaultResolver::new().open_asset(&ResolvedPath::new(path.to_owned()))?;
    if asset.size()? > budget.min(rift_fx::io::MAX_INPUT_BYTES) {
        return Err(std::io::Error::other(format!(
            "it holds {} MiB, more than the {} MiB left for textures",
            asset.size()? >> 20,
            budget >> 20
        )));
    }
    asset.read_all()
}
