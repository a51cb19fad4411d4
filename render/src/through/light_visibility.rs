//! How much of ordinary light sampling's estimate is not blocked, on a coarse grid over the
//! scene, to weigh it against light through openings; and, on the same cells, what light
//! sampling through the openings is worth there, which tells where searching them pays.
//! [`crate::prepare::visibility`] measures both.
//!
//! The light tree's estimate ignores occlusion: inside a closed room lit through a window, it
//! still counts the sky and the lamps behind the walls, and light sampling through the window
//! then gets few of the samples. Each cell of this grid traces a few ordinary light samples
//! from random points inside it and keeps the unblocked share of their contribution; the
//! strategy search scales the ordinary estimate by it. It only moves samples between
//! strategies, so a poor grid costs noise, never bias; a floor keeps some ordinary samples
//! wherever the probes saw nothing.
//!
//! The search for light through openings costs about a thousand instructions at every shading
//! point with a few openings, several times that where many windows compete (it visits the
//! ones that could be kept, [`crate::through::aperture_tree`]). Where the openings bring a small share of the light, or fill much of the view, BSDF
//! sampling finds their light nearly as well, and the search costs more time than it saves
//! noise: on the showcase, whose room is lit by its own rings and lamp through openings as
//! wide as a door, searching everywhere took 8% of the render time for 2% of the variance.
//! Each cell therefore also keeps the mean [`Strategies::worth`] at its probe points (the
//! variance the openings' strategies save over BSDF sampling, relative to the point's light
//! squared), and shading points in cells below [`SEARCH_WORTH`] sample ordinary light only;
//! BSDF sampling then weighs what it finds through openings fully, as where light sampling
//! does not look through them at all.

#[cfg(doc)]
use crate::through::Strategies;
use glam::{UVec3, Vec3};

/// Cells in the grid (about; its shape follows the scene's bounds). Fuzz builds, where
/// sanitizers make each probe some thirty times dearer, probe a coarse grid: the same code
/// runs, and an input no longer takes the fuzzer's whole timeout.
const CELLS: f32 = if cfg!(fuzzing) { 64.0 } else { 8192.0 };
/// What light sampling through the openings must be worth in a cell (the mean
/// [`Strategies::worth`] at its probe points) for shading points there to search them. On
/// the room lit through a window (`rift bench through`) a tenth keeps the error as it was,
/// and 0.3 raised it by a fifth; on the showcase, a tenth and above took 8% off the time.
pub const SEARCH_WORTH: f32 = 0.1;

/// A grid of boxes over the scene: the cells this module measures, which
/// [`crate::through::candidates`] shares.
#[derive(Clone, Copy, Debug, Default)]
pub struct Cells {
    lower: Vec3,
    /// Cell size along each axis.
    size: Vec3,
    dims: UVec3,
}

impl Cells {
    /// About [`CELLS`] cells over `bounds` (lower and upper corner); `None` for an infinite
    /// box.
    pub fn new(bounds: [Vec3; 2]) -> Option<Self> {
        let [lower, upper] = bounds;
        let extent = (upper - lower).max(Vec3::splat(1e-3));
        let dims = grid_shape(extent)?;
        Some(Self {
            lower,
            size: extent / dims.as_vec3(),
            dims,
        })
    }

    /// How many cells there are.
    pub fn count(&self) -> usize {
        self.dims.element_product() as usize
    }

    /// Cell size along each axis.
    pub fn size(&self) -> Vec3 {
        self.size
    }

    /// The lower corner of cell `i` (numbered x fastest).
    pub fn corner(&self, i: u32) -> Vec3 {
        let dims = self.dims;
        let index = UVec3::new(i % dims.x, (i / dims.x) % dims.y, i / (dims.x * dims.y));
        self.lower + index.as_vec3() * self.size
    }

    /// The index of the cell holding `p`; points outside the grid take the nearest cell.
    #[inline]
    pub fn of(&self, p: Vec3) -> usize {
        // The cast truncates, which is the floor at or above zero, and saturates below zero
        // (and NaN) to cell 0: the same cells as flooring and clamping, without the three
        // library floors a build for plain SSE2 calls (0.4% of the showcase).
        let index = ((p - self.lower) / self.size)
            .as_uvec3()
            .min(self.dims - UVec3::ONE);
        (index.x + self.dims.x * (index.y + self.dims.y * index.z)) as usize
    }
}

/// The unblocked share of ordinary light sampling per cell, and what light sampling through
/// the openings is worth there.
#[derive(Clone, Debug, Default)]
pub struct LightVisibility {
    cells: Cells,
    share: Vec<f32>,
    /// Per cell, the mean [`Strategies::worth`] at its probe points; empty until measured
    /// ([`Self::with_worth`]).
    worth: Vec<f32>,
}

impl LightVisibility {
    /// The grid over `cells` with the unblocked `share` of each (numbered as
    /// [`Cells::corner`] numbers them); every point searches the openings until
    /// [`Self::with_worth`] says where that pays.
    pub fn new(cells: Cells, share: Vec<f32>) -> Self {
        debug_assert_eq!(share.len(), cells.count());
        Self {
            cells,
            share,
            worth: Vec::new(),
        }
    }

