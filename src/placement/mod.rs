//! Record placement (cache-miss detection) on the GPU, parallel and deterministic: rounds
//! of "find uncovered visible pixels, pick sites that do not crowd each other, compute
//! their records, splat them" until every visible pixel is covered (no record with
//! w >= 1/a, algorithms.md decision 2) or the record budget is reached.
//!
//! Sites: the screen is cut into cells, coarse to fine (64 px halving to 4 px); each round
//! activates one of the four 2 x 2 parity classes of cells, and each active cell proposes
//! its uncovered pixel nearest its centre. New records of a round are thus at least a cell
//! apart, and later rounds see their coverage, much like the thesis's sequential scan
//! (Algorithm 4, kept as [`sequential`]) but with thousands of records per round.
//!
//! Tail fill ([`crate::records::CacheSettings::tail_share`]): the last rounds of a large
//! image place records into slivers between earlier records' footprints, each newly
//! covering a few pixels (Sponza sun 1000x1000: the last 3.7 % of the pixels took half the
//! records, 1 to 10 new pixels each). Once at most `tail_share` of the visible pixels is
//! uncovered, and records cover on average at least `TAIL_MIN_PIXELS_PER_RECORD` pixels
//! each, later rounds cover at the tail's wider accuracy: a new record marks the pixels it
//! reaches there, so the sliver pixels around it need no records of their own. The
//! gather then gives each pixel that no record reaches at a the records that reach it at
//! the wider accuracy (`SplatPass::fill_empty`). Covering again every earlier record at
//! the wider accuracy when the tail begins was tried and left out: it also relaxes the
//! real gaps between records (Cornell box 128x128: 1.65 % indirect error against 1.41 %).

pub mod sequential;

use crate::Result;
use crate::gpu::GpuContext;
use crate::gpu::pipeline::{Binding, ComputePass};
use crate::gpu::scene_buffers::GpuScene;
use crate::light_maps::LightMaps;
use crate::records::{RecordCache, RecordPass, RecordSource, RecordStage};
use crate::splat::{CoverInFlight, CoverageMask, SplatPass, SplatSource, TileBounds};
use crate::visibility::VisibilityBuffer;
use bytemuck::{Pod, Zeroable};

/// `NO_CANDIDATE` in `wgsl/placement_select.wgsl`.
const NO_CANDIDATE: u32 = u32::MAX;
/// Coarsest and finest cell edge in pixels.
const FIRST_CELL: u32 = 64;
const LAST_CELL: u32 = 4;
/// Full parity cycles at the finest cell size before placement gives up (each cycle covers
/// every candidate pixel it picks, so this only stops pathological cases).
const MAX_FINE_CYCLES: u32 = 256;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct SelectParams {
    width: u32,
    height: u32,
    cell_size: u32,
    cells_x: u32,
    cells_y: u32,
    first_parity: u32,
    _pad: [u32; 2],
}

/// What placement did in one frame.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct PlacementStats {
    /// Records added this frame.
    pub new_records: u32,
    /// Rounds that added records.
    pub rounds: u32,
    /// Placement stopped at the record budget or the per-frame limit with pixels still
    /// uncovered.
    pub limit_reached: bool,
    /// Records in the cache when tail fill began (`None`: it did not).
    pub tail_from_record: Option<u32>,
    /// Records added by tail fill, with planes at the tail's resolution
    /// ([`crate::records::CacheSettings::tail_plane_resolution`]).
    pub tail_records: u32,
    /// Hemisphere-plane rays the added records traced (plane pixels plus refined
    /// sub-samples; VPL records count none).
    pub plane_rays: u64,
}

/// Tail fill only where records are large on screen: the records so far cover at least this
/// many pixels each on average. Where they are small (low resolutions), the last records
/// are not slivers but the spacing itself, and leaving them out costs accuracy: Cornell box
/// 64x64 (32x32 planes) 542 -> 484 records, indirect error 1.49 -> 1.91 %; 128x128 1,191
/// -> 975, 1.34 -> 1.41 %; conference room 160x120 2,467 -> 2,081, 3.06 -> 3.17 %; Sponza
/// sun 1000x1000 14,512 -> 8,554, 10.19 -> 10.51 % (records there cover 68 pixels each on
/// average, the Cornell box's 13, the conference room's 7).
const TAIL_MIN_PIXELS_PER_RECORD: f64 = 32.0;

