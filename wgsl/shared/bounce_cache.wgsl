// The surface bounce cache (`--bounces N`, src/bounce): indirect irradiance stored on a
// barycentric grid of cells over every triangle side of the scene, so that a secondary hit
// (a hemisphere-plane sample, a glossy lobe's hit, a cell's own gather ray) reflects more
// than its direct light. The including pass declares
// `bounce_cache: array<u32>` (read) in its own group. Layout, in u32 words (written by
// src/bounce/layout.rs, read by its CPU mirror `BounceLayout::lookup`):
//   [0]        instance count I (0: no cache, every lookup is zero)
//   [1]        V, the word where the values start
//   [2 + i]    the first triangle entry of instance i (entries are in BVH leaf order)
//   [2 + I + e] entry e: the triangle's first cell (bits 0..25) | n << 26, n x n cells
//   [V + 3 (2 c + side) + ch] f32 bits of channel ch of cell c's side (0 front, 1 back)

const BOUNCE_CELL_BITS: u32 = 26u;

// Cells per row below row j of an n x n barycentric grid: row j holds n - j lower and
// n - j - 1 upper cells, so rows 0..j hold 2 n j - j^2.
fn bounce_row_base(j: u32, n: u32) -> u32 {
    return 2u * n * j - j * j;
}

// The cell of barycentrics (u, v) (of v1 and v2) in an n x n grid: lower cells at even
// places of their row, upper cells (u + v past the row's diagonal) at odd ones.
fn bounce_cell(u: f32, v: f32, n: u32) -> u32 {
    let nf = f32(n);
    let a = clamp(u, 0.0, 1.0) * nf;
    let b = clamp(v, 0.0, 1.0) * nf;
    let j = min(u32(b), n - 1u);
    let i = min(u32(a), n - 1u - j);
    let upper = (a - f32(i)) + (b - f32(j)) > 1.0 && i + j + 1u < n;
    return bounce_row_base(j, n) + 2u * i + select(0u, 1u, upper);
}

// Bit of SCENE_FEATURES (shared/scene.wgsl; `gpu::SceneFeatures`): the frame's bounce cache
// may hold something. A pipeline compiled without it (one bounce) leaves the lookup's eight
// storage loads out, which lavapipe would run for every hit even on an empty cache.
const FEATURE_BOUNCE_CACHE: u32 = 128u;

// Indirect irradiance at `hit` on the side `front` (Surface::front_face); zero without a
// cache or outside it.
fn bounce_irradiance(hit: Hit, front: bool) -> vec3f {
    if (SCENE_FEATURES & FEATURE_BOUNCE_CACHE) == 0u {
        return vec3f(0.0);
    }
    let count = bounce_cache[0];
    if hit.instance >= count {
        return vec3f(0.0);
    }
    let local = hit.triangle - instances[hit.instance].first_triangle;
    let entry = bounce_cache[2u + count + bounce_cache[2u + hit.instance] + local];
    let n = entry >> BOUNCE_CELL_BITS;
    let cell = (entry & ((1u << BOUNCE_CELL_BITS) - 1u)) + bounce_cell(hit.u, hit.v, n);
    let w = bounce_cache[1] + 3u * (2u * cell + select(1u, 0u, front));
    return vec3f(
        bitcast<f32>(bounce_cache[w]),
        bitcast<f32>(bounce_cache[w + 1u]),
        bitcast<f32>(bounce_cache[w + 2u]),
    );
}
