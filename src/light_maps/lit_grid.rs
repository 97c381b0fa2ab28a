//! Where lit surfaces are, coarsely: a pyramid of voxel grids over the scene's bounds
//! (`wgsl/shared/lit_grid.wgsl`). The light-map trace marks, in the voxel of every texel's
//! first hit (a surface its light reaches), the face bit of that surface's lit side
//! ([`face_bit`]); each coarser level is the OR of its 2x2x2 children
//! (`lit_grid_reduce.wgsl`). A hemisphere plane that saw no light then refines
//! only the pixels whose rays could land near a lit surface (`plane_refine_select.wgsl`).

use crate::Result;
use crate::gpu::GpuContext;
use crate::gpu::pipeline::{Binding, ComputePass};
use crate::gpu::scene_buffers::GpuScene;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Voxels of level 0 along the bounds' longest axis.
pub const FINEST: u32 = 64;
/// Most levels (the WGSL offsets table holds eight).
const MAX_LEVELS: u32 = 8;

/// Mirror of WGSL `LitGridParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct LitGridParams {
    pub lo: [f32; 3],
    pub cell: f32,
    pub dims: [u32; 3],
    /// 0: no grid (every query says "maybe lit").
    pub levels: u32,
    pub offsets: [u32; 8],
}

impl LitGridParams {
    /// The pyramid over `bounds`: level 0 cubic voxels, `FINEST` along the longest axis,
    /// halved per level down to one voxel.
    pub fn over(bounds: (Vec3, Vec3)) -> Self {
        let (lo, hi) = bounds;
        let extent = (hi - lo).max(Vec3::splat(1e-6));
        // A hair wider than FINEST cells along the longest side, so that its far end lies
        // inside the last voxel (marks are clamped to the grid too).
        let cell = extent.max_element() / FINEST as f32 * 1.0001;
        let dims = (extent / cell).ceil().as_uvec3().max(glam::UVec3::ONE);
        let mut offsets = [0u32; 8];
        let mut total = 0;
        let mut levels = 0;
        for l in 0..MAX_LEVELS {
            let d = level_dims(dims.into(), l);
            offsets[l as usize] = total;
            total += d[0] * d[1] * d[2];
            levels = l + 1;
            if d == [1, 1, 1] {
                break;
            }
        }
        Self {
            lo: lo.into(),
            cell,
            dims: dims.into(),
            levels,
            offsets,
        }
    }

    /// Voxels over every level.
    pub fn voxels(&self) -> u32 {
        let last = self.levels.saturating_sub(1);
        let d = level_dims(self.dims, last);
        self.offsets[last as usize] + d[0] * d[1] * d[2]
    }
}

/// Voxels per axis of `level` (`lit_grid_dims` in WGSL).
pub fn level_dims(dims: [u32; 3], level: u32) -> [u32; 3] {
    dims.map(|d| (d.div_ceil(1 << level)).max(1))
}

/// A frame's lit grid: its parameters (uniform) and voxels (one u32 each).
pub struct LitGrid {
    pub params: LitGridParams,
    pub params_buffer: wgpu::Buffer,
    pub voxels: wgpu::Buffer,
}

impl LitGrid {
    /// No grid: every query answers "maybe lit" (planes refine as without one).
    pub fn none(ctx: &GpuContext) -> Result<Self> {
        let params = LitGridParams::default();
        Ok(Self {
            params,
            params_buffer: ctx.uniform_buffer("lit grid params", &params),
            voxels: ctx.storage_buffer_sized("lit grid", 16)?,
        })
    }

    /// An empty grid over `bounds`, for the light-map trace to mark.
    pub fn over(ctx: &GpuContext, bounds: (Vec3, Vec3)) -> Result<Self> {
        let params = LitGridParams::over(bounds);
        Ok(Self {
            params,
            params_buffer: ctx.uniform_buffer("lit grid params", &params),
            voxels: ctx.storage_buffer_sized("lit grid", u64::from(params.voxels()) * 4)?,
        })
    }
}

/// Builds the coarser levels once level 0 is marked.
pub struct LitGridReducePass {
    reduce: std::sync::Arc<ComputePass>,
}

impl LitGridReducePass {
    /// Compiles the pass.
    pub fn new(ctx: &GpuContext) -> Result<Self> {
        Ok(Self {
            reduce: ComputePass::new(
                ctx,
                "lit_grid_reduce.wgsl",
                &[
                    Binding::Uniform,
                    Binding::StorageReadWrite,
                    Binding::Uniform,
                ],
            )?,
        })
    }

