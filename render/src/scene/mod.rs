//! The render scene built from a shot: triangles with materials (static ones baked to world
//! space, moving ones kept in object space under their keyframed transform), the ray-query
//! structure, emitters, the camera, the shutter and render settings. Syntax of the renderer's shot
//! sections: [`schema`].

pub mod camera;
pub mod media;
pub mod mesh;
pub mod metals;
pub mod ply;
pub mod portals;
pub mod rings;
pub mod schema;

use crate::camera::{Clip, Stereo};
use crate::environment::{Environment, LatLong};
use crate::error::{RenderError, key_error};
use crate::geometry::{
    Accel, Hit, MovingInstance, ObjectMotion, RingFrame, STATIC, StrandHit, Strands, Triangle,
    changes_during, every_triangle,
};
use crate::light_visibility::LightVisibility;
use crate::lights::{Emitter, LightSelection, Lights};
use crate::material::{Bsdf, Material};
use crate::microfacet::{ConductorFresnel, Ggx, Shadowing};
use crate::multiscatter::Multiscatter;
use crate::portal::Portals;
use crate::ray::Ray;
use crate::visibility::{Flags, RayClass, Visibility};
use glam::Vec3;
use rift_fx::rig::{AnimatedTransform, Camera};
use rift_fx::shot::check;
use rift_fx::shot::pose::{self, Facing};
use rift_fx::{Invalid, Shot};
use rings::RingSource;
use schema::{
    EnvironmentSection, MaterialKind, MaterialSection, ObjectSection, RenderSection, ShadowingKind,
    VisibilitySection,
};
use serde::de::DeserializeOwned;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Render settings from `[render]` (command-line flags override them).
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub spp: u32,
    pub seed: u32,
    /// `None`: unlimited (Russian roulette ends paths).
    pub max_bounces: Option<u32>,
    /// Teleports allowed in a row before the next scattering event.
    pub max_portal_depth: u32,
    /// Light sampling also looks through openings (see [`crate::through`]).
    pub light_through_openings: bool,
    /// Output path pattern; `#`s become the frame number.
    pub output: String,
    /// `[render] rings`: where the shot's rings come from (`None`: generated in memory).
    pub rings: Option<String>,
}

impl Settings {
    /// The shot's `[render]` settings with `overrides` applied (what the scene is built with;
    /// also what farm jobs are split by).
    pub fn read(shot: &Shot, overrides: &Overrides) -> Result<Self, RenderError> {
        let file = &shot.source;
        let invalid = |e: Invalid| RenderError::Shot(e.in_file(file));
        let render: RenderSection = match &shot.render.render {
            Some(t) => parse(file, "render", t)?,
            None => RenderSection::default(),
        };
        let settings = Settings {
            spp: match render.spp {
                Some(v) => check::integer("render.spp", v, 1, 1 << 16, "a positive integer")
                    .map_err(invalid)?,
                None => 16,
            },
            seed: match render.seed {
                Some(v) => check::integer("render.seed", v, 0, u32::MAX as i64, "an integer ≥ 0")
                    .map_err(invalid)?,
                None => 0,
            },
            max_bounces: match render.max_bounces {
                Some(v) => Some(
                    check::integer("render.max_bounces", v, 0, 1 << 16, "an integer ≥ 0")
                        .map_err(invalid)?,
                ),
                None => None,
            },
            max_portal_depth: match render.max_portal_depth {
                Some(v) => {
                    check::integer("render.max_portal_depth", v, 0, 1 << 16, "an integer ≥ 0")
                        .map_err(invalid)?
                }
                None => portals::DEFAULT_MAX_PORTAL_DEPTH,
            },
            light_through_openings: render.light_through_openings.unwrap_or(true),
            output: render
                .output
                .unwrap_or_else(|| format!("out/{}.####.exr", shot.name)),
            rings: render.rings,
        };
        Ok(Settings {
            spp: overrides.spp.unwrap_or(settings.spp),
            seed: overrides.seed.unwrap_or(settings.seed),
            max_portal_depth: overrides
                .max_portal_depth
                .unwrap_or(settings.max_portal_depth),
            light_through_openings: overrides
                .light_through_openings
                .unwrap_or(settings.light_through_openings),
            ..settings
        })
    }
}

