// One glossy bounce: importance-sampled first-bounce indirect light through a material's
// glossy lobe, shared by the reference (reference_indirect.wgsl) and the glossy indirect
// pass (glossy_indirect.wgsl). CPU mirror: reference::cpu::glossy_bounce.
//!include shared/glossy.wgsl
//!include shared/trace_and_shade.wgsl

// Scrambles a glossy pixel's lobe directions (with its seed).
const GLOSSY_SEED: u32 = 0x6c055u;

// Lobe sample `k` of surface `s` seen from `wo`: the radiance of the closest hit (direct
// light, Lambertian, and emission not sampled as a light) times f cos / pdf, an unbiased
// estimate of the lobe's first-bounce indirect light. Misses add nothing: the environment
// is a light of direct lighting (as for the Lambertian bounce).
fn glossy_bounce(s: Surface, wo: vec3f, seed: u32, k: u32) -> vec3f {
    let wi = phong_sample(s, wo, sobol_2d(k, hash_combine(seed, GLOSSY_SEED)));
    let cos_i = dot(wi, s.shading_normal);
    if cos_i <= 0.0 || dot(wi, s.geometric_normal) <= 0.0 {
        return vec3f(0.0);
    }
    let pdf = phong_pdf(s, wo, wi);
    if pdf <= 0.0 {
        return vec3f(0.0);
    }
    let origin = offset_ray_origin(s.position, s.geometric_normal);
    let shaded = trace_and_shade(
        Ray(origin, 0.0, wi, INF), hash_combine(seed, k ^ GLOSSY_SEED), scene_info.light_samples);
    if shaded.hit.instance == NO_HIT {
        return vec3f(0.0);
    }
    let l = hit_radiance(shaded, hash_combine(seed, GLOSSY_SEED), k);
    return phong_eval(s, wo, wi) * (cos_i / pdf) * l;
}
