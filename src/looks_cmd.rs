//! `rift looks`: the ring look presets, listed, and drawn as a contact sheet: one row per
//! preset, one column per moment (half a second apart), each ring seen face-on with its baked
//! colour, intensity and width and blurred along its baked motion over the shutter.

use anyhow::{Context, bail};
use clap::Args;
use glam::{Vec2, Vec3};
use rift_fx::Shot;
use rift_fx::ring::presets::{self, NAMES};
use rift_fx::ring::{RingCurves, RingGenerator};
use std::path::{Path, PathBuf};

/// Arguments of `rift looks`.
#[derive(Args)]
pub struct LooksArgs {
    /// Draw the presets over a few moments into this PNG.
    #[arg(long, value_name = "PNG")]
    contact_sheet: Option<PathBuf>,
    /// Moments per preset (columns), half a second apart.
    #[arg(long, default_value_t = 4, value_name = "N")]
    moments: u32,
    /// Size of each picture in pixels.
    #[arg(long, default_value_t = 256, value_name = "PX")]
    size: u32,
}

/// Frames per second of the sheet's shots, and frames between columns.
const FPS: f64 = 24.0;
const STEP: i64 = 12;

pub fn run(args: LooksArgs) -> anyhow::Result<()> {
    for name in NAMES {
        let look = presets::preset(name, 1.0).context("a named preset")?;
        let unstable = match &look.instability {
            Some(i) => format!(
                "separation {} bands, flares {} radii at {} Hz",
                i.separation, i.flare, i.rate
            ),
            None => "steady".into(),
        };
        println!(
            "{name:<10} {} strands, band {:.2} R, noise {:.3} R at {} features, {} turns/s, \
             flicker {}; {unstable}",
            look.strands,
            look.band,
            look.noise.amplitude,
            look.noise.frequency,
            look.speed.turns_per_second,
            look.color.flicker
        );
    }
    let Some(path) = &args.contact_sheet else {
        return Ok(());
    };
    if !(1..=16).contains(&args.moments) || !(32..=1024).contains(&args.size) {
        bail!("--moments: 1 to 16, --size: 32 to 1024 pixels");
    }
    let size = args.size as usize;
    let columns = args.moments as usize;
    let mut sheet = Sheet::new(columns * size, NAMES.len() * size);
    for (row, name) in NAMES.iter().enumerate() {
        let shot = face_on_shot(name)?;
        let frames = rift_fx::FrameRange {
            first: 1,
            last: 1 + STEP * (columns as i64 - 1),
        };
        let generator = RingGenerator::new(&shot, frames);
        for column in 0..columns {
            let frame = generator.checked_frame(1 + STEP * column as i64)?;
            let origin = Vec2::new((column * size) as f32, (row * size) as f32);
            for ring in &frame.rings {
                sheet.draw_ring(ring, origin, size as f32);
            }
        }
    }
    sheet.write_png(path)?;
    eprintln!(
        "rift looks: {} presets x {columns} moments -> {}",
        NAMES.len(),
        path.display()
    );
    Ok(())
}

/// A shot whose camera looks straight at one opening with the preset's ring of radius 1.
fn face_on_shot(preset: &str) -> anyhow::Result<Shot> {
    let text = format!(
        r#"[shot]
name = "{preset}"
fps = {FPS}
frames = [1, 100]
shutter = [-0.25, 0.25]
[camera]
resolution = [512, 512]
fov_degrees = 40.0
[camera.transform]
position = [0.0, 0.0, 3.6]
look_at = [0.0, 0.0, 0.0]
[[portal]]
name = "ring"
here = {{ position = [0.0, 0.0, 0.0] }}
there = {{ position = [0.0, 0.0, -50.0] }}
[portal.ring]
preset = "{preset}"
radius = 1.0
seed = 7
"#
    );
    Ok(Shot::parse(&text, Path::new(preset))?)
}

/// Linear RGB light accumulated over the sheet.
struct Sheet {
    width: usize,
    height: usize,
    light: Vec<Vec3>,
}

impl Sheet {
    fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            light: vec![Vec3::ZERO; width * height],
        }
    }

    /// Draws `ring` face-on into the `size`-pixel square at `origin`: every segment of every
    /// strand splatted along its length, at five moments across the shutter (its baked
    /// velocity and acceleration), weighted by colour × intensity.
    fn draw_ring(&mut self, ring: &RingCurves, origin: Vec2, size: f32) {
        const SHUTTER: [f32; 5] = [-0.25, -0.125, 0.0, 0.125, 0.25];
        let scale = 0.42 * size / 1.25;
        let centre = origin + Vec2::splat(0.5 * size);
        let to_pixel = |p: Vec3| centre + Vec2::new(p.x, -p.y) * scale;
        for range in ring.strand_ranges() {
            let n = range.len();
            for k in 0..n {
                let (i, j) = (range.start + k, range.start + (k + 1) % n);
                let light = ring.colors[i] * ring.intensities[i] / SHUTTER.len() as f32;
                let radius = (0.5 * ring.widths[i] * scale).max(0.6);
                for s in SHUTTER {
                    let dt = s / FPS as f32;
                    let at = |v: usize| {
                        ring.points[v]
                            + ring.velocities[v] * dt
                            + 0.5 * ring.accelerations[v] * dt * dt
                    };
                    self.segment(to_pixel(at(i)), to_pixel(at(j)), radius, light);
                }
            }
        }
    }

    /// Splats a segment as discs every half pixel, each weighted by the length it stands for.
    fn segment(&mut self, a: Vec2, b: Vec2, radius: f32, light: Vec3) {
        let length = a.distance(b);
        let steps = (length / 0.5).ceil().max(1.0) as usize;
        let weight = 0.06 * length / steps as f32;
        for k in 0..steps {
            let p = a.lerp(b, (k as f32 + 0.5) / steps as f32);
            self.disc(p, radius, light * weight);
        }
    }

    /// Adds light in a soft disc: a Gaussian of the given radius, normalised.
    fn disc(&mut self, centre: Vec2, radius: f32, light: Vec3) {
        let reach = (2.5 * radius).ceil() as i64;
        let (cx, cy) = (centre.x.floor() as i64, centre.y.floor() as i64);
        let norm = 1.0 / (std::f32::consts::PI * radius * radius);
        for y in cy - reach..=cy + reach {
            for x in cx - reach..=cx + reach {
                if x < 0 || y < 0 || x as usize >= self.width || y as usize >= self.height {
                    continue;
                }
                let d = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) - centre;
                let g = (-d.length_squared() / (radius * radius)).exp() * norm;
                self.light[y as usize * self.width + x as usize] += light * g;
            }
        }
    }

    /// The light tone-mapped (1 − e^−x), as an 8-bit sRGB PNG, written atomically.
    fn write_png(&self, path: &Path) -> anyhow::Result<()> {
        let mapped: Vec<Vec3> = self
            .light
            .iter()
            .map(|c| Vec3::ONE - (-c.max(Vec3::ZERO)).exp())
            .collect();
        rift_render::frame::film::write_srgb_png(path, self.width, self.height, &mapped)?;
        Ok(())
    }
}
