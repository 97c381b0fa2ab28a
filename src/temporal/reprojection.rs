//! The E(t+1) estimate of new records (seed 000 section IV-G, thesis 5.2.4, algorithms.md
//! 4.3) as three compute passes recorded right after a batch's hemisphere planes, bound
//! to the scene at t+1: `plane_reproject` (move each plane hit with its instance, project
//! it onto the record's plane with a depth test, keep the radiance traced at t where its
//! lighting cannot have changed and list the other samples), `plane_reshade` (re-shade
//! the listed samples with the lights at t+1, an indirect dispatch sized by the list) and
//! `plane_fill` (take each cell's nearest sample, fill holes from the deepest neighbour).
//! The resulting plane goes through the ordinary record reduction
//! ([`crate::records::RecordPass::compute`] with a [`super::Lookahead`] stage).
//!
//! With an estimate stride s > 1 only every s-th sample each way is moved, onto a plane of
//! P/s cells, and the samples at t it was moved from are reduced too: tau is the ratio of
//! the two over the same subset, and the record at t+1 is the record scaled by it
//! ([`super::scaled_by_estimate`]). With interpolated gradients tau is all the estimate is
//! used for, and the subset costs 1/s^2 as much (seed 000 section V-g puts the reprojection at 10 %
//! of a record; the whole-plane estimate here cost about half of one).

use super::motion::{instance_motions, lights_unchanged};
use super::plane_refresh::SpanMotion;
use crate::Result;
use crate::gpu::pipeline::{Binding, ComputePass};
use crate::gpu::scene_buffers::GpuScene;
use crate::gpu::timer::PassTimer;
use crate::gpu::{GpuContext, SceneFeatures};
use crate::records::{CacheSettings, PlaneMode, PlaneTable};
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
    estimate_resolution: u32,
    stride: u32,
    light_choices: u32,
    cosine_spacing: u32,
    skip_movers: u32,
    _pad: [u32; 3],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct FillParams {
    estimate_resolution: u32,
    count: u32,
    resolution: u32,
    stride: u32,
}

/// The plane pixel (along one axis) that cell `i` of an estimate of `estimate_resolution`
/// cells reprojects: of the `stride` pixels of its block, the one nearest the plane's
/// centre, so the subset is symmetric about it (WGSL `subset_pixel`).
pub fn subset_pixel(i: u32, stride: u32, estimate_resolution: u32) -> u32 {
    i * stride
        + if 2 * i + 1 < estimate_resolution {
            stride - 1
        } else {
            0
        }
}

/// Checks that an estimate stride divides the plane resolution into at least 4 cells.
pub fn validate_estimate_stride(stride: u32, plane_resolution: u32) -> Result<()> {
    if stride == 0 || !plane_resolution.is_multiple_of(stride) || plane_resolution / stride < 4 {
        return Err(crate::Error::Usage(format!(
            "the estimate stride ({stride}) must divide the plane resolution \
             ({plane_resolution}) into at least 4 cells each way"
        )));
    }
    Ok(())
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
    /// Records on instances that move to t+1 are not estimated: their estimate is their
    /// plane at t (tau 1). Set where such records live one frame anyway
    /// ([`super::MoverRecords::OneFrame`]), so their reprojection and re-shading are saved.
    pub skip_movers: bool,
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
            skip_movers: false,
            movers,
        })
    }
}

/// The half-extent `plane_reproject.wgsl`'s `plane_index` bins in: the plane's in the
/// coordinate its pixel edges are even in ([`crate::records::PlaneSpacing::even_half_extent`]
/// of the f32 `tan(fov / 2)`, which it leaves unchanged for evenly spaced planes).
pub fn estimate_half_extent(settings: &CacheSettings) -> f32 {
    let s = (settings.plane_fov_degrees.to_radians() * 0.5).tan();
    settings.plane_spacing.even_half_extent(f64::from(s)) as f32
}

/// The `plane_reproject`, `plane_reshade` and `plane_fill` passes.
pub struct ReprojectionPass {
    reproject: std::sync::Arc<ComputePass>,
    reshade: std::sync::Arc<ComputePass>,
    fill: std::sync::Arc<ComputePass>,
    /// The estimate moves every `stride`-th plane sample each way (1: all of them).
    pub stride: u32,
    /// The table of the estimated plane (P / stride cells each way), for its reduction.
    pub table: PlaneTable,
}