    /// No grid: ordinary light sampling counts in full everywhere, and every point searches.
    pub fn none() -> Self {
        Self::default()
    }

    /// The grid with what light sampling through the openings is worth in each cell (the mean
    /// [`Strategies::worth`] at its probe points).
    pub fn with_worth(self, worth: Vec<f32>) -> Self {
        debug_assert_eq!(worth.len(), self.share.len());
        Self { worth, ..self }
    }

    /// The grid's cells; `None` where there is no grid (an empty or infinite scene, or one
    /// where openings bring no light).
    pub fn cells(&self) -> Option<&Cells> {
        (!self.share.is_empty()).then_some(&self.cells)
    }

    /// The share at `p` (its cell's; points outside the grid take the nearest cell's); 1 for
    /// an empty grid.
    pub fn at(&self, p: Vec3) -> f32 {
        if self.share.is_empty() {
            return 1.0;
        }
        self.share[self.cells.of(p)]
    }

    /// True when shading points at `p` should search the openings for light: it is worth
    /// [`SEARCH_WORTH`] in its cell, or that is not measured.
    #[inline]
    pub fn worth_searching(&self, p: Vec3) -> bool {
        self.worth.is_empty() || self.worth[self.cells.of(p)] >= SEARCH_WORTH
    }
}

/// Cells along each axis for a box of `extent`: about [`CELLS`] of them, as near cubes as
/// the box allows (a long thin scene gets a row, not billions of cells); `None` for an
/// infinite box.
fn grid_shape(extent: Vec3) -> Option<UVec3> {
    if !extent.is_finite() {
        return None;
    }
    let count = |side: f32| (extent / side).ceil().max(Vec3::ONE);
    let mut side = (extent.element_product() / CELLS)
        .cbrt()
        .max(f32::MIN_POSITIVE);
    while count(side).element_product() > 2.0 * CELLS {
        side *= 1.25;
    }
    Some(count(side).as_uvec3())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_take_their_cell_or_the_nearest_one_outside() {
        // A 2×3×2 grid of unit cells from (−1, −1, −1), each share its index.
        let grid = LightVisibility {
            cells: Cells {
                lower: Vec3::splat(-1.0),
                size: Vec3::ONE,
                dims: UVec3::new(2, 3, 2),
            },
            share: (0..12).map(|i| i as f32).collect(),
            worth: Vec::new(),
        };
        let cell = |x: u32, y: u32, z: u32| (x + 2 * (y + 3 * z)) as f32;
        assert_eq!(grid.at(Vec3::new(-0.5, 0.5, 0.5)), cell(0, 1, 1));
        assert_eq!(grid.at(Vec3::new(0.0, 1.999, -1.0)), cell(1, 2, 0));
        // Just below the lower corner, far below, far above, and no number at all.
        assert_eq!(grid.at(Vec3::new(-1.001, -0.2, 0.3)), cell(0, 0, 1));
        assert_eq!(grid.at(Vec3::new(-1e30, 5.0, -7.0)), cell(0, 2, 0));
        assert_eq!(grid.at(Vec3::new(1e30, 1e30, 1e30)), cell(1, 2, 1));
        assert_eq!(grid.at(Vec3::new(f32::NAN, 0.5, 0.5)), cell(0, 1, 1));
    }

    #[test]
    fn points_search_where_their_cell_is_worth_it_or_nothing_was_measured() {
        let grid = LightVisibility {
            cells: Cells {
                lower: Vec3::ZERO,
                size: Vec3::ONE,
                dims: UVec3::new(2, 1, 1),
            },
            share: vec![1.0; 2],
            worth: Vec::new(),
        };
        let (cell_0, cell_1) = (Vec3::splat(0.5), Vec3::new(1.5, 0.5, 0.5));
        assert!(grid.worth_searching(cell_0) && grid.worth_searching(cell_1));
        let grid = grid.with_worth(vec![0.5 * SEARCH_WORTH, SEARCH_WORTH]);
        assert!(!grid.worth_searching(cell_0));
        assert!(grid.worth_searching(cell_1));
        // Beyond the grid, the nearest cell decides.
        assert!(!grid.worth_searching(Vec3::new(-3.0, 0.5, 0.5)));
        assert!(grid.worth_searching(Vec3::new(9.0, 0.5, 0.5)));
    }

    #[test]
    fn grids_stay_near_the_cell_budget_whatever_the_box() {
        for extent in [
            Vec3::new(4.0, 3.0, 4.0),
            Vec3::new(84.0, 3.0, 4.0),
            Vec3::new(1e20, 3.0, 4.0),
            Vec3::new(1e20, 1e20, 1e-3),
            Vec3::new(1e-3, 1e-3, 1e-3),
            Vec3::new(3e38, 3e38, 3e38),
        ] {
            let dims = grid_shape(extent).unwrap();
            let cells = dims.as_vec3().element_product();
            assert!(
                dims.min_element() >= 1 && cells <= 2.0 * CELLS,
                "{extent}: {dims}"
            );
        }
        let room = grid_shape(Vec3::new(4.0, 3.0, 4.0)).unwrap();
        assert!(room.as_vec3().element_product() >= 0.5 * CELLS, "{room}");
        assert!(grid_shape(Vec3::new(f32::INFINITY, 1.0, 1.0)).is_none());
    }
}
