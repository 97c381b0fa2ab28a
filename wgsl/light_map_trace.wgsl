// Light-map trace: one ray per texel of every light map (shared/light_map.wgsl), writing
// the distance to the first hit (MAP_NO_HIT on a miss). z indexes the map.
//!include shared/bvh.wgsl
//!include shared/light_map.wgsl
//!include shared/lit_grid.wgsl

@group(1) @binding(0) var<storage, read> maps: array<LightMap>;
@group(1) @binding(1) var<storage, read_write> depths: array<f32>;
// Level 0 of the lit grid: the voxel of every first hit is marked.
@group(1) @binding(2) var<uniform> lit_grid_params: LitGridParams;
@group(1) @binding(3) var<storage, read_write> lit_grid: array<atomic<u32>>;

@compute @workgroup_size(8, 8)
fn main(
    @builtin(global_invocation_id) id: vec3u,
    @builtin(local_invocation_index) lane: u32,
) {
    bvh_stack_init(lane);
    let m = maps[id.z];
    if id.x >= m.resolution || id.y >= m.resolution {
        return;
    }
    let ray = light_map_ray(m, id.xy);
    let hit = trace_closest(ray);
    depths[m.offset + id.y * m.resolution + id.x] = select(MAP_NO_HIT, hit.t, hit.instance != NO_HIT);
    if hit.instance != NO_HIT && lit_grid_params.levels > 0u {
        let p = lit_grid_params;
        let q = (ray.origin + hit.t * ray.dir - p.lo) / p.cell;
        let c = vec3u(clamp(vec3i(floor(q)), vec3i(0), vec3i(p.dims) - vec3i(1)));
        // The lit side's normal (facing the light), by its dominant axis: bit 2 axis + (0
        // for +, 1 for -) of the voxel's mask (lit_grid.wgsl).
        let tri = traversal_triangle(hit.triangle);
        var n = cross(tri.e1.xyz, tri.e2.xyz);
        if TRAVERSES_INSTANCES {
            // Without instances the one instance is placed as modelled: its normal matrix
            // is the identity, which could change only the sign of a zero component, and
            // neither the face bit nor the flip below tells those apart.
            n = transform_vector(instances[hit.instance].normal_to_world, n);
        }
        if dot(n, ray.dir) > 0.0 {
            n = -n;
        }
        atomicOr(&lit_grid[lit_grid_voxel(p, 0u, c)], lit_face_bit(n));
    }
}
