//! More than one bounce (`--bounces N`, Radiance's `-ab N`): a world-space cache of the
//! indirect irradiance on the scene's surfaces, which every secondary hit reflects.
//!
//! A record's hemisphere plane sees its hits' direct light; with one bounce that is all
//! (a record holds light reflected once). For N bounces the hits must reflect the light
//! that reaches them indirectly too. Radiance recurses (records at the hits of records);
//! the descendants of radiance caching on GPUs (hash-grid caches such as SHaRC, GI-1.0)
//! keep a world-space cache filled by short gathers instead, which is what this is:
//!
//! - every triangle of every instance gets an n x n barycentric grid of cells, n from its
//!   world-space size (`--bounce-cell`, a fraction of the scene diagonal, coarsened until
//!   `--bounce-cells` sides fit), two sides per cell ([`layout`]);
//! - level k of the cache is gathered at every cell side's centroid from
//!   `--bounce-rays` cosine-distributed rays whose hits reflect their direct light plus
//!   level k - 1 (`wgsl/bounce_gather.wgsl`); level N - 1 holds light reflected N - 1
//!   times before it reaches a surface;
//! - hemisphere-plane samples (traced, refined, re-traced or re-shaded at t+1) and glossy
//!   lobe rays reflect their hit's cell of level N - 1 (`hit_radiance` in `wgsl/shared/trace_and_shade.wgsl`), so
//!   records hold N bounces.
//!
//! The cache is computed once per prepared scene (it depends on the scene, not the
//! camera), deterministically (one invocation per cell side, rays summed in order). With
//! one bounce it is empty and every image is byte for byte what it was. The reference
//! (`radsplat reference --bounces N`) follows its paths instead; the two agree exactly
//! where radiance is uniform (the furnace test) and within the cache's resolution
//! elsewhere. In animations every frame's prepared scene has its own cache; temporal
//! caching builds frame t+1's while rendering frame t, for its estimates at t+1.

pub mod layout;
pub mod reference;

use crate::gpu::pipeline::{Binding, ComputePass};
use crate::gpu::scene_buffers::GpuScene;
use crate::gpu::timer::{PassTimer, spanning};
use crate::gpu::{GpuContext, SceneFeatures};
use crate::light_maps::LightMaps;
use crate::{Error, Result};
pub use layout::{BounceCell, BounceGeometry, BounceLayout};

/// The most direct irradiance (largest channel) a point of `scene` can receive: a
/// hemisphere full of its brightest area emitter or environment (pi L), plus every sun, plus
/// every point or spot light seen from 1 % of the scene `diagonal`. A gather hit's direct
/// light is one light sample per light, whose estimate near an area light grows as
/// 1 / r^2 of the sampled point: with 32 rays a cell, one hit a centimetre from a panel
/// made a cell of the conference room 4,000 times its neighbours' (and, reflected by
/// every plane hit on it, a bright blotch in the image). Clamping each hit's estimate to
/// what no point can exceed removes those without touching any estimate a point can have.
pub fn direct_irradiance_bound(scene: &crate::scene::Scene, diagonal: f32) -> f32 {
    use crate::scene::Light;
    let max = |v: glam::Vec3| v.max_element().max(0.0);
    let mut area = max(scene.environment);
    if let Some(map) = &scene.environment_map {
        area = area.max(map.texels.iter().map(|&t| max(t)).fold(0.0, f32::max));
    }
    for m in &scene.materials {
        area = area.max(max(m.emission));
    }
    let mut bound = 0.0;
    let r_min = 0.01 * diagonal.max(f32::MIN_POSITIVE);
    for light in &scene.lights {
        match *light {
            Light::Rect { radiance, .. } => area = area.max(max(radiance)),
            Light::Sun { irradiance, .. } => bound += max(irradiance),
            Light::Point { intensity, .. } | Light::Spot { intensity, .. } => {
                bound += max(intensity) / (r_min * r_min)
            }
        }
    }
    bound + std::f32::consts::PI * area
}

/// Most bounces `--bounces` accepts.
pub const MAX_BOUNCES: u32 = 8;

/// How many bounces, and how the cache that carries the ones past the first is made.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct BounceSettings {
    /// Bounces N (1: the first bounce alone, no cache).
    pub bounces: u32,
    /// Gather rays per cell side and level.
    pub rays: u32,
    /// Cell edge as a fraction of the scene's bounding-box diagonal.
    pub cell_size: f32,
    /// Most cell sides (two per cell); cells are coarsened to fit.
    pub max_cells: u32,
    /// Shadows of the gather's hits from light-space maps of every light (rect lights
    /// included); false: one shadow ray per light sample.
    pub shadow_maps: bool,
}

impl Default for BounceSettings {
    fn default() -> Self {
        Self {
            bounces: 1,
            rays: 32,
            cell_size: 1.0 / 64.0,
            max_cells: 1 << 21,
            shadow_maps: true,
        }
    }
}

impl BounceSettings {
    /// Checks the ranges, naming the flag.
    pub fn validate(&self) -> Result<()> {
        let bad = |field: &str, why: &str| Err(Error::Usage(format!("{field} {why}")));
        if !(1..=MAX_BOUNCES).contains(&self.bounces) {
            return bad("--bounces", &format!("must be 1 to {MAX_BOUNCES}"));
        }
        if !(1..=4096).contains(&self.rays) {
            return bad("--bounce-rays", "must be 1 to 4096");
        }
        if !(self.cell_size.is_finite() && self.cell_size > 0.0 && self.cell_size <= 1.0) {
            return bad("--bounce-cell", "must be in (0, 1]");
        }
        if self.max_cells < 2 {
            return bad("--bounce-cells", "must be at least 2");
        }
        Ok(())
    }

