//! The render scene built from a shot: triangles with materials (static ones baked to world
//! space, moving ones kept in object space under their keyframed transform), the ray-query
//! structure, emitters, the camera, the shutter and render settings. Syntax of the renderer's shot
//! sections: [`schema`].

pub mod camera;
pub mod characters;
mod environment;
pub mod grids;
pub mod light_groups;
mod lights;
mod load;
mod materials;
pub mod media;
pub mod mesh;
pub mod metals;
mod objects;
pub mod ply;
pub mod portals;
pub mod rings;
pub mod schema;
pub(crate) mod sequence;
mod settings;
pub mod usd;

pub use load::scene_bytes;
pub use settings::{Overrides, Settings};

use crate::camera::{Clip, Stereo};
use crate::error::{RenderError, key_error};
use crate::geometry::ray::Ray;
use crate::geometry::{
    Accel, Hit, PackedNormal, STATIC, StrandHit, Strands, Triangle, changes_during, every_triangle,
};
use crate::lights::Lights;
use crate::material::surface::Material;
use crate::portals::openings::Portals;
use crate::portals::visibility::{Flags, RayClass, Visibility};
use crate::texture::Textures;
use glam::Vec3;
use rift_fx::Invalid;
use rift_fx::rig::{AnimatedTransform, Camera};
use rift_fx::shot::check;
use schema::VisibilitySection;
use serde::de::DeserializeOwned;
use std::path::Path;
use std::sync::Arc;

/// The object index of no object (the sky, a medium, an opening at the depth limit), beside
/// the indices of [`Scene::id_names`].
pub const NO_OBJECT: u32 = u32::MAX;

/// A section as a table, with where it came from for messages: the shot file and its key
/// (`material[2]`), or a USD layer and the prim it was made from (`</World/Looks/Wood>`).
pub struct Entry {
    pub file: std::path::PathBuf,
    pub key: String,
    pub table: toml::Table,
}

impl Entry {
    /// The shot's own sections `tables`, keyed `<name>[i]`.
    pub(crate) fn of_shot(file: &Path, name: &str, tables: &[toml::Table]) -> Vec<Entry> {
        tables
            .iter()
            .enumerate()
            .map(|(i, table)| Entry {
                file: file.to_owned(),
                key: format!("{name}[{i}]"),
                table: table.clone(),
            })
            .collect()
    }
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
    /// Static triangles (world space) first, then each moving object's (object space); a
    /// deforming object's in its first sample's shape (its shape at a time:
    /// [`Self::object_triangle`]).
    pub triangles: Vec<Triangle>,
    /// Per triangle, its corners' UVs; empty when no mesh gives any.
    pub triangle_uvs: Vec<[glam::Vec2; 3]>,
    /// Per triangle, its corners' authored normals in the triangle's space, for smooth shading
    /// ([`PackedNormal::NONE`]: shaded flat); empty when no mesh gives any.
    pub triangle_normals: Vec<[PackedNormal; 3]>,
    /// The materials' textures, by index.
    pub textures: Textures,
    /// What the shot asks for that rift does not do yet, rendered without (for the user).
    pub warnings: Vec<String>,
    /// How many of [`Self::triangles`] are static.
    pub static_triangles: usize,
    /// Unit geometric normal per triangle, in the triangle's space (a deforming object's at
    /// its first sample; [`Self::surface`] gives the normal at a hit's time).
    pub normals: Vec<Vec3>,
    /// Material index per triangle.
    pub triangle_material: Vec<u32>,
    pub materials: Vec<Material>,
    pub accel: Accel,
    /// Where static surfaces of different objects touch.
    pub contacts: crate::geometry::Contacts,
    /// Some static triangle's material is a cut-out ([`Material::cuts_out`]): rays test
    /// opacity where they meet it.
    pub cut_out: bool,
    /// Some material has a normal map.
    pub normal_maps: bool,
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
    /// The objects', then the rings' names (`"<opening>/ring"`), then the names of instances
    /// that have their own (a USD prototype's), which object IDs index (Cryptomatte).
    pub id_names: Vec<String>,
    /// Per moving instance of [`Self::accel`], its name's index in [`Self::id_names`] where it
    /// has one of its own, else [`NO_OBJECT`] (its triangles' object's).
    pub instance_object: Vec<u32>,
    /// How many of [`Self::id_names`] are objects (the rings follow).
    pub object_count: u32,
    /// Per object, its placement over time. The triangles in [`Self::triangles`] of objects
    /// that move within the shutter are in object space, the others in world space.
    pub object_placement: Vec<crate::geometry::ObjectMotion>,
    /// Instanced objects (a USD PointInstancer's prototype, say) and the range of their
    /// instances in [`Self::accel`]'s moving instances: their triangles, in the prototype's
    /// space, are drawn once for each.
    pub object_instances: Vec<(u32, std::ops::Range<u32>)>,
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
    /// True when light sampling may look through openings: the shot allows it, and light can
    /// come through openings at all.
    pub fn light_through_openings_possible(&self) -> bool {
        self.settings.light_through_openings && self.light_can_come_through_openings()
    }

