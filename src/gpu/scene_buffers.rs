//! The scene tables on the GPU (bind group 0 of every pass): BVH nodes (a texture),
//! triangles, shading data, instances, materials, textures, lights and a small info block.

use super::GpuContext;
use super::triangle_fetch::TriangleFetch;
use crate::bvh::SceneBvh;
use crate::scene::{Light, Scene};
use crate::{Error, Result};
use bytemuck::{Pod, Zeroable};

/// Must match `BVH_STACK_SIZE` in `wgsl/shared/bvh.wgsl`.
pub const BVH_STACK_SIZE: u32 = crate::bvh::TRAVERSAL_STACK;

/// Width in texels of the BVH node texture (binding 0): 512 nodes of four texels per row.
/// Must match `bvh_texel` in `wgsl/shared/scene.wgsl`; within WebGPU's default 2D limit.
pub const BVH_TEXTURE_WIDTH: u32 = 2048;

/// Nodes are read through a texture, not a storage buffer: lavapipe (Mesa 22.3) turns each
/// storage-buffer load into a per-lane loop, while texel fetches are straight-line gathers
/// (`docs/bvh-performance.md`).
/// With [`TriangleFetch::Texture`] the triangles follow the nodes, three texels each, from
/// texel `4 * nodes`, which it returns beside the texture ([`GpuSceneInfo::triangle_texels`]).
fn bvh_texture(ctx: &GpuContext, bvh: &SceneBvh) -> Result<(wgpu::Texture, u32)> {
    use wgpu::util::DeviceExt;
    let nodes = bvh.gpu_nodes();
    let triangles: &[u32] = match ctx.triangle_fetch() {
        TriangleFetch::Texture => bytemuck::cast_slice(&bvh.triangles),
        TriangleFetch::Buffer => &[],
    };
    let texels = nodes.len() as u64 * 4 + triangles.len() as u64 / 4;
    let rows = texels.div_ceil(u64::from(BVH_TEXTURE_WIDTH)).max(1);
    let max = ctx.device.limits().max_texture_dimension_2d;
    if rows > u64::from(max) {
        let what = if triangles.is_empty() {
            format!("{} BVH nodes", nodes.len())
        } else {
            format!(
                "{} BVH nodes and {} triangles",
                nodes.len(),
                bvh.triangles.len()
            )
        };
        return Err(Error::DeviceLimit(format!(
            "{what} need a {BVH_TEXTURE_WIDTH}x{rows} texture; this device allows {max} rows"
        )));
    }
    let rows = rows as u32;
    let triangle_texels = nodes.len() as u32 * 4;
    let mut words: Vec<u32> = bytemuck::cast_slice(&nodes).to_vec();
    words.extend_from_slice(triangles);
    words.resize((rows * BVH_TEXTURE_WIDTH * 4) as usize, 0);
    let texture = ctx.device.create_texture_with_data(
        &ctx.queue,
        &wgpu::TextureDescriptor {
            label: Some("bvh nodes"),
            size: wgpu::Extent3d {
                width: BVH_TEXTURE_WIDTH,
                height: rows,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba32Uint,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        bytemuck::cast_slice(&words),
    );
    Ok((texture, triangle_texels))
}

/// Rust mirror of WGSL `Material`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuMaterial {
    pub albedo: [f32; 3],
    pub texture: u32,
    pub emission: [f32; 3],
    /// Bit flags, `MATERIAL_SAMPLED_LIGHT`, `MATERIAL_PHONG`.
    pub flags: u32,
    /// The glossy lobe's reflectance (zero without one).
    pub specular: [f32; 3],
    /// The glossy lobe's exponent.
    pub exponent: f32,
}

/// [`GpuMaterial::flags`]: the emitter is sampled by direct lighting (a rect light's quad).
pub const MATERIAL_SAMPLED_LIGHT: u32 = 1;
/// [`GpuMaterial::flags`]: the material has a Phong glossy lobe
/// ([`crate::scene::GlossyLobe::Phong`]).
pub const MATERIAL_PHONG: u32 = 2;

/// Rust mirror of WGSL `TextureInfo`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuTextureInfo {
    pub offset: u32,
    pub width: u32,
    pub height: u32,
    pub _pad: u32,
}

