// Temporal reprojection, step 1 of 3 (seed 000 section IV-G, thesis 5.2.4; algorithms.md
// 4.3): estimate a new record's plane at the next frame. Bound with the scene of frame
// t+1 at group 0: each plane sample's hit (instance, triangle, u, v) is rebuilt there,
// which moves it with its instance's transform. The moved point is projected onto the record's plane
// (the record keeps its world position and frame) and written into that pixel's cell
// with a depth test: the smallest (depth bits, sample index) key wins whatever the thread
// order (stored complemented, atomicMax on cells cleared to 0, so no fill pass is needed).
// A miss keeps its own pixel at the farthest depth, so any surface moving in front of it
// wins. With `anchored`, records move with the instance they lie on (temporal/motion.rs):
// the moved point is seen from the record's place at t+1 and projected in the record's
// frame carried along, i.e. after undoing the record's own motion. With `stride` > 1 only
// every stride-th sample each way is moved, onto a plane of P/stride cells (the estimate
// then only gives tau; `subset_pixel`). One invocation per (moved sample, record).
// Its radiance at t+1 is the radiance traced at t where nothing that lights it can have
// changed; the other samples that land in a cell are appended to `work`, and step 2
// (plane_reshade.wgsl) re-shades them with the lights of t+1 in a dense dispatch. On a
// CPU-like SIMD device a branchy per-sample re-shade costs the whole SIMD row whenever
// one lane needs it; the list keeps every lane busy. The list's order depends on thread
// timing, but every entry is computed on its own and written to its own sample, so the
// result does not.
//!include shared/reprojection.wgsl
//!include shared/movers.wgsl
//!include shared/work_list.wgsl

@group(1) @binding(0) var<uniform> params: ReprojectParams;
@group(1) @binding(1) var<storage, read> sites: array<RecordSite>;
@group(1) @binding(2) var<storage, read> hits: array<PlaneHit>;
@group(1) @binding(3) var<storage, read_write> cells: array<atomic<u32>>;
@group(1) @binding(4) var<storage, read_write> moved: array<vec4f>;   // radiance at t+1, depth
@group(1) @binding(5) var<storage, read> motion: array<InstanceMotion>;
@group(1) @binding(6) var<storage, read> moving: array<MovingBounds>;
@group(1) @binding(7) var<storage, read> traced: array<PlaneSample>;   // the plane at t
@group(1) @binding(8) var<storage, read_write> work: WorkList;   // samples to re-shade
@group(1) @binding(9) var<storage, read_write> work_groups: array<atomic<u32>, 3>;

// Estimate-plane cell of a direction whose tangent-frame components are `a` (along one
// axis) and `z` (along the normal, > 0), clamped into the border cells when they are
// stretched; -1 outside an unstretched plane. The cell edges are even in the plane's
// spacing coordinate: x = a / z for evenly spaced planes, sin(atan x) = a / |(a, z)| for
// cosine-spaced ones (records::PlaneSpacing::fraction; computed from the direction, so a
// grazing z stays finite).
fn plane_index(a: f32, z: f32) -> i32 {
    let res = i32(params.estimate_resolution);
    var u = a / z;
    if params.cosine_spacing != 0u {
        u = a / sqrt(a * a + z * z);
    }
    let i = i32(floor((u + params.half_extent) / (2.0 * params.half_extent) * f32(res)));
    if params.stretched != 0u {
        return clamp(i, 0, res - 1);
    }
    return select(-1, i, i >= 0 && i < res);
}

@compute @workgroup_size(8, 8)
fn main(
    @builtin(global_invocation_id) id: vec3u,
    @builtin(local_invocation_index) lane: u32,
) {
    bvh_stack_init(lane);
    let cells_res = params.estimate_resolution;
    if id.x >= cells_res || id.y >= cells_res || id.z >= params.count {
        return;
    }
    let res = params.resolution;
    let pixel = subset_pixel(id.y, params.stride, cells_res) * res
        + subset_pixel(id.x, params.stride, cells_res);
    let sample = id.z * res * res + pixel;
    let base = id.z * cells_res * cells_res;
    let site = sites[id.z];
    // A record on an instance that moves to t+1 lives one frame (MoverRecords::OneFrame):
    // no estimate. Its cells stay empty, so plane_fill.wgsl gives it its plane at t.
    if params.skip_movers != 0u && motion[site.instance].moves != 0u {
        return;
    }
    let h = hits[sample];
    if h.instance == NO_HIT {
        atomicMax(&cells[base + id.y * cells_res + id.x], ~reprojection_key(MISS_DEPTH, pixel));
        moved[sample] = vec4f(0.0, 0.0, 0.0, -1.0);
        return;
    }
    let frame = record_frame(site);
    let m = moved_hit(site, h, pixel);
    // Tangent-frame coordinates of the moved point (frame columns are t, b, n).
    let local = vec3f(dot(m.to_point, frame[0]), dot(m.to_point, frame[1]), dot(m.to_point, frame[2]));
    moved[sample] = vec4f(0.0, 0.0, 0.0, local.z);
    if local.z <= 0.0 {
        return;   // moved below the record's tangent plane: out of its hemisphere
    }
    let ix = plane_index(local.x, local.z);
    let iy = plane_index(local.y, local.z);
    if ix < 0 || iy < 0 {
        return;   // off the plane: no cell will read this sample
    }
    let cell = base + u32(iy) * cells_res + u32(ix);
    atomicMax(&cells[cell], ~reprojection_key(local.z, pixel));
    // Re-shading is the costly part (shadow rays at t+1); skip it where nothing that
    // lights this hit has changed. Diffuse radiance does not depend on where it is seen
    // from, so a record that moves keeps it too, as long as it sees the same side.
    let still = motion[h.instance].moves == 0u && m.same_side;
    if params.reuse_shading != 0u && still
        && !shadows_may_change(m.surface, m.seed, m.first, params.light_samples) {
        moved[sample] = vec4f(traced[sample].radiance, local.z);
    } else {
        push_work(sample);
    }
}
