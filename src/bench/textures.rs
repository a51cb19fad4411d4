//! `rift bench textures`: what textures cost a scene. First the mipmap build, per megapixel
//! of the full image, for an 8-bit sRGB colour map, an 8-bit linear data map and a float map.
//! Then a scene of `--megabytes` of 8-bit RGB textures (procedural PNGs written to a temporary
//! folder, or to `--keep` for measuring `rift render` on it with farm-bench): its load time
//! (files read, decoded and mipmapped) and the process's peak memory over the load, against
//! the texels' own size.

use super::median;
use super::scaling::{reset_peak_memory, status_mib};
use anyhow::Context;
use clap::Args;
use rift_fx::Shot;
use rift_render::Scene;
use rift_render::sampling::hash32;
use rift_render::texture::image::{ColorSpace, Picture, Texels};
use rift_render::texture::mipmap::Texture;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `rift bench textures`.
#[derive(Args)]
pub struct TexturesArgs {
    /// Megabytes of 8-bit RGB texels the scene holds (before mipmaps).
    #[arg(long, default_value_t = 1024)]
    megabytes: u64,
    /// Side of each square texture, texels.
    #[arg(long, default_value_t = 8192)]
    size: usize,
    /// Keep the textures and the shot in this folder (else a temporary one).
    #[arg(long)]
    keep: Option<PathBuf>,
}

pub fn run(args: TexturesArgs) -> anyhow::Result<()> {
    let size = args.size.clamp(16, 16384);
    mipmap_table()?;
    let temporary = tempfile::tempdir()?;
    let dir = args.keep.as_deref().unwrap_or(temporary.path());
    std::fs::create_dir_all(dir)?;
    let per_texture = (size * size * 3) as u64;
    let count = (args.megabytes * 1_000_000).div_ceil(per_texture).max(1) as usize;
    println!(
        "\nscene of {count} textures of {size} x {size} 8-bit RGB ({:.0} MB of texels)",
        (count as u64 * per_texture) as f64 / 1e6
    );
    let t = Instant::now();
    let mut file_bytes = 0u64;
    for i in 0..count {
        file_bytes += write_png(&dir.join(format!("map{i}.png")), size, i as u32)?;
    }
    println!(
        "  written: {:.0} MB of PNG in {:.1} s",
        file_bytes as f64 / 1e6,
        t.elapsed().as_secs_f64()
    );
    let shot = dir.join("textures.toml");
    std::fs::write(&shot, shot_text(count))?;
    std::fs::write(
        dir.join("tile.obj"),
        "v -1 0 1\nv 1 0 1\nv 1 0 -1\nv -1 0 -1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
         f 1/1 2/2 3/3 4/4\n",
    )?;
    let peak_known = reset_peak_memory();
    let before = status_mib("VmRSS:").unwrap_or(0.0);
    let t = Instant::now();
    let shot = Shot::load(&shot)?;
    let scene = Scene::load(&shot, shot.frames.first)?;
    let seconds = t.elapsed().as_secs_f64();
    let texels = scene.textures.bytes() as f64 / 1e6;
    println!(
        "  load: {seconds:.2} s ({:.0} MB of texels a second); texels with mipmaps {texels:.0} MB",
        (count as u64 * per_texture) as f64 / 1e6 / seconds
    );
    match (peak_known, status_mib("VmHWM:")) {
        (true, Some(peak)) => println!(
            "  peak memory over the load: {:.0} MB above the {before:.0} MB before it \
             ({:.2}x the texels with their mipmaps)",
            (peak - before) * 1.048_576,
            (peak - before) * 1.048_576 / texels
        ),
        _ => println!("  peak memory: not measurable here"),
    }
    if let Some(keep) = &args.keep {
        println!(
            "  kept in {}: time the whole render with\n  farm-bench -- rift render {} --spp 1",
            keep.display(),
            keep.join("textures.toml").display()
        );
    }
    Ok(())
}

