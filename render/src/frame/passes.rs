//! Rendering a frame: tiles of pixels in parallel with rayon, in passes of samples.
//!
//! Each pixel's samples depend only on the pixel, the sample index and the seed, so the image is
//! the same for any thread count. Adaptive sampling is decided per pixel from that pixel's own
//! samples, so it keeps that property; only a wall-clock time limit makes output depend on the
//! machine.

use crate::camera::{Eye, Lens};
use crate::color::luminance_f64;
use crate::frame::cryptomatte::{Counts, Cryptomatte};
use crate::frame::film::{BACKGROUND_DEPTH, Image, Metadata, Window};
use crate::geometry::ray::Ray;
use crate::integrator::{Context, NoRecorder, PathSample, trace};
use crate::prepare::Prepared;
use crate::sampling::{SampleStream, hash32};
use crate::scene::Scene;
use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::RecvTimeoutError;
use std::time::{Duration, Instant};

const TILE: usize = 16;

/// Bytes the film of a frame of `pixels` pixels takes at its peak: the per-pixel sums (held in
/// tiles while sampling, then once more in rows), the finished image with its AOVs, and the
/// EXR writer's channels (about 26 floats a pixel, which the encoder copies once more).
pub fn film_bytes(pixels: usize) -> u64 {
    const EXR_CHANNEL_BYTES: usize = 2 * 26 * std::mem::size_of::<f32>();
    let image = 5 * std::mem::size_of::<Vec3>() + 4 * std::mem::size_of::<f32>();
    let per_pixel = 2 * std::mem::size_of::<Pixel>() + image + EXR_CHANNEL_BYTES;
    (pixels as u64).saturating_mul(per_pixel as u64)
}
/// Samples a pixel takes before its error estimate is trusted.
const MIN_ADAPTIVE_SPP: u32 = 16;
/// The first pass when sampling progressively (adaptive or time-limited).
const FIRST_PASS: u32 = 4;

/// How to render, beyond the scene.
pub struct RenderOptions<'a> {
    /// Samples per pixel (the most any pixel takes when sampling adaptively); with
    /// `first_sample`, the end of the range of sample indices rendered.
    pub spp: u32,
    /// The first sample index rendered (0 for a whole render): a render of the indices
    /// `first_sample..spp` is a part that `rift merge` combines with the other ranges into
    /// exactly the whole render, as every sample depends only on pixel, index and seed.
    pub first_sample: u32,
    /// Only these pixels; `None`: the whole frame.
    pub crop: Option<Window>,
    /// Stop sampling a pixel once the estimated relative error of the means around it (3×3)
    /// falls below this: standard error / sqrt(mean² + 0.01), the same regularised measure as
    /// relMSE (see `mark_converged`).
    pub target_error: Option<f32>,
    /// Wall-clock budget: passes shrink to what is predicted to fit, and no tile starts after it
    /// runs out (every pixel still gets its first pass).
    pub time_limit: Option<Duration>,
    /// Called with the number of samples just finished, from worker threads.
    pub progress: Option<&'a (dyn Fn(u64) + Sync)>,
    /// Which eye of the scene's stereo pair to render; `None` (or a scene without stereo):
    /// the shot camera itself.
    pub eye: Option<Eye>,
    /// Sums to continue from (a checkpoint's, row-major over the window) instead of nothing.
    pub resume: Option<&'a Sums>,
    /// Hand the running sums out every so often, and once more if `stop` ends the render.
    pub checkpoint: Option<Checkpointing<'a>>,
    /// Set (from a signal handler) to end the render early: no pixel starts after it is set.
    pub stop: Option<&'a AtomicBool>,
    /// Count the objects each pixel's camera samples see first, for Cryptomatte layers.
    pub cryptomatte: bool,
}

impl RenderOptions<'_> {
    /// Plain rendering at `spp` samples per pixel over the whole frame.
    pub fn new(spp: u32) -> Self {
        Self {
            spp,
            first_sample: 0,
            crop: None,
            target_error: None,
            time_limit: None,
            progress: None,
            eye: None,
            resume: None,
            checkpoint: None,
            stop: None,
            cryptomatte: false,
        }
    }
}

