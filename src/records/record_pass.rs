//! The record pass ([`RecordPass`]): record sites to records on the GPU, from hemisphere
//! planes (traced, refined, reduced) or from virtual point lights.

use super::{
    CacheSettings, PlaneBatch, PlanePixel, PlaneSample, RecordCache, RecordKind, RecordRadius,
    RecordSite, RecordSource, RecordStage, neighbour_grid, radiance_projection, refine, vpl_gather,
};
use crate::gpu::pipeline::{Binding, LazyPass, PassRecipe};
use crate::gpu::scene_buffers::GpuScene;
use crate::gpu::texel_table::{TexelCopy, TexelTable};
use crate::gpu::{GpuContext, SceneFeatures};
use crate::light_maps::LightMaps;
use crate::visibility::VisibilityBuffer;
use crate::{Error, Result};
use bytemuck::{Pod, Zeroable};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct SiteParams {
    count: u32,
    first_record: u32,
    r_min_pixels: f32,
    accuracy: f32,
    r_min_world: f32,
    _pad: [u32; 3],
}

/// Rows of a [`RecordSite`] in a texel table (`plane_site` in `wgsl/hemisphere_plane.wgsl`).
const SITE_TEXELS: u64 = (std::mem::size_of::<RecordSite>() / 16) as u64;

/// Parameters of the plane pass and its refinement (`hemisphere_plane.wgsl`), and of the
/// plane refresh's re-trace (`plane_retrace.wgsl`, which reads the first eight fields).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct PlaneParams {
    pub resolution: u32,
    pub count: u32,
    pub light_samples: u32,
    /// 1: also write each sample's hit.
    pub record_hits: u32,
    /// [`CacheSettings::plane_light_choices`].
    pub light_choices: u32,
    /// 1: also write each sample's environment-sampled share (refinement's selection).
    pub record_noise: u32,
    /// [`Self::TRACE`] or [`Self::REFINE`].
    pub mode: u32,
    /// Refining: K pixels selected per lit plane by contrast.
    pub refined: u32,
    /// Refining: strata per pixel, `split^2`.
    pub subsamples: u32,
    /// Refining: the centre ray's weight, `1 / (1 + split^2)`.
    pub centre_weight: f32,
    /// Refining: selection slots per record ([`refine::RefinePass::slots`]).
    pub slots: u32,
    /// Refining: pixels per workgroup, `64 / split^2` (one invocation per stratum).
    pub per_group: u32,
}

impl PlaneParams {
    /// `mode`: trace the planes (`MODE_TRACE` in `hemisphere_plane.wgsl`).
    pub const TRACE: u32 = 0;
    /// `mode`: refine the selected pixels in place, one workgroup per item the selection
    /// listed ([`refine::RefinePass::record`]).
    pub const REFINE: u32 = 1;
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ReduceParams {
    resolution: u32,
    count: u32,
    first_record: u32,
    gradients: u32,
    r_max_factor: f32,
    cos_weight_sum: f32,
    neighbour_clamp: u32,
    hessian_scale: f32,
}

/// Planes traced and refined by [`RecordPass::trace_planes_refined`].
#[derive(Clone, Debug, Default)]
pub struct RefinedPlanes {
    /// The traced planes, P^2 samples per site.
    pub coarse: Vec<PlaneSample>,
    /// The same after refinement.
    pub refined: Vec<PlaneSample>,
    /// Each traced sample's environment-sampled share (zeros without refinement).
    pub noise: Vec<f32>,
    /// The K refined pixels of each site, in pixel order.
    pub selected: Vec<u32>,
}

/// The records a reduction writes: `count` records from `first_record`, at `sites`.
pub struct ReductionBatch<'a> {
    pub sites: &'a wgpu::Buffer,
    pub first_record: u32,
    pub count: u32,
}

/// A [`HemispherePlane`](super::HemispherePlane)'s pixel table on the GPU, as the record reduction reads it: its
/// `P^2` pixels, then where its settings refine planes, each pixel's `split^2` strata as
/// pixels of their own (centre in `center`, weight in the refined pixel in `cos_weight`:
/// [`HemispherePlane::refine_samples`](super::HemispherePlane::refine_samples)), which the plane pass's refinement traces.
pub struct PlaneTable {
    pub resolution: u32,
    pub pixels: wgpu::Buffer,
    /// Sum of the pixels' cosine weights (pi when the border is stretched).
    pub cos_weight_sum: f32,
    /// The pixels by cosine weight, largest first ([`refine::filler_order`]): the order in
    /// which refinement gives a lit plane's spare slots to pixels near light.
    pub filler_order: wgpu::Buffer,
    /// `pixels` as a texel table, two rows a pixel, for the passes that read the table
    /// through texels on hosts where storage loads stall ([`crate::gpu::texel_table`]).
    pub pixel_texels: TexelTable,
}

