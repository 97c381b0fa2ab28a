// Which records contribute to a pixel: Ward's error with the "behind" test, shared by the
// splat gather (the weighted sums) and the splat cover (placement's cache-miss test), so
// that a pixel the cover marks is exactly a pixel the gather gives a non-zero weight. The
// including pass declares `records: array<Record>` and a `params: SplatParams` uniform.
//!include shared/records.wgsl
//!include shared/corral.wgsl
//!include shared/splat.wgsl

// 1: the pipeline weighs the records' corrals (SplatSource::corral; never in tail fill's
// gather): a pipeline constant, so that the pipelines of splats without corrals carry none
// of their code.
override CORRAL: bool = false;

// The part of record k the contribution test reads: its position, radius, normal and
// corral, 40 of its 144 bytes (every storage load is a per-lane loop on lavapipe: load only those, and
// once for all the pixels an invocation tests).
fn record_reach(k: u32) -> Record {
    var r: Record;
    r.position = records[k].position;
    r.radius = records[k].radius;
    r.normal = records[k].normal;
    if CORRAL {
        r.rotation_gradient[1].w = records[k].rotation_gradient[1].w;
        r.rotation_gradient[2].w = records[k].rotation_gradient[2].w;
    }
    return r;
}

// Ward's error of record r (its reach, `record_reach`) at (p, n) (eq. 4.2), or NOT_REACHED
// where the record is behind p or its corral keeps it from p: it contributes where this is at most the accuracy a.
const NOT_REACHED: f32 = 1.0e30;
fn reach_error(r: Record, p: vec3f, n: vec3f) -> f32 {
    let err = record_error(r, p, n);
    if err <= params.accuracy && record_in_front(r, p, n, params.accuracy)
        && (!CORRAL || corral_allows(r, p)) {
        return err;
    }
    return NOT_REACHED;
}

// Ward's error of record k at (p, n), as `reach_error`.
fn contribution_error(k: u32, p: vec3f, n: vec3f) -> f32 {
    return reach_error(record_reach(k), p, n);
}

// The weight of a contributing record with error `err` <= a (splat_gather.wgsl; CPU mirror
// splat::reference::splat_weight): 1 / err capped at 1 / plateau (0 but in a gather widened
// for noisy records, records::noise_widening::PLATEAU).
fn splat_weight(err: f32, accuracy: f32, plateau: f32) -> f32 {
    return max(1.0 / max(err, max(plateau, 1.0e-6)) - 1.0 / accuracy, 1.0e-6);
}
