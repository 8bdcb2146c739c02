//! Sleeping: a strand that has come to rest under a still head stops being stepped until
//! something that could move it changes, as bodies sleep in a rigid-body engine (avian's
//! `Sleeping`, Rapier's islands).
//!
//! Position-based hair never reaches an exact fixed point where contacts, friction and the
//! length pass disagree by a fraction of a substep's fall: a strand lying against the head
//! keeps stepping between a few places a hair's breadth apart, or sways about a place by a
//! few millimetres. A strand whose every particle stays within
//! [`SimParams::sleep_distance`] of where it has been on average (its anchor, which follows
//! it over about [`SimParams::sleep_time`]) for [`SimParams::sleep_time`] is put to sleep
//! where it is, with no velocity. It wakes when
//! the head moves, when its root is not where the head puts it, when the wind blows, when
//! the skin moves against the head, or when the settings or the extra colliders change.

use super::StepInput;
use super::params::SimParams;
use super::wind::is_calm;
use crate::math::Vec3;
use std::hash::{DefaultHasher, Hash, Hasher};

/// A strand's watch: how long it has stayed near its anchors (where its particles have
/// been on average since the watch began), and the settings it has stayed under.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct SleepWatch {
    /// Seconds every particle has stayed within `sleep_distance` of its anchor.
    pub quiet: f32,
    /// [`Stillness::key`] when the watch began.
    pub key: u64,
}

/// What a step tells the sleeping strands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stillness {
    /// Nothing moves the hair in this step but the hair itself: the head keeps its pose
    /// through the step, no wind blows, and no skin moves against the head.
    pub still: bool,
    /// The settings and extra colliders of the step, hashed: a strand sleeps only under
    /// those it went to sleep under.
    pub key: u64,
}

impl Stillness {
    /// The stillness of `input`, whose settings are already sanitized.
    pub fn of(input: &StepInput) -> Self {
        let p = input.params;
        let still = input.head_from == input.head_to && is_calm(&p.wind) && input.surface_patch.is_none();
        // Every field counts, so a field added to the settings later counts too.
        let mut hasher = DefaultHasher::new();
        format!("{p:?}{:?}", input.extra_colliders).hash(&mut hasher);
        Stillness { still, key: hasher.finish() }
    }
}

/// Whether a strand watched by `watch` stays asleep through a step of `stillness`, its
/// root at `root` where the step's last pose puts it at `pinned`.
#[inline]
pub(crate) fn stays_asleep(watch: &SleepWatch, stillness: Stillness, p: &SimParams, root: Vec3, pinned: Vec3) -> bool {
    asleep(watch, p) && stillness.still && stillness.key == watch.key && root.distance(pinned) <= ROOT_TOLERANCE
}

/// Whether a strand watched by `watch` is asleep.
#[inline]
pub(crate) fn asleep(watch: &SleepWatch, p: &SimParams) -> bool {
    p.sleep_distance > 0.0 && watch.quiet >= p.sleep_time
}

/// After a step of `dt` seconds in which the strand at `positions` was stepped: in a still
/// step under the same settings, each anchor moves toward its particle by `dt /
/// sleep_time` of the way (an average over about `sleep_time`), and the watch goes on
/// while every particle is near its anchor and starts over where one is not; in any other
/// step the watch starts over with the anchors where the particles are. A strand that
/// falls asleep keeps no velocity.
///
/// Anchors that follow the strand's average find the middle of a contact's cycle or a
/// sway, which an anchor left where the watch began, at one end of it, never did; a
/// strand creeping on stays as far behind its anchor as before (`sleep_distance` over
/// `sleep_time`, 6 mm/s by default, puts it to sleep).
pub(crate) fn watch(
    watch: &mut SleepWatch,
    anchors: &mut [Vec3],
    positions: &[Vec3],
    velocities: &mut [Vec3],
    stillness: Stillness,
    p: &SimParams,
    dt: f32,
) {
    if !(stillness.still && stillness.key == watch.key) {
        *watch = SleepWatch { quiet: 0.0, key: stillness.key };
        anchors.copy_from_slice(positions);
        return;
    }
    let follow = dt / p.sleep_time.max(dt);
    let limit = p.sleep_distance * p.sleep_distance;
    let mut near = true;
    for (a, &x) in anchors.iter_mut().zip(positions) {
        *a += (x - *a) * follow;
        near &= x.distance_squared(*a) <= limit;
    }
    if near {
        watch.quiet += dt;
        if asleep(watch, p) {
            velocities.fill(Vec3::ZERO);
        }
    } else {
        watch.quiet = 0.0;
    }
}

