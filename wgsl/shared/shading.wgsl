// Surface reconstruction from a hit, textured albedo, and direct light with shadow rays.
// Used by the direct-light pass (camera hits) and by later passes that shade secondary hits.
//!include shared/bvh.wgsl
//!include shared/sampling.wgsl
//!include shared/environment.wgsl

// The kinds of light a pipeline shades: bits `1 << kind` (LIGHT_POINT .. LIGHT_SUN) and
// ENVIRONMENT_KIND_BIT of SCENE_FEATURES (shared/scene.wgsl). A pipeline built for one scene
// (the plane passes) leaves out the code of the kinds the scene has not, which lavapipe then
// neither compiles nor carries (Sponza 400x400, a sun alone: plane pass 19 % and refinement
// 23 % faster, the same bytes).
const ENVIRONMENT_KIND_BIT: u32 = 16u;

// Whether this pipeline shades lights of each kind (LIGHT_*), and the environment. Overrides,
// not functions, so that the module handed to the driver has the branches of the kinds left
// out removed (`gpu::shader::specialise`).
override SHADES_POINT: bool = (SCENE_FEATURES & (1u << LIGHT_POINT)) != 0u;
override SHADES_SPOT: bool = (SCENE_FEATURES & (1u << LIGHT_SPOT)) != 0u;
override SHADES_RECT: bool = (SCENE_FEATURES & (1u << LIGHT_RECT)) != 0u;
override SHADES_SUN: bool = (SCENE_FEATURES & (1u << LIGHT_SUN)) != 0u;
override SHADES_ENVIRONMENT: bool = (SCENE_FEATURES & ENVIRONMENT_KIND_BIT) != 0u;

struct Surface {
    position: vec3f,
    geometric_normal: vec3f,   // unit, facing the incoming ray
    shading_normal: vec3f,     // unit, same hemisphere as geometric_normal
    uv: vec2f,
    material: u32,
    front_face: bool,          // the ray hit the side the triangle's winding faces
    mesh_triangle: u32,
}

fn surface_at(hit: Hit, ray_dir: vec3f) -> Surface {
    let tri = traversal_triangle(hit.triangle);
    let sh = shading[hit.triangle];
    // A scene of one instance placed as modelled (no TRAVERSES_INSTANCES: rays never leave
    // its BLAS) takes that instance's transforms from the scene's uniform: the same
    // products, so the same bits, without the 24 storage loads a hit that lavapipe runs
    // lane by lane, stalling on each lane on hosts without AVX-512 (gpu::triangle_fetch).
    // nave-west's plane rays took 0.94 of their time, its CPU seconds 0.92-0.96.
    var world_from_object = scene_info.one_instance_world_from_object;
    var normal_to_world = scene_info.one_instance_normal_to_world;
    if TRAVERSES_INSTANCES {
        let inst = instances[hit.instance];
        world_from_object = inst.world_from_object;
        normal_to_world = inst.normal_to_world;
    }
    let w = 1.0 - hit.u - hit.v;
    let p_obj = tri.v0.xyz + hit.u * tri.e1.xyz + hit.v * tri.e2.xyz;
    var s: Surface;
    s.position = transform_point(world_from_object, p_obj);
    var ng = normalize(transform_vector(normal_to_world, cross(tri.e1.xyz, tri.e2.xyz)));
    // Vertex normals of zero length mark missing or broken data: use the geometric normal.
    let usable = dot(sh.n0, sh.n0) > 0.0 && dot(sh.n1, sh.n1) > 0.0 && dot(sh.n2, sh.n2) > 0.0;
    var ns = ng;
    if usable {
        let n_obj = w * sh.n0 + hit.u * sh.n1 + hit.v * sh.n2;
        if dot(n_obj, n_obj) > 1.0e-12 {
            ns = normalize(transform_vector(normal_to_world, n_obj));
        }
    }
    s.front_face = dot(ng, ray_dir) < 0.0;
    if !s.front_face {
        ng = -ng;
    }
    // Keep the shading normal on the viewer's side of the surface.
    if dot(ns, ng) < 0.0 {
        ns = -ns;
    }
    s.geometric_normal = ng;
    s.shading_normal = ns;
    s.uv = w * sh.uv01.xy + hit.u * sh.uv01.zw + hit.v * sh.uv2.xy;
    s.material = sh.material;
    s.mesh_triangle = sh.mesh_triangle;
    return s;
}