    /// Levels of the cache: N - 1.
    pub fn levels(&self) -> u32 {
        self.bounces.saturating_sub(1)
    }
}

/// What building a cache cost.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct BounceStats {
    pub levels: u32,
    pub cells: u32,
    pub cell_size: f32,
    pub rays: u64,
    pub bytes: u64,
}

/// A computed cache: the buffer the passes bind (the layout's table, then 3 floats per
/// cell side of the last level).
pub struct BounceCache {
    pub buffer: wgpu::Buffer,
    pub stats: BounceStats,
}

/// Mirror of WGSL `GatherParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct GatherParams {
    first_side: u32,
    sides: u32,
    ray_begin: u32,
    ray_end: u32,
    rays: u32,
    light_samples: u32,
    irradiance_bound: f32,
    _pad: u32,
}

/// Cell sides per gather dispatch (a dispatch's x extent, at 64 per workgroup).
const SIDES_PER_DISPATCH: u32 = 1 << 18;

/// The gather pass.
pub struct BouncePass {
    gather: std::sync::Arc<ComputePass>,
}

impl BouncePass {
    /// The pass for any scene.
    /// [`Self::for_scene`] compiles it for one scene's features alone (`SceneFeatures::of`),
    /// which lavapipe builds and runs faster: an engine that knows its scene should use that.
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        Self::for_scene(ctx, SceneFeatures::ALL)
    }

    /// The pass compiled for scenes of `features` alone (`gpu::SceneFeatures`; the bounce
    /// cache's bit included, as levels after the first read the level before).
    pub fn for_scene(ctx: &GpuContext, features: SceneFeatures) -> Result<Self> {
        use Binding::*;
        Ok(Self {
            gather: ComputePass::with_constants(
                ctx,
                "bounce_gather.wgsl",
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
        })
    }

    /// Builds the cache of `layout` (levels `1..bounces`) over `scene` with
    /// `light_samples` light samples per light at each gather hit, their shadows from
    /// `light_maps` where those have a map (else shadow rays), and sets it as the scene's
    /// ([`GpuScene::set_bounce_cache`]). Timed as "bounce cache".
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        layout: &BounceLayout,
        settings: &BounceSettings,
        light_samples: u32,
        light_maps: &LightMaps,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<BounceCache> {
        settings.validate()?;
        let sides = layout.sides();
        let value_bytes = u64::from(sides) * 12;
        let table_bytes = layout.table.len() as u64 * 4;
        let cache = ctx.storage_buffer_sized("bounce cache", table_bytes + value_bytes)?;
        ctx.queue
            .write_buffer(&cache, 0, bytemuck::cast_slice(&layout.table));
        let cells = ctx.storage_buffer("bounce cells", &layout.cells)?;
        let values = ctx.storage_buffer_sized("bounce values", value_bytes)?;
        // Rays one invocation may trace per dispatch: each gather ray and its hit's
        // shadow rays (llvmpipe's loop budget, as the reference's samples).
        let shadow_rays = scene.info.max_shadow_rays(light_samples.max(1));
        let per_dispatch =
            crate::gpu::context::max_samples_per_dispatch(shadow_rays).min(settings.rays);
        // Every level in one submission, timed as one span and read back once: wgpu
        // orders each dispatch after the copy of the level before it.
        let ray_chunks = settings.rays.div_ceil(per_dispatch);
        let side_chunks = sides.div_ceil(SIDES_PER_DISPATCH).max(1);
        let dispatches = settings.levels() * ray_chunks * side_chunks;
        let mut timer = PassTimer::new(ctx, 1);
        let stamps = timer.next("bounce cache");
        let mut dispatch = 0;
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        for _level in 0..settings.levels() {
            let mut ray = 0;
            while ray < settings.rays {
                let ray_end = (ray + per_dispatch).min(settings.rays);
                let mut first = 0;
                while first < sides {
                    let n = (sides - first).min(SIDES_PER_DISPATCH);
                    let params = ctx.uniform_buffer(
                        "bounce gather params",
                        &GatherParams {
                            first_side: first,
                            sides,
                            ray_begin: ray,
                            ray_end,
                            rays: settings.rays,
                            light_samples: light_samples.max(1),
                            irradiance_bound: layout.irradiance_bound,
                            _pad: 0,
                        },
                    );
                    let bind = self.gather.bind(
                        ctx,
                        &[
                            &params,
                            &cells,
                            &cache,
                            &values,
                            &light_maps.maps_buffer,
                            &light_maps.depths,
                            &light_maps.first_buffer,
                        ],
                    );
                    self.gather.record(
                        &mut enc,
                        &scene.bind_group,
                        &bind,
                        [n.div_ceil(64), 1, 1],
                        spanning(stamps.as_ref(), dispatch == 0, dispatch + 1 == dispatches),
                    );
                    dispatch += 1;
                    first += n;
                }
                ray = ray_end;
            }
            // The level just gathered becomes what the next one (and every pass) reads.
            enc.copy_buffer_to_buffer(&values, 0, &cache, table_bytes, value_bytes);
        }
        timer.resolve(&mut enc);
        ctx.queue.submit([enc.finish()]);
        let ms: f64 = timer.read(ctx)?.iter().map(|(_, t)| t).sum();
        ctx.check()?;
        times.push(("bounce cache", ms));
        scene.set_bounce_cache(cache.clone(), true);
        Ok(BounceCache {
            buffer: cache,
            stats: BounceStats {
                levels: settings.levels(),
                cells: layout.cells.len() as u32,
                cell_size: layout.cell_size,
                rays: u64::from(sides) * u64::from(settings.rays) * u64::from(settings.levels()),
                bytes: table_bytes + value_bytes,
            },
        })
    }
}