    /// Records the reduction of every level after the first.
    pub fn record(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        grid: &LitGrid,
    ) {
        #[repr(C)]
        #[derive(Clone, Copy, Pod, Zeroable)]
        struct Level {
            level: u32,
            pad: [u32; 3],
        }
        for level in 1..grid.params.levels {
            let d = level_dims(grid.params.dims, level);
            let u = ctx.uniform_buffer("lit grid level", &Level { level, pad: [0; 3] });
            let bind = self
                .reduce
                .bind(ctx, &[&grid.params_buffer, &grid.voxels, &u]);
            self.reduce.record(
                enc,
                &scene.bind_group,
                &bind,
                [(d[0] * d[1] * d[2]).div_ceil(64), 1, 1],
                None,
            );
        }
    }
}

/// The face bit of a lit surface's normal `n` (facing its light): its dominant axis and
/// sign (WGSL `lit_face_bit`).
pub fn face_bit(n: Vec3) -> u32 {
    let a = n.abs();
    let (axis, v) = if a.y > a.x && a.y >= a.z {
        (1, n.y)
    } else if a.z > a.x && a.z > a.y {
        (2, n.z)
    } else {
        (0, n.x)
    };
    1 << (2 * axis + u32::from(v < 0.0))
}

/// The face bits of lit surfaces whose lit side a ray of direction `d` can meet (WGSL
/// `lit_faces_seen`): a normal in a face's cone (at most 54.7 degrees from its axis) can
/// face `-d` only if the axis lies within 144.7 degrees of `-d` (cos -0.8165); -0.85
/// leaves the spread of a pixel's sub-ray directions a margin.
pub fn faces_seen(d: Vec3) -> u32 {
    let v = -d;
    let mut mask = 0;
    for axis in 0..3 {
        if v[axis] > -0.85 {
            mask |= 1 << (2 * axis);
        }
        if -v[axis] > -0.85 {
            mask |= 1 << (2 * axis + 1);
        }
    }
    mask
}

/// The face bits whose cones come within about 10 degrees of the unit normal `n` (WGSL
/// `lit_faces_near`): a surface's lit side, if it is lit, is marked with one of them
/// ([`face_bit`] of its own normal, which rounding may tip to a neighbouring face near a
/// cone's edge).
pub fn faces_near(n: Vec3) -> u32 {
    let mut mask = 0;
    for axis in 0..3 {
        if n[axis] > 0.43 {
            mask |= 1 << (2 * axis);
        }
        if -n[axis] > 0.43 {
            mask |= 1 << (2 * axis + 1);
        }
    }
    mask
}

impl LitGridParams {
    /// Index of voxel `c` of `level` (WGSL `lit_grid_voxel`).
    pub fn voxel(&self, level: u32, c: [u32; 3]) -> usize {
        let d = level_dims(self.dims, level);
        (self.offsets[level as usize] + (c[2] * d[1] + c[1]) * d[0] + c[0]) as usize
    }

