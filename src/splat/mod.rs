//! Tile-binned record splatting (thesis section 4.5, algorithms.md decision 8): records
//! are binned into 8 x 8-pixel tiles by the screen bound of their footprint (atomic
//! counts, a prefix sum, a scatter, a rank sort by record id), then each pixel gathers its
//! tile's records in id order. [`reference`](mod@reference) is the same sum on the CPU.
//!
//! A frame splats once: placement rounds only ask which pixels are covered ([`cover`],
//! the same contribution test without the sums), and the weighted gather runs over every
//! record after placement.

pub mod consistency;
pub mod cover;
pub mod radiance;
pub mod reference;
pub mod tile_bounds;

pub use cover::{CoverInFlight, CoverageMask};
pub use tile_bounds::TileBounds;

use crate::gpu::GpuContext;
use crate::gpu::pipeline::{Binding, ComputePass, OnFirstUse, image_groups};
use crate::gpu::scene_buffers::GpuScene;
use crate::gpu::timer::PassTimer;
use crate::records::RecordCache;
use crate::visibility::VisibilityBuffer;
use crate::{Error, Result};
use bytemuck::{Pod, Zeroable};

/// Tile edge in pixels (`TILE_SIZE` in `wgsl/shared/splat.wgsl`).
pub const TILE_SIZE: u32 = 8;

/// `splat_tile_bounds.wgsl`'s bindings (with and without `EMPTY_ONLY`).
const TILE_BOUNDS_BINDINGS: &[Binding] = &[
    Binding::Uniform,
    Binding::StorageRead,
    Binding::StorageReadWrite,
    Binding::StorageRead,
    Binding::StorageReadWrite,
    Binding::StorageReadWrite,
];

/// What a splat counts per record (`count_coverage`; `COUNT_ALL` and `COUNT_NEEDED` in
/// `wgsl/splat_gather.wgsl`): nothing, every pixel it contributes to, or only those no
/// record outliving the frame contributes to.
const COUNT_NONE: u32 = 0;
const COUNT_ALL: u32 = 1;
const COUNT_NEEDED: u32 = 2;

/// Bindings of `splat_gather.wgsl` (group 1).
const GATHER_BINDINGS: &[Binding] = &[
    Binding::Uniform,
    Binding::StorageRead,
    Binding::StorageRead,
    Binding::StorageRead,
    Binding::StorageRead,
    Binding::StorageReadWrite,
    Binding::StorageReadWrite,
    Binding::StorageRead,
    Binding::Texels,
];

/// Rows of a record in its texel table (`record_for_sums` in `wgsl/shared/splat_pixel.wgsl`).
const RECORD_TEXELS: u64 = (std::mem::size_of::<crate::records::Record>() / 16) as u64;

/// Bindings of `splat_cover.wgsl`.
const COVER_BINDINGS: &[Binding] = &[
    Binding::Uniform,
    Binding::StorageRead,
    Binding::StorageRead,
    Binding::StorageRead,
    Binding::StorageRead,
    Binding::StorageReadWrite,
    Binding::StorageReadWrite,
    Binding::StorageRead,
    Binding::StorageRead,
];

/// The bindings of `splat_cover_by_record.wgsl`.
const COVER_BY_RECORD_BINDINGS: &[Binding] = &[
    Binding::Uniform,
    Binding::Uniform,
    Binding::StorageRead,
    Binding::StorageRead,
    Binding::StorageRead,
    Binding::StorageReadWrite,
    Binding::StorageReadWrite,
];

/// Bindings `splat_fill.wgsl` adds after the gather's: the empty pixels' list and count.
const FILL_EXTRA_BINDINGS: &[Binding] = &[Binding::StorageRead, Binding::StorageRead];

/// A gather compiled up to four times: with coverage counting or without
/// (`COUNTS_COVERAGE` in `wgsl/shared/splat_pixel.wgsl`), with the records' corrals or
/// without (`CORRAL` in `wgsl/shared/splat_weight.wgsl`). Still frames count nothing and,
/// by default, weigh no corral: that pipeline is built up front, the others when a splat
/// first asks for one (temporal caching counts; `records::Corral` other than Off weighs
/// corrals; the device keeps them once built, `ComputePass::with_constants`). Lavapipe runs
/// the count's loads and atomic for every record of a tile's list even when nothing is
/// counted (on Sponza 400x400 the gather without them took 0.80 of its time, the same
/// bytes), and builds a pipeline with the corral's code 1.2x as slowly.
struct GatherPipelines {
    name: &'static str,
    bindings: Vec<Binding>,
    plain: std::sync::Arc<ComputePass>,
}

