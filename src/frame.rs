//! Running a frame: scene → BVH → visibility → direct light → records (placement,
//! hemisphere planes) → splat → resolve → images. [`Renderer::render_gi_frame`] renders a
//! global-illumination frame; the function behind it (`render_cached_frame_timed`) reads
//! as the frame's data flow, one call a stage: the records' other sources, visibility and
//! direct light, the irradiance records' placement and gather, the radiance records, the
//! resolve.

use crate::bvh::SceneBvh;
use crate::direct::{DirectLightPass, DirectOutput};
use crate::glossy::GlossyIndirectPass;
use crate::gpu::pipeline::OnFirstUse;
use crate::gpu::scene_buffers::GpuLight;
use crate::gpu::timer::PassTimer;
use crate::gpu::{GpuContext, GpuScene, SceneFeatures};
use crate::light_maps::{LightMapPass, LightMapSettings, LightMaps, MappedLights};
use crate::placement::{PlacementPass, PlacementStats};
use crate::records::kind::RadianceSettings;
use crate::records::{CacheSettings, PlaneShadows, Record, RecordCache, RecordPass};
use crate::resolve::{GlossyInput, ResolvePass};
use crate::scene::{Camera, Scene};
use crate::splat::radiance::{RadianceSplatPass, RadianceTables};
use crate::splat::{CoverageMask, SplatBuffer, SplatPass, SplatSource, TileBounds};
use crate::visibility::{VisSample, VisibilityBuffer, VisibilityPass};
use crate::{Error, Result};
use std::time::Instant;

/// A scene made ready for the GPU: its BVH built and its tables uploaded.
pub struct PreparedScene {
    pub gpu: GpuScene,
    pub bvh_stats: BvhStats,
    /// The lights as uploaded and the scene's world bounds: what light maps are laid out
    /// from.
    pub lights: Vec<GpuLight>,
    pub bounds: (glam::Vec3, glam::Vec3),
    /// Shadow rays a hit casts: this many per light sample (rect lights and the
    /// environment), plus `.1` (one per point, spot or sun): `scene::shadow_rays_per_hit`.
    shadow_rays: (u64, u64),
    /// The light maps traced for this scene, with what they were traced for: they depend
    /// on the scene, not the camera, so every frame rendered from it (a walkthrough, an
    /// engine's views) reuses them.
    light_maps: std::sync::Mutex<Option<TracedLightMaps>>,
    /// The triangles' areas the bounce cache is laid out from, and the cache built for this
    /// scene with the settings it was built for (none: one bounce).
    bounce_geometry: crate::bounce::BounceGeometry,
    bounce: std::sync::Mutex<Option<BuiltBounceCache>>,
    /// The emitters VPL paths leave, and the VPLs traced for this scene with the plan they
    /// were traced for (none: no cache gathers from VPLs).
    emitter_powers: crate::vpl::EmitterPowers,
    vpls: std::sync::Mutex<Option<(crate::vpl::VplPlan, crate::vpl::VplStats)>>,
    /// The photon map traced for this scene, with the plan and gather it was built for
    /// (none: no cache takes records from photons).
    photons: std::sync::Mutex<Option<ScenePhotonMap>>,
}

/// A prepared scene's photon map and what it was built for.
type ScenePhotonMap = (
    crate::vpl::VplPlan,
    u32,
    std::sync::Arc<crate::photons::ScenePhotons>,
);

/// A bounce cache of a prepared scene, with its settings and gather light samples.
type BuiltBounceCache = (
    crate::bounce::BounceSettings,
    u32,
    std::sync::Arc<crate::bounce::BounceCache>,
);

/// Light maps of a prepared scene and the settings they were traced with.
type TracedLightMaps = (LightMapSettings, MappedLights, std::sync::Arc<LightMaps>);

/// Size and build time of a scene's BVH.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct BvhStats {
    /// Instances traced (the commands bake a static scene's into one:
    /// [`crate::scene::Scene::merge_static_instances`]).
    pub instances: usize,
    pub triangles: usize,
    pub blas_nodes: usize,
    pub tlas_nodes: usize,
    pub build_ms: f64,
    pub upload_bytes: u64,
}

/// What [`Renderer::cover_in_rounds`] saw: the coverage mask and the count of marked
/// pixels after each round, the rounds covered again because their lists did not fit, and
/// the pixels a cover whose lists did not fit marked (none, if it marks nothing as it
/// should).
#[derive(Debug, Default)]
pub struct CoverRounds {
    pub masks: Vec<Vec<u32>>,
    pub marked: Vec<u32>,
    pub repeats: u32,
    pub stray: usize,
}

/// What [`Renderer::splat_cache_in_rounds`] returns: the visibility buffer, the splat sums
/// `(sum w E', sum w)` and the coverage mask, per pixel.
pub type SplatRounds = (Vec<VisSample>, Vec<[f32; 4]>, Vec<u32>);

/// Options of [`Renderer::render_cached_frame`].
#[derive(Default)]
pub struct CachedFrameOptions<'a, 'b> {
    /// At most this many new records (None: until every visible pixel is covered).
    pub max_new_records: Option<u32>,
    /// A stage run inside record computation (temporal caching: estimate every new
    /// record at the next frame).
    pub stage: Option<&'a mut (dyn crate::records::RecordStage + 'b)>,
    /// Count the pixels each record covers.
    pub count_coverage: bool,
    /// Only place records: no direct light, no resolve; the returned frame has stats and
    /// no images (the first pass of interpolated temporal gradients).
    pub placement_only: bool,
    /// The frame's visibility buffer when already traced (temporal replacement decides
    /// with it); None: traced here.
    pub visibility: Option<VisibilityBuffer>,
    /// Radiance records for the glossy pixels they shade (placed, then splatted); None:
    /// every glossy lobe by Monte Carlo.
    pub radiance: Option<RadianceFrame<'a, 'b>>,
}

/// The radiance records a frame splats and the pass that places more
/// ([`CachedFrameOptions::radiance`]): a [`RadianceCache`]'s parts, or temporal caching's.
pub struct RadianceFrame<'a, 'b> {
    pub records: &'a mut RecordCache,
    pub pass: &'a RecordPass,
    pub splat: &'a RadianceSplatPass,
    /// A stage run inside their computation (temporal caching: their estimate at t+1).
    pub stage: Option<&'a mut (dyn crate::records::RecordStage + 'b)>,
    /// At most this many new radiance records (None: every pixel they shade covered).
    pub max_new_records: Option<u32>,
}

impl RadianceCache {
    /// This cache as a frame's radiance records, placing as many as the frame needs.
    pub fn frame(&mut self) -> RadianceFrame<'_, 'static> {
        RadianceFrame {
            records: &mut self.records,
            pass: &self.pass,
            splat: &self.splat,
            stage: None,
            max_new_records: None,
        }
    }
}

/// Statistics of one frame.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FrameStats {
    pub width: u32,
    pub height: u32,
    /// GPU time per pass in ms (timestamp queries), without shader compilation; empty
    /// unless passes are timed ([`crate::gpu::GpuContext::set_pass_timing`]) on a device
    /// with timestamps.
    pub pass_ms: Vec<(String, f64)>,
    /// Shader compilation per pass in ms (wall time), for the pipelines first dispatched
    /// during this frame: compiled once per process, at first use, so later frames have
    /// none (see `gpu::pipeline::ComputePass`). On drivers that compile at the first
    /// dispatch (lavapipe), only while passes are timed.
    pub shader_compile_ms: Vec<(String, f64)>,
    /// Wall time of the frame on the CPU side, submit to readback, in ms.
    pub wall_ms: f64,
    /// Times the host waited for the device during the frame (read-backs and timer
    /// reads; shader compilations not counted): on a fast GPU each is a round trip of
    /// launch latency that bounds the frame's wall time.
    pub gpu_waits: u64,
    pub camera_rays: u64,
    /// Irradiance cache statistics (GI frames only).
    pub cache: Option<CacheFrameStats>,
}

/// What the irradiance cache did in one frame.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct CacheFrameStats {
    /// Records in the cache after the frame.
    pub records: u32,
    /// Records reused from earlier frames.
    pub reused_records: u32,
    #[serde(flatten)]
    pub placement: PlacementStats,
    /// Hemisphere-plane rays traced this frame (one per plane pixel, plus the sub-samples
    /// of refined pixels, every pixel's for planes that saw no light; shadow rays of the
    /// plane hits not counted).
    pub plane_rays: u64,
    /// Of `plane_rays`, those of planes that saw no light beyond their refinement's
    /// share (they were refined everywhere).
    pub dark_plane_rays: u64,
    /// Visible pixels no record covers after placement.
    pub uncovered_pixels: u64,
    /// The factor of the accuracy the frame's records were interpolated at: the settings'
    /// `interpolation_factor`, widened for noisy records (`records::noise_widening`), and
    /// their median relative noise (0: no record carries one, or it was not read).
    pub interpolation_factor: f32,
    pub median_record_noise: f32,
    /// Pixels that kept the widened gather's irradiance, within
    /// `CacheSettings::widening_tolerance` of the default gather's (0 where the frame did
    /// not widen, or widened without the check).
    pub widened_pixels: u64,
    /// Radiance records in their cache after the frame, and those added this frame.
    pub radiance_records: u32,
    pub new_radiance_records: u32,
    /// The radiance records' HSH order: the most bands a lobe they shade keeps (0: none).
    pub radiance_order: u32,
    /// The surface bounce cache the plane hits reflected (`--bounces` above 1).
    pub bounce: Option<crate::bounce::BounceStats>,
    /// The VPLs the records gathered from (`--records vpl`).
    pub vpls: Option<crate::vpl::VplStats>,
    /// The photon map and the records placed from it (`--records photons`; none on a
    /// frame whose cache already held records).
    pub photons: Option<PhotonRecordStats>,
}

