//! The seam where a higher layer plugs into record computation without records/ knowing
//! it. [`RecordPass::compute`](super::RecordPass::compute) computes records in batches
//! (sites → planes → reduction); a [`RecordStage`] may replace a batch's tracing, read
//! its planes, and reduce more planes after it. Temporal caching is the stage today
//! (`temporal::Lookahead`: capture the planes and estimate each record at t+1;
//! `temporal::plane_refresh`: refresh planes instead of tracing them), so the static
//! pipeline (records/, placement/, frame.rs) never imports temporal/.

use super::{CacheSettings, PlaneTable, RecordCache, RecordPass};
use crate::Result;
use crate::gpu::GpuContext;
use crate::gpu::scene_buffers::GpuScene;
use crate::gpu::timer::PassTimer;

/// One batch of new records on the GPU, as a [`RecordStage`] sees it.
pub struct PlaneBatch<'a> {
    /// The batch's [`super::RecordSite`]s, `count` of them.
    pub sites: &'a wgpu::Buffer,
    /// Their planes: `P^2` [`super::PlaneSample`]s per site.
    pub samples: &'a wgpu::Buffer,
    /// The same planes as traced, before adaptive refinement (`samples` itself when the
    /// pass refines nothing or a stage replaced the tracing): what goes with `hits`, the
    /// centre rays' hits, for a stage that moves them (temporal caching's estimate at
    /// t+1 and the subset it is compared with).
    pub traced: &'a wgpu::Buffer,
    /// What each sample hit (`P^2` WGSL `PlaneHit`s per site); written because a stage is
    /// present.
    pub hits: &'a wgpu::Buffer,
    /// Cache index of the batch's first record.
    pub first_record: u32,
    /// Index of the batch's first site among the sites of the `compute` call.
    pub first_site: u32,
    /// Records in the batch.
    pub count: u32,
}

/// A stage of a higher layer run inside [`RecordPass::compute`]. Every method has a
/// default that does nothing, so a stage implements only what it adds.
pub trait RecordStage {
    /// Called once before the batches: `count` new records will be appended to `cache` in
    /// batches of at most `batch_records`.
    fn begin(
        &mut self,
        _ctx: &GpuContext,
        _cache: &RecordCache,
        _count: u32,
        _batch_records: u32,
    ) -> Result<()> {
        Ok(())
    }

    /// Records the planes of `batch` into `batch.samples` (and `batch.hits`) instead of the
    /// plane pass; `Ok(false)` leaves the tracing to the plane pass.
    #[allow(clippy::too_many_arguments)]
    fn replace_tracing(
        &mut self,
        _ctx: &GpuContext,
        _enc: &mut wgpu::CommandEncoder,
        _scene: &GpuScene,
        _settings: &CacheSettings,
        _table: &PlaneTable,
        _batch: &PlaneBatch<'_>,
        _timer: &mut PassTimer,
    ) -> Result<bool> {
        Ok(false)
    }

    /// The batch's planes are recorded (traced or replaced), its reduction not yet.
    fn planes_ready(
        &mut self,
        _ctx: &GpuContext,
        _enc: &mut wgpu::CommandEncoder,
        _batch: &PlaneBatch<'_>,
        _resolution: u32,
    ) -> Result<()> {
        Ok(())
    }

    /// The batch's reduction is recorded; `pass` can reduce other planes
    /// ([`RecordPass::record_reduction`]).
    fn reduced(
        &mut self,
        _ctx: &GpuContext,
        _enc: &mut wgpu::CommandEncoder,
        _scene: &GpuScene,
        _pass: &RecordPass,
        _batch: &PlaneBatch<'_>,
        _timer: &mut PassTimer,
    ) -> Result<()> {
        Ok(())
    }

    /// The batch was submitted and its `count` records appended to the cache.
    fn batch_done(&mut self, _count: u32) {}
}