impl GatherPipelines {
    fn new(ctx: &GpuContext, name: &'static str, bindings: Vec<Binding>) -> Result<Self> {
        Ok(Self {
            name,
            plain: Self::build(ctx, name, &bindings, false, false)?,
            bindings,
        })
    }

    fn build(
        ctx: &GpuContext,
        name: &'static str,
        bindings: &[Binding],
        counting: bool,
        corral: bool,
    ) -> Result<std::sync::Arc<ComputePass>> {
        ComputePass::with_constants(
            ctx,
            name,
            bindings,
            &[
                ("COUNTS_COVERAGE", f64::from(u8::from(counting))),
                ("CORRAL", f64::from(u8::from(corral))),
            ],
        )
    }

    /// The pipeline for a splat counting `coverage_mode` (`COUNT_NONE`, `COUNT_ALL` or
    /// `COUNT_NEEDED`), weighing the records' corrals or not.
    fn for_mode(
        &self,
        ctx: &GpuContext,
        coverage_mode: u32,
        corral: bool,
    ) -> Result<std::sync::Arc<ComputePass>> {
        let counting = coverage_mode != COUNT_NONE;
        if !counting && !corral {
            return Ok(std::sync::Arc::clone(&self.plain));
        }
        Self::build(ctx, self.name, &self.bindings, counting, corral)
    }
}

/// The pipelines that bin records into tiles (`splat_bin_*.wgsl` and a prefix sum).
struct Binning {
    count: std::sync::Arc<ComputePass>,
    scan: crate::gpu::prefix_sum::PrefixSumPass,
    busy_tiles: std::sync::Arc<ComputePass>,
    scatter: std::sync::Arc<ComputePass>,
    sort: std::sync::Arc<ComputePass>,
}

impl Binning {
    fn new(ctx: &GpuContext) -> Result<Self> {
        use Binding::*;
        Ok(Self {
            count: ComputePass::new(
                ctx,
                "splat_bin_count.wgsl",
                &[
                    Uniform,
                    Uniform,
                    StorageRead,
                    StorageReadWrite,
                    StorageReadWrite,
                    StorageRead,
                ],
            )?,
            scan: crate::gpu::prefix_sum::PrefixSumPass::new(ctx)?,
            busy_tiles: ComputePass::new(
                ctx,
                "splat_bin_tiles.wgsl",
                &[
                    Uniform,
                    StorageRead,
                    StorageReadWrite,
                    StorageReadWrite,
                    StorageReadWrite,
                ],
            )?,
            scatter: ComputePass::new(
                ctx,
                "splat_bin_scatter.wgsl",
                &[
                    Uniform,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                    StorageReadWrite,
                    StorageRead,
                    StorageRead,
                ],
            )?,
            sort: ComputePass::new(
                ctx,
                "splat_bin_sort.wgsl",
                &[Uniform, StorageRead, StorageRead, StorageReadWrite],
            )?,
        })
    }
}

/// What a gather does with the sums already in its buffer (`accumulate` in
/// `wgsl/splat_gather.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum SplatInto {
    /// Replaces them.
    Fresh = 0,
    /// Adds onto them.
    Accumulate = 1,
    /// Only pixels whose sums are empty take the records' sums.
    FillEmpty = 2,
}

/// Mirror of WGSL `SplatParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct SplatParams {
    width: u32,
    height: u32,
    tiles_x: u32,
    tiles_y: u32,
    first_record: u32,
    record_end: u32,
    accuracy: f32,
    accumulate: u32,
    count_coverage: u32,
    /// [`SplatSource::plateau`].
    plateau: f32,
    /// [`SplatSource::dark_only_empty`], 1 or 0.
    dark_only_empty: u32,
    _pad: u32,
}

impl SplatParams {
    /// The image and tile size alone, for the per-tile passes (tile bounds, coverage count).
    fn tiles(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            tiles_x: width.div_ceil(TILE_SIZE),
            tiles_y: height.div_ceil(TILE_SIZE),
            ..Zeroable::zeroed()
        }
    }
}

/// Per-pixel splat sums `(sum w E'_k (rgb), sum w)`, resident on the GPU, and optionally
/// per-record coverage counts.
pub struct SplatBuffer {
    pub width: u32,
    pub height: u32,
    pub sums: wgpu::Buffer,
    /// Per record id, the pixels it contributed to (u32), when counting
    /// ([`SplatBuffer::with_coverage`]); a 4-byte placeholder otherwise.
    pub coverage: wgpu::Buffer,
    /// Records `coverage` has room for (0: not counting).
    pub coverage_records: u32,
    /// What `coverage` counts (`count_coverage` in `wgsl/shared/splat.wgsl`).
    coverage_mode: u32,
    /// Per record id, 1 where the record expires after this frame
    /// ([`SplatBuffer::with_needed_coverage`]); a 4-byte placeholder otherwise.
    expiring: wgpu::Buffer,
}

