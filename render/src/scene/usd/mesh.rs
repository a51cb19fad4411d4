//! UsdGeomMesh prims into mesh parts: polygons triangulated as fans (holes left out, a
//! left-handed mesh's winding turned), `primvars:st` as UVs and `normals` (or
//! `primvars:normals`) as smooth-shading normals at any interpolation (indexed or not), one part
//! per material (the mesh's binding and its `materialBind` subsets), and
//! time-sampled points (with their velocities) as a deforming mesh.

use super::Source;
use super::values::{int_array, token, value, vec2_array, vec3_array};
use super::xform::{Placement, within};
use crate::error::RenderError;
use crate::scene::mesh::Shape;
use crate::scene::mesh::{MeshPart, MtlMaterial};
use crate::scene::sequence::{self, Sample};
use glam::{DMat4, Vec2, Vec3};
use openusd::sdf::Value;
use openusd::usd::{Prim, TimeCode};

/// A mesh prim as read: its shape (parts without material names yet), per part the USD
/// material bound to it, and what of it rift renders otherwise than USD says.
pub struct ReadMesh {
    pub shape: Shape,
    pub bindings: Vec<Option<String>>,
    /// Its subdivision scheme, when not "none" (rendered as its control cage).
    pub subdivision: Option<String>,
    /// Its points deform but its normals are not sampled over time: they were dropped, and
    /// it is shaded flat.
    pub still_normals: bool,
}

impl Shape {
    /// This shape with part `i` using the scene material `names[i]`.
    pub fn with_materials(mut self, names: &[String]) -> Self {
        for (part, name) in self.parts.iter_mut().zip(names) {
            part.material = Some(MtlMaterial {
                name: name.clone(),
                declared: true,
                ..MtlMaterial::default()
            });
        }
        self
    }
}

/// The polygons of a mesh: corner counts and point indices, checked.
struct Topology {
    counts: Vec<u32>,
    indices: Vec<u32>,
    /// Per face, the index of its first corner in `indices`.
    starts: Vec<usize>,
    /// Per face, the part it belongs to (`u32::MAX`: a hole).
    part: Vec<u32>,
    left_handed: bool,
}

