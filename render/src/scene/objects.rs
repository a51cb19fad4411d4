//! `[[object]]` sections into triangles: each object's mesh loaded, its material found, and its
//! triangles baked to world space when it stands still within the times rays can reach, or kept
//! in object space under its motion (keyed, or carried through an opening) when it moves; then
//! all of them gathered, still ones first, into the arrays the scene holds.

use super::light_groups::LightGroups;
use super::materials::{self, BOUNDARY_MATERIAL, TextureReader};
use super::media::MediaSections;
use super::schema::{ObjectSection, StageOrigin};
use super::sequence::{self, Sequence};
use super::{flags, mesh, parse, within_single_precision};
use crate::error::{RenderError, key_error};
use crate::geometry::triangle_bvh::TriangleBvh;
use crate::geometry::{Deformation, MovingInstance, ObjectMotion, PackedNormal, STATIC, Triangle};
use crate::lights::emitters::Emitter;
use crate::material::inputs::{ColorInput, Lookup};
use crate::material::surface::Material;
use crate::portals::openings::Portals;
use crate::portals::visibility::Flags;
use crate::sampling::uniform_triangle;
use crate::texture::Texture;
use glam::{DQuat, DVec3, Vec2, Vec3};
use rift_fx::rig::{AnimatedTransform, Rig, Similarity};
use rift_fx::shot::check;
use rift_fx::shot::pose::{self, Facing};
use rift_fx::{Invalid, Shot};
use std::collections::HashMap;
use std::ops::Range;
use std::path::Path;
use std::path::PathBuf;
use std::sync::Arc;

/// One object's triangles on their way into the scene.
pub(super) struct Part {
    /// Index of the `[[object]]`.
    object: u32,
    triangles: Vec<Triangle>,
    /// Per triangle, its corners' UVs; empty when no part of its mesh gives any.
    uvs: Vec<[Vec2; 3]>,
    /// Per triangle, its corners' shading normals in the triangles' space ([`PackedNormal::NONE`]
    /// where its part gives none: shaded flat); empty when no part of its mesh gives any.
    normals: Vec<[PackedNormal; 3]>,
    materials: Vec<u32>,
    /// Its placement over time.
    motion: ObjectMotion,
    /// Its mesh's shape over time, where it comes from a mesh sequence (shared by copies).
    deformation: Option<Arc<Deformation>>,
    /// Where its mesh is instanced (its triangles and BVH shared by all): the placement of
    /// each instance; empty for an object placed once by `motion`.
    instances: Vec<ObjectMotion>,
    /// The name each instance goes by in ID passes, where they have names of their own.
    instance_names: Vec<String>,
    /// Whether it moves within the times rays can reach (else its triangles are baked to
    /// world space).
    moves: bool,
    /// The light group of its emissive triangles.
    group: u8,
    /// What its mesh asks for that rift does not do yet (rendered without).
    pub warnings: Vec<String>,
}

/// The `[[object]]` sections after the `imported` objects of USD layers, with names checked
/// unique (a section named like a USD prim, without a mesh, changes that prim's object
/// instead) and each `copy_of` filled in from the earlier object it names (mesh, material and
/// transform, where the copy gives none).
pub(super) fn object_sections(
    file: &Path,
    tables: &[toml::Table],
    imported: Vec<ObjectSection>,
) -> Result<Vec<ObjectSection>, RenderError> {
    let mut out: Vec<ObjectSection> = imported;
    for (i, table) in tables.iter().enumerate() {
        let key = format!("object[{i}]");
        let mut o: ObjectSection = parse(file, &key, table)?;
        // A section named like a USD prim, with no mesh of its own, changes that object.
        if let Some(prim) = out
            .iter_mut()
            .find(|x| x.name == o.name && x.shape.is_some() && x.copy_of.is_none())
            .filter(|_| o.mesh.is_none() && o.copy_of.is_none())
        {
            override_prim(prim, o);
            continue;
        }
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
            if o.mesh.is_none() {
                o.shape = from.shape.clone();
            }
            o.mesh = o.mesh.or_else(|| from.mesh.clone());
            o.material = o.material.or_else(|| from.material.clone());
            o.stage_origin = match o.transform {
                Some(_) => from.stage_origin.replaced(),
                None => from.stage_origin,
            };
            o.transform = o.transform.or_else(|| from.transform.clone());
            if o.transform.is_none() {
                o.instances = from.instances.clone();
            }
        }
        out.push(o);
    }
    Ok(out)
}

