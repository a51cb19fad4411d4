//! What the layout page draws, as JSON: the shot's frame range and rate, and at one frame the
//! camera, every object's triangles in its own space with its placement and base colour, every
//! opening's frames and outline, and the rings' strands as line segments (by opening, in world
//! space). Built from the renderer's own scene, so the page shows exactly what `rift render`
//! renders. With them, what the page needs to edit: which keys each pose has, and which
//! objects the solver places through which opening, so copies follow their source live.

use super::edit::{self, Side, Target};
use super::shot_file::ShotFile;
use glam::Vec3;
use rift_render::Scene;
use rift_render::camera::Lens;
use rift_render::portals::masks::Mask;
use rift_render::portals::visibility::RayClass;
use rift_render::rift_fx::Shot;
use rift_render::rift_fx::rig::{Similarity, ThereFrame};
use serde_json::{Value, json};

/// Points of a round outline.
const OUTLINE_POINTS: usize = 64;

/// Points of a ring's outline (its inner envelope wavers around the circle).
const RING_OUTLINE_POINTS: usize = 256;

/// The scene of `shot` (as `file` holds it) at `frame` as the page's JSON.
pub fn scene(shot: &Shot, scene: &Scene, frame: i64, file: &ShotFile) -> Value {
    let time = shot.time_of(frame as f64);
    let mut camera = camera(scene, time);
    camera["keys"] = json!(edit::key_frames(file.doc(), &Target::Camera));
    json!({
        "shot": shot.name,
        "file": file.path().display().to_string(),
        "unsaved": file.unsaved(),
        "frame": frame,
        "frames": [shot.frames.first, shot.frames.last],
        "fps": shot.fps,
        "camera": camera,
        "objects": objects(shot, scene, time, file),
        "openings": openings(shot, scene, time, file),
        "rings": strands(shot, scene, time),
        "maxPortalDepth": scene.settings.max_portal_depth,
        "time": time,
        "rayTimes": scene.portals.times(),
        "moments": moments(shot, scene, time),
    })
}

/// The most other moments sent (a chain of openings with time offsets reaches one each).
const MAX_MOMENTS: usize = 32;

/// Where things are at the other times rays reach through openings with time offsets (each
/// opening passed shifts a ray's time, within the scene's ray times): per time, the objects'
/// placements (and each object's instances, empty but for instanced objects), the openings'
/// frames and the rings. Empty when no opening has an offset.
fn moments(shot: &Shot, scene: &Scene, time: f64) -> Vec<Value> {
    let portals = &scene.portals;
    let mut times = vec![time];
    let mut frontier = vec![time];
    for _ in 0..scene.settings.max_portal_depth {
        let mut next = Vec::new();
        for &t in &frontier {
            for i in 0..portals.len() {
                let exit = portals.exit_time(i, t);
                if times.len() < MAX_MOMENTS + 1 && !times.iter().any(|s| (s - exit).abs() < 1e-9) {
                    times.push(exit);
                    next.push(exit);
                }
            }
        }
        frontier = next;
    }
    times[1..]
        .iter()
        .map(|&t| {
            let placements: Vec<Value> = scene
                .object_placement
                .iter()
                .map(|m| similarity(m.at(t)))
                .collect();
            let instances: Vec<Value> = (0..scene.object_count)
                .map(|o| instances(scene, o, t))
                .collect();
            let frames: Vec<Value> = (0..portals.len())
                .map(|i| json!({ "here": similarity(portals.here(i, t)), "there": similarity(portals.there(i, t)) }))
                .collect();
            json!({
                "time": t,
                "placements": placements,
                "instances": instances,
                "openings": frames,
                "rings": strands(shot, scene, t),
            })
        })
        .collect()
}

/// Where each instance of instanced object `object` is at `time`, eight numbers each
/// (position, quaternion x y z w, scale) one after another; empty for other objects.
fn instances(scene: &Scene, object: u32, time: f64) -> Value {
    let flat: Vec<f32> = (scene.instance_placements(object, time).iter())
        .flat_map(|s| {
            let (p, q) = (s.translation.as_vec3(), s.rotation.as_quat());
            [p.x, p.y, p.z, q.x, q.y, q.z, q.w, s.scale as f32]
        })
        .collect();
    json!(flat)
}