/// Settings given outside the shot (the command line), applied before the scene is built
/// because some shape it: the portal depth limit bounds the times rays can reach.
#[derive(Clone, Debug, Default)]
pub struct Overrides {
    pub spp: Option<u32>,
    pub seed: Option<u32>,
    pub max_portal_depth: Option<u32>,
    /// `Some(false)` turns light sampling through openings off.
    pub light_through_openings: Option<bool>,
    /// A ring cache path pattern (`#` frame tokens) replacing `[render] rings`.
    pub rings: Option<PathBuf>,
    /// How light sampling picks emitters (default: the light tree).
    pub light_selection: Option<LightSelection>,
}

/// What a ray met: a triangle or a ring's strand.
#[derive(Clone, Copy, Debug)]
pub enum SceneHit {
    Surface(Hit),
    Strand(StrandHit),
}

impl SceneHit {
    /// Distance along the ray.
    #[inline]
    pub fn t(&self) -> f32 {
        match self {
            SceneHit::Surface(h) => h.t,
            SceneHit::Strand(h) => h.t,
        }
    }
}

/// Everything the integrator needs.
pub struct Scene {
    /// Static triangles (world space) first, then each moving object's (object space).
    pub triangles: Vec<Triangle>,
    /// Unit geometric normal per triangle, in the triangle's space.
    pub normals: Vec<Vec3>,
    /// Material index per triangle.
    pub triangle_material: Vec<u32>,
    pub materials: Vec<Material>,
    pub accel: Accel,
    pub lights: Lights,
    pub settings: Settings,
    pub camera: Camera,
    /// Clipping of camera rays that have not been teleported.
    pub clip: Clip,
    /// The left/right eye pair, when the shot asks for stereo.
    pub stereo: Option<Stereo>,
    /// Portal openings (none: the integrator never tests for them).
    pub portals: Portals,
    /// The openings as light sampling through them sees them.
    pub apertures: crate::through::Apertures,
    /// How much of ordinary light sampling is unblocked where (empty unless openings may
    /// bring light).
    pub light_visibility: crate::light_visibility::LightVisibility,
    /// Per-object visibility flags and cull volumes.
    pub visibility: Visibility,
    /// The participating media and where they are.
    pub media: crate::volumes::Volumes,
    /// The rings' strands (emissive round curves).
    pub strands: Strands,
    /// Which rays see each ring's strands (by ring of [`Self::strands`]).
    pub strand_flags: Vec<Flags>,
    /// The frame rendered.
    pub frame: i64,
    /// Shutter open and close, seconds.
    pub shutter: [f64; 2],
}

/// A surface point in world space.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub p: Vec3,
    /// Unit geometric normal (front side: counter-clockwise winding).
    pub ng: Vec3,
    /// World area of the triangle over its stored area (a moving object's scale squared).
    pub area_scale: f32,
}

/// One object's triangles on their way into the scene.
struct Part {
    /// Index of the `[[object]]`.
    object: u32,
    triangles: Vec<Triangle>,
    materials: Vec<u32>,
    /// `None`: baked to world space.
    motion: Option<ObjectMotion>,
}

/// The material given to a medium's boundary when its object names none.
const BOUNDARY_MATERIAL: &str = "(medium boundary)";

/// Deserialises one renderer-owned table, naming `key` in errors.
pub(crate) fn parse<T: DeserializeOwned>(
    file: &Path,
    key: &str,
    table: &toml::Table,
) -> Result<T, RenderError> {
    serde_path_to_error::deserialize(toml::Value::Table(table.clone())).map_err(|e| {
        let path = e.path().to_string();
        let full = if path == "." {
            key.to_owned()
        } else {
            format!("{key}.{path}")
        };
        key_error(file, full, e.inner().to_string())
    })
}

impl Scene {
    /// Builds the scene of `shot` at `frame`.
    pub fn build(shot: &Shot, frame: i64) -> Result<Self, RenderError> {
        Self::build_with(shot, frame, &Overrides::default())
    }