/// [`Renderer::splat_cache_checked`]'s gathers, per pixel `(sum w E (rgb), sum w)`.
pub struct CheckedSplat {
    pub vis: Vec<VisSample>,
    /// The frame's widened interpolation factor.
    pub factor: f32,
    /// At the settings' `interpolation_factor`.
    pub narrow: Vec<[f32; 4]>,
    /// At `factor`, before the check.
    pub wide: Vec<[f32; 4]>,
    /// `wide` after the check against `narrow` on the GPU.
    pub checked: Vec<[f32; 4]>,
    /// Pixels that kept `wide`'s sums where both had some.
    pub kept: u32,
}

/// What photon-mapped records cost and gave in a frame.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct PhotonRecordStats {
    #[serde(flatten)]
    pub map: crate::photons::PhotonStats,
    /// Records placed along the photon array (Algorithm 6).
    pub records: u32,
    /// Photons inside the frustum that the walk visited.
    pub walked: u32,
    /// Uncovered photons with too few neighbours for a record.
    pub too_sparse: u32,
    /// Photons the records were reduced from (with repeats).
    pub gathered: u64,
}

/// What a frame's records take light from beyond their own planes
/// ([`Renderer::record_sources`]), for its statistics.
struct RecordSources {
    bounce: Option<crate::bounce::BounceStats>,
    vpls: Option<crate::vpl::VplStats>,
    photons: Option<PhotonRecordStats>,
}

/// What a frame's radiance records gave it ([`Renderer::radiance_records`]); the default:
/// none.
#[derive(Default)]
struct RadianceOutcome<'p> {
    /// The pass that computed them.
    pass: Option<&'p RecordPass>,
    /// Records in their cache after the frame, and those added this frame.
    records: u32,
    new_records: u32,
    /// Their HSH order.
    order: u32,
    /// Whether they cover every pixel with a glossy lobe (no Monte Carlo lobe rays).
    covers_all: bool,
    /// Their gather, `(sum w L (rgb), sum w)` per pixel (None in a placement-only pass).
    sums: Option<wgpu::Buffer>,
}

/// A resolved frame's images, read back ([`Renderer::resolve_images`]).
struct ResolvedImages {
    beauty: Vec<[f32; 4]>,
    albedo: Vec<[f32; 4]>,
    direct: Vec<[f32; 4]>,
    indirect: Vec<[f32; 4]>,
    visibility: Vec<VisSample>,
    /// Visible pixels no record reached.
    uncovered_pixels: u64,
}

/// Every record of `records`, gathered at `factor` times the settings' accuracy with the
/// weight plateau that factor takes (`records::noise_widening::weight_plateau`): a frame's
/// gather, which the test helpers `Renderer::splat_cache*` repeat. A `still` frame of
/// plane records leaves the pixels only dark records reach to tail fill
/// (`SplatSource::dark_only_empty`); temporal caching's first pass does not (the second
/// pass of interpolated gradients renders as a still frame).
fn frame_gather_source<'a>(
    scene: &'a PreparedScene,
    vis: &'a VisibilityBuffer,
    bounds: &'a TileBounds,
    records: &'a RecordCache,
    settings: &CacheSettings,
    factor: f32,
    still: bool,
) -> SplatSource<'a> {
    SplatSource {
        scene: &scene.gpu,
        vis,
        bounds,
        records,
        first: 0,
        accuracy: settings.accuracy * factor,
        plateau: crate::records::noise_widening::weight_plateau(settings, factor),
        dark_only_empty: still && settings.source == crate::records::RecordSource::Planes,
        corral: settings.corral.in_gathers(),
    }
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
    /// Reflected first-bounce indirect light (GI frames only).
    pub indirect: Option<Vec<[f32; 4]>>,
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

/// The renderer: its passes on one GPU context, each compiled at its first use, so that a
/// command builds only the pipelines it runs (`render --direct-only` never builds the
/// cache's, `reference` never the splat's).
pub struct Renderer {
    pub ctx: GpuContext,
    splat: OnFirstUse<SplatPass>,
    placement: OnFirstUse<PlacementPass>,
    resolve: OnFirstUse<ResolvePass>,
    light_maps: OnFirstUse<LightMapPass>,
    vpl: OnFirstUse<crate::vpl::VplPass>,
    photon: OnFirstUse<crate::photons::PhotonPass>,
    photon_reduce: OnFirstUse<crate::records::photon_records::PhotonReducePass>,
}

/// A pass to build ahead ([`Renderer::build_frame_start_passes`], [`Renderer::build_ahead`]).
type Build<'a> = Box<dyn Fn() -> Result<()> + Sync + 'a>;

/// How the threads that build passes ahead share the CPU with a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BuildPriority {
    /// As any other thread: nothing else runs (start-up, or a caller that waits for them).
    Now,
    /// At the lowest priority (on Linux; elsewhere as `Now`): beside a running frame, they
    /// take the cores lavapipe leaves idle (its compilations at a pipeline's first
    /// dispatch, one at a time on its queue thread; the last workgroups of a dispatch)
    /// without slowing its passes. A pass the frame needs before it is built, the frame
    /// builds itself at its own priority (or waits for it while its own cores are idle).
    /// At the same priority as the frame, the builds only moved time from start-up into
    /// the frame: nave-west 160x160's process took 1.02 of its time; at the lowest, 0.90
    /// (docs/results.md, "Pipelines built while the frame runs").
    IdleCores,
}

/// Gives the calling thread the lowest scheduling priority (nice 19). On Linux the nice
/// value is per thread; elsewhere `setpriority` would lower the whole process, so nothing
/// is done.
fn lower_this_threads_priority() {
    #[cfg(target_os = "linux")]
    {
        // SAFETY: gettid takes no arguments; setpriority only reads its arguments, and a
        // failure (no permission is needed to lower one's priority) leaves it unchanged.
        unsafe {
            let tid = libc::syscall(libc::SYS_gettid) as libc::id_t;
            libc::setpriority(libc::PRIO_PROCESS, tid, 19);
        }
    }
}

/// Runs `builds` on up to `threads` threads (at least one) at `priority`, each thread
/// taking the next in order; the first error is returned once all have stopped. More
/// threads than cores only made the builds contend (Cornell box 128x128: 0.51 s against
/// 0.4 s serial).
fn run_builds(builds: &[Build], threads: usize, priority: BuildPriority) -> Result<()> {
    let next = std::sync::atomic::AtomicUsize::new(0);
    let worker = || -> Result<()> {
        if priority == BuildPriority::IdleCores {
            lower_this_threads_priority();
        }
        loop {
            let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            match builds.get(i) {
                Some(build) => build()?,
                None => return Ok(()),
            }
        }
    };
    std::thread::scope(|s| {
        let workers: Vec<_> = (0..threads.max(1).min(builds.len()))
            .map(|_| s.spawn(worker))
            .collect();
        for w in workers {
            w.join()
                .unwrap_or_else(|_| Err(Error::Gpu("building a pass panicked".into())))?;
        }
        Ok(())
    })
}

/// An irradiance cache: its records on the GPU and the pass that computes new ones with
/// the cache's settings. Records are view-independent, so one cache serves any number of
/// cameras over the same static scene (thesis section 4.7.2).
pub struct IrradianceCache {
    pub records: RecordCache,
    pub pass: RecordPass,
    /// The radiance records beside the irradiance ones, built at the first frame of a
    /// scene with lobes they shade (`settings.radiance`; None before, or when off).
    pub radiance: Option<RadianceCache>,
}

/// Radiance records (issue 18): a cache of [`crate::records::RecordKind::Radiance`]
/// records, the pass that computes them (planes projected onto HSH) and the splat with its
/// scene's tables.
/// Placed on their own, at their own accuracy, where visible pixels have a lobe they
/// shade; splatted onto those pixels only.
pub struct RadianceCache {
    pub records: RecordCache,
    pub pass: RecordPass,
    pub splat: RadianceSplatPass,
}

impl RadianceCache {
    /// The radiance cache for `scene` with `settings` (their `radiance` part), or None
    /// when radiance records are off or no material's lobe qualifies.
    pub fn new(
        ctx: &GpuContext,
        scene: &GpuScene,
        settings: &CacheSettings,
    ) -> Result<Option<Self>> {
        let Some((record_settings, tables)) = Self::record_settings(ctx, scene, settings) else {
            return Ok(None);
        };
        let kind = tables.settings.kind();
        Ok(Some(Self {
            records: RecordCache::with_kind(ctx, kind)?,
            // Its plane pipelines compiled for the scene's features alone.
            pass: RecordPass::for_scene(ctx, &record_settings, kind, scene.features())?,
            splat: RadianceSplatPass::new(ctx, tables)?,
        }))
    }

    /// The settings radiance records of `scene` are computed with (their own accuracy,
    /// plane resolution and a budget of what one binding holds) and the splat's tables;
    /// None when radiance records are off or no material's lobe qualifies.
    pub fn record_settings(
        ctx: &GpuContext,
        scene: &GpuScene,
        settings: &CacheSettings,
    ) -> Option<(CacheSettings, RadianceTables)> {
        let r = settings.radiance;
        if r.order == 0 || !scene.has_glossy {
            return None;
        }
        let mut tables = RadianceTables::new(&scene.glossy_lobes, r);
        if !tables.any_slot() {
            return None;
        }
        // Records carry only the bands some lobe keeps (`--radiance-lobe-share`): where
        // every lobe is broad (Sponza's Phong 1: 4 bands), the order drops and with it the
        // projection, the memory and the splat.
        let order = tables.bands_needed();
        if order < r.order {
            tables = RadianceTables::new(&scene.glossy_lobes, RadianceSettings { order, ..r });
        }
        let r = tables.settings;
        // Past what one binding holds, placement stops (its uncovered pixels take Monte
        // Carlo) rather than the frame failing.
        let record_budget = settings
            .record_budget
            .min(RecordCache::max_records_of(ctx, r.kind()).min(u64::from(u32::MAX)) as u32);
        let record_settings = CacheSettings {
            // Radiance records project their planes, whatever the irradiance records' source.
            source: crate::records::RecordSource::Planes,
            accuracy: r.accuracy,
            record_budget,
            // The radiance gather has no tail tier (`radiance_gather.wgsl`): unmeasured.
            tail_share: 0.0,
            plane_resolution: r
                .plane_resolution_for(settings.plane_resolution, tables.sharpest_exponent()),
            radiance: r,
            ..settings.clone()
        };
        Some((record_settings, tables))
    }
}