/// How often the running sums are handed out, and to what.
#[derive(Clone, Copy)]
pub struct Checkpointing<'a> {
    pub every: Duration,
    /// Called from a background thread with the partial image and the sums it was made
    /// from; rendering goes on meanwhile.
    pub save: &'a (dyn Fn(&Image, Sums) + Sync),
}

/// A window's running sums, row-major: each pixel's, and its light groups' radiance (`groups`
/// holds [`Scene::light_groups`]`.len()` sums per pixel, pixel after pixel; empty without
/// groups).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Sums {
    pub pixels: Vec<Pixel>,
    pub groups: Vec<DVec3>,
    /// Per pixel, the objects its samples saw first (empty without Cryptomatte).
    pub ids: Vec<Counts>,
}

impl Sums {
    /// Light groups per pixel.
    pub fn group_count(&self) -> usize {
        self.groups
            .len()
            .checked_div(self.pixels.len())
            .unwrap_or(0)
    }
}

/// One pixel's running sums: what passes carry forward and a checkpoint keeps.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pixel {
    pub(crate) sum: DVec3,
    /// The part of `sum` that arrived through openings.
    pub(crate) through: DVec3,
    /// The part of `sum` the camera saw emitted directly.
    pub(crate) emitted: DVec3,
    /// Sum of squared luminance, for the error estimate.
    pub(crate) lum_sq: f64,
    pub(crate) hits: u32,
    pub(crate) albedo: Vec3,
    pub(crate) normal: Vec3,
    pub(crate) depth: f64,
    /// Sum of the camera paths' teleport counts.
    pub(crate) portal_depth: u32,
    /// The next sample index to take.
    pub(crate) samples: u32,
    pub(crate) discarded: u32,
    pub(crate) converged: bool,
}

impl Pixel {
    /// Samples that count in the pixel's mean, of those from index `first` on.
    fn kept(&self, first: u32) -> u32 {
        self.samples.saturating_sub(first + self.discarded)
    }

    /// Standard error of the mean luminance over sqrt(mean² + 0.01).
    fn relative_error(&self, first: u32) -> f64 {
        let n = self.kept(first) as f64;
        if n < 2.0 {
            return f64::INFINITY;
        }
        let mean = luminance_f64(self.sum) / n;
        let variance = ((self.lum_sq / n - mean * mean) * n / (n - 1.0)).max(0.0);
        (variance / n).sqrt() / (mean * mean + 0.01).sqrt()
    }

    /// Whether the pixel needs no more samples below index `spp`.
    fn finished(&self, spp: u32) -> bool {
        self.converged || self.samples >= spp
    }
}

/// A finished render, or one a stop ended early.
pub struct Rendered {
    pub image: Image,
    /// False when `stop` ended the render before every pixel had its samples.
    pub complete: bool,
}

/// Renders the prepared scene through its camera; each sample has its own time within the
/// shutter.
pub fn render(prepared: &Prepared, options: &RenderOptions) -> Image {
    render_resumable(prepared, options).image
}

/// [`render`], continuing from `options.resume`, handing out checkpoints and honouring
/// `options.stop`.
pub fn render_resumable(prepared: &Prepared, options: &RenderOptions) -> Rendered {
    let started = Instant::now();
    let scene = &prepared.scene;
    let frame = FrameSampler::new(prepared.context(), options);
    let window = frame.window;
    let groups = scene.light_groups.len();
    let tiles = tiles(
        window,
        frame.first,
        groups,
        options.resume,
        options.cryptomatte,
    );
    std::thread::scope(|threads| {
        let (finished, wait) = std::sync::mpsc::channel::<()>();
        if let Some(checkpoint) = options.checkpoint {
            let tiles = &tiles;
            threads.spawn(move || {
                while let Err(RecvTimeoutError::Timeout) = wait.recv_timeout(checkpoint.every) {
                    let sums = rows(tiles, window, groups, options.cryptomatte);
                    (checkpoint.save)(&finish(scene, options, window, &sums, started), sums);
                }
            });
        }
        run_passes(&frame, options, &tiles, started);
        drop(finished);
    });
    let sums = rows(&tiles, window, groups, options.cryptomatte);
    let image = finish(scene, options, window, &sums, started);
    let stopped = options.stop.is_some_and(|s| s.load(Ordering::Relaxed));
    let complete = !stopped || sums.pixels.iter().all(|p| p.finished(options.spp));
    if !complete && let Some(checkpoint) = options.checkpoint {
        (checkpoint.save)(&image, sums);
    }
    Rendered { image, complete }
}

