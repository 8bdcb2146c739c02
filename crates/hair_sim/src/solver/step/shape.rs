//! Shape keeping (global and local) and the length constraints.
//! GPU twin: `move_strand`, `bend` and `place_shaped` in `hair_gpu`'s `step/substep.wgsl`.

use super::GroupState;
use crate::math::Vec3;
use crate::solver::lanes::{M3, PoseLanes, Simd, V3, Wide};
use crate::solver::params::{LengthMode, SimParams};

/// The length constraint of `p.length_mode`.
#[inline(always)]
pub(super) fn length_pass<S: Simd>(g: &mut GroupState<S>, p: &SimParams) {
    match p.length_mode {
        LengthMode::Inextensible => follow_the_leader(g),
        LengthMode::Springs => clamp_lengths(g, p.length_tolerance),
    }
}

/// Pulls each particle toward the rest pose carried by the head, by `alpha[j]`.
#[inline(always)]
pub(super) fn global_shape<S: Simd>(g: &mut GroupState<S>, alpha: &[f32], pose: &PoseLanes<S>) {
    for ((x, &rest), &alpha) in g.positions.iter_mut().zip(&g.rest_positions).zip(alpha).skip(1) {
        if alpha > 0.0 {
            *x = *x + (pose.world_point(rest) - *x) * Wide::splat(alpha);
        }
    }
}

/// Turns each segment toward its rest direction in its parent segment's frame, as a bend
/// of the joint between the two: the segment turns about its parent particle, keeping its
/// length, and the parent segment turns back about the same particle (the joint's
/// reaction), so a bend moves neither the strand's centre nor its spin. Without the
/// reaction the pull is a follower force, which feeds energy into a hanging strand: under a
/// still head the hair would never come to rest, and at 8 substeps it would swing by
/// centimetres a step.
///
/// The frame starts as the head-carried root frame; each segment's deviation from where
/// its parent expected it rotates the frame handed to its child, so a bent strand keeps
/// its curl relative to the bend instead of snapping back to the head's orientation.
#[inline(always)]
pub(super) fn local_shape<S: Simd>(g: &mut GroupState<S>, alpha: f32, root_frame: M3<S>) {
    let alpha = Wide::splat(alpha);
    let mut frame = root_frame;
    for j in 1..g.positions.len() {
        // Unit, so the arc below is a rotation: from a frame scaled by s it would build a
        // matrix scaled by s again, and the rounding would square itself segment by
        // segment until a long strand's tip frame overflows.
        let expected = frame.mul_vec(g.rest_directions[j]).normalize_or(g.rest_directions[j]);
        let parent = g.positions[j - 1];
        let segment = g.positions[j] - parent;
        let direction = segment.normalize_or(expected);
        let turned = (direction + (expected - direction) * alpha).normalize_or(expected);
        let turn = parent + turned * segment.length() - g.positions[j];
        if j == 1 {
            // The root's frame is the head's: the head takes the reaction.
            g.positions[1] += turn;
        } else {
            let [grandparent, parent, child] = bend(g, j, turn);
            g.positions[j - 2] += grandparent;
            g.positions[j - 1] += parent;
            g.positions[j] += child;
        }
        let actual = (g.positions[j] - g.positions[j - 1]).normalize_or(expected);
        frame = M3::rotation_arc(expected, actual).mul_mat(&frame);
    }
}

/// The moves of particles `j − 2`, `j − 1` and `j` (equal masses, the root not moving)
/// that take the joint at `j − 1` as far toward its rest bend as moving particle `j` by
/// `turn` alone would: position-based dynamics' projection of the joint's angle. Particle
/// `j` moves along `turn`, `j − 2` so that the parent segment takes the opposite torque
/// about `j − 1`, and `j − 1` against both, so that the three keep their momentum.
#[inline(always)]
pub(super) fn bend<S: Simd>(g: &GroupState<S>, j: usize, turn: V3<S>) -> [V3<S>; 3] {
    let (child_length, parent_length) = (g.lengths[j], g.lengths[j - 1]);
    let (x, parent, grandparent) = (g.positions[j], g.positions[j - 1], g.positions[j - 2]);
    // The grandparent's move that turns the parent segment (`grandparent − parent`)
    // with the torque that `turn` puts on the child segment, reversed.
    let parent_segment = parent - grandparent;
    let torque = (x - parent).cross(turn);
    let reaction = torque.cross(parent_segment) * (parent_length * parent_length).recip();
    // The projection's share for each: the joint angle's gradient with respect to each
    // particle is 1/length of the segments the particle ends, over its weight.
    let grandparent_weight = if j == 2 { Wide::zero() } else { Wide::one() };
    let ratio = child_length * parent_length.recip();
    let share =
        (Wide::one() + ratio * ratio * grandparent_weight + (Wide::one() + ratio) * (Wide::one() + ratio)).recip();
    let (child, grandparent) = (turn * share, reaction * (share * grandparent_weight));
    [grandparent, -(child + grandparent), child]
}

/// Follow-The-Leader: walk root → tip, putting each particle at rest length from its
/// parent. Records each particle's correction for Müller's velocity term.
#[inline(always)]
pub(super) fn follow_the_leader<S: Simd>(g: &mut GroupState<S>) {
    let down = V3::splat(Vec3::NEG_Y);
    for j in 1..g.positions.len() {
        let parent = g.positions[j - 1];
        let d = g.positions[j] - parent;
        let placed = parent + d.normalize_or(down) * g.lengths[j];
        g.ftl_correction[j] += placed - g.positions[j];
        g.positions[j] = placed;
    }
}

/// The reference's length constraint: no segment longer or shorter than `tolerance` ×
/// its rest length. Root → tip, so each fix rests on an already-fixed parent.
#[inline(always)]
pub(super) fn clamp_lengths<S: Simd>(g: &mut GroupState<S>, tolerance: f32) {
    let down = V3::splat(Vec3::NEG_Y);
    let (shortest, longest) = (Wide::splat(1.0 - tolerance), Wide::splat(1.0 + tolerance));
    for j in 1..g.positions.len() {
        let parent = g.positions[j - 1];
        let d = g.positions[j] - parent;
        let l = d.length();
        let clamped = l.clamp(g.lengths[j] * shortest, g.lengths[j] * longest);
        let moved = parent + d.normalize_or(down) * clamped;
        g.positions[j] = V3::select(clamped.cmpne(l), moved, g.positions[j]);
    }
}
