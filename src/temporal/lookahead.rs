//! Temporal caching's stages inside record computation ([`RecordStage`]): every new record
//! is also estimated at the next frame by reprojecting its plane ([`Lookahead`],
//! algorithms.md 4.3), and replacements may refresh their predecessor's plane instead of
//! tracing it ([`RefreshStage`], [`super::plane_refresh`]). The static pipeline runs them
//! through the [`RecordStage`] seam without knowing them.

use super::plane_refresh::{PlaneCapture, PlaneRefresh};
use super::reprojection::{NextFrame, ReprojectionPass};
use crate::gpu::GpuContext;
use crate::gpu::scene_buffers::GpuScene;
use crate::gpu::timer::PassTimer;
use crate::records::{
    CacheSettings, PlaneBatch, PlaneSample, PlaneTable, RecordCache, RecordPass, RecordSite,
    RecordStage, ReductionBatch,
};
use crate::{Error, Result};

/// What record computation needs to also estimate each new record at the next frame: the
/// scene at t+1 and the caches that receive the estimates at the same indices as the new
/// records.
pub struct Lookahead<'a> {
    pub next_frame: &'a NextFrame<'a>,
    pub reprojection: &'a ReprojectionPass,
    /// Records at t+1, in step with the cache (`next.count == cache.count`).
    pub next: &'a mut RecordCache,
    /// With an estimate stride above 1, the records of the samples at t the estimate was
    /// moved from (tau = E(t+1) / this); in step with the cache, written only then.
    pub subset: &'a mut RecordCache,
    /// Keeps the sites and traced planes of the records computed.
    pub capture: Option<&'a mut PlaneCapture>,
    /// Radiance records' estimates at t+1 carry their coefficient values only
    /// ([`super::TemporalSettings::estimates_values_only`]; the translational gradients
    /// are two thirds of the projection).
    pub values_only: bool,
    /// Whether the records are estimated at all: false keeps their sites and planes only
    /// ([`super::estimate_rule`]: the records then live one frame).
    pub estimate: bool,
    /// The estimated planes at t+1 and the samples at t they were moved from, sized to the
    /// largest batch of the current `compute` call.
    estimates: Option<(wgpu::Buffer, wgpu::Buffer)>,
}

impl<'a> Lookahead<'a> {
    pub fn new(
        next_frame: &'a NextFrame<'a>,
        reprojection: &'a ReprojectionPass,
        next: &'a mut RecordCache,
        subset: &'a mut RecordCache,
        capture: Option<&'a mut PlaneCapture>,
        values_only: bool,
        estimate: bool,
    ) -> Self {
        Self {
            next_frame,
            reprojection,
            next,
            subset,
            capture,
            values_only,
            estimate,
            estimates: None,
        }
    }
}

impl RecordStage for Lookahead<'_> {
    fn begin(
        &mut self,
        ctx: &GpuContext,
        cache: &RecordCache,
        count: u32,
        batch_records: u32,
    ) -> Result<()> {
        for (what, records) in [("lookahead", &self.next), ("subset", &self.subset)] {
            if records.count != cache.count {
                return Err(Error::Usage(format!(
                    "{what} records ({}) out of step with the cache ({})",
                    records.count, cache.count
                )));
            }
        }
        self.next.reserve(ctx, count)?;
        self.subset.reserve(ctx, count)?;
        if !self.estimate {
            return Ok(());
        }
        let cells = u64::from(batch_records) * u64::from(self.reprojection.table.resolution.pow(2));
        self.estimates = Some((
            ctx.storage_buffer_sized("estimated planes", cells * 16)?,
            ctx.storage_buffer_sized("estimate subsets", cells * 16)?,
        ));
        Ok(())
    }

    fn planes_ready(
        &mut self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        batch: &PlaneBatch<'_>,
        resolution: u32,
    ) -> Result<()> {
        if let Some(capture) = self.capture.as_deref_mut() {
            capture.capture(
                ctx,
                enc,
                batch.sites,
                batch.traced,
                batch.hits,
                batch.first_record,
                batch.count,
                resolution,
            )?;
        }
        Ok(())
    }

    fn reduced(
        &mut self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        pass: &RecordPass,
        batch: &PlaneBatch<'_>,
        timer: &mut PassTimer,
    ) -> Result<()> {
        if !self.estimate {
            return Ok(());
        }
        let Some((estimate, subset)) = self.estimates.as_ref() else {
            return Err(Error::Usage("lookahead: reduced before begin".into()));
        };
        // E(t+1) estimate: reproject this batch's plane as traced (its centre rays, whose
        // hits move), then reduce it into the lookahead records at the same indices; with
        // a stride, also the samples at t it was moved from (tau is the ratio of the two).
        self.reprojection.record(
            ctx,
            enc,
            self.next_frame,
            &pass.settings,
            batch.sites,
            batch.hits,
            batch.traced,
            (estimate, subset),
            batch.count,
            timer,
        )?;
        let reduction = ReductionBatch {
            sites: batch.sites,
            first_record: batch.first_record,
            count: batch.count,
        };
        let table = &self.reprojection.table;
        pass.record_reduction(
            ctx,
            enc,
            self.next_frame.scene,
            table,
            &reduction,
            estimate,
            &self.next.buffer,
            timer,
        )?;
        // Radiance records: the estimated plane projected onto HSH too, into the blocks at
        // t+1 (stride 1 only: the projection's basis is the record plane's).
        if self.next.kind.coefficient_floats() > 0 {
            if self.reprojection.stride != 1 {
                return Err(Error::Usage(
                    "internal: radiance records are estimated at t+1 with stride 1".into(),
                ));
            }
            pass.record_projection(
                ctx,
                enc,
                self.next_frame.scene,
                batch.sites,
                estimate,
                &self.next.coefficients,
                batch.first_record,
                batch.count,
                self.values_only,
                timer,
            );
            // Gradients at t+1 (extrapolated temporal gradients) are limited as at t.
            if !self.values_only {
                pass.record_radiance_limit(
                    ctx,
                    enc,
                    self.next_frame.scene,
                    &self.next.buffer,
                    &self.next.coefficients,
                    batch.first_record,
                    batch.count,
                    timer,
                );
            }
        }
        // The subset at t: the samples the estimate was moved from (a stride), or the whole
        // plane as traced when the record's own plane was refined by contrast, so that tau
        // compares the estimate with the centre rays it moved, not with the refined record
        // (whose sub-rays the estimate cannot move). A plane refined only because it was
        // dark is compared as refined: its traced plane has no light to compare with.
        if self.reprojection.stride > 1 || pass.refines_by_contrast() {
            // (At stride 1 the reprojection's table is the plane's own.)
            let samples = if self.reprojection.stride > 1 {
                subset
            } else {
                batch.traced
            };
            pass.record_reduction(
                ctx,
                enc,
                scene,
                table,
                &reduction,
                samples,
                &self.subset.buffer,
                timer,
            )?;
        }
        Ok(())
    }

    fn batch_done(&mut self, count: u32) {
        self.next.count += count;
        self.subset.count += count;
    }
}

