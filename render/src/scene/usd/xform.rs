//! Where a prim is over time: its world transform at the time samples of its own and its
//! ancestors' xform ops around the times rays reach, split into a constant part baked into its
//! points and a similarity that moves it (the only motion rift blurs).

use super::{Source, ops};
use crate::error::RenderError;
use crate::scene::mesh::Shape;
use crate::scene::schema::{ObjectSection, StageOrigin};
use glam::{DAffine3, DMat3, DMat4, DVec3};
use openusd::schemas::geom::{Imageable, Purpose, Visibility, Xformable};
use openusd::usd::{Prim, SchemaBase, SchemaKind};
use rift_fx::rig::{AnimatedTransform, Interpolation, Similarity, TransformKey};
use rift_fx::shot::schema::{InterpolationSpec, PoseSpec};
use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::Rc;
use std::sync::Arc;

/// Any prim, seen as imageable and transformable (every prim rift reads is).
pub(super) struct Placed(pub(super) Prim);

impl SchemaBase for Placed {
    const KIND: SchemaKind = SchemaKind::AbstractTyped;
    fn prim(&self) -> &Prim {
        &self.0
    }
}
impl Imageable for Placed {}
impl Xformable for Placed {}

/// False for prims no render shows: invisible ones (or under one), guides and proxies.
pub fn rendered(prim: &Prim) -> anyhow::Result<bool> {
    let placed = Placed(prim.clone());
    if placed.compute_visibility()? == Visibility::Invisible {
        return Ok(false);
    }
    Ok(matches!(
        placed.compute_purpose()?,
        Purpose::Default | Purpose::Render
    ))
}

/// A prim's placement: `bake` (column-vector) applied to its points once, then `keys` (shot
/// frames, similarities) moving them. Standing still, `bake` is its whole world transform and
/// there are no keys; moving, `bake` is its first sample's linear part (what of its shape no
/// similarity can carry, with its turn and size then) and the keys place its origin.
pub struct Placement {
    pub bake: DMat4,
    pub keys: Vec<(f64, DMat4)>,
}

impl Placement {
    /// The object section of a mesh prim at `path` placed here, with its `shape`.
    pub fn object(&self, path: String, shape: Arc<Shape>) -> ObjectSection {
        ObjectSection {
            name: path.clone(),
            mesh: None,
            material: None,
            transform: self.pose(),
            copy_of: None,
            through: None,
            back_through: None,
            visibility: None,
            light_group: None,
            shape: Some(shape),
            instances: Vec::new(),
            instance_names: Vec::new(),
            stage_origin: match self.keys.as_slice() {
                [(_, first), _, ..] => StageOrigin::Keyed(first.w_axis.truncate().to_array()),
                _ => StageOrigin::Included,
            },
        }
    }

    /// As a shot file's `transform` (for sections built as tables): one matrix, or keyed
    /// matrices.
    pub fn pose_value(&self) -> toml::Value {
        let matrix = |m: glam::DMat4| {
            let rows = m.transpose().to_cols_array_2d();
            toml::Value::Array(
                rows.iter()
                    .map(|r| toml::Value::Array(r.iter().map(|&x| x.into()).collect()))
                    .collect(),
            )
        };
        let mut t = toml::Table::new();
        match self.keys.as_slice() {
            [(_, m)] => {
                t.insert("matrix".into(), matrix(*m));
            }
            keys => {
                let keys = keys
                    .iter()
                    .map(|&(frame, m)| {
                        let mut k = toml::Table::new();
                        k.insert("frame".into(), frame.into());
                        k.insert("matrix".into(), matrix(m));
                        toml::Value::Table(k)
                    })
                    .collect();
                t.insert("keys".into(), toml::Value::Array(keys));
                t.insert("interpolation".into(), "linear".into());
            }
        }
        toml::Value::Table(t)
    }

    /// The keys as a shot-file pose (none when it stands still).
    pub fn pose(&self) -> Option<PoseSpec> {
        (self.keys.len() >= 2).then(|| keyed_pose(&self.keys))
    }
}

