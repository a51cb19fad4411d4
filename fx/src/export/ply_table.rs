//! Reading PLY files of any kind (ASCII and binary, either byte order) into named columns: what
//! the renderer's mesh loader and the ring point-cloud reader share. Every value is widened to
//! f64; a list property keeps one list per item.

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

/// A property as the header declares it: a scalar, or a list with its count type.
struct Property {
    name: String,
    count: Option<Scalar>,
    value: Scalar,
}

/// One property's values over an element's items.
#[derive(Clone, Debug, PartialEq)]
pub enum Column {
    Scalar(Vec<f64>),
    List(Vec<Vec<f64>>),
}

/// One element (`vertex`, `face`, …) with its items' values, column by column.
#[derive(Clone, Debug, PartialEq)]
pub struct Element {
    pub name: String,
    pub count: usize,
    /// Property names with their values, in header order.
    pub columns: Vec<(String, Column)>,
}

impl Element {
    /// The values of scalar property `name`.
    pub fn scalar(&self, name: &str) -> Option<&[f64]> {
        self.columns.iter().find_map(|(n, c)| match c {
            Column::Scalar(v) if n == name => Some(v.as_slice()),
            _ => None,
        })
    }

    /// The lists of list property `name`.
    pub fn list(&self, name: &str) -> Option<&[Vec<f64>]> {
        self.columns.iter().find_map(|(n, c)| match c {
            Column::List(v) if n == name => Some(v.as_slice()),
            _ => None,
        })
    }
}

/// A whole PLY file.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    /// The header's `comment` lines, without the keyword.
    pub comments: Vec<String>,
    pub elements: Vec<Element>,
}

impl Table {
    /// The element called `name`.
    pub fn element(&self, name: &str) -> Option<&Element> {
        self.elements.iter().find(|e| e.name == name)
    }
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
    /// The fewest bytes one value of `property` can take: its binary size (a list's count
    /// alone, for an empty list), or a digit and a separator in ASCII.
    fn least_bytes(&self, property: &Property) -> usize {
        match self.format {
            Format::Ascii => 2,
            _ => property.count.unwrap_or(property.value).size(),
        }
    }

    /// Bytes left to read (in ASCII, at most this many).
    fn remaining(&self) -> usize {
        self.bytes.len().saturating_sub(self.at)
    }

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

/// Longest list a property may declare (guards against a corrupt count allocating wildly).
const MAX_LIST: f64 = 1e6;

/// Parses a PLY file; the message of an error says where it went wrong.
pub fn parse(bytes: &[u8]) -> Result<Table, String> {
    let (header, body_start) = split_header(bytes)?;
    let Header {
        format,
        comments,
        declared,
    } = parse_header(header)?;
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
    let elements = declared
        .into_iter()
        .map(|(name, count, properties)| read_element(&mut body, name, count, properties))
        .collect::<Result<_, _>>()?;
    Ok(Table { comments, elements })
}

/// The header's text (up to `end_header`) and where the body starts.
fn split_header(bytes: &[u8]) -> Result<(&str, usize), String> {
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
    let header = std::str::from_utf8(&bytes[..end]).map_err(|_| "the header is not text")?;
    Ok((header, body_start + 1))
}

/// What a PLY header declares.
struct Header {
    format: Format,
    comments: Vec<String>,
    /// Each element's name, item count and properties, in file order.
    declared: Vec<(String, usize, Vec<Property>)>,
}

/// The header's lines (after the magic `ply`), each checked.
fn parse_header(header: &str) -> Result<Header, String> {
    let mut lines = header.lines().map(str::trim);
    if lines.next() != Some("ply") {
        return Err("the file does not start with `ply`".into());
    }
    let mut format = None;
    let mut comments = Vec::new();
    let mut declared: Vec<(String, usize, Vec<Property>)> = Vec::new();
    for (number, line) in lines.enumerate() {
        let words: Vec<&str> = line.split_whitespace().collect();
        let at = |what: &str| format!("header line {}: {what}", number + 2);
        match words.as_slice() {
            ["comment", ..] => {
                comments.push(line.strip_prefix("comment").unwrap_or("").trim().to_owned())
            }
            [] | ["obj_info", ..] => {}
            ["format", f, _version] => {
                format = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Little,
                    "binary_big_endian" => Format::Big,
                    _ => return Err(at(&format!("unknown format {f:?}"))),
                });
            }
            ["element", name, count] => declared.push((
                (*name).to_owned(),
                count
                    .parse()
                    .map_err(|_| at(&format!("bad element count {count:?}")))?,
                Vec::new(),
            )),
            ["property", rest @ ..] => declared
                .last_mut()
                .ok_or_else(|| at("property before any element"))?
                .2
                .push(property(rest, line, &at)?),
            _ => return Err(at(&format!("cannot read {line:?}"))),
        }
    }
    Ok(Header {
        format: format.ok_or("no format line")?,
        comments,
        declared,
    })
}

