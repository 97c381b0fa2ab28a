//! Placement's view of the splat: which pixels some record covers (contributes to with
//! Ward's weight w >= 1/a), without the weighted sums. A placement round bins its new
//! records and marks the pixels they cover (`wgsl/splat_cover.wgsl`); the weighted gather
//! runs once per frame, after placement, instead of once per round.

use super::{SplatPass, SplatSource, TILE_SIZE};
use crate::Result;
use crate::gpu::GpuContext;
use crate::gpu::scene_buffers::GpuScene;
use crate::gpu::timer::PassTimer;
use crate::records::Record;
use crate::visibility::{VisSample, VisibilityBuffer};
use glam::Vec3;

/// One flag per pixel (u32, row-major): 1 where a record covers the pixel.
pub struct CoverageMask {
    pub width: u32,
    pub height: u32,
    pub covered: wgpu::Buffer,
    /// How many pixels the covers have marked so far (one u32, `splat_cover.wgsl`).
    pub marked: wgpu::Buffer,
}

impl CoverageMask {
    /// A mask of `width x height` pixels, none covered.
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> Result<Self> {
        Ok(Self {
            width,
            height,
            covered: ctx
                .storage_buffer_sized("coverage mask", u64::from(width) * u64::from(height) * 4)?,
            marked: ctx.storage_buffer_sized("coverage mask marks", 4)?,
        })
    }

    /// How many pixels the covers into this mask have marked (each pixel once).
    pub fn marked(&self, ctx: &GpuContext) -> Result<u32> {
        let count: Vec<u32> = ctx.read_buffer(&self.marked)?;
        Ok(count.first().copied().unwrap_or(0))
    }

    /// Reads the flags back.
    pub fn read(&self, ctx: &GpuContext) -> Result<Vec<u32>> {
        let mut flags: Vec<u32> = ctx.read_buffer(&self.covered)?;
        flags.truncate(self.width as usize * self.height as usize);
        Ok(flags)
    }
}

/// The room a cover's bins get for their lists before their total is known
/// ([`SplatPass::cover_in_flight`]): 4 entries a tile of a `width x height` image, at
/// least 4,096 (8 bytes each).
pub fn cover_room(width: u32, height: u32) -> u32 {
    (width.div_ceil(TILE_SIZE) * height.div_ceil(TILE_SIZE) * 4).max(4096)
}

/// How a placement round's cover finds the pixels its records reach.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CoverMode {
    /// Record by record on images of at most [`BY_RECORD_MAX_TILES`] tiles, binned on
    /// larger ones: what placement uses.
    Auto,
    /// Always binned (`splat_cover.wgsl` over the tiles' lists), as on large images: for
    /// tests of the binned cover's lists and their room.
    Binned,
}

/// The most tiles (8 x 8 pixels) of an image whose covers go record by record
/// (`splat_cover_by_record.wgsl`, one dispatch) rather than binned (five: the bins'
/// counts, their prefix sum, the busy tiles, the lists, the cover): 1,024, a 256 x 256
/// image. A record's workgroup walks its tiles one after the other, so on larger images
/// a round's widest records would each walk thousands, where the binned cover spreads
/// them over the tiles' workgroups. On lavapipe a dispatch costs about 81 us whatever its
/// work (`cargo bench --bench kernels -- driver`), and a small still's placement makes
/// dozens of rounds (docs/results.md, stop 69).
pub const BY_RECORD_MAX_TILES: u32 = 1024;

/// A cover's pipeline (`shader` with `bindings`), with the records' corrals where `corral`
/// (`CORRAL`): built at its first use, then kept by the device.
pub(super) fn cover_pass(
    ctx: &GpuContext,
    shader: &'static str,
    bindings: &[crate::gpu::pipeline::Binding],
    corral: bool,
) -> Result<std::sync::Arc<crate::gpu::pipeline::ComputePass>> {
    let constants: &[(&str, f64)] = if corral { &[("CORRAL", 1.0)] } else { &[] };
    crate::gpu::pipeline::ComputePass::with_constants(ctx, shader, bindings, constants)
}

/// A cover submitted without a wait ([`SplatPass::cover_in_flight`]).
pub struct CoverInFlight {
    /// The bins' lists' total entries (one u32), read back with the next wait.
    pub total: wgpu::Buffer,
    /// The entries the lists had room for.
    pub capacity: u32,
}

impl CoverInFlight {
    /// Whether lists of `total` entries fitted (the cover then marked its pixels).
    pub fn fitted(&self, total: u32) -> bool {
        total <= self.capacity
    }
}

