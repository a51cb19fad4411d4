//! Instances: prims marked instanceable (each an instance of a prototype the stage composes once)
//! and PointInstancers (arrays of placements of prototype prims). Each prototype mesh is read
//! once, in its prototype's space, and becomes one object that its `instances` place: the scene
//! shares its triangles and BVH among all of them. Instances that stretch their prototype alike
//! (a non-uniform scale inside them) share it too, the stretch baked into its points; one whose
//! stretch differs from the others', or changes over time, gets its own copy, baked; so does each
//! instance of a deforming mesh (the copies share the deformation).

use super::stage::Walk;
use super::{values, xform};
use crate::error::RenderError;
use crate::scene::schema::{ObjectSection, StageOrigin};
use glam::{DMat3, DMat4, DQuat, DVec3};
use openusd::sdf::Value;
use openusd::usd::Prim;
use std::cell::RefCell;
use std::collections::HashMap;
use std::sync::Arc;

/// Bytes each shared instance takes while it is read and placed (its keys, its placement, its
/// box, and its name for ID passes, held twice while the scene is made), for the memory check
/// before a PointInstancer's instances are made.
const BYTES_PER_INSTANCE: u64 = 640;

/// Bytes each further key of an instance takes, where a PointInstancer's placements are
/// sampled over time: the key itself, the matrix it is made from, and the instance's position,
/// orientation and scale read at that time.
const BYTES_PER_KEY: u64 = (std::mem::size_of::<rift_fx::rig::TransformKey>()
    + std::mem::size_of::<(f64, DMat4)>()
    + std::mem::size_of::<(DVec3, DQuat, DVec3)>()) as u64;

/// A mesh inside a prototype: its prim, its transform relative to the prototype's placement,
/// its path below the prototype (which names it under each instance), and what its instances
/// share it by (with the transform baked into its points).
struct ProtoMesh {
    prim: Prim,
    local: DMat4,
    relative: String,
    key: String,
}

