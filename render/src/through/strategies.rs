//! Light sampling through openings: where next-event estimation looks for light.
//!
//! A ray that teleports through openings a, b, … continues on the straight line that the
//! composed teleport S = S_b ∘ S_a (each S = P_T · P_H⁻¹ at the ray's times) makes of it. So
//! the light that a shading point p receives through that chain is the light that the virtual
//! point S(p) receives in the space beyond it, restricted to the directions that pass every
//! opening's mask. Similarities keep solid angles, so a light sample drawn for S(p) has the same
//! solid-angle pdf at p, and its direction maps back to p by S's rotation.
//!
//! At each shading point [`Strategies::update`] lists the ways to sample light: ordinary light
//! sampling, and one *virtual space* per chain of up to [`CHAIN_DEPTH`] openings (never past
//! `max_portal_depth`) whose front the point faces, whose aperture is above its surface and,
//! for a second opening, which can be seen through the first. Each gets a probability in
//! proportion to an estimate of what it brings:
//!
//! - ordinary: the light tree's unoccluded estimate at p (plus the environment's), times the
//!   share of ordinary light sampling that walls do not block around p
//!   ([`crate::through::light_visibility`]), so a closed room lit through a window spends its samples
//!   on the window;
//! - a chain: the product of its openings' opacity × tint, times the aperture bound
//!   Ω · E_exit / π, where Ω is the smallest projected solid angle of the chain's openings seen
//!   along the way (capped at 2π) and E_exit what the last exit passes on, measured once per
//!   scene with ordinary light samples and their shadow rays ([`crate::prepare::exits`]).
//!
//! The six most promising chains are kept, each bringing at least `KEEP_SHARE` of the ordinary
//! estimate. A chain grows by a further opening only where the longer chains could bring a
//! noticeable share of the light (`DEEPER_SHARE`, bounded with the brightest exit an opening
//! beyond it leads to): a room lit through two openings in a row searches them, a room with
//! its own light does not pay for them. The openings come through a tree whose nodes bound
//! what their chains could bring ([`crate::through::aperture_tree`]), so a wall of windows costs the
//! windows that may be kept, not all of them; where more openings compete than that tree can
//! rule out, a point tries only its cell's candidates for the first opening
//! ([`crate::through::candidates`]).
//!
//! Openings behind the point, facing away, below its surface or hidden behind the previous
//! opening get no strategy at all, and a scene without openings has only the ordinary one: it
//! pays nothing. Nor do points where the strategies would save little over BSDF sampling
//! (openings that bring little light, or fill much of the view): a grid measured with the
//! scene tells where ([`crate::through::light_visibility`]).
//!
//! Openings with an index of refraction other than 1 bend light in a way that has no
//! closed-form inverse, so no chain passes them: light through them is found by BSDF sampling
//! alone, with full weight, as before.
//!
//! A chain's strategy draws most of its samples for the sky beyond on its first opening
//! ([`crate::through::aperture_sampling`]) rather than on the sky, when the sky brings much of the light there:
//! a window is a small part of the sky, so few of the sky's own samples pass it. The two are
//! one strategy with a mixture density.
//!
//! The probabilities enter the light-sampling density (q · pdf), so the MIS weight of emission
//! that BSDF sampling finds after the same chain of teleports uses [`Strategies::find`] at the
//! previous vertex, with the BSDF density times the chain's coin probabilities (opacity per
//! teleport, 1 − opacity per opening passed). Estimates may be poor without bias: every path is
//! still counted once.

use crate::lights::Receiver;
use crate::portals::Portals;
use crate::through::View;
use crate::through::aperture_sampling;
use crate::through::aperture_tree::{Bounds, Visitor};
use crate::through::apertures::{Aperture, Exit};
use glam::{DQuat, DVec3, Vec3};
use std::f64::consts::PI;

/// The most openings in a row that light sampling looks through. Longer chains (a corridor of
/// mirrors) are still lit, by BSDF sampling.
pub const CHAIN_DEPTH: usize = 2;
/// The most virtual spaces kept at one shading point (the most promising).
const MAX_SPACES: usize = 6;
/// A chain is extended by further openings only where the longer chains could bring at least
/// this share of what the point gets directly and through the chain itself (their bound takes
/// the brightest exit of all). Searching them costs as much as the first openings; where the
/// first openings' light dominates they change nothing: on the showcase, searching every
/// second opening took 7% of the render time and left the noise as it was.
const DEEPER_SHARE: f32 = 0.05;

