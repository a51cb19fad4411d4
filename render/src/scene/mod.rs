//! The render scene built from a shot: triangles with materials (static ones baked to world
//! space, moving ones kept in object space under their keyframed transform), the ray-query
//! structure, emitters, the camera, the shutter and render settings. Syntax of the renderer's shot
//! sections: [`schema`].

pub mod camera;
pub mod grids;
pub mod light_groups;
mod materials;
pub mod media;
pub mod mesh;
pub mod metals;
mod objects;
pub mod ply;
pub mod portals;
pub mod rings;
pub mod schema;

use crate::camera::{Clip, Stereo};
use crate::error::{RenderError, key_error};
use crate::geometry::ray::Ray;
use crate::geometry::{
    Accel, Hit, STATIC, StrandHit, Strands, Triangle, changes_during, every_triangle,
};
use crate::lights::emitters::{LightSelection, Lights};
use crate::lights::environment::{Environment, LatLong};
use crate::material::bsdf::Material;
use crate::portals::openings::Portals;
use crate::portals::visibility::{Flags, RayClass, Visibility};
use glam::Vec3;
use materials::color;
use rift_fx::rig::{AnimatedTransform, Camera};
use rift_fx::shot::check;
use rift_fx::{Invalid, Shot};
use rings::RingSource;
use schema::{EnvironmentSection, RenderSection, VisibilitySection};
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
    /// Branches a camera path splits into at its first scattering event (1: none).
    pub indirect_samples: u32,
    /// Teleports allowed in a row before the next scattering event.
    pub max_portal_depth: u32,
    /// Light sampling also looks through openings (see [`crate::through::strategies`]).
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
            spp: optional(render.spp, 16, |v| {
                check::integer("render.spp", v, 1, 1 << 16, "a positive integer")
            })
            .map_err(invalid)?,
            seed: optional(render.seed, 0, |v| {
                check::integer("render.seed", v, 0, u32::MAX as i64, "an integer ≥ 0")
            })
            .map_err(invalid)?,
            max_bounces: optional(render.max_bounces, None, |v| {
                check::integer("render.max_bounces", v, 0, 1 << 16, "an integer ≥ 0").map(Some)
            })
            .map_err(invalid)?,
            indirect_samples: optional(render.indirect_samples, 1, |v| {
                check::integer(
                    "render.indirect_samples",
                    v,
                    1,
                    16,
                    "an integer from 1 to 16",
                )
            })
            .map_err(invalid)?,
            max_portal_depth: optional(
                render.max_portal_depth,
                portals::DEFAULT_MAX_PORTAL_DEPTH,
                |v| check::integer("render.max_portal_depth", v, 0, 1 << 16, "an integer ≥ 0"),
            )
            .map_err(invalid)?,
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
    /// Bytes the scene may take; a scene whose triangles would need more is refused once its
    /// meshes are read, before any BVH is built.
    pub memory_budget: Option<u64>,
}

/// Bytes a scene of `triangles` triangles takes at its peak while it is built: the triangles
/// as loaded, baked and stored with their normals and indices, and the BVH builder's working
/// set (about 280 bytes a triangle, measured on 0.5 to 4 million).
pub fn scene_bytes(triangles: usize) -> u64 {
    const PER_TRIANGLE: u64 = 400;
    (triangles as u64).saturating_mul(PER_TRIANGLE)
}

/// The object index of no object (the sky, a medium, an opening at the depth limit), beside
/// the indices of [`Scene::id_names`].
pub const NO_OBJECT: u32 = u32::MAX;

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

    /// Adds `start` to the distance along the ray.
    fn move_start(&mut self, start: f32) {
        match self {
            SceneHit::Surface(h) => h.t += start,
            SceneHit::Strand(h) => h.t += start,
        }
    }
}

