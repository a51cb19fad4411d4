//! Mesh files: OBJ (with its MTL, through tobj); PLY is in [`super::ply`]. Each OBJ object/group becomes one part with the
//! name of its `usemtl` material and, when the MTL has it, that material's Kd and Ke.

use super::within_single_precision;
use crate::error::RenderError;
use glam::{Vec2, Vec3};
use std::path::Path;

/// The material a part's `usemtl` names, with the values its MTL gives.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct MtlMaterial {
    pub name: String,
    pub diffuse: Option<Vec3>,
    pub emission: Option<Vec3>,
    /// `map_Kd`: the diffuse colour's texture, relative to the MTL's folder.
    pub diffuse_map: Option<String>,
    /// `Ks`, `Ns`, and the PBR extension's `Pr` (roughness) and `Pm` (metallic): any of them
    /// makes the material a standard one.
    pub specular: Option<Vec3>,
    pub shininess: Option<f32>,
    pub roughness: Option<f32>,
    pub metallic: Option<f32>,
    /// `map_Pr` (or Blender's `map_Ns`): a roughness texture; `map_Pm`: a metallic one.
    pub roughness_map: Option<String>,
    pub metallic_map: Option<String>,
    /// `norm` (or `map_Bump`/`bump`, as Blender writes normal maps): a tangent-space normal
    /// map, with its `-bm` strength.
    pub normal_map: Option<(String, f32)>,
    /// `d` and `map_d`: opacity (cut-outs), as Blender writes alpha.
    pub opacity: Option<f32>,
    pub opacity_map: Option<String>,
    /// `map_Ke`: the emission's texture (its colour scaled by Ke, else by 1).
    pub emission_map: Option<String>,
    /// The maps it names that rift does not read yet (`map_Ka`, `map_Ks`, …).
    pub unread_maps: Vec<String>,
    /// False when no MTL defines the name: only the shot's `[[material]]` can supply it.
    pub declared: bool,
}

/// The MTL rift hands the OBJ parser itself, declaring every `usemtl` name (so a name that
/// only the shot defines still reaches the part); real MTLs, read after it, override it.
const USEMTL_NAMES: &str = "rift-usemtl-names.mtl";

/// One part of a mesh file: triangles in the file's space, their texture coordinates when the
/// file gives them, and the material it names.
#[derive(Clone, Debug)]
pub struct MeshPart {
    pub name: String,
    pub triangles: Vec<[Vec3; 3]>,
    /// Per triangle, its corners' UVs (v = 0 at an image's bottom row); empty without.
    pub uvs: Vec<[Vec2; 3]>,
    /// Per triangle, its corners' velocities in units per second (a PLY's `vx vy vz`, for a
    /// mesh sequence's motion between frames); empty without.
    pub velocities: Vec<[Vec3; 3]>,
    /// Per triangle, its corners' authored normals (OBJ `vn`, PLY `nx ny nz`, USD `normals`),
    /// unit length, interpolated across the triangle for smooth shading; empty without.
    pub normals: Vec<[Vec3; 3]>,
    pub material: Option<MtlMaterial>,
}

/// Loads an OBJ file, with the MTL files it names beside it.
pub fn load_obj(path: &Path) -> Result<Vec<MeshPart>, RenderError> {
    let bad = |message: String| RenderError::Mesh {
        file: path.to_owned(),
        message,
    };
    let bytes = rift_fx::io::read(path).map_err(|e| bad(format!("cannot read: {e}")))?;
    // Its MTL files are read within the same bounds.
    let read_mtl = |mtl: &Path| {
        let full = path.parent().map_or(mtl.to_owned(), |dir| dir.join(mtl));
        rift_fx::io::read(&full).ok()
    };
    parse_obj(&bytes, read_mtl).map_err(bad)
}

