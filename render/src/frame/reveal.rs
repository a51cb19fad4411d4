//! What the openings reveal: set dressers and lighters work to camera, and must dress what an
//! opening shows. One camera ray through each pixel's centre, at the shutter's opening, follows
//! the openings as the path tracer's camera rays do (to the shot's portal depth, an opening of
//! opacity 0 teleporting nothing) and counts, per opening it passed first, the object it meets.

use crate::camera::Lens;
use crate::geometry::Ray;
use crate::integrator::PORTAL_TIE;
use crate::portals::RayClass;
use crate::scene::{Scene, SceneHit};
use glam::Vec2;
use std::collections::HashMap;

/// What a ray met: an object (an index into [`Scene::id_names`]), or nothing.
pub type Seen = Option<u32>;

/// Pixels of one frame by what the camera sees there.
#[derive(Clone, Debug, Default)]
pub struct Revealed {
    /// Camera rays traced.
    pub pixels: u64,
    /// Per (first opening passed, or `None` for a ray that passed none; what the ray met):
    /// pixels.
    pub counts: HashMap<(Option<usize>, Seen), u64>,
}

/// Traces the camera rays of `scene`'s frame at `width` x `height`.
pub fn reveal(scene: &Scene, width: u32, height: u32) -> Revealed {
    let time = scene.shutter[0];
    let lens = Lens::at(&scene.camera, time);
    let mut out = Revealed::default();
    for y in 0..height {
        for x in 0..width {
            let ndc =
                (Vec2::new(x as f32, y as f32) + 0.5) / Vec2::new(width as f32, height as f32);
            let (origin, dir) = lens.ray(ndc, Vec2::splat(0.5));
            let range = scene.clip.interval(&lens, origin, dir);
            let key = match range {
                Some((t_min, t_max)) => follow(
                    scene,
                    Ray::new(origin, dir, t_max, time).between(t_min, t_max),
                ),
                None => (None, None),
            };
            *out.counts.entry(key).or_default() += 1;
            out.pixels += 1;
        }
    }
    out
}

/// Follows a camera ray through the openings it meets before anything else: the first opening
/// it passed, and what it met in the end.
fn follow(scene: &Scene, mut ray: Ray) -> (Option<usize>, Seen) {
    let portals = &scene.portals;
    let mut first = None;
    let mut depth = 0;
    loop {
        let class = match depth {
            0 => RayClass::Camera,
            _ => RayClass::ThroughPortal,
        };
        let hit = scene.intersect(&ray, class);
        let hit_t = hit.as_ref().map(hit_distance);
        // As the path loop does: an opening just behind the hit still counts (ties).
        let limit = hit_t.map_or(ray.t_max, |t| t * (1.0 + PORTAL_TIE));
        let mut from = ray.t_min;
        let mut teleported = false;
        while let Some(ph) = portals.intersect(&ray.between(from, limit)) {
            if portals.look(ph.opening).opacity <= 0.0 {
                from = ph.t;
                continue;
            }
            if depth >= scene.settings.max_portal_depth {
                return (first, None);
            }
            let time = portals.exit_time(ph.opening, ray.time);
            let Some(next) = portals.teleport(&ph, ray.dir, time) else {
                return (first, None);
            };
            first.get_or_insert(ph.opening);
            depth += 1;
            ray = Ray::new(next.origin, next.direction, f32::INFINITY, time);
            teleported = true;
            break;
        }
        if !teleported {
            return (first, hit.map(|h| object_of(scene, &h)));
        }
    }
}

fn hit_distance(hit: &SceneHit) -> f32 {
    match hit {
        SceneHit::Surface(h) => h.t,
        SceneHit::Strand(h) => h.t,
    }
}

/// The object (or ring) a hit belongs to, as [`Scene::id_names`] indexes them.
fn object_of(scene: &Scene, hit: &SceneHit) -> u32 {
    match hit {
        // By object: what a layout artist dresses (an instanced prototype's instances count
        // together, where Cryptomatte tells them apart).
        SceneHit::Surface(h) => scene.triangle_object[h.triangle as usize],
        SceneHit::Strand(h) => scene.object_count + scene.strands.segment_ring[h.segment as usize],
    }
}
