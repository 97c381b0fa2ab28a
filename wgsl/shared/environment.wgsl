// The environment: a constant radiance, or an HDR latitude-longitude map sampled by
// importance (Rust: scene::environment::EnvironmentMap, the same texels, tables and
// conventions). The map lives in the texel table at `scene_info.env_map`: RGB floats of
// every texel (top row first), the row CDF, then each row's column CDF, as f32 bits.
// Map frame: the world turned by -rotation about +y; theta from +y, phi = atan2(x, -z).
//!include shared/scene.wgsl

const NO_ENVIRONMENT_MAP: u32 = 0xffffffffu;   // Rust: gpu::scene_buffers::NO_ENVIRONMENT_MAP

fn has_environment_map() -> bool {
    return scene_info.env_map != NO_ENVIRONMENT_MAP;
}

// Whether the environment is a light at all (a map, or a non-black constant).
fn has_environment() -> bool {
    return has_environment_map() || any(scene_info.environment != vec3f(0.0));
}

fn env_float(k: u32) -> f32 {
    return bitcast<f32>(texels[scene_info.env_map + k]);
}

fn env_texel(i: u32, j: u32) -> vec3f {
    let k = 3u * (j * scene_info.env_size.x + i);
    return vec3f(env_float(k), env_float(k + 1u), env_float(k + 2u));
}

// World direction -> map frame (rotation by -angle about +y).
fn env_to_map(d: vec3f) -> vec3f {
    let c = scene_info.env_rotation.x;
    let s = -scene_info.env_rotation.y;
    return vec3f(c * d.x + s * d.z, d.y, -s * d.x + c * d.z);
}

fn env_to_world(m: vec3f) -> vec3f {
    let c = scene_info.env_rotation.x;
    let s = scene_info.env_rotation.y;
    return vec3f(c * m.x + s * m.z, m.y, -s * m.x + c * m.z);
}

// The texel (i, j) a world direction falls in.
fn env_texel_of(d: vec3f) -> vec2u {
    let m = env_to_map(d);
    let theta = acos(clamp(m.y, -1.0, 1.0));
    var phi = atan2(m.x, -m.z);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let w = scene_info.env_size.x;
    let h = scene_info.env_size.y;
    return vec2u(min(u32(phi / (2.0 * PI) * f32(w)), w - 1u),
                 min(u32(theta / PI * f32(h)), h - 1u));
}

// Radiance arriving from world direction `d` (unit) out of the scene.
fn environment_radiance(d: vec3f) -> vec3f {
    if !has_environment_map() {
        return scene_info.environment;
    }
    let t = env_texel_of(d);
    return env_texel(t.x, t.y);
}

struct EnvInterval {
    index: u32,
    fraction: f32,
    ok: bool,
}

// The interval k of the CDF at `base` (n + 1 values) with cdf[k] <= u < cdf[k + 1], and
// where u falls in it (Rust: environment::invert).
fn env_invert(base: u32, n: u32, u: f32) -> EnvInterval {
    var lo = 0u;
    var hi = n;
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if env_float(base + mid) <= u {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let c0 = env_float(base + lo);
    let width = env_float(base + lo + 1u) - c0;
    if width <= 0.0 {
        return EnvInterval(lo, 0.0, false);
    }
    return EnvInterval(lo, clamp((u - c0) / width, 0.0, 0.999999), true);
}

struct EnvSample {
    dir: vec3f,
    pdf: f32,           // per solid angle; 0: no sample
    radiance: vec3f,
}

// Density per solid angle of a direction in texel (i, j) at sin(theta) `st`.
fn env_pdf_texel(i: u32, j: u32, st: f32) -> f32 {
    let w = scene_info.env_size.x;
    let h = scene_info.env_size.y;
    let rows = 3u * w * h;
    let p_row = env_float(rows + j + 1u) - env_float(rows + j);
    let cols = rows + h + 1u + j * (w + 1u);
    let p_col = env_float(cols + i + 1u) - env_float(cols + i);
    if st <= 0.0 {
        return 0.0;
    }
    return p_row * p_col * f32(w * h) / (2.0 * PI * PI * st);
}

// A direction drawn from the map by importance for `u` in [0, 1)^2.
fn environment_sample(u: vec2f) -> EnvSample {
    var out = EnvSample(vec3f(0.0, 1.0, 0.0), 0.0, vec3f(0.0));
    let w = scene_info.env_size.x;
    let h = scene_info.env_size.y;
    let rows = 3u * w * h;
    let r = env_invert(rows, h, u.x);
    if !r.ok {
        return out;
    }
    let c = env_invert(rows + h + 1u + r.index * (w + 1u), w, u.y);
    if !c.ok {
        return out;
    }
    let x = (f32(c.index) + c.fraction) / f32(w);
    let y = (f32(r.index) + r.fraction) / f32(h);
    let theta = PI * y;
    let phi = 2.0 * PI * x;
    let st = sin(theta);
    out.dir = env_to_world(vec3f(st * sin(phi), cos(theta), -st * cos(phi)));
    out.pdf = env_pdf_texel(c.index, r.index, st);
    out.radiance = env_texel(c.index, r.index);
    return out;
}
