// One-dimensional dispatches of 256-invocation workgroups, split over y past the device's
// per-dimension limit (Rust: gpu::pipeline::linear_groups).

// Index of a 1-D invocation in such a dispatch.
fn flat_index(id: vec3u, groups: vec3u) -> u32 {
    return id.y * groups.x * 256u + id.x;
}
