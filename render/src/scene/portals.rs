//! The renderer's side of a shot's openings: `[portal.surface]` (teleport mask, tint, opacity,
//! ior, distortion, time offset, strand look), `[[portal.cull]]` and the portal depth limit. Syntax: [`super::schema`].

use super::light_groups::LightGroups;
use super::schema::{CullSection, CullSide, PortalSurfaceSection, StrandsSection};
use super::{flags, moves_during, optional, parse};
use crate::error::RenderError;
use crate::portals::masks::{Mask, Polygon, RingBoundary};
use crate::portals::openings::{Distortion, OpeningLook, Portals};
use crate::portals::visibility::{CullVolume, Flags, Side};
use glam::DVec2;
use rift_fx::rig::ThereFrame;
use rift_fx::ring::RingFrame;
use rift_fx::shot::check;
use rift_fx::{Invalid, Shot};

/// Teleports in a row allowed when the shot does not say.
pub const DEFAULT_MAX_PORTAL_DEPTH: u32 = 8;

/// How one opening's ring strands render (`[portal.surface.strands]`).
#[derive(Clone, Copy, Debug)]
pub struct StrandLook {
    /// Scales the baked Cd · intensity.
    pub intensity: f32,
    pub flags: Flags,
    /// The light group of the ring's light.
    pub group: u8,
}

/// The openings of `shot` over the shutter `[open, close]` (seconds), with chains of up to
/// `max_portal_depth` teleports in a row; `rings` are the frame's baked rings, whose boundaries
/// become the teleport masks. Also returns each opening's strand look.
pub(crate) fn portals(
    shot: &Shot,
    shutter: [f64; 2],
    max_portal_depth: u32,
    rings: Option<&RingFrame>,
    groups: &mut LightGroups,
) -> Result<(Portals, Vec<StrandLook>), RenderError> {
    let file = &shot.source;
    let invalid = |e: Invalid| RenderError::Shot(e.in_file(file));
    let mut shapes = Vec::new();
    let mut looks = Vec::new();
    let mut strand_looks = Vec::new();
    for (i, surface) in shot.render.portal_surfaces.iter().enumerate() {
        let key = format!("portal[{i}].surface");
        let s: PortalSurfaceSection = match surface {
            Some(t) => parse(file, &key, t)?,
            None => PortalSurfaceSection::default(),
        };
        let shape = shape(&key, &s).map_err(invalid)?;
        let look = surface_look(&key, &s, shot.fps).map_err(invalid)?;
        shapes.push(shape);
        looks.push(look);
        let mut strand = strand_look(&key, s.strands.as_ref()).map_err(invalid)?;
        let group = s.strands.as_ref().and_then(|s| s.light_group.as_deref());
        strand.group = groups.index(file, &format!("{key}.strands.light_group"), group)?;
        strand_looks.push(strand);
    }
    let times = reachable_times(shutter, &looks, max_portal_depth);
    let masks = shot
        .rig
        .openings
        .iter()
        .zip(shapes)
        .map(|(opening, shape)| {
            let ring = rings.and_then(|f| {
                f.rings
                    .iter()
                    .find(|r| r.opening == opening.name)
                    .map(|r| (r, f.time))
            });
            match (shape, ring) {
                (Some(shape), _) => shape,
                (None, Some((curves, frame_time))) => {
                    Mask::Ring(RingBoundary::new(curves, frame_time, times))
                }
                (None, None) => Mask::Disk { radius: 1.0 },
            }
        })
        .collect();
    let openings = &shot.rig.openings;
    let here_moves: Vec<bool> = openings
        .iter()
        .map(|o| moves_during(&o.here, times))
        .collect();
    let moving: Vec<bool> = openings
        .iter()
        .enumerate()
        .map(|(i, o)| {
            here_moves[i]
                || match &o.there {
                    ThereFrame::Explicit(t) => moves_during(t, times),
                    ThereFrame::Paired(pair) => here_moves[*pair],
                }
        })
        .collect();
    Ok((
        Portals::new(shot.rig.clone(), masks, looks, times, &moving),
        strand_looks,
    ))
}

fn strand_look(key: &str, s: Option<&StrandsSection>) -> Result<StrandLook, Invalid> {
    let intensity = optional(s.and_then(|s| s.intensity), 1.0, |v| {
        check::non_negative(&format!("{key}.strands.intensity"), v)
    })? as f32;
    Ok(StrandLook {
        intensity,
        flags: flags(s.and_then(|s| s.visibility)),
        group: 0,
    })
}

/// The times rays can have: the shutter widened by a chain of `depth` teleports through the
/// openings with the largest offset each way. Only when some opening has an offset does the
/// scene's motion have to cover more than the shutter.
fn reachable_times(shutter: [f64; 2], looks: &[OpeningLook], depth: u32) -> [f64; 2] {
    let offsets = looks.iter().map(|l| l.time_offset);
    let later = offsets.clone().fold(0.0f64, f64::max);
    let earlier = offsets.fold(0.0f64, f64::min);
    [
        shutter[0] + earlier * depth as f64,
        shutter[1] + later * depth as f64,
    ]
}