/// A frame's scene as the shot describes it: geometry, materials, lights, openings, media, the
/// camera and the render settings.
pub struct Scene {
    /// Static triangles (world space) first, then each moving object's (object space).
    pub triangles: Vec<Triangle>,
    /// How many of [`Self::triangles`] are static.
    pub static_triangles: usize,
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
    /// Per-object visibility flags and cull volumes.
    pub visibility: Visibility,
    /// The participating media and where they are.
    pub media: crate::media::volumes::Volumes,
    /// The object of each triangle (an index into [`Self::id_names`]), shared with
    /// [`Self::visibility`].
    pub triangle_object: Arc<[u32]>,
    /// The objects', then the rings' names (`"<opening>/ring"`), which object IDs index
    /// (Cryptomatte).
    pub id_names: Vec<String>,
    /// How many of [`Self::id_names`] are objects (the rings follow).
    pub object_count: u32,
    /// Per object, its placement over time. The triangles in [`Self::triangles`] of objects
    /// that move within the shutter are in object space, the others in world space.
    pub object_placement: Vec<crate::geometry::ObjectMotion>,
    /// The rings' strands (emissive round curves).
    pub strands: Strands,
    /// Which rays see each ring's strands (by ring of [`Self::strands`]).
    pub strand_flags: Vec<Flags>,
    /// Light groups ([`light_groups`]): their names, the default first; empty when the shot
    /// names none.
    pub light_groups: Vec<String>,
    /// Light group per triangle, and per ring of strands (empty without groups).
    pub triangle_group: Vec<u8>,
    pub strand_group: Vec<u8>,
    /// The environment's light group.
    pub environment_group: u8,
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

/// An optional key's value: `value` passed through its `check` when the shot gives one,
/// `default` when it does not.
pub(crate) fn optional<T, U>(
    value: Option<T>,
    default: U,
    check: impl FnOnce(T) -> Result<U, Invalid>,
) -> Result<U, Invalid> {
    value.map_or(Ok(default), check)
}

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
    /// Loads the scene of `shot` at `frame`.
    pub fn load(shot: &Shot, frame: i64) -> Result<Self, RenderError> {
        Self::load_with(shot, frame, &Overrides::default())
    }

    /// Loads the scene of `shot` at `frame`, with `overrides` replacing the shot's settings.
    /// It is complete: what rendering it also needs measured comes from
    /// [`crate::prepare::Prepared`].
    pub fn load_with(shot: &Shot, frame: i64, overrides: &Overrides) -> Result<Self, RenderError> {
        let file = &shot.source;
        let base = file.parent().unwrap_or(Path::new("."));
        let sections = &shot.render;

        let settings = Settings::read(shot, overrides)?;
        let media = media::sections(file, &sections.media)?;
        let mut materials = materials::materials(file, &sections.materials)?;

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
        let mut groups = light_groups::LightGroups::new();
        let (environment, environment_group) =
            environment_section(file, base, sections.environment.as_ref(), &mut groups)?;
        let (portals, strand_looks) = portals::portals(
            shot,
            shutter,
            settings.max_portal_depth,
            ring_frame.as_ref(),
            &mut groups,
        )?;
        // Every time a ray can have: objects that move within it are blurred, the rest baked.
        let times = portals.times();
        let rig = Arc::new(shot.rig.clone());
        let objects = objects::object_sections(file, &sections.objects)?;
        // The remaining sections are read before any mesh is loaded, so their mistakes are
        // reported at once.
        let names: Vec<&str> = objects.iter().map(|o| o.name.as_str()).collect();
        let volumes = portals::cull_volumes(shot, &names)?;
        let clip = camera::clip(file, sections.camera_clip.as_ref())?;
        let stereo = camera::stereo(file, sections.camera_stereo.as_ref())?;
        let loader = objects::Loader {
            shot,
            base,
            times,
            rig: &rig,
            portals: &portals,
            media: &media,
        };
        let (parts, flags) = loader.parts(&objects, &mut materials, &mut groups)?;
        let grids = grids::load(&loader, &media.grids, frame, overrides.memory_budget)?;
        let count = objects::triangle_count(&parts);
        let grid_bytes = grids.bytes() as u64;
        if let Some(budget) = overrides.memory_budget
            && scene_bytes(count) + grid_bytes > budget
        {
            return Err(RenderError::Settings(format!(
                "{}: its meshes hold {count} triangles, which need about {} MiB to render (their \
                 BVH included), beside {} MiB of density grids: more than the {} MiB available; \
                 use lighter meshes, or give more with --max-memory where the machine has it",
                file.display(),
                scene_bytes(count) >> 20,
                grid_bytes >> 20,
                budget >> 20
            )));
        }
        let mut g = objects::Geometry::assemble(parts, objects.len(), times);
        let participating = media::volumes(
            file,
            media,
            &names,
            &g.moving,
            &g.triangles,
            &g.triangle_object,
            grids,
        )?;
        let normals: Vec<Vec3> = g
            .triangles
            .iter()
            .map(|t| t.normal().normalize_or_zero())
            .collect();

        let emitters = objects::emitters(&g, &normals, &materials);
        let (strands, ring_looks) =
            rings::strands(shot, ring_frame.as_ref(), &strand_looks, times, &rig);
        let light_groups = groups.names();
        let grouped = |v: Vec<u8>| {
            if light_groups.is_empty() {
                Vec::new()
            } else {
                v
            }
        };
        let lights = Lights::new(
            emitters,
            g.triangles.len(),
            &strands,
            times,
            &g.instances,
            environment,
            light_selection,
        );
        let static_triangles = g.static_count;
        let still = &g.triangles[..static_triangles];
        let accel = Accel::build(still, g.instances);
        let triangle_object: Arc<[u32]> = std::mem::take(&mut g.triangle_object).into();
        let object_placement = std::mem::take(&mut g.placements);
        let id_names: Vec<String> = names
            .iter()
            .map(|n| n.to_string())
            .chain(
                ring_frame
                    .iter()
                    .flat_map(|f| &f.rings)
                    .map(|c| format!("{}/ring", c.opening)),
            )
            .collect();
        let visibility = Visibility::new(
            triangle_object.clone(),
            flags,
            volumes,
            rig,
            portals.moving(),
            times[0],
        );
        Ok(Self {
            triangles: g.triangles,
            static_triangles,
            normals,
            triangle_material: g.triangle_material,
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
            triangle_object,
            id_names,
            object_count: names.len() as u32,
            object_placement,
            strands,
            strand_flags: ring_looks.iter().map(|l| l.flags).collect(),
            strand_group: grouped(ring_looks.iter().map(|l| l.group).collect()),
            triangle_group: grouped(g.triangle_group),
            light_groups,
            environment_group,
            frame,
            shutter,
        })
    }

