// Temporal instant caching, second pass of an update: one invocation per ray listed by
// vpl_update_select.wgsl, traced from its record (as vpl_gather.wgsl traces it, from
// `site_of`) to its VPL; a ray that reaches it sets its bit. Rays listed together are
// traced together, not scattered over the records' workgroups.
//!include shared/bvh.wgsl
//!include shared/sampling.wgsl
//!include shared/records.wgsl
//!include shared/vpl.wgsl

struct TraceParams {
    first: u32,
    count: u32,
    visibility_words: u32,
    _pad: u32,
}

@group(1) @binding(0) var<uniform> params: TraceParams;
@group(1) @binding(1) var<storage, read> records: array<Record>;
@group(1) @binding(2) var<storage, read> vpls: array<Vpl>;
@group(1) @binding(3) var<storage, read_write> visibility: array<atomic<u32>>;
@group(1) @binding(4) var<storage, read> rays: array<vec2u>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(local_invocation_index) lane: u32) {
    bvh_stack_init(lane);
    let k = params.first + id.x;
    if id.x >= params.count {
        return;
    }
    let e = rays[k];
    let r = records[e.x];
    let v = vpls[e.y];
    let origin = offset_ray_origin(r.position, r.normal);
    let to_vpl = v.position - origin;
    let h = trace(Ray(origin, 0.0, to_vpl, 1.0 - 1.0e-4), false);
    if h.instance == NO_HIT {
        atomicOr(&visibility[e.x * params.visibility_words + e.y / 32u], 1u << (e.y % 32u));
    }
}
