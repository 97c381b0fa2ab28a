// Virtual point lights (src/vpl, instant radiosity): what the VPL trace writes and record
// gathers read, and seed 003's bounded geometry term.

// One VPL (48 bytes; Rust: vpl::Vpl). Zero power: an empty slot.
struct Vpl {
    position: vec3f,   // the hit moved off its surface: a visibility ray ends here
    _pad0: f32,
    normal: vec3f,     // shading normal, on the side the light arrived from
    _pad1: f32,
    power: vec3f,      // flux * albedo / pi: intensity power * cos(theta) towards theta
    _pad2: f32,
}

// The bounding factor of seed 003 eq. 2-3: f(0.8 min_d, 1.2 min_d, d), a smoothstep that
// fades out VPLs nearer than about min_d (0: no bound). Rust: records::vpl_gather::bound.
fn vpl_bound(d: f32, min_d: f32) -> f32 {
    if min_d <= 0.0 {
        return 1.0;
    }
    let t = clamp((d - 0.8 * min_d) / (0.4 * min_d), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

// Its derivative by d.
fn vpl_bound_derivative(d: f32, min_d: f32) -> f32 {
    if min_d <= 0.0 {
        return 0.0;
    }
    let t = (d - 0.8 * min_d) / (0.4 * min_d);
    if t <= 0.0 || t >= 1.0 {
        return 0.0;
    }
    return 6.0 * t * (1.0 - t) / (0.4 * min_d);
}
