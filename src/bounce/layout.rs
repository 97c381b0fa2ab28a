//! Where the surface bounce cache keeps its values: a barycentric grid of n x n cells over
//! every triangle of every instance (n from the triangle's world-space size), two sides
//! per cell, and the u32 table `wgsl/shared/bounce_cache.wgsl` reads them through. The
//! lookup and the cell geometry are mirrored here in plain Rust for the tests.

use super::BounceSettings;
use crate::bvh::SceneBvh;
use crate::{Error, Result};
use glam::{Mat3, Vec3};

/// WGSL `BOUNCE_CELL_BITS`: an entry holds its triangle's first cell in these low bits.
pub const CELL_BITS: u32 = 26;
/// Most subdivisions per triangle edge (the entry's 6 high bits).
pub const MAX_SUBDIVISIONS: u32 = 63;

/// One triangle of an instance in world space: what its cells are sized and grouped by.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TriangleInfo {
    pub area: f32,
    pub centroid: Vec3,
    /// Unit normal of the winding (zero for a degenerate triangle).
    pub normal: Vec3,
}

/// Every triangle of every instance in world space, in BVH leaf order: what the layout is
/// built from. Taken from the BVH when a scene is prepared.
#[derive(Clone, Debug, Default)]
pub struct BounceGeometry {
    /// Per instance: its mesh's first triangle (leaf order, absolute) and its triangles.
    pub instances: Vec<(u32, Vec<TriangleInfo>)>,
    /// The most direct irradiance any point of the scene can receive (per channel, the
    /// largest): what a gather hit's one-sample estimate is clamped to
    /// ([`super::direct_irradiance_bound`]).
    pub irradiance_bound: f32,
}

impl BounceGeometry {
    /// The triangles of `bvh`'s instances, and the irradiance bound of `scene`.
    pub fn new(bvh: &SceneBvh, scene: &crate::scene::Scene) -> Self {
        let (lo, hi) = bvh.world_bounds();
        Self {
            irradiance_bound: super::direct_irradiance_bound(scene, (hi - lo).length()),
            ..Self::from_bvh(bvh)
        }
    }

    /// The triangles of `bvh`'s instances (no irradiance bound: infinite).
    pub fn from_bvh(bvh: &SceneBvh) -> Self {
        let ends: Vec<u32> = bvh
            .mesh_offsets
            .iter()
            .skip(1)
            .map(|&(_, t)| t)
            .chain(std::iter::once(bvh.triangles.len() as u32))
            .collect();
        let instances = bvh
            .instances
            .iter()
            .map(|inst| {
                let first = inst.first_triangle;
                let end = ends
                    .get(inst.mesh as usize)
                    .copied()
                    .unwrap_or(first)
                    .max(first);
                let r = inst.world_from_object;
                let row = |i: usize| Vec3::new(r[i][0], r[i][1], r[i][2]);
                let linear = Mat3::from_cols(row(0), row(1), row(2)).transpose();
                let offset = Vec3::new(r[0][3], r[1][3], r[2][3]);
                let triangles = (first..end)
                    .map(|t| {
                        let tri = &bvh.triangles[t as usize];
                        let v0 = linear * Vec3::from_slice(&tri.v0[..3]) + offset;
                        let e1 = linear * Vec3::from_slice(&tri.e1[..3]);
                        let e2 = linear * Vec3::from_slice(&tri.e2[..3]);
                        let cross = e1.cross(e2);
                        TriangleInfo {
                            area: 0.5 * cross.length(),
                            centroid: v0 + (e1 + e2) / 3.0,
                            normal: cross.normalize_or_zero(),
                        }
                    })
                    .collect();
                (first, triangles)
            })
            .collect();
        Self {
            instances,
            irradiance_bound: f32::INFINITY,
        }
    }

    /// Triangles over all instances.
    pub fn triangles(&self) -> usize {
        self.instances.iter().map(|(_, t)| t.len()).sum()
    }
}