/// A tile of pixels and their sums (row-major within the tile), with `groups` light-group
/// sums per pixel.
struct Tile {
    window: Window,
    pixels: Vec<Pixel>,
    groups: Vec<DVec3>,
    /// Per pixel when counting object IDs, else empty.
    ids: Vec<Counts>,
}

/// The window cut in tiles, each owning its pixels so passes can run tiles in parallel and
/// carry their sums from pass to pass; their sums start from `resume` when given.
fn tiles(
    window: Window,
    first: u32,
    groups: usize,
    resume: Option<&Sums>,
    ids: bool,
) -> Vec<Mutex<Tile>> {
    let resume = resume.filter(|r| r.pixels.len() == window.area() && r.group_count() == groups);
    let index = |x: usize, y: usize| (y - window.y0) * window.width() + (x - window.x0);
    let start = |x: usize, y: usize| match resume {
        Some(r) => r.pixels[index(x, y)],
        None => Pixel {
            samples: first,
            ..Pixel::default()
        },
    };
    let start_groups = |x: usize, y: usize| match resume {
        Some(r) => r.groups[index(x, y) * groups..][..groups].to_vec(),
        None => vec![DVec3::ZERO; groups],
    };
    (window.y0..window.y1)
        .step_by(TILE)
        .flat_map(|y0| {
            (window.x0..window.x1).step_by(TILE).map(move |x0| {
                let tile = Window {
                    x0,
                    x1: (x0 + TILE).min(window.x1),
                    y0,
                    y1: (y0 + TILE).min(window.y1),
                };
                let pixels = (tile.y0..tile.y1)
                    .flat_map(|y| (tile.x0..tile.x1).map(move |x| start(x, y)))
                    .collect();
                let groups = (tile.y0..tile.y1)
                    .flat_map(|y| (tile.x0..tile.x1).flat_map(move |x| start_groups(x, y)))
                    .collect();
                let ids = if ids {
                    vec![Counts::default(); tile.area()]
                } else {
                    Vec::new()
                };
                Mutex::new(Tile {
                    window: tile,
                    pixels,
                    groups,
                    ids,
                })
            })
        })
        .collect()
}

/// The tiles' sums in rows over the window (each tile locked in turn, so a tile is never
/// copied halfway through a pass).
fn rows(tiles: &[Mutex<Tile>], window: Window, groups: usize, ids: bool) -> Sums {
    let mut sums = Sums {
        pixels: vec![Pixel::default(); window.area()],
        groups: vec![DVec3::ZERO; window.area() * groups],
        ids: if ids {
            vec![Counts::default(); window.area()]
        } else {
            Vec::new()
        },
    };
    for tile in tiles {
        let tile = tile.lock().unwrap_or_else(|e| e.into_inner());
        let w = tile.window;
        for (k, px) in tile.pixels.iter().enumerate() {
            let i = row_index(window, w, k);
            sums.pixels[i] = *px;
            sums.groups[i * groups..][..groups]
                .copy_from_slice(&tile.groups[k * groups..][..groups]);
            if let Some(ids) = tile.ids.get(k) {
                sums.ids[i] = *ids;
            }
        }
    }
    sums
}

