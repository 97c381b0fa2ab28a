// Radiance cache splatting (thesis section 4.4 with chapter 3's records, algorithms.md
// 2.4-2.6): each glossy pixel sums its tile's radiance records in record order, with
// Ward's weight at the radiance accuracy (the irradiance splat's test and weight). Per
// record: the coefficients moved to the pixel by their translational gradients, the
// record's frame rotated into the pixel's (Z-Y-Z: exact turns about the normals, the
// tabulated tilt matrix M(beta), hsh/rotation.rs), dotted with the lobe's coefficients for
// the pixel's view direction (thesis eq. 2.11). Rather than rotating three channels of
// record coefficients, the pixel's lobe vector c is rotated the other way (transposes),
// one vector instead of three, the same sum: (M lambda).c = lambda.(M^T c).
// Output per pixel: (specular * sum w L_k, sum w); 0 where the material has no slot.
// CPU mirror: splat::radiance::reference_gather.
//!include shared/splat_weight.wgsl
//!include shared/radiance_records.wgsl

@group(1) @binding(0) var<uniform> params: SplatParams;
@group(1) @binding(1) var<uniform> rparams: RadianceParams;
@group(1) @binding(2) var<uniform> camera: Camera;
@group(1) @binding(3) var<storage, read> vis: array<VisSample>;
@group(1) @binding(4) var<storage, read> records: array<Record>;
@group(1) @binding(5) var<storage, read> coefficients: array<f32>;
@group(1) @binding(6) var<storage, read> tile_offsets: array<u32>;
@group(1) @binding(7) var<storage, read> sorted: array<u32>;
@group(1) @binding(8) var<storage, read> lobe_table: array<u32>;
// Per tabulated angle, M^T row by row, each row padded to a multiple of 4 (vec4 loads).
@group(1) @binding(9) var<storage, read> rotations: array<vec4f>;
@group(1) @binding(10) var<storage, read_write> out: array<vec4f>;
@group(1) @binding(11) var<uniform> chunk: GatherChunk;

// One dispatch gathers entries [entry_begin, entry_end) of each tile's list onto the sums
// the one before left (llvmpipe stops an invocation after 65,535 loop iterations in all,
// and a tilted record costs about order^4 / 8 of them: the host sizes the chunks,
// RadianceTables::iterations_per_record).
struct GatherChunk {
    entry_begin: u32,
    entry_end: u32,
    first: u32,   // 1: start from zero
    last: u32,    // 1: apply the specular and finish
}

// The lobe at theta_o (phi_o = 0), the same lobe turned, and the working vector.
var<private> lobe0: array<f32, MAX_COEFFICIENTS>;
var<private> work: array<f32, MAX_COEFFICIENTS>;

// Turns `work` about the normal by `alpha` (hsh::rotate_z: the coefficients of
// f(theta, phi - alpha)): the m = 0 terms stay, each (m, -m) pair turns by m alpha.
fn turn_work(alpha: f32) {
    let n = rparams.order;
    let c1 = cos(alpha);
    let s1 = sin(alpha);
    var cm = 1.0;
    var sm = 0.0;
    for (var m = 1u; m < n; m++) {
        // cos, sin of m alpha by the angle-sum recurrence.
        let c_next = cm * c1 - sm * s1;
        sm = sm * c1 + cm * s1;
        cm = c_next;
        for (var l = m; l < n; l++) {
            let centre = l * (l + 1u);
            let p = work[centre + m];
            let q = work[centre - m];
            work[centre + m] = p * cm - q * sm;
            work[centre - m] = p * sm + q * cm;
        }
    }
}