/// A chain is kept only where it may bring at least this share of what ordinary light
/// sampling finds at the point: less is not worth its samples, and without that bar a lit room
/// searched every opening in sight for the few chains it keeps (a lamp room seeing a wall of 64
/// windows 46 m away through its own walls).
const KEEP_SHARE: f32 = 0.01;

/// The openings a path teleported through since its last scattering event, in order. Chains
/// order by their openings, which breaks ties between equal estimates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord)]
pub struct Chain {
    /// The first [`CHAIN_DEPTH`] openings (no strategy samples a longer chain).
    openings: [u16; CHAIN_DEPTH],
    /// Teleports in all, however many.
    teleports: u32,
}

impl Chain {
    /// Appends opening `i`.
    pub fn push(&mut self, i: usize) {
        if (self.teleports as usize) < CHAIN_DEPTH {
            self.openings[self.teleports as usize] = i as u16;
        }
        self.teleports += 1;
    }

    /// How many teleports the chain holds.
    pub fn teleports(&self) -> u32 {
        self.teleports
    }

    /// The openings, in the order a ray meets them (the first [`CHAIN_DEPTH`] of them).
    pub fn openings(&self) -> impl Iterator<Item = usize> + '_ {
        self.openings[..(self.teleports as usize).min(CHAIN_DEPTH)]
            .iter()
            .map(|&i| i as usize)
    }
}

/// The space beyond a chain of openings, as a shading point's light sampling sees it.
#[derive(Clone, Copy, Debug)]
pub struct Space {
    pub chain: Chain,
    /// The rotation of the composed teleport (directions at p to directions beyond).
    rotation: DQuat,
    /// The shading point mapped beyond the chain, with the last exit's outward normal (light
    /// can only come from that side) and the time after the chain's offsets.
    pub receiver: Receiver,
    /// Probability that the strategy draws a point on the chain's first opening, for the sky
    /// beyond ([`crate::through::aperture_sampling`]), rather than a light sample there: the sky's share of the
    /// light at the last exit, less where the openings fill much of the point's view (there
    /// the sky's own sampling finds them as often), and never above `MAX_APERTURE_SHARE`, so
    /// a sun behind a window is still sampled as a light.
    pub aperture: f32,
}

/// The largest share of a chain's samples drawn on its first opening.
const MAX_APERTURE_SHARE: f32 = 0.9;

impl Space {
    /// A direction beyond the chain brought back to the shading point.
    pub fn direction_back(&self, d: Vec3) -> Vec3 {
        (self.rotation.inverse() * d.as_dvec3())
            .normalize()
            .as_vec3()
    }

    /// A direction at the shading point taken beyond the chain.
    pub fn direction_beyond(&self, d: Vec3) -> Vec3 {
        (self.rotation * d.as_dvec3()).normalize().as_vec3()
    }

    /// The strategy's solid-angle density of a sample that light sampling beyond the chain
    /// draws with `light_pdf`; for the sky, `sky` gives the shading point and the direction
    /// there, whose aperture density adds to it.
    pub fn density(
        &self,
        portals: &Portals,
        light_pdf: f32,
        sky: Option<(&Receiver, Vec3)>,
    ) -> f32 {
        match sky {
            Some((at, dir)) if self.aperture > 0.0 => {
                let aperture_pdf =
                    aperture_sampling::pdf(portals, self.first(), at.time, at.p, dir);
                self.mixture(light_pdf, aperture_pdf)
            }
            _ => (1.0 - self.aperture) * light_pdf,
        }
    }

    /// The density of the sky in one direction when light sampling draws it with `light_pdf`
    /// and the first opening with `aperture_pdf`.
    pub fn mixture(&self, light_pdf: f32, aperture_pdf: f32) -> f32 {
        (1.0 - self.aperture) * light_pdf + self.aperture * aperture_pdf
    }

    /// The chain's first opening.
    pub fn first(&self) -> usize {
        self.chain.openings[0] as usize
    }
}

/// The ways light sampling can go at one shading point, with their probabilities.
#[derive(Clone, Copy, Debug)]
pub struct Strategies {
    /// Probability of ordinary light sampling.
    direct: f32,
    /// The shading point, from which a kept chain's [`Space`] is built when a sample or a
    /// weight needs it: most points take ordinary light sampling, and building every kept
    /// chain's space at every point took a third of the search.
    at: Receiver,
    kept: [Option<(Kept, f32)>; MAX_SPACES],
}