// `s` (from `surface_at(hit, d)`) as `surface_at(hit, ray_dir)` would give it: only the
// side it is seen from changes, so the triangle and instance need not be loaded again.
fn surface_facing(s: Surface, ray_dir: vec3f) -> Surface {
    let ng = select(-s.geometric_normal, s.geometric_normal, s.front_face);
    var out = s;
    out.front_face = dot(ng, ray_dir) < 0.0;
    if out.front_face != s.front_face {
        out.geometric_normal = -s.geometric_normal;
        out.shading_normal = -s.shading_normal;
    }
    return out;
}

fn srgb_to_linear(c: f32) -> f32 {
    return select(pow((c + 0.055) / 1.055, 2.4), c / 12.92, c <= 0.04045);
}

fn texel(info: TextureInfo, x: i32, y: i32) -> vec3f {
    // Repeat wrap.
    let xi = u32(((x % i32(info.width)) + i32(info.width)) % i32(info.width));
    let yi = u32(((y % i32(info.height)) + i32(info.height)) % i32(info.height));
    let c = unpack4x8unorm(texels[info.offset + yi * info.width + xi]);
    return vec3f(srgb_to_linear(c.x), srgb_to_linear(c.y), srgb_to_linear(c.z));
}

// Bilinear lookup in linear colour; v = 1 is the top row of the image.
fn sample_texture(index: u32, uv: vec2f) -> vec3f {
    let info = texture_info(index);
    let x = (uv.x - floor(uv.x)) * f32(info.width) - 0.5;
    let y = (1.0 - (uv.y - floor(uv.y))) * f32(info.height) - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let xi = i32(x0);
    let yi = i32(y0);
    let top = mix(texel(info, xi, yi), texel(info, xi + 1, yi), fx);
    let bottom = mix(texel(info, xi, yi + 1), texel(info, xi + 1, yi + 1), fx);
    return mix(top, bottom, fy);
}

// Bit of SCENE_FEATURES (shared/scene.wgsl; `gpu::SceneFeatures`): some material has an
// albedo texture. Without it the texture lookup (five storage loads and twelve sRGB decodes,
// run by lavapipe for every hit, lanes masked off) is left out of the pipeline.
const FEATURE_TEXTURES: u32 = 64u;

fn surface_albedo(s: Surface) -> vec3f {
    let m = materials[s.material];
    if (SCENE_FEATURES & FEATURE_TEXTURES) == 0u || m.texture == NO_TEXTURE {
        return m.albedo;
    }
    return m.albedo * sample_texture(m.texture, s.uv);
}

// Emitted radiance towards the viewer (emitters are one-sided).
fn surface_emission(s: Surface) -> vec3f {
    return select(vec3f(0.0), materials[s.material].emission, s.front_face);
}

// Emitted radiance seen by an indirect (secondary) ray: emitters that direct lighting
// already samples count as zero there, or they would be counted twice (Ward's rule).
fn indirect_emission(s: Surface) -> vec3f {
    if (materials[s.material].flags & MATERIAL_SAMPLED_LIGHT) != 0u {
        return vec3f(0.0);
    }
    return surface_emission(s);
}

// Shadow ray from the surface to `target_point` (excluded), or towards a direction when
// `to_infinity`.
fn shadow_ray(s: Surface, target_point: vec3f, to_infinity: bool) -> Ray {
    let origin = offset_ray_origin(s.position, s.geometric_normal);
    var ray: Ray;
    ray.origin = origin;
    ray.tmin = 0.0;
    if to_infinity {
        ray.dir = target_point;
        ray.tmax = INF;
    } else {
        ray.dir = target_point - origin;
        ray.tmax = 1.0 - 1.0e-4;
    }
    return ray;
}

// Whether nothing blocks the shadow ray of `shadow_ray(s, target_point, to_infinity)`.
fn visible(s: Surface, target_point: vec3f, to_infinity: bool) -> bool {
    return !occluded(shadow_ray(s, target_point, to_infinity));
}

// Direct irradiance at a surface from every light and the environment (constant, or a map
// sampled by importance), with visibility. Area lights and the environment use `scene_info.light_samples` points of an
// Owen-scrambled Sobol sequence whose scramble is seeded by `seed` (e.g. the pixel).
fn direct_irradiance(s: Surface, seed: u32) -> vec3f {
    return direct_irradiance_samples(s, seed, scene_info.light_samples);
}

// Sample k of a rect light seen from `origin` (`rect_light_sample`'s point).
fn rect_light_point(light: Light, origin: vec3f, k: u32, light_seed: u32) -> vec3f {
    return rect_light_sample(light, origin, sobol_2d(k, light_seed)).point;
}

