// The widened gather checked against the default one (records::noise_widening,
// `widening_tolerance` times the accuracy a, given here as `tolerance`): a still frame
// whose records are noisy interpolates them wider, which averages their plane noise away
// but also spreads a narrow peak of light (the bright foot of a sunlit wall) over its
// darker neighbours. Per pixel, the widened gather's sums stay where the irradiance they
// give, E_wide = sum w E / sum w, is within `tolerance` of the default gather's,
// |Y_wide - Y_default| <= tolerance Y_default (Y the channel sum); elsewhere the default
// gather's sums replace them. A pixel the default gather does not reach keeps the widened
// one's. So no pixel strays further than the tolerance from the default's irradiance. One
// invocation per pixel; `kept` counts the pixels that keep the widened sums (an exact
// integer whatever the order). CPU mirror: splat::reference::keep_consistent.
//!include shared/linear_dispatch.wgsl
//!include shared/records.wgsl

struct ConsistencyParams {
    pixels: u32,
    tolerance: f32,
    _pad0: u32,
    _pad1: u32,
}

@group(1) @binding(0) var<uniform> params: ConsistencyParams;
@group(1) @binding(1) var<storage, read> narrow: array<vec4f>;
@group(1) @binding(2) var<storage, read_write> wide: array<vec4f>;
@group(1) @binding(3) var<storage, read_write> kept: array<atomic<u32>>;

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let pixel = flat_index(id, groups);
    if pixel >= params.pixels {
        return;
    }
    let n = narrow[pixel];
    let w = wide[pixel];
    if n.w <= 0.0 || w.w <= 0.0 {
        // Nothing to compare: the widened gather's sums (empty, or the only ones).
        return;
    }
    let y_narrow = channel_sum(n.xyz) / n.w;
    let y_wide = channel_sum(w.xyz) / w.w;
    if abs(y_wide - y_narrow) <= params.tolerance * y_narrow {
        atomicAdd(&kept[0], 1u);
    } else {
        wide[pixel] = n;
    }
}
