//! How far ahead a record's estimate can see: the animation's horizon.
//!
//! A record's lifespan comes from its estimate at t+1 (`tau = E(t+1) / E(t)`, seed 000
//! eqs. 6-8): the change from t to t+1, extrapolated over the lifespan by the temporal
//! gradient. That holds only while the scene keeps changing as it did from t to t+1. A
//! light switched on at a later keyframe, a light or an object that starts to move, stops
//! or turns, is a change the estimate cannot see: a record born before it said "nothing
//! changes" and kept the old light for up to dt_max frames (a light switched back on
//! showed up to `max_lifespan` frames late; with interpolated gradients it faded in over
//! the frames before it was switched on).
//!
//! The animation is known ahead, so the horizon looks at it: for each frame f after t+1
//! it extrapolates every animated light and object along its course through its states
//! at t and t+1 (what the estimate assumed), compares with its keyed state at f, and ends
//! the records' lifespan at the last frame at which every one is within the temporal
//! accuracy a_t of that course (the seed's own bound on a record's relative change over
//! its life, `|tau - 1| (t - t_k) <= a_t`). The departures are first-order estimates of
//! the relative change they make to a record's light:
//! - a light's intensity, radiance or irradiance: the relative difference (largest
//!   channel);
//! - a point, spot or rect light's position: `2 delta / d`, `delta` the distance between
//!   the true and the extrapolated position (for a rect light, the largest over its
//!   corners) and `d` the record's distance to the light (irradiance falls as `1 / d^2`);
//! - a sun's or spot's direction: the angle between true and extrapolated direction, in
//!   radians (a cosine's relative change for unit change of angle at 45 degrees), for a
//!   spot relative to its cone's half-angle;
//! - an object: its bounding box's largest corner departure `delta` against the radius
//!   `r` of the sphere around the box, `min(1, delta / r)`, times the share of the
//!   record's cosine-weighted hemisphere the sphere covers, `(r / d)^2` (1 within it).
//!
//! An object on its course may still change a record's light otherwise than in a straight
//! line: coming nearer, it takes a growing share of the hemisphere. That drift, the share
//! at f against the straight line through the shares at t and t+1, ends the records too
//! when it passes a_t. A moving object's change is continuous (its keys are interpolated,
//! it does not jump), so a record such an object ends is still interpolated towards its
//! successor; one a light ends is not (a lamp switches on between two frames): it keeps
//! its own extrapolated gradient ([`HorizonEnd::broken`]). Measured: with every object's
//! end a break, glossy and diffuse Spheres (balls bouncing every few frames) flickered 4 %
//! more and erred more than with stop 59; as drift, less (docs/results.md). An object that
//! stood still from t to t+1 and then starts is a break too: the record saw nothing move,
//! so its extrapolated gradient is the true one up to the start, while interpolating
//! towards a successor born after the start showed part of the motion before it (stop 61).
//!
//! Lights and objects follow straight courses between keyframes (positions, intensities
//! and scales are interpolated linearly; rotations are slerped, which the extrapolation
//! continues exactly), so records keep their lifespan inside a keyframe interval; only
//! where a course bends or jumps do the records born within dt_max before it end there.
//! Lights the record does not see count too (which light a record sees is not known
//! here): a conservative bound that costs replacements, never light.

use crate::scene::animation::{Interpolate, Track, TransformKey};
use crate::scene::{Light, Scene};
use glam::Vec3;

/// One animated light's or object's departure from its extrapolated course at one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Departure {
    Light {
        /// Relative departure that holds at every record (intensity, direction).
        everywhere: f32,
        /// A position's departure (`delta`, m) and the light's true position there: the
        /// relative departure at a record is `2 delta / d`.
        moved: Option<(f32, Vec3)>,
    },
    /// An object: its bounding box's largest corner departure `delta`, and the sphere
    /// around the box where it truly is.
    Object {
        delta: f32,
        center: Vec3,
        radius: f32,
        /// The centres of its bounding sphere at t and t+1, and `f - t`: how much of a
        /// record's hemisphere the estimate saw it take, continued in a straight line.
        seen_from: [Vec3; 2],
        steps: f32,
        /// It stood still from t to t+1: any departure is a start, a break.
        still: bool,
    },
}