impl Walk<'_> {
    /// A scene-graph instance: the meshes under it (its prototype's, which the stage shows in
    /// the instance's namespace), placed where the instance is and shared with every other
    /// instance of its prototype.
    pub(super) fn instance(&mut self, prim: &Prim) -> Result<(), RenderError> {
        let path = prim.path().as_str().to_owned();
        let read = |e| self.source.read_error(&path, e);
        // Instances of one prototype share its meshes; without one, the instance is alone.
        let prototype = prim.prototype().map_err(read)?;
        let shared_by = prototype.map_or_else(|| path.clone(), |p| p.as_str().to_owned());
        let samples = xform::world_samples(prim, self.source)?;
        // The meshes relative to the instance where the span starts (they move with it).
        let at_start = xform::world(prim, self.source.codes()[0], self.source).map_err(read)?;
        let inverse = invertible(at_start).ok_or_else(|| self.singular(&path))?;
        for mesh in self.meshes_below(prim, inverse, &shared_by)? {
            let name = format!("{path}{}", mesh.relative);
            self.place(&mesh, (&name, &name), &samples)?;
        }
        Ok(())
    }

    /// The meshes under `root` (it included), each with its transform taken relative by
    /// `inverse` (the inverse of what places `root`'s frame), its path below `root`, and its
    /// key among shared meshes: `shared_by` followed by that path.
    fn meshes_below(
        &mut self,
        root: &Prim,
        inverse: DMat4,
        shared_by: &str,
    ) -> Result<Vec<ProtoMesh>, RenderError> {
        let root_path = root.path().as_str().to_owned();
        let code = self.source.codes()[0];
        let mut out = Vec::new();
        let mut stack = vec![root.clone()];
        while let Some(prim) = stack.pop() {
            let path = prim.path().as_str().to_owned();
            let read = |e| self.source.read_error(&path, e);
            if !xform::rendered(&prim).map_err(read)? {
                continue;
            }
            let relative = path[root_path.len()..].to_owned();
            let kind = prim.type_name().map_err(read)?;
            match kind.as_ref().map_or("", |t| t.as_str()) {
                "Mesh" => out.push(ProtoMesh {
                    local: inverse * xform::world(&prim, code, self.source).map_err(read)?,
                    key: format!("{shared_by}{relative}"),
                    prim: prim.clone(),
                    relative,
                }),
                "" | "Xform" | "Scope" => {}
                "Material" | "Shader" | "NodeGraph" | "GeomSubset" => continue,
                other => {
                    self.unread(&path, other);
                    continue;
                }
            }
            let mut kids = super::stage::children(self.source, &prim)?;
            kids.reverse();
            stack.extend(kids);
        }
        Ok(out)
    }

    /// Places `mesh` at the world transforms `samples` (time code and matrix): as one more
    /// instance of its shared object (called `names.0` when this makes it; the instance itself
    /// is called `names.1` in ID passes), or as a copy of its own (called `names.1`). Instances
    /// that stretch their prototype alike (a Blender object scaled in one axis, instanced)
    /// share it too, the stretch baked into its points: what places each of them is then a
    /// similarity.
    fn place(
        &mut self,
        mesh: &ProtoMesh,
        (name, copy_name): (&str, &str),
        samples: &[(f64, DMat4)],
    ) -> Result<(), RenderError> {
        let stretch = unit_stretch(samples[0].1);
        let key = (
            mesh.key.clone(),
            quantized(mesh.local.to_cols_array()),
            stretch.map(|p| quantized(p.to_cols_array())),
        );
        let existing = self.shared.0.get(&key).copied();
        // The stretch the shared object bakes in: the first such instance's.
        let stretch = existing.map_or(stretch.unwrap_or(DMat3::IDENTITY), |(_, s)| s);
        let unstretch = DMat4::from_mat3(stretch.inverse());
        let placed: Vec<(f64, DMat4)> = samples.iter().map(|&(c, m)| (c, m * unstretch)).collect();
        let Some(motion) = xform::animated(self.source, &placed) else {
            // Its stretch changes over time, or it mirrors its prototype: a copy of its own.
            return self.copy(mesh, copy_name, samples);
        };
        let index = match existing {
            Some((index, _)) => index,
            None => {
                let placement = xform::Placement {
                    bake: DMat4::from_mat3(stretch) * mesh.local,
                    keys: Vec::new(),
                };
                let shape = self.mesh_shape(&mesh.prim, mesh.prim.path().as_str(), &placement)?;
                let object = placement.object(name.to_owned(), Arc::new(shape));
                self.out.objects.push(object);
                let index = self.out.objects.len() - 1;
                self.shared.0.insert(key, (index, stretch));
                index
            }
        };
        let object = &mut self.out.objects[index];
        if object
            .shape
            .as_ref()
            .is_some_and(|s| s.deformation.is_some())
        {
            // A deforming prototype: a copy per instance, all sharing its deformation.
            let copy = ObjectSection {
                name: copy_name.to_owned(),
                transform: Some(xform::pose_of(self.source, &placed)),
                instances: Vec::new(),
                instance_names: Vec::new(),
                stage_origin: StageOrigin::Included,
                ..object.clone()
            };
            // The object as made (at no transform) becomes the first copy.
            if object.instances.is_empty() && object.transform.is_none() {
                *object = copy;
            } else {
                self.out.objects.push(copy);
            }
            return Ok(());
        }
        object.instances.push(motion);
        object.instance_names.push(copy_name.to_owned());
        Ok(())
    }

    /// `mesh` placed at `samples` as an object of its own, the part of its placement that is
    /// not a similarity baked into its points.
    fn copy(
        &mut self,
        mesh: &ProtoMesh,
        name: &str,
        samples: &[(f64, DMat4)],
    ) -> Result<(), RenderError> {
        let placed: Vec<(f64, DMat4)> = samples.iter().map(|&(c, m)| (c, m * mesh.local)).collect();
        let placement = xform::of_samples(name, self.source, &placed)?;
        let shape = self.mesh_shape(&mesh.prim, mesh.prim.path().as_str(), &placement)?;
        let object = placement.object(name.to_owned(), Arc::new(shape));
        self.out.objects.push(object);
        Ok(())
    }

    /// A PointInstancer: each of its instances places its prototype's meshes.
    pub(super) fn point_instancer(&mut self, prim: &Prim) -> Result<(), RenderError> {
        let path = prim.path().as_str().to_owned();
        let read = |e| self.source.read_error(&path, e);
        let prototypes = prim.relationship("prototypes").targets().map_err(read)?;
        let arrays = self.instance_arrays(prim, prototypes.len())?;
        let n = arrays.proto_indices.len();
        let mut world = xform::world_samples(prim, self.source)?;
        if arrays.poses.len() > 1 {
            // The instancer's transform at the placements' samples too.
            for code in arrays.poses.iter().map(|p| p.code) {
                if !world.iter().any(|&(c, _)| c == code) {
                    world.push((code, xform::world(prim, code, self.source).map_err(read)?));
                }
            }
            world.sort_by(|a, b| a.0.total_cmp(&b.0));
        }
        self.check_instances(&path, n, (n * world.len()) as u64)?;
        let mut prototype_meshes = Vec::with_capacity(prototypes.len());
        for target in &prototypes {
            let proto = prim.stage().prim(target.clone());
            let parent_world = match target.parent().filter(|p| !p.is_abs_root()) {
                Some(parent) => xform::world(
                    &prim.stage().prim(parent),
                    self.source.codes()[0],
                    self.source,
                )
                .map_err(read)?,
                None => DMat4::IDENTITY,
            };
            let inverse = invertible(parent_world).ok_or_else(|| self.singular(&path))?;
            let name = target.as_str().rsplit('/').next().unwrap_or_default();
            let meshes = self.meshes_below(&proto, inverse, target.as_str())?;
            prototype_meshes.push((format!("{path}/{name}"), meshes));
        }
        let hidden = arrays.hidden();
        let world_at = WorldAt::new(prim, &world, self.source);
        let mut followed = 0;
        for i in 0..n {
            if hidden.get(i).copied().unwrap_or(false) {
                continue;
            }
            let (base, meshes) = &prototype_meshes[arrays.proto_indices[i] as usize];
            let samples = arrays.placements(i, &world, &world_at)?;
            if samples.len() > world.len() {
                // Keys beyond those counted up front, where instances were followed.
                followed += (samples.len() - world.len()) as u64;
                self.check_instances(&path, n, (n * world.len()) as u64 + followed)?;
            }
            for mesh in meshes {
                let shared = format!("{base}{}", mesh.relative);
                self.place(mesh, (&shared, &format!("{shared}[{i}]")), &samples)?;
            }
        }
        if arrays.angular_velocities {
            self.out.warnings.push(format!(
                "{}: <{path}> gives angularVelocities, which rift does not blur yet (its \
                 instances turn at their first sample's orientation)",
                self.source.layer.display()
            ));
        }
        Ok(())
    }

    /// Refuses a PointInstancer of `n` instances, placed by `keys` keys in all, whose
    /// placements would not fit in the memory budget, before they are made.
    fn check_instances(&self, path: &str, n: usize, keys: u64) -> Result<(), RenderError> {
        let need = (n as u64)
            .saturating_mul(BYTES_PER_INSTANCE)
            .saturating_add(keys.saturating_sub(n as u64).saturating_mul(BYTES_PER_KEY));
        match self.source.budget {
            Some(budget) if need > budget => Err(self.source.error(
                path,
                Some("protoIndices"),
                format!(
                    "its {n} instances need about {} MiB, more than the memory budget of {} \
                     MiB (--max-memory)",
                    need >> 20,
                    budget >> 20
                ),
            )),
            _ => Ok(()),
        }
    }

    /// The per-instance arrays of a PointInstancer of `prototypes` prototypes, checked.
    fn instance_arrays(
        &mut self,
        prim: &Prim,
        prototypes: usize,
    ) -> Result<InstanceArrays, RenderError> {
        let path = prim.path().as_str();
        let code = self.source.codes()[0];
        let error =
            |attribute: &str, message: String| self.source.error(path, Some(attribute), message);
        let read = |e| self.source.read_error(path, e);
        let proto_indices = values::int_array(prim, "protoIndices", code)
            .map_err(read)?
            .ok_or_else(|| error("protoIndices", "missing: a PointInstancer needs it".into()))?;
        let n = proto_indices.len();
        if let Some((i, &p)) = proto_indices
            .iter()
            .enumerate()
            .find(|&(_, &p)| p as usize >= prototypes)
        {
            return Err(error(
                "protoIndices",
                format!("entry {i} is {p}, past the {prototypes} prototypes it targets"),
            ));
        }
        let at_start = self.poses(prim, code)?;
        if let Some((name, entries)) = at_start.miscounted(n) {
            return Err(error(
                name,
                format!("it has {entries} entries for {n} instances"),
            ));
        }
        let velocities = self.vectors(prim, "velocities", code)?;
        if let Some(v) = velocities.as_ref().filter(|v| v.len() != n) {
            return Err(error(
                "velocities",
                format!("it has {} entries for {n} instances", v.len()),
            ));
        }
        let ids = values::int_array(prim, "ids", code).map_err(read)?;
        let invisible = values::int_array(prim, "invisibleIds", code).map_err(read)?;
        let angular_velocities = values::value(prim, "angularVelocities", code)
            .map_err(read)?
            .is_some();
        let mut poses = self.sampled_poses(prim, (&proto_indices, ids.as_ref()))?;
        if poses.len() > 1 && velocities.iter().flatten().any(|&v| v != DVec3::ZERO) {
            self.out.warnings.push(format!(
                "{}: <{path}> gives velocities and samples its placements over time: rift \
                 moves its instances between the samples, as USD interpolates them, and does \
                 not use the velocities",
                self.source.layer.display()
            ));
        }
        if poses.is_empty() {
            poses.push(at_start);
        }
        Ok(InstanceArrays {
            proto_indices,
            poses,
            velocities,
            ids,
            invisible,
            angular_velocities,
        })
    }

    /// The placements of a PointInstancer with `proto_indices` and `ids` at the span's start at
    /// each time code the span needs (its samples within it, and the nearest outside each end),
    /// where they are sampled over time; none where they are not, or where the instances cannot
    /// be followed from sample to sample (their number, prototypes or `ids` change), which is
    /// said: they are then placed as at the span's start, moved by their velocities.
    fn sampled_poses(
        &mut self,
        prim: &Prim,
        (proto_indices, ids): (&[u32], Option<&Vec<u32>>),
    ) -> Result<Vec<Poses>, RenderError> {
        let n = proto_indices.len();
        let path = prim.path().as_str();
        let read = |e| self.source.read_error(path, e);
        let mut times = Vec::new();
        for name in POSE_ATTRIBUTES {
            times.extend(prim.attribute(name).time_sample_times().map_err(read)?);
        }
        let codes = xform::codes_within(times, self.source.codes());
        if codes.len() < 2 {
            return Ok(Vec::new());
        }
        self.check_instances(path, n, (n * codes.len()) as u64)?;
        let mut poses = Vec::with_capacity(codes.len());
        for code in codes {
            let pose = self.poses(prim, code)?;
            let changed = match pose.miscounted(n) {
                Some((name, entries)) => Some(format!("{name} has {entries} entries")),
                None => {
                    let same = |name: &str, then: Option<&[u32]>| {
                        let now = values::int_array(prim, name, code).map_err(read)?;
                        Ok::<_, RenderError>(now.as_deref() == then)
                    };
                    if !same("protoIndices", Some(proto_indices))? {
                        Some("its protoIndices differ".to_owned())
                    } else if !same("ids", ids.map(Vec::as_slice))? {
                        Some("its ids differ".to_owned())
                    } else {
                        None
                    }
                }
            };
            if let Some(changed) = changed {
                self.out.warnings.push(format!(
                    "{}: <{path}> cannot be followed over time: at time code {code} {changed} \
                     (against {n} instances at the span's start); its instances stay where the \
                     span starts, moved by their velocities",
                    self.source.layer.display()
                ));
                return Ok(Vec::new());
            }
            poses.push(pose);
        }
        Ok(poses)
    }

    /// A PointInstancer's placement arrays at `code`, each of the length authored.
    fn poses(&self, prim: &Prim, code: f64) -> Result<Poses, RenderError> {
        let positions = self.vectors(prim, "positions", code)?.ok_or_else(|| {
            let message = "missing: a PointInstancer needs it".into();
            self.source
                .error(prim.path().as_str(), Some("positions"), message)
        })?;
        Ok(Poses {
            code,
            positions,
            orientations: self.orientations(prim, code)?,
            scales: self.vectors(prim, "scales", code)?,
        })
    }

    /// An array of 3-vectors at `code`, `None` where it is not authored.
    fn vectors(
        &self,
        prim: &Prim,
        name: &str,
        code: f64,
    ) -> Result<Option<Vec<DVec3>>, RenderError> {
        let path = prim.path().as_str();
        let Some(v) =
            values::value(prim, name, code).map_err(|e| self.source.read_error(path, e))?
        else {
            return Ok(None);
        };
        let array = values::vec3_array(&v).ok_or_else(|| {
            self.source
                .error(path, Some(name), "expected an array of 3-vectors".into())
        })?;
        Ok(Some(array.into_iter().map(|p| p.as_dvec3()).collect()))
    }

    /// A PointInstancer's orientations (half or single precision) at `code`.
    fn orientations(&self, prim: &Prim, code: f64) -> Result<Option<Vec<DQuat>>, RenderError> {
        let path = prim.path().as_str();
        let read = |e| self.source.read_error(path, e);
        for name in ["orientations", "orientationsf"] {
            let Some(v) = values::value(prim, name, code).map_err(read)? else {
                continue;
            };
            let quats: Vec<DQuat> = match v {
                Value::QuathVec(q) => q
                    .iter()
                    .map(|q| quat(q.w.to_f64(), q.x.to_f64(), q.y.to_f64(), q.z.to_f64()))
                    .collect(),
                Value::QuatfVec(q) => q
                    .iter()
                    .map(|q| quat(q.w as f64, q.x as f64, q.y as f64, q.z as f64))
                    .collect(),
                Value::QuatdVec(q) => q.iter().map(|q| quat(q.w, q.x, q.y, q.z)).collect(),
                _ => {
                    return Err(self.source.error(
                        path,
                        Some(name),
                        "expected an array of quaternions".into(),
                    ));
                }
            };
            if let Some(i) = quats
                .iter()
                .position(|q| !q.is_finite() || q.length() == 0.0)
            {
                return Err(self.source.error(
                    path,
                    Some(name),
                    format!("entry {i} is not a rotation"),
                ));
            }
            return Ok(Some(quats.into_iter().map(DQuat::normalize).collect()));
        }
        Ok(None)
    }

    /// Says that a prim of type `kind` inside an instance is not read.
    fn unread(&mut self, path: &str, kind: &str) {
        self.out.warnings.push(format!(
            "{}: <{path}> (in an instance) is a {kind}, which rift does not read from USD \
             inside instances yet; rendered without it",
            self.source.layer.display()
        ));
    }

    fn singular(&self, path: &str) -> RenderError {
        self.source.error(
            path,
            Some("xformOp"),
            "its world transform is singular or not finite".into(),
        )
    }
}