/// Similarities at shot frames as a shot-file pose: one matrix, or linear keys.
fn keyed_pose(keys: &[(f64, DMat4)]) -> PoseSpec {
    let matrix = |m: DMat4| Some(m.transpose().to_cols_array_2d());
    if let [(_, m)] = keys {
        return PoseSpec {
            matrix: matrix(*m),
            ..PoseSpec::default()
        };
    }
    let keys = keys
        .iter()
        .map(|&(frame, m)| PoseSpec {
            frame: Some(frame),
            matrix: matrix(m),
            ..PoseSpec::default()
        })
        .collect();
    PoseSpec {
        keys: Some(keys),
        interpolation: Some(InterpolationSpec::Linear),
        ..PoseSpec::default()
    }
}

/// World transforms (similarities) at time codes as a shot-file pose.
pub fn pose_of(source: &Source, samples: &[(f64, DMat4)]) -> PoseSpec {
    let keys: Vec<(f64, DMat4)> = samples
        .iter()
        .map(|&(code, m)| (source.clock.frame(code), m))
        .collect();
    keyed_pose(&keys)
}

/// Where `prim` is over the times rays reach. A transform whose shape changes over time
/// (animated non-uniform scale or shear) is refused: rift blurs rigid motion and uniform scale.
pub fn placement(prim: &Prim, source: &Source) -> Result<Placement, RenderError> {
    of_samples(prim.path().as_str(), source, &world_samples(prim, source)?)
}

/// The placement of the prim at `path` whose world transform has the `samples` (time code and
/// matrix, at least one), as [`placement`] splits it.
pub fn of_samples(
    path: &str,
    source: &Source,
    samples: &[(f64, DMat4)],
) -> Result<Placement, RenderError> {
    let bake = samples[0].1;
    if !bake.is_finite() || bake.determinant() == 0.0 {
        return Err(source.error(
            path,
            Some("xformOp"),
            "its world transform is singular or not finite".into(),
        ));
    }
    if samples.iter().all(|(_, m)| *m == bake) {
        return Ok(Placement {
            bake,
            keys: Vec::new(),
        });
    }
    // Moving: only the first sample's linear part is baked, about the prim's own origin, and
    // each key places that origin where the sample puts it (absolute keys, as instances have).
    // Keys relative to the first sample's whole transform would turn the prim about the
    // stage's origin between samples, off its own centre.
    let linear = DMat4::from_mat3(DMat3::from_mat4(bake));
    let inverse = linear.inverse();
    let mut keys = Vec::with_capacity(samples.len());
    for &(code, m) in samples {
        let relative = m * inverse;
        if !is_similarity(DMat3::from_mat4(relative)) {
            return Err(source.error(
                path,
                Some("xformOp"),
                format!(
                    "its transform changes shape at time code {code} (animated non-uniform \
                     scale or shear), which rift cannot blur; bake it into the points"
                ),
            ));
        }
        keys.push((source.clock.frame(code), relative));
    }
    Ok(Placement { bake: linear, keys })
}

/// A light's placement: its world transform's per-axis scales at the first sample (which
/// size the light) taken out, the rest as keys of similarities from the origin.
pub fn light_placement(prim: &Prim, source: &Source) -> Result<(Placement, DVec3), RenderError> {
    let path = prim.path().as_str();
    let samples = world_samples(prim, source)?;
    let first = samples[0].1;
    let axes = DMat3::from_mat4(first);
    let scales = DVec3::new(
        axes.x_axis.length(),
        axes.y_axis.length(),
        axes.z_axis.length(),
    );
    if !first.is_finite() || scales.min_element() <= 0.0 {
        return Err(source.error(
            path,
            Some("xformOp"),
            "its world transform is singular or not finite".into(),
        ));
    }
    let unscale = DMat4::from_scale(1.0 / scales);
    let mut keys = Vec::with_capacity(samples.len());
    for &(code, m) in &samples {
        let m = m * unscale;
        if !is_similarity(DMat3::from_mat4(m)) {
            return Err(source.error(
                path,
                Some("xformOp"),
                format!(
                    "its transform at time code {code} shears the light or scales it \
                     differently than at its first sample, which rift cannot place"
                ),
            ));
        }
        keys.push((source.clock.frame(code), m));
    }
    let keys = match keys.windows(2).all(|w| w[0].1 == w[1].1) {
        // Standing still: one key, as a pose.
        true => vec![keys[0]],
        false => keys,
    };
    Ok((
        Placement {
            bake: DMat4::IDENTITY,
            keys,
        },
        scales,
    ))
}

