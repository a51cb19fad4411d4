//! A prim's local transform from its xformOps, evaluated by rift rather than the USD crate:
//! the crate reads a usda sample of a scalar attribute written as a whole number (`90`, as
//! usd-core writes a float 90.0) as an integer and holds integers between samples, where USD
//! interpolates them (a `rotateZ` keyed 0 then 90 would stay at 0 until its second sample).
//! Every op gives the crate's matrix (tests below); a scalar op between two samples either of
//! which is a whole number is interpolated here.

use super::values;
use glam::{DMat4, DQuat, DVec3};
use openusd::sdf::Value;
use openusd::usd::Prim;

/// The op that, first in `xformOpOrder`, stops a prim inheriting its parent's transform.
pub const RESET: &str = "!resetXformStack!";

/// `prim`'s local transform (column-vector) at time `code` from its xformOps `order`.
pub fn local_transform(prim: &Prim, order: &[String], code: f64) -> anyhow::Result<DMat4> {
    let mut m = DMat4::IDENTITY;
    for (i, op) in order.iter().enumerate() {
        if op == RESET {
            if i == 0 {
                continue;
            }
            anyhow::bail!("xformOpOrder: `!resetXformStack!` is only valid first, found at {i}");
        }
        m *= op_matrix(prim, op, code)?;
    }
    Ok(m)
}

/// The name of op `op`'s attribute (without its `!invert!` prefix), checked before the crate
/// composes it (its composition loops on a malformed one).
pub fn attribute_name(op: &str) -> anyhow::Result<&str> {
    let name = op.strip_prefix("!invert!").unwrap_or(op);
    let plain = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == ':';
    if name.is_empty() || name.len() > 256 || !name.chars().all(plain) {
        anyhow::bail!("xformOpOrder names a malformed op {op:?}");
    }
    Ok(name)
}

/// The op's kind (`rotateZ` of `xformOp:rotateZ:spin`).
fn kind(name: &str) -> &str {
    let after = name.strip_prefix("xformOp:").unwrap_or(name);
    after.split(':').next().unwrap_or(after)
}

/// True for the ops whose value is one number.
fn is_scalar(kind: &str) -> bool {
    matches!(
        kind,
        "translateX"
            | "translateY"
            | "translateZ"
            | "scaleX"
            | "scaleY"
            | "scaleZ"
            | "rotateX"
            | "rotateY"
            | "rotateZ"
    )
}

/// The matrix of op `op` (column-vector) at `code`, inverted where it says so: a scalar op's
/// number interpolated linearly between its samples, any other value as the crate gives it.
fn op_matrix(prim: &Prim, op: &str, code: f64) -> anyhow::Result<DMat4> {
    let (inverted, name) = (op.starts_with("!invert!"), attribute_name(op)?);
    let kind = kind(name);
    // Whether the crate would hold a scalar only the samples around `code` tell (a decimal one
    // before a whole one is held too, as a float), so a scalar op always asks for them.
    let value = match is_scalar(kind) {
        true => values::scalar_at(prim, name, code)?,
        false => values::value(prim, name, code)?,
    };
    let scalar = || {
        let default = if kind.starts_with("scale") { 1.0 } else { 0.0 };
        value.as_ref().and_then(values::number).unwrap_or(default)
    };
    let vector = |default: f64| {
        value
            .as_ref()
            .and_then(vec3)
            .unwrap_or(DVec3::splat(default))
    };
    let m = match kind {
        "translate" => DMat4::from_translation(vector(0.0)),
        "translateX" => DMat4::from_translation(DVec3::X * scalar()),
        "translateY" => DMat4::from_translation(DVec3::Y * scalar()),
        "translateZ" => DMat4::from_translation(DVec3::Z * scalar()),
        "scale" => DMat4::from_scale(vector(1.0)),
        "scaleX" => DMat4::from_scale(DVec3::new(scalar(), 1.0, 1.0)),
        "scaleY" => DMat4::from_scale(DVec3::new(1.0, scalar(), 1.0)),
        "scaleZ" => DMat4::from_scale(DVec3::new(1.0, 1.0, scalar())),
        "rotateX" => DMat4::from_rotation_x(scalar().to_radians()),
        "rotateY" => DMat4::from_rotation_y(scalar().to_radians()),
        "rotateZ" => DMat4::from_rotation_z(scalar().to_radians()),
        "orient" => DMat4::from_quat(value.as_ref().and_then(quat).unwrap_or(DQuat::IDENTITY)),
        "transform" => match value {
            // Row-vector rows, read as column-vector columns.
            Some(Value::Matrix4d(m)) => DMat4::from_cols_array(&m.0),
            _ => DMat4::IDENTITY,
        },
        "rotateXYZ" | "rotateXZY" | "rotateYXZ" | "rotateYZX" | "rotateZXY" | "rotateZYX" => {
            euler(kind, vector(0.0))
        }
        _ => DMat4::IDENTITY,
    };
    match inverted {
        false => Ok(m),
        true if m.determinant() != 0.0 => Ok(m.inverse()),
        true => anyhow::bail!("xformOp `{op}` is singular and cannot be inverted"),
    }
}