/// The attributes that place a PointInstancer's instances, and may be sampled over time.
const POSE_ATTRIBUTES: [&str; 4] = ["positions", "orientations", "orientationsf", "scales"];

/// A PointInstancer's placement arrays at one time code.
struct Poses {
    code: f64,
    positions: Vec<DVec3>,
    orientations: Option<Vec<DQuat>>,
    scales: Option<Vec<DVec3>>,
}

impl Poses {
    /// The first array whose length is not `n`, and its length.
    fn miscounted(&self, n: usize) -> Option<(&'static str, usize)> {
        let lengths = [
            ("positions", Some(self.positions.len())),
            ("orientations", self.orientations.as_ref().map(Vec::len)),
            ("scales", self.scales.as_ref().map(Vec::len)),
        ];
        lengths
            .into_iter()
            .find_map(|(name, len)| len.filter(|&l| l != n).map(|l| (name, l)))
    }

    /// Instance `i`'s rotation, scale and position.
    fn of(&self, i: usize) -> (DQuat, DVec3, DVec3) {
        (
            self.orientations.as_ref().map_or(DQuat::IDENTITY, |q| q[i]),
            self.scales.as_ref().map_or(DVec3::ONE, |s| s[i]),
            self.positions[i],
        )
    }
}

/// A PointInstancer's per-instance arrays, each as long as `proto_indices`.
struct InstanceArrays {
    proto_indices: Vec<u32>,
    /// The placements at each time code the span needs, in order; one (at the span's start)
    /// where they are not sampled over time.
    poses: Vec<Poses>,
    velocities: Option<Vec<DVec3>>,
    ids: Option<Vec<u32>>,
    invisible: Option<Vec<u32>>,
    angular_velocities: bool,
}

