// Light-map trace: one ray per texel of every light map (shared/light_map.wgsl), writing
// the distance to the first hit (MAP_NO_HIT on a miss). z indexes the map.
//!include shared/bvh.wgsl
//!include shared/light_map.wgsl

@group(1) @binding(0) var<storage, read> maps: array<LightMap>;
@group(1) @binding(1) var<storage, read_write> depths: array<f32>;

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
    let hit = trace_closest(light_map_ray(m, id.xy));
    depths[m.offset + id.y * m.resolution + id.x] = select(MAP_NO_HIT, hit.t, hit.instance != NO_HIT);
}
