//! Where a key is written: the line of a dotted key path (`portal[0].ring.radius`) in a TOML
//! text, so errors found after parsing (validation, the renderer's sections) can point at it
//! as parse errors do.

use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// The 1-based line of the value at `key` in `text`; where the path stops existing (a missing
/// key), the line of the deepest part that does. `None` when the text does not parse or no
/// part of the path is found.
pub fn line_of_key(text: &str, key: &str) -> Option<usize> {
    let root = DeTable::parse(text).ok()?;
    let mut table = root.get_ref();
    let mut found: Option<std::ops::Range<usize>> = None;
    for segment in key.split('.') {
        let (name, indices) = split_indices(segment)?;
        let Some(mut value) = lookup(table, name) else {
            break;
        };
        found = Some(value.span());
        for index in indices {
            let DeValue::Array(items) = value.get_ref() else {
                return found.map(|span| line_at(text, span.start));
            };
            let Some(item) = items.get(index) else {
                return found.map(|span| line_at(text, span.start));
            };
            value = item;
            found = Some(value.span());
        }
        match value.get_ref() {
            DeValue::Table(inner) => table = inner,
            _ => break,
        }
    }
    found.map(|span| line_at(text, span.start))
}

/// `name[1][2]` as (`name`, [1, 2]); `None` when the brackets are not indices.
fn split_indices(segment: &str) -> Option<(&str, Vec<usize>)> {
    let (name, mut rest) = match segment.find('[') {
        Some(at) => segment.split_at(at),
        None => return Some((segment, Vec::new())),
    };
    let mut indices = Vec::new();
    while let Some(inner) = rest.strip_prefix('[') {
        let close = inner.find(']')?;
        indices.push(inner[..close].parse().ok()?);
        rest = &inner[close + 1..];
    }
    rest.is_empty().then_some((name, indices))
}

fn lookup<'a, 'i>(table: &'a DeTable<'i>, name: &str) -> Option<&'a Spanned<DeValue<'i>>> {
    table
        .iter()
        .find(|(k, _)| k.get_ref().as_ref() == name)
        .map(|(_, v)| v)
}

/// 1-based line of a byte offset.
pub fn line_at(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "[shot]\nname = \"x\"\nfps = 24.0\n\n[[portal]]\nname = \"a\"\n[portal.ring]\nradius = -1\n\n[[portal]]\nname = \"b\"\nhere = { keys = [\n  { frame = 1, scale = 1.0 },\n  { frame = 2, scale = 0.0 },\n] }\n";

    #[test]
    fn key_paths_find_their_lines() {
        assert_eq!(line_of_key(TEXT, "shot.fps"), Some(3));
        assert_eq!(line_of_key(TEXT, "portal[0].ring.radius"), Some(8));
        assert_eq!(line_of_key(TEXT, "portal[1].name"), Some(11));
        assert_eq!(line_of_key(TEXT, "portal[1].here.keys[1].scale"), Some(14));
        // A missing key points at the deepest table that exists.
        assert_eq!(
            line_of_key(TEXT, "portal[1].here.keys[1].rotation"),
            Some(14)
        );
        assert_eq!(line_of_key(TEXT, "camera.fov"), None);
        assert_eq!(line_of_key("not = = toml", "not"), None);
        assert_eq!(split_indices("a[2][3]"), Some(("a", vec![2, 3])));
        assert_eq!(split_indices("a[x]"), None);
    }
}
