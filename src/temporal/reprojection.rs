//! The E(t+1) estimate of new records (seed 000 section IV-G, thesis 5.2.4, algorithms.md
//! 4.3) as three compute passes recorded right after a batch's hemisphere planes, bound
//! to the scene at t+1: `plane_reproject` (move each plane hit with its instance, project
//! it onto the record's plane with a depth test, keep the radiance traced at t where its
//! lighting cannot have changed and list the other samples), `plane_reshade` (re-shade
//! the listed samples with the lights at t+1, an indirect dispatch sized by the list) and
//! `plane_fill` (take each cell's nearest sample, fill holes from the deepest neighbour). The resulting plane goes through the ordinary record reduction
//! ([`crate::records::RecordPass::compute`] with a [`crate::records::Lookahead`]).

use super::motion::{instance_motions, lights_unchanged};
use super::plane_refresh::SpanMotion;
use crate::Result;
use crate::gpu::GpuContext;
use crate::gpu::pipeline::{Binding, ComputePass};
use crate::gpu::scene_buffers::GpuScene;
use crate::gpu::timer::PassTimer;
use crate::records::{CacheSettings, PlaneMode};
use crate::scene::Scene;
use bytemuck::{Pod, Zeroable};

/// Largest plane the reprojection keys can index (14 bits of sample index,
/// `REPROJECTION_INDEX_BITS` in `wgsl/shared/records.wgsl`).
pub const MAX_REPROJECTION_RESOLUTION: u32 = 128;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ReprojectParams {
    resolution: u32,
    count: u32,
    light_samples: u32,
    stretched: u32,
    half_extent: f32,
    anchored: u32,
    reuse_shading: u32,
    moving_count: u32,
    movers_lo: [f32; 4],
    movers_hi: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct FillParams {
    resolution: u32,
    count: u32,
    _pad: [u32; 2],
}

/// Reuse of the radiance traced at t is tested against at most this many moving
/// instances (each shadow pyramid is tested against every box, then its rays against the
/// few boxes it meets); with more, every hit is re-shaded.
pub const MAX_MOVING_FOR_REUSE: usize = 256;

/// Frame t+1 as the reprojection sees it.
pub struct NextFrame<'a> {
    /// The scene at t+1.
    pub scene: &'a GpuScene,
    /// One [`super::InstanceMotion`] per instance, from t to t+1.
    motion: wgpu::Buffer,
    /// The instances that move from t to t+1, with their boxes at both frames.
    movers: SpanMotion,
    /// Records move with the instance they lie on ([`super::RecordAnchor::Instance`]).
    pub anchored: bool,
    /// Hits whose lighting cannot have changed keep the radiance traced at t.
    pub reuse_shading: bool,
}

impl<'a> NextFrame<'a> {
    /// Frame t+1 of `now` (the CPU scene at t): `next` is the CPU scene at t+1 and
    /// `scene` the same on the GPU.
    pub fn new(
        ctx: &GpuContext,
        scene: &'a GpuScene,
        now: &Scene,
        next: &Scene,
        anchored: bool,
    ) -> Result<Self> {
        let motions = instance_motions(now, next);
        let transforms = |s: &Scene| s.instances.iter().map(|i| i.transform).collect::<Vec<_>>();
        let movers = SpanMotion::new(ctx, now, &transforms(now), &transforms(next))?;
        Ok(Self {
            scene,
            motion: ctx.storage_buffer("instance motion", &motions)?,
            anchored,
            reuse_shading: lights_unchanged(now, next)
                && movers.moving_count as usize <= MAX_MOVING_FOR_REUSE,
            movers,
        })
    }
}

/// The `plane_reproject`, `plane_reshade` and `plane_fill` passes.
pub struct ReprojectionPass {
    reproject: ComputePass,
    reshade: ComputePass,
    fill: ComputePass,
}

