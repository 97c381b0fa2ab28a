//! A uniform grid over the photons (their slots sorted by cell, then by slot): the
//! neighbourhood queries of photon-mapped records, deterministic (ties broken by slot).

use super::Photon;
use glam::{IVec3, Vec3};
use std::collections::HashMap;

/// Photons on the same surface as a query point: normals within about 25 degrees...
pub const SAME_SURFACE_COS: f32 = 0.9;
/// ...and within about 14 degrees of its tangent plane (a curved surface of radius rho
/// bends x^2 / (2 rho) out of the plane over x; the normal bound keeps x <= 0.45 rho, so
/// this keeps every photon of a smooth surface and drops those of a nearby parallel one).
pub const SAME_SURFACE_SLOPE: f32 = 0.25;

/// The photons of a map, indexed by a uniform grid.
pub struct PhotonMap {
    pub photons: Vec<Photon>,
    cell: f32,
    /// Slots of the non-empty photons, sorted by (cell, slot).
    order: Vec<u32>,
    /// Each occupied cell's range of `order`.
    cells: HashMap<IVec3, (u32, u32)>,
}

/// How many rings of cells a nearest-photons query searches at most.
pub const MAX_RINGS: i32 = 8;

/// The grid cell for `photons` photons spread over `surface_area` that a query for the
/// `gather` nearest should span: the radius holding that many at the mean density.
pub fn cell_for(photons: u32, surface_area: f32, gather: u32) -> f32 {
    (surface_area * gather as f32 / (std::f32::consts::PI * photons.max(1) as f32)).sqrt()
}

/// A photon found by a query: its slot and squared distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbour {
    pub slot: u32,
    pub distance2: f32,
}

impl PhotonMap {
    /// Indexes `photons` (all slots; empty ones are left out) in cells of `cell` world
    /// units: about the radius of the queries to come.
    pub fn new(photons: Vec<Photon>, cell: f32) -> Self {
        let cell = if cell.is_finite() && cell > 0.0 {
            cell
        } else {
            1.0
        };
        let key = |p: &Photon| (p.position() / cell).floor().as_ivec3();
        let mut keyed: Vec<(IVec3, u32)> = photons
            .iter()
            .enumerate()
            .filter(|(_, p)| !p.is_empty() && p.position().is_finite())
            .map(|(i, p)| (key(p), i as u32))
            .collect();
        keyed.sort_unstable_by_key(|&(k, i)| (k.x, k.y, k.z, i));
        let mut cells = HashMap::new();
        let mut start = 0;
        while start < keyed.len() {
            let k = keyed[start].0;
            let mut end = start;
            while end < keyed.len() && keyed[end].0 == k {
                end += 1;
            }
            cells.insert(k, (start as u32, end as u32));
            start = end;
        }
        Self {
            photons,
            cell,
            order: keyed.into_iter().map(|(_, i)| i).collect(),
            cells,
        }
    }

    /// Photons stored (non-empty slots).
    pub fn len(&self) -> usize {
        self.order.len()
    }

    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    /// The cell size.
    pub fn cell(&self) -> f32 {
        self.cell
    }

    /// Whether photon `q` lies on the surface through `p` with normal `n`
    /// ([`SAME_SURFACE_COS`], [`SAME_SURFACE_SLOPE`]).
    pub fn same_surface(q: &Photon, p: Vec3, n: Vec3) -> bool {
        let d = q.position() - p;
        q.normal().dot(n) >= SAME_SURFACE_COS
            && d.dot(n).abs() <= SAME_SURFACE_SLOPE * d.length() + 1e-6 * self_scale(p)
            && q.direction().dot(n) > 0.0
    }

