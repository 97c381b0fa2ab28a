//! `radsplat info`: the adapter, driver and the limits that matter.

use crate::Result;
use crate::gpu::GpuContext;

/// `radsplat info`: prints the adapter, its driver, the limits that matter and the
/// largest image.
pub fn info() -> Result<()> {
    let ctx = GpuContext::new()?;
    if let Some(a) = &ctx.adapter_info {
        println!("adapter:      {}", a.name);
        println!("backend:      {:?}", a.backend);
        println!("device type:  {:?}", a.device_type);
        println!("driver:       {} ({})", a.driver, a.driver_info);
        if a.device_type == wgpu::DeviceType::Cpu {
            // `radsplat` sets it (two per core) unless the user did:
            // gpu::context::two_lavapipe_threads_per_core.
            println!(
                "CPU threads:  LP_NUM_THREADS={}",
                std::env::var("LP_NUM_THREADS").unwrap_or_else(|_| "unset".to_string())
            );
        }
    }
    // gpu::TriangleFetch: where the traversal reads triangles, and by the same choice
    // whether the per-round tables are read from texel tables (RADSPLAT_TRIANGLE_FETCH
    // overrides the choice).
    println!(
        "triangles:    {}",
        match ctx.triangle_fetch() {
            crate::gpu::TriangleFetch::Texture => {
                "node texture, per-round tables as texel tables (storage loads stall here)"
            }
            crate::gpu::TriangleFetch::Buffer => "storage buffer",
        }
    );
    let l = ctx.device.limits();
    println!("limits:");
    println!(
        "  max_storage_buffer_binding_size   {} MiB",
        l.max_storage_buffer_binding_size >> 20
    );
    println!(
        "  max_buffer_size                   {} MiB",
        l.max_buffer_size >> 20
    );
    println!(
        "  max_storage_buffers_per_stage     {}",
        l.max_storage_buffers_per_shader_stage
    );
    println!(
        "  max_compute_workgroups_per_dim    {}",
        l.max_compute_workgroups_per_dimension
    );
    println!(
        "  max_compute_invocations_per_wg    {}",
        l.max_compute_invocations_per_workgroup
    );
    println!(
        "  max_compute_workgroup_storage     {} KiB",
        l.max_compute_workgroup_storage_size >> 10
    );
    let side =
        ((ctx.max_binding_size() / crate::visibility::VIS_SAMPLE_BYTES) as f64).sqrt() as u64;
    println!("  largest square image              {side}x{side}");
    println!("features used:");
    println!(
        "  TIMESTAMP_QUERY (per-pass GPU times, with --time-passes): {}",
        ctx.has_timestamps()
    );
    println!(
        "  PIPELINE_CACHE (compiled pipelines kept between runs): {}",
        match ctx.pipeline_cache_path() {
            Some(p) => format!("true, {}", p.display()),
            None => "false".to_string(),
        }
    );
    let need = crate::gpu::required_limits();
    println!(
        "required by radsplat: {} storage buffers per stage, {} KiB of workgroup storage \
         (the traversal stacks)",
        need.max_storage_buffers_per_shader_stage,
        need.max_compute_workgroup_storage_size >> 10
    );
    Ok(())
}
