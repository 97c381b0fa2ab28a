// The corral, shared by the record reduction (which computes it) and the contribution
// test of the gathers and covers that weigh it (shared/splat_weight.wgsl). Rust mirrors:
// records::Record::corral_allows, records::corral_level, records::reference::reduce_plane.
//!include shared/records.wgsl

// The corral (after Radiance's ambcorral, Ward): a record must not reach across a surface
// that stands near it, such as the end of a wall whose sunlit face it cannot see while a
// pixel a hand's width away, in front of that face, sees it whole (the irradiance jumps
// there; no gradient or curvature measured at the record predicts it). The corral is a
// polygon around the record in its tangent plane: CORRAL_SECTORS vertices, along the
// directions at the sectors' edges, each as far out as the nearest horizontal distance at
// which the plane's outermost ring of pixels (the rays nearest the horizon) hit something
// within a quarter sector of that direction (corral_level: 3 bits a vertex, rounded in;
// nothing hit: far). A pixel outside the polygon does not take the record. An edge
// between two vertices follows a wall that runs past the record, so the pixels along the
// wall keep it, where a cut per sector would cut them off. The vertices are stored eight
// to a word, in the rotational gradient's unused w of the green and blue channels, as
// exact integers (records::Record::corral), and counted from Duff's basis around the
// normal, so they need no stored frame.
const CORRAL_SECTORS: u32 = 16u;
const CORRAL_BITS: u32 = 3u;
const CORRAL_PER_WORD: u32 = 8u;

// Where offset (u, v) (components along orthonormal_basis(n)'s first two axes) lies around
// the normal, in sectors: vertex b is at b, sector s spans [s, s + 1). Rust:
// records::corral_turn.
fn corral_turn(u: f32, v: f32) -> f32 {
    return (atan2(v, u) + PI) * (f32(CORRAL_SECTORS) / (2.0 * PI));
}

// The level of a vertex whose nearest hit lies `h` away (h < 0: nothing hit), for a record
// of radius R: the farthest corral_distance within h (the nearest one, R / 16, below it);
// 0 (far) for h >= R. Rust: records::corral_level.
fn corral_level(h: f32, radius: f32) -> u32 {
    if h < 0.0 || h >= radius {
        return 0u;
    }
    return 1u + u32(0.125 * radius <= h) + u32(0.1875 * radius <= h) + u32(0.25 * radius <= h)
        + u32(0.375 * radius <= h) + u32(0.5 * radius <= h) + u32(0.75 * radius <= h);
}

// tan(22.5 degrees).
const CORRAL_TAN: f32 = 0.41421357;

// Where a tangent-plane offset (u, v) lies: its quarter turn from -pi (vertices 4 quarter
// .. 4 quarter + 4), and the offset in that quarter's frame (x along its first vertex, y
// along its last: a turn by a multiple of 90 degrees, exact in floats). Rust:
// records::corral_quarter.
struct CorralQuarter {
    quarter: u32,
    xy: vec2f,
}

fn corral_quarter(u: f32, v: f32) -> CorralQuarter {
    if v < 0.0 && u >= 0.0 {
        return CorralQuarter(1u, vec2f(-v, u));
    }
    if v >= 0.0 && u >= 0.0 {
        return CorralQuarter(2u, vec2f(u, v));
    }
    if v >= 0.0 {
        return CorralQuarter(3u, vec2f(v, -u));
    }
    return CorralQuarter(0u, vec2f(-u, -v));
}

// The sector within the quarter (0..3) of a point xy of its frame: from comparisons alone
// (no atan2 where every reached pixel tests a record). 4 quarter + this is the whole part
// of corral_turn but at its edges. Rust: records::corral_sector.
fn corral_sub_sector(xy: vec2f) -> u32 {
    return u32(xy.y >= xy.x * CORRAL_TAN) + u32(xy.y >= xy.x) + u32(xy.y * CORRAL_TAN >= xy.x);
}

// The direction of vertex k (0..4) of a quarter, in its frame: (cos, sin) of k 22.5 degrees
// (selects, not an indexed table: lavapipe copies a table to memory for every lookup).
fn corral_quarter_direction(k: u32) -> vec2f {
    let c = 0.9238795;
    let s = 0.38268343;
    let h = 0.70710677;
    return select(select(select(select(vec2f(0.0, 1.0), vec2f(s, c), k == 3u), vec2f(h, h), k == 2u),
        vec2f(c, s), k == 1u), vec2f(1.0, 0.0), k == 0u);
}

// CORRAL_DISTANCE[level], by selects (see corral_quarter_direction).
fn corral_distance(level: u32) -> f32 {
    let l = f32(level);
    return select(select(select(select(l * 0.0625, 0.375, level == 5u), 0.5, level == 6u), 0.75,
        level == 7u), 2.0, level == 0u);
}

fn corral_vertex_level(words: vec2u, b: u32) -> u32 {
    let word = select(words.x, words.y, b >= CORRAL_PER_WORD);
    return (word >> (CORRAL_BITS * (b % CORRAL_PER_WORD))) & 7u;
}

// Whether record r's corral lets it reach p: p's offset from r along r's tangent plane lies
// on the record's side of the polygon edge across p's sector. Rust:
// records::Record::corral_allows.
fn corral_allows(r: Record, p: vec3f) -> bool {
    let words = vec2u(u32(r.rotation_gradient[1].w), u32(r.rotation_gradient[2].w));
    if all(words == vec2u(0u)) {
        return true;
    }
    let base = orthonormal_basis(r.normal);
    let d = p - r.position;
    let at = corral_quarter(dot(d, base[0]), dot(d, base[1]));
    let k = corral_sub_sector(at.xy);
    let s = 4u * at.quarter + k;
    let l0 = corral_vertex_level(words, s);
    let l1 = corral_vertex_level(words, (s + 1u) % CORRAL_SECTORS);
    if l0 == 0u && l1 == 0u {
        return true;
    }
    // The edge from vertex s to s + 1, in the quarter's frame.
    let p0 = corral_quarter_direction(k) * (corral_distance(l0) * r.radius);
    let p1 = corral_quarter_direction(k + 1u) * (corral_distance(l1) * r.radius);
    let edge = p1 - p0;
    // The record (the origin) and p on the same side of the edge (the origin is never on
    // it: both vertices lie at least R / 16 out, along directions 22.5 degrees apart).
    let side_p = edge.x * (at.xy.y - p0.y) - edge.y * (at.xy.x - p0.x);
    let side_o = edge.x * (-p0.y) - edge.y * (-p0.x);
    return side_p * side_o >= 0.0;
}
