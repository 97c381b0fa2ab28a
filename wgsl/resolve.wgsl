// Resolve: indirect = albedo / pi * sum(w E'_k) / sum(w) (thesis Algorithm 3's
// normalisation, Lambertian reflection) + the glossy lobe's indirect light (glossy
// indirect pass; zero without glossy materials), final = emission + direct + indirect.
//!include shared/ray.wgsl

struct ResolveParams {
    width: u32,
    height: u32,
    // 0: no glossy lobes (`glossy` is a placeholder); 1: add `glossy`, the glossy pass's
    // output; 2: `glossy` is the radiance splat's (sum w L, sum w): add its mean
    has_glossy: u32,
    _pad1: u32,
}

@group(1) @binding(0) var<uniform> params: ResolveParams;
@group(1) @binding(1) var<storage, read> splat: array<vec4f>;
@group(1) @binding(2) var<storage, read> albedo: array<vec4f>;
@group(1) @binding(3) var<storage, read_write> beauty: array<vec4f>;   // in: direct; out: + indirect
@group(1) @binding(4) var<storage, read_write> indirect: array<vec4f>;
@group(1) @binding(5) var<storage, read> glossy: array<vec4f>;

// Four pixels an invocation, 8 apart (a workgroup covers 32 x 8): lavapipe's cost here is
// mostly per invocation, not the few loads.
const PER: u32 = 4u;

@compute @workgroup_size(8, 8)
fn main(@builtin(workgroup_id) group: vec3u, @builtin(local_invocation_id) local: vec3u) {
    let y = group.y * 8u + local.y;
    if y >= params.height {
        return;
    }
    for (var i = 0u; i < PER; i++) {
        let x = group.x * 8u * PER + i * 8u + local.x;
        if x < params.width {
            resolve_pixel(y * params.width + x);
        }
    }
}

fn resolve_pixel(pixel: u32) {
    let s = splat[pixel];
    var l = vec3f(0.0);
    if s.w > 0.0 {
        l = albedo[pixel].xyz * (1.0 / PI) * (s.xyz / s.w);
    }
    if params.has_glossy == 1u {
        l = l + glossy[pixel].xyz;
    } else if params.has_glossy == 2u {
        let g = glossy[pixel];
        if g.w > 0.0 {
            l = l + g.xyz / g.w;
        }
    }
    indirect[pixel] = vec4f(l, 1.0);
    beauty[pixel] = vec4f(beauty[pixel].xyz + l, 1.0);
}
