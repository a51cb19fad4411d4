//! `[[light]]` sections into the lights a lighter places: shape lights (point, spot, rect,
//! disk) and distant lights, with UsdLux's units and defaults. Every key a kind does not take
//! is refused by name.

use super::light_groups::LightGroups;
use super::schema::{LightKind, LightSection, VisibilitySection};
use super::{Entry, optional, parse};
use crate::error::{RenderError, key_error};
use crate::lights::{Cone, Shape, ShapeLight, Sun};
use crate::portals::Flags;
use glam::Vec3;
use rift_fx::rig::{AnimatedTransform, Similarity};
use rift_fx::shot::check;
use rift_fx::shot::pose::{self, Facing};
use rift_fx::{Invalid, Shot};

/// The lights of `entries` (the shot's `[[light]]`s, then those USD layers bring): shape
/// lights and distant lights, in order; each names its light group in `groups`.
pub(super) fn lights(
    shot: &Shot,
    entries: &[Entry],
    groups: &mut LightGroups,
) -> Result<(Vec<ShapeLight>, Vec<Sun>), RenderError> {
    let (mut shapes, mut suns) = (Vec::new(), Vec::new());
    let mut names: Vec<String> = Vec::new();
    for Entry { file, key, table } in entries {
        let section: LightSection = parse(file, key, table)?;
        if names.contains(&section.name) {
            return Err(key_error(
                file,
                format!("{key}.name"),
                format!("another light is already called {:?}", section.name),
            ));
        }
        names.push(section.name.clone());
        let group = groups.index(
            file,
            &format!("{key}.light_group"),
            section.light_group.as_deref(),
        )?;
        let light =
            light(shot, key, &section, group).map_err(|e| RenderError::Shot(e.in_file(file)))?;
        match light {
            Light::Shape(l) => shapes.push(l),
            Light::Sun(s) => suns.push(s),
        }
    }
    Ok((shapes, suns))
}

/// One light, of either kind.
enum Light {
    Shape(ShapeLight),
    Sun(Sun),
}

/// The light of section `s` (at `key`).
fn light(shot: &Shot, key: &str, s: &LightSection, group: u8) -> Result<Light, Invalid> {
    let k = |name: &str| format!("{key}.{name}");
    refuse_foreign_keys(key, s)?;
    let color = optional(s.color, Vec3::ONE, |c| {
        check::color(&k("color"), c).map(|c| c.as_vec3())
    })?;
    let default_intensity = if s.kind == LightKind::Distant {
        50_000.0
    } else {
        1.0
    };
    let intensity = optional(s.intensity, default_intensity, |v| {
        check::non_negative(&k("intensity"), v)
    })?;
    let exposure = optional(s.exposure, 0.0, |v| {
        check::within(&k("exposure"), v, -64.0, 64.0, false)
    })?;
    let base = color * (intensity * exposure.exp2()) as f32;
    if !base.is_finite() {
        return Err(Invalid::new(
            k("intensity"),
            "intensity × 2^exposure is too large to represent",
        ));
    }
    let placement = match &s.transform {
        Some(spec) => pose::animated(&k("transform"), spec, Facing::NegativeZ, shot.fps)?,
        None => AnimatedTransform::constant(Similarity::IDENTITY),
    };
    let flags = flags(key, s.kind, s.visibility)?;
    let name = s.name.clone();
    if s.kind == LightKind::Distant {
        let angle = optional(s.angle, 0.53, |v| {
            check::within(&k("angle"), v, 0.0, 180.0, true)
        })? as f32;
        let normalize =
            always_normalised(key, s.normalize, angle == 0.0, "a distant light of angle 0")?;
        let sun = Sun::new(name, angle, base, normalize, placement, flags, group);
        return Ok(Light::Sun(sun));
    }
    let shape = shape(key, s)?;
    let point = shape == Shape::Sphere { radius: 0.0 };
    let normalize = always_normalised(key, s.normalize, point, "a point light (radius 0)")?;
    let cone = cone(key, s)?;
    Ok(Light::Shape(ShapeLight {
        name,
        shape,
        base,
        normalize,
        cone,
        placement: placement.into(),
        flags,
        group,
    }))
}

/// `normalize`, which a light without area or angle (`degenerate`, described as `what`)
/// cannot turn off.
fn always_normalised(
    key: &str,
    normalize: Option<bool>,
    degenerate: bool,
    what: &str,
) -> Result<bool, Invalid> {
    match (normalize, degenerate) {
        (Some(false), true) => Err(Invalid::new(
            format!("{key}.normalize"),
            format!(
                "{what} has no size to divide by: it is always normalised; give it a size or leave out `normalize`"
            ),
        )),
        (n, degenerate) => Ok(degenerate || n.unwrap_or(false)),
    }
}