/// Parses OBJ bytes into parts; `read_mtl` gives the bytes of an MTL file the OBJ names
/// (`None`: it cannot be read).
pub fn parse_obj(
    bytes: &[u8],
    read_mtl: impl Fn(&Path) -> Option<Vec<u8>>,
) -> Result<Vec<MeshPart>, String> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ..Default::default()
    };
    check_face_corners(bytes)?;
    // What the MTL parser would panic on, found first.
    let mtl_problem = std::cell::RefCell::new(None);
    let declared = std::cell::RefCell::new(std::collections::HashSet::new());
    let names = usemtl_names(bytes);
    let load_mtl = |mtl: &Path| {
        if mtl == Path::new(USEMTL_NAMES) {
            let text: String = names.iter().map(|n| format!("newmtl {n}\n")).collect();
            return tobj::load_mtl_buf(&mut text.as_bytes());
        }
        let Some(bytes) = read_mtl(mtl) else {
            *mtl_problem.borrow_mut() = Some(format!("{} could not be read", mtl.display()));
            return Err(tobj::LoadError::OpenFileFailed);
        };
        if let Err(problem) = check_mtl(&bytes) {
            *mtl_problem.borrow_mut() = Some(format!("{}: {problem}", mtl.display()));
            return Err(tobj::LoadError::MaterialParseError);
        }
        declared
            .borrow_mut()
            .extend(keyword_arguments(&bytes, "newmtl"));
        tobj::load_mtl_buf(&mut bytes.as_slice())
    };
    let prefixed;
    let mut reader = if names.is_empty() {
        bytes
    } else {
        prefixed = [format!("mtllib {USEMTL_NAMES}\n").as_bytes(), bytes].concat();
        prefixed.as_slice()
    };
    let (models, materials) = tobj::load_obj_buf(&mut reader, &options, load_mtl)
        .map_err(|e| format!("malformed OBJ: {e}"))?;
    // With several MTLs (ours among them) the parser may keep going past one that failed.
    if let Some(problem) = mtl_problem.take() {
        return Err(format!("its MTL {problem}"));
    }
    let materials = materials.map_err(|e| format!("its MTL could not be read: {e}"))?;
    let mut parts = Vec::with_capacity(models.len());
    for model in models {
        let m = &model.mesh;
        let positions: Vec<Vec3> = m
            .positions
            .chunks_exact(3)
            .map(|p| Vec3::new(p[0], p[1], p[2]))
            .collect();
        if let Some(i) = positions.iter().position(|&p| !within_single_precision(p)) {
            return Err(format!(
                "object {:?}: vertex {i} is not finite or beyond ±{:e} m",
                model.name,
                rift_fx::shot::check::MAX_LENGTH
            ));
        }
        let uvs = part_uvs(&model)?;
        let normals = part_normals(&model)?;
        let mut triangles = Vec::with_capacity(m.indices.len() / 3);
        for (f, idx) in m.indices.chunks_exact(3).enumerate() {
            let get = |k: usize| {
                positions.get(idx[k] as usize).copied().ok_or_else(|| {
                    format!(
                        "object {:?}: face {f} uses vertex {} of {}",
                        model.name,
                        idx[k],
                        positions.len()
                    )
                })
            };
            triangles.push([get(0)?, get(1)?, get(2)?]);
        }
        let material = m
            .material_id
            .and_then(|id| materials.get(id))
            .map(|mat| mtl_material(mat, declared.borrow().contains(&mat.name)))
            .transpose()?;
        parts.push(MeshPart {
            name: model.name,
            triangles,
            uvs,
            velocities: Vec::new(),
            normals,
            material,
        });
    }
    if parts.iter().all(|p| p.triangles.is_empty()) {
        return Err("malformed OBJ: no faces".into());
    }
    Ok(parts)
}