    /// Whether a lit surface whose lit side faces one of `faces` may lie within `radius`
    /// of `q` (WGSL `lit_near`): the 2x2x2 voxels of the first level whose voxels are at
    /// least `2 radius` wide contain the ball. Always true without a grid or for a ball
    /// wider than the coarsest level.
    pub fn near(&self, voxels: &[u32], q: Vec3, radius: f32, faces: u32) -> bool {
        if self.levels == 0 {
            return true;
        }
        let (mut level, mut cell) = (0, self.cell);
        while cell < 2.0 * radius && level + 1 < self.levels {
            level += 1;
            cell *= 2.0;
        }
        if cell < 2.0 * radius {
            return true;
        }
        let d = level_dims(self.dims, level).map(|v| v as i32);
        let c = ((q - Vec3::from(self.lo)) / cell - Vec3::splat(0.5))
            .floor()
            .as_ivec3();
        for z in 0..2 {
            for y in 0..2 {
                for x in 0..2 {
                    let v = c + glam::IVec3::new(x, y, z);
                    let inside = (0..3).all(|a| v[a] >= 0 && v[a] < d[a]);
                    if inside && voxels[self.voxel(level, v.as_uvec3().into())] & faces != 0 {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// Fills the coarser levels of `voxels` from level 0 (WGSL `lit_grid_reduce.wgsl`):
    /// each voxel the OR of its 2x2x2 children.
    pub fn reduce(&self, voxels: &mut [u32]) {
        for level in 1..self.levels {
            let d = level_dims(self.dims, level);
            let fine = level_dims(self.dims, level - 1);
            for z in 0..d[2] {
                for y in 0..d[1] {
                    for x in 0..d[0] {
                        let mut any = 0;
                        for (dx, dy, dz) in cube_corners() {
                            let f = [2 * x + dx, 2 * y + dy, 2 * z + dz];
                            if (0..3).all(|a| f[a] < fine[a]) {
                                any |= voxels[self.voxel(level - 1, f)];
                            }
                        }
                        let i = self.voxel(level, [x, y, z]);
                        voxels[i] = any;
                    }
                }
            }
        }
    }
}

/// The eight corners of a unit cube, x fastest.
fn cube_corners() -> impl Iterator<Item = (u32, u32, u32)> {
    (0..8).map(|i| (i & 1, (i >> 1) & 1, i >> 2))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn face_bits_and_the_faces_a_ray_can_see() {
        assert_eq!(face_bit(Vec3::Y), 1 << 2);
        assert_eq!(face_bit(-Vec3::Y), 1 << 3);
        assert_eq!(face_bit(Vec3::new(0.2, -0.1, -0.9)), 1 << 5);
        // A ray going straight up meets no surface lit from above (a roof's top), every
        // other face it can.
        let up = faces_seen(Vec3::Y);
        assert_eq!(up & face_bit(Vec3::Y), 0);
        assert_ne!(up & face_bit(-Vec3::Y), 0);
        assert_ne!(up & face_bit(Vec3::X), 0);
        // Conservative: whenever a lit surface's normal faces -d, its face is seen.
        let unit = |k: u32, salt: u32| {
            let h = |x: u32| crate::sampling::u32_to_unit(crate::sampling::hash_combine(x, salt));
            let (u, v) = (h(2 * k), h(2 * k + 1));
            let z = 1.0 - 2.0 * u;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = std::f32::consts::TAU * v;
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        };
        let (mut checked, mut excluded) = (0, 0);
        for k in 0..20_000 {
            let (n, d) = (unit(k, 1), unit(k, 2));
            if n.dot(-d) > 0.0 {
                checked += 1;
                assert_ne!(faces_seen(d) & face_bit(n), 0, "n {n:?} d {d:?}");
            }
            excluded += (!faces_seen(d)).count_ones() - 26;
        }
        assert!(checked > 9_000);
        // A surface's own face is among those near its normal, for normals turned by up
        // to 10 degrees from it.
        for k in 0..5_000 {
            let (n, t) = (unit(k, 3), unit(k, 4));
            let turned = (n + 0.17 * (t - t.dot(n) * n)).normalize();
            if n.dot(turned) > 0.9848 {
                assert_ne!(faces_near(n) & face_bit(turned), 0, "{n:?} {turned:?}");
            }
        }
        // And it does rule faces out: about one face for every two directions (a ray near
        // an axis rules out the face opposite it).
        assert!(excluded > 6_000, "{excluded}");
    }

    #[test]
    fn queries_are_conservative_over_the_pyramid() {
        let p = LitGridParams::over((Vec3::ZERO, Vec3::new(8.0, 4.0, 2.0)));
        assert_eq!(p.dims, [64, 32, 16]);
        let mut voxels = vec![0u32; p.voxels() as usize];
        // One lit voxel holding a floor lit from above, at about (5.06, 1.06, 1.06).
        let lit = Vec3::new(5.06, 1.06, 1.06);
        let c = ((lit - Vec3::from(p.lo)) / p.cell).floor().as_uvec3();
        voxels[p.voxel(0, c.into())] = face_bit(Vec3::Y);
        p.reduce(&mut voxels);
        let top = p.levels - 1;
        assert_eq!(level_dims(p.dims, top), [1, 1, 1]);
        assert_ne!(voxels[p.voxel(top, [0, 0, 0])], 0);
        let down = faces_seen(-Vec3::Y);
        // Every ball that holds the lit point finds it, at every radius.
        for k in 0..400 {
            let t = k as f32;
            let radius = 0.01 * (1.0 + (t * 0.61).sin().abs() * 100.0);
            let dir = Vec3::new((t * 1.7).sin(), (t * 0.9).cos(), (t * 2.3).sin()).normalize();
            let q = lit + dir * radius * 0.99;
            assert!(p.near(&voxels, q, radius, down), "{q:?} {radius}");
        }
        // Far from it, or looking for surfaces lit from below, nothing.
        assert!(!p.near(&voxels, Vec3::new(1.0, 3.0, 0.5), 0.05, down));
        assert!(!p.near(&voxels, lit, 0.05, faces_seen(Vec3::Y)));
        // No grid: always maybe.
        assert!(LitGridParams::default().near(&[], lit, 0.0, 0));
    }
}
