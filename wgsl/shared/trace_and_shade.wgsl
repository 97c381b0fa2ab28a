// One traced ray and its hit's direct light through a single call of `trace`
// (shared/shading.wgsl `ShadowLoop`), for the passes that shade secondary hits: hemisphere
// planes (shared/plane.wgsl), glossy lobes (shared/glossy_bounce.wgsl), the bounce cache's
// gather (bounce_gather.wgsl) and the reference's bounce (reference_indirect.wgsl).
//!include shared/shading.wgsl

// What `trace_and_shade` found: the closest hit (instance NO_HIT on a miss), its surface
// and the direct irradiance there.
struct ShadedHit {
    hit: Hit,
    surface: Surface,
    irradiance: vec3f,
    env_irradiance: vec3f,   // the environment's share of `irradiance`
}

// The closest hit of `primary` and `direct_irradiance_samples(surface, seed, count)` at it,
// with the primary ray and every shadow ray traced by one call of `trace` (see
// `ShadowLoop`): the same hit and the same bytes as tracing and shading apart. The
// including pass defines `fn shadow_from_maps(st: ShadowLoop, s: Surface) -> f32`: the
// visibility in [0, 1] of the current sample from light-space maps, or a negative value
// to trace its shadow ray (shared/light_map_lookup.wgsl; `return -1.0;` traces them all).
fn trace_and_shade(primary: Ray, seed: u32, count: u32) -> ShadedHit {
    return trace_and_shade_at(primary, seed, 0u, count, 0u);
}

// The same with the light samples from index `first` of their sequences on
// (`shadow_loop_start_at`), and with `choices` above 0 from that many lights chosen by
// weight (`shadow_loop_start_chosen`: hemisphere-plane hits).
fn trace_and_shade_at(primary: Ray, seed: u32, first: u32, count: u32, choices: u32) -> ShadedHit {
    var out: ShadedHit;
    out.irradiance = vec3f(0.0);
    out.env_irradiance = vec3f(0.0);
    var st: ShadowLoop;
    var ray = primary;
    var shadow = false;
    loop {
        let h = trace(ray, shadow);
        if !shadow {
            out.hit = h;
            if h.instance == NO_HIT {
                break;
            }
            out.surface = surface_at(h, primary.dir);
            st = shadow_loop_start_chosen(out.surface, seed, first, count, choices);
        } else if h.instance == NO_HIT {
            shadow_loop_add(&st);
        }
        // The next sample that needs a ray; those the maps answer are counted here.
        var traced = false;
        while shadow_loop_next(&st, out.surface) {
            let v = shadow_from_maps(st, out.surface);
            if v < 0.0 {
                traced = true;
                break;
            }
            shadow_loop_add_visible(&st, v);
        }
        if !traced {
            out.irradiance = st.e;
            out.env_irradiance = st.e_env;
            break;
        }
        ray = shadow_ray(out.surface, st.sample.target_point, st.sample.to_infinity);
        shadow = true;
    }
    return out;
}

// Outgoing radiance of a shaded secondary hit (Lambertian): its direct irradiance plus the
// indirect irradiance the including pass finds there, reflected, and emission not sampled
// as a light. The including pass defines
// `fn hit_indirect_irradiance(shaded: ShadedHit, seed: u32, k: u32) -> vec3f`: the
// surface bounce cache (shared/bounce_cache.wgsl) with `--bounces` above 1, the
// reference's path continuation, or zero (one bounce). `seed` and `k` are the caller's
// sequence seed and sample index.
fn hit_radiance(shaded: ShadedHit, seed: u32, k: u32) -> vec3f {
    return hit_radiance_with_albedo(shaded, surface_albedo(shaded.surface), seed, k);
}

// The same with the hit's albedo (`surface_albedo`) already looked up: a textured albedo
// is four texel loads and twelve sRGB decodes, which a caller that needs it again pays
// once.
fn hit_radiance_with_albedo(shaded: ShadedHit, albedo: vec3f, seed: u32, k: u32) -> vec3f {
    let e = shaded.irradiance + hit_indirect_irradiance(shaded, seed, k);
    return albedo * (1.0 / PI) * e + indirect_emission(shaded.surface);
}