/// World transforms at time codes (each a similarity) as an animated transform in shot
/// seconds; `None` when one of them stretches or shears (then it cannot be shared).
pub fn animated(source: &Source, samples: &[(f64, DMat4)]) -> Option<AnimatedTransform> {
    let mut keys = Vec::with_capacity(samples.len());
    for &(code, m) in samples {
        if !is_similarity(DMat3::from_mat4(m)) {
            return None;
        }
        let value = Similarity::from_affine(&DAffine3::from_mat4(m)).ok()?;
        keys.push(TransformKey {
            time: source.clock.seconds(code),
            value,
        });
    }
    Some(match keys.as_slice() {
        [only] => AnimatedTransform::constant(only.value),
        _ => AnimatedTransform::new(keys, Interpolation::Linear),
    })
}

/// True when `m` is a rotation times a uniform scale (columns orthogonal, of one length).
fn is_similarity(m: DMat3) -> bool {
    let gram = m.transpose() * m;
    let s2 = (gram.x_axis.x + gram.y_axis.y + gram.z_axis.z) / 3.0;
    if s2.is_nan() || s2 <= 0.0 || m.determinant() <= 0.0 {
        return false;
    }
    let off = (gram - DMat3::from_diagonal(DVec3::splat(s2))) * (1.0 / s2);
    off.to_cols_array().iter().all(|x| x.abs() < 1e-5)
}

/// Most times an interval between two of a prim's samples is halved to follow its path
/// ([`Follow::between`]): at most 64 steps between two samples.
pub(super) const MOST_HALVINGS: u32 = 6;

/// Most samples a prim keeps once [`world_samples`] follows it between its own: past them a
/// file with samples by the thousand within a frame is read at those alone, as before.
const MOST_FOLLOWED: usize = 1024;

/// How far rift's blend of two samples may stray from where USD puts the prim halfway between
/// them before that halfway sample is added: as a share of how far its origin moves (an arc of
/// angle θ strays about θ/8 of its chord from it, so arcs are followed in steps of about 4.6°,
/// a blur streak's middle within 1% of its length of the arc), as a share of its size, and in
/// radians of its turn.
const MOST_STRAY: f64 = 0.01;

/// `prim`'s world transform at each of its [`sample_codes`] (at least one), and between them
/// wherever rift's blend of two would stray from the prim's path ([`Follow::between`]): the
/// time code and the matrix, in order.
pub fn world_samples(prim: &Prim, source: &Source) -> Result<Vec<(f64, DMat4)>, RenderError> {
    let read = |e| source.read_error(prim.path().as_str(), e);
    let at = |code| world(prim, code, source).map_err(read);
    let codes = sample_codes(prim, source).map_err(read)?;
    let mut out: Vec<(f64, DMat4)> = Vec::with_capacity(codes.len());
    let follow = Follow::new(source.codes(), &at);
    for code in codes {
        let sample = (code, at(code)?);
        if let Some(&before) = out.last() {
            follow.between(before, sample, MOST_HALVINGS, &mut out)?;
        }
        out.push(sample);
    }
    Ok(out)
}

/// How [`world_samples`] follows a prim between its samples (and a PointInstancer its
/// instances): over the time codes `span` the frame's rays see, reading the world transform
/// with `at`.
pub(super) struct Follow<'a, F> {
    span: [f64; 2],
    at: &'a F,
}

