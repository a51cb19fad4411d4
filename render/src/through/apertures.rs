//! The openings as light sampling through them sees them: per opening, its teleport region's
//! bounding sphere and area, the teleport, its exit and what the exit passes on (measured once
//! per scene, [`crate::prepare::exits`]), gathered in the tree the strategy search walks
//! ([`crate::through::aperture_tree`]).

use crate::color::luminance;
use crate::portals::Portals;
use crate::through::aperture_tree::{ApertureTree, Placed};
use glam::{DVec3, Vec3};
use rift_fx::rig::Similarity;
use std::borrow::Cow;

/// One opening's exit, measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExitLight {
    /// About π times the mean irradiance over the exit from the side rays leave into (the light
    /// tree's units, so it weighs against ordinary light sampling's estimate).
    pub light: f32,
    /// The share of `light` that comes from the environment.
    pub sky_share: f32,
}

/// The openings as the strategy search sees them, built once per scene.
pub struct Apertures {
    /// Per opening that stands still (a moving one's is built at each ray's time).
    still: Vec<Option<Aperture>>,
    /// What each opening's exit passes on.
    pub(super) exits: Vec<ExitLight>,
    /// Per opening, the most light (times their factor) that the exit of any opening a ray
    /// can meet beyond it passes on: what bounds the chains that one more opening would add
    /// ([`brightest_beyond`]).
    pub(super) beyond: Vec<f32>,
    /// The usable openings as the search visits them.
    pub(super) tree: ApertureTree,
}

impl Apertures {
    /// The openings of `portals`, whose exits pass on `exits` (one per opening, as
    /// [`crate::prepare::exits::measure`] measures them); rays found walls between the pairs
    /// of [`facing_pairs`] listed in `walled_off`.
    pub fn new(portals: &Portals, exits: Vec<ExitLight>, walled_off: &[(u32, u32)]) -> Self {
        debug_assert_eq!(exits.len(), portals.len());
        let (still, factors) = still_and_factors(portals);
        let usable = (0..portals.len()).filter(|&i| factors[i] > 0.0);
        let (placed, moving) =
            usable.fold((Vec::new(), Vec::new()), |(mut placed, mut moving), i| {
                match &still[i] {
                    Some(a) => placed.push(Placed {
                        opening: i as u32,
                        centre: a.centre,
                        radius: a.radius,
                        area: a.area,
                    }),
                    None => moving.push(i as u32),
                }
                (placed, moving)
            });
        let light: Vec<f32> = (0..exits.len())
            .map(|i| exits[i].light * factors[i])
            .collect();
        let beyond = brightest_beyond(&still, &light, walled_off);
        let mut tree = ApertureTree::new(placed, moving);
        tree.set_light(|i| (light[i], factors[i] * beyond[i]));
        Self {
            still,
            exits,
            beyond,
            tree,
        }
    }

    /// Makes the strategy search walk every opening, without the tree's bounds: what the
    /// bounds must not change (for tests).
    #[doc(hidden)]
    pub fn search_every_opening(&mut self) {
        self.tree = self.tree.flattened();
    }

    /// True when opening `i` stands still.
    pub fn stands_still(&self, i: usize) -> bool {
        self.still.get(i).is_some_and(Option::is_some)
    }

    /// How many openings stand still and can be sampled through.
    pub fn still_count(&self) -> usize {
        self.tree.still_count()
    }

    /// What each opening's exit passes on, as the strategy search weighs it.
    pub fn exits(&self) -> &[ExitLight] {
        &self.exits
    }

    /// Opening `i` at `time`, borrowed where it stands still (copying it costs more
    /// than the test that reads it).
    #[inline]
    pub(super) fn get(&self, portals: &Portals, i: usize, time: f64) -> Cow<'_, Aperture> {
        match &self.still[i] {
            Some(still) => Cow::Borrowed(still),
            None => Cow::Owned(Aperture::new(portals, i, time)),
        }
    }
}

/// Per opening of `portals`, its aperture where it stands still, and its factor
/// ([`light_factor`]).
fn still_and_factors(portals: &Portals) -> (Vec<Option<Aperture>>, Vec<f32>) {
    let times = portals.times();
    let still = (0..portals.len())
        .map(|i| (!portals.opening_moves(i)).then(|| Aperture::new(portals, i, times[0])))
        .collect();
    let factors = (0..portals.len())
        .map(|i| light_factor(portals, i))
        .collect();
    (still, factors)
}

/// The pairs of usable still openings of `portals` (from, to) placed so that a ray leaving
/// `from`'s exit could meet `to` (see [`brightest_beyond`]), for rays to test whether walls
/// stand between ([`crate::prepare::exits::walled_off`]); none past [`WALL_TEST_PAIRS`] pairs.
pub fn facing_pairs(portals: &Portals) -> Vec<(u32, u32)> {
    let n = portals.len();
    if n * n > WALL_TEST_PAIRS {
        return Vec::new();
    }
    let (still, factors) = still_and_factors(portals);
    let usable = |i: usize| factors[i] > 0.0;
    let mut pairs = Vec::new();
    for (i, from) in still.iter().enumerate().filter(|&(i, _)| usable(i)) {
        let Some(from) = from else {
            continue;
        };
        for (j, to) in still.iter().enumerate().filter(|&(j, _)| usable(j)) {
            if to.as_ref().is_some_and(|to| can_meet(from, to)) {
                pairs.push((i as u32, j as u32));
            }
        }
    }
    pairs
}

