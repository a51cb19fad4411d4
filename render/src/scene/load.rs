//! Loading a shot's frame into a [`Scene`]: every section the renderer reads is checked first
//! ([`Sections::read`]), so a mistake is reported before any mesh is loaded; then the meshes and
//! density grids are read within the memory budget, and the geometry, media, lights and
//! ray-query structure are built from them.

use super::NO_OBJECT;
use super::light_groups::LightGroups;
use super::materials::TextureReader;
use super::media::MediaSections;
use super::objects::{Geometry, Loader, Part};
use super::portals::StrandLook;
use super::rings::RingSource;
use super::schema::ObjectSection;
use super::settings::{Overrides, Settings};
use super::{
    Entry, Scene, camera, environment, grids, lights, materials, media, objects, portals, rings,
    usd,
};
use crate::camera::{Clip, Stereo};
use crate::error::{RenderError, key_error};
use crate::geometry::{Accel, Contacts, Triangle};
use crate::lights::{Environment, Lights, ShapeLight, Sky, Sun};
use crate::material::Material;
use crate::media::grid::GridMedia;
use crate::portals::Portals;
use crate::portals::visibility::{CullVolume, Flags, Visibility};
use crate::texture::Textures;
use glam::Vec3;
use rift_fx::Shot;
use rift_fx::ring::RingFrame;
use std::path::Path;
use std::sync::Arc;

/// Bytes a scene of `triangles` triangles takes at its peak while it is built: the triangles
/// as loaded, baked and stored with their normals, UVs and indices, and the BVH builder's working
/// set (about 280 bytes a triangle, measured on 0.5 to 4 million).
pub fn scene_bytes(triangles: usize) -> u64 {
    const PER_TRIANGLE: u64 = 400;
    (triangles as u64).saturating_mul(PER_TRIANGLE)
}

/// Every section of the shot the renderer reads, checked.
struct Sections {
    settings: Settings,
    media: MediaSections,
    materials: Vec<Material>,
    /// The materials' textures.
    textures: Textures,
    /// Shutter open and close, seconds.
    shutter: [f64; 2],
    rings: Option<RingFrame>,
    groups: LightGroups,
    environment: Option<Environment>,
    environment_group: u8,
    shape_lights: Vec<ShapeLight>,
    suns: Vec<Sun>,
    portals: Portals,
    strand_looks: Vec<StrandLook>,
    objects: Vec<ObjectSection>,
    cull_volumes: Vec<CullVolume>,
    clip: Clip,
    stereo: Option<Stereo>,
    /// What the USD layers hold that rift does not read.
    warnings: Vec<String>,
    /// How many of `objects` (the first) USD layers brought.
    imported: usize,
}

impl Sections {
    /// The sections of `shot` at `frame`, with `overrides` applied, in the order their
    /// mistakes are reported.
    fn read(shot: &Shot, frame: i64, overrides: &Overrides) -> Result<Self, RenderError> {
        let file = &shot.source;
        let base = file.parent().unwrap_or(Path::new("."));
        let sections = &shot.render;
        let settings = Settings::read(shot, overrides)?;
        let media = media::sections(file, &sections.media)?;
        let mut textures = Textures::default();
        let mut reader = TextureReader {
            file,
            textures: &mut textures,
            budget: overrides.memory_budget,
        };
        let materials = materials::materials(
            &Entry::of_shot(file, "material", &sections.materials),
            &mut reader,
        )?;
        let shutter = shot
            .shutter_seconds()
            .map(|s| s + shot.time_of(frame as f64));
        let rings = rings::load(shot, frame, &ring_source(shot, &settings, overrides))?;
        let mut groups = LightGroups::new();
        let shot_environment = sections.environment.as_ref().map(|table| Entry {
            file: file.clone(),
            key: "environment".into(),
            table: table.clone(),
        });
        let (environment, environment_group) =
            environment::environment_section(shot_environment.as_ref(), base, &mut groups)?;
        let shot_lights = Entry::of_shot(file, "light", &sections.lights);
        let (shape_lights, suns) = lights::lights(shot, &shot_lights, &mut groups)?;
        let (portals, strand_looks) = portals::portals(
            shot,
            shutter,
            settings.max_portal_depth,
            rings.as_ref(),
            &mut groups,
        )?;
        let mut imported = usd::import(
            shot,
            portals.times(),
            portals.largest_time_offset(),
            overrides.memory_budget,
        )?;
        let usd_objects = std::mem::take(&mut imported.objects);
        let imported_objects = usd_objects.len();
        let objects = objects::object_sections(file, &sections.objects, usd_objects)?;
        let names: Vec<&str> = objects.iter().map(|o| o.name.as_str()).collect();
        let mut read = Self {
            cull_volumes: portals::cull_volumes(shot, &names)?,
            clip: camera::clip(file, sections.camera_clip.as_ref())?,
            stereo: camera::stereo(file, sections.camera_stereo.as_ref())?,
            settings,
            media,
            materials,
            textures,
            shutter,
            rings,
            groups,
            environment,
            environment_group,
            shape_lights,
            suns,
            portals,
            strand_looks,
            objects,
            warnings: Vec::new(),
            imported: imported_objects,
        };
        read.add_imported(shot, imported, overrides.memory_budget)?;
        Ok(read)
    }