impl<'a, F: Fn(f64) -> Result<DMat4, RenderError>> Follow<'a, F> {
    pub(super) fn new(span: [f64; 2], at: &'a F) -> Self {
        Self { span, at }
    }

    /// Adds to `out`, in order, the samples between `a` and `b` (time code, world matrix) that
    /// rift needs to follow the prim where its blend of the two strays from where USD puts it
    /// ([`strays`]): a parent turning it along an arc, ops that turn it about several axes, a
    /// scale op's straight growth. Halves the interval up to `halvings` times, where it
    /// overlaps the span.
    pub(super) fn between(
        &self,
        a: (f64, DMat4),
        b: (f64, DMat4),
        halvings: u32,
        out: &mut Vec<(f64, DMat4)>,
    ) -> Result<(), RenderError> {
        let [start, end] = self.span;
        if halvings == 0 || b.0 <= start || a.0 >= end || out.len() >= MOST_FOLLOWED {
            return Ok(());
        }
        let code = 0.5 * (a.0 + b.0);
        let half = (code, (self.at)(code)?);
        if !strays(a.1, b.1, half.1) {
            return Ok(());
        }
        self.between(a, half, halvings - 1, out)?;
        out.push(half);
        self.between(half, b, halvings - 1, out)
    }
}

/// Whether rift's halfway blend of world transforms `a` and `b` strays from `half`, the prim's
/// transform halfway, by more than [`MOST_STRAY`]. Compared as the similarities left after
/// `a`'s linear part, as a moving prim's keys are ([`of_samples`]); transforms that change
/// shape are left for `of_samples` to refuse.
fn strays(a: DMat4, b: DMat4, half: DMat4) -> bool {
    let linear = DMat4::from_mat3(DMat3::from_mat4(a));
    if !linear.is_finite() || linear.determinant() == 0.0 {
        return false;
    }
    let inverse = linear.inverse();
    let similarity = |m: DMat4| Similarity::from_affine(&DAffine3::from_mat4(m * inverse)).ok();
    let (Some(a), Some(b), Some(half)) = (similarity(a), similarity(b), similarity(half)) else {
        return false;
    };
    let blend = a.interpolate(&b, 0.5);
    // How far the origin moves, kept above rounding where it stands still.
    let size = 1.0 + a.translation.length() + b.translation.length();
    let travel = a.translation.distance(b.translation).max(1e-9 * size);
    blend.translation.distance(half.translation) > MOST_STRAY * travel
        || (blend.scale - half.scale).abs() > MOST_STRAY * half.scale
        || blend.rotation.angle_between(half.rotation) > MOST_STRAY
        // Near a half turn, which way the blend turns is a matter of rounding.
        || a.rotation.angle_between(b.rotation) > std::f64::consts::FRAC_PI_2
}

/// What a stage's prims share with their siblings, read once: each ancestor's world transform
/// at the time codes asked for, and the time samples of its ops and those above it. Read per
/// prim, a stage of thousands of prims under a deep hierarchy spent most of its load reading
/// the same ancestors' ops again for every child and time code.
///
/// Each table is emptied when it reaches [`MOST_ANCESTORS_KEPT`] entries: the stage is walked
/// depth first, so siblings follow one another, and what was dropped is read again once.
/// Kept whole, a stage of a million meshes each under an Xform of its own (as many exporters
/// write them) would hold a million transforms no sibling reads.
pub struct Ancestors {
    /// By ancestor path and time code (its bits).
    worlds: RefCell<HashMap<(String, u64), DMat4>>,
    /// By ancestor path: every time sample of its ops and of those above it, up to a reset.
    codes: RefCell<HashMap<String, Rc<[f64]>>>,
    most_kept: usize,
}

/// Entries each table of [`Ancestors`] keeps at most (about 3 MiB of transforms).
const MOST_ANCESTORS_KEPT: usize = 1 << 14;

impl Default for Ancestors {
    fn default() -> Self {
        Self::keeping(MOST_ANCESTORS_KEPT)
    }
}

