//! The GPU context: instance, adapter, device and queue, either created headless by us or
//! handed to us by an embedding engine.

use super::triangle_fetch::TriangleFetch;
use crate::{Error, Result};
use std::sync::{Arc, Mutex};

/// Features radsplat can use when the adapter has them. None is required.
/// `PIPELINE_CACHE` keeps compiled pipelines on disk between runs ([`PipelineCacheFile`]).
pub const OPTIONAL_FEATURES: wgpu::Features =
    wgpu::Features::TIMESTAMP_QUERY.union(wgpu::Features::PIPELINE_CACHE);

/// Number of storage buffers one radsplat pass binds at most (scene tables + pass buffers).
pub const STORAGE_BUFFERS_PER_STAGE: u32 = 16;

/// Invocations per workgroup of every pass that traces rays (their BVH stacks share
/// the workgroup's memory: `BVH_WORKGROUP_INVOCATIONS` in `wgsl/shared/bvh.wgsl`).
pub const TRACING_WORKGROUP_INVOCATIONS: u32 = 64;

/// Workgroup memory of the traversal stacks of one tracing workgroup, in bytes.
pub const TRAVERSAL_STACKS_BYTES: u32 =
    TRACING_WORKGROUP_INVOCATIONS * crate::bvh::TRAVERSAL_STACK * 4;

/// The limits radsplat needs from a device. Engines that hand us their device must have
/// created it with at least these. Buffer sizes of a given scene or resolution are
/// checked against the device's actual limits before anything is allocated.
pub fn required_limits() -> wgpu::Limits {
    wgpu::Limits {
        max_storage_buffers_per_shader_stage: STORAGE_BUFFERS_PER_STAGE,
        // Splat binning and scans run 256-wide workgroups (WebGPU's default limits).
        max_compute_invocations_per_workgroup: 256,
        max_compute_workgroup_size_x: 256,
        max_compute_workgroup_size_y: 8,
        // Tracing passes keep their 64 invocations' BVH stacks in workgroup memory
        // (wgsl/shared/bvh.wgsl): 64 x 96 u32 = 24 KiB.
        max_compute_workgroup_storage_size: TRAVERSAL_STACKS_BYTES,
        ..wgpu::Limits::downlevel_defaults()
    }
}

