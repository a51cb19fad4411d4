//! Turning pose specs (position + orientation + scale, or a matrix, possibly keyed) into
//! validated similarity transforms.

use super::check;
use super::schema::{InterpolationSpec, PoseSpec};
use crate::error::Invalid;
use crate::rig::{AnimatedTransform, Interpolation, Similarity, TransformKey};
use glam::{DAffine3, DMat3, DMat4, DQuat, DVec3, EulerRot};

/// Which local axis `look_at` points at the target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Facing {
    /// Cameras look down their −Z.
    NegativeZ,
    /// An opening's front is its +Z.
    PositiveZ,
}

/// A pose spec that may hold keys, as an animated transform. `fps` converts key frames to seconds.
pub fn animated(
    key: &str,
    spec: &PoseSpec,
    facing: Facing,
    fps: f64,
) -> Result<AnimatedTransform, Invalid> {
    if spec.frame.is_some() {
        return Err(Invalid::new(
            format!("{key}.frame"),
            "`frame` belongs inside `keys`",
        ));
    }
    let Some(keys) = &spec.keys else {
        if spec.interpolation.is_some() {
            return Err(Invalid::new(
                format!("{key}.interpolation"),
                "`interpolation` needs `keys`",
            ));
        }
        return Ok(AnimatedTransform::constant(pose(key, spec, facing)?));
    };
    let has_static_fields = spec.position.is_some()
        || spec.rotation_degrees.is_some()
        || spec.quaternion.is_some()
        || spec.look_at.is_some()
        || spec.up.is_some()
        || spec.scale.is_some()
        || spec.matrix.is_some();
    if has_static_fields {
        return Err(Invalid::new(
            key,
            "give either `keys` or a single pose, not both",
        ));
    }
    if keys.is_empty() {
        return Err(Invalid::new(
            format!("{key}.keys"),
            "expected at least one key",
        ));
    }
    let mut out = Vec::with_capacity(keys.len());
    for (i, k) in keys.iter().enumerate() {
        let kkey = format!("{key}.keys[{i}]");
        if k.keys.is_some() || k.interpolation.is_some() {
            return Err(Invalid::new(
                kkey,
                "a key cannot hold `keys` or `interpolation`",
            ));
        }
        let frame = k
            .frame
            .ok_or_else(|| Invalid::new(kkey.clone(), "missing field `frame`"))?;
        let frame = check::finite(&format!("{kkey}.frame"), frame)?;
        if let Some(prev) = out.last().map(|p: &TransformKey| p.time)
            && frame / fps <= prev
        {
            return Err(Invalid::new(
                format!("{kkey}.frame"),
                "keys must be in increasing frame order",
            ));
        }
        out.push(TransformKey {
            time: frame / fps,
            value: pose(&kkey, k, facing)?,
        });
    }
    let interpolation = match spec.interpolation.unwrap_or(InterpolationSpec::Smooth) {
        InterpolationSpec::Smooth => Interpolation::Smooth,
        InterpolationSpec::Linear => Interpolation::Linear,
        InterpolationSpec::Step => Interpolation::Step,
    };
    Ok(AnimatedTransform::new(out, interpolation))
}