impl Ancestors {
    /// Tables that keep at most `most_kept` entries each.
    fn keeping(most_kept: usize) -> Self {
        Self {
            worlds: RefCell::default(),
            codes: RefCell::default(),
            most_kept,
        }
    }

    /// Adds `key` to `table`, emptied first when full.
    fn keep<K: std::hash::Hash + Eq, V>(&self, table: &RefCell<HashMap<K, V>>, key: K, value: V) {
        let mut table = table.borrow_mut();
        if table.len() >= self.most_kept {
            table.clear();
        }
        table.insert(key, value);
    }

    /// What ancestor `prim` passes down to its children: `inherit(above, own)`, its `own` part
    /// (and whether its ops reset those above it) on what its parent passes down, `top` above
    /// the root or a reset. Walks up to the nearest ancestor `table` knows (by `key`), then
    /// keeps each one's on the way down.
    fn passed_down<K: std::hash::Hash + Eq, V: Clone, P>(
        &self,
        prim: &Prim,
        (table, key): (&RefCell<HashMap<K, V>>, impl Fn(&Prim) -> K),
        own: impl Fn(&Prim) -> anyhow::Result<(P, bool)>,
        top: V,
        inherit: impl Fn(&V, P) -> V,
    ) -> anyhow::Result<V> {
        let mut owns = Vec::new();
        let mut above = top;
        let mut next = Some(prim.clone());
        while let Some(at) = next {
            let k = key(&at);
            if let Some(known) = table.borrow().get(&k) {
                above = known.clone();
                break;
            }
            let (part, resets) = own(&at)?;
            owns.push((k, part));
            next = if resets { None } else { parent(&at) };
        }
        for (k, part) in owns.into_iter().rev() {
            above = inherit(&above, part);
            self.keep(table, k, above.clone());
        }
        Ok(above)
    }
}

/// `prim`'s local-to-world transform at time `code`, column-vector: its own ops on its
/// parent's world transform (from `source`'s [`Ancestors`]), or alone after a reset.
pub fn world(prim: &Prim, code: f64, source: &Source) -> anyhow::Result<DMat4> {
    let (own, resets) = local(prim, code)?;
    let Some(parent) = parent(prim).filter(|_| !resets) else {
        return Ok(own);
    };
    let ancestors = &source.ancestors;
    let key = |p: &Prim| (p.path().as_str().to_owned(), code.to_bits());
    let above = ancestors.passed_down(
        &parent,
        (&ancestors.worlds, key),
        |p| local(p, code),
        DMat4::IDENTITY,
        |above, own| *above * own,
    )?;
    Ok(above * own)
}

/// `prim`'s transform relative to its parent at time `code`, and whether its ops reset the
/// ancestors' transform.
fn local(prim: &Prim, code: f64) -> anyhow::Result<(DMat4, bool)> {
    let order = Placed(prim.clone()).xform_op_order()?.unwrap_or_default();
    Ok((ops::local_transform(prim, &order, code)?, resets(&order)))
}

/// True when xformOps `order` starts with [`ops::RESET`].
fn resets(order: &[String]) -> bool {
    order.first().is_some_and(|op| op == ops::RESET)
}

/// `prim`'s parent, unless that is the pseudo-root.
fn parent(prim: &Prim) -> Option<Prim> {
    let path = prim.path().parent()?;
    (!path.is_abs_root()).then(|| prim.stage().prim(path))
}

/// The time codes `prim`'s world transform is read at: every time sample of the ops of it
/// and its ancestors within the span, with the nearest one outside each end; the span's
/// start alone when nothing is sampled there.
fn sample_codes(prim: &Prim, source: &Source) -> anyhow::Result<Vec<f64>> {
    let (mut all, resets) = own_codes(prim)?;
    if let Some(parent) = parent(prim).filter(|_| !resets) {
        let ancestors = &source.ancestors;
        let key = |p: &Prim| p.path().as_str().to_owned();
        // Every time sample of the parent's ops and of those above it, sorted, once a stage.
        let above = ancestors.passed_down(
            &parent,
            (&ancestors.codes, key),
            own_codes,
            Rc::from([]),
            |above, mut codes| {
                codes.extend_from_slice(above);
                codes.retain(|t| t.is_finite());
                codes.sort_by(f64::total_cmp);
                codes.dedup();
                Rc::from(codes)
            },
        )?;
        all.extend_from_slice(&above);
    }
    Ok(codes_within(all, source.codes()))
}