    /// Builds the scene of `shot` at `frame`, with `overrides` replacing the shot's settings.
    pub fn build_with(shot: &Shot, frame: i64, overrides: &Overrides) -> Result<Self, RenderError> {
        let file = &shot.source;
        let invalid = |e: Invalid| RenderError::Shot(e.in_file(file));
        let base = file.parent().unwrap_or(Path::new("."));
        let sections = &shot.render;

        let settings = Settings::read(shot, overrides)?;
        let media = media::sections(file, &sections.media)?;
        let mut materials = Vec::new();
        for (i, table) in sections.materials.iter().enumerate() {
            let key = format!("material[{i}]");
            let m: MaterialSection = parse(file, &key, table)?;
            if materials.iter().any(|x: &Material| x.name == m.name) {
                return Err(key_error(
                    file,
                    format!("{key}.name"),
                    format!("another material is already called {:?}", m.name),
                ));
            }
            materials.push(material(&key, &m).map_err(invalid)?);
        }

        let shutter = shot
            .shutter_seconds()
            .map(|s| s + shot.time_of(frame as f64));
        let light_selection = overrides.light_selection.unwrap_or_default();
        let ring_source = match &overrides.rings {
            Some(pattern) => RingSource::Cache {
                pattern: pattern.clone(),
                key: None,
            },
            None => rings::shot_source(shot, settings.rings.as_deref()),
        };
        let ring_frame = rings::load(shot, frame, &ring_source)?;
        let (portals, strand_looks) = portals::portals(
            shot,
            shutter,
            settings.max_portal_depth,
            ring_frame.as_ref(),
        )?;
        // Every time a ray can have: objects that move within it are blurred, the rest baked.
        let times = portals.times();
        let rig = Arc::new(shot.rig.clone());
        let objects = object_sections(file, &sections.objects)?;
        // The remaining sections are read before any mesh is loaded, so their mistakes are
        // reported at once.
        let names: Vec<&str> = objects.iter().map(|o| o.name.as_str()).collect();
        let volumes = portals::cull_volumes(shot, &names)?;
        let clip = camera::clip(file, sections.camera_clip.as_ref())?;
        let stereo = camera::stereo(file, sections.camera_stereo.as_ref())?;
        let mut parts = Vec::new();
        let mut flags = Vec::new();
        for (i, o) in objects.iter().enumerate() {
            let key = format!("object[{i}]");
            let transform = match &o.transform {
                Some(spec) => pose::animated(
                    &format!("{key}.transform"),
                    spec,
                    Facing::PositiveZ,
                    shot.fps,
                )
                .map_err(invalid)?,
                None => AnimatedTransform::constant(rift_fx::rig::Similarity::IDENTITY),
            };
            let motion = match &o.through {
                None => ObjectMotion::new(transform),
                Some(name) => {
                    let opening = shot.rig.find(name).ok_or_else(|| {
                        key_error(
                            file,
                            format!("{key}.through"),
                            format!("no portal opening is called {name:?}"),
                        )
                    })?;
                    let delay = portals.look(opening).time_offset;
                    ObjectMotion::through(transform, rig.clone(), opening, delay)
                }
            };
            flags.push(if media.inside(&o.name).is_some() {
                // Paths cross a medium's boundary; shadow rays pass it (attenuated by the media).
                Flags::new(true, true, true, false)
            } else {
                self::flags(o.visibility)
            });
            let Some(mesh_name) = &o.mesh else {
                return Err(key_error(
                    file,
                    format!("{key}.mesh"),
                    "missing: give `mesh`, or `copy_of` another object",
                ));
            };
            let mesh_path = base.join(mesh_name);
            let mesh_parts = match mesh_path.extension().and_then(|e| e.to_str()) {
                Some(ext) if ext.eq_ignore_ascii_case("obj") => mesh::load_obj(&mesh_path)?,
                Some(ext) if ext.eq_ignore_ascii_case("ply") => ply::load_ply(&mesh_path)?,
                _ => {
                    return Err(key_error(
                        file,
                        format!("{key}.mesh"),
                        format!("{mesh_name:?}: expected an .obj or .ply file"),
                    ));
                }
            };
            let moves = motion.moves_during(times);
            let placed = motion.at(times[0]);
            let mut part = Part {
                object: i as u32,
                triangles: Vec::new(),
                materials: Vec::new(),
                motion: moves.then_some(motion),
            };
            for mesh_part in mesh_parts {
                let index = match (&o.material, &mesh_part.material) {
                    (Some(name), _) => find(&materials, name).ok_or_else(|| {
                        key_error(
                            file,
                            format!("{key}.material"),
                            format!("no material is called {name:?}"),
                        )
                    })?,
                    (None, Some(mtl)) => match find(&materials, &mtl.name) {
                        Some(i) => i,
                        None if !mtl.declared => {
                            return Err(key_error(
                                file,
                                format!("{key}.material"),
                                format!(
                                    "part {:?} of {mesh_name} uses material {:?}, which is \
                                     neither a [[material]] nor in its MTL",
                                    mesh_part.name, mtl.name
                                ),
                            ));
                        }
                        None => {
                            // From the MTL: Kd as diffuse reflectance, Ke as one-sided emission.
                            materials.push(Material {
                                name: mtl.name.clone(),
                                bsdf: Bsdf::Diffuse {
                                    reflectance: mtl.diffuse.unwrap_or(Vec3::splat(0.8)),
                                },
                                emission: mtl.emission.unwrap_or(Vec3::ZERO),
                                two_sided_emission: false,
                            });
                            materials.len() - 1
                        }
                    },
                    (None, None) if media.inside(&o.name).is_some() => {
                        // A medium's boundary is never shaded; it still needs an index.
                        find(&materials, BOUNDARY_MATERIAL).unwrap_or_else(|| {
                            materials.push(Material {
                                name: BOUNDARY_MATERIAL.into(),
                                bsdf: Bsdf::Diffuse {
                                    reflectance: Vec3::ZERO,
                                },
                                emission: Vec3::ZERO,
                                two_sided_emission: false,
                            });
                            materials.len() - 1
                        })
                    }
                    (None, None) => {
                        return Err(key_error(
                            file,
                            format!("{key}.material"),
                            format!(
                                "part {:?} of {mesh_name} names no material; set `material`",
                                mesh_part.name
                            ),
                        ));
                    }
                };
                for tri in mesh_part.triangles {
                    let v = if moves {
                        tri
                    } else {
                        tri.map(|p| placed.transform_point(p.as_dvec3()).as_vec3())
                    };
                    if !v.iter().all(|&p| within_single_precision(p)) {
                        return Err(key_error(
                            file,
                            format!("{key}.transform"),
                            format!(
                                "it places {mesh_name} beyond ±{:e} m, more than single-precision \
                                 rendering can hold",
                                check::MAX_LENGTH
                            ),
                        ));
                    }
                    part.triangles.push(Triangle { v });
                    part.materials.push(index as u32);
                }
            }
            parts.push(part);
        }
        // Static parts first so their triangles take the indices the static BVH starts at.
        parts.sort_by_key(|p| p.motion.is_some());

        let mut triangles = Vec::new();
        let mut triangle_material = Vec::new();
        let mut triangle_instance = Vec::new();
        let mut triangle_object = Vec::new();
        let mut instances = Vec::new();
        let mut static_count = 0;
        let mut moving = vec![false; objects.len()];
        for part in parts {
            moving[part.object as usize] = part.motion.is_some();
            let first = triangles.len() as u32;
            let instance = match part.motion {
                None => {
                    static_count += part.triangles.len();
                    STATIC
                }
                Some(motion) => {
                    instances.push(MovingInstance::new(&part.triangles, first, motion, times));
                    instances.len() as u32 - 1
                }
            };
            triangle_instance.extend(std::iter::repeat_n(instance, part.triangles.len()));
            triangle_object.extend(std::iter::repeat_n(part.object, part.triangles.len()));
            triangles.extend(part.triangles);
            triangle_material.extend(part.materials);
        }
        let participating =
            media::volumes(file, media, &names, &moving, &triangles, &triangle_object)?;
        let normals: Vec<Vec3> = triangles
            .iter()
            .map(|t| t.normal().normalize_or_zero())
            .collect();

        let emitters = triangles
            .iter()
            .enumerate()
            .filter_map(|(i, tri)| {
                let m = &materials[triangle_material[i] as usize];
                (m.emits() && tri.area() > 0.0).then(|| Emitter {
                    triangle: i as u32,
                    instance: triangle_instance[i],
                    radiance: m.emission,
                    two_sided: m.two_sided_emission,
                    vertices: *tri,
                    normal: normals[i],
                    area: tri.area(),
                })
            })
            .collect();
        let environment = match &sections.environment {
            Some(t) => Some(environment(
                file,
                base,
                &parse::<EnvironmentSection>(file, "environment", t)?,
            )?),
            None => None,
        };
        let mut strands = Strands::default();
        let mut strand_flags = Vec::new();
        for curves in ring_frame.iter().flat_map(|f| &f.rings) {
            let opening = shot
                .rig
                .find(&curves.opening)
                .expect("rings::load checks every ring names an opening");
            let frame = if moves_during(&shot.rig.openings[opening].here, times) {
                let rig = rig.clone();
                RingFrame::Moving(Box::new(move |t| rig.here_at(opening, t)))
            } else {
                let to_world = shot.rig.here_at(opening, times[0]);
                RingFrame::Fixed {
                    to_world,
                    to_local: to_world.inverse(),
                }
            };
            let look = strand_looks[opening];
            strands.add_ring(
                curves,
                frame,
                ring_frame.as_ref().map_or(0.0, |f| f.time),
                times,
                look.intensity,
            );
            strand_flags.push(look.flags);
        }
        let lights = Lights::new(
            emitters,
            triangles.len(),
            &strands,
            times,
            &instances,
            environment,
            light_selection,
        );
        let accel = Accel::build(&triangles[..static_count], instances);
        let visibility = Visibility::new(
            triangle_object,
            flags,
            volumes,
            rig,
            portals.moving(),
            times[0],
        );
        let apertures = crate::through::Apertures::new(&portals, &lights);
        let bounds = static_bounds(&triangles[..static_count]);
        let mut scene = Self {
            apertures,
            light_visibility: Default::default(),
            triangles,
            normals,
            triangle_material,
            materials,
            accel,
            lights,
            settings,
            camera: shot.camera.clone(),
            clip,
            stereo,
            portals,
            visibility,
            media: participating,
            strands,
            strand_flags,
            frame,
            shutter,
        };
        if scene.light_through_openings_possible() {
            scene.light_visibility = LightVisibility::new(&scene, bounds, times);
        }
        Ok(scene)
    }