/// Rust mirror of WGSL `Light` (see the field comments in `wgsl/shared/scene.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuLight {
    pub a: [f32; 4],
    pub b: [f32; 4],
    pub c: [f32; 4],
    pub d: [f32; 4],
}

/// Light kinds, as in WGSL.
pub const LIGHT_POINT: u32 = 0;
pub const LIGHT_SPOT: u32 = 1;
pub const LIGHT_RECT: u32 = 2;
pub const LIGHT_SUN: u32 = 3;
/// Material without texture.
pub const NO_TEXTURE: u32 = u32::MAX;

impl GpuLight {
    pub fn new(light: &Light) -> Self {
        let v4 = |v: glam::Vec3, w: f32| [v.x, v.y, v.z, w];
        let kind = |k: u32| f32::from_bits(k);
        let z = glam::Vec3::ZERO;
        match *light {
            Light::Point {
                position,
                intensity,
            } => GpuLight {
                a: v4(position, kind(LIGHT_POINT)),
                b: v4(z, 0.0),
                c: v4(z, 0.0),
                d: v4(intensity, 0.0),
            },
            Light::Spot {
                position,
                direction,
                intensity,
                cos_inner,
                cos_outer,
            } => GpuLight {
                a: v4(position, kind(LIGHT_SPOT)),
                b: v4(direction.normalize(), cos_inner),
                c: v4(z, cos_outer),
                d: v4(intensity, 0.0),
            },
            Light::Rect {
                corner,
                edge_u,
                edge_v,
                radiance,
            } => GpuLight {
                a: v4(corner, kind(LIGHT_RECT)),
                b: v4(edge_u, 0.0),
                c: v4(edge_v, 0.0),
                d: v4(radiance, 0.0),
            },
            Light::Sun {
                direction,
                irradiance,
            } => GpuLight {
                a: v4(direction.normalize(), kind(LIGHT_SUN)),
                b: v4(z, 0.0),
                c: v4(z, 0.0),
                d: v4(irradiance, 0.0),
            },
        }
    }
}

/// Rust mirror of WGSL `SceneInfo` (uniform).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuSceneInfo {
    pub environment: [f32; 3],
    pub light_count: u32,
    pub light_samples: u32,
    pub instance_count: u32,
    /// The traversal entry rays start from ([`SceneBvh::traversal_start`]): the TLAS root's
    /// index in the node array ([`SceneBvh::gpu_nodes`]), a single instance's leaf, or its
    /// BLAS root ([`GpuSceneInfo::root_in_blas`]).
    pub tlas_root: u32,
    /// Where the environment map starts in the texel table ([`NO_ENVIRONMENT_MAP`]: none):
    /// `3 width height` RGB floats (as bits), then its row CDF (`height + 1`) and its
    /// column CDFs (`height (width + 1)`), as `scene::EnvironmentMap` holds them.
    pub env_map: u32,
    pub env_width: u32,
    pub env_height: u32,
    /// cos and sin of the map's rotation about +y.
    pub env_rotation: [f32; 2],
    /// 1: `tlas_root` is in instance 0's BLAS, whose object space is world space.
    pub root_in_blas: u32,
    /// The first texel of the triangles in the BVH node texture ([`TriangleFetch::Texture`];
    /// 4 texels a node precede them).
    pub triangle_texels: u32,
    pub _pad: [u32; 2],
    /// Instance 0's `world_from_object` and `normal_to_world` rows
    /// ([`crate::bvh::gpu_layout::GpuInstance`]), the identity when there is none. A scene
    /// of one instance placed as modelled (no instances bit in [`crate::gpu::SceneFeatures`])
    /// shades its hits with them from this uniform: the same products, so the same bits,
    /// where the `instances` buffer cost 24 storage loads a hit, lane by lane on lavapipe
    /// (`surface_at` in `wgsl/shared/shading.wgsl`).
    pub one_instance_world_from_object: [[f32; 4]; 3],
    pub one_instance_normal_to_world: [[f32; 4]; 3],
}

