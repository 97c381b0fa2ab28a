// Shadow lookups in light-space visibility maps (shared/light_map.wgsl, src/light_maps):
// what a plane hit uses instead of a shadow ray when the frame has maps. The including
// pass declares `light_maps: array<LightMap>`, `light_map_depths: array<f32>` and
// `light_map_first: array<u32>` (element 0: the number of maps, 0 for none; elements
// 1 + 2 slot and 2 + 2 slot: the first map of light `slot`, NO_MAP for none, and for a
// rect light the n of its n x n grid of maps, traced from the cells' centres).
//!include shared/shading.wgsl
//!include shared/light_map.wgsl

const NO_MAP: u32 = 0xffffffffu;

// Texel (i, j) of map `m` (clamped to the map) against the receiver's plane through `p`
// with normal `n`: how far from the plane, in texels, lies the first surface along the
// texel's own ray (positive beyond it, negative in front of it; receiver-plane depth
// test). It is exact for a planar receiver, so it needs no normal offset and no depth bias
// beyond rounding: the texel and a half of both that an earlier lookup used let sunlight
// through contact shadows (docs/results.md, "The sun's light map makes Sponza's plane hits
// too bright"). NO_VOTE where the ray grazes the plane.
const NO_VOTE: f32 = -1.0e30;
// A texel's surface within this many texels of the plane is the receiver's own surface.
const PLANE_TOLERANCE: f32 = 0.5;
// Occluders nearer the plane than this many texels, where the texels disagree, leave the
// answer to a shadow ray (`light_map_visibility`).
const NEAR_GAP: f32 = 3.0;
fn light_map_gap(m: LightMap, i: i32, j: i32, p: vec3f, n: vec3f, texel: f32) -> f32 {
    let r = i32(m.resolution) - 1;
    let t = vec2u(u32(clamp(i, 0, r)), u32(clamp(j, 0, r)));
    let ray = light_map_ray(m, t);
    let cos_plane = dot(n, ray.dir);
    if abs(cos_plane) < 0.02 {
        return NO_VOTE;
    }
    let expected = dot(n, p - ray.origin) / cos_plane;
    let found = light_map_depths[m.offset + t.y * m.resolution + t.x];
    // The distance from the plane of the surface found, with the traces' rounding
    // (relative to their depths) counted in the receiver's favour.
    let rounding = 1.0e-4 * abs(expected);
    return (min(found, 1.0e20) - expected + rounding) * abs(cos_plane) / texel;
}

// Visibility in [0, 1] of the shadow loop's current sample from surface `s`, from the four
// texels nearest the receiver (`light_map_gap`). A texel whose ray meets the receiver's
// plane says lit, one with a surface in front of the plane says shadowed, and one whose
// ray crosses the plane where the receiver's surface does not reach (past an edge of it)
// says nothing. Where they agree, their answer; at a shadow's edge cast from afar, the
// bilinear mix of their answers (percentage-closer filtering). The sample traces its
// shadow ray instead where the texels disagree and one of them says nothing, or sees a
// surface within NEAR_GAP texels in front of the plane: a crease of the receiver (a lit
// floor at a wall's foot, which the wall's texels would darken) or a contact shadow (the
// floor behind the wall, which the floor's texels would light), which the map cannot
// tell apart. Rays also decide where the light grazes the plane or no texel meets it.
// What the map still gets wrong: an occluder (or a hole) thinner than a texel that all four
// texels' rays miss. A rect light's sample keeps its own random point (the geometric
// term stays exact) and takes its visibility from the map of the grid cell it falls in.
// Negative: trace the shadow ray (also where no map covers the sample).
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
    if SHADES_RECT && st.kind == LIGHT_RECT {
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
    var uv: vec2f;
    var texel: f32;
    let p = s.position;
    if m.kind == MAP_ORTHOGRAPHIC {
        m.axis_u = light_maps[index].axis_u;
        m.axis_v = light_maps[index].axis_v;
        m.dir = light_maps[index].dir;
        texel = m.origin.w;
        let q = p - m.origin.xyz;
        uv = vec2f(dot(q, m.axis_u.xyz) / m.axis_u.w, dot(q, m.axis_v.xyz) / m.axis_v.w);
    } else {
        let d = p - m.origin.xyz;
        let dist = length(d);
        texel = m.origin.w * dist;
        uv = octahedral_encode(d / dist);
    }
    let xy = uv * f32(m.resolution) - 0.5;
    let base = vec2i(floor(xy));
    let n = s.geometric_normal;
    let g = vec4f(light_map_gap(m, base.x, base.y, p, n, texel),
                  light_map_gap(m, base.x + 1, base.y, p, n, texel),
                  light_map_gap(m, base.x, base.y + 1, p, n, texel),
                  light_map_gap(m, base.x + 1, base.y + 1, p, n, texel));
    if any(g == vec4f(NO_VOTE)) {
        return -1.0;
    }
    // Each texel: 1 where its ray meets the receiver's plane (the receiver's surface, or
    // its continuation, is what the light sees there), 0 where a surface lies in front.
    // Past the plane (its ray crossed the plane where the receiver's surface does not
    // reach, beyond an edge of it) the texel tells nothing about the receiver.
    let lit = select(vec4f(0.0), vec4f(1.0), g >= vec4f(-PLANE_TOLERANCE));
    let past = g > vec4f(PLANE_TOLERANCE);
    let near = (g < vec4f(-PLANE_TOLERANCE)) & (g > vec4f(-NEAR_GAP));
    if all(past) || ((any(past) || any(near)) && !all(lit == vec4f(lit.x))) {
        return -1.0;
    }
    let f = xy - floor(xy);
    return mix(mix(lit.x, lit.y, f.x), mix(lit.z, lit.w, f.x), f.y);
}
