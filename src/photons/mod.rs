//! The photon map of photon-mapped irradiance caching (thesis chapter 6, Brouillat's
//! method; `../shared/docs/algorithms.md` section 5): photons traced from the lights on the
//! GPU (`wgsl/photon_trace.wgsl`), read back in slot order, and indexed by a uniform grid
//! ([`map::PhotonMap`]) for the neighbourhood queries of record placement and record
//! generation (`records::photon_records`, a layer above).
//!
//! - **Paths** leave the emitters exactly as the VPL paths do (the same plan: paths shared
//!   out by power, the same Sobol sequences, `wgsl/shared/light_paths.wgsl`), so the map is
//!   the same every frame and run.
//! - **A photon** is stored at each of a path's hits after the first `bounces` times: the
//!   first hit is direct light, which pixels compute exactly; the photon at the d-th hit
//!   after it carries light reflected d times. Summed over a record's neighbourhood they
//!   give the record's indirect irradiance with `bounces` bounces (any number).
//! - Each photon keeps its flux, the direction it arrived from, its surface's shading
//!   normal and the distance to the surface it was last reflected from (thesis Fig. 6.1):
//!   the harmonic mean of those distances is the record's R, as the plane's hit distances
//!   are for a plane record.
//! - **Slots.** Path p's d-th photon sits at slot `p * bounces + d - 1` (ordered writes);
//!   a path that leaves the scene leaves its later slots empty (zero flux).
//!
//! CPU mirror of the trace: [`reference`](mod@reference).

pub mod map;
pub mod reference;

use crate::gpu::GpuContext;
use crate::gpu::pipeline::{Binding, ComputePass};
use crate::gpu::scene_buffers::GpuScene;
use crate::vpl::{EmitterPowers, VplPlan, VplSettings};
use crate::{Error, Result};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Most light paths `--photon-paths` accepts (64 bytes per photon and bounce).
pub const MAX_PATHS: u32 = 1 << 21;

/// How many photons, and how many a record's first neighbourhood holds.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct PhotonSettings {
    /// Light paths traced (about: every emitter gets at least one); each stores up to
    /// `bounces` photons.
    pub paths: u32,
    /// Photons of the first neighbourhood query of a record (Algorithm 7 step 1): the
    /// nearest this many on the record's surface estimate its harmonic mean distance R;
    /// the record's irradiance comes from the photons within `a R` (step 3), and only
    /// where those are at least this many (elsewhere plane records fill in).
    pub gather: u32,
    /// How a record measures the area its photons cover (`--photon-area`).
    pub area: PhotonArea,
}

/// The area a photon record divides its photons' flux by (E = sum Phi / A, thesis eq. 6.2).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, clap::ValueEnum)]
pub enum PhotonArea {
    /// The thesis's: the convex hull of the photons in the tangent plane, divided by the
    /// mean shortfall of a hull of that many uniform points. Where the neighbourhood spans
    /// gaps (coplanar pieces: chair seats and legs, a wall between windows) the hull covers
    /// surface that is not there and E comes out low.
    Hull,
    /// The hull, less its part with no surface under it: 64 probe points spread over the
    /// photons' disc, each inside the hull looks for the record's surface (a short ray
    /// along -n, the same normal and slope bounds as the photons); A = hull x the share
    /// of those probes that find it (records/photon_records.rs, `probe_points`).
    #[default]
    Probed,
}

impl Default for PhotonSettings {
    fn default() -> Self {
        Self {
            paths: 1 << 17,
            gather: 64,
            area: PhotonArea::default(),
        }
    }
}

impl PhotonSettings {
    /// Checks the ranges, naming the flag.
    pub fn validate(&self) -> Result<()> {
        if !(1..=MAX_PATHS).contains(&self.paths) {
            return Err(Error::Usage(format!(
                "--photon-paths {}: must be 1 to {MAX_PATHS}",
                self.paths
            )));
        }
        if !(8..=1024).contains(&self.gather) {
            return Err(Error::Usage(format!(
                "--photon-gather {}: must be 8 to 1024 (the convex hull of fewer photons \
                 says little about the area they cover)",
                self.gather
            )));
        }
        Ok(())
    }

    /// The paths of these settings over `powers`, `bounces` photons each (the VPL plan's
    /// sharing of paths among emitters).
    pub fn plan(&self, powers: &EmitterPowers, bounces: u32) -> VplPlan {
        VplPlan::new(
            powers,
            &VplSettings {
                paths: self.paths,
                clamp: 0.0,
            },
            bounces,
        )
    }
}

