//! Attribute values of any precision the stage may author them in, as rift's types.

use glam::{Vec2, Vec3};
use openusd::sdf::Value;
use openusd::usd::{Prim, TimeCode};

/// An attribute's value at `code`, of whatever type it is authored with; `None` when it is not
/// authored.
pub fn value(prim: &Prim, name: &str, code: f64) -> anyhow::Result<Option<Value>> {
    prim.attribute(name).get_at::<Value>(TimeCode::new(code))
}

/// An attribute's value at `code` as [`value`] reads it, except where it is sampled in whole
/// numbers on either side of `code`: the USD crate reads a usda sample written `90` (as usd-core
/// writes a float 90.0) as an integer and holds it until the next sample, where USD
/// interpolates; that value is interpolated here.
pub fn scalar_at(prim: &Prim, name: &str, code: f64) -> anyhow::Result<Option<Value>> {
    if let Some([(t0, a), (t1, b)]) = whole_numbers_around(prim, name, code)? {
        return Ok(Some(Value::Double(a + (b - a) * (code - t0) / (t1 - t0))));
    }
    value(prim, name, code)
}

/// The samples (time and number) of the attribute `name` on each side of `code`, where `code`
/// lies strictly between two of them and either is read as an integer.
fn whole_numbers_around(
    prim: &Prim,
    name: &str,
    code: f64,
) -> anyhow::Result<Option<[(f64, f64); 2]>> {
    let attribute = prim.attribute(name);
    let times = attribute.time_sample_times()?;
    let after = times.partition_point(|&t| t <= code);
    let (Some(&lo), Some(&hi)) = (
        after.checked_sub(1).and_then(|i| times.get(i)),
        times.get(after),
    ) else {
        return Ok(None);
    };
    if lo == code {
        return Ok(None);
    }
    let (a, b) = (value(prim, name, lo)?, value(prim, name, hi)?);
    let whole = |v: &Option<Value>| matches!(v, Some(Value::Int(_) | Value::Int64(_)));
    if !whole(&a) && !whole(&b) {
        return Ok(None);
    }
    let (Some(a), Some(b)) = (a.as_ref().and_then(number), b.as_ref().and_then(number)) else {
        return Ok(None);
    };
    Ok(Some([(lo, a), (hi, b)]))
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
