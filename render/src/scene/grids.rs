//! Media from density grids: each `[[medium]]` with a `vdb` file has its grid read (by name,
//! "density" unless `grid` says) and placed by its `transform` and `through` keys like an
//! object (see [`crate::media::grid`]). A run of `#` in the file name is the frame number, so
//! a simulation's cache (`smoke.####.vdb`) gives each frame its own grid.

use super::media::GridSection;
use super::objects::{Carried, Loader};
use crate::error::{RenderError, key_error};
use crate::media::grid::{GridMedia, GridMedium, MAX_GRIDS};

/// The grids' voxels may take at most this much memory when no budget is given.
const DEFAULT_GRID_BYTES: u64 = 8 << 30;

/// Reads and places every grid medium; `budget` bounds their voxels' memory together.
pub(super) fn load(
    loader: &Loader,
    sections: &[GridSection],
    frame: i64,
    budget: Option<u64>,
) -> Result<GridMedia, RenderError> {
    let file = &loader.shot.source;
    if sections.len() > MAX_GRIDS {
        return Err(key_error(
            file,
            &sections[MAX_GRIDS].key,
            format!("a scene may have at most {MAX_GRIDS} media from grids"),
        ));
    }
    let mut left = budget.unwrap_or(DEFAULT_GRID_BYTES);
    let mut grids = Vec::new();
    for g in sections {
        let s = &g.section;
        let vdb_key = format!("{}.vdb", g.key);
        let relative = s.vdb.as_deref().unwrap_or_default();
        let path = loader.base.join(super::rings::frame_path(relative, frame));
        let bytes = rift_fx::io::read(&path).map_err(|e| {
            key_error(
                file,
                &vdb_key,
                format!("cannot read {}: {e}", path.display()),
            )
        })?;
        let name = s.grid.as_deref().unwrap_or("density");
        let grid = crate::media::vdb::read_grid(&bytes, name, left).map_err(|e| {
            let key = if e.starts_with("no grid is called") {
                format!("{}.grid", g.key)
            } else {
                vdb_key.clone()
            };
            key_error(file, key, format!("{}: {e}", path.display()))
        })?;
        left = left.saturating_sub(grid.voxels.bytes() as u64);
        let motion = loader.placement(
            &g.key,
            s.transform.as_ref(),
            s.through.as_deref().map(Carried::Through),
        )?;
        grids.push(GridMedium::new(
            s.name.clone(),
            grid.voxels,
            grid.world_from_index,
            g.coefficients,
            motion,
            loader.times,
        ));
    }
    Ok(GridMedia { grids })
}