/// The cull volumes of every opening (`[[portal.cull]]`), linked to objects by name.
pub fn cull_volumes(shot: &Shot, objects: &[&str]) -> Result<Vec<CullVolume>, RenderError> {
    let file = &shot.source;
    let invalid = |e: Invalid| RenderError::Shot(e.in_file(file));
    let mut volumes = Vec::new();
    for (i, tables) in shot.render.portal_culls.iter().enumerate() {
        for (j, table) in tables.iter().enumerate() {
            let key = format!("portal[{i}].cull[{j}]");
            let c: CullSection = parse(file, &key, table)?;
            let linked = c
                .objects
                .iter()
                .enumerate()
                .map(|(k, name)| {
                    objects
                        .iter()
                        .position(|o| o == name)
                        .map(|o| o as u32)
                        .ok_or_else(|| {
                            invalid(Invalid::new(
                                format!("{key}.objects[{k}]"),
                                format!("no object is called {name:?}"),
                            ))
                        })
                })
                .collect::<Result<Vec<_>, _>>()?;
            if linked.is_empty() {
                return Err(invalid(Invalid::new(
                    format!("{key}.objects"),
                    "name at least one object to hide",
                )));
            }
            let limit = |name: &str, v: Option<f64>| {
                optional(v, f64::INFINITY, |v| {
                    check::positive(&format!("{key}.{name}"), v)
                })
            };
            volumes.push(CullVolume {
                opening: i,
                side: match c.side {
                    Some(CullSide::There) => Side::There,
                    Some(CullSide::Here) | None => Side::Here,
                },
                depth: limit("depth", c.depth).map_err(invalid)?,
                radius: limit("radius", c.radius).map_err(invalid)?,
                objects: linked,
            });
        }
    }
    Ok(volumes)
}

/// The teleport region an opening's surface asks for instead of its ring's boundary (a disk,
/// a rectangle or a polygon; at most one of them).
fn shape(key: &str, s: &PortalSurfaceSection) -> Result<Option<Mask>, Invalid> {
    let k = |name: &str| format!("{key}.{name}");
    let given: Vec<&str> = [
        ("radius", s.radius.is_some()),
        ("rectangle", s.rectangle.is_some()),
        ("polygon", s.polygon.is_some()),
    ]
    .into_iter()
    .filter_map(|(name, set)| set.then_some(name))
    .collect();
    if given.len() > 1 {
        return Err(Invalid::new(
            k(given[1]),
            format!(
                "give one teleport shape: `{}` and `{}` are both set",
                given[0], given[1]
            ),
        ));
    }
    if let Some(r) = s.radius {
        return Ok(Some(Mask::Disk {
            radius: check::positive(&k("radius"), r)?,
        }));
    }
    if let Some([w, h]) = s.rectangle {
        let width = check::positive(&format!("{key}.rectangle[0]"), w)?;
        let height = check::positive(&format!("{key}.rectangle[1]"), h)?;
        return Ok(Some(Mask::Rectangle {
            half: DVec2::new(0.5 * width, 0.5 * height),
        }));
    }
    if let Some(points) = &s.polygon {
        let points = points.iter().map(|&[x, y]| DVec2::new(x, y)).collect();
        let polygon =
            Polygon::new(points).map_err(|e| Invalid::new(k("polygon"), e.to_string()))?;
        return Ok(Some(Mask::Polygon(polygon)));
    }
    Ok(None)
}

/// The look of one opening.
fn surface_look(key: &str, s: &PortalSurfaceSection, fps: f64) -> Result<OpeningLook, Invalid> {
    let k = |name: &str| format!("{key}.{name}");
    // Unset keys keep the defaults of [`OpeningLook`].
    let mut look = OpeningLook::default();
    if let Some(c) = s.tint {
        look.tint = check::color(&k("tint"), c)?.as_vec3();
    }
    if let Some(v) = s.opacity {
        look.opacity = check::within(&k("opacity"), v, 0.0, 1.0, false)? as f32;
    }
    if let Some(v) = s.ior {
        look.ior = check::within(&k("ior"), v, 1e-3, 1e3, false)?;
    }
    if let Some(frames) = s.time_offset {
        look.time_offset = check::finite(&k("time_offset"), frames)? / fps;
    }
    if let Some(d) = &s.distortion {
        let dk = |name: &str| format!("{key}.distortion.{name}");
        look.distortion = Some(Distortion::new(
            check::non_negative(&dk("amplitude"), d.amplitude)?,
            optional(d.frequency, 3.0, |f| check::positive(&dk("frequency"), f))?,
            optional(d.evolution, 0.5, |e| {
                check::non_negative(&dk("evolution"), e)
            })?,
            optional(d.seed, 0, |v| {
                check::integer(&dk("seed"), v, 0, u32::MAX as i64, "an integer ≥ 0")
            })?,
        ));
    }
    Ok(look)
}