/// Which group a triangle too small for a grid of its own joins: its instance, the cube of
/// edge `h` its centroid lies in, and one of 54 normal directions (the dominant axis and
/// its sign, the two other components in thirds), so that a group's triangles face alike
/// and their sides agree.
fn group_key(instance: usize, t: &TriangleInfo, h: f32) -> (usize, [i64; 3], u32) {
    let c = (t.centroid / h).floor();
    let cube = [c.x as i64, c.y as i64, c.z as i64];
    let n = t.normal;
    let a = n.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    let sign = u32::from(n[axis] < 0.0);
    let third = |x: f32| (((x + 1.0) * 1.5).floor() as u32).min(2);
    let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
    (
        instance,
        cube,
        ((axis as u32 * 2 + sign) * 3 + third(n[b])) * 3 + third(n[c]),
    )
}

/// One cell (mirror of WGSL `BounceCell`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BounceCell {
    pub instance: u32,
    /// Absolute triangle index (BVH leaf order).
    pub triangle: u32,
    /// Index in the triangle's n x n grid.
    pub cell: u32,
    pub n: u32,
}

/// The cache's table and cells for one scene and settings.
#[derive(Clone, Debug)]
pub struct BounceLayout {
    /// Header, instance table and triangle entries (`wgsl/shared/bounce_cache.wgsl`); the
    /// values follow at word [`BounceLayout::values_word`].
    pub table: Vec<u32>,
    pub cells: Vec<BounceCell>,
    /// The cell edge the subdivision aimed at (world units), after the budget.
    pub cell_size: f32,
    /// [`BounceGeometry::irradiance_bound`].
    pub irradiance_bound: f32,
}

/// Subdivisions of a triangle of `area` for cells of edge `h`: a right triangle with legs
/// L gets L / h per leg.
fn subdivisions(area: f32, h: f32) -> u32 {
    if !(area.is_finite() && area > 0.0) {
        return 1;
    }
    ((2.0 * area).sqrt() / h)
        .ceil()
        .clamp(1.0, MAX_SUBDIVISIONS as f32) as u32
}

impl BounceLayout {
    /// Lays the cells of `geometry` out at `settings.cell_size` of the scene's `diagonal`:
    /// a triangle of at least two cells per edge gets its own n x n grid; smaller ones
    /// share one cell per group (same instance, cube of the cell edge and
    /// normal direction), gathered at the centroid of the group's largest triangle, so a
    /// finely tessellated mesh costs cells by its area, not by its triangle count. The
    /// cell edge grows by quarters until the sides fit `settings.max_cells`.
    pub fn new(
        geometry: &BounceGeometry,
        settings: &BounceSettings,
        diagonal: f32,
    ) -> Result<Self> {
        let mut h = settings.cell_size * diagonal.max(f32::MIN_POSITIVE);
        let max_h = 4.0 * diagonal.max(f32::MIN_POSITIVE);
        loop {
            let layout = Self::with_cell_size(geometry, h)?;
            if 2 * layout.cells.len() as u64 <= u64::from(settings.max_cells) {
                return Ok(layout);
            }
            if h > max_h {
                return Err(Error::Usage(format!(
                    "the bounce cache needs {} cell sides even with one cell per group of \
                     triangles, more than --bounce-cells {}; raise --bounce-cells",
                    2 * layout.cells.len(),
                    settings.max_cells
                )));
            }
            h *= 1.25;
        }
    }

