//! How far ahead a record's estimate can see: the lights' horizon.
//!
//! A record's lifespan comes from its estimate at t+1 (`tau = E(t+1) / E(t)`, seed 000
//! eqs. 6-8): the change from t to t+1, extrapolated over the lifespan by the temporal
//! gradient. That holds only while the scene keeps changing as it did from t to t+1. A
//! light switched on at a later keyframe, or one that starts to move, or turns, is a
//! change the estimate cannot see: a record born before it said "nothing changes" and
//! kept the old light for up to dt_max frames (a light switched back on showed up to
//! `max_lifespan` frames late).
//!
//! The animation is known ahead, so the horizon looks at it: for each frame f after t+1
//! it extrapolates every animated light along the straight path through its states at t
//! and t+1 (what the estimate assumed), compares with the light's true state at f, and
//! ends the records' lifespan at the last frame at which every light is within the
//! temporal accuracy a_t of that path (the seed's own bound on a record's relative change
//! over its life, `|tau - 1| (t - t_k) <= a_t`). The deviations are first-order estimates
//! of the relative change the departure makes to a record's light:
//! - intensity, radiance or irradiance: the relative difference (largest channel);
//! - a point, spot or rect light's position: `2 delta / d`, `delta` the distance between
//!   the true and the extrapolated position (for a rect light, the largest over its
//!   corners) and `d` the record's distance to the light (irradiance falls as `1 / d^2`);
//! - a sun's or spot's direction: the angle between true and extrapolated direction, in
//!   radians (a cosine's relative change for unit change of angle at 45 degrees), for a
//!   spot relative to its cone's half-angle.
//!
//! A light that follows a straight path between keyframes (the tracks are piecewise
//! linear) leaves records their lifespan inside a keyframe interval; only where its
//! course bends do the records born within dt_max before the bend end at it. Lights the
//! record does not see are counted too (which light a record sees is not known here): a
//! conservative bound that costs replacements, never light.

use crate::scene::{Light, Scene};
use glam::Vec3;

/// One animated light's departure from its extrapolated path at one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Departure {
    /// Relative departure that holds at every record (intensity, direction).
    everywhere: f32,
    /// A position's departure (`delta`, m) and the light's true position there: the
    /// relative departure at a record is `2 delta / d`.
    moved: Option<(f32, Vec3)>,
}

impl Departure {
    /// The relative change at a record at `position`.
    fn at(&self, position: Vec3) -> f32 {
        let moved = self.moved.map_or(0.0, |(delta, light)| {
            if delta <= 0.0 {
                0.0
            } else {
                let d = position.distance(light);
                if d > 0.0 {
                    2.0 * delta / d
                } else {
                    f32::INFINITY
                }
            }
        });
        self.everywhere.max(moved)
    }
}

/// The frames after t+1 up to dt_max, and what each animated light does there beyond the
/// estimate's straight path ([`Horizon::last_frame`]).
#[derive(Clone, Debug)]
pub struct Horizon {
    /// The frame the records are born in.
    birth: u32,
    accuracy: f32,
    /// Per frame `birth + 2 + i`: each animated light's departure.
    frames: Vec<Vec<Departure>>,
}

impl Horizon {
    /// The horizon of records born at `t` that live at most `max_lifespan` frames, under
    /// temporal accuracy `accuracy`. None when no light is animated (nothing to see).
    pub fn ahead(scene: &Scene, t: u32, max_lifespan: u32, accuracy: f32) -> Option<Self> {
        let animated: Vec<usize> = scene
            .animation
            .as_ref()
            .map(|a| a.lights.iter().map(|(i, _)| *i).collect())
            .unwrap_or_default();
        if animated.is_empty() {
            return None;
        }
        let latest = t.saturating_add(max_lifespan.max(1) - 1);
        let now = scene.lights_at(t as f32);
        let next = scene.lights_at(t as f32 + 1.0);
        let frames = (t.saturating_add(2)..=latest)
            .map(|f| {
                let steps = (f - t) as f32;
                let truth = scene.lights_at(f as f32);
                animated
                    .iter()
                    .filter_map(|&i| {
                        Some(departure(now.get(i)?, next.get(i)?, truth.get(i)?, steps))
                    })
                    .collect()
            })
            .collect();
        Some(Self {
            birth: t,
            accuracy,
            frames,
        })
    }