    /// True when light sampling may look through openings: the shot allows it, and there are
    /// openings, teleports and lights.
    pub fn light_through_openings_possible(&self) -> bool {
        self.settings.light_through_openings
            && !self.portals.is_empty()
            && !self.lights.is_empty()
            && self.settings.max_portal_depth > 0
    }

    /// The closest surface or strand a ray of `class` sees along `ray`. A ray whose range
    /// starts past its origin is traced from there (clipping moves the camera ray's start), and
    /// the hit's parameter still counts from the origin.
    #[inline]
    pub fn intersect(&self, ray: &Ray, class: RayClass) -> Option<SceneHit> {
        if ray.t_min <= 0.0 {
            return self.intersect_from_origin(ray, class);
        }
        let start = ray.t_min;
        let moved = Ray::new(ray.at(start), ray.dir, ray.t_max - start, ray.time);
        Some(match self.intersect_from_origin(&moved, class)? {
            SceneHit::Surface(mut h) => {
                h.t += start;
                SceneHit::Surface(h)
            }
            SceneHit::Strand(mut h) => {
                h.t += start;
                SceneHit::Strand(h)
            }
        })
    }

    /// [`Self::intersect`] for a ray whose range starts at its origin.
    #[inline]
    fn intersect_from_origin(&self, ray: &Ray, class: RayClass) -> Option<SceneHit> {
        let surface = if !self.visibility.hides_anything() {
            self.accel.intersect(ray, &every_triangle)
        } else {
            let admits = |triangle, t| self.visibility.admits(triangle, class, ray.at(t), ray.time);
            self.accel.intersect(ray, &admits)
        };
        if self.strands.is_empty() {
            return surface.map(SceneHit::Surface);
        }
        let limit = surface.map_or(ray.t_max, |h| h.t);
        let strand = self.strands.intersect(
            &Ray {
                t_max: limit,
                ..*ray
            },
            |ring| self.strand_flags[ring].sees(class),
        );
        match strand {
            Some(h) => Some(SceneHit::Strand(h)),
            None => surface.map(SceneHit::Surface),
        }
    }

