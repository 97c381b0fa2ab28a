// The plane's samples and pixel table, read from their storage buffers or from their copies
// in texel tables (shared/texel_table.wgsl). The including pass declares `samples:
// array<PlaneSample>`, `plane: array<PlanePixel>`, `sample_texels` and `pixel_texels`
// (texture_2d<u32>: the same rows; two a pixel).
//!include shared/texel_table.wgsl

// Plane sample `i` (the batch's planes one after another).
fn plane_sample(i: u32) -> PlaneSample {
    if TABLE_TEXELS {
        let t = bitcast<vec4f>(texel_row(sample_texels, i));
        return PlaneSample(t.xyz, t.w);
    }
    return samples[i];
}

// Pixel `k` of the plane table (two rows a pixel in the copy).
fn plane_pixel(k: u32) -> PlanePixel {
    if TABLE_TEXELS {
        return PlanePixel(bitcast<vec4f>(texel_row(pixel_texels, 2u * k)),
                          bitcast<vec4f>(texel_row(pixel_texels, 2u * k + 1u)));
    }
    return plane[k];
}
