//! Radiance's ambient corral (Ward's `ambcorral`) for irradiance records: the nearest
//! horizon hit per direction around a record, stored in two words of the record, so that
//! a record does not reach pixels beyond a surface standing near it (WGSL:
//! `shared/corral.wgsl`).

/// Where the records' corrals ([`Record::corral_allows`](super::Record::corral_allows): a record does not reach pixels
/// beyond a surface its plane's horizon rays hit near it, so records on the dark side of
/// a wall's end do not darken the floor in front of its lit face, nor the lit side's
/// records light the dark one) apply.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, clap::ValueEnum)]
pub enum Corral {
    /// No corral: records are computed without one (animations: a record outlives the
    /// geometry its corral saw).
    Off,
    /// Placement's cover weighs the corrals, the gathers do not (the default): a pixel
    /// beyond the corral of every record that reaches it gets a record of its own, and the
    /// gathers then weigh that record beside the others. Where a lit surface's end stands
    /// beside the floor (the nave with the sun 34 degrees up) 16.6 -> 9.0 %, the nave
    /// 13.2 -> 11.2 %; Sponza's views 2-8 % worse (relative), the rest within 2 %; about
    /// 1.00-1.05x the process time on lavapipe (docs/results.md, "The corral in placement's
    /// cover alone").
    #[default]
    Cover,
    /// The gathers weigh no record beyond its corral; placement covers as without (the
    /// same records), so a pixel that only corralled records reach takes them in tail
    /// fill's gather rather than reading black. The nave 13.07 -> 12.58 %, the conference
    /// room 2.55 -> 2.47 %, the nave with the sun 34 degrees up 16.56 -> 13.56 %, Sponza's
    /// west sun 10.70 -> 10.83 %, for 1.03-1.09x the process time.
    Gather,
    /// Placement's cover and the gathers: pixels beyond a record's corral get records of
    /// their own and do not take it. Where a lit surface's end stands beside the floor
    /// (the nave with the sun 34 degrees up) 16.6 -> 6.8 %, for 1.1-1.2x the time on
    /// lavapipe (the gathers' corral test).
    Placement,
}

impl Corral {
    /// Whether records get corrals.
    pub fn in_records(self) -> bool {
        self != Corral::Off
    }

    /// Whether the gathers weigh them.
    pub fn in_gathers(self) -> bool {
        matches!(self, Corral::Gather | Corral::Placement)
    }

    /// Whether placement's cover weighs them too.
    pub fn in_cover(self) -> bool {
        matches!(self, Corral::Placement | Corral::Cover)
    }
}

/// Vertices of a record's corral polygon around its normal (WGSL `CORRAL_SECTORS`,
/// shared/corral.wgsl), 22.5 degrees apart.
pub const CORRAL_SECTORS: u32 = 16;
/// Bits of a corral vertex's level.
pub const CORRAL_BITS: u32 = 3;
/// Vertices in each of the two words of a corral (24 bits, exact in an f32).
pub const CORRAL_PER_WORD: u32 = 8;
/// A corral vertex's distance from the record in units of R, by level (0: far).
pub const CORRAL_DISTANCE: [f32; 8] = [2.0, 0.0625, 0.125, 0.1875, 0.25, 0.375, 0.5, 0.75];

/// Where a tangent-plane offset (u, v) along [`crate::sampling::orthonormal_basis`]'s
/// first two axes lies around the normal, in sectors (WGSL `corral_turn`): vertex b at b.
pub fn corral_turn(u: f32, v: f32) -> f32 {
    (v.atan2(u) + std::f32::consts::PI) * (CORRAL_SECTORS as f32 / std::f32::consts::TAU)
}

/// The level of a corral vertex whose nearest hit lies `h` away along the tangent plane
/// (negative: none), for a record of radius `radius` (WGSL `corral_level`): the farthest
/// [`CORRAL_DISTANCE`] within h (the nearest, R / 16, below it); 0 (far) for h >= R.
pub fn corral_level(h: f32, radius: f32) -> u32 {
    if h < 0.0 || h >= radius {
        return 0;
    }
    (2..8u32)
        .filter(|&l| CORRAL_DISTANCE[l as usize] * radius <= h)
        .max()
        .unwrap_or(1)
}

