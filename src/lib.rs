//! radsplat: global illumination on compute shaders — radiance cache splatting and
//! temporal radiance caching (Gautron et al.) on wgpu.
//!
//! The data flow of a frame is readable from the module names and from
//! [`frame::Renderer::render_frame`]:
//! [`scene`] → [`bvh`] → [`visibility`] → [`direct`] → [`light_maps`] → [`placement`] +
//! [`records`] →
//! [`splat`] → [`resolve`] → [`output`] ([`frame::Renderer::render_gi_frame`]).
//! [`reference`](mod@reference) renders the brute-force direct + first-bounce reference and [`compare`]
//! measures images against it.
//!
//! Embedding: build a [`gpu::GpuContext`] from your own `wgpu::Device` and `Queue` with
//! [`gpu::GpuContext::from_device`]; [`gpu::required_limits`] says what the device needs.

pub mod bench;
pub mod bounce;
pub mod bvh;
pub mod commands;
pub mod compare;
pub mod compare_seq;
pub mod direct;
pub mod error;
pub mod frame;
pub mod glossy;
pub mod gpu;
pub mod hsh;
pub mod input;
pub mod light_maps;
pub mod output;
pub mod parallel;
pub mod photons;
pub mod placement;
pub mod radiance_export;
pub mod records;
pub mod reference;
pub mod resolve;
pub mod sampling;
pub mod scene;
pub mod splat;
pub mod temporal;
pub mod visibility;
pub mod vpl;

pub use error::{Error, Result};
pub use frame::{Frame, FrameStats, IrradianceCache, PreparedScene, Renderer};
