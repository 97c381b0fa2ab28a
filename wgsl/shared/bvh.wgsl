// Two-level BVH traversal (TLAS over instances, one BLAS per mesh), closest hit and any hit.
// One stack holds TLAS entries below `tlas_sp` and the current BLAS's entries above it;
// when the stack unwinds to `tlas_sp` the ray returns to world space.
//!include shared/ray.wgsl
//!include shared/scene.wgsl

const BVH_STACK_SIZE: u32 = 64u;

fn safe_inverse(d: vec3f) -> vec3f {
    let eps = 1.0e-20;
    return vec3f(
        select(1.0 / d.x, select(1.0 / eps, -1.0 / eps, d.x < 0.0), abs(d.x) < eps),
        select(1.0 / d.y, select(1.0 / eps, -1.0 / eps, d.y < 0.0), abs(d.y) < eps),
        select(1.0 / d.z, select(1.0 / eps, -1.0 / eps, d.z < 0.0), abs(d.z) < eps),
    );
}

// Slab test in fma form (`oid` = origin * inv_dir); returns the entry distance, or INF
// when the box is missed or lies beyond tmax.
fn intersect_aabb(bmin: vec3f, bmax: vec3f, inv_dir: vec3f, oid: vec3f, tmin: f32, tmax: f32) -> f32 {
    let t0 = fma(bmin, inv_dir, -oid);
    let t1 = fma(bmax, inv_dir, -oid);
    let near = min(t0, t1);
    let far = max(t0, t1);
    let tn = max(max(near.x, near.y), max(near.z, tmin));
    let tf = min(min(far.x, far.y), min(far.z, tmax));
    return select(INF, tn, tn <= tf);
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

// A traversal entry is one u32: an inner node's child pair (the index of its first child;
// siblings are adjacent, so one entry names two boxes), or, with LEAF_BIT set, a leaf's
// first primitive (bits 4..30) and primitive count - 1 (bits 0..3). Testing both children
// of a pair in one step means a node's own record is never fetched. Limits checked in
// `GpuScene::upload` and `bvh::SceneBvh::build_with`.
const LEAF_BIT: u32 = 0x80000000u;

fn node_entry(node: BvhNode) -> u32 {
    let index = bitcast<u32>(node.lo.w);
    let count = bitcast<u32>(node.hi.w);
    return select(index, LEAF_BIT | (index << 4u) | (count - 1u), count > 0u);
}

// Traverses the scene. `any_hit`: stop at the first hit (shadow rays).
fn trace(ray: Ray, any_hit: bool) -> Hit {
    var hit = Hit(ray.tmax, NO_HIT, 0u, 0.0, 0.0);
    if scene_info.instance_count == 0u {
        return hit;
    }
    var stack: array<u32, BVH_STACK_SIZE>;
    var sp = 0u;
    var tlas_sp = 0u;
    var in_blas = false;
    var instance = 0u;
    var origin = ray.origin;
    var dir = ray.dir;
    var inv_dir = safe_inverse(dir);
    var oid = origin * inv_dir;
    // The TLAS root's bounds are tested here; every other box is tested with its sibling.
    let root = bvh_nodes[scene_info.tlas_root];
    if intersect_aabb(root.lo.xyz, root.hi.xyz, inv_dir, oid, ray.tmin, hit.t) == INF {
        return hit;
    }
    var entry = node_entry(root);
    loop {
        if (entry & LEAF_BIT) == 0u {
            let a = bvh_nodes[entry];
            let b = bvh_nodes[entry + 1u];
            let ta = intersect_aabb(a.lo.xyz, a.hi.xyz, inv_dir, oid, ray.tmin, hit.t);
            let tb = intersect_aabb(b.lo.xyz, b.hi.xyz, inv_dir, oid, ray.tmin, hit.t);
            let ea = node_entry(a);
            let eb = node_entry(b);
            if ta != INF && tb != INF {
                // Visit the nearer child first; the farther one waits on the stack.
                let a_first = ta <= tb;
                entry = select(eb, ea, a_first);
                stack[sp] = select(ea, eb, a_first);
                sp = min(sp + 1u, BVH_STACK_SIZE - 1u);
                continue;
            }
            if ta != INF || tb != INF {
                entry = select(eb, ea, ta != INF);
                continue;
            }
        } else if in_blas {
            let first = (entry >> 4u) & 0x07ffffffu;
            let count = (entry & 15u) + 1u;
            for (var i = 0u; i < count; i++) {
                let tri_index = first + i;
                let r = intersect_triangle(triangles[tri_index], origin, dir, ray.tmin, hit.t);
                if r.x < hit.t {
                    hit = Hit(r.x, instance, tri_index, r.y, r.z);
                    if any_hit {
                        return hit;
                    }
                }
            }
        } else {
            // TLAS leaf: enter the instance's BLAS with the ray in object space. The
            // direction is not renormalised, so t keeps its meaning across instances. The
            // BLAS root's box is not tested: the TLAS leaf's box already bounds it.
            instance = (entry >> 4u) & 0x07ffffffu;
            let inst = instances[instance];
            origin = transform_point(inst.object_from_world, ray.origin);
            dir = transform_vector(inst.object_from_world, ray.dir);
            inv_dir = safe_inverse(dir);
            oid = origin * inv_dir;
            in_blas = true;
            tlas_sp = sp;
            entry = node_entry(bvh_nodes[inst.blas_root]);
            continue;
        }
        // Pop; leaving the BLAS when its part of the stack is used up.
        if in_blas && sp == tlas_sp {
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
        entry = stack[sp];
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