impl SplatBuffer {
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> Result<Self> {
        Self::with_coverage(ctx, width, height, 0)
    }

    /// As [`SplatBuffer::new`], also counting the pixels covered by each of the first
    /// `records` record ids (temporal caching: expired records that cover nothing are
    /// deleted). Counts start at zero.
    pub fn with_coverage(ctx: &GpuContext, width: u32, height: u32, records: u32) -> Result<Self> {
        Self::counting(ctx, width, height, records, COUNT_ALL, &[])
    }

    /// Sums of a `width x height` image and `records` coverage counters in `mode` (none
    /// when `records` is 0), with one expiry flag per record (`COUNT_NEEDED`).
    fn counting(
        ctx: &GpuContext,
        width: u32,
        height: u32,
        records: u32,
        mode: u32,
        expiring: &[u32],
    ) -> Result<Self> {
        Ok(Self {
            width,
            height,
            sums: ctx
                .storage_buffer_sized("splat sums", u64::from(width) * u64::from(height) * 16)?,
            coverage: ctx.storage_buffer_sized("record coverage", u64::from(records.max(1)) * 4)?,
            coverage_records: records,
            coverage_mode: if records > 0 { mode } else { COUNT_NONE },
            expiring: ctx.storage_buffer("expiring records", expiring)?,
        })
    }

    /// As [`SplatBuffer::new`], also counting for each record that `expiring` (one flag per
    /// record id) marks as expiring after this frame the pixels it contributes to where no
    /// record outlives the frame: the pixels that need it replaced (temporal caching's
    /// replacement of the records that cover pixels). Counts start at zero.
    pub fn with_needed_coverage(
        ctx: &GpuContext,
        width: u32,
        height: u32,
        expiring: &[bool],
    ) -> Result<Self> {
        let flags: Vec<u32> = expiring.iter().map(|&e| u32::from(e)).collect();
        let records = u32::try_from(flags.len())
            .map_err(|_| Error::Usage(format!("{} records exceed u32", flags.len())))?;
        Self::counting(ctx, width, height, records, COUNT_NEEDED, &flags)
    }

    /// An error where this buffer counts coverage for fewer records than `cache` holds.
    fn check_room(&self, cache: &RecordCache) -> Result<()> {
        if self.coverage_records > 0 && cache.count > self.coverage_records {
            return Err(Error::Usage(format!(
                "splat: {} records exceed the coverage counters' {}",
                cache.count, self.coverage_records
            )));
        }
        Ok(())
    }

    /// Reads the coverage counts back (one per record id, `coverage_records` of them).
    pub fn read_coverage(&self, ctx: &GpuContext) -> Result<Vec<u32>> {
        let mut counts: Vec<u32> = ctx.read_buffer(&self.coverage)?;
        counts.truncate(self.coverage_records as usize);
        Ok(counts)
    }
}

/// Records binned into tiles ([`SplatPass::bin`]): what a gather reads.
pub(crate) struct TileBins {
    /// The `SplatParams` uniform of the splat.
    pub params: wgpu::Buffer,
    /// Per tile, the first entry of its list (tiles + 1 entries).
    pub tile_offsets: wgpu::Buffer,
    /// Per tile, its records in id order (the scatter's `(record, tile)` pairs sorted).
    pub sorted: wgpu::Buffer,
    /// Tiles across and down.
    pub tiles: [u32; 2],
    pub records: u32,
    /// (record, tile) pairs.
    pub total: u32,
}

/// Binning's first half ([`SplatPass::record_bin_counts`]): what the scatter and a cover
/// read, before the lists' total is known.
pub(crate) struct BinCounts {
    pub params: wgpu::Buffer,
    /// Per new record, the tile range its footprint bounds.
    record_tiles: wgpu::Buffer,
    /// Per tile, the first entry of its list (tiles + 1 entries; the last is the total).
    pub tile_offsets: wgpu::Buffer,
    pub busy_tiles: wgpu::Buffer,
    pub busy_count: wgpu::Buffer,
    /// The cover's indirect dispatch, one workgroup per busy tile.
    pub cover_groups: wgpu::Buffer,
    pub tiles: [u32; 2],
    pub records: u32,
    sorted: bool,
}

