// The plane's samples and pixel table, read from a storage buffer or from its copy in a
// texel table (src/gpu/texel_table.rs: one 16-byte row a texel, TEXEL_TABLE_WIDTH texels a
// texture row). The including pass declares `samples: array<PlaneSample>`, `plane:
// array<PlanePixel>`, `sample_texels` and `pixel_texels` (texture_2d<u32>: the same rows).
// On lavapipe without AVX-512 a storage-buffer load stalls on every lane's every component
// and a texel fetch does not (gpu::triangle_fetch); the passes that read every sample and
// pixel of a plane read the copy there. A pipeline constant the device sets, so each
// pipeline holds one way; the same bits either way.
override PLANE_TEXELS: bool = false;

const TEXEL_TABLE_WIDTH: u32 = 2048u;

fn texel_row(table: texture_2d<u32>, i: u32) -> vec4u {
    return textureLoad(table, vec2u(i % TEXEL_TABLE_WIDTH, i / TEXEL_TABLE_WIDTH), 0);
}

// Plane sample `i` (the batch's planes one after another).
fn plane_sample(i: u32) -> PlaneSample {
    if PLANE_TEXELS {
        let t = bitcast<vec4f>(texel_row(sample_texels, i));
        return PlaneSample(t.xyz, t.w);
    }
    return samples[i];
}

// Pixel `k` of the plane table (two rows a pixel in the copy).
fn plane_pixel(k: u32) -> PlanePixel {
    if PLANE_TEXELS {
        return PlanePixel(bitcast<vec4f>(texel_row(pixel_texels, 2u * k)),
                          bitcast<vec4f>(texel_row(pixel_texels, 2u * k + 1u)));
    }
    return plane[k];
}
