//! WGSL sources and their composition.
//!
//! WGSL has no include mechanism, so shared code (`wgsl/shared/*.wgsl`: ray, BVH
//! traversal, sampling, scene bindings, shading) is written once and spliced into each pass
//! by `//!include <name>` lines. Every source is embedded in the binary at compile time.

use crate::{Error, Result};

/// All WGSL files, by the name used in `//!include` lines and [`compose`].
const SOURCES: &[(&str, &str)] = &[
    (
        "shared/ray.wgsl",
        include_str!("../../wgsl/shared/ray.wgsl"),
    ),
    (
        "shared/scene.wgsl",
        include_str!("../../wgsl/shared/scene.wgsl"),
    ),
    (
        "shared/bvh.wgsl",
        include_str!("../../wgsl/shared/bvh.wgsl"),
    ),
    (
        "shared/sampling.wgsl",
        include_str!("../../wgsl/shared/sampling.wgsl"),
    ),
    (
        "shared/shading.wgsl",
        include_str!("../../wgsl/shared/shading.wgsl"),
    ),
    (
        "shared/camera.wgsl",
        include_str!("../../wgsl/shared/camera.wgsl"),
    ),
    (
        "shared/glossy.wgsl",
        include_str!("../../wgsl/shared/glossy.wgsl"),
    ),
    (
        "shared/environment.wgsl",
        include_str!("../../wgsl/shared/environment.wgsl"),
    ),
    (
        "shared/glossy_bounce.wgsl",
        include_str!("../../wgsl/shared/glossy_bounce.wgsl"),
    ),
    (
        "visibility.wgsl",
        include_str!("../../wgsl/visibility.wgsl"),
    ),
    (
        "direct_light.wgsl",
        include_str!("../../wgsl/direct_light.wgsl"),
    ),
    (
        "glossy_indirect.wgsl",
        include_str!("../../wgsl/glossy_indirect.wgsl"),
    ),
    (
        "radiance_project.wgsl",
        include_str!("../../wgsl/radiance_project.wgsl"),
    ),
    (
        "radiance_limit.wgsl",
        include_str!("../../wgsl/radiance_limit.wgsl"),
    ),
    (
        "radiance_need.wgsl",
        include_str!("../../wgsl/radiance_need.wgsl"),
    ),
    (
        "radiance_gather.wgsl",
        include_str!("../../wgsl/radiance_gather.wgsl"),
    ),
    (
        "shared/radiance_records.wgsl",
        include_str!("../../wgsl/shared/radiance_records.wgsl"),
    ),
    (
        "shared/records.wgsl",
        include_str!("../../wgsl/shared/records.wgsl"),
    ),
    (
        "shared/corral.wgsl",
        include_str!("../../wgsl/shared/corral.wgsl"),
    ),
    (
        "shared/record_hessian.wgsl",
        include_str!("../../wgsl/shared/record_hessian.wgsl"),
    ),
    (
        "record_sites.wgsl",
        include_str!("../../wgsl/record_sites.wgsl"),
    ),
    (
        "hemisphere_plane.wgsl",
        include_str!("../../wgsl/hemisphere_plane.wgsl"),
    ),
    (
        "plane_refine_combine.wgsl",
        include_str!("../../wgsl/plane_refine_combine.wgsl"),
    ),
    (
        "shared/plane_refine_items.wgsl",
        include_str!("../../wgsl/shared/plane_refine_items.wgsl"),
    ),
    (
        "shared/refine_selection.wgsl",
        include_str!("../../wgsl/shared/refine_selection.wgsl"),
    ),
    (
        "plane_reproject.wgsl",
        include_str!("../../wgsl/plane_reproject.wgsl"),
    ),
    (
        "shared/reprojection.wgsl",
        include_str!("../../wgsl/shared/reprojection.wgsl"),
    ),
    (
        "shared/plane_direction.wgsl",
        include_str!("../../wgsl/shared/plane_direction.wgsl"),
    ),
    (
        "shared/texel_table.wgsl",
        include_str!("../../wgsl/shared/texel_table.wgsl"),
    ),
    (
        "shared/plane_texels.wgsl",
        include_str!("../../wgsl/shared/plane_texels.wgsl"),
    ),
    (
        "shared/plane.wgsl",
        include_str!("../../wgsl/shared/plane.wgsl"),
    ),
    (
        "shared/movers.wgsl",
        include_str!("../../wgsl/shared/movers.wgsl"),
    ),
    (
        "shared/work_list.wgsl",
        include_str!("../../wgsl/shared/work_list.wgsl"),
    ),
    (
        "shared/work_items.wgsl",
        include_str!("../../wgsl/shared/work_items.wgsl"),
    ),
    (
        "plane_refresh.wgsl",
        include_str!("../../wgsl/plane_refresh.wgsl"),
    ),
    (
        "plane_retrace.wgsl",
        include_str!("../../wgsl/plane_retrace.wgsl"),
    ),
    (
        "plane_reshade.wgsl",
        include_str!("../../wgsl/plane_reshade.wgsl"),
    ),
    (
        "plane_fill.wgsl",
        include_str!("../../wgsl/plane_fill.wgsl"),
    ),
    (
        "shared/trace_and_shade.wgsl",
        include_str!("../../wgsl/shared/trace_and_shade.wgsl"),
    ),
    (
        "shared/light_map.wgsl",
        include_str!("../../wgsl/shared/light_map.wgsl"),
    ),
    (
        "shared/light_map_lookup.wgsl",
        include_str!("../../wgsl/shared/light_map_lookup.wgsl"),
    ),
    (
        "shared/lit_grid.wgsl",
        include_str!("../../wgsl/shared/lit_grid.wgsl"),
    ),
    (
        "shared/lit_grid_query.wgsl",
        include_str!("../../wgsl/shared/lit_grid_query.wgsl"),
    ),
    (
        "lit_grid_reduce.wgsl",
        include_str!("../../wgsl/lit_grid_reduce.wgsl"),
    ),
    (
        "light_map_trace.wgsl",
        include_str!("../../wgsl/light_map_trace.wgsl"),
    ),
    (
        "shared/bounce_cache.wgsl",
        include_str!("../../wgsl/shared/bounce_cache.wgsl"),
    ),
    (
        "bounce_gather.wgsl",
        include_str!("../../wgsl/bounce_gather.wgsl"),
    ),
    (
        "shared/vpl.wgsl",
        include_str!("../../wgsl/shared/vpl.wgsl"),
    ),
    (
        "shared/light_paths.wgsl",
        include_str!("../../wgsl/shared/light_paths.wgsl"),
    ),
    ("vpl_trace.wgsl", include_str!("../../wgsl/vpl_trace.wgsl")),
    (
        "photon_trace.wgsl",
        include_str!("../../wgsl/photon_trace.wgsl"),
    ),
    (
        "photon_reduce.wgsl",
        include_str!("../../wgsl/photon_reduce.wgsl"),
    ),
    (
        "vpl_gather.wgsl",
        include_str!("../../wgsl/vpl_gather.wgsl"),
    ),
    (
        "vpl_update_select.wgsl",
        include_str!("../../wgsl/vpl_update_select.wgsl"),
    ),
    (
        "vpl_update_trace.wgsl",
        include_str!("../../wgsl/vpl_update_trace.wgsl"),
    ),
    (
        "plane_refine_select.wgsl",
        include_str!("../../wgsl/plane_refine_select.wgsl"),
    ),
    (
        "record_reduce.wgsl",
        include_str!("../../wgsl/record_reduce.wgsl"),
    ),
    (
        "shared/splat.wgsl",
        include_str!("../../wgsl/shared/splat.wgsl"),
    ),
    (
        "splat_bin_count.wgsl",
        include_str!("../../wgsl/splat_bin_count.wgsl"),
    ),
    (
        "shared/linear_dispatch.wgsl",
        include_str!("../../wgsl/shared/linear_dispatch.wgsl"),
    ),
    (
        "shared/neighbour_grid.wgsl",
        include_str!("../../wgsl/shared/neighbour_grid.wgsl"),
    ),
    (
        "neighbour_grid_count.wgsl",
        include_str!("../../wgsl/neighbour_grid_count.wgsl"),
    ),
    (
        "prefix_sum.wgsl",
        include_str!("../../wgsl/prefix_sum.wgsl"),
    ),
    (
        "neighbour_grid_scatter.wgsl",
        include_str!("../../wgsl/neighbour_grid_scatter.wgsl"),
    ),
    (
        "splat_bin_scatter.wgsl",
        include_str!("../../wgsl/splat_bin_scatter.wgsl"),
    ),
    (
        "splat_bin_sort.wgsl",
        include_str!("../../wgsl/splat_bin_sort.wgsl"),
    ),
    (
        "shared/splat_weight.wgsl",
        include_str!("../../wgsl/shared/splat_weight.wgsl"),
    ),
    (
        "shared/splat_pixel.wgsl",
        include_str!("../../wgsl/shared/splat_pixel.wgsl"),
    ),
    (
        "splat_fill.wgsl",
        include_str!("../../wgsl/splat_fill.wgsl"),
    ),
    (
        "splat_consistency.wgsl",
        include_str!("../../wgsl/splat_consistency.wgsl"),
    ),
    (
        "splat_tile_bounds.wgsl",
        include_str!("../../wgsl/splat_tile_bounds.wgsl"),
    ),
    (
        "splat_block_bounds.wgsl",
        include_str!("../../wgsl/splat_block_bounds.wgsl"),
    ),
    (
        "splat_bin_tiles.wgsl",
        include_str!("../../wgsl/splat_bin_tiles.wgsl"),
    ),
    (
        "splat_cover.wgsl",
        include_str!("../../wgsl/splat_cover.wgsl"),
    ),
    (
        "shared/tile_walk.wgsl",
        include_str!("../../wgsl/shared/tile_walk.wgsl"),
    ),
    (
        "splat_cover_by_record.wgsl",
        include_str!("../../wgsl/splat_cover_by_record.wgsl"),
    ),
    (
        "coverage_count.wgsl",
        include_str!("../../wgsl/coverage_count.wgsl"),
    ),
    (
        "splat_gather.wgsl",
        include_str!("../../wgsl/splat_gather.wgsl"),
    ),
    ("resolve.wgsl", include_str!("../../wgsl/resolve.wgsl")),
    (
        "placement_select.wgsl",
        include_str!("../../wgsl/placement_select.wgsl"),
    ),
    (
        "reference_indirect.wgsl",
        include_str!("../../wgsl/reference_indirect.wgsl"),
    ),
    (
        "trace_rays.wgsl",
        include_str!("../../wgsl/trace_rays.wgsl"),
    ),
];

