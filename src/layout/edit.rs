//! Edits made in the layout page, applied to the shot file's TOML with its comments and layout
//! kept (toml_edit): a pose set at a frame (a key where the transform is keyed, or where the
//! page asks for one), a key deleted, and a here-side copy placed by the inverse solver.
//!
//! Poses arrive in world space. Where they are written depends on the target: the camera's
//! `[camera.transform]`; an opening's `here`, or its `there` (a paired opening's there frame is
//! its partner's here frame turned half a turn, so that is what changes); an object's
//! `transform`, or for a solver-placed copy the transform it is placed by (its own, else its
//! source's), solved back through its opening (own = T⁻¹·world, or T·world for a copy carried
//! back).

use glam::{DQuat, DVec3, EulerRot};
use rift_render::rift_fx::Shot;
use rift_render::rift_fx::rig::{Similarity, solve_here, solve_there};
use serde::Deserialize;
use toml_edit::{Array, ArrayOfTables, DocumentMut, InlineTable, Item, Table, TableLike, Value};

/// What an edit changes.
#[derive(Debug, Deserialize, Clone, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Target {
    Camera,
    Object { name: String },
    Opening { name: String, side: Side },
}

impl std::fmt::Display for Target {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Target::Camera => write!(f, "camera"),
            Target::Object { name } => write!(f, "object {name:?}"),
            Target::Opening { name, side } => write!(
                f,
                "opening {name:?} ({})",
                if *side == Side::Here { "here" } else { "there" }
            ),
        }
    }
}

/// An opening's two frames.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    Here,
    There,
}

/// One edit from the page.
#[derive(Debug, Deserialize, Clone)]
#[serde(tag = "op", rename_all = "snake_case", deny_unknown_fields)]
pub enum Edit {
    /// Poses `target` at `frame`, in world space: a rotation (quaternion x, y, z, w) or, for
    /// the camera, a point it looks at (and its up); the scale stays unless given. A keyed
    /// transform gets (or changes) its key at the frame; a still one changes, or with `key`
    /// becomes keyed.
    Pose {
        target: Target,
        frame: i64,
        position: [f64; 3],
        rotation: Option<[f64; 4]>,
        look_at: Option<[f64; 3]>,
        up: Option<[f64; 3]>,
        scale: Option<f64>,
        #[serde(default)]
        key: bool,
    },
    /// Deletes `target`'s key at `frame`.
    DeleteKey { target: Target, frame: i64 },
    /// Adds the here-side copy of object `object` back through opening `opening` (the inverse
    /// solver), a locator no ray sees, for rigs on the here side that reach through; checked
    /// at `frame`.
    CopyBack {
        object: String,
        opening: String,
        frame: i64,
    },
}

impl Edit {
    /// The frame the edit is made (and checked) at.
    pub fn frame(&self) -> i64 {
        match self {
            Edit::Pose { frame, .. }
            | Edit::DeleteKey { frame, .. }
            | Edit::CopyBack { frame, .. } => *frame,
        }
    }

    /// What the edit changes, for messages.
    pub fn what(&self) -> String {
        match self {
            Edit::Pose { target, .. } | Edit::DeleteKey { target, .. } => target.to_string(),
            Edit::CopyBack { object, .. } => format!("object {object:?}"),
        }
    }

    /// The target and the world pose asked for, to check the edit lands there.
    pub fn asked_pose(&self) -> Option<(&Target, DVec3)> {
        match self {
            Edit::Pose {
                target, position, ..
            } => Some((target, DVec3::from_array(*position))),
            _ => None,
        }
    }
}