/// What a shot-file section named like a USD prim changes of it: its material, transform,
/// opening, visibility and light group, each where the section gives it.
fn override_prim(prim: &mut ObjectSection, o: ObjectSection) {
    prim.material = o.material.or(prim.material.take());
    if o.transform.is_some() {
        prim.stage_origin = prim.stage_origin.replaced();
    }
    prim.transform = o.transform.or(prim.transform.take());
    if o.through.is_some() || o.back_through.is_some() {
        (prim.through, prim.back_through) = (o.through, o.back_through);
    }
    prim.visibility = o.visibility.or(prim.visibility);
    prim.light_group = o.light_group.or(prim.light_group.take());
}

/// The opening the constraint solver carries a section's transform through, by name.
#[derive(Clone, Copy)]
pub enum Carried<'a> {
    /// `through`: the there-side copy, T·transform.
    Through(&'a str),
    /// `back_through`: the here-side copy of a there-side target, T⁻¹·transform.
    Back(&'a str),
}

/// An object's mesh: its name for messages, its path (empty for a shape a USD layer gave),
/// its parts and its deformation.
struct ObjectMesh<'o> {
    name: &'o str,
    path: PathBuf,
    parts: Vec<mesh::MeshPart>,
    deformation: Option<Arc<Deformation>>,
}

/// What loading objects needs from the rest of the scene.
pub(super) struct Loader<'a> {
    pub shot: &'a Shot,
    /// The shot file's directory, which mesh paths are relative to.
    pub base: &'a Path,
    /// Every time a ray can have.
    pub times: [f64; 2],
    pub rig: &'a Arc<Rig>,
    pub portals: &'a Portals,
    pub media: &'a MediaSections,
    /// How many of the objects (the first) USD layers brought.
    pub imported: usize,
}

