//! Our own BVH2 builder: binned SAH whose tree height is bounded by construction, for the
//! inputs obvhs's PLOC handles badly (fans, coincident or nested primitives; see
//! [`degenerate`]) and for every tree of obvhs's that would not fit the traversal stack.
//!
//! **Height bound.** A node may have height at most `b` (edges down to its deepest leaf)
//! only if it holds at most `max_leaf * 2^b` primitives; the root gets `b = height_bound`.
//! A split is accepted only if both children satisfy the bound for `b - 1`; when no binned
//! SAH split does (or the centroids cannot be separated at all), the node is split at the
//! object median, ordered by (centroid on the widest axis, primitive index). The median
//! always satisfies the bound, since `ceil(m / 2) <= max_leaf * 2^(b-1)` whenever
//! `m <= max_leaf * 2^b`, so no input (100 copies of one face, coincident instances, fans)
//! can make the tree deeper than `height_bound`.
//!
//! **Build time.** Each level of the tree touches each primitive a constant number of
//! times (bounds, binning, one partition or one selection), and there are at most
//! `height_bound = O(log n)` levels: O(n log n) for any input.
//!
//! **Stack need.** [`super::wide::collapse`] with [`super::wide::Open::Tallest`] turns a
//! BVH2 of height `h` into a wide tree of at most `ceil(h / 2)` levels, so the traversal
//! stack need is at most `3 * ceil(h / 2)` (see [`stack_bound`]).

use glam::Vec3A;
use obvhs::{
    aabb::Aabb,
    bvh2::{Bvh2, DEFAULT_MAX_STACK_DEPTH, node::Bvh2Node},
};

/// Height slack above the minimum `ceil(log2(ceil(n / max_leaf)))` that binned SAH may use
/// for unbalanced splits before the bound forces balanced ones (capped by the caller's
/// stack budget, see [`height_bound`]).
pub const MAX_SLACK: u32 = 8;

/// SAH bins per axis.
const BINS: usize = 16;

/// SAH cost of traversing a node, relative to intersecting one primitive: the one obvhs's
/// leaf collapse is given ([`super::COLLAPSE_TRAVERSAL_COST`]), so that our leaves are
/// sized like its.
const TRAVERSAL_COST: f32 = super::COLLAPSE_TRAVERSAL_COST;

/// `ceil(log2(x))` for `x >= 1`.
pub fn ceil_log2(x: usize) -> u32 {
    if x <= 1 {
        0
    } else {
        usize::BITS - (x - 1).leading_zeros()
    }
}

/// The smallest height any BVH2 over `n` primitives with leaves of at most `max_leaf`
/// can have.
pub fn min_height(n: usize, max_leaf: u32) -> u32 {
    ceil_log2(n.div_ceil(max_leaf.max(1) as usize).max(1))
}

/// The height bound the builder uses for `n` primitives when the wide tree's stack need
/// must stay within `stack_budget` entries: as much slack as the budget allows (at most
/// [`MAX_SLACK`]), never below [`min_height`] (then the budget cannot be met by any tree
/// and the bound is the balanced tree's).
pub fn height_bound(n: usize, max_leaf: u32, stack_budget: u32) -> u32 {
    let min = min_height(n, max_leaf);
    // 3 * ceil(h / 2) <= budget  <=>  h <= 2 * floor(budget / 3).
    let fits = 2 * (stack_budget / 3);
    (min + MAX_SLACK).min(fits).max(min)
}

/// Greatest traversal stack need of the 4-wide collapse ([`super::wide::Open::Tallest`])
/// of a BVH2 of height `h`: each wide level pushes at most 3 entries, and each wide level
/// descends at least two BVH2 levels.
pub fn stack_bound(h: u32) -> u32 {
    3 * h.div_ceil(2)
}

/// Which property of the input makes obvhs's PLOC slow or deep on it, if any (see
/// [`degenerate`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Degenerate {
    /// This many triangles share one vertex position (a fan: disc caps, sphere poles).
    Fan(u32),
    /// This many primitives have bit-identical boxes (copies of one face or instance).
    Coincident(u32),
    /// The primitives' boxes sum to this many times the root box's area: many boxes
    /// overlap the same region (nested or crossing primitives).
    Overlap(u32),
}

/// A fan with more triangles than this around one vertex goes to our builder.
pub const FAN_LIMIT: u32 = 64;
/// More bit-identical boxes than this go to our builder.
pub const COINCIDENT_LIMIT: u32 = 16;
/// A summed box area above this many root boxes goes to our builder.
pub const OVERLAP_LIMIT: f32 = 32.0;