impl IrradianceCache {
    pub fn settings(&self) -> &CacheSettings {
        &self.pass.settings
    }

    /// Reads the records back.
    pub fn read(&self, ctx: &GpuContext) -> Result<Vec<Record>> {
        self.records.read(ctx)
    }
}

impl Renderer {
    /// A renderer on `ctx`; its passes are compiled when first used, and a pass's
    /// compilation errors are reported by the call that first needs it. (The Result
    /// stays for callers: nothing fails here today.)
    pub fn new(ctx: GpuContext) -> Result<Self> {
        Ok(Self {
            ctx,
            splat: OnFirstUse::new(),
            placement: OnFirstUse::new(),
            resolve: OnFirstUse::new(),
            light_maps: OnFirstUse::new(),
            vpl: OnFirstUse::new(),
            photon: OnFirstUse::new(),
            photon_reduce: OnFirstUse::new(),
        })
    }

    /// The visibility pass for scenes of `features` (built on the device's first request).
    fn visibility_pass(&self, features: SceneFeatures) -> Result<VisibilityPass> {
        VisibilityPass::for_scene(&self.ctx, features)
    }

    /// The direct-light pass for scenes of `features` (built on the device's first request).
    fn direct_pass(&self, features: SceneFeatures) -> Result<DirectLightPass> {
        DirectLightPass::for_scene(&self.ctx, features)
    }

    fn splat_pass(&self) -> Result<&SplatPass> {
        self.splat.get(|| SplatPass::new(&self.ctx))
    }

    fn placement_pass(&self) -> Result<&PlacementPass> {
        self.placement.get(|| PlacementPass::new(&self.ctx))
    }

    /// The glossy indirect pass for scenes of `features` (built on the device's first
    /// request).
    fn glossy_pass(&self, features: SceneFeatures) -> Result<GlossyIndirectPass> {
        GlossyIndirectPass::for_scene(&self.ctx, features)
    }

    fn light_map_pass(&self) -> Result<&LightMapPass> {
        self.light_maps.get(|| LightMapPass::new(&self.ctx))
    }

    /// The light maps of `scene` for `settings` (every light mapped), as a frame traces
    /// them: for tests and tools that trace planes with them.
    pub fn traced_light_maps(
        &self,
        scene: &PreparedScene,
        settings: &LightMapSettings,
    ) -> Result<std::sync::Arc<LightMaps>> {
        self.scene_light_maps(scene, settings, MappedLights::All, &mut Vec::new())
    }

