//! PLY polygon meshes (ASCII and binary, either byte order, read by fx's PLY table reader): the
//! `vertex` element's x, y, z (and texture coordinates `u v`, `s t` or `texture_u texture_v`
//! when it has them; normals `nx ny nz` for smooth shading; velocities `vx vy vz`, units per
//! second, for mesh sequences) and the `face`
//! element's index list, polygons split into triangle fans. Other elements and properties are
//! ignored.

use super::mesh::MeshPart;
use crate::error::RenderError;
use glam::{Vec2, Vec3};
use rift_fx::export::ply_table;
use std::path::Path;

/// Loads a PLY mesh as one part (PLY names no materials).
pub fn load_ply(path: &Path) -> Result<Vec<MeshPart>, RenderError> {
    let bad = |message: String| RenderError::Mesh {
        file: path.to_owned(),
        message,
    };
    let bytes = rift_fx::io::read(path).map_err(|e| bad(format!("cannot read: {e}")))?;
    parse(&bytes).map_err(|m| bad(format!("malformed PLY: {m}")))
}

/// Parses PLY mesh bytes into one part.
pub fn parse(bytes: &[u8]) -> Result<Vec<MeshPart>, String> {
    let table = ply_table::parse(bytes)?;
    let vertices = match table.element("vertex") {
        None => Vec::new(),
        Some(_) => {
            vectors(&table, ["x", "y", "z"], "")?.ok_or("the vertex element lacks x, y or z")?
        }
    };
    let velocities = vectors(&table, ["vx", "vy", "vz"], "'s velocity")?;
    let texcoords = texcoords(&table)?;
    let normals = normals(&table)?;
    let mut triangles = Vec::new();
    let mut uvs = Vec::new();
    let mut corner_normals = Vec::new();
    let mut corner_velocities = Vec::new();
    if let Some(face) = table.element("face") {
        let faces = face
            .list("vertex_indices")
            .or_else(|| face.list("vertex_index"))
            .ok_or("the face element lacks vertex_indices")?;
        for (item, list) in faces.iter().enumerate() {
            let index = |v: f64| -> Result<Vec3, String> {
                if v >= 0.0 && (v as usize) < vertices.len() {
                    Ok(vertices[v as usize])
                } else {
                    Err(format!("face {item} names vertex {v}"))
                }
            };
            for i in 1..list.len().saturating_sub(1) {
                triangles.push([index(list[0])?, index(list[i])?, index(list[i + 1])?]);
                if let Some(t) = &texcoords {
                    let uv = |v: f64| t[v as usize];
                    uvs.push([uv(list[0]), uv(list[i]), uv(list[i + 1])]);
                }
                if let Some(n) = &normals {
                    let at = |v: f64| n[v as usize];
                    corner_normals.push([at(list[0]), at(list[i]), at(list[i + 1])]);
                }
                if let Some(vel) = &velocities {
                    let at = |v: f64| vel[v as usize];
                    corner_velocities.push([at(list[0]), at(list[i]), at(list[i + 1])]);
                }
            }
        }
    }
    if triangles.is_empty() {
        return Err("no faces".into());
    }
    Ok(vec![MeshPart {
        name: "ply".into(),
        triangles,
        uvs,
        velocities: corner_velocities,
        normals: corner_normals,
        material: None,
    }])
}

/// The vertex element's normals `nx ny nz`, each made unit length (`None` without them); a
/// zero normal is an error.
fn normals(table: &ply_table::Table) -> Result<Option<Vec<Vec3>>, String> {
    let Some(normals) = vectors(table, ["nx", "ny", "nz"], "'s normal")? else {
        return Ok(None);
    };
    normals
        .into_iter()
        .enumerate()
        .map(|(i, n)| {
            super::mesh::unit_normal(n).ok_or_else(|| format!("vertex {i}'s normal is zero"))
        })
        .collect::<Result<_, _>>()
        .map(Some)
}

/// The vertex element's vectors from the three properties `names` (`None` when it lacks any
/// of them), each finite and within single precision's reach; `what` follows "vertex N" in
/// errors (empty for positions).
fn vectors(
    table: &ply_table::Table,
    names: [&str; 3],
    what: &str,
) -> Result<Option<Vec<Vec3>>, String> {
    let Some(vertex) = table.element("vertex") else {
        return Ok(None);
    };
    let [Some(x), Some(y), Some(z)] = names.map(|a| vertex.scalar(a)) else {
        return Ok(None);
    };
    let mut out = Vec::with_capacity(vertex.count);
    for (item, ((&x, &y), &z)) in x.iter().zip(y).zip(z).enumerate() {
        let p = Vec3::new(x as f32, y as f32, z as f32);
        if !super::within_single_precision(p) {
            return Err(format!(
                "vertex {item}{what} is not finite or beyond ±{:e}",
                rift_fx::shot::check::MAX_LENGTH
            ));
        }
        out.push(p);
    }
    Ok(Some(out))
}