/// Replacements whose planes are refreshed rather than traced, each new record also
/// estimated at t+1 when there is a next frame.
pub struct RefreshStage<'r, 'l, 'a> {
    pub refresh: Option<&'r PlaneRefresh<'r>>,
    pub lookahead: Option<&'l mut Lookahead<'a>>,
}

impl RecordStage for RefreshStage<'_, '_, '_> {
    fn begin(
        &mut self,
        ctx: &GpuContext,
        cache: &RecordCache,
        count: u32,
        batch_records: u32,
    ) -> Result<()> {
        match self.lookahead.as_deref_mut() {
            Some(la) => la.begin(ctx, cache, count, batch_records),
            None => Ok(()),
        }
    }

    fn replace_tracing(
        &mut self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        settings: &CacheSettings,
        table: &PlaneTable,
        batch: &PlaneBatch<'_>,
        timer: &mut PassTimer,
    ) -> Result<bool> {
        let Some(r) = self.refresh else {
            return Ok(false);
        };
        r.record(
            ctx,
            enc,
            scene,
            settings,
            &table.pixels,
            batch.sites,
            batch.samples,
            batch.hits,
            batch.first_site,
            batch.count,
            timer,
        )?;
        Ok(true)
    }

    fn planes_ready(
        &mut self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        batch: &PlaneBatch<'_>,
        resolution: u32,
    ) -> Result<()> {
        match self.lookahead.as_deref_mut() {
            Some(la) => la.planes_ready(ctx, enc, batch, resolution),
            None => Ok(()),
        }
    }

    fn reduced(
        &mut self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        pass: &RecordPass,
        batch: &PlaneBatch<'_>,
        timer: &mut PassTimer,
    ) -> Result<()> {
        match self.lookahead.as_deref_mut() {
            Some(la) => la.reduced(ctx, enc, scene, pass, batch, timer),
            None => Ok(()),
        }
    }

    fn batch_done(&mut self, count: u32) {
        if let Some(la) = self.lookahead.as_deref_mut() {
            la.batch_done(count);
        }
    }
}

/// Planes traced at t and estimated at t+1 ([`trace_planes_ahead`]).
#[derive(Clone, Debug, Default)]
pub struct PlanesAhead {
    /// The planes traced at t, P^2 samples per site.
    pub now: Vec<PlaneSample>,
    /// The planes estimated at t+1, (P / stride)^2 samples per site.
    pub estimate: Vec<PlaneSample>,
    /// The samples at t the estimate was moved from, (P / stride)^2 per site.
    pub subset: Vec<PlaneSample>,
}

/// Traces the planes of `sites` (at most one batch of `pass`) and, with `ahead = (scene
/// at t+1, reprojection)`, also the planes estimated at t+1 by reprojection and the
/// samples at t they were moved from (tests, Table 5.1); those are empty without `ahead`.
pub fn trace_planes_ahead(
    pass: &RecordPass,
    ctx: &GpuContext,
    scene: &GpuScene,
    ahead: Option<(&NextFrame<'_>, &ReprojectionPass)>,
    sites: &[RecordSite],
) -> Result<PlanesAhead> {
    let n = sites.len() as u32;
    let (now, estimated) =
        pass.trace_planes_then(ctx, scene, sites, ahead.is_some(), |enc, batch| {
            let Some((next, reprojection)) = ahead else {
                return Ok(None);
            };
            let cells = u64::from(n) * u64::from(reprojection.table.resolution.pow(2));
            let estimate = ctx.storage_buffer_sized("estimated planes", cells * 16)?;
            let subset = ctx.storage_buffer_sized("estimate subsets", cells * 16)?;
            let mut timer = PassTimer::new(ctx, 3);
            reprojection.record(
                ctx,
                enc,
                next,
                &pass.settings,
                batch.sites,
                batch.hits,
                batch.samples,
                (&estimate, &subset),
                n,
                &mut timer,
            )?;
            Ok(Some((estimate, subset, cells as usize)))
        })?;
    let mut out = PlanesAhead {
        now,
        ..Default::default()
    };
    if let Some((estimate, subset, cells)) = estimated {
        out.estimate = ctx.read_buffer(&estimate)?;
        out.estimate.truncate(cells);
        out.subset = ctx.read_buffer(&subset)?;
        out.subset.truncate(cells);
    }
    Ok(out)
}