    /// The last frame up to which every animated light stays within a_t of its straight
    /// path through t and t+1, as seen from a record at `position`: at least t+1 (where
    /// the estimate is exact). None when none departs up to dt_max.
    pub fn last_frame(&self, position: Vec3) -> Option<u32> {
        self.frames.iter().enumerate().find_map(|(i, lights)| {
            lights
                .iter()
                .any(|d| {
                    let change = d.at(position);
                    // NaN (a light of infinite intensity is refused at load) departs.
                    change.is_nan() || change > self.accuracy
                })
                .then_some(self.birth + 1 + i as u32)
        })
    }
}

/// A light's departure at `steps` frames after t from the straight path through its
/// states `now` (t) and `next` (t+1), against its true state `truth`.
fn departure(now: &Light, next: &Light, truth: &Light, steps: f32) -> Departure {
    let ahead = |a: Vec3, b: Vec3| a + (b - a) * steps;
    let turn = |a: Vec3, b: Vec3, truth: Vec3| {
        ahead(a, b)
            .try_normalize()
            .map_or(std::f32::consts::PI, |p| p.angle_between(truth))
    };
    match (now, next, truth) {
        (
            Light::Point {
                position: p0,
                intensity: i0,
            },
            Light::Point {
                position: p1,
                intensity: i1,
            },
            Light::Point {
                position,
                intensity,
            },
        ) => Departure {
            everywhere: relative(ahead(*i0, *i1), *intensity),
            moved: Some((ahead(*p0, *p1).distance(*position), *position)),
        },
        (
            Light::Spot {
                position: p0,
                direction: d0,
                intensity: i0,
                ..
            },
            Light::Spot {
                position: p1,
                direction: d1,
                intensity: i1,
                ..
            },
            Light::Spot {
                position,
                direction,
                intensity,
                cos_outer,
                ..
            },
        ) => {
            let half_angle = cos_outer.clamp(-1.0, 1.0).acos().max(1e-3);
            Departure {
                everywhere: relative(ahead(*i0, *i1), *intensity)
                    .max(turn(*d0, *d1, *direction) / half_angle),
                moved: Some((ahead(*p0, *p1).distance(*position), *position)),
            }
        }
        (
            Light::Rect {
                corner: c0,
                edge_u: u0,
                edge_v: v0,
                radiance: r0,
            },
            Light::Rect {
                corner: c1,
                edge_u: u1,
                edge_v: v1,
                radiance: r1,
            },
            Light::Rect {
                corner,
                edge_u,
                edge_v,
                radiance,
            },
        ) => {
            let corners = |c: Vec3, u: Vec3, v: Vec3| [c, c + u, c + v, c + u + v];
            let (a, b, truth) = (
                corners(*c0, *u0, *v0),
                corners(*c1, *u1, *v1),
                corners(*corner, *edge_u, *edge_v),
            );
            let delta = (0..4)
                .map(|k| ahead(a[k], b[k]).distance(truth[k]))
                .fold(0.0f32, f32::max);
            Departure {
                everywhere: relative(ahead(*r0, *r1), *radiance),
                moved: Some((delta, *corner + 0.5 * (*edge_u + *edge_v))),
            }
        }
        (
            Light::Sun {
                direction: d0,
                irradiance: e0,
            },
            Light::Sun {
                direction: d1,
                irradiance: e1,
            },
            Light::Sun {
                direction,
                irradiance,
            },
        ) => Departure {
            everywhere: relative(ahead(*e0, *e1), *irradiance).max(turn(*d0, *d1, *direction)),
            moved: None,
        },
        // A track keeps its light's type (checked at load); a mismatch departs at once.
        _ => Departure {
            everywhere: f32::INFINITY,
            moved: None,
        },
    }
}

