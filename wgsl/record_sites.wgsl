// Record sites from visibility-buffer pixels chosen by placement: position, normals, and
// R_min from the pixel footprint, so that a record's validity radius a R_min spans at
// least `r_min_pixels` pixels on screen (algorithms.md decision 5), and at least
// `r_min_world` (a world-space bound on record spacing, like Radiance's -ar: near the
// camera the pixel bound alone lets records crowd at high resolutions).
//!include shared/records.wgsl
//!include shared/camera.wgsl
//!include shared/sampling.wgsl

struct SiteParams {
    count: u32,
    first_record: u32,
    r_min_pixels: f32,
    accuracy: f32,
    r_min_world: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(1) @binding(0) var<uniform> params: SiteParams;
@group(1) @binding(1) var<uniform> camera: Camera;
@group(1) @binding(2) var<storage, read> vis: array<VisSample>;
@group(1) @binding(3) var<storage, read> pixels: array<u32>;
@group(1) @binding(4) var<storage, read_write> sites: array<RecordSite>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= params.count {
        return;
    }
    let v = vis[pixels[id.x]];
    // World size of one pixel at the hit distance (vertical extent 2 |up| t / height).
    let footprint = 2.0 * length(camera.up) * v.t / f32(camera.height);
    var site: RecordSite;
    site.position = v.position;
    site.r_min = max(params.r_min_pixels * footprint / params.accuracy, params.r_min_world);
    site.normal = v.shading_normal;
    site.seed = hash_u32(params.first_record + id.x);
    site.geometric_normal = v.geometric_normal;
    site.instance = v.instance;
    sites[id.x] = site;
}
