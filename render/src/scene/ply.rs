//! PLY polygon meshes (ASCII and binary, either byte order): the `vertex` element's x, y, z and
//! the `face` element's index list, polygons split into triangle fans. Other elements and
//! properties are read past and ignored.

use super::mesh::MeshPart;
use crate::error::RenderError;
use glam::Vec3;
use std::path::Path;

/// How the body is encoded.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Format {
    Ascii,
    Little,
    Big,
}

/// A scalar property type.
#[derive(Clone, Copy)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

/// A property: a scalar, or a list with its count type.
#[derive(Clone)]
struct Property {
    name: String,
    count: Option<Scalar>,
    value: Scalar,
}

struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
}

/// Reads values one at a time from the body.
struct Body<'a> {
    bytes: &'a [u8],
    at: usize,
    format: Format,
    /// ASCII tokens.
    tokens: std::str::SplitAsciiWhitespace<'a>,
}

impl Body<'_> {
    fn read(&mut self, t: Scalar) -> Result<f64, String> {
        if self.format == Format::Ascii {
            let token = self.tokens.next().ok_or("the file ends early")?;
            return token
                .parse::<f64>()
                .map_err(|_| format!("{token:?} is not a number"));
        }
        let n = t.size();
        let raw = self
            .bytes
            .get(self.at..self.at + n)
            .ok_or("the file ends early")?;
        self.at += n;
        let mut b = [0u8; 8];
        b[..n].copy_from_slice(raw);
        if self.format == Format::Big {
            b[..n].reverse();
        }
        Ok(match t {
            Scalar::I8 => b[0] as i8 as f64,
            Scalar::U8 => b[0] as f64,
            Scalar::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::F64 => f64::from_le_bytes(b),
        })
    }
}

/// Loads a PLY mesh as one part (PLY names no materials).
pub fn load_ply(path: &Path) -> Result<Vec<MeshPart>, RenderError> {
    let bad = |message: String| RenderError::Mesh {
        file: path.to_owned(),
        message,
    };
    if !path.is_file() {
        return Err(bad("no such mesh file".into()));
    }
    let bytes = std::fs::read(path).map_err(|e| bad(e.to_string()))?;
    parse(&bytes).map_err(|m| bad(format!("malformed PLY: {m}")))
}