/// Applies `edit` to `doc`, the text of `shot` (which gives the rig and frame rate).
pub fn apply(doc: &mut DocumentMut, edit: &Edit, shot: &Shot) -> Result<(), String> {
    match edit {
        Edit::Pose {
            target,
            frame,
            position,
            rotation,
            look_at,
            up,
            scale,
            key,
        } => {
            let (holder, solve) = pose_holder(doc, target, shot, *frame)?;
            let world = Similarity::new(
                rotation.map_or(DQuat::IDENTITY, DQuat::from_array),
                DVec3::from_array(*position),
                scale.unwrap_or(1.0),
            );
            let orientation = match look_at {
                Some(at) => Orientation::LookAt {
                    target: *at,
                    up: *up,
                },
                None if rotation.is_some() => Orientation::Rotation,
                None => {
                    return Err("the pose needs `rotation` (or, for the camera, `look_at`)".into());
                }
            };
            if look_at.is_some() && !matches!(solve, Solve::AsIs) {
                return Err("`look_at` cannot pose what the solver places: give `rotation`".into());
            }
            let pose = Pose {
                similarity: solve.apply(&world),
                orientation,
                scale: scale.is_some(),
                facing_back: matches!(target, Target::Camera),
            };
            let transform = pose_item(doc, &holder)?;
            set_pose(transform, *frame, &pose, *key)
        }
        Edit::DeleteKey { target, frame } => {
            let (holder, _) = locate(doc, target)?;
            delete_key(pose_item(doc, &holder)?, *frame)
        }
        Edit::CopyBack {
            object, opening, ..
        } => copy_back(doc, object, opening, shot),
    }
}

/// Where a target's pose is written.
#[derive(Debug, Clone)]
enum Holder {
    Camera,
    /// `[[object]]` number i's `transform`.
    Object(usize),
    /// `[[portal]]` number i's `here` or `there`.
    Opening(usize, Side),
}

impl Holder {
    /// The key of its table that holds the pose.
    fn key(&self) -> &'static str {
        match self {
            Holder::Opening(_, Side::Here) => "here",
            Holder::Opening(_, Side::There) => "there",
            Holder::Camera | Holder::Object(_) => "transform",
        }
    }
}

/// How a world pose becomes the pose written.
enum Solve {
    AsIs,
    /// Through an opening: own = T⁻¹·world.
    Here(Similarity),
    /// Back through an opening: own = T·world.
    There(Similarity),
    /// A paired opening's there frame, written as its partner's here frame.
    Partner,
}

impl Solve {
    fn apply(&self, world: &Similarity) -> Similarity {
        match self {
            Solve::AsIs => *world,
            Solve::Here(teleport) => solve_here(teleport, world),
            Solve::There(teleport) => solve_there(teleport, world),
            Solve::Partner => world.compose(&Similarity::half_turn_y()),
        }
    }
}

/// Where `target`'s pose is written, and what places it there from that pose.
enum Placed<'a> {
    AsIs,
    /// By the solver, through (or back through, `true`) the named opening.
    Carried(&'a str, bool),
    /// As its paired partner's here frame, turned.
    Partner,
}

/// The pose that holds `target`, and what places the target from it.
fn locate<'a>(doc: &'a DocumentMut, target: &Target) -> Result<(Holder, Placed<'a>), String> {
    match target {
        Target::Camera => match doc.get("camera").and_then(|c| c.get("usd")) {
            Some(prim) => Err(format!(
                "the camera is the USD camera {}: move it in the layer that holds it",
                prim.to_string().trim()
            )),
            None => Ok((Holder::Camera, Placed::AsIs)),
        },
        Target::Opening { name, side } => {
            let i = portal_index(doc, name)?;
            let portal = portals(doc)?.get(i).expect("an index found above");
            match (side, portal.contains_key("there"), portal.get("pair")) {
                (Side::Here, _, _) | (Side::There, true, _) => {
                    Ok((Holder::Opening(i, *side), Placed::AsIs))
                }
                (Side::There, false, Some(pair)) => {
                    let partner = pair.as_str().ok_or("pair: expected a name")?;
                    let j = portal_index(doc, partner)?;
                    Ok((Holder::Opening(j, Side::Here), Placed::Partner))
                }
                (Side::There, false, None) => {
                    Err(format!("opening {name:?} has neither `there` nor `pair`"))
                }
            }
        }
        Target::Object { name } => {
            let objects = objects(doc)?;
            let i = object_index(objects, name)?;
            let placed = match carried(objects.get(i).expect("an index found above")) {
                None => Placed::AsIs,
                Some((opening, back)) => Placed::Carried(opening, back),
            };
            Ok((Holder::Object(transform_source(objects, i)), placed))
        }
    }
}