fn source(name: &str) -> Result<&'static str> {
    SOURCES
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, s)| *s)
        .ok_or_else(|| Error::Gpu(format!("internal: no WGSL source named {name}")))
}

/// The passes (every WGSL source outside `shared/`), by file name.
pub fn passes() -> impl Iterator<Item = &'static str> {
    SOURCES
        .iter()
        .map(|(n, _)| *n)
        .filter(|n| !n.starts_with("shared/"))
}

/// Returns the full WGSL text of a pass with its includes expanded (each file once).
pub fn compose(name: &str) -> Result<String> {
    super::wgsl_compose::compose_with(name, &|n: &str| {
        source(n).map_err(|_| format!("internal: no WGSL source named {n}"))
    })
    .map_err(Error::Gpu)
}

/// Compiles a composed pass into a shader module specialised for `constants` (its
/// pipeline-overridable constants; those not named keep their defaults), turning WGSL errors
/// into [`Error::Gpu`].
///
/// The module handed to the device has its overrides replaced by their values, every branch
/// those values decide removed, and the functions only such branches called dropped
/// ([`super::specialise::specialise`]): a driver converts and optimises the whole module
/// it is given before it folds a constant. The pipeline is then created with no constants.
///
/// `device_constants` are the device's own (the triangle fetch,
/// [`super::triangle_fetch::TRIANGLE_TEXELS_CONSTANT`]): each applies to the passes that
/// declare it, where `constants` must all be declared.
pub fn module(
    device: &wgpu::Device,
    name: &str,
    constants: &[(&str, f64)],
    device_constants: &[(&str, f64)],
) -> Result<PassModule> {
    let (parsed, info) = parsed_module(name)?;
    let mut all = constants.to_vec();
    all.extend(device_constants.iter().filter(|(key, _)| {
        parsed
            .overrides
            .iter()
            .any(|(_, o)| o.name.as_deref() == Some(key))
    }));
    let specialised = super::specialise::specialise(&parsed, &info, &all)
        .map_err(|e| Error::Gpu(format!("{name}: {e}")))?;
    let zeroed_workgroup_memory = needs_zeroed_workgroup_memory(&specialised);
    // The module itself, not WGSL text, which wgpu would parse again (wgpu still validates
    // it against the device's own capabilities).
    let descriptor = wgpu::ShaderModuleDescriptor {
        label: Some(name),
        source: wgpu::ShaderSource::Naga(std::borrow::Cow::Owned(specialised)),
    };
    // SAFETY: the checks kept are wgpu's defaults; the one dropped, `force_loop_bounding`,
    // requires that no loop runs forever, and none of ours does (`RUNTIME_CHECKS`).
    let module = unsafe { device.create_shader_module_trusted(descriptor, RUNTIME_CHECKS) };
    Ok(PassModule {
        module,
        zeroed_workgroup_memory,
    })
}