fn parse(bytes: &[u8]) -> Result<Vec<MeshPart>, String> {
    const END: &[u8] = b"end_header";
    let end = bytes
        .windows(END.len())
        .position(|w| w == END)
        .ok_or("no end_header")?;
    let mut body_start = end + END.len();
    // The header line ends with \n (or \r\n).
    while body_start < bytes.len() && bytes[body_start] != b'\n' {
        body_start += 1;
    }
    body_start += 1;
    let header = std::str::from_utf8(&bytes[..end]).map_err(|_| "the header is not text")?;
    let mut lines = header.lines().map(str::trim);
    if lines.next() != Some("ply") {
        return Err("the file does not start with `ply`".into());
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    for (number, line) in lines.enumerate() {
        let words: Vec<&str> = line.split_whitespace().collect();
        let at = |what: &str| format!("header line {}: {what}", number + 2);
        match words.as_slice() {
            [] | ["comment", ..] | ["obj_info", ..] => {}
            ["format", f, _version] => {
                format = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Little,
                    "binary_big_endian" => Format::Big,
                    _ => return Err(at(&format!("unknown format {f:?}"))),
                });
            }
            ["element", name, count] => elements.push(Element {
                name: (*name).to_owned(),
                count: count
                    .parse()
                    .map_err(|_| at(&format!("bad element count {count:?}")))?,
                properties: Vec::new(),
            }),
            ["property", rest @ ..] => {
                let scalar =
                    |t: &str| Scalar::parse(t).ok_or_else(|| at(&format!("unknown type {t:?}")));
                let property = match rest {
                    ["list", count, value, name] => Property {
                        name: (*name).to_owned(),
                        count: Some(scalar(count)?),
                        value: scalar(value)?,
                    },
                    [value, name] => Property {
                        name: (*name).to_owned(),
                        count: None,
                        value: scalar(value)?,
                    },
                    _ => return Err(at(&format!("cannot read {line:?}"))),
                };
                elements
                    .last_mut()
                    .ok_or_else(|| at("property before any element"))?
                    .properties
                    .push(property);
            }
            _ => return Err(at(&format!("cannot read {line:?}"))),
        }
    }
    let format = format.ok_or("no format line")?;
    let rest = &bytes[body_start.min(bytes.len())..];
    let text = if format == Format::Ascii {
        std::str::from_utf8(rest).map_err(|_| "the ASCII body is not text")?
    } else {
        ""
    };
    let mut body = Body {
        bytes: rest,
        at: 0,
        format,
        tokens: text.split_ascii_whitespace(),
    };

    let mut vertices: Vec<Vec3> = Vec::new();
    let mut triangles = Vec::new();
    for element in &elements {
        let position = |axis: &str| element.properties.iter().position(|p| p.name == axis);
        let xyz = [position("x"), position("y"), position("z")];
        let faces = element.name == "face";
        let indices = element
            .properties
            .iter()
            .position(|p| p.name == "vertex_indices" || p.name == "vertex_index");
        if element.name == "vertex" && xyz.iter().any(Option::is_none) {
            return Err("the vertex element lacks x, y or z".into());
        }
        if faces && indices.is_none() {
            return Err("the face element lacks vertex_indices".into());
        }
        for item in 0..element.count {
            let mut point = [0.0f32; 3];
            for (k, property) in element.properties.iter().enumerate() {
                match property.count {
                    None => {
                        let v = body.read(property.value)?;
                        if let Some(axis) = xyz.iter().position(|&i| i == Some(k)) {
                            point[axis] = v as f32;
                        }
                    }
                    Some(count_type) => {
                        let n = body.read(count_type)?;
                        if !(0.0..=1e6).contains(&n) {
                            return Err(format!("{} {item}: list length {n}", element.name));
                        }
                        let list: Vec<f64> = (0..n as usize)
                            .map(|_| body.read(property.value))
                            .collect::<Result<_, _>>()?;
                        if faces && Some(k) == indices {
                            let index = |v: f64| -> Result<usize, String> {
                                if v >= 0.0 && (v as usize) < vertices.len() {
                                    Ok(v as usize)
                                } else {
                                    Err(format!("face {item} names vertex {v}"))
                                }
                            };
                            for i in 1..list.len().saturating_sub(1) {
                                triangles.push([
                                    vertices[index(list[0])?],
                                    vertices[index(list[i])?],
                                    vertices[index(list[i + 1])?],
                                ]);
                            }
                        }
                    }
                }
            }
            if element.name == "vertex" {
                if !point.iter().all(|v| v.is_finite()) {
                    return Err(format!("vertex {item} is not finite"));
                }
                vertices.push(Vec3::from(point));
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

    const SQUARE_ASCII: &str = "ply\nformat ascii 1.0\ncomment a unit square\n\
        element vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
        property uchar red\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0 255\n1 0 0 0\n1 1 0 0\n0 1 0 9\n4 0 1 2 3\n";

    fn binary(big: bool) -> Vec<u8> {
        let mut out = format!(
            "ply\nformat {} 1.0\nelement vertex 4\nproperty double x\nproperty double y\n\
             property double z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n",
            if big { "binary_big_endian" } else { "binary_little_endian" }
        )
        .into_bytes();
        let f = |v: f64| {
            if big {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            }
        };
        for p in [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ] {
            for c in p {
                out.extend(f(c));
            }
        }
        out.push(4);
        for i in [0u32, 1, 2, 3] {
            out.extend(if big {
                i.to_be_bytes()
            } else {
                i.to_le_bytes()
            });
        }
        out
    }

    #[test]
    fn reads_ascii_and_binary_alike() {
        let a = parse(SQUARE_ASCII.as_bytes()).unwrap();
        let b = parse(&binary(false)).unwrap();
        let c = parse(&binary(true)).unwrap();
        assert_eq!(a[0].triangles.len(), 2, "a quad splits into two triangles");
        assert_eq!(a[0].triangles, b[0].triangles);
        assert_eq!(b[0].triangles, c[0].triangles);
        assert_eq!(
            a[0].triangles[1],
            [Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Y]
        );
    }

    #[test]
    fn rejects_malformed_files() {
        for (text, expect) in [
            ("plx\n", "end_header"),
            ("ply\nformat ascii 1.0\nend_header\n", "no faces"),
            (
                &SQUARE_ASCII.replace("4 0 1 2 3", "3 0 1 7"),
                "names vertex 7",
            ),
            (&SQUARE_ASCII.replace("1 1 0 0\n", ""), "ends early"),
            (
                &SQUARE_ASCII.replace("format ascii", "format weird"),
                "unknown format",
            ),
        ] {
            let err = parse(text.as_bytes()).unwrap_err();
            assert!(err.contains(expect), "{err:?} lacks {expect:?}");
        }
        let mut cut = binary(false);
        cut.truncate(cut.len() - 3);
        assert!(parse(&cut).unwrap_err().contains("ends early"));
    }
}
