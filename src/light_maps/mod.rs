//! Light-space visibility maps: the compute equivalent of the shadow maps the thesis shades
//! hemisphere planes with (section 4.4). Once per prepared scene, each light traces a grid of rays
//! from its side (`wgsl/light_map_trace.wgsl`) and stores the distance to the first
//! surface; plane hits then look their shadows up (`wgsl/shared/light_map_lookup.wgsl`)
//! instead of tracing a shadow ray each. A sun gets an orthographic map over the scene's
//! bounds; a point or spot light an octahedral map around it; a rect light an n x n grid
//! of octahedral maps traced from its cells' centres: a plane hit keeps its own random
//! point on the light (the geometric term stays exact) and takes the visibility of the
//! cell the point falls in. The lookup tests the nearest texels' rays against the
//! receiver's plane; where they cannot decide (a crease, a contact shadow, a texel past
//! an edge of the receiver) the plane hit traces its exact shadow ray instead.
//! The environment keeps its shadow rays (no map covers a constant sky). The camera
//! pixels' direct light keeps exact shadow rays too: maps only feed the indirect light,
//! which averages their error over a record's plane.

pub mod lit_grid;

use crate::Result;
use crate::gpu::GpuContext;
use crate::gpu::pipeline::{Binding, ComputePass};
use crate::gpu::scene_buffers::{
    GpuLight, GpuScene, LIGHT_POINT, LIGHT_RECT, LIGHT_SPOT, LIGHT_SUN,
};
use crate::gpu::timer::PassTimer;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// `MAP_ORTHOGRAPHIC` and `MAP_OCTAHEDRAL` in `wgsl/shared/light_map.wgsl`.
pub const MAP_ORTHOGRAPHIC: u32 = 0;
pub const MAP_OCTAHEDRAL: u32 = 1;
/// `NO_MAP` in `wgsl/shared/light_map_lookup.wgsl`: a light without maps.
pub const NO_MAP: u32 = u32::MAX;

/// Where an octahedral map's rays start, as a fraction of the scene's diagonal (`dir.w` of
/// such a map, [`layout`]).
pub const OCTAHEDRAL_TMIN: f32 = 1e-4;

/// How big the maps are.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LightMapSettings {
    /// Texels per side of a sun's orthographic map; octahedral maps (points) get half.
    pub resolution: u32,
    /// A rect light gets an n x n grid of maps (one per cell, traced from its centre).
    pub rect_grid: u32,
}

/// Which lights get maps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MappedLights {
    /// Every light.
    All,
    /// Suns, point and spot lights (rect lights keep their shadow rays).
    DeltaOnly,
}

/// One map (mirror of WGSL `LightMap`, 80 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuLightMap {
    pub kind: u32,
    pub light: u32,
    pub resolution: u32,
    pub offset: u32,
    /// Orthographic: the corner of texel (0, 0) on the ray plane; octahedral: the point
    /// the rays start from. w: the texel size (world units; radians for octahedral).
    pub origin: [f32; 4],
    /// Orthographic: unit axes across the map (xyz) and the map's extent along them (w).
    pub axis_u: [f32; 4],
    pub axis_v: [f32; 4],
    /// Orthographic: the rays' unit direction (away from the sun). Octahedral: w, the
    /// distance from the light where the rays start ([`OCTAHEDRAL_TMIN`]).
    pub dir: [f32; 4],
}

/// The maps of one frame: their layout (the CPU side) and, once traced, the GPU buffers
/// plane passes bind.
pub struct LightMaps {
    /// The maps, in light order (a rect light's points in order).
    pub layout: Vec<GpuLightMap>,
    /// Element 0: the number of maps; elements 1 + 2 slot and 2 + 2 slot: light `slot`'s
    /// first map (or [`NO_MAP`]) and, for a rect light, its grid's n.
    pub first: Vec<u32>,
    pub maps_buffer: wgpu::Buffer,
    pub depths: wgpu::Buffer,
    pub first_buffer: wgpu::Buffer,
    /// Where the maps' lights reach (every texel's first hit), coarsely.
    pub lit_grid: lit_grid::LitGrid,
}

