// Direct-light pass: shades every visible pixel with direct light (shadow rays) and
// emission; background pixels see the environment. Writes the beauty image and AOVs.
// Lambertian and glossy lobes share the shadow samples (one loop, one ray each).
//!include shared/glossy.wgsl
//!include shared/camera.wgsl

@group(1) @binding(0) var<uniform> camera: Camera;
@group(1) @binding(1) var<storage, read> vis: array<VisSample>;
@group(1) @binding(2) var<storage, read_write> beauty: array<vec4f>;   // emission + direct
@group(1) @binding(3) var<storage, read_write> albedo_out: array<vec4f>;
@group(1) @binding(4) var<storage, read_write> direct_out: array<vec4f>; // reflected direct light

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
    let dir = camera_ray_dir(camera, id.xy);
    if v.instance == NO_HIT {
        beauty[pixel] = vec4f(environment_radiance(dir), 1.0);
        albedo_out[pixel] = vec4f(0.0);
        direct_out[pixel] = vec4f(0.0);
        return;
    }
    let s = surface_at(Hit(v.t, v.instance, v.triangle, v.bary.x, v.bary.y), dir);
    let albedo = surface_albedo(s);
    // direct_irradiance's loop, with each visible sample also weighed by the glossy lobe:
    // L = albedo / pi * E + sum f(wo, wi) L_i cos dw_i.
    var st = shadow_loop_start(s, hash_u32(pixel), scene_info.light_samples);
    let phong = has_phong(s);
    let wo = -dir;
    var glossy = vec3f(0.0);
    while shadow_loop_next(&st, s) {
        if visible(s, st.sample.target_point, st.sample.to_infinity) {
            if phong {
                glossy += phong_eval(s, wo, shadow_sample_direction(st, s))
                    * shadow_sample_irradiance(st);
            }
            shadow_loop_add(&st);
        }
    }
    let direct = albedo * (1.0 / PI) * st.e + glossy;
    beauty[pixel] = vec4f(surface_emission(s) + direct, 1.0);
    albedo_out[pixel] = vec4f(albedo, 1.0);
    direct_out[pixel] = vec4f(direct, 1.0);
}