impl InstanceArrays {
    /// Per instance, whether `invisibleIds` hides it (by its id, or its index without ids).
    fn hidden(&self) -> Vec<bool> {
        let Some(invisible) = &self.invisible else {
            return Vec::new();
        };
        let invisible: std::collections::HashSet<u32> = invisible.iter().copied().collect();
        (0..self.proto_indices.len())
            .map(|i| {
                let id = self.ids.as_ref().and_then(|ids| ids.get(i)).copied();
                invisible.contains(&id.unwrap_or(i as u32))
            })
            .collect()
    }

    /// Instance `i`'s world transform at each of the instancer's `world` samples (time code
    /// and matrix, read between them by `world_at`), its placements interpolated between their
    /// samples at each (`world` then holds every placement's code too), and followed between
    /// them ([`Self::followed`]); or, standing in the instancer and given a velocity, moved by
    /// it at the span's ends.
    fn placements(
        &self,
        i: usize,
        world: &[(f64, DMat4)],
        world_at: &WorldAt,
    ) -> Result<Vec<(f64, DMat4)>, RenderError> {
        if self.poses.len() > 1 {
            return self.followed(i, world, world_at);
        }
        let source = world_at.source;
        let (rotation, scale, position) = self.poses[0].of(i);
        let at = |offset: DVec3| {
            DMat4::from_scale_rotation_translation(scale, rotation, position + offset)
        };
        match self.velocities.as_ref().map(|v| v[i]) {
            Some(v) if v != DVec3::ZERO => Ok({
                let [start, end] = source.codes();
                let first = source.clock.seconds(start);
                let world_at = |code: f64| nearest(world, code);
                let codes = if end > start {
                    vec![start, end]
                } else {
                    vec![start]
                };
                codes
                    .iter()
                    .map(|&c| {
                        let dt = source.clock.seconds(c) - first;
                        (c, world_at(c) * at(v * dt))
                    })
                    .collect()
            }),
            _ => self.followed(i, world, world_at),
        }
    }