    /// True when light sampling may look through openings: the shot allows it, and there are
    /// openings, teleports and lights.
    pub fn light_through_openings_possible(&self) -> bool {
        self.settings.light_through_openings
            && !self.portals.is_empty()
            && !self.lights.is_empty()
            && self.settings.max_portal_depth > 0
    }

    /// True when the scene holds only surfaces and lamps: no openings, media, strands, sky or
    /// hidden objects. Its paths then take the integrator's plain loop, which leaves out the
    /// tests for all of those.
    pub fn only_surfaces_and_lamps(&self) -> bool {
        self.portals.is_empty()
            && self.media.is_empty()
            && self.strands.is_empty()
            && self.lights.environment.is_none()
            && !self.visibility.hides_anything()
    }

    /// The closest surface or strand a ray of `class` sees along `ray`. A ray whose range
    /// starts past its origin is traced from there (clipping moves the camera ray's start), and
    /// the hit's parameter still counts from the origin.
    #[inline]
    pub fn intersect(&self, ray: &Ray, class: RayClass) -> Option<SceneHit> {
        from_range_start(
            ray,
            |from_origin| self.intersect_from_origin(from_origin, class),
            SceneHit::move_start,
        )
    }

    /// [`Self::intersect`] for a scene [`Self::only_surfaces_and_lamps`] holds for.
    #[inline]
    pub fn intersect_surfaces(&self, ray: &Ray) -> Option<Hit> {
        from_range_start(
            ray,
            |from_origin| self.accel.intersect(from_origin, &every_triangle),
            |h, start| h.t += start,
        )
    }