impl Departure {
    /// The relative change at a record at `position`: (a break, a drift). A break is a
    /// light leaving its course (switched on, turned) or a still object starting; a drift
    /// is a moving object's change to the record's hemisphere, off its course or along it
    /// (it comes nearer): it moves continuously, so a record's successor still continues
    /// the change.
    fn at(&self, position: Vec3) -> (f32, f32) {
        match *self {
            Departure::Light { everywhere, moved } => {
                let moved = moved.map_or(0.0, |(delta, light)| {
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
                (everywhere.max(moved), 0.0)
            }
            // The object covers about (radius / d)^2 of the record's cosine-weighted
            // hemisphere; moved off its course by its own size, all of that changes.
            Departure::Object {
                delta,
                center,
                radius,
                seen_from,
                steps,
                still,
            } => {
                let share = |c: Vec3| {
                    let d = position.distance(c);
                    if d > radius {
                        (radius / d).powi(2)
                    } else {
                        1.0
                    }
                };
                let seen = share(center);
                let moved = if delta <= 0.0 {
                    0.0
                } else if radius > 0.0 {
                    (delta / radius).min(1.0)
                } else {
                    1.0
                };
                // On its course, an object that comes nearer takes more of the record's
                // hemisphere than the straight line through t and t+1 said.
                let (a, b) = (share(seen_from[0]), share(seen_from[1]));
                let course = (seen - (a + (b - a) * steps)).abs();
                // Objects move continuously (their keys are interpolated): whether it
                // left its course or drifted along it, the change is continuous, but for
                // the start of a still object, before which the record's view is exact.
                let change = (seen * moved).max(course);
                if still { (change, 0.0) } else { (0.0, change) }
            }
        }
    }
}

/// A scene's animated objects: each instance with a transform track and the box of its
/// mesh (object space), found once per scene ([`Horizon::ahead`] runs every frame).
#[derive(Clone, Debug, Default)]
pub struct AnimatedObjects {
    boxes: Vec<(usize, [Vec3; 8])>,
}

impl AnimatedObjects {
    pub fn of(scene: &Scene) -> Self {
        let boxes = scene
            .animation
            .iter()
            .flat_map(|a| &a.instances)
            .filter_map(|(i, _)| {
                let mesh = scene.meshes.get(scene.instances.get(*i)?.mesh as usize)?;
                Some((*i, box_corners(&mesh.positions)?))
            })
            .collect();
        Self { boxes }
    }
}

/// Where a record's view of the animation ends ([`Horizon::end`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HorizonEnd {
    /// The last frame at which the record's estimate still holds.
    pub last_frame: u32,
    /// A light left its course there, or an object that stood still started (a break: the
    /// record's successor, born after it, must not be interpolated towards); false when a
    /// moving object changed what the record sees (a continuous change).
    pub broken: bool,
}

/// The frames after t+1 up to dt_max, and what each animated light and object does there
/// beyond the estimate's course ([`Horizon::end`]).
#[derive(Clone, Debug)]
pub struct Horizon {
    /// The frame the records are born in.
    birth: u32,
    accuracy: f32,
    /// Per frame `birth + 2 + i`: each animated light's and object's departure.
    frames: Vec<Vec<Departure>>,
}

impl Horizon {
    /// The horizon of records born at `t` that live at most `max_lifespan` frames, under
    /// temporal accuracy `accuracy`, for `scene` and its `objects`. None when no light or
    /// object is animated.
    pub fn ahead(
        scene: &Scene,
        objects: &AnimatedObjects,
        t: u32,
        max_lifespan: u32,
        accuracy: f32,
    ) -> Option<Self> {
        let animation = scene.animation.as_ref()?;
        let lights: Vec<usize> = animation.lights.iter().map(|(i, _)| *i).collect();
        let objects: Vec<(&Track<TransformKey>, &[Vec3; 8])> = objects
            .boxes
            .iter()
            .filter_map(|(i, corners)| Some((animation.instance_track(*i)?, corners)))
            .collect();
        if lights.is_empty() && objects.is_empty() {
            return None;
        }
        let latest = t.saturating_add(max_lifespan.max(1) - 1);
        let now = scene.lights_at(t as f32);
        let next = scene.lights_at(t as f32 + 1.0);
        let frames = (t.saturating_add(2)..=latest)
            .map(|f| {
                let steps = (f - t) as f32;
                let truth = scene.lights_at(f as f32);
                let lights = lights.iter().filter_map(|&i| {
                    Some(departure(now.get(i)?, next.get(i)?, truth.get(i)?, steps))
                });
                let objects = objects
                    .iter()
                    .map(|(track, corners)| object_departure(track, corners, t as f32, f as f32));
                lights.chain(objects).collect()
            })
            .collect();
        Some(Self {
            birth: t,
            accuracy,
            frames,
        })
    }

