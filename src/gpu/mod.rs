//! Everything that talks to wgpu: the device, buffers, shader composition, the scene
//! tables on the GPU, and a small helper for compute pipelines.

mod buffers;
pub mod context;
pub mod pipeline;
pub mod prefix_sum;
pub mod scene_buffers;
pub mod scene_features;
pub mod scene_pass;
pub mod shader;
pub mod specialise;
pub mod texel_table;
pub mod timer;
pub mod triangle_fetch;
mod wgsl_compose;

pub use context::{GpuContext, OPTIONAL_FEATURES, required_limits};
pub use pipeline::ComputePass;
pub use scene_buffers::GpuScene;
pub use scene_features::SceneFeatures;
pub use triangle_fetch::TriangleFetch;

/// The name [`SceneFeatures`] had while it held only the kinds of light.
#[deprecated(
    note = "renamed `SceneFeatures`: it also says whether rays enter instances, \
                     textures and the bounce cache"
)]
pub type LightKinds = SceneFeatures;
