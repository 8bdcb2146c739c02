//! Whole segments kept out of the thin parts of the head (an ear's rim).
//! GPU twin: `hair_gpu`'s `step/segments.wgsl`.

use super::final_length::{MAX_TURNS, contact_at, place_outside, set_final};
use super::{GroupState, PoseMatrix, SubstepPoses};
use crate::collide::{ContactHint, HeadCollider};
use crate::math::Vec3;
use crate::solver::lanes::{Mask, Simd, V3, Wide};
use crate::solver::params::SimParams;
use crate::solver::{ChunkState, StepInput, StepReport};

/// How far outside the surface [`turn_out_of`] lifts the middle of a segment's crossed
/// stretch, m: just clear of it. Lifted onto the particles' collision shell, a segment
/// resting on an ear's rim rose further than gravity brings it back in a step, and fell
/// through the rim again a few steps later, over and over.
pub(super) const SEGMENT_CLEARANCE: f32 = 1e-4;

/// Segments whose two ends are outside can still cut through a thin part of the head
/// between them (an ear's rim). A segment may reach the head only where its ends' clear
/// balls (what collision left them, [`GroupState::clearance`], less how far the final pass
/// moved them) do not cover it, and the lower end clears less than the surface can rise
/// under it ([`HeadCollider::rise_under`]); on a skull neither happens, so the test runs a
/// lane-wide sum and one table lookup per segment. What remains is tested exactly
/// ([`HeadCollider::segment_crossing`]: by a sharp feature, against the triangles listed
/// in reach; elsewhere, a ray through the BVH). Where it crosses, it turns about its
/// parent until the middle of the crossed stretch is just outside the surface (a few
/// turns at most), or under a still head back to where it lay ([`rest_on_rim`]); the strand
/// below follows it as a leader, and the final pass places the rest outside from there
/// ([`place_outside`]).
#[inline(always)]
pub(super) fn keep_segments_outside<S: Simd>(
    g: &mut GroupState<S>,
    state: &mut ChunkState,
    p: &SimParams,
    poses: &SubstepPoses<S>,
    input: &StepInput,
    report: &mut StepReport,
) {
    let Some(collider) = input.collider else { return };
    let head_still = input.head_from == input.head_to;
    let n = g.positions.len();
    let real_lanes = g.real_lanes();
    // Lanes whose particles from here on were moved by a turn: their clearance is unknown
    // (none yet: this pass runs once a step, on its last substep).
    debug_assert_eq!(g.turned_lanes, 0, "a step's first turns");
    // What collision knew, less how far the final pass moved each particle since.
    for j in 1..n {
        g.clearance[j] = (g.clearance[j] - (g.positions[j] - g.collided[j]).length()).max(Wide::zero());
    }
    let cells = collider.rise_cells();
    let (origin, inverse_cell, last) =
        (V3::splat(cells.origin), Wide::splat(cells.inverse_cell), V3::splat(cells.last));
    for j in 2..n {
        let length = (g.positions[j] - g.positions[j - 1]).length();
        let turned = Mask::from_bits(g.turned_lanes);
        let clear_parent = Wide::select(turned, Wide::zero(), g.clearance[j - 1]);
        let clear_child = Wide::select(turned, Wide::zero(), g.clearance[j]);
        // Every point of the segment is within `length` of an end together.
        let uncovered = !(clear_parent + clear_child).cmpgt(length).bitmask() & real_lanes;
        if uncovered == 0 {
            continue;
        }
        let lowest = clear_parent.min(clear_child);
        let middle = poses.now.local_point((g.positions[j - 1] + g.positions[j]) * Wide::splat(0.5));
        let cell = ((middle - origin) * inverse_cell).max(V3::zero()).min(last);
        for l in (0..g.lanes).filter(|&l| uncovered & (1 << l) != 0) {
            if lowest.get(l) > collider.rise_in_cell(cell.lane(l), length.get(l)) {
                continue;
            }
            let (parent, child, length) = (g.positions[j - 1].lane(l), g.positions[j].lane(l), length.get(l));
            let (local_parent, local_child) = (poses.now_one.local_point(parent), poses.now_one.local_point(child));
            let local_turned = turn_out_of(collider, local_parent, local_child, length);
            if local_turned == local_child {
                continue;
            }
            let local_turned = if head_still {
                let lay = (g.step_start[j - 1].lane(l), g.step_start[j].lane(l));
                rest_on_rim(collider, poses.step_start, lay, local_parent, local_turned, length)
            } else {
                local_turned
            };
            // Only the turn's direction comes back from head-local space, where a mesh far
            // from its own origin leaves coordinates of many metres: the particle is placed
            // at the segment's length from its parent in the solver's space.
            let direction = poses.now_one.rotate((local_turned - local_parent).normalize_or(Vec3::Y));
            let turned = parent + direction * length;
            // The strand below follows the turned particle as a leader: each particle is
            // drawn toward where it was, then placed outside.
            for k in j + 1..n {
                let was = g.positions[k].lane(l);
                g.collided[k].set_lane(l, was);
            }
            g.collided[j].set_lane(l, turned);
            report.segment_turns += 1;
            g.turned_lanes |= 1 << l;
            place_outside(g, state, p, poses, input, report, l, j, true);
            // Placing the particle on the shell turns the segment once more, which can take
            // it back through (a fold of the surface): there, the turned segment stands (its
            // end is outside the head, if within the shell) and the rest is placed from it,
            // unless the turned end is inside something the turn did not see (the skin
            // that moved against the baked head): a particle inside weighs more than a
            // segment through.
            let placed = poses.now_one.local_point(g.positions[j].lane(l));
            let outside = |x| {
                let mut hint = ContactHint::NONE;
                contact_at(x, p, poses, input, &mut hint).is_none_or(|c| c.depth <= p.collision_thickness)
            };
            if placed != local_turned && collider.segment_crossing(local_parent, placed).is_some() && outside(turned) {
                set_final(g, p, l, j, turned);
                place_outside(g, state, p, poses, input, report, l, j + 1, true);
            }
        }
    }
}