/// A chain kept at a shading point, with the share of its samples drawn on its first opening
/// ([`Space::aperture`]).
#[derive(Clone, Copy, Debug)]
struct Kept {
    chain: Chain,
    aperture: f32,
    /// The smallest projected solid angle of its openings seen from the point.
    solid_angle: f32,
}

impl Strategies {
    /// Sets `slot` to the strategies at `at` (world space, at its time) in a scene whose
    /// openings may bring light (`view`); `None` when there is only ordinary light sampling:
    /// light sampling through the openings is worth too little around the point to search them
    /// ([`crate::through::light_visibility::LightVisibility::worth_searching`]), or no opening
    /// can bring light to the point. Where many openings compete, the first opening of a chain
    /// is one of the point's candidates ([`crate::through::candidates`]).
    ///
    /// It fills the caller's slot rather than returning the table because the compiler copies
    /// a returned table even when it is `None` (when the table held whole spaces, half a
    /// kilobyte, that was 10% of the Cornell box's render time).
    #[inline]
    pub fn update(slot: &mut Option<Self>, view: &View, at: &Receiver) {
        let survey = view.survey;
        if survey.visibility.worth_searching(at.p) {
            let listed = survey.candidates.as_ref().map(|c| c.at(view, at));
            Self::search(slot, view, at, listed);
        } else {
            *slot = None;
        }
    }

    /// Fills `slot` with the strategies at `at` in a scene where openings may bring light,
    /// the chains' first openings among `listed` (and the moving ones) when given, else all.
    pub(crate) fn search(
        slot: &mut Option<Self>,
        view: &View,
        at: &Receiver,
        listed: Option<&[u16]>,
    ) {
        let table = slot.insert(Self {
            direct: 0.0,
            at: *at,
            kept: [None; MAX_SPACES],
        });
        let depth = CHAIN_DEPTH.min(view.max_depth as usize);
        let direct = view.lights.importance(at) * view.survey.visibility.at(at.p);
        table.extend(view, &Reach::start(at), depth, direct, listed);
        if !table.normalise(direct) {
            *slot = None;
        }
    }

    /// Keeps the chains that extend `from` by one opening, and by up to `depth` − 1 more
    /// where they may bring enough beside the point's `direct` estimate ([`DEEPER_SHARE`]).
    /// The openings come through [`crate::through::aperture_tree::ApertureTree`], which skips those whose bounds show they
    /// could not change what is kept. The longer chains are searched once this level's are
    /// kept, the most promising first, so that their searches skip what cannot beat those.
    /// With `listed`, this level takes those still openings rather than the tree's.
    fn extend(
        &mut self,
        view: &View,
        from: &Reach,
        depth: usize,
        direct: f32,
        listed: Option<&[u16]>,
    ) {
        // What the last exit lets the point see, once for every opening tested beyond it.
        let cone = from
            .exit
            .as_ref()
            .map(|exit| ExitCone::new(exit, from.point));
        let mut search = Search {
            table: self,
            view,
            from,
            cone: cone.as_ref(),
            depth,
            direct,
            deeper: [None; MAX_SPACES],
        };
        match listed {
            Some(listed) => view.survey.apertures.tree.visit_listed(listed, &mut search),
            None => view.survey.apertures.tree.visit(&mut search),
        }
        let deeper = search.deeper;
        for (bound, i, solid_angle) in deeper.into_iter().flatten() {
            if !self.would_keep(bound, direct) {
                continue;
            }
            let (portals, apertures) = (view.portals, &view.survey.apertures);
            let aperture = apertures.get(portals, i as usize, from.time);
            let exit_time = portals.exit_time(i as usize, from.time);
            let reach = from.beyond(&aperture, i as usize, exit_time, solid_angle);
            self.extend(view, &reach, depth - 1, direct, None);
        }
    }

    /// True when a chain with `estimate` would be among the [`MAX_SPACES`] kept, at a point
    /// whose ordinary light sampling's estimate is `direct` ([`KEEP_SHARE`]).
    fn would_keep(&self, estimate: f32, direct: f32) -> bool {
        estimate >= KEEP_SHARE * direct
            && self.kept[MAX_SPACES - 1].is_none_or(|(_, kept)| kept <= estimate)
    }

