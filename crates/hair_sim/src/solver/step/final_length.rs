//! The final length pass after collision, which never moves a particle back inside.
//! GPU twin: `hair_gpu`'s `step/final_length.wgsl`.

use super::contacts::FRICTION_SLACK;
use super::segments::{around, sphere_nearest};
use super::{GroupState, SubstepPoses};
use crate::collide::{Contact, ContactHint};
use crate::math::Vec3;
use crate::solver::lanes::{MAX_LANES, Mask, Simd, Wide};
use crate::solver::params::{LengthMode, SimParams};
use crate::solver::{ChunkState, StepInput, StepReport};

/// How many times [`outside_at_length`] turns one segment before collision simply wins.
pub(super) const MAX_TURNS: usize = 4;

/// The final length pass may move a particle by this share of the thickness unchecked: with
/// [`FRICTION_SLACK`] it adds up to the whole thickness, so the particle cannot reach the
/// surface.
pub(super) const LENGTH_SLACK: f32 = 1.0 - FRICTION_SLACK;

/// How far the final length pass may move a particle that touched the head this substep
/// unchecked, m. Such a particle lies on the shell; moved into it by the full
/// [`LENGTH_SLACK`], a little more each step, a strand bent over an ear's rim or the jaw's
/// edge crept in until its segment crossed and was turned out again, over and over.
#[inline(always)]
pub(super) fn contact_margin(p: &SimParams) -> f32 {
    CONTACT_SLACK * p.collision_thickness
}

/// [`contact_margin`] as a share of the collision thickness.
pub(super) const CONTACT_SLACK: f32 = 0.1;

/// Redoes the final length pass, one lane at a time, from the first particle it moved by
/// more than [`LENGTH_SLACK`] of the collision thickness ([`contact_margin`] for one that
/// touched the head): only those can have gone back
/// inside, because collision left every particle at least `(1 - FRICTION_SLACK) ×
/// thickness` above every surface. From there, each particle is placed as the length pass
/// places it (the same rule, one lane at a time) and, if that is inside a collider, its
/// segment is turned about its parent until it is out ([`outside_at_length`]).
#[inline(always)]
pub(super) fn keep_outside<S: Simd>(
    g: &mut GroupState<S>,
    state: &mut ChunkState,
    p: &SimParams,
    poses: &SubstepPoses<S>,
    input: &StepInput,
    report: &mut StepReport,
) {
    let n = g.positions.len();
    let (margin, touching) = (Wide::splat(LENGTH_SLACK * p.collision_thickness), Wide::splat(contact_margin(p)));
    // Per lane, the first particle moved too far (n: none).
    let mut first = [n; MAX_LANES];
    let mut pending = g.real_lanes();
    for j in 1..n {
        if pending == 0 {
            break;
        }
        let margin = Wide::select(Mask::from_bits(g.moved[j]), touching, margin);
        let far = (g.positions[j] - g.collided[j]).length().cmpgt(margin).bitmask() & pending;
        for l in (0..Wide::<S>::LANES).filter(|&l| far & (1 << l) != 0) {
            first[l] = j;
        }
        pending &= !far;
    }
    for l in (0..g.lanes).filter(|&l| first[l] < n) {
        place_outside(g, state, p, poses, input, report, l, first[l], false);
    }
}

/// The final length pass of lane `l` from particle `from` to the tip, each particle where
/// collision put it (`g.collided`) brought to its segment's length from its (already
/// placed) parent and, if that is inside a collider or its shell, turned about the parent
/// until it is out ([`outside_at_length`]). Unless `verify`, `g.collided` is known to be
/// outside, and only particles moved further than [`LENGTH_SLACK`] from it are tested.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn place_outside<S: Simd>(
    g: &mut GroupState<S>,
    state: &mut ChunkState,
    p: &SimParams,
    poses: &SubstepPoses<S>,
    input: &StepInput,
    report: &mut StepReport,
    l: usize,
    from: usize,
    verify: bool,
) {
    let n = g.positions.len();
    let margin = LENGTH_SLACK * p.collision_thickness;
    let down = Vec3::NEG_Y;
    let hints = &mut state.hints[g.strands[l] * n..][..n];
    let mut parent = g.positions[from - 1].lane(l);
    for (j, hint) in hints.iter_mut().enumerate().skip(from) {
        let collided = g.collided[j].lane(l);
        let rest_length = g.lengths[j].get(l);
        let towards = collided - parent;
        let length = match p.length_mode {
            LengthMode::Inextensible => rest_length,
            LengthMode::Springs => {
                let tolerance = p.length_tolerance;
                towards.length().clamp(rest_length * (1.0 - tolerance), rest_length * (1.0 + tolerance))
            }
        };
        let mut placed = parent + towards.normalize_or(down) * length;
        let margin = if g.moved[j] & (1 << l) != 0 { contact_margin(p) } else { margin };
        if verify || (placed - collided).length() > margin {
            let clear = |x: Vec3| {
                let local = |x: Vec3| poses.now_one.local_point(x);
                input.collider.is_none_or(|c| c.segment_crossing(local(parent), local(x)).is_none())
            };
            let contact = |x| contact_at(x, p, poses, input, hint);
            let (outside, kept_length) =
                outside_at_length(placed, parent, length, p.collision_thickness, contact, clear);
            placed = outside;
            report.contact_stretches += u32::from(!kept_length);
        }
        set_final(g, p, l, j, placed);
        parent = placed;
    }
}

