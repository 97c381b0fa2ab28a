// VPL trace (src/vpl, instant radiosity): one invocation per light path. Path p leaves the
// emitter whose run of paths holds it, from a point and along a direction drawn from
// Owen-scrambled Sobol sequences seeded by the emitter (the same every frame and run), and
// deposits a VPL at each of its first `bounces` hits: slot p * bounces + d holds the d-th,
// with power flux * albedo / pi. The flux of a path is the emitter's flux sample over its
// run's length; at each hit it is multiplied by the albedo and the path goes on along a
// cosine direction (the Lambertian lobe sampled exactly). A path that leaves the scene
// leaves its later slots empty (zero power). CPU mirror: src/vpl/reference.rs.
//!include shared/shading.wgsl
//!include shared/light_paths.wgsl
//!include shared/vpl.wgsl

@group(1) @binding(0) var<uniform> params: LightPathParams;
@group(1) @binding(1) var<storage, read> emitters: array<VplEmitter>;
@group(1) @binding(2) var<storage, read_write> vpls: array<Vpl>;

@compute @workgroup_size(64)
fn main(
    @builtin(global_invocation_id) id: vec3u,
    @builtin(local_invocation_index) lane: u32,
) {
    bvh_stack_init(lane);
    let p = id.x;
    if p >= params.paths {
        return;
    }
    let index = path_emitter(p);
    let e = emitters[index];
    let k = p - e.first_path;
    let em = emit(e, index, k, params.sphere);
    var ray = em.ray;
    var flux = em.flux;
    var alive = all(flux >= vec3f(0.0)) && any(flux > vec3f(0.0));
    for (var d = 0u; d < params.bounces; d++) {
        var vpl = Vpl(vec3f(0.0), 0.0, vec3f(0.0), 0.0, vec3f(0.0), 0.0);
        if alive {
            let h = trace(ray, false);
            if h.instance == NO_HIT {
                alive = false;
            } else {
                let s = surface_at(h, ray.dir);
                let albedo = surface_albedo(s);
                vpl.position = offset_ray_origin(s.position, s.geometric_normal);
                vpl.normal = s.shading_normal;
                vpl.power = flux * albedo * (1.0 / PI);
                flux *= albedo;
                alive = any(flux > vec3f(0.0));
                let dir = orthonormal_basis(s.shading_normal)
                    * cosine_hemisphere(sobol_2d(k, emitter_seed(index, 2u + d)));
                ray = Ray(vpl.position, 0.0, dir, INF);
                // A direction below the geometric surface would leave through it.
                if dot(dir, s.geometric_normal) <= 0.0 {
                    alive = false;
                }
            }
        }
        vpls[p * params.bounces + d] = vpl;
    }
}
