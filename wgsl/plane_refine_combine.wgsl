// Adaptive plane refinement, step 3: each refined pixel's sample becomes the weighted mean
// of its centre ray and the `split^2` stratum rays hemisphere_plane.wgsl traced (kept in
// `strata`): radiance `L_c w_c + sum L_i w_i`, depth the same weighted harmonic mean of
// the hit depths (misses add 0 to the sum of 1/Z, as in R), so the reduction
// (record_reduce.wgsl) reads refined pixels. The same sums, in the same order, as
// records::refine::refine_plane. One workgroup per item of the refinement's list, as the
// tracing pass's (the same indirect dispatch), each pixel's first invocation summing its
// strata. A pass of its own so that the tracing pass has no barrier (there, see its head).
//!include shared/plane_refine_items.wgsl

@group(1) @binding(0) var<uniform> params: PlaneParams;
// The plane's P^2 pixels, then each pixel's `subsamples` strata (weight in the refined
// pixel: weights.x).
@group(1) @binding(1) var<storage, read> plane: array<PlanePixel>;
@group(1) @binding(2) var<storage, read_write> samples: array<PlaneSample>;
@group(1) @binding(3) var<storage, read> selected: array<u32>;
// Per stratum ray of the list: radiance and depth (`stratum_offset`).
@group(1) @binding(4) var<storage, read> strata: array<f32>;

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) group: vec3u,
    @builtin(local_invocation_index) lane: u32,
) {
    let r = refine_stratum(group, lane);
    if !r.listed || !r.work || r.q != 0u {
        return;
    }
    let n = params.resolution * params.resolution;
    let base = r.record * n;
    let centre = samples[base + r.k];
    var radiance = centre.radiance * params.centre_weight;
    var inv_depth = select(0.0, params.centre_weight / centre.depth, centre.depth > 0.0);
    for (var t = 0u; t < params.subsamples; t++) {
        let o = stratum_offset(r.item, lane + t);
        let s = vec4f(strata[o], strata[o + 1u], strata[o + 2u], strata[o + 3u]);
        let weight = plane[n + r.k * params.subsamples + t].weights.x;
        radiance += s.xyz * weight;
        if s.w > 0.0 {
            inv_depth += weight / s.w;
        }
    }
    samples[base + r.k] = PlaneSample(radiance, select(-1.0, 1.0 / inv_depth, inv_depth > 0.0));
}