/// A pass's shader module, and whether its pipeline must zero its workgroup memory.
pub struct PassModule {
    pub module: wgpu::ShaderModule,
    /// False where the pass's only workgroup memory is the traversal stacks
    /// ([`needs_zeroed_workgroup_memory`]).
    pub zeroed_workgroup_memory: bool,
}

/// The workgroup variables a pass may leave unzeroed: each invocation writes an entry of
/// them before it reads it. `bvh_stacks` (wgsl/shared/bvh.wgsl): a traversal pushes an
/// entry before it pops it (the stack pointer starts at 0 in every traversal), and
/// nothing else touches them. A test keeps this list in step with `wgsl/`.
pub const WORKGROUP_VARIABLES_WRITTEN_FIRST: &[&str] = &["bvh_stacks"];

/// Whether a pipeline of `module` must have its workgroup memory zeroed before each
/// workgroup (WebGPU's rule, and wgpu's default): true unless every workgroup variable
/// the module keeps is written before it is read
/// ([`WORKGROUP_VARIABLES_WRITTEN_FIRST`]).
///
/// Zeroing is not free on a CPU device: lavapipe clears a workgroup's memory with a
/// `memset` before it runs, 24 KiB of traversal stacks for each workgroup of a tracing
/// pass. On nave-west that was 0.81 G of the render's 9.19 G instructions under callgrind
/// (`rep stosb` counts each byte there), about 0.6 % of its CPU samples under `perf`, for
/// memory no invocation reads before writing it.
pub fn needs_zeroed_workgroup_memory(module: &naga::Module) -> bool {
    module.global_variables.iter().any(|(_, var)| {
        var.space == naga::AddressSpace::WorkGroup
            && !var
                .name
                .as_deref()
                .is_some_and(|n| WORKGROUP_VARIABLES_WRITTEN_FIRST.contains(&n))
    })
}