// A point on a rect light for a receiver, and the solid angle one sample stands for.
struct RectSample {
    point: vec3f,
    // dw of the sample: cos_l A / d^2 drawn by area, Omega drawn by solid angle (so that
    // E = L mean(V cos_s weight)); 0 where the receiver is behind the light.
    weight: f32,
}

// Rect lights drawn by solid angle below this (steradians) are drawn by area: far lights,
// whose 1 / d^2 varies little over them, and where the spherical rectangle's angles
// (summed to about 2 pi in f32) would leave too few digits of Omega.
const RECT_AREA_SAMPLING_BELOW: f32 = 1.0e-2;

// The angle between -a and b (unit vectors), by atan2 (accurate near 0 and pi).
fn corner_angle(a: vec3f, b: vec3f) -> f32 {
    return atan2(length(cross(a, b)), -dot(a, b));
}

// The solid angle of the triangle (a, b, c) seen from the origin (Van Oosterom and
// Strackee 1983).
fn triangle_solid_angle(a: vec3f, b: vec3f, c: vec3f) -> f32 {
    let la = length(a);
    let lb = length(b);
    let lc = length(c);
    let num = abs(dot(a, cross(b, c)));
    let den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
    return 2.0 * atan2(num, den);
}

// Sample `xi` of a rect light (corner a, edges b, c) seen from `origin`. A rectangle is
// drawn uniformly in the solid angle it subtends (Urena, Fajardo and King 2013, "An
// area-preserving parametrization for spherical rectangles"): the sample's weight is then
// Omega, bounded, where drawn by area it is cos_l A / d^2, unbounded for a receiver
// millimetres from the light (a plane hit beside a ceiling panel drew a conference-room
// record 17 times brighter than its neighbours). Parallelograms whose edges are not
// perpendicular, and small solid angles, are drawn by area. Mirrored by
// `direct::reference::rect_light_sample`.
fn rect_light_sample(light: Light, origin: vec3f, xi: vec2f) -> RectSample {
    let b = light.b.xyz;
    let c = light.c.xyz;
    let bl = length(b);
    let cl = length(c);
    let ex = b / bl;
    let ey = c / cl;
    let ez = normalize(cross(ex, ey));
    let rel = light.a.xyz - origin;
    let z0 = dot(rel, ez);
    let area_point = light.a.xyz + xi.x * b + xi.y * c;
    var out = RectSample(area_point, 0.0);
    // The light emits to the side its normal b x c points to: the receiver's z0 < 0.
    if z0 >= 0.0 {
        return out;   // behind the light or in its plane
    }
    let x0 = dot(rel, ex);
    let y0 = dot(rel, ey);
    let x1 = x0 + bl;
    let y1 = y0 + cl;
    var omega = 0.0;
    var n0 = vec3f(0.0);
    var n2 = vec3f(0.0);
    var au0 = 0.0;
    let square = abs(dot(ex, ey)) < 1.0e-4;
    if square {
        // The receiver's frame (ex, ey, ez) puts the rectangle at z = z0 < 0.
        let v00 = vec3f(x0, y0, z0);
        let v01 = vec3f(x0, y1, z0);
        let v10 = vec3f(x1, y0, z0);
        let v11 = vec3f(x1, y1, z0);
        n0 = normalize(cross(v00, v10));
        let n1 = normalize(cross(v10, v11));
        n2 = normalize(cross(v11, v01));
        let n3 = normalize(cross(v01, v00));
        // Angles by atan2 and Omega as two triangles' solid angles (Van Oosterom and
        // Strackee 1983), not as the angles' sum less 2 pi: that difference of numbers
        // near 2 pi kept too few digits with a GPU's acos (lavapipe: 0.2 % off the CPU).
        let g01 = corner_angle(n0, n1) + corner_angle(n1, n2);
        let g23 = corner_angle(n2, n3) + corner_angle(n3, n0);
        omega = triangle_solid_angle(v00, v10, v11) + triangle_solid_angle(v00, v11, v01);
        // The x-marginal's angle runs over [2 pi - g2 - g3, g0 + g1], Omega wide (the
        // paper's eq. 8): its start halfway between both ends' estimates.
        au0 = 0.5 * ((2.0 * PI - g23) + (g01 - omega));
    }
    if !square || !(omega >= RECT_AREA_SAMPLING_BELOW) {
        let to_q = area_point - origin;
        let d2 = dot(to_q, to_q);
        let cos_l = -dot(cross(b, c), to_q) * inverseSqrt(d2);   // cos_l A
        out.weight = max(cos_l, 0.0) / d2;
        return out;
    }
    // Invert the solid angle's x-marginal (the paper's eq. 7-9), then y within the column.
    let b0 = n0.z;
    let b1 = n2.z;
    let au = au0 + xi.x * omega;
    let fu = (cos(au) * b0 - b1) / sin(au);
    var cu = sign(fu) / sqrt(fu * fu + b0 * b0);
    cu = clamp(cu, -0.99999994, 0.99999994);
    let xu = clamp(-(cu * z0) / sqrt(max(1.0 - cu * cu, 0.0)), x0, x1);
    let dd = sqrt(xu * xu + z0 * z0);
    let h0 = y0 / sqrt(dd * dd + y0 * y0);
    let h1 = y1 / sqrt(dd * dd + y1 * y1);
    let hv = h0 + xi.y * (h1 - h0);
    let hv2 = hv * hv;
    let yv = select(y1, hv * dd / sqrt(1.0 - hv2), hv2 < 1.0 - 1.0e-6);
    out.point = origin + xu * ex + yv * ey + z0 * ez;
    out.weight = omega;
    return out;
}

