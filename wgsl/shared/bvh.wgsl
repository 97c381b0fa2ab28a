// Two-level BVH traversal (TLAS over instances, one BLAS per mesh), closest hit and any hit.
// Nodes are 4-wide with quantised child boxes (`GpuNode` in src/bvh/gpu_layout.rs), read
// from the `bvh_nodes` texture. One stack holds TLAS entries below `tlas_sp` and the current
// BLAS's entries above it; when the stack unwinds to `tlas_sp` the ray returns to world
// space.
//!include shared/ray.wgsl
//!include shared/scene.wgsl

// `bvh::TRAVERSAL_STACK`: enough for any tree the builders make over < 2^27 triangles and
// instances (src/bvh/mod.rs).
const BVH_STACK_SIZE: u32 = 96u;

// The traversal stacks live in workgroup memory, one slice of BVH_STACK_SIZE entries per
// invocation, not in a function-local array. A dynamically indexed local array is lowered
// by Mesa (lavapipe) to a tree of branches over all its entries at every access: the
// 96-entry stack made a tracing pass's JIT compile take 0.4-0.6 s longer on a cold start
// and its pushes slower (visibility 95 -> 50 ms, direct light 857 -> 711 ms on Sponza
// 256x256, same bytes). Every pass that traces runs 64 invocations per workgroup and calls
// `bvh_stack_init(local_invocation_index)` first (checked by `cargo test`); the 24 KiB
// this takes are part of `gpu::required_limits`.
const BVH_WORKGROUP_INVOCATIONS: u32 = 64u;
var<workgroup> bvh_stacks: array<u32, 6144>; // BVH_WORKGROUP_INVOCATIONS * BVH_STACK_SIZE
var<private> bvh_stack_base: u32;

// Gives this invocation its slice of the workgroup's traversal stacks.
fn bvh_stack_init(local_invocation_index: u32) {
    bvh_stack_base = local_invocation_index * BVH_STACK_SIZE;
}

// A traversal entry is one u32: an inner node's index, or, with LEAF_BIT set, a leaf's
// first primitive (bits 4..30) and primitive count - 1 (bits 0..3); EMPTY marks an unused
// child slot. Limits checked in `GpuScene::upload` and `GpuNode::new`.
const LEAF_BIT: u32 = 0x80000000u;
const EMPTY: u32 = 0xffffffffu;

// Bit of SCENE_FEATURES (shared/scene.wgsl; `gpu::SceneFeatures`): rays may reach a TLAS
// leaf and enter an instance. A pipeline compiled without it, for a scene of one instance
// placed as modelled, traces every ray in that BLAS from its root: the instance loads and
// the return to world space leave the traversal loop, whose every branch lavapipe runs
// (the nave's incoherent rays 8 % faster, its primary rays 12 %; the same hits).
const FEATURE_INSTANCES: u32 = 32u;

override TRAVERSES_INSTANCES: bool = (SCENE_FEATURES & FEATURE_INSTANCES) != 0u;

fn safe_inverse(d: vec3f) -> vec3f {
    let eps = 1.0e-20;
    return vec3f(
        select(1.0 / d.x, select(1.0 / eps, -1.0 / eps, d.x < 0.0), abs(d.x) < eps),
        select(1.0 / d.y, select(1.0 / eps, -1.0 / eps, d.y < 0.0), abs(d.y) < eps),
        select(1.0 / d.z, select(1.0 / eps, -1.0 / eps, d.z < 0.0), abs(d.z) < eps),
    );
}

// Möller–Trumbore; returns (t, u, v) with t = INF on a miss. Same formulation as
// `bvh::cpu_trace::barycentrics`.
fn intersect_triangle(tri: Triangle, origin: vec3f, dir: vec3f, tmin: f32, tmax: f32) -> vec3f {
    let e1 = tri.e1.xyz;
    let e2 = tri.e2.xyz;
    let p = cross(dir, e2);
    let det = dot(e1, p);
    if det == 0.0 {
        return vec3f(INF, 0.0, 0.0);
    }
    let inv_det = 1.0 / det;
    let s = origin - tri.v0.xyz;
    let u = dot(s, p) * inv_det;
    let q = cross(s, e1);
    let v = dot(dir, q) * inv_det;
    let t = dot(e2, q) * inv_det;
    let inside = u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t >= tmin && t < tmax;
    return select(vec3f(INF, 0.0, 0.0), vec3f(t, u, v), inside);
}