/// The corner normals of each triangle of `model` (its `vn`s by the faces' normal indices);
/// none when its faces give no normals.
fn part_normals(model: &tobj::Model) -> Result<Vec<[Vec3; 3]>, String> {
    let m = &model.mesh;
    if m.normal_indices.is_empty() {
        return Ok(Vec::new());
    }
    if m.normal_indices.len() != m.indices.len() {
        return Err(format!(
            "object {:?}: some faces give normals and others do not",
            model.name
        ));
    }
    let normal = |k: u32| -> Result<Vec3, String> {
        let k = k as usize;
        match m.normals.get(3 * k..3 * k + 3) {
            Some(&[x, y, z]) => unit_normal(Vec3::new(x, y, z)).ok_or_else(|| {
                format!("object {:?}: normal {k} is zero or not finite", model.name)
            }),
            _ => Err(format!(
                "object {:?}: a face uses normal {k} of {}",
                model.name,
                m.normals.len() / 3
            )),
        }
    };
    m.normal_indices
        .chunks_exact(3)
        .map(|t| Ok([normal(t[0])?, normal(t[1])?, normal(t[2])?]))
        .collect()
}

/// `n` made unit length; `None` when it is zero, too small to normalise, or not finite.
pub(crate) fn unit_normal(n: Vec3) -> Option<Vec3> {
    n.is_finite().then(|| n.try_normalize()).flatten()
}

/// The UVs of each triangle of `model` (its `vt`s by the faces' texture indices); none when
/// its faces give no texture coordinates.
fn part_uvs(model: &tobj::Model) -> Result<Vec<[Vec2; 3]>, String> {
    let m = &model.mesh;
    if m.texcoord_indices.is_empty() {
        return Ok(Vec::new());
    }
    if m.texcoord_indices.len() != m.indices.len() {
        return Err(format!(
            "object {:?}: some faces give texture coordinates and others do not",
            model.name
        ));
    }
    let uv = |k: u32| -> Result<Vec2, String> {
        let k = k as usize;
        match m.texcoords.get(2 * k..2 * k + 2) {
            Some(&[u, v]) if u.is_finite() && v.is_finite() => Ok(Vec2::new(u, v)),
            Some(_) => Err(format!(
                "object {:?}: texture coordinate {k} is not finite",
                model.name
            )),
            None => Err(format!(
                "object {:?}: a face uses texture coordinate {k} of {}",
                model.name,
                m.texcoords.len() / 2
            )),
        }
    };
    m.texcoord_indices
        .chunks_exact(3)
        .map(|t| Ok([uv(t[0])?, uv(t[1])?, uv(t[2])?]))
        .collect()
}

/// A material of an MTL as rift reads it.
fn mtl_material(mat: &tobj::Material, declared: bool) -> Result<MtlMaterial, String> {
    let param = |key: &str| mat.unknown_param.get(key).map(String::as_str);
    let number = |key: &str| -> Result<Option<f32>, String> {
        let Some(text) = param(key) else {
            return Ok(None);
        };
        match text.parse::<f32>() {
            Ok(x) if (0.0..=1.0).contains(&x) => Ok(Some(x)),
            _ => Err(format!(
                "material {:?}: {key} {text:?} is not a number from 0 to 1",
                mat.name
            )),
        }
    };
    let roughness_map = param("map_Pr").or(mat.shininess_texture.as_deref());
    let normal = param("norm").or(mat.normal_texture.as_deref());
    let mut unread_maps: Vec<String> = [
        ("map_Ka", &mat.ambient_texture),
        ("map_Ks", &mat.specular_texture),
    ]
    .iter()
    .filter(|(_, map)| map.is_some())
    .map(|(name, _)| name.to_string())
    .collect();
    let read = ["map_Pr", "map_Pm", "map_Ke"];
    let mut keys: Vec<&String> = mat.unknown_param.keys().collect();
    keys.sort();
    unread_maps.extend(
        keys.into_iter()
            .filter(|k| k.starts_with("map_") && !read.contains(&k.as_str()))
            .cloned(),
    );
    Ok(MtlMaterial {
        name: mat.name.clone(),
        diffuse: mat.diffuse.map(Vec3::from_array),
        emission: mat.emissive.map(Vec3::from_array),
        diffuse_map: mat.diffuse_texture.as_deref().map(map_file),
        specular: mat.specular.map(Vec3::from_array),
        shininess: mat.shininess.filter(|s| s.is_finite()),
        roughness: number("Pr")?,
        metallic: number("Pm")?,
        roughness_map: roughness_map.map(map_file),
        metallic_map: param("map_Pm").map(map_file),
        normal_map: normal.map(|value| (map_file(value), bump_strength(value))),
        opacity: mat.dissolve.filter(|d| (0.0..=1.0).contains(d)),
        opacity_map: mat.dissolve_texture.as_deref().map(map_file),
        emission_map: param("map_Ke").map(map_file),
        unread_maps,
        declared,
    })
}