impl PlaneTable {
    /// The table of a `resolution` x `resolution` plane with `settings`' field of view and
    /// border mode.
    pub fn new(ctx: &GpuContext, resolution: u32, settings: &CacheSettings) -> Result<Self> {
        let table = settings.plane(resolution);
        let cos_weight_sum = table
            .pixels
            .iter()
            .map(|p| f64::from(p.cos_weight))
            .sum::<f64>();
        let mut pixels = table.pixels.clone();
        if settings.refined_pixels() > 0 || settings.dark_plane_refine {
            pixels.extend(
                table
                    .refine_samples(settings.plane_refine_split)
                    .iter()
                    .map(|s| PlanePixel {
                        cos_weight: s.weight,
                        center: s.center,
                        ..PlanePixel::default()
                    }),
            );
        }
        Ok(Self {
            resolution,
            pixels: ctx.storage_buffer("plane table", &pixels)?,
            pixel_texels: TexelTable::with_data(
                ctx,
                "plane table texels",
                bytemuck::cast_slice(&pixels),
            )?,
            cos_weight_sum: cos_weight_sum as f32,
            filler_order: ctx
                .storage_buffer("plane filler order", &refine::filler_order(&table))?,
        })
    }
}

/// How refinement's rays differ from [`CacheSettings::plane_rays_per_record`]'s
/// `K split^2` a record ([`RecordPass::take_refinement_rays`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RefinementRays {
    /// Traced beyond it by planes that saw no light (refined everywhere, or at every pixel
    /// near light, instead of at K pixels).
    pub dark: u64,
    /// Not traced of it by lit planes that found fewer than K pixels to refine (where the
    /// light maps see every lit surface, pixels of no contrast far from light are not).
    pub unused: u64,
}

/// Computes records on the GPU: `record_sites.wgsl` (pixels → sites),
/// `hemisphere_plane.wgsl` (trace and shade the planes), `record_reduce.wgsl` (E, R,
/// gradients), in batches sized to the device.
pub struct RecordPass {
    /// Every record pass of a device has the same pipelines (built once per device,
    /// [`ComputePass::with_constants`]): tail fill's ([`Self::tail_pass`]), radiance
    /// records', temporal caching's.
    /// Built at first use ([`Self::pipeline_recipes`] builds them ahead).
    sites: LazyPass,
    plane: LazyPass,
    reduce: LazyPass,
    /// The grid over earlier records that neighbour clamping searches.
    neighbour_grid: neighbour_grid::NeighbourGridPass,
    /// The plane table for `settings`.
    table: PlaneTable,
    /// Adaptive plane refinement, when `settings.plane_refine` selects any pixel.
    refine: Option<refine::RefinePass>,
    pub settings: CacheSettings,
    /// Records per plane dispatch.
    pub batch: u32,
    /// What plane passes bind when a frame has no light maps.
    no_light_maps: LightMaps,
    /// What plane passes bind when no sample's environment share is kept (zeros).
    no_noise: wgpu::Buffer,
    /// What the plane pass binds as refinement's selection when it traces.
    no_selection: wgpu::Buffer,
    /// The plane samples the reduction reads as texels where its pipeline reads texels
    /// ([`crate::gpu::ComputePass::reads_texel_tables`]).
    sample_texels: TexelCopy,
    /// The batch's sites as the plane pass and its refinement read them where they read
    /// texel tables ([`Self::site_texels_of`]).
    site_texels: TexelCopy,
    /// The kind of records computed; radiance records also project their planes.
    pub kind: RecordKind,
    /// The scene features its plane pipelines are compiled for ([`Self::for_scene`]).
    features: SceneFeatures,
    projection: Option<radiance_projection::RadianceProjectionPass>,
    /// The gather of VPL records ([`RecordSource::Vpl`]).
    vpl: Option<vpl_gather::VplGatherPass>,
    /// The pass of tail fill's records: planes at
    /// [`CacheSettings::tail_plane_resolution`] (irradiance records from planes, when that
    /// is below the plane resolution). Built on first use; no plane resolution is compiled
    /// into a pipeline, so its pipelines are this pass's and only its plane table and
    /// buffers are new.
    tail: std::sync::OnceLock<Box<RecordPass>>,
}

impl RecordPass {
    /// A pass computing irradiance records.
    pub fn new(ctx: &GpuContext, settings: &CacheSettings) -> Result<Self> {
        Self::with_kind(ctx, settings, RecordKind::Irradiance)
    }

    /// A pass computing `kind` records: radiance records are irradiance records whose
    /// planes are also projected onto HSH (`radiance_project.wgsl`). Its plane hits are
    /// shaded for every kind of light ([`Self::for_scene`] compiles fewer).
    pub fn with_kind(ctx: &GpuContext, settings: &CacheSettings, kind: RecordKind) -> Result<Self> {
        Self::for_scene(ctx, settings, kind, SceneFeatures::ALL)
    }

