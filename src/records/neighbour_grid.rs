//! A uniform grid over the records placed before a batch, which neighbour clamping
//! (Krivanek et al. 2006, algorithms.md 1.8; `record_reduce.wgsl`) searches instead of
//! every earlier record: the bound `min_j R_j + |p - p_j|` was a loop over all of them for
//! each new record, quadratic in the record count (Sponza sun 1000x1000 at the defaults:
//! about 2 s of a 5.0 s reduction, 14,500 records; 32,000 records at a 0.15: about 8 s of
//! 15.4 s).
//!
//! The grid is rebuilt for each batch on the GPU: count the records per cell, scan, scatter
//! (`neighbour_grid_count.wgsl`, `prefix_sum.wgsl`, `neighbour_grid_scatter.wgsl`). The
//! reduction then visits the cells ring by ring around the new record and stops once no
//! farther cell can hold a smaller bound (or one below the record's own R, which is all the
//! clamp needs). The search is exact where it matters, and a minimum does not depend on the
//! order it visits records in, so the records are byte for byte those of the full loop
//! (tests/gpu_records.rs compares them with the CPU's full loop).

use crate::Result;
use crate::gpu::GpuContext;
use crate::gpu::pipeline::{Binding, ComputePass};
use crate::gpu::scene_buffers::GpuScene;
use bytemuck::{Pod, Zeroable};

/// Cells along the scene's longest side (the others in proportion): at most 32^3 cells,
/// which one workgroup scans. A cell is then about the world-space R_min bound
/// (`r_min_scene` 1/32 of the diagonal), so most searches end after a ring or two.
pub const CELLS_PER_SIDE: u32 = 32;

/// Below this many earlier records the reduction loops over all of them (cheaper than
/// building a grid; the early placement rounds have few, sparse records).
pub const MIN_RECORDS: u32 = 2048;

/// WGSL `NeighbourGrid` (shared/neighbour_grid.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct GridParams {
    origin: [f32; 3],
    cell_size: f32,
    dims: [u32; 3],
    enabled: u32,
    records: u32,
    _pad: [u32; 3],
}

impl GridParams {
    /// The grid over world bounds `lo..hi` for `records` earlier records.
    fn over(lo: [f32; 3], hi: [f32; 3], records: u32) -> Self {
        let extent = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
        let longest = extent.iter().copied().fold(0.0f32, f32::max);
        let cell_size = if longest.is_finite() && longest > 0.0 {
            longest / CELLS_PER_SIDE as f32
        } else {
            1.0
        };
        let dims = extent.map(|e| {
            if e.is_finite() && e > 0.0 {
                ((e / cell_size).ceil() as u32).clamp(1, CELLS_PER_SIDE)
            } else {
                1
            }
        });
        Self {
            origin: lo,
            cell_size,
            dims,
            enabled: 1,
            records,
            _pad: [0; 3],
        }
    }

    fn cells(&self) -> u32 {
        self.dims.iter().product()
    }
}

/// The grid's passes (one set per record pass).
pub struct NeighbourGridPass {
    count: std::sync::Arc<ComputePass>,
    scan: crate::gpu::prefix_sum::PrefixSumPass,
    scatter: std::sync::Arc<ComputePass>,
    /// What a reduction binds when it searches no grid (made once).
    pub(crate) disabled: NeighbourGrid,
}

/// What the reduction binds for its neighbour search: the grid's parameters, its cell
/// offsets and the records by cell (a disabled grid's are placeholders).
pub struct NeighbourGrid {
    pub params: wgpu::Buffer,
    pub offsets: wgpu::Buffer,
    pub records: wgpu::Buffer,
}

impl NeighbourGridPass {
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        use Binding::*;
        Ok(Self {
            count: ComputePass::new(
                ctx,
                "neighbour_grid_count.wgsl",
                &[Uniform, StorageRead, StorageReadWrite],
            )?,
            scan: crate::gpu::prefix_sum::PrefixSumPass::new(ctx)?,
            scatter: ComputePass::new(
                ctx,
                "neighbour_grid_scatter.wgsl",
                &[Uniform, StorageRead, StorageReadWrite, StorageReadWrite],
            )?,
            // A grid the reduction does not search (it loops over every earlier record).
            disabled: NeighbourGrid {
                params: ctx.uniform_buffer("neighbour grid", &GridParams::zeroed()),
                offsets: ctx.storage_buffer_sized("neighbour grid offsets", 16)?,
                records: ctx.storage_buffer_sized("neighbour grid records", 16)?,
            },
        })
    }

    /// Records the building of the grid over `records[..count]` into `enc`; None below
    /// [`MIN_RECORDS`] (then bind `Self::disabled`).
    pub fn record(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        records: &wgpu::Buffer,
        count: u32,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<Option<NeighbourGrid>> {
        if count < MIN_RECORDS {
            return Ok(None);
        }
        let (lo, hi) = scene.bounds;
        let grid = GridParams::over(lo, hi, count);
        let cells = u64::from(grid.cells());
        let params = ctx.uniform_buffer("neighbour grid", &grid);
        let counts = ctx.storage_buffer_sized("neighbour grid counts", cells * 4)?;
        let offsets = ctx.storage_buffer_sized("neighbour grid offsets", (cells + 1) * 4)?;
        let by_cell = ctx.storage_buffer_sized("neighbour grid records", u64::from(count) * 4)?;
        enc.clear_buffer(&counts, 0, None);
        use crate::gpu::timer::spanning;
        let bind = self.count.bind(ctx, &[&params, records, &counts]);
        self.count.record(
            enc,
            &scene.bind_group,
            &bind,
            crate::gpu::pipeline::linear_groups(ctx, count),
            spanning(timestamps.as_ref(), true, false),
        );
        self.scan.record(
            ctx,
            enc,
            &scene.bind_group,
            &counts,
            &offsets,
            grid.cells(),
            None,
        );
        // Each cell's write cursor starts at its offset.
        enc.copy_buffer_to_buffer(&offsets, 0, &counts, 0, cells * 4);
        let bind = self
            .scatter
            .bind(ctx, &[&params, records, &counts, &by_cell]);
        self.scatter.record(
            enc,
            &scene.bind_group,
            &bind,
            crate::gpu::pipeline::linear_groups(ctx, count),
            spanning(timestamps.as_ref(), false, true),
        );
        Ok(Some(NeighbourGrid {
            params,
            offsets,
            records: by_cell,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_cells_are_cubes_covering_the_bounds() {
        let g = GridParams::over([0.0, -1.0, 2.0], [8.0, 1.0, 2.0], 5000);
        assert_eq!(g.cell_size, 0.25);
        assert_eq!(g.dims, [32, 8, 1]);
        assert!(g.cells() <= CELLS_PER_SIDE.pow(3));
        // Degenerate bounds still give one valid cell.
        let g = GridParams::over([1.0; 3], [1.0; 3], 5000);
        assert_eq!((g.cell_size, g.dims), (1.0, [1, 1, 1]));
    }
}