/// Cheap O(n) test (hashing and one sum) for inputs on which PLOC degenerates. PLOC merges
/// two clusters only when each is the other's best neighbour in Morton order; when boxes
/// nest or coincide (every triangle of a fan contains the centre vertex), the best
/// neighbour of each cluster is the next smaller one, so each pass merges only a few pairs
/// and the passes, O(n) each, number O(n): quadratic time and a chain-like tree.
///
/// `corners`: each triangle's three vertex positions, for the fan test (none for
/// instances).
pub fn degenerate(boxes: &[Aabb], corners: Option<&[[Vec3A; 3]]>) -> Option<Degenerate> {
    // Only counts are read from the maps, so any hash gives the same answer; SipHash was
    // a tenth of loading the conference room (700k corners, 233k boxes).
    type HashMap<K, V> = std::collections::HashMap<K, V, std::hash::BuildHasherDefault<WordHasher>>;
    if boxes.len() <= COINCIDENT_LIMIT as usize {
        return None;
    }
    let key = |p: Vec3A| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    if let Some(corners) = corners {
        let mut valence: HashMap<[u32; 3], u32> =
            HashMap::with_capacity_and_hasher(corners.len(), Default::default());
        let mut worst = 0;
        for tri in corners {
            for &p in tri {
                let v = valence.entry(key(p)).or_insert(0);
                *v += 1;
                worst = worst.max(*v);
            }
        }
        if worst > FAN_LIMIT {
            return Some(Degenerate::Fan(worst));
        }
    }
    let mut same: HashMap<([u32; 3], [u32; 3]), u32> =
        HashMap::with_capacity_and_hasher(boxes.len(), Default::default());
    let mut worst = 0;
    let mut root = Aabb::empty();
    let mut area = 0.0f64;
    for b in boxes {
        let v = same.entry((key(b.min), key(b.max))).or_insert(0);
        *v += 1;
        worst = worst.max(*v);
        root = root.union(b);
        area += f64::from(b.half_area());
    }
    if worst > COINCIDENT_LIMIT {
        return Some(Degenerate::Coincident(worst));
    }
    let root_area = f64::from(root.half_area());
    if root_area > 0.0 && area > f64::from(OVERLAP_LIMIT) * root_area {
        return Some(Degenerate::Overlap((area / root_area) as u32));
    }
    None
}

/// A multiply-rotate hash of 32-bit words (FxHash's), for maps keyed by float bits.
#[derive(Default)]
struct WordHasher(u64);

impl std::hash::Hasher for WordHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(4) {
            let mut word = [0u8; 4];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u32(u32::from_le_bytes(word));
        }
    }

    fn write_u32(&mut self, word: u32) {
        self.0 = (self.0.rotate_left(5) ^ u64::from(word)).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
}

/// One node still to be built: its slot, its primitive range in `refs`, its height bound.
struct Task {
    node: usize,
    lo: usize,
    hi: usize,
    height: u32,
}