/// Passes of samples over the tiles until every pixel has its samples, the time runs out or a
/// stop is asked for.
fn run_passes(
    frame: &FrameSampler,
    options: &RenderOptions,
    tiles: &[Mutex<Tile>],
    started: Instant,
) {
    let first = frame.first;
    let stopping = || options.stop.is_some_and(|s| s.load(Ordering::Relaxed));
    // Progressive passes (4, 4, 8, 16, ... samples) let adaptive sampling and the time limit
    // decide as they go, and give checkpoints an even image; a pixel's samples are the same
    // whatever the passes.
    let progressive = options.target_error.is_some()
        || options.time_limit.is_some()
        || options.checkpoint.is_some()
        || options.stop.is_some();
    let deadline = options.time_limit.map(|limit| started + limit);
    // A resumed render continues the pass its unfinished pixels are in.
    let mut done = tiles
        .iter()
        .flat_map(|t| {
            let tile = t.lock().unwrap_or_else(|e| e.into_inner());
            tile.pixels
                .iter()
                .filter(|p| !p.finished(options.spp))
                .map(|p| p.samples)
                .min()
        })
        .min()
        .unwrap_or(options.spp)
        .max(first);
    let mut seconds_per_sample = 0.0f64;
    while done < options.spp && !stopping() {
        let left = options.spp - done;
        let mut size = if !progressive {
            left
        } else if done == first {
            FIRST_PASS.min(left)
        } else {
            (done - first).min(left)
        };
        // Under a time limit, shrink the pass to what the remaining time is predicted to fit.
        if let Some(deadline) = deadline.filter(|_| done > first) {
            let left = deadline
                .saturating_duration_since(Instant::now())
                .as_secs_f64();
            let fits = (left / seconds_per_sample.max(1e-12)).floor() as u32;
            if fits == 0 {
                break;
            }
            size = size.min(fits);
        }
        let last = done + size;
        let pass_started = Instant::now();
        let first_pass = done == first;
        tiles.par_iter().for_each(|tile| {
            if !first_pass && deadline.is_some_and(|d| Instant::now() > d) {
                return;
            }
            let mut guard = tile.lock().unwrap_or_else(|e| e.into_inner());
            let Tile {
                window: tile,
                pixels,
                groups,
                ids,
            } = &mut *guard;
            let n = frame.groups;
            let mut taken = 0u64;
            for (k, px) in pixels.iter_mut().enumerate() {
                if stopping() {
                    break;
                }
                if px.converged {
                    continue;
                }
                let before = px.samples;
                let (x, y) = (tile.x0 + k % tile.width(), tile.y0 + k / tile.width());
                frame.sample_pixel(x, y, px, &mut groups[k * n..][..n], ids.get_mut(k), last);
                taken += (px.samples - before) as u64;
            }
            if let Some(report) = options.progress {
                report(taken);
            }
        });
        seconds_per_sample = pass_started.elapsed().as_secs_f64() / size as f64;
        if let Some(target) = options.target_error {
            mark_converged(tiles, frame.window, first, target as f64);
        }
        done = last;
    }
}

/// Marks the pixels whose neighbourhood has converged after a pass: a pixel stops once it
/// has [`MIN_ADAPTIVE_SPP`] samples and the largest relative error around it (3×3, within the
/// window) is below `target`. Deciding by its own error alone darkened the image: a pixel
/// whose samples had not yet met a rare bright path also had a small variance, so it stopped
/// low (the Cornell box at a target of 0.03 came out 0.5% dark). Its neighbours' samples are
/// independent of its own, so they hold it until the region has converged. Decided between
/// passes from every tile's sums, so the same whatever the thread count.
fn mark_converged(tiles: &[Mutex<Tile>], window: Window, first: u32, target: f64) {
    let (width, height) = (window.width(), window.height());
    let mut error = vec![f64::INFINITY; width * height];
    for_each_pixel(tiles, window, |i, px| {
        if px.samples - first >= MIN_ADAPTIVE_SPP {
            error[i] = px.relative_error(first);
        }
    });
    for_each_pixel(tiles, window, |i, px| {
        if px.converged || px.samples - first < MIN_ADAPTIVE_SPP {
            return;
        }
        let (x, y) = (i % width, i / width);
        let around = (y.saturating_sub(1)..(y + 2).min(height)).flat_map(|ny| {
            (x.saturating_sub(1)..(x + 2).min(width)).map(move |nx| ny * width + nx)
        });
        let worst = around.map(|n| error[n]).fold(0.0f64, f64::max);
        px.converged = worst <= target;
    });
}

/// Calls `f` with each pixel of the tiles and its index in rows over `window`.
fn for_each_pixel(tiles: &[Mutex<Tile>], window: Window, mut f: impl FnMut(usize, &mut Pixel)) {
    for tile in tiles {
        let mut tile = tile.lock().unwrap_or_else(|e| e.into_inner());
        let w = tile.window;
        for (k, px) in tile.pixels.iter_mut().enumerate() {
            f(row_index(window, w, k), px);
        }
    }
}

