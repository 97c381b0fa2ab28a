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

// Slab test; returns the entry distance, or INF when the box is missed or lies beyond tmax.
fn intersect_aabb(bmin: vec3f, bmax: vec3f, origin: vec3f, inv_dir: vec3f, tmin: f32, tmax: f32) -> f32 {
    let t0 = (bmin - origin) * inv_dir;
    let t1 = (bmax - origin) * inv_dir;
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

// Traverses the scene. `any_hit`: stop at the first hit (shadow rays).
fn trace(ray: Ray, any_hit: bool) -> Hit {
    var hit = Hit(ray.tmax, NO_HIT, 0u, 0.0, 0.0);
    if arrayLength(&tlas_nodes) == 0u || scene_info.instance_count == 0u {
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
    var node_index = 0u;
    // The TLAS root's bounds are tested here; every other node is tested by its parent.
    let root = tlas_nodes[0];
    if intersect_aabb(root.min, root.max, origin, inv_dir, ray.tmin, hit.t) == INF {
        return hit;
    }
    loop {
        var node: BvhNode;
        if in_blas {
            node = blas_nodes[node_index];
        } else {
            node = tlas_nodes[node_index];
        }
        var descend = false;
        if node.count == 0u {
            var left: BvhNode;
            var right: BvhNode;
            if in_blas {
                left = blas_nodes[node.index];
                right = blas_nodes[node.index + 1u];
            } else {
                left = tlas_nodes[node.index];
                right = tlas_nodes[node.index + 1u];
            }
            let tl = intersect_aabb(left.min, left.max, origin, inv_dir, ray.tmin, hit.t);
            let tr = intersect_aabb(right.min, right.max, origin, inv_dir, ray.tmin, hit.t);
            let hit_l = tl != INF;
            let hit_r = tr != INF;
            if hit_l && hit_r {
                // Visit the nearer child first; the farther one waits on the stack.
                let near_is_left = tl <= tr;
                node_index = select(node.index + 1u, node.index, near_is_left);
                stack[sp] = select(node.index, node.index + 1u, near_is_left);
                sp = min(sp + 1u, BVH_STACK_SIZE - 1u);
                descend = true;
            } else if hit_l || hit_r {
                node_index = select(node.index + 1u, node.index, hit_l);
                descend = true;
            }
        } else if in_blas {
            for (var i = 0u; i < node.count; i++) {
                let tri_index = node.index + i;
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
            // direction is not renormalised, so t keeps its meaning across instances.
            instance = node.index;
            let inst = instances[instance];
            origin = transform_point(inst.object_from_world, ray.origin);
            dir = transform_vector(inst.object_from_world, ray.dir);
            inv_dir = safe_inverse(dir);
            in_blas = true;
            tlas_sp = sp;
            node_index = inst.blas_root;
            descend = true;
        }
        if descend {
            continue;
        }
        // Pop; leaving the BLAS when its part of the stack is used up.
        if in_blas && sp == tlas_sp {
            in_blas = false;
            origin = ray.origin;
            dir = ray.dir;
            inv_dir = safe_inverse(dir);
        }
        if sp == 0u {
            break;
        }
        sp -= 1u;
        node_index = stack[sp];
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
