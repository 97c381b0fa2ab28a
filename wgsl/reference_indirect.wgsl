// Reference first-bounce indirect light: brute-force Monte Carlo per pixel, deterministic.
// For every visible pixel, samples [sample_begin, sample_end) of N cosine-distributed
// directions around the shading normal (Owen-scrambled Sobol, scramble seeded per pixel
// and by `params.seed`: 0 is the historical sequence, any other value an independent one)
// are traced to their closest hit, whose outgoing radiance is
//   L = albedo(hit) / pi * E_direct(hit) + indirect_emission(hit)         (Lambertian)
// and added, in sample order, to the pixel's running sum. With the cosine pdf
// p(w) = cos(w) / pi, the irradiance estimate is E = pi / N * sum(L) and the reflected
// radiance albedo / pi * E = albedo / N * sum(L); the host does that last step.
// Rays that miss add nothing: the environment is already a light of `direct_irradiance`
// (it would otherwise be counted twice, like sampled emitters: Ward's rule).
// With N bounces (`params.bounces`) the path goes on from the hit N - 1 more times
// (`hit_indirect_irradiance`): cosine-distributed, Lambertian at every hit, each hit's
// direct light sampled, so L = albedo / pi * E_direct + L_e + albedo * L(next hit).
// Pixels with a glossy lobe also sample the lobe (importance sampling, `glossy_bounce`):
// `glossy_sum` gathers f cos / pdf * L per sample, the host divides by N. The two lobes'
// estimates add up to the pixel's first-bounce indirect light.
// CPU mirror: src/reference/cpu.rs.
//!include shared/glossy_bounce.wgsl
//!include shared/camera.wgsl

struct ReferenceParams {
    sample_begin: u32,
    sample_end: u32,
    row_begin: u32,
    row_end: u32,
    // `radsplat reference --seed`: 0 keeps the seed-less bytes; others rescramble.
    seed: u32,
    bounces: u32,   // N: light reflected N times in all (1: direct light at the bounce hit)
    _pad1: u32,
    _pad2: u32,
}

@group(1) @binding(0) var<uniform> camera: Camera;
@group(1) @binding(1) var<storage, read> vis: array<VisSample>;
@group(1) @binding(2) var<uniform> params: ReferenceParams;
@group(1) @binding(3) var<storage, read_write> radiance_sum: array<vec4f>;
@group(1) @binding(4) var<storage, read_write> glossy_sum: array<vec4f>;

// Scramble seed of a pixel's hemisphere directions (the direct pass uses hash_u32(pixel)).
// A non-zero `seed` is hashed in too: a different Owen scramble of the Sobol points and
// different light samples at the bounce hits (seed 0 gives the historical, seed-less bytes).
fn indirect_seed(pixel: u32, seed: u32) -> u32 {
    let s = hash_combine(hash_u32(pixel), 0x1d1u);
    if seed == 0u {
        return s;
    }
    return hash_combine(s, seed);
}

// The reference traces every shadow ray (no light maps).
fn shadow_from_maps(st: ShadowLoop, s: Surface) -> f32 {
    return -1.0;
}

// Outgoing radiance towards the pixel of the closest hit along direction sample `k`.
// Indirect irradiance at a bounce hit: bounces 2..N of the path from it, one
// cosine-distributed direction each (sample `k` of a sequence scrambled per bounce), with
// the hits' direct light and emission; with the cosine pdf, pi times the path's radiance
// estimates it. Zero with one bounce. CPU mirror: reference::cpu::path_irradiance.
fn hit_indirect_irradiance(shaded: ShadedHit, seed: u32, k: u32) -> vec3f {
    var l = vec3f(0.0);
    var throughput = vec3f(1.0);
    var s = shaded.surface;
    for (var b = 2u; b <= params.bounces; b++) {
        let bounce_seed = hash_combine(seed, PATH_SEED + b);
        let dir = orthonormal_basis(s.shading_normal) * cosine_hemisphere(sobol_2d(k, bounce_seed));
        if dot(dir, s.geometric_normal) <= 0.0 {
            break;
        }
        let next = trace_and_shade(
            Ray(offset_ray_origin(s.position, s.geometric_normal), 0.0, dir, INF),
            hash_combine(bounce_seed, k), scene_info.light_samples);
        if next.hit.instance == NO_HIT {
            break;
        }
        let h = next.surface;
        let albedo = surface_albedo(h);
        l += throughput * (albedo * (1.0 / PI) * next.irradiance + indirect_emission(h));
        throughput *= albedo;
        s = h;
    }
    return PI * l;
}

// Scrambles the directions of bounce b >= 2 (with the caller's seed, plus b).
const PATH_SEED: u32 = 0xb0u;

fn bounce_radiance(s: Surface, seed: u32, k: u32) -> vec3f {
    let dir = orthonormal_basis(s.shading_normal) * cosine_hemisphere(sobol_2d(k, seed));
    if dot(dir, s.geometric_normal) <= 0.0 {
        return vec3f(0.0); // below the geometric surface: the ray cannot leave it
    }
    let origin = offset_ray_origin(s.position, s.geometric_normal);
    // The bounce ray and its hit's shadow rays through one traversal (cheaper to compile).
    let shaded = trace_and_shade(
        Ray(origin, 0.0, dir, INF), hash_combine(seed, k), scene_info.light_samples);
    if shaded.hit.instance == NO_HIT {
        return vec3f(0.0);
    }
    return hit_radiance(shaded, seed, k);
}

@compute @workgroup_size(8, 8)
fn main(
    @builtin(global_invocation_id) id: vec3u,
    @builtin(local_invocation_index) lane: u32,
) {
    bvh_stack_init(lane);
    let y = params.row_begin + id.y;
    if id.x >= camera.width || y >= params.row_end || y >= camera.height {
        return;
    }
    let pixel = y * camera.width + id.x;
    let v = vis[pixel];
    if v.instance == NO_HIT {
        return;
    }
    let dir = camera_ray_dir(camera, vec2u(id.x, y));
    let s = surface_at(Hit(v.t, v.instance, v.triangle, v.bary.x, v.bary.y), dir);
    let seed = indirect_seed(pixel, params.seed);
    var sum = radiance_sum[pixel].xyz;
    for (var k = params.sample_begin; k < params.sample_end; k++) {
        sum += bounce_radiance(s, seed, k);
    }
    radiance_sum[pixel] = vec4f(sum, 1.0);
    if has_phong(s) {
        var g = glossy_sum[pixel].xyz;
        for (var k = params.sample_begin; k < params.sample_end; k++) {
            g += glossy_bounce(s, -dir, seed, k);
        }
        glossy_sum[pixel] = vec4f(g, 1.0);
    }
}