impl BinCounts {
    fn scatter_label(&self) -> &'static str {
        if self.sorted {
            "splat: bin scatter"
        } else {
            "placement: cover bin scatter"
        }
    }
}

impl TileBins {
    fn stats(&self) -> SplatStats {
        SplatStats {
            records: self.records,
            tile_entries: self.total,
        }
    }
}

/// Statistics of one splat.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct SplatStats {
    pub records: u32,
    /// (record, tile) pairs binned.
    pub tile_entries: u32,
}

/// The splat passes (`splat_bin_count`, `prefix_sum` over the tiles, `splat_bin_scatter`,
/// `splat_bin_sort`, `splat_gather`, and placement's `splat_cover`).
/// What a splat, a cover or a binning reads: the frame's visible surfaces and their per-tile
/// bounds, and records `first..records.count` with the accuracy they splat at.
#[derive(Clone, Copy)]
pub struct SplatSource<'a> {
    /// The prepared scene (its bind group: the passes read instances and the camera).
    pub scene: &'a GpuScene,
    /// The frame's visibility buffer: the pixels records splat onto.
    pub vis: &'a VisibilityBuffer,
    /// Per-tile bounds of `vis` ([`SplatPass::tile_bounds`]), for binning.
    pub bounds: &'a TileBounds,
    /// The record buffer; records `first..records.count` are splatted.
    pub records: &'a RecordCache,
    pub first: u32,
    /// Ward's accuracy a: a record contributes where its error is at most a.
    pub accuracy: f32,
    /// Below this error a record's weight stops growing (`splat_weight`): 0 but in a
    /// gather widened for noisy records (`records::noise_widening::weight_plateau`).
    pub plateau: f32,
    /// A pixel that only dark records reach (E exactly 0: planes that saw no light, even
    /// refined) keeps empty sums, for tail fill to give it the lit records that reach it
    /// at the tail's accuracy: a still frame's gather of plane records. P^2 rays that all
    /// miss a bright patch of small solid angle are no evidence that the record's
    /// surroundings are dark, and splatting their zeros alone drew floors of exactly zero
    /// indirect light where the reference has some (docs/results.md, "Pixels only dark
    /// records reach"). Where a lit record reaches too, dark records count as before.
    pub dark_only_empty: bool,
    /// Whether the records' corrals apply ([`crate::records::Record::corral_allows`]), as
    /// [`crate::records::Corral`] says for placement's cover and the gathers; never in
    /// tail fill's gather, so that a pixel they keep from every lit record is not left
    /// black.
    pub corral: bool,
}

impl<'a> SplatSource<'a> {
    /// Records `first..records.count` splatted at `accuracy` as every splat but a still
    /// frame's final gather splats them: no weight plateau, dark records counted like any
    /// other; the corrals weighed or not (`corral`).
    pub fn new(
        scene: &'a GpuScene,
        vis: &'a VisibilityBuffer,
        bounds: &'a TileBounds,
        records: &'a RecordCache,
        first: u32,
        accuracy: f32,
        corral: bool,
    ) -> Self {
        Self {
            scene,
            vis,
            bounds,
            records,
            first,
            accuracy,
            plateau: 0.0,
            dark_only_empty: false,
            corral,
        }
    }
}

pub struct SplatPass {
    /// Binning records into tiles: the gather's, and the binned cover's on large images.
    /// Built at first use, like the gathers: a still frame first asks for them after its
    /// placement, so they can build while it places records (`SplatPass::build_late`).
    binning: OnFirstUse<Binning>,
    gather: OnFirstUse<GatherPipelines>,
    /// Tail fill's gather over the listed empty pixels.
    fill: OnFirstUse<GatherPipelines>,
    /// What a record-by-record cover (`cover::CoverMode`) gives as its lists' total: a
    /// zero, never written (it has no lists), made once rather than every round.
    no_lists_total: wgpu::Buffer,
    count_coverage: std::sync::Arc<ComputePass>,
    bounds: std::sync::Arc<ComputePass>,
    /// The tile bounds of the pixels tail fill's gather fills (`EMPTY_ONLY`).
    fill_bounds: std::sync::Arc<ComputePass>,
    /// The blocks' bounds from their tiles' (after `bounds` or `fill_bounds`).
    block_bounds: std::sync::Arc<ComputePass>,
    /// What `bounds` binds for the sums it does not read and the empty pixels it does not
    /// list.
    no_sums: wgpu::Buffer,
    no_empty: tile_bounds::EmptyPixels,
    /// The widened gather's check against the default one, built when a frame first widens.
    consistency: OnFirstUse<consistency::ConsistencyPass>,
    /// The records as the gathers read them where their pipelines read texel tables
    /// ([`ComputePass::reads_texel_tables`]), copied before each gather.
    record_texels: crate::gpu::texel_table::TexelCopy,
}

