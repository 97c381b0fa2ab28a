//! A compute pipeline for one pass: the scene tables at group 0, the pass's own buffers
//! at group 1.

use super::{GpuContext, scene_buffers::scene_layout, shader};
use crate::{Error, Result};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// How a pass binds one of its own buffers (group 1, bindings in order).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Binding {
    Uniform,
    StorageRead,
    StorageReadWrite,
    /// A `texture_2d<u32>` ([`super::texel_table::TexelTable`]'s view).
    Texels,
}

/// What a pass is built from: its shader, its group-1 bindings and its pipeline constants
/// (by their bits).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
struct PassKey {
    name: &'static str,
    bindings: Vec<Binding>,
    constants: Vec<(String, u64)>,
}

/// The passes [`ComputePass::with_constants`] built on one device: a slot per key, locked while
/// its pass is built (a failed build leaves it empty, for the next asker to try).
#[derive(Default)]
pub(crate) struct BuiltPasses {
    slots: Mutex<HashMap<PassKey, Arc<PassSlot>>>,
}

/// One key's pass, once built.
type PassSlot = Mutex<Option<Arc<ComputePass>>>;

/// A pass (or a group of pipelines) built when it is first asked for: by the frame that
/// needs it, or earlier by a thread building ahead
/// (`Renderer::build_ahead`, in the frame layer). Its pipelines go through
/// [`ComputePass::with_constants`], which builds each once per device, so two threads that
/// ask at once build each pipeline once (the later one waits for it) and keep one of the
/// two small structs.
pub(crate) struct OnFirstUse<T>(std::sync::OnceLock<T>);

impl<T> OnFirstUse<T> {
    pub(crate) fn new() -> Self {
        Self(std::sync::OnceLock::new())
    }

    /// The pass, built by `make` on first use (if two threads race, one build is kept).
    pub(crate) fn get(&self, make: impl FnOnce() -> Result<T>) -> Result<&T> {
        if let Some(pass) = self.0.get() {
            return Ok(pass);
        }
        let pass = make()?;
        Ok(self.0.get_or_init(|| pass))
    }
}