impl Loader<'_> {
    /// Every object's part and visibility flags; materials an OBJ brings are added to
    /// `materials`.
    pub fn parts(
        &self,
        objects: &[ObjectSection],
        materials: &mut Vec<Material>,
        groups: &mut LightGroups,
        reader: &mut TextureReader,
    ) -> Result<(Vec<Part>, Vec<Flags>), RenderError> {
        let mut parts = Vec::new();
        let mut flags = Vec::new();
        let motions = self.motions(objects)?;
        let sequences = self.sequences(objects, &motions, reader.budget)?;
        for ((i, o), motion) in objects.iter().enumerate().zip(motions) {
            flags.push(if self.media.inside(&o.name).is_some() {
                // Paths cross a medium's boundary; shadow rays pass it (attenuated by the media).
                Flags::new(true, true, true, false)
            } else {
                self::flags(o.visibility)
            });
            let placed = (motion, self.instance_motions(&self.key(i, o), o)?);
            let mut part = self.part(i, o, placed, &sequences, materials, reader)?;
            let key = format!("{}.light_group", self.key(i, o));
            part.group = groups.index(&self.shot.source, &key, o.light_group.as_deref())?;
            parts.push(part);
        }
        Ok((parts, flags))
    }

    /// The key that names object `i` in messages: `object[j]` for the shot's own, the prim's
    /// path for one a USD layer brings.
    fn key(&self, i: usize, o: &ObjectSection) -> String {
        match i.checked_sub(self.imported) {
            Some(j) => format!("object[{j}]"),
            None => format!("<{}>", o.name),
        }
    }

    fn invalid(&self, e: Invalid) -> RenderError {
        RenderError::Shot(e.in_file(&self.shot.source))
    }

    fn error(&self, key: String, message: String) -> RenderError {
        key_error(&self.shot.source, key, message)
    }

    /// The mesh sequences the objects name, each read once over the times every object that
    /// uses it (an original and its copies, each at its own time) needs.
    pub fn sequences(
        &self,
        objects: &[ObjectSection],
        motions: &[ObjectMotion],
        budget: Option<u64>,
    ) -> Result<HashMap<PathBuf, Sequence>, RenderError> {
        let mut spans: Vec<(PathBuf, String, [f64; 2])> = Vec::new();
        for (i, (o, motion)) in objects.iter().zip(motions).enumerate() {
            let Some(name) = o.mesh.as_deref().filter(|m| sequence::is_sequence(m)) else {
                continue;
            };
            let path = self.base.join(name);
            let [a, b] = motion.source_times(self.times);
            match spans.iter_mut().find(|(p, ..)| *p == path) {
                Some((_, _, span)) => *span = [span[0].min(a), span[1].max(b)],
                None => spans.push((path, format!("{}.mesh", self.key(i, o)), [a, b])),
            }
        }
        let mut out = HashMap::new();
        for (path, key, span) in spans {
            let s = sequence::load(&path, span, self.shot.fps, budget)
                .map_err(|e| self.error(key, e.to_string()))?;
            out.insert(path, s);
        }
        Ok(out)
    }

    /// Object `i`'s triangles, placed by `motion` (or at each of its `instances`) and with
    /// their materials.
    fn part(
        &self,
        i: usize,
        o: &ObjectSection,
        (motion, instances): (ObjectMotion, Vec<ObjectMotion>),
        sequences: &HashMap<PathBuf, Sequence>,
        materials: &mut Vec<Material>,
        reader: &mut TextureReader,
    ) -> Result<Part, RenderError> {
        let key = self.key(i, o);
        let ObjectMesh {
            name: mesh_name,
            path: mesh_path,
            parts: mesh_parts,
            deformation,
        } = self.mesh(&key, o, sequences)?;
        if deformation.is_some() && !instances.is_empty() {
            return Err(self.error(
                format!("{key}.mesh"),
                format!("{mesh_name} deforms and is instanced, which rift does not do yet"),
            ));
        }
        // A deforming or instanced object is an instance whether or not it also moves.
        let moves =
            deformation.is_some() || !instances.is_empty() || motion.moves_during(self.times);
        let placed = motion.at(self.times[0]);
        let mut part = Part {
            object: i as u32,
            triangles: Vec::new(),
            uvs: Vec::new(),
            normals: Vec::new(),
            materials: Vec::new(),
            motion,
            deformation,
            instance_names: match o.instance_names.len() == instances.len() {
                true => o.instance_names.clone(),
                false => Vec::new(),
            },
            instances,
            moves,
            group: 0,
            warnings: Vec::new(),
        };
        let any_uvs = mesh_parts.iter().any(|p| !p.uvs.is_empty());
        let any_normals = self.shading_normals_kept(&key, mesh_name, &mesh_parts, &mut part);
        let folder = mesh_path.parent().unwrap_or(Path::new("."));
        for mesh_part in mesh_parts {
            let index =
                self.material_of(&key, o, (mesh_name, folder), &mesh_part, materials, reader)?;
            let material = &materials[index];
            let deforms = part.deformation.is_some();
            self.check_mesh_part(&key, mesh_name, &mesh_part, material, deforms, &mut part)?;
            let n = mesh_part.triangles.len();
            let uvs = mesh_part.uvs.iter().copied();
            append_per_triangle(&mut part.uvs, any_uvs, uvs, n, [Vec2::ZERO; 3]);
            // A static object's triangles are baked to world space: so are its normals.
            let placed_normal = |n: Vec3| match moves {
                true => n,
                false => (placed.rotation * n.as_dvec3()).as_vec3(),
            };
            let normals = (mesh_part.normals.iter())
                .map(|corners| corners.map(|n| PackedNormal::pack(placed_normal(n))));
            append_per_triangle(
                &mut part.normals,
                any_normals,
                normals,
                n,
                [PackedNormal::NONE; 3],
            );
            for tri in mesh_part.triangles {
                let v = if moves {
                    tri
                } else {
                    tri.map(|p| placed.transform_point(p.as_dvec3()).as_vec3())
                };
                if !v.iter().all(|&p| within_single_precision(p)) {
                    return Err(self.error(
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
        Ok(part)
    }

    /// True when the mesh's authored normals shade `part` smoothly: some part of it gives
    /// normals, and if it deforms, its normals deform with it (every sample gives them);
    /// otherwise it is shaded flat, and `part` says so.
    fn shading_normals_kept(
        &self,
        key: &str,
        mesh_name: &str,
        mesh_parts: &[mesh::MeshPart],
        part: &mut Part,
    ) -> bool {
        let given = mesh_parts.iter().any(|p| !p.normals.is_empty());
        if given && part.deformation.as_ref().is_some_and(|d| !d.has_normals()) {
            part.warnings.push(format!(
                "{key}.mesh: {mesh_name} deforms, and not every part of every sample gives \
                 normals; each triangle is shaded by its own normal"
            ));
            return false;
        }
        given
    }

    /// Object `o`'s mesh (its `key` names it in messages).
    fn mesh<'o>(
        &self,
        key: &str,
        o: &'o ObjectSection,
        sequences: &HashMap<PathBuf, Sequence>,
    ) -> Result<ObjectMesh<'o>, RenderError> {
        Ok(match (&o.mesh, &o.shape) {
            (Some(mesh_name), _) => {
                let mesh_path = self.base.join(mesh_name);
                let sequence = sequences.get(&mesh_path);
                let mesh_parts = match sequence {
                    Some(s) => s.parts.clone(),
                    // A mesh's own error (its file, line or element) under the key that names it.
                    None => super::load_mesh(&mesh_path)
                        .map_err(|e| self.error(format!("{key}.mesh"), e.to_string()))?,
                };
                ObjectMesh {
                    name: mesh_name,
                    path: mesh_path,
                    parts: mesh_parts,
                    deformation: sequence.map(|s| s.mesh.clone()),
                }
            }
            (None, Some(shape)) => ObjectMesh {
                name: &o.name,
                path: PathBuf::new(),
                parts: shape.parts.clone(),
                deformation: shape.deformation.clone(),
            },
            (None, None) => {
                return Err(self.error(
                    format!("{key}.mesh"),
                    "missing: give `mesh`, or `copy_of` another object".into(),
                ));
            }
        })
    }

    /// What one part of object `key`'s mesh asks of its `material`: MTL maps rift does not
    /// read yet (a warning on `part`), emission on a deforming mesh (`deforms`) or a texture
    /// without UVs (errors).
    fn check_mesh_part(
        &self,
        key: &str,
        mesh_name: &str,
        mesh_part: &mesh::MeshPart,
        material: &Material,
        deforms: bool,
        part: &mut Part,
    ) -> Result<(), RenderError> {
        if let Some(mtl) = mesh_part
            .material
            .as_ref()
            .filter(|m| !m.unread_maps.is_empty())
        {
            part.warnings.push(format!(
                "{key}.mesh: material {:?} of {mesh_name} names {}, which rift does not read \
                 yet; rendered without",
                mtl.name,
                mtl.unread_maps.join(", ")
            ));
        }
        if deforms && material.emits() {
            return Err(self.error(
                format!("{key}.material"),
                format!(
                    "material {:?} emits light, which a deforming mesh ({mesh_name}) cannot do \
                     yet; give its emissive parts a mesh that does not deform",
                    material.name
                ),
            ));
        }
        if material.textured() && mesh_part.uvs.is_empty() {
            return Err(self.error(
                format!("{key}.mesh"),
                format!(
                    "material {:?} is textured, but {mesh_name} gives no texture coordinates \
                     for its part {:?}",
                    material.name, mesh_part.name
                ),
            ));
        }
        Ok(())
    }

    /// Every object's placement over time ([`Self::motion`]).
    pub fn motions(&self, objects: &[ObjectSection]) -> Result<Vec<ObjectMotion>, RenderError> {
        objects
            .iter()
            .enumerate()
            .map(|(i, o)| self.motion(&self.key(i, o), o))
            .collect()
    }

    /// The object's placement over time: its keyed transform, carried through an opening (or
    /// back through one) by the constraint solver.
    fn motion(&self, key: &str, o: &ObjectSection) -> Result<ObjectMotion, RenderError> {
        let carried = self.carried(key, o)?;
        let mut transform = self.pose(key, o.transform.as_ref())?;
        if let StageOrigin::Replaced(origin) = o.stage_origin {
            // The shot file's transform places the prim from where its stage puts it.
            let from = Similarity::new(DQuat::IDENTITY, DVec3::from(origin), 1.0);
            transform = transform.after(&from);
        }
        self.carry(key, transform, carried)
    }

    /// Where each instance of an instanced object is over time, each carried through the
    /// object's opening like a single object; empty for an object that is not instanced.
    fn instance_motions(
        &self,
        key: &str,
        o: &ObjectSection,
    ) -> Result<Vec<ObjectMotion>, RenderError> {
        if o.instances.is_empty() {
            return Ok(Vec::new());
        }
        if o.transform.is_some() {
            return Err(self.error(
                format!("{key}.transform"),
                format!(
                    "{:?} is instanced ({} instances), each placed by its instancer; \
                     give the instancer's prim a transform in USD instead",
                    o.name,
                    o.instances.len()
                ),
            ));
        }
        let carried = self.carried(key, o)?;
        o.instances
            .iter()
            .map(|placed| self.carry(key, placed.clone(), carried))
            .collect()
    }

    /// The opening a section says its object is carried through, if any.
    fn carried<'o>(
        &self,
        key: &str,
        o: &'o ObjectSection,
    ) -> Result<Option<Carried<'o>>, RenderError> {
        match (&o.through, &o.back_through) {
            (Some(_), Some(_)) => Err(self.error(
                format!("{key}.back_through"),
                "give `through` or `back_through`, not both".into(),
            )),
            (Some(name), None) => Ok(Some(Carried::Through(name))),
            (None, Some(name)) => Ok(Some(Carried::Back(name))),
            (None, None) => Ok(None),
        }
    }

    /// A placement over time from a section's `transform` key and the opening it is carried
    /// through (under `key`).
    pub fn placement(
        &self,
        key: &str,
        transform: Option<&rift_fx::shot::schema::PoseSpec>,
        carried: Option<Carried<'_>>,
    ) -> Result<ObjectMotion, RenderError> {
        let transform = self.pose(key, transform)?;
        self.carry(key, transform, carried)
    }

    /// A section's `transform` key (under `key`) over time; none stands at the origin.
    fn pose(
        &self,
        key: &str,
        transform: Option<&rift_fx::shot::schema::PoseSpec>,
    ) -> Result<AnimatedTransform, RenderError> {
        match transform {
            Some(spec) => pose::animated(
                &format!("{key}.transform"),
                spec,
                Facing::PositiveZ,
                self.shot.fps,
            )
            .map_err(|e| self.invalid(e)),
            None => Ok(AnimatedTransform::constant(Similarity::IDENTITY)),
        }
    }

    /// `transform`, carried through the opening `carried` names (under `key`).
    fn carry(
        &self,
        key: &str,
        transform: AnimatedTransform,
        carried: Option<Carried<'_>>,
    ) -> Result<ObjectMotion, RenderError> {
        let Some(carried) = carried else {
            return Ok(ObjectMotion::new(transform));
        };
        let (name, field) = match carried {
            Carried::Through(name) => (name, "through"),
            Carried::Back(name) => (name, "back_through"),
        };
        let opening = self.shot.rig.find(name).ok_or_else(|| {
            self.error(
                format!("{key}.{field}"),
                format!("no portal opening is called {name:?}"),
            )
        })?;
        let delay = self.portals.look(opening).time_offset;
        let rig = self.rig.clone();
        Ok(match carried {
            Carried::Through(_) => ObjectMotion::through(transform, rig, opening, delay),
            Carried::Back(_) => ObjectMotion::back_through(transform, rig, opening, delay),
        })
    }

    /// The material of one part of an object's mesh: the object's, else the part's own from
    /// its MTL (a `[[material]]` of that name wins), else a medium boundary's.
    fn material_of(
        &self,
        key: &str,
        o: &ObjectSection,
        (mesh_name, folder): (&str, &Path),
        mesh_part: &mesh::MeshPart,
        materials: &mut Vec<Material>,
        reader: &mut TextureReader,
    ) -> Result<usize, RenderError> {
        match (&o.material, &mesh_part.material) {
            (Some(name), _) => materials::find(materials, name).ok_or_else(|| {
                self.error(
                    format!("{key}.material"),
                    format!("no material is called {name:?}"),
                )
            }),
            (None, Some(mtl))
                if !mtl.declared && materials::find(materials, &mtl.name).is_none() =>
            {
                Err(self.error(
                    format!("{key}.material"),
                    format!(
                        "part {:?} of {mesh_name} uses material {:?}, which is neither a \
                         [[material]] nor in its MTL",
                        mesh_part.name, mtl.name
                    ),
                ))
            }
            (None, Some(mtl)) => match materials::find(materials, &mtl.name) {
                Some(i) => Ok(i),
                None => {
                    let map_key = format!("{key}.mesh");
                    materials.push(materials::from_mtl(mtl, folder, &map_key, reader)?);
                    Ok(materials.len() - 1)
                }
            },
            (None, None) if self.media.inside(&o.name).is_some() => Ok(materials::find_or_add(
                materials,
                BOUNDARY_MATERIAL,
                materials::boundary,
            )),
            (None, None) => Err(self.error(
                format!("{key}.material"),
                format!(
                    "part {:?} of {mesh_name} names no material; set `material`",
                    mesh_part.name
                ),
            )),
        }
    }
}