/// The runtime checks wgpu compiles into radsplat's shaders: all of its defaults (bounds,
/// integer division) but the counter it otherwise adds to every loop
/// (`force_loop_bounding`), which guards against a driver that assumes loops end meeting a
/// shader whose loop does not.
///
/// The counter is code in every loop, the traversal's included: without it lavapipe
/// started nave-west in 0.83x the time, traced its incoherent rays in 0.93x and ran the
/// whole render in 0.96x (8 alternating pairs, the same bytes; docs/results.md, "Loops
/// without wgpu's counters"). Leaving out the integer division guards as well gained
/// nothing more, so they stay. A test keeps the list of loops below in step with
/// `wgsl/`.
///
/// Every loop in `wgsl/` ends, whatever the data. Each is one of:
/// - a count up to a bound fixed before it starts (`for` over pixels, lights, slots, rings,
///   histogram bins, the halvings of a reduction, the bits of an index, placement's parity
///   classes);
/// - a bisection whose interval shrinks each time round (`env_invert`);
/// - a walk that moves on by at least one entry each time round and stops at the list's
///   end (`shadow_loop_next` over samples and lights, the refinement selection's bin walks);
/// - the BVH traversal, which pops an entry or descends into a child each time round, over
///   a tree of finite depth whose stack is clamped to its size (a ray with NaNs misses every
///   box, pushes nothing and ends when its stack is empty);
/// - the neighbour-grid search, whose ring grows each time round up to the grid's extent.
///
/// A new loop must be one of these, or count its iterations itself. (lavapipe, besides,
/// ends any loop after 65,535 iterations.)
pub(crate) const RUNTIME_CHECKS: wgpu::ShaderRuntimeChecks = wgpu::ShaderRuntimeChecks {
    force_loop_bounding: false,
    ..wgpu::ShaderRuntimeChecks::checked()
};

