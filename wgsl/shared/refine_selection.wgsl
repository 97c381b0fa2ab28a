// A plane refinement's selection and work list as plane_refine_select.wgsl writes them and
// the refinement's passes read them (shared/plane_refine_items.wgsl). Per record, `slots`
// entries: a lit plane's selected pixels, or a flag in the first slot; after every
// record's slots, the list of workgroups to refine. Rust: records::refine.

// Every slot of a dark plane's selection (records::refine::DARK_PLANE).
const DARK_PLANE: u32 = 0xffffffffu;
// The first slot of a selection that refines nothing (records::refine::NO_PIXELS).
const NO_PIXELS: u32 = 0xfffffffeu;
// A dark plane refined only at the pixels its selection lists: slot 1 holds their count,
// slots 2.. the pixels in pixel order (records::refine::DARK_GUIDED; RefinePass::slots makes
// room for P^2 of them).
const DARK_GUIDED: u32 = 0xfffffffdu;
// A lit plane's slots past its last selected pixel (records::refine::UNUSED_SLOT).
const UNUSED_SLOT: u32 = 0xfffffffcu;

// Workgroup `g` of `record`'s refinement as an entry of the work list (0: past its end).
fn refine_item(record: u32, g: u32) -> u32 {
    return ((g << 16u) | record) + 1u;
}

// The record of a work-list entry (`refine_item`).
fn refine_item_record(item: u32) -> u32 {
    return (item - 1u) & 0xffffu;
}

// The record's workgroup of a work-list entry (`refine_item`).
fn refine_item_group(item: u32) -> u32 {
    return (item - 1u) >> 16u;
}