    /// Keeps `chain` if it is among the [`MAX_SPACES`] most promising so far, in order of
    /// estimate; ties go to the lesser chain, so what is kept does not depend on the order in
    /// which the search meets the chains.
    fn keep(&mut self, chain: Kept, estimate: f32) {
        let kept = &mut self.kept;
        let Some(at) = kept.iter().position(|s| {
            s.is_none_or(|(other, other_estimate)| {
                other_estimate < estimate
                    || (other_estimate == estimate && chain.chain < other.chain)
            })
        }) else {
            return;
        };
        // Shift the rest down one place, the last dropping out: a plain loop over at most
        // five entries, where `rotate_right` was a library call that cost 1% of the showcase.
        for k in (at + 1..MAX_SPACES).rev() {
            kept[k] = kept[k - 1];
        }
        kept[at] = Some((chain, estimate));
    }

    /// Turns the kept estimates and ordinary sampling's `direct` into probabilities; false
    /// when there is nothing to choose between.
    fn normalise(&mut self, direct: f32) -> bool {
        let total = direct + self.kept.iter().flatten().map(|s| s.1).sum::<f32>();
        if !(total > 0.0 && total.is_finite()) || self.kept[0].is_none() {
            return false;
        }
        self.direct = direct / total;
        for (_, q) in self.kept.iter_mut().flatten() {
            *q /= total;
        }
        true
    }

    /// The probability of ordinary light sampling.
    pub fn direct(&self) -> f32 {
        self.direct
    }

    /// What the chains' strategies save over finding their light by BSDF sampling alone, in
    /// units of the point's light squared: per chain, its share q squared times the relative
    /// variance with which cosine sampling finds an opening of projected solid angle Ω
    /// (π / Ω − 1). Small where the openings bring little or fill much of the view.
    pub fn worth(&self) -> f32 {
        self.kept
            .iter()
            .flatten()
            .map(|(kept, q)| q * q * (std::f32::consts::PI / kept.solid_angle - 1.0).max(0.0))
            .sum()
    }

    /// The chains light sampling may take, with their probabilities, the most promising first.
    pub fn chains(&self) -> impl Iterator<Item = (Chain, f32)> + '_ {
        self.kept.iter().flatten().map(|(kept, q)| (kept.chain, *q))
    }

    /// Picks a strategy with `u` in [0, 1): `None` is ordinary light sampling, else the space
    /// beyond the chain picked. Returns its probability too.
    pub fn pick(&self, view: &View, u: f32) -> (Option<Space>, f32) {
        let mut below = self.direct;
        if u < below || self.kept[0].is_none() {
            return (None, self.direct);
        }
        let mut last = None;
        for (kept, q) in self.kept.iter().flatten() {
            below += q;
            last = Some((kept, *q));
            if u < below {
                break;
            }
        }
        match last {
            Some((kept, q)) => (Some(self.space(view, kept)), q),
            None => (None, self.direct),
        }
    }

    /// The probability of the strategy that samples light through `chain` (ordinary light
    /// sampling for an empty chain), with its space; 0 when no strategy does.
    pub fn find(&self, view: &View, chain: &Chain) -> (f32, Option<Space>) {
        if *chain == Chain::default() {
            return (self.direct, None);
        }
        self.kept
            .iter()
            .flatten()
            .find(|(kept, _)| kept.chain == *chain)
            .map_or((0.0, None), |(kept, q)| (*q, Some(self.space(view, kept))))
    }

    /// The space beyond a kept chain: the shading point taken through its openings as a
    /// teleport takes it, at each opening's time.
    fn space(&self, view: &View, kept: &Kept) -> Space {
        let (portals, apertures) = (view.portals, &view.survey.apertures);
        let mut reach = Reach::start(&self.at);
        for i in kept.chain.openings() {
            let aperture = apertures.get(portals, i, reach.time);
            let exit_time = portals.exit_time(i, reach.time);
            reach = reach.beyond(&aperture, i, exit_time, f32::INFINITY);
        }
        Space {
            aperture: kept.aperture,
            chain: kept.chain,
            rotation: reach.rotation,
            receiver: Receiver {
                p: reach.point.as_vec3(),
                n: reach.normal.map(DVec3::as_vec3),
                time: reach.time,
            },
        }
    }
}

/// One level of the strategy search: the chains that extend `from` by one opening, taken
/// from the [`crate::through::aperture_tree::ApertureTree`] into `table`.
struct Search<'a> {
    table: &'a mut Strategies,
    view: &'a View<'a>,
    from: &'a Reach,
    cone: Option<&'a ExitCone>,
    depth: usize,
    direct: f32,
    /// The openings to search beyond once this level is done, the most promising first:
    /// the bound on what longer chains through each could bring, the opening, and its solid
    /// angle from the point.
    deeper: [Option<(f32, u16, f32)>; MAX_SPACES],
}

