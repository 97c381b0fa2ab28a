//! Plane refresh: a record that replaces an expired one at the same place (seed 000
//! section IV-D) traces again only the plane samples that something could have changed
//! since its predecessor was computed. The replacement keeps its predecessor's site and
//! seed, so every other sample would be traced to the same hit and shaded with the same
//! shadow rays: the refreshed plane is the bytes a full trace would give, for a fraction of
//! the rays. Two compute passes over a copy of the retained plane: `plane_refresh` lists
//! the samples whose ray or shadow rays may meet the box of an instance that moved during
//! the span (or that hit one), `plane_retrace` traces the listed samples again (an indirect
//! dispatch). It applies when the lights did not change during the span and the record
//! itself did not move; [`PlaneStore`] keeps the planes, within a memory budget.

use super::motion::MovingBounds;
use crate::Result;
use crate::gpu::pipeline::{Binding, ComputePass};
use crate::gpu::scene_buffers::GpuScene;
use crate::gpu::timer::PassTimer;
use crate::gpu::{GpuContext, SceneFeatures};
use crate::records::{CacheSettings, PlaneParams, RecordSite};
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};
use std::collections::HashMap;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct RefreshParams {
    resolution: u32,
    count: u32,
    light_samples: u32,
    moving_count: u32,
    movers_lo: [f32; 4],
    movers_hi: [f32; 4],
}

/// Bytes of one retained plane at resolution `res`: its samples, then its hits.
fn plane_bytes(res: u32) -> u64 {
    u64::from(res) * u64::from(res) * 16
}

/// What moved during a span of frames, on the GPU.
pub struct SpanMotion {
    /// [`MovingBounds`] of each instance that moved between the span's two ends.
    pub(super) moving: wgpu::Buffer,
    pub(super) moving_count: u32,
    /// The world box around all of them ([`MovingBounds::union`]).
    pub(super) union: ([f32; 4], [f32; 4]),
    /// Per instance, 1 when it moved during the span.
    moved: wgpu::Buffer,
}

impl SpanMotion {
    /// The motion of `scene`'s instances between the frames whose instance transforms
    /// are `start` and `end` (one transform per instance each).
    pub fn new(
        ctx: &GpuContext,
        scene: &crate::scene::Scene,
        start: &[Mat4],
        end: &[Mat4],
    ) -> Result<Self> {
        let (bounds, moved) = span_bounds(scene, start, end);
        Ok(Self {
            moving: ctx.storage_buffer("span movers", &bounds)?,
            moving_count: bounds.len() as u32,
            union: MovingBounds::union(&bounds),
            moved: ctx.storage_buffer("span moved instances", &moved)?,
        })
    }
}

/// The instances of `scene` whose transform differs between `start` and `end` (one
/// transform per instance each, at the two ends of a span of frames) as
/// [`MovingBounds`], and a per-instance moved flag. What happens between the two ends
/// does not matter: a plane traced at the start is compared with the scene at the end.
pub fn span_bounds(
    scene: &crate::scene::Scene,
    start: &[Mat4],
    end: &[Mat4],
) -> (Vec<MovingBounds>, Vec<u32>) {
    let mut bounds = Vec::new();
    let mut moved = vec![0u32; scene.instances.len().max(1)];
    for (i, inst) in scene.instances.iter().enumerate() {
        let (Some(a), Some(b)) = (start.get(i), end.get(i)) else {
            continue;
        };
        if a == b {
            continue;
        }
        moved[i] = 1;
        let Some(mesh) = scene.meshes.get(inst.mesh as usize) else {
            continue;
        };
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for p in &mesh.positions {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        if lo.x > hi.x {
            continue;
        }
        bounds.push(MovingBounds::new(lo, hi, a, b));
    }
    (bounds, moved)
}

/// Replacements whose planes are refreshed rather than traced: one retained plane per
/// site (in site order) and what moved since those planes were traced.
pub struct PlaneRefresh<'a> {
    pub pass: &'a RefreshPass,
    pub planes: Vec<&'a wgpu::Buffer>,
    pub motion: &'a SpanMotion,
    /// The lists of samples traced again, one per batch recorded (their first word is
    /// the count): how much refreshing saved ([`crate::temporal::RefreshMode::Auto`]).
    pub retraced: std::cell::RefCell<Vec<wgpu::Buffer>>,
}

/// The `plane_refresh` and `plane_retrace` passes.
pub struct RefreshPass {
    select: std::sync::Arc<ComputePass>,
    retrace: std::sync::Arc<ComputePass>,
    /// The re-trace shades with shadow rays: animations have no light maps (they would
    /// need tracing again every frame), so it binds none.
    no_light_maps: crate::light_maps::LightMaps,
}

impl RefreshPass {
    /// The passes for any scene.
    /// [`Self::for_scene`] compiles them for one scene's features alone (`SceneFeatures::of`),
    /// which lavapipe builds and runs faster: an engine that knows its scene should use that.
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        Self::for_scene(ctx, SceneFeatures::ALL)
    }

    /// The selection and re-trace compiled for the scene features `features` alone
    /// (`RecordPass::features` of the cache's record pass).
    pub fn for_scene(ctx: &GpuContext, features: SceneFeatures) -> Result<Self> {
        use Binding::*;
        Ok(Self {
            select: ComputePass::with_constants(
                ctx,
                "plane_refresh.wgsl",
                &[
                    Uniform,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                    StorageReadWrite,
                ],
                &[features.constant()],
            )?,
            retrace: ComputePass::with_constants(
                ctx,
                "plane_retrace.wgsl",
                &[
                    Uniform,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                    StorageReadWrite,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                ],
                &[features.constant()],
            )?,
            no_light_maps: crate::light_maps::LightMaps::none(ctx)?,
        })
    }
}