    /// Where the view from a record at `position` ends: the last frame up to which every
    /// animated light and object stays within a_t of its course through t and t+1, and
    /// an object's share of the record's hemisphere within a_t of its straight line; at
    /// least t+1 (where the estimate is exact). None when nothing departs up to dt_max.
    pub fn end(&self, position: Vec3) -> Option<HorizonEnd> {
        // NaN (a light of infinite intensity is refused at load) departs.
        let beyond = |x: f32| x.is_nan() || x > self.accuracy;
        self.frames.iter().enumerate().find_map(|(i, departures)| {
            let (left, drift) = departures.iter().fold((false, false), |(l, d), dep| {
                let (course, along) = dep.at(position);
                (l || beyond(course), d || beyond(along))
            });
            (left || drift).then_some(HorizonEnd {
                last_frame: self.birth + 1 + i as u32,
                broken: left,
            })
        })
    }
}

/// The corners of the box around `points` (None for no points).
fn box_corners(points: &[Vec3]) -> Option<[Vec3; 8]> {
    let first = *points.first()?;
    let (lo, hi) = points
        .iter()
        .fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    Some(std::array::from_fn(|k| {
        Vec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        )
    }))
}

/// An object's departure at frame `f` from the course through its transforms at `t` and
/// t+1: translation and scale continued in a straight line, the rotation from t to t+1
/// continued about the same axis at the same rate (the motion between two keyframes
/// exactly), against its keyed transform at `f`; measured at its box's corners.
fn object_departure(track: &Track<TransformKey>, corners: &[Vec3; 8], t: f32, f: f32) -> Departure {
    let (a, b, truth) = (track.sample(t), track.sample(t + 1.0), track.sample(f));
    let steps = f - t;
    // Not `slerp` past 1: glam's falls back to a normalised lerp for rotations this
    // close (a few degrees a frame), which drifts off the arc when continued.
    let mut turn = a.rotation.inverse() * b.rotation;
    if turn.w < 0.0 {
        turn = -turn; // the shortest arc, as the keys are slerped
    }
    let (axis, angle) = turn.to_axis_angle();
    let course = TransformKey {
        translate: a.translate + (b.translate - a.translate) * steps,
        rotation: (a.rotation * glam::Quat::from_axis_angle(axis, angle * steps)).normalize(),
        scale: a.scale + (b.scale - a.scale) * steps,
    }
    .matrix();
    let truth = truth.matrix();
    let at = corners.map(|c| truth.transform_point3(c));
    let delta = corners
        .iter()
        .zip(&at)
        .map(|(&c, &p)| course.transform_point3(c).distance(p))
        .fold(0.0f32, f32::max);
    let centre_of =
        |m: glam::Mat4| corners.iter().map(|&c| m.transform_point3(c)).sum::<Vec3>() / 8.0;
    let center = centre_of(truth);
    let radius = at.iter().map(|p| p.distance(center)).fold(0.0f32, f32::max);
    Departure::Object {
        delta,
        center,
        radius,
        seen_from: [centre_of(a.matrix()), centre_of(b.matrix())],
        steps,
        still: a.matrix() == b.matrix(),
    }
}

