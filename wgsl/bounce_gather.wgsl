// Surface bounce cache, one level (src/bounce, `--bounces N`): the indirect irradiance at
// every cell side of the cache, gathered from `rays` cosine-distributed directions around
// the cell's shading normal (Owen-scrambled Sobol, scrambled per cell side). Each hit
// reflects its direct light and the previous level's indirect irradiance
// (`bounce_cache`, zero at level 1), so level k holds light reflected k times before it
// reaches the cell. E = pi / K * sum(L) (cosine pdf). One invocation per cell side; rays
// [ray_begin, ray_end) per dispatch (llvmpipe's loop budget, MAX_RAYS_PER_INVOCATION),
// summed in ray order into `values`, scaled by pi / K by the dispatch that ends at K.
// Misses add nothing: the environment is a light of every hit's direct light. The hits'
// shadows come from light-space maps of every light when the pass binds them (a level's
// error averages over the cells a record's plane sees), else from shadow rays.
// CPU mirror: src/bounce/reference.rs (shadow rays).
//!include shared/trace_and_shade.wgsl
//!include shared/light_map_lookup.wgsl
//!include shared/bounce_cache.wgsl

struct GatherParams {
    first_side: u32,     // first cell side of this dispatch
    sides: u32,          // cell sides in all
    ray_begin: u32,
    ray_end: u32,
    rays: u32,           // K
    light_samples: u32,  // per light at each hit
    irradiance_bound: f32,   // the most direct irradiance any point can get (src/bounce)
    _pad: u32,
}

struct BounceCell {
    instance: u32,
    triangle: u32,   // absolute (BVH leaf order)
    cell: u32,       // index in the triangle's n x n grid
    n: u32,
}

@group(1) @binding(0) var<uniform> params: GatherParams;
@group(1) @binding(1) var<storage, read> cells: array<BounceCell>;
@group(1) @binding(2) var<storage, read> bounce_cache: array<u32>;   // the previous level
@group(1) @binding(3) var<storage, read_write> values: array<f32>;  // 3 per cell side
@group(1) @binding(4) var<storage, read> light_maps: array<LightMap>;
@group(1) @binding(5) var<storage, read> light_map_depths: array<f32>;
@group(1) @binding(6) var<storage, read> light_map_first: array<u32>;

fn shadow_from_maps(st: ShadowLoop, s: Surface) -> f32 {
    return light_map_visibility(st, s);
}

fn hit_indirect_irradiance(shaded: ShadedHit, seed: u32, k: u32) -> vec3f {
    return bounce_irradiance(shaded.hit, shaded.surface.front_face);
}

// Barycentrics (of v1, v2) of the centroid of cell `cell` of an n x n grid (the inverse
// of `bounce_cell`). Rust: bounce::cell_centroid.
fn bounce_cell_centroid(cell: u32, n: u32) -> vec2f {
    var j = 0u;
    while j + 1u < n && bounce_row_base(j + 1u, n) <= cell {
        j++;
    }
    let r = cell - bounce_row_base(j, n);
    let i = r / 2u;
    let third = select(1.0, 2.0, (r & 1u) == 1u) / 3.0;
    return (vec2f(f32(i), f32(j)) + vec2f(third)) / f32(n);
}

// Scramble seed of a cell side's directions. Rust: bounce::side_seed.
fn side_seed(side: u32) -> u32 {
    return hash_combine(hash_u32(side), 0xb0cu);
}

@compute @workgroup_size(64)
fn main(
    @builtin(global_invocation_id) id: vec3u,
    @builtin(local_invocation_index) lane: u32,
) {
    bvh_stack_init(lane);
    let side = params.first_side + id.x;
    if side >= params.sides {
        return;
    }
    let c = cells[side / 2u];
    let uv = bounce_cell_centroid(c.cell, c.n);
    // surface_at with a zero direction gives the back side; the front faces -normal.
    let back = surface_at(Hit(0.0, c.instance, c.triangle, uv.x, uv.y), vec3f(0.0));
    var s = back;
    if (side & 1u) == 0u {
        s = surface_facing(back, back.geometric_normal);
    }
    let seed = side_seed(side);
    var sum = vec3f(0.0);
    if params.ray_begin > 0u {
        sum = vec3f(values[3u * side], values[3u * side + 1u], values[3u * side + 2u]);
    }
    let basis = orthonormal_basis(s.shading_normal);
    let origin = offset_ray_origin(s.position, s.geometric_normal);
    for (var k = params.ray_begin; k < params.ray_end; k++) {
        let dir = basis * cosine_hemisphere(sobol_2d(k, seed));
        if dot(dir, s.geometric_normal) > 0.0 {
            let shaded = trace_and_shade(
                Ray(origin, 0.0, dir, INF), hash_combine(seed, k), params.light_samples);
            if shaded.hit.instance != NO_HIT {
                // A one-sample estimate beside an area light can exceed any true
                // irradiance (1 / r^2 of the sampled point): clamp it to the bound.
                var clamped = shaded;
                clamped.irradiance = min(shaded.irradiance, vec3f(params.irradiance_bound));
                sum += hit_radiance(clamped, seed, k);
            }
        }
    }
    if params.ray_end == params.rays {
        sum *= PI / f32(params.rays);
    }
    values[3u * side] = sum.x;
    values[3u * side + 1u] = sum.y;
    values[3u * side + 2u] = sum.z;
}