/// The pose that holds `target` and how a world pose at `frame` maps to it.
fn pose_holder(
    doc: &DocumentMut,
    target: &Target,
    shot: &Shot,
    frame: i64,
) -> Result<(Holder, Solve), String> {
    let (holder, placed) = locate(doc, target)?;
    let solve = match placed {
        Placed::AsIs => Solve::AsIs,
        Placed::Partner => Solve::Partner,
        Placed::Carried(opening, back) => {
            let k = shot
                .rig
                .find(opening)
                .ok_or_else(|| format!("no portal opening is called {opening:?}"))?;
            if time_offset(doc, k) != 0.0 {
                return Err(format!(
                    "it is shown through {opening:?}, whose time offset shows it at another \
                     time: move what it copies instead"
                ));
            }
            let teleport = shot.rig.teleport_at(k, shot.time_of(frame as f64));
            if back {
                Solve::There(teleport)
            } else {
                Solve::Here(teleport)
            }
        }
    };
    Ok((holder, solve))
}

/// The frames of the keys of the transform that places `target` (`None`: it has none, a still
/// pose or none at all).
pub fn key_frames(doc: &DocumentMut, target: &Target) -> Option<Vec<i64>> {
    let (holder, _) = locate(doc, target).ok()?;
    let table: &dyn TableLike = match holder {
        Holder::Camera => doc.get("camera")?.as_table_like()?,
        Holder::Object(i) => objects(doc).ok()?.get(i)?,
        Holder::Opening(i, _) => portals(doc).ok()?.get(i)?,
    };
    let keys = table
        .get(holder.key())?
        .as_table_like()?
        .get("keys")?
        .as_array()?;
    Some(keys.iter().filter_map(frame_of).collect())
}

/// The `[[portal]]` tables.
fn portals(doc: &DocumentMut) -> Result<&ArrayOfTables, String> {
    doc.get("portal")
        .and_then(Item::as_array_of_tables)
        .ok_or_else(|| "the shot has no [[portal]]".to_string())
}

/// The `[[object]]` tables.
pub fn objects(doc: &DocumentMut) -> Result<&ArrayOfTables, String> {
    doc.get("object")
        .and_then(Item::as_array_of_tables)
        .ok_or_else(|| "the shot has no [[object]]".to_string())
}

fn name_of(table: &Table) -> Option<&str> {
    table.get("name").and_then(Item::as_str)
}

fn portal_index(doc: &DocumentMut, name: &str) -> Result<usize, String> {
    portals(doc)?
        .iter()
        .position(|t| name_of(t) == Some(name))
        .ok_or_else(|| format!("no portal opening is called {name:?}"))
}

fn object_index(objects: &ArrayOfTables, name: &str) -> Result<usize, String> {
    objects
        .iter()
        .position(|t| name_of(t) == Some(name))
        .ok_or_else(|| format!("no object is called {name:?}"))
}

/// The opening an object is carried through by the solver, and whether back.
pub fn carried(object: &Table) -> Option<(&str, bool)> {
    let through = object.get("through").and_then(Item::as_str);
    let back = object.get("back_through").and_then(Item::as_str);
    through.map(|o| (o, false)).or(back.map(|o| (o, true)))
}

/// The object whose `transform` object `i` is placed by: itself when it has one, else what it
/// is a copy of (the first in the chain with a transform, else the chain's start).
pub fn transform_source(objects: &ArrayOfTables, mut i: usize) -> usize {
    for _ in 0..objects.len() {
        let table = objects.get(i).expect("an index into the objects");
        if table.contains_key("transform") {
            return i;
        }
        let source = table.get("copy_of").and_then(Item::as_str);
        match source.and_then(|s| object_index(objects, s).ok()) {
            Some(j) => i = j,
            None => return i,
        }
    }
    i
}

/// Opening `k`'s time offset (frames) as its `[portal.surface]` gives it.
pub fn time_offset(doc: &DocumentMut, k: usize) -> f64 {
    portals(doc)
        .ok()
        .and_then(|p| p.get(k))
        .and_then(|t| t.get("surface"))
        .and_then(|s| s.get("time_offset"))
        .and_then(Item::as_value)
        .and_then(real)
        .unwrap_or(0.0)
}

