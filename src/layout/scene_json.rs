//! What the layout page draws, as JSON: the shot's frame range and rate, and at one frame the
//! camera, every object's triangles in world space with its base colour, every opening's
//! frames and outline, and the rings' strands as line segments. Built from the renderer's own
//! scene, so the page shows exactly what `rift render` renders.

use glam::Vec3;
use rift_render::Scene;
use rift_render::camera::Lens;
use rift_render::mask::Mask;
use rift_render::rift_fx::Shot;
use rift_render::visibility::RayClass;
use serde_json::{Value, json};

/// Points of a round outline (disks, and rings by their widest extent).
const OUTLINE_POINTS: usize = 64;

/// The scene of `shot` at `frame` as the page's JSON.
pub fn scene(shot: &Shot, scene: &Scene, frame: i64) -> Value {
    let time = shot.time_of(frame as f64);
    json!({
        "shot": shot.name,
        "frame": frame,
        "frames": [shot.frames.first, shot.frames.last],
        "fps": shot.fps,
        "camera": camera(scene, time),
        "objects": objects(scene, time),
        "openings": openings(shot, scene, time),
        "strands": strands(scene, time),
        "maxPortalDepth": scene.settings.max_portal_depth,
    })
}

fn camera(scene: &Scene, time: f64) -> Value {
    let lens = Lens::at(&scene.camera, time);
    let [w, h] = scene.camera.projection.resolution;
    json!({
        "position": lens.position.to_array(),
        "right": lens.right.to_array(),
        "up": lens.up.to_array(),
        "back": lens.back.to_array(),
        "fovY": 2.0 * lens.tan_half_fov_y.atan().to_degrees(),
        "aspect": lens.aspect,
        "resolution": [w, h],
    })
}

/// Per object: its name, base colour (the mean albedo of its triangles' materials), its
/// triangles' corners in world space at `time`, flattened, and the cull volumes that hide
/// parts of it (world-to-local matrix, column-major; which side is behind; depth; radius), and
/// whether camera rays see it directly and through openings (its visibility flags).
fn objects(scene: &Scene, time: f64) -> Vec<Value> {
    let count = scene.object_count as usize;
    let mut positions: Vec<Vec<f32>> = vec![Vec::new(); count];
    let mut colour = vec![(Vec3::ZERO, 0u32); count];
    let placements: Vec<_> = scene
        .object_motion
        .iter()
        .map(|m| m.as_ref().map(|m| m.at(time)))
        .collect();
    for (t, tri) in scene.triangles.iter().enumerate() {
        let o = scene.object_of(t as u32) as usize;
        let corners = match &placements[o] {
            Some(p) => tri.v.map(|v| p.transform_point(v.as_dvec3()).as_vec3()),
            None => tri.v,
        };
        positions[o].extend(corners.iter().flat_map(|c| c.to_array()));
        let albedo = scene.material(t as u32).bsdf.albedo();
        colour[o] = (colour[o].0 + albedo, colour[o].1 + 1);
    }
    (0..count)
        .map(|o| {
            let (sum, n) = colour[o];
            let culls: Vec<Value> = scene
                .visibility
                .culls_of(o as u32, time)
                .into_iter()
                .map(|(frame, sign, depth, radius)| {
                    json!({
                        "toLocal": frame.inverse().to_mat4().to_cols_array(),
                        "sign": sign,
                        "depth": depth,
                        "radius": radius,
                    })
                })
                .collect();
            json!({
                "name": scene.id_names[o],
                "color": (sum / n.max(1) as f32).to_array(),
                "positions": positions[o],
                "culls": culls,
                "seenByCamera": scene.visibility.object_seen(o as u32, RayClass::Camera),
                "seenThroughOpenings": scene.visibility.object_seen(o as u32, RayClass::ThroughPortal),
            })
        })
        .collect()
}

/// Per opening: its name, here and there frames (position, quaternion x y z w, scale) and its
/// teleport region's outline in its local XY plane.
fn openings(shot: &Shot, scene: &Scene, time: f64) -> Vec<Value> {
    let portals = &scene.portals;
    (0..portals.len())
        .map(|i| {
            let frame = |s: rift_render::rift_fx::rig::Similarity| {
                json!({
                    "position": s.translation.to_array(),
                    "rotation": s.rotation.to_array(),
                    "scale": s.scale,
                })
            };
            json!({
                "name": shot.rig.openings[i].name,
                "here": frame(portals.here(i, time)),
                "there": frame(portals.there(i, time)),
                "outline": outline(portals.mask(i)),
                "opacity": portals.look(i).opacity,
            })
        })
        .collect()
}

/// A mask's outline as points in the opening's local XY plane.
fn outline(mask: &Mask) -> Vec<[f64; 2]> {
    let circle = |r: f64| {
        (0..OUTLINE_POINTS)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / OUTLINE_POINTS as f64;
                [r * a.cos(), r * a.sin()]
            })
            .collect()
    };
    match mask {
        Mask::Disk { radius } => circle(*radius),
        Mask::Rectangle { half } => vec![
            [-half.x, -half.y],
            [half.x, -half.y],
            [half.x, half.y],
            [-half.x, half.y],
        ],
        Mask::Polygon(polygon) => polygon.points().iter().map(|p| [p.x, p.y]).collect(),
        Mask::Ring(_) => circle(mask.bounding_radius()),
    }
}

/// The strands at `time` as segment end points, flattened, with their colour.
fn strands(scene: &Scene, time: f64) -> Value {
    let n = scene.strands.segments.len() as u32;
    let mut points = Vec::with_capacity(6 * n as usize);
    let mut colors = Vec::with_capacity(3 * n as usize);
    for i in 0..n {
        let cone = scene.strands.world_segment(i, time);
        points.extend(cone.a.to_array());
        points.extend(cone.b.to_array());
        let c = scene.strands.radiance(i, 0.5);
        let c = c / c.max_element().max(1e-6);
        colors.extend(c.to_array());
    }
    json!({ "points": points, "colors": colors })
}