/// The index in rows over `window` of pixel `k` (row-major) of the tile over `tile`.
fn row_index(window: Window, tile: Window, k: usize) -> usize {
    let (x, y) = (tile.x0 + k % tile.width(), tile.y0 + k / tile.width());
    (y - window.y0) * window.width() + (x - window.x0)
}

/// What every sample of the frame shares: the camera, the window and the seeds.
struct FrameSampler<'a> {
    ctx: Context<'a>,
    eye: Option<Eye>,
    /// The full frame's size.
    size: (usize, usize),
    window: Window,
    shutter: [f64; 2],
    still_lens: Option<Lens>,
    seed: u32,
    clipped: bool,
    first: u32,
    /// Light groups tracked per pixel (0: none).
    groups: usize,
}

impl<'a> FrameSampler<'a> {
    fn new(ctx: Context<'a>, options: &RenderOptions) -> Self {
        let scene = ctx.scene;
        let [w, h] = scene.camera.projection.resolution.map(|v| v as usize);
        Self {
            ctx,
            eye: options.eye,
            size: (w, h),
            window: options.crop.unwrap_or(Window::full(w, h)),
            shutter: scene.shutter,
            still_lens: (!scene.camera_moves())
                .then(|| scene_lens(scene, options.eye, scene.shutter[0])),
            seed: hash32(scene.settings.seed.wrapping_add(0x9e37_79b9)),
            clipped: !scene.clip.is_none(),
            first: options.first_sample.min(options.spp),
            groups: scene.light_groups.len(),
        }
    }

    /// Samples `px` (the pixel at column x, row y, whose light-group sums are `groups`) up to
    /// sample index `last` (exclusive).
    fn sample_pixel(
        &self,
        x: usize,
        y: usize,
        px: &mut Pixel,
        groups: &mut [DVec3],
        mut ids: Option<&mut Counts>,
        last: u32,
    ) {
        let (w, h) = self.size;
        let [open, close] = self.shutter;
        let scene = self.ctx.scene;
        let pixel_seed = hash32(hash32((y * w + x) as u32) ^ self.seed);
        for i in px.samples..last {
            let mut s = SampleStream::new(i, pixel_seed);
            let [jx, jy, lx, ly] = s.next_4d();
            let time = if close > open {
                open + (close - open) * s.time() as f64
            } else {
                open
            };
            let ndc =
                (Vec2::new(x as f32, y as f32) + Vec2::new(jx, jy)) / Vec2::new(w as f32, h as f32);
            let lens = self
                .still_lens
                .unwrap_or_else(|| scene_lens(scene, self.eye, time));
            let (o, d) = lens.ray(ndc, Vec2::new(lx, ly));
            let range = if self.clipped {
                scene.clip.interval(&lens, o, d)
            } else {
                Some((0.0, f32::INFINITY))
            };
            let sample = match range {
                Some((t_min, t_max)) => {
                    let ray = Ray::new(o, d, t_max, time).between(t_min, t_max);
                    trace(&self.ctx, ray, &mut s, &mut NoRecorder)
                }
                None => PathSample::default(),
            };
            if !sample.radiance.is_finite() {
                px.discarded += 1;
                continue;
            }
            let c = sample.radiance.as_dvec3();
            px.sum += c;
            px.through += sample.through.as_dvec3();
            px.emitted += sample.direct_emission().as_dvec3();
            px.lum_sq += luminance_f64(c) * luminance_f64(c);
            px.portal_depth += sample.portal_depth;
            for (sum, light) in groups.iter_mut().zip(&sample.groups) {
                *sum += light.as_dvec3();
            }
            if let Some(first) = sample.first {
                if let Some(ids) = ids.as_deref_mut() {
                    ids.add(first.object);
                }
                px.hits += 1;
                px.albedo += first.albedo;
                px.normal += first.normal;
                // Depth along the camera's viewing axis at this sample's time.
                px.depth += (first.t * d.dot(-lens.back)) as f64;
            }
        }
        px.samples = px.samples.max(last);
    }
}