    /// Instance `i`'s world transform at the instancer's `world` samples, and between two of
    /// them wherever rift's blend of the two would stray from where USD puts it: its scales
    /// grow linearly, which rift's blend of keys does geometrically, and a turning instancer
    /// carries its moving instances along curves ([`xform::Follow`]).
    fn followed(
        &self,
        i: usize,
        world: &[(f64, DMat4)],
        world_at: &WorldAt,
    ) -> Result<Vec<(f64, DMat4)>, RenderError> {
        let matrix = |code: f64| {
            let (rotation, scale, position) = self.pose_at(i, code);
            DMat4::from_scale_rotation_translation(scale, rotation, position)
        };
        let at = |code: f64| Ok(world_at.at(code)? * matrix(code));
        let follow = xform::Follow::new(world_at.source.codes(), &at);
        let mut out = Vec::with_capacity(world.len());
        // The sample before, and the instancer's transform then.
        let mut previous: Option<((f64, DMat4), DMat4)> = None;
        for &(code, m) in world {
            let sample = (code, m * matrix(code));
            if let Some((before, before_world)) = previous
                && (before_world != m || self.grows(i, (before.0, code)))
            {
                follow.between(before, sample, xform::MOST_HALVINGS, &mut out)?;
            }
            out.push(sample);
            previous = Some((sample, m));
        }
        Ok(out)
    }

