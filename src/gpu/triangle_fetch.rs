//! Where the traversal reads its triangles from: the triangle storage buffer, or texels of
//! the BVH node texture (`wgsl/shared/scene.wgsl`, `traversal_triangle`).
//!
//! lavapipe (Mesa 22.3) loads from a storage buffer one lane at a time, and LLVM puts each
//! lane's value into the result vector with a variable index. Without AVX-512 that is a
//! store of the vector to the stack, a store of the lane, and a load of the vector that the
//! CPU cannot forward from the two stores: a stall for every component of every lane. A
//! triangle is three `vec4f` loads, so a leaf of eight triangles paid 96 of them for each
//! SIMD group of eight rays. A texel fetch is a gather in straight-line code. On a
//! two-core AMD EPYC (Zen 3, AVX2) a render took 0.83-0.88x the CPU time with the triangles
//! in the node texture, on each scene measured (the same bytes; docs/results.md,
//! "Triangles from the node texture where storage loads stall"). With AVX-512 LLVM inserts
//! the lane with a masked move, so the loads do not stall, and the texture's address work
//! would buy nothing; such hosts (none was at hand to measure) keep the buffer, as do GPUs
//! (not measured either). Earlier rounds had measured triangles from a texture slower
//! (docs/bvh-performance.md: 0.86x in the second round, incoherent rays 0.93x in the
//! third), on hosts whose vector extensions were not recorded.

/// Which copy of the triangles the traversal reads (`TRIANGLE_TEXELS` in
/// `wgsl/shared/scene.wgsl`). The plane hits' surfaces and the light-map
/// trace read the same copy; every other reader keeps the storage buffer. The same choice
/// makes the passes that read a per-round table many times a lane read its texel table
/// ([`super::texel_table`], `TABLE_TEXELS`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TriangleFetch {
    /// `triangles`, the storage buffer (group 0 binding 1).
    Buffer,
    /// Three texels per triangle after the nodes in the BVH node texture (group 0 binding
    /// 0), from `SceneInfo::triangle_texels`.
    Texture,
}

/// The environment variable that overrides the choice (`buffer` or `texture`), for
/// measuring one against the other.
pub const TRIANGLE_FETCH_VAR: &str = "RADSPLAT_TRIANGLE_FETCH";

/// The pipeline constant that selects the texture (`wgsl/shared/scene.wgsl`).
pub const TRIANGLE_TEXELS_CONSTANT: &str = "TRIANGLE_TEXELS";

impl TriangleFetch {
    /// The choice for an adapter: the texture on lavapipe where the host CPU lacks
    /// AVX-512 (see the module doc), the buffer elsewhere; [`TRIANGLE_FETCH_VAR`] overrides
    /// it. `is_llvmpipe` is None for a device handed to us (its driver is unknown).
    pub fn for_adapter(is_llvmpipe: Option<bool>) -> Self {
        match std::env::var(TRIANGLE_FETCH_VAR).ok().as_deref() {
            Some("texture") => return Self::Texture,
            Some("buffer") => return Self::Buffer,
            Some(other) => {
                static WARNED: std::sync::Once = std::sync::Once::new();
                WARNED.call_once(|| {
                    log::warn!(
                        "{TRIANGLE_FETCH_VAR}={other:?} is neither `buffer` nor `texture`; ignored"
                    )
                });
            }
            None => {}
        }
        if is_llvmpipe == Some(true) && !host_has_avx512() {
            Self::Texture
        } else {
            Self::Buffer
        }
    }

    /// The value of [`TRIANGLE_TEXELS_CONSTANT`].
    pub fn constant(self) -> f64 {
        match self {
            Self::Buffer => 0.0,
            Self::Texture => 1.0,
        }
    }
}

/// Whether LLVM may insert a lane with a masked move (AVX-512F with VL).
fn host_has_avx512() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512vl")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}