impl LightMaps {
    /// No maps: plane hits trace every shadow ray (placeholder buffers to bind).
    pub fn none(ctx: &GpuContext) -> Result<Self> {
        Ok(Self {
            layout: Vec::new(),
            first: vec![0, NO_MAP, 0, 0],
            maps_buffer: ctx.storage_buffer("light maps", &[GpuLightMap::default()])?,
            depths: ctx.storage_buffer_sized("light map depths", 16)?,
            first_buffer: ctx.storage_buffer("light map table", &[0u32; 4])?,
            lit_grid: lit_grid::LitGrid::none(ctx)?,
        })
    }

    /// Whether these maps see every surface a plane ray can find light on in `scene`, so that
    /// a plane that saw no light may skip the pixels the lit grid rules out
    /// (`records::refine::guided_pixels`): the grid exists only where every light has a map
    /// and neither an environment nor an emitter of its own lights a hit
    /// ([`LightMapPass::build`]), and hits must not reflect a bounce cache either.
    pub fn see_every_lit_surface(&self, scene: &GpuScene) -> bool {
        self.lit_grid.params.levels > 0 && !scene.features().has_bounce_cache()
    }

    /// Texels over all maps (rays traced to build them).
    pub fn texels(&self) -> u64 {
        self.layout
            .iter()
            .map(|m| u64::from(m.resolution).pow(2))
            .sum()
    }
}

