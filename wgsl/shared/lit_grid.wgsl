// Where lit surfaces are, coarsely (src/light_maps/lit_grid.rs): a pyramid of voxel grids
// over the scene's bounds. A voxel holds the face bits (`lit_face_bit`) of the lit sides of
// the light-map texels' first hits (surfaces a light reaches) that lie in it; each coarser
// level is the OR of its 2x2x2 children. Lets a plane that saw no light refine only the
// pixels whose rays could land near a lit surface. The including pass declares
// `lit_grid_params: LitGridParams` and `lit_grid: array<u32>` (or atomics, for marking).

struct LitGridParams {
    lo: vec3f,
    cell: f32,              // level 0's voxel edge
    dims: vec3u,            // level 0's voxels per axis
    levels: u32,            // 0: no grid (every query answers true)
    offsets: array<vec4u, 2>, // first voxel of level l: offsets[l / 4][l % 4]
}

fn lit_grid_offset(p: LitGridParams, level: u32) -> u32 {
    return p.offsets[level / 4u][level % 4u];
}

fn lit_grid_dims(p: LitGridParams, level: u32) -> vec3u {
    return max((p.dims + vec3u((1u << level) - 1u)) >> vec3u(level), vec3u(1u));
}

fn lit_grid_voxel(p: LitGridParams, level: u32, c: vec3u) -> u32 {
    let d = lit_grid_dims(p, level);
    return lit_grid_offset(p, level) + (c.z * d.y + c.y) * d.x + c.x;
}

// The face bit of a lit surface's normal `n` (facing its light): its dominant axis and sign.
fn lit_face_bit(n: vec3f) -> u32 {
    let a = abs(n);
    var axis = 0u;
    var v = n.x;
    if a.y > a.x && a.y >= a.z {
        axis = 1u;
        v = n.y;
    } else if a.z > a.x && a.z > a.y {
        axis = 2u;
        v = n.z;
    }
    return 1u << (2u * axis + select(0u, 1u, v < 0.0));
}

// The face bits of lit surfaces whose lit side a ray of direction `d` can meet: a normal
// within the face's cone (dominant axis: at most 54.7 degrees from it) faces -d only if
// the face's axis is within 144.7 degrees of -d (cos -0.8165; -0.85 leaves the pixel's
// spread of sub-ray directions a margin).
fn lit_faces_seen(d: vec3f) -> u32 {
    var mask = 0u;
    let v = -d;
    for (var axis = 0u; axis < 3u; axis++) {
        if v[axis] > -0.85 {
            mask |= 1u << (2u * axis);
        }
        if -v[axis] > -0.85 {
            mask |= 1u << (2u * axis + 1u);
        }
    }
    return mask;
}

// The face bits whose cones come within about 10 degrees of the unit normal `n` (a
// surface's lit side, if lit, is marked with one of them: `lit_face_bit` of its own
// normal, which rounding may tip to a neighbouring face near a cone's edge).
fn lit_faces_near(n: vec3f) -> u32 {
    var mask = 0u;
    for (var axis = 0u; axis < 3u; axis++) {
        if n[axis] > 0.43 {
            mask |= 1u << (2u * axis);
        }
        if -n[axis] > 0.43 {
            mask |= 1u << (2u * axis + 1u);
        }
    }
    return mask;
}
