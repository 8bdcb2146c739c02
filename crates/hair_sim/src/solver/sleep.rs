//! Sleeping: a strand that has come to rest under a still head stops being stepped until
//! something that could move it changes, as bodies sleep in a rigid-body engine (avian's
//! `Sleeping`, Rapier's islands).
//!
//! Position-based hair never reaches an exact fixed point where contacts, friction and the
//! length pass disagree by a fraction of a substep's fall: a strand lying against the head
//! keeps stepping between a few places a hair's breadth apart. A strand whose every particle
//! stays within [`SimParams::sleep_distance`] of where it was for
//! [`SimParams::sleep_time`] is put to sleep where it is, with no velocity. It wakes when
//! the head moves, when its root is not where the head puts it, when the wind blows, when
//! the skin moves against the head, or when the settings or the extra colliders change.

use super::StepInput;
use super::params::SimParams;
use super::wind::is_calm;
use crate::math::Vec3;
use std::hash::{DefaultHasher, Hash, Hasher};

/// A strand's watch: how long it has stayed near its anchors (the positions it had when
/// the watch began), and the settings it has stayed under.
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

/// After a step of `dt` seconds in which the strand at `positions` was stepped: its watch
/// goes on while every particle stays near its anchor, under the same settings, in a still
/// step; else it starts over from here. A strand that falls asleep keeps no velocity.
pub(crate) fn watch(
    watch: &mut SleepWatch,
    anchors: &mut [Vec3],
    positions: &[Vec3],
    velocities: &mut [Vec3],
    stillness: Stillness,
    p: &SimParams,
    dt: f32,
) {
    let limit = p.sleep_distance * p.sleep_distance;
    let near = positions.iter().zip(anchors.iter()).all(|(x, a)| x.distance_squared(*a) <= limit);
    if stillness.still && stillness.key == watch.key && near {
        watch.quiet += dt;
        if asleep(watch, p) {
            velocities.fill(Vec3::ZERO);
        }
    } else {
        *watch = SleepWatch { quiet: 0.0, key: stillness.key };
        anchors.copy_from_slice(positions);
    }
}

/// How far a sleeping strand's root may be from where the head puts it: the head's pose
/// as the strand fell asleep, composed again, may round differently.
const ROOT_TOLERANCE: f32 = 1e-6;
