//! Rendering a frame: tiles of pixels in parallel with rayon. Each pixel's samples depend only on
//! the pixel, the sample index and the seed, so the image is the same for any thread count.

use crate::camera::Lens;
use crate::film::Image;
use crate::integrator::trace;
use crate::sampling::{SampleStream, hash32};
use crate::scene::Scene;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

const TILE: usize = 16;

/// Renders `scene` through its camera with `spp` samples per pixel, each at a time spread over
/// the shutter.
pub fn render(scene: &Scene, spp: u32) -> Image {
    let camera = &scene.camera;
    let [w, h] = camera.projection.resolution.map(|v| v as usize);
    let [open, close] = scene.shutter;
    let still_lens = (!scene.camera_moves()).then(|| Lens::at(camera, open));
    let tiles_x = w.div_ceil(TILE);
    let tiles: Vec<(usize, usize)> = (0..h.div_ceil(TILE))
        .flat_map(|ty| (0..tiles_x).map(move |tx| (tx, ty)))
        .collect();
    let seed = scene.settings.seed;
    let done: Vec<Vec<(usize, Vec3, f32, u64)>> = tiles
        .par_iter()
        .map(|&(tx, ty)| {
            let mut out = Vec::with_capacity(TILE * TILE);
            for y in ty * TILE..((ty + 1) * TILE).min(h) {
                for x in tx * TILE..((tx + 1) * TILE).min(w) {
                    let pixel_seed =
                        hash32(hash32((y * w + x) as u32) ^ hash32(seed.wrapping_add(0x9e37_79b9)));
                    let mut sum = Vec3::ZERO;
                    let mut alpha = 0.0;
                    let mut discarded = 0;
                    for i in 0..spp {
                        let mut s = SampleStream::new(i, pixel_seed);
                        let [jx, jy, lx, ly] = s.next_4d();
                        let (jitter, lens_u) = (Vec2::new(jx, jy), Vec2::new(lx, ly));
                        let time = if close > open {
                            open + (close - open) * s.time() as f64
                        } else {
                            open
                        };
                        let ndc = (Vec2::new(x as f32, y as f32) + jitter)
                            / Vec2::new(w as f32, h as f32);
                        let lens = still_lens.unwrap_or_else(|| Lens::at(camera, time));
                        let (o, d) = lens.ray(ndc, lens_u);
                        let sample = trace(scene, o, d, time, &mut s);
                        if sample.radiance.is_finite() {
                            sum += sample.radiance;
                            alpha += sample.alpha;
                        } else {
                            discarded += 1;
                        }
                    }
                    let kept = (spp as u64 - discarded).max(1) as f32;
                    out.push((y * w + x, sum / kept, alpha / kept, discarded));
                }
            }
            out
        })
        .collect();
    let mut image = Image {
        width: w,
        height: h,
        rgb: vec![Vec3::ZERO; w * h],
        alpha: vec![0.0; w * h],
        discarded: 0,
    };
    for (i, c, a, d) in done.into_iter().flatten() {
        image.rgb[i] = c;
        image.alpha[i] = a;
        image.discarded += d;
    }
    image
}
