// Shared by the two reprojection passes (plane_reproject.wgsl, plane_reshade.wgsl): their
// parameters, how instances move from t to t+1, and where a plane sample's hit is at t+1.
// Both passes are bound to the scene of frame t+1 at group 0 and declare `params` (a
// ReprojectParams uniform) and `motion` (one InstanceMotion per instance) at group 1.
//!include shared/shading.wgsl
//!include shared/records.wgsl

struct ReprojectParams {
    resolution: u32,
    count: u32,
    light_samples: u32,
    stretched: u32,      // 1: border pixels reach infinity (decision 6)
    // The plane's half-extent in the coordinate its pixel edges are even in: tan(fov / 2)
    // for evenly spaced planes (x in [-s, s] at z = 1), sin(fov / 2) for cosine-spaced ones
    // (edges even in sin(atan x); records::PlaneSpacing).
    half_extent: f32,
    anchored: u32,       // 1: records move with their instance (`motion`)
    reuse_shading: u32,  // 1: lights unchanged from t to t+1 and `moving` lists every mover
    moving_count: u32,
    movers_lo: vec4f,    // world box around every mover's box (MovingBounds::union)
    movers_hi: vec4f,
    estimate_resolution: u32,  // P / stride: cells of the estimated plane
    stride: u32,               // the estimate reprojects every stride-th sample each way
    light_choices: u32,        // lights sampled per plane hit (`shadow_loop_start_chosen`)
    cosine_spacing: u32,       // 1: PlaneSpacing::Cosine, 0: PlaneSpacing::Uniform
    skip_movers: u32,          // 1: records on moving instances are not estimated
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// How an instance moves from t to t+1 (Rust: temporal::motion::InstanceMotion).
struct InstanceMotion {
    to_next: mat4x4f,     // world at t -> world at t+1, for points on the instance
    from_next: mat4x4f,   // its inverse
    moves: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// A plane sample's hit at t+1, as the record sees it.
struct MovedHit {
    surface: Surface,     // rebuilt at t+1, facing the record
    to_point: vec3f,      // record -> hit, in the record's frame at t (for the projection)
    seed: u32,            // the light-sample seed and first sequence index the plane
    first: u32,           // pass used for this sample (`plane_light_first`)
    // The hit is seen from the same side of its surface as at t. Always so when the
    // record does not move; a record that moves with its instance could cross the plane
    // of a surface it sees (the side decides which normal is lit).
    same_side: bool,
}

// Rebuilds hit `h` of sample `pixel` of the record at `site` in the scene at t+1: its
// triangle moved with its instance. With `anchored`, the record moves too: the hit is seen
// from the record's place at t+1 and taken back by the record's own motion, so that it is
// projected in the record's frame carried along.
fn moved_hit(site: RecordSite, h: PlaneHit, pixel: u32) -> MovedHit {
    let origin = offset_ray_origin(site.position, site.geometric_normal);
    let probe = surface_at(Hit(0.0, h.instance, h.triangle, h.u, h.v), site.normal);
    var to_point = probe.position - origin;
    var view = to_point;
    var same_side = true;
    if params.anchored != 0u {
        let m = motion[site.instance];
        if m.moves != 0u {
            view = probe.position - (m.to_next * vec4f(origin, 1.0)).xyz;
            to_point = (m.from_next * vec4f(probe.position, 1.0)).xyz - origin;
            // The plane pass decided the side with the cell's ray direction, parallel to
            // `probe.position - origin` up to rounding (for a hit that does not move):
            // only a clear sign counts as the same side.
            let ng = probe.geometric_normal;
            let before = dot(ng, normalize(probe.position - origin));
            let after = dot(ng, normalize(view));
            same_side = before * after > 0.0 && abs(before) > 1.0e-4 && abs(after) > 1.0e-4;
        }
    }
    return MovedHit(surface_facing(probe, view), to_point, site.seed,
                    plane_light_first(pixel, params.light_samples), same_side);
}
