//! A compute pass that traces a buffer of arbitrary rays (closest or any hit). Benchmarks
//! and traversal tests use it to run the exact rays the CPU reference runs.

use crate::gpu::pipeline::{Binding, ComputePass};
use crate::gpu::{GpuContext, GpuScene};
use crate::{Error, Result};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Rust mirror of WGSL `Ray`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuRay {
    pub origin: [f32; 3],
    pub tmin: f32,
    pub dir: [f32; 3],
    pub tmax: f32,
}

impl GpuRay {
    pub fn new(origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Self {
        GpuRay {
            origin: origin.into(),
            tmin,
            dir: dir.into(),
            tmax: tmax.min(3.0e38),
        }
    }
}

/// Rust mirror of WGSL `Hit` (20 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuHit {
    pub t: f32,
    /// `u32::MAX` on a miss.
    pub instance: u32,
    /// Absolute triangle index (BVH leaf order).
    pub triangle: u32,
    pub u: f32,
    pub v: f32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct TraceParams {
    count: u32,
    any_hit: u32,
    _pad: [u32; 2],
}

const WORKGROUP: u32 = 64;

/// Uploaded rays ready to be traced repeatedly.
pub struct RayBatch {
    pub count: u32,
    pub any_hit: bool,
    bind: wgpu::BindGroup,
    pub hits: wgpu::Buffer,
    groups: [u32; 3],
}

/// The ray-tracing pass (`wgsl/trace_rays.wgsl`).
pub struct TraceRaysPass {
    pass: std::sync::Arc<ComputePass>,
}

impl TraceRaysPass {
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        use Binding::*;
        Ok(Self {
            pass: ComputePass::new(
                ctx,
                "trace_rays.wgsl",
                &[Uniform, StorageRead, StorageReadWrite],
            )?,
        })
    }

    /// Uploads `rays`; `any_hit` makes them shadow rays (stop at the first hit).
    pub fn upload(&self, ctx: &GpuContext, rays: &[GpuRay], any_hit: bool) -> Result<RayBatch> {
        let count =
            u32::try_from(rays.len()).map_err(|_| Error::DeviceLimit("too many rays".into()))?;
        let params = ctx.uniform_buffer(
            "trace params",
            &TraceParams {
                count,
                any_hit: any_hit as u32,
                _pad: [0; 2],
            },
        );
        let ray_buf = ctx.storage_buffer("rays", rays)?;
        let hits = ctx.storage_buffer_sized(
            "hits",
            u64::from(count) * std::mem::size_of::<GpuHit>() as u64,
        )?;
        let bind = self.pass.bind(ctx, &[&params, &ray_buf, &hits]);
        let groups_total = count.div_ceil(WORKGROUP);
        let max = ctx.device.limits().max_compute_workgroups_per_dimension;
        let gx = groups_total.min(max);
        let groups = [gx.max(1), groups_total.div_ceil(gx.max(1)).max(1), 1];
        Ok(RayBatch {
            count,
            any_hit,
            bind,
            hits,
            groups,
        })
    }

    /// Records a trace of `batch` into `encoder`.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        batch: &RayBatch,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        self.pass.record(
            encoder,
            &scene.bind_group,
            &batch.bind,
            batch.groups,
            timestamps,
        );
    }

    /// Traces `batch` and waits; returns the hits.
    pub fn trace(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        batch: &RayBatch,
    ) -> Result<Vec<GpuHit>> {
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        self.record(&mut encoder, scene, batch, None);
        ctx.queue.submit([encoder.finish()]);
        ctx.read_buffer(&batch.hits)
    }
}