    /// True when a surface or strand that shadow rays see blocks `ray` (which starts at its
    /// origin: t in (0, t_max)).
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        debug_assert!(ray.t_min == 0.0);
        let blocked = if !self.visibility.hides_anything() {
            self.accel.occluded(ray, &every_triangle)
        } else {
            let admits = |triangle, t| {
                self.visibility
                    .admits(triangle, RayClass::Shadow, ray.at(t), ray.time)
            };
            self.accel.occluded(ray, &admits)
        };
        blocked
            || (!self.strands.is_empty()
                && self
                    .strands
                    .occluded(ray, |ring| self.strand_flags[ring].sees(RayClass::Shadow)))
    }

    /// The world-space point and normal of `hit` at time `time`.
    #[inline]
    pub fn surface(&self, hit: &Hit, time: f64) -> SurfacePoint {
        let tri = &self.triangles[hit.triangle as usize];
        let p = tri.point(hit.b1, hit.b2);
        let n = self.normals[hit.triangle as usize];
        if hit.instance == STATIC {
            return SurfacePoint {
                p,
                ng: n,
                area_scale: 1.0,
            };
        }
        let placement = self.accel.placement(hit.instance, time);
        SurfacePoint {
            p: placement.to_world.transform_point3(p),
            ng: placement.to_world.transform_vector3(n).normalize(),
            area_scale: placement.scale * placement.scale,
        }
    }

    /// Triangle `i` of `instance` in world space at time `time`.
    pub fn world_triangle(&self, i: u32, instance: u32, time: f64) -> Triangle {
        let tri = self.triangles[i as usize];
        if instance == STATIC {
            return tri;
        }
        let to_world = self.accel.placement(instance, time).to_world;
        Triangle {
            v: tri.v.map(|v| to_world.transform_point3(v)),
        }
    }

    /// True when the camera moves while the shutter is open.
    pub fn camera_moves(&self) -> bool {
        moves_during(&self.camera.transform, self.shutter)
    }

    /// True when rays of `class` see strand segment `segment`.
    #[inline]
    pub fn strand_sees(&self, segment: u32, class: RayClass) -> bool {
        self.strand_flags[self.strands.segment_ring[segment as usize] as usize].sees(class)
    }

    /// The material of triangle `i`.
    pub fn material(&self, triangle: u32) -> &Material {
        &self.materials[self.triangle_material[triangle as usize] as usize]
    }
}