/// Moves particle `j` of lane `l` to `placed` in the final pass; FTL's velocity correction
/// counts the move.
#[inline(always)]
pub(super) fn set_final<S: Simd>(g: &mut GroupState<S>, p: &SimParams, l: usize, j: usize, placed: Vec3) {
    if p.length_mode == LengthMode::Inextensible {
        let length_pass_placed = g.positions[j].lane(l);
        let correction = g.ftl_correction[j].lane(l) + (placed - length_pass_placed);
        g.ftl_correction[j].set_lane(l, correction);
    }
    g.positions[j].set_lane(l, placed);
}

/// The deepest contact at world point `x` with anything: the head as baked or the skin that
/// moved against it, else an extra collider. Along the normal whatever the response:
/// turning a segment onto the tangent plane needs the plane.
#[inline(always)]
pub(super) fn contact_at<S: Simd>(
    x: Vec3,
    p: &SimParams,
    poses: &SubstepPoses<S>,
    input: &StepInput,
    hint: &mut ContactHint,
) -> Option<Contact> {
    let local = poses.now_one.local_point(x);
    let baked = input.collider.and_then(|c| c.resolve_hinted(local, p.collision_thickness, hint));
    let moved = input.surface_patch.and_then(|patch| patch.resolve(local, p.collision_thickness));
    let head = match (baked, moved) {
        (Some(b), Some(m)) => Some(if m.depth > b.depth { m } else { b }),
        (b, m) => b.or(m),
    };
    let head = head.map(|c| poses.now_one.world_contact(c));
    head.or_else(|| input.extra_colliders.iter().find_map(|e| e.resolve(x, p.collision_thickness)))
}

/// Where to put a particle that should sit `length` from `parent` (itself outside) but is
/// within `thickness` of a collider at `placed`: the segment turns about the parent, toward
/// the contact's normal, until the particle lies on the tangent plane of the collider's
/// thickness shell at the contact; on a curved surface that may take a few turns. Where the
/// parent lies behind that plane (the contact is on another face, around an ear), the
/// segment points straight out along the contact's normal instead. Returns the position
/// and whether the length was kept.
///
/// Where no turn clears the shell within [`MAX_TURNS`] (a crease tighter than the segment,
/// or a shell thicker than it), the length wins over the shell but not over the surface:
/// the particle stays where the last turn put it if that is outside the collider itself,
/// else goes to the nearest direction [`around`] the contact's normal that is outside it
/// and that the segment `reaches` without passing through the head, else to the nearest
/// that is outside it at all, else the same over the whole sphere ([`sphere_nearest`]), and
/// only where none is goes onto the surface, stretching the segment.
pub(super) fn outside_at_length(
    mut placed: Vec3,
    parent: Vec3,
    length: f32,
    thickness: f32,
    mut contact_at: impl FnMut(Vec3) -> Option<Contact>,
    reaches: impl Fn(Vec3) -> bool,
) -> (Vec3, bool) {
    for _ in 0..MAX_TURNS {
        let Some(contact) = contact_at(placed) else { return (placed, true) };
        let normal = contact.normal;
        let direction = (placed - parent) / length;
        // The lowest the segment may point along the normal: onto the plane (1 µm above, so
        // the next query does not read it as touching).
        let lowest = (normal.dot(contact.position - parent) + 1e-6) / length;
        let along = normal.dot(direction);
        if !(lowest < 1.0 && lowest > along) {
            // The contact is on another face than the parent sees (around an ear), or the
            // shell is out of reach: point the segment straight out, and look again.
            placed = parent + normal * length;
            continue;
        }
        let across = (direction - normal * along).try_normalize().unwrap_or_else(|| normal.any_orthonormal_vector());
        placed = parent + (normal * lowest + across * (1.0 - lowest * lowest).sqrt()) * length;
    }
    // Inside the shell, outside the collider: keep the length.
    let outside = |contact: &Option<Contact>| contact.is_none_or(|c| c.depth <= thickness);
    let Some(deep) = contact_at(placed).filter(|c| c.depth > thickness) else { return (placed, true) };
    // Inside the collider, in a crease tighter than the segment: another direction at full
    // length that is out of it (and reached without passing through it), nearest the one
    // the turns arrived at; failing that, one out of it that the segment reaches only
    // through a thin part (the segment pass turns it out of that; stretched onto the
    // surface instead, a strand below an ear's rim was left half as long again). Around the
    // contact's normal first, then, where the whole of that half of space is inside (the
    // contact is on the far side of a nose or a cheek from the parent), over the sphere.
    // Failing all, onto its surface (1 µm out), stretching the segment.
    let wanted = (placed - parent) / length;
    let mut out_of_it = |directions: &mut dyn Iterator<Item = Vec3>| {
        let mut outside_only = None;
        for x in directions.map(|d| parent + d * length) {
            if outside(&contact_at(x)) {
                if reaches(x) {
                    return Some(x);
                }
                outside_only.get_or_insert(x);
            }
        }
        outside_only
    };
    match out_of_it(&mut around(deep.normal, wanted)).or_else(|| out_of_it(&mut sphere_nearest(wanted))) {
        Some(x) => (x, true),
        None => (deep.position - deep.normal * (thickness - 1e-6), false),
    }
}