/// The corral vertices' directions in the tangent plane: vertex b at -pi + b pi / 8
/// (WGSL `CORRAL_DIRECTIONS`, the same constants).
pub const CORRAL_DIRECTIONS: [[f32; 2]; 16] = [
    [-1.0, 0.0],
    [-0.923_879_5, -0.382_683_43],
    [-0.707_106_77, -0.707_106_77],
    [-0.382_683_43, -0.923_879_5],
    [0.0, -1.0],
    [0.382_683_43, -0.923_879_5],
    [0.707_106_77, -0.707_106_77],
    [0.923_879_5, -0.382_683_43],
    [1.0, 0.0],
    [0.923_879_5, 0.382_683_43],
    [0.707_106_77, 0.707_106_77],
    [0.382_683_43, 0.923_879_5],
    [0.0, 1.0],
    [-0.382_683_43, 0.923_879_5],
    [-0.707_106_77, 0.707_106_77],
    [-0.923_879_5, 0.382_683_43],
];

/// tan(22.5 degrees) (WGSL `CORRAL_TAN`).
const CORRAL_TAN: f32 = 0.414_213_57;

/// The sector (0..15) of a tangent-plane offset (u, v), between vertices s and s + 1: the
/// whole part of [`corral_turn`] but at its edges, from comparisons alone (WGSL
/// `corral_sector`: no atan2 where every reached pixel tests a record).
pub fn corral_sector(u: f32, v: f32) -> u32 {
    let (quarter, xy) = corral_quarter(u, v);
    4 * quarter + corral_sub_sector(xy)
}

/// The quarter turn from -pi that a tangent-plane offset (u, v) lies in (vertices
/// 4 quarter .. 4 quarter + 4), and the offset in that quarter's frame: x along its first
/// vertex, y along its last (WGSL `corral_quarter`; a turn by a multiple of 90 degrees,
/// exact in floats).
pub fn corral_quarter(u: f32, v: f32) -> (u32, glam::Vec2) {
    if v < 0.0 && u >= 0.0 {
        (1, glam::Vec2::new(-v, u))
    } else if v >= 0.0 && u >= 0.0 {
        (2, glam::Vec2::new(u, v))
    } else if v >= 0.0 {
        (3, glam::Vec2::new(v, -u))
    } else {
        (0, glam::Vec2::new(-u, -v))
    }
}

/// The sector within a quarter (0..3) of a point of its frame (WGSL `corral_sub_sector`).
pub(super) fn corral_sub_sector(xy: glam::Vec2) -> u32 {
    u32::from(xy.y >= xy.x * CORRAL_TAN)
        + u32::from(xy.y >= xy.x)
        + u32::from(xy.y * CORRAL_TAN >= xy.x)
}

/// The corral of `h`, the nearest horizon hit per vertex (negative: none), for a record of
/// radius `radius`: the two words [`Record::set_corral`](super::Record::set_corral) stores.
pub fn corral_words(h: &[f32; CORRAL_SECTORS as usize], radius: f32) -> [u32; 2] {
    let mut words = [0u32; 2];
    for (b, &h) in h.iter().enumerate() {
        let b = b as u32;
        words[(b / CORRAL_PER_WORD) as usize] |=
            corral_level(h, radius) << (CORRAL_BITS * (b % CORRAL_PER_WORD));
    }
    words
}

#[cfg(test)]
mod tests {
    /// A record on a floor (normal +y) 0.1 m from the end of a wall, its corral from the
    /// horizontal distances at which its vertices' directions meet the wall.
    fn record_beside(wall: impl Fn(glam::Vec3) -> Option<f32>) -> crate::records::Record {
        use super::{CORRAL_SECTORS, corral_words};
        use crate::records::Record;
        let mut r: Record = bytemuck::Zeroable::zeroed();
        r.normal = [0.0, 1.0, 0.0];
        r.radius = 1.0;
        r.irradiance = [1.0; 3];
        let base = crate::sampling::orthonormal_basis(glam::Vec3::Y);
        let mut h = [-1.0f32; CORRAL_SECTORS as usize];
        for (b, h) in h.iter_mut().enumerate() {
            let angle =
                b as f32 * std::f32::consts::TAU / CORRAL_SECTORS as f32 - std::f32::consts::PI;
            let dir = angle.cos() * base.x_axis + angle.sin() * base.y_axis;
            *h = wall(dir).unwrap_or(-1.0);
        }
        r.set_corral(corral_words(&h, r.radius));
        r
    }