/// The time samples of `prim`'s own ops, and whether its ops reset the ancestors' transform.
fn own_codes(prim: &Prim) -> anyhow::Result<(Vec<f64>, bool)> {
    let placed = Placed(prim.clone());
    let order = placed.xform_op_order()?.unwrap_or_default();
    let mut codes = Vec::new();
    for op in order.iter().filter(|op| *op != ops::RESET) {
        let name = ops::attribute_name(op)?;
        codes.extend(prim.attribute(name).time_sample_times()?);
    }
    Ok((codes, resets(&order)))
}

/// Of sample `times` (any order, repeats and non-finite ones included), those [`within`] `span`.
pub fn codes_within(mut times: Vec<f64>, span: [f64; 2]) -> Vec<f64> {
    times.retain(|t| t.is_finite());
    times.sort_by(f64::total_cmp);
    times.dedup();
    within(&times, span)
}

/// Of sorted `times`, those within `[start, end]` and the nearest outside each end; `start`
/// alone when there are none.
pub fn within(times: &[f64], [start, end]: [f64; 2]) -> Vec<f64> {
    if times.is_empty() {
        return vec![start];
    }
    let first = times.partition_point(|&t| t < start).saturating_sub(1);
    let last = times.partition_point(|&t| t <= end).min(times.len() - 1);
    times[first..=last.max(first)].to_vec()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_around_the_span_are_kept_with_one_outside_each_end() {
        let t = [0.0, 1.0, 2.0, 3.0, 4.0];
        assert_eq!(within(&t, [1.5, 2.5]), vec![1.0, 2.0, 3.0]);
        assert_eq!(within(&t, [2.0, 2.0]), vec![1.0, 2.0, 3.0]);
        assert_eq!(within(&t, [-5.0, -4.0]), vec![0.0]);
        assert_eq!(within(&t, [9.0, 10.0]), vec![4.0]);
        assert_eq!(within(&[], [1.0, 2.0]), vec![1.0]);
    }

    /// A stage of a turning root, a sliding middle and three leaves (one resetting the
    /// transform stack). Samples keyed in decimals: the crate, the reference here, holds
    /// scalars keyed in whole numbers between samples (which rift's reading of ops corrects).
    fn hierarchy() -> (tempfile::TempDir, openusd::usd::Stage) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("h.usda");
        let op =
            |name: &str, value: &str| format!("{value}\n uniform token[] xformOpOrder = [{name}]");
        let leaf = |name: &str, order: &str, x: f64| {
            format!(
                "def Xform \"{name}\" {{\n double3 xformOp:translate = ({x}, 0, 1)\n \
                 uniform token[] xformOpOrder = [{order}\"xformOp:translate\"]\n }}\n"
            )
        };
        let text = format!(
            "#usda 1.0\ndef Xform \"Root\" {{\n {}\n def Xform \"Mid\" {{\n {}\n {}{}{} }}\n}}\n",
            op(
                "\"xformOp:rotateY\"",
                "float xformOp:rotateY.timeSamples = { 1.0: 0.0, 3.0: 90.0 }"
            ),
            op(
                "\"xformOp:translate\"",
                "double3 xformOp:translate.timeSamples = { 2.0: (1, 0, 0), 2.5: (2, 0, 0) }"
            ),
            leaf("A", "", 1.0),
            leaf("B", "\"!resetXformStack!\", ", 2.0),
            leaf("C", "", 3.0),
        );
        std::fs::write(&path, text).unwrap();
        let stage = openusd::usd::Stage::builder()
            .open(path.to_str().unwrap())
            .unwrap();
        (dir, stage)
    }

    /// A source over time codes 0 to 4, with no ancestors read yet.
    fn source() -> Source<'static> {
        Source {
            layer: std::path::Path::new("h.usda"),
            key: "usd[0]",
            shot_file: std::path::Path::new("h.toml"),
            root: None,
            clock: super::super::Clock {
                codes_per_second: 1.0,
                offset: 0.0,
                fps: 1.0,
            },
            span: [0.0, 4.0],
            budget: None,
            shot_camera: None,
            ancestors: Ancestors::default(),
        }
    }

    /// The crate's own local-to-parent transforms, composed up to the root or a reset.
    fn composed_by_the_crate(stage: &openusd::usd::Stage, path: &str, code: f64) -> DMat4 {
        let mut m = DMat4::IDENTITY;
        let mut prim = Some(stage.prim(path));
        while let Some(p) = prim {
            let placed = Placed(p.clone());
            let local = placed
                .local_to_parent_transform(openusd::usd::TimeCode::new(code))
                .unwrap();
            m = DMat4::from_cols_array(&local.0) * m;
            let order = placed.xform_op_order().unwrap().unwrap_or_default();
            prim = if resets(&order) { None } else { parent(&p) };
        }
        m
    }

    /// World transforms read through the shared ancestors are the ones each prim's own walk up
    /// its hierarchy gives, whichever prim and time code comes first; a reset leaves them out.
    #[test]
    fn ancestors_read_once_give_every_prim_its_own_world_transform() {
        let (_dir, stage) = hierarchy();
        let shared = source();
        for round in 0..2 {
            for leaf in ["A", "B", "C", "A"] {
                let path = format!("/Root/Mid/{leaf}");
                for code in [0.0, 1.0, 1.5, 2.25, 3.0, 4.0] {
                    let prim = stage.prim(path.as_str());
                    let fresh = world(&prim, code, &source()).unwrap();
                    let expected = composed_by_the_crate(&stage, &path, code);
                    assert!(fresh.abs_diff_eq(expected, 1e-12), "{path} at {code}");
                    let cached = world(&prim, code, &shared).unwrap();
                    assert_eq!(cached, fresh, "{path} at {code}, round {round}");
                }
            }
        }
        assert_eq!(
            shared.ancestors.worlds.borrow().len(),
            2 * 6,
            "Root and Mid, six codes"
        );
        // Tables emptied every third entry give the same transforms.
        let forgetful = Source {
            ancestors: Ancestors::keeping(2),
            ..source()
        };
        for leaf in ["A", "B", "C"] {
            let prim = stage.prim(format!("/Root/Mid/{leaf}").as_str());
            for code in [1.5, 2.25, 1.5, 4.0] {
                let expected = world(&prim, code, &shared).unwrap();
                assert_eq!(world(&prim, code, &forgetful).unwrap(), expected);
                assert!(forgetful.ancestors.worlds.borrow().len() <= 2);
            }
        }
        // Sample times: the leaves' own ops have none; the ancestors' are theirs, within the
        // span with the nearest outside, except after a reset.
        let codes = |leaf: &str| {
            sample_codes(&stage.prim(format!("/Root/Mid/{leaf}").as_str()), &shared).unwrap()
        };
        assert_eq!(codes("A"), vec![1.0, 2.0, 2.5, 3.0]);
        assert_eq!(codes("C"), codes("A"));
        assert_eq!(
            codes("B"),
            vec![0.0],
            "a reset ignores the ancestors' samples"
        );
    }

    #[test]
    fn similarities_are_told_from_stretches() {
        let rot = DMat3::from_rotation_y(0.7) * 2.5;
        assert!(is_similarity(rot));
        assert!(!is_similarity(DMat3::from_diagonal(DVec3::new(
            1.0, 2.0, 1.0
        ))));
        // A mirror is not a motion.
        assert!(!is_similarity(DMat3::from_diagonal(DVec3::new(
            -1.0, 1.0, 1.0
        ))));
    }

    /// The samples [`world_samples`] keeps for `at` between time codes 1 and 2, over the span
    /// `span`.
    fn followed_over(span: [f64; 2], at: impl Fn(f64) -> DMat4) -> Vec<(f64, DMat4)> {
        let at = |code| Ok(at(code));
        let (a, b) = ((1.0, at(1.0).unwrap()), (2.0, at(2.0).unwrap()));
        let mut out = vec![a];
        let follow = Follow { span, at: &at };
        follow.between(a, b, MOST_HALVINGS, &mut out).unwrap();
        out.push(b);
        out
    }

    /// [`followed_over`] the whole interval.
    fn followed(at: impl Fn(f64) -> DMat4) -> Vec<(f64, DMat4)> {
        followed_over([1.0, 2.0], at)
    }

    #[test]
    fn an_arc_is_followed_and_straight_motion_is_not() {
        let turn = |code: f64| DMat4::from_rotation_y((code - 1.0) * std::f64::consts::FRAC_PI_2);
        // Carried 3 m out on an arm that turns a quarter: samples are added until each step
        // strays less than MOST_STRAY of its chord from the arc.
        let arm = followed(|code| turn(code) * DMat4::from_translation(DVec3::new(3.0, 0.0, 0.0)));
        assert!(arm.len() > 16, "{} samples", arm.len());
        assert!(arm.windows(2).all(|w| w[0].0 < w[1].0));
        for w in arm.windows(2) {
            let half = 0.5 * (w[0].0 + w[1].0);
            let arc = turn(half) * DMat4::from_translation(DVec3::new(3.0, 0.0, 0.0));
            assert!(
                !strays(w[0].1, w[1].1, arc),
                "between {} and {}",
                w[0].0,
                w[1].0
            );
        }
        // Turning about its own origin as it slides, growing geometrically, under a fixed
        // non-uniform scale: rift's blend is the path itself.
        let stretch = DMat4::from_scale(DVec3::new(1.0, 2.0, 0.5));
        let own = |code: f64| {
            DMat4::from_translation(DVec3::new(code, 5.0, -2.0))
                * turn(code)
                * DMat4::from_scale(DVec3::splat(4f64.powf(code - 1.0)))
                * stretch
        };
        assert_eq!(followed(own).len(), 2);
        // A scale op's straight growth is followed (rift blends scale geometrically).
        let grows = followed(|code| DMat4::from_scale(DVec3::splat(code)));
        assert!(
            grows.len() > 2 && grows.len() <= 9,
            "{} samples",
            grows.len()
        );
        // A whole turn between samples, which their matrices alone do not show: followed in
        // quarter turns, each of which the blend takes the short way.
        let spins = followed(|code| DMat4::from_rotation_z((code - 1.0) * std::f64::consts::TAU));
        let codes: Vec<f64> = spins.iter().map(|s| s.0).collect();
        assert_eq!(codes, [1.0, 1.25, 1.5, 1.75, 2.0]);
        // Only where the frame's rays look: the first half of the interval.
        let half_arm = followed_over([1.0, 1.5], |code| {
            turn(code) * DMat4::from_translation(DVec3::new(3.0, 0.0, 0.0))
        });
        assert!(
            half_arm.len() <= arm.len() / 2 + 2,
            "{} of {}",
            half_arm.len(),
            arm.len()
        );
        assert!(half_arm[half_arm.len() - 2].0 <= 1.5);
        // Past MOST_FOLLOWED samples nothing more is read.
        let mut full = vec![(1.0, DMat4::IDENTITY); MOST_FOLLOWED];
        let never = |_: f64| -> Result<DMat4, RenderError> { panic!("read past the cap") };
        let follow = Follow {
            span: [1.0, 2.0],
            at: &never,
        };
        let ends = ((1.0, turn(1.0)), (2.0, turn(2.0)));
        follow
            .between(ends.0, ends.1, MOST_HALVINGS, &mut full)
            .unwrap();
        assert_eq!(full.len(), MOST_FOLLOWED);
    }
}