/// A primvar (texture coordinates, normals) and how it is spread over the mesh: one value per
/// point, face, face corner, or for the whole mesh, each looked up through `indices` when the
/// primvar is indexed.
struct Primvar<T> {
    /// The attribute it was read from, for errors.
    name: &'static str,
    values: Vec<T>,
    indices: Option<Vec<u32>>,
    interpolation: Interpolation,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Interpolation {
    Constant,
    Uniform,
    Vertex,
    FaceVarying,
}

/// Reads the mesh `prim`, placed by `placement`.
pub fn read(prim: &Prim, source: &Source, placement: &Placement) -> Result<ReadMesh, RenderError> {
    let path = prim.path().as_str();
    let code = source.codes()[0];
    let scheme = token(prim, "subdivisionScheme", code)
        .map_err(|e| source.read_error(path, e))?
        .unwrap_or_else(|| "catmullClark".into());
    let (topology, bindings) = topology(prim, source, code)?;
    let uvs = uvs(prim, source, code)?;
    let times = point_times(prim, source).map_err(|e| source.read_error(path, e))?;
    check_memory(source, path, &topology, times.len())?;
    // Deforming points need normals sampled with them, read at each sample below; normals
    // that stay put while the points move are dropped.
    let deforms = times.len() > 1;
    let normals_follow = deforms && normals_sampled(prim);
    let still = match normals_follow {
        true => None,
        false => normals(prim, source, code, placement.bake)?,
    };
    let still_normals = deforms && still.is_some();
    let mut primvars = Primvars {
        uvs,
        normals: still.filter(|_| !deforms),
    };
    let mut samples = Vec::with_capacity(times.len());
    for &t in &times {
        if normals_follow {
            primvars.normals = normals(prim, source, t, placement.bake)?;
        }
        let points = points(prim, source, "points", t)?;
        check_indices(source, path, &topology, (t, points.len()))?;
        let velocities = match times.len() > 1 {
            true => velocities(prim, source, t, points.len())?,
            false => None,
        };
        let parts = parts(
            path,
            source,
            (&topology, &primvars, bindings.len()),
            &points,
            velocities.as_deref(),
            placement.bake,
        )?;
        samples.push((t, parts));
    }
    let shape = shape(source, samples)?;
    Ok(ReadMesh {
        shape,
        bindings,
        subdivision: (scheme != "none").then_some(scheme),
        still_normals,
    })
}

/// The shape of a mesh from its samples' parts: still with one sample, else deforming.
fn shape(source: &Source, samples: Vec<(f64, Vec<MeshPart>)>) -> Result<Shape, RenderError> {
    let mut samples = samples.into_iter();
    let (first_code, first) = samples.next().expect("a mesh is read at one time at least");
    if samples.len() == 0 {
        return Ok(Shape {
            parts: first,
            deformation: None,
        });
    }
    let sample = |code: f64| Sample {
        frame: source.clock.frame(code),
        path: source.layer.to_owned(),
    };
    let rest: Vec<(Sample, Vec<MeshPart>)> = samples.map(|(c, p)| (sample(c), p)).collect();
    let first_sample = sample(first_code);
    let sequence = sequence::assemble(
        (&first_sample, first),
        rest.iter().map(|(s, p)| Ok((s, p.clone()))),
        source.clock.fps,
    )?;
    Ok(Shape {
        parts: sequence.parts,
        deformation: Some(sequence.mesh),
    })
}

/// True when the mesh's normals (`primvars:normals` or `normals`) have time samples.
fn normals_sampled(prim: &Prim) -> bool {
    ["primvars:normals", "normals"].iter().any(|name| {
        (prim.attribute(*name).time_sample_times()).is_ok_and(|times| !times.is_empty())
    })
}

/// The time codes the points are read at: their samples around the span, or the span's
/// start when they are not sampled.
fn point_times(prim: &Prim, source: &Source) -> anyhow::Result<Vec<f64>> {
    let times = prim.attribute("points").time_sample_times()?;
    Ok(within(&times, source.codes()))
}

/// Refuses a mesh whose triangles (at every sample) would not fit the memory budget, before
/// any is made.
fn check_memory(
    source: &Source,
    path: &str,
    topology: &Topology,
    samples: usize,
) -> Result<(), RenderError> {
    let triangles: u64 = topology.counts.iter().map(|&c| c as u64 - 2).sum();
    // Corners, UVs, normals and the part's share of the scene's arrays, per sample.
    let bytes = triangles.saturating_mul(36 + 24 + 36 + 16) * samples as u64;
    match source.budget {
        Some(budget) if bytes > budget => Err(source.error(
            path,
            Some("faceVertexCounts"),
            format!(
                "its {triangles} triangles at {samples} time samples need about {} MiB, \
                 more than the {} MiB available",
                bytes >> 20,
                budget >> 20
            ),
        )),
        _ => Ok(()),
    }
}

/// Refuses faces that name points past the `count` the points have at time code `code` (each
/// sample is checked: a sample may hold fewer points than another).
fn check_indices(
    source: &Source,
    path: &str,
    topology: &Topology,
    (code, count): (f64, usize),
) -> Result<(), RenderError> {
    let Some(i) = topology.indices.iter().position(|&i| i as usize >= count) else {
        return Ok(());
    };
    Err(source.error(
        path,
        Some("faceVertexIndices"),
        format!(
            "index {} (entry {i}) is past the mesh's {count} points at time code {code}",
            topology.indices[i]
        ),
    ))
}

/// The mesh's polygons and, per part, the material bound to it: the mesh's own first, then
/// each `materialBind` subset's.
fn topology(
    prim: &Prim,
    source: &Source,
    code: f64,
) -> Result<(Topology, Vec<Option<String>>), RenderError> {
    let path = prim.path().as_str();
    let read = |name: &str| {
        int_array(prim, name, code)
            .map_err(|e| source.read_error(path, e))?
            .ok_or_else(|| source.error(path, Some(name), "missing".into()))
    };
    let counts = read("faceVertexCounts")?;
    let indices = read("faceVertexIndices")?;
    let mut starts = Vec::with_capacity(counts.len());
    let mut at = 0usize;
    for (f, &c) in counts.iter().enumerate() {
        if c < 3 {
            return Err(source.error(
                path,
                Some("faceVertexCounts"),
                format!("face {f} has {c} corners; a face needs 3 or more"),
            ));
        }
        starts.push(at);
        at = at.saturating_add(c as usize);
    }
    if at != indices.len() {
        return Err(source.error(
            path,
            Some("faceVertexIndices"),
            format!(
                "holds {} indices where faceVertexCounts add up to {at}",
                indices.len()
            ),
        ));
    }
    let mut part = vec![0u32; counts.len()];
    let mut bindings =
        vec![super::shading::bound_material(prim).map_err(|e| source.read_error(path, e))?];
    subsets(prim, source, &mut part, &mut bindings)?;
    for h in int_array(prim, "holeIndices", code)
        .map_err(|e| source.read_error(path, e))?
        .unwrap_or_default()
    {
        if let Some(p) = part.get_mut(h as usize) {
            *p = u32::MAX;
        }
    }
    let left_handed = token(prim, "orientation", code)
        .map_err(|e| source.read_error(path, e))?
        .is_some_and(|o| o == "leftHanded");
    Ok((
        Topology {
            counts,
            indices,
            starts,
            part,
            left_handed,
        },
        bindings,
    ))
}

/// Gives the faces of each `materialBind` subset under `prim` a part of its own, bound to the
/// subset's material.
fn subsets(
    prim: &Prim,
    source: &Source,
    part: &mut [u32],
    bindings: &mut Vec<Option<String>>,
) -> Result<(), RenderError> {
    let path = prim.path().as_str();
    let children = prim.children().map_err(|e| source.read_error(path, e))?;
    for child in children {
        let child_path = child.path().as_str().to_owned();
        let kind = child
            .type_name()
            .map_err(|e| source.read_error(&child_path, e))?;
        if kind.as_ref().map(|k| k.as_str()) != Some("GeomSubset") {
            continue;
        }
        let family =
            token(&child, "familyName", 0.0).map_err(|e| source.read_error(&child_path, e))?;
        if family.as_deref() != Some("materialBind") {
            continue;
        }
        let faces = int_array(&child, "indices", 0.0)
            .map_err(|e| source.read_error(&child_path, e))?
            .unwrap_or_default();
        let index = bindings.len() as u32;
        bindings.push(
            super::shading::bound_material(&child)
                .map_err(|e| source.read_error(&child_path, e))?,
        );
        for f in faces {
            let Some(p) = part.get_mut(f as usize) else {
                return Err(source.error(
                    &child_path,
                    Some("indices"),
                    format!("face {f} is past the mesh's {} faces", part.len()),
                ));
            };
            *p = index;
        }
    }
    Ok(())
}

/// The primvars a mesh's triangles carry to their corners.
struct Primvars {
    uvs: Option<Primvar<Vec2>>,
    /// Unit length, in the space the mesh's points are placed in.
    normals: Option<Primvar<Vec3>>,
}

/// The mesh's UVs: `primvars:st`, else Blender's `primvars:UVMap` (face-varying unless they
/// say otherwise, as Blender and most tools write them).
fn uvs(prim: &Prim, source: &Source, code: f64) -> Result<Option<Primvar<Vec2>>, RenderError> {
    let candidates = [
        ("primvars:st", Interpolation::FaceVarying),
        ("primvars:UVMap", Interpolation::FaceVarying),
    ];
    first_primvar(prim, source, code, &candidates, |name, value| {
        let error = |message: String| source.error(prim.path().as_str(), Some(name), message);
        let values = vec2_array(value)
            .ok_or_else(|| error("expected texture coordinates (float2[])".into()))?;
        match values.iter().position(|uv| !uv.is_finite()) {
            Some(i) => Err(error(format!("texture coordinate {i} is not finite"))),
            None => Ok(values),
        }
    })
}

/// The mesh's normals for smooth shading: `primvars:normals` (which wins, as in USD), else
/// `normals` (per point unless it says otherwise), carried through the linear part of
/// `bake` as normals are (its inverse transpose) and made unit length.
fn normals(
    prim: &Prim,
    source: &Source,
    code: f64,
    bake: DMat4,
) -> Result<Option<Primvar<Vec3>>, RenderError> {
    let to_placed = glam::DMat3::from_mat4(bake).inverse().transpose();
    let candidates = [
        ("primvars:normals", Interpolation::Constant),
        ("normals", Interpolation::Vertex),
    ];
    first_primvar(prim, source, code, &candidates, |name, value| {
        let error = |message: String| source.error(prim.path().as_str(), Some(name), message);
        let given =
            vec3_array(value).ok_or_else(|| error("expected normals (normal3f[])".into()))?;
        (given.into_iter().enumerate())
            .map(|(i, n)| {
                let placed = (to_placed * n.as_dvec3()).as_vec3();
                crate::scene::mesh::unit_normal(placed)
                    .ok_or_else(|| error(format!("normal {i} is zero or not finite")))
            })
            .collect()
    })
}

/// The first of `candidates` (a primvar's name and its interpolation where it names none) the
/// mesh authors, its values made by `values` from the attribute's, with its indices.
fn first_primvar<T>(
    prim: &Prim,
    source: &Source,
    code: f64,
    candidates: &[(&'static str, Interpolation)],
    values: impl Fn(&'static str, &Value) -> Result<Vec<T>, RenderError>,
) -> Result<Option<Primvar<T>>, RenderError> {
    for &(name, default) in candidates {
        let Some((value, interpolation)) = primvar(prim, source, name, code, default)? else {
            continue;
        };
        return Ok(Some(Primvar {
            name,
            values: values(name, &value)?,
            indices: indices(prim, source, name, code)?,
            interpolation,
        }));
    }
    Ok(None)
}

/// The value of primvar `name` at `code` with its interpolation (`default` where it names
/// none); `None` when it is not authored.
fn primvar(
    prim: &Prim,
    source: &Source,
    name: &str,
    code: f64,
    default: Interpolation,
) -> Result<Option<(Value, Interpolation)>, RenderError> {
    let path = prim.path().as_str();
    let attr = prim.attribute(name);
    let value = attr
        .get_at::<Value>(TimeCode::new(code))
        .map_err(|e| source.read_error(path, e))?;
    let Some(value) = value else {
        return Ok(None);
    };
    let interpolation = match attr
        .get_metadata::<openusd::tf::Token>("interpolation")
        .map_err(|e| source.read_error(path, e))?
        .as_ref()
        .map(|t| t.as_str())
    {
        None => default,
        Some("constant") => Interpolation::Constant,
        Some("uniform") => Interpolation::Uniform,
        Some("vertex") | Some("varying") => Interpolation::Vertex,
        Some("faceVarying") => Interpolation::FaceVarying,
        Some(other) => {
            return Err(source.error(
                path,
                Some(name),
                format!("interpolation {other:?} is not one rift reads"),
            ));
        }
    };
    Ok(Some((value, interpolation)))
}

/// The `:indices` of primvar `name`, when it is indexed.
fn indices(
    prim: &Prim,
    source: &Source,
    name: &str,
    code: f64,
) -> Result<Option<Vec<u32>>, RenderError> {
    int_array(prim, &format!("{name}:indices"), code)
        .map_err(|e| source.read_error(prim.path().as_str(), e))
}

/// The triangles of each part, their points placed by `bake`.
fn parts(
    path: &str,
    source: &Source,
    (topology, primvars, count): (&Topology, &Primvars, usize),
    points: &[Vec3],
    velocities: Option<&[Vec3]>,
    bake: DMat4,
) -> Result<Vec<MeshPart>, RenderError> {
    let placed: Vec<Vec3> = points
        .iter()
        .map(|p| bake.transform_point3(p.as_dvec3()).as_vec3())
        .collect();
    let linear = glam::DMat3::from_mat4(bake);
    let moved: Option<Vec<Vec3>> = velocities.map(|v| {
        v.iter()
            .map(|v| (linear * v.as_dvec3()).as_vec3())
            .collect()
    });
    let mut out: Vec<MeshPart> = (0..count)
        .map(|i| MeshPart {
            name: format!("{path}[{i}]"),
            triangles: Vec::new(),
            uvs: Vec::new(),
            velocities: Vec::new(),
            normals: Vec::new(),
            material: None,
        })
        .collect();
    for (f, (&c, &start)) in topology.counts.iter().zip(&topology.starts).enumerate() {
        let Some(part) = out.get_mut(topology.part[f] as usize) else {
            continue;
        };
        let corner = |k: usize| start + k;
        for k in 1..c as usize - 1 {
            let mut tri = [corner(0), corner(k), corner(k + 1)];
            if topology.left_handed {
                tri.swap(1, 2);
            }
            let vertex = |c: usize| topology.indices[c] as usize;
            part.triangles.push(tri.map(|c| placed[vertex(c)]));
            if let Some(moved) = &moved {
                part.velocities.push(tri.map(|c| moved[vertex(c)]));
            }
            let error = |name, m| source.error(path, Some(name), m);
            if let Some(uvs) = &primvars.uvs {
                let corners = uvs.corners(f, tri, vertex);
                part.uvs.push(corners.map_err(|m| error(uvs.name, m))?);
            }
            if let Some(normals) = &primvars.normals {
                let corners = normals.corners(f, tri, vertex);
                part.normals
                    .push(corners.map_err(|m| error(normals.name, m))?);
            }
        }
    }
    out.retain(|p| !p.triangles.is_empty());
    Ok(out)
}

impl<T: Copy> Primvar<T> {
    /// Its values at a triangle's corners (`tri`: indices into the face-vertex list) of face
    /// `face`; an index past the values is an error.
    fn corners(
        &self,
        face: usize,
        tri: [usize; 3],
        vertex: impl Fn(usize) -> usize,
    ) -> Result<[T; 3], String> {
        let element = |corner: usize| match self.interpolation {
            Interpolation::Constant => 0,
            Interpolation::Uniform => face,
            Interpolation::Vertex => vertex(corner),
            Interpolation::FaceVarying => corner,
        };
        let lookup = |corner: usize| -> Result<T, String> {
            let e = element(corner);
            let i = match &self.indices {
                Some(ix) => *ix
                    .get(e)
                    .ok_or_else(|| format!("its indices have no entry {e}"))?
                    as usize,
                None => e,
            };
            self.values
                .get(i)
                .copied()
                .ok_or_else(|| format!("entry {i} is missing"))
        };
        Ok([lookup(tri[0])?, lookup(tri[1])?, lookup(tri[2])?])
    }
}

/// A `point3f[]` attribute at time `code`, each point finite.
fn points(prim: &Prim, source: &Source, name: &str, code: f64) -> Result<Vec<Vec3>, RenderError> {
    let path = prim.path().as_str();
    let value = value(prim, name, code)
        .map_err(|e| source.read_error(path, e))?
        .ok_or_else(|| source.error(path, Some(name), "missing".into()))?;
    let points = vec3_array(&value)
        .ok_or_else(|| source.error(path, Some(name), "expected points (point3f[])".into()))?;
    if let Some(i) = points
        .iter()
        .position(|p| !crate::scene::within_single_precision(*p))
    {
        return Err(source.error(
            path,
            Some(name),
            format!("point {i} is not finite or lies beyond ±1e12"),
        ));
    }
    Ok(points)
}

/// The mesh's `velocities` at `code`, when authored for every point.
fn velocities(
    prim: &Prim,
    source: &Source,
    code: f64,
    count: usize,
) -> Result<Option<Vec<Vec3>>, RenderError> {
    if value(prim, "velocities", code).ok().flatten().is_none() {
        return Ok(None);
    }
    let v = points(prim, source, "velocities", code)?;
    Ok((v.len() == count).then_some(v))
}