// Scrambles the environment's directions (with the surface's seed).
const ENVIRONMENT_SEED: u32 = 0xe17u;

// The environment's slot after the lights in the shadow-sample loop.
const LIGHT_ENVIRONMENT: u32 = 0xffffffffu;

// One shadow sample: the ray's target (a point, or a direction when `to_infinity`),
// whether it is traced at all (`lit`), and what its contribution needs.
struct ShadowSample {
    target_point: vec3f,
    to_infinity: bool,
    lit: bool,
    cos_s: f32,
    rect_weight: f32,   // a rect light's dw (`RectSample::weight`)
    d2: f32,
    intensity: vec3f,
}

// Direct irradiance as a loop over shadow samples: lights and the environment are slots,
// each with one sample (point, spot, sun) or `count` (rect light, environment). The loop
// is a state machine (`shadow_loop_next` finds the next sample to trace, `shadow_loop_add`
// counts it when visible) so that its callers trace every ray through one call of `trace`:
// each call site is a full copy of the traversal for the shader compiler (lavapipe's LLVM
// JIT took about 0.9 s per copy on a cold start), and a shading pass had five. The sums are
// the same expressions in the same order as one branch per light kind (the golden hashes
// hold). llvmpipe's per-loop iteration limit then counts a pass's rays together, which
// `GpuContext::check_shadow_rays` (all lights and the environment summed, plus the one
// primary ray of `trace_and_shade`) and the reference's per-invocation budget assume.
struct ShadowLoop {
    slots: u32,        // lights, plus the environment when it is not black
    count: u32,        // samples per rect light and for the environment
    slot: u32,         // current slot
    k: u32,            // next sample of the current slot
    first: u32,        // index of sample 0 in the slots' Sobol sequences
    seed: u32,
    env_frame: mat3x3f,
    env_seed: u32,
    sum: vec3f,        // rect light: sum of cos cos / d^2 over its visible samples
    unoccluded: u32,   // environment: visible samples
    e: vec3f,          // the irradiance of the finished samples
    e_env: vec3f,      // the environment's share of `e` (its samples are noisy at a hit)
    light: Light,      // the current slot's light, loaded once per slot (any light for
    kind: u32,         // the environment's slot, unused there) and its kind
    sample: ShadowSample,
    // Lights chosen by weight (`shadow_loop_start_chosen`; 0: every light is sampled): the
    // number of choices m, m / T (T: the weights' sum), the shared offset of their goals,
    // the weight of the slots before the current one, the current slot's factor
    // t T / (m w), and `e` before the current slot.
    choices: u32,
    choice_scale: f32,
    choice_xi: f32,
    choice_cum: f32,
    chosen_weight: f32,
    e_before: vec3f,
    // The weights of the first CHOICE_WEIGHTS lights, kept from the sum (a rect's
    // weight is a clipped polygon's Lambert sum: dearer than a weight of slots).
    choice_weights: array<f32, CHOICE_WEIGHTS>,
}

// Lights whose choice weights a shadow loop keeps (the rest are computed again).
const CHOICE_WEIGHTS: u32 = 8u;

// Scrambles the choice of one light (with the surface's seed).
const LIGHT_CHOICE_SEED: u32 = 0x5e1ec7u;

fn shadow_loop_start(s: Surface, seed: u32, count: u32) -> ShadowLoop {
    return shadow_loop_start_at(s, seed, 0u, count);
}

