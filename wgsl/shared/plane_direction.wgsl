// The direction of a hemisphere-plane pixel (thesis section 4.4): for the plane pass
// (shared/plane.wgsl) and the plane refresh's selection (plane_refresh.wgsl), which must
// agree on it. The including pass declares `plane: array<PlanePixel>` (the plane table).
//!include shared/records.wgsl
//!include shared/sampling.wgsl

// The direction of plane pixel `pixel` of the record at `site`, in world space.
fn plane_direction(site: RecordSite, pixel: u32) -> vec3f {
    let frame = record_frame(site);
    return normalize(frame * vec3f(plane[pixel].rot_center.zw, 1.0));
}