    /// What USD layers bring beside their objects: their materials and lights after the
    /// shot's (what the shot file says of the same name wins), their dome where the shot gives
    /// no environment, and what they hold that rift does not read.
    fn add_imported(
        &mut self,
        shot: &Shot,
        imported: usd::Imported,
        budget: Option<u64>,
    ) -> Result<(), RenderError> {
        let file = &shot.source;
        let named = |e: &Entry| {
            e.table
                .get("name")
                .and_then(|n| n.as_str())
                .map(str::to_owned)
        };
        let materials: Vec<Entry> = (imported.materials.into_iter())
            .filter(|e| {
                !self
                    .materials
                    .iter()
                    .any(|m| Some(&m.name) == named(e).as_ref())
            })
            .collect();
        let mut reader = TextureReader {
            file,
            textures: &mut self.textures,
            budget,
        };
        self.materials
            .extend(materials::materials(&materials, &mut reader)?);
        let (shapes, suns) = lights::lights(shot, &imported.lights, &mut self.groups)?;
        self.shape_lights.extend(shapes);
        self.suns.extend(suns);
        if self.environment.is_none() {
            let base = file.parent().unwrap_or(Path::new("."));
            (self.environment, self.environment_group) = environment::environment_section(
                imported.environment.as_ref(),
                base,
                &mut self.groups,
            )?;
        }
        self.warnings = imported.warnings;
        Ok(())
    }
}