/// Visibility flags from an optional `visibility` table (each flag defaults to true).
pub(crate) fn flags(v: Option<VisibilitySection>) -> Flags {
    v.map_or(Flags::ALL, |v| {
        Flags::new(
            v.camera.unwrap_or(true),
            v.through_portal.unwrap_or(true),
            v.indirect.unwrap_or(true),
            v.shadow.unwrap_or(true),
        )
    })
}

/// True when `transform` is not the same at every time in `interval`.
pub(crate) fn moves_during(transform: &AnimatedTransform, interval: [f64; 2]) -> bool {
    let keys: Vec<f64> = transform.keys().iter().map(|k| k.time).collect();
    !transform.is_static() && changes_during(|t| transform.at(t), &keys, interval)
}

/// The `[[object]]` sections, with names checked unique and each `copy_of` filled in from the
/// earlier object it names (mesh, material and transform, where the copy gives none).
fn object_sections(file: &Path, tables: &[toml::Table]) -> Result<Vec<ObjectSection>, RenderError> {
    let mut out: Vec<ObjectSection> = Vec::new();
    for (i, table) in tables.iter().enumerate() {
        let key = format!("object[{i}]");
        let mut o: ObjectSection = parse(file, &key, table)?;
        if out.iter().any(|x| x.name == o.name) {
            return Err(key_error(
                file,
                format!("{key}.name"),
                format!("another object is already called {:?}", o.name),
            ));
        }
        if let Some(source) = &o.copy_of {
            let Some(from) = out.iter().find(|x| &x.name == source) else {
                return Err(key_error(
                    file,
                    format!("{key}.copy_of"),
                    format!("no earlier object is called {source:?}"),
                ));
            };
            o.mesh = o.mesh.or_else(|| from.mesh.clone());
            o.material = o.material.or_else(|| from.material.clone());
            o.transform = o.transform.or_else(|| from.transform.clone());
        }
        out.push(o);
    }
    Ok(out)
}

