//! Collision of the particles with the head and the extra colliders, with friction.
//! GPU twin: `hair_gpu`'s `step/head.wgsl` (the contact) and `collide_particle` in
//! `step/substep.wgsl`.

use super::{Constants, GroupState, SubstepPoses};
use crate::collide::{Contact, ContactHint, HeadCollider, Resolution};
use crate::math::Vec3;
use crate::solver::lanes::{Mask, Simd, V3, Wide};
use crate::solver::params::SimParams;
use crate::solver::{ChunkState, StepInput, StepReport};

/// Moves particles out of the head and the extra colliders, with friction. Queries are
/// per particle (their paths differ), on the real lanes only.
#[inline(always)]
pub(super) fn collide<S: Simd>(
    g: &mut GroupState<S>,
    state: &mut ChunkState,
    p: &SimParams,
    c: &Constants<S>,
    poses: &SubstepPoses<S>,
    input: &StepInput,
    report: &mut StepReport,
) {
    let n = g.positions.len();
    let mut touch = |contact: &Contact| {
        report.contacts += 1;
        report.max_depth = report.max_depth.max(contact.depth);
    };
    if let Some(collider) = input.collider {
        // Into head space and back for all lanes at once; most particles touch nothing and
        // keep their position untouched.
        for (local, &x) in g.local.iter_mut().zip(&g.positions) {
            *local = poses.now.local_point(x);
        }
        g.moved.fill(0);
        // A particle without a contact is as far as the query proved (at least the
        // thickness); one with a contact is put there, less what friction slides it back
        // unchecked.
        let thickness = p.collision_thickness;
        g.clearance.fill(Wide::splat(thickness));
        // The queries, strand by strand (neighbouring particles query neighbouring cells
        // and triangles, and each particle's path differs): where each contact pushes.
        for l in 0..g.lanes {
            let hints = &mut state.hints[g.strands[l] * n..][..n];
            for (j, hint) in hints.iter_mut().enumerate().skip(1) {
                match crease_contact(collider, g.local[j].lane(l), thickness, c.shared.ray_from, hint) {
                    Resolution::Contact(contact) => {
                        g.pushed[j].set_lane(l, contact.position);
                        g.normals[j].set_lane(l, contact.normal);
                        g.moved[j] |= 1 << l;
                        touch(&contact);
                    }
                    Resolution::Clear(distance) => g.clearance[j].set(l, distance),
                }
            }
        }
        // Friction ([`with_friction`]) on every contact of a particle index at once. It
        // acts on sliding relative to the head, so it compares in head space, and slides
        // back along the tangent plane, which in a hollow (by an ear) dips under the
        // surface: out again from there, one lane at a time, unless the slide is too short
        // to reach the surface ([`FRICTION_SLACK`]).
        let (friction, slack) = (Wide::splat(p.friction), Wide::splat(FRICTION_SLACK * thickness));
        for j in 1..n {
            let contacts = g.moved[j];
            if contacts == 0 {
                continue;
            }
            let (pushed, normal) = (g.pushed[j], g.normals[j]);
            let slide = pushed - poses.before_lanes.local_point(g.start[j]);
            let held = pushed - (slide - normal * slide.dot(normal)) * friction;
            let back = (held - pushed).length();
            let far = back.cmpgt(slack).bitmask() & contacts;
            let mask = Mask::from_bits(contacts);
            g.local[j] = V3::select(mask, held, g.local[j]);
            g.clearance[j] =
                Wide::select(Mask::from_bits(contacts & !far), Wide::splat(thickness) - back, g.clearance[j]);
            for l in (0..g.lanes).filter(|&l| far & (1 << l) != 0) {
                let hint = &mut state.hints[g.strands[l] * n + j];
                if let Resolution::Contact(again) =
                    head_contact(collider, held.lane(l), thickness, c.shared.ray_from, hint)
                {
                    g.local[j].set_lane(l, again.position);
                }
            }
        }
        // The skin that moved against the head's frame, as it is now.
        if let Some(patch) = input.surface_patch {
            for l in 0..g.lanes {
                for j in 1..n {
                    let Some(contact) = patch.resolve(g.local[j].lane(l), thickness) else { continue };
                    let local_start = poses.before.local_point(g.start[j].lane(l));
                    let pushed = with_friction(contact, local_start, p.friction);
                    let left = g.clearance[j].get(l) - (pushed - g.local[j].lane(l)).length();
                    g.clearance[j].set(l, left);
                    g.local[j].set_lane(l, pushed);
                    g.moved[j] |= 1 << l;
                    touch(&contact);
                }
            }
        }
        for ((x, &local), &moved) in g.positions.iter_mut().zip(&g.local).zip(&g.moved) {
            if moved != 0 {
                *x = V3::select(Mask::from_bits(moved), poses.now.world_point(local), *x);
            }
        }
    }
    if input.extra_colliders.is_empty() {
        return;
    }
    for j in 1..n {
        for l in 0..g.lanes {
            let before = g.positions[j].lane(l);
            let mut x = before;
            for extra in input.extra_colliders {
                if let Some(contact) = extra.resolve(x, p.collision_thickness) {
                    x = with_friction(contact, g.start[j].lane(l), p.friction);
                    // Spheres and capsules are convex: the tangent plane stays outside.
                    touch(&contact);
                }
            }
            if x != before {
                let left = g.clearance[j].get(l) - (x - before).length();
                g.clearance[j].set(l, left);
            }
            g.positions[j].set_lane(l, x);
        }
    }
}