/// The table-like pose (a static pose, or `keys` and `interpolation`) of a holder, made empty
/// where there was none.
fn pose_item<'a>(doc: &'a mut DocumentMut, holder: &Holder) -> Result<&'a mut Item, String> {
    let key = holder.key();
    let parent: &mut dyn TableLike = match holder {
        Holder::Camera => doc
            .get_mut("camera")
            .and_then(Item::as_table_like_mut)
            .ok_or("the shot has no [camera]")?,
        Holder::Object(i) => doc
            .get_mut("object")
            .and_then(Item::as_array_of_tables_mut)
            .and_then(|a| a.get_mut(*i))
            .ok_or("no such object")?,
        Holder::Opening(i, _) => doc
            .get_mut("portal")
            .and_then(Item::as_array_of_tables_mut)
            .and_then(|a| a.get_mut(*i))
            .ok_or("no such opening")?,
    };
    if parent.get(key).is_none() {
        parent.insert(key, Item::Value(Value::InlineTable(InlineTable::new())));
    }
    let item = parent.get_mut(key).expect("inserted above");
    if item.as_table_like().is_none() {
        return Err(format!("{key}: expected a table"));
    }
    Ok(item)
}

/// How a pose's orientation is written.
#[derive(Clone, Copy)]
enum Orientation {
    /// As the rotation of the pose (in the style of the pose it replaces).
    Rotation,
    /// As a point looked at, with an up direction when given.
    LookAt {
        target: [f64; 3],
        up: Option<[f64; 3]>,
    },
}

/// A pose to write.
struct Pose {
    similarity: Similarity,
    orientation: Orientation,
    /// The scale was given (else the pose keeps the scale it had).
    scale: bool,
    /// It looks down its −Z (a camera), not +Z.
    facing_back: bool,
}

/// The keys a pose may hold, all replaced when it is written.
const POSE_KEYS: [&str; 7] = [
    "position",
    "rotation_degrees",
    "quaternion",
    "look_at",
    "up",
    "scale",
    "matrix",
];

/// Writes `pose` into a transform at `frame`: its key there (added in frame order where it
/// has none) when keyed, else the still pose (or, with `key`, a first key).
fn set_pose(transform: &mut Item, frame: i64, pose: &Pose, key: bool) -> Result<(), String> {
    let table = transform.as_table_like_mut().expect("checked by pose_item");
    if let Some(keys) = table.get_mut("keys") {
        let keys = keys
            .as_array_mut()
            .ok_or("keys: expected an array of keys")?;
        return set_key(keys, frame, pose);
    }
    if !key {
        let style = Style::of(&*table);
        write_pose(table, pose, style);
        return Ok(());
    }
    let style = Style::of(&*table);
    for k in POSE_KEYS {
        table.remove(k);
    }
    let mut first = InlineTable::new();
    first.insert("frame", frame.into());
    write_pose(&mut first, pose, style);
    let mut keys = Array::new();
    keys.push_formatted(Value::InlineTable(first).decorated("\n  ", ""));
    keys.set_trailing(",\n");
    table.insert("keys", Item::Value(Value::Array(keys)));
    Ok(())
}

/// Sets (or adds, in frame order) the key at `frame` of a `keys` array of inline tables.
fn set_key(keys: &mut Array, frame: i64, pose: &Pose) -> Result<(), String> {
    let at = keys
        .iter()
        .position(|v| frame_of(v).is_some_and(|f| f >= frame))
        .unwrap_or(keys.len());
    if let Some(existing) = keys.get_mut(at).filter(|v| frame_of(v) == Some(frame)) {
        let key = existing
            .as_inline_table_mut()
            .ok_or("keys: expected inline tables")?;
        let style = Style::of(&*key);
        write_pose(key, pose, style);
        return Ok(());
    }
    // Written in the style of its neighbour, and laid out like it (one key per line, as shots
    // write them).
    let neighbour = keys.get(at.min(keys.len().saturating_sub(1)));
    let style = neighbour
        .and_then(Value::as_inline_table)
        .map_or(Style::default(), |t| Style::of(t));
    let mut key = InlineTable::new();
    key.insert("frame", frame.into());
    write_pose(&mut key, pose, style);
    let mut key = Value::InlineTable(key);
    // What precedes the key it goes before (a comment ending the line above, a newline and
    // the indentation) now precedes the new key, which that one follows on a line of its own.
    let decor_text =
        |d: Option<&toml_edit::RawString>| d.and_then(|p| p.as_str()).unwrap_or(" ").to_owned();
    let line_start = |text: &str| match text.rfind('\n') {
        Some(i) => text[i..].to_owned(),
        None => " ".to_owned(),
    };
    if at < keys.len() {
        let before = decor_text(keys.get(at).and_then(|v| v.decor().prefix()));
        key.decor_mut().set_prefix(before.clone());
        if let Some(next) = keys.get_mut(at) {
            next.decor_mut().set_prefix(line_start(&before));
        }
    } else {
        let last = decor_text(
            keys.get(at.wrapping_sub(1))
                .and_then(|v| v.decor().prefix()),
        );
        let trailing = keys.trailing().as_str().unwrap_or("").to_owned();
        match trailing.rfind('\n') {
            Some(i) => {
                key.decor_mut()
                    .set_prefix(format!("{}{}", &trailing[..i], line_start(&last)));
                keys.set_trailing(&trailing[i..]);
            }
            None => key.decor_mut().set_prefix(line_start(&last)),
        }
    }
    keys.insert_formatted(at, key);
    Ok(())
}

