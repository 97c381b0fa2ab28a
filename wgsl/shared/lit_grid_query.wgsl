// The lit grid's query (shared/lit_grid.wgsl), for passes that read it.
//!include shared/lit_grid.wgsl

// Whether a lit surface whose lit side faces one of `faces` (lit_faces_seen) may lie
// within `radius` of `q` (conservative: the 2x2x2 voxels of
// the first level whose voxels are at least 2 radius wide contain the ball).
fn lit_near(q: vec3f, radius: f32, faces: u32) -> bool {
    let p = lit_grid_params;
    if p.levels == 0u {
        return true;
    }
    var level = 0u;
    var cell = p.cell;
    loop {
        if cell >= 2.0 * radius || level + 1u >= p.levels {
            break;
        }
        level += 1u;
        cell *= 2.0;
    }
    if cell < 2.0 * radius {
        return true;    // wider than the whole grid
    }
    let d = vec3i(lit_grid_dims(p, level));
    let c = vec3i(floor((q - p.lo) / cell - vec3f(0.5)));
    for (var z = 0; z < 2; z++) {
        for (var y = 0; y < 2; y++) {
            for (var x = 0; x < 2; x++) {
                let v = c + vec3i(x, y, z);
                if all(v >= vec3i(0)) && all(v < d) && (lit_grid[lit_grid_voxel(p, level, vec3u(v))] & faces) != 0u {
                    return true;
                }
            }
        }
    }
    return false;
}