/// The relative difference of two RGB quantities: the largest channel's difference over
/// the largest channel of either (0 when both are dark).
fn relative(predicted: Vec3, truth: Vec3) -> f32 {
    let scale = predicted.abs().max_element().max(truth.abs().max_element());
    if scale > 0.0 {
        (predicted - truth).abs().max_element() / scale
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(position: Vec3, intensity: f32) -> Light {
        Light::Point {
            position,
            intensity: Vec3::splat(intensity),
        }
    }

    #[test]
    fn a_light_on_its_straight_path_departs_nowhere() {
        let d = departure(
            &point(Vec3::ZERO, 1.0),
            &point(Vec3::X * 0.1, 1.1),
            &point(Vec3::X * 0.5, 1.5),
            5.0,
        );
        assert!(d.at(Vec3::Y) < 1e-5, "{d:?}");
    }

    #[test]
    fn a_light_switched_on_departs_everywhere() {
        let d = departure(
            &point(Vec3::ZERO, 0.0),
            &point(Vec3::ZERO, 0.0),
            &point(Vec3::ZERO, 2.0),
            3.0,
        );
        assert_eq!(d.at(Vec3::splat(100.0)), 1.0);
        // Dark throughout: nothing to see.
        let d = departure(
            &point(Vec3::ZERO, 0.0),
            &point(Vec3::ZERO, 0.0),
            &point(Vec3::ZERO, 0.0),
            3.0,
        );
        assert_eq!(d.at(Vec3::ONE), 0.0);
    }

    #[test]
    fn a_light_that_starts_to_move_departs_by_distance() {
        // Still at t and t+1, then 0.1 m away: 2 * 0.1 / d.
        let d = departure(
            &point(Vec3::ZERO, 1.0),
            &point(Vec3::ZERO, 1.0),
            &point(Vec3::X * 0.1, 1.0),
            4.0,
        );
        assert!((d.at(Vec3::new(0.1, 4.0, 0.0)) - 0.05).abs() < 1e-6);
        assert!(d.at(Vec3::new(0.1, 1.0, 0.0)) > 0.19);
    }

    #[test]
    fn a_turning_sun_departs_by_its_angle() {
        let sun = |x: f32| Light::Sun {
            direction: Vec3::new(x, 1.0, 0.0).normalize(),
            irradiance: Vec3::ONE,
        };
        let d = departure(&sun(0.0), &sun(0.0), &sun(0.1), 2.0);
        assert!((d.at(Vec3::ZERO) - 0.1f32.atan()).abs() < 1e-5, "{d:?}");
    }

    #[test]
    fn the_lamp_switched_on_at_frame_12_ends_the_records_born_before_it() {
        let scene = crate::scene::bundled("lamp-switch.toml");
        let anywhere = [Vec3::ZERO, Vec3::new(1.9, 3.9, 1.9)];
        for t in [0, 5, 10] {
            let h = Horizon::ahead(&scene, t, 20, 0.05).expect("the lamp is animated");
            for p in anywhere {
                assert_eq!(h.last_frame(p), Some(11), "born at {t}");
            }
        }
        // Born with the lamp on: nothing changes any more. Born at 3 with dt_max 4 (its
        // last frame 6 at most): the switch lies beyond its life.
        let h = Horizon::ahead(&scene, 12, 20, 0.05).expect("horizon");
        assert_eq!(h.last_frame(Vec3::ZERO), None);
        let h = Horizon::ahead(&scene, 3, 4, 0.05).expect("horizon");
        assert_eq!(h.last_frame(Vec3::ZERO), None);
        // No animated light: no horizon.
        assert!(
            Horizon::ahead(&crate::scene::bundled("cube-in-box-anim.toml"), 0, 20, 0.05).is_none()
        );
    }

    #[test]
    fn the_moving_panel_ends_records_after_its_turn_near_it_first() {
        // The panel moves along +x until frame 100, then along +z (moving-light.toml),
        // 2 cm a frame: a record born at 95 sees the turn; one under the panel departs
        // sooner than one across the room.
        let scene = crate::scene::bundled("moving-light.toml");
        let h = Horizon::ahead(&scene, 95, 20, 0.02).expect("horizon");
        let near = h.last_frame(Vec3::new(0.5, 3.0, -1.0)).expect("departs");
        let far = h.last_frame(Vec3::new(-1.9, 0.0, 1.9)).expect("departs");
        assert!((100..=104).contains(&near), "{near}");
        assert!(far > near && far < 95 + 20, "{near} {far}");
        // Inside a leg the panel follows its straight path.
        let h = Horizon::ahead(&scene, 20, 20, 0.02).expect("horizon");
        assert_eq!(h.last_frame(Vec3::new(0.5, 3.0, -1.0)), None);
    }
}