/// A TOML number, integer or float, as a float.
fn real(v: &Value) -> Option<f64> {
    v.as_float().or(v.as_integer().map(|i| i as f64))
}

fn frame_of(v: &Value) -> Option<i64> {
    let frame = v.as_inline_table()?.get("frame")?;
    frame.as_integer().or(frame
        .as_float()
        .filter(|f| f.fract() == 0.0)
        .map(|f| f as i64))
}

/// Deletes the key at `frame` of a keyed transform (never its last: a keyed transform needs
/// one; set a still pose instead).
fn delete_key(transform: &mut Item, frame: i64) -> Result<(), String> {
    let table = transform.as_table_like_mut().expect("checked by pose_item");
    let Some(keys) = table.get_mut("keys").and_then(Item::as_array_mut) else {
        return Err("it has no keys, only a still pose".into());
    };
    let at = keys
        .iter()
        .position(|v| frame_of(v) == Some(frame))
        .ok_or_else(|| format!("it has no key at frame {frame}"))?;
    if keys.len() == 1 {
        return Err(format!(
            "the key at frame {frame} is its only one (a keyed transform needs one)"
        ));
    }
    keys.remove(at);
    Ok(())
}

/// How the pose being replaced wrote its orientation and scale, so an edit keeps the file's
/// style.
#[derive(Clone, Copy, Default)]
struct Style {
    orientation: Written,
    /// It gives a scale (or a matrix, which holds one).
    scale: bool,
    /// The scale it gives.
    scale_value: Option<f64>,
    /// The distance to the point looked at.
    look_distance: Option<f64>,
}

#[derive(Clone, Copy, Default, PartialEq)]
enum Written {
    #[default]
    Degrees,
    Quaternion,
    LookAt,
}

impl Style {
    fn of(pose: &dyn TableLike) -> Self {
        let vector = |k: &str| -> Option<DVec3> {
            let a = pose.get(k)?.as_array()?;
            let v: Vec<f64> = a.iter().filter_map(real).collect();
            (v.len() == 3).then(|| DVec3::new(v[0], v[1], v[2]))
        };
        let orientation = if pose.contains_key("look_at") {
            Written::LookAt
        } else if pose.contains_key("quaternion") || pose.contains_key("matrix") {
            Written::Quaternion
        } else {
            Written::Degrees
        };
        let look_distance = vector("look_at")
            .map(|at| (at - vector("position").unwrap_or(DVec3::ZERO)).length())
            .filter(|d| *d > 1e-6);
        let scale_value = pose.get("scale").and_then(Item::as_value).and_then(real);
        Self {
            orientation,
            scale: pose.contains_key("scale") || pose.contains_key("matrix"),
            scale_value,
            look_distance,
        }
    }
}