/// What a pass is built from: its shader, its group-1 bindings and its pipeline constants
/// ([`ComputePass::with_constants`]). A thread that holds a recipe can build the pass
/// ahead of the frame that will ask for it: the device keeps it.
#[derive(Clone, Debug)]
pub struct PassRecipe {
    pub name: &'static str,
    pub bindings: Vec<Binding>,
    pub constants: Vec<(&'static str, f64)>,
}

impl PassRecipe {
    /// The pass, built now or found built (once per device).
    pub fn build(&self, ctx: &GpuContext) -> Result<Arc<ComputePass>> {
        ComputePass::with_constants(ctx, self.name, &self.bindings, &self.constants)
    }
}

/// A pass built from its recipe at its first use (or found built, by a thread that built
/// its recipe ahead).
pub struct LazyPass {
    recipe: PassRecipe,
    built: OnFirstUse<Arc<ComputePass>>,
}

impl LazyPass {
    pub fn new(
        name: &'static str,
        bindings: &[Binding],
        constants: &[(&'static str, f64)],
    ) -> Self {
        Self {
            recipe: PassRecipe {
                name,
                bindings: bindings.to_vec(),
                constants: constants.to_vec(),
            },
            built: OnFirstUse::new(),
        }
    }

    /// The pass, built on first use.
    pub fn get(&self, ctx: &GpuContext) -> Result<&Arc<ComputePass>> {
        self.built.get(|| self.recipe.build(ctx))
    }

    /// What it is built from.
    pub fn recipe(&self) -> &PassRecipe {
        &self.recipe
    }
}

/// A compiled compute pass.
///
/// Drivers may compile a pipeline's shader only when it is first dispatched (lavapipe
/// runs its LLVM JIT then: seconds for a tracing pass on a cold shader cache), which would
/// count the compilation as that pass's GPU time. So where passes are timed
/// ([`GpuContext::set_pass_timing`]), the first dispatch of each pipeline is preceded by
/// an empty one (zero workgroups, same bind groups) in a submission of its own, waited for
/// and timed; the time goes to [`GpuContext::take_compile_times`] and the pass times stay
/// those of the work. Later dispatches cost nothing extra. Untimed, the first real
/// dispatch compiles, unmeasured, and nothing waits. Drivers that compile at creation
/// ([`GpuContext::compiles_at_first_dispatch`] false) skip it: there the creation is
/// timed instead.
pub struct ComputePass {
    pub name: &'static str,
    pub pipeline: wgpu::ComputePipeline,
    pub pass_layout: wgpu::BindGroupLayout,
    /// What the first-dispatch compilation needs: the device, queue and the log.
    device: wgpu::Device,
    queue: wgpu::Queue,
    compile_times: std::sync::Arc<std::sync::Mutex<Vec<(&'static str, f64)>>>,
    compiled: std::sync::atomic::AtomicBool,
    /// The context's [`GpuContext::set_pass_timing`] switch.
    timing: std::sync::Arc<std::sync::atomic::AtomicBool>,
    /// Built to read its tables from texel tables (`TABLE_TEXELS`, where the shader
    /// declares it): the pass's caller copies them there.
    texel_tables: bool,
}

impl ComputePass {
    /// The pass of `wgsl/<name>` (entry point `main`) with the given group-1 bindings.
    pub fn new(ctx: &GpuContext, name: &'static str, bindings: &[Binding]) -> Result<Arc<Self>> {
        Self::with_constants(ctx, name, bindings, &[])
    }

    /// [`Self::new`] with values for the shader's pipeline-overridable constants
    /// (`override` in WGSL): the driver compiles the branches they turn off away.
    ///
    /// A pass is built once per device: asked for again with the same shader, bindings and
    /// constants, it is the one built first (concurrent askers wait for it). So the record
    /// passes of tail fill's coarser planes, of radiance records and of temporal caching,
    /// and temporal caching's stages for each kind of record, share the frame's pipelines:
    /// lavapipe spent 0.05-0.2 s creating and compiling each copy, often in the middle of
    /// a frame (docs/results.md, stop 59).
    pub fn with_constants(
        ctx: &GpuContext,
        name: &'static str,
        bindings: &[Binding],
        constants: &[(&str, f64)],
    ) -> Result<Arc<Self>> {
        // The device's constants are in the key too: a pass is built again when they change
        // (GpuContext::set_triangle_fetch).
        let device_constants = device_constants(ctx);
        let key = PassKey {
            name,
            bindings: bindings.to_vec(),
            constants: constants
                .iter()
                .chain(&device_constants)
                .map(|&(k, v)| (k.to_string(), v.to_bits()))
                .collect(),
        };
        let slot = ctx
            .built_passes
            .slots
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .entry(key)
            .or_default()
            .clone();
        let mut built = slot.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(pass) = built.as_ref() {
            return Ok(Arc::clone(pass));
        }
        let pass = Arc::new(Self::build(ctx, name, bindings, constants)?);
        *built = Some(Arc::clone(&pass));
        Ok(pass)
    }

    /// Creates the pipeline of [`Self::with_constants`].
    fn build(
        ctx: &GpuContext,
        name: &'static str,
        bindings: &[Binding],
        constants: &[(&str, f64)],
    ) -> Result<Self> {
        let device = &ctx.device;
        let t0 = std::time::Instant::now();
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let pass_module = shader::module(device, name, constants, &device_constants(ctx))?;
        let module = pass_module.module;
        let entries: Vec<_> = bindings
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupLayoutEntry {
                binding: i as u32,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: match b {
                    Binding::Texels => wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Uint,
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    buffer => wgpu::BindingType::Buffer {
                        ty: match buffer {
                            Binding::Uniform => wgpu::BufferBindingType::Uniform,
                            Binding::StorageRead => {
                                wgpu::BufferBindingType::Storage { read_only: true }
                            }
                            _ => wgpu::BufferBindingType::Storage { read_only: false },
                        },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                },
                count: None,
            })
            .collect();
        let pass_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(name),
            entries: &entries,
        });
        let scene = scene_layout(device);
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(name),
            bind_group_layouts: &[Some(&scene), Some(&pass_layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(name),
            layout: Some(&layout),
            module: &module,
            entry_point: Some("main"),
            // The module is already specialised for the constants (shader::module). Its
            // workgroup memory is zeroed unless every invocation writes it before reading
            // it (`shader::needs_zeroed_workgroup_memory`).
            compilation_options: wgpu::PipelineCompilationOptions {
                zero_initialize_workgroup_memory: pass_module.zeroed_workgroup_memory
                    || ctx.zeroes_all_workgroup_memory(),
                ..Default::default()
            },
            cache: ctx.pipeline_cache.as_ref().map(|c| &c.cache),
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Gpu(format!("creating pass {name}: {e}")));
        }
        // Drivers that compile when the pipeline is created (every GPU driver we ran on)
        // have compiled it now: its creation is the compilation, and the empty first
        // dispatch, two waits for the device, would only cost launch latency.
        let lazy = ctx.compiles_at_first_dispatch();
        if !lazy {
            ctx.compile_times
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .push((name, t0.elapsed().as_secs_f64() * 1e3));
        }
        Ok(Self {
            name,
            pipeline,
            pass_layout,
            device: ctx.device.clone(),
            queue: ctx.queue.clone(),
            compile_times: ctx.compile_times.clone(),
            compiled: std::sync::atomic::AtomicBool::new(!lazy),
            timing: ctx.pass_timing.clone(),
            texel_tables: ctx.triangle_fetch() == super::TriangleFetch::Texture,
        })
    }

    /// Compiles the pipeline by an empty dispatch before its first real one, timed on the
    /// CPU from submit to completion after the queue went idle (see the type's doc).
    fn compile_once(&self, scene: &wgpu::BindGroup, pass: &wgpu::BindGroup) {
        if self
            .compiled
            .swap(true, std::sync::atomic::Ordering::Relaxed)
        {
            return;
        }
        // Untimed, the dispatch about to be recorded compiles it (and it counts as
        // compiled from now on: a later timed dispatch finds nothing to compile).
        if !self.timing.load(std::sync::atomic::Ordering::Relaxed) {
            return;
        }
        // Work submitted earlier must not count: wait for it first. A failure here (device
        // loss) shows up again, with its message, where the frame waits for its work.
        let _ = self.device.poll(wgpu::PollType::wait_indefinitely());
        let t0 = std::time::Instant::now();
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some(self.name),
            });
        {
            let mut cpass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(self.name),
                timestamp_writes: None,
            });
            cpass.set_pipeline(&self.pipeline);
            cpass.set_bind_group(0, scene, &[]);
            cpass.set_bind_group(1, pass, &[]);
            cpass.dispatch_workgroups(0, 0, 0);
        }
        self.queue.submit([encoder.finish()]);
        let _ = self.device.poll(wgpu::PollType::wait_indefinitely());
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        self.compile_times
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .push((self.name, ms));
    }

    /// Whether a pass that declares `TABLE_TEXELS` reads its tables from texel tables
    /// ([`super::texel_table`]), as the device said when it was built.
    pub fn reads_texel_tables(&self) -> bool {
        self.texel_tables
    }

    /// Binds `buffers` (in binding order) for this pass.
    pub fn bind(&self, ctx: &GpuContext, buffers: &[&wgpu::Buffer]) -> wgpu::BindGroup {
        let resources: Vec<_> = buffers.iter().map(|b| b.as_entire_binding()).collect();
        self.bind_resources(ctx, &resources)
    }

    /// Binds `resources` (in binding order) for this pass: buffers and texel tables.
    pub fn bind_resources(
        &self,
        ctx: &GpuContext,
        resources: &[wgpu::BindingResource<'_>],
    ) -> wgpu::BindGroup {
        let entries: Vec<_> = resources
            .iter()
            .enumerate()
            .map(|(i, r)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: r.clone(),
            })
            .collect();
        ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(self.name),
            layout: &self.pass_layout,
            entries: &entries,
        })
    }

    /// Records one dispatch into `encoder`.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        scene: &wgpu::BindGroup,
        pass: &wgpu::BindGroup,
        groups: [u32; 3],
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        self.begin(encoder, scene, pass, timestamps)
            .dispatch_workgroups(groups[0], groups[1], groups[2]);
    }

    /// Records one dispatch into `encoder` whose workgroup counts an earlier pass wrote
    /// into `groups` (three u32, x y z; the buffer has `INDIRECT` usage).
    pub fn record_indirect(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        scene: &wgpu::BindGroup,
        pass: &wgpu::BindGroup,
        groups: &wgpu::Buffer,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        self.begin(encoder, scene, pass, timestamps)
            .dispatch_workgroups_indirect(groups, 0);
    }

    /// A compute pass in `encoder` with this pipeline and its two bind groups set.
    fn begin<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        scene: &wgpu::BindGroup,
        pass: &wgpu::BindGroup,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> wgpu::ComputePass<'e> {
        self.compile_once(scene, pass);
        let mut cpass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(self.name),
            timestamp_writes: timestamps,
        });
        cpass.set_pipeline(&self.pipeline);
        cpass.set_bind_group(0, scene, &[]);
        cpass.set_bind_group(1, pass, &[]);
        cpass
    }
}