    /// Whether instance `i`'s scale changes between time codes `a` and `b`: the one change of
    /// its own placement that rift's blend of keys does not make as USD interpolates it (its
    /// position and turn alone blend alike). Where the instancer's transform changes, the
    /// instance's keys are checked whatever it does: an instance away from the instancer's
    /// origin is carried along an arc when it turns, even standing still in it.
    fn grows(&self, i: usize, (a, b): (f64, f64)) -> bool {
        self.pose_at(i, a).1 != self.pose_at(i, b).1
    }

    /// Instance `i`'s rotation, scale and position at `code`, interpolated between the
    /// placements' samples as USD does (positions and scales linearly, rotations along the
    /// sphere), held beyond the first and the last.
    fn pose_at(&self, i: usize, code: f64) -> (DQuat, DVec3, DVec3) {
        let after = self.poses.partition_point(|p| p.code <= code);
        let (Some(a), Some(b)) = (
            after.checked_sub(1).map(|k| &self.poses[k]),
            self.poses.get(after),
        ) else {
            let held = &self.poses[after.min(self.poses.len() - 1)];
            return held.of(i);
        };
        let t = (code - a.code) / (b.code - a.code);
        let ((ra, sa, pa), (rb, sb, pb)) = (a.of(i), b.of(i));
        (ra.slerp(rb, t), sa.lerp(sb, t), pa.lerp(pb, t))
    }
}