/// Replaces a pose's keys with `pose`, written in `style`.
fn write_pose(table: &mut dyn TableLike, pose: &Pose, style: Style) {
    for k in POSE_KEYS {
        table.remove(k);
    }
    let s = &pose.similarity;
    let put = |table: &mut dyn TableLike, k: &str, v: Value| {
        table.insert(k, Item::Value(v));
    };
    put(table, "position", vector(s.translation.to_array(), 1e6));
    match (pose.orientation, style.orientation) {
        (Orientation::LookAt { target, up }, _) => {
            put(table, "look_at", vector(target, 1e6));
            if let Some(up) = up {
                put(table, "up", vector(up, 1e6));
            }
        }
        (Orientation::Rotation, Written::LookAt) => {
            let facing = if pose.facing_back {
                -DVec3::Z
            } else {
                DVec3::Z
            };
            let forward = s.rotation * facing;
            let target = s.translation + forward * style.look_distance.unwrap_or(1.0);
            put(table, "look_at", vector(target.to_array(), 1e6));
            // `up` only where +Y would not give the same roll.
            let up = s.rotation * DVec3::Y;
            let right = s.rotation * DVec3::X;
            if right.y.abs() > 1e-9 || up.y <= 0.0 {
                put(table, "up", vector(up.to_array(), 1e6));
            }
        }
        (Orientation::Rotation, Written::Quaternion) => {
            let q = s.rotation.normalize();
            let q = if q.w < 0.0 { -q } else { q };
            put(table, "quaternion", vector(q.to_array(), 1e9));
        }
        (Orientation::Rotation, Written::Degrees) => {
            let (z, y, x) = s.rotation.to_euler(EulerRot::ZYX);
            let degrees = [x, y, z].map(f64::to_degrees);
            put(table, "rotation_degrees", vector(degrees, 1e6));
        }
    }
    let scale = if pose.scale {
        Some(s.scale)
    } else {
        style.scale_value
    };
    if let Some(scale) = scale.filter(|v| style.scale || (v - 1.0).abs() > 1e-9) {
        put(table, "scale", number(scale, 1e9));
    }
}

/// A number rounded to `1/per` (as a person would write it; −0 written as 0).
fn number(x: f64, per: f64) -> Value {
    let x = (x * per).round() / per;
    Value::from(if x == 0.0 { 0.0 } else { x })
}

fn vector<const N: usize>(v: [f64; N], per: f64) -> Value {
    Value::Array(v.iter().map(|&x| number(x, per)).collect())
}