/// Builds a BVH2 over `boxes` (leaves of at most `max_leaf`, which must be >= 1) whose
/// height is at most `height` if `boxes.len() <= max_leaf * 2^height` (else at most
/// [`min_height`]). Children of a node are adjacent and come after it, as in obvhs, so the
/// result works with obvhs's traversal and refit.
pub fn build(boxes: &[Aabb], max_leaf: u32, height: u32) -> Bvh2 {
    let n = boxes.len();
    if n == 0 {
        return Bvh2::default();
    }
    let max_leaf = max_leaf.max(1) as usize;
    let height = height.max(min_height(n, max_leaf as u32));
    let centroids: Vec<Vec3A> = boxes.iter().map(|b| b.center()).collect();
    let mut refs: Vec<u32> = (0..n as u32).collect();
    let mut nodes = Vec::with_capacity(2 * n.div_ceil(max_leaf));
    nodes.push(Bvh2Node::default());
    let mut tasks = vec![Task {
        node: 0,
        lo: 0,
        hi: n,
        height,
    }];
    let mut deepest = 0u32;
    let mut depth_of = vec![0u32];
    while let Some(task) = tasks.pop() {
        let Task {
            node,
            lo,
            hi,
            height,
        } = task;
        let m = hi - lo;
        let mut bounds = Aabb::empty();
        let mut cbounds = Aabb::empty();
        for &r in &refs[lo..hi] {
            bounds = bounds.union(&boxes[r as usize]);
            cbounds.extend(centroids[r as usize]);
        }
        // Children must fit the bound one level down.
        let cap = if height == 0 {
            0
        } else {
            max_leaf.saturating_mul(1usize.checked_shl(height - 1).unwrap_or(usize::MAX))
        };
        let split = if m > 1 && height > 0 {
            sah_split(&refs[lo..hi], boxes, &centroids, &cbounds, cap)
        } else {
            None
        };
        let leaf_cost = m as f32 * bounds.half_area();
        let make_leaf = m <= max_leaf
            && split.is_none_or(|s| leaf_cost <= TRAVERSAL_COST * bounds.half_area() + s.cost);
        if make_leaf || height == 0 {
            nodes[node] = Bvh2Node::new(bounds, m as u32, lo as u32);
            deepest = deepest.max(depth_of[node]);
            continue;
        }
        let mid = match split {
            Some(s) => {
                let (axis, k) = (s.axis, bin_scale(&cbounds, s.axis));
                let origin = cbounds.min[axis];
                let mut i = lo;
                for j in lo..hi {
                    if bin(centroids[refs[j] as usize][axis], origin, k) < s.bin {
                        refs.swap(i, j);
                        i += 1;
                    }
                }
                i
            }
            None => median_split(&mut refs[lo..hi], &centroids, &cbounds) + lo,
        };
        debug_assert!(lo < mid && mid < hi && mid - lo <= cap.max(1) && hi - mid <= cap.max(1));
        let first = nodes.len();
        nodes.push(Bvh2Node::default());
        nodes.push(Bvh2Node::default());
        let d = depth_of[node] + 1;
        depth_of.extend([d, d]);
        nodes[node] = Bvh2Node::new(bounds, 0, first as u32);
        // Right first so that the left subtree is built (and laid out) first.
        tasks.push(Task {
            node: first + 1,
            lo: mid,
            hi,
            height: height - 1,
        });
        tasks.push(Task {
            node: first,
            lo,
            hi: mid,
            height: height - 1,
        });
    }
    Bvh2 {
        nodes,
        primitive_indices: refs,
        children_are_ordered_after_parents: true,
        // obvhs sizes its CPU traversal stack from this (one entry per level is enough).
        max_depth: DEFAULT_MAX_STACK_DEPTH.max(deepest as usize + 2),
        ..Bvh2::default()
    }
}

#[derive(Clone, Copy)]
struct Split {
    axis: usize,
    /// Primitives in bins below this go left.
    bin: usize,
    /// Summed (count * half area) of the two children.
    cost: f32,
}

/// Bins per unit of centroid extent on `axis` (0 when the centroids do not spread on it).
fn bin_scale(cbounds: &Aabb, axis: usize) -> f32 {
    let extent = cbounds.max[axis] - cbounds.min[axis];
    if extent > 0.0 && extent.is_finite() {
        BINS as f32 * (1.0 - 1e-6) / extent
    } else {
        0.0
    }
}

fn bin(c: f32, origin: f32, k: f32) -> usize {
    (((c - origin) * k) as usize).min(BINS - 1)
}

/// The cheapest binned SAH split whose children each hold at most `cap` primitives.
fn sah_split(
    refs: &[u32],
    boxes: &[Aabb],
    centroids: &[Vec3A],
    cbounds: &Aabb,
    cap: usize,
) -> Option<Split> {
    let m = refs.len();
    let mut best: Option<Split> = None;
    for axis in [0usize, 1, 2] {
        let k = bin_scale(cbounds, axis);
        if k == 0.0 {
            continue;
        }
        let origin = cbounds.min[axis];
        let mut counts = [0usize; BINS];
        let mut bbox = [Aabb::empty(); BINS];
        for &r in refs {
            let b = bin(centroids[r as usize][axis], origin, k);
            counts[b] += 1;
            bbox[b] = bbox[b].union(&boxes[r as usize]);
        }
        // Right sweep: cost of bins i.. for each i.
        let mut right_cost = [0.0f32; BINS];
        let mut acc = Aabb::empty();
        let mut count = 0;
        for i in (1..BINS).rev() {
            acc = acc.union(&bbox[i]);
            count += counts[i];
            right_cost[i] = if count > 0 {
                count as f32 * acc.half_area()
            } else {
                0.0
            };
        }
        let mut acc = Aabb::empty();
        let mut left = 0;
        for i in 1..BINS {
            acc = acc.union(&bbox[i - 1]);
            left += counts[i - 1];
            let right = m - left;
            if left == 0 || right == 0 || left > cap || right > cap {
                continue;
            }
            let cost = left as f32 * acc.half_area() + right_cost[i];
            if best.is_none_or(|b| cost < b.cost) {
                best = Some(Split { axis, bin: i, cost });
            }
        }
    }
    best
}