/// Where the frame's rings come from: `--rings`, else the shot's `[render] rings` or its
/// generated rings.
fn ring_source(shot: &Shot, settings: &Settings, overrides: &Overrides) -> RingSource {
    match &overrides.rings {
        Some(pattern) => RingSource::Cache {
            pattern: pattern.clone(),
            key: None,
        },
        None => rings::shot_source(shot, settings.rings.as_deref()),
    }
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
        if let Some(prim) = shot.camera_prim.as_ref().filter(|_| !shot.camera_read) {
            return Err(key_error(
                file,
                "camera.usd",
                format!(
                    "the USD camera {prim:?} has not been read into the shot \
                     (scene::usd::camera::read_camera)"
                ),
            ));
        }
        let mut s = Sections::read(shot, frame, overrides)?;
        // Every time a ray can have: objects that move within it are blurred, the rest baked.
        let times = s.portals.times();
        let rig = Arc::new(shot.rig.clone());
        let loader = Loader {
            shot,
            base: file.parent().unwrap_or(Path::new(".")),
            times,
            rig: &rig,
            portals: &s.portals,
            media: &s.media,
            imported: s.imported,
        };
        let mut reader = TextureReader {
            file,
            textures: &mut s.textures,
            budget: overrides.memory_budget,
        };
        let (parts, flags) =
            loader.parts(&s.objects, &mut s.materials, &mut s.groups, &mut reader)?;
        let grids = grids::load(&loader, &s.media.grids, frame, overrides.memory_budget)?;
        let triangles = objects::triangle_count(&parts);
        let other_bytes = grids.bytes() as u64
            + s.textures.bytes()
            + objects::deformation_bytes(&parts)
            + objects::instance_bytes(&parts);
        check_memory(file, triangles, other_bytes, overrides.memory_budget)?;
        let selection = overrides.light_selection.unwrap_or_default();
        Self::assemble(shot, frame, s, (parts, flags), grids, rig, selection)
    }

    /// The scene of `shot` at `frame` from its checked sections, its objects' `parts` and
    /// visibility flags, and its density grids; lights picked by `selection`.
    fn assemble(
        shot: &Shot,
        frame: i64,
        s: Sections,
        (parts, flags): (Vec<Part>, Vec<Flags>),
        grids: GridMedia,
        rig: Arc<rift_fx::rig::Rig>,
        selection: crate::lights::LightSelection,
    ) -> Result<Self, RenderError> {
        let file = &shot.source;
        let times = s.portals.times();
        let names: Vec<&str> = s.objects.iter().map(|o| o.name.as_str()).collect();
        let warnings = (s.warnings.iter().cloned())
            .chain(parts.iter().flat_map(|p| p.warnings.clone()))
            .collect();
        let mut g = Geometry::assemble(parts, names.len(), times);
        let media = media::volumes(
            file,
            s.media,
            &names,
            &g.moving,
            &g.triangles,
            &g.triangle_object,
            grids,
        )?;
        let normals = unit_normals(&g.triangles);
        let emitters = objects::emitters(&g, &normals, &s.materials, s.textures.list());
        let (strands, ring_looks) =
            rings::strands(shot, s.rings.as_ref(), &s.strand_looks, times, &rig);
        let lights = Lights::new(
            emitters,
            g.triangles.len(),
            &strands,
            s.shape_lights,
            times,
            &g.instances,
            Sky::new(s.environment, s.suns),
            selection,
        );
        let surfaces = Surfaces::of(file, &g, &normals, &s.materials, &names)?;
        let object_instances = g.instanced_objects();
        let (id_names, instance_object) = id_names(
            &names,
            s.rings.as_ref(),
            std::mem::take(&mut g.instance_names),
        );
        let accel = Accel::build(&g.triangles[..g.static_count], g.instances);
        let triangle_object: Arc<[u32]> = std::mem::take(&mut g.triangle_object).into();
        let visibility = Visibility::new(
            triangle_object.clone(),
            flags,
            s.cull_volumes,
            rig,
            s.portals.moving(),
            times[0],
        );
        let light_groups = s.groups.names();
        let grouped = |v: Vec<u8>| {
            if light_groups.is_empty() {
                Vec::new()
            } else {
                v
            }
        };
        Ok(Self {
            id_names,
            instance_object,
            object_count: names.len() as u32,
            static_triangles: g.static_count,
            triangles: g.triangles,
            triangle_uvs: g.triangle_uvs,
            triangle_normals: g.triangle_normals,
            textures: s.textures,
            warnings,
            normals,
            triangle_material: g.triangle_material,
            materials: s.materials,
            accel,
            contacts: surfaces.contacts,
            cut_out: surfaces.cut_out,
            normal_maps: surfaces.normal_maps,
            lights,
            settings: s.settings,
            camera: frame_camera(shot, frame),
            clip: s.clip,
            stereo: s.stereo,
            portals: s.portals,
            visibility,
            media,
            triangle_object,
            object_placement: g.placements,
            object_instances,
            strands,
            strand_flags: ring_looks.iter().map(|l| l.flags).collect(),
            strand_group: grouped(ring_looks.iter().map(|l| l.group).collect()),
            triangle_group: grouped(g.triangle_group),
            light_groups,
            environment_group: s.environment_group,
            frame,
            shutter: s.shutter,
        })
    }
}

/// What the path loop must know of the scene's surfaces beyond their BSDFs.
struct Surfaces {
    contacts: Contacts,
    cut_out: bool,
    normal_maps: bool,
}