/// The splat passes' parameters (`SplatParams`) for `src`, and its image's tiles (x, y),
/// checked against its tile bounds'.
fn splat_params(
    ctx: &GpuContext,
    src: SplatSource,
    into: SplatInto,
    count_coverage: u32,
) -> Result<(wgpu::Buffer, [u32; 2])> {
    let SplatSource {
        vis,
        bounds,
        records: cache,
        first,
        accuracy,
        plateau,
        dark_only_empty,
        // Pipelines, not parameters, weigh the corrals (`CORRAL`).
        ..
    } = src;
    let (width, height) = (vis.width, vis.height);
    let tiles_x = width.div_ceil(TILE_SIZE);
    let tiles_y = height.div_ceil(TILE_SIZE);
    if [bounds.tiles_x, bounds.tiles_y] != [tiles_x, tiles_y] {
        return Err(Error::Usage(format!(
            "splat: tile bounds of {}x{} tiles for an image of {tiles_x}x{tiles_y}",
            bounds.tiles_x, bounds.tiles_y
        )));
    }
    let params = ctx.uniform_buffer(
        "splat params",
        &SplatParams {
            width,
            height,
            tiles_x,
            tiles_y,
            first_record: first,
            record_end: cache.count,
            accuracy,
            accumulate: into as u32,
            count_coverage,
            plateau,
            dark_only_empty: u32::from(dark_only_empty),
            _pad: 0,
        },
    );
    Ok((params, [tiles_x, tiles_y]))
}

impl SplatPass {
    /// Builds now placement's record-by-record covers for a frame with `corral` (with the
    /// records' corrals first when the cover weighs them: a still frame's first rounds ask
    /// for it, tail fill for the other). The device keeps them. (The binned cover, for
    /// images of more than `cover::BY_RECORD_MAX_TILES` tiles, builds at its first round
    /// from the binning, [`Self::build_late`].)
    pub fn build_covers(&self, ctx: &GpuContext, corral: crate::records::Corral) -> Result<()> {
        if corral.in_cover() {
            self.cover_by_record_pipeline(ctx, true)?;
        }
        self.cover_by_record_pipeline(ctx, false).map(|_| ())
    }

    pub fn new(ctx: &GpuContext) -> Result<Self> {
        use Binding::*;
        Ok(Self {
            binning: OnFirstUse::new(),
            gather: OnFirstUse::new(),
            fill: OnFirstUse::new(),
            no_lists_total: ctx.storage_buffer_sized("cover lists total (none)", 4)?,
            count_coverage: ComputePass::new(
                ctx,
                "coverage_count.wgsl",
                &[Uniform, StorageRead, StorageRead, StorageReadWrite],
            )?,
            bounds: ComputePass::new(ctx, "splat_tile_bounds.wgsl", TILE_BOUNDS_BINDINGS)?,
            fill_bounds: ComputePass::with_constants(
                ctx,
                "splat_tile_bounds.wgsl",
                TILE_BOUNDS_BINDINGS,
                &[("EMPTY_ONLY", 1.0)],
            )?,
            block_bounds: ComputePass::new(
                ctx,
                "splat_block_bounds.wgsl",
                &[Uniform, StorageReadWrite],
            )?,
            no_sums: ctx.storage_buffer_sized("no splat sums", 16)?,
            record_texels: crate::gpu::texel_table::TexelCopy::new(ctx, "record texels")?,
            no_empty: tile_bounds::EmptyPixels {
                list: ctx.storage_buffer_sized("no empty pixels", 4)?,
                count: ctx.storage_buffer_sized("no empty pixel count", 4)?,
            },
            consistency: OnFirstUse::new(),
        })
    }

    /// The pipelines that bin records into tiles, built at their first use.
    fn binning(&self, ctx: &GpuContext) -> Result<&Binning> {
        self.binning.get(|| Binning::new(ctx))
    }

    /// The gather's pipelines, the still frame's (no counting, no corral) built with them.
    fn gather(&self, ctx: &GpuContext) -> Result<&GatherPipelines> {
        self.gather
            .get(|| GatherPipelines::new(ctx, "splat_gather.wgsl", GATHER_BINDINGS.to_vec()))
    }

    /// Tail fill's gather pipelines, as [`Self::gather`].
    fn fill(&self, ctx: &GpuContext) -> Result<&GatherPipelines> {
        self.fill.get(|| {
            GatherPipelines::new(
                ctx,
                "splat_fill.wgsl",
                [GATHER_BINDINGS, FILL_EXTRA_BINDINGS].concat(),
            )
        })
    }