/// [`GpuSceneInfo::env_map`] of a scene without an environment map.
pub const NO_ENVIRONMENT_MAP: u32 = u32::MAX;

impl GpuSceneInfo {
    /// Most shadow rays one hit casts with `samples` samples per light: `samples` per
    /// light and for the environment (an upper bound: point lights and suns cast one).
    pub fn max_shadow_rays(&self, samples: u32) -> u64 {
        (u64::from(self.light_count) + 1) * u64::from(samples)
    }
}

/// Materials, and the texture table with the packed texels, in GPU layout.
pub fn material_tables(scene: &Scene) -> (Vec<GpuMaterial>, Vec<u32>) {
    let mut texels = texture_tables(scene);
    append_environment_map(scene, &mut texels);
    (gpu_materials(scene), texels)
}

/// The material table in GPU layout.
fn gpu_materials(scene: &Scene) -> Vec<GpuMaterial> {
    scene
        .materials
        .iter()
        .map(|m| {
            let (lobe, specular, exponent) = match m.glossy {
                Some(crate::scene::GlossyLobe::Phong { specular, exponent }) => {
                    (MATERIAL_PHONG, specular.into(), exponent)
                }
                None => (0, [0.0; 3], 0.0),
            };
            GpuMaterial {
                albedo: m.albedo.into(),
                texture: m.albedo_texture.unwrap_or(NO_TEXTURE),
                emission: m.emission.into(),
                flags: lobe
                    | if m.sampled_light {
                        MATERIAL_SAMPLED_LIGHT
                    } else {
                        0
                    },
                specular,
                exponent,
            }
        })
        .collect()
}

/// The texture table and every texture's texels packed in one array: per texture four
/// u32 (a [`GpuTextureInfo`]: its first texel, width, height), then the texels. One
/// binding for both leaves room for the passes' own (`STORAGE_BUFFERS_PER_STAGE`).
fn texture_tables(scene: &Scene) -> Vec<u32> {
    let header = TEXTURE_INFO_WORDS * scene.textures.len();
    let mut table = Vec::with_capacity(header);
    let mut texels = Vec::new();
    for t in &scene.textures {
        let info = GpuTextureInfo {
            offset: (header + texels.len()) as u32,
            width: t.width,
            height: t.height,
            _pad: 0,
        };
        table.extend_from_slice(bytemuck::cast_slice(&[info]));
        texels.extend(t.texels.iter().map(|c| u32::from_le_bytes(*c)));
    }
    table.extend(texels);
    table
}

/// u32 words of one texture's entry at the head of the texel table.
const TEXTURE_INFO_WORDS: usize = std::mem::size_of::<GpuTextureInfo>() / 4;

/// Where the environment map starts in the texel table: after every texture's texels
/// ([`NO_ENVIRONMENT_MAP`] without one).
fn environment_map_offset(scene: &Scene) -> u32 {
    match &scene.environment_map {
        Some(_) => {
            let header = TEXTURE_INFO_WORDS * scene.textures.len();
            (header + scene.textures.iter().map(|t| t.texels.len()).sum::<usize>()) as u32
        }
        None => NO_ENVIRONMENT_MAP,
    }
}

/// Appends the environment map (texels, then its CDFs, as f32 bits) to the texel table of
/// [`texture_tables`], at [`environment_map_offset`].
fn append_environment_map(scene: &Scene, texels: &mut Vec<u32>) {
    let Some(map) = &scene.environment_map else {
        return;
    };
    debug_assert_eq!(texels.len() as u32, environment_map_offset(scene));
    for c in &map.texels {
        texels.extend([c.x.to_bits(), c.y.to_bits(), c.z.to_bits()]);
    }
    texels.extend(map.row_cdf.iter().map(|v| v.to_bits()));
    texels.extend(map.column_cdf.iter().map(|v| v.to_bits()));
}