// The same with the samples taken from index `first` of the sequences on: samples of one
// sequence (one seed) at several surfaces, `count` apart, stratify the light over them
// all (the hemisphere planes' hits, shared/plane.wgsl).
fn shadow_loop_start_at(s: Surface, seed: u32, first: u32, count: u32) -> ShadowLoop {
    var st: ShadowLoop;
    let env = scene_info.environment;
    st.slots = scene_info.light_count
        + select(0u, 1u, SHADES_ENVIRONMENT && (any(env != vec3f(0.0)) || has_environment_map()));
    st.count = count;
    st.slot = 0u;
    st.k = 0u;
    st.first = first;
    st.seed = seed;
    st.env_frame = orthonormal_basis(s.shading_normal);
    st.env_seed = hash_combine(seed, ENVIRONMENT_SEED);
    st.sum = vec3f(0.0);
    st.unoccluded = 0u;
    st.e = vec3f(0.0);
    st.e_env = vec3f(0.0);
    st.choices = 0u;
    st.choice_scale = 0.0;
    st.choice_xi = 0.0;
    st.choice_cum = 0.0;
    st.chosen_weight = 1.0;
    st.e_before = vec3f(0.0);
    shadow_loop_enter(&st);
    return st;
}

// The weight of light `light`'s choice at surface `s` by `shadow_loop_start_chosen`: what
// it gives `s` unoccluded, exactly (up to the sum of the light's colour channels): a
// sun's or point's cosine law, a rect light's radiance times its cosine-weighted solid
// angle above the horizon (`rect_projected_solid_angle`). A chosen light's sample over its
// weight is then its visibility times its own sampling noise, and the total T is the
// unoccluded irradiance. (Weights from a rect's centre fell far below the samples of a
// surface a few millimetres under a panel; an upper bound of one sample, L A min(up /
// d_min, 1) h / d_min^3 capped at pi L, rose far above what such a surface receives and
// multiplied the other lights' samples: conference-room records 20 and 250 times too
// bright.) Zero exactly where the light cannot light `s` (below the shading horizon, a
// rect seen from behind or wholly below the horizon), so that the choice is unbiased.
// Mirrored by `direct::reference::light_choice_weight`.
fn light_choice_weight(s: Surface, light: Light) -> f32 {
    // NaN (a surface at a point light) weighs nothing, infinity a finite large weight.
    let w = light_choice_weight_raw(s, light);
    return select(0.0, min(w, 1.0e30), w > 0.0);
}

fn light_choice_weight_raw(s: Surface, light: Light) -> f32 {
    let kind = bitcast<u32>(light.a.w);
    let n = s.shading_normal;
    let power = light.d.x + light.d.y + light.d.z;
    if SHADES_SUN && kind == LIGHT_SUN {
        return power * max(dot(n, light.a.xyz), 0.0);
    }
    if SHADES_RECT && kind == LIGHT_RECT {
        let a = light.a.xyz - s.position;
        if dot(normalize_rect_normal(light), a) >= 0.0 {
            return 0.0;   // behind the light (or in its plane)
        }
        return power * rect_projected_solid_angle(n, a, light.b.xyz, light.c.xyz);
    }
    // Point and spot lights.
    let to_light = light.a.xyz - s.position;
    let d2 = dot(to_light, to_light);
    var cone = 1.0;
    if kind == LIGHT_SPOT {
        cone = smoothstep(light.c.w, light.b.w, dot(-to_light / sqrt(d2), light.b.xyz));
    }
    return power * cone * max(dot(n, to_light), 0.0) / (d2 * sqrt(d2));
}

// The cosine-weighted solid angle of the parallelogram `a + u b + v c` (u, v in [0, 1];
// relative to the surface) above the plane of normal `n`: E / L of a uniform emitter, by
// Lambert's formula (half the sum over the edges of their angle times n . their unit
// normal) after clipping the polygon to n.x >= 0. Mirrored by
// `direct::reference::rect_projected_solid_angle`.
fn rect_projected_solid_angle(n: vec3f, a: vec3f, b: vec3f, c: vec3f) -> f32 {
    let quad = array<vec3f, 4>(a, a + b, a + b + c, a + c);
    // The clipped polygon's vertices are taken in order and each edge summed as its second
    // vertex arrives, the closing edge last: the same edges in the same order as a list of
    // the vertices, without the list (Mesa, lavapipe, turns a dynamically indexed local
    // array into a tree of branches at every access).
    var count = 0u;
    var first = vec3f(0.0);
    var last = vec3f(0.0);
    var sum = 0.0;
    for (var k = 0u; k < 4u; k++) {
        let p0 = quad[k];
        let p1 = quad[(k + 1u) % 4u];
        let d0 = dot(n, p0);
        let d1 = dot(n, p1);
        if d0 > 0.0 {
            polygon_vertex(&count, &first, &last, &sum, n, p0);
        }
        if (d0 > 0.0) != (d1 > 0.0) {
            polygon_vertex(&count, &first, &last, &sum, n, p0 + (d0 / (d0 - d1)) * (p1 - p0));
        }
    }
    if count < 3u {
        return 0.0;
    }
    add_lambert_edge(&sum, n, last, first);
    return 0.5 * abs(sum);
}