// work <- M(beta)^T work, M interpolated linearly between its tabulated angles. The tilt
// never mixes cosine-kind (m >= 0) and sine-kind (m < 0) coefficients (hsh::rotation::
// is_sine_kind), so the table holds the two blocks only: `blocks` takes `work` in block
// order (cosine kind, padded to a vec4, then sine kind, padded), each block's rows are
// products with their own block, four terms per iteration, written back to `work`. `work`
// holds a lobe of `bands` bands (zero past them, turns about the normal keep bands), so
// each row's product stops at the vec4 that holds the last of its block's nonzero terms
// (the blocks list l ascending): a broad lobe costs a fraction of the full product.
var<private> blocks: array<f32, BLOCK_FLOATS>;
const BLOCK_FLOATS: u32 = 104u;   // order 10: 55 -> 56 cosine-kind, 45 -> 48 sine-kind

fn tilt_work(beta: f32, bands: u32) {
    let n = rparams.order;
    let cosine = n * (n + 1u) / 2u;
    let sine = n * (n - 1u) / 2u;
    let cosine_quads = (cosine + 3u) / 4u;
    let sine_quads = (sine + 3u) / 4u;
    // The vec4s of each block that hold the lobe's bands.
    let cosine_used = (bands * (bands + 1u) / 2u + 3u) / 4u;
    let sine_used = (bands * (bands - 1u) / 2u + 3u) / 4u;
    let sine_base = 4u * cosine_quads;
    var c = 0u;
    var s = sine_base;
    for (var l = 0u; l < n; l++) {
        let centre = l * (l + 1u);
        blocks[c] = work[centre];
        c++;
        for (var m = 1u; m <= l; m++) {
            blocks[c] = work[centre + m];
            blocks[s] = work[centre - m];
            c++;
            s++;
        }
    }
    for (; c < sine_base; c++) {
        blocks[c] = 0.0;
    }
    for (; s < sine_base + 4u * sine_quads; s++) {
        blocks[s] = 0.0;
    }
    let steps = rparams.beta_steps;
    let t = clamp(beta / rparams.beta_max, 0.0, 1.0) * f32(steps - 1u);
    let i = min(u32(floor(t)), steps - 2u);
    let f = t - f32(i);
    let per_angle = cosine * cosine_quads + sine * sine_quads;
    let a = i * per_angle;
    let b = a + per_angle;
    let sine_rows = cosine * cosine_quads;
    var row_c = 0u;
    var row_s = 0u;
    for (var l = 0u; l < n; l++) {
        let centre = l * (l + 1u);
        for (var m = 0u; m <= l; m++) {
            let r = row_c * cosine_quads;
            var sum = 0.0;
            for (var q = 0u; q < cosine_used; q++) {
                let k = 4u * q;
                let v = vec4f(blocks[k], blocks[k + 1u], blocks[k + 2u], blocks[k + 3u]);
                sum += dot(mix(rotations[a + r + q], rotations[b + r + q], f), v);
            }
            work[centre + m] = sum;
            row_c++;
        }
        for (var m = 1u; m <= l; m++) {
            let r = sine_rows + row_s * sine_quads;
            var sum = 0.0;
            for (var q = 0u; q < sine_used; q++) {
                let k = sine_base + 4u * q;
                let v = vec4f(blocks[k], blocks[k + 1u], blocks[k + 2u], blocks[k + 3u]);
                sum += dot(mix(rotations[a + r + q], rotations[b + r + q], f), v);
            }
            work[centre - m] = sum;
            row_s++;
        }
    }
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    let pixel = id.y * params.width + id.x;
    let v = vis[pixel];
    var sum = vec4f(0.0);
    if chunk.first == 0u {
        sum = out[pixel];
    }
    if v.instance == NO_HIT {
        out[pixel] = sum;
        return;
    }
    let slot = material_lobe_slot(v.material);
    let np = v.shading_normal;
    let wo = -camera_ray_dir(camera, id.xy);
    let cos_o = dot(wo, np);
    if slot == NO_LOBE_SLOT || cos_o <= 0.0 {
        out[pixel] = sum;
        return;
    }
    let p = v.position;
    let tile = (id.y / TILE_SIZE) * params.tiles_x + id.x / TILE_SIZE;
    let list_end = tile_offsets[tile + 1u];
    let begin = min(tile_offsets[tile] + chunk.entry_begin, list_end);
    let end = min(tile_offsets[tile] + chunk.entry_end, list_end);
    if begin >= end {
        // No record of this tile's list in this dispatch.
        if chunk.last != 0u {
            sum = vec4f(material_specular(v.material) * sum.xyz, sum.w);
        }
        out[pixel] = sum;
        return;
    }
    let n2 = rparams.coefficients;
    // The lobe at theta_o, interpolated (splat::radiance::LobeTable::at).
    let steps = rparams.lobe_steps;
    let t = clamp(acos(min(cos_o, 1.0)) / (0.5 * PI) * f32(steps - 1u), 0.0, f32(steps - 1u));
    let i = min(u32(floor(t)), steps - 2u);
    let f = t - f32(i);
    // The slot's table (shared/radiance_records.wgsl): its bands, then the lobe shapes.
    let table = 4u * rparams.materials + slot * (4u + steps * n2);
    let bands = lobe_table[table];
    let lobe_base = table + 4u + i * n2;
    for (var k = 0u; k < n2; k++) {
        lobe0[k] = mix(
            bitcast<f32>(lobe_table[lobe_base + k]),
            bitcast<f32>(lobe_table[lobe_base + n2 + k]),
            f,
        );
    }
    for (var j = begin; j < end; j++) {
        let k = sorted[j];
        let err = contribution_error(k, p, np);
        if err > params.accuracy {
            continue;
        }
        let w = splat_weight(err, params.accuracy, params.plateau);
        let nk = records[k].normal;
        let pk = records[k].position;
        let block = k * rparams.stride;
        let tk = vec3f(coefficients[block], coefficients[block + 1u], coefficients[block + 2u]);
        let bk = vec3f(coefficients[block + 4u], coefficients[block + 5u], coefficients[block + 6u]);
        // Frame A: the record's normal with x_A = u x n_k, y_A = u the tilt axis; B = A
        // turned by beta about u, whose normal is the pixel's (hsh/rotation.rs).
        let axis = cross(nk, np);
        let sin_b = length(axis);
        let cos_b = clamp(dot(nk, np), -1.0, 1.0);
        var u = bk;
        var xa = tk;
        let tilt = sin_b > 1.0e-4;
        if tilt {
            u = axis / sin_b;
            xa = cross(u, nk);
        }
        let xb = xa * cos_b - nk * sin_b;
        // c_B: the lobe turned to the view's azimuth in B.
        for (var q = 0u; q < n2; q++) {
            work[q] = lobe0[q];
        }
        turn_work(atan2(dot(wo, u), dot(wo, xb)));
        if tilt {
            tilt_work(atan2(sin_b, cos_b), bands);
        }
        // c_K = Z(gamma) c_A, gamma the azimuth of x_A in the record's frame.
        turn_work(atan2(dot(xa, bk), dot(xa, tk)));
        // lambda_k + dx grad_x + dy grad_y (the record's tangent axes), dotted with c_K.
        let d = p - pk;
        let dx = dot(d, tk);
        let dy = dot(d, bk);
        var l = vec3f(0.0);
        let values = block + FRAME_FLOATS;
        for (var q = 0u; q < n2; q++) {
            let r = values + q;
            let lambda = vec3f(coefficients[r], coefficients[r + n2], coefficients[r + 2u * n2])
                + dx * vec3f(coefficients[r + 3u * n2], coefficients[r + 4u * n2], coefficients[r + 5u * n2])
                + dy * vec3f(coefficients[r + 6u * n2], coefficients[r + 7u * n2], coefficients[r + 8u * n2]);
            l += work[q] * lambda;
        }
        sum += vec4f(w * max(l, vec3f(0.0)), w);
    }
    if chunk.last != 0u {
        sum = vec4f(material_specular(v.material) * sum.xyz, sum.w);
    }
    out[pixel] = sum;
}