/// Splits `refs` in two halves by (centroid on the widest centroid axis, primitive index):
/// a total order, so identical centroids are split by index. Returns the left size.
fn median_split(refs: &mut [u32], centroids: &[Vec3A], cbounds: &Aabb) -> usize {
    let extent = cbounds.max - cbounds.min;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let mid = refs.len() / 2;
    refs.select_nth_unstable_by(mid, |&a, &b| {
        centroids[a as usize][axis]
            .total_cmp(&centroids[b as usize][axis])
            .then(a.cmp(&b))
    });
    mid
}

/// Height of every node of a BVH2 (edges down to its deepest leaf), without recursion.
pub fn node_heights(bvh: &Bvh2) -> Vec<u32> {
    let mut heights = vec![0u32; bvh.nodes.len()];
    if bvh.nodes.is_empty() {
        return heights;
    }
    // Pre-order, then children before parents in reverse.
    let mut order = Vec::with_capacity(bvh.nodes.len());
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        order.push(i);
        let n = &bvh.nodes[i];
        if !n.is_leaf() {
            stack.push(n.first_index as usize);
            stack.push(n.first_index as usize + 1);
        }
    }
    for &i in order.iter().rev() {
        let n = &bvh.nodes[i];
        if !n.is_leaf() {
            let f = n.first_index as usize;
            heights[i] = 1 + heights[f].max(heights[f + 1]);
        }
    }
    heights
}

#[cfg(test)]
mod tests {
    use super::super::wide::{self, Open};
    use super::*;
    use glam::vec3a;
    use obvhs::{
        ray::{Ray, RayHit},
        triangle::Triangle,
    };

    /// A fan of `n` triangles around the origin in the z = 0 plane.
    fn fan(n: usize) -> Vec<Triangle> {
        let p = |i: usize| {
            let a = std::f32::consts::TAU * i as f32 / n as f32;
            vec3a(a.cos(), a.sin(), 0.0)
        };
        (0..n)
            .map(|i| Triangle {
                v0: Vec3A::ZERO,
                v1: p(i),
                v2: p(i + 1),
            })
            .collect()
    }

    fn boxes(tris: &[Triangle]) -> Vec<Aabb> {
        tris.iter().map(|t| t.aabb()).collect()
    }

    /// Every primitive exactly once, leaves within `max_leaf`, every node bounding its
    /// children (or its primitives), height within `bound`.
    fn check_tree(bvh: &Bvh2, boxes: &[Aabb], max_leaf: u32, bound: u32) {
        let mut seen = vec![0u32; boxes.len()];
        let mut stack = vec![0usize];
        let contains = |outer: &Aabb, inner: &Aabb| {
            outer.min.cmple(inner.min).all() && outer.max.cmpge(inner.max).all()
        };
        let mut reached = 0;
        while let Some(i) = stack.pop() {
            reached += 1;
            let n = &bvh.nodes[i];
            if n.is_leaf() {
                assert!(n.prim_count <= max_leaf, "leaf of {}", n.prim_count);
                let first = n.first_index as usize;
                for &p in &bvh.primitive_indices[first..first + n.prim_count as usize] {
                    seen[p as usize] += 1;
                    assert!(contains(&n.aabb, &boxes[p as usize]));
                }
            } else {
                let f = n.first_index as usize;
                assert!(f > i, "children after their parent");
                for c in [f, f + 1] {
                    assert!(contains(&n.aabb, &bvh.nodes[c].aabb));
                    stack.push(c);
                }
            }
        }
        assert_eq!(reached, bvh.nodes.len(), "every node reachable");
        assert!(seen.iter().all(|&s| s == 1), "every primitive exactly once");
        let h = node_heights(bvh)[0];
        assert!(h <= bound, "height {h} above the bound {bound}");
    }

