//! Wide BVH nodes for the GPU: a BVH2 collapsed into 4-wide nodes, and the
//! conservative 8-bit quantisation of their child boxes ([`super::gpu_layout::GpuNode`]).

use obvhs::{aabb::Aabb, bvh2::Bvh2};

/// A traversal entry with this bit set names a leaf (see `wgsl/shared/bvh.wgsl`).
pub const LEAF_BIT: u32 = 0x8000_0000;
/// Entry of an unused child slot.
pub const EMPTY: u32 = u32::MAX;

/// A child of a wide node, before encoding.
#[derive(Clone, Copy, Debug)]
pub enum Child {
    /// Index of a wide node, local to its tree.
    Inner(u32),
    /// A leaf: first primitive and count (already absolute).
    Leaf { first: u32, count: u32 },
}

/// A collapsed node: up to `width` children with their bounds, in BVH2 order.
#[derive(Clone, Debug)]
pub struct WideNode {
    pub bounds: Vec<Aabb>,
    pub children: Vec<Child>,
}

/// Which inner child [`collapse`] opens next when filling a wide node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Open {
    /// Largest surface area first: the best traversal order for obvhs's trees, whose
    /// depth it does not bound.
    LargestArea,
    /// Greatest height first (largest area among equals): every inner child of a wide
    /// node is then at least two BVH2 levels lower than the node, so a BVH2 of height
    /// `h` gives at most `ceil(h / 2)` wide levels. Used for the trees of
    /// [`super::bounded`], whose height is bounded.
    Tallest,
}

/// Collapses a BVH2 into `width`-wide nodes (root at 0, pre-order). An inner child is
/// opened (replaced by its two children) in the `open` order, until the node is full.
/// `leaf` maps a BVH2 leaf to its (first, count). The root is always a wide node, even
/// when the BVH2 is a single leaf (or empty: then it has no children).
pub fn collapse(
    bvh: &Bvh2,
    width: usize,
    open: Open,
    leaf: &dyn Fn(u32, u32) -> (u32, u32),
) -> Vec<WideNode> {
    let mut out = Vec::new();
    if bvh.nodes.is_empty() {
        out.push(WideNode {
            bounds: vec![],
            children: vec![],
        });
        return out;
    }
    let heights = match open {
        Open::LargestArea => vec![],
        Open::Tallest => super::bounded::node_heights(bvh),
    };
    collapse_node(bvh, 0, width, &heights, leaf, &mut out);
    out
}

fn collapse_node(
    bvh: &Bvh2,
    node: usize,
    width: usize,
    heights: &[u32],
    leaf: &dyn Fn(u32, u32) -> (u32, u32),
    out: &mut Vec<WideNode>,
) -> u32 {
    let n = &bvh.nodes[node];
    let mut kids: Vec<usize> = if n.prim_count > 0 {
        vec![node]
    } else {
        vec![n.first_index as usize, n.first_index as usize + 1]
    };
    // Without heights (Open::LargestArea) every node counts as height 0, so the order is
    // the area order alone.
    let height = |k: usize| heights.get(k).copied().unwrap_or(0);
    while kids.len() < width {
        let best = kids
            .iter()
            .enumerate()
            .filter(|(_, k)| bvh.nodes[**k].prim_count == 0)
            .max_by(|a, b| {
                let sa = bvh.nodes[*a.1].aabb.half_area();
                let sb = bvh.nodes[*b.1].aabb.half_area();
                height(*a.1)
                    .cmp(&height(*b.1))
                    .then(sa.total_cmp(&sb))
                    .then(b.0.cmp(&a.0))
            })
            .map(|(i, _)| i);
        let Some(i) = best else { break };
        let f = bvh.nodes[kids[i]].first_index as usize;
        kids.splice(i..=i, [f, f + 1]);
    }
    let me = out.len();
    out.push(WideNode {
        bounds: kids.iter().map(|&k| bvh.nodes[k].aabb).collect(),
        children: vec![],
    });
    let mut children = Vec::with_capacity(kids.len());
    for &k in &kids {
        let c = &bvh.nodes[k];
        if c.prim_count > 0 {
            let (first, count) = leaf(c.first_index, c.prim_count);
            children.push(Child::Leaf { first, count });
        } else {
            children.push(Child::Inner(collapse_node(
                bvh, k, width, heights, leaf, out,
            )));
        }
    }
    out[me].children = children;
    me as u32
}

/// Encodes a child as a traversal entry; inner indices are offset by `node_base`.
pub fn entry(c: &Child, node_base: u32) -> u32 {
    match *c {
        Child::Inner(i) => i + node_base,
        Child::Leaf { first, count } => LEAF_BIT | (first << 4) | (count - 1),
    }
}

