// The direction of a hemisphere-plane pixel (thesis section 4.4): for the plane pass
// (shared/plane.wgsl) and the plane refresh's selection (plane_refresh.wgsl), which must
// agree on it. The including pass declares `plane: array<PlanePixel>` (the plane table).
//!include shared/records.wgsl
//!include shared/sampling.wgsl

// The direction of plane pixel `pixel` of the record at `site`, in world space.
fn plane_direction(site: RecordSite, pixel: u32) -> vec3f {
    return plane_point_direction(site, plane[pixel].rot_center.zw);
}

// The direction through plane coordinates `xy` (the point (x, y, 1) of the record's
// frame), in world space: pixel centres and refinement's sub-samples alike.
fn plane_point_direction(site: RecordSite, xy: vec2f) -> vec3f {
    return normalize(record_frame(site) * vec3f(xy, 1.0));
}
