//! Denoising a finished frame with Open Image Denoise ([`crate::platform::oidn`]), keeping it
//! a compositor's frame: the emission the camera sees directly is kept out of the filter, the
//! noisy beauty stays as its own layer (`noisy.R/G/B`, as Cycles keeps "Noisy Image"), and
//! every part of the beauty that is written as a layer is denoised with the same auxiliary
//! images so the parts still sum to the denoised beauty: the light groups each filtered and
//! then rescaled, pixel by pixel and channel by channel; the light through openings filtered
//! and kept within the beauty, the rest being the beauty less it.

use crate::frame::film::Image;
use crate::platform::oidn::{Device, Images, Quality, Settings};
use glam::Vec3;

/// What denoising took, for the report.
pub struct Denoised {
    pub seconds: f64,
    /// Filter runs: the two auxiliary images, the beauty and each layer.
    pub runs: usize,
}

/// Denoises `image` in place at `quality` on `threads` threads (0: all): the albedo and normal
/// are cleaned first (OIDN's advice for auxiliaries that carry noise: depth of field, motion
/// blur, glossy first hits), then the beauty and each layer are filtered with them.
pub fn denoise(image: &mut Image, quality: Quality, threads: usize) -> Result<Denoised, String> {
    let started = std::time::Instant::now();
    let device = Device::new(threads)?;
    let size = (image.window.width(), image.window.height());
    let guides = aux_quality(quality);
    let albedo = cleaned(&device, "albedo", &image.albedo, size, guides)?;
    let normal = cleaned(&device, "normal", &image.normal, size, guides)?;
    let filter = |pixels: &mut [Vec3]| {
        let images = Images {
            color: pixels,
            albedo: Some(&albedo),
            normal: Some(&normal),
            size,
        };
        let settings = Settings {
            hdr: true,
            clean_aux: true,
            quality,
        };
        device.filter(images, settings)
    };
    // What the camera sees emitted directly (a lamp, a ring a pixel wide) is left out of the
    // filter and added back: to the filter a thin bright emitter is a firefly, which it would
    // spread over the dark pixels beside it.
    let noisy = image.rgb.clone();
    for (v, e) in image.rgb.iter_mut().zip(&image.emitted) {
        *v = (*v - *e).max(Vec3::ZERO);
    }
    filter(&mut image.rgb)?;
    for (v, e) in image.rgb.iter_mut().zip(&image.emitted) {
        *v = v.max(Vec3::ZERO) + *e;
    }
    let mut runs = 3;
    if !image.light_groups.is_empty() {
        // Each group filtered, then all rescaled to sum to the denoised beauty.
        let mut parts: Vec<Vec<Vec3>> = (image.light_groups.iter_mut())
            .map(|(_, group)| std::mem::take(group))
            .collect();
        for part in parts.iter_mut() {
            filter(part)?;
        }
        runs += parts.len();
        rescale(&mut parts, &image.rgb);
        for ((_, group), part) in image.light_groups.iter_mut().zip(parts) {
            *group = part;
        }
    }
    if let Some(through) = &mut image.through {
        // Filtered and kept within the denoised beauty; the film writes the not-through layer
        // as the beauty less this one, so one filter run serves both.
        filter(through)?;
        runs += 1;
        for (part, total) in through.iter_mut().zip(&image.rgb) {
            *part = part.max(Vec3::ZERO).min(total.max(Vec3::ZERO));
        }
    }
    image.noisy = Some(noisy);
    Ok(Denoised {
        seconds: started.elapsed().as_secs_f64(),
        runs,
    })
}

/// The quality the albedo and normal are cleaned at for a frame filtered at `quality`: at most
/// `Balanced`. Cleaning them at `High` cost a quarter of the showcase's denoising time and
/// changed nothing one could measure: at 1280x720 and 16 spp its denoised frame's relMSE
/// against a 128-spp reference moved by 0.3% (the two frames differ by 1.9e-5, the frame's
/// own error is 7.0e-4), and OIDN's `Fast` cleans them exactly as `Balanced` does.
fn aux_quality(quality: Quality) -> Quality {
    match quality {
        Quality::High => Quality::Balanced,
        other => other,
    }
}

/// A copy of the auxiliary image `name` ("albedo" or "normal") with its noise filtered out.
fn cleaned(
    device: &Device,
    name: &str,
    image: &[Vec3],
    size: (usize, usize),
    quality: Quality,
) -> Result<Vec<Vec3>, String> {
    let mut out = image.to_vec();
    device.prefilter(name, &mut out, size, quality)?;
    Ok(out)
}

/// Scales `parts` (each denoised on its own, so they no longer add up) so that at every pixel
/// and channel they sum to `total`: each part keeps its share of their sum (negative values,
/// which filters can leave, count as zero). Where they sum to nothing but the total is
/// positive, the first part takes it all.
fn rescale(parts: &mut [Vec<Vec3>], total: &[Vec3]) {
    for (i, &t) in total.iter().enumerate() {
        for k in 0..3 {
            let sum: f32 = parts.iter().map(|p| p[i][k].max(0.0)).sum();
            for (j, part) in parts.iter_mut().enumerate() {
                let v = part[i][k].max(0.0);
                part[i][k] = match sum > 0.0 {
                    true => v / sum * t[k],
                    false if j == 0 => t[k],
                    false => 0.0,
                };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rescaled_parts_sum_to_the_total_and_keep_their_shares() {
        let total = vec![Vec3::new(2.0, 0.0, 1.0), Vec3::new(3.0, 4.0, 0.0)];
        let mut parts = vec![
            vec![Vec3::new(1.0, 0.5, 0.0), Vec3::new(-1.0, 1.0, 2.0)],
            vec![Vec3::new(3.0, 0.5, 0.0), Vec3::new(2.0, 3.0, 2.0)],
        ];
        rescale(&mut parts, &total);
        for (i, t) in total.iter().enumerate() {
            let sum = parts[0][i] + parts[1][i];
            assert!(sum.abs_diff_eq(*t, 1e-6), "pixel {i}: {sum} against {t}");
        }
        // Shares kept: 1 of 4, and the negative value counted as nothing.
        assert_eq!(parts[0][0].x, 0.5);
        assert_eq!(parts[0][1].x, 0.0);
        // Parts that sum to nothing: the first takes a positive total.
        assert_eq!(parts[0][0].z, 1.0);
        assert_eq!(parts[1][0].z, 0.0);
    }
}
