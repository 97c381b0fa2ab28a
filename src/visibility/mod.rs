//! The visibility pass: one camera ray per pixel through the two-level BVH, writing the
//! visibility buffer ([`VisSample`] per pixel) that every later pass reads.

use crate::gpu::pipeline::{Binding, image_groups};
use crate::gpu::scene_pass::{ScenePass, ScenePassShader};
use crate::gpu::{GpuContext, GpuScene, SceneFeatures};
use crate::scene::Camera;
use crate::{Error, Result};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Rust mirror of WGSL `Camera` (`wgsl/shared/camera.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuCamera {
    pub origin: [f32; 3],
    pub width: u32,
    pub forward: [f32; 3],
    pub height: u32,
    pub right: [f32; 3],
    /// Where camera rays start: Ray Tracing Gems' offset at the camera's position
    /// (`scene::limits::ray_offset`), so a camera placed exactly on a surface sees past it
    /// rather than that surface alone (a hit at t = 0 in every pixel).
    pub tmin: f32,
    pub up: [f32; 3],
    pub _pad1: u32,
}

impl GpuCamera {
    pub fn new(c: &Camera) -> Self {
        let forward = (c.target - c.position).normalize();
        let right = forward.cross(c.up).normalize();
        let up = right.cross(forward);
        let tan_half = (c.fov_y_degrees.to_radians() * 0.5).tan();
        let aspect = c.width as f32 / c.height as f32;
        GpuCamera {
            origin: c.position.into(),
            width: c.width,
            forward: forward.into(),
            height: c.height,
            right: (right * tan_half * aspect).into(),
            tmin: crate::scene::limits::ray_offset(c.position.abs().max_element()),
            up: (up * tan_half).into(),
            _pad1: 0,
        }
    }

    /// Unit direction through the centre of pixel (x, y), as `camera_ray_dir` in WGSL.
    pub fn ray_dir(&self, x: u32, y: u32) -> Vec3 {
        let ndc_x = 2.0 * (x as f32 + 0.5) / self.width as f32 - 1.0;
        let ndc_y = 1.0 - 2.0 * (y as f32 + 0.5) / self.height as f32;
        (Vec3::from(self.forward) + ndc_x * Vec3::from(self.right) + ndc_y * Vec3::from(self.up))
            .normalize()
    }
}

/// One pixel of the visibility buffer (mirror of WGSL `VisSample`, 64 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct VisSample {
    /// World-space hit position.
    pub position: [f32; 3],
    /// Distance along the unit camera ray; negative on a miss.
    pub t: f32,
    pub shading_normal: [f32; 3],
    /// Instance hit, `u32::MAX` on a miss.
    pub instance: u32,
    pub geometric_normal: [f32; 3],
    /// Triangle index within the instance's mesh.
    pub mesh_triangle: u32,
    /// Barycentrics of v1 and v2.
    pub bary: [f32; 2],
    pub material: u32,
    /// Absolute triangle index in BVH leaf order (GPU shading tables).
    pub triangle: u32,
}

impl VisSample {
    pub fn is_hit(&self) -> bool {
        self.instance != u32::MAX
    }
}

/// Bytes per pixel of the visibility buffer.
pub const VIS_SAMPLE_BYTES: u64 = std::mem::size_of::<VisSample>() as u64;

/// The visibility buffer of one frame, resident on the GPU.
pub struct VisibilityBuffer {
    pub width: u32,
    pub height: u32,
    pub camera: GpuCamera,
    pub camera_buffer: wgpu::Buffer,
    pub samples: wgpu::Buffer,
}

impl VisibilityBuffer {
    /// Reads the whole buffer back.
    pub fn read(&self, ctx: &GpuContext) -> Result<Vec<VisSample>> {
        ctx.read_buffer(&self.samples)
    }
}

/// Checks that a `width x height` image fits the device (per-pixel buffers and dispatch size).
pub fn check_resolution(ctx: &GpuContext, width: u32, height: u32) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(Error::Usage(format!(
            "resolution {width}x{height} is empty"
        )));
    }
    let pixels = u64::from(width) * u64::from(height);
    let max_groups = u64::from(ctx.device.limits().max_compute_workgroups_per_dimension);
    if u64::from(width.div_ceil(8)) > max_groups || u64::from(height.div_ceil(8)) > max_groups {
        return Err(Error::DeviceLimit(format!(
            "resolution {width}x{height} needs more than {max_groups} workgroups per dimension"
        )));
    }
    let bytes = pixels * VIS_SAMPLE_BYTES;
    let max = ctx.max_binding_size();
    if bytes > max {
        let side = ((max / VIS_SAMPLE_BYTES) as f64).sqrt() as u64;
        return Err(Error::DeviceLimit(format!(
            "resolution {width}x{height} needs a {} MiB visibility buffer; this device binds at most \
             {} MiB per buffer (largest square image: {side}x{side})",
            bytes.div_ceil(1 << 20),
            max >> 20,
        )));
    }
    Ok(())
}

/// The visibility pass (`wgsl/visibility.wgsl`).
pub struct VisibilityPass {
    pass: ScenePass,
}

/// The visibility pass's shader and bindings: the camera and the visibility buffer.
static SHADER: ScenePassShader = ScenePassShader {
    shader: "visibility.wgsl",
    bindings: &[Binding::Uniform, Binding::StorageReadWrite],
    name: "visibility pass",
    builder: "VisibilityPass::for_scene",
    reads_bounce_cache: false,
};

impl VisibilityPass {
    /// The pass for any scene.
    /// [`Self::for_scene`] compiles it for one scene's features alone (`SceneFeatures::of`),
    /// which lavapipe builds and runs faster: an engine that knows its scene should use that.
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        Self::for_scene(ctx, SceneFeatures::ALL)
    }

    /// The pass compiled for scenes of `features` alone (the traversal without instances,
    /// the albedo without textures: `gpu::SceneFeatures`); built once per device and set
    /// of features.
    pub fn for_scene(ctx: &GpuContext, features: SceneFeatures) -> Result<Self> {
        Ok(Self {
            pass: ScenePass::compile(ctx, &SHADER, features)?,
        })
    }

    /// Allocates the visibility buffer for `camera` and records the pass into `encoder`.
    pub fn record(
        &self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        camera: &Camera,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<VisibilityBuffer> {
        let pass = self.pass.for_scene(scene.features())?;
        check_resolution(ctx, camera.width, camera.height)?;
        let gpu_camera = GpuCamera::new(camera);
        let camera_buffer = ctx.uniform_buffer("camera", &gpu_camera);
        let bytes = u64::from(camera.width) * u64::from(camera.height) * VIS_SAMPLE_BYTES;
        let samples = ctx.storage_buffer_sized("visibility buffer", bytes)?;
        let bind = pass.bind(ctx, &[&camera_buffer, &samples]);
        pass.record(
            encoder,
            &scene.bind_group,
            &bind,
            image_groups(camera.width, camera.height),
            timestamps,
        );
        Ok(VisibilityBuffer {
            width: camera.width,
            height: camera.height,
            camera: gpu_camera,
            camera_buffer,
            samples,
        })
    }
}