    /// The layout for cells of edge `h` (world units).
    pub fn with_cell_size(geometry: &BounceGeometry, h: f32) -> Result<Self> {
        // Groups of small triangles, numbered in order of first appearance, each with its
        // largest triangle (the first of equal ones).
        let mut groups: std::collections::HashMap<(usize, [i64; 3], u32), usize> =
            Default::default();
        let mut representative: Vec<(u32, u32, f32)> = Vec::new();
        let mut group_of: Vec<Vec<usize>> = Vec::with_capacity(geometry.instances.len());
        for (i, (first, triangles)) in geometry.instances.iter().enumerate() {
            let mut of = Vec::with_capacity(triangles.len());
            for (t, tri) in triangles.iter().enumerate() {
                if subdivisions(tri.area, h) > 1 {
                    of.push(usize::MAX);
                    continue;
                }
                let next = representative.len();
                let g = *groups.entry(group_key(i, tri, h)).or_insert(next);
                if g == next {
                    representative.push((i as u32, first + t as u32, tri.area));
                } else if tri.area > representative[g].2 {
                    representative[g] = (i as u32, first + t as u32, tri.area);
                }
                of.push(g);
            }
            group_of.push(of);
        }
        let instances = geometry.instances.len() as u32;
        let mut table = vec![instances, 0];
        let mut first_entry = 0u32;
        for (_, triangles) in &geometry.instances {
            table.push(first_entry);
            first_entry += triangles.len() as u32;
        }
        let mut cells = Vec::new();
        let mut group_cell = vec![u32::MAX; representative.len()];
        for (i, (first, triangles)) in geometry.instances.iter().enumerate() {
            for (t, tri) in triangles.iter().enumerate() {
                let start = cells.len() as u32;
                if start >= 1 << CELL_BITS {
                    return Err(Error::Usage(
                        "the bounce cache has more cells than its table can index (2^26): \
                         raise --bounce-cell"
                            .into(),
                    ));
                }
                let g = group_of[i][t];
                if g == usize::MAX {
                    let n = subdivisions(tri.area, h);
                    table.push(start | (n << CELL_BITS));
                    cells.extend((0..n * n).map(|k| BounceCell {
                        instance: i as u32,
                        triangle: first + t as u32,
                        cell: k,
                        n,
                    }));
                } else {
                    if group_cell[g] == u32::MAX {
                        let (instance, triangle, _) = representative[g];
                        group_cell[g] = start;
                        cells.push(BounceCell {
                            instance,
                            triangle,
                            cell: 0,
                            n: 1,
                        });
                    }
                    table.push(group_cell[g] | (1 << CELL_BITS));
                }
            }
        }
        table[1] = table.len() as u32;
        Ok(Self {
            table,
            cells,
            cell_size: h,
            irradiance_bound: geometry.irradiance_bound,
        })
    }

    /// The word of the table where the values start (the table's length).
    pub fn values_word(&self) -> u32 {
        self.table[1]
    }

    /// Cell sides (two per cell).
    pub fn sides(&self) -> u32 {
        2 * self.cells.len() as u32
    }

    /// The value index of the side `front` of the cell `hit` falls in, as WGSL
    /// `bounce_irradiance` (instance, absolute leaf-order triangle, barycentrics of v1 and
    /// v2); None outside the cache.
    pub fn side_of(
        &self,
        instance: u32,
        first_triangle: u32,
        triangle: u32,
        u: f32,
        v: f32,
        front: bool,
    ) -> Option<usize> {
        let count = self.table[0];
        if instance >= count {
            return None;
        }
        let entry_index =
            2 + count + self.table[2 + instance as usize] + (triangle - first_triangle);
        let entry = *self.table.get(entry_index as usize)?;
        let n = entry >> CELL_BITS;
        let cell = (entry & ((1 << CELL_BITS) - 1)) + cell_of(u, v, n);
        Some(2 * cell as usize + usize::from(!front))
    }
}

/// WGSL `bounce_row_base`.
pub fn row_base(j: u32, n: u32) -> u32 {
    2 * n * j - j * j
}

/// WGSL `bounce_cell`: the cell of barycentrics (u, v) in an n x n grid.
pub fn cell_of(u: f32, v: f32, n: u32) -> u32 {
    let nf = n as f32;
    let a = u.clamp(0.0, 1.0) * nf;
    let b = v.clamp(0.0, 1.0) * nf;
    let j = (b as u32).min(n - 1);
    let i = (a as u32).min(n - 1 - j);
    let upper = (a - i as f32) + (b - j as f32) > 1.0 && i + j + 1 < n;
    row_base(j, n) + 2 * i + u32::from(upper)
}