/// Keeps Mesa's device-selection layer from asking a Wayland compositor for the default
/// GPU where there can be none: with `XDG_RUNTIME_DIR` unset or not a directory (a
/// container, ssh, CI) libwayland prints "error: XDG_RUNTIME_DIR is invalid or not set in
/// the environment." twice per process, which reads like one of our errors. The layer only
/// reorders devices for programs that take the first one; radsplat picks its adapter
/// itself (`WGPU_ADAPTER_NAME`, power preference), so nothing is lost by setting the
/// layer's own off switch `NODEVICE_SELECT=1`. Left alone when the user set
/// `NODEVICE_SELECT` or `MESA_VK_DEVICE_SELECT` (which needs the layer), and wherever
/// `XDG_RUNTIME_DIR` is a directory (the layer can do its work there).
///
/// # Safety
/// Sets a process environment variable: call it before any other thread exists (first
/// thing in `main`), as [`std::env::set_var`] requires.
pub unsafe fn quiet_device_select_layer() {
    let runtime_dir_ok = std::env::var_os("XDG_RUNTIME_DIR")
        .is_some_and(|d| !d.is_empty() && std::path::Path::new(&d).is_dir());
    let user_chose = std::env::var_os("NODEVICE_SELECT").is_some()
        || std::env::var_os("MESA_VK_DEVICE_SELECT").is_some();
    if !runtime_dir_ok && !user_chose {
        // SAFETY: the caller guarantees no other thread runs yet.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}

/// Gives lavapipe (Mesa's Vulkan on the CPU) two compute threads per core instead of
/// one. llvmpipe splits each dispatch statically: every thread takes one contiguous share
/// of the workgroups (`lp_cs_tpool`, Mesa 22.3), so a share that costs more (the
/// workgroups of records that see the open hall), or a core that runs slower for a while,
/// leaves the other threads idle until it ends. With twice the threads the shares are half
/// as large and the kernel runs whichever is left on whichever core is free. Measured on
/// this project's two-core machine (`benches/paired/paired.py`, process wall, against the
/// default of one per core; docs/results.md, "Two lavapipe threads a core"): nave-west
/// 0.86x (20 pairs), nave-sun-17 0.91x, the nave 0.96x, nave-sun-34 0.97x, the Cornell box
/// and the conference room 1.00x, Sponza's west sun at 400x400 1.01x; four per core were
/// slower than two. The same bytes: a workgroup's result does not depend on its thread.
/// Other drivers ignore the variable. Left alone when the user set `LP_NUM_THREADS`; at
/// most llvmpipe's 32.
///
/// # Safety
/// Sets a process environment variable: call it before any other thread exists (first
/// thing in `main`), as [`std::env::set_var`] requires.
pub unsafe fn two_lavapipe_threads_per_core() {
    if std::env::var_os("LP_NUM_THREADS").is_some() {
        return;
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let threads = (2 * cores).min(LAVAPIPE_MAX_THREADS);
    // SAFETY: the caller guarantees no other thread runs yet.
    unsafe { std::env::set_var("LP_NUM_THREADS", threads.to_string()) };
}

/// llvmpipe's most compute threads (`LP_MAX_THREADS`, Mesa 22.3).
const LAVAPIPE_MAX_THREADS: usize = 32;

/// A device and queue radsplat runs on.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    /// Adapter description, when we created the device ourselves.
    pub adapter_info: Option<wgpu::AdapterInfo>,
    /// First uncaptured wgpu error (validation, out of memory) or device loss, if any.
    fault: Arc<Mutex<Option<String>>>,
    /// Shader compilations measured since the last [`GpuContext::take_compile_times`]:
    /// (pass, ms), see [`super::pipeline::ComputePass`].
    pub(crate) compile_times: Arc<Mutex<Vec<(&'static str, f64)>>>,
    /// The driver's pipeline cache, loaded from and saved to disk (headless contexts on
    /// devices with `PIPELINE_CACHE`; None otherwise).
    pub(crate) pipeline_cache: Option<PipelineCacheFile>,
    /// Waits for the device since the last [`GpuContext::take_waits`]: each is a round trip
    /// to the GPU that the host sits out (on a fast GPU they, not the passes, bound a
    /// frame's wall time).
    waits: Arc<std::sync::atomic::AtomicU64>,
    /// Pass timers read later, in one wait ([`GpuContext::deferring_pass_times`]); None:
    /// timers are read when their submission is done.
    pub(crate) deferred_times: Arc<Mutex<Option<Vec<super::timer::DeferredTimes>>>>,
    /// The passes built on this device, by shader, bindings and constants
    /// ([`super::pipeline::ComputePass::with_constants`]).
    pub(crate) built_passes: super::pipeline::BuiltPasses,
    /// Whether passes are timed ([`GpuContext::set_pass_timing`]); shared with the passes,
    /// which read it at each dispatch.
    pub(crate) pass_timing: Arc<std::sync::atomic::AtomicBool>,
    /// Whether every pass's workgroup memory is zeroed, not only that of passes that read
    /// it before writing it ([`GpuContext::set_zero_all_workgroup_memory`]).
    pub(crate) zero_all_workgroup_memory: Arc<std::sync::atomic::AtomicBool>,
    /// Whether the traversal reads triangles from the node texture
    /// ([`GpuContext::triangle_fetch`]).
    pub(crate) triangles_in_texture: std::sync::atomic::AtomicBool,
}

/// A wgpu pipeline cache kept in a file between runs, so a driver that compiles pipelines
/// when they are created (most GPUs) does not compile them again on the next start.
/// The file is `<dir>/<wgpu's cache key for the adapter>.bin`, with `<dir>` from
/// `RADSPLAT_CACHE_DIR` (empty: no cache), else `$XDG_CACHE_HOME/radsplat`, else
/// `$HOME/.cache/radsplat`. wgpu checks the data's header against the device and starts
/// empty when it does not match (`fallback`), so a stale or foreign file only costs a
/// compilation. lavapipe compiles at first dispatch and keeps its own Mesa shader cache,
/// so there the file stays small and changes nothing.
pub struct PipelineCacheFile {
    pub cache: wgpu::PipelineCache,
    path: std::path::PathBuf,
    loaded_bytes: usize,
}

impl PipelineCacheFile {
    /// The cache for `adapter` on `device`, from its file when there is one.
    fn open(device: &wgpu::Device, info: &wgpu::AdapterInfo) -> Option<Self> {
        Self::open_in(device, info, &cache_dir()?)
    }

    /// The cache for `adapter` on `device` kept in `dir` (None where the device has no
    /// pipeline cache or wgpu knows no key for its backend).
    pub fn open_in(
        device: &wgpu::Device,
        info: &wgpu::AdapterInfo,
        dir: &std::path::Path,
    ) -> Option<Self> {
        if !device.features().contains(wgpu::Features::PIPELINE_CACHE) {
            return None;
        }
        let key = wgpu::util::pipeline_cache_key(info)?;
        let path = dir.join(format!("{key}.bin"));
        let data = std::fs::read(&path).ok();
        // SAFETY: the data is what `get_data` of an earlier run wrote for this adapter's
        // key; wgpu validates its header against the device and, with `fallback`, starts
        // an empty cache when it does not fit.
        let cache = unsafe {
            device.create_pipeline_cache(&wgpu::PipelineCacheDescriptor {
                label: Some("radsplat pipelines"),
                data: data.as_deref(),
                fallback: true,
            })
        };
        Some(Self {
            cache,
            path,
            loaded_bytes: data.map_or(0, |d| d.len()),
        })
    }

    /// The file the cache is kept in.
    pub fn path(&self) -> &std::path::Path {
        &self.path
    }

    /// Writes the cache back when it holds more than was loaded (atomically, under a
    /// name unique to this process and call, so that concurrent runs never mix bytes).
    /// Failures only cost the next run a compilation, so they are logged, not returned.
    pub fn save(&self) {
        let Some(data) = self.cache.get_data() else {
            return;
        };
        if data.len() <= self.loaded_bytes {
            return;
        }
        static SAVES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let n = SAVES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let Some(dir) = self.path.parent() else {
            return;
        };
        let tmp = dir.join(format!(".pipelines.{}.{n}.tmp", std::process::id()));
        let result = std::fs::create_dir_all(dir)
            .and_then(|()| std::fs::write(&tmp, &data))
            .and_then(|()| std::fs::rename(&tmp, &self.path));
        if let Err(e) = result {
            let _ = std::fs::remove_file(&tmp);
            log::info!("pipeline cache {} not saved: {e}", self.path.display());
        }
    }
}

/// Where pipeline caches are kept (see [`PipelineCacheFile`]); None: no cache.
fn cache_dir() -> Option<std::path::PathBuf> {
    use std::path::PathBuf;
    if let Some(dir) = std::env::var_os("RADSPLAT_CACHE_DIR") {
        return (!dir.is_empty()).then(|| PathBuf::from(dir));
    }
    if let Some(dir) = std::env::var_os("XDG_CACHE_HOME").filter(|d| !d.is_empty()) {
        return Some(PathBuf::from(dir).join("radsplat"));
    }
    let home = std::env::var_os("HOME").filter(|d| !d.is_empty())?;
    Some(PathBuf::from(home).join(".cache").join("radsplat"))
}

impl Drop for PipelineCacheFile {
    /// Saves the cache for the next run when its context goes.
    fn drop(&mut self) {
        self.save();
    }
}

/// Shadow rays one pass may cast per invocation on llvmpipe (lavapipe). llvmpipe stops
/// running a loop once it has iterated 65,535 times in one invocation, counted over every
/// entry into it, and carries on with whatever the loop had computed: a pixel that traces
/// more rays than that budget of BVH steps allows silently gets misses and unoccluded
/// shadow rays (measured: 4,096 light samples per pixel gave the Cornell box a quarter of
/// its direct light). 256 rays stay below it for BVHs of up to ~250 steps per ray; a
/// plane sample traces its primary ray through the same loop (`trace_and_shade`), and 257
/// rays of 250 steps are still 64,250 iterations.
pub const LLVMPIPE_MAX_SHADOW_RAYS: u32 = 256;

impl GpuContext {
    /// Whether the device is llvmpipe (lavapipe), whose loop limit bounds how many rays one
    /// invocation may trace ([`LLVMPIPE_MAX_SHADOW_RAYS`]). False for devices handed to
    /// [`GpuContext::from_device`] (their adapter is unknown).
    pub fn stops_long_loops(&self) -> bool {
        self.is_llvmpipe() == Some(true)
    }

    /// Whether the adapter is llvmpipe; None for devices handed to
    /// [`GpuContext::from_device`] (their adapter is unknown).
    fn is_llvmpipe(&self) -> Option<bool> {
        self.adapter_info
            .as_ref()
            .map(|i| i.name.to_ascii_lowercase().contains("llvmpipe"))
    }

    /// Whether the driver may compile a pipeline only at its first dispatch (llvmpipe runs
    /// its LLVM JIT then), so that [`super::pipeline::ComputePass`] compiles it by an empty
    /// dispatch first. True also for devices handed to [`GpuContext::from_device`], whose
    /// driver is unknown.
    pub fn compiles_at_first_dispatch(&self) -> bool {
        self.is_llvmpipe() != Some(false)
    }

    /// Refuses `rays` shadow rays per invocation on llvmpipe beyond
    /// [`LLVMPIPE_MAX_SHADOW_RAYS`], naming the setting `field` that asked for them.
    pub fn check_shadow_rays(&self, rays: u64, field: &str) -> Result<()> {
        if self.stops_long_loops() && rays > u64::from(LLVMPIPE_MAX_SHADOW_RAYS) {
            return Err(Error::Usage(format!(
                "{field} asks for up to {rays} shadow rays per pixel; lavapipe (llvmpipe) \
                 silently stops loops after 65,535 iterations per invocation, so at most \
                 {LLVMPIPE_MAX_SHADOW_RAYS} are allowed on it: lower {field}"
            )));
        }
        Ok(())
    }

    /// Creates a headless context on the best adapter. Honours `WGPU_BACKEND` (e.g. `vulkan`),
    /// `WGPU_ADAPTER_NAME` (substring of the adapter name, case-insensitive) and
    /// `WGPU_POWER_PREF`. Runs on lavapipe (Mesa's CPU Vulkan) with no variables set.
    pub fn new() -> Result<Self> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = pick_adapter(&instance)?;
        let info = adapter.get_info();
        log::info!(
            "adapter: {} ({:?}, {:?}, driver {} {})",
            info.name,
            info.backend,
            info.device_type,
            info.driver,
            info.driver_info
        );
        let required = required_limits();
        if let Some(missing) = missing_limit(&adapter.limits(), &required) {
            return Err(Error::Gpu(format!(
                "adapter '{}' lacks a required limit: {missing}",
                info.name
            )));
        }
        // Ask for everything the adapter offers: scene and image sizes are then checked
        // against the real limits instead of the WebGPU defaults.
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("radsplat"),
            required_features: adapter.features() & OPTIONAL_FEATURES,
            required_limits: adapter.limits(),
            ..Default::default()
        }))
        .map_err(|e| Error::Gpu(format!("cannot create a device on '{}': {e}", info.name)))?;
        let ctx = Self::from_device(device, queue);
        let fault = ctx.fault.clone();
        ctx.device
            .on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
                log::error!("wgpu: {e}");
                let mut f = fault.lock().unwrap_or_else(|p| p.into_inner());
                f.get_or_insert_with(|| e.to_string());
            }));
        let pipeline_cache = PipelineCacheFile::open(&ctx.device, &info);
        let is_llvmpipe = info.name.to_ascii_lowercase().contains("llvmpipe");
        ctx.set_triangle_fetch(TriangleFetch::for_adapter(Some(is_llvmpipe)));
        Ok(Self {
            adapter_info: Some(info),
            pipeline_cache,
            ..ctx
        })
    }

    /// Wraps a device and queue owned by an embedding engine. The device must satisfy
    /// [`required_limits`]; radsplat uses [`OPTIONAL_FEATURES`] only where enabled.
    /// Our own errors are caught with error scopes, so the engine's uncaptured-error
    /// handler is left alone; device loss is reported by the next call.
    pub fn from_device(device: wgpu::Device, queue: wgpu::Queue) -> Self {
        let fault = Arc::new(Mutex::new(None::<String>));
        let lost = fault.clone();
        device.set_device_lost_callback(move |reason, msg| {
            let mut f = lost.lock().unwrap_or_else(|p| p.into_inner());
            f.get_or_insert_with(|| format!("device lost ({reason:?}): {msg}"));
        });
        Self {
            device,
            queue,
            adapter_info: None,
            fault,
            compile_times: Arc::default(),
            pipeline_cache: None,
            waits: Arc::default(),
            deferred_times: Arc::default(),
            built_passes: Default::default(),
            pass_timing: Arc::default(),
            zero_all_workgroup_memory: Arc::default(),
            triangles_in_texture: std::sync::atomic::AtomicBool::new(
                TriangleFetch::for_adapter(None) == TriangleFetch::Texture,
            ),
        }
    }

    /// Times each GPU pass (timestamp queries, where the device has `TIMESTAMP_QUERY`) and,
    /// on drivers that compile a pipeline at its first dispatch, that compilation apart
    /// (an empty dispatch of its own, waited for: [`super::pipeline::ComputePass`]). Off
    /// by default: it is a profile, and it costs. On lavapipe each timestamp wakes
    /// llvmpipe's idle rasteriser threads (nave-west: 12,000 context switches a run
    /// against 4,300 untimed) and each compilation adds two waits for the device, about
    /// 6 % of the process's wall time there (docs/results.md, "Passes timed only when
    /// asked"). Untimed frames report no pass times ([`crate::FrameStats::pass_ms`] empty)
    /// and no first-dispatch compilations. The images are the same bytes either way.
    pub fn set_pass_timing(&self, on: bool) {
        self.pass_timing
            .store(on, std::sync::atomic::Ordering::Relaxed);
    }

    /// Zeroes the workgroup memory of every pass built from now on before each workgroup
    /// runs, as WebGPU does by default. Without it, a pass whose only workgroup memory is
    /// written before it is read (the traversal stacks:
    /// [`shader::needs_zeroed_workgroup_memory`](super::shader::needs_zeroed_workgroup_memory))
    /// skips the clearing, which on lavapipe is a `memset` of 24 KiB for each workgroup of
    /// a tracing pass. The images are the same bytes either way (a test renders both);
    /// this is for checking that. Passes already built on this device keep how they were
    /// built, so call it before the first frame.
    pub fn set_zero_all_workgroup_memory(&self, on: bool) {
        self.zero_all_workgroup_memory
            .store(on, std::sync::atomic::Ordering::Relaxed);
    }

    /// Whether every pass built from now on zeroes its workgroup memory
    /// ([`GpuContext::set_zero_all_workgroup_memory`]).
    pub fn zeroes_all_workgroup_memory(&self) -> bool {
        self.zero_all_workgroup_memory
            .load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Where the traversal reads triangles from ([`TriangleFetch`]): chosen for the adapter
    /// when radsplat creates the device ([`TriangleFetch::for_adapter`]), the buffer for a
    /// device handed to [`GpuContext::from_device`].
    pub fn triangle_fetch(&self) -> TriangleFetch {
        if self
            .triangles_in_texture
            .load(std::sync::atomic::Ordering::Relaxed)
        {
            TriangleFetch::Texture
        } else {
            TriangleFetch::Buffer
        }
    }

    /// Sets where the traversal reads triangles from. Scenes uploaded and passes built
    /// afterwards follow it (a pass's pipelines are kept per choice); call it before
    /// uploading the scenes it should render, as a scene uploaded for the buffer has no
    /// triangle texels. The images are the same bytes either way.
    pub fn set_triangle_fetch(&self, fetch: TriangleFetch) {
        self.triangles_in_texture.store(
            fetch == TriangleFetch::Texture,
            std::sync::atomic::Ordering::Relaxed,
        );
    }

    /// Whether passes are timed: [`GpuContext::set_pass_timing`] asked for it and the
    /// device has timestamp queries.
    pub fn times_passes(&self) -> bool {
        self.pass_timing.load(std::sync::atomic::Ordering::Relaxed) && self.has_timestamps()
    }

    /// The shader compilations (pass name, ms) measured since the last call: each pipeline
    /// is compiled once per process, at its first dispatch, and that time is kept out of
    /// the pass times (see [`super::pipeline::ComputePass`]).
    pub fn take_compile_times(&self) -> Vec<(&'static str, f64)> {
        let mut t = self.compile_times.lock().unwrap_or_else(|p| p.into_inner());
        std::mem::take(&mut *t)
    }

    /// Returns the first recorded wgpu error or device loss as an [`Error::Gpu`].
    pub fn check(&self) -> Result<()> {
        let f = self.fault.lock().unwrap_or_else(|p| p.into_inner());
        match f.as_ref() {
            Some(msg) => Err(Error::Gpu(msg.clone())),
            None => Ok(()),
        }
    }

    /// The waits for the device ([`GpuContext::wait`]) since the last call.
    pub fn take_waits(&self) -> u64 {
        self.waits.swap(0, std::sync::atomic::Ordering::Relaxed)
    }

    /// Waits for all submitted work, then reports errors.
    pub fn wait(&self) -> Result<()> {
        self.waits
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| Error::Gpu(format!("waiting for the device: {e}")))?;
        self.check()
    }

    /// Writes the pipeline cache back now (as its drop does; [`PipelineCacheFile::save`]),
    /// for a process that ends without dropping its context.
    pub fn save_pipeline_cache(&self) {
        if let Some(cache) = &self.pipeline_cache {
            cache.save();
        }
    }

    /// The file the pipeline cache is kept in, where there is one.
    pub fn pipeline_cache_path(&self) -> Option<&std::path::Path> {
        self.pipeline_cache.as_ref().map(|c| c.path())
    }

    /// Whether the device has GPU timestamp queries, which per-pass timings use when they
    /// are asked for ([`GpuContext::set_pass_timing`]).
    pub fn has_timestamps(&self) -> bool {
        self.device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
    }

    /// Largest storage buffer binding this device accepts, in bytes.
    pub fn max_binding_size(&self) -> u64 {
        let l = self.device.limits();
        l.max_storage_buffer_binding_size.min(l.max_buffer_size)
    }
}

