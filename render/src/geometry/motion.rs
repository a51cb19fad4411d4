//! Where an object is at each time: its own keyed transform, or that transform carried through a
//! portal opening by the constraint solver (M_T = T·M_H), for the there-side copy of an object
//! passing through. An opening that delays rays shows the copy as the object was that much
//! earlier, which is what a ray crossing the opening at that time would see.
//!
//! The inverse solver carries a transform back (M_H = T⁻¹·M_T): the here-side copy of a
//! there-side target, as a ray entering the opening would find it (that much later, with a
//! delay), for rigs on the here side that must reach it.

use rift_fx::rig::{AnimatedTransform, Rig, Similarity, ThereFrame, solve_here, solve_there};
use std::sync::Arc;

/// An object's placement over time.
#[derive(Clone, Debug)]
pub struct ObjectMotion {
    own: AnimatedTransform,
    through: Option<Carried>,
}

/// The opening a copy is carried through.
#[derive(Clone, Debug)]
struct Carried {
    rig: Arc<Rig>,
    opening: usize,
    /// The opening's time offset, seconds.
    delay: f64,
    /// Carried back from the there side (T⁻¹) rather than through (T).
    back: bool,
}

impl ObjectMotion {
    /// The object at its own transform.
    pub fn new(own: AnimatedTransform) -> Self {
        Self { own, through: None }
    }

    /// The object's there-side copy through `opening` of `rig`, whose rays are shifted later by
    /// `delay` seconds.
    pub fn through(own: AnimatedTransform, rig: Arc<Rig>, opening: usize, delay: f64) -> Self {
        Self::carried(own, rig, opening, delay, false)
    }

    /// The here-side copy, back through `opening` of `rig`, of a there-side object at `own`;
    /// rays entering the opening see the there side later by `delay` seconds.
    pub fn back_through(own: AnimatedTransform, rig: Arc<Rig>, opening: usize, delay: f64) -> Self {
        Self::carried(own, rig, opening, delay, true)
    }

    fn carried(
        own: AnimatedTransform,
        rig: Arc<Rig>,
        opening: usize,
        delay: f64,
        back: bool,
    ) -> Self {
        let through = Some(Carried {
            rig,
            opening,
            delay,
            back,
        });
        Self { own, through }
    }

    /// The placement at time `t` (seconds).
    pub fn at(&self, t: f64) -> Similarity {
        match &self.through {
            None => self.own.at(t),
            Some(c) if c.back => {
                let teleport = c.rig.teleport_at(c.opening, t);
                solve_here(&teleport, &self.own.at(self.source_time(t)))
            }
            Some(c) => solve_there(
                &c.rig.teleport_at(c.opening, t),
                &self.own.at(self.source_time(t)),
            ),
        }
    }

    /// The time at which the object itself is read for this placement at time `t`: a copy
    /// through an opening that delays rays shows the object that much earlier, one carried
    /// back that much later (its shape, where it deforms, is taken then too).
    #[inline]
    pub fn source_time(&self, t: f64) -> f64 {
        match &self.through {
            None => t,
            Some(c) if c.back => t + c.delay,
            Some(c) => t - c.delay,
        }
    }

    /// The interval of [`Self::source_time`] over `times`.
    pub fn source_times(&self, times: [f64; 2]) -> [f64; 2] {
        times.map(|t| self.source_time(t))
    }

    /// Times where the placement may bend (keys of the transform and of the rig's frames).
    pub fn key_times(&self) -> Vec<f64> {
        let delay = self
            .through
            .as_ref()
            .map_or(0.0, |c| if c.back { -c.delay } else { c.delay });
        let mut times: Vec<f64> = self.own.keys().iter().map(|k| k.time + delay).collect();
        if let Some(c) = &self.through {
            for o in &c.rig.openings {
                times.extend(o.here.keys().iter().map(|k| k.time));
                if let ThereFrame::Explicit(t) = &o.there {
                    times.extend(t.keys().iter().map(|k| k.time));
                }
            }
        }
        times
    }

