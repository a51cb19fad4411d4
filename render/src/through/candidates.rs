//! Which openings the strategy search tries first at a shading point where many compete
//! ([`crate::through::strategies`]): per cell of the light-visibility grid and per facing of the surface
//! (the axis its normal leans along most, either way, or no surface), the first openings of
//! the chains that a whole search keeps at the cell's corners, with normals spread over the
//! facing, the most promising [`MAX_LISTED`] of them. A cell's list is built when a point in
//! it first needs it.
//!
//! Without it, every shading point in a room with a wall of windows walks the aperture tree,
//! and where the windows lie close together the tree's bounds rule few of them out: more than
//! half the render time of a room lit through sixteen windows went to that walk, and a room
//! with 64 windows renders in half the time with the lists, as noisy. The list depends on
//! the cell and facing alone, so light sampling and the MIS weights that replay the same
//! strategies agree; a chain the list leaves out at some point is found there by BSDF
//! sampling, as light through any opening that light sampling does not look through is. A poor
//! list costs noise, never bias.

use crate::lights::Receiver;
use crate::through::View;
use crate::through::apertures::Apertures;
use crate::through::light_visibility::Cells;
use crate::through::strategies::Strategies;
use glam::Vec3;
use std::sync::OnceLock;

/// The most openings listed per cell and facing. A scene with no more still openings than
/// this searches them all at every point, through the tree.
pub const MAX_LISTED: usize = 24;
/// Facings: the six axis directions, then points with no surface (in a medium).
const FACINGS: usize = 7;

/// One cell and facing's openings.
#[derive(Clone, Copy, Debug, Default)]
struct Listed {
    openings: [u16; MAX_LISTED],
    len: u8,
}

/// The candidates per cell and facing, each built on first use.
#[derive(Debug)]
pub struct OpeningCandidates {
    cells: Cells,
    /// When the search at a cell's points looks (still openings do not change with it).
    time: f64,
    lists: Vec<OnceLock<Listed>>,
}

impl OpeningCandidates {
    /// For the openings of `apertures` on the grid of `cells` (none without a grid), the
    /// search looking at `time`; `None` where there is no grid or no more than [`MAX_LISTED`]
    /// still openings.
    pub fn new(apertures: &Apertures, cells: Option<&Cells>, time: f64) -> Option<Self> {
        if apertures.still_count() <= MAX_LISTED {
            return None;
        }
        let cells = *cells?;
        Some(Self {
            cells,
            time,
            lists: (0..cells.count() * FACINGS)
                .map(|_| OnceLock::new())
                .collect(),
        })
    }

    /// The still openings a chain's first opening is taken from at `at`.
    pub fn at(&self, view: &View, at: &Receiver) -> &[u16] {
        let (cell, facing) = (self.cells.of(at.p), facing(at.n));
        let list = self.lists[cell * FACINGS + facing]
            .get_or_init(|| self.build(view, cell as u32, facing));
        &list.openings[..list.len as usize]
    }

    /// The list of `cell` for `facing`: the still openings that begin the chains a whole
    /// search keeps at the cell's corners (with each of the facing's normals), by the largest
    /// share any of them gets there.
    fn build(&self, view: &View, cell: u32, facing: usize) -> Listed {
        let (corner, size) = (self.cells.corner(cell), self.cells.size());
        let corners =
            (0..8u32).map(|k| Vec3::new((k & 1) as f32, (k >> 1 & 1) as f32, (k >> 2) as f32));
        let mut best: Vec<(u16, f32)> = Vec::new();
        let mut strategies = None;
        let normals = facing_normals(facing);
        for (place, normal) in corners.flat_map(|c| normals.iter().map(move |&n| (c, n))) {
            let receiver = Receiver {
                p: corner + size * place,
                n: normal,
                time: self.time,
            };
            Strategies::search(&mut strategies, view, &receiver, None);
            for (chain, share) in strategies.iter().flat_map(Strategies::chains) {
                let Some(first) = chain.openings().next() else {
                    continue;
                };
                if !view.survey.apertures.stands_still(first) {
                    continue;
                }
                match best.iter_mut().find(|(i, _)| *i as usize == first) {
                    Some((_, most)) => *most = most.max(share),
                    None => best.push((first as u16, share)),
                }
            }
        }
        best.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        let mut listed = Listed::default();
        for (slot, (i, _)) in listed.openings.iter_mut().zip(&best) {
            *slot = *i;
            listed.len += 1;
        }
        listed
    }
}

/// The facing of a surface with normal `n`: 2·axis for the axis it leans along most, plus 1
/// when it points down that axis; 6 without a surface.
fn facing(n: Option<Vec3>) -> usize {
    let Some(n) = n else {
        return FACINGS - 1;
    };
    let a = n.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    2 * axis + usize::from(n[axis] < 0.0)
}

/// The normals a cell's search takes for `facing` (see [`facing`]): its axis and the four
/// halfway to the neighbouring axes, which span the normals that lean along it most (points
/// whose normal leans between them may keep other chains: about one in twenty, in a room
/// with a wall of 30 windows); none without a surface.
fn facing_normals(facing: usize) -> Vec<Option<Vec3>> {
    if facing == FACINGS - 1 {
        return vec![None];
    }
    let axis = facing / 2;
    let n = Vec3::AXES[axis] * if facing.is_multiple_of(2) { 1.0 } else { -1.0 };
    let (a, b) = (Vec3::AXES[(axis + 1) % 3], Vec3::AXES[(axis + 2) % 3]);
    [n, n + a, n - a, n + b, n - b]
        .map(|m| Some(m.normalize()))
        .to_vec()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_axis_normal_is_its_own_facing() {
        for f in 0..FACINGS {
            assert_eq!(facing(facing_normals(f)[0]), f);
        }
        assert_eq!(facing(Some(Vec3::new(0.3, -0.9, 0.2))), 3);
        assert_eq!(facing(Some(Vec3::new(0.1, 0.2, -0.97))), 5);
        assert!(facing(Some(Vec3::NAN)) < FACINGS);
    }

    #[test]
    fn a_facings_normals_lean_at_most_halfway_from_its_axis() {
        for f in 0..FACINGS - 1 {
            let normals = facing_normals(f);
            let axis = normals[0].unwrap();
            for n in normals.iter().map(|n| n.unwrap()) {
                assert!((n.length() - 1.0).abs() < 1e-6);
                assert!(
                    n.dot(axis) >= std::f32::consts::FRAC_1_SQRT_2 - 1e-6,
                    "{f}: {n}"
                );
            }
        }
        assert_eq!(facing_normals(FACINGS - 1), vec![None]);
    }
}
