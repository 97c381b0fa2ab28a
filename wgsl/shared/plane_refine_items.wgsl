// The hemisphere planes' parameters, and the refinement's work list as both of its passes
// read it: hemisphere_plane.wgsl traces the strata of the pixels plane_refine_select.wgsl
// selected, plane_refine_combine.wgsl sums them into the pixels. The including pass
// declares `params: PlaneParams` and `selected: array<u32>` (shared/refine_selection.wgsl).
//!include shared/records.wgsl
//!include shared/refine_selection.wgsl

// Rust: records::PlaneParams.
struct PlaneParams {
    resolution: u32,
    count: u32,
    light_samples: u32,
    record_hits: u32,   // 1: also write each sample's hit (temporal reprojection)
    light_choices: u32, // lights sampled per hit (`shadow_loop_start_chosen`; 0: all)
    record_noise: u32,  // 1: also write each sample's environment-sampled share (`noise`)
    mode: u32,          // MODE_*
    refined: u32,       // K selected pixels per lit plane
    subsamples: u32,    // split^2 strata per pixel
    centre_weight: f32, // 1 / (1 + split^2)
    slots: u32,         // selection slots per record (RefinePass::slots)
    per_group: u32,     // refined pixels per workgroup: 64 / split^2
}

const MODE_TRACE: u32 = 0u;
const MODE_REFINE: u32 = 1u;

// The stratum ray of invocation `lane` of refinement workgroup `group`: the workgroup's
// item (its index in the list) and record, the pixel k and its stratum q, and whether the
// invocation has one (`work`). `listed` is false past the list's end, for the whole
// workgroup. A workgroup holds `per_group` pixels' strata, each pixel's `subsamples`
// invocations side by side: a lit plane's selected pixels (up to K), a dark plane's
// (DARK_PLANE: all of them; DARK_GUIDED: those listed).
struct RefineStratum {
    listed: bool,
    item: u32,
    record: u32,
    k: u32,
    q: u32,
    work: bool,
}

fn refine_stratum(group: vec3u, lane: u32) -> RefineStratum {
    var out = RefineStratum(false, 0u, 0u, 0u, 0u, false);
    let n = params.resolution * params.resolution;
    // The list holds up to ceil(P^2 / per_group) items a record, zeros past its end.
    let i = group.x + group.y * 65535u;
    let capacity = params.count * ((n + params.per_group - 1u) / params.per_group);
    if i >= capacity {
        return out;     // past the list in the last row
    }
    let item = selected[params.count * params.slots + i];
    if item == 0u {
        return out;     // past the last item
    }
    out.listed = true;
    out.item = i;
    out.record = refine_item_record(item);
    let g = refine_item_group(item);
    let row = out.record * params.slots;
    let first_slot = selected[row];
    // Slot j of the selection: a lit plane's K, a guided plane's listed pixels, or
    // every pixel of a plane refined everywhere.
    let j = g * params.per_group + lane / params.subsamples;
    out.q = lane % params.subsamples;
    var count = params.refined;
    if first_slot == DARK_GUIDED {
        count = selected[row + 1u];
    } else if first_slot == DARK_PLANE {
        count = n;
    }
    out.work = lane < params.per_group * params.subsamples && j < count;
    if first_slot == DARK_GUIDED {
        out.k = selected[row + 2u + min(j, n - 1u)];
    } else if first_slot == DARK_PLANE {
        out.k = j;
    } else {
        out.k = selected[row + min(j, params.refined - 1u)];
        if out.k == UNUSED_SLOT {
            // Past a lit plane's last pixel (fewer than K near light).
            out.work = false;
            out.k = 0u;
        }
    }
    return out;
}

// Where stratum ray `lane` of list item `item` keeps its radiance and depth between the
// two passes: four floats each, 64 a workgroup.
fn stratum_offset(item: u32, lane: u32) -> u32 {
    return (item * 64u + lane) * 4u;
}