    /// [`Self::with_kind`] with the plane and refinement pipelines compiled for the scene
    /// features `features` alone (its kinds of light, instances or one BLAS, textures; the
    /// bounce cache its settings make is added): a scene with others is refused by
    /// [`Self::check_features`].
    pub fn for_scene(
        ctx: &GpuContext,
        settings: &CacheSettings,
        kind: RecordKind,
        features: SceneFeatures,
    ) -> Result<Self> {
        settings.validate()?;
        // Its plane hits reflect the bounce cache its settings make (none with one bounce).
        let features = features.with_bounce_cache(settings.bounce.levels() > 0);
        // Photon records leave holes that plane records fill.
        let planes = settings.source != RecordSource::Vpl;
        if settings.source != RecordSource::Planes && kind != RecordKind::Irradiance {
            return Err(Error::Usage(format!(
                "{} come from hemisphere planes only (--records {} is for irradiance records)",
                kind.describe(),
                settings.source.name()
            )));
        }
        let projection = match kind {
            RecordKind::Irradiance => None,
            RecordKind::Radiance { order } => {
                let plane = settings.plane(settings.plane_resolution);
                Some(radiance_projection::RadianceProjectionPass::new(
                    ctx, &plane, order, 16,
                )?)
            }
        };
        // The largest buffer a record needs in one binding: its plane's samples, or, where
        // planes are refined, its strata (refine::strata_bytes).
        let plane_bytes = (u64::from(settings.plane_resolution).pow(2) * 16).max(
            refine::strata_bytes(settings.plane_resolution, settings.plane_refine_split, 1),
        );
        // As many records per dispatch as fit one binding, at most 256 (a few seconds of
        // rays on a CPU device, so progress stays visible).
        let batch = (ctx.max_binding_size() / plane_bytes).clamp(1, 256) as u32;
        // Its pipelines build at their first use, or ahead from `pipeline_recipes`
        // (`Renderer::build_ahead`, on as many threads as cores).
        let mut pass =
            Self::without_refinement(ctx, settings, kind, planes, projection, batch, features)?;
        pass.refine = if planes {
            refine::RefinePass::new(ctx, settings)?
        } else {
            None
        };
        Ok(pass)
    }