impl Search<'_> {
    /// Notes that the chains beyond opening `i` could bring up to `bound`; the most
    /// promising [`MAX_SPACES`] are searched (of equal bounds, the lesser openings).
    fn search_beyond(&mut self, bound: f32, i: usize, solid_angle: f32) {
        let deeper = &mut self.deeper;
        let Some(at) = deeper.iter().position(|d| {
            d.is_none_or(|(other, j, _)| other < bound || (other == bound && (i as u16) < j))
        }) else {
            return;
        };
        for k in (at + 1..MAX_SPACES).rev() {
            deeper[k] = deeper[k - 1];
        }
        deeper[at] = Some((bound, i as u16, solid_angle));
    }
}

/// Bounds are computed in another order than the estimates they bound; this much above them
/// covers the rounding.
const BOUND_SLACK: f32 = 1.001;

impl Visitor for Search<'_> {
    /// The most a chain through the node's openings, or any chain longer than that, could
    /// bring (the estimates of [`Search::opening`] with each factor at the node's largest and
    /// the solid angle of its largest opening at its nearest point); `None` where its
    /// openings lie wholly below the point's surface or outside what the last exit shows, or
    /// where nothing they could bring would be kept.
    fn priority(&self, bounds: &Bounds) -> Option<f32> {
        let from = self.from;
        let (centre, radius) = (bounds.centre, bounds.radius);
        let to = centre - from.point;
        if from.normal.is_some_and(|n| to.dot(n) + radius <= 0.0) {
            return None;
        }
        if let Some(cone) = self.cone
            && !cone.shows(centre, to, to.length(), radius)
        {
            return None;
        }
        let d2 = bounds.distance_squared(from.point);
        let largest_view = if d2 > 0.0 {
            (bounds.largest_area / d2).min(2.0 * PI)
        } else {
            2.0 * PI
        };
        let solid_angle = from.solid_angle.min(largest_view as f32);
        let pi = std::f32::consts::PI;
        let estimate = from.factor * bounds.brightest * solid_angle / pi;
        let deeper = from.factor * bounds.brightest_beyond * solid_angle / pi;
        let deeper = if self.depth > 1 && deeper >= DEEPER_SHARE * self.direct {
            deeper
        } else {
            0.0
        };
        let priority = estimate.max(deeper) * BOUND_SLACK;
        (priority > 0.0 && self.table.would_keep(priority, self.direct)).then_some(priority)
    }

    fn still_matters(&self, priority: f32) -> bool {
        self.table.would_keep(priority, self.direct)
    }

    /// Keeps the chain through opening `i` if it is among the most promising, and searches
    /// beyond it where longer chains could bring enough and be kept.
    fn opening(&mut self, i: usize) {
        let Self {
            view,
            from,
            cone,
            depth,
            direct,
            ..
        } = *self;
        let (portals, apertures) = (view.portals, &view.survey.apertures);
        let aperture = apertures.get(portals, i, from.time);
        let Some(solid_angle) = from.sees(&aperture, cone) else {
            return;
        };
        // What the chain would bring per unit of its exit's light.
        let reach_factor = from.factor * aperture.factor * from.solid_angle.min(solid_angle)
            / std::f32::consts::PI;
        let estimate = reach_factor * apertures.exits[i].light;
        let table = &mut *self.table;
        if estimate > 0.0 && estimate.is_finite() && table.would_keep(estimate, direct) {
            let mut chain = from.chain;
            chain.push(i);
            let smallest = from.solid_angle.min(solid_angle);
            let aperture = aperture_share(apertures.exits[i].sky_share, smallest);
            table.keep(
                Kept {
                    chain,
                    aperture,
                    solid_angle: smallest,
                },
                estimate,
            );
        }
        // Longer chains bring at most `reach_factor` times the brightest exit beyond.
        let deeper = reach_factor * apertures.beyond[i] * BOUND_SLACK;
        if depth > 1
            && deeper >= DEEPER_SHARE * (direct + estimate)
            && table.would_keep(deeper, direct)
        {
            self.search_beyond(deeper, i, solid_angle);
        }
    }
}

/// The share of a chain's samples drawn on its first opening ([`Space::aperture`]), where the
/// sky brings `sky_share` of the light at its last exit and its openings' smallest projected
/// solid angle is `solid_angle`.
fn aperture_share(sky_share: f32, solid_angle: f32) -> f32 {
    let open_view = (1.0 - solid_angle / (2.0 * std::f32::consts::PI)).max(0.0);
    (sky_share * open_view).min(MAX_APERTURE_SHARE)
}

