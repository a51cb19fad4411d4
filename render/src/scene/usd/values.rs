//! Attribute values of any precision the stage may author them in, as rift's types.

use glam::{Vec2, Vec3};
use openusd::sdf::Value;
use openusd::usd::{Prim, TimeCode};

/// An attribute's value at `code`, of whatever type it is authored with; `None` when it is not
/// authored.
pub fn value(prim: &Prim, name: &str, code: f64) -> anyhow::Result<Option<Value>> {
    prim.attribute(name).get_at::<Value>(TimeCode::new(code))
}

/// An integer array attribute at `code`.
pub fn int_array(prim: &Prim, name: &str, code: f64) -> anyhow::Result<Option<Vec<u32>>> {
    let Some(value) = value(prim, name, code)? else {
        return Ok(None);
    };
    let ints: Vec<i64> = match value {
        Value::IntVec(v) => v.into_iter().map(i64::from).collect(),
        Value::UintVec(v) => v.into_iter().map(i64::from).collect(),
        Value::Int64Vec(v) => v,
        other => anyhow::bail!("{name}: expected an integer array, found {}", kind(&other)),
    };
    ints.into_iter()
        .map(|i| u32::try_from(i).map_err(|_| anyhow::anyhow!("{name}: {i} is not an index")))
        .collect::<anyhow::Result<Vec<u32>>>()
        .map(Some)
}

/// A token (or string) attribute at `code`.
pub fn token(prim: &Prim, name: &str, code: f64) -> anyhow::Result<Option<String>> {
    Ok(match value(prim, name, code)? {
        Some(Value::Token(t)) => Some(t.as_str().to_owned()),
        Some(Value::String(s)) => Some(s),
        _ => None,
    })
}

/// A short name of a value's type, for messages.
pub fn kind(v: &Value) -> String {
    let debug = format!("{v:?}");
    debug.split('(').next().unwrap_or("?").to_owned()
}

/// A number of any precision.
pub fn number(v: &Value) -> Option<f64> {
    match *v {
        Value::Float(f) => Some(f as f64),
        Value::Double(d) => Some(d),
        Value::Half(h) => Some(h.to_f32() as f64),
        Value::Int(i) => Some(i as f64),
        // Whole numbers in a usda time sample of a float attribute come as 64-bit integers.
        Value::Int64(i) => Some(i as f64),
        Value::Uint(i) => Some(i as f64),
        Value::Uint64(i) => Some(i as f64),
        _ => None,
    }
}

/// A colour (a 3-vector) of any precision.
pub fn color(v: &Value) -> Option<[f32; 3]> {
    match v {
        Value::Vec3f(c) => Some([c.x, c.y, c.z]),
        Value::Vec3d(c) => Some([c.x as f32, c.y as f32, c.z as f32]),
        Value::Vec3h(c) => Some([c.x.to_f32(), c.y.to_f32(), c.z.to_f32()]),
        _ => None,
    }
}

/// A 3-vector array of any precision.
pub fn vec3_array(v: &Value) -> Option<Vec<Vec3>> {
    Some(match v {
        Value::Vec3fVec(a) => a.iter().map(|p| Vec3::new(p.x, p.y, p.z)).collect(),
        Value::Vec3dVec(a) => a
            .iter()
            .map(|p| Vec3::new(p.x as f32, p.y as f32, p.z as f32))
            .collect(),
        Value::Vec3hVec(a) => a
            .iter()
            .map(|p| Vec3::new(p.x.to_f32(), p.y.to_f32(), p.z.to_f32()))
            .collect(),
        _ => return None,
    })
}

/// A 2-vector array of any precision.
pub fn vec2_array(v: &Value) -> Option<Vec<Vec2>> {
    Some(match v {
        Value::Vec2fVec(a) => a.iter().map(|p| Vec2::new(p.x, p.y)).collect(),
        Value::Vec2dVec(a) => a
            .iter()
            .map(|p| Vec2::new(p.x as f32, p.y as f32))
            .collect(),
        Value::Vec2hVec(a) => a
            .iter()
            .map(|p| Vec2::new(p.x.to_f32(), p.y.to_f32()))
            .collect(),
        _ => return None,
    })
}