/// The shape of a point, spot, rect or disk light.
fn shape(key: &str, s: &LightSection) -> Result<Shape, Invalid> {
    let k = |name: &str| format!("{key}.{name}");
    Ok(match s.kind {
        LightKind::Point | LightKind::Spot => Shape::Sphere {
            radius: optional(s.radius, 0.0, |v| {
                check::non_negative_length(&k("radius"), v)
            })? as f32,
        },
        LightKind::Disk => Shape::Disk {
            radius: optional(s.radius, 0.5, |v| check::positive_length(&k("radius"), v))? as f32,
        },
        LightKind::Rect => Shape::Rect {
            width: optional(s.width, 1.0, |v| check::positive_length(&k("width"), v))? as f32,
            height: optional(s.height, 1.0, |v| check::positive_length(&k("height"), v))? as f32,
        },
        LightKind::Distant => unreachable!("distant lights have no shape"),
    })
}

/// The cone of a spot (which must give `cone_angle`) or of any other shaped light.
fn cone(key: &str, s: &LightSection) -> Result<Option<Cone>, Invalid> {
    let k = |name: &str| format!("{key}.{name}");
    let Some(angle) = s.cone_angle else {
        if s.kind == LightKind::Spot {
            return Err(Invalid::new(
                k("cone_angle"),
                "missing: a spot light gives the angle of its cone from its −Z axis, in degrees",
            ));
        }
        if s.cone_softness.is_some() {
            return Err(Invalid::new(
                k("cone_softness"),
                "softens a cone: give `cone_angle` too",
            ));
        }
        return Ok(None);
    };
    let angle = check::within(&k("cone_angle"), angle, 0.0, 180.0, false)?;
    if angle == 0.0 {
        return Err(Invalid::new(k("cone_angle"), "a cone of 0° emits nothing"));
    }
    let softness = optional(s.cone_softness, 0.0, |v| {
        check::within(&k("cone_softness"), v, 0.0, 1.0, false)
    })?;
    Ok(Some(Cone::new(angle as f32, softness as f32)))
}

/// Refuses the keys the light's kind does not take.
fn refuse_foreign_keys(key: &str, s: &LightSection) -> Result<(), Invalid> {
    let kind = match s.kind {
        LightKind::Point => "point",
        LightKind::Spot => "spot",
        LightKind::Rect => "rect",
        LightKind::Disk => "disk",
        LightKind::Distant => "distant",
    };
    let takes = |field: &str| match field {
        "radius" => matches!(s.kind, LightKind::Point | LightKind::Spot | LightKind::Disk),
        "width" | "height" => s.kind == LightKind::Rect,
        "angle" => s.kind == LightKind::Distant,
        "cone_angle" | "cone_softness" => s.kind != LightKind::Distant,
        _ => true,
    };
    let given = [
        ("radius", s.radius.is_some()),
        ("width", s.width.is_some()),
        ("height", s.height.is_some()),
        ("angle", s.angle.is_some()),
        ("cone_angle", s.cone_angle.is_some()),
        ("cone_softness", s.cone_softness.is_some()),
    ];
    match given.iter().find(|(field, given)| *given && !takes(field)) {
        Some((field, _)) => Err(Invalid::new(
            format!("{key}.{field}"),
            format!("a {kind} light has no {field}"),
        )),
        None => Ok(()),
    }
}

/// Which rays see the light: camera and through-portal rays only when asked (the camera does
/// not see lights by default), rays that scatter unless told not to (a distant light always:
/// its light and the sky's arrive together). No light blocks a ray, so it takes no `shadow`.
fn flags(key: &str, kind: LightKind, v: Option<VisibilitySection>) -> Result<Flags, Invalid> {
    let v = v.unwrap_or(VisibilitySection {
        camera: None,
        through_portal: None,
        indirect: None,
        shadow: None,
    });
    if v.shadow.is_some() {
        return Err(Invalid::new(
            format!("{key}.visibility.shadow"),
            "a light blocks no ray, so it casts no shadow of its own",
        ));
    }
    if kind == LightKind::Distant && v.indirect == Some(false) {
        return Err(Invalid::new(
            format!("{key}.visibility.indirect"),
            "a distant light is part of the sky, which rays that scatter always see",
        ));
    }
    Ok(Flags::new(
        v.camera.unwrap_or(false),
        v.through_portal.unwrap_or(false),
        v.indirect.unwrap_or(true),
        false,
    ))
}