    /// True when bounces may be aimed at openings: the shot allows it, and light can come
    /// through openings at all.
    pub fn guide_through_openings_possible(&self) -> bool {
        self.settings.guide_through_openings && self.light_can_come_through_openings()
    }

    /// True when there are openings, teleports and lights.
    fn light_can_come_through_openings(&self) -> bool {
        !self.portals.is_empty() && !self.lights.is_empty() && self.settings.max_portal_depth > 0
    }

    /// True when the scene holds only surfaces and lamps: no openings, media, strands, sky,
    /// shape lights or hidden objects. Its paths then take the integrator's plain loop, which leaves out the
    /// tests for all of those.
    pub fn only_surfaces_and_lamps(&self) -> bool {
        self.portals.is_empty()
            && self.media.is_empty()
            && self.strands.is_empty()
            && self.lights.sky.is_none()
            && self.lights.shapes.is_empty()
            && !self.visibility.hides_anything()
            && !self.cut_out
            && !self.normal_maps
            && self.triangle_normals.is_empty()
            && self.contacts.is_empty()
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
        let surface = if !self.visibility.hides_anything() && !self.cut_out {
            self.accel.intersect(ray, &every_triangle)
        } else {
            let admits = |triangle, t| {
                self.visibility.admits(triangle, class, ray.at(t), ray.time)
                    && self.solid_at(triangle, ray, t)
            };
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
            if !self.visibility.hides_anything() && !self.cut_out {
                self.accel.occluded(ray, &every_triangle)
            } else {
                let admits = |triangle, t| {
                    self.visibility
                        .admits(triangle, RayClass::Shadow, ray.at(t), ray.time)
                        && self.solid_at(triangle, ray, t)
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

    /// False where `ray` passes the cut-out triangle `triangle` at `t` without meeting it: the
    /// material's opacity there against a number hashed from the ray and the triangle, so a
    /// ray asked again gets the same answer, and over many rays the share that pass is
    /// 1 − opacity (as pbrt's alpha test). Only static triangles cut out (load refuses the
    /// others), so the point's barycentrics come from the world-space triangle.
    #[inline(never)]
    fn solid_at(&self, triangle: u32, ray: &Ray, t: f32) -> bool {
        if triangle as usize >= self.static_triangles {
            return true;
        }
        let material = self.material(triangle);
        if !material.cuts_out() {
            return true;
        }
        let (b1, b2) = barycentrics(&self.triangles[triangle as usize], ray.at(t));
        let uv = self.uv_of(triangle, b1, b2);
        let opacity = material.opacity_at(self.textures.list(), uv);
        if opacity >= 1.0 {
            return true;
        }
        let bits = [ray.origin.to_array(), ray.dir.to_array()]
            .concat()
            .iter()
            .fold(triangle, |h, x| crate::sampling::hash32(h ^ x.to_bits()));
        ((bits >> 8) as f32 / (1u32 << 24) as f32) < opacity
    }

    /// The texture coordinates of `hit` and how many UV units a metre of the surface spans
    /// there at `time` (its triangle's world area is `area_scale` times its object-space
    /// area); `None` when no mesh gives UVs.
    pub fn uv_at(&self, hit: &Hit, time: f64, area_scale: f32) -> Option<(glam::Vec2, f32)> {
        let [a, b, c] = *self.triangle_uvs.get(hit.triangle as usize)?;
        let uv = interpolated(&[a, b, c], hit.b1, hit.b2);
        let uv_area = 0.5 * (b - a).perp_dot(c - a).abs();
        let world_area = self
            .object_triangle(hit.triangle, hit.instance, time)
            .area()
            * area_scale;
        let per_metre = if world_area > 0.0 {
            (uv_area / world_area).sqrt()
        } else {
            0.0
        };
        Some((uv, per_metre))
    }

    /// The texture coordinates of triangle `triangle` at barycentrics `(b1, b2)`; `None` when
    /// no mesh gives UVs.
    fn uv_of(&self, triangle: u32, b1: f32, b2: f32) -> Option<glam::Vec2> {
        let uvs = self.triangle_uvs.get(triangle as usize)?;
        Some(interpolated(uvs, b1, b2))
    }

    /// The radiance triangle `triangle` emits at barycentrics `(b1, b2)`, from its material's
    /// emission texture at that point's UV (or its constant emission): where light sampling
    /// draws a point, and where a ray meets a textured emitter.
    pub fn emitted_at(&self, triangle: u32, b1: f32, b2: f32) -> Vec3 {
        let uv = self.uv_of(triangle, b1, b2);
        self.material(triangle)
            .radiance_at(self.textures.list(), uv)
    }

    /// The surface's derivatives ∂p/∂u and ∂p/∂v on the triangle of `hit` (world space at
    /// `time`), for a tangent frame; `None` without UVs or where the UVs are degenerate.
    pub fn tangents(&self, hit: &Hit, time: f64) -> Option<(Vec3, Vec3)> {
        let [a, b, c] = *self.triangle_uvs.get(hit.triangle as usize)?;
        let tri = self.object_triangle(hit.triangle, hit.instance, time);
        let (e1, e2) = (tri.v[1] - tri.v[0], tri.v[2] - tri.v[0]);
        let (d1, d2) = (b - a, c - a);
        let det = d1.perp_dot(d2);
        if det.abs() < 1e-12 {
            return None;
        }
        let dpdu = (e1 * d2.y - e2 * d1.y) / det;
        let dpdv = (e2 * d1.x - e1 * d2.x) / det;
        if hit.instance == STATIC {
            return Some((dpdu, dpdv));
        }
        let placement = self.accel.placement(hit.instance, time);
        let to_world = |v: Vec3| placement.to_world.transform_vector3(v);
        Some((to_world(dpdu), to_world(dpdv)))
    }

    /// The smooth-shading normal at `hit` at time `time`: its triangle's authored corner
    /// normals interpolated, in world space, turned to the side of the geometric normal `ng`;
    /// `None` where the mesh gives no normals.
    #[inline]
    pub fn shading_normal(&self, hit: &Hit, time: f64, ng: Vec3) -> Option<Vec3> {
        let [a, b, c] = *self.triangle_normals.get(hit.triangle as usize)?;
        let (a, b, c) = (a.get()?, b.unpack(), c.unpack());
        let stored = || a * (1.0 - hit.b1 - hit.b2) + b * hit.b1 + c * hit.b2;
        let n = match hit.instance {
            STATIC => stored(),
            instance => {
                let barycentrics = (hit.b1, hit.b2);
                let n = (self.accel)
                    .deformed_normal(instance, hit.triangle, time, barycentrics)
                    .unwrap_or_else(stored);
                (self.accel.placement(instance, time).to_world).transform_vector3(n)
            }
        };
        let n = n.try_normalize()?;
        Some(if n.dot(ng) < 0.0 { -n } else { n })
    }

    /// The point over `hit` (at time `time`) on the smooth surface its triangle's corner
    /// normals describe, in world space, on the side of the unit vector `side`; `None` where
    /// the mesh gives no normals. A coarse mesh's flat triangle lies inside the round surface
    /// its normals stand for; rays leaving from this point instead of the triangle see past
    /// the neighbouring triangles as they would past that surface, which keeps the shadow line
    /// where light grazes round instead of stepping with the facets (Hanika's terminator
    /// offset, as Cycles uses it): the hit point is pushed out of each corner's tangent plane
    /// it lies under, the pushes blended by the barycentrics.
    pub fn smooth_point(&self, hit: &Hit, time: f64, side: Vec3) -> Option<Vec3> {
        let [a, b, c] = *self.triangle_normals.get(hit.triangle as usize)?;
        let stored = [a.get()?, b.unpack(), c.unpack()];
        let (b1, b2) = (hit.b1, hit.b2);
        let tri = self.object_triangle(hit.triangle, hit.instance, time);
        let p = tri.point(b1, b2);
        let weights = [1.0 - b1 - b2, b1, b2];
        let (corners, side) = match hit.instance {
            STATIC => (stored, side),
            instance => {
                let corner = |k: usize, at: (f32, f32)| {
                    (self.accel)
                        .deformed_normal(instance, hit.triangle, time, at)
                        .and_then(Vec3::try_normalize)
                        .unwrap_or(stored[k])
                };
                let corners = [
                    corner(0, (0.0, 0.0)),
                    corner(1, (1.0, 0.0)),
                    corner(2, (0.0, 1.0)),
                ];
                let to_object = self.accel.placement(instance, time).to_object;
                (corners, to_object.transform_vector3(side))
            }
        };
        // The corner normals turned together to the path's side, as the shading normal is.
        let blended: Vec3 = (0..3).map(|k| corners[k] * weights[k]).sum();
        let turn = if blended.dot(side) < 0.0 { -1.0 } else { 1.0 };
        let lift: Vec3 = (0..3)
            .map(|k| {
                let n = corners[k] * turn;
                let under = (p - tri.v[k]).dot(n).min(0.0);
                n * (-under * weights[k])
            })
            .sum();
        let smooth = p + lift;
        Some(match hit.instance {
            STATIC => smooth,
            instance => (self.accel.placement(instance, time).to_world).transform_point3(smooth),
        })
    }

    /// The world-space point and normal of `hit` at time `time`.
    #[inline]
    pub fn surface(&self, hit: &Hit, time: f64) -> SurfacePoint {
        let stored = &self.triangles[hit.triangle as usize];
        if hit.instance == STATIC {
            return SurfacePoint {
                p: stored.point(hit.b1, hit.b2),
                ng: self.normals[hit.triangle as usize],
                area_scale: 1.0,
            };
        }
        let (p, n) = match self
            .accel
            .deformed_triangle(hit.instance, hit.triangle, time)
        {
            None => (
                stored.point(hit.b1, hit.b2),
                self.normals[hit.triangle as usize],
            ),
            Some(tri) => (tri.point(hit.b1, hit.b2), tri.normal().normalize_or_zero()),
        };
        let placement = self.accel.placement(hit.instance, time);
        SurfacePoint {
            p: placement.to_world.transform_point3(p),
            ng: placement.to_world.transform_vector3(n).normalize(),
            area_scale: placement.scale * placement.scale,
        }
    }

    /// Triangle `i` of `instance` at time `time` in its own space: a static triangle's is the
    /// world, a moving one's its object's, where a deforming object has its shape at `time`.
    #[inline]
    pub fn object_triangle(&self, i: u32, instance: u32, time: f64) -> Triangle {
        if instance == STATIC {
            return self.triangles[i as usize];
        }
        match self.accel.deformed_triangle(instance, i, time) {
            Some(tri) => tri,
            None => self.triangles[i as usize],
        }
    }

    /// Triangle `i` of `instance` in world space at time `time`.
    pub fn world_triangle(&self, i: u32, instance: u32, time: f64) -> Triangle {
        let tri = self.object_triangle(i, instance, time);
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

    /// Where each instance of instanced object `object` is at `time`; empty for an object that
    /// is not instanced.
    pub fn instance_placements(&self, object: u32, time: f64) -> Vec<rift_fx::rig::Similarity> {
        (self.instances_of(object))
            .map(|i| self.accel.instance_at(i, time))
            .collect()
    }

    /// The names the instances of instanced object `object` go by in ID passes (each its own,
    /// or the object's); empty for other objects.
    pub fn instance_names(&self, object: u32) -> Vec<&str> {
        (self.instances_of(object))
            .map(|i| self.id_names[self.named_instance(i).unwrap_or(object) as usize].as_str())
            .collect()
    }

    /// The moving instances of instanced object `object` (none for other objects).
    fn instances_of(&self, object: u32) -> std::ops::Range<u32> {
        let found = self.object_instances.iter().find(|(o, _)| *o == object);
        found.map_or(0..0, |(_, instances)| instances.clone())
    }

    /// The index in [`Self::id_names`] of moving instance `instance`'s own name, if it has one.
    #[inline]
    fn named_instance(&self, instance: u32) -> Option<u32> {
        let named = *self.instance_object.get(instance as usize)?;
        (named != NO_OBJECT).then_some(named)
    }

    /// The object (or named instance) `hit` met, as [`Self::id_names`] indexes it.
    #[inline]
    pub fn object_at(&self, hit: &Hit) -> u32 {
        (self.named_instance(hit.instance)).unwrap_or_else(|| self.object_of(hit.triangle))
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

/// The barycentric coordinates (of the second and third corners) of point `p` on `tri`.
fn barycentrics(tri: &Triangle, p: Vec3) -> (f32, f32) {
    let (e1, e2, d) = (tri.v[1] - tri.v[0], tri.v[2] - tri.v[0], p - tri.v[0]);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d1, d2) = (d.dot(e1), d.dot(e2));
    let det = d11 * d22 - d12 * d12;
    if det.abs() < f32::MIN_POSITIVE {
        return (0.0, 0.0);
    }
    ((d22 * d1 - d12 * d2) / det, (d11 * d2 - d12 * d1) / det)
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

/// The value at barycentrics `(b1, b2)` of a triangle whose corners hold `[a, b, c]`.
pub(crate) fn interpolated(&[a, b, c]: &[glam::Vec2; 3], b1: f32, b2: f32) -> glam::Vec2 {
    a * (1.0 - b1 - b2) + b * b1 + c * b2
}

/// Loads an OBJ (with its MTL files) or a PLY mesh, by the file's extension.
pub fn load_mesh(path: &std::path::Path) -> Result<Vec<mesh::MeshPart>, RenderError> {
    match path.extension().and_then(|e| e.to_str()) {
        Some(ext) if ext.eq_ignore_ascii_case("obj") => mesh::load_obj(path),
        Some(ext) if ext.eq_ignore_ascii_case("ply") => ply::load_ply(path),
        _ => Err(RenderError::Mesh {
            file: path.to_owned(),
            message: "expected an .obj or .ply file".into(),
        }),
    }
}

/// True when every coordinate of `p` is finite and within [`check::MAX_LENGTH`].
pub fn within_single_precision(p: Vec3) -> bool {
    p.is_finite() && p.abs().max_element() <= check::MAX_LENGTH as f32
}
