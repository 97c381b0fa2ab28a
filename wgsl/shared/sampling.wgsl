// Deterministic sampling: hashes, Owen-scrambled Sobol points (Burley 2020, "Practical
// Hash-based Owen Scrambling"), cosine hemisphere, orthonormal bases. Mirrored bit for bit
// by src/sampling.rs for the CPU references.
//!include shared/ray.wgsl

fn hash_u32(x: u32) -> u32 {
    // PCG output permutation (Jarzynski & Olano 2020).
    let state = x * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn hash_combine(seed: u32, v: u32) -> u32 {
    return hash_u32(seed ^ (v + 0x9e3779b9u + (seed << 6u) + (seed >> 2u)));
}

fn laine_karras_permutation(x_in: u32, seed: u32) -> u32 {
    var x = x_in + seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    return reverseBits(laine_karras_permutation(reverseBits(x), seed));
}

// Second Sobol dimension (the first is the bit-reversed index).
fn sobol_dim1(index: u32) -> u32 {
    var v = 1u << 31u;
    var r = 0u;
    var i = index;
    loop {
        if i == 0u {
            break;
        }
        if (i & 1u) != 0u {
            r ^= v;
        }
        v ^= v >> 1u;
        i >>= 1u;
    }
    return r;
}

fn u32_to_unit(x: u32) -> f32 {
    return f32(x >> 8u) * (1.0 / 16777216.0);
}

// Point `index` of a 2D Owen-scrambled Sobol sequence; `seed` picks the scramble.
fn sobol_2d(index: u32, seed: u32) -> vec2f {
    let i = nested_uniform_scramble(index, hash_u32(seed));
    let x = nested_uniform_scramble(reverseBits(i), hash_combine(seed, 1u));
    let y = nested_uniform_scramble(sobol_dim1(i), hash_combine(seed, 2u));
    return vec2f(u32_to_unit(x), u32_to_unit(y));
}

// Builds a tangent frame around unit `n` (Duff et al. 2017).
fn orthonormal_basis(n: vec3f) -> mat3x3f {
    let s = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    let t = vec3f(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    let bt = vec3f(b, s + n.y * n.y * a, -n.y);
    return mat3x3f(t, bt, n);
}

// Cosine-weighted direction around +z (pdf cos/pi).
fn cosine_hemisphere(u: vec2f) -> vec3f {
    let r = sqrt(u.x);
    let phi = 2.0 * PI * u.y;
    return vec3f(r * cos(phi), r * sin(phi), sqrt(max(0.0, 1.0 - u.x)));
}