// The four children's planes on one axis: bytes of `q` on the grid origin + q * step. The
// product is exact (step is a power of two), so this matches `wide::plane` bit for bit.
fn dequantise(q: u32, step: f32, origin: f32) -> vec4f {
    let b = (vec4u(q) >> vec4u(0u, 8u, 16u, 24u)) & vec4u(255u);
    return fma(vec4f(b), vec4f(step), vec4f(origin));
}

// Slab test of node `node`'s four child boxes in fma form (`oid` = origin * inv_dir).
// Returns each child's entry distance, INF when missed, beyond tmax or an empty slot.
fn intersect_children(node: u32, entries: vec4u, inv_dir: vec3f, oid: vec3f, tmin: f32, tmax: f32) -> vec4f {
    let a = bvh_texel(node, 0u);
    let qxy = bvh_texel(node, 1u);
    let qz = bvh_texel(node, 2u);
    let o = bitcast<vec3f>(a.xyz);
    let step = vec3f(
        bitcast<f32>((a.w & 255u) << 23u),
        bitcast<f32>(((a.w >> 8u) & 255u) << 23u),
        bitcast<f32>(((a.w >> 16u) & 255u) << 23u),
    );
    let t0x = fma(dequantise(qxy.x, step.x, o.x), vec4f(inv_dir.x), vec4f(-oid.x));
    let t1x = fma(dequantise(qxy.y, step.x, o.x), vec4f(inv_dir.x), vec4f(-oid.x));
    let t0y = fma(dequantise(qxy.z, step.y, o.y), vec4f(inv_dir.y), vec4f(-oid.y));
    let t1y = fma(dequantise(qxy.w, step.y, o.y), vec4f(inv_dir.y), vec4f(-oid.y));
    let t0z = fma(dequantise(qz.x, step.z, o.z), vec4f(inv_dir.z), vec4f(-oid.z));
    let t1z = fma(dequantise(qz.y, step.z, o.z), vec4f(inv_dir.z), vec4f(-oid.z));
    let tn = max(max(min(t0x, t1x), min(t0y, t1y)), max(min(t0z, t1z), vec4f(tmin)));
    let tf = min(min(max(t0x, t1x), max(t0y, t1y)), min(max(t0z, t1z), vec4f(tmax)));
    return select(vec4f(INF), tn, (tn <= tf) & (entries != vec4u(EMPTY)));
}

// One compare-exchange of a sorting network over (distance, entry) pairs.
fn sort_pair(da: ptr<function, f32>, db: ptr<function, f32>, ea: ptr<function, u32>, eb: ptr<function, u32>) {
    let swap = *db < *da;
    let d = select(*da, *db, swap);
    let e = select(*ea, *eb, swap);
    *db = select(*db, *da, swap);
    *eb = select(*eb, *ea, swap);
    *da = d;
    *ea = e;
}

