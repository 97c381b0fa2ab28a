// Glossy indirect light by importance-sampled Monte Carlo through each glossy pixel's lobe
// (algorithms.md 2.6: what the seeds do for lobes too sharp for the radiance cache, and
// here for glossy pixels no radiance record covers; covered pixels take the radiance
// splat's weighted mean, divided here): up to `samples`
// lobe directions per pixel (`glossy_sample_count`), each hit shaded with direct light (shared/glossy_bounce.wgsl, as
// the reference's glossy estimate), averaged. Pixels without a glossy lobe get 0.
// CPU mirror: glossy::reference::glossy_indirect.
//!include shared/glossy_bounce.wgsl
//!include shared/bounce_cache.wgsl
//!include shared/camera.wgsl

// One dispatch takes lobe samples [sample_begin, sample_end) of `samples` and adds them to
// the pixel's running sum (llvmpipe stops an invocation's loops after 65,535 iterations,
// so the host bounds the rays per dispatch as for the reference); the last one divides.
struct GlossyParams {
    sample_begin: u32,
    sample_end: u32,
    samples: u32,
    use_radiance: u32,   // 1: pixels the radiance splat covered take its value instead
    monte_carlo: u32,    // 0: no pixel needs lobe rays (radiance records cover them all)
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(1) @binding(0) var<uniform> camera: Camera;
@group(1) @binding(1) var<storage, read> vis: array<VisSample>;
@group(1) @binding(2) var<uniform> params: GlossyParams;
@group(1) @binding(3) var<storage, read_write> glossy_out: array<vec4f>;
// (specular * sum w L, sum w) of the radiance records (splat/radiance.rs), when used.
@group(1) @binding(4) var<storage, read> radiance: array<vec4f>;
@group(1) @binding(5) var<storage, read> bounce_cache: array<u32>;

// Secondary hits reflect the surface bounce cache's indirect irradiance (zero with one
// bounce: the cache is then empty).
fn hit_indirect_irradiance(shaded: ShadedHit, seed: u32, k: u32) -> vec3f {
    return bounce_irradiance(shaded.hit, shaded.surface.front_face);
}

// Every shadow ray is traced (no light maps).
fn shadow_from_maps(st: ShadowLoop, s: Surface) -> f32 {
    return -1.0;
}

// Lobe samples of a pixel: `samples` times the lobe's share of the material's reflectance
// (channel sums), at least 1. The lobe's noise in the pixel scales with its share, so a
// faint lobe (Sponza's vaults: Ks 0.03 beside Kd 0.85) needs few samples for the same
// relative noise as a strong one. Rust: reference::cpu::glossy_sample_count.
fn glossy_sample_count(s: Surface) -> u32 {
    let ks = materials[s.material].specular;
    let kd = surface_albedo(s);
    let g = (ks.x + ks.y) + ks.z;
    let share = g / max((kd.x + kd.y) + kd.z + g, 1.0e-6);
    return clamp(u32(ceil(f32(params.samples) * share)), 1u, params.samples);
}

// Scrambles a pixel's lobe directions (not the reference's: an independent estimate).
fn glossy_pixel_seed(pixel: u32) -> u32 {
    return hash_combine(hash_u32(pixel), 0x910u);
}

@compute @workgroup_size(8, 8)
fn main(
    @builtin(global_invocation_id) id: vec3u,
    @builtin(local_invocation_index) lane: u32,
) {
    bvh_stack_init(lane);
    if id.x >= camera.width || id.y >= camera.height {
        return;
    }
    let pixel = id.y * camera.width + id.x;
    let v = vis[pixel];
    var g = vec3f(0.0);
    var cached = vec4f(0.0);
    if params.use_radiance != 0u {
        cached = radiance[pixel];
    }
    if cached.w > 0.0 {
        // Radiance records cover the pixel: their interpolated reflection, written once.
        if params.sample_end == params.samples {
            glossy_out[pixel] = vec4f(cached.xyz / cached.w, 1.0);
        }
        return;
    }
    // Without Monte Carlo (radiance records cover every glossy pixel) the others are 0:
    // do not shade their surface (on Sponza that was 0.4 s for a copy).
    if v.instance != NO_HIT && params.monte_carlo != 0u {
        let dir = camera_ray_dir(camera, id.xy);
        let s = surface_at(Hit(v.t, v.instance, v.triangle, v.bary.x, v.bary.y), dir);
        if has_phong(s) {
            if params.sample_begin > 0u {
                g = glossy_out[pixel].xyz;
            }
            let count = glossy_sample_count(s);
            let seed = glossy_pixel_seed(pixel);
            for (var k = params.sample_begin; k < min(params.sample_end, count); k++) {
                g += glossy_bounce(s, -dir, seed, k);
            }
            if params.sample_end == params.samples {
                g = g / f32(count);
            }
        }
    }
    glossy_out[pixel] = vec4f(g, 1.0);
}
