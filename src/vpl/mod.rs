//! Virtual point lights by instant radiosity (Keller 1997), the light that instant caching
//! (Debattista et al. 2009, seed 003; `../shared/docs/algorithms-other.md` section 2) gathers
//! its records from (`--records vpl`, `records::RecordSource::Vpl` a layer above).
//!
//! Light paths leave the scene's emitters with a fixed, frame-independent sequence
//! (Owen-scrambled Sobol points, the same for every frame and run), and a VPL is deposited
//! at each of a path's first `bounces` diffuse hits (`wgsl/vpl_trace.wgsl`, one invocation
//! per path). A VPL at the d-th hit carries light reflected d times, so a record that sums
//! the VPLs holds `bounces` bounces: instant caching needs no bounce cache.
//!
//! - **Paths per emitter.** Every light (and the environment, when it is not black) gets
//!   a share of the paths proportional to its power, at least one ([`VplPlan`]); each of
//!   its paths carries `1 / paths` of its emitted flux, so the estimate of every emitter is
//!   the mean of its own paths (stratified by emitter, not drawn at random).
//! - **Emission.** Point lights emit uniformly over the sphere, spots over their outer
//!   cone (weighted by their falloff), rect lights from a point of the quad along a cosine
//!   direction, suns from a disk of the scene's bounding-sphere radius facing them, the
//!   environment from such a disk for a direction drawn by importance (or uniformly for a
//!   constant one). Emitters that are not lights (emissive triangles) emit no VPLs.
//! - **A VPL** holds its position (off its surface), its shading normal and
//!   `power = flux * albedo / pi`: its radiant intensity towards a direction at angle
//!   theta is `power * cos(theta)`, so it gives a point `power cos_y cos_x / d^2` of
//!   irradiance (seed 003 eq. 1). A path continues along a cosine direction of its hit's
//!   shading normal with its flux times the albedo (the Lambertian lobe sampled exactly).
//! - **Slots.** Path p's VPL at hit d sits at slot `p * bounces + d`, so a VPL keeps its
//!   slot when other paths change (temporal instant caching compares slots); a path that
//!   leaves the scene leaves its later slots at zero power, which gathers skip.
//!
//! Built once per prepared scene (VPLs depend on the scene and its lights, not on the
//! camera), deterministically. CPU mirror: [`reference`](mod@reference).

pub mod reference;

use crate::gpu::GpuContext;
use crate::gpu::pipeline::{Binding, ComputePass};
use crate::gpu::scene_buffers::{GpuScene, SceneVpls};
use crate::gpu::timer::PassTimer;
use crate::scene::{Light, Scene};
use crate::{Error, Result};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::f32::consts::PI;

/// The emitter index of the environment (WGSL `LIGHT_ENVIRONMENT`).
pub const ENVIRONMENT: u32 = u32::MAX;

/// Most light paths `--vpl-paths` accepts.
pub const MAX_PATHS: u32 = 1 << 16;

/// How many VPLs, and how near a receiver they may come.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct VplSettings {
    /// Light paths traced (about: every emitter gets at least one); `paths x bounces`
    /// VPL slots, one visibility ray each per record.
    pub paths: u32,
    /// The bounding distance min_d of seed 003 eq. 2-3 (VPLs nearer a receiver than about
    /// min_d fade out, so that none makes a spike) in units of the mean spacing of the VPLs
    /// over the scene's surfaces, `sqrt(area / paths)`: a rule in the VPLs' own scale, the
    /// same on any scene size and VPL count.
    pub clamp: f32,
}

impl Default for VplSettings {
    fn default() -> Self {
        Self {
            paths: 1024,
            // 0.5 x the spacing: lower error than 1 (the first default) on the Cornell box,
            // cube in a box, conference room and Sponza at 1,024, 4,096 and 16,384 paths,
            // two bounces (docs/results.md, "The VPL bounding distance").
            clamp: 0.5,
        }
    }
}

impl VplSettings {
    /// Checks the ranges, naming the flag.
    pub fn validate(&self) -> Result<()> {
        if !(1..=MAX_PATHS).contains(&self.paths) {
            return Err(Error::Usage(format!(
                "--vpl-paths {}: must be 1 to {MAX_PATHS}",
                self.paths
            )));
        }
        if !(self.clamp.is_finite() && self.clamp >= 0.0) {
            return Err(Error::Usage(format!(
                "--vpl-clamp {}: must be a number >= 0 (0: no bounding distance)",
                self.clamp
            )));
        }
        Ok(())
    }
}

