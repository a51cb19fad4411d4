//! PLY polygon meshes (ASCII and binary, either byte order, read by fx's PLY table reader): the
//! `vertex` element's x, y, z and the `face` element's index list, polygons split into triangle
//! fans. Other elements and properties are ignored.

use super::mesh::MeshPart;
use crate::error::RenderError;
use glam::Vec3;
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
    let vertices: Vec<Vec3> = match table.element("vertex") {
        None => Vec::new(),
        Some(vertex) => {
            let [Some(x), Some(y), Some(z)] = ["x", "y", "z"].map(|a| vertex.scalar(a)) else {
                return Err("the vertex element lacks x, y or z".into());
            };
            let mut points = Vec::with_capacity(vertex.count);
            for (item, ((&x, &y), &z)) in x.iter().zip(y).zip(z).enumerate() {
                let p = Vec3::new(x as f32, y as f32, z as f32);
                if !super::within_single_precision(p) {
                    return Err(format!(
                        "vertex {item} is not finite or beyond ±{:e} m",
                        rift_fx::shot::check::MAX_LENGTH
                    ));
                }
                points.push(p);
            }
            points
        }
    };
    let mut triangles = Vec::new();
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
            }
        }
    }
    if triangles.is_empty() {
        return Err("no faces".into());
    }
    Ok(vec![MeshPart {
        name: "ply".into(),
        triangles,
        material: None,
    }])
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
