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

// The environment's slot after the lights in `direct_irradiance_samples`' light loop.
const LIGHT_ENVIRONMENT: u32 = 0xffffffffu;

// Same with `count` samples per area light and for the environment (secondary hits use
// fewer than camera pixels: the hemisphere sum averages their noise).
//
// Every shadow ray goes through the one `visible` call below: lights and the environment
// are slots of one loop, each with one sample (point, spot, sun) or `count` (rect light,
// environment), set up by kind before the shared trace. Each call site of the BVH
// traversal is a full copy of it for the shader compiler (lavapipe's LLVM JIT took
// seconds per copy on a cold start); the sums are the same expressions in the same order
// as one branch per kind would give. (llvmpipe's per-loop iteration limit counts this
// loop's rays together, which `GpuContext::check_shadow_rays` already assumes: it bounds
// the rays of all lights and the environment summed.)
fn direct_irradiance_samples(s: Surface, seed: u32, count: u32) -> vec3f {
    let n = s.shading_normal;
    let ng = s.geometric_normal;
    let env = scene_info.environment;
    let slots = scene_info.light_count + select(0u, 1u, any(env != vec3f(0.0)));
    let env_frame = orthonormal_basis(n);
    let env_seed = hash_combine(seed, ENVIRONMENT_SEED);
    var e = vec3f(0.0);
    for (var li = 0u; li < slots; li++) {
        let is_env = li == scene_info.light_count;
        let light = lights[min(li, max(scene_info.light_count, 1u) - 1u)];
        let kind = select(bitcast<u32>(light.a.w), LIGHT_ENVIRONMENT, is_env);
        let many = kind == LIGHT_RECT || kind == LIGHT_ENVIRONMENT;
        let samples = select(1u, count, many);
        // Rect light: its quad's area and normal; its sum of cos cos / d^2 over samples.
        let cr = cross(light.b.xyz, light.c.xyz);
        let area = length(cr);
        let nl = cr / area;
        let light_seed = hash_combine(seed, li);
        var sum = vec3f(0.0);
        var unoccluded = 0u;
        for (var k = 0u; k < samples; k++) {
            // The shadow ray of this sample: towards `target_point` (a point, or a
            // direction when `to_infinity`), traced only when `lit` (the tests are
            // written as the negated refusals so that NaNs go the same way as in
            // `direct::reference`).
            var target_point = vec3f(0.0);
            var to_infinity = false;
            var lit = false;
            var cos_s = 0.0;
            var cos_l = 0.0;
            var d2 = 1.0;
            var intensity = vec3f(0.0);
            if kind == LIGHT_POINT || kind == LIGHT_SPOT {
                let to_light = light.a.xyz - s.position;
                d2 = dot(to_light, to_light);
                let l = to_light * inverseSqrt(d2);
                cos_s = dot(n, l);
                intensity = light.d.xyz;
                if kind == LIGHT_SPOT {
                    intensity *= smoothstep(light.c.w, light.b.w, dot(-l, light.b.xyz));
                }
                target_point = light.a.xyz;
                lit = !(cos_s <= 0.0 || dot(ng, l) <= 0.0) && !all(intensity == vec3f(0.0));
            } else if kind == LIGHT_SUN {
                let l = light.a.xyz;
                cos_s = dot(n, l);
                target_point = l;
                to_infinity = true;
                lit = !(cos_s <= 0.0 || dot(ng, l) <= 0.0);
            } else if kind == LIGHT_RECT {
                let q = rect_light_point(light, k, light_seed);
                let to_q = q - s.position;
                d2 = dot(to_q, to_q);
                let l = to_q * inverseSqrt(d2);
                cos_s = dot(n, l);
                cos_l = -dot(nl, l);
                target_point = q;
                lit = !(cos_s <= 0.0 || cos_l <= 0.0 || dot(ng, l) <= 0.0);
            } else if kind == LIGHT_ENVIRONMENT {
                let dir = env_frame * cosine_hemisphere(sobol_2d(k, env_seed));
                target_point = dir;
                to_infinity = true;
                lit = dot(dir, ng) > 0.0;
            }
            if lit && visible(s, target_point, to_infinity) {
                if kind == LIGHT_RECT {
                    sum += vec3f(cos_s * cos_l / d2);
                } else if kind == LIGHT_ENVIRONMENT {
                    unoccluded += 1u;
                } else if kind == LIGHT_SUN {
                    e += light.d.xyz * cos_s;
                } else {
                    e += intensity * cos_s / d2;
                }
            }
        }
        if kind == LIGHT_RECT {
            e += light.d.xyz * sum * (area / f32(count));
        } else if kind == LIGHT_ENVIRONMENT {
            // Constant environment: E = L_env * integral of V cos = pi L_env * mean
            // visibility over cosine-distributed directions.
            e += env * (PI * f32(unoccluded) / f32(count));
        }
    }
    return e;
}
