// Photon trace (src/photons, thesis chapter 6 / algorithms.md section 5: the photon map of
// photon-mapped irradiance caching): one invocation per light path, leaving its emitter as
// the VPL trace's paths do (shared/light_paths.wgsl, the same sequences). The path's first
// hit is direct light, which pixels compute exactly, so it stores nothing; at each of its
// next `bounces` hits it stores a photon: the flux arriving there (light reflected d times,
// what a record's irradiance E holds), the direction it came from, its shading normal and
// the distance d to the surface it was last reflected from (thesis Fig. 6.1, the sample
// distance of the harmonic mean R). Slot p * bounces + d - 1 holds path p's d-th photon:
// ordered writes, so the map is the same bytes every run. A path that leaves the scene
// leaves its later slots empty (zero flux). At each hit the flux is multiplied by the
// albedo and the path goes on along a cosine direction. CPU mirror: src/photons/reference.rs.
//!include shared/shading.wgsl
//!include shared/light_paths.wgsl

// One photon (64 bytes; Rust: photons::Photon). Zero flux: an empty slot.
struct Photon {
    position: vec3f,   // on its surface
    distance: f32,     // from the surface it left (its ray's length)
    direction: vec3f,  // unit, towards where it came from
    bounce: u32,       // reflections before it arrived (1..bounces)
    flux: vec3f,
    _pad0: f32,
    normal: vec3f,     // unit shading normal, on the side it arrived from
    _pad1: f32,
}

@group(1) @binding(0) var<uniform> params: LightPathParams;
@group(1) @binding(1) var<storage, read> emitters: array<VplEmitter>;
@group(1) @binding(2) var<storage, read_write> photons: array<Photon>;

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
    for (var d = 0u; d <= params.bounces; d++) {
        var photon = Photon(vec3f(0.0), 0.0, vec3f(0.0), 0u, vec3f(0.0), 0.0, vec3f(0.0), 0.0);
        if alive {
            let h = trace(ray, false);
            if h.instance == NO_HIT {
                alive = false;
            } else {
                let s = surface_at(h, ray.dir);
                if d > 0u {
                    photon.position = s.position;
                    photon.distance = h.t;
                    photon.direction = -ray.dir;
                    photon.bounce = d;
                    photon.flux = flux;
                    photon.normal = s.shading_normal;
                }
                flux *= surface_albedo(s);
                alive = any(flux > vec3f(0.0));
                let dir = orthonormal_basis(s.shading_normal)
                    * cosine_hemisphere(sobol_2d(k, emitter_seed(index, 2u + d)));
                ray = Ray(offset_ray_origin(s.position, s.geometric_normal), 0.0, dir, INF);
                // A direction below the geometric surface would leave through it.
                if dot(dir, s.geometric_normal) <= 0.0 {
                    alive = false;
                }
            }
        }
        if d > 0u {
            photons[p * params.bounces + d - 1u] = photon;
        }
    }
}
