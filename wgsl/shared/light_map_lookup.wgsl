// Shadow lookups in light-space visibility maps (shared/light_map.wgsl, src/light_maps):
// what a plane hit uses instead of a shadow ray when the frame has maps. The including
// pass declares `light_maps: array<LightMap>`, `light_map_depths: array<f32>` and
// `light_map_first: array<u32>` (element 0: the number of maps, 0 for none; elements
// 1 + 2 slot and 2 + 2 slot: the first map of light `slot`, NO_MAP for none, and for a
// rect light the n of its n x n grid of maps, traced from the cells' centres).
//!include shared/shading.wgsl
//!include shared/light_map.wgsl

const NO_MAP: u32 = 0xffffffffu;

// Texel size of map `m` at distance `dist` from its origin, in world units.
fn light_map_texel(m: LightMap, dist: f32) -> f32 {
    return select(m.origin.w * dist, m.origin.w, m.kind == MAP_ORTHOGRAPHIC);
}

// Whether the depth of texel (i, j), clamped to the map, lies beyond `depth - bias`.
fn light_map_lit(m: LightMap, i: i32, j: i32, depth: f32, bias: f32) -> f32 {
    let r = i32(m.resolution) - 1;
    let t = light_map_depths[m.offset + u32(clamp(j, 0, r)) * m.resolution + u32(clamp(i, 0, r))];
    return select(0.0, 1.0, depth <= t + bias);
}

// Visibility in [0, 1] of the shadow loop's current sample from surface `s`, by
// percentage-closer filtering (the four nearest texels' tests, weighted bilinearly). The receiver moves
// along its geometric normal by a texel and a half (normal-offset shadow mapping) and
// the test allows a texel and a half of depth, against self-shadowing; contact shadows
// thinner than that are lost (plane hits feed the indirect light only, which averages
// them). A rect light's sample keeps its own random point (the geometric term stays
// exact) and takes its visibility from the map of the grid cell it falls in. Negative
// where no map covers the sample: trace its ray.
fn light_map_visibility(st: ShadowLoop, s: Surface) -> f32 {
    let slot = st.slot;
    if light_map_first[0] == 0u || slot >= scene_info.light_count {
        return -1.0;
    }
    let first = light_map_first[1u + 2u * slot];
    if first == NO_MAP {
        return -1.0;
    }
    var k = 0u;
    if st.kind == LIGHT_RECT {
        let n = light_map_first[2u + 2u * slot];
        let q = st.sample.target_point - st.light.a.xyz;
        let b = st.light.b.xyz;
        let c = st.light.c.xyz;
        let cell = vec2u(clamp(vec2f(dot(q, b) / dot(b, b), dot(q, c) / dot(c, c)) * f32(n),
                               vec2f(0.0), vec2f(f32(n) - 1.0)));
        k = cell.x + n * cell.y;
    }
    // Only the fields the map's kind needs (a storage load is a per-lane loop on
    // lavapipe; point maps need 24 of the 80 bytes).
    let index = first + k;
    var m: LightMap;
    m.kind = light_maps[index].kind;
    m.resolution = light_maps[index].resolution;
    m.offset = light_maps[index].offset;
    m.origin = light_maps[index].origin;
    var depth: f32;
    var uv: vec2f;
    var texel: f32;
    if m.kind == MAP_ORTHOGRAPHIC {
        m.axis_u = light_maps[index].axis_u;
        m.axis_v = light_maps[index].axis_v;
        m.dir = light_maps[index].dir;
        texel = m.origin.w;
        let q = s.position + (1.5 * texel) * s.geometric_normal - m.origin.xyz;
        uv = vec2f(dot(q, m.axis_u.xyz) / m.axis_u.w, dot(q, m.axis_v.xyz) / m.axis_v.w);
        depth = dot(q, m.dir.xyz);
    } else {
        let dist0 = length(s.position - m.origin.xyz);
        texel = light_map_texel(m, dist0);
        let d = s.position + (1.5 * texel) * s.geometric_normal - m.origin.xyz;
        depth = length(d);
        uv = octahedral_encode(d / depth);
    }
    let xy = uv * f32(m.resolution) - 0.5;
    let base = floor(xy);
    let f = xy - base;
    let i = i32(base.x);
    let j = i32(base.y);
    let bias = 1.5 * texel;
    let top = mix(light_map_lit(m, i, j, depth, bias), light_map_lit(m, i + 1, j, depth, bias), f.x);
    let bottom = mix(light_map_lit(m, i, j + 1, depth, bias), light_map_lit(m, i + 1, j + 1, depth, bias), f.x);
    return mix(top, bottom, f.y);
}