/// One virtual point light (mirror of WGSL `Vpl`, 48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Vpl {
    /// Its hit point moved off the surface (a visibility ray ends here).
    pub position: [f32; 3],
    pub _pad0: f32,
    /// Unit shading normal on the side the light arrived from.
    pub normal: [f32; 3],
    pub _pad1: f32,
    /// `flux * albedo / pi` (rgb); zero: an empty slot.
    pub power: [f32; 3],
    pub _pad2: f32,
}

impl Vpl {
    pub fn is_empty(&self) -> bool {
        self.power == [0.0; 3]
    }
}

/// The emitters of a scene and their power (mean of rgb, in watts): what the paths are
/// shared out by. Computed when a scene is prepared.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EmitterPowers {
    /// (light index or [`ENVIRONMENT`], power).
    pub emitters: Vec<(u32, f32)>,
    /// Total one-sided area of the scene's triangles (the VPLs' spacing, `clamp`).
    pub surface_area: f32,
    /// The scene's bounding sphere (centre, radius): suns and the environment emit from
    /// a disk of this radius.
    pub sphere: (Vec3, f32),
}

fn mean(v: Vec3) -> f32 {
    (v.x + v.y + v.z) / 3.0
}

impl EmitterPowers {
    /// The emitters of `scene`, whose world bounds are `bounds`.
    pub fn new(scene: &Scene, bounds: (Vec3, Vec3)) -> Self {
        let centre = 0.5 * (bounds.0 + bounds.1);
        let radius = (0.5 * (bounds.1 - bounds.0).length()).max(1e-6);
        let disk = PI * radius * radius;
        let mut emitters = Vec::new();
        for (i, light) in scene.lights.iter().enumerate() {
            let power = match *light {
                Light::Point { intensity, .. } => 4.0 * PI * mean(intensity),
                Light::Spot {
                    intensity,
                    cos_outer,
                    ..
                } => 2.0 * PI * (1.0 - cos_outer) * mean(intensity),
                Light::Rect {
                    edge_u,
                    edge_v,
                    radiance,
                    ..
                } => PI * edge_u.cross(edge_v).length() * mean(radiance),
                Light::Sun { irradiance, .. } => disk * mean(irradiance),
            };
            if power.is_finite() && power > 0.0 {
                emitters.push((i as u32, power));
            }
        }
        let environment = match &scene.environment_map {
            Some(map) => {
                // The integral of L over the sphere: texel radiance times solid angle.
                let (w, h) = (map.width as usize, map.height as usize);
                let mut sum = 0.0f64;
                for j in 0..h {
                    let theta = PI * (j as f32 + 0.5) / h as f32;
                    let dw = (2.0 * PI / w as f32) * (PI / h as f32) * theta.sin();
                    for i in 0..w {
                        sum += f64::from(mean(map.texels[j * w + i]) * dw);
                    }
                }
                sum as f32 * disk
            }
            None => 4.0 * PI * mean(scene.environment) * disk,
        };
        if environment.is_finite() && environment > 0.0 {
            emitters.push((ENVIRONMENT, environment));
        }
        let mut surface_area = 0.0f64;
        for inst in &scene.instances {
            let mesh = &scene.meshes[inst.mesh as usize];
            for idx in &mesh.indices {
                let p = |k: usize| {
                    inst.transform
                        .transform_point3(mesh.positions[idx[k] as usize])
                };
                surface_area += f64::from(0.5 * (p(1) - p(0)).cross(p(2) - p(0)).length());
            }
        }
        Self {
            emitters,
            surface_area: surface_area as f32,
            sphere: (centre, radius),
        }
    }
}

/// One emitter's run of paths (mirror of WGSL `VplEmitter`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct VplEmitter {
    /// Light index, or [`ENVIRONMENT`].
    pub light: u32,
    pub first_path: u32,
    pub paths: u32,
    pub _pad: u32,
}

/// The paths of a VPL set: which emitter each path leaves, and where the VPLs go.
#[derive(Clone, Debug, PartialEq)]
pub struct VplPlan {
    pub emitters: Vec<VplEmitter>,
    pub paths: u32,
    pub bounces: u32,
    pub sphere: (Vec3, f32),
    /// The bounding distance min_d in world units.
    pub clamp_distance: f32,
}