/// A similarity as the page takes it: position, quaternion (x, y, z, w), scale.
fn similarity(s: Similarity) -> Value {
    json!({
        "position": s.translation.to_array(),
        "rotation": s.rotation.to_array(),
        "scale": s.scale,
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
/// triangles' corners in its own space (a deforming object's in its shape at `time`),
/// flattened, and its placement at `time` (an instanced object's triangles are drawn at each
/// of its instances' placements, `instances`, instead); the cull
/// volumes that hide parts of it (world-to-local matrix, column-major; the opening whose frame
/// it is; which side is behind; depth; radius); whether camera rays see it directly and through openings (its visibility
/// flags); and for editing, the keys of the transform that places it, the object whose
/// transform that is, and the opening the solver carries it through (or back through).
fn objects(shot: &Shot, scene: &Scene, time: f64, file: &ShotFile) -> Vec<Value> {
    let count = scene.object_count as usize;
    let mut positions: Vec<Vec<f32>> = vec![Vec::new(); count];
    let mut colour = vec![(Vec3::ZERO, 0u32); count];
    let placements: Vec<Similarity> = scene.object_placement.iter().map(|m| m.at(time)).collect();
    let to_local: Vec<_> = placements.iter().map(Similarity::inverse).collect();
    for (t, tri) in scene.triangles.iter().enumerate() {
        let o = scene.object_of(t as u32) as usize;
        // Moving objects' triangles are in their own space already; a deforming object's
        // take their shape at `time` (each copy's at its own).
        let corners = if t >= scene.static_triangles {
            match scene.accel.find_deformed(t as u32, time) {
                Some(shape) => shape.v,
                None => tri.v,
            }
        } else {
            tri.v
                .map(|v| to_local[o].transform_point(v.as_dvec3()).as_vec3())
        };
        positions[o].extend(corners.iter().flat_map(|c| c.to_array()));
        let albedo = scene.material(t as u32).bsdf.albedo();
        colour[o] = (colour[o].0 + albedo, colour[o].1 + 1);
    }
    let sections = edit::objects(file.doc()).ok();
    let section = |o: usize| sections.and_then(|s| s.get(o));
    (0..count)
        .map(|o| {
            let (sum, n) = colour[o];
            let culls: Vec<Value> = scene
                .visibility
                .culls_of(o as u32, time)
                .into_iter()
                .map(|(frame, opening, sign, depth, radius)| {
                    json!({
                        "toLocal": frame.inverse().to_mat4().to_cols_array(),
                        "opening": opening,
                        "sign": sign,
                        "depth": depth,
                        "radius": radius,
                    })
                })
                .collect();
            let name = &scene.id_names[o];
            let carried = section(o).and_then(edit::carried);
            let target = Target::Object { name: name.clone() };
            json!({
                "name": name,
                "color": (sum / n.max(1) as f32).to_array(),
                "positions": positions[o],
                "placement": similarity(placements[o]),
                "instances": instances(scene, o as u32, time),
                "instanceNames": scene.instance_names(o as u32),
                "culls": culls,
                "seenByCamera": scene.visibility.object_seen(o as u32, RayClass::Camera),
                "seenThroughOpenings": scene.visibility.object_seen(o as u32, RayClass::ThroughPortal),
                "keys": edit::key_frames(file.doc(), &target),
                "placedBy": sections.map(|s| edit::transform_source(s, o)),
                "through": carried.and_then(|(opening, _)| shot.rig.find(opening)),
                "back": carried.is_some_and(|(_, back)| back),
            })
        })
        .collect()
}

/// Per opening: its name, here and there frames (position, quaternion x y z w, scale), its
/// teleport region's outline in its local XY plane, its opacity and time offset (seconds), the
/// opening it is paired with, and the keys of each frame.
fn openings(shot: &Shot, scene: &Scene, time: f64, file: &ShotFile) -> Vec<Value> {
    let portals = &scene.portals;
    (0..portals.len())
        .map(|i| {
            let name = &shot.rig.openings[i].name;
            let side = |side| Target::Opening {
                name: name.clone(),
                side,
            };
            let pair = match shot.rig.openings[i].there {
                ThereFrame::Paired(j) => Some(j),
                ThereFrame::Explicit(_) => None,
            };
            json!({
                "name": name,
                "here": similarity(portals.here(i, time)),
                "there": similarity(portals.there(i, time)),
                "outline": outline(portals.mask(i), time),
                "opacity": portals.look(i).opacity,
                "timeOffset": portals.look(i).time_offset,
                "pair": pair,
                "hereKeys": edit::key_frames(file.doc(), &side(Side::Here)),
                "thereKeys": edit::key_frames(file.doc(), &side(Side::There)),
            })
        })
        .collect()
}

/// A mask's outline at `time` as points in the opening's local XY plane.
fn outline(mask: &Mask, time: f64) -> Vec<[f64; 2]> {
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
        // The strands' inner envelope at the frame, as the renderer teleports inside it.
        Mask::Ring(boundary) => (0..RING_OUTLINE_POINTS)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / RING_OUTLINE_POINTS as f64;
                let direction = glam::DVec2::new(a.cos(), a.sin());
                let r = boundary.radius(direction, time);
                [r * direction.x, r * direction.y]
            })
            .collect(),
    }
}

