// Surface reconstruction from a hit, textured albedo, and direct light with shadow rays.
// Used by the direct-light pass (camera hits) and by later passes that shade secondary hits.
//!include shared/bvh.wgsl
//!include shared/sampling.wgsl

struct Surface {
    position: vec3f,
    geometric_normal: vec3f,   // unit, facing the incoming ray
    shading_normal: vec3f,     // unit, same hemisphere as geometric_normal
    uv: vec2f,
    material: u32,
    front_face: bool,          // the ray hit the side the triangle's winding faces
    mesh_triangle: u32,
}

fn surface_at(hit: Hit, ray_dir: vec3f) -> Surface {
    let tri = triangles[hit.triangle];
    let sh = shading[hit.triangle];
    let inst = instances[hit.instance];
    let w = 1.0 - hit.u - hit.v;
    let p_obj = tri.v0.xyz + hit.u * tri.e1.xyz + hit.v * tri.e2.xyz;
    var s: Surface;
    s.position = transform_point(inst.world_from_object, p_obj);
    var ng = normalize(transform_vector(inst.normal_to_world, cross(tri.e1.xyz, tri.e2.xyz)));
    // Vertex normals of zero length mark missing or broken data: use the geometric normal.
    let usable = dot(sh.n0, sh.n0) > 0.0 && dot(sh.n1, sh.n1) > 0.0 && dot(sh.n2, sh.n2) > 0.0;
    var ns = ng;
    if usable {
        let n_obj = w * sh.n0 + hit.u * sh.n1 + hit.v * sh.n2;
        if dot(n_obj, n_obj) > 1.0e-12 {
            ns = normalize(transform_vector(inst.normal_to_world, n_obj));
        }
    }
    s.front_face = dot(ng, ray_dir) < 0.0;
    if !s.front_face {
        ng = -ng;
    }
    // Keep the shading normal on the viewer's side of the surface.
    if dot(ns, ng) < 0.0 {
        ns = -ns;
    }
    s.geometric_normal = ng;
    s.shading_normal = ns;
    s.uv = w * sh.uv01.xy + hit.u * sh.uv01.zw + hit.v * sh.uv2.xy;
    s.material = sh.material;
    s.mesh_triangle = sh.mesh_triangle;
    return s;
}

// `s` (from `surface_at(hit, d)`) as `surface_at(hit, ray_dir)` would give it: only the
// side it is seen from changes, so the triangle and instance need not be loaded again.
fn surface_facing(s: Surface, ray_dir: vec3f) -> Surface {
    let ng = select(-s.geometric_normal, s.geometric_normal, s.front_face);
    var out = s;
    out.front_face = dot(ng, ray_dir) < 0.0;
    if out.front_face != s.front_face {
        out.geometric_normal = -s.geometric_normal;
        out.shading_normal = -s.shading_normal;
    }
    return out;
}

fn srgb_to_linear(c: f32) -> f32 {
    return select(pow((c + 0.055) / 1.055, 2.4), c / 12.92, c <= 0.04045);
}

fn texel(info: TextureInfo, x: i32, y: i32) -> vec3f {
    // Repeat wrap.
    let xi = u32(((x % i32(info.width)) + i32(info.width)) % i32(info.width));
    let yi = u32(((y % i32(info.height)) + i32(info.height)) % i32(info.height));
    let c = unpack4x8unorm(texels[info.offset + yi * info.width + xi]);
    return vec3f(srgb_to_linear(c.x), srgb_to_linear(c.y), srgb_to_linear(c.z));
}

// Bilinear lookup in linear colour; v = 1 is the top row of the image.
fn sample_texture(index: u32, uv: vec2f) -> vec3f {
    let info = texture_infos[index];
    let x = (uv.x - floor(uv.x)) * f32(info.width) - 0.5;
    let y = (1.0 - (uv.y - floor(uv.y))) * f32(info.height) - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let xi = i32(x0);
    let yi = i32(y0);
    let top = mix(texel(info, xi, yi), texel(info, xi + 1, yi), fx);
    let bottom = mix(texel(info, xi, yi + 1), texel(info, xi + 1, yi + 1), fx);
    return mix(top, bottom, fy);
}

fn surface_albedo(s: Surface) -> vec3f {
    let m = materials[s.material];
    if m.texture == NO_TEXTURE {
        return m.albedo;
    }
    return m.albedo * sample_texture(m.texture, s.uv);
}

// Emitted radiance towards the viewer (emitters are one-sided).
fn surface_emission(s: Surface) -> vec3f {
    return select(vec3f(0.0), materials[s.material].emission, s.front_face);
}

