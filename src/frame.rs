//! Running a frame: scene → BVH → visibility → direct light → images.

use crate::Result;
use crate::bvh::SceneBvh;
use crate::direct::DirectLightPass;
use crate::gpu::timer::PassTimer;
use crate::gpu::{GpuContext, GpuScene};
use crate::scene::{Camera, Scene};
use crate::visibility::{VisSample, VisibilityPass};
use std::time::Instant;

/// A scene made ready for the GPU: its BVH built and its tables uploaded.
pub struct PreparedScene {
    pub gpu: GpuScene,
    pub bvh_stats: BvhStats,
}

/// Size and build time of a scene's BVH.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct BvhStats {
    pub triangles: usize,
    pub blas_nodes: usize,
    pub tlas_nodes: usize,
    pub build_ms: f64,
    pub upload_bytes: u64,
}

/// Statistics of one frame.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FrameStats {
    pub width: u32,
    pub height: u32,
    /// GPU time per pass in ms (timestamp queries; empty if the device lacks them).
    pub pass_ms: Vec<(String, f64)>,
    /// Wall time of the frame on the CPU side, submit to readback, in ms.
    pub wall_ms: f64,
    pub camera_rays: u64,
}

/// The images of one frame, row-major, top row first.
#[derive(Clone, Debug)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// Final linear radiance (RGB + alpha 1).
    pub beauty: Vec<[f32; 4]>,
    pub albedo: Vec<[f32; 4]>,
    /// Reflected direct light.
    pub direct: Vec<[f32; 4]>,
    /// The visibility buffer (positions, normals, ids) as rendered.
    pub visibility: Vec<VisSample>,
    pub stats: FrameStats,
}

impl Frame {
    /// World-space shading normal per pixel (zero on background).
    pub fn normals(&self) -> Vec<[f32; 3]> {
        self.visibility
            .iter()
            .map(|v| {
                if v.is_hit() {
                    v.shading_normal
                } else {
                    [0.0; 3]
                }
            })
            .collect()
    }

    /// Distance from the camera per pixel (+inf on background).
    pub fn depth(&self) -> Vec<f32> {
        self.visibility
            .iter()
            .map(|v| if v.is_hit() { v.t } else { f32::INFINITY })
            .collect()
    }
}

/// The renderer: compiled passes on one GPU context.
pub struct Renderer {
    pub ctx: GpuContext,
    visibility: VisibilityPass,
    direct: DirectLightPass,
}

impl Renderer {
    /// Compiles every pass on `ctx`.
    pub fn new(ctx: GpuContext) -> Result<Self> {
        let visibility = VisibilityPass::new(&ctx)?;
        let direct = DirectLightPass::new(&ctx)?;
        Ok(Self {
            ctx,
            visibility,
            direct,
        })
    }

    /// Builds the BVH and uploads the scene.
    pub fn prepare(&self, scene: &Scene) -> Result<PreparedScene> {
        let t0 = Instant::now();
        let bvh = SceneBvh::build(scene);
        let build_ms = t0.elapsed().as_secs_f64() * 1e3;
        let gpu = GpuScene::upload(&self.ctx, scene, &bvh, scene.settings.light_samples)?;
        self.ctx.check()?;
        Ok(PreparedScene {
            bvh_stats: BvhStats {
                triangles: bvh.triangles.len(),
                blas_nodes: bvh.blas_nodes.len(),
                tlas_nodes: bvh.tlas_nodes.len(),
                build_ms,
                upload_bytes: gpu.bytes,
            },
            gpu,
        })
    }

    /// Renders one frame of a prepared scene from `camera`: visibility, then direct light,
    /// then reads the images back.
    pub fn render_frame(&self, scene: &PreparedScene, camera: &Camera) -> Result<Frame> {
        let ctx = &self.ctx;
        let t0 = Instant::now();
        let mut timer = PassTimer::new(ctx, 4);
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        let vis = self.visibility.record(
            ctx,
            &mut encoder,
            &scene.gpu,
            camera,
            timer.next("visibility"),
        )?;
        let direct =
            self.direct
                .record(ctx, &mut encoder, &scene.gpu, &vis, timer.next("direct"))?;
        timer.resolve(&mut encoder);
        ctx.queue.submit([encoder.finish()]);
        // One submission and one wait for all three images.
        let mut images = ctx
            .read_buffers::<[f32; 4]>(&[&direct.beauty, &direct.albedo, &direct.direct])?
            .into_iter();
        let (beauty, albedo, direct_img) = match (images.next(), images.next(), images.next()) {
            (Some(b), Some(a), Some(d)) => (b, a, d),
            _ => {
                return Err(crate::Error::Gpu(
                    "internal: image readback incomplete".into(),
                ));
            }
        };
        let visibility = vis.read(ctx)?;
        let pass_ms = timer
            .read(ctx)?
            .into_iter()
            .map(|(n, ms)| (n.to_string(), ms))
            .collect();
        let (width, height) = (camera.width, camera.height);
        Ok(Frame {
            width,
            height,
            beauty,
            albedo,
            direct: direct_img,
            visibility,
            stats: FrameStats {
                width,
                height,
                pass_ms,
                wall_ms: t0.elapsed().as_secs_f64() * 1e3,
                camera_rays: u64::from(width) * u64::from(height),
            },
        })
    }
}