    /// Visits the photons of the cells within `ring` cells (Chebyshev) of `centre` cell,
    /// only those exactly `ring` away.
    fn ring(&self, centre: IVec3, ring: i32, mut visit: impl FnMut(u32)) {
        for x in -ring..=ring {
            for y in -ring..=ring {
                for z in -ring..=ring {
                    if x.abs().max(y.abs()).max(z.abs()) != ring {
                        continue;
                    }
                    if let Some(&(a, b)) = self.cells.get(&(centre + IVec3::new(x, y, z))) {
                        for &slot in &self.order[a as usize..b as usize] {
                            visit(slot);
                        }
                    }
                }
            }
        }
    }

    /// The `k` nearest photons on the surface through `p` with normal `n`, nearest first
    /// (ties by slot), searching no farther than `max_radius` nor [`MAX_RINGS`] cells (the
    /// cells hold about k photons at the mean density: where 8 cells around hold fewer
    /// than k, the surface is too sparse for a photon record anyway).
    pub fn nearest(&self, p: Vec3, n: Vec3, k: usize, max_radius: f32) -> Vec<Neighbour> {
        let centre = (p / self.cell).floor().as_ivec3();
        let mut found = Vec::new();
        let max_ring = ((max_radius / self.cell).ceil() as i32).clamp(1, MAX_RINGS);
        for ring in 0..=max_ring {
            self.ring(centre, ring, |slot| {
                let q = &self.photons[slot as usize];
                if Self::same_surface(q, p, n) {
                    found.push(Neighbour {
                        slot,
                        distance2: (q.position() - p).length_squared(),
                    });
                }
            });
            // Every photon not yet visited lies more than `ring` cells away.
            let reach = ring as f32 * self.cell;
            if found
                .iter()
                .filter(|f| f.distance2 <= reach * reach)
                .count()
                >= k
            {
                break;
            }
        }
        sort_neighbours(&mut found);
        found.retain(|f| f.distance2 <= max_radius * max_radius);
        found.truncate(k);
        found
    }

    /// The photons on the surface through `p` with normal `n` within `radius`, nearest
    /// first (ties by slot), at most `limit`.
    pub fn within(&self, p: Vec3, n: Vec3, radius: f32, limit: usize) -> Vec<Neighbour> {
        let lo = ((p - Vec3::splat(radius)) / self.cell).floor().as_ivec3();
        let hi = ((p + Vec3::splat(radius)) / self.cell).floor().as_ivec3();
        let span = hi - lo;
        let mut found = Vec::new();
        let r2 = radius * radius;
        let mut visit = |slot: u32| {
            let q = &self.photons[slot as usize];
            let d2 = (q.position() - p).length_squared();
            if d2 <= r2 && Self::same_surface(q, p, n) {
                found.push(Neighbour {
                    slot,
                    distance2: d2,
                });
            }
        };
        if i64::from(span.x + 1) * i64::from(span.y + 1) * i64::from(span.z + 1)
            > self.cells.len() as i64
        {
            // A query wider than the occupied cells: walk the cells instead.
            for (key, &(a, b)) in &self.cells {
                if key.cmplt(lo).any() || key.cmpgt(hi).any() {
                    continue;
                }
                for &slot in &self.order[a as usize..b as usize] {
                    visit(slot);
                }
            }
        } else {
            for x in lo.x..=hi.x {
                for y in lo.y..=hi.y {
                    for z in lo.z..=hi.z {
                        if let Some(&(a, b)) = self.cells.get(&IVec3::new(x, y, z)) {
                            for &slot in &self.order[a as usize..b as usize] {
                                visit(slot);
                            }
                        }
                    }
                }
            }
        }
        sort_neighbours(&mut found);
        found.truncate(limit);
        found
    }
}

/// A tolerance in the scale of `p`'s coordinates (points on the plane itself).
fn self_scale(p: Vec3) -> f32 {
    p.abs().max_element().max(1.0)
}

fn sort_neighbours(found: &mut [Neighbour]) {
    found.sort_unstable_by(|a, b| {
        a.distance2
            .total_cmp(&b.distance2)
            .then(a.slot.cmp(&b.slot))
    });
}