impl ReprojectionPass {
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        use Binding::*;
        Ok(Self {
            reproject: ComputePass::new(
                ctx,
                "plane_reproject.wgsl",
                &[
                    Uniform,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                    StorageReadWrite,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                    StorageReadWrite,
                ],
            )?,
            reshade: ComputePass::new(
                ctx,
                "plane_reshade.wgsl",
                &[
                    Uniform,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                    StorageRead,
                    StorageRead,
                ],
            )?,
            fill: ComputePass::new(
                ctx,
                "plane_fill.wgsl",
                &[Uniform, StorageRead, StorageRead, StorageReadWrite],
            )?,
        })
    }

    /// Records the estimate at t+1 of `count` records' planes: reads their sites, plane
    /// hits and `plane` (`count * P^2` [`crate::records::PlaneSample`]s traced at t), and
    /// writes the reprojected, hole-filled plane over `plane`.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        next: &NextFrame<'_>,
        settings: &CacheSettings,
        sites: &wgpu::Buffer,
        hits: &wgpu::Buffer,
        plane: &wgpu::Buffer,
        count: u32,
        timer: &mut PassTimer,
    ) -> Result<()> {
        let res = settings.plane_resolution;
        if res > MAX_REPROJECTION_RESOLUTION {
            return Err(crate::Error::Usage(format!(
                "temporal caching reprojects planes of at most {MAX_REPROJECTION_RESOLUTION} x \
                 {MAX_REPROJECTION_RESOLUTION} pixels, not {res} x {res}"
            )));
        }
        let cells_count = u64::from(count) * u64::from(res * res);
        let cells = ctx.storage_buffer_sized("reprojected cells", cells_count * 4)?;
        let moved = ctx.storage_buffer_sized("reprojected samples", cells_count * 16)?;
        // Cells hold complemented keys: 0 is empty (`plane_reproject.wgsl`).
        enc.clear_buffer(&cells, 0, None);
        // The samples to re-shade, and the size of the dispatch that re-shades them.
        let (reshade, reshade_groups) = ctx.work_list("samples to re-shade", cells_count)?;
        let reproject_params = ctx.uniform_buffer(
            "reproject params",
            &ReprojectParams {
                resolution: res,
                count,
                light_samples: settings.plane_light_samples,
                stretched: u32::from(settings.plane_mode == PlaneMode::Stretched),
                half_extent: (settings.plane_fov_degrees.to_radians() * 0.5).tan(),
                anchored: u32::from(next.anchored),
                reuse_shading: u32::from(next.reuse_shading),
                moving_count: next.movers.moving_count,
                movers_lo: next.movers.union.0,
                movers_hi: next.movers.union.1,
            },
        );
        let bind = self.reproject.bind(
            ctx,
            &[
                &reproject_params,
                sites,
                hits,
                &cells,
                &moved,
                &next.motion,
                &next.movers.moving,
                plane,
                &reshade,
                &reshade_groups,
            ],
        );
        let groups = [res.div_ceil(8), res.div_ceil(8), count];
        self.reproject.record(
            enc,
            &next.scene.bind_group,
            &bind,
            groups,
            timer.next("temporal: reprojection"),
        );
        let bind = self.reshade.bind(
            ctx,
            &[
                &reproject_params,
                sites,
                hits,
                &moved,
                &next.motion,
                &reshade,
            ],
        );
        self.reshade.record_indirect(
            enc,
            &next.scene.bind_group,
            &bind,
            &reshade_groups,
            timer.next("temporal: re-shading"),
        );
        let params = ctx.uniform_buffer(
            "fill params",
            &FillParams {
                resolution: res,
                count,
                _pad: [0; 2],
            },
        );
        let bind = self.fill.bind(ctx, &[&params, &cells, &moved, plane]);
        self.fill.record(
            enc,
            &next.scene.bind_group,
            &bind,
            groups,
            timer.next("temporal: hole filling"),
        );
        Ok(())
    }
}