    #[test]
    fn the_corral_keeps_a_record_from_beyond_a_wall_and_not_from_along_it() {
        use glam::Vec3;
        // A wall along z at x = 0.1, as long as the floor: every direction with x > 0
        // meets it at 0.1 / x.
        let r = record_beside(|d| (d.x > 1e-3).then(|| 0.1 / d.x));
        assert!(r.corral() != [0, 0]);
        // Beyond the wall: cut off (the corral rounds its vertices in, to 1/16 R here).
        assert!(!r.corral_allows(Vec3::new(0.3, 0.0, 0.0)));
        assert!(!r.corral_allows(Vec3::new(0.3, 0.0, 0.2)));
        // In front of it, along it and away from it: kept.
        assert!(r.corral_allows(Vec3::new(0.05, 0.0, 0.0)));
        assert!(r.corral_allows(Vec3::new(0.02, 0.0, 0.8)));
        assert!(r.corral_allows(Vec3::new(0.02, 0.0, -0.8)));
        assert!(r.corral_allows(Vec3::new(-0.6, 0.0, 0.3)));
        // Ward's test with the corral: the pixel beyond is not reached, the one along is.
        assert!(!r.reaches(Vec3::new(0.2, 0.0, 0.0), Vec3::Y, 0.25));
        assert!(r.reaches(Vec3::new(0.0, 0.0, 0.2), Vec3::Y, 0.25));

        // The end of a wall (the wall for z > 0 only, its end 0.02 beside the record): the
        // floor in front of its far side (x > 0.1, z < 0) is cut off where the segment from
        // the record crosses the wall, the floor past its end (z < -0.2) is not.
        let end = record_beside(|d| (d.x > 1e-3).then(|| 0.1 / d.x).filter(|t| d.z * t > 0.02));
        assert!(!end.corral_allows(Vec3::new(0.3, 0.0, 0.3)));
        assert!(end.corral_allows(Vec3::new(0.3, 0.0, -0.4)));
        assert!(end.corral_allows(Vec3::new(-0.3, 0.0, 0.3)));
        // Nothing near: no corral, every pixel kept.
        let open = record_beside(|_| None);
        assert_eq!(open.corral(), [0, 0]);
        assert!(open.corral_allows(Vec3::new(0.9, 0.0, 0.0)));
    }

    #[test]
    fn corral_sectors_follow_the_angle_and_the_directions_table() {
        use super::{CORRAL_DIRECTIONS, corral_sector, corral_turn};
        for k in 0..720 {
            // Away from the sectors' edges, the sector is the whole part of the turn.
            let angle = (k as f32 + 0.37) * std::f32::consts::TAU / 720.0 - std::f32::consts::PI;
            let (u, v) = (2.5 * angle.cos(), 2.5 * angle.sin());
            let turn = corral_turn(u, v);
            if (turn - turn.round()).abs() > 1e-3 {
                assert_eq!(corral_sector(u, v), turn.floor() as u32, "angle {angle}");
            }
        }
        for (b, d) in CORRAL_DIRECTIONS.iter().enumerate() {
            let turn = corral_turn(d[0], d[1]);
            let expected = if b == 0 { 16.0 } else { b as f32 };
            assert!((turn - expected).abs() < 1e-4, "vertex {b}: turn {turn}");
        }
    }

    #[test]
    fn corral_levels_round_in_and_fit_an_f32() {
        use super::{CORRAL_DISTANCE, corral_level};
        for &h in &[0.0f32, 0.01, 0.07, 0.13, 0.2, 0.3, 0.45, 0.6, 0.8, 0.99] {
            let level = corral_level(h, 1.0);
            assert!((1..8).contains(&level), "h {h}: level {level}");
            // Rounded in (the nearest vertex, R / 16, may lie past a nearer hit).
            assert!(CORRAL_DISTANCE[level as usize] <= h.max(CORRAL_DISTANCE[1]));
        }
        assert_eq!(corral_level(1.0, 1.0), 0);
        assert_eq!(corral_level(-1.0, 1.0), 0);
        let words = super::corral_words(&[0.0; 16], 1.0);
        assert!(words.iter().all(|&w| w < 1 << 24));
    }
}