impl PlaneRefresh<'_> {
    /// Records the refreshed planes of sites `first..first + count` (bound as
    /// `batch_sites`) into `samples` and `hits` (batch buffers of `count` planes).
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        settings: &CacheSettings,
        plane_table: &wgpu::Buffer,
        batch_sites: &wgpu::Buffer,
        samples: &wgpu::Buffer,
        hits: &wgpu::Buffer,
        first: u32,
        count: u32,
        timer: &mut PassTimer,
    ) -> Result<()> {
        let res = settings.plane_resolution;
        let bytes = plane_bytes(res);
        for j in 0..count {
            let Some(plane) = self.planes.get((first + j) as usize) else {
                return Err(crate::Error::Usage(format!(
                    "plane refresh: no retained plane for site {}",
                    first + j
                )));
            };
            enc.copy_buffer_to_buffer(plane, 0, samples, u64::from(j) * bytes, bytes);
            enc.copy_buffer_to_buffer(plane, bytes, hits, u64::from(j) * bytes, bytes);
        }
        let cells = u64::from(count) * u64::from(res * res);
        let (work, work_groups) = ctx.work_list("samples to trace again", cells)?;
        self.retraced.borrow_mut().push(work.clone());
        let params = ctx.uniform_buffer(
            "refresh params",
            &RefreshParams {
                resolution: res,
                count,
                light_samples: settings.plane_light_samples,
                moving_count: self.motion.moving_count,
                movers_lo: self.motion.union.0,
                movers_hi: self.motion.union.1,
            },
        );
        let bind = self.pass.select.bind(
            ctx,
            &[
                &params,
                batch_sites,
                plane_table,
                hits,
                &self.motion.moving,
                &self.motion.moved,
                &work,
                &work_groups,
            ],
        );
        self.pass.select.record(
            enc,
            &scene.bind_group,
            &bind,
            [res.div_ceil(8), res.div_ceil(8), count],
            timer.next("plane refresh: select"),
        );
        let params = ctx.uniform_buffer(
            "retrace params",
            &PlaneParams {
                resolution: res,
                count,
                light_samples: settings.plane_light_samples,
                record_hits: 1,
                light_choices: settings.plane_light_choices,
                record_noise: 0,
                ..bytemuck::Zeroable::zeroed()
            },
        );
        let bind = self.pass.retrace.bind(
            ctx,
            &[
                &params,
                batch_sites,
                plane_table,
                samples,
                hits,
                &work,
                &self.pass.no_light_maps.maps_buffer,
                &self.pass.no_light_maps.depths,
                &self.pass.no_light_maps.first_buffer,
                &scene.bounce_cache(),
            ],
        );
        self.pass.retrace.record_indirect(
            enc,
            &scene.bind_group,
            &bind,
            &work_groups,
            timer.next("hemisphere planes"),
        );
        Ok(())
    }
}

/// What the record pass keeps of the records it computes in a frame, by their index in
/// the frame's cache: their sites (always: a replacement inherits its predecessor's) and,
/// within the budget, their traced planes (for [`PlaneRefresh`]).
#[derive(Default)]
pub struct PlaneCapture {
    /// Keep planes, not only sites.
    pub planes: bool,
    /// Bytes of planes this capture may still keep.
    pub budget: u64,
    /// (first cache index, count, their sites).
    pub site_batches: Vec<(u32, u32, wgpu::Buffer)>,
    /// (cache index, its plane: samples then hits).
    pub kept: Vec<(u32, wgpu::Buffer)>,
}

impl PlaneCapture {
    /// Records copies of a batch's sites and (within the budget) traced planes; call
    /// between the plane pass and anything that overwrites `samples`.
    #[allow(clippy::too_many_arguments)]
    pub fn capture(
        &mut self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        batch_sites: &wgpu::Buffer,
        samples: &wgpu::Buffer,
        hits: &wgpu::Buffer,
        first_index: u32,
        count: u32,
        res: u32,
    ) -> Result<()> {
        let site_bytes = u64::from(count) * std::mem::size_of::<RecordSite>() as u64;
        let sites = ctx.storage_buffer_sized("captured sites", site_bytes)?;
        enc.copy_buffer_to_buffer(batch_sites, 0, &sites, 0, site_bytes);
        self.site_batches.push((first_index, count, sites));
        if !self.planes {
            return Ok(());
        }
        let bytes = plane_bytes(res);
        for j in 0..count {
            if self.budget < 2 * bytes {
                break;
            }
            self.budget -= 2 * bytes;
            let plane = ctx.storage_buffer_sized("retained plane", 2 * bytes)?;
            enc.copy_buffer_to_buffer(samples, u64::from(j) * bytes, &plane, 0, bytes);
            enc.copy_buffer_to_buffer(hits, u64::from(j) * bytes, &plane, bytes, bytes);
            self.kept.push((first_index + j, plane));
        }
        Ok(())
    }
}

/// Retained planes of live records, by record id, within a memory budget.
pub struct PlaneStore {
    pub planes: HashMap<u32, wgpu::Buffer>,
    /// Most bytes of planes kept at once.
    pub budget: u64,
    bytes_per_plane: u64,
}

impl PlaneStore {
    pub fn new(budget: u64, res: u32) -> Self {
        Self {
            planes: HashMap::new(),
            budget,
            bytes_per_plane: 2 * plane_bytes(res),
        }
    }

    /// Bytes still free.
    pub fn free(&self) -> u64 {
        self.budget
            .saturating_sub(self.planes.len() as u64 * self.bytes_per_plane)
    }
}
