// Radiance records' coefficient blocks and the lobe and rotation tables their splat reads
// (records/kind.rs, splat/radiance.rs), shared by the radiance gather and its need mask.

// No radiance records for this material: no glossy lobe, or one too sharp for the order
// (shaded by Monte Carlo, algorithms.md 2.6).
const NO_LOBE_SLOT: u32 = 0xffffffffu;
// The most coefficients per channel (HSH order 10).
const MAX_COEFFICIENTS: u32 = 100u;

struct RadianceParams {
    order: u32,
    coefficients: u32,   // order^2
    stride: u32,         // f32s per record block
    materials: u32,      // per-material headers at the start of the lobe table
    lobe_steps: u32,     // theta_o entries per lobe
    beta_steps: u32,     // tilt matrices
    beta_max: f32,       // tilt of the last matrix
    _pad: u32,
}

// Per material: 4 words, (slot, specular rgb as f32 bits); then per slot 4 words (the
// bands that hold the lobe, hsh::brdf_projection::LobeTable::bands, and padding) and
// `lobe_steps x order^2` f32 (as bits) of the lobe's shape at theta_o, phi_o = 0, zero
// from band `bands` on.
fn material_lobe_slot(material: u32) -> u32 {
    return lobe_table[4u * material];
}

fn material_specular(material: u32) -> vec3f {
    let b = 4u * material;
    return vec3f(
        bitcast<f32>(lobe_table[b + 1u]),
        bitcast<f32>(lobe_table[b + 2u]),
        bitcast<f32>(lobe_table[b + 3u]),
    );
}

