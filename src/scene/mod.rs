//! Scene description after loading: geometry in object space, instances with transforms,
//! materials, textures, lights, environment and camera.
//!
//! The scene file format (TOML) is documented in `docs/scene-format.md`; parsing lives in
//! [`mod@file`], OBJ/MTL loading in [`obj`], textures in [`texture`], and asset lookup along
//! `RADSPLAT_ASSET_PATH` in [`asset_path`]; keyframed animation in [`animation`]; a static
//! scene's instances baked into one mesh in [`merge`]; the caps on sizes and values that
//! untrusted input may claim in [`limits`].

pub mod animation;
pub mod asset_path;
pub mod brdf;
pub mod environment;
pub mod file;
pub mod limits;
pub mod merge;
pub mod obj;
pub mod texture;

pub use brdf::GlossyLobe;
pub use environment::EnvironmentMap;

use glam::{Mat4, Vec2, Vec3};
use std::path::PathBuf;

pub use animation::Animation;
pub use file::load_scene;

/// A triangle mesh in its own object space. One OBJ file gives one `Mesh`; several
/// instances may share it (they share one bottom-level BVH).
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Human-readable name (scene entry name or file stem).
    pub name: String,
    /// Vertex positions, object space. All finite (checked at load).
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals, same length as `positions`. A zero vector means
    /// "no usable normal here": shading falls back to the geometric normal.
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates, same length as `positions` (zero when the file has none).
    pub uvs: Vec<Vec2>,
    /// Triangles as vertex index triples. Degenerate (zero-area) triangles are removed at load.
    pub indices: Vec<[u32; 3]>,
    /// Material index (into [`Scene::materials`]) of each triangle, same length as `indices`.
    pub material_ids: Vec<u32>,
}

/// One placement of a mesh in the world.
#[derive(Clone, Debug)]
pub struct Instance {
    /// Index into [`Scene::meshes`].
    pub mesh: u32,
    /// Object-to-world transform (affine, invertible: checked at load).
    pub transform: Mat4,
}

/// A diffuse (Lambertian) material with optional emission.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name from the MTL file or the scene file.
    pub name: String,
    /// Diffuse albedo in linear RGB, each channel in [0, 1]. Multiplied by the texture when present.
    pub albedo: Vec3,
    /// Index into [`Scene::textures`] of the diffuse albedo texture (sRGB-encoded).
    pub albedo_texture: Option<u32>,
    /// Emitted radiance (linear RGB, W/(m^2 sr)), one-sided along the geometric normal.
    pub emission: Vec3,
    /// The emitter is also a sampled light (a rect light's quad): direct lighting already
    /// accounts for it, so indirect light must count it as zero (Ward: "we count as zero any
    /// samples that intersect a light source") or it would be counted twice.
    pub sampled_light: bool,
    /// A glossy lobe beside the Lambertian one (MTL `Ks`/`Ns`, scene file `specular` and
    /// `exponent`); `albedo + specular <= 1` per channel.
    pub glossy: Option<GlossyLobe>,
}

/// An 8-bit RGBA texture, sRGB-encoded colour, rows top to bottom (v = 1 is the top row).
#[derive(Clone, Debug)]
pub struct Texture {
    /// Where it was loaded from (for messages).
    pub path: PathBuf,
    pub width: u32,
    pub height: u32,
    /// `width * height` texels, row-major, top row first.
    pub texels: Vec<[u8; 4]>,
}

/// Light sources. All quantities are linear RGB.
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// Isotropic point light; `intensity` in W/sr.
    Point { position: Vec3, intensity: Vec3 },
    /// Spot light: point light restricted to a cone around `direction` (unit), with a smooth
    /// falloff between `cos_outer` and `cos_inner` (cosines of the half-angles).
    Spot {
        position: Vec3,
        direction: Vec3,
        intensity: Vec3,
        cos_inner: f32,
        cos_outer: f32,
    },
    /// One-sided rectangular area light: the parallelogram `corner + s*edge_u + t*edge_v`,
    /// s, t in \[0, 1\], emitting `radiance` towards `normalize(cross(edge_u, edge_v))`.
    /// The loader also adds the rectangle to the scene as an emissive two-triangle mesh, so
    /// the light is visible to camera and GI rays.
    Rect {
        corner: Vec3,
        edge_u: Vec3,
        edge_v: Vec3,
        radiance: Vec3,
    },
    /// Directional light (sun): `direction` (unit) points *from the scene towards the sun*;
    /// `irradiance` in W/m^2 on a surface facing it.
    Sun { direction: Vec3, irradiance: Vec3 },
}

/// Pinhole camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    /// Vertical field of view in degrees, in (0, 180).
    pub fov_y_degrees: f32,
    pub width: u32,
    pub height: u32,
}

/// Render settings that live in the scene file (the CLI can override some of them).
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    /// Number of samples per area light (and for the environment) per pixel for direct light.
    pub light_samples: u32,
    /// Exposure multiplier applied before tone mapping to PNG.
    pub exposure: f32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            light_samples: 16,
            exposure: 1.0,
        }
    }
}

/// A fully loaded, validated scene.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The scene file this came from.
    pub source: PathBuf,
    pub meshes: Vec<Mesh>,
    pub instances: Vec<Instance>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub lights: Vec<Light>,
    /// Constant environment radiance seen by rays that leave the scene (zero when there
    /// is an environment map).
    pub environment: Vec3,
    /// An HDR environment map instead of the constant (`[environment] map`).
    pub environment_map: Option<EnvironmentMap>,
    pub camera: Camera,
    pub settings: RenderSettings,
    /// Keyframes and frame range; `None` for a scene file without `[animation]` and without
    /// keyframes. The other fields hold the values at the first frame after loading; use
    /// [`Scene::set_frame`] to move the scene to another frame.
    pub animation: Option<Animation>,
}

impl Scene {
    /// Total triangle count over all instances.
    pub fn triangle_count(&self) -> usize {
        self.instances
            .iter()
            .map(|i| self.meshes[i.mesh as usize].indices.len())
            .sum()
    }
}

/// Shadow rays one surface hit casts for `scene`'s lights with `samples` samples per light
/// (Scene `light_samples`, `--plane-light-samples`): `samples` for each rect light and for
/// the environment, one for each point, spot or sun (`shadow_loop_next` in
/// wgsl/shared/shading.wgsl).
pub fn shadow_rays_per_hit(scene: &Scene, samples: u32) -> u64 {
    let rects = scene
        .lights
        .iter()
        .filter(|l| matches!(l, Light::Rect { .. }))
        .count() as u64;
    let delta = scene.lights.len() as u64 - rects;
    let environment = u64::from(scene.environment != Vec3::ZERO || scene.environment_map.is_some());
    (rects + environment) * u64::from(samples) + delta
}

/// A scene bundled in `scenes/`, loaded (unit tests of several modules).
#[cfg(test)]
pub(crate) fn bundled(name: &str) -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    load_scene(&path).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The matrix that takes object-space normals to world space under `transform` (the
/// inverse transpose of its linear part); shared by the scene's lights, the CPU references
/// and the GPU layout.
pub fn normal_matrix(transform: glam::Mat4) -> glam::Mat3 {
    glam::Mat3::from_mat4(transform).inverse().transpose()
}