/// WGSL `bounce_cell_centroid`: barycentrics of the centroid of cell `cell`.
pub fn cell_centroid(cell: u32, n: u32) -> (f32, f32) {
    let mut j = 0;
    while j + 1 < n && row_base(j + 1, n) <= cell {
        j += 1;
    }
    let r = cell - row_base(j, n);
    let i = r / 2;
    let third = if r & 1 == 1 { 2.0 } else { 1.0 } / 3.0;
    ((i as f32 + third) / n as f32, (j as f32 + third) / n as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_cell_centroid_falls_in_its_own_cell() {
        for n in [1, 2, 3, 7, 63] {
            for k in 0..n * n {
                let (u, v) = cell_centroid(k, n);
                assert!(u > 0.0 && v > 0.0 && u + v < 1.0, "n {n} cell {k}: {u} {v}");
                assert_eq!(cell_of(u, v, n), k, "n {n}");
            }
        }
    }

    #[test]
    fn cells_tile_the_triangle_with_equal_areas() {
        // Points on a fine barycentric lattice land in every cell equally often.
        let n = 5;
        let m = 400;
        let mut hits = vec![0u32; (n * n) as usize];
        for a in 0..m {
            for b in 0..m - a {
                let (u, v) = ((a as f32 + 0.3) / m as f32, (b as f32 + 0.3) / m as f32);
                if u + v < 1.0 {
                    hits[cell_of(u, v, n) as usize] += 1;
                }
            }
        }
        let mean = hits.iter().sum::<u32>() as f32 / hits.len() as f32;
        for (k, &h) in hits.iter().enumerate() {
            assert!(
                (h as f32 / mean - 1.0).abs() < 0.05,
                "cell {k}: {h} of mean {mean}"
            );
        }
    }

    /// Right triangles in the z = 0 plane with legs `leg`, at `x` along x.
    fn geometry(triangles: &[(f32, f32)]) -> BounceGeometry {
        BounceGeometry {
            irradiance_bound: f32::INFINITY,
            instances: vec![(
                10,
                triangles
                    .iter()
                    .map(|&(leg, x)| TriangleInfo {
                        area: 0.5 * leg * leg,
                        centroid: Vec3::new(x + leg / 3.0, leg / 3.0, 0.0),
                        normal: Vec3::Z,
                    })
                    .collect(),
            )],
        }
    }

    #[test]
    fn layout_subdivides_by_size_and_keeps_to_the_budget() {
        let settings = BounceSettings {
            cell_size: 0.1,
            ..BounceSettings::default()
        };
        // Diagonal 1: cells of 0.1; a right triangle with legs 0.5 gets n = 5; two small
        // ones in the same 0.1 cube share a cell, a third one elsewhere gets its own.
        let tris = [(0.5, 0.0), (0.001, 2.0), (0.01, 2.02), (0.01, 3.0)];
        let l = BounceLayout::new(&geometry(&tris), &settings, 1.0).unwrap();
        assert_eq!(l.cells.len(), 25 + 2);
        // The shared cell is gathered on the larger of its two triangles.
        assert_eq!(l.cells[25].triangle, 12);
        assert_eq!(
            l.side_of(0, 10, 11, 0.2, 0.2, true),
            l.side_of(0, 10, 12, 0.5, 0.1, true)
        );
        assert_eq!(l.table[0], 1);
        assert_eq!(l.values_word() as usize, l.table.len());
        assert_eq!(l.side_of(0, 10, 10, 0.05, 0.05, true), Some(0));
        assert_eq!(l.side_of(0, 10, 11, 0.3, 0.3, false), Some(2 * 25 + 1));
        assert_eq!(l.side_of(0, 10, 13, 0.3, 0.3, true), Some(2 * 26));
        let tight = BounceSettings {
            max_cells: 20,
            ..settings
        };
        let l = BounceLayout::new(&geometry(&tris), &tight, 1.0).unwrap();
        assert!(2 * l.cells.len() <= 20, "{} cells", l.cells.len());
        let too_tight = BounceSettings {
            max_cells: 1,
            ..settings
        };
        let err = BounceLayout::new(&geometry(&tris), &too_tight, 1.0).unwrap_err();
        assert!(err.to_string().contains("--bounce-cells"), "{err}");
    }
}