/// Scene data resident on the GPU, with its bind group.
pub struct GpuScene {
    pub layout: wgpu::BindGroupLayout,
    pub bind_group: wgpu::BindGroup,
    pub info: GpuSceneInfo,
    info_buffer: wgpu::Buffer,
    /// Buffers kept alive for the bind group, in binding order (from binding 1).
    _buffers: Vec<wgpu::Buffer>,
    /// The BVH node texture (binding 0).
    _bvh_nodes: wgpu::Texture,
    /// Bytes uploaded, for memory reports.
    pub bytes: u64,
    /// Length of the diagonal of the scene's world bounds (`SceneBvh::world_bounds`).
    pub diagonal: f32,
    /// The scene's world bounds (min, max corners).
    pub bounds: ([f32; 3], [f32; 3]),
    /// The scene's kinds of light, whether its rays enter instances and whether it has
    /// textures ([`Self::features`] adds the bounce cache).
    static_features: super::SceneFeatures,
    /// Whether any material has a glossy lobe (passes for glossy pixels run only then).
    pub has_glossy: bool,
    /// Whether some material emits light that no light samples (an emitter that is not a
    /// rect light's quad): plane rays can find light there that no light map shows.
    pub unsampled_emission: bool,
    /// Each material's glossy lobe (index: material), for the tables radiance records
    /// are splatted with.
    pub glossy_lobes: Vec<Option<crate::scene::GlossyLobe>>,
    /// The surface bounce cache the passes that shade secondary hits bind (laid out by the
    /// bounce module, a layer above; 16 zero bytes, the empty cache, until one is set): the
    /// indirect light of this scene's surfaces, so it belongs to the scene, not to a pass.
    /// The surface bounce cache passes bind, and whether it holds anything.
    bounce_cache: std::sync::Mutex<(wgpu::Buffer, bool)>,
    /// The virtual point lights traced for this scene (instant caching's record source,
    /// laid out by the vpl module, a layer above), when a cache gathers from them.
    vpls: std::sync::Mutex<Option<SceneVpls>>,
}

/// Virtual point lights of a scene on the GPU: `count` WGSL `Vpl`s (48 bytes each; empty
/// slots have zero power) and the bounding distance their gathers fade them out within.
#[derive(Clone, Debug)]
pub struct SceneVpls {
    pub buffer: wgpu::Buffer,
    pub count: u32,
    pub clamp_distance: f32,
}

/// Group 0: the BVH node texture at binding 0, storage buffers at bindings
/// `1..SCENE_STORAGE_BINDINGS`; the info uniform follows.
const SCENE_STORAGE_BINDINGS: u32 = 7;

/// The bind group layout of the scene tables (group 0 in every pass).
pub fn scene_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let storage = |binding| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let mut entries = vec![wgpu::BindGroupLayoutEntry {
        binding: 0,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Uint,
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }];
    entries.extend((1..SCENE_STORAGE_BINDINGS).map(storage));
    entries.push(wgpu::BindGroupLayoutEntry {
        binding: SCENE_STORAGE_BINDINGS,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    });
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("scene"),
        entries: &entries,
    })
}

impl GpuScene {
    /// Uploads a scene and its BVH. Fails cleanly when a table exceeds the device limits.
    pub fn upload(
        ctx: &GpuContext,
        scene: &Scene,
        bvh: &SceneBvh,
        light_samples: u32,
    ) -> Result<Self> {
        Self::upload_frame(ctx, scene, bvh, light_samples, None)
    }