    /// Builds the pipelines a still frame with `corral` first asks for once its placement
    /// is done: the binning, the gather and tail fill's gather, and with `widening` the
    /// widened gather's check. A frame asks for them itself when it needs them; built
    /// ahead on other threads (`Renderer::build_ahead`), they build while
    /// the frame places its records, when lavapipe leaves a core idle (its compilations at
    /// a pipeline's first dispatch, one at a time, and the plane passes' last workgroups).
    pub fn build_late(
        &self,
        ctx: &GpuContext,
        corral: crate::records::Corral,
        widening: bool,
    ) -> Result<()> {
        self.binning(ctx)?;
        self.gather(ctx)?
            .for_mode(ctx, COUNT_NONE, corral.in_gathers())?;
        self.fill(ctx)?;
        if widening {
            self.consistency(ctx)?;
        }
        Ok(())
    }

    /// The check of a widened gather against the default one
    /// ([`consistency::ConsistencyPass`]), built when a frame first widens.
    pub fn consistency(&self, ctx: &GpuContext) -> Result<&consistency::ConsistencyPass> {
        self.consistency
            .get(|| consistency::ConsistencyPass::new(ctx))
    }

    /// Splats `src`'s records into `out`: onto its previous sums when `accumulate`, else
    /// from zero. Appends per-pass GPU times to `times`.
    pub fn splat(
        &self,
        ctx: &GpuContext,
        src: SplatSource,
        out: &SplatBuffer,
        accumulate: bool,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<SplatStats> {
        let into = if accumulate {
            SplatInto::Accumulate
        } else {
            SplatInto::Fresh
        };
        self.gather_into(ctx, src, out, into, times)
    }

    /// Tail fill's gather: `src`'s records, at `src`'s accuracy (the tail's, wider than the
    /// first gather's), give their sums to the pixels of `out` whose sums are still empty
    /// (no record reached them at the first gather's accuracy); the others keep theirs.
    /// It bins against tile bounds of those pixels alone (`fill_tile_bounds`), not
    /// `src.bounds`: tiles without any bin nothing; and gathers over the list of those
    /// pixels (`splat_fill.wgsl`), not over the busy tiles' every pixel. Returns how many
    /// pixels were empty before it (0: it changed nothing, and a wider fill after it
    /// would find none).
    pub fn fill_empty(
        &self,
        ctx: &GpuContext,
        src: SplatSource,
        out: &SplatBuffer,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<u32> {
        let (bounds, empty) = self.fill_tile_bounds(ctx, src.scene, src.vis, out, times)?;
        // A still frame runs the fill wherever it reaches further than the gather (pixels
        // only dark records reach are left to it, `SplatSource::dark_only_empty`); most
        // have no empty pixel, and then nothing is binned.
        let pixels = ctx
            .read_buffer::<u32>(&empty.count)?
            .first()
            .copied()
            .unwrap_or(0);
        if pixels == 0 {
            return Ok(0);
        }
        let src = SplatSource {
            bounds: &bounds,
            ..src
        };
        out.check_room(src.records)?;
        let bins = self.bin(ctx, src, (SplatInto::FillEmpty, out.coverage_mode), times)?;
        if bins.total == 0 {
            return Ok(pixels);
        }
        let mut timer = PassTimer::new(ctx, 1);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        // Tail fill weighs no corral (`SplatSource::corral`).
        let fill = self.fill(ctx)?.for_mode(ctx, out.coverage_mode, false)?;
        let bind = self.bind_gather(
            ctx,
            &mut enc,
            &fill,
            (&bins, src.vis, src.records, out),
            &[&empty.list, &empty.count],
        )?;
        fill.record(
            &mut enc,
            &src.scene.bind_group,
            &bind,
            crate::gpu::pipeline::linear_groups(ctx, pixels),
            timer.next("splat: tail fill gather"),
        );
        timer.resolve(&mut enc);
        ctx.queue.submit([enc.finish()]);
        times.extend(timer.read(ctx)?);
        Ok(pixels)
    }

    /// Binds a gather pipeline (`pass`: the gather's or tail fill's) to the bindings both
    /// share (`shared/splat_pixel.wgsl`: the bins, the visibility samples, the records and
    /// their texel table, the sums), then `extra`. Where the pipeline reads texel tables,
    /// records the copy of the records into `enc` first.
    fn bind_gather(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        pass: &ComputePass,
        (bins, vis, records, out): (&TileBins, &VisibilityBuffer, &RecordCache, &SplatBuffer),
        extra: &[&wgpu::Buffer],
    ) -> Result<wgpu::BindGroup> {
        let record_texels = self.record_texels.view(
            ctx,
            enc,
            &records.buffer,
            u64::from(records.count) * RECORD_TEXELS,
            pass.reads_texel_tables(),
        )?;
        let mut resources = vec![
            bins.params.as_entire_binding(),
            vis.samples.as_entire_binding(),
            records.buffer.as_entire_binding(),
            bins.tile_offsets.as_entire_binding(),
            bins.sorted.as_entire_binding(),
            out.sums.as_entire_binding(),
            out.coverage.as_entire_binding(),
            out.expiring.as_entire_binding(),
            wgpu::BindingResource::TextureView(&record_texels),
        ];
        resources.extend(extra.iter().map(|b| b.as_entire_binding()));
        Ok(pass.bind_resources(ctx, &resources))
    }

    fn gather_into(
        &self,
        ctx: &GpuContext,
        src: SplatSource,
        out: &SplatBuffer,
        into: SplatInto,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<SplatStats> {
        let accumulate = into != SplatInto::Fresh;
        let SplatSource {
            scene,
            vis,
            records: cache,
            ..
        } = src;
        out.check_room(cache)?;
        let bins = self.bin(ctx, src, (into, out.coverage_mode), times)?;
        let mut timer = PassTimer::new(ctx, 1);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        if bins.total > 0 || !accumulate {
            let gather = self
                .gather(ctx)?
                .for_mode(ctx, out.coverage_mode, src.corral)?;
            let bind = self.bind_gather(ctx, &mut enc, &gather, (&bins, vis, cache, out), &[])?;
            gather.record(
                &mut enc,
                &scene.bind_group,
                &bind,
                image_groups(vis.width, vis.height),
                timer.next("splat: gather"),
            );
        }
        timer.resolve(&mut enc);
        ctx.queue.submit([enc.finish()]);
        times.extend(timer.read(ctx)?);
        Ok(bins.stats())
    }

    /// Bins `src`'s records into the `TILE_SIZE`-pixel tiles their footprints bound, for a
    /// gather: counts, prefix sum, scatter and the rank sort by record id that makes its
    /// sums deterministic, timed as "splat: bin ...". `(into, count_coverage)` go into the
    /// bins' parameters. Waits for the GPU once, for the lists' total size (placement's
    /// cover, which needs no order, sizes them ahead instead: [`Self::cover_in_flight`]).
    pub(crate) fn bin(
        &self,
        ctx: &GpuContext,
        src: SplatSource,
        (into, count_coverage): (SplatInto, u32),
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<TileBins> {
        // Count and scan, then read the total to size the lists.
        let mut timer = PassTimer::new(ctx, 2);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let counts =
            self.record_bin_counts(ctx, src, (into, count_coverage), true, &mut enc, &mut timer)?;
        timer.resolve(&mut enc);
        let totals_buf = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("splat totals"),
            size: 4,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let tiles = counts.tiles[0] * counts.tiles[1];
        enc.copy_buffer_to_buffer(
            &counts.tile_offsets,
            u64::from(tiles) * 4,
            &totals_buf,
            0,
            4,
        );
        ctx.queue.submit([enc.finish()]);
        times.extend(timer.read(ctx)?);
        let total = ctx
            .read_buffer::<u32>(&totals_buf)?
            .first()
            .copied()
            .unwrap_or(0);

        // Scatter, then sort.
        let entries = ctx.storage_buffer_sized("tile entries", u64::from(total) * 8)?;
        let sorted = ctx.storage_buffer_sized("sorted tile entries", u64::from(total) * 4)?;
        if total > 0 {
            let mut timer = PassTimer::new(ctx, 2);
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            self.record_bin_scatter(ctx, src, &counts, &entries, &mut enc, &mut timer)?;
            let sort = &self.binning(ctx)?.sort;
            let bind = sort.bind(
                ctx,
                &[&counts.params, &counts.tile_offsets, &entries, &sorted],
            );
            sort.record(
                &mut enc,
                &src.scene.bind_group,
                &bind,
                crate::gpu::pipeline::linear_groups(ctx, total),
                timer.next("splat: bin sort"),
            );
            timer.resolve(&mut enc);
            ctx.queue.submit([enc.finish()]);
            times.extend(timer.read(ctx)?);
        }
        Ok(TileBins {
            params: counts.params,
            tile_offsets: counts.tile_offsets,
            sorted,
            tiles: counts.tiles,
            records: counts.records,
            total,
        })
    }

    /// Binning's first half, recorded into `enc`: each record's tile range and the count
    /// per tile, their prefix sum (`tile_offsets`, whose last entry is the lists' total) and,
    /// for unsorted bins, the list of busy tiles with the cover's indirect dispatch.
    fn record_bin_counts(
        &self,
        ctx: &GpuContext,
        src: SplatSource,
        (into, count_coverage): (SplatInto, u32),
        sorted: bool,
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
    ) -> Result<BinCounts> {
        let SplatSource {
            scene,
            vis,
            bounds,
            records: cache,
            first,
            ..
        } = src;
        let (params, [tiles_x, tiles_y]) = splat_params(ctx, src, into, count_coverage)?;
        let tiles = tiles_x * tiles_y;
        let records = cache.count.saturating_sub(first);
        let record_tiles = ctx.storage_buffer_sized("record tiles", u64::from(records) * 16)?;
        let tile_counts = ctx.storage_buffer_sized("tile counts", u64::from(tiles) * 4)?;
        let tile_offsets = ctx.storage_buffer_sized("tile offsets", u64::from(tiles + 1) * 4)?;
        let busy_tiles =
            ctx.storage_buffer_sized("busy tiles", if sorted { 4 } else { u64::from(tiles) * 4 })?;
        let busy_count = ctx.storage_buffer_sized("busy tile count", 4)?;
        // The cover's workgroups, one per busy tile (x y z, raised from 0 1 1 by
        // `splat_bin_tiles.wgsl`).
        let cover_groups = wgpu::util::DeviceExt::create_buffer_init(
            &ctx.device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("cover groups"),
                contents: bytemuck::cast_slice(&[0u32, 1, 1]),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT,
            },
        );
        let [count_label, scan_label] = if sorted {
            ["splat: bin count", "splat: bin scan"]
        } else {
            ["placement: cover bin count", "placement: cover bin scan"]
        };
        let binning = self.binning(ctx)?;
        if records > 0 {
            let bind = binning.count.bind(
                ctx,
                &[
                    &params,
                    &vis.camera_buffer,
                    &cache.buffer,
                    &record_tiles,
                    &tile_counts,
                    &bounds.buffer,
                ],
            );
            binning.count.record(
                enc,
                &scene.bind_group,
                &bind,
                crate::gpu::pipeline::linear_groups(ctx, records),
                timer.next(count_label),
            );
        }
        binning.scan.record(
            ctx,
            enc,
            &scene.bind_group,
            &tile_counts,
            &tile_offsets,
            tiles,
            timer.next(scan_label),
        );
        if !sorted {
            // Only the cover dispatches over the busy tiles; a gather runs every tile.
            let bind = binning.busy_tiles.bind(
                ctx,
                &[
                    &params,
                    &tile_offsets,
                    &busy_tiles,
                    &busy_count,
                    &cover_groups,
                ],
            );
            binning.busy_tiles.record(
                enc,
                &scene.bind_group,
                &bind,
                crate::gpu::pipeline::linear_groups(ctx, tiles),
                timer.next(scan_label),
            );
        }
        Ok(BinCounts {
            params,
            record_tiles,
            tile_offsets,
            busy_tiles,
            busy_count,
            cover_groups,
            tiles: [tiles_x, tiles_y],
            records,
            sorted,
        })
    }

    /// Binning's second half, recorded into `enc`: each record writes `(record, tile)`
    /// into its tiles' lists in `entries`. A list that would run past `entries` is cut
    /// there (`splat_bin_scatter.wgsl`); a cover of such bins marks nothing
    /// (`splat_cover.wgsl`).
    fn record_bin_scatter(
        &self,
        ctx: &GpuContext,
        src: SplatSource,
        counts: &BinCounts,
        entries: &wgpu::Buffer,
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
    ) -> Result<()> {
        if counts.records == 0 {
            return Ok(());
        }
        let tiles = counts.tiles[0] * counts.tiles[1];
        let cursors = ctx.storage_buffer_sized("tile cursors", u64::from(tiles) * 4)?;
        let scatter = &self.binning(ctx)?.scatter;
        let bind = scatter.bind(
            ctx,
            &[
                &counts.params,
                &counts.record_tiles,
                &counts.tile_offsets,
                &cursors,
                entries,
                &src.records.buffer,
                &src.bounds.buffer,
            ],
        );
        scatter.record(
            enc,
            &src.scene.bind_group,
            &bind,
            crate::gpu::pipeline::linear_groups(ctx, counts.records),
            timer.next(counts.scatter_label()),
        );
        Ok(())
    }
}