/// One photon (mirror of WGSL `Photon`, 64 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Photon {
    /// On its surface.
    pub position: [f32; 3],
    /// From the surface it was last reflected from (its ray's length).
    pub distance: f32,
    /// Unit direction towards where it came from.
    pub direction: [f32; 3],
    /// Reflections before it arrived (1..=bounces).
    pub bounce: u32,
    /// Flux (rgb, watts); zero: an empty slot.
    pub flux: [f32; 3],
    pub _pad0: f32,
    /// Unit shading normal of its surface, on the side it arrived from.
    pub normal: [f32; 3],
    pub _pad1: f32,
}

impl Photon {
    pub fn is_empty(&self) -> bool {
        self.flux == [0.0; 3]
    }
    pub fn position(&self) -> Vec3 {
        self.position.into()
    }
    pub fn normal(&self) -> Vec3 {
        self.normal.into()
    }
    pub fn direction(&self) -> Vec3 {
        self.direction.into()
    }
    pub fn flux(&self) -> Vec3 {
        self.flux.into()
    }
}

/// The photon tracing pass.
pub struct PhotonPass {
    trace: std::sync::Arc<ComputePass>,
}

impl PhotonPass {
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        use Binding::*;
        Ok(Self {
            trace: ComputePass::new(
                ctx,
                "photon_trace.wgsl",
                &[Uniform, StorageRead, StorageReadWrite],
            )?,
        })
    }

    /// Traces the photons of `plan` (`plan.bounces` slots per path) over `scene` and reads
    /// them back in slot order, empty slots included. Timed as "photon trace".
    pub fn trace(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        plan: &VplPlan,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<Vec<Photon>> {
        Ok(self.trace_on_gpu(ctx, scene, plan, times)?.1)
    }

    /// As [`PhotonPass::trace`], also returning the GPU buffer the photons were traced
    /// into (what the record reduction reads: no second upload).
    fn trace_on_gpu(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        plan: &VplPlan,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<(wgpu::Buffer, Vec<Photon>)> {
        let slots = u64::from(plan.slots());
        let bytes = slots.max(1) * std::mem::size_of::<Photon>() as u64;
        if bytes > ctx.max_binding_size() {
            return Err(Error::DeviceLimit(format!(
                "{slots} photon slots ({} paths x {} bounces) need {} MiB in one buffer; this \
                 device allows {} MiB per binding: use fewer --photon-paths",
                plan.paths,
                plan.bounces,
                bytes.div_ceil(1 << 20),
                ctx.max_binding_size() >> 20
            )));
        }
        let photons = ctx.storage_buffer_sized("photons", bytes)?;
        plan.dispatch(ctx, &self.trace, scene, &photons, "photon trace", times)?;
        let mut all: Vec<Photon> = ctx.read_buffer(&photons)?;
        ctx.check()?;
        all.truncate(plan.slots() as usize);
        Ok((photons, all))
    }
}

/// A scene's photon map: on the CPU for the neighbourhood queries, on the GPU for the
/// record reduction.
pub struct ScenePhotons {
    pub map: map::PhotonMap,
    pub buffer: wgpu::Buffer,
    pub stats: PhotonStats,
}

/// What tracing a photon map cost and gave.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct PhotonStats {
    pub paths: u32,
    pub slots: u32,
    /// Slots holding a photon.
    pub photons: u32,
    /// The map's grid cell (world units).
    pub cell: f32,
}

impl PhotonPass {
    /// Traces the photons of `plan` and indexes them ([`map::PhotonMap`]) in cells about
    /// the radius that holds `gather` photons at their mean density over
    /// `surface_area`. Timed as "photon trace" (GPU) and "photon map" (CPU).
    pub fn build(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        plan: &VplPlan,
        gather: u32,
        surface_area: f32,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<ScenePhotons> {
        let (buffer, photons) = self.trace_on_gpu(ctx, scene, plan, times)?;
        let t0 = std::time::Instant::now();
        let stored = photons.iter().filter(|p| !p.is_empty()).count() as u32;
        let cell = map::cell_for(stored, surface_area, gather);
        let map = map::PhotonMap::new(photons, cell);
        times.push(("photon map", t0.elapsed().as_secs_f64() * 1e3));
        Ok(ScenePhotons {
            stats: PhotonStats {
                paths: plan.paths,
                slots: plan.slots(),
                photons: stored,
                cell: map.cell(),
            },
            map,
            buffer,
        })
    }
}