/// The mipmap build's time per megapixel of the full image, median of three, for each kind of
/// texture.
fn mipmap_table() -> anyhow::Result<()> {
    const SIDE: usize = 2048;
    println!("mipmap build ({SIDE} x {SIDE} RGB, median of 3)");
    println!("  {:<24} {:>12}", "texture", "ms per MP");
    let bytes: Vec<u8> = (0..SIDE * SIDE * 3).map(|i| texel(i, 0)).collect();
    let floats: Vec<f32> = bytes.iter().map(|&b| b as f32 / 255.0).collect();
    let kinds = [
        (
            "8-bit sRGB colour",
            Texels::Bytes(bytes.clone()),
            ColorSpace::Srgb,
        ),
        (
            "8-bit linear data",
            Texels::Bytes(bytes),
            ColorSpace::Linear,
        ),
        (
            "32-bit float (EXR)",
            Texels::Floats(floats),
            ColorSpace::Linear,
        ),
    ];
    for (name, texels, space) in kinds {
        let times: Vec<f64> = (0..3)
            .map(|_| {
                let picture = Picture {
                    width: SIDE,
                    height: SIDE,
                    channels: 3,
                    texels: texels.clone(),
                };
                let t = Instant::now();
                let texture = Texture::new(picture, space);
                let seconds = t.elapsed().as_secs_f64();
                std::hint::black_box(texture);
                seconds
            })
            .collect();
        let megapixels = (SIDE * SIDE) as f64 / 1e6;
        println!("  {name:<24} {:>12.1}", median(times) * 1e3 / megapixels);
    }
    Ok(())
}

/// Byte `i` of a procedural image (`seed`): a smooth gradient under hashed grain, so the PNG
/// neither compresses to nothing nor holds pure noise.
fn texel(i: usize, seed: u32) -> u8 {
    let grain = hash32(i as u32 ^ seed.wrapping_mul(0x9e37_79b9)) & 31;
    ((i / 3 % 4096) as u32 / 32 + grain) as u8
}

/// Writes a `size` × `size` RGB PNG of [`texel`]s, fast compression; returns its bytes.
fn write_png(path: &Path, size: usize, seed: u32) -> anyhow::Result<u64> {
    let file = std::fs::File::create(path).with_context(|| format!("{}", path.display()))?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), size as u32, size as u32);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_compression(png::Compression::Fast);
    let mut writer = encoder.write_header()?;
    let row = size * 3;
    let mut stream = writer.stream_writer()?;
    let mut line = vec![0u8; row];
    for y in 0..size {
        for (x, b) in line.iter_mut().enumerate() {
            *b = texel(y * row + x, seed);
        }
        std::io::Write::write_all(&mut stream, &line)?;
    }
    stream.finish()?;
    Ok(std::fs::metadata(path)?.len())
}

/// A shot of `count` textured floor tiles side by side under a sky.
fn shot_text(count: usize) -> String {
    let mut text = String::from(
        "[shot]\nname = \"textures\"\nfps = 24.0\nframes = [1, 1]\n\
         [camera]\nresolution = [64, 64]\nfov_degrees = 60.0\n\
         [camera.transform]\nposition = [0.0, 20.0, 0.1]\nlook_at = [0.0, 0.0, 0.0]\n\
         [render]\nmax_bounces = 2\n[environment]\nradiance = [1.0, 1.0, 1.0]\n",
    );
    for i in 0..count {
        let x = i as f32 * 2.2 - count as f32;
        text += &format!(
            "[[material]]\nname = \"m{i}\"\ntype = \"diffuse\"\n\
             reflectance = {{ texture = \"map{i}.png\" }}\n\
             [[object]]\nname = \"tile{i}\"\nmesh = \"tile.obj\"\nmaterial = \"m{i}\"\n\
             transform = {{ position = [{x}, 0.0, 0.0] }}\n"
        );
    }
    text
}
