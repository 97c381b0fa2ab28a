// The processing side of a work list (shared/work_list.wgsl): the including pass
// declares `work: WorkItems` (read) and is dispatched indirectly with the list's size.

struct WorkItems {
    count: u32,
    items: array<u32>,
}

const NO_WORK: u32 = 0xffffffffu;

// The item of this invocation of the processing pass, or NO_WORK past the end.
fn work_item(group: vec3u, groups: vec3u, lane: u32) -> u32 {
    let slot = (group.y * groups.x + group.x) * 64u + lane;
    if slot >= work.count {
        return NO_WORK;
    }
    return work.items[slot];
}