/// A PointInstancer's world transform at any time code, each read once: its instances are
/// followed between samples at the same halfway codes.
struct WorldAt<'a> {
    prim: &'a Prim,
    source: &'a super::Source<'a>,
    known: RefCell<HashMap<u64, DMat4>>,
}

impl<'a> WorldAt<'a> {
    /// Knowing the instancer `prim`'s world transform at its `samples` already.
    fn new(prim: &'a Prim, samples: &[(f64, DMat4)], source: &'a super::Source<'a>) -> Self {
        let known = samples.iter().map(|&(c, m)| (c.to_bits(), m)).collect();
        Self {
            prim,
            source,
            known: RefCell::new(known),
        }
    }

    fn at(&self, code: f64) -> Result<DMat4, RenderError> {
        if let Some(&m) = self.known.borrow().get(&code.to_bits()) {
            return Ok(m);
        }
        let path = self.prim.path().as_str();
        let m = xform::world(self.prim, code, self.source)
            .map_err(|e| self.source.read_error(path, e))?;
        self.known.borrow_mut().insert(code.to_bits(), m);
        Ok(m)
    }
}

/// The sample of `samples` (time code and matrix, sorted) nearest `code` at or before it.
fn nearest(samples: &[(f64, DMat4)], code: f64) -> DMat4 {
    let i = samples
        .partition_point(|(c, _)| *c <= code)
        .saturating_sub(1);
    samples[i].1
}

/// The stretch of `m`'s linear part A = U·P (U a rotation times a uniform scale, P symmetric):
/// P scaled to determinant 1; `None` where A is a similarity already, mirrors or is singular.
fn unit_stretch(m: DMat4) -> Option<DMat3> {
    let a = DMat3::from_mat4(m);
    if !a.is_finite() || a.determinant() <= 0.0 {
        return None;
    }
    // Newton's iteration for the orthogonal polar factor.
    let mut u = a * (1.0 / a.determinant().cbrt());
    for _ in 0..64 {
        let next = (u + u.inverse().transpose()) * 0.5;
        let change = (next - u)
            .to_cols_array()
            .iter()
            .fold(0.0f64, |m, x| m.max(x.abs()));
        u = next;
        if change < 1e-14 {
            break;
        }
    }
    let p = u.transpose() * a;
    let p = p * (1.0 / p.determinant().cbrt());
    let off_identity = (p - DMat3::IDENTITY)
        .to_cols_array()
        .iter()
        .fold(0.0f64, |m, x| m.max(x.abs()));
    (off_identity > 1e-6).then_some(p)
}

/// A matrix rounded to six decimals: instances that place a prototype alike up to rounding
/// (each instance's transforms composed in its own order) share it.
fn quantized<const N: usize>(m: [f64; N]) -> [i64; N] {
    m.map(|x| (x * 1e6).round() as i64)
}

/// `m`'s inverse, where it has one.
fn invertible(m: DMat4) -> Option<DMat4> {
    let d = m.determinant();
    (d.is_finite() && d != 0.0).then(|| m.inverse())
}

/// A quaternion from USD's real part first.
fn quat(w: f64, x: f64, y: f64, z: f64) -> DQuat {
    DQuat::from_xyzw(x, y, z, w)
}