impl Surfaces {
    /// Those of geometry `g` (unit `normals`) with its `materials`; `names` are the objects'
    /// (for messages).
    fn of(
        file: &Path,
        g: &Geometry,
        normals: &[Vec3],
        materials: &[Material],
        names: &[&str],
    ) -> Result<Self, RenderError> {
        Ok(Self {
            contacts: contacts(g, normals, materials),
            cut_out: cut_outs(file, g, materials, names)?,
            normal_maps: materials.iter().any(|m| m.normal_mapped()),
        })
    }
}

/// Where the static triangles of different objects touch (see [`Contacts`]).
fn contacts(g: &Geometry, normals: &[Vec3], materials: &[Material]) -> Contacts {
    let count = g.static_count;
    let material = |t: u32| &materials[g.triangle_material[t as usize] as usize];
    Contacts::find(
        &g.triangles[..count],
        &normals[..count],
        &g.triangle_object[..count],
        |t| material(t).bsdf.transmits(),
        |t| material(t).optical_contact,
    )
}

/// True when some static triangle's material is a cut-out; a moving or instanced object with
/// one is refused (its rays meet its triangles in object space, where the alpha test has no
/// point to read the opacity at), naming the object.
fn cut_outs(
    file: &Path,
    g: &Geometry,
    materials: &[Material],
    names: &[&str],
) -> Result<bool, RenderError> {
    let cuts = |t: usize| materials[g.triangle_material[t] as usize].cuts_out();
    if let Some(t) = (g.static_count..g.triangles.len()).find(|&t| cuts(t)) {
        let object = g.triangle_object[t] as usize;
        let material = &materials[g.triangle_material[t] as usize].name;
        return Err(key_error(
            file,
            format!("object[{object}]"),
            format!(
                "object {:?} moves or is instanced, and its material {material:?} cuts out \
                 (opacity): cut-outs work on objects that stand still",
                names.get(object).copied().unwrap_or("?")
            ),
        ));
    }
    Ok((0..g.static_count).any(cuts))
}

/// Refuses a scene of `triangles` triangles and `other_bytes` of density grids and textures
/// that would not fit in `budget` bytes, before any BVH is built.
fn check_memory(
    file: &Path,
    triangles: usize,
    other_bytes: u64,
    budget: Option<u64>,
) -> Result<(), RenderError> {
    match budget {
        Some(budget) if scene_bytes(triangles) + other_bytes > budget => {
            Err(RenderError::Settings(format!(
                "{}: its meshes hold {triangles} triangles, which need about {} MiB to render \
                 (their BVH included), beside {} MiB of density grids, textures and deforming meshes: more than \
                 the {} MiB available; use lighter meshes, or give more with --max-memory \
                 where the machine has it",
                file.display(),
                scene_bytes(triangles) >> 20,
                other_bytes >> 20,
                budget >> 20
            )))
        }
        _ => Ok(()),
    }
}

/// The unit geometric normal of each triangle (zero for a degenerate one).
fn unit_normals(triangles: &[Triangle]) -> Vec<Vec3> {
    triangles
        .iter()
        .map(|t| t.normal().normalize_or_zero())
        .collect()
}

/// The names object IDs index: the objects', then each ring's (`"<opening>/ring"`), then those
/// of the moving instances that have names of their own (`instance_names`, one per moving
/// instance); and per moving instance, the index of its name, or [`NO_OBJECT`] (its object's).
fn id_names(
    objects: &[&str],
    rings: Option<&RingFrame>,
    instance_names: Vec<Option<String>>,
) -> (Vec<String>, Vec<u32>) {
    let rings = rings.iter().flat_map(|f| &f.rings);
    let mut names: Vec<String> = (objects.iter())
        .map(|n| n.to_string())
        .chain(rings.map(|c| format!("{}/ring", c.opening)))
        .collect();
    let instance_object = (instance_names.into_iter())
        .map(|name| match name {
            Some(name) => {
                names.push(name);
                names.len() as u32 - 1
            }
            None => NO_OBJECT,
        })
        .collect();
    (names, instance_object)
}

/// The shot camera as `frame` renders it: a lens that changes over the shot is the frame's for
/// the whole frame.
fn frame_camera(shot: &Shot, frame: i64) -> rift_fx::rig::Camera {
    rift_fx::rig::Camera {
        projection: shot.camera.projection_at(shot.time_of(frame as f64)),
        ..shot.camera.clone()
    }
}