impl ReprojectionPass {
    /// The passes for planes of `settings`, estimated from every `stride`-th sample each
    /// way: with interpolated gradients the estimate only gives tau, the ratio of E(t+1)
    /// to E(t) over the same samples, so a subset costs a stride^2-th as much.
    pub fn new(ctx: &GpuContext, settings: &CacheSettings, stride: u32) -> Result<Self> {
        Self::for_scene(ctx, settings, stride, SceneFeatures::ALL)
    }

    /// [`Self::new`] with the reprojection and re-shading compiled for the scene features
    /// `features` alone (`RecordPass::features` of the cache's record pass: its kinds of
    /// light, instances, textures, bounce cache).
    pub fn for_scene(
        ctx: &GpuContext,
        settings: &CacheSettings,
        stride: u32,
        features: SceneFeatures,
    ) -> Result<Self> {
        use Binding::*;
        validate_estimate_stride(stride, settings.plane_resolution)?;
        Ok(Self {
            stride,
            table: PlaneTable::new(ctx, settings.plane_resolution / stride, settings)?,
            reproject: ComputePass::with_constants(
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
                &[features.constant()],
            )?,
            reshade: ComputePass::with_constants(
                ctx,
                "plane_reshade.wgsl",
                &[
                    Uniform,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                ],
                &[features.constant()],
            )?,
            fill: ComputePass::new(
                ctx,
                "plane_fill.wgsl",
                &[
                    Uniform,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                    StorageReadWrite,
                ],
            )?,
        })
    }

    /// Records the estimate at t+1 of `count` records' planes: reads their sites, plane
    /// hits and `plane` (`count * P^2` [`crate::records::PlaneSample`]s traced at t), and
    /// writes the reprojected, hole-filled planes to `out.0` and the samples at t they
    /// were moved from to `out.1` (`count * (P / stride)^2` samples each).
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
        out: (&wgpu::Buffer, &wgpu::Buffer),
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
        if res != self.table.resolution * self.stride {
            return Err(crate::Error::Usage(format!(
                "internal: reprojection built for planes of {} pixels, given {res}",
                self.table.resolution * self.stride
            )));
        }
        let cells_res = self.table.resolution;
        let samples_count = u64::from(count) * u64::from(res * res);
        let cells_count = u64::from(count) * u64::from(cells_res * cells_res);
        let cells = ctx.storage_buffer_sized("reprojected cells", cells_count * 4)?;
        let moved = ctx.storage_buffer_sized("reprojected samples", samples_count * 16)?;
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
                // Cells are even in the plane's spacing coordinate (`plane_index`).
                half_extent: estimate_half_extent(settings),
                anchored: u32::from(next.anchored),
                reuse_shading: u32::from(next.reuse_shading),
                moving_count: next.movers.moving_count,
                movers_lo: next.movers.union.0,
                movers_hi: next.movers.union.1,
                estimate_resolution: cells_res,
                stride: self.stride,
                light_choices: settings.plane_light_choices,
                cosine_spacing: u32::from(
                    settings.plane_spacing == crate::records::PlaneSpacing::Cosine,
                ),
                skip_movers: u32::from(next.skip_movers),
                _pad: [0; 3],
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
        let groups = [cells_res.div_ceil(8), cells_res.div_ceil(8), count];
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
                &next.scene.bounce_cache(),
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
                estimate_resolution: cells_res,
                count,
                resolution: res,
                stride: self.stride,
            },
        );
        let bind = self
            .fill
            .bind(ctx, &[&params, &cells, &moved, plane, out.0, out.1]);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_estimate_subset_is_symmetric_about_the_plane_centre() {
        for (resolution, stride) in [(32u32, 2u32), (30, 2), (32, 4), (16, 1), (12, 3)] {
            let cells = resolution / stride;
            let picked: Vec<u32> = (0..cells).map(|i| subset_pixel(i, stride, cells)).collect();
            for (i, &p) in picked.iter().enumerate() {
                // Inside its own block, and mirrored by the mirrored cell.
                assert_eq!(p / stride, i as u32, "P {resolution}, stride {stride}");
                let mirror = picked[cells as usize - 1 - i];
                if cells % 2 == 0 || i as u32 != cells / 2 {
                    assert_eq!(
                        p + mirror,
                        resolution - 1,
                        "P {resolution}, stride {stride}"
                    );
                }
            }
        }
        assert!(validate_estimate_stride(2, 32).is_ok());
        assert!(validate_estimate_stride(3, 32).is_err());
        assert!(validate_estimate_stride(0, 32).is_err());
        assert!(validate_estimate_stride(4, 12).is_err());
    }
}
