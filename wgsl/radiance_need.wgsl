// Which pixels need radiance records (splat/radiance.rs): placement of the radiance cache
// runs on a coverage mask that starts with every pixel marked covered except the visible
// ones whose material's glossy lobe radiance records shade.
//!include shared/ray.wgsl
//!include shared/camera.wgsl
//!include shared/radiance_records.wgsl

@group(1) @binding(0) var<uniform> camera: Camera;
@group(1) @binding(1) var<storage, read> vis: array<VisSample>;
@group(1) @binding(2) var<storage, read> lobe_table: array<u32>;
@group(1) @binding(3) var<storage, read_write> covered: array<u32>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= camera.width || id.y >= camera.height {
        return;
    }
    let pixel = id.y * camera.width + id.x;
    let v = vis[pixel];
    var needs = false;
    if v.instance != NO_HIT {
        needs = material_lobe_slot(v.material) != NO_LOBE_SLOT;
    }
    covered[pixel] = select(1u, 0u, needs);
}