    /// [`Self::occluded`] for a scene [`Self::only_surfaces_and_lamps`] holds for.
    #[inline]
    pub fn occluded_by_surfaces(&self, ray: &Ray) -> bool {
        self.accel.occluded(ray, &every_triangle)
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
    /// origin: t in (0, t_max)); the strand segment it ends on, if any, is not tested. A ray
    /// aimed at a strand asks the strands first: most strands lie behind others, so most such
    /// rays end there without the surfaces' query.
    #[inline]
    pub fn occluded(&self, ray: &Ray, ends_on_strand: Option<u32>) -> bool {
        debug_assert!(ray.t_min == 0.0);
        let surfaces = || {
            if !self.visibility.hides_anything() {
                self.accel.occluded(ray, &every_triangle)
            } else {
                let admits = |triangle, t| {
                    self.visibility
                        .admits(triangle, RayClass::Shadow, ray.at(t), ray.time)
                };
                self.accel.occluded(ray, &admits)
            }
        };
        let strands = || {
            !self.strands.is_empty()
                && self.strands.occluded(ray, ends_on_strand, |ring| {
                    self.strand_flags[ring].sees(RayClass::Shadow)
                })
        };
        let aimed_at_strand = ends_on_strand.is_some();
        (aimed_at_strand && strands()) || surfaces() || (!aimed_at_strand && strands())
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

    /// The object triangle `t` belongs to, as [`Self::id_names`] indexes it.
    #[inline]
    pub fn object_of(&self, t: u32) -> u32 {
        self.triangle_object[t as usize]
    }

    /// The ring strand segment `segment` belongs to, as [`Self::id_names`] indexes it.
    #[inline]
    pub fn strand_object(&self, segment: u32) -> u32 {
        self.object_count + self.strands.segment_ring[segment as usize]
    }

    /// The light group of the light triangle `t` emits.
    #[inline]
    pub fn triangle_light_group(&self, t: u32) -> u8 {
        self.triangle_group.get(t as usize).copied().unwrap_or(0)
    }

    /// The light group of the light strand segment `segment` emits.
    #[inline]
    pub fn strand_light_group(&self, segment: u32) -> u8 {
        let ring = self.strands.segment_ring[segment as usize] as usize;
        self.strand_group.get(ring).copied().unwrap_or(0)
    }

    /// The material of triangle `i`.
    pub fn material(&self, triangle: u32) -> &Material {
        &self.materials[self.triangle_material[triangle as usize] as usize]
    }
}

/// The hit `from_origin` finds for `ray` traced from the start of its range, with the hit's
/// parameter counted from the ray's origin (`move_start` adds the start to it).
#[inline(always)]
fn from_range_start<H>(
    ray: &Ray,
    from_origin: impl FnOnce(&Ray) -> Option<H>,
    move_start: impl FnOnce(&mut H, f32),
) -> Option<H> {
    if ray.t_min <= 0.0 {
        return from_origin(ray);
    }
    let start = ray.t_min;
    let moved = Ray::new(ray.at(start), ray.dir, ray.t_max - start, ray.time);
    let mut hit = from_origin(&moved)?;
    move_start(&mut hit, start);
    Some(hit)
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

/// The `[environment]` section's light, when the shot has one, and its light group.
fn environment_section(
    file: &Path,
    base: &Path,
    table: Option<&toml::Table>,
    groups: &mut light_groups::LightGroups,
) -> Result<(Option<Environment>, u8), RenderError> {
    let Some(t) = table else {
        return Ok((None, 0));
    };
    let section = parse::<EnvironmentSection>(file, "environment", t)?;
    let group = groups.index(
        file,
        "environment.light_group",
        section.light_group.as_deref(),
    )?;
    Ok((Some(environment(file, base, &section)?), group))
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
            let intensity = optional(e.intensity, 1.0, |v| {
                check::non_negative("environment.intensity", v)
            })
            .map_err(invalid)?;
            let degrees = optional(e.rotation_degrees, 0.0, |v| {
                check::finite("environment.rotation_degrees", v)
            })
            .map_err(invalid)?;
            let path = base.join(map);
            let (w, h, texels) = crate::texture::read_exr_rgb(&path)
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

/// True when every coordinate of `p` is finite and within [`check::MAX_LENGTH`].
pub fn within_single_precision(p: Vec3) -> bool {
    p.is_finite() && p.abs().max_element() <= check::MAX_LENGTH as f32
}