/// The environment light of `[environment]`: a constant or a lat-long map.
fn environment(
    file: &Path,
    base: &Path,
    e: &EnvironmentSection,
) -> Result<Environment, RenderError> {
    let invalid = |e: Invalid| RenderError::Shot(e.in_file(file));
    match (&e.radiance, &e.map) {
        (Some(_), Some(_)) => Err(key_error(
            file,
            "environment.map",
            "give either `radiance` or `map`, not both",
        )),
        (None, None) => Err(key_error(
            file,
            "environment",
            "expected `radiance = [r, g, b]` or `map = \"file.exr\"`",
        )),
        (Some(radiance), None) => {
            if e.intensity.is_some() || e.rotation_degrees.is_some() {
                return Err(key_error(
                    file,
                    "environment",
                    "`intensity` and `rotation_degrees` apply to a `map` only",
                ));
            }
            Ok(Environment::Constant(
                color("environment.radiance", Some(*radiance), Vec3::ZERO).map_err(invalid)?,
            ))
        }
        (None, Some(map)) => {
            let intensity = match e.intensity {
                Some(v) => check::non_negative("environment.intensity", v).map_err(invalid)?,
                None => 1.0,
            };
            let degrees = match e.rotation_degrees {
                Some(v) => check::finite("environment.rotation_degrees", v).map_err(invalid)?,
                None => 0.0,
            };
            let path = base.join(map);
            let (w, h, texels) = crate::film::read_exr_rgb(&path)
                .map_err(|cause| key_error(file, "environment.map", format!("{map:?}: {cause}")))?;
            if let Some(bad) = texels
                .iter()
                .position(|c| !c.is_finite() || c.min_element() < 0.0)
            {
                return Err(key_error(
                    file,
                    "environment.map",
                    format!(
                        "{map:?}: texel ({}, {}) is negative or not finite",
                        bad % w,
                        bad / w
                    ),
                ));
            }
            Ok(Environment::LatLong(LatLong::new(
                w,
                h,
                texels,
                intensity as f32,
                degrees as f32,
            )))
        }
    }
}

fn find(materials: &[Material], name: &str) -> Option<usize> {
    materials.iter().position(|m| m.name == name)
}

fn color(key: &str, v: Option<[f64; 3]>, default: Vec3) -> Result<Vec3, Invalid> {
    v.map_or(Ok(default), |c| check::color(key, c).map(|c| c.as_vec3()))
}

fn material(key: &str, m: &MaterialSection) -> Result<Material, Invalid> {
    let reflectance = color(
        &format!("{key}.reflectance"),
        m.reflectance,
        Vec3::splat(0.8),
    )?;
    if reflectance.max_element() > 1.0 {
        return Err(Invalid::new(
            format!("{key}.reflectance"),
            "a reflectance above 1 creates energy",
        ));
    }
    let roughness = match m.roughness {
        Some(r) => check::within(&format!("{key}.roughness"), r, 0.0, 1.0, false)? as f32,
        None => 0.0,
    };
    let ggx = Ggx::from_roughness(roughness).with_shadowing(match m.shadowing {
        Some(ShadowingKind::HeightCorrelated) | None => Shadowing::HeightCorrelated,
        Some(ShadowingKind::Separable) => Shadowing::Separable,
    });
    let unused = |field: &str, what: &str| {
        Invalid::new(
            format!("{key}.{field}"),
            format!("a {what} material has no {field}"),
        )
    };
    let bsdf = match m.kind {
        MaterialKind::Diffuse | MaterialKind::Dielectric
            if m.eta.is_some() || m.k.is_some() || m.metal.is_some() =>
        {
            let field = if m.metal.is_some() {
                "metal"
            } else if m.eta.is_some() {
                "eta"
            } else {
                "k"
            };
            let what = if m.kind == MaterialKind::Diffuse {
                "diffuse"
            } else {
                "dielectric"
            };
            return Err(unused(field, what));
        }
        MaterialKind::Diffuse => {
            if m.roughness.is_some() {
                return Err(unused("roughness", "diffuse"));
            }
            if m.shadowing.is_some() {
                return Err(unused("shadowing", "diffuse"));
            }
            if m.multiscatter.is_some() {
                return Err(unused("multiscatter", "diffuse"));
            }
            if m.ior.is_some() {
                return Err(unused("ior", "diffuse"));
            }
            Bsdf::Diffuse { reflectance }
        }
        MaterialKind::Conductor => {
            if m.ior.is_some() {
                return Err(unused("ior", "conductor"));
            }
            let fresnel = conductor_fresnel(key, m)?;
            let multiscatter = match m.multiscatter {
                Some(true) => Multiscatter::new(&fresnel, ggx),
                _ => None,
            };
            Bsdf::Conductor {
                fresnel,
                ggx,
                multiscatter,
            }
        }
        MaterialKind::Dielectric => {
            if m.reflectance.is_some() {
                return Err(unused("reflectance", "dielectric"));
            }
            if m.multiscatter.is_some() {
                return Err(Invalid::new(
                    format!("{key}.multiscatter"),
                    "energy compensation is for conductors only (dielectrics: not yet)",
                ));
            }
            let ior = match m.ior {
                Some(v) => check::within(&format!("{key}.ior"), v, 1e-3, 1e3, false)? as f32,
                None => 1.5,
            };
            Bsdf::Dielectric { ior, ggx }
        }
    };
    Ok(Material {
        name: m.name.clone(),
        bsdf,
        emission: color(&format!("{key}.emission"), m.emission, Vec3::ZERO)?,
        two_sided_emission: m.two_sided_emission.unwrap_or(false),
    })
}