/// Bytes the parts' deformations hold, each shared one (an original's and its copies') once.
pub(super) fn deformation_bytes(parts: &[Part]) -> u64 {
    crate::geometry::deforming::shared_bytes(parts.iter().filter_map(|p| p.deformation.as_ref()))
        as u64
}

/// Bytes the instances of instanced objects take beyond their shared triangles: each one's
/// placement, its keys and its box in the top-level BVH.
pub(super) fn instance_bytes(parts: &[Part]) -> u64 {
    const PER_KEY: usize = 64;
    let placements = parts.iter().flat_map(|p| &p.instances);
    placements
        .map(|m| size_of::<MovingInstance>() + 2 * 32 + PER_KEY * m.key_times().len().max(1))
        .sum::<usize>() as u64
}

/// Triangles in all `parts`.
pub(super) fn triangle_count(parts: &[Part]) -> usize {
    parts.iter().map(|p| p.triangles.len()).sum()
}

/// Every object's triangles in the arrays the scene holds: still parts first, so their
/// triangles take the indices the static BVH starts at, then one instance per moving part.
pub(super) struct Geometry {
    pub triangles: Vec<Triangle>,
    /// Per triangle, its corners' UVs; empty when no mesh gives any.
    pub triangle_uvs: Vec<[Vec2; 3]>,
    /// Per triangle, its corners' shading normals in the triangle's space
    /// ([`PackedNormal::NONE`]: shaded flat); empty when no mesh gives any.
    pub triangle_normals: Vec<[PackedNormal; 3]>,
    pub triangle_material: Vec<u32>,
    /// The moving instance of each triangle (an instanced object's: its first instance),
    /// or [`STATIC`].
    pub triangle_instance: Vec<u32>,
    /// Instanced objects: the range of their (shared) triangles, and of their instances.
    pub instanced: Vec<(Range<u32>, Range<u32>)>,
    pub triangle_object: Vec<u32>,
    pub triangle_group: Vec<u8>,
    pub instances: Vec<MovingInstance>,
    /// Per moving instance, the name it goes by in ID passes where it has one of its own (an
    /// instance of a USD prototype), else `None` (its object's).
    pub instance_names: Vec<Option<String>>,
    /// How many triangles (from the first) stand still.
    pub static_count: usize,
    /// Per object: whether it moves within the times rays can reach.
    pub moving: Vec<bool>,
    /// Per object, its placement over time (the triangles of those that move are in object
    /// space).
    pub placements: Vec<ObjectMotion>,
}

