//! Static friction for the spring model under a still head: a strand that the head's
//! touch left with more energy than it started the step with stays where it lay.
//! GPU twin: `hair_gpu`'s `step/contact_hold.wgsl`.
//!
//! Contacts are inelastic, but a strand's contacts and segment turns move it by more than
//! its speed says: a turn out of an ear's rim
//! ([`keep_segments_outside`](super::segments::keep_segments_outside)) lifts the
//! segment's end onto the rim, and a contact pushes a particle out, and gravity and the
//! springs spend that lift as speed. Follow-The-Leader's brake takes it out again. The
//! spring model has no brake: a strand hanging over an ear or the nape swung through the
//! rim and back for good, each turn or push adding more than the springs' damping took
//! out in between. In a still step (the head keeps its pose, no wind, no skin moving
//! against the head) under the extra colliders and settings of the step before, nothing
//! else feeds a strand energy, so a step that the head touched the strand in (a segment
//! turn, or a contact in the last substep) and that left it with more energy than it
//! started with is undone: the strand goes back to where it began, motionless, with the
//! spring model's memory started over there (BDF2 would throw it on with the speed it
//! remembers). It rests where the head holds it, as static friction would hold it, and
//! falls asleep: the same step comes again, and is undone again.

use super::{Constants, GroupState};
use crate::math::Vec3;
use crate::solver::lanes::{Simd, V3, Wide};
use crate::solver::params::LengthMode;
use crate::solver::{ChunkState, StepInput, Stillness};

/// Whether the step (of `stillness`) may hold strands: the spring model, collision with
/// the head, and a still step ([`Stillness::still`]).
pub(super) fn applies(input: &StepInput, stillness: Stillness) -> bool {
    let p = input.params;
    p.length_mode == LengthMode::Springs && p.collision && input.collider.is_some() && stillness.still
}

/// The lanes whose strands the step of stillness `key` may hold: those stepped under the
/// same extra colliders and settings before, as their sleep watch says (a moved collider
/// feeds energy too), which a strand started over at rest has not.
#[inline(always)]
pub(super) fn lanes_under<S: Simd>(g: &GroupState<S>, state: &ChunkState, key: u64) -> u64 {
    (0..g.lanes).filter(|&l| state.sleep[g.strands[l]].key == key).fold(0, |lanes, l| lanes | 1 << l)
}

/// Each lane's energy per unit mass in its motion and its springs' stretch: at the step's
/// start, what [`hold_where_touches_gained`] compares with. (Its height enters as the fall
/// since then.)
#[inline(always)]
pub(super) fn motion_and_stretch<S: Simd>(g: &GroupState<S>, c: &Constants<S>, particle_mass: f32) -> Wide<S> {
    let stiffness_per_mass = c.spring_k * Wide::splat(1.0 / particle_mass);
    let half = Wide::splat(0.5);
    let mut energy = Wide::zero();
    for j in 1..g.positions.len() {
        let stretch = (g.positions[j] - g.positions[j - 1]).length() - g.lengths[j];
        let v = g.velocities[j];
        energy = energy + half * (v.dot(v) + stiffness_per_mass * stretch * stretch);
    }
    energy
}

/// Puts the strands of `lanes` that the head touched in the step and that it left with more
/// energy than they started with (`start`, [`motion_and_stretch`] then) back where they
/// lay at the step's start, motionless, with the spring model's memory started over there.
#[inline(always)]
pub(super) fn hold_where_touches_gained<S: Simd>(
    g: &mut GroupState<S>,
    c: &Constants<S>,
    input: &StepInput,
    lanes: u64,
    start: Wide<S>,
) {
    let n = g.positions.len();
    let touched = g.moved[1..].iter().fold(g.turned_lanes, |touched, &moved| touched | moved) & lanes;
    if touched == 0 {
        return;
    }
    let gravity = V3::splat(Vec3::from_array(input.params.gravity));
    // Height as the work gravity did since the step's start: a difference of small moves
    // keeps what heights of a metre would round away.
    let mut fall = Wide::zero();
    for j in 1..n {
        fall = fall + gravity.dot(g.positions[j] - g.step_start[j]);
    }
    let end = motion_and_stretch(g, c, input.params.particle_mass) - fall;
    let gained = end.cmpgt(start).bitmask() & touched;
    for l in (0..g.lanes).filter(|&l| gained & (1 << l) != 0) {
        for j in 1..n {
            let x = g.step_start[j].lane(l);
            g.positions[j].set_lane(l, x);
            g.velocities[j].set_lane(l, Vec3::ZERO);
            g.previous_positions[j].set_lane(l, x);
            g.previous_velocities[j].set_lane(l, Vec3::ZERO);
        }
    }
}