/// The `-bm` option of a map statement (1 without it).
fn bump_strength(value: &str) -> f32 {
    let words: Vec<&str> = value.split_whitespace().collect();
    words
        .windows(2)
        .find(|w| w[0] == "-bm")
        .and_then(|w| w[1].parse::<f32>().ok())
        .filter(|s| s.is_finite() && *s >= 0.0)
        .unwrap_or(1.0)
}

/// The file of a map statement's value (its last word: options such as `-bm 1` come first).
fn map_file(value: &str) -> String {
    value.split_whitespace().last().unwrap_or("").to_owned()
}

/// The distinct `usemtl` names of an OBJ, in order of first use.
fn usemtl_names(obj: &[u8]) -> Vec<String> {
    let mut names = Vec::new();
    for name in keyword_arguments(obj, "usemtl") {
        if !names.contains(&name) {
            names.push(name);
        }
    }
    names
}

/// Refuses an object (an `o` or `g` group) whose face corners give normals, or texture
/// coordinates, at some corners and not at others: the OBJ parser would fill the missing ones
/// with others, silently.
fn check_face_corners(obj: &[u8]) -> Result<(), String> {
    let mut given: [Option<bool>; 2] = [None, None];
    for (i, line) in String::from_utf8_lossy(obj).lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("o") | Some("g") => given = [None, None],
            Some("f") => {
                for corner in words {
                    let mut fields = corner.split('/').skip(1);
                    let has =
                        [fields.next(), fields.next()].map(|f| f.is_some_and(|f| !f.is_empty()));
                    for (k, what) in ["texture coordinates", "normals"].iter().enumerate() {
                        match given[k] {
                            None => given[k] = Some(has[k]),
                            Some(g) if g != has[k] => {
                                return Err(format!(
                                    "line {}: some face corners of its object give {what} and \
                                     others do not",
                                    i + 1
                                ));
                            }
                            _ => {}
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// The argument of every `keyword` line of an OBJ or MTL text.
fn keyword_arguments(text: &[u8], keyword: &str) -> Vec<String> {
    String::from_utf8_lossy(text)
        .lines()
        .filter_map(|line| {
            let rest = line.trim_start().strip_prefix(keyword)?;
            let name = rest.trim();
            (rest.starts_with(char::is_whitespace) && !name.is_empty()).then(|| name.to_owned())
        })
        .collect()
}

/// Checks what the MTL parser takes on trust: a colour line (`Ka`, `Kd`, `Ks`, `Ke`) has at
/// least three values.
fn check_mtl(bytes: &[u8]) -> Result<(), String> {
    for (i, line) in String::from_utf8_lossy(bytes).lines().enumerate() {
        let mut words = line.split_whitespace();
        if let Some(key @ ("Ka" | "Kd" | "Ks" | "Ke")) = words.next()
            && words.count() < 3
        {
            return Err(format!("line {}: {key} needs three numbers (r g b)", i + 1));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_colour_with_fewer_than_three_values_is_an_error_not_a_panic() {
        let obj = b"mtllib a.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        let mtl = b"newmtl m\nKd 0.5 0.5\n".to_vec();
        let err = parse_obj(obj, |_| Some(mtl.clone())).unwrap_err();
        assert!(
            err.contains("a.mtl: line 2: Kd needs three numbers"),
            "{err}"
        );
        let good = b"newmtl m\nKd 0.5 0.5 0.5\n".to_vec();
        let parts = parse_obj(obj, |_| Some(good.clone())).unwrap();
        assert_eq!(
            parts[0].material.as_ref().unwrap().diffuse,
            Some(Vec3::splat(0.5))
        );
    }

    /// A `usemtl` name no MTL defines still reaches its part (for the shot's [[material]]),
    /// marked undeclared; a name the MTL defines keeps the MTL's values.
    #[test]
    fn usemtl_names_reach_their_parts_with_or_without_an_mtl() {
        let obj = b"mtllib a.mtl\no one\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n\
                    o two\nusemtl glass\nf 1 3 2\n";
        let mtl = b"newmtl m\nKd 0.25 0.5 0.75\n".to_vec();
        let parts = parse_obj(obj, |_| Some(mtl.clone())).unwrap();
        let m = parts[0].material.as_ref().unwrap();
        assert_eq!((m.name.as_str(), m.declared), ("m", true));
        assert_eq!(m.diffuse, Some(Vec3::new(0.25, 0.5, 0.75)));
        let glass = parts[1].material.as_ref().unwrap();
        assert_eq!((glass.name.as_str(), glass.declared), ("glass", false));
        // Without any mtllib line.
        let bare = b"usemtl glass\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        let parts = parse_obj(bare, |_| None).unwrap();
        assert_eq!(parts[0].material.as_ref().unwrap().name, "glass");
    }

    #[test]
    fn normals_follow_each_face_corner_made_unit_and_bad_ones_are_refused() {
        let obj = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 2\nvn 1 0 1\n\
                    f 1//1 2//2 3//2 4//1\n";
        let parts = parse_obj(obj, |_| None).unwrap();
        let (z, tilted) = (Vec3::Z, Vec3::new(1.0, 0.0, 1.0).normalize());
        assert_eq!(parts[0].normals, [[z, tilted, tilted], [z, tilted, z]]);
        let plain = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        assert!(parse_obj(plain, |_| None).unwrap()[0].normals.is_empty());
        let zero = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nf 1//1 2//1 3//1\n";
        let err = parse_obj(zero, |_| None).unwrap_err();
        assert!(err.contains("normal 0 is zero"), "{err}");
        let mixed = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\nf 1 3 2\n";
        let err = parse_obj(mixed, |_| None).unwrap_err();
        assert!(
            err.contains("line 6: some face corners of its object give normals and others do not"),
            "{err}"
        );
    }

    #[test]
    fn texture_coordinates_follow_each_face_corner_and_the_mtl_names_its_maps() {
        let obj = b"mtllib a.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
                    vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n";
        let mtl = b"newmtl m\nmap_Kd -bm 1 wood.png\nmap_Bump bump.png\nmap_d leaf.png\n".to_vec();
        let parts = parse_obj(obj, |_| Some(mtl.clone())).unwrap();
        let uvs = &parts[0].uvs;
        assert_eq!(uvs.len(), 2);
        let (a, b, c, d) = (Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y);
        assert_eq!(uvs[0], [a, b, c]);
        assert_eq!(uvs[1], [a, c, d]);
        let m = parts[0].material.as_ref().unwrap();
        assert_eq!(m.diffuse_map.as_deref(), Some("wood.png"));
        assert!(m.unread_maps.is_empty());
        assert_eq!(m.opacity_map.as_deref(), Some("leaf.png"));
        assert_eq!(m.normal_map, Some(("bump.png".to_owned(), 1.0)));
        // Faces without texture coordinates give none; a face naming a missing one is refused.
        let plain = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        assert!(parse_obj(plain, |_| None).unwrap()[0].uvs.is_empty());
        let bad = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/7\n";
        assert!(parse_obj(bad, |_| None).is_err());
    }
}

/// A mesh given in memory rather than named by file (a USD mesh prim's): its parts in the
/// space its object's transform places, and how they deform over time when its points are
/// time-sampled.
pub struct Shape {
    pub parts: Vec<MeshPart>,
    pub deformation: Option<std::sync::Arc<crate::geometry::Deformation>>,
}

impl std::fmt::Debug for Shape {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let triangles: usize = self.parts.iter().map(|p| p.triangles.len()).sum();
        write!(
            f,
            "Shape({} parts, {triangles} triangles, deforms: {})",
            self.parts.len(),
            self.deformation.is_some()
        )
    }
}
