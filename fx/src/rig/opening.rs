//! Portal openings and the teleportal constraint solver.
//!
//! An opening has a *here* frame P_H (the opening lies in its local XY plane, front along +Z) and a
//! *there* frame P_T. A ray entering the front of *here* continues from *there* transformed by
//! T = P_T · P_H⁻¹. Two openings A, B are *paired* when A's there frame is B's here frame turned
//! half a turn about local Y (and vice versa), so a ray entering A's front leaves B's front.
//!
//! Constraint solver: a here-side frame M_H has the there-side copy M_T = T · M_H; a there-side
//! frame M_T has the here-side copy M_H = T⁻¹ · M_T.

use super::keyframes::AnimatedTransform;
use super::similarity::Similarity;

/// Where an opening leads.
#[derive(Clone, Debug, PartialEq)]
pub enum ThereFrame {
    /// An explicit, keyframed there frame.
    Explicit(AnimatedTransform),
    /// The here frame of another opening (index into the rig), turned half a turn about Y.
    Paired(usize),
}

/// One portal opening.
#[derive(Clone, Debug, PartialEq)]
pub struct Opening {
    pub name: String,
    pub here: AnimatedTransform,
    pub there: ThereFrame,
}

/// All openings of a shot, with pairings resolved.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Rig {
    pub openings: Vec<Opening>,
}

impl Rig {
    /// Two still openings, "A" at `a` and "B" at `b`, each the other's way out.
    pub fn still_pair(a: Similarity, b: Similarity) -> Self {
        let opening = |name: &str, frame, pair| Opening {
            name: name.into(),
            here: AnimatedTransform::constant(frame),
            there: ThereFrame::Paired(pair),
        };
        Self {
            openings: vec![opening("A", a, 1), opening("B", b, 0)],
        }
    }

    /// Index of the opening called `name`.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.openings.iter().position(|o| o.name == name)
    }

    /// P_H of opening `i` at time `t`.
    pub fn here_at(&self, i: usize, t: f64) -> Similarity {
        self.openings[i].here.at(t)
    }

    /// P_T of opening `i` at time `t`.
    pub fn there_at(&self, i: usize, t: f64) -> Similarity {
        match &self.openings[i].there {
            ThereFrame::Explicit(anim) => anim.at(t),
            ThereFrame::Paired(j) => self.here_at(*j, t) * Similarity::half_turn_y(),
        }
    }

    /// T = P_T · P_H⁻¹ of opening `i` at time `t`.
    pub fn teleport_at(&self, i: usize, t: f64) -> Similarity {
        self.there_at(i, t) * self.here_at(i, t).inverse()
    }

    /// True when no frame of the rig moves, so teleports can be computed once.
    pub fn is_static(&self) -> bool {
        self.openings.iter().all(|o| {
            o.here.is_static()
                && match &o.there {
                    ThereFrame::Explicit(a) => a.is_static(),
                    ThereFrame::Paired(_) => true,
                }
        })
    }
}

/// The there-side copy of a here-side frame: M_T = T · M_H.
pub fn solve_there(teleport: &Similarity, here_side: &Similarity) -> Similarity {
    teleport.compose(here_side)
}

/// The here-side copy of a there-side frame: M_H = T⁻¹ · M_T.
pub fn solve_here(teleport: &Similarity, there_side: &Similarity) -> Similarity {
    teleport.inverse().compose(there_side)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DQuat, DVec3};

    fn pair() -> Rig {
        let a = Similarity::new(DQuat::from_rotation_y(0.4), DVec3::new(-2.0, 1.0, 0.0), 1.0);
        let b = Similarity::new(
            DQuat::from_rotation_x(-0.3),
            DVec3::new(5.0, 1.5, -3.0),
            2.0,
        );
        Rig::still_pair(a, b)
    }

    #[test]
    fn paired_teleports_are_inverse_and_front_to_front() {
        let rig = pair();
        let ta = rig.teleport_at(0, 0.0);
        let tb = rig.teleport_at(1, 0.0);
        assert!((ta * tb).distance(&Similarity::IDENTITY, 10.0) < 1e-12);
        // A ray going into A's front (along A's −Z) leaves B along B's +Z (out of its front).
        let into_a = rig.here_at(0, 0.0).transform_direction(-DVec3::Z);
        let out_b = rig.here_at(1, 0.0).transform_direction(DVec3::Z);
        assert!((ta.transform_direction(into_a) - out_b).length() < 1e-12);
        // A's centre arrives at B's centre.
        let centre = ta.transform_point(rig.here_at(0, 0.0).translation);
        assert!((centre - rig.here_at(1, 0.0).translation).length() < 1e-12);
    }

    #[test]
    fn solver_round_trips() {
        let rig = pair();
        let t = rig.teleport_at(0, 0.0);
        let m = Similarity::new(DQuat::from_rotation_z(1.0), DVec3::new(0.3, 0.2, 4.0), 0.7);
        let back = solve_here(&t, &solve_there(&t, &m));
        assert!(back.distance(&m, 10.0) < 1e-12);
    }
}