/// A light's departure at `steps` frames after t from the straight path through its
/// states `now` (t) and `next` (t+1), against its true state `truth`. The path is the
/// keys' own interpolation continued past t+1 (positions, edges and colours lerped,
/// directions lerped and normalised).
fn departure(now: &Light, next: &Light, truth: &Light, steps: f32) -> Departure {
    let course = Light::interpolate(now, next, steps);
    match (&course, truth) {
        (
            Light::Point {
                position: p,
                intensity: i,
            },
            Light::Point {
                position,
                intensity,
            },
        ) => Departure::Light {
            everywhere: relative(*i, *intensity),
            moved: Some((p.distance(*position), *position)),
        },
        (
            Light::Spot {
                position: p,
                direction: d,
                intensity: i,
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
            Departure::Light {
                everywhere: relative(*i, *intensity).max(d.angle_between(*direction) / half_angle),
                moved: Some((p.distance(*position), *position)),
            }
        }
        (
            Light::Rect {
                corner: c,
                edge_u: u,
                edge_v: v,
                radiance: r,
            },
            Light::Rect {
                corner,
                edge_u,
                edge_v,
                radiance,
            },
        ) => {
            let corners = |c: Vec3, u: Vec3, v: Vec3| [c, c + u, c + v, c + u + v];
            let (a, truth) = (corners(*c, *u, *v), corners(*corner, *edge_u, *edge_v));
            let delta = (0..4)
                .map(|k| a[k].distance(truth[k]))
                .fold(0.0f32, f32::max);
            Departure::Light {
                everywhere: relative(*r, *radiance),
                moved: Some((delta, *corner + 0.5 * (*edge_u + *edge_v))),
            }
        }
        (
            Light::Sun {
                direction: d,
                irradiance: e,
            },
            Light::Sun {
                direction,
                irradiance,
            },
        ) => Departure::Light {
            everywhere: relative(*e, *irradiance).max(d.angle_between(*direction)),
            moved: None,
        },
        // A track keeps its light's type (checked at load); a mismatch departs at once.
        _ => Departure::Light {
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

    fn ahead(scene: &Scene, t: u32, max_lifespan: u32, accuracy: f32) -> Option<Horizon> {
        Horizon::ahead(
            scene,
            &AnimatedObjects::of(scene),
            t,
            max_lifespan,
            accuracy,
        )
    }

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
        assert!(d.at(Vec3::Y).0 < 1e-5, "{d:?}");
    }

    #[test]
    fn a_light_switched_on_departs_everywhere() {
        let d = departure(
            &point(Vec3::ZERO, 0.0),
            &point(Vec3::ZERO, 0.0),
            &point(Vec3::ZERO, 2.0),
            3.0,
        );
        assert_eq!(d.at(Vec3::splat(100.0)), (1.0, 0.0));
        // Dark throughout: nothing to see.
        let d = departure(
            &point(Vec3::ZERO, 0.0),
            &point(Vec3::ZERO, 0.0),
            &point(Vec3::ZERO, 0.0),
            3.0,
        );
        assert_eq!(d.at(Vec3::ONE), (0.0, 0.0));
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
        assert!((d.at(Vec3::new(0.1, 4.0, 0.0)).0 - 0.05).abs() < 1e-6);
        assert!(d.at(Vec3::new(0.1, 1.0, 0.0)).0 > 0.19);
    }

    #[test]
    fn a_turning_sun_departs_by_its_angle() {
        let sun = |x: f32| Light::Sun {
            direction: Vec3::new(x, 1.0, 0.0).normalize(),
            irradiance: Vec3::ONE,
        };
        let d = departure(&sun(0.0), &sun(0.0), &sun(0.1), 2.0);
        assert!((d.at(Vec3::ZERO).0 - 0.1f32.atan()).abs() < 1e-5, "{d:?}");
    }

    #[test]
    fn the_lamp_switched_on_at_frame_12_ends_the_records_born_before_it() {
        let scene = crate::scene::bundled("lamp-switch.toml");
        let anywhere = [Vec3::ZERO, Vec3::new(1.9, 3.9, 1.9)];
        for t in [0, 5, 10] {
            let h = ahead(&scene, t, 20, 0.05).expect("the lamp is animated");
            for p in anywhere {
                let end = HorizonEnd {
                    last_frame: 11,
                    broken: true,
                };
                assert_eq!(h.end(p), Some(end), "born at {t}");
            }
        }
        // Born with the lamp on: nothing changes any more. Born at 3 with dt_max 4 (its
        // last frame 6 at most): the switch lies beyond its life.
        let h = ahead(&scene, 12, 20, 0.05).expect("horizon");
        assert_eq!(h.end(Vec3::ZERO), None);
        let h = ahead(&scene, 3, 4, 0.05).expect("horizon");
        assert_eq!(h.end(Vec3::ZERO), None);
        // Nothing animated: no horizon.
        assert!(ahead(&crate::scene::bundled("cube-in-box.toml"), 0, 20, 0.05).is_none());
    }

    #[test]
    fn the_moving_panel_ends_records_after_its_turn_near_it_first() {
        // The panel moves along +x until frame 100, then along +z (moving-light.toml),
        // 2 cm a frame: a record born at 95 sees the turn; one under the panel departs
        // sooner than one across the room.
        let scene = crate::scene::bundled("moving-light.toml");
        let h = ahead(&scene, 95, 20, 0.02).expect("horizon");
        let near = h.end(Vec3::new(0.5, 3.0, -1.0)).expect("departs");
        let far = h.end(Vec3::new(-1.9, 0.0, 1.9)).expect("departs");
        assert!(near.broken && far.broken);
        let (near, far) = (near.last_frame, far.last_frame);
        assert!((100..=104).contains(&near), "{near}");
        assert!(far > near && far < 95 + 20, "{near} {far}");
        // Inside a leg the panel follows its straight path.
        let h = ahead(&scene, 20, 20, 0.02).expect("horizon");
        assert_eq!(h.end(Vec3::new(0.5, 3.0, -1.0)), None);
    }

    fn unit_box() -> [Vec3; 8] {
        box_corners(&[Vec3::splat(-0.5), Vec3::splat(0.5)]).expect("corners")
    }

    fn key(x: f32, degrees: f32) -> TransformKey {
        TransformKey::from_trs(
            Vec3::new(x, 0.0, 0.0),
            Vec3::new(0.0, degrees, 0.0),
            Vec3::ONE,
        )
    }

    #[test]
    fn an_object_turning_and_sliding_between_keyframes_departs_nowhere() {
        let track = Track {
            keys: vec![(0.0, key(0.0, 0.0)), (100.0, key(2.0, 170.0))],
        };
        let d = object_departure(&track, &unit_box(), 10.0, 29.0);
        let Departure::Object { delta, .. } = d else {
            panic!("{d:?}")
        };
        assert!(delta < 1e-4, "{delta}");
    }

    #[test]
    fn an_object_that_starts_to_move_departs_near_it_first() {
        // Still until frame 20, then 5 cm a frame along x.
        let track = Track {
            keys: vec![
                (0.0, key(0.0, 0.0)),
                (20.0, key(0.0, 0.0)),
                (40.0, key(1.0, 0.0)),
            ],
        };
        let d = object_departure(&track, &unit_box(), 10.0, 22.0);
        // 10 cm off its course: all of it (10 % of its size) seen from on it, a
        // hundredth of that from 10 box radii away.
        // Still from frame 10 to 11: a start, so a break.
        let radius = 0.75f32.sqrt();
        assert!((d.at(Vec3::ZERO).0 - 0.1 / radius).abs() < 1e-4, "{d:?}");
        assert_eq!(d.at(Vec3::ZERO).1, 0.0);
        // (The box's centre is at x = 0.1 at frame 22.)
        let far = d.at(Vec3::new(10.0 * radius + 0.1, 0.0, 0.0)).0;
        assert!((far - 0.001 / radius).abs() < 1e-5, "{far}");
        // Already moving at frame 21 (5 cm a frame), it is on its course at 23: no
        // departure; one that slows down departs as a drift, not a break.
        let moving = object_departure(&track, &unit_box(), 21.0, 23.0).at(Vec3::ZERO);
        assert!(moving.0 == 0.0 && moving.1 < 1e-4, "{moving:?}");
        let slowing = Track {
            keys: vec![
                (0.0, key(0.0, 0.0)),
                (20.0, key(1.0, 0.0)),
                (40.0, key(1.2, 0.0)),
            ],
        };
        let slows = object_departure(&slowing, &unit_box(), 18.0, 22.0).at(Vec3::ZERO);
        assert!(slows.0 == 0.0 && slows.1 > 0.05, "{slows:?}");
        assert_eq!(
            object_departure(&track, &unit_box(), 10.0, 20.0).at(Vec3::ZERO),
            (0.0, 0.0)
        );
    }

    #[test]
    fn the_cube_that_starts_at_frame_12_ends_records_beside_it_there_with_a_break() {
        let scene = crate::scene::bundled("cube-starts.toml");
        let h = ahead(&scene, 5, 20, 0.05).expect("the cube is animated");
        // On the floor beside the cube (its box spans x -1.7..-0.7 at the start).
        let end = h.end(Vec3::new(-0.5, 0.0, -1.2)).expect("the cube departs");
        assert_eq!(
            end,
            HorizonEnd {
                last_frame: 12,
                broken: true
            }
        );
        // Across the room the cube's share stays small for longer.
        let far = h
            .end(Vec3::new(1.9, 3.9, 1.9))
            .map_or(u32::MAX, |e| e.last_frame);
        assert!(far > 13, "{far}");
    }
}