    /// As [`GpuScene::upload`] for a frame of an animation: with `previous`, a frame of
    /// the same scene (same meshes and textures, only transforms, lights and emission
    /// changed), its triangle, shading and texture buffers are shared instead of uploaded
    /// again; the instance, material and light tables and the BVH nodes are new.
    pub fn upload_frame(
        ctx: &GpuContext,
        scene: &Scene,
        bvh: &SceneBvh,
        light_samples: u32,
        previous: Option<&GpuScene>,
    ) -> Result<Self> {
        // Leaf entries pack the first primitive into 27 bits (`wgsl/shared/bvh.wgsl`).
        // Checked first: below these counts the BVH builder keeps the stack need within
        // the stack (`bvh::TRAVERSAL_STACK`), so the depth check below cannot fire.
        if bvh.triangles.len() >= 1 << 27 || bvh.instances.len() >= 1 << 27 {
            return Err(Error::DeviceLimit(format!(
                "{} triangles / {} instances exceed the BVH leaf encoding (2^27)",
                bvh.triangles.len(),
                bvh.instances.len()
            )));
        }
        // Transforms can carry vertices far past their file's coordinates.
        let (lo, hi) = bvh.world_bounds();
        let far = lo.abs().max(hi.abs()).max_element();
        if !far.is_finite() || far > crate::scene::limits::MAX_COORDINATE {
            return Err(Error::Usage(format!(
                "the scene reaches {far:e} from the origin (world bounds {lo} to {hi}): \
                 beyond +-{:e} a triangle's normal overflows f32; check the instances' \
                 transforms and keyframes, or rescale the scene",
                crate::scene::limits::MAX_COORDINATE
            )));
        }
        // Ray origins leave surfaces by up to 256 ULPs of their coordinates
        // (`scene::limits::ray_offset`): a scene far from the origin, or tiny, loses its
        // details below that (light leaks through walls, contact shadows vanish). Said once
        // per process (an animation uploads every frame).
        let diagonal = (hi - lo).length();
        let offset = crate::scene::limits::ray_offset(far);
        if offset > 0.05 * diagonal {
            return Err(Error::Usage(format!(
                "the scene is {diagonal:.3e} across and reaches {far:.3e} from the origin: \
                 rays would leave surfaces up to {offset:.2e} off them, {:.0} % of the scene \
                 (light through walls, no contact shadows); move the scene to the origin and \
                 use units of about its size",
                100.0 * offset / diagonal.max(f32::MIN_POSITIVE)
            )));
        }
        if offset > 1e-3 * diagonal {
            static WARNED: std::sync::Once = std::sync::Once::new();
            WARNED.call_once(|| {
                log::warn!(
                    "the scene is {diagonal:.3e} across and reaches {far:.3e} from the origin: \
                     rays leave surfaces up to {offset:.2e} off them ({:.2} % of the scene), so \
                     smaller details are lost (light leaks, missing contact shadows); move the \
                     scene to the origin and use units of about its size",
                    100.0 * offset / diagonal.max(f32::MIN_POSITIVE)
                );
            });
        }
        if bvh.max_depth >= BVH_STACK_SIZE {
            let (mesh, need) = bvh.deepest_blas.unwrap_or((0, 0));
            let name = scene
                .meshes
                .get(mesh as usize)
                .map_or("", |m| m.name.as_str());
            return Err(Error::DeviceLimit(format!(
                "BVH of mesh '{name}' ({need} stack entries) with the TLAS ({} entries) needs \
                 {} entries, more than the traversal stack of {BVH_STACK_SIZE}",
                bvh.max_depth - need,
                bvh.max_depth
            )));
        }
        let materials = gpu_materials(scene);
        let lights: Vec<GpuLight> = scene.lights.iter().map(GpuLight::new).collect();
        let (bvh_nodes, triangle_texels) = bvh_texture(ctx, bvh)?;
        let bvh_view = bvh_nodes.create_view(&Default::default());
        // Binding order (from 1): triangles, shading, instances, materials, texels (with
        // the texture table at their head), lights. The mesh and texture tables do not
        // change between frames.
        let shared = previous.map(|p| p._buffers.clone());
        let buffers = match shared {
            Some(mut b) if b.len() == 6 => {
                b[2] = ctx.storage_buffer("instances", &bvh.instances)?;
                b[3] = ctx.storage_buffer("materials", &materials)?;
                b[5] = ctx.storage_buffer("lights", &lights)?;
                b
            }
            _ => {
                let mut texels = texture_tables(scene);
                append_environment_map(scene, &mut texels);
                vec![
                    ctx.storage_buffer("triangles", &bvh.triangles)?,
                    ctx.storage_buffer("triangle shading", &bvh.shading)?,
                    ctx.storage_buffer("instances", &bvh.instances)?,
                    ctx.storage_buffer("materials", &materials)?,
                    ctx.storage_buffer("texels", &texels)?,
                    ctx.storage_buffer("lights", &lights)?,
                ]
            }
        };
        let start = bvh.traversal_start();
        let first_instance = bvh.instances.first();
        let info = GpuSceneInfo {
            environment: scene.environment.into(),
            light_count: lights.len() as u32,
            light_samples: light_samples.max(1),
            instance_count: scene.instances.len() as u32,
            tlas_root: start.entry,
            root_in_blas: u32::from(start.in_blas),
            triangle_texels,
            _pad: [0; 2],
            one_instance_world_from_object: first_instance
                .map_or(crate::bvh::IDENTITY_ROWS, |i| i.world_from_object),
            one_instance_normal_to_world: first_instance
                .map_or(crate::bvh::IDENTITY_ROWS, |i| i.normal_to_world),
            env_map: environment_map_offset(scene),
            env_width: scene.environment_map.as_ref().map_or(0, |m| m.width),
            env_height: scene.environment_map.as_ref().map_or(0, |m| m.height),
            env_rotation: scene
                .environment_map
                .as_ref()
                .map_or([1.0, 0.0], |m| [m.rotation.cos(), m.rotation.sin()]),
        };
        let info_buffer = ctx.uniform_buffer("scene info", &info);
        let layout = scene_layout(&ctx.device);
        let mut entries = vec![wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::TextureView(&bvh_view),
        }];
        entries.extend(
            buffers
                .iter()
                .enumerate()
                .map(|(i, b)| wgpu::BindGroupEntry {
                    binding: i as u32 + 1,
                    resource: b.as_entire_binding(),
                }),
        );
        entries.push(wgpu::BindGroupEntry {
            binding: SCENE_STORAGE_BINDINGS,
            resource: info_buffer.as_entire_binding(),
        });
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("scene"),
            layout: &layout,
            entries: &entries,
        });
        let texture_bytes = u64::from(bvh_nodes.width()) * u64::from(bvh_nodes.height()) * 16;
        let bytes = buffers.iter().map(|b| b.size()).sum::<u64>() + texture_bytes;
        Ok(Self {
            layout,
            bind_group,
            info,
            info_buffer,
            _buffers: buffers,
            _bvh_nodes: bvh_nodes,
            bytes,
            diagonal: {
                let (lo, hi) = bvh.world_bounds();
                (hi - lo).length()
            },
            bounds: {
                let (lo, hi) = bvh.world_bounds();
                (lo.to_array(), hi.to_array())
            },
            static_features: super::SceneFeatures::of(scene).with_traversal(start.in_blas),
            has_glossy: scene.materials.iter().any(|m| m.glossy.is_some()),
            unsampled_emission: scene
                .materials
                .iter()
                .any(|m| !m.sampled_light && m.emission.max_element() > 0.0),
            glossy_lobes: scene.materials.iter().map(|m| m.glossy).collect(),
            bounce_cache: std::sync::Mutex::new((Self::empty_bounce_cache(ctx)?, false)),
            vpls: std::sync::Mutex::new(None),
        })
    }

    /// The empty surface bounce cache: every lookup in it is zero (its instance count).
    pub fn empty_bounce_cache(ctx: &GpuContext) -> Result<wgpu::Buffer> {
        ctx.storage_buffer("bounce cache", &[0u32; 4])
    }

    /// The surface bounce cache to bind (a handle: the buffer itself is shared).
    pub fn bounce_cache(&self) -> wgpu::Buffer {
        match self.bounce_cache.lock() {
            Ok(b) => b.0.clone(),
            Err(poisoned) => poisoned.into_inner().0.clone(),
        }
    }

    /// Sets the surface bounce cache later passes bind (the bounce module's gather), and
    /// whether it holds anything (`filled`; false for [`Self::empty_bounce_cache`]).
    pub fn set_bounce_cache(&self, cache: wgpu::Buffer, filled: bool) {
        match self.bounce_cache.lock() {
            Ok(mut b) => *b = (cache, filled),
            Err(poisoned) => *poisoned.into_inner() = (cache, filled),
        }
    }

    /// What the scene's rays meet now: its kinds of light, instances and textures, and the
    /// bounce cache when one is set (pipelines compiled for fewer features refuse it).
    pub fn features(&self) -> super::SceneFeatures {
        let filled = match self.bounce_cache.lock() {
            Ok(b) => b.1,
            Err(poisoned) => poisoned.into_inner().1,
        };
        self.static_features.with_bounce_cache(filled)
    }

    /// The scene's virtual point lights (None until a VPL set is traced for it).
    pub fn vpls(&self) -> Option<SceneVpls> {
        match self.vpls.lock() {
            Ok(v) => v.clone(),
            Err(poisoned) => poisoned.into_inner().clone(),
        }
    }

    /// Sets the virtual point lights record gathers read (the vpl module's trace).
    pub fn set_vpls(&self, vpls: SceneVpls) {
        match self.vpls.lock() {
            Ok(mut v) => *v = Some(vpls),
            Err(poisoned) => *poisoned.into_inner() = Some(vpls),
        }
    }

    /// Changes the number of light samples without re-uploading the scene.
    pub fn set_light_samples(&mut self, ctx: &GpuContext, samples: u32) {
        self.info.light_samples = samples.max(1);
        ctx.queue
            .write_buffer(&self.info_buffer, 0, bytemuck::bytes_of(&self.info));
    }
}