/// Adds `[[object]]` `<object>_here` (or the first free name like it): a copy of `object` back
/// through `opening`, seen by no ray.
fn copy_back(
    doc: &mut DocumentMut,
    object: &str,
    opening: &str,
    shot: &Shot,
) -> Result<(), String> {
    let objects = objects(doc)?;
    let i = object_index(objects, object)?;
    // A copy starts from its source's own transform, so a copy of what the solver already
    // places would not land where that is: its here-side counterpart is what it copies.
    if let Some((through, _)) = carried(objects.get(i).expect("an index found above")) {
        return Err(format!(
            "it is already placed by the solver through {through:?}; copy the object it is a \
             copy of instead"
        ));
    }
    if shot.rig.find(opening).is_none() {
        return Err(format!("no portal opening is called {opening:?}"));
    }
    let taken = |n: &str| objects.iter().any(|t| name_of(t) == Some(n));
    let name = std::iter::once(format!("{object}_here"))
        .chain((2..).map(|k| format!("{object}_here{k}")))
        .find(|n| !taken(n))
        .expect("a free name");
    let mut table = Table::new();
    table.insert("name", toml_edit::value(name));
    table.insert("copy_of", toml_edit::value(object));
    table.insert("back_through", toml_edit::value(opening));
    let mut hidden = InlineTable::new();
    for ray in ["camera", "through_portal", "indirect", "shadow"] {
        hidden.insert(ray, false.into());
    }
    table.insert("visibility", toml_edit::value(hidden));
    table.decor_mut().set_prefix(
        "\n# the here-side copy of a there-side target (rift layout's inverse solver)\n",
    );
    // At the end of the file (a table without a position is written last).
    doc.get_mut("object")
        .and_then(Item::as_array_of_tables_mut)
        .expect("found above")
        .push(table);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    const SHOT: &str = r#"# a shot to edit
[shot]
name = "edits"
fps = 24.0
frames = [1, 24]

[camera]
resolution = [64, 36]
fov_degrees = 40.0
[camera.transform]
keys = [
  { frame = 1, position = [0.0, 1.0, 5.0], look_at = [0.0, 1.0, 0.0] },   # start
  { frame = 24, position = [1.0, 1.0, 5.0], look_at = [0.0, 1.0, 0.0] },
]

[[object]]
name = "ball"                 # the hero
mesh = "ball.obj"
transform = { position = [1.0, 0.0, 0.0], rotation_degrees = [0.0, 30.0, 0.0], scale = 0.5 }

[[object]]
name = "ball_there"
copy_of = "ball"
through = "door"

[[portal]]
name = "door"
here = { position = [0.0, 1.0, 0.0] }
pair = "exit"

[[portal]]
name = "exit"
here = { position = [5.0, 1.0, -3.0], rotation_degrees = [0.0, 90.0, 0.0] }
pair = "door"
"#;

    fn shot(text: &str) -> Shot {
        Shot::parse(text, Path::new("edits.toml")).unwrap()
    }

    fn edited(edit: Edit) -> Result<String, String> {
        let mut doc: DocumentMut = SHOT.parse().unwrap();
        apply(&mut doc, &edit, &shot(SHOT))?;
        Ok(doc.to_string())
    }

    fn pose(target: Target, frame: i64, position: [f64; 3], rotation: [f64; 4]) -> Edit {
        Edit::Pose {
            target,
            frame,
            position,
            rotation: Some(rotation),
            look_at: None,
            up: None,
            scale: None,
            key: false,
        }
    }

    fn object(name: &str) -> Target {
        Target::Object { name: name.into() }
    }

    /// The lines of `after` that `before` does not have.
    fn added(before: &str, after: &str) -> Vec<String> {
        let old: Vec<&str> = before.lines().collect();
        after
            .lines()
            .filter(|l| !old.contains(l))
            .map(str::to_owned)
            .collect()
    }

    #[test]
    fn a_still_pose_changes_in_its_own_style_and_keeps_its_scale_and_comments() {
        let q = DQuat::from_rotation_y(45f64.to_radians()).to_array();
        let text = edited(pose(object("ball"), 12, [2.0, 0.0, -1.0], q)).unwrap();
        assert_eq!(
            added(SHOT, &text),
            [
                "transform = { position = [2.0, 0.0, -1.0], rotation_degrees = [0.0, 45.0, 0.0], \
                 scale = 0.5 }"
            ]
        );
        assert!(text.contains("name = \"ball\"                 # the hero"));
    }

    #[test]
    fn keys_are_set_added_in_frame_order_and_deleted() {
        let camera = |frame| Edit::Pose {
            target: Target::Camera,
            frame,
            position: [0.5, 1.0, 5.0],
            rotation: None,
            look_at: Some([0.0, 1.0, 0.0]),
            up: None,
            scale: None,
            key: false,
        };
        let text = edited(camera(12)).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let at = lines.iter().position(|l| l.contains("frame = 12")).unwrap();
        assert_eq!(
            lines[at],
            "  { frame = 12, position = [0.5, 1.0, 5.0], look_at = [0.0, 1.0, 0.0] },"
        );
        assert!(lines[at - 1].contains("frame = 1,") && lines[at + 1].contains("frame = 24"));
        // The comment ending key 1's line stays there.
        assert!(lines[at - 1].ends_with("# start"), "{text}");
        let text = edited(camera(30)).unwrap();
        assert!(
            text.contains(
                "[0.0, 1.0, 0.0] },\n  { frame = 30, position = [0.5, 1.0, 5.0], look_at = \
                 [0.0, 1.0, 0.0] },\n]"
            ),
            "{text}"
        );
        // Setting an existing key changes it in place, its comment kept.
        let text = edited(camera(1)).unwrap();
        assert!(text.contains(
            "  { frame = 1, position = [0.5, 1.0, 5.0], look_at = [0.0, 1.0, 0.0] },   # start"
        ));
        let delete = |frame| Edit::DeleteKey {
            target: Target::Camera,
            frame,
        };
        let text = edited(delete(24)).unwrap();
        assert!(!text.contains("frame = 24") && text.contains("frame = 1,"));
        assert!(
            edited(delete(12))
                .unwrap_err()
                .contains("no key at frame 12")
        );
        // A still pose has no key to delete; a keyed one keeps its last.
        let err = edited(Edit::DeleteKey {
            target: object("ball"),
            frame: 1,
        });
        assert!(err.unwrap_err().contains("still pose"));
        let mut doc: DocumentMut = SHOT.parse().unwrap();
        apply(&mut doc, &delete(24), &shot(SHOT)).unwrap();
        let err = apply(&mut doc, &delete(1), &shot(SHOT)).unwrap_err();
        assert!(err.contains("only one"), "{err}");
    }

    #[test]
    fn a_key_on_a_still_pose_makes_it_keyed() {
        let Edit::Pose {
            target,
            position,
            rotation,
            ..
        } = pose(object("ball"), 7, [1.0, 2.0, 3.0], [0.0, 0.0, 0.0, 1.0])
        else {
            unreachable!()
        };
        let text = edited(Edit::Pose {
            target,
            frame: 7,
            position,
            rotation,
            look_at: None,
            up: None,
            scale: None,
            key: true,
        })
        .unwrap();
        let shot = shot(&text.replace("mesh = \"ball.obj\"\n", ""));
        assert!(text.contains("transform = { keys = [\n  { frame = 7, position = [1.0, 2.0, 3.0]"));
        assert_eq!(shot.name, "edits", "{text}");
    }

    #[test]
    fn a_copy_moved_moves_its_source_solved_back_through_the_opening() {
        let shot = shot(SHOT);
        let time = shot.time_of(12.0);
        let teleport = shot.rig.teleport_at(0, time);
        let world = Similarity::new(DQuat::from_rotation_y(0.3), DVec3::new(6.0, 0.5, -2.0), 0.5);
        let text = edited(Edit::Pose {
            target: object("ball_there"),
            frame: 12,
            position: world.translation.to_array(),
            rotation: Some(world.rotation.to_array()),
            look_at: None,
            up: None,
            scale: Some(0.5),
            key: false,
        })
        .unwrap();
        // The source's transform changed to T⁻¹·world, in its own style.
        let own = solve_here(&teleport, &world);
        let doc: DocumentMut = text.parse().unwrap();
        let ball = objects(&doc).unwrap().get(0).unwrap();
        let position: Vec<f64> = ball["transform"]["position"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_float().unwrap())
            .collect();
        assert!(
            (DVec3::from_slice(&position) - own.translation).length() < 1e-5,
            "{position:?} {own:?}"
        );
        assert!(
            !objects(&doc)
                .unwrap()
                .get(1)
                .unwrap()
                .contains_key("transform")
        );
    }

    #[test]
    fn a_paired_there_frame_is_written_as_its_partners_here_frame() {
        let there = Target::Opening {
            name: "door".into(),
            side: Side::There,
        };
        // door's there frame is exit's here frame turned half a turn: asking for exit's
        // current frame turned gives exit's frame back, moved.
        let shot = shot(SHOT);
        let current = shot.rig.there_at(0, 0.0);
        let text = edited(pose(
            there,
            12,
            [5.0, 1.0, -4.0],
            current.rotation.to_array(),
        ))
        .unwrap();
        assert_eq!(
            added(SHOT, &text),
            ["here = { position = [5.0, 1.0, -4.0], rotation_degrees = [0.0, 90.0, 0.0] }"]
        );
    }

    #[test]
    fn the_inverse_solver_adds_a_hidden_here_side_copy_with_a_free_name() {
        let copy = || Edit::CopyBack {
            object: "ball".into(),
            opening: "door".into(),
            frame: 1,
        };
        let mut doc: DocumentMut = SHOT.parse().unwrap();
        apply(&mut doc, &copy(), &shot(SHOT)).unwrap();
        apply(&mut doc, &copy(), &shot(SHOT)).unwrap();
        let text = doc.to_string();
        // After the last object, with a comment that says what it is.
        assert!(
            text.contains(
                "shadow = false }\n\n# the here-side copy of a there-side target (rift layout's \
             inverse solver)\n[[object]]\nname = \"ball_here2\"\ncopy_of = \"ball\"\n\
             back_through = \"door\"\nvisibility = { camera = false, through_portal = false, \
             indirect = false, shadow = false }\n\n[[portal]]"
            ),
            "{text}"
        );
        assert!(text.contains("name = \"ball_here\"\n"));
        let bad = Edit::CopyBack {
            object: "nothing".into(),
            opening: "door".into(),
            frame: 1,
        };
        assert!(edited(bad).unwrap_err().contains("no object"));
        let placed = Edit::CopyBack {
            object: "ball_there".into(),
            opening: "door".into(),
            frame: 1,
        };
        assert!(
            edited(placed)
                .unwrap_err()
                .contains("already placed by the solver")
        );
    }
}
