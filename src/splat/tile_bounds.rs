//! Per-tile bounds of what the visibility buffer sees (`wgsl/splat_tile_bounds.wgsl`): the
//! box of the visible world positions and of the shading normals of each splat tile.
//! Binning tests each record against them (`tile_may_receive` in
//! `wgsl/shared/splat.wgsl`), so a record's tile list holds only the tiles whose pixels it
//! can reach, not every tile its screen bound overlaps: the same sums with far fewer
//! (record, pixel) tests. After the tiles' bounds the buffer holds those of blocks of
//! [`BLOCK_TILES`] x [`BLOCK_TILES`] tiles (`wgsl/splat_block_bounds.wgsl`), which binning
//! tests first: one test drops a block's tiles together.

use super::{SplatParams, SplatPass};
use crate::Result;
use crate::gpu::GpuContext;
use crate::gpu::scene_buffers::GpuScene;
use crate::gpu::timer::PassTimer;
use crate::visibility::VisibilityBuffer;

/// Bytes per tile (WGSL `TileBound`: four vec4f).
const TILE_BOUND_BYTES: u64 = 64;

/// The visible pixels whose sums are empty after the first gather, listed in an order that
/// depends on thread timing (`splat_tile_bounds.wgsl` with `EMPTY_ONLY`), and how many
/// (`count[0]`): what `splat_fill.wgsl` gathers.
pub(super) struct EmptyPixels {
    pub list: wgpu::Buffer,
    pub count: wgpu::Buffer,
}

/// Block edge in tiles (`BLOCK_TILES` in `wgsl/shared/splat.wgsl`).
pub const BLOCK_TILES: u32 = 8;

/// The tile bounds of one visibility buffer, resident on the GPU.
pub struct TileBounds {
    pub tiles_x: u32,
    pub tiles_y: u32,
    /// The tiles' bounds, row-major, then their blocks' bounds, row-major.
    pub buffer: wgpu::Buffer,
}

impl SplatPass {
    /// Computes the tile bounds of `vis` (one dispatch, timed as "splat: tile bounds").
    pub fn tile_bounds(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        vis: &VisibilityBuffer,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<TileBounds> {
        self.bounds_of(ctx, scene, vis, None, times)
    }

    /// The tile bounds of the visible pixels whose sums in `first` are empty: the pixels
    /// tail fill's gather ([`SplatPass::fill_empty`]) can change, so that it bins records
    /// only into tiles that have some (the same sums); and the list of those pixels.
    pub(super) fn fill_tile_bounds(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        vis: &VisibilityBuffer,
        first: &super::SplatBuffer,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<(TileBounds, EmptyPixels)> {
        let empty = EmptyPixels {
            list: ctx.storage_buffer_sized(
                "empty pixels",
                u64::from(vis.width) * u64::from(vis.height) * 4,
            )?,
            count: ctx.storage_buffer_sized("empty pixel count", 4)?,
        };
        let bounds = self.bounds_of(ctx, scene, vis, Some((&first.sums, &empty)), times)?;
        Ok((bounds, empty))
    }

    fn bounds_of(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        vis: &VisibilityBuffer,
        empty_in: Option<(&wgpu::Buffer, &EmptyPixels)>,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<TileBounds> {
        let tiles = SplatParams::tiles(vis.width, vis.height);
        let (tiles_x, tiles_y) = (tiles.tiles_x, tiles.tiles_y);
        let blocks = u64::from(tiles_x.div_ceil(BLOCK_TILES) * tiles_y.div_ceil(BLOCK_TILES));
        let buffer = ctx.storage_buffer_sized(
            "splat tile bounds",
            (u64::from(tiles_x) * u64::from(tiles_y) + blocks) * TILE_BOUND_BYTES,
        )?;
        let params = ctx.uniform_buffer("tile bounds params", &tiles);
        let mut timer = PassTimer::new(ctx, 2);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let (pass, sums, list, count) = match empty_in {
            Some((sums, empty)) => (&self.fill_bounds, sums, &empty.list, &empty.count),
            None => (
                &self.bounds,
                &self.no_sums,
                &self.no_empty.list,
                &self.no_empty.count,
            ),
        };
        let bind = pass.bind(ctx, &[&params, &vis.samples, &buffer, sums, list, count]);
        pass.record(
            &mut enc,
            &scene.bind_group,
            &bind,
            [(tiles_x * tiles_y).div_ceil(64), 1, 1],
            timer.next("splat: tile bounds"),
        );
        let bind = self.block_bounds.bind(ctx, &[&params, &buffer]);
        self.block_bounds.record(
            &mut enc,
            &scene.bind_group,
            &bind,
            [(blocks as u32).div_ceil(64), 1, 1],
            timer.next("splat: tile bounds"),
        );
        timer.resolve(&mut enc);
        ctx.queue.submit([enc.finish()]);
        times.extend(timer.read(ctx)?);
        Ok(TileBounds {
            tiles_x,
            tiles_y,
            buffer,
        })
    }
}