/// Greatest stack use of a pre-order traversal that pushes all but one hit child of each
/// node: (width - 1) per level on the path.
pub fn stack_need(nodes: &[WideNode]) -> u32 {
    fn rec(nodes: &[WideNode], i: usize) -> u32 {
        let n = &nodes[i];
        let push = n.children.len().saturating_sub(1) as u32;
        let below = n
            .children
            .iter()
            .map(|c| match c {
                Child::Inner(j) => rec(nodes, *j as usize),
                Child::Leaf { .. } => 0,
            })
            .max()
            .unwrap_or(0);
        push + below
    }
    if nodes.is_empty() { 0 } else { rec(nodes, 0) }
}

/// Dequantised plane: `origin + q * scale`, exactly as the shader computes it (the
/// product is exact, so an fma gives the same result).
pub fn plane(origin: f32, q: u32, scale: f32) -> f32 {
    origin + q as f32 * scale
}

/// Per-axis quantisation frame of a node: origin (the node's min) and a power-of-two scale
/// (biased exponent) such that 255 steps cover the node.
pub fn frame(lo: f32, hi: f32) -> (f32, u32) {
    // Start just below the estimate 2^floor(log2(extent / 255)), then step up.
    let estimate = ((hi - lo) / 255.0).to_bits() >> 23;
    let start = estimate.saturating_sub(1).clamp(1, 254);
    for eb in start..255 {
        if plane(lo, 255, f32::from_bits(eb << 23)) >= hi {
            return (lo, eb);
        }
    }
    // Only reached for non-finite bounds (see `quantise`).
    (lo, 254)
}

/// Conservative quantised bounds of [lo, hi] in the frame (origin, scale).
pub fn quantise(lo: f32, hi: f32, origin: f32, scale: f32) -> (u32, u32) {
    if !(lo.is_finite() && hi.is_finite() && origin.is_finite()) {
        return (0, 255);
    }
    let mut qlo = (((lo - origin) / scale).floor().clamp(0.0, 255.0)) as u32;
    while qlo > 0 && plane(origin, qlo, scale) > lo {
        qlo -= 1;
    }
    while qlo < 255 && plane(origin, qlo + 1, scale) <= lo {
        qlo += 1;
    }
    let mut qhi = (((hi - origin) / scale).ceil().clamp(0.0, 255.0)) as u32;
    while qhi < 255 && plane(origin, qhi, scale) < hi {
        qhi += 1;
    }
    while qhi > 0 && plane(origin, qhi - 1, scale) >= hi {
        qhi -= 1;
    }
    debug_assert!(plane(origin, qlo, scale) <= lo && plane(origin, qhi, scale) >= hi);
    (qlo, qhi)
}

#[cfg(test)]
mod tests {
    use super::super::gpu_layout::GpuNode;
    use super::*;
    use glam::Vec3A;

    /// Every dequantised child box contains the exact box, and the entries survive.
    #[test]
    fn quantised_boxes_are_conservative() {
        let mut state = 12345u32;
        let mut rnd = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32
        };
        for scale in [1e-3f32, 1.0, 37.5, 1e5] {
            for _ in 0..200 {
                let base = Vec3A::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * scale * 10.0;
                let bounds: Vec<Aabb> = (0..4)
                    .map(|_| {
                        let a = base + Vec3A::new(rnd(), rnd(), rnd()) * scale;
                        let b = a + Vec3A::new(rnd(), rnd(), rnd()) * scale * rnd();
                        Aabb { min: a, max: b }
                    })
                    .collect();
                let node = WideNode {
                    bounds: bounds.clone(),
                    children: (0..4).map(|i| Child::Inner(i * 7)).collect(),
                };
                let gpu = GpuNode::new(&node, 100);
                for (s, b) in bounds.iter().enumerate() {
                    let (lo, hi) = gpu.child_bounds(s);
                    assert!(lo.cmple(b.min.into()).all() && hi.cmpge(b.max.into()).all());
                    assert_eq!(gpu.words[12 + s], 100 + s as u32 * 7);
                }
            }
        }
    }

    /// A BVH2 leaf root still gets a wide root node; empty slots are marked.
    #[test]
    fn single_leaf_collapses_to_one_node() {
        let aabbs = [Aabb {
            min: Vec3A::ZERO,
            max: Vec3A::ONE,
        }];
        let mut core = std::time::Duration::ZERO;
        let bvh = obvhs::bvh2::builder::build_bvh2(&aabbs, super::super::tlas_params(), &mut core);
        let nodes = collapse(&bvh, 4, Open::LargestArea, &|f, c| (f, c));
        assert_eq!(nodes.len(), 1);
        assert_eq!(nodes[0].children.len(), 1);
        let gpu = GpuNode::new(&nodes[0], 0);
        assert_eq!(gpu.words[12], LEAF_BIT);
        assert_eq!(&gpu.words[13..16], &[EMPTY; 3]);
    }
}