/// The camera of `scene` at time `t`, as `eye` of its stereo pair when it has one.
fn scene_lens(scene: &Scene, eye: Option<Eye>, t: f64) -> Lens {
    let lens = Lens::at(&scene.camera, t);
    match (&scene.stereo, eye) {
        (Some(stereo), Some(eye)) => lens.eye(stereo, eye),
        _ => lens,
    }
}

/// The median of the pixels' relative standard errors ([`Pixel::relative_error`]), over those
/// with two samples or more; `None` when none has.
fn median_noise(pixels: &[Pixel], first: u32) -> Option<f32> {
    let mut errors: Vec<f64> = (pixels.iter())
        .map(|p| p.relative_error(first))
        .filter(|e| e.is_finite())
        .collect();
    if errors.is_empty() {
        return None;
    }
    let middle = errors.len() / 2;
    let (_, median, _) = errors.select_nth_unstable_by(middle, f64::total_cmp);
    Some(*median as f32)
}

/// Means of the accumulated sums, as an image with metadata.
fn finish(
    scene: &Scene,
    options: &RenderOptions,
    window: Window,
    sums: &Sums,
    started: Instant,
) -> Image {
    let pixels = &sums.pixels;
    let [w, h] = scene.camera.projection.resolution.map(|v| v as usize);
    let spp = options.spp;
    let first = options.first_sample.min(spp);
    let kept = |p: &Pixel| p.kept(first).max(1) as f64;
    let per_hit = |p: &Pixel| p.hits.max(1) as f32;
    let lens = scene_lens(scene, options.eye, scene.shutter[0]);
    let view = scene
        .stereo
        .and(options.eye)
        .map(|eye| eye.name().to_owned());
    Image {
        width: w,
        height: h,
        window,
        rgb: pixels.iter().map(|p| (p.sum / kept(p)).as_vec3()).collect(),
        emitted: pixels
            .iter()
            .map(|p| (p.emitted / kept(p)).as_vec3())
            .collect(),
        through: (!scene.portals.is_empty()).then(|| {
            pixels
                .iter()
                .map(|p| (p.through / kept(p)).as_vec3())
                .collect()
        }),
        alpha: pixels
            .iter()
            .map(|p| (p.hits as f64 / kept(p)) as f32)
            .collect(),
        albedo: pixels.iter().map(|p| p.albedo / per_hit(p)).collect(),
        normal: pixels.iter().map(|p| p.normal / per_hit(p)).collect(),
        depth: pixels
            .iter()
            .map(|p| {
                if p.hits == 0 {
                    BACKGROUND_DEPTH
                } else {
                    (p.depth / p.hits as f64) as f32
                }
            })
            .collect(),
        portal_depth: pixels
            .iter()
            .map(|p| (p.portal_depth as f64 / kept(p)) as f32)
            .collect(),
        noisy: None,
        light_groups: light_group_means(scene, sums, first),
        cryptomatte: (!sums.ids.is_empty()).then(|| Cryptomatte {
            names: scene.id_names.clone(),
            pixels: sums
                .ids
                .iter()
                .zip(pixels)
                .map(|(ids, p)| ids.ranked(p.kept(first)))
                .collect(),
        }),
        spp: pixels.iter().map(|p| p.kept(first)).collect(),
        discarded: pixels.iter().map(|p| p.discarded as u64).sum(),
        noise: median_noise(pixels, first),
        metadata: Metadata {
            frame: scene.frame,
            render_seconds: started.elapsed().as_secs_f64(),
            spp,
            first_sample: first,
            seed: scene.settings.seed,
            shot_id: 0,
            world_to_camera: lens.world_to_camera(),
            world_to_ndc: lens.world_to_ndc(),
            view,
        },
    }
}

/// Each light group's mean radiance per pixel, named.
fn light_group_means(scene: &Scene, sums: &Sums, first: u32) -> Vec<(String, Vec<Vec3>)> {
    let n = sums.group_count();
    scene
        .light_groups
        .iter()
        .enumerate()
        .map(|(g, name)| {
            let means = sums
                .pixels
                .iter()
                .enumerate()
                .map(|(i, p)| (sums.groups[i * n + g] / p.kept(first).max(1) as f64).as_vec3())
                .collect();
            (name.clone(), means)
        })
        .collect()
}