/// How far a sleeping strand's root may be from where the head puts it: the head's pose
/// as the strand fell asleep, composed again, may round differently.
const ROOT_TOLERANCE: f32 = 1e-6;

#[cfg(test)]
mod tests {
    use super::*;

    /// A strand of two particles, its root at the origin, its tip where `tip` says at step
    /// `k` of 1/60 s under `stillness(k)`: the step at which it falls asleep (`None` within
    /// 10 s) and its anchors then.
    fn watched(stillness: impl Fn(usize) -> Stillness, tip: impl Fn(usize) -> Vec3) -> (Option<usize>, [Vec3; 2]) {
        let p = SimParams::default();
        let (mut sleep, mut anchors, mut velocities) = (SleepWatch::default(), [Vec3::ZERO; 2], [Vec3::X; 2]);
        for k in 0..600 {
            watch(&mut sleep, &mut anchors, &[Vec3::ZERO, tip(k)], &mut velocities, stillness(k), &p, 1.0 / 60.0);
            if asleep(&sleep, &p) {
                assert_eq!(velocities, [Vec3::ZERO; 2], "asleep, motionless");
                return (Some(k), anchors);
            }
        }
        (None, anchors)
    }

    /// Still, under the same settings throughout.
    fn still(_: usize) -> Stillness {
        Stillness { still: true, key: 1 }
    }

    /// The tip `at` metres along x from its start at step `k`.
    fn tip_at(at: impl Fn(usize) -> f32) -> impl Fn(usize) -> Vec3 {
        move |k| Vec3::new(0.2 + at(k), 0.0, 0.0)
    }

    /// A strand stepping between two places (a contact's cycle) or swaying about one falls
    /// asleep within 2 s where its particles stay within `sleep_distance` of their middle:
    /// two places up to nearly twice `sleep_distance` apart, its anchor between them. An
    /// anchor left at one end never let them sleep. Further apart, or swaying wider, or
    /// creeping on at 1 cm/s, it never does; at rest it sleeps after `sleep_time`.
    #[test]
    fn a_strand_cycling_about_a_place_sleeps_watched_from_its_middle() {
        let d = SimParams::default().sleep_distance;
        let between = |apart: f32| tip_at(move |k| apart * (k % 2) as f32);
        let sway = |across: f32| tip_at(move |k| 0.5 * across * (k as f32 * 0.2).sin());
        let (steps, anchors) = watched(still, between(1.8 * d));
        assert!(steps.is_some_and(|k| k < 120), "stepping 1.8 sleep distances: asleep after {steps:?} steps");
        assert!((anchors[1].x - (0.2 + 0.9 * d)).abs() < 0.1 * d, "watched from {} m", anchors[1].x - 0.2);
        let (steps, _) = watched(still, sway(1.8 * d));
        assert!(steps.is_some_and(|k| k < 120), "swaying 1.8 sleep distances: asleep after {steps:?} steps");
        // The first step begins the watch (its settings are new), the next 30 make 0.5 s.
        assert_eq!(watched(still, tip_at(|_| 0.0)).0, Some(30), "at rest: asleep after the sleep time");
        assert_eq!(watched(still, between(2.2 * d)).0, None, "asleep stepping 2.2 sleep distances");
        assert_eq!(watched(still, sway(2.2 * d)).0, None, "asleep swaying 2.2 sleep distances");
        assert_eq!(watched(still, tip_at(|k| 0.01 * k as f32 / 60.0)).0, None, "asleep creeping at 1 cm/s");
    }

    /// Under a moving head, or settings that change from step to step, a strand never
    /// sleeps and its watch starts over from where it is: its anchors are where it ended.
    #[test]
    fn a_strand_the_head_moves_is_watched_from_where_it_is() {
        let d = SimParams::default().sleep_distance;
        let tip = tip_at(move |k| 1.5 * d * (k % 2) as f32);
        let moving = |_| Stillness { still: false, key: 1 };
        let new_settings = |k: usize| Stillness { still: true, key: k as u64 + 1 };
        for (what, stillness) in [("moving", &moving as &dyn Fn(usize) -> Stillness), ("new settings", &new_settings)] {
            let (steps, anchors) = watched(stillness, &tip);
            assert_eq!(steps, None, "{what}: asleep");
            assert_eq!(anchors[1], tip(599), "{what}: watched from {}", anchors[1]);
        }
    }
}