/// A conductor's Fresnel term: Schlick's from `reflectance` (the default, white), or the exact
/// term from `eta` and `k`, or from a named `metal`'s.
fn conductor_fresnel(key: &str, m: &MaterialSection) -> Result<ConductorFresnel, Invalid> {
    let conflict = |a: &str, b: &str| {
        Invalid::new(
            format!("{key}.{b}"),
            format!("give `{a}` or `{b}`, not both: they are two ways to set the same colour"),
        )
    };
    let complex = |field: &str, v: [f64; 3]| -> Result<Vec3, Invalid> {
        let c = glam::DVec3::from_array(v);
        if c.is_finite() && c.min_element() > 0.0 && c.max_element() <= 1e3 {
            Ok(c.as_vec3())
        } else {
            Err(Invalid::new(
                format!("{key}.{field}"),
                format!(
                    "expected three finite numbers > 0 and ≤ 1000 (one per channel), got {v:?}"
                ),
            ))
        }
    };
    match (m.reflectance, m.eta, m.k, &m.metal) {
        (Some(_), Some(_), _, _) => Err(conflict("reflectance", "eta")),
        (Some(_), _, Some(_), _) => Err(conflict("reflectance", "k")),
        (Some(_), _, _, Some(_)) => Err(conflict("reflectance", "metal")),
        (_, Some(_), _, Some(_)) => Err(conflict("metal", "eta")),
        (_, _, Some(_), Some(_)) => Err(conflict("metal", "k")),
        (None, None, None, Some(name)) => {
            let (eta, k) = metals::named(name).ok_or_else(|| {
                let known: Vec<_> = metals::names().collect();
                Invalid::new(
                    format!("{key}.metal"),
                    format!("no metal is called {name:?}; known: {}", known.join(", ")),
                )
            })?;
            Ok(ConductorFresnel::Complex { eta, k })
        }
        (None, Some(eta), Some(k), None) => Ok(ConductorFresnel::Complex {
            eta: complex("eta", eta)?,
            k: complex("k", k)?,
        }),
        (None, Some(_), None, None) => Err(Invalid::new(
            format!("{key}.k"),
            "`eta` needs `k` beside it (the imaginary part of the index, per channel)",
        )),
        (None, None, Some(_), None) => Err(Invalid::new(
            format!("{key}.eta"),
            "`k` needs `eta` beside it (the real part of the index, per channel)",
        )),
        (reflectance, None, None, None) => Ok(ConductorFresnel::Schlick(color(
            &format!("{key}.reflectance"),
            reflectance,
            Vec3::ONE,
        )?)),
    }
}

/// The lower and upper corners of the static triangles (a unit box around the origin when
/// there are none).
fn static_bounds(triangles: &[Triangle]) -> [Vec3; 2] {
    let corners = triangles.iter().flat_map(|t| t.v);
    let lower = corners.clone().fold(Vec3::INFINITY, Vec3::min);
    let upper = corners.fold(Vec3::NEG_INFINITY, Vec3::max);
    if lower.cmple(upper).all() {
        [lower, upper]
    } else {
        [Vec3::splat(-0.5), Vec3::splat(0.5)]
    }
}

/// True when every coordinate of `p` is finite and within [`check::MAX_LENGTH`].
pub fn within_single_precision(p: Vec3) -> bool {
    p.is_finite() && p.abs().max_element() <= check::MAX_LENGTH as f32
}