impl Geometry {
    pub fn assemble(mut parts: Vec<Part>, objects: usize, times: [f64; 2]) -> Self {
        parts.sort_by_key(|p| p.moves);
        let any_uvs = parts.iter().any(|p| !p.uvs.is_empty());
        let any_normals = parts.iter().any(|p| !p.normals.is_empty());
        let mut g = Geometry {
            triangles: Vec::new(),
            triangle_uvs: Vec::new(),
            triangle_normals: Vec::new(),
            triangle_material: Vec::new(),
            triangle_instance: Vec::new(),
            instanced: Vec::new(),
            triangle_object: Vec::new(),
            triangle_group: Vec::new(),
            instances: Vec::new(),
            instance_names: Vec::new(),
            static_count: 0,
            moving: vec![false; objects],
            placements: vec![
                ObjectMotion::new(AnimatedTransform::constant(Similarity::IDENTITY));
                objects
            ],
        };
        for mut part in parts {
            g.moving[part.object as usize] = part.moves;
            g.placements[part.object as usize] = part.motion.clone();
            let first = g.triangles.len() as u32;
            let instance = if !part.instances.is_empty() {
                g.instance_all(&mut part, first, times)
            } else if part.moves {
                let moving = match part.deformation {
                    Some(mesh) => MovingInstance::deforming(mesh, first, part.motion, times),
                    None => MovingInstance::new(&part.triangles, first, part.motion, times),
                };
                g.instances.push(moving);
                g.instance_names.push(None);
                g.instances.len() as u32 - 1
            } else {
                g.static_count += part.triangles.len();
                STATIC
            };
            let n = part.triangles.len();
            g.triangle_instance.extend(std::iter::repeat_n(instance, n));
            g.triangle_object
                .extend(std::iter::repeat_n(part.object, n));
            g.triangle_group.extend(std::iter::repeat_n(part.group, n));
            let (uvs, normals) = (part.uvs.into_iter(), part.normals.into_iter());
            append_per_triangle(&mut g.triangle_uvs, any_uvs, uvs, n, [Vec2::ZERO; 3]);
            let none = [PackedNormal::NONE; 3];
            append_per_triangle(&mut g.triangle_normals, any_normals, normals, n, none);
            g.triangles.extend(part.triangles);
            g.triangle_material.extend(part.materials);
        }
        g
    }