// The next vertex `v` of a polygon (`rect_projected_solid_angle`): `count` vertices so far,
// the `first` and the `last`, and the `sum` of Lambert's terms of the edges between them.
fn polygon_vertex(
    count: ptr<function, u32>,
    first: ptr<function, vec3f>,
    last: ptr<function, vec3f>,
    sum: ptr<function, f32>,
    n: vec3f,
    v: vec3f,
) {
    if *count == 0u {
        *first = v;
    } else {
        add_lambert_edge(sum, n, *last, v);
    }
    *last = v;
    *count += 1u;
}

// Adds to `sum` Lambert's term of the polygon edge from `p` to `q`: its angle seen from the
// origin times n . its unit normal.
fn add_lambert_edge(sum: ptr<function, f32>, n: vec3f, p: vec3f, q: vec3f) {
    let u0 = normalize(p);
    let u1 = normalize(q);
    let cr = cross(u0, u1);
    let len = length(cr);
    if len > 0.0 {
        *sum += atan2(len, dot(u0, u1)) * (dot(n, cr) / len);
    }
}

// The shadow loop of `shadow_loop_start_at` with `m` lights chosen instead of every light
// (`m` 0, or at least the number of lights: every light), by systematic resampling of the
// lights' `light_choice_weight`s: with T their sum and one number xi, the goals
// `(xi + c) T / m`, c = 0..m, fall on the lights, light i taking t_i of them with
// E[t_i] = m w_i / T, so that a light with t_i > 0 is sampled once and its irradiance
// multiplied by t_i T / (m w_i): unbiased, and a light heavier than T / m is never
// missed. The environment's slot is sampled as before. For hemisphere-plane hits: a
// record averages hundreds of them, so m shadow rays a hit instead of one per light cost
// little error where lights are many (the conference room's six panels took six of every
// seven rays a plane traced). xi is dimension 0 of the record's scrambled Sobol sequence
// at `first`, so that the hits of one plane share the lights out in proportion. Mirrored
// by `direct::reference::choose_lights`.
fn shadow_loop_start_chosen(s: Surface, seed: u32, first: u32, count: u32, m: u32) -> ShadowLoop {
    var st = shadow_loop_start_at(s, seed, first, count);
    let n = scene_info.light_count;
    if m == 0u || m >= n {
        return st;
    }
    var total = 0.0;
    for (var i = 0u; i < n; i++) {
        let w = light_choice_weight(s, lights[i]);
        if i < CHOICE_WEIGHTS {
            st.choice_weights[i] = w;
        }
        total += w;
    }
    if total <= 0.0 {
        // None can light s: skip them all.
        st.slot = n;
        shadow_loop_enter(&st);
        return st;
    }
    st.choices = m;
    st.choice_scale = f32(m) / total;
    st.choice_xi = sobol_2d(first, hash_combine(seed, LIGHT_CHOICE_SEED)).x;
    shadow_loop_seek(&st, s);
    return st;
}

// From the current slot on, moves to the first light some goal falls on (or past the
// lights) and enters it, with its factor t T / (m w).
fn shadow_loop_seek(st: ptr<function, ShadowLoop>, s: Surface) {
    let n = scene_info.light_count;
    let scale = (*st).choice_scale;
    loop {
        if (*st).slot >= n {
            break;
        }
        var w: f32;
        if (*st).slot < CHOICE_WEIGHTS {
            w = (*st).choice_weights[(*st).slot];
        } else {
            w = light_choice_weight(s, lights[(*st).slot]);
        }
        let before = ceil((*st).choice_cum * scale - (*st).choice_xi);
        (*st).choice_cum += w;
        let t = ceil((*st).choice_cum * scale - (*st).choice_xi) - before;
        if w > 0.0 && t > 0.0 {
            (*st).chosen_weight = t / (w * scale);
            break;
        }
        (*st).slot += 1u;
    }
    (*st).e_before = (*st).e;
    shadow_loop_enter(st);
}