/// A three-axis rotation op such as `rotateXYZ` (degrees, the first axis named turned first).
fn euler(kind: &str, degrees: DVec3) -> DMat4 {
    kind[6..].chars().fold(DMat4::IDENTITY, |m, axis| {
        let turn = match axis {
            'X' => DMat4::from_rotation_x(degrees.x.to_radians()),
            'Y' => DMat4::from_rotation_y(degrees.y.to_radians()),
            _ => DMat4::from_rotation_z(degrees.z.to_radians()),
        };
        turn * m
    })
}

/// A 3-vector of any precision.
fn vec3(v: &Value) -> Option<DVec3> {
    match v {
        Value::Vec3d(a) => Some(DVec3::new(a.x, a.y, a.z)),
        Value::Vec3f(a) => Some(DVec3::new(a.x as f64, a.y as f64, a.z as f64)),
        Value::Vec3h(a) => Some(DVec3::new(
            a.x.to_f32() as f64,
            a.y.to_f32() as f64,
            a.z.to_f32() as f64,
        )),
        _ => None,
    }
}

/// A quaternion of any precision.
fn quat(v: &Value) -> Option<DQuat> {
    let [w, x, y, z] = match v {
        Value::Quatd(q) => [q.w, q.x, q.y, q.z],
        Value::Quatf(q) => [q.w, q.x, q.y, q.z].map(f64::from),
        Value::Quath(q) => [q.w, q.x, q.y, q.z].map(|c| c.to_f64()),
        _ => return None,
    };
    Some(DQuat::from_xyzw(x, y, z, w).normalize())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::usd::xform::Placed;
    use openusd::schemas::geom::Xformable;
    use openusd::usd::{Stage, TimeCode};

    /// A stage of one Xform, `/A`, with the ops `ops` (usda lines) in the order `order`.
    fn stage_with(ops: &str, order: &str) -> (tempfile::TempDir, Stage) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.usda");
        let text = format!(
            "#usda 1.0\ndef Xform \"A\" {{\n{ops}\n uniform token[] xformOpOrder = [{order}]\n}}\n"
        );
        std::fs::write(&path, text).unwrap();
        let stage = Stage::builder().open(path.to_str().unwrap()).unwrap();
        (dir, stage)
    }

    const ORDER: &str = "\"xformOp:translate\", \"xformOp:rotateZ\", \"xformOp:rotateXYZ\", \
                         \"xformOp:translateX\", \"xformOp:orient\", \"!invert!xformOp:scaleY\", \
                         \"xformOp:rotateYZX:tilt\", \"xformOp:scale\", \"xformOp:transform\"";

    /// Every kind of op, sampled at 1 and 3, with `n(x)` writing the scalars' numbers.
    fn ops(n: impl Fn(f64) -> String) -> String {
        format!(
            " double3 xformOp:translate.timeSamples = {{ 1: (0, 1, 2), 3: (2, -1, 0) }}\n \
             float xformOp:rotateZ.timeSamples = {{ 1: {}, 3: {} }}\n \
             float3 xformOp:rotateXYZ.timeSamples = {{ 1: (10, 20, 30), 3: (40, -20, 0) }}\n \
             double xformOp:translateX.timeSamples = {{ 1: {}, 3: {} }}\n \
             quatf xformOp:orient = (0.9238795, 0, 0.38268343, 0)\n \
             float xformOp:scaleY.timeSamples = {{ 1: {}, 3: {} }}\n \
             float3 xformOp:rotateYZX:tilt = (5, 15, 25)\n \
             float3 xformOp:scale = (1, 2, 3)\n \
             matrix4d xformOp:transform = ( (1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (4, 5, 6, 1) )",
            n(0.0),
            n(90.0),
            n(-3.0),
            n(5.0),
            n(1.0),
            n(3.0)
        )
    }

    fn crate_transform(stage: &Stage, code: f64) -> DMat4 {
        let placed = Placed(stage.prim("/A"));
        DMat4::from_cols_array(
            &placed
                .local_to_parent_transform(TimeCode::new(code))
                .unwrap()
                .0,
        )
    }

    fn order(stage: &Stage) -> Vec<String> {
        Placed(stage.prim("/A")).xform_op_order().unwrap().unwrap()
    }

    #[test]
    fn whole_number_samples_are_interpolated_as_the_crate_interpolates_decimal_ones() {
        let (_d1, decimal) = stage_with(&ops(|x| format!("{x:.1}")), ORDER);
        let (_d2, whole) = stage_with(&ops(|x| format!("{x}")), ORDER);
        for code in [0.5, 1.0, 1.25, 2.0, 2.9, 3.0, 4.0] {
            let right = crate_transform(&decimal, code);
            let ours = local_transform(&whole.prim("/A"), &order(&whole), code).unwrap();
            let between = code > 1.0 && code < 3.0;
            assert!(
                ours.abs_diff_eq(right, 1e-5),
                "{code}: {ours} against {right}"
            );
            // What the crate does alone with whole numbers: held between samples.
            if between {
                assert!(
                    !crate_transform(&whole, code).abs_diff_eq(right, 1e-3),
                    "{code}"
                );
            }
        }
    }

    #[test]
    fn every_op_kind_matches_the_crates_matrix() {
        // Decimal samples, which the crate interpolates, and a reset of the stack first.
        let (_d, stage) = stage_with(&ops(|x| format!("{x:.1}")), ORDER);
        for code in [0.0, 1.0, 1.5, 2.0, 2.5, 3.0, 7.0] {
            let ours = local_transform(&stage.prim("/A"), &order(&stage), code).unwrap();
            let right = crate_transform(&stage, code);
            assert!(
                ours.abs_diff_eq(right, 1e-6),
                "{code}: {ours} against {right}"
            );
        }
        let reset = format!("\"!resetXformStack!\", {ORDER}");
        let (_e, stage) = stage_with(&ops(|x| format!("{x:.1}")), &reset);
        let ours = local_transform(&stage.prim("/A"), &order(&stage), 2.0).unwrap();
        assert!(ours.abs_diff_eq(crate_transform(&stage, 2.0), 1e-6));
        // A reset anywhere else is refused, as the crate refuses it.
        let late = format!("{ORDER}, \"!resetXformStack!\"");
        let (_f, stage) = stage_with(&ops(|x| format!("{x:.1}")), &late);
        assert!(local_transform(&stage.prim("/A"), &order(&stage), 2.0).is_err());
        assert!(
            Placed(stage.prim("/A"))
                .local_to_parent_transform(TimeCode::new(2.0))
                .is_err()
        );
    }

    #[test]
    fn a_decimal_sample_before_a_whole_one_is_interpolated_too() {
        // The crate holds 10.5 (a float) until 3 here: what it returns between the samples is
        // no integer, so only the samples themselves tell.
        let (_d, stage) = stage_with(
            " float xformOp:rotateZ.timeSamples = { 1: 10.5, 3: 90 }",
            "\"xformOp:rotateZ\"",
        );
        let ours = local_transform(&stage.prim("/A"), &order(&stage), 2.0).unwrap();
        let right = DMat4::from_rotation_z(50.25f64.to_radians());
        assert!(ours.abs_diff_eq(right, 1e-9), "{ours} against {right}");
    }

    #[test]
    fn a_scalar_keyed_in_whole_numbers_is_read_between_its_samples_as_usd_interpolates_it() {
        // As a light's intensity or a camera's focal length is read.
        let (_d, stage) = stage_with(" float intensity.timeSamples = { 1: 10, 3: 30.5 }", "");
        let at = |code: f64| {
            let v = values::scalar_at(&stage.prim("/A"), "intensity", code).unwrap();
            v.as_ref().and_then(values::number).unwrap()
        };
        assert_eq!(
            [at(0.0), at(1.0), at(2.0), at(3.0), at(4.0)],
            [10.0, 10.0, 20.25, 30.5, 30.5]
        );
    }
}