    /// One moving instance per placement of an instanced `part` (whose triangles start at
    /// `first`), all sharing one BVH, each with its name (taken from the part): the first
    /// instance's index.
    fn instance_all(&mut self, part: &mut Part, first: u32, times: [f64; 2]) -> u32 {
        let bvh = Arc::new(TriangleBvh::build(&part.triangles, first));
        let corners = crate::geometry::instance::object_corners(&part.triangles);
        let start = self.instances.len() as u32;
        self.instances.extend(
            part.instances
                .iter()
                .map(|m| MovingInstance::sharing(&bvh, &corners, m.clone(), times)),
        );
        let names = std::mem::take(&mut part.instance_names)
            .into_iter()
            .map(Some);
        let unnamed = std::iter::repeat(None);
        (self.instance_names).extend(names.chain(unnamed).take(part.instances.len()));
        let triangles = first..first + part.triangles.len() as u32;
        self.instanced
            .push((triangles, start..self.instances.len() as u32));
        start
    }

    /// Each instanced object and the range of its moving instances.
    pub fn instanced_objects(&self) -> Vec<(u32, Range<u32>)> {
        (self.instanced.iter())
            .map(|(triangles, instances)| {
                let object = self.triangle_object[triangles.start as usize];
                (object, instances.clone())
            })
            .collect()
    }

