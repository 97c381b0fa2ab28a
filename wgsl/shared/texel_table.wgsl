// Tables read through texel fetches (src/gpu/texel_table.rs: a storage buffer's copy in an
// Rgba32Uint texture, one 16-byte row a texel, TEXEL_TABLE_WIDTH texels a texture row). On
// lavapipe without AVX-512 a storage-buffer load stalls on every lane's every component and
// a texel fetch does not (gpu::triangle_fetch): the passes that read a table many times a
// lane read its copy there. A pipeline constant the device sets, so each pipeline holds one
// way; the same bits either way.
override TABLE_TEXELS: bool = false;

const TEXEL_TABLE_WIDTH: u32 = 2048u;

// Row `i` of `table`.
fn texel_row(table: texture_2d<u32>, i: u32) -> vec4u {
    return textureLoad(table, vec2u(i % TEXEL_TABLE_WIDTH, i / TEXEL_TABLE_WIDTH), 0);
}