/// Tail fill's bookkeeping: the visible pixels, those covered when placement began, and
/// the mask's marks then (`splat_cover.wgsl` counts the pixels it marks).
struct TailFill {
    visible: u32,
    covered: u32,
    marked: u32,
    share: f32,
}

impl TailFill {
    fn start(
        ctx: &GpuContext,
        scene: &GpuScene,
        vis: &VisibilityBuffer,
        splat_pass: &SplatPass,
        mask: &CoverageMask,
        share: f32,
    ) -> Result<Self> {
        let (visible, covered) = splat_pass.coverage_counts(ctx, scene, vis, mask)?;
        Ok(Self {
            visible,
            covered,
            marked: mask.marked(ctx)?,
            share,
        })
    }

    /// At most `share` of the visible pixels left uncovered, by records that cover on
    /// average at least [`TAIL_MIN_PIXELS_PER_RECORD`] pixels each (`records` in the cache);
    /// `marked`: the mask's marks now.
    fn reached(&self, marked: u32, records: u32) -> bool {
        let covered = self.covered + marked.saturating_sub(self.marked);
        let uncovered = self.visible.saturating_sub(covered);
        f64::from(uncovered) <= f64::from(self.share) * f64::from(self.visible)
            && f64::from(covered) >= TAIL_MIN_PIXELS_PER_RECORD * f64::from(records.max(1))
    }
}

/// The placement pass (`wgsl/placement_select.wgsl`) and its round loop.
pub struct PlacementPass {
    select: std::sync::Arc<ComputePass>,
}