// Loads the light and kind of the current slot: once per slot, not per sample (a storage
// load is a per-lane loop on lavapipe).
fn shadow_loop_enter(st: ptr<function, ShadowLoop>) {
    if (*st).slot >= (*st).slots {
        return;
    }
    (*st).light = lights[min((*st).slot, max(scene_info.light_count, 1u) - 1u)];
    (*st).kind = select(bitcast<u32>((*st).light.a.w), LIGHT_ENVIRONMENT,
                        (*st).slot == scene_info.light_count);
}

// Sample k of slot `slot` at surface `s` (the tests are written as the negated refusals
// so that NaNs go the same way as in `direct::reference`).
fn shadow_sample(st: ShadowLoop, s: Surface, light: Light, kind: u32) -> ShadowSample {
    let n = s.shading_normal;
    let ng = s.geometric_normal;
    var out = ShadowSample(vec3f(0.0), false, false, 0.0, 0.0, 1.0, vec3f(0.0));
    if (SHADES_POINT || SHADES_SPOT) && (kind == LIGHT_POINT || kind == LIGHT_SPOT) {
        let to_light = light.a.xyz - s.position;
        out.d2 = dot(to_light, to_light);
        let l = to_light * inverseSqrt(out.d2);
        out.cos_s = dot(n, l);
        out.intensity = light.d.xyz;
        if kind == LIGHT_SPOT {
            out.intensity *= smoothstep(light.c.w, light.b.w, dot(-l, light.b.xyz));
        }
        out.target_point = light.a.xyz;
        out.lit = !(out.cos_s <= 0.0 || dot(ng, l) <= 0.0) && !all(out.intensity == vec3f(0.0));
    } else if SHADES_SUN && kind == LIGHT_SUN {
        let l = light.a.xyz;
        out.cos_s = dot(n, l);
        out.target_point = l;
        out.to_infinity = true;
        out.lit = !(out.cos_s <= 0.0 || dot(ng, l) <= 0.0);
    } else if SHADES_RECT && kind == LIGHT_RECT {
        let rs = rect_light_sample(light, s.position,
                                   sobol_2d(st.first + st.k, hash_combine(st.seed, st.slot)));
        let to_q = rs.point - s.position;
        out.d2 = dot(to_q, to_q);
        let l = to_q * inverseSqrt(out.d2);
        out.cos_s = dot(n, l);
        out.rect_weight = rs.weight;
        out.target_point = rs.point;
        out.lit = !(out.cos_s <= 0.0 || rs.weight <= 0.0 || dot(ng, l) <= 0.0);
    } else if SHADES_ENVIRONMENT && kind == LIGHT_ENVIRONMENT && has_environment_map() {
        // Drawn from the map by importance: `intensity` carries L cos / pdf.
        let es = environment_sample(sobol_2d(st.first + st.k, st.env_seed));
        out.target_point = es.dir;
        out.to_infinity = true;
        out.cos_s = dot(n, es.dir);
        out.lit = es.pdf > 0.0 && !(out.cos_s <= 0.0 || dot(ng, es.dir) <= 0.0);
        if out.lit {
            out.intensity = es.radiance * (out.cos_s / es.pdf);
        }
    } else if SHADES_ENVIRONMENT && kind == LIGHT_ENVIRONMENT {
        let dir = st.env_frame * cosine_hemisphere(sobol_2d(st.first + st.k, st.env_seed));
        out.target_point = dir;
        out.to_infinity = true;
        out.lit = dot(dir, ng) > 0.0;
    }
    return out;
}

// A rect light's unit normal (its edges' cross product over its area).
fn normalize_rect_normal(light: Light) -> vec3f {
    let cr = cross(light.b.xyz, light.c.xyz);
    return cr / length(cr);
}