/// The head's contact for a head-local point: pushed out along the ray from `ray_from`
/// ([`CollisionResponse::CentreRay`](crate::solver::CollisionResponse::CentreRay)), or else along the surface normal.
#[inline]
pub(super) fn head_contact(
    collider: &HeadCollider,
    x: Vec3,
    thickness: f32,
    ray_from: Option<Vec3>,
    hint: &mut ContactHint,
) -> Resolution {
    match ray_from {
        Some(from) => collider.resolve_measuring_along_ray(x, thickness, hint, from),
        None => collider.resolve_measuring(x, thickness, hint),
    }
}

/// The least depth, as a share of the thickness, at which [`crease_contact`] takes a second
/// face into account: the query answers points on the shell with depths of a few ulps.
pub(super) const CREASE_DEPTH: f32 = 1e-3;

/// The head's contact for a head-local point, as [`head_contact`], looked up again from
/// where it pushes to: in a crease (behind an ear, under the jaw) the push out of one face
/// can leave the particle inside the shell of the other, and a particle left there is
/// pushed out again next step and pulled back in by its segment, over and over. Where the
/// second query finds it within another face's shell, it goes where the two shells meet
/// (on both offset planes, the nearest such point to the first push), with the mean of the
/// two normals. The depth is the first query's: how far the particle had gone in.
#[inline(always)]
pub(super) fn crease_contact(
    collider: &HeadCollider,
    x: Vec3,
    thickness: f32,
    ray_from: Option<Vec3>,
    hint: &mut ContactHint,
) -> Resolution {
    let first = head_contact(collider, x, thickness, ray_from, hint);
    let Resolution::Contact(contact) = first else { return first };
    match head_contact(collider, contact.position, thickness, ray_from, hint) {
        Resolution::Contact(second) if second.depth > CREASE_DEPTH * thickness => {
            Resolution::Contact(between_shells(contact, second))
        }
        _ => first,
    }
}

/// Where the shells of two contacts meet: the point `first.position + α n₁ + β n₂` on both
/// offset planes (through each contact's position, along its normal), with the mean normal
/// and the first depth. Two faces nearly parallel meet nowhere near: the second contact.
#[inline(always)]
pub(super) fn between_shells(first: Contact, second: Contact) -> Contact {
    let (n1, n2) = (first.normal, second.normal);
    let c = n1.dot(n2);
    let sine_squared = 1.0 - c * c;
    // Written to take NaN as parallel too.
    if sine_squared.is_nan() || sine_squared <= 1e-4 {
        return Contact { depth: first.depth, ..second };
    }
    let beta = (second.position - first.position).dot(n2) / sine_squared;
    let position = first.position + (n2 - n1 * c) * beta;
    Contact { position, normal: (n1 + n2).normalize_or(n2), depth: first.depth }
}

/// Collision leaves a particle on (or beyond) its shell, `thickness` above the surface,
/// unless friction then slid it back along the tangent plane: by less than this share of
/// the thickness, that slide is not checked again.
pub(super) const FRICTION_SLACK: f32 = 0.25;

/// The contact position with a `friction` fraction of the tangential slide since `start`
/// taken back.
#[inline]
pub(super) fn with_friction(contact: Contact, start: Vec3, friction: f32) -> Vec3 {
    let slide = contact.position - start;
    let tangential = slide - contact.normal * slide.dot(contact.normal);
    contact.position - tangential * friction
}