impl PlacementPass {
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        use Binding::*;
        Ok(Self {
            select: ComputePass::new(
                ctx,
                "placement_select.wgsl",
                &[Uniform, StorageRead, StorageRead, StorageReadWrite],
            )?,
        })
    }

    /// Candidate pixels of the parity classes `from..4` of one cell size, in cell order,
    /// all selected against the same coverage in one dispatch, with the mask's marked
    /// count (for tail fill): one submission and one wait. Placement uses the first class with
    /// candidates; its records change the coverage, so the later classes are selected
    /// again after them (a class without candidates has none after more coverage either).
    /// `in_flight`: the last round's cover, whose lists' total is read in the same wait
    /// (returned last, 0 without one).
    #[allow(clippy::too_many_arguments)]
    fn candidates(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        vis: &VisibilityBuffer,
        mask: &CoverageMask,
        cell_size: u32,
        from: u32,
        in_flight: Option<&CoverInFlight>,
    ) -> Result<(Vec<Vec<u32>>, u32, u32)> {
        let cells_x = vis.width.div_ceil(cell_size);
        let cells_y = vis.height.div_ceil(cell_size);
        // Cells of each parity class `from..4`; the shader writes one slot for each, class
        // after class, in one dispatch.
        let active: Vec<u32> = (from..4)
            .map(|parity| {
                let half_x = (cells_x + 1 - parity % 2) / 2;
                let half_y = (cells_y + 1 - parity / 2) / 2;
                half_x * half_y
            })
            .collect();
        let cells: u32 = active.iter().sum();
        let out = ctx.storage_buffer_sized("candidates", u64::from(cells.max(1)) * 4)?;
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        if cells > 0 {
            let params = ctx.uniform_buffer(
                "select params",
                &SelectParams {
                    width: vis.width,
                    height: vis.height,
                    cell_size,
                    cells_x,
                    cells_y,
                    first_parity: from,
                    _pad: [0; 2],
                },
            );
            let bind = self
                .select
                .bind(ctx, &[&params, &vis.samples, &mask.covered, &out]);
            self.select.record(
                &mut enc,
                &scene.bind_group,
                &bind,
                [cells.div_ceil(64), 1, 1],
                None,
            );
        }
        ctx.queue.submit([enc.finish()]);
        let mut reads: Vec<&wgpu::Buffer> = vec![&out];
        reads.push(&mask.marked);
        if let Some(cover) = in_flight {
            reads.push(&cover.total);
        }
        let mut all: Vec<Vec<u32>> = ctx.read_buffers(&reads)?;
        let total = match in_flight {
            Some(_) => all.pop().and_then(|t| t.first().copied()).unwrap_or(0),
            None => 0,
        };
        let marked = all.pop().and_then(|m| m.first().copied()).unwrap_or(0);
        let slots = all.pop().unwrap_or_default();
        let mut start = 0usize;
        let lists = active
            .iter()
            .map(|&n| {
                let end = (start + n as usize).min(slots.len());
                let list: Vec<u32> = slots[start..end]
                    .iter()
                    .copied()
                    .filter(|&p| p != NO_CANDIDATE)
                    .collect();
                start = end;
                list
            })
            .collect();
        Ok((lists, marked, total))
    }

    /// Adds records until every visible pixel is covered, `limit` records were added, or
    /// the cache reaches `budget`. `mask` must mark the pixels the records already in the
    /// cache cover; it is kept up to date (the weighted splat is the caller's, once
    /// placement is done). `progress` gets the records added. The rounds' pass timers
    /// are read once, at the end ([`GpuContext::deferring_pass_times`]): a round then
    /// waits for the GPU once (its candidates, with the last round's cover lists' total:
    /// [`SplatPass::cover_in_flight`]), not seven times.
    #[allow(clippy::too_many_arguments)]
    pub fn place(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        vis: &VisibilityBuffer,
        cache: &mut RecordCache,
        records: &RecordPass,
        splat_pass: &SplatPass,
        bounds: &TileBounds,
        mask: &CoverageMask,
        light_maps: Option<&LightMaps>,
        limit: Option<u32>,
        mut stage: Option<&mut (dyn RecordStage + '_)>,
        times: &mut Vec<(&'static str, f64)>,
        mut progress: impl FnMut(u32),
    ) -> Result<PlacementStats> {
        let (stats, deferred) = ctx.deferring_pass_times(|| {
            let settings = &records.settings;
            let mut stats = PlacementStats::default();
            let mut cell = FIRST_CELL;
            let mut fine_cycles = 0;
            // Covers at the tail's accuracy once at most `tail_share` of the visible pixels is
            // uncovered (checked before the first round too: held records may cover enough).
            let tail_accuracy = settings.tail_accuracy();
            let tail = if tail_accuracy > settings.accuracy {
                Some(TailFill::start(
                    ctx,
                    scene,
                    vis,
                    splat_pass,
                    mask,
                    settings.tail_share,
                )?)
            } else {
                None
            };
            let mut cover_accuracy = settings.accuracy;
            // The last round's cover, submitted without a wait (`SplatPass::cover_in_flight`),
            // with the first record and the accuracy it covered: its lists' total comes back
            // with the next candidates, and where they overflowed their room (it then marked
            // nothing) the cover is made again with room for them, before anything reads
            // the mask. A round's room grows after an overflow and stays.
            let mut in_flight: Option<(CoverInFlight, u32, f32)> = None;
            let mut cover_room = crate::splat::cover::cover_room(vis.width, vis.height);
            // Covers records `first..` of the cache at `accuracy` with room for `room` list
            // entries, without a wait.
            let cover_records =
                |cache: &RecordCache,
                 first: u32,
                 accuracy: f32,
                 room: u32,
                 times: &mut Vec<(&'static str, f64)>| {
                    let records = SplatSource::new(
                        scene,
                        vis,
                        bounds,
                        cache,
                        first,
                        accuracy,
                        // Tail fill's records cover at the tail's accuracy, where its
                        // gather serves the pixels they reach, and that gather weighs no
                        // corral: neither does their cover (with it, the Cornell box
                        // 256x256 took 2,214 records in 37 rounds, 706 of them in the
                        // tail; without, 2,059 in 31, 551 in the tail).
                        settings.corral.in_cover() && accuracy <= settings.accuracy,
                    );
                    splat_pass.cover_in_flight(ctx, records, mask, room, times)
                };
            'rounds: loop {
                let mut placed = 0;
                let mut parity = 0;
                while parity < 4 {
                    let (lists, marked, total) = self.candidates(
                        ctx,
                        scene,
                        vis,
                        mask,
                        cell,
                        parity,
                        in_flight.as_ref().map(|(cover, _, _)| cover),
                    )?;
                    if let Some((cover, first, accuracy)) = in_flight.take()
                        && !cover.fitted(total)
                    {
                        // Its lists overflowed, so it marked nothing: cover again with
                        // room for them (no wait: it fits), then select again against the
                        // complete mask. Room to spare from then on, within what one binding
                        // holds (the cover made again needs `total` itself, and refuses more).
                        let most = u32::try_from(ctx.max_binding_size() / 8).unwrap_or(u32::MAX);
                        cover_room = total
                            .checked_next_power_of_two()
                            .unwrap_or(total)
                            .min(most)
                            .max(total.min(most));
                        cover_records(cache, first, accuracy, total, times)?;
                        continue;
                    }
                    // Tail fill begins once the records so far cover enough (the marks are
                    // those after the last round).
                    if let Some(tail) = &tail
                        && cover_accuracy < tail_accuracy
                        && tail.reached(marked, cache.count)
                    {
                        cover_accuracy = tail_accuracy;
                        stats.tail_from_record = Some(cache.count);
                    }
                    let Some((skipped, mut pixels)) = lists
                        .into_iter()
                        .enumerate()
                        .find(|(_, pixels)| !pixels.is_empty())
                    else {
                        break;
                    };
                    parity += skipped as u32 + 1;
                    let room_budget = settings.record_budget.saturating_sub(cache.count);
                    let room_limit =
                        limit.map_or(u32::MAX, |l| l.saturating_sub(stats.new_records));
                    let room = room_budget.min(room_limit) as usize;
                    if pixels.len() > room {
                        pixels.truncate(room);
                        stats.limit_reached = true;
                    }
                    if !pixels.is_empty() {
                        let n = pixels.len() as u32;
                        let first = cache.count;
                        let sites = records.sites_from_pixels(ctx, scene, vis, &pixels, first)?;
                        // The tail's records trace coarser planes (they answer to its wider
                        // accuracy).
                        let in_tail = stats.tail_from_record.is_some();
                        let pass = if in_tail {
                            records.tail_pass(ctx)?
                        } else {
                            records
                        };
                        if in_tail {
                            stats.tail_records += n;
                        }
                        if pass.settings.source != RecordSource::Vpl {
                            stats.plane_rays +=
                                u64::from(n) * pass.settings.plane_rays_per_record();
                        }
                        times.extend(pass.compute(
                            ctx,
                            scene,
                            &sites,
                            n,
                            cache,
                            light_maps,
                            stage.as_deref_mut(),
                            |_| {},
                        )?);
                        in_flight = cover_records(cache, first, cover_accuracy, cover_room, times)?
                            .map(|c| (c, first, cover_accuracy));
                        stats.new_records += n;
                        stats.rounds += 1;
                        placed += n;
                        progress(stats.new_records);
                    }
                    if stats.limit_reached {
                        break 'rounds;
                    }
                }
                if placed == 0 {
                    break 'rounds;
                }
                if cell > LAST_CELL {
                    cell /= 2;
                } else {
                    fine_cycles += 1;
                    if fine_cycles >= MAX_FINE_CYCLES {
                        stats.limit_reached = true;
                        break 'rounds;
                    }
                }
            }
            // The last round's cover, if no candidates were read after it.
            if let Some((cover, first, accuracy)) = in_flight {
                let total: Vec<u32> = ctx.read_buffer(&cover.total)?;
                let total = total.first().copied().unwrap_or(0);
                if !cover.fitted(total) {
                    cover_records(cache, first, accuracy, total, times)?;
                }
            }
            Ok(stats)
        })?;
        times.extend(deferred);
        Ok(stats)
    }
}