    /// True when the placement is not the same at every time in `interval`.
    pub fn moves_during(&self, interval: [f64; 2]) -> bool {
        let still = self.own.is_static() && self.through.as_ref().is_none_or(|c| c.rig.is_static());
        !still && changes_during(|t| self.at(t), &self.key_times(), interval)
    }
}

/// True when `at` is not the same at every time in `interval`. Sampled at the ends, at `keys`
/// inside and at interior points, so a segment that leaves and comes back still counts.
pub fn changes_during(at: impl Fn(f64) -> Similarity, keys: &[f64], interval: [f64; 2]) -> bool {
    let first = at(interval[0]);
    let keys_inside = keys
        .iter()
        .copied()
        .filter(|&t| t > interval[0] && t < interval[1]);
    (1..=8)
        .map(|i| interval[0] + (interval[1] - interval[0]) * i as f64 / 8.0)
        .chain(keys_inside)
        .any(|t| at(t) != first)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use rift_fx::rig::{Interpolation, Opening, TransformKey};

    fn keyed(points: &[(f64, DVec3)]) -> AnimatedTransform {
        AnimatedTransform::new(
            points
                .iter()
                .map(|&(time, p)| TransformKey {
                    time,
                    value: Similarity::from_translation(p),
                })
                .collect(),
            Interpolation::Linear,
        )
    }

    fn rig(there: AnimatedTransform) -> Arc<Rig> {
        Arc::new(Rig {
            openings: vec![Opening {
                name: "A".into(),
                here: AnimatedTransform::constant(Similarity::IDENTITY),
                there: ThereFrame::Explicit(there),
            }],
        })
    }

    #[test]
    fn a_carried_copy_is_the_solved_frame_of_the_object_a_delay_earlier() {
        let own = keyed(&[(0.0, DVec3::ZERO), (1.0, DVec3::new(1.0, 0.0, 0.0))]);
        let there = keyed(&[
            (0.0, DVec3::new(0.0, 5.0, 0.0)),
            (1.0, DVec3::new(0.0, 7.0, 0.0)),
        ]);
        let copy = ObjectMotion::through(own.clone(), rig(there.clone()), 0, 0.25);
        for t in [0.3, 0.5, 0.9] {
            let expected = there.at(t).compose(&own.at(t - 0.25));
            assert!(copy.at(t).distance(&expected, 1.0) < 1e-12, "t = {t}");
        }
        assert!(copy.moves_during([0.4, 0.6]));
        // Still object, still rig: nothing moves; a moving rig alone moves the copy.
        let still = AnimatedTransform::constant(Similarity::IDENTITY);
        let fixed_there = AnimatedTransform::constant(Similarity::from_translation(DVec3::Y));
        assert!(
            !ObjectMotion::through(still.clone(), rig(fixed_there), 0, 0.25)
                .moves_during([0.0, 1.0])
        );
        assert!(ObjectMotion::through(still.clone(), rig(there), 0, 0.0).moves_during([0.4, 0.6]));
        assert!(!ObjectMotion::new(still).moves_during([0.0, 1.0]));
    }

    #[test]
    fn a_copy_carried_back_is_where_a_ray_through_the_opening_meets_the_target() {
        let target = keyed(&[
            (0.0, DVec3::new(0.0, 5.0, -1.0)),
            (1.0, DVec3::new(1.0, 6.0, -1.0)),
        ]);
        let there = keyed(&[
            (0.0, DVec3::new(0.0, 5.0, 0.0)),
            (1.0, DVec3::new(0.0, 7.0, 0.0)),
        ]);
        let rig = rig(there);
        let back = ObjectMotion::back_through(target.clone(), rig.clone(), 0, 0.25);
        for t in [0.1, 0.5, 0.7] {
            // Carried through again (where the opening delays rays, by the same delay), the
            // here-side copy lands on the target.
            let teleport = rig.teleport_at(0, t);
            let again = solve_there(&teleport, &back.at(t));
            assert!(again.distance(&target.at(t + 0.25), 1.0) < 1e-12, "t = {t}");
        }
        assert!(back.moves_during([0.4, 0.6]));
        // Its keys move with the delay the other way.
        assert_eq!(back.key_times()[..2], [-0.25, 0.75]);
    }
}
