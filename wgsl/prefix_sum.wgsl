// Exclusive prefix sum of `count` u32 counts into `offsets` (count + 1 entries, the total
// last), in one workgroup: each lane sums a contiguous run, a Hillis-Steele scan over the
// 256 run totals, then each lane writes its run's offsets. Integer sums: exact, in any
// order. Rust: gpu::prefix_sum (splat binning's tiles, the neighbour grid's cells).

struct PrefixSumParams {
    count: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(1) @binding(0) var<uniform> params: PrefixSumParams;
@group(1) @binding(1) var<storage, read> counts: array<u32>;
@group(1) @binding(2) var<storage, read_write> offsets: array<u32>;

var<workgroup> run_totals: array<u32, 256>;

@compute @workgroup_size(256)
fn main(@builtin(local_invocation_index) lane: u32) {
    let n = params.count;
    let run = (n + 255u) / 256u;
    let begin = min(lane * run, n);
    let end = min(begin + run, n);
    var total = 0u;
    for (var t = begin; t < end; t++) {
        total += counts[t];
    }
    run_totals[lane] = total;
    workgroupBarrier();
    for (var stride = 1u; stride < 256u; stride *= 2u) {
        var v = run_totals[lane];
        if lane >= stride {
            v += run_totals[lane - stride];
        }
        workgroupBarrier();
        run_totals[lane] = v;
        workgroupBarrier();
    }
    var offset = run_totals[lane] - total;
    for (var t = begin; t < end; t++) {
        offsets[t] = offset;
        offset += counts[t];
    }
    if lane == 255u {
        offsets[n] = run_totals[255];
    }
}
