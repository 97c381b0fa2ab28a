// Temporal instant caching, first pass of an update (src/temporal/instant.rs, seed 003
// Algorithm 1): which visibility rays of the kept records must be traced again. One
// 64-lane workgroup per record; lane l takes the 32-slot words l, l + 64, ... of the VPLs.
// A ray in front of the site is listed (`rays`: record index, VPL slot) where its VPL
// changed (`changed`: Cases 1-2) or its segment meets the box of an instance that moved
// between the frames at either end (`moving`: Cases 3-4, by boxes, shared/movers.wgsl);
// the others keep their bit. The listed rays' bits are cleared here and set by
// vpl_update_trace.wgsl where the ray reaches its VPL; the list's order depends on thread
// timing, the bits it sets do not. vpl_gather.wgsl (update mode, nothing stale) then sums
// every record from its bits.
//!include shared/movers.wgsl
//!include shared/records.wgsl
//!include shared/vpl.wgsl

const LANES: u32 = 64u;

struct SelectParams {
    count: u32,
    visibility_words: u32,
    vpl_count: u32,
    moving_count: u32,
    movers_lo: vec4f,
    movers_hi: vec4f,
    capacity: u32,   // entries `rays` holds
    first: u32,      // the first record of this dispatch
    _pad1: u32,
    _pad2: u32,
}

@group(1) @binding(0) var<uniform> params: SelectParams;
@group(1) @binding(1) var<storage, read> records: array<Record>;
@group(1) @binding(2) var<storage, read> vpls: array<Vpl>;
@group(1) @binding(3) var<storage, read_write> visibility: array<u32>;
@group(1) @binding(4) var<storage, read> changed: array<u32>;
@group(1) @binding(5) var<storage, read> moving: array<MovingBounds>;
@group(1) @binding(6) var<storage, read_write> rays: array<vec2u>;
@group(1) @binding(7) var<storage, read_write> counters: array<atomic<u32>>;  // listed, reused

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) group: vec3u, @builtin(local_invocation_index) lane: u32) {
    // Traces nothing, but includes the traversal (through shared/movers.wgsl).
    bvh_stack_init(lane);
    let index = params.first + group.x;
    if index >= params.count {
        return;
    }
    let r = records[index];
    let n = r.normal;
    let origin = offset_ray_origin(r.position, n);
    let base = index * params.visibility_words;
    var reused = 0u;
    let words = (params.vpl_count + 31u) / 32u;
    for (var word = lane; word < words; word += LANES) {
        let old = visibility[base + word];
        let stale = changed[word];
        var keep = 0u;
        for (var b = 0u; b < 32u; b++) {
            let j = word * 32u + b;
            if j >= params.vpl_count {
                break;
            }
            let v = vpls[j];
            if all(v.power == vec3f(0.0)) {
                continue;
            }
            let w = v.position - r.position;
            let dir = w / sqrt(dot(w, w));
            // The gather's tests (vpl_gather.wgsl): rays it never traces are never listed.
            if !(dot(n, dir) > 0.0 && -dot(v.normal, dir) > 0.0) {
                continue;
            }
            if ((stale >> b) & 1u) != 0u || meets_a_mover(origin, v.position - origin, 1.0) {
                let at = atomicAdd(&counters[0], 1u);
                if at < params.capacity {
                    rays[at] = vec2u(index, j);
                }
            } else {
                keep |= old & (1u << b);
                reused++;
            }
        }
        visibility[base + word] = keep;
    }
    atomicAdd(&counters[1], reused);
}