    /// The light maps of `scene` for `settings` and `mapped`: traced on first use and kept
    /// with the scene, traced again only for other settings.
    fn scene_light_maps(
        &self,
        scene: &PreparedScene,
        settings: &LightMapSettings,
        mapped: MappedLights,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<std::sync::Arc<LightMaps>> {
        let mut slot = scene
            .light_maps
            .lock()
            .map_err(|_| Error::Gpu("internal: light-map cache poisoned".into()))?;
        if let Some((s, m, maps)) = slot.as_ref() {
            if (s, *m) == (settings, mapped) {
                return Ok(maps.clone());
            }
        }
        let maps = std::sync::Arc::new(self.light_map_pass()?.build(
            &self.ctx,
            &scene.gpu,
            &scene.lights,
            scene.bounds,
            settings,
            mapped,
            times,
        )?);
        *slot = Some((*settings, mapped, maps.clone()));
        Ok(maps)
    }

    /// Makes `scene`'s bounce cache the one `settings` ask for (built once per prepared
    /// scene and settings; with one bounce, the empty cache), timed as "bounce cache".
    /// Returns its statistics (None: one bounce).
    pub fn scene_bounce_cache(
        &self,
        scene: &PreparedScene,
        settings: &CacheSettings,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<Option<crate::bounce::BounceStats>> {
        let wanted = settings.bounce;
        let light_samples = settings.plane_light_samples;
        let mut slot = scene
            .bounce
            .lock()
            .map_err(|_| Error::Gpu("internal: bounce cache poisoned".into()))?;
        if let Some((s, l, cache)) = slot.as_ref() {
            if (*s, *l) == (wanted, light_samples) {
                return Ok(Some(cache.stats));
            }
        }
        if wanted.levels() == 0 {
            if slot.take().is_some() {
                scene
                    .gpu
                    .set_bounce_cache(GpuScene::empty_bounce_cache(&self.ctx)?, false);
            }
            return Ok(None);
        }
        let layout =
            crate::bounce::BounceLayout::new(&scene.bounce_geometry, &wanted, scene.gpu.diagonal)?;
        let maps = if wanted.shadow_maps {
            self.scene_light_maps(scene, &settings.light_maps, MappedLights::All, times)?
        } else {
            std::sync::Arc::new(LightMaps::none(&self.ctx)?)
        };
        // Its levels after the first reflect the level before: the cache's lookup is in.
        let features = scene.gpu.features().with_bounce_cache(true);
        let cache = self.bounce_pass(features)?.build(
            &self.ctx,
            &scene.gpu,
            &layout,
            &wanted,
            light_samples,
            &maps,
            times,
        )?;
        let stats = cache.stats;
        *slot = Some((wanted, light_samples, std::sync::Arc::new(cache)));
        Ok(Some(stats))
    }

    /// Traces `scene`'s VPLs for `settings` (their paths, one VPL per bounce) and sets them
    /// as the scene's (once per prepared scene and plan), timed as "vpl trace". None when
    /// the records come from planes.
    pub fn scene_vpls(
        &self,
        scene: &PreparedScene,
        settings: &CacheSettings,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<Option<crate::vpl::VplStats>> {
        if settings.source != crate::records::RecordSource::Vpl {
            return Ok(None);
        }
        let plan = crate::vpl::VplPlan::new(
            &scene.emitter_powers,
            &settings.vpl,
            settings.bounce.bounces,
        );
        let mut slot = scene
            .vpls
            .lock()
            .map_err(|_| Error::Gpu("internal: VPL set poisoned".into()))?;
        if let Some((traced, stats)) = slot.as_ref() {
            if *traced == plan {
                return Ok(Some(*stats));
            }
        }
        let stats = self
            .vpl
            .get(|| crate::vpl::VplPass::new(&self.ctx))?
            .build(&self.ctx, &scene.gpu, &plan, times)?;
        *slot = Some((plan, stats));
        Ok(Some(stats))
    }

    /// Traces `scene`'s photon map for `settings` (once per prepared scene, plan and
    /// gather), timed as "photon trace" and "photon map".
    pub fn scene_photons(
        &self,
        scene: &PreparedScene,
        settings: &CacheSettings,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<std::sync::Arc<crate::photons::ScenePhotons>> {
        let plan = settings
            .photons
            .plan(&scene.emitter_powers, settings.bounce.bounces);
        let gather = settings.photons.gather;
        let mut slot = scene
            .photons
            .lock()
            .map_err(|_| Error::Gpu("internal: photon map poisoned".into()))?;
        if let Some((traced, g, map)) = slot.as_ref() {
            if *traced == plan && *g == gather {
                return Ok(map.clone());
            }
        }
        let map = std::sync::Arc::new(
            self.photon
                .get(|| crate::photons::PhotonPass::new(&self.ctx))?
                .build(
                    &self.ctx,
                    &scene.gpu,
                    &plan,
                    gather,
                    scene.emitter_powers.surface_area,
                    times,
                )?,
        );
        *slot = Some((plan, gather, map.clone()));
        Ok(map)
    }

    /// Places records along `scene`'s photon map for `camera` (thesis Algorithm 6, on the
    /// CPU, timed as "photon placement") and reduces them from their photons on the GPU
    /// (Algorithm 7, "photon records"), appending them to `records`.
    pub fn photon_records(
        &self,
        scene: &PreparedScene,
        camera: &Camera,
        records: &mut RecordCache,
        settings: &CacheSettings,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<PhotonRecordStats> {
        let photons = self.scene_photons(scene, settings, times)?;
        let t0 = Instant::now();
        let placement = crate::records::photon_records::place(
            &photons.map,
            &crate::visibility::GpuCamera::new(camera),
            settings,
            settings.r_min_scene * scene.gpu.diagonal,
        );
        times.push(("photon placement", t0.elapsed().as_secs_f64() * 1e3));
        let count = placement.sites.len() as u32;
        let budget = settings.record_budget.saturating_sub(records.count);
        if count > budget {
            return Err(Error::DeviceLimit(format!(
                "the photon map places {count} records, past the record budget \
                 (--record-budget {}): use a larger --accuracy",
                settings.record_budget
            )));
        }
        records.reserve(&self.ctx, count)?;
        self.photon_reduce
            .get(|| crate::records::photon_records::PhotonReducePass::new(&self.ctx))?
            .reduce(
                &self.ctx,
                &scene.gpu,
                &photons.buffer,
                &placement,
                &records.buffer,
                records.count,
                settings,
                times,
            )?;
        records.count += count;
        Ok(PhotonRecordStats {
            map: photons.stats,
            records: count,
            walked: placement.walked,
            too_sparse: placement.too_sparse,
            gathered: placement.list.len() as u64,
        })
    }

    /// The bounce cache's gather for scenes of `features` (built on the device's first
    /// request).
    fn bounce_pass(&self, features: SceneFeatures) -> Result<crate::bounce::BouncePass> {
        crate::bounce::BouncePass::for_scene(&self.ctx, features)
    }

    fn resolve_pass(&self) -> Result<&ResolvePass> {
        self.resolve.get(|| ResolvePass::new(&self.ctx))
    }

    /// Builds the passes a frame runs (a GI frame with `cache`'s settings, or direct light
    /// only) on as many threads as there are cores, and returns the cache for those
    /// settings. Passes are otherwise built at first use, one after the other: on a GPU
    /// whose driver compiles at creation that was 110-230 ms of a Sponza frame on the H200
    /// machine (lavapipe translates at creation too: 0.4 s of a Cornell box frame here),
    /// and `radsplat render` runs this while the scene loads. More threads than cores
    /// only made the builds contend (Cornell box 128x128: 0.51 s against 0.4 s serial).
    pub fn build_passes(&self, cache: Option<&CacheSettings>) -> Result<Option<IrradianceCache>> {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        self.build_passes_on(cache, cores)
    }

    /// [`Self::build_passes`] on up to `threads` threads (at least one).
    pub fn build_passes_on(
        &self,
        cache: Option<&CacheSettings>,
        threads: usize,
    ) -> Result<Option<IrradianceCache>> {
        self.build_passes_for(cache, threads, &|| SceneFeatures::ALL)
    }

    /// [`Self::build_passes_on`] with the record pass's plane pipelines, the visibility pass
    /// and the direct-light pass compiled for the scene features `features` returns
    /// ([`RecordPass::for_scene`], [`VisibilityPass::for_scene`]); the threads building
    /// them ask for them when they start (`features` must give the same value each time).
    pub fn build_passes_for(
        &self,
        cache: Option<&CacheSettings>,
        threads: usize,
        features: &(dyn Fn() -> SceneFeatures + Sync),
    ) -> Result<Option<IrradianceCache>> {
        let built = self.build_frame_start_passes(cache, threads, features)?;
        if let Some(gi) = &built {
            self.build_ahead(
                &gi.pass.pipeline_recipes(),
                &gi.pass.settings,
                features(),
                threads,
                BuildPriority::Now,
            )?;
        }
        Ok(built)
    }

    /// The passes a frame runs first, built on up to `threads` threads: the visibility
    /// pass, and with `cache` the splat pass (its tile bounds; its later pipelines build at
    /// first use) and placement's selection, with the cache for `cache`'s settings, whose
    /// record pass's pipelines are not built yet; without it the direct light too.
    /// [`Self::build_passes_for`] builds the rest next ([`Self::build_ahead`]);
    /// `radsplat render` builds it on other threads while its frame begins, so that the
    /// frame starts sooner and the builds take the cores lavapipe leaves idle (its
    /// compilations at a pipeline's first dispatch, one at a time).
    pub fn build_frame_start_passes(
        &self,
        cache: Option<&CacheSettings>,
        threads: usize,
        features: &(dyn Fn() -> SceneFeatures + Sync),
    ) -> Result<Option<IrradianceCache>> {
        let built_cache = std::sync::Mutex::new(None);
        // The pass the frame runs first (it waits for the scene's features).
        let mut builds: Vec<Build> =
            vec![Box::new(|| self.visibility_pass(features()).map(|_| ()))];
        if cache.is_none() {
            // A direct-light frame runs only it and the direct light.
            builds.push(Box::new(|| self.direct_pass(features()).map(|_| ())));
        }
        if let Some(settings) = cache {
            let built = &built_cache;
            builds.extend([
                Box::new(|| self.splat_pass().map(|_| ())) as Build,
                Box::new(|| self.placement_pass().map(|_| ())),
                // The cache's record pass, its pipelines not built (`pipeline_recipes`).
                Box::new(move || {
                    let cache = self.new_cache_for(settings, features())?;
                    *built.lock().unwrap_or_else(|p| p.into_inner()) = Some(cache);
                    Ok(())
                }),
            ]);
        }
        run_builds(&builds, threads, BuildPriority::Now)?;
        drop(builds);
        Ok(built_cache.into_inner().unwrap_or_else(|p| p.into_inner()))
    }

    /// Builds, on up to `threads` threads, what a frame with `settings` over a scene with
    /// `features` asks for after its visibility pass, in the order it asks: the direct
    /// light and the light maps, `recipes` (the record pass's pipelines,
    /// [`RecordPass::pipeline_recipes`]: the longest builds), placement's covers
    /// ([`SplatPass::build_covers`]), then the splat's binning and gathers
    /// ([`SplatPass::build_late`]) and the resolve. A frame builds whatever it reaches
    /// first itself (a pass being built is waited for: each is built once per device).
    /// Beside a running frame, build at [`BuildPriority::IdleCores`].
    pub fn build_ahead(
        &self,
        recipes: &[crate::gpu::pipeline::PassRecipe],
        settings: &CacheSettings,
        features: SceneFeatures,
        threads: usize,
        priority: BuildPriority,
    ) -> Result<()> {
        let mut builds: Vec<Build> = vec![
            Box::new(move || self.direct_pass(features).map(|_| ())),
            Box::new(move || {
                self.light_map_pass()?
                    .trace(&self.ctx, features)
                    .map(|_| ())
            }),
        ];
        builds.extend(
            recipes
                .iter()
                .map(|r| Box::new(move || r.build(&self.ctx).map(|_| ())) as Build),
        );
        builds.extend([
            Box::new(|| self.splat_pass()?.build_covers(&self.ctx, settings.corral)) as Build,
            Box::new(|| {
                self.splat_pass()?.build_late(
                    &self.ctx,
                    settings.corral,
                    settings.noise_widening > 0.0,
                )?;
                self.resolve_pass().map(|_| ())
            }),
        ]);
        run_builds(&builds, threads, priority)
    }

    /// An empty irradiance cache with `settings` as a still frame uses them
    /// ([`CacheSettings::resolved`]).
    pub fn new_cache(&self, settings: &CacheSettings) -> Result<IrradianceCache> {
        self.new_cache_for(settings, SceneFeatures::ALL)
    }

    /// [`Self::new_cache`] with its plane pipelines compiled for the scene features
    /// `features` alone ([`RecordPass::for_scene`]; `SceneFeatures::of` a scene): less code
    /// for the shader compiler and the plane rays (the same bytes; figures in
    /// `gpu::scene_features`). A scene with another feature is refused by its frames.
    pub fn new_cache_for(
        &self,
        settings: &CacheSettings,
        features: SceneFeatures,
    ) -> Result<IrradianceCache> {
        Ok(IrradianceCache {
            records: RecordCache::new(&self.ctx)?,
            pass: RecordPass::for_scene(
                &self.ctx,
                &settings.resolved(false),
                crate::records::RecordKind::Irradiance,
                features,
            )?,
            radiance: None,
        })
    }

    /// The visibility buffer of `camera` (left on the GPU), its GPU time added to `times`.
    pub fn visibility(
        &self,
        scene: &PreparedScene,
        camera: &Camera,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<VisibilityBuffer> {
        Ok(self
            .visibility_and_direct(scene, camera, None, false, times)?
            .0)
    }

    /// The visibility buffer of `camera` and its per-tile bounds: what the splat helpers
    /// for tests start from.
    fn visible_tiles(
        &self,
        scene: &PreparedScene,
        camera: &Camera,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<(VisibilityBuffer, TileBounds)> {
        let vis = self.visibility(scene, camera, times)?;
        let bounds = self
            .splat_pass()?
            .tile_bounds(&self.ctx, &scene.gpu, &vis, times)?;
        Ok((vis, bounds))
    }

    /// Splats `src` into `out` and, with `tail`, tail fill: the pixels no record reaches
    /// then take every record that reaches them at the tail's accuracy (placement made one
    /// reach each of them). Only the tail's records are sure to, but the others make a
    /// smoother mean (Cornell box 128x128: 1.46 % indirect error with the tail's alone,
    /// 1.41 % with all, for 0.5 s more binning on Sponza 1000x1000). Where the gather
    /// leaves the pixels only dark records reach empty (`SplatSource::dark_only_empty`), a
    /// last tier then gives those the tail left empty every record that reaches them at
    /// Ward's widest accuracy (`CacheSettings::last_tier_accuracy`).
    fn gather_with_tail(
        &self,
        settings: &CacheSettings,
        src: SplatSource,
        tail: bool,
        out: &SplatBuffer,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<()> {
        let splat_pass = self.splat_pass()?;
        splat_pass.splat(&self.ctx, src, out, false, times)?;
        if !tail {
            return Ok(());
        }
        // Tail fill, then the last tier for the pixels only dark records reach. A tier
        // changes a pixel only where it reaches further than the gathers before it (the
        // fills weigh no corral, so a gather that weighed them reached nowhere for sure):
        // a frame widened for noisy records (the nave: 4 a = 1) skips both. Once a tier
        // finds no empty pixel, none is left for the next.
        let mut reached = if src.corral { 0.0 } else { src.accuracy };
        let tiers = [
            Some(settings.tail_accuracy()),
            settings
                .last_tier_accuracy()
                .filter(|_| src.dark_only_empty),
        ];
        for accuracy in tiers.into_iter().flatten() {
            if accuracy <= reached {
                continue;
            }
            let fill = SplatSource { accuracy, ..src };
            if splat_pass.fill_empty(&self.ctx, fill, out, times)? == 0 {
                break;
            }
            reached = accuracy;
        }
        Ok(())
    }

    /// A frame gathered at `factor` wider than the settings' `interpolation_factor` keeps
    /// the wider gather in `widened` (from `src`'s records, as [`Self::gather_with_tail`]
    /// made it) only where it agrees with the gather at the settings' factor
    /// (`CacheSettings::widening_tolerance`, `wgsl/splat_consistency.wgsl`): a peak of light
    /// narrower than the records' spacing is not spread over its neighbours. Returns the
    /// pixels that kept the widened sums and the default gather checked against; None where
    /// nothing was widened or the tolerance is infinite (no check).
    fn check_widened(
        &self,
        settings: &CacheSettings,
        src: SplatSource,
        factor: f32,
        tail: bool,
        widened: &SplatBuffer,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<Option<(u32, SplatBuffer)>> {
        let base = settings.interpolation_factor;
        let tolerance = settings.widening_tolerance * settings.accuracy;
        if factor <= base || !tolerance.is_finite() {
            return Ok(None);
        }
        let default_gather = SplatSource {
            accuracy: settings.accuracy * base,
            plateau: 0.0,
            ..src
        };
        let narrow = SplatBuffer::new(&self.ctx, widened.width, widened.height)?;
        self.gather_with_tail(settings, default_gather, tail, &narrow, times)?;
        let kept = self
            .splat_pass()?
            .consistency(&self.ctx)?
            .keep_consistent(&self.ctx, src.scene, &narrow, widened, tolerance, times)?;
        Ok(Some((kept, narrow)))
    }

    /// The visibility buffer of `camera` and the splat sums `(sum w E', sum w)` of every
    /// record in `cache` (no placement, no resolve): for tests and tools. With `tail`, the
    /// pixels no record reaches then take the records that reach them at the cache's tail
    /// accuracy, as a frame's gather after tail fill.
    pub fn splat_cache(
        &self,
        scene: &PreparedScene,
        camera: &Camera,
        cache: &IrradianceCache,
        tail: bool,
    ) -> Result<(Vec<VisSample>, Vec<[f32; 4]>)> {
        let ctx = &self.ctx;
        let mut times = Vec::new();
        let (vis, bounds) = self.visible_tiles(scene, camera, &mut times)?;
        let splat = SplatBuffer::new(ctx, camera.width, camera.height)?;
        let (factor, _) = self.frame_interpolation_factor(cache.settings(), &cache.records)?;
        let src = frame_gather_source(
            scene,
            &vis,
            &bounds,
            &cache.records,
            cache.settings(),
            factor,
            true,
        );
        self.gather_with_tail(cache.settings(), src, tail, &splat, &mut times)?;
        let sums = ctx.read_buffer(&splat.sums)?;
        let visibility = vis.read(ctx)?;
        ctx.check()?;
        Ok((visibility, sums))
    }

    /// The gathers of every record of `cache` (no placement, no tail fill) that a widened
    /// still frame compares (`CacheSettings::widening_tolerance`): at the settings'
    /// `interpolation_factor` and at the frame's widened factor, and the widened one after
    /// the check on the GPU (`wgsl/splat_consistency.wgsl`), with how many pixels kept
    /// it: for tests.
    pub fn splat_cache_checked(
        &self,
        scene: &PreparedScene,
        camera: &Camera,
        cache: &IrradianceCache,
    ) -> Result<CheckedSplat> {
        let ctx = &self.ctx;
        let mut times = Vec::new();
        let (vis, bounds) = self.visible_tiles(scene, camera, &mut times)?;
        let settings = cache.settings();
        let (factor, _) = self.frame_interpolation_factor(settings, &cache.records)?;
        let wide = SplatBuffer::new(ctx, camera.width, camera.height)?;
        let src = frame_gather_source(scene, &vis, &bounds, &cache.records, settings, factor, true);
        self.gather_with_tail(settings, src, false, &wide, &mut times)?;
        let wide_sums = ctx.read_buffer(&wide.sums)?;
        let (kept, narrow) = self
            .check_widened(settings, src, factor, false, &wide, &mut times)?
            .ok_or_else(|| Error::Usage("the cache's frame does not widen".into()))?;
        let narrow_sums = ctx.read_buffer(&narrow.sums)?;
        let checked = ctx.read_buffer(&wide.sums)?;
        let vis = vis.read(ctx)?;
        ctx.check()?;
        Ok(CheckedSplat {
            vis,
            factor,
            narrow: narrow_sums,
            wide: wide_sums,
            checked,
            kept,
        })
    }

    /// The visibility buffer of `camera` and the radiance splat sums
    /// `(specular * sum w L, sum w)` of every record of `cache` (no placement): for tests.
    pub fn splat_radiance_cache(
        &self,
        scene: &PreparedScene,
        camera: &Camera,
        cache: &RadianceCache,
    ) -> Result<(Vec<VisSample>, Vec<[f32; 4]>)> {
        let ctx = &self.ctx;
        let mut times = Vec::new();
        let (vis, bounds) = self.visible_tiles(scene, camera, &mut times)?;
        let splat_pass = self.splat_pass()?;
        let src = SplatSource::new(
            &scene.gpu,
            &vis,
            &bounds,
            &cache.records,
            0,
            cache.pass.settings.accuracy,
            cache.pass.settings.corral.in_gathers(),
        );
        let sums = cache.splat.gather(ctx, splat_pass, src, &mut times)?;
        let sums = ctx.read_buffer(&sums)?;
        let visibility = vis.read(ctx)?;
        ctx.check()?;
        Ok((visibility, sums))
    }

    /// As [`Renderer::splat_cache`], with the records added in rounds as placement adds
    /// them: ranges split at `splits` (increasing record counts), each splatted onto the
    /// previous sums (accumulating) and marked in a coverage mask (the cover placement
    /// runs). Returns the visibility, the sums and the mask: for tests that the rounds give
    /// the bytes of one full splat and the mask its support.
    pub fn splat_cache_in_rounds(
        &self,
        scene: &PreparedScene,
        camera: &Camera,
        cache: &IrradianceCache,
        splits: &[u32],
    ) -> Result<SplatRounds> {
        let ctx = &self.ctx;
        let mut times = Vec::new();
        let (vis, bounds) = self.visible_tiles(scene, camera, &mut times)?;
        let splat = SplatBuffer::new(ctx, camera.width, camera.height)?;
        let mask = CoverageMask::new(ctx, camera.width, camera.height)?;
        let splat_pass = self.splat_pass()?;
        let accuracy = cache.settings().accuracy;
        let mut first = 0;
        for &end in splits.iter().chain([&cache.records.count]) {
            let partial = cache.records.prefix(end);
            let src = SplatSource::new(
                &scene.gpu,
                &vis,
                &bounds,
                &partial,
                first,
                accuracy,
                cache.settings().corral.in_gathers(),
            );
            splat_pass.splat(ctx, src, &splat, true, &mut times)?;
            // Placement's cover: the corrals with `Corral::Cover` and `Corral::Placement`.
            let cover = SplatSource {
                corral: cache.settings().corral.in_cover(),
                ..src
            };
            splat_pass.cover(ctx, cover, &mask, &mut times)?;
            first = partial.count;
        }
        let sums = ctx.read_buffer(&splat.sums)?;
        let covered = mask.read(ctx)?;
        let visibility = vis.read(ctx)?;
        ctx.check()?;
        Ok((visibility, sums, covered))
    }

    /// `cache`'s records covered in rounds (records `..splits[0]`, then up to each later
    /// split, then the rest) as placement covers them, in `mode`: each round's cover
    /// submitted without a wait and with room for `room` list entries
    /// ([`SplatPass::cover_in_flight_as`]), and covered again, waiting, with room for its
    /// lists where they did not fit. For tests.
    #[allow(clippy::too_many_arguments)]
    pub fn cover_in_rounds(
        &self,
        scene: &PreparedScene,
        camera: &Camera,
        cache: &IrradianceCache,
        splits: &[u32],
        room: u32,
        mode: crate::splat::cover::CoverMode,
    ) -> Result<CoverRounds> {
        let ctx = &self.ctx;
        let mut times = Vec::new();
        let (vis, bounds) = self.visible_tiles(scene, camera, &mut times)?;
        let mask = CoverageMask::new(ctx, camera.width, camera.height)?;
        let splat_pass = self.splat_pass()?;
        let mut first = 0;
        let mut rounds = CoverRounds::default();
        for &end in splits.iter().chain([&cache.records.count]) {
            let partial = cache.records.prefix(end);
            let src = SplatSource::new(
                &scene.gpu,
                &vis,
                &bounds,
                &partial,
                first,
                cache.settings().accuracy,
                cache.settings().corral.in_cover(),
            );
            let before = mask.read(ctx)?;
            if let Some(cover) =
                splat_pass.cover_in_flight_as(ctx, src, &mask, room, mode, &mut times)?
            {
                let total: Vec<u32> = ctx.read_buffer(&cover.total)?;
                let total = total.first().copied().unwrap_or(0);
                if !cover.fitted(total) {
                    let after = mask.read(ctx)?;
                    rounds.stray += before.iter().zip(&after).filter(|(b, a)| b != a).count();
                    splat_pass.cover_in_flight_as(ctx, src, &mask, total, mode, &mut times)?;
                    rounds.repeats += 1;
                }
            }
            rounds.masks.push(mask.read(ctx)?);
            rounds.marked.push(mask.marked(ctx)?);
            first = partial.count;
        }
        ctx.check()?;
        Ok(rounds)
    }

    /// The light maps of `scene` with `settings` ([`crate::light_maps`]): their layout
    /// and depths read back, for tests and tools.
    pub fn light_maps(
        &self,
        scene: &PreparedScene,
        settings: &crate::light_maps::LightMapSettings,
    ) -> Result<(Vec<crate::light_maps::GpuLightMap>, Vec<f32>)> {
        let maps = self.light_map_pass()?.build(
            &self.ctx,
            &scene.gpu,
            &scene.lights,
            scene.bounds,
            settings,
            crate::light_maps::MappedLights::All,
            &mut Vec::new(),
        )?;
        let mut depths: Vec<f32> = self.ctx.read_buffer(&maps.depths)?;
        depths.truncate(maps.texels() as usize);
        self.ctx.check()?;
        Ok((maps.layout, depths))
    }

    /// Renders one global-illumination frame from `camera` over `cache`: visibility and
    /// direct light, the cache's records splatted, new records placed where no record
    /// covers a visible pixel (at most `max_new_records` when given), then the resolve.
    /// `progress` gets the number of records added so far.
    pub fn render_gi_frame(
        &self,
        scene: &PreparedScene,
        camera: &Camera,
        cache: &mut IrradianceCache,
        max_new_records: Option<u32>,
        progress: impl FnMut(u32),
    ) -> Result<Frame> {
        if cache.radiance.is_none() {
            cache.radiance = RadianceCache::new(&self.ctx, &scene.gpu, &cache.pass.settings)?;
        }
        let (frame, _) = self.render_cached_frame(
            scene,
            camera,
            &mut cache.records,
            &cache.pass,
            CachedFrameOptions {
                max_new_records,
                radiance: cache.radiance.as_mut().map(RadianceCache::frame),
                ..Default::default()
            },
            progress,
        )?;
        Ok(frame)
    }

    /// The frame of [`Renderer::render_gi_frame`] over `records` (computed by `pass`),
    /// with the temporal options: new records also seen by a record stage (`stage`:
    /// temporal caching estimates them at t+1), and
    /// per-record coverage counted (returned, one count per record of `records`; empty
    /// when not counted). The passes' GPU times are read once, after the frame
    /// ([`GpuContext::deferring_pass_times`]), not in a wait after each pass. With
    /// placement's covers in flight ([`crate::splat::SplatPass::cover_in_flight`]) a still
    /// frame of nave-west 160x160 waits for the GPU 42 times, where it waited 87 times
    /// (docs/results.md, "One wait a placement round").
    pub fn render_cached_frame(
        &self,
        scene: &PreparedScene,
        camera: &Camera,
        records: &mut RecordCache,
        pass: &RecordPass,
        options: CachedFrameOptions<'_, '_>,
        progress: impl FnMut(u32),
    ) -> Result<(Frame, Vec<u32>)> {
        let ((mut frame, coverage), deferred) = self.ctx.deferring_pass_times(|| {
            self.render_cached_frame_timed(scene, camera, records, pass, options, progress)
        })?;
        if !deferred.is_empty() {
            let mut all: Vec<(String, f64)> = std::mem::take(&mut frame.stats.pass_ms);
            all.extend(deferred.iter().map(|(n, ms)| (n.to_string(), *ms)));
            frame.stats.pass_ms = sum_by_pass_owned(&all);
        }
        // The wait that read the timers.
        frame.stats.gpu_waits += self.ctx.take_waits();
        Ok((frame, coverage))
    }

    /// [`Self::render_cached_frame`], its pass timers read by the caller. The frame's data
    /// flow, stage by stage: where records' light comes from beyond their planes, the
    /// visibility buffer and direct light, the irradiance records (the held ones' cover,
    /// placement of new ones, one gather), the radiance records, then the glossy pass and
    /// the resolve.
    fn render_cached_frame_timed(
        &self,
        scene: &PreparedScene,
        camera: &Camera,
        records: &mut RecordCache,
        pass: &RecordPass,
        options: CachedFrameOptions<'_, '_>,
        progress: impl FnMut(u32),
    ) -> Result<(Frame, Vec<u32>)> {
        let CachedFrameOptions {
            max_new_records,
            stage,
            count_coverage,
            placement_only,
            visibility,
            radiance,
        } = options;
        let ctx = &self.ctx;
        let settings = &pass.settings;
        // Shadow rays of each plane hit (its re-shading and plane refresh cast the same).
        let (sampled, delta) = scene.shadow_rays;
        ctx.check_shadow_rays(
            sampled * u64::from(settings.plane_light_samples) + delta,
            "--plane-light-samples",
        )?;
        let t0 = Instant::now();
        ctx.take_waits();
        let mut times: Vec<(&'static str, f64)> = Vec::new();

        let sources = self.record_sources(scene, camera, records, settings, &mut times)?;

        // Visibility buffer and direct light (placement needs only the visibility).
        let (vis, direct) =
            self.visibility_and_direct(scene, camera, visibility, !placement_only, &mut times)?;

        // Irradiance records: mark the pixels the records the cache already holds cover,
        // place new records where none does, then splat every record once (the weighted
        // gather).
        let reused_records = records.count;
        // Temporal caching keeps one interpolation factor for every frame.
        let temporal = stage.is_some();
        let bounds = self
            .splat_pass()?
            .tile_bounds(ctx, &scene.gpu, &vis, &mut times)?;
        let light_maps = self.plane_light_maps(scene, settings, &mut times)?;
        let mask = CoverageMask::new(ctx, camera.width, camera.height)?;
        let placement = self.place_records(
            scene,
            &vis,
            &bounds,
            &mask,
            records,
            pass,
            light_maps.as_deref(),
            max_new_records,
            stage,
            &mut times,
            progress,
        )?;
        let coverage_records = if count_coverage {
            settings.record_budget.max(records.count)
        } else {
            0
        };
        let splat = SplatBuffer::with_coverage(ctx, camera.width, camera.height, coverage_records)?;
        let (interpolation_factor, median_record_noise) = if temporal {
            (settings.interpolation_factor, None)
        } else {
            self.frame_interpolation_factor(settings, records)?
        };
        let widened_pixels = if !placement_only || count_coverage {
            let all = frame_gather_source(
                scene,
                &vis,
                &bounds,
                records,
                settings,
                interpolation_factor,
                !temporal,
            );
            self.gather_records(
                settings,
                all,
                &placement,
                interpolation_factor,
                &splat,
                &mut times,
            )?
        } else {
            0
        };

        // Radiance records: their own placement over the pixels with lobes they shade, at
        // their own accuracy, then their gather.
        let radiance = match radiance {
            Some(rf) => self.radiance_records(
                scene,
                &vis,
                &bounds,
                rf,
                light_maps.as_deref(),
                placement_only,
                &mut times,
            )?,
            None => RadianceOutcome::default(),
        };

        // A VPL record traces one ray per VPL slot; placement counts plane records' rays
        // (tail fill's planes are coarser).
        let record_rays = match &sources.vpls {
            Some(v) => u64::from(placement.new_records) * u64::from(v.slots),
            None => placement.plane_rays,
        };
        // Planes that saw no light were refined everywhere (their rays beyond the count
        // above), and lit planes may have refined fewer than K pixels.
        let refinement_rays = RecordPass::take_refinement_rays(
            ctx,
            &std::iter::once(pass)
                .chain(radiance.pass)
                .collect::<Vec<_>>(),
        )?;
        let (width, height) = (camera.width, camera.height);
        let stats = |times: &[(&'static str, f64)], uncovered_pixels| FrameStats {
            width,
            height,
            pass_ms: sum_by_pass(times),
            shader_compile_ms: sum_by_pass(&ctx.take_compile_times()),
            wall_ms: t0.elapsed().as_secs_f64() * 1e3,
            gpu_waits: ctx.take_waits(),
            camera_rays: u64::from(width) * u64::from(height),
            cache: Some(CacheFrameStats {
                records: records.count,
                reused_records,
                plane_rays: (record_rays
                    + radiance.pass.map_or(0, |p| {
                        u64::from(radiance.new_records) * p.settings.plane_rays_per_record()
                    })
                    + refinement_rays.dark)
                    .saturating_sub(refinement_rays.unused),
                dark_plane_rays: refinement_rays.dark,
                placement,
                uncovered_pixels,
                interpolation_factor,
                median_record_noise: median_record_noise.unwrap_or(0.0),
                widened_pixels,
                radiance_records: radiance.records,
                new_radiance_records: radiance.new_records,
                radiance_order: radiance.order,
                bounce: sources.bounce,
                vpls: sources.vpls,
                photons: sources.photons,
            }),
        };
        let mut coverage = if count_coverage {
            splat.read_coverage(ctx)?
        } else {
            Vec::new()
        };
        coverage.truncate(records.count as usize);
        let Some(direct) = direct else {
            ctx.check()?;
            let frame = Frame {
                width,
                height,
                beauty: Vec::new(),
                albedo: Vec::new(),
                direct: Vec::new(),
                indirect: None,
                visibility: Vec::new(),
                stats: stats(&times, 0),
            };
            return Ok((frame, coverage));
        };

        let images = self.resolve_images(
            scene,
            &vis,
            &splat,
            &direct,
            settings.glossy_samples,
            &radiance,
            &mut times,
        )?;
        let frame = Frame {
            width,
            height,
            beauty: images.beauty,
            albedo: images.albedo,
            direct: images.direct,
            indirect: Some(images.indirect),
            visibility: images.visibility,
            stats: stats(&times, images.uncovered_pixels),
        };
        Ok((frame, coverage))
    }

    /// Where a frame's records take light from beyond their own planes: the surface bounce
    /// cache their plane hits reflect (bounces past the first; once per prepared scene),
    /// the VPLs of `--records vpl`, and the records placed from the photon map
    /// (`--records photons`, into an empty cache: thesis Algorithm 6, before any pixel
    /// asks; the pixels they leave uncovered get plane records from placement).
    fn record_sources(
        &self,
        scene: &PreparedScene,
        camera: &Camera,
        records: &mut RecordCache,
        settings: &CacheSettings,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<RecordSources> {
        // VPL records carry their bounces in the VPL paths; glossy lobe rays still reflect
        // the cache.
        let planes = settings.source != crate::records::RecordSource::Vpl;
        let bounce = if planes || scene.gpu.has_glossy {
            self.scene_bounce_cache(scene, settings, times)?
        } else {
            None
        };
        let vpls = self.scene_vpls(scene, settings, times)?;
        let photons =
            if settings.source == crate::records::RecordSource::Photons && records.count == 0 {
                Some(self.photon_records(scene, camera, records, settings, times)?)
            } else {
                None
            };
        Ok(RecordSources {
            bounce,
            vpls,
            photons,
        })
    }

    /// Light-space visibility for the plane hits of new records
    /// (`CacheSettings::plane_shadows`), traced once per scene; None where plane hits
    /// trace shadow rays.
    fn plane_light_maps(
        &self,
        scene: &PreparedScene,
        settings: &CacheSettings,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<Option<std::sync::Arc<LightMaps>>> {
        let mapped = match settings.plane_shadows {
            PlaneShadows::Maps => MappedLights::All,
            PlaneShadows::Auto => MappedLights::DeltaOnly,
            PlaneShadows::Rays => return Ok(None),
        };
        Ok(Some(self.scene_light_maps(
            scene,
            &settings.light_maps,
            mapped,
            times,
        )?))
    }

    /// Marks in `mask` the pixels the records `cache` already holds reach (at the
    /// placement accuracy), then places new records computed by `pass` where no record
    /// reaches a pixel `mask` leaves unmarked (thesis Algorithm 4, on the GPU). Irradiance
    /// records start from an empty mask; radiance records from one that marks the pixels
    /// without a lobe they shade.
    #[allow(clippy::too_many_arguments)]
    fn place_records(
        &self,
        scene: &PreparedScene,
        vis: &VisibilityBuffer,
        bounds: &TileBounds,
        mask: &CoverageMask,
        cache: &mut RecordCache,
        pass: &RecordPass,
        light_maps: Option<&LightMaps>,
        max_new_records: Option<u32>,
        stage: Option<&mut (dyn crate::records::RecordStage + '_)>,
        times: &mut Vec<(&'static str, f64)>,
        progress: impl FnMut(u32),
    ) -> Result<PlacementStats> {
        let ctx = &self.ctx;
        let splat_pass = self.splat_pass()?;
        let settings = &pass.settings;
        let held = SplatSource::new(
            &scene.gpu,
            vis,
            bounds,
            cache,
            0,
            settings.accuracy,
            settings.corral.in_cover(),
        );
        splat_pass.cover(ctx, held, mask, times)?;
        self.placement_pass()?.place(
            ctx,
            &scene.gpu,
            vis,
            cache,
            pass,
            splat_pass,
            bounds,
            mask,
            light_maps,
            max_new_records,
            stage,
            times,
            progress,
        )
    }

    /// Gathers every record of `all` into `splat`, those placement added included, at the
    /// frame's interpolation factor (`CacheSettings::interpolation_factor`, widened for
    /// noisy records): placement left every pixel within a of some record, so each is
    /// still reached, by more records. Tail fill also gives the pixels only dark records
    /// reach the lit records that reach them at the tail's accuracy. Returns the pixels
    /// that kept a widened gather ([`Self::check_widened`]).
    fn gather_records(
        &self,
        settings: &CacheSettings,
        all: SplatSource,
        placement: &PlacementStats,
        interpolation_factor: f32,
        splat: &SplatBuffer,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<u64> {
        let tail = placement.tail_from_record.is_some() || all.dark_only_empty;
        self.gather_with_tail(settings, all, tail, splat, times)?;
        Ok(self
            .check_widened(settings, all, interpolation_factor, tail, splat, times)?
            .map_or(0, |(kept, _)| u64::from(kept)))
    }

    /// The radiance records of a frame (`rf`): their cover of the pixels whose lobes they
    /// shade, their placement at their own accuracy (in the placement-only pass too: the
    /// first pass of interpolated temporal gradients computes every frame's records), then
    /// their gather, its passes timed under their own names.
    #[allow(clippy::too_many_arguments)]
    fn radiance_records<'p>(
        &self,
        scene: &PreparedScene,
        vis: &VisibilityBuffer,
        bounds: &TileBounds,
        rf: RadianceFrame<'p, '_>,
        light_maps: Option<&LightMaps>,
        placement_only: bool,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<RadianceOutcome<'p>> {
        let ctx = &self.ctx;
        let splat_pass = self.splat_pass()?;
        let first_time = times.len();
        let need = CoverageMask::new(ctx, vis.width, vis.height)?;
        rf.splat.need_mask(ctx, &scene.gpu, vis, &need);
        let placed = self.place_records(
            scene,
            vis,
            bounds,
            &need,
            rf.records,
            rf.pass,
            light_maps,
            rf.max_new_records,
            rf.stage,
            times,
            |_| {},
        )?;
        let settings = &rf.pass.settings;
        // Placement covered every pixel with a radiance lobe: if every glossy lobe has
        // one, no pixel needs Monte Carlo lobe rays.
        let covers_all = !placed.limit_reached && rf.splat.tables.every_lobe_has_slot();
        let sums = if placement_only {
            None
        } else {
            let all = SplatSource::new(
                &scene.gpu,
                vis,
                bounds,
                rf.records,
                0,
                settings.accuracy,
                settings.corral.in_gathers(),
            );
            Some(rf.splat.gather(ctx, splat_pass, all, times)?)
        };
        for (name, _) in &mut times[first_time..] {
            *name = radiance_pass_name(name);
        }
        Ok(RadianceOutcome {
            pass: Some(rf.pass),
            records: rf.records.count,
            new_records: placed.new_records,
            order: rf.splat.tables.settings.order,
            covers_all,
            sums,
        })
    }

    /// Glossy lobes' indirect light (Monte Carlo through the lobe, where radiance records
    /// do not cover every glossy pixel), then the resolve: direct + albedo / pi *
    /// interpolated irradiance + glossy; the frame's images read back.
    #[allow(clippy::too_many_arguments)]
    fn resolve_images(
        &self,
        scene: &PreparedScene,
        vis: &VisibilityBuffer,
        splat: &SplatBuffer,
        direct: &DirectOutput,
        glossy_samples: u32,
        radiance: &RadianceOutcome<'_>,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<ResolvedImages> {
        let ctx = &self.ctx;
        let mut timer = PassTimer::new(ctx, 2);
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        // Radiance records covering every glossy pixel need no lobe rays: the resolve takes
        // their mean itself (the glossy pass would only copy it).
        let radiance_only = radiance.covers_all && radiance.sums.is_some();
        let glossy = if scene.gpu.has_glossy && !radiance_only {
            Some(self.glossy_pass(scene.gpu.features())?.record(
                ctx,
                &mut encoder,
                &scene.gpu,
                vis,
                glossy_samples,
                radiance.sums.as_ref(),
                radiance.covers_all,
                timer.next("glossy indirect"),
            )?)
        } else {
            None
        };
        let glossy_input = match (&glossy, &radiance.sums) {
            (Some(g), _) => GlossyInput::Indirect(g),
            (None, Some(sums)) if scene.gpu.has_glossy => GlossyInput::RadianceSums(sums),
            _ => GlossyInput::None,
        };
        let indirect = self.resolve_pass()?.record(
            ctx,
            &mut encoder,
            &scene.gpu,
            splat,
            &direct.albedo,
            &direct.beauty,
            glossy_input,
            timer.next("resolve"),
        )?;
        timer.resolve(&mut encoder);
        ctx.queue.submit([encoder.finish()]);
        times.extend(timer.read(ctx)?);

        let mut images = ctx
            .read_buffers::<[f32; 4]>(&[
                &direct.beauty,
                &direct.albedo,
                &direct.direct,
                &indirect,
                &splat.sums,
            ])?
            .into_iter();
        let mut next = || {
            images
                .next()
                .ok_or_else(|| Error::Gpu("internal: image readback incomplete".into()))
        };
        let (beauty, albedo, direct_img, indirect_img, sums) =
            (next()?, next()?, next()?, next()?, next()?);
        let visibility = vis.read(ctx)?;
        let uncovered_pixels = visibility
            .iter()
            .zip(&sums)
            .filter(|(v, s)| v.is_hit() && s[3] <= 0.0)
            .count() as u64;
        ctx.check()?;
        Ok(ResolvedImages {
            beauty,
            albedo,
            direct: direct_img,
            indirect: indirect_img,
            visibility,
            uncovered_pixels,
        })
    }

    /// The interpolation factor of a frame over `records`
    /// ([`crate::records::noise_widening::frame_interpolation_factor`]) and their median
    /// relative noise: the records are read back only where the settings widen for it.
    fn frame_interpolation_factor(
        &self,
        settings: &CacheSettings,
        records: &RecordCache,
    ) -> Result<(f32, Option<f32>)> {
        use crate::records::noise_widening;
        if settings.noise_widening <= 0.0 || records.count == 0 {
            return Ok((settings.interpolation_factor, None));
        }
        let median = noise_widening::median_noise(&records.read(&self.ctx)?);
        Ok((
            noise_widening::frame_interpolation_factor(settings, median),
            median,
        ))
    }

    /// Per record of `records`, the pixels of `vis` it contributes to; with `expiring`
    /// (one flag per record, true where it expires), only those no unflagged record
    /// contributes to, and 0 for unflagged records (see
    /// [`SplatBuffer::with_needed_coverage`]).
    pub fn record_coverage(
        &self,
        scene: &PreparedScene,
        vis: &VisibilityBuffer,
        records: &RecordCache,
        expiring: Option<&[bool]>,
        accuracy: f32,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<Vec<u32>> {
        let ctx = &self.ctx;
        let out = match expiring {
            Some(flags) => SplatBuffer::with_needed_coverage(ctx, vis.width, vis.height, flags)?,
            None => SplatBuffer::with_coverage(ctx, vis.width, vis.height, records.count)?,
        };
        let splat_pass = self.splat_pass()?;
        let bounds = splat_pass.tile_bounds(ctx, &scene.gpu, vis, times)?;
        // Temporal records, the ones counted, carry no corral.
        let src = SplatSource::new(&scene.gpu, vis, &bounds, records, 0, accuracy, false);
        splat_pass.splat(ctx, src, &out, false, times)?;
        out.read_coverage(ctx)
    }

    /// Builds the BVH and uploads the scene.
    pub fn prepare(&self, scene: &Scene) -> Result<PreparedScene> {
        let mut bvh = None;
        self.prepare_frame(scene, &mut bvh, None)
    }

    /// Prepares a frame of an animation: the first call (with `bvh` None) builds every
    /// mesh's BVH; later calls rebuild only the top level for the new instance transforms
    /// (the meshes must be those of the first call, as after [`Scene::set_frame`]) and,
    /// given a `previous` frame prepared with the same `bvh`, share its mesh and texture
    /// buffers instead of uploading them again.
    pub fn prepare_frame(
        &self,
        scene: &Scene,
        bvh: &mut Option<SceneBvh>,
        previous: Option<&PreparedScene>,
    ) -> Result<PreparedScene> {
        let t0 = Instant::now();
        match bvh.as_mut() {
            Some(b) => b.update_instances(scene),
            None => *bvh = Some(SceneBvh::build(scene)),
        }
        let Some(bvh) = bvh.as_ref() else {
            return Err(Error::Gpu("internal: no BVH".into()));
        };
        let build_ms = t0.elapsed().as_secs_f64() * 1e3;
        self.upload(scene, bvh, build_ms, previous)
    }

    /// Prepares `scene` with its BVH built already (`build_ms` for the stats), e.g. while
    /// the device was starting: uploads it.
    pub fn prepare_built(
        &self,
        scene: &Scene,
        bvh: &SceneBvh,
        build_ms: f64,
    ) -> Result<PreparedScene> {
        self.upload(scene, bvh, build_ms, None)
    }

    /// Checks `scene`'s shadow-ray counts against the device and uploads it with `bvh`.
    fn upload(
        &self,
        scene: &Scene,
        bvh: &SceneBvh,
        build_ms: f64,
        previous: Option<&PreparedScene>,
    ) -> Result<PreparedScene> {
        // A scene built in code (an engine's) has not been through the loader's checks:
        // a light that is not finite or past the light cap would render NaN pixels.
        for (i, light) in scene.lights.iter().enumerate() {
            crate::scene::animation::check_light(light).map_err(|(field, message)| {
                Error::Usage(format!("light[{i}].{field}: {message}"))
            })?;
        }
        crate::scene::animation::check_light_value(scene.environment)
            .map_err(|m| Error::Usage(format!("environment.radiance: {m}")))?;
        for (i, m) in scene.materials.iter().enumerate() {
            let bad = |field: &str, rule: &str| {
                Error::Usage(format!("material[{i}] '{}'.{field}: {rule}", m.name))
            };
            let unit =
                |v: glam::Vec3| v.is_finite() && v.min_element() >= 0.0 && v.max_element() <= 1.0;
            if !unit(m.albedo) {
                return Err(bad(
                    "albedo",
                    &format!("{} must be within [0, 1]", m.albedo),
                ));
            }
            crate::scene::animation::check_light_value(m.emission)
                .map_err(|e| bad("emission", &e))?;
            if let Some(crate::scene::GlossyLobe::Phong { specular, exponent }) = m.glossy {
                // The loaders scale Ks so that Kd + Ks <= 1, within rounding.
                if !unit(specular) || !unit((m.albedo + specular) / 1.0001) {
                    return Err(bad(
                        "specular",
                        &format!("{specular} must be within [0, 1], with the albedo at most 1"),
                    ));
                }
                let max = crate::scene::limits::MAX_PHONG_EXPONENT;
                if !(exponent.is_finite() && (0.0..=max).contains(&exponent)) {
                    return Err(bad(
                        "exponent",
                        &format!("{exponent} must be from 0 to {max:e}"),
                    ));
                }
            }
        }
        // Direct light casts `light_samples` shadow rays per rect light and for the
        // environment, one per point, spot or sun.
        let delta = crate::scene::shadow_rays_per_hit(scene, 0);
        let sampled = crate::scene::shadow_rays_per_hit(scene, 1) - delta;
        let rays = sampled * u64::from(scene.settings.light_samples) + delta;
        if self.ctx.stops_long_loops()
            && delta > u64::from(crate::gpu::context::LLVMPIPE_MAX_SHADOW_RAYS)
        {
            return Err(Error::Usage(format!(
                "the scene has {delta} point, spot and sun lights, each casting a shadow ray \
                 per pixel; lavapipe (llvmpipe) silently stops loops after 65,535 iterations \
                 per invocation, so at most {} are allowed on it: merge lights or render on a GPU",
                crate::gpu::context::LLVMPIPE_MAX_SHADOW_RAYS
            )));
        }
        self.ctx.check_shadow_rays(rays, "render.light_samples")?;
        let gpu = GpuScene::upload_frame(
            &self.ctx,
            scene,
            bvh,
            scene.settings.light_samples,
            previous.map(|p| &p.gpu),
        )?;
        self.ctx.check()?;
        Ok(PreparedScene {
            shadow_rays: (sampled, delta),
            lights: scene.lights.iter().map(GpuLight::new).collect(),
            bounds: bvh.world_bounds(),
            light_maps: Default::default(),
            bounce_geometry: crate::bounce::BounceGeometry::new(bvh, scene),
            bounce: Default::default(),
            emitter_powers: crate::vpl::EmitterPowers::new(scene, bvh.world_bounds()),
            vpls: Default::default(),
            photons: Default::default(),
            bvh_stats: BvhStats {
                instances: scene.instances.len(),
                triangles: bvh.triangles.len(),
                blas_nodes: bvh.blas_nodes.len(),
                tlas_nodes: bvh.tlas_nodes.len(),
                build_ms,
                upload_bytes: gpu.bytes,
            },
            gpu,
        })
    }

    /// Records and runs the visibility and direct-light passes (one submission), adding
    /// their GPU times to `times`; with `traced` (this camera's visibility buffer, already
    /// traced) only the direct-light pass.
    fn visibility_and_direct(
        &self,
        scene: &PreparedScene,
        camera: &Camera,
        traced: Option<VisibilityBuffer>,
        with_direct: bool,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<(VisibilityBuffer, Option<DirectOutput>)> {
        let ctx = &self.ctx;
        let mut timer = PassTimer::new(ctx, 2);
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        let vis = match traced {
            Some(vis) => vis,
            None => self.visibility_pass(scene.gpu.features())?.record(
                ctx,
                &mut encoder,
                &scene.gpu,
                camera,
                timer.next("visibility"),
            )?,
        };
        let direct = if with_direct {
            Some(self.direct_pass(scene.gpu.features())?.record(
                ctx,
                &mut encoder,
                &scene.gpu,
                &vis,
                timer.next("direct"),
            )?)
        } else {
            None
        };
        timer.resolve(&mut encoder);
        ctx.queue.submit([encoder.finish()]);
        times.extend(timer.read(ctx)?);
        Ok((vis, direct))
    }

    /// Renders one frame of a prepared scene from `camera`: visibility, then direct light,
    /// then reads the images back.
    pub fn render_frame(&self, scene: &PreparedScene, camera: &Camera) -> Result<Frame> {
        let ctx = &self.ctx;
        let t0 = Instant::now();
        ctx.take_waits();
        let mut times = Vec::new();
        let (vis, direct) = self.visibility_and_direct(scene, camera, None, true, &mut times)?;
        let direct = direct.ok_or_else(|| Error::Gpu("internal: no direct light".into()))?;
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
        let pass_ms = sum_by_pass(&times);
        let (width, height) = (camera.width, camera.height);
        Ok(Frame {
            width,
            height,
            beauty,
            albedo,
            direct: direct_img,
            indirect: None,
            visibility,
            stats: FrameStats {
                width,
                height,
                pass_ms,
                shader_compile_ms: sum_by_pass(&self.ctx.take_compile_times()),
                wall_ms: t0.elapsed().as_secs_f64() * 1e3,
                gpu_waits: self.ctx.take_waits(),
                camera_rays: u64::from(width) * u64::from(height),
                cache: None,
            },
        })
    }
}

/// A pass of the radiance cache under its own name in frame statistics.
pub fn radiance_pass_name(name: &str) -> &'static str {
    match name {
        "hemisphere planes" => "radiance: hemisphere planes",
        "plane refinement select" => "radiance: plane refinement select",
        "plane refinement" => "radiance: plane refinement",
        "record reduction" => "radiance: record reduction",
        "radiance projection" => "radiance: projection",
        "radiance limit" => "radiance: gradient limit",
        "splat: radiance gather" => "radiance: gather",
        "placement: cover" => "radiance: cover",
        n if n.starts_with("splat: bin") || n.starts_with("placement: cover bin") => {
            "radiance: binning"
        }
        "temporal: reprojection" => "radiance: reprojection",
        "temporal: re-shading" => "radiance: re-shading",
        "temporal: hole filling" => "radiance: hole filling",
        _ => "radiance: other",
    }
}

/// Total GPU time per pass name, in first-seen order (passes run once per round).
fn sum_by_pass(times: &[(&'static str, f64)]) -> Vec<(String, f64)> {
    let owned: Vec<(String, f64)> = times.iter().map(|(n, ms)| (n.to_string(), *ms)).collect();
    sum_by_pass_owned(&owned)
}

/// Per-pass totals in first-seen order.
pub(crate) fn sum_by_pass_owned(times: &[(String, f64)]) -> Vec<(String, f64)> {
    let mut out: Vec<(String, f64)> = Vec::new();
    for (name, ms) in times {
        match out.iter_mut().find(|(n, _)| n == name) {
            Some((_, total)) => *total += ms,
            None => out.push((name.to_string(), *ms)),
        }
    }
    out
}