impl VplPlan {
    /// `settings.paths` paths shared out by power (each emitter at least one), `bounces`
    /// VPLs per path.
    pub fn new(powers: &EmitterPowers, settings: &VplSettings, bounces: u32) -> Self {
        let total: f64 = powers.emitters.iter().map(|&(_, p)| f64::from(p)).sum();
        let mut emitters = Vec::new();
        let mut first = 0u32;
        for &(light, power) in &powers.emitters {
            let share = f64::from(power) / total * f64::from(settings.paths);
            let paths = (share.round() as u32).max(1);
            emitters.push(VplEmitter {
                light,
                first_path: first,
                paths,
                _pad: 0,
            });
            first += paths;
        }
        let spacing = (powers.surface_area / settings.paths as f32).sqrt();
        Self {
            emitters,
            paths: first,
            bounces: bounces.max(1),
            sphere: powers.sphere,
            clamp_distance: settings.clamp * spacing,
        }
    }

    /// VPL slots: `paths x bounces`.
    pub fn slots(&self) -> u32 {
        self.paths * self.bounces
    }

    /// Runs `pass` (a light-path trace: `vpl_trace.wgsl`, `photon_trace.wgsl`, bound to
    /// the plan's params, its emitters and `out`) over the plan's paths, one invocation
    /// per path, timed as `name`.
    pub fn dispatch(
        &self,
        ctx: &GpuContext,
        pass: &ComputePass,
        scene: &GpuScene,
        out: &wgpu::Buffer,
        name: &'static str,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<()> {
        let (c, r) = self.sphere;
        let params = ctx.uniform_buffer(
            "light path params",
            &TraceParams {
                paths: self.paths,
                bounces: self.bounces,
                emitters: self.emitters.len() as u32,
                _pad: 0,
                sphere: [c.x, c.y, c.z, r],
            },
        );
        let emitters = if self.emitters.is_empty() {
            ctx.storage_buffer("light path emitters", &[VplEmitter::default()])?
        } else {
            ctx.storage_buffer("light path emitters", &self.emitters)?
        };
        let bind = pass.bind(ctx, &[&params, &emitters, out]);
        let mut timer = PassTimer::new(ctx, 1);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        pass.record(
            &mut enc,
            &scene.bind_group,
            &bind,
            [self.paths.div_ceil(64), 1, 1],
            timer.next(name),
        );
        timer.resolve(&mut enc);
        ctx.queue.submit([enc.finish()]);
        times.extend(timer.read(ctx)?);
        Ok(())
    }
}

/// What building a VPL set cost and gave.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct VplStats {
    pub paths: u32,
    pub slots: u32,
    /// Slots holding a VPL (the others: paths that left the scene).
    pub vpls: u32,
    pub clamp_distance: f32,
}

/// Mirror of WGSL `LightPathParams` (shared/light_paths.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct TraceParams {
    paths: u32,
    bounces: u32,
    emitters: u32,
    _pad: u32,
    sphere: [f32; 4],
}

/// The VPL tracing pass.
pub struct VplPass {
    trace: std::sync::Arc<ComputePass>,
}

impl VplPass {
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        use Binding::*;
        Ok(Self {
            trace: ComputePass::new(
                ctx,
                "vpl_trace.wgsl",
                &[Uniform, StorageRead, StorageReadWrite],
            )?,
        })
    }

    /// Traces the VPLs of `plan` over `scene` and sets them as the scene's
    /// ([`GpuScene::set_vpls`]). Timed as "vpl trace".
    pub fn build(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        plan: &VplPlan,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<VplStats> {
        let slots = plan.slots().max(1);
        let vpls =
            ctx.storage_buffer_sized("vpls", u64::from(slots) * std::mem::size_of::<Vpl>() as u64)?;
        plan.dispatch(ctx, &self.trace, scene, &vpls, "vpl trace", times)?;
        let all: Vec<Vpl> = ctx.read_buffer(&vpls)?;
        ctx.check()?;
        let filled = all
            .iter()
            .take(plan.slots() as usize)
            .filter(|v| !v.is_empty())
            .count() as u32;
        scene.set_vpls(SceneVpls {
            buffer: vpls,
            count: plan.slots(),
            clamp_distance: plan.clamp_distance,
        });
        Ok(VplStats {
            paths: plan.paths,
            slots: plan.slots(),
            vpls: filled,
            clamp_distance: plan.clamp_distance,
        })
    }

    /// Traces the VPLs of `plan` and reads them back (tests).
    pub fn trace(&self, ctx: &GpuContext, scene: &GpuScene, plan: &VplPlan) -> Result<Vec<Vpl>> {
        self.build(ctx, scene, plan, &mut Vec::new())?;
        let set = scene
            .vpls()
            .ok_or_else(|| Error::Gpu("internal: no VPLs after tracing".into()))?;
        let mut all: Vec<Vpl> = ctx.read_buffer(&set.buffer)?;
        all.truncate(plan.slots() as usize);
        Ok(all)
    }
}