/// The naga module of pass `name` specialised for `constants` ([`module`]). It starts from
/// the module `build.rs` parsed and validated (embedded, [`parsed_module`]); wgpu validates
/// the result against the device when the shader module is created.
pub fn specialised_module(name: &str, constants: &[(&str, f64)]) -> Result<naga::Module> {
    let (parsed, info) = parsed_module(name)?;
    super::specialise::specialise(&parsed, &info, constants)
        .map_err(|e| Error::Gpu(format!("{name}: {e}")))
}

/// Each pass's module as `build.rs` parsed and validated it.
mod parsed {
    include!(concat!(env!("OUT_DIR"), "/parsed_passes.rs"));
}

/// Pass `name`'s parsed module and its validation info: the build's (deserialising it takes
/// a twentieth of parsing the WGSL: 0.26 against 4.5 ms for the hemisphere plane), else the
/// embedded WGSL parsed and validated now.
pub fn parsed_module(name: &str) -> Result<(naga::Module, naga::valid::ModuleInfo)> {
    if let Some((_, bytes)) = parsed::PARSED_PASSES.iter().find(|(n, _)| *n == name) {
        if let Ok(parsed) = postcard::from_bytes(bytes) {
            return Ok(parsed);
        }
    }
    let text = compose(name)?;
    // Validate with naga first: its messages name the line, wgpu's uncaptured error would not.
    let parsed = naga::front::wgsl::parse_str(&text)
        .map_err(|e| Error::Gpu(format!("{name}: {}", e.emit_to_string(&text))))?;
    let info = validator()
        .validate(&parsed)
        .map_err(|e| Error::Gpu(format!("{name}: {}", e.emit_to_string(&text))))?;
    Ok((parsed, info))
}