    /// [`Self::with_kind`]'s pass, its refinement (built apart) not yet in it.
    fn without_refinement(
        ctx: &GpuContext,
        settings: &CacheSettings,
        kind: RecordKind,
        planes: bool,
        projection: Option<radiance_projection::RadianceProjectionPass>,
        batch: u32,
        features: SceneFeatures,
    ) -> Result<Self> {
        use Binding::*;
        Ok(Self {
            sites: LazyPass::new(
                "record_sites.wgsl",
                &[Uniform, Uniform, StorageRead, StorageRead, StorageReadWrite],
                &[],
            ),
            // Traces the planes and refines them (`refine::RefinePass::record`). Ten storage
            // buffers: with the scene's six, the 16 a stage may bind
            // (`gpu::context::STORAGE_BUFFERS_PER_STAGE`).
            plane: LazyPass::new(
                "hemisphere_plane.wgsl",
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
                    StorageReadWrite,
                    StorageRead,
                    Texels,
                    Texels,
                ],
                &[features.constant()],
            ),
            // The Hessian's mesh sum only in the pipeline that uses it (lavapipe ran the
            // split-sphere reduction slower with the unused branch compiled in).
            reduce: LazyPass::new(
                "record_reduce.wgsl",
                &[
                    Uniform,
                    StorageRead,
                    StorageRead,
                    StorageRead,
                    StorageReadWrite,
                    Uniform,
                    StorageRead,
                    StorageRead,
                    Texels,
                    Texels,
                ],
                &[
                    (
                        "RECORD_RADIUS_HESSIAN",
                        f64::from(u8::from(matches!(
                            settings.record_radius,
                            RecordRadius::Hessian { .. }
                        ))),
                    ),
                    // The corral's code only where records get one (lavapipe's start-up
                    // built the larger pipeline 1.2x as slowly).
                    ("CORRAL", f64::from(u8::from(settings.corral.in_records()))),
                ],
            ),
            neighbour_grid: neighbour_grid::NeighbourGridPass::new(ctx)?,
            table: PlaneTable::new(ctx, settings.plane_resolution, settings)?,
            refine: None,
            settings: settings.clone(),
            batch,
            no_light_maps: LightMaps::none(ctx)?,
            no_noise: ctx.storage_buffer_sized("no plane noise", 16)?,
            no_selection: ctx.storage_buffer_sized("no refinement selection", 16)?,
            sample_texels: TexelCopy::new(ctx, "plane sample texels")?,
            site_texels: TexelCopy::new(ctx, "record site texels")?,
            kind,
            features,
            projection,
            vpl: if planes {
                None
            } else {
                Some(vpl_gather::VplGatherPass::new(ctx)?)
            },
            tail: std::sync::OnceLock::new(),
        })
    }

    /// What its pipelines are built from, the longest to build first (the plane's, then the
    /// refinement's selection, the reduction, the sites): a thread that builds them ahead
    /// leaves this pass nothing to build at its first records.
    pub fn pipeline_recipes(&self) -> Vec<PassRecipe> {
        let mut recipes = vec![self.plane.recipe().clone()];
        if let Some(r) = &self.refine {
            recipes.push(r.select_recipe().clone());
            recipes.push(r.combine_recipe().clone());
        }
        recipes.push(self.reduce.recipe().clone());
        recipes.push(self.sites.recipe().clone());
        recipes
    }

    /// How refinement's rays since the last call differ from
    /// [`CacheSettings::plane_rays_per_record`]'s `K split^2` a record
    /// ([`refine::select_pixels`]): those of `passes` and their tail passes, read in one wait
    /// for the device (none when no pass refines), the counters then cleared.
    pub fn take_refinement_rays(
        ctx: &GpuContext,
        passes: &[&RecordPass],
    ) -> Result<RefinementRays> {
        let refines: Vec<&refine::RefinePass> = passes
            .iter()
            .flat_map(|&pass| std::iter::once(pass).chain(pass.tail.get().map(|t| &**t)))
            .filter_map(|pass| pass.refine.as_ref())
            .collect();
        let mut rays = RefinementRays::default();
        if refines.is_empty() {
            return Ok(rays);
        }
        let counters: Vec<&wgpu::Buffer> = refines.iter().map(|r| r.ray_counts()).collect();
        let counts: Vec<Vec<u32>> = ctx.read_buffers(&counters)?;
        for (r, count) in refines.iter().zip(&counts) {
            let count = |i: usize| u64::from(count.get(i).copied().unwrap_or(0));
            let per_pixel = r.rays_per_guided_pixel();
            rays.dark += count(0) * r.extra_rays_per_dark_plane();
            // Guided dark planes: their flagged pixels instead of the K by contrast.
            rays.dark += count(1) * per_pixel;
            rays.dark = rays
                .dark
                .saturating_sub(count(2) * u64::from(r.refined()) * per_pixel);
            rays.unused += count(3) * per_pixel;
            ctx.queue
                .write_buffer(r.ray_counts(), 0, bytemuck::bytes_of(&[0u32; 4]));
        }
        Ok(rays)
    }

    /// Selection slots per record of its refinement (`max(K, 1)`; 0 without refinement):
    /// how [`RefinedPlanes::selected`] is laid out.
    pub fn refine_slots(&self) -> u32 {
        self.refine.as_ref().map_or(0, |r| r.slots())
    }

    /// Whether this pass refines its planes ([`refine`]): by contrast, or dark planes alone.
    pub fn refines(&self) -> bool {
        self.refine.is_some()
    }

    /// Whether this pass refines lit planes too (by contrast, `plane_refine` > 0): only
    /// then does a lit record differ from its plane as traced, which temporal caching's
    /// tau must then be taken against (`temporal::Lookahead`). A plane refined because it
    /// was dark has nothing for the estimate to compare with.
    pub fn refines_by_contrast(&self) -> bool {
        self.refine.as_ref().is_some_and(|r| r.refined() > 0)
    }

    /// The pass that computes tail fill's records ([`CacheSettings::tail_plane_resolution`]):
    /// this one when their planes are not coarser (radiance and VPL records, no tail).
    pub fn tail_pass(&self, ctx: &GpuContext) -> Result<&RecordPass> {
        let tail_resolution = self.settings.tail_plane_resolution();
        if self.kind != RecordKind::Irradiance
            || self.settings.source != RecordSource::Planes
            || tail_resolution >= self.settings.plane_resolution
        {
            return Ok(self);
        }
        if let Some(pass) = self.tail.get() {
            return Ok(pass);
        }
        let tail_settings = CacheSettings {
            plane_resolution: tail_resolution,
            ..self.settings.clone()
        };
        let pass = Self::for_scene(ctx, &tail_settings, self.kind, self.features)?;
        Ok(self.tail.get_or_init(|| Box::new(pass)))
    }

    /// The name [`Self::for_scene`] had while the features were only kinds of light.
    #[deprecated(note = "renamed `for_scene`")]
    pub fn for_lights(
        ctx: &GpuContext,
        settings: &CacheSettings,
        kind: RecordKind,
        features: SceneFeatures,
    ) -> Result<Self> {
        Self::for_scene(ctx, settings, kind, features)
    }

    /// The name [`Self::check_features`] had while the features were only kinds of light.
    #[deprecated(note = "renamed `check_features`")]
    pub fn check_lights(&self, scene: &GpuScene) -> Result<()> {
        self.check_features(scene)
    }

    /// The scene features its plane pipelines were compiled for (the bounce cache its
    /// settings make included).
    pub fn features(&self) -> SceneFeatures {
        self.features
    }

    /// Refuses a scene with a feature this pass's plane pipelines were not compiled for
    /// ([`Self::for_scene`]): its hits would be shaded without that light, or its rays
    /// would not enter its instances.
    pub fn check_features(&self, scene: &GpuScene) -> Result<()> {
        self.features
            .require(scene.features(), "record pass", "RecordPass::for_scene")
    }

    /// Sites for the visibility-buffer `pixels` (one per new record, in order), computed on
    /// the GPU; `first_record` is the index the first of them will get.
    pub fn sites_from_pixels(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        vis: &VisibilityBuffer,
        pixels: &[u32],
        first_record: u32,
    ) -> Result<wgpu::Buffer> {
        let count = pixels.len() as u32;
        let params = ctx.uniform_buffer(
            "site params",
            &SiteParams {
                count,
                first_record,
                r_min_pixels: self.settings.r_min_pixels,
                accuracy: self.settings.accuracy,
                r_min_world: self.settings.r_min_scene * scene.diagonal,
                _pad: [0; 3],
            },
        );
        let pixel_buf = ctx.storage_buffer("site pixels", pixels)?;
        let sites = ctx.storage_buffer_sized(
            "record sites",
            u64::from(count) * std::mem::size_of::<RecordSite>() as u64,
        )?;
        let sites_pass = self.sites.get(ctx)?;
        let bind = sites_pass.bind(
            ctx,
            &[
                &params,
                &vis.camera_buffer,
                &vis.samples,
                &pixel_buf,
                &sites,
            ],
        );
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        sites_pass.record(
            &mut enc,
            &scene.bind_group,
            &bind,
            [count.div_ceil(64), 1, 1],
            None,
        );
        ctx.queue.submit([enc.finish()]);
        Ok(sites)
    }

    /// Computes records for `count` sites (a buffer of [`RecordSite`]) and appends them to
    /// `cache`; `on_batch` is called after each batch with the number done. Returns the
    /// per-pass GPU times. Each batch goes to the settings' [`RecordSource`]: VPL records
    /// are one gather (`vpl_gather.wgsl`); plane records are traced, refined, projected
    /// (radiance records) and reduced. A `stage` (temporal caching of plane records) runs
    /// inside each batch ([`RecordStage`]): it may replace the tracing, read the planes and
    /// their hits, and reduce more planes.
    #[allow(clippy::too_many_arguments)]
    pub fn compute(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        sites: &wgpu::Buffer,
        count: u32,
        cache: &mut RecordCache,
        light_maps: Option<&LightMaps>,
        mut stage: Option<&mut (dyn RecordStage + '_)>,
        mut on_batch: impl FnMut(u32),
    ) -> Result<Vec<(&'static str, f64)>> {
        self.check_features(scene)?;
        let light_maps = light_maps.unwrap_or(&self.no_light_maps);
        if self.vpl.is_some() && stage.is_some() {
            return Err(Error::Usage(
                "records from VPLs (--records vpl) do not work with temporal caching yet: \
                 use --records planes or --temporal off"
                    .into(),
            ));
        }
        if cache.kind != self.kind {
            return Err(Error::Usage(format!(
                "internal: a pass for {} appends to a cache of {}",
                self.kind.describe(),
                cache.kind.describe()
            )));
        }
        cache.reserve(ctx, count)?;
        let res = self.settings.plane_resolution;
        // Sized to this call's largest batch: small placement rounds stay small.
        let batch_records = self.batch.min(count.max(1));
        // VPL records trace no planes.
        let plane_pixels = if self.vpl.is_some() { 1 } else { res * res };
        let batch_samples = u64::from(batch_records) * u64::from(plane_pixels);
        let samples = ctx.storage_buffer_sized("plane samples", batch_samples * 16)?;
        // A stage (temporal caching) reads the hit of each sample.
        let record_hits = stage.is_some();
        let hits = ctx.storage_buffer_sized(
            "plane hits",
            if record_hits { batch_samples * 16 } else { 16 },
        )?;
        if let Some(st) = stage.as_deref_mut() {
            st.begin(ctx, cache, count, batch_records)?;
        }
        let selected = match &self.refine {
            Some(r) => {
                ctx.storage_buffer_sized("refined pixels", r.selected_bytes(batch_records))?
            }
            None => ctx.storage_buffer_sized("refined pixels", 16)?,
        };
        // Each sample's environment-sampled share, for refinement's selection.
        let noise = match &self.refine {
            Some(_) => Some(ctx.storage_buffer_sized("plane noise", batch_samples * 4)?),
            None => None,
        };
        // A stage reads the planes as traced beside their hits: refinement keeps a copy.
        let traced = if self.refine.is_some() && stage.is_some() {
            Some(ctx.storage_buffer_sized("traced plane samples", batch_samples * 16)?)
        } else {
            None
        };
        let mut times = Vec::new();
        let site_bytes = std::mem::size_of::<RecordSite>() as u64;
        let mut done = 0;
        while done < count {
            let n = (count - done).min(self.batch);
            // The batch's sites, as their own binding (offsets need 256-byte alignment).
            let batch_sites = ctx.storage_buffer_sized("batch sites", u64::from(n) * site_bytes)?;
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            enc.copy_buffer_to_buffer(
                sites,
                u64::from(done) * site_bytes,
                &batch_sites,
                0,
                u64::from(n) * site_bytes,
            );
            let batch = PlaneBatch {
                sites: &batch_sites,
                samples: &samples,
                traced: &samples,
                hits: &hits,
                first_record: cache.count,
                first_site: done,
                count: n,
            };
            let mut timer = crate::gpu::timer::PassTimer::new(ctx, 24);
            if let Some(vpl) = &self.vpl {
                // Records from VPLs: one gather writes them (RecordSource::Vpl).
                vpl.record(
                    ctx,
                    &mut enc,
                    scene,
                    &self.settings,
                    &batch_sites,
                    cache.count,
                    n,
                    &vpl_gather::GatherTarget::of(cache),
                    &mut timer,
                )?;
                timer.resolve(&mut enc);
                ctx.queue.submit([enc.finish()]);
                times.extend(timer.read(ctx)?);
                cache.count += n;
                done += n;
                on_batch(done);
                continue;
            }
            let site_texels = self.site_texels_of(ctx, &mut enc, &batch_sites, n)?;
            let replaced = match stage.as_deref_mut() {
                Some(st) => st.replace_tracing(
                    ctx,
                    &mut enc,
                    scene,
                    &self.settings,
                    &self.table,
                    &batch,
                    &mut timer,
                )?,
                None => false,
            };
            if !replaced {
                self.record_planes(
                    ctx,
                    &mut enc,
                    scene,
                    &batch,
                    &site_texels,
                    record_hits,
                    noise.as_ref(),
                    light_maps,
                    timer.next("hemisphere planes"),
                )?;
            }
            // Refinement follows the planes however they were made: a refreshed plane is
            // its traced plane exactly (temporal caching's plane refresh), so refining it
            // gives the record a fresh trace would.
            if let Some(r) = &self.refine {
                if let Some(traced) = &traced {
                    enc.copy_buffer_to_buffer(
                        &samples,
                        0,
                        traced,
                        0,
                        u64::from(n) * u64::from(plane_pixels) * 16,
                    );
                }
                let noise = noise.as_ref().unwrap_or(&self.no_noise);
                if replaced {
                    // Refreshed planes keep no environment shares: rank them by plain
                    // contrast rather than by a previous batch's.
                    enc.clear_buffer(noise, 0, None);
                }
                r.record(
                    ctx,
                    &mut enc,
                    scene,
                    self.plane.get(ctx)?,
                    &self.table,
                    &batch_sites,
                    &site_texels,
                    &samples,
                    &selected,
                    noise,
                    n,
                    light_maps,
                    &mut timer,
                )?;
            }
            // Refined planes: the stage reads their traced copy beside the hits.
            let batch = match &traced {
                Some(traced) => PlaneBatch { traced, ..batch },
                None => batch,
            };
            if let Some(st) = stage.as_deref_mut() {
                st.planes_ready(ctx, &mut enc, &batch, res)?;
            }
            self.record_projection(
                ctx,
                &mut enc,
                scene,
                &batch_sites,
                &samples,
                &cache.coefficients,
                cache.count,
                n,
                false,
                &mut timer,
            );
            let reduction = ReductionBatch {
                sites: &batch_sites,
                first_record: cache.count,
                count: n,
            };
            self.record_reduction(
                ctx,
                &mut enc,
                scene,
                &self.table,
                &reduction,
                &samples,
                &cache.buffer,
                &mut timer,
            )?;
            self.record_radiance_limit(
                ctx,
                &mut enc,
                scene,
                &cache.buffer,
                &cache.coefficients,
                cache.count,
                n,
                &mut timer,
            );
            if let Some(st) = stage.as_deref_mut() {
                st.reduced(ctx, &mut enc, scene, self, &batch, &mut timer)?;
            }
            timer.resolve(&mut enc);
            ctx.queue.submit([enc.finish()]);
            times.extend(timer.read(ctx)?);
            cache.count += n;
            if let Some(st) = stage.as_deref_mut() {
                st.batch_done(n);
            }
            done += n;
            on_batch(done);
        }
        Ok(times)
    }

    /// Records the HSH projection (`radiance_project.wgsl`) of `count` planes of this
    /// pass's resolution in `samples`, traced from `sites`, into the coefficient blocks of
    /// records `first_record..` of `coefficients`; nothing for irradiance records. Stages
    /// project their own planes with it (temporal caching: the planes estimated at t+1);
    /// `values_only` leaves the coefficients' gradients out (and their floats as they are).
    #[allow(clippy::too_many_arguments)]
    pub fn record_projection(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        sites: &wgpu::Buffer,
        samples: &wgpu::Buffer,
        coefficients: &wgpu::Buffer,
        first_record: u32,
        count: u32,
        values_only: bool,
        timer: &mut crate::gpu::timer::PassTimer,
    ) {
        if let Some(projection) = &self.projection {
            projection.record(
                ctx,
                enc,
                scene,
                sites,
                samples,
                coefficients,
                first_record,
                count,
                values_only,
                timer.next("radiance projection"),
            );
        }
    }

    /// Records Ward's gradient limit on radiance records `first_record..first_record +
    /// count` of `records` and `coefficients` (`radiance_limit.wgsl`,
    /// [`radiance_projection::limit_gradients`]) after their projection and reduction;
    /// nothing for irradiance records or without gradients. Stages that project gradients
    /// of their own limit them with it.
    #[allow(clippy::too_many_arguments)]
    pub fn record_radiance_limit(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        records: &wgpu::Buffer,
        coefficients: &wgpu::Buffer,
        first_record: u32,
        count: u32,
        timer: &mut crate::gpu::timer::PassTimer,
    ) {
        if let Some(projection) = &self.projection
            && self.settings.gradients
        {
            projection.record_limit(
                ctx,
                enc,
                scene,
                records,
                coefficients,
                first_record,
                count,
                // The records' own accuracy (the radiance accuracy, `record_settings`).
                self.settings.accuracy,
                timer.next("radiance limit"),
            );
        }
    }

    /// The first `count` sites of `sites` as the plane pipeline reads them: where it reads
    /// texel tables, records their copy into `enc` (once a batch: the plane pass and its
    /// refinement both bind it).
    fn site_texels_of(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        sites: &wgpu::Buffer,
        count: u32,
    ) -> Result<wgpu::TextureView> {
        let reads = self.plane.get(ctx)?.reads_texel_tables();
        self.site_texels
            .view(ctx, enc, sites, u64::from(count) * SITE_TEXELS, reads)
    }

    /// Records the plane pass (`hemisphere_plane.wgsl`) for `batch`: its samples, and with
    /// `record_hits` what each sample hit.
    #[allow(clippy::too_many_arguments)]
    fn record_planes(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        batch: &PlaneBatch<'_>,
        site_texels: &wgpu::TextureView,
        record_hits: bool,
        noise: Option<&wgpu::Buffer>,
        light_maps: &LightMaps,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<()> {
        let res = self.settings.plane_resolution;
        let plane = self.plane.get(ctx)?;
        let plane_params = ctx.uniform_buffer(
            "plane params",
            &PlaneParams {
                resolution: res,
                count: batch.count,
                light_samples: self.settings.plane_light_samples,
                record_hits: u32::from(record_hits),
                light_choices: self.settings.plane_light_choices,
                record_noise: u32::from(noise.is_some()),
                mode: PlaneParams::TRACE,
                ..PlaneParams::zeroed()
            },
        );
        let plane_bind = plane.bind_resources(
            ctx,
            &[
                plane_params.as_entire_binding(),
                batch.sites.as_entire_binding(),
                self.table.pixels.as_entire_binding(),
                batch.samples.as_entire_binding(),
                batch.hits.as_entire_binding(),
                light_maps.maps_buffer.as_entire_binding(),
                light_maps.depths.as_entire_binding(),
                light_maps.first_buffer.as_entire_binding(),
                scene.bounce_cache().as_entire_binding(),
                noise.unwrap_or(&self.no_noise).as_entire_binding(),
                self.no_selection.as_entire_binding(),
                wgpu::BindingResource::TextureView(site_texels),
                wgpu::BindingResource::TextureView(self.table.pixel_texels.view()),
            ],
        );
        plane.record(
            enc,
            &scene.bind_group,
            &plane_bind,
            [(res * res).div_ceil(64), 1, batch.count],
            timestamps,
        );
        Ok(())
    }

    /// Records the reduction of a batch's planes (`table`'s resolution, in `samples`) into
    /// `records` (`record_reduce.wgsl`). Stages reduce their own planes with it (temporal
    /// caching: the planes estimated at t+1 into the records at t+1).
    #[allow(clippy::too_many_arguments)]
    pub fn record_reduction(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        table: &PlaneTable,
        batch: &ReductionBatch<'_>,
        samples: &wgpu::Buffer,
        records: &wgpu::Buffer,
        timer: &mut crate::gpu::timer::PassTimer,
    ) -> Result<()> {
        let built = if self.settings.neighbour_clamp {
            self.neighbour_grid.record(
                ctx,
                enc,
                scene,
                records,
                batch.first_record,
                timer.next("neighbour grid"),
            )?
        } else {
            None
        };
        let grid = built.as_ref().unwrap_or(&self.neighbour_grid.disabled);
        let params = ctx.uniform_buffer(
            "reduce params",
            &ReduceParams {
                resolution: table.resolution,
                count: batch.count,
                first_record: batch.first_record,
                gradients: u32::from(self.settings.gradients),
                r_max_factor: self.settings.r_max_factor,
                cos_weight_sum: table.cos_weight_sum,
                neighbour_clamp: u32::from(self.settings.neighbour_clamp),
                hessian_scale: self.settings.record_radius.hessian_scale(),
            },
        );
        let reduce = self.reduce.get(ctx)?;
        let rows = u64::from(batch.count) * u64::from(table.resolution * table.resolution);
        let sample_texels =
            self.sample_texels
                .view(ctx, enc, samples, rows, reduce.reads_texel_tables())?;
        let bind = reduce.bind_resources(
            ctx,
            &[
                params.as_entire_binding(),
                batch.sites.as_entire_binding(),
                table.pixels.as_entire_binding(),
                samples.as_entire_binding(),
                records.as_entire_binding(),
                grid.params.as_entire_binding(),
                grid.offsets.as_entire_binding(),
                grid.records.as_entire_binding(),
                wgpu::BindingResource::TextureView(&sample_texels),
                wgpu::BindingResource::TextureView(table.pixel_texels.view()),
            ],
        );
        reduce.record(
            enc,
            &scene.bind_group,
            &bind,
            [batch.count, 1, 1],
            timer.next("record reduction"),
        );
        Ok(())
    }

    /// Traces the planes of `sites` and refines them as the settings say: the traced
    /// (coarse) planes, the refined ones and each site's `max(K, 1)` selection slots
    /// (the K pixels refined by contrast, or `DARK_PLANE`; tests).
    /// Without refinement the refined planes are the coarse ones and no pixel is listed.
    pub fn trace_planes_refined(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        sites: &[RecordSite],
    ) -> Result<RefinedPlanes> {
        self.trace_planes_refined_with(ctx, scene, sites, &self.no_light_maps)
    }

    /// [`Self::trace_planes_refined`] with the plane hits shadowed by `light_maps` (and
    /// dark planes refined near their lit grid's lit surfaces where it sees them all).
    pub fn trace_planes_refined_with(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        sites: &[RecordSite],
        light_maps: &LightMaps,
    ) -> Result<RefinedPlanes> {
        let Some(r) = &self.refine else {
            let coarse = self.trace_planes(ctx, scene, sites)?;
            return Ok(RefinedPlanes {
                refined: coarse.clone(),
                noise: vec![0.0; coarse.len()],
                coarse,
                selected: Vec::new(),
            });
        };
        let res = self.settings.plane_resolution;
        let n = sites.len() as u32;
        let samples_len = (n * res * res) as usize;
        let noise = ctx.storage_buffer_sized("plane noise", (samples_len as u64 * 4).max(16))?;
        let (coarse, ()) = self.trace_planes_with(
            ctx,
            scene,
            sites,
            false,
            Some(&noise),
            light_maps,
            |_, _| Ok(()),
        )?;
        let mut noise_values: Vec<f32> = ctx.read_buffer(&noise)?;
        noise_values.truncate(samples_len);
        let sites_buf = ctx.storage_buffer("record sites", sites)?;
        let samples = ctx.storage_buffer("plane samples", &coarse)?;
        let selected = ctx.storage_buffer_sized("refined pixels", r.selected_bytes(n).max(4))?;
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let mut timer = crate::gpu::timer::PassTimer::new(ctx, 3);
        let site_texels = self.site_texels_of(ctx, &mut enc, &sites_buf, n)?;
        r.record(
            ctx,
            &mut enc,
            scene,
            self.plane.get(ctx)?,
            &self.table,
            &sites_buf,
            &site_texels,
            &samples,
            &selected,
            &noise,
            n,
            light_maps,
            &mut timer,
        )?;
        ctx.queue.submit([enc.finish()]);
        let mut refined: Vec<PlaneSample> = ctx.read_buffer(&samples)?;
        refined.truncate(coarse.len());
        let mut selected: Vec<u32> = ctx.read_buffer(&selected)?;
        selected.truncate((n * r.slots()) as usize);
        Ok(RefinedPlanes {
            coarse,
            refined,
            noise: noise_values,
            selected,
        })
    }

    /// Traces the planes of `count` sites and returns their samples, unrefined (tests,
    /// Table 4.1; [`RecordPass::trace_planes_refined`] refines them).
    pub fn trace_planes(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        sites: &[RecordSite],
    ) -> Result<Vec<PlaneSample>> {
        Ok(self
            .trace_planes_then(ctx, scene, sites, false, |_, _| Ok(()))?
            .0)
    }

    /// Traces the planes of `sites` (at most one batch), with `record_hits` also what each
    /// sample hit, and lets `then` record more work on the planes in the same submission
    /// (temporal caching's reprojection, `temporal::trace_planes_ahead`). Returns the
    /// samples, unrefined, and what `then` returned.
    pub fn trace_planes_then<T>(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        sites: &[RecordSite],
        record_hits: bool,
        then: impl FnOnce(&mut wgpu::CommandEncoder, &PlaneBatch<'_>) -> Result<T>,
    ) -> Result<(Vec<PlaneSample>, T)> {
        self.trace_planes_with(
            ctx,
            scene,
            sites,
            record_hits,
            None,
            &self.no_light_maps,
            then,
        )
    }

    /// [`Self::trace_planes_then`], with `noise` also receiving each sample's
    /// environment-sampled share (`hemisphere_plane.wgsl`).
    #[allow(clippy::too_many_arguments)]
    fn trace_planes_with<T>(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        sites: &[RecordSite],
        record_hits: bool,
        noise: Option<&wgpu::Buffer>,
        light_maps: &LightMaps,
        then: impl FnOnce(&mut wgpu::CommandEncoder, &PlaneBatch<'_>) -> Result<T>,
    ) -> Result<(Vec<PlaneSample>, T)> {
        self.check_features(scene)?;
        let res = self.settings.plane_resolution;
        let n = sites.len() as u32;
        if n > self.batch {
            return Err(Error::Usage(format!(
                "trace_planes: {n} sites exceed the batch of {}",
                self.batch
            )));
        }
        let sites_buf = ctx.storage_buffer("record sites", sites)?;
        let plane_bytes = u64::from(n) * u64::from(res * res) * 16;
        let samples = ctx.storage_buffer_sized("plane samples", plane_bytes)?;
        let hits =
            ctx.storage_buffer_sized("plane hits", if record_hits { plane_bytes } else { 16 })?;
        let batch = PlaneBatch {
            sites: &sites_buf,
            samples: &samples,
            traced: &samples,
            hits: &hits,
            first_record: 0,
            first_site: 0,
            count: n,
        };
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let site_texels = self.site_texels_of(ctx, &mut enc, &sites_buf, n)?;
        self.record_planes(
            ctx,
            &mut enc,
            scene,
            &batch,
            &site_texels,
            record_hits,
            noise,
            light_maps,
            None,
        )?;
        let out = then(&mut enc, &batch)?;
        ctx.queue.submit([enc.finish()]);
        let mut now: Vec<PlaneSample> = ctx.read_buffer(&samples)?;
        now.truncate((n * res * res) as usize);
        Ok((now, out))
    }
}