/// One static pose.
pub fn pose(key: &str, spec: &PoseSpec, facing: Facing) -> Result<Similarity, Invalid> {
    let sub = |name: &str| format!("{key}.{name}");
    if let Some(rows) = &spec.matrix {
        if spec.position.is_some()
            || spec.rotation_degrees.is_some()
            || spec.quaternion.is_some()
            || spec.look_at.is_some()
            || spec.scale.is_some()
        {
            return Err(Invalid::new(
                key,
                "`matrix` cannot be combined with position, rotation or scale",
            ));
        }
        let m = DMat4::from_cols_array_2d(rows).transpose();
        if !m.is_finite() {
            return Err(Invalid::new(sub("matrix"), "expected finite numbers"));
        }
        if (m.row(3) - glam::DVec4::W).abs().max_element() > 1e-9 {
            return Err(Invalid::new(
                sub("matrix"),
                "the last row must be [0, 0, 0, 1] (no projective part)",
            ));
        }
        let similarity = Similarity::from_affine(&DAffine3::from_mat4(m))
            .map_err(|e| Invalid::new(sub("matrix"), e.to_string()))?;
        check::point(&sub("matrix"), similarity.translation.to_array())?;
        check::positive_length(&sub("matrix"), similarity.scale)?;
        return Ok(similarity);
    }

    let position = check::point(&sub("position"), spec.position.unwrap_or([0.0; 3]))?;
    let orientation_count = [
        spec.rotation_degrees.is_some(),
        spec.quaternion.is_some(),
        spec.look_at.is_some(),
    ]
    .iter()
    .filter(|b| **b)
    .count();
    if orientation_count > 1 {
        return Err(Invalid::new(
            key,
            "give one of `rotation_degrees`, `quaternion` or `look_at`",
        ));
    }
    if spec.up.is_some() && spec.look_at.is_none() {
        return Err(Invalid::new(sub("up"), "`up` goes with `look_at`"));
    }
    let rotation = if let Some(deg) = spec.rotation_degrees {
        let r = vec3(&sub("rotation_degrees"), deg)?;
        DQuat::from_euler(
            EulerRot::ZYX,
            r.z.to_radians(),
            r.y.to_radians(),
            r.x.to_radians(),
        )
    } else if let Some(q) = spec.quaternion {
        let q = DQuat::from_array(q);
        if !q.is_finite() || q.length() < 1e-9 {
            return Err(Invalid::new(
                sub("quaternion"),
                "expected a non-zero quaternion [x, y, z, w]",
            ));
        }
        q.normalize()
    } else if let Some(target) = spec.look_at {
        let target = vec3(&sub("look_at"), target)?;
        let up = vec3(&sub("up"), spec.up.unwrap_or([0.0, 1.0, 0.0]))?;
        look_rotation(position, target, up, facing).map_err(|m| Invalid::new(sub("look_at"), m))?
    } else {
        DQuat::IDENTITY
    };
    let scale = match spec.scale {
        None => 1.0,
        Some(s) => check::positive_length(&sub("scale"), s).map_err(|_| {
            Invalid::new(
                sub("scale"),
                format!(
                    "expected a positive scale no larger than {:e}, got {s} (the frame would \
                     be singular or beyond single precision)",
                    check::MAX_LENGTH
                ),
            )
        })?,
    };
    Ok(Similarity::new(rotation, position, scale))
}

fn vec3(key: &str, v: [f64; 3]) -> Result<DVec3, Invalid> {
    let v = DVec3::from_array(v);
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Invalid::new(key, "expected finite numbers"))
    }
}

/// The rotation whose facing axis points from `eye` to `target` with +Y towards `up`.
fn look_rotation(eye: DVec3, target: DVec3, up: DVec3, facing: Facing) -> Result<DQuat, String> {
    let to_target = target - eye;
    let scale = eye
        .abs()
        .max_element()
        .max(target.abs().max_element())
        .max(1.0);
    if to_target.length() <= 1e-12 * scale {
        return Err("the target equals the position (singular frame)".into());
    }
    let forward = to_target.normalize();
    let z = match facing {
        Facing::NegativeZ => -forward,
        Facing::PositiveZ => forward,
    };
    let x = up.cross(z);
    if x.length() < 1e-9 * up.length().max(1e-300) {
        return Err("the view direction is parallel to `up` (singular frame)".into());
    }
    let x = x.normalize();
    let y = z.cross(x);
    Ok(DQuat::from_mat3(&DMat3::from_cols(x, y, z)).normalize())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn look_at_points_the_right_axis() {
        let eye = DVec3::new(1.0, 2.0, 3.0);
        let target = DVec3::new(-4.0, 0.5, 1.0);
        let dir = (target - eye).normalize();
        let cam = look_rotation(eye, target, DVec3::Y, Facing::NegativeZ).unwrap();
        assert!((cam * -DVec3::Z - dir).length() < 1e-12);
        assert!((cam * DVec3::X).y.abs() < 1e-12, "camera stays level");
        let portal = look_rotation(eye, target, DVec3::Y, Facing::PositiveZ).unwrap();
        assert!((portal * DVec3::Z - dir).length() < 1e-12);
        assert!(look_rotation(eye, eye, DVec3::Y, Facing::PositiveZ).is_err());
        assert!(look_rotation(eye, eye + DVec3::Y, DVec3::Y, Facing::PositiveZ).is_err());
    }

    #[test]
    fn euler_order_is_x_then_y_then_z() {
        let spec = PoseSpec {
            rotation_degrees: Some([90.0, 90.0, 0.0]),
            ..Default::default()
        };
        let r = pose("p", &spec, Facing::PositiveZ).unwrap().rotation;
        // X first takes +Y to +Z, then Y takes +Z to +X.
        assert!((r * DVec3::Y - DVec3::X).length() < 1e-12);
    }
}