/// A chain being extended while strategies are enumerated: where the shading point is in the
/// space reached so far, and what the chain has cost.
struct Reach {
    chain: Chain,
    /// Rotation of the composed teleport so far.
    rotation: DQuat,
    /// The shading point in the space reached, its normal there (the last exit's for a
    /// virtual point), and its time.
    point: DVec3,
    normal: Option<DVec3>,
    time: f64,
    /// Product of opacity × luminance of tint over the chain.
    factor: f32,
    /// The smallest projected solid angle of the chain's openings seen along the way.
    solid_angle: f32,
    /// The last exit.
    exit: Option<Exit>,
}

impl Reach {
    fn start(at: &Receiver) -> Self {
        Self {
            chain: Chain::default(),
            rotation: DQuat::IDENTITY,
            point: at.p.as_dvec3(),
            normal: at.n.map(Vec3::as_dvec3),
            time: at.time,
            factor: 1.0,
            solid_angle: f32::INFINITY,
            exit: None,
        }
    }

    /// The projected solid angle of aperture `a` (its bounding sphere) from the point, when
    /// light can come through it at all: it is usable, the point is in front of it, above the
    /// point's surface, and seen through the last exit (`cone`).
    #[inline(always)]
    fn sees(&self, a: &Aperture, cone: Option<&ExitCone>) -> Option<f32> {
        if a.factor <= 0.0 {
            return None;
        }
        let to_centre = a.centre - self.point;
        // The point's height above the opening's plane.
        let height = -to_centre.dot(a.front);
        if height <= 0.0 {
            return None; // behind the opening
        }
        let distance = to_centre.length();
        // Above the point's surface: some of the aperture's sphere is in front of it.
        let cos_receiver = match self.normal {
            Some(n) => ((to_centre.dot(n) + a.radius) / distance).min(1.0),
            None => 1.0,
        };
        if cos_receiver <= 0.0 {
            return None;
        }
        if let Some(cone) = cone
            && !cone.shows(a.centre, to_centre, distance, a.radius)
        {
            return None;
        }
        let cos_aperture = height / distance;
        Some(((a.area * cos_aperture / (distance * distance)).min(2.0 * PI) * cos_receiver) as f32)
    }

    /// The chain extended through opening `i` (seen as `a`, with `solid_angle`; rays leave it
    /// at `exit_time`).
    fn beyond(&self, a: &Aperture, i: usize, exit_time: f64, solid_angle: f32) -> Self {
        let mut chain = self.chain;
        chain.push(i);
        Self {
            chain,
            rotation: a.teleport.rotation * self.rotation,
            point: a.teleport.transform_point(self.point),
            normal: Some(a.exit.leaving),
            time: exit_time,
            factor: self.factor * a.factor,
            solid_angle: self.solid_angle.min(solid_angle),
            exit: Some(a.exit),
        }
    }
}

/// The directions from a point through an exit's bounding sphere: a cone.
struct ExitCone {
    exit: Exit,
    /// Unit axis, and the sine and cosine of the half angle; `None` when the point is inside
    /// the sphere (it sees through the exit every way).
    cone: Option<(DVec3, f64, f64)>,
}

impl ExitCone {
    fn new(exit: &Exit, point: DVec3) -> Self {
        let to_exit = exit.centre - point;
        let d = to_exit.length();
        let cone = (d > exit.radius).then(|| {
            let sin = exit.radius / d;
            (to_exit / d, sin, (1.0 - sin * sin).sqrt())
        });
        Self { exit: *exit, cone }
    }

    /// True when the sphere around `centre` of `radius` (at `to` from the point, `d` away)
    /// can be seen through the exit: it reaches the far side of the exit, and its cone from
    /// the point overlaps the exit's.
    fn shows(&self, centre: DVec3, to: DVec3, d: f64, radius: f64) -> bool {
        let exit = &self.exit;
        if (centre - exit.centre).dot(exit.leaving) < -radius {
            return false;
        }
        let Some((axis, sin_a, cos_a)) = self.cone else {
            return true;
        };
        if d <= radius {
            return true;
        }
        // angle ≤ a + b ⇔ cos(angle) ≥ cos a cos b − sin a sin b (a, b within [0, π/2]).
        let sin_b = radius / d;
        let cos_b = (1.0 - sin_b * sin_b).sqrt();
        axis.dot(to) / d >= cos_a * cos_b - sin_a * sin_b
    }
}
