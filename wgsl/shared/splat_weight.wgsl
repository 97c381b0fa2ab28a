// Which records contribute to a pixel: Ward's error with the "behind" test, shared by the
// splat gather (the weighted sums) and the splat cover (placement's cache-miss test), so
// that a pixel the cover marks is exactly a pixel the gather gives a non-zero weight. The
// including pass declares `records: array<Record>` and a `params: SplatParams` uniform.
//!include shared/records.wgsl
//!include shared/splat.wgsl

// Ward's error of record k at (p, n) (eq. 4.2), or infinity where the record is behind p:
// it contributes where this is at most the accuracy a. The test needs 32 of the record's
// 144 bytes: load only those (every storage load is a per-lane loop on lavapipe).
fn contribution_error(k: u32, p: vec3f, n: vec3f) -> f32 {
    var r: Record;
    r.position = records[k].position;
    r.radius = records[k].radius;
    r.normal = records[k].normal;
    let err = record_error(r, p, n);
    if err <= params.accuracy && record_in_front(r, p, n, params.accuracy) {
        return err;
    }
    return 1.0e30;
}

// The weight of a contributing record with error `err` <= a (splat_gather.wgsl; CPU mirror
// splat::reference::splat_weight).
fn splat_weight(err: f32, accuracy: f32) -> f32 {
    return max(1.0 / max(err, 1.0e-6) - 1.0 / accuracy, 1.0e-6);
}
