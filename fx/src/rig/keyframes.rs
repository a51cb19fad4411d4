//! Keyframed similarity transforms, evaluated at any time in seconds.
//!
//! Translation is a cubic Hermite curve whose tangents are the time-weighted average of the
//! neighbouring slopes (smooth through uneven key spacing), or straight lines; rotation is slerp
//! along the shortest arc between neighbouring keys; scale is interpolated geometrically so that
//! halving and doubling are symmetric. Before the first key and after the last the transform holds.

use super::similarity::Similarity;

/// How values between keys are found.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Interpolation {
    /// Hermite translation (C1), slerp rotation.
    #[default]
    Smooth,
    /// Straight-line translation, slerp rotation.
    Linear,
    /// Holds each key until the next.
    Step,
}

/// One key: a transform at a time in seconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransformKey {
    pub time: f64,
    pub value: Similarity,
}

/// A transform that may change over time.
#[derive(Clone, Debug, PartialEq)]
pub struct AnimatedTransform {
    keys: Vec<TransformKey>,
    interpolation: Interpolation,
}

impl AnimatedTransform {
    /// A transform that never changes.
    pub fn constant(value: Similarity) -> Self {
        Self {
            keys: vec![TransformKey { time: 0.0, value }],
            interpolation: Interpolation::Step,
        }
    }

    /// Keys must be non-empty and strictly increasing in time (the shot loader checks this and
    /// names the offending key; here it is a programming error).
    pub fn new(keys: Vec<TransformKey>, interpolation: Interpolation) -> Self {
        assert!(!keys.is_empty(), "an animated transform needs a key");
        assert!(
            keys.windows(2).all(|w| w[0].time < w[1].time),
            "keys must be strictly increasing in time"
        );
        Self {
            keys,
            interpolation,
        }
    }

    /// The keys, in time order.
    pub fn keys(&self) -> &[TransformKey] {
        &self.keys
    }

    /// `applied` after this transform at every time: the keys mapped by `applied`, with the
    /// same interpolation. This is exact: Hermite translation is linear in the keys, slerp is
    /// unchanged by a fixed rotation applied first, and geometric scale by a fixed factor.
    pub fn then(&self, applied: &Similarity) -> Self {
        self.map_keys(|k| applied.compose(k))
    }

    /// `first` before this transform at every key: exact at the keys; between them the keys'
    /// translations are interpolated as they come out, so a `first` off the origin moves along
    /// the chord while the keys turn, not the arc.
    pub fn after(&self, first: &Similarity) -> Self {
        self.map_keys(|k| k.compose(first))
    }

    /// Every key's value replaced by `f` of it, at the same times.
    fn map_keys(&self, f: impl Fn(&Similarity) -> Similarity) -> Self {
        Self {
            keys: self
                .keys
                .iter()
                .map(|k| TransformKey {
                    time: k.time,
                    value: f(&k.value),
                })
                .collect(),
            interpolation: self.interpolation,
        }
    }

    /// True when the transform is the same at every time: callers skip motion work then.
    pub fn is_static(&self) -> bool {
        self.keys.windows(2).all(|w| w[0].value == w[1].value)
    }

    /// The transform at time `t` (seconds).
    pub fn at(&self, t: f64) -> Similarity {
        let keys = &self.keys;
        let last = keys.len() - 1;
        if t <= keys[0].time || last == 0 {
            return keys[0].value;
        }
        if t >= keys[last].time {
            return keys[last].value;
        }
        // Index of the segment [i, i+1] that holds t.
        let i = keys.partition_point(|k| k.time <= t) - 1;
        let (k0, k1) = (&keys[i], &keys[i + 1]);
        let dt = k1.time - k0.time;
        let w = (t - k0.time) / dt;
        match self.interpolation {
            Interpolation::Step => k0.value,
            Interpolation::Linear => k0.value.interpolate(&k1.value, w),
            Interpolation::Smooth => {
                let mut s = k0.value.interpolate(&k1.value, w);
                let m0 = self.tangent(i) * dt;
                let m1 = self.tangent(i + 1) * dt;
                s.translation = hermite(k0.value.translation, m0, k1.value.translation, m1, w);
                s
            }
        }
    }

    /// Velocity of the translation at key `i` (units per second) for Hermite interpolation.
    fn tangent(&self, i: usize) -> glam::DVec3 {
        let keys = &self.keys;
        let slope = |a: usize, b: usize| {
            (keys[b].value.translation - keys[a].value.translation) / (keys[b].time - keys[a].time)
        };
        let last = keys.len() - 1;
        if i == 0 {
            slope(0, 1)
        } else if i == last {
            slope(last - 1, last)
        } else {
            // Weight each neighbouring slope by the length of the *other* interval: exact for
            // quadratic motion with uneven key spacing.
            let h0 = keys[i].time - keys[i - 1].time;
            let h1 = keys[i + 1].time - keys[i].time;
            (slope(i - 1, i) * h1 + slope(i, i + 1) * h0) / (h0 + h1)
        }
    }
}

/// The cubic Hermite curve from `p0` (slope `m0`) to `p1` (slope `m1`) at `w` in [0, 1], slopes
/// already scaled by the segment length.
pub fn hermite<T>(p0: T, m0: T, p1: T, m1: T, w: f64) -> T
where
    T: std::ops::Mul<f64, Output = T> + std::ops::Add<Output = T>,
{
    let (w2, w3) = (w * w, w * w * w);
    p0 * (2.0 * w3 - 3.0 * w2 + 1.0)
        + m0 * (w3 - 2.0 * w2 + w)
        + p1 * (-2.0 * w3 + 3.0 * w2)
        + m1 * (w3 - w2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DQuat, DVec3};

    fn key(time: f64, x: f64, angle: f64, scale: f64) -> TransformKey {
        TransformKey {
            time,
            value: Similarity::new(
                DQuat::from_rotation_y(angle),
                DVec3::new(x, 0.0, 0.0),
                scale,
            ),
        }
    }

    #[test]
    fn passes_through_keys_and_holds_outside() {
        let anim = AnimatedTransform::new(
            vec![
                key(0.0, 0.0, 0.0, 1.0),
                key(1.0, 2.0, 1.0, 2.0),
                key(3.0, 3.0, 2.0, 4.0),
            ],
            Interpolation::Smooth,
        );
        for k in anim.keys() {
            assert!(anim.at(k.time).distance(&k.value, 1.0) < 1e-12);
        }
        assert_eq!(anim.at(-5.0), anim.keys()[0].value);
        assert_eq!(anim.at(50.0), anim.keys()[2].value);
        // geometric scale: halfway between 1 and 2 is sqrt(2)
        let mid = AnimatedTransform::new(
            vec![key(0.0, 0.0, 0.0, 1.0), key(1.0, 0.0, 0.0, 2.0)],
            Interpolation::Linear,
        );
        assert!((mid.at(0.5).scale - 2f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn smooth_reproduces_quadratic_motion_on_uneven_keys() {
        let f = |t: f64| 0.5 * t * t - t;
        let times = [0.0, 0.4, 1.5, 2.0, 3.7];
        let anim = AnimatedTransform::new(
            times.iter().map(|&t| key(t, f(t), 0.0, 1.0)).collect(),
            Interpolation::Smooth,
        );
        // Interior segments see exact tangents, so the quadratic comes back exactly there.
        for i in 1..=30 {
            let t = 0.4 + 1.6 * i as f64 / 31.0;
            assert!((anim.at(t).translation.x - f(t)).abs() < 1e-9, "t = {t}");
        }
    }
}