    /// The moving instances triangle `i` is placed by: one, several for an instanced
    /// object's, none (an empty range) for a static one.
    fn instances_of(&self, i: u32) -> Range<u32> {
        if let Some((_, instances)) = self.instanced.iter().find(|(t, _)| t.contains(&i)) {
            return instances.clone();
        }
        match self.triangle_instance[i as usize] {
            STATIC => 0..0,
            instance => instance..instance + 1,
        }
    }
}

/// The emissive triangles (of non-zero area) as emitters; a textured one's radiance is its
/// mean over the triangle.
pub(super) fn emitters(
    g: &Geometry,
    normals: &[Vec3],
    materials: &[Material],
    textures: &[Texture],
) -> Vec<Emitter> {
    let mut out = Vec::new();
    for (i, tri) in g.triangles.iter().enumerate() {
        let m = &materials[g.triangle_material[i] as usize];
        if !m.emits() || tri.area() <= 0.0 {
            continue;
        }
        let emitter = Emitter {
            triangle: i as u32,
            instance: g.triangle_instance[i],
            radiance: match (m.emission_map(), g.triangle_uvs.get(i)) {
                (Some(map), Some(&uvs)) => mean_emission(map, textures, uvs),
                _ => m.emission,
            },
            textured: m.emission_map().is_some(),
            two_sided: m.two_sided_emission,
            vertices: *tri,
            normal: normals[i],
            area: tri.area(),
        };
        // An instanced object's emissive triangle is a light at each of its instances.
        match g.instances_of(i as u32) {
            r if r.len() > 1 => out.extend(r.map(|instance| Emitter {
                instance,
                ..emitter
            })),
            _ => out.push(emitter),
        }
    }
    out
}