#[cfg(test)]
mod tests {
    use super::GpuSceneInfo;

    /// `GpuSceneInfo` is the WGSL `SceneInfo` byte for byte: its size, and the offsets of
    /// the instance transforms that `surface_at` reads for a one-instance scene (a
    /// mismatch would shade every hit of such a scene with wrong transforms).
    #[test]
    fn scene_info_mirror_matches_the_wgsl_struct() {
        let (module, _) = crate::gpu::shader::parsed_module("visibility.wgsl").expect("parse");
        let (members, span) = module
            .types
            .iter()
            .find_map(|(_, t)| match (&t.name, &t.inner) {
                (Some(n), naga::TypeInner::Struct { members, span }) if n == "SceneInfo" => {
                    Some((members.clone(), *span))
                }
                _ => None,
            })
            .expect("SceneInfo in scene.wgsl");
        assert_eq!(span as usize, std::mem::size_of::<GpuSceneInfo>());
        let offset = |name: &str| {
            members
                .iter()
                .find(|m| m.name.as_deref() == Some(name))
                .map(|m| m.offset as usize)
                .expect("member")
        };
        assert_eq!(
            offset("one_instance_world_from_object"),
            std::mem::offset_of!(GpuSceneInfo, one_instance_world_from_object)
        );
        assert_eq!(
            offset("one_instance_normal_to_world"),
            std::mem::offset_of!(GpuSceneInfo, one_instance_normal_to_world)
        );
        assert_eq!(
            offset("triangle_texels"),
            std::mem::offset_of!(GpuSceneInfo, triangle_texels)
        );
    }
}
