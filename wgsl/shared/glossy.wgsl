// The glossy lobe of materials (Rust: scene::brdf::GlossyLobe): normalised Phong,
// f = specular (n + 2) / (2 pi) cos^n(alpha), alpha between wi and the mirror direction of
// wo; its sampling (cos^n about the mirror direction); each visible shadow sample's share
// of the irradiance (what the lobe weighs in glossy direct light). Directions point away
// from the surface. One glossy bounce: shared/glossy_bounce.wgsl.
//!include shared/shading.wgsl

fn has_phong(s: Surface) -> bool {
    return (materials[s.material].flags & MATERIAL_PHONG) != 0u;
}

fn mirror_direction(n: vec3f, wo: vec3f) -> vec3f {
    return 2.0 * dot(n, wo) * n - wo;
}

// The Phong lobe's BRDF (not cosine-weighted) of surface `s`.
fn phong_eval(s: Surface, wo: vec3f, wi: vec3f) -> vec3f {
    let n = s.shading_normal;
    if dot(n, wo) <= 0.0 || dot(n, wi) <= 0.0 {
        return vec3f(0.0);
    }
    let c = dot(mirror_direction(n, wo), wi);
    if c <= 0.0 {
        return vec3f(0.0);
    }
    let m = materials[s.material];
    return m.specular * ((m.exponent + 2.0) / (2.0 * PI) * pow(c, m.exponent));
}

// The density per solid angle of `phong_sample`.
fn phong_pdf(s: Surface, wo: vec3f, wi: vec3f) -> f32 {
    let c = dot(mirror_direction(s.shading_normal, wo), wi);
    if c <= 0.0 {
        return 0.0;
    }
    let e = materials[s.material].exponent;
    return (e + 1.0) / (2.0 * PI) * pow(c, e);
}

// A direction of density cos^n about the mirror direction, for `u` in [0, 1)^2.
fn phong_sample(s: Surface, wo: vec3f, u: vec2f) -> vec3f {
    let e = materials[s.material].exponent;
    let cos_a = pow(u.x, 1.0 / (e + 1.0));
    let sin_a = sqrt(max(0.0, 1.0 - cos_a * cos_a));
    let phi = 2.0 * PI * u.y;
    return orthonormal_basis(mirror_direction(s.shading_normal, wo))
        * vec3f(sin_a * cos(phi), sin_a * sin(phi), cos_a);
}

// The current shadow sample's share of the irradiance when visible (`shadow_loop_add` sums
// these per slot): L cos dw for its light, so that sum(f * share) is the glossy radiance.
fn shadow_sample_irradiance(st: ShadowLoop) -> vec3f {
    let smp = st.sample;
    if st.kind == LIGHT_RECT {
        return st.light.d.xyz * (smp.cos_s * smp.rect_weight / f32(st.count));
    } else if st.kind == LIGHT_ENVIRONMENT && has_environment_map() {
        // Importance-sampled map: L cos / pdf / count per sample.
        return smp.intensity / f32(st.count);
    } else if st.kind == LIGHT_ENVIRONMENT {
        // Cosine-distributed directions: L cos dw = pi L / count per sample.
        return scene_info.environment * (PI / f32(st.count));
    } else if st.kind == LIGHT_SUN {
        return st.light.d.xyz * smp.cos_s;
    }
    return smp.intensity * (smp.cos_s / smp.d2);
}

// The direction from `s` to the current shadow sample.
fn shadow_sample_direction(st: ShadowLoop, s: Surface) -> vec3f {
    if st.sample.to_infinity {
        return st.sample.target_point;
    }
    return normalize(st.sample.target_point - s.position);
}