/// The most line segments a ring is drawn with: a ring's strands run to a hundred thousand
/// segments, which software WebGL would draw at a few frames a second at every level of
/// openings; joined k at a time along each strand they look the same at preview sizes.
const MAX_RING_SEGMENTS: usize = 6000;

/// The rings' strands at `time`, per ring: the opening it belongs to (by index) and its
/// segments' end points, flattened, with their colour (consecutive segments of a strand joined
/// so a ring has at most [`MAX_RING_SEGMENTS`]).
fn strands(shot: &Shot, scene: &Scene, time: f64) -> Vec<Value> {
    let strands = &scene.strands;
    let rings = scene.id_names.len() - scene.object_count as usize;
    let mut segments: Vec<Vec<u32>> = vec![Vec::new(); rings];
    for i in strands.strand_order() {
        segments[strands.segment_ring[i as usize] as usize].push(i);
    }
    (0..rings)
        .map(|ring| {
            let (points, colors) = joined(scene, &segments[ring], time);
            // Rings are named "<opening>/ring", as Cryptomatte lists them.
            let name = &scene.id_names[scene.object_count as usize + ring];
            let opening = name.strip_suffix("/ring").and_then(|o| shot.rig.find(o));
            json!({ "opening": opening, "points": points, "colors": colors })
        })
        .collect()
}

/// A ring's segments (in strand order) at `time` as flattened end points and colours, every
/// run of k consecutive segments of a strand drawn as one.
fn joined(scene: &Scene, segments: &[u32], time: f64) -> (Vec<f64>, Vec<f64>) {
    let strands = &scene.strands;
    let k = segments.len().div_ceil(MAX_RING_SEGMENTS).max(1);
    let (mut points, mut colors) = (Vec::new(), Vec::new());
    let mut emit = |a: Vec3, b: Vec3, segment: u32| {
        // A tenth of a millimetre and a thousandth of a colour are plenty to draw, and keep
        // the JSON small.
        points.extend(
            a.to_array()
                .into_iter()
                .chain(b.to_array())
                .map(|x| rounded(x, 1e4)),
        );
        let c = strands.radiance(segment, 0.5);
        let c = c / c.max_element().max(1e-6);
        colors.extend(c.to_array().map(|x| rounded(x, 1e3)));
    };
    // The run being joined: where it starts, its last segment and end, and its length.
    let mut run: Option<(Vec3, u32, Vec3, usize)> = None;
    for &i in segments {
        let cone = strands.world_segment(i, time);
        run = Some(match run {
            // The strand goes on from the run's end.
            Some((start, _, end, n)) if end.distance(cone.a) <= 1e-5 * (1.0 + end.length()) => {
                (start, i, cone.b, n + 1)
            }
            Some((start, last, end, _)) => {
                emit(start, end, last);
                (cone.a, i, cone.b, 1)
            }
            None => (cone.a, i, cone.b, 1),
        });
        if let Some((start, last, end, n)) = run
            && n == k
        {
            emit(start, end, last);
            run = None;
        }
    }
    if let Some((start, last, end, _)) = run {
        emit(start, end, last);
    }
    (points, colors)
}

/// `x` rounded to `1/per`, as f64 so it prints as short as it is.
fn rounded(x: f32, per: f64) -> f64 {
    (x as f64 * per).round() / per
}