/// Per opening, the most of `light` (each opening's factor × what its exit passes on) among
/// the openings a ray leaving its exit could meet: those whose disk reaches in front of the
/// exit ([`can_meet`]) and that rays did not find `walled_off` from it. An opening in the
/// exit's own wall cannot be met (rays leave that plane), so a room's windows do not promise
/// each other's light, nor the windows of a room beyond walls. Openings that move promise
/// theirs to all, and past [`BEYOND_PAIRS`] pairs every opening promises the brightest exit.
fn brightest_beyond(
    still: &[Option<Aperture>],
    light: &[f32],
    walled_off: &[(u32, u32)],
) -> Vec<f32> {
    let brightest = light.iter().copied().fold(0.0, f32::max);
    if still.len() * still.len() > BEYOND_PAIRS {
        return vec![brightest; still.len()];
    }
    let walled_off: std::collections::HashSet<(u32, u32)> = walled_off.iter().copied().collect();
    let reachable = |i: usize, from: &Aperture, j: usize, to: &Option<Aperture>| match to {
        None => true,
        Some(to) => can_meet(from, to) && !walled_off.contains(&(i as u32, j as u32)),
    };
    (still.iter().enumerate())
        .map(|(i, from)| match from {
            None => brightest,
            Some(from) => (still.iter().zip(light).enumerate())
                .filter(|(j, (to, _))| reachable(i, from, *j, to))
                .fold(0.0f32, |most, (_, (_, &l))| most.max(l)),
        })
        .collect()
}

/// True when `to`'s disk reaches in front of `from`'s exit, where a ray leaving the exit
/// could meet it.
fn can_meet(from: &Aperture, to: &Aperture) -> bool {
    let exit = &from.exit;
    let tilt = (1.0 - to.front.dot(exit.leaving).powi(2)).max(0.0).sqrt();
    let offset = to.centre - exit.centre;
    // Openings in the exit's plane up to rounding count as in it.
    offset.dot(exit.leaving) + to.radius * tilt > 1e-9 * (offset.length() + to.radius)
}

/// The most pairs of openings tested with rays for walls between them ([`facing_pairs`]):
/// 256 openings.
const WALL_TEST_PAIRS: usize = 1 << 16;

/// The most pairs of openings [`brightest_beyond`] tests.
const BEYOND_PAIRS: usize = 1 << 24;

/// One opening at one time: what deciding whether light can come through it needs.
#[derive(Clone)]
pub(super) struct Aperture {
    /// Opacity × luminance of tint; 0 when light sampling does not look through it (an ior
    /// other than 1, opaque or black).
    pub factor: f32,
    pub centre: DVec3,
    /// Unit normal of the front (rays going against it teleport).
    pub front: DVec3,
    /// Bounding radius and area of the teleport region, in world units.
    pub radius: f64,
    pub area: f64,
    /// The teleport of rays that meet it (to the exit time).
    pub teleport: Similarity,
    pub exit: Exit,
}

/// Where rays leave an opening.
#[derive(Clone, Copy)]
pub(super) struct Exit {
    pub centre: DVec3,
    /// Bounding radius of its mask.
    pub radius: f64,
    /// Unit direction rays leave in.
    pub leaving: DVec3,
}

/// Opacity × luminance of tint of opening `i`; 0 when light sampling does not look through it
/// (an ior other than 1, opaque or black).
fn light_factor(portals: &Portals, i: usize) -> f32 {
    let look = portals.look(i);
    let usable = look.ior == 1.0 && look.opacity > 0.0 && look.tint != Vec3::ZERO;
    if usable {
        look.opacity * luminance(look.tint)
    } else {
        0.0
    }
}

impl Aperture {
    pub(super) fn new(portals: &Portals, i: usize, time: f64) -> Self {
        // Each frame evaluated once (a moving opening interpolates its keys for each): the
        // teleport is P_T at the exit time ∘ P_H⁻¹.
        let here = portals.here(i, time);
        let there = portals.there(i, portals.exit_time(i, time));
        let teleport = there.compose(&here.inverse());
        let mask = portals.mask(i);
        Self {
            factor: light_factor(portals, i),
            centre: here.translation,
            front: here.transform_direction(DVec3::Z),
            radius: mask.bounding_radius() * here.scale,
            area: mask.area() * here.scale * here.scale,
            teleport,
            exit: Exit {
                centre: there.translation,
                radius: mask.bounding_radius() * there.scale,
                leaving: there.transform_direction(-DVec3::Z),
            },
        }
    }
}
