// Light-space visibility maps (thesis section 4.4 shades hemisphere planes with shadow
// maps; this is the compute equivalent, src/light_maps): per light sample point, the
// distance to the first surface along a grid of rays traced from the light once per
// frame, so a plane hit looks its shadow up instead of tracing a shadow ray.
// Two parameterizations: orthographic for the sun (parallel rays from a plane above the
// scene, perpendicular to the sun's direction) and octahedral for a point (point and spot
// lights, and fixed points on rect lights): the sphere of directions folded onto a square.

const MAP_ORTHOGRAPHIC: u32 = 0u;
const MAP_OCTAHEDRAL: u32 = 1u;
const MAP_NO_HIT: f32 = 1.0e30;

// Mirror of `GpuLightMap` (src/light_maps/mod.rs).
struct LightMap {
    kind: u32,
    light: u32,         // the light's slot in `lights`
    resolution: u32,    // texels per side
    offset: u32,        // first texel in the depth array
    origin: vec4f,      // orthographic: texel (0, 0)'s corner on the ray plane; octahedral:
                        // the point rays start from. w: texel size (world units, or radians)
    axis_u: vec4f,      // orthographic: unit u and v across the map (xyz), and the map's
    axis_v: vec4f,      // extent along them (w)
    dir: vec4f,         // orthographic: the rays' unit direction (away from the sun);
                        // octahedral: w, where the rays start (OCTAHEDRAL_TMIN)
}

// Octahedral encoding of a unit direction onto [0, 1]^2 (Engelhardt & Dachsbacher 2008).
fn octahedral_encode(d: vec3f) -> vec2f {
    let a = d / (abs(d.x) + abs(d.y) + abs(d.z));
    var e = a.xy;
    if a.z < 0.0 {
        let s = vec2f(select(-1.0, 1.0, a.x >= 0.0), select(-1.0, 1.0, a.y >= 0.0));
        e = (1.0 - abs(a.yx)) * s;
    }
    return e * 0.5 + 0.5;
}

fn octahedral_decode(uv: vec2f) -> vec3f {
    let e = uv * 2.0 - 1.0;
    var d = vec3f(e, 1.0 - abs(e.x) - abs(e.y));
    if d.z < 0.0 {
        let s = vec2f(select(-1.0, 1.0, d.x >= 0.0), select(-1.0, 1.0, d.y >= 0.0));
        d = vec3f((1.0 - abs(d.yx)) * s, d.z);
    }
    return normalize(d);
}

// The ray of texel (i, j) of map `m`.
fn light_map_ray(m: LightMap, texel: vec2u) -> Ray {
    let uv = (vec2f(texel) + 0.5) / f32(m.resolution);
    if m.kind == MAP_ORTHOGRAPHIC {
        let o = m.origin.xyz + uv.x * m.axis_u.w * m.axis_u.xyz + uv.y * m.axis_v.w * m.axis_v.xyz;
        return Ray(o, 0.0, m.dir.xyz, INF);
    }
    // Starting dir.w out (light_maps::OCTAHEDRAL_TMIN): a light on a surface would
    // otherwise hit it at t = 0 in every direction.
    return Ray(m.origin.xyz, m.dir.w, octahedral_decode(uv), INF);
}