/// Where a segment turned out of the head to `turned` (head-local, `length` from `parent`)
/// goes instead: back to the direction it had at the step's start (`lay`, its two ends in
/// the solver's space under the head's pose then, `step_start`), if that crosses nothing
/// and lies within [`RIM_REST_REACH`] of the turn; else `turned`.
///
/// Asked only where the head kept its pose through the step: a segment draped over an
/// ear's rim rests there, as static friction holds it. Turned anew each step, it cycled
/// under a still head: gravity brings it back through the rim, and the turn, which lifts
/// the middle of the crossed stretch onto the surface, lands a few millimetres from the
/// last one (the nearest face of a thin part changes with the smallest move). Under a
/// moving head the turn stands: resting where it lay stretched whipped hair past its bound.
pub(super) fn rest_on_rim(
    collider: &HeadCollider,
    step_start: &PoseMatrix,
    lay: (Vec3, Vec3),
    parent: Vec3,
    turned: Vec3,
    length: f32,
) -> Vec3 {
    let direction = step_start.local_point(lay.1) - step_start.local_point(lay.0);
    let rested = parent + direction.normalize_or(Vec3::Y) * length;
    if rested.distance(turned) < RIM_REST_REACH && collider.segment_crossing(parent, rested).is_none() {
        rested
    } else {
        turned
    }
}

/// How far from where a segment lay the turn out of a thin part may put its end for the
/// segment to go back there instead ([`rest_on_rim`]), m: more than gravity moves it in a
/// step at rest, less than a strand swinging past the rim does.
pub(super) const RIM_REST_REACH: f32 = 1e-2;