/// A `property` line's words after `property` (`at` names the line in errors).
fn property(rest: &[&str], line: &str, at: &dyn Fn(&str) -> String) -> Result<Property, String> {
    let scalar = |t: &str| Scalar::parse(t).ok_or_else(|| at(&format!("unknown type {t:?}")));
    match rest {
        ["list", count, value, name] => Ok(Property {
            name: (*name).to_owned(),
            count: Some(scalar(count)?),
            value: scalar(value)?,
        }),
        [value, name] => Ok(Property {
            name: (*name).to_owned(),
            count: None,
            value: scalar(value)?,
        }),
        _ => Err(at(&format!("cannot read {line:?}"))),
    }
}

/// The `count` items of element `name` from `body`, property after property.
fn read_element(
    body: &mut Body,
    name: String,
    count: usize,
    properties: Vec<Property>,
) -> Result<Element, String> {
    // Items are stored property after property, so the columns fill row by row.
    let reserve = count.min(1 << 20);
    let mut columns: Vec<Column> = properties
        .iter()
        .map(|p| match p.count {
            None => Column::Scalar(Vec::with_capacity(reserve)),
            Some(_) => Column::List(Vec::with_capacity(reserve)),
        })
        .collect();
    // Trust no count before the bytes for it are there; an element without properties
    // holds no bytes at all, however many items it declares.
    let least: usize = properties.iter().map(|p| body.least_bytes(p)).sum();
    if count.saturating_mul(least).saturating_sub(1) > body.remaining() {
        return Err(format!(
            "the header declares {count} {name} items, which need at least {} bytes, but \
             only {} follow",
            count.saturating_mul(least),
            body.remaining()
        ));
    }
    let items = if properties.is_empty() { 0 } else { count };
    for item in 0..items {
        for (property, column) in properties.iter().zip(&mut columns) {
            match (property.count, column) {
                (None, Column::Scalar(values)) => values.push(body.read(property.value)?),
                (Some(count_type), Column::List(lists)) => {
                    let n = body.read(count_type)?;
                    if !(0.0..=MAX_LIST).contains(&n) {
                        return Err(format!("{name} {item}: list length {n}"));
                    }
                    let list = (0..n as usize)
                        .map(|_| body.read(property.value))
                        .collect::<Result<_, _>>()?;
                    lists.push(list);
                }
                _ => unreachable!("columns are made to match their properties"),
            }
        }
    }
    Ok(Element {
        name,
        count,
        columns: properties
            .into_iter()
            .map(|p| p.name)
            .zip(columns)
            .collect(),
    })
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
            "ply\nformat {} 1.0\ncomment a unit square\nelement vertex 4\nproperty double x\n\
             property float y\nproperty int z\nproperty uchar red\nelement face 1\n\
             property list uchar uint vertex_indices\nend_header\n",
            if big {
                "binary_big_endian"
            } else {
                "binary_little_endian"
            }
        )
        .into_bytes();
        let order = |mut b: Vec<u8>| {
            if big {
                b.reverse();
            }
            b
        };
        for (p, red) in [
            ([0.0, 0.0, 0.0], 255u8),
            ([1.0, 0.0, 0.0], 0),
            ([1.0, 1.0, 0.0], 0),
            ([0.0, 1.0, 0.0], 9),
        ] {
            out.extend(order(f64::to_le_bytes(p[0]).to_vec()));
            out.extend(order((p[1] as f32).to_le_bytes().to_vec()));
            out.extend(order((p[2] as i32).to_le_bytes().to_vec()));
            out.push(red);
        }
        out.push(4);
        for i in [0u32, 1, 2, 3] {
            out.extend(order(i.to_le_bytes().to_vec()));
        }
        out
    }

    #[test]
    fn reads_ascii_and_binary_of_either_order_alike() {
        let a = parse(SQUARE_ASCII.as_bytes()).unwrap();
        let (b, c) = (
            parse(&binary(false)).unwrap(),
            parse(&binary(true)).unwrap(),
        );
        assert_eq!(a.comments, ["a unit square"]);
        let vertex = a.element("vertex").unwrap();
        assert_eq!(vertex.count, 4);
        assert_eq!(vertex.scalar("x").unwrap(), [0.0, 1.0, 1.0, 0.0]);
        assert_eq!(vertex.scalar("red").unwrap(), [255.0, 0.0, 0.0, 9.0]);
        assert_eq!(
            a.element("face").unwrap().list("vertex_indices").unwrap(),
            [vec![0.0, 1.0, 2.0, 3.0]]
        );
        assert_eq!(vertex.scalar("nothing"), None);
        assert_eq!(vertex.list("x"), None, "x is a scalar, not a list");
        for other in [&b, &c] {
            assert_eq!(other.comments, a.comments);
            for name in ["vertex", "face"] {
                assert_eq!(other.element(name), a.element(name), "{name}");
            }
        }
    }

    #[test]
    fn rejects_malformed_files() {
        for (text, expect) in [
            ("plx\n", "end_header"),
            ("plx\nend_header\n", "does not start with `ply`"),
            ("ply\nend_header\n", "no format line"),
            (&SQUARE_ASCII.replace("4 0 1 2 3", "4 0 1 2"), "ends early"),
            (&SQUARE_ASCII.replace("1 1 0 0\n", ""), "ends early"),
            (
                &SQUARE_ASCII.replace("0 1 0 9", "0 one 0 9"),
                "is not a number",
            ),
            (
                &SQUARE_ASCII.replace("format ascii", "format weird"),
                "unknown format",
            ),
            (
                &SQUARE_ASCII.replace("property uchar red", "property colour red"),
                "header line 8: unknown type \"colour\"",
            ),
            (
                &SQUARE_ASCII.replace("element vertex 4", "element vertex four"),
                "bad element count",
            ),
            (
                &SQUARE_ASCII.replace("4 0 1 2 3", "-4 0 1 2 3"),
                "face 0: list length -4",
            ),
        ] {
            let err = parse(text.as_bytes()).unwrap_err();
            assert!(err.contains(expect), "{err:?} lacks {expect:?}");
        }
        let mut cut = binary(false);
        cut.truncate(cut.len() - 3);
        assert!(parse(&cut).unwrap_err().contains("ends early"));
    }

    #[test]
    fn counts_in_the_header_are_not_trusted_before_their_bytes() {
        let huge = 1u64 << 40;
        for format in ["ascii", "binary_little_endian"] {
            let text = format!(
                "ply\nformat {format} 1.0\nelement vertex {huge}\nproperty float x\nend_header\n1 2 3\n"
            );
            let err = parse(text.as_bytes()).unwrap_err();
            assert!(err.contains("declares 1099511627776 vertex items"), "{err}");
        }
        // No properties: no bytes, whatever the count (it used to loop over every item).
        let text = format!("ply\nformat ascii 1.0\nelement vertex {huge}\nend_header\n");
        let table = parse(text.as_bytes()).unwrap();
        assert_eq!(table.element("vertex").unwrap().count, huge as usize);
        // One small ASCII item without a final newline still reads.
        let text = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2";
        assert_eq!(
            parse(text.as_bytes())
                .unwrap()
                .element("vertex")
                .unwrap()
                .count,
            1
        );
    }
}