impl SplatPass {
    /// Marks in `mask` the visible pixels of `vis` that records `first..cache.count`
    /// contribute to (pixels already marked stay marked). Appends per-pass GPU times.
    /// [`Self::cover_in_flight`] with [`cover_room`]'s room, then one wait for its lists'
    /// total; where they did not fit, once more with room for them (it marked nothing).
    pub fn cover(
        &self,
        ctx: &GpuContext,
        src: SplatSource,
        mask: &CoverageMask,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<()> {
        let room = cover_room(src.vis.width, src.vis.height);
        let Some(cover) = self.cover_in_flight(ctx, src, mask, room, times)? else {
            return Ok(());
        };
        let total = ctx
            .read_buffer::<u32>(&cover.total)?
            .first()
            .copied()
            .unwrap_or(0);
        if !cover.fitted(total) {
            self.cover_in_flight(ctx, src, mask, total, times)?;
        }
        Ok(())
    }

    /// [`Self::cover`] without waiting for the GPU: the bins' lists get room for
    /// `capacity` entries, sized before their total is known, and everything is one
    /// submission. Whether the lists fitted is known once [`CoverInFlight::total`] is read
    /// back (placement reads it with its next candidates, a wait it makes anyway): where
    /// they did not, this cover marked nothing (`splat_cover.wgsl`), and [`Self::cover`]
    /// of the same records marks exactly what it would have. So a placement round waits
    /// for the GPU once, not twice. None when there are no records to cover.
    ///
    /// On images of at most [`BY_RECORD_MAX_TILES`] tiles the cover goes record by record
    /// (`splat_cover_by_record.wgsl`: the same mask and marks in one dispatch, no lists, so
    /// nothing to overflow).
    pub fn cover_in_flight(
        &self,
        ctx: &GpuContext,
        src: SplatSource,
        mask: &CoverageMask,
        capacity: u32,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<Option<CoverInFlight>> {
        self.cover_in_flight_as(ctx, src, mask, capacity, CoverMode::Auto, times)
    }

    /// [`Self::cover_in_flight`] in `mode`.
    pub fn cover_in_flight_as(
        &self,
        ctx: &GpuContext,
        src: SplatSource,
        mask: &CoverageMask,
        capacity: u32,
        mode: CoverMode,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<Option<CoverInFlight>> {
        // The cover's workgroups are the splat's tiles (`@workgroup_size(TILE_SIZE,
        // TILE_SIZE)`), within the device's 256 invocations; a record's workgroup in
        // `splat_cover_by_record.wgsl` tests one pixel of a tile per invocation (64).
        const _: () = assert!(TILE_SIZE * TILE_SIZE <= 256);
        const _: () = assert!(TILE_SIZE * TILE_SIZE == 64);
        if src.records.count <= src.first {
            return Ok(None);
        }
        let tiles = src.vis.width.div_ceil(TILE_SIZE) * src.vis.height.div_ceil(TILE_SIZE);
        if mode == CoverMode::Auto && tiles <= BY_RECORD_MAX_TILES {
            return self.cover_by_record(ctx, src, mask, times).map(Some);
        }
        let cover = self.cover_pipeline(ctx, src.corral)?;
        let mut timer = PassTimer::new(ctx, 5);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let counts = self.record_bin_counts(
            ctx,
            src,
            (super::SplatInto::Fresh, 0),
            false,
            &mut enc,
            &mut timer,
        )?;
        let entries = ctx.storage_buffer_sized("tile entries", u64::from(capacity.max(1)) * 8)?;
        self.record_bin_scatter(ctx, src, &counts, &entries, &mut enc, &mut timer)?;
        let bind = cover.bind(
            ctx,
            &[
                &counts.params,
                &src.vis.samples,
                &src.records.buffer,
                &counts.tile_offsets,
                &entries,
                &mask.covered,
                &mask.marked,
                &counts.busy_tiles,
                &counts.busy_count,
            ],
        );
        cover.record_indirect(
            &mut enc,
            &src.scene.bind_group,
            &bind,
            &counts.cover_groups,
            timer.next("placement: cover"),
        );
        timer.resolve(&mut enc);
        let total = ctx.storage_buffer_sized("tile entries total", 4)?;
        let tiles = counts.tiles[0] * counts.tiles[1];
        enc.copy_buffer_to_buffer(&counts.tile_offsets, u64::from(tiles) * 4, &total, 0, 4);
        ctx.queue.submit([enc.finish()]);
        times.extend(timer.read(ctx)?);
        Ok(Some(CoverInFlight {
            total,
            // What the buffer holds (it is at least 16 bytes): the shaders test against it.
            capacity: u32::try_from(entries.size() / 8).unwrap_or(u32::MAX),
        }))
    }

    /// [`Self::cover_in_flight`] record by record: one workgroup a new record. Its lists'
    /// total reads 0 against a capacity of `u32::MAX`: it always fits.
    fn cover_by_record(
        &self,
        ctx: &GpuContext,
        src: SplatSource,
        mask: &CoverageMask,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<CoverInFlight> {
        let pass = self.cover_by_record_pipeline(ctx, src.corral)?;
        let (params, _) = super::splat_params(ctx, src, super::SplatInto::Fresh, 0)?;
        let bind = pass.bind(
            ctx,
            &[
                &params,
                &src.vis.camera_buffer,
                &src.vis.samples,
                &src.records.buffer,
                &src.bounds.buffer,
                &mask.covered,
                &mask.marked,
            ],
        );
        let mut timer = PassTimer::new(ctx, 1);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        pass.record(
            &mut enc,
            &src.scene.bind_group,
            &bind,
            crate::gpu::pipeline::split_groups(ctx, src.records.count - src.first),
            timer.next("placement: cover"),
        );
        timer.resolve(&mut enc);
        ctx.queue.submit([enc.finish()]);
        times.extend(timer.read(ctx)?);
        Ok(CoverInFlight {
            total: self.no_lists_total.clone(),
            capacity: u32::MAX,
        })
    }

    /// The record-by-record cover's pipeline, with the records' corrals where `corral`
    /// (the one without them is built with the splat pass: small images' placement uses it
    /// from its first round).
    pub(super) fn cover_by_record_pipeline(
        &self,
        ctx: &GpuContext,
        corral: bool,
    ) -> Result<std::sync::Arc<crate::gpu::pipeline::ComputePass>> {
        cover_pass(
            ctx,
            "splat_cover_by_record.wgsl",
            super::COVER_BY_RECORD_BINDINGS,
            corral,
        )
    }

    /// The binned cover's pipeline, with the records' corrals where `corral`: built at its
    /// first use (images of more than [`BY_RECORD_MAX_TILES`] tiles).
    pub(super) fn cover_pipeline(
        &self,
        ctx: &GpuContext,
        corral: bool,
    ) -> Result<std::sync::Arc<crate::gpu::pipeline::ComputePass>> {
        cover_pass(ctx, "splat_cover.wgsl", super::COVER_BINDINGS, corral)
    }

    /// The visible pixels of `vis` and how many of them `mask` marks
    /// (`wgsl/coverage_count.wgsl`).
    pub fn coverage_counts(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        vis: &VisibilityBuffer,
        mask: &CoverageMask,
    ) -> Result<(u32, u32)> {
        let tiles = super::SplatParams::tiles(vis.width, vis.height);
        let (tiles_x, tiles_y) = (tiles.tiles_x, tiles.tiles_y);
        let params = ctx.uniform_buffer("coverage count params", &tiles);
        let counts = ctx.storage_buffer_sized("coverage counts", 8)?;
        let bind = self
            .count_coverage
            .bind(ctx, &[&params, &vis.samples, &mask.covered, &counts]);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        self.count_coverage.record(
            &mut enc,
            &scene.bind_group,
            &bind,
            [(tiles_x * tiles_y).div_ceil(64), 1, 1],
            None,
        );
        ctx.queue.submit([enc.finish()]);
        let c: Vec<u32> = ctx.read_buffer(&counts)?;
        Ok((
            c.first().copied().unwrap_or(0),
            c.get(1).copied().unwrap_or(0),
        ))
    }
}

/// Plain-Rust cover: 1 where any of `records` contributes to the visible pixel (the test
/// of [`super::reference::splat_records`], so exactly where its `sum w` is non-zero), the
/// records' corrals applied or not ([`super::SplatSource::corral`]).
pub fn reference_cover(
    records: &[Record],
    vis: &[VisSample],
    accuracy: f32,
    corral: bool,
) -> Vec<u32> {
    vis.iter()
        .map(|v| {
            let p = Vec3::from(v.position);
            let n = Vec3::from(v.shading_normal);
            u32::from(
                v.is_hit()
                    && records
                        .iter()
                        .any(|r| r.reaches_corralled(p, n, accuracy, corral)),
            )
        })
        .collect()
}