// Emitted radiance seen by an indirect (secondary) ray: emitters that direct lighting
// already samples count as zero there, or they would be counted twice (Ward's rule).
fn indirect_emission(s: Surface) -> vec3f {
    if (materials[s.material].flags & MATERIAL_SAMPLED_LIGHT) != 0u {
        return vec3f(0.0);
    }
    return surface_emission(s);
}

// Shadow ray from the surface to `target_point` (excluded), or towards a direction when
// `to_infinity`.
fn visible(s: Surface, target_point: vec3f, to_infinity: bool) -> bool {
    let origin = offset_ray_origin(s.position, s.geometric_normal);
    var ray: Ray;
    ray.origin = origin;
    ray.tmin = 0.0;
    if to_infinity {
        ray.dir = target_point;
        ray.tmax = INF;
    } else {
        ray.dir = target_point - origin;
        ray.tmax = 1.0 - 1.0e-4;
    }
    return !occluded(ray);
}

// Direct irradiance at a surface from every light and the constant environment, with
// visibility. Area lights and the environment use `scene_info.light_samples` points of an
// Owen-scrambled Sobol sequence whose scramble is seeded by `seed` (e.g. the pixel).
fn direct_irradiance(s: Surface, seed: u32) -> vec3f {
    return direct_irradiance_samples(s, seed, scene_info.light_samples);
}

// Sample k of a rect light (scrambled Sobol point on the quad).
fn rect_light_point(light: Light, k: u32, light_seed: u32) -> vec3f {
    let xi = sobol_2d(k, light_seed);
    return light.a.xyz + xi.x * light.b.xyz + xi.y * light.c.xyz;
}

// Scrambles the environment's directions (with the surface's seed).
const ENVIRONMENT_SEED: u32 = 0xe17u;

// Same with `count` samples per area light and for the environment (secondary hits use
// fewer than camera pixels: the hemisphere sum averages their noise).
fn direct_irradiance_samples(s: Surface, seed: u32, count: u32) -> vec3f {
    let n = s.shading_normal;
    let ng = s.geometric_normal;
    var e = vec3f(0.0);
    for (var li = 0u; li < scene_info.light_count; li++) {
        let light = lights[li];
        let kind = bitcast<u32>(light.a.w);
        if kind == LIGHT_POINT || kind == LIGHT_SPOT {
            let to_light = light.a.xyz - s.position;
            let d2 = dot(to_light, to_light);
            let l = to_light * inverseSqrt(d2);
            let cos_s = dot(n, l);
            if cos_s <= 0.0 || dot(ng, l) <= 0.0 {
                continue;
            }
            var intensity = light.d.xyz;
            if kind == LIGHT_SPOT {
                intensity *= smoothstep(light.c.w, light.b.w, dot(-l, light.b.xyz));
            }
            if all(intensity == vec3f(0.0)) || !visible(s, light.a.xyz, false) {
                continue;
            }
            e += intensity * cos_s / d2;
        } else if kind == LIGHT_SUN {
            let l = light.a.xyz;
            let cos_s = dot(n, l);
            if cos_s <= 0.0 || dot(ng, l) <= 0.0 || !visible(s, l, true) {
                continue;
            }
            e += light.d.xyz * cos_s;
        } else if kind == LIGHT_RECT {
            let eu = light.b.xyz;
            let ev = light.c.xyz;
            let cr = cross(eu, ev);
            let area = length(cr);
            let nl = cr / area;
            var sum = vec3f(0.0);
            let light_seed = hash_combine(seed, li);
            for (var k = 0u; k < count; k++) {
                let q = rect_light_point(light, k, light_seed);
                let to_q = q - s.position;
                let d2 = dot(to_q, to_q);
                let l = to_q * inverseSqrt(d2);
                let cos_s = dot(n, l);
                let cos_l = -dot(nl, l);
                if cos_s <= 0.0 || cos_l <= 0.0 || dot(ng, l) <= 0.0 {
                    continue;
                }
                if visible(s, q, false) {
                    sum += vec3f(cos_s * cos_l / d2);
                }
            }
            e += light.d.xyz * sum * (area / f32(count));
        }
    }
    // Constant environment: E = L_env * integral of V cos = pi L_env * mean visibility
    // over cosine-distributed directions.
    let env = scene_info.environment;
    if any(env != vec3f(0.0)) {
        let frame = orthonormal_basis(n);
        var unoccluded = 0u;
        let env_seed = hash_combine(seed, ENVIRONMENT_SEED);
        for (var k = 0u; k < count; k++) {
            let dir = frame * cosine_hemisphere(sobol_2d(k, env_seed));
            if dot(dir, ng) > 0.0 && visible(s, dir, true) {
                unoccluded += 1u;
            }
        }
        e += env * (PI * f32(unoccluded) / f32(count));
    }
    return e;
}