/// The centre of cell `(i, j)` of a rect light's `n x n` grid.
pub fn rect_cell_centre(light: &GpuLight, n: u32, i: u32, j: u32) -> Vec3 {
    let v = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
    let (s, t) = ((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
    v(light.a) + s * v(light.b) + t * v(light.c)
}

/// The maps of `lights` in a scene with world bounds `bounds` (CPU only: what
/// [`LightMapPass::build`] traces). Deterministic.
pub fn layout(
    lights: &[GpuLight],
    bounds: (Vec3, Vec3),
    settings: &LightMapSettings,
    mapped: MappedLights,
) -> (Vec<GpuLightMap>, Vec<u32>) {
    let mut maps = Vec::new();
    let mut first = vec![0u32; 2 * lights.len() + 1];
    let (lo, hi) = bounds;
    let diagonal = (hi - lo).length().max(1e-6);
    let point_res = (settings.resolution / 2).max(8);
    let v = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
    let v4 = |p: Vec3, w: f32| [p.x, p.y, p.z, w];
    let octahedral = |slot: u32, origin: Vec3, maps: &mut Vec<GpuLightMap>| {
        maps.push(GpuLightMap {
            kind: MAP_OCTAHEDRAL,
            light: slot,
            resolution: point_res,
            offset: 0,
            // An octahedral texel spans about 4 / resolution radians on the sphere's
            // widest parts (the square's side is 2 pi over the equator's four faces).
            origin: v4(origin, 4.0 / point_res as f32),
            // w: where the rays start, OCTAHEDRAL_TMIN of the scene's diagonal out: a light
            // on a surface (a ceiling lamp) would otherwise find that surface at t = 0 in
            // every direction and shadow the whole scene, where exact shadow rays stop
            // 1e-4 of their length short of the light (`shadow_ray` in shading.wgsl).
            dir: [0.0, 0.0, 0.0, OCTAHEDRAL_TMIN * diagonal],
            ..Default::default()
        });
    };
    for (slot, light) in lights.iter().enumerate() {
        let slot_u = slot as u32;
        let kind = light.a[3].to_bits();
        first[1 + 2 * slot] = maps.len() as u32;
        match kind {
            LIGHT_SUN => {
                let to_sun = v(light.a).normalize_or_zero();
                if to_sun == Vec3::ZERO {
                    first[1 + 2 * slot] = NO_MAP;
                    continue;
                }
                let frame = crate::sampling::orthonormal_basis(to_sun);
                let (u, w) = (frame.x_axis, frame.y_axis);
                // The scene's box in the sun's frame.
                let mut min = Vec3::splat(f32::INFINITY);
                let mut max = Vec3::splat(f32::NEG_INFINITY);
                for c in 0..8 {
                    let p = Vec3::new(
                        if c & 1 != 0 { hi.x } else { lo.x },
                        if c & 2 != 0 { hi.y } else { lo.y },
                        if c & 4 != 0 { hi.z } else { lo.z },
                    );
                    let q = Vec3::new(p.dot(u), p.dot(w), p.dot(to_sun));
                    min = min.min(q);
                    max = max.max(q);
                }
                // Square texels over the larger side, a margin of one percent.
                let margin = 0.01 * diagonal;
                let extent = (max.x - min.x).max(max.y - min.y) + 2.0 * margin;
                let res = settings.resolution;
                let corner =
                    (min.x - margin) * u + (min.y - margin) * w + (max.z + margin) * to_sun;
                maps.push(GpuLightMap {
                    kind: MAP_ORTHOGRAPHIC,
                    light: slot_u,
                    resolution: res,
                    offset: 0,
                    origin: v4(corner, extent / res as f32),
                    axis_u: v4(u, extent),
                    axis_v: v4(w, extent),
                    dir: v4(-to_sun, 0.0),
                });
            }
            LIGHT_POINT | LIGHT_SPOT => octahedral(slot_u, v(light.a), &mut maps),
            LIGHT_RECT if mapped == MappedLights::DeltaOnly => first[1 + 2 * slot] = NO_MAP,
            LIGHT_RECT => {
                // Cell centres just off the emitting side, so rays leave the light's quad;
                // cell (i, j) is map i + n j.
                let normal = v(light.b).cross(v(light.c)).normalize_or_zero();
                let n = settings.rect_grid;
                first[2 + 2 * slot] = n;
                for j in 0..n {
                    for i in 0..n {
                        let q = rect_cell_centre(light, n, i, j) + normal * (1e-4 * diagonal);
                        octahedral(slot_u, q, &mut maps);
                    }
                }
            }
            _ => first[1 + 2 * slot] = NO_MAP,
        }
    }
    let mut offset = 0u32;
    for m in &mut maps {
        m.offset = offset;
        offset += m.resolution * m.resolution;
    }
    first[0] = maps.len() as u32;
    (maps, first)
}

/// The trace pass's bindings (`wgsl/light_map_trace.wgsl`).
const TRACE_BINDINGS: [Binding; 4] = [
    Binding::StorageRead,
    Binding::StorageReadWrite,
    Binding::Uniform,
    Binding::StorageReadWrite,
];

/// The trace pass (`wgsl/light_map_trace.wgsl`), compiled for whether the scene's rays enter
/// instances (built once per device and such feature, at the first scene that has it).
pub struct LightMapPass {
    lit_grid: lit_grid::LitGridReducePass,
}

impl LightMapPass {
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        Ok(Self {
            lit_grid: lit_grid::LitGridReducePass::new(ctx)?,
        })
    }

    /// The trace compiled for a scene of `features`: without the TLAS leaf's instance loads
    /// and transforms when its rays never leave one BLAS placed as modelled (lavapipe runs
    /// every branch of the traversal loop). Built once per device and traversal; a frame's
    /// builds ahead call it with the scene's features.
    pub fn trace(
        &self,
        ctx: &GpuContext,
        features: crate::gpu::SceneFeatures,
    ) -> Result<std::sync::Arc<ComputePass>> {
        ComputePass::with_constants(
            ctx,
            "light_map_trace.wgsl",
            &TRACE_BINDINGS,
            &[features.traversal_only().constant()],
        )
    }

    /// Lays out and traces the maps of `lights` over `scene` (timed as "light maps").
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        lights: &[GpuLight],
        bounds: (Vec3, Vec3),
        settings: &LightMapSettings,
        mapped: MappedLights,
        times: &mut Vec<(&'static str, f64)>,
    ) -> Result<LightMaps> {
        let (layout, first) = layout(lights, bounds, settings, mapped);
        if layout.is_empty() {
            return LightMaps::none(ctx);
        }
        let texels: u64 = layout.iter().map(|m| u64::from(m.resolution).pow(2)).sum();
        let maps_buffer = ctx.storage_buffer("light maps", &layout)?;
        let depths = ctx.storage_buffer_sized("light map depths", texels * 4)?;
        let first_buffer = ctx.storage_buffer("light map table", &first)?;
        let max_res = layout.iter().map(|m| m.resolution).max().unwrap_or(8);
        // The lit grid only where the maps see every lit surface (every light mapped, no
        // environment, no emitters of their own): elsewhere no plane could use it.
        let every_light_mapped = first.iter().skip(1).step_by(2).all(|&m| m != NO_MAP);
        let grid = if every_light_mapped
            && !scene.unsampled_emission
            && !scene.features().has_environment()
        {
            lit_grid::LitGrid::over(ctx, bounds)?
        } else {
            lit_grid::LitGrid::none(ctx)?
        };
        let trace = self.trace(ctx, scene.features())?;
        let bind = trace.bind(
            ctx,
            &[&maps_buffer, &depths, &grid.params_buffer, &grid.voxels],
        );
        let mut timer = PassTimer::new(ctx, 1);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        trace.record(
            &mut enc,
            &scene.bind_group,
            &bind,
            [
                max_res.div_ceil(8),
                max_res.div_ceil(8),
                layout.len() as u32,
            ],
            timer.next("light maps"),
        );
        self.lit_grid.record(ctx, &mut enc, scene, &grid);
        timer.resolve(&mut enc);
        ctx.queue.submit([enc.finish()]);
        times.extend(timer.read(ctx)?);
        Ok(LightMaps {
            layout,
            first,
            maps_buffer,
            depths,
            first_buffer,
            lit_grid: grid,
        })
    }
}

/// Plain-Rust mirror of `light_map_ray` in `wgsl/shared/light_map.wgsl`: origin and unit
/// direction of texel `(i, j)` of `m`.
pub fn texel_ray(m: &GpuLightMap, i: u32, j: u32) -> (Vec3, Vec3) {
    let v = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
    let res = m.resolution as f32;
    let (u, w) = ((i as f32 + 0.5) / res, (j as f32 + 0.5) / res);
    if m.kind == MAP_ORTHOGRAPHIC {
        let o = v(m.origin) + u * m.axis_u[3] * v(m.axis_u) + w * m.axis_v[3] * v(m.axis_v);
        (o, v(m.dir))
    } else {
        (v(m.origin), octahedral_decode(u, w))
    }
}

/// `octahedral_decode` of `wgsl/shared/light_map.wgsl`.
pub fn octahedral_decode(u: f32, v: f32) -> Vec3 {
    let (ex, ey) = (u * 2.0 - 1.0, v * 2.0 - 1.0);
    let mut d = Vec3::new(ex, ey, 1.0 - ex.abs() - ey.abs());
    if d.z < 0.0 {
        let sx = if d.x >= 0.0 { 1.0 } else { -1.0 };
        let sy = if d.y >= 0.0 { 1.0 } else { -1.0 };
        d = Vec3::new((1.0 - d.y.abs()) * sx, (1.0 - d.x.abs()) * sy, d.z);
    }
    d.normalize()
}

/// The maps' depths traced on the CPU ([`crate::bvh::cpu_trace::CpuTracer`]): the
/// reference the GPU trace is tested against. `f32::INFINITY`-like `1e30` on a miss, as
/// `MAP_NO_HIT` in WGSL.
pub fn reference_depths(
    maps: &[GpuLightMap],
    tracer: &crate::bvh::cpu_trace::CpuTracer,
) -> Vec<f32> {
    let mut out = Vec::new();
    for m in maps {
        for j in 0..m.resolution {
            for i in 0..m.resolution {
                let (o, d) = texel_ray(m, i, j);
                let tmin = if m.kind == MAP_OCTAHEDRAL {
                    m.dir[3]
                } else {
                    0.0
                };
                out.push(
                    tracer
                        .closest_hit(o, d, tmin, f32::INFINITY)
                        .map_or(1.0e30, |h| h.t),
                );
            }
        }
    }
    out
}