// Moves to the next sample to trace (in `st.sample`), adding each finished slot to `st.e`;
// false when every slot is done.
fn shadow_loop_next(st: ptr<function, ShadowLoop>, s: Surface) -> bool {
    loop {
        if (*st).slot >= (*st).slots {
            return false;
        }
        let light = (*st).light;
        let kind = (*st).kind;
        let samples = select(1u, (*st).count, kind == LIGHT_RECT || kind == LIGHT_ENVIRONMENT);
        if (*st).k >= samples {
            if SHADES_RECT && kind == LIGHT_RECT {
                (*st).e += light.d.xyz * ((*st).sum / f32((*st).count));
            } else if SHADES_ENVIRONMENT && kind == LIGHT_ENVIRONMENT && has_environment_map() {
                // Importance-sampled map: E = mean of V L cos / pdf.
                let add = (*st).sum / f32((*st).count);
                (*st).e += add;
                (*st).e_env += add;
            } else if SHADES_ENVIRONMENT && kind == LIGHT_ENVIRONMENT {
                // Constant environment: E = L_env * integral of V cos = pi L_env * mean
                // visibility over cosine-distributed directions.
                let add = scene_info.environment
                    * (PI * f32((*st).unoccluded) / f32((*st).count));
                (*st).e += add;
                (*st).e_env += add;
            }
            (*st).k = 0u;
            (*st).sum = vec3f(0.0);
            (*st).unoccluded = 0u;
            if (*st).choices != 0u && (*st).slot < scene_info.light_count {
                // A chosen light: weigh what it added, go on to the next chosen one.
                (*st).e = (*st).e_before + ((*st).e - (*st).e_before) * (*st).chosen_weight;
                (*st).slot += 1u;
                shadow_loop_seek(st, s);
                continue;
            }
            (*st).slot += 1u;
            shadow_loop_enter(st);
            continue;
        }
        let candidate = shadow_sample(*st, s, light, kind);
        (*st).k += 1u;
        if candidate.lit {
            (*st).sample = candidate;
            return true;
        }
    }
    return false;
}

// Counts the current sample (`st.sample`, of slot `st.slot`) as visible.
fn shadow_loop_add(st: ptr<function, ShadowLoop>) {
    let light = (*st).light;
    let kind = (*st).kind;
    let smp = (*st).sample;
    if SHADES_RECT && kind == LIGHT_RECT {
        (*st).sum += vec3f(smp.cos_s * smp.rect_weight);
    } else if SHADES_ENVIRONMENT && kind == LIGHT_ENVIRONMENT && has_environment_map() {
        (*st).sum += smp.intensity;
    } else if SHADES_ENVIRONMENT && kind == LIGHT_ENVIRONMENT {
        (*st).unoccluded += 1u;
    } else if SHADES_SUN && kind == LIGHT_SUN {
        (*st).e += light.d.xyz * smp.cos_s;
    } else if SHADES_POINT || SHADES_SPOT {
        (*st).e += smp.intensity * smp.cos_s / smp.d2;
    }
}

// Counts the current sample with visibility `v` in [0, 1] (a light map's filtered
// lookup): its contribution times v. Never the environment's slot (no map covers it).
fn shadow_loop_add_visible(st: ptr<function, ShadowLoop>, v: f32) {
    let light = (*st).light;
    let kind = (*st).kind;
    let smp = (*st).sample;
    if SHADES_RECT && kind == LIGHT_RECT {
        (*st).sum += vec3f(v * smp.cos_s * smp.rect_weight);
    } else if SHADES_SUN && kind == LIGHT_SUN {
        (*st).e += light.d.xyz * (v * smp.cos_s);
    } else if (SHADES_POINT || SHADES_SPOT) && kind != LIGHT_ENVIRONMENT {
        (*st).e += smp.intensity * (v * smp.cos_s / smp.d2);
    }
}

// Same with `count` samples per area light and for the environment (secondary hits use
// fewer than camera pixels: the hemisphere sum averages their noise).
fn direct_irradiance_samples(s: Surface, seed: u32, count: u32) -> vec3f {
    return direct_irradiance_samples_at(s, seed, 0u, count);
}

// The same with the samples from index `first` of their sequences on
// (`shadow_loop_start_at`: a plane sample re-shaded with its plane's light samples).
fn direct_irradiance_samples_at(s: Surface, seed: u32, first: u32, count: u32) -> vec3f {
    return direct_irradiance_loop(s, shadow_loop_start_at(s, seed, first, count));
}

// The same from `m` lights chosen by weight (`shadow_loop_start_chosen`): a plane sample
// re-shaded as its plane shaded it.
fn plane_direct_irradiance(s: Surface, seed: u32, first: u32, count: u32, m: u32) -> vec3f {
    return direct_irradiance_loop(s, shadow_loop_start_chosen(s, seed, first, count, m));
}

// Runs shadow loop `start` to its end, a shadow ray per sample.
fn direct_irradiance_loop(s: Surface, start: ShadowLoop) -> vec3f {
    var st = start;
    while shadow_loop_next(&st, s) {
        if visible(s, st.sample.target_point, st.sample.to_infinity) {
            shadow_loop_add(&st);
        }
    }
    return st.e;
}
