// Plane refresh, step 1 of 2: which samples of a retained plane a replacement record must
// trace again. A replacement sits at its predecessor's place (seed 000 section IV-D) with
// the same site and seed, so its plane would be the predecessor's plane traced again,
// except where something moved since the predecessor's birth: `moving` holds the boxes
// of the instances that moved during that span (each at the predecessor's frame and at
// this one: frames between do not matter), and the lights did not change (the caller checks). A sample is listed for step 2
// (plane_retrace.wgsl) when its ray, up to its hit (or without end for a miss), meets
// such a box, when it hit an instance that moved, or when one of its shadow rays may meet
// such a box; every other sample would be traced to the same hit and shaded with the same
// shadow rays, so the retained bytes are the bytes a trace would give. Bound with the
// scene at the replacement's frame. One invocation per (pixel, record).
//!include shared/shading.wgsl
//!include shared/plane_direction.wgsl
//!include shared/movers.wgsl
//!include shared/work_list.wgsl

struct RefreshParams {
    resolution: u32,
    count: u32,
    light_samples: u32,
    moving_count: u32,
    movers_lo: vec4f,    // world box around every mover's box (MovingBounds::union)
    movers_hi: vec4f,
}

@group(1) @binding(0) var<uniform> params: RefreshParams;
@group(1) @binding(1) var<storage, read> sites: array<RecordSite>;
@group(1) @binding(2) var<storage, read> plane: array<PlanePixel>;
@group(1) @binding(3) var<storage, read> hits: array<PlaneHit>;   // the retained plane's
@group(1) @binding(4) var<storage, read> moving: array<MovingBounds>;
@group(1) @binding(5) var<storage, read> moved_instances: array<u32>;   // 1: moved in the span
@group(1) @binding(6) var<storage, read_write> work: WorkList;   // samples to trace again
@group(1) @binding(7) var<storage, read_write> work_groups: array<atomic<u32>, 3>;

@compute @workgroup_size(8, 8)
fn main(
    @builtin(global_invocation_id) id: vec3u,
    @builtin(local_invocation_index) lane: u32,
) {
    bvh_stack_init(lane);
    let res = params.resolution;
    if id.x >= res || id.y >= res || id.z >= params.count {
        return;
    }
    let pixel = id.y * res + id.x;
    let sample = id.z * res * res + pixel;
    let site = sites[id.z];
    let dir = plane_direction(site, pixel);
    if dot(dir, site.geometric_normal) <= 0.0 {
        return;   // never traced (shared/plane.wgsl): nothing can change
    }
    let origin = offset_ray_origin(site.position, site.geometric_normal);
    let h = hits[sample];
    if h.instance == NO_HIT {
        if meets_a_mover(origin, dir, INF) {
            push_work(sample);
        }
        return;
    }
    if moved_instances[h.instance] != 0u {
        push_work(sample);
        return;
    }
    let s = surface_at(Hit(0.0, h.instance, h.triangle, h.u, h.v), dir);
    if meets_a_mover(origin, s.position - origin, 1.0)
        || shadows_may_change(s, site.seed, plane_light_first(pixel, params.light_samples),
                              params.light_samples) {
        push_work(sample);
    }
}