// Traverses the scene. `any_hit`: stop at the first hit (shadow rays).
//
// Inner nodes run in a loop of their own until every lane holds a leaf or is done, then the
// leaves ("while-while", Aila & Laine 2009). Lavapipe runs every branch of a loop body with
// the lanes that do not take it masked off, and a loop's body at least once: with nodes and
// leaves in one body, every node visit also paid a triangle test (three storage loads,
// each a loop over the lanes). The same visits in the same order per ray, so the same hits;
// the nave's incoherent rays 1.11x, primary 1.10x, shadow rays 1.25x as fast (stop 54).
fn trace(ray: Ray, any_hit: bool) -> Hit {
    var hit = Hit(ray.tmax, NO_HIT, 0u, 0.0, 0.0);
    if scene_info.instance_count == 0u {
        return hit;
    }
    var sp = 0u;
    var tlas_sp = 0u;
    // A single instance placed as modelled is traversed from its BLAS root in world space
    // (bvh::SceneBvh::traversal_start): its identity transform would change at most the
    // sign of a zero coordinate, which no box or triangle test tells apart.
    var in_blas = scene_info.root_in_blas != 0u || !TRAVERSES_INSTANCES;
    var instance = 0u;
    var origin = ray.origin;
    var dir = ray.dir;
    var inv_dir = safe_inverse(dir);
    var oid = origin * inv_dir;
    var entry = scene_info.tlas_root;
    var done = false;
    loop {
        // Inner nodes until this lane holds a leaf (or a TLAS leaf) or its stack runs out.
        loop {
            if (entry & LEAF_BIT) != 0u {
                break;
            }
            let e = bvh_texel(entry, 3u);
            let d = intersect_children(entry, e, inv_dir, oid, ray.tmin, hit.t);
            var d0 = d.x;
            var d1 = d.y;
            var d2 = d.z;
            var d3 = d.w;
            var e0 = e.x;
            var e1 = e.y;
            var e2 = e.z;
            var e3 = e.w;
            sort_pair(&d0, &d1, &e0, &e1);
            sort_pair(&d2, &d3, &e2, &e3);
            sort_pair(&d0, &d2, &e0, &e2);
            sort_pair(&d1, &d3, &e1, &e3);
            sort_pair(&d1, &d2, &e1, &e2);
            if d0 != INF {
                // Nearest child next, the other hit children onto the stack, farthest
                // deepest: unconditional stores, conditional increments.
                bvh_stacks[bvh_stack_base + sp] = e3;
                sp = min(sp + select(0u, 1u, d3 != INF), BVH_STACK_SIZE - 1u);
                bvh_stacks[bvh_stack_base + sp] = e2;
                sp = min(sp + select(0u, 1u, d2 != INF), BVH_STACK_SIZE - 1u);
                bvh_stacks[bvh_stack_base + sp] = e1;
                sp = min(sp + select(0u, 1u, d1 != INF), BVH_STACK_SIZE - 1u);
                entry = e0;
                continue;
            }
            // Pop; leaving the BLAS when its part of the stack is used up.
            if TRAVERSES_INSTANCES && in_blas && sp == tlas_sp {
                in_blas = false;
                origin = ray.origin;
                dir = ray.dir;
                inv_dir = safe_inverse(dir);
                oid = origin * inv_dir;
            }
            if sp == 0u {
                done = true;
                break;
            }
            sp -= 1u;
            entry = bvh_stacks[bvh_stack_base + sp];
        }
        if done {
            break;
        }
        if in_blas {
            let first = (entry >> 4u) & 0x07ffffffu;
            let count = (entry & 15u) + 1u;
            for (var i = 0u; i < count; i++) {
                let tri_index = first + i;
                let r = intersect_triangle(traversal_triangle(tri_index), origin, dir, ray.tmin, hit.t);
                if r.x < hit.t {
                    hit = Hit(r.x, instance, tri_index, r.y, r.z);
                    if any_hit {
                        return hit;
                    }
                }
            }
        } else if TRAVERSES_INSTANCES {
            // TLAS leaf: enter the instance's BLAS with the ray in object space. The
            // direction is not renormalised, so t keeps its meaning across instances.
            instance = (entry >> 4u) & 0x07ffffffu;
            let inst = instances[instance];
            origin = transform_point(inst.object_from_world, ray.origin);
            dir = transform_vector(inst.object_from_world, ray.dir);
            inv_dir = safe_inverse(dir);
            oid = origin * inv_dir;
            in_blas = true;
            tlas_sp = sp;
            entry = inst.blas_root;
            continue;
        }
        if TRAVERSES_INSTANCES && in_blas && sp == tlas_sp {
            in_blas = false;
            origin = ray.origin;
            dir = ray.dir;
            inv_dir = safe_inverse(dir);
            oid = origin * inv_dir;
        }
        if sp == 0u {
            break;
        }
        sp -= 1u;
        entry = bvh_stacks[bvh_stack_base + sp];
    }
    return hit;
}

fn trace_closest(ray: Ray) -> Hit {
    return trace(ray, false);
}

// True if anything lies on the ray between tmin and tmax.
fn occluded(ray: Ray) -> bool {
    return trace(ray, true).instance != NO_HIT;
}