/// The vertices' texture coordinates, under whichever pair of names the file uses; `None`
/// without.
fn texcoords(table: &ply_table::Table) -> Result<Option<Vec<Vec2>>, String> {
    let Some(vertex) = table.element("vertex") else {
        return Ok(None);
    };
    let pairs = [("u", "v"), ("s", "t"), ("texture_u", "texture_v")];
    let Some((u, v)) = pairs
        .iter()
        .find_map(|(a, b)| Some((vertex.scalar(a)?, vertex.scalar(b)?)))
    else {
        return Ok(None);
    };
    u.iter()
        .zip(v)
        .enumerate()
        .map(|(item, (&u, &v))| {
            let uv = Vec2::new(u as f32, v as f32);
            uv.is_finite()
                .then_some(uv)
                .ok_or_else(|| format!("vertex {item}'s texture coordinates are not finite"))
        })
        .collect::<Result<Vec<_>, _>>()
        .map(Some)
}

#[cfg(test)]
mod tests {
    use super::*;

    const SQUARE: &str = "ply\nformat ascii 1.0\ncomment a unit square\n\
        element vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
        property uchar red\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0 255\n1 0 0 0\n1 1 0 0\n0 1 0 9\n4 0 1 2 3\n";

    #[test]
    fn a_quad_splits_into_a_triangle_fan() {
        let parts = parse(SQUARE.as_bytes()).unwrap();
        assert_eq!(
            parts[0].triangles,
            [
                [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0)],
                [Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Y]
            ]
        );
    }

    #[test]
    fn vertex_normals_reach_each_corner_made_unit_and_a_zero_one_is_refused() {
        let with = |normals: [&str; 4]| {
            let header = SQUARE[..SQUARE.find("end_header\n").unwrap() + 11].replace(
                "property uchar red\n",
                "property float nx\nproperty float ny\nproperty float nz\n",
            );
            let corners = ["0 0 0", "1 0 0", "1 1 0", "0 1 0"];
            let vertices: String = corners
                .iter()
                .zip(normals)
                .map(|(p, n)| format!("{p} {n}\n"))
                .collect();
            header + &vertices + "4 0 1 2 3\n"
        };
        let parts = parse(with(["0 0 3", "1 0 1", "1 0 1", "0 0 1"]).as_bytes()).unwrap();
        let (z, tilted) = (Vec3::Z, Vec3::new(1.0, 0.0, 1.0).normalize());
        assert_eq!(parts[0].normals, [[z, tilted, tilted], [z, tilted, z]]);
        assert!(parse(SQUARE.as_bytes()).unwrap()[0].normals.is_empty());
        let err = parse(with(["0 0 1", "0 0 0", "0 0 1", "0 0 1"]).as_bytes()).unwrap_err();
        assert!(err.contains("vertex 1's normal is zero"), "{err}");
    }

    #[test]
    fn texture_coordinates_come_from_u_v_or_s_t() {
        let with = |u: &str, v: &str| {
            SQUARE
                .replace(
                    "property uchar red\n",
                    &format!("property float {u}\nproperty float {v}\n"),
                )
                .replace("0 0 0 255\n", "0 0 0 0 0\n")
                .replace("1 0 0 0\n", "1 0 0 1 0\n")
                .replace("1 1 0 0\n", "1 1 0 1 1\n")
                .replace("0 1 0 9\n", "0 1 0 0 1\n")
        };
        for (u, v) in [("u", "v"), ("s", "t"), ("texture_u", "texture_v")] {
            let parts = parse(with(u, v).as_bytes()).unwrap();
            assert_eq!(parts[0].uvs[0], [Vec2::ZERO, Vec2::X, Vec2::ONE], "{u} {v}");
            assert_eq!(parts[0].uvs[1], [Vec2::ZERO, Vec2::ONE, Vec2::Y], "{u} {v}");
        }
        assert!(parse(SQUARE.as_bytes()).unwrap()[0].uvs.is_empty());
        let nan = with("u", "v").replace("1 1 0 1 1\n", "1 1 0 nan 1\n");
        assert!(
            parse(nan.as_bytes())
                .unwrap_err()
                .contains("vertex 2's texture coordinates")
        );
    }

    #[test]
    fn rejects_meshes_it_cannot_use() {
        for (text, expect) in [
            (
                "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n\
                 property float z\nend_header\n",
                "no faces",
            ),
            (&SQUARE.replace("4 0 1 2 3", "3 0 1 7"), "names vertex 7"),
            (
                &SQUARE.replace("property float z\n", "property float w\n"),
                "lacks x, y or z",
            ),
            (
                &SQUARE.replace("vertex_indices", "corners"),
                "lacks vertex_indices",
            ),
            (
                &SQUARE.replace("0 1 0 9", "0 inf 0 9"),
                "vertex 3 is not finite",
            ),
            (&SQUARE.replace("1 1 0 0\n", ""), "ends early"),
        ] {
            let err = parse(text.as_bytes()).unwrap_err();
            assert!(err.contains(expect), "{err:?} lacks {expect:?}");
        }
    }
}