/// Where to put `child` (head-local, `length` from `parent`) so that the segment between
/// them no longer runs through the head: turned about the parent until the middle of the
/// crossed stretch is just outside the surface ([`SEGMENT_CLEARANCE`]), a few turns at most. Where that does not
/// clear it (a fold of the surface, an ear's rim seen edge-on), the segment turns toward
/// the surface's normal at the parent instead, as little as bisection finds enough.
/// Returns `child` itself when the segment crosses nothing.
pub(super) fn turn_out_of(collider: &HeadCollider, parent: Vec3, child: Vec3, length: f32) -> Vec3 {
    let mut turned = child;
    for _ in 0..MAX_TURNS {
        let Some((enters, leaves)) = collider.segment_crossing(parent, turned) else { return turned };
        // The middle of the stretch inside, out onto the shell.
        let inside = parent + (turned - parent) * (0.5 * (enters + leaves) / length.max(1e-9));
        let mut hint = ContactHint::NONE;
        let Some(contact) = collider.resolve_hinted(inside, SEGMENT_CLEARANCE, &mut hint) else { break };
        turned = parent + (contact.position - parent).normalize_or(Vec3::Y) * length;
    }
    if collider.segment_crossing(parent, turned).is_none() {
        return turned;
    }
    // The parent is outside, so within `length` of the surface a contact that reaches that
    // far has the outward normal nearest it.
    let mut hint = ContactHint::NONE;
    let Some(out) = collider.resolve_hinted(parent, length, &mut hint).map(|c| c.normal) else { return turned };
    let mut crossing = (turned - parent) / length;
    let Some(mut clear) = clear_direction(collider, parent, out, crossing, length) else { return turned };
    for _ in 0..BISECTIONS {
        let middle = (crossing + clear).normalize_or(clear);
        if collider.segment_crossing(parent, parent + middle * length).is_some() {
            crossing = middle;
        } else {
            clear = middle;
        }
    }
    parent + clear * length
}

/// A direction from `parent` in which a segment of `length` crosses nothing: `out` itself,
/// or else the nearest to `wanted` of [`around`] it, where a fold of the surface stands in
/// the way of `out`, or else, in a pocket of the surface (an eye socket) where all of
/// those cross, the nearest to `wanted` of [`SPHERE_DIRECTIONS`] spread over all of space.
pub(super) fn clear_direction(
    collider: &HeadCollider,
    parent: Vec3,
    out: Vec3,
    wanted: Vec3,
    length: f32,
) -> Option<Vec3> {
    let clear = |d: &Vec3| collider.segment_crossing(parent, parent + *d * length).is_none();
    around(out, wanted).find(clear).or_else(|| sphere_nearest(wanted).find(clear))
}

/// The [`SPHERE_DIRECTIONS`], nearest to `wanted` first: the last resort of a search for a
/// way out of a pocket of the surface.
pub(super) fn sphere_nearest(wanted: Vec3) -> impl Iterator<Item = Vec3> {
    let mut sphere: Vec<Vec3> = (0..SPHERE_DIRECTIONS).map(sphere_direction).collect();
    sphere.sort_by(|a, b| b.dot(wanted).total_cmp(&a.dot(wanted)));
    sphere.into_iter()
}

/// How many directions [`clear_direction`] and the final length pass try over the whole
/// sphere as their last resort.
pub(super) const SPHERE_DIRECTIONS: usize = 96;

/// The `k`-th of [`SPHERE_DIRECTIONS`] unit vectors spread evenly over the sphere (a
/// Fibonacci lattice).
pub(super) fn sphere_direction(k: usize) -> Vec3 {
    let golden_angle = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let y = 1.0 - 2.0 * (k as f32 + 0.5) / SPHERE_DIRECTIONS as f32;
    let radius = (1.0 - y * y).sqrt();
    let (sin, cos) = (golden_angle * k as f32).sin_cos();
    Vec3::new(radius * cos, y, radius * sin)
}

/// `out` and the directions tilted from it by 30°, 60° and 90° (eight around each), the
/// tilted ones nearest `wanted` first.
pub(super) fn around(out: Vec3, wanted: Vec3) -> impl Iterator<Item = Vec3> {
    let (u, v) = out.any_orthonormal_pair();
    let mut tilted: Vec<Vec3> = [30f32, 60.0, 90.0]
        .into_iter()
        .flat_map(|tilt| {
            let (sin_tilt, cos_tilt) = tilt.to_radians().sin_cos();
            (0..8).map(move |k| {
                let (sin_around, cos_around) = (k as f32 * std::f32::consts::FRAC_PI_4).sin_cos();
                out * cos_tilt + (u * cos_around + v * sin_around) * sin_tilt
            })
        })
        .collect();
    tilted.sort_by(|a, b| b.dot(wanted).total_cmp(&a.dot(wanted)));
    std::iter::once(out).chain(tilted)
}

/// Halvings of the angle between a crossing direction and a clear one in [`turn_out_of`].
pub(super) const BISECTIONS: usize = 5;
