// A list of work items one pass finds and the next pass processes densely (an indirect
// dispatch of 64-invocation groups), so that a few items scattered among many threads do
// not cost every SIMD row they touch. The finding pass declares
//   `work: WorkList` (read_write) and `work_groups: array<atomic<u32>, 3>` (the indirect
// dispatch, x y z, starting at 0 1 1); the processing pass declares `work: WorkItems`
// (read) and calls `work_item` (shared/work_items.wgsl). Slots are handed out in thread order, which varies, so
// items must be independent of one another: then the result does not depend on it.

struct WorkList {
    count: atomic<u32>,
    items: array<u32>,
}


// Appends `item`. Slots are contiguous, so the first slot of each group of 64 raises the
// dispatch size (x at most 65535, then y); the maxima do not depend on thread order.
fn push_work(item: u32) {
    let slot = atomicAdd(&work.count, 1u);
    work.items[slot] = item;
    if slot % 64u == 0u {
        let group = slot / 64u;
        atomicMax(&work_groups[0], min(group + 1u, 65535u));
        atomicMax(&work_groups[1], group / 65535u + 1u);
    }
}