pub(crate) fn validator() -> naga::valid::Validator {
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shaders are compiled without wgpu's loop counters ([`RUNTIME_CHECKS`]), whose doc
    /// argues why each `loop` and `while` in `wgsl/` ends whatever the data. A loop added,
    /// or one removed, fails here until it is checked against that argument and this list.
    #[test]
    fn every_loop_without_a_fixed_count_is_one_runtime_checks_argues_ends() {
        let expected: &[(&str, usize)] = &[
            ("bounce_gather.wgsl", 1),          // a row walk up to n
            ("direct_light.wgsl", 1),           // shadow_loop_next
            ("placement_select.wgsl", 1),       // parity classes, up to the fourth
            ("plane_refine_select.wgsl", 2),    // bin walks, each bounded by its last bin
            ("record_reduce.wgsl", 1),          // the neighbour grid's rings
            ("shared/bvh.wgsl", 2),             // the traversal and its inner-node loop
            ("shared/environment.wgsl", 1),     // bisection of the CDF
            ("shared/lit_grid_query.wgsl", 1),  // levels up to the pyramid's top
            ("shared/sampling.wgsl", 1),        // the bits of an index
            ("shared/shading.wgsl", 3),         // light choice and shadow-sample walks
            ("shared/trace_and_shade.wgsl", 2), // ray then shadow rays; shadow_loop_next
        ];
        let mut found: Vec<(&str, usize)> = SOURCES
            .iter()
            .map(|(name, text)| {
                let loops = text
                    .lines()
                    .map(|l| l.split("//").next().unwrap_or(""))
                    .filter(|code| code.contains("loop {") || code.contains("while "))
                    .count();
                (*name, loops)
            })
            .filter(|(_, n)| *n > 0)
            .collect();
        found.sort();
        assert_eq!(
            found, expected,
            "a `loop` or `while` was added to or removed from wgsl/: check that it ends \
             whatever the data (gpu::shader::RUNTIME_CHECKS) and update this list"
        );
    }

    /// A pass leaves its workgroup memory unzeroed only where every variable in it is one
    /// [`WORKGROUP_VARIABLES_WRITTEN_FIRST`] argues is written before it is read: the
    /// traversal stacks, which only `shared/bvh.wgsl` touches (its pushes and pops). Every
    /// tracing pass skips the
    /// zeroing, every other pass with workgroup memory keeps it (it is small). A workgroup
    /// variable added to a tracing pass, or the stacks read elsewhere, fails here until
    /// checked against that argument.
    #[test]
    fn workgroup_memory_is_left_unzeroed_only_where_it_is_written_first() {
        assert_eq!(WORKGROUP_VARIABLES_WRITTEN_FIRST, &["bvh_stacks"]);
        for (name, text) in SOURCES.iter() {
            if *name == "shared/bvh.wgsl" {
                continue;
            }
            assert!(
                !text.contains("bvh_stacks"),
                "{name} reads or writes the traversal stacks outside shared/bvh.wgsl"
            );
        }
        let mut unzeroed = Vec::new();
        for name in passes() {
            let (module, _) = parsed_module(name).expect("parse");
            let tracing = compose(name).expect("compose").contains("fn trace(");
            let zeroed = needs_zeroed_workgroup_memory(&module);
            let workgroup_memory = module
                .global_variables
                .iter()
                .any(|(_, v)| v.space == naga::AddressSpace::WorkGroup);
            assert!(
                !(tracing && zeroed),
                "{name}: a tracing pass's only workgroup memory must be the traversal stacks"
            );
            if !tracing && workgroup_memory {
                assert!(
                    zeroed,
                    "{name}: a pass that does not trace keeps its memory zeroed"
                );
            }
            if tracing {
                unzeroed.push(name);
            }
        }
        assert!(
            unzeroed.contains(&"hemisphere_plane.wgsl") && unzeroed.len() >= 9,
            "passes left unzeroed: {unzeroed:?}"
        );
    }

    /// The plane pass has no barrier: lavapipe runs a shader with one as coroutines, and the
    /// planes' rays took 1.10x the instructions so (nave-west, refinement off); the
    /// refinement's sums are a pass of their own (`plane_refine_combine.wgsl`).
    #[test]
    fn the_plane_pass_has_no_barrier() {
        let text = compose("hemisphere_plane.wgsl").expect("compose");
        assert!(!text.contains("Barrier("), "a barrier in the plane pass");
        assert!(compose("plane_refine_combine.wgsl").is_ok());
    }

    /// Every pass that can trace rays gives each invocation its own slice of the workgroup's
    /// traversal stacks before tracing (else invocations would share slice 0 and corrupt
    /// each other's traversal) and runs the 64 invocations the stacks are sized for.
    #[test]
    fn every_tracing_pass_has_its_own_traversal_stack() {
        use crate::gpu::context::TRACING_WORKGROUP_INVOCATIONS as N;
        let bvh = source("shared/bvh.wgsl").expect("bvh.wgsl");
        let stacks = N * crate::bvh::TRAVERSAL_STACK;
        assert!(
            bvh.contains(&format!("var<workgroup> bvh_stacks: array<u32, {stacks}>;"))
                && bvh.contains(&format!("const BVH_WORKGROUP_INVOCATIONS: u32 = {N}u;")),
            "bvh.wgsl's stack array must hold {N} x {} entries",
            crate::bvh::TRAVERSAL_STACK
        );
        let mut tracing = Vec::new();
        for (name, _) in SOURCES.iter().filter(|(n, _)| !n.starts_with("shared/")) {
            let text = compose(name).expect("compose");
            // Every pass that includes the traversal (the shading code calls it), whether
            // its entry point traces or not: the rule is then plain to keep.
            if !text.contains("fn trace(") {
                continue;
            }
            tracing.push(*name);
            let own = source(name).expect("pass source");
            assert!(
                own.contains("bvh_stack_init(lane);"),
                "{name} never calls bvh_stack_init"
            );
            let size = own
                .split("@workgroup_size(")
                .nth(1)
                .and_then(|r| r.split(')').next())
                .expect("workgroup size");
            let invocations: u32 = size
                .split(',')
                .map(|d| d.trim().parse::<u32>().expect("literal size"))
                .product();
            assert_eq!(invocations, N, "{name}: @workgroup_size({size})");
        }
        assert!(tracing.len() >= 9, "tracing passes found: {tracing:?}");
    }

    /// Every tracing pass declares the triangle fetch's constant (so the device's choice
    /// reaches its traversal), and specialises and validates with the triangles read from
    /// the node texture, alone and with every pass constant at its default; a pass that does
    /// not trace declares no such constant and is built without it.
    #[test]
    fn every_tracing_pass_specialises_for_triangles_from_the_node_texture() {
        use crate::gpu::triangle_fetch::{TRIANGLE_TEXELS_CONSTANT, TriangleFetch};
        let mut tracing = 0;
        for (name, _) in SOURCES.iter().filter(|(n, _)| !n.starts_with("shared/")) {
            let text = compose(name).expect("compose");
            let (parsed, _) = parsed_module(name).expect("parsed");
            let declares = parsed
                .overrides
                .iter()
                .any(|(_, o)| o.name.as_deref() == Some(TRIANGLE_TEXELS_CONSTANT));
            assert_eq!(
                declares,
                text.contains("fn trace("),
                "{name}: declares {TRIANGLE_TEXELS_CONSTANT} exactly when it traces"
            );
            if !declares {
                continue;
            }
            tracing += 1;
            let constant = [(TRIANGLE_TEXELS_CONSTANT, TriangleFetch::Texture.constant())];
            let module =
                specialised_module(name, &constant).unwrap_or_else(|e| panic!("{name}: {e}"));
            validator()
                .validate(&module)
                .unwrap_or_else(|e| panic!("{name} with triangle texels: {e:?}"));
        }
        assert!(tracing >= 9, "tracing passes: {tracing}");
    }

    /// The passes that read a table many times a lane (the record reduction and
    /// refinement's selection, every plane sample; the splat gathers, each contributing
    /// record) declare the texel-table constant, so the device's choice reaches them, and
    /// specialise and validate with it; no other pass declares it.
    #[test]
    fn the_table_readers_specialise_for_texel_tables() {
        use crate::gpu::texel_table::TABLE_TEXELS_CONSTANT;
        let mut readers = Vec::new();
        for (name, _) in SOURCES.iter().filter(|(n, _)| !n.starts_with("shared/")) {
            let (parsed, _) = parsed_module(name).expect("parsed");
            if !parsed
                .overrides
                .iter()
                .any(|(_, o)| o.name.as_deref() == Some(TABLE_TEXELS_CONSTANT))
            {
                continue;
            }
            readers.push(*name);
            let module = specialised_module(name, &[(TABLE_TEXELS_CONSTANT, 1.0)])
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            validator()
                .validate(&module)
                .unwrap_or_else(|e| panic!("{name} with texel tables: {e:?}"));
        }
        readers.sort();
        assert_eq!(
            readers,
            [
                "hemisphere_plane.wgsl",
                "plane_refine_select.wgsl",
                "record_reduce.wgsl",
                "splat_fill.wgsl",
                "splat_gather.wgsl"
            ]
        );
    }

    #[test]
    fn every_pass_composes_and_validates() {
        for (name, _) in SOURCES.iter().filter(|(n, _)| !n.starts_with("shared/")) {
            let text = compose(name).expect("compose");
            let module = naga::front::wgsl::parse_str(&text)
                .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&text)));
            naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::all(),
            )
            .validate(&module)
            .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&text)));
        }
    }

    /// Every pass's module embedded by `build.rs` is the one its WGSL parses to now (the
    /// build is not stale) and deserialises.
    #[test]
    fn the_modules_parsed_at_build_time_are_the_passes_wgsl() {
        let passes: Vec<_> = passes().collect();
        assert_eq!(parsed::PARSED_PASSES.len(), passes.len());
        for name in passes {
            let (_, embedded) = parsed::PARSED_PASSES
                .iter()
                .find(|(n, _)| *n == name)
                .unwrap_or_else(|| panic!("{name} not parsed at build time"));
            let text = compose(name).expect("compose");
            let module = naga::front::wgsl::parse_str(&text).expect("parse");
            let info = validator().validate(&module).expect("validate");
            let now = postcard::to_allocvec(&(&module, &info)).expect("serialise");
            assert!(
                now == *embedded,
                "{name}: the build's module differs from its WGSL"
            );
            let (back, _): (naga::Module, naga::valid::ModuleInfo) =
                postcard::from_bytes(embedded).expect("deserialise");
            assert_eq!(back.entry_points.len(), module.entry_points.len(), "{name}");
        }
    }
}