fn pick_adapter(instance: &wgpu::Instance) -> Result<wgpu::Adapter> {
    if let Ok(wanted) = std::env::var("WGPU_ADAPTER_NAME") {
        let wanted = wanted.to_lowercase();
        let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
        let names: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
        return adapters
            .into_iter()
            .find(|a| a.get_info().name.to_lowercase().contains(&wanted))
            .ok_or_else(|| {
                Error::Gpu(format!(
                    "WGPU_ADAPTER_NAME={wanted}: no such adapter (found: {})",
                    if names.is_empty() {
                        "none".to_string()
                    } else {
                        names.join(", ")
                    }
                ))
            });
    }
    pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference:
            wgpu::PowerPreference::from_env().unwrap_or(wgpu::PowerPreference::HighPerformance),
        ..Default::default()
    }))
    .map_err(|e| {
        Error::Gpu(format!(
            "no GPU adapter found ({e}); on Linux without a GPU install Mesa's lavapipe: \
             apt-get install mesa-vulkan-drivers"
        ))
    })
}

fn missing_limit(have: &wgpu::Limits, need: &wgpu::Limits) -> Option<String> {
    let checks = [
        (
            "max_storage_buffers_per_shader_stage",
            have.max_storage_buffers_per_shader_stage,
            need.max_storage_buffers_per_shader_stage,
        ),
        (
            "max_compute_invocations_per_workgroup",
            have.max_compute_invocations_per_workgroup,
            need.max_compute_invocations_per_workgroup,
        ),
        (
            "max_compute_workgroup_size_x",
            have.max_compute_workgroup_size_x,
            need.max_compute_workgroup_size_x,
        ),
        (
            "max_compute_workgroup_storage_size",
            have.max_compute_workgroup_storage_size,
            need.max_compute_workgroup_storage_size,
        ),
    ];
    checks
        .iter()
        .find(|(_, h, n)| h < n)
        .map(|(name, h, n)| format!("{name} is {h}, radsplat needs {n}"))
}

/// Most rays one invocation traces in one dispatch (a bounce ray and its hit's shadow rays
/// per sample). llvmpipe (lavapipe) stops running a loop once it has iterated 65,535 times
/// in an invocation, summed over every time the loop is entered, and carries on past it:
/// a reference pixel that traced ~900 rays through the Cornell box (~75 BVH steps each)
/// then saw every later bounce miss, which made references of 64 spp x 16 light samples
/// up to 40 % too dark in their indirect light, without any error. 64 rays stay far below
/// the limit for BVHs up to ~1,000 steps per ray.
pub const MAX_RAYS_PER_INVOCATION: u32 = 64;

/// Bounce samples one invocation may take in one dispatch when each also casts
/// `shadow_rays` shadow rays ([`MAX_RAYS_PER_INVOCATION`]; at least 1).
pub fn max_samples_per_dispatch(shadow_rays: u64) -> u32 {
    (u64::from(MAX_RAYS_PER_INVOCATION) / shadow_rays.saturating_add(1)).max(1) as u32
}