/// A textured emitter's mean radiance over its triangle of UVs `[a, b, c]`, which sets how
/// often light sampling picks it (the texture itself is read at each point drawn): the texture
/// at 16 stratified points, each read over a sixteenth of the triangle's UV area.
fn mean_emission(map: &ColorInput, textures: &[Texture], [a, b, c]: [Vec2; 3]) -> Vec3 {
    const N: usize = 4;
    let uv_area = 0.5 * (b - a).perp_dot(c - a).abs();
    let width = (uv_area / (N * N) as f32).sqrt();
    let mut sum = Vec3::ZERO;
    for i in 0..N {
        for j in 0..N {
            let u = Vec2::new(i as f32 + 0.5, j as f32 + 0.5) / N as f32;
            let (b1, b2) = uniform_triangle(u);
            let uv = super::interpolated(&[a, b, c], b1, b2);
            sum += map.at(textures, &Lookup { uv, width }).max(Vec3::ZERO);
        }
    }
    sum / (N * N) as f32
}

/// Appends a part's `given` values, one per triangle, to `out`, or `n` copies of `missing`
/// where the part gives none; nothing unless some part gives them (`wanted`), so scenes
/// without UVs or normals keep no arrays of them.
fn append_per_triangle<T: Copy>(
    out: &mut Vec<T>,
    wanted: bool,
    given: impl ExactSizeIterator<Item = T>,
    n: usize,
    missing: T,
) {
    if !wanted {
        return;
    }
    match given.len() {
        0 => out.extend(std::iter::repeat_n(missing, n)),
        _ => out.extend(given),
    }
}