    #[test]
    fn degenerate_inputs_build_within_the_height_bound() {
        let face = Triangle {
            v0: vec3a(0.0, 0.0, 0.0),
            v1: vec3a(1.0, 0.0, 0.0),
            v2: vec3a(0.0, 1.0, 0.0),
        };
        let copies = vec![face; 100];
        let unit = Aabb {
            min: Vec3A::ZERO,
            max: Vec3A::ONE,
        };
        let cases: Vec<(&str, Vec<Aabb>, u32)> = vec![
            ("fan of 256", boxes(&fan(256)), 8),
            ("fan of 100000", boxes(&fan(100_000)), 8),
            ("100 copies of one face", boxes(&copies), 8),
            ("70 coincident boxes, one per leaf", vec![unit; 70], 1),
            ("one box", vec![unit], 1),
        ];
        for (name, b, leaf) in cases {
            for budget in [45, 48, 12] {
                let h = height_bound(b.len(), leaf, budget);
                let bvh = build(&b, leaf, h);
                eprintln!("{name}: height bound {h}, budget {budget}");
                check_tree(&bvh, &b, leaf, h);
                let nodes = wide::collapse(&bvh, 4, Open::Tallest, &|f, c| (f, c));
                let need = wide::stack_need(&nodes);
                assert!(
                    need <= stack_bound(h),
                    "{name}: need {need} > {}",
                    stack_bound(h)
                );
                if min_height(b.len(), leaf) <= 2 * (budget / 3) {
                    assert!(need <= budget, "{name}: need {need} above budget {budget}");
                }
            }
        }
    }

    /// The height bound leaves room for the largest inputs the GPU encoding accepts
    /// (2^27 triangles in leaves of 8, 2^27 instances one per leaf).
    #[test]
    fn bounds_fit_the_budgets_at_the_encoding_limits() {
        let n = (1usize << 27) - 1;
        assert!(stack_bound(height_bound(n, 8, super::super::BLAS_STACK_BUDGET)) <= 45);
        assert!(stack_bound(height_bound(n, 1, super::super::TLAS_STACK_BUDGET)) <= 48);
        assert_eq!(ceil_log2(1), 0);
        assert_eq!(ceil_log2(2), 1);
        assert_eq!(ceil_log2(3), 2);
        assert_eq!(ceil_log2(1 << 20), 20);
        assert_eq!(min_height(9, 8), 1);
        assert_eq!(min_height(8, 8), 0);
    }

    /// obvhs's CPU traversal of our tree finds the same closest hits as brute force.
    #[test]
    fn traversal_matches_brute_force_on_degenerate_meshes() {
        let mut tris = fan(3000);
        // Plus 50 copies of one face above the fan, and a second fan tilted through it.
        let face = Triangle {
            v0: vec3a(-0.3, -0.2, 0.3),
            v1: vec3a(0.4, -0.1, 0.3),
            v2: vec3a(0.0, 0.5, 0.3),
        };
        tris.extend(std::iter::repeat_n(face, 50));
        tris.extend(fan(500).into_iter().map(|t| Triangle {
            v0: vec3a(t.v0.x, t.v0.z + 0.1, t.v0.y),
            v1: vec3a(t.v1.x, t.v1.z + 0.1, t.v1.y),
            v2: vec3a(t.v2.x, t.v2.z + 0.1, t.v2.y),
        }));
        let b = boxes(&tris);
        let h = height_bound(b.len(), 8, 45);
        let bvh = build(&b, 8, h);
        check_tree(&bvh, &b, 8, h);
        let mut state = 7u32;
        let mut rnd = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        let mut hits = 0;
        for _ in 0..2000 {
            let origin = vec3a(rnd() * 3.0, rnd() * 3.0, 2.0 + rnd());
            let target = vec3a(rnd() * 2.0, rnd() * 2.0, rnd() * 0.5);
            let ray = Ray::new(origin, (target - origin).normalize(), 0.0, f32::INFINITY);
            let brute = tris
                .iter()
                .enumerate()
                .map(|(i, t)| (t.intersect(&ray), i))
                .filter(|(t, _)| t.is_finite())
                .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let mut hit = RayHit::none();
            let found = bvh.ray_traverse(ray, &mut hit, |r, id| {
                tris[bvh.primitive_indices[id] as usize].intersect(r)
            });
            match brute {
                None => assert!(!found),
                Some((t, _)) => {
                    hits += 1;
                    assert!(found);
                    // Same distance (copies of one face tie: any of them is right).
                    assert_eq!(hit.t, t);
                }
            }
        }
        assert!(hits > 500, "the rays hit the meshes ({hits} of 2000)");
    }
}
