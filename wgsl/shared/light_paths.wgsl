// Light paths leaving the scene's emitters (src/vpl: the VPL trace; src/photons: the photon
// trace): which emitter a path leaves, and its first ray and flux, from Owen-scrambled Sobol
// sequences seeded by the emitter (the same every frame and run). Rust mirror:
// vpl::reference::emit. Needs shared/shading.wgsl; a pass including it declares
// `params: LightPathParams` and `emitters: array<VplEmitter>` (Rust: VplPlan::dispatch).

// Rust: vpl::TraceParams.
struct LightPathParams {
    paths: u32,
    bounces: u32,
    emitters: u32,
    _pad: u32,
    sphere: vec4f,   // the scene's bounding sphere: centre, radius
}

// One emitter's run of paths (Rust: vpl::VplEmitter).
struct VplEmitter {
    light: u32,      // light index, or LIGHT_ENVIRONMENT
    first_path: u32,
    paths: u32,
    _pad: u32,
}

// The emitter whose run of paths holds path p (runs are in order of their first path).
fn path_emitter(p: u32) -> u32 {
    var index = 0u;
    for (var i = 1u; i < params.emitters; i++) {
        if emitters[i].first_path <= p {
            index = i;
        }
    }
    return index;
}

// Seeds of an emitter's sequences. Rust: vpl::reference::emitter_seed.
fn emitter_seed(emitter: u32, dimension: u32) -> u32 {
    return hash_combine(hash_u32(emitter), 0x7e10u + dimension);
}

fn uniform_sphere(u: vec2f) -> vec3f {
    let z = 1.0 - 2.0 * u.x;
    let r = sqrt(max(0.0, 1.0 - z * z));
    let phi = 2.0 * PI * u.y;
    return vec3f(r * cos(phi), r * sin(phi), z);
}

// A point of the disk of radius `r` around `centre`, facing `axis`.
fn disk_point(centre: vec3f, axis: vec3f, r: f32, u: vec2f) -> vec3f {
    let basis = orthonormal_basis(axis);
    let rho = r * sqrt(u.x);
    let phi = 2.0 * PI * u.y;
    return centre + basis * vec3f(rho * cos(phi), rho * sin(phi), 0.0);
}

struct Emission {
    ray: Ray,
    flux: vec3f,
}

// The emission of path k of emitter e's n paths (e is emitter `index`): its first ray and
// its flux (the emitter's flux sample over n). `sphere`: the scene's bounding sphere
// (centre, radius), which suns and the environment emit through.
fn emit(e: VplEmitter, index: u32, k: u32, sphere: vec4f) -> Emission {

    let u_pos = sobol_2d(k, emitter_seed(index, 0u));
    let u_dir = sobol_2d(k, emitter_seed(index, 1u));
    let n = f32(e.paths);
    let centre = sphere.xyz;
    let radius = sphere.w;
    var out = Emission(Ray(vec3f(0.0), 0.0, vec3f(0.0, 0.0, 1.0), INF), vec3f(0.0));
    if e.light == LIGHT_ENVIRONMENT {
        // Light arriving from direction w enters through the disk facing w.
        var w = uniform_sphere(u_dir);
        var l_over_pdf = scene_info.environment * (4.0 * PI);
        if has_environment_map() {
            let es = environment_sample(u_dir);
            w = es.dir;
            l_over_pdf = select(vec3f(0.0), es.radiance / es.pdf, es.pdf > 0.0);
        }
        out.ray.origin = disk_point(centre + w * radius, w, radius, u_pos);
        out.ray.dir = -w;
        out.flux = l_over_pdf * (PI * radius * radius / n);
        return out;
    }
    let light = lights[e.light];
    let kind = bitcast<u32>(light.a.w);
    if kind == LIGHT_POINT {
        out.ray.origin = light.a.xyz;
        out.ray.dir = uniform_sphere(u_dir);
        out.flux = light.d.xyz * (4.0 * PI / n);
    } else if kind == LIGHT_SPOT {
        // Uniform over the outer cone, weighted by the falloff.
        let cos_outer = light.c.w;
        let c = 1.0 - u_dir.x * (1.0 - cos_outer);
        let s = sqrt(max(0.0, 1.0 - c * c));
        let phi = 2.0 * PI * u_dir.y;
        out.ray.origin = light.a.xyz;
        out.ray.dir = orthonormal_basis(light.b.xyz) * vec3f(s * cos(phi), s * sin(phi), c);
        let falloff = smoothstep(cos_outer, light.b.w, c);
        out.flux = light.d.xyz * (falloff * 2.0 * PI * (1.0 - cos_outer) / n);
    } else if kind == LIGHT_RECT {
        let nl = normalize_rect_normal(light);
        let area = length(cross(light.b.xyz, light.c.xyz));
        let q = light.a.xyz + u_pos.x * light.b.xyz + u_pos.y * light.c.xyz;
        out.ray.origin = offset_ray_origin(q, nl);
        out.ray.dir = orthonormal_basis(nl) * cosine_hemisphere(u_dir);
        out.flux = light.d.xyz * (PI * area / n);
    } else if kind == LIGHT_SUN {
        let w = light.a.xyz;
        out.ray.origin = disk_point(centre + w * radius, w, radius, u_pos);
        out.ray.dir = -w;
        out.flux = light.d.xyz * (PI * radius * radius / n);
    }
    return out;
}
