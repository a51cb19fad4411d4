//! Writing a pose edited in the page back into the shot file: the camera's key at a frame (or
//! its one static pose) set to a position and a point it looks at, with the rest of the file,
//! comments and layout included, left as it was (toml_edit). The edited text must load as a
//! shot before anything is written; the previous file is kept as `<shot>.bak`.

use rift_render::rift_fx::Shot;
use std::path::Path;
use toml_edit::{DocumentMut, InlineTable, Item, Value, value};

/// The orientation keys a pose may give instead of `look_at`, all replaced by it.
const ORIENTATIONS: [&str; 4] = ["rotation_degrees", "quaternion", "look_at", "matrix"];

/// Sets the camera's pose at `frame` in the shot file `path` to `position` looking at
/// `look_at`, and writes it (after a backup) once the result loads as a shot; returns the
/// reloaded shot, or why not (the file untouched).
pub fn camera(
    path: &Path,
    frame: i64,
    position: [f64; 3],
    look_at: [f64; 3],
) -> Result<Shot, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut doc: DocumentMut = text
        .parse()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let transform = doc
        .get_mut("camera")
        .and_then(|c| c.get_mut("transform"))
        .ok_or_else(|| format!("{}: no [camera.transform] to edit", path.display()))?;
    match transform.get_mut("keys").and_then(Item::as_array_mut) {
        Some(keys) => set_key(keys, frame, position, look_at),
        None => {
            let table = transform
                .as_table_like_mut()
                .ok_or_else(|| format!("{}: camera.transform is not a table", path.display()))?;
            for key in ORIENTATIONS {
                table.remove(key);
            }
            table.insert("position", value(array(position)));
            table.insert("look_at", value(array(look_at)));
        }
    }
    let edited = doc.to_string();
    let shot = Shot::parse(&edited, path).map_err(|e| e.to_string())?;
    let backup = path.with_extension("toml.bak");
    rift_render::rift_fx::export::atomic::write(&backup, |out| out.write_all(text.as_bytes()))
        .map_err(|e| format!("{}: cannot write the backup: {e}", backup.display()))?;
    rift_render::rift_fx::export::atomic::write(path, |out| out.write_all(edited.as_bytes()))
        .map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
    Ok(shot)
}

/// Sets (or adds, in frame order) the key at `frame` of a `keys` array of inline tables.
fn set_key(keys: &mut toml_edit::Array, frame: i64, position: [f64; 3], look_at: [f64; 3]) {
    let frame_of = |v: &Value| {
        v.as_inline_table()
            .and_then(|t| t.get("frame"))
            .and_then(Value::as_integer)
    };
    if let Some(key) = keys
        .iter_mut()
        .find(|v| frame_of(v) == Some(frame))
        .and_then(Value::as_inline_table_mut)
    {
        for k in ORIENTATIONS {
            key.remove(k);
        }
        key.insert("position", array(position));
        key.insert("look_at", array(look_at));
        return;
    }
    let mut key = InlineTable::new();
    key.insert("frame", frame.into());
    key.insert("position", array(position));
    key.insert("look_at", array(look_at));
    let at = keys
        .iter()
        .position(|v| frame_of(v).is_some_and(|f| f > frame))
        .unwrap_or(keys.len());
    // Laid out like its neighbours (one key per line, as shots write them).
    let prefix = keys
        .get(at.min(keys.len().saturating_sub(1)))
        .and_then(|v| v.decor().prefix())
        .and_then(|p| p.as_str())
        .unwrap_or(" ")
        .to_owned();
    let mut key = Value::InlineTable(key);
    key.decor_mut().set_prefix(prefix);
    keys.insert_formatted(at, key);
}

fn array(v: [f64; 3]) -> Value {
    // Rounded to micrometres, as a person would write them.
    let round = |x: f64| (x * 1e6).round() / 1e6;
    Value::Array(v.iter().map(|&x| round(x)).collect())
}
