// Traces a buffer of rays (closest hit, or any hit for shadow rays) and writes hits:
// used by benchmarks and by the GPU-vs-CPU traversal tests.
//!include shared/bvh.wgsl

struct TraceParams {
    count: u32,
    any_hit: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(1) @binding(0) var<uniform> params: TraceParams;
@group(1) @binding(1) var<storage, read> rays: array<Ray>;
@group(1) @binding(2) var<storage, read_write> hits: array<Hit>;

@compute @workgroup_size(64)
fn main(
    @builtin(global_invocation_id) id: vec3u,
    @builtin(num_workgroups) groups: vec3u,
    @builtin(local_invocation_index) lane: u32,
) {
    bvh_stack_init(lane);
    let i = id.x + id.y * groups.x * 64u;
    if i >= params.count {
        return;
    }
    hits[i] = trace(rays[i], params.any_hit != 0u);
}
