// Scene tables, bound at group 0 by every pass (layout: src/gpu/scene_buffers.rs,
// Rust mirrors: src/bvh/gpu_layout.rs and src/gpu/scene_buffers.rs).

struct Triangle {
    v0: vec4f,
    e1: vec4f,   // v1 - v0
    e2: vec4f,   // v2 - v0
}

struct TriangleShading {
    n0: vec3f,
    material: u32,
    n1: vec3f,
    mesh_triangle: u32,
    n2: vec3f,
    _pad: u32,
    uv01: vec4f,
    uv2: vec4f,
}

struct Instance {
    world_from_object: array<vec4f, 3>,   // rows of a 3x4 affine matrix
    object_from_world: array<vec4f, 3>,
    normal_to_world: array<vec4f, 3>,
    blas_root: u32,
    first_triangle: u32,
    mesh: u32,
    _pad: u32,
}

struct Material {
    albedo: vec3f,
    texture: u32,   // NO_TEXTURE or a texture's index (texture_info)
    emission: vec3f,
    flags: u32,     // MATERIAL_SAMPLED_LIGHT, MATERIAL_PHONG
    specular: vec3f, // the glossy lobe's reflectance (0 without one)
    exponent: f32,   // the glossy lobe's Phong exponent
}

struct TextureInfo {
    offset: u32,   // first texel in `texels`
    width: u32,
    height: u32,
    _pad: u32,
}

const NO_TEXTURE: u32 = 0xffffffffu;
// The emitter is a rect light's quad, already sampled by direct lighting.
const MATERIAL_SAMPLED_LIGHT: u32 = 1u;
const MATERIAL_PHONG: u32 = 2u;      // Rust: gpu::scene_buffers::MATERIAL_PHONG
const LIGHT_POINT: u32 = 0u;
const LIGHT_SPOT: u32 = 1u;
const LIGHT_RECT: u32 = 2u;
const LIGHT_SUN: u32 = 3u;

// a.xyz: position / corner / direction to the sun; a.w: kind (bitcast u32)
// b.xyz: spot direction / rect edge_u;            b.w: spot cos_inner
// c.xyz: rect edge_v;                              c.w: spot cos_outer
// d.xyz: intensity (W/sr) / radiance / irradiance
struct Light {
    a: vec4f,
    b: vec4f,
    c: vec4f,
    d: vec4f,
}

struct SceneInfo {
    environment: vec3f,
    light_count: u32,
    light_samples: u32,
    instance_count: u32,
    tlas_root: u32,   // the entry traversal starts from: the TLAS root node in `bvh_nodes`
                      // (after every BLAS), a single instance's TLAS leaf, or the BLAS
                      // root of a single instance placed as modelled (root_in_blas;
                      // bvh::SceneBvh::traversal_start)
    env_map: u32,     // start of the environment map in `texels` (shared/environment.wgsl)
    env_size: vec2u,  // its width and height
    env_rotation: vec2f, // cos and sin of its rotation about +y
    root_in_blas: u32,   // 1: `tlas_root` is in instance 0's BLAS, in world space
    triangle_texels: u32, // with TRIANGLE_TEXELS: the triangles' first texel in `bvh_nodes`
    // Instance 0's transforms, for a scene of one instance placed as modelled (no
    // FEATURE_INSTANCES): its hits read them here, not lane by lane from `instances`.
    one_instance_world_from_object: array<vec4f, 3>,
    one_instance_normal_to_world: array<vec4f, 3>,
}

// What a pipeline is compiled for (`gpu::SceneFeatures`): the kinds of light it shades (bits
// 0-4, shared/shading.wgsl), FEATURE_INSTANCES (shared/bvh.wgsl), FEATURE_TEXTURES
// (shared/shading.wgsl) and FEATURE_BOUNCE_CACHE (shared/bounce_cache.wgsl). Lavapipe runs both
// sides of every branch, lanes masked off, so a pipeline built for one scene leaves out the
// code that scene never takes. Everything unless the pass sets it (the plane passes do).
override SCENE_FEATURES: u32 = 0xffffffffu;

// BVH nodes: every BLAS (one per mesh), then the TLAS, so traversal loads never branch on
// the level. 4-wide nodes of four texels each (layout: `GpuNode` in
// src/bvh/gpu_layout.rs), read with `bvh_texel`. A texture, not a storage buffer: lavapipe
// turns each storage-buffer load into a per-lane loop (docs/bvh-performance.md).
@group(0) @binding(0) var bvh_nodes: texture_2d<u32>;
@group(0) @binding(1) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(2) var<storage, read> shading: array<TriangleShading>;
@group(0) @binding(3) var<storage, read> instances: array<Instance>;
@group(0) @binding(4) var<storage, read> materials: array<Material>;
// Per texture four words (its TextureInfo), then every texture's texels, then the
// environment map's (one binding for the table and the texels: gpu::scene_buffers
// `texture_tables`).
@group(0) @binding(5) var<storage, read> texels: array<u32>;
@group(0) @binding(6) var<storage, read> lights: array<Light>;
@group(0) @binding(7) var<uniform> scene_info: SceneInfo;

// Texture `index`'s entry at the head of `texels`.
fn texture_info(index: u32) -> TextureInfo {
    let b = 4u * index;
    return TextureInfo(texels[b], texels[b + 1u], texels[b + 2u], 0u);
}

// Texels per row of `bvh_nodes` (`BVH_TEXTURE_WIDTH` in src/gpu/scene_buffers.rs).
const BVH_TEXTURE_WIDTH: u32 = 2048u;

// Texel `k` (0..3) of BVH node `node`; 512 nodes per row of 2048 texels.
fn bvh_texel(node: u32, k: u32) -> vec4u {
    return textureLoad(bvh_nodes, vec2u(((node & 511u) << 2u) | k, node >> 9u), 0);
}

// Whether the traversal reads triangles from `bvh_nodes` (three texels each, from
// `scene_info.triangle_texels`) instead of `triangles`: gpu::TriangleFetch. On lavapipe
// without AVX-512 a storage-buffer load stalls on every lane's every component, a texel
// fetch does not. A pipeline constant the device sets, so each pipeline holds one way.
override TRIANGLE_TEXELS: bool = false;

// Triangle `index` for the traversal's tests (the same bits either way).
fn traversal_triangle(index: u32) -> Triangle {
    if TRIANGLE_TEXELS {
        let t = scene_info.triangle_texels + 3u * index;
        return Triangle(triangle_texel(t), triangle_texel(t + 1u), triangle_texel(t + 2u));
    }
    return triangles[index];
}

// Texel `t` of `bvh_nodes` counted row by row, as floats.
fn triangle_texel(t: u32) -> vec4f {
    return bitcast<vec4f>(textureLoad(bvh_nodes, vec2u(t % BVH_TEXTURE_WIDTH, t / BVH_TEXTURE_WIDTH), 0));
}

fn transform_point(m: array<vec4f, 3>, p: vec3f) -> vec3f {
    let h = vec4f(p, 1.0);
    return vec3f(dot(m[0], h), dot(m[1], h), dot(m[2], h));
}

fn transform_vector(m: array<vec4f, 3>, v: vec3f) -> vec3f {
    let h = vec4f(v, 0.0);
    return vec3f(dot(m[0], h), dot(m[1], h), dot(m[2], h));
}
