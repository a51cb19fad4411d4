//! Small validators for shot values: each names the key it checks and says what it expected.

use crate::error::Invalid;
use glam::DVec3;

/// A finite number.
pub fn finite(key: &str, v: f64) -> Result<f64, Invalid> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Invalid::new(
            key,
            format!("expected a finite number, got {v}"),
        ))
    }
}

/// A finite number > 0.
pub fn positive(key: &str, v: f64) -> Result<f64, Invalid> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(Invalid::new(
            key,
            format!("expected a positive number, got {v}"),
        ))
    }
}

/// The largest length or coordinate, in metres, a shot may give. Rendering works in single
/// precision, whose range ends near 3.4e38: beyond about 1e19 the square of a length (every
/// distance and intersection test takes one) is infinite, and 1e40 is infinite as it is read.
/// 1e12 m (seven times the distance to the sun) leaves that headroom with room to spare.
pub const MAX_LENGTH: f64 = 1e12;

/// A length or coordinate: a finite number no larger than [`MAX_LENGTH`] either way.
pub fn length(key: &str, v: f64) -> Result<f64, Invalid> {
    if v.is_finite() && v.abs() <= MAX_LENGTH {
        Ok(v)
    } else {
        Err(Invalid::new(key, too_long(v)))
    }
}

/// A length > 0 and no larger than [`MAX_LENGTH`].
pub fn positive_length(key: &str, v: f64) -> Result<f64, Invalid> {
    positive(key, v).and_then(|v| length(key, v))
}

/// A length ≥ 0 and no larger than [`MAX_LENGTH`].
pub fn non_negative_length(key: &str, v: f64) -> Result<f64, Invalid> {
    non_negative(key, v).and_then(|v| length(key, v))
}

/// Three coordinates, each within [`MAX_LENGTH`].
pub fn point(key: &str, v: [f64; 3]) -> Result<DVec3, Invalid> {
    let p = DVec3::from_array(v);
    if p.is_finite() && p.abs().max_element() <= MAX_LENGTH {
        Ok(p)
    } else {
        Err(Invalid::new(
            key,
            format!(
                "expected three finite coordinates within ±{MAX_LENGTH:e} m, got {:?}",
                v
            ),
        ))
    }
}

fn too_long(v: f64) -> String {
    format!(
        "expected a finite length within ±{MAX_LENGTH:e} m (single-precision rendering cannot          hold more), got {v}"
    )
}

/// A finite number ≥ 0.
pub fn non_negative(key: &str, v: f64) -> Result<f64, Invalid> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(Invalid::new(key, format!("expected a number ≥ 0, got {v}")))
    }
}

/// A number in [lo, hi] (or [lo, hi) when `hi_open`).
pub fn within(key: &str, v: f64, lo: f64, hi: f64, hi_open: bool) -> Result<f64, Invalid> {
    let ok = v.is_finite() && v >= lo && if hi_open { v < hi } else { v <= hi };
    if ok {
        Ok(v)
    } else {
        let close = if hi_open { ')' } else { ']' };
        Err(Invalid::new(
            key,
            format!("expected a number in [{lo}, {hi}{close}, got {v}"),
        ))
    }
}

/// An integer in [lo, hi]; `what` describes it when out of range (e.g. "a positive integer").
pub fn integer(key: &str, v: i64, lo: i64, hi: i64, what: &str) -> Result<u32, Invalid> {
    if v >= lo && v <= hi {
        Ok(v as u32)
    } else {
        Err(Invalid::new(
            key,
            format!("expected {what} (at most {hi}), got {v}"),
        ))
    }
}

/// A name usable in file names: letters, digits, `_`, `-` and `.`, not empty.
pub fn name(key: &str, v: &str) -> Result<String, Invalid> {
    let ok = !v.is_empty()
        && !v.starts_with('.')
        && v.chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'));
    if ok {
        Ok(v.to_owned())
    } else {
        Err(Invalid::new(
            key,
            format!("expected a name of letters, digits, '_', '-' or '.', got {v:?}"),
        ))
    }
}

/// A linear Rec.709 colour: three finite numbers ≥ 0.
pub fn color(key: &str, v: [f64; 3]) -> Result<DVec3, Invalid> {
    let c = DVec3::from_array(v);
    if c.is_finite() && c.min_element() >= 0.0 {
        Ok(c)
    } else {
        Err(Invalid::new(
            key,
            "expected three finite numbers ≥ 0 (linear RGB)",
        ))
    }
}