/// Workgroup counts covering a `width x height` image with 8x8 groups.
pub fn image_groups(width: u32, height: u32) -> [u32; 3] {
    [width.div_ceil(8), height.div_ceil(8), 1]
}

/// Workgroups for `n` invocations of 256, split over y past the per-dimension limit
/// (`flat_index`, wgsl/shared/linear_dispatch.wgsl).
pub fn linear_groups(ctx: &GpuContext, n: u32) -> [u32; 3] {
    split_groups(ctx, n.div_ceil(256))
}

/// `groups` workgroups (at least one), split over y past the per-dimension limit: a shader
/// numbers them `group.y * groups.x + group.x`.
pub fn split_groups(ctx: &GpuContext, groups: u32) -> [u32; 3] {
    let groups = groups.max(1);
    let max = ctx.device.limits().max_compute_workgroups_per_dimension;
    if groups <= max {
        [groups, 1, 1]
    } else {
        [max, groups.div_ceil(max), 1]
    }
}

/// The constants every pass that declares them is built with, from the device's settings:
/// where the traversal reads triangles ([`super::TriangleFetch`]), and, by the same
/// choice, whether the passes that read a table many times a lane read its texel table
/// ([`super::texel_table`]).
fn device_constants(ctx: &GpuContext) -> [(&'static str, f64); 2] {
    let fetch = ctx.triangle_fetch().constant();
    [
        (super::triangle_fetch::TRIANGLE_TEXELS_CONSTANT, fetch),
        (super::texel_table::TABLE_TEXELS_CONSTANT, fetch),
    ]
}
