//! The reference mass-spring model, solved implicitly: one tension per segment.
//! GPU twin: `hair_gpu`'s `step/springs.wgsl`.

use super::{Constants, GroupState};
use crate::solver::lanes::{Mask, Simd, V3, Wide};
use crate::solver::params::SimParams;

/// The reference mass-spring model, `F_s = k_s (l − l0)` and `F_d = k_d (Δv · dir)`
/// along each segment, integrated implicitly so that any stiffness is stable: BDF2
/// (Choi & Ko 2002), which damps the modes a substep cannot resolve but keeps the slow
/// ones, with backward Euler for a lane's first substep or after the substep length
/// changed.
///
/// Both schemes are `v = v̂ + step · f(x)/m`, `x = x̂ + step · v`, with `x̂`, `v̂` from the
/// last one or two substeps plus gravity and wind. The spring forces act along the
/// segments, so the unknowns are one tension per segment: linearised at the predicted
/// `x* = x̂ + step · v̂`, they solve the tridiagonal system
/// `(I + (k step² + d step) J M⁻¹ Jᵀ) t = −k C − d J v̂` exactly ([`solve_tensions`]).
/// At rest that is the static balance itself, so a hanging strand stretches by exactly
/// the weight it carries over `k`.
///
/// A segment that this would take past the length tolerance is instead held at its bound
/// in a second solve, its tension whatever that takes (a rigid rod): the clamp is part of
/// the balance, and the segments below a clamped one still carry exactly their weight.
///
/// With hair volume, the grid's friction is a force of the same solve,
/// `rate · m · (v̄ − v)` toward the hair's mean velocity `v̄` around a particle: implicit,
/// it gives `v = ρ (v̂ + step · rate · v̄) + ρ · step · f/m` with `ρ = 1 / (1 + step · rate)`,
/// so each particle's prediction moves toward `v̄` and its inverse mass is `ρ / m` in the
/// tension solve. The springs and the friction then agree within the substep, instead of
/// one undoing the other's work. The density push and the pressure enter `v̂` once, in the
/// step's `first` substep.
#[inline(always)]
pub(super) fn implicit_springs<S: Simd>(g: &mut GroupState<S>, c: &Constants<S>, p: &SimParams, first: bool) {
    let n = g.positions.len();
    let h = Wide::splat(c.shared.h);
    // BDF2 where a lane remembers a substep of the same length, else backward Euler.
    let fresh = g.history_step.cmpne(h);
    let (now, before) = (Wide::splat(4.0 / 3.0), Wide::splat(1.0 / 3.0));
    let current = Wide::select(fresh, Wide::one(), now);
    let previous = Wide::select(fresh, Wide::zero(), before);
    let step = Wide::select(fresh, h, h * Wide::splat(2.0 / 3.0));
    let drag = Wide::splat(c.shared.drag_factor);
    // The grid's push, where it enters: a change of the velocity and of its memory alike,
    // so that BDF2 does not read it as a trend to carry on.
    let kick = g.grid_feedback && first;
    for j in 1..n {
        let (x, mut v, mut v_before) = (g.start[j], g.velocities[j], g.previous_velocities[j]);
        if kick {
            (v, v_before) = (v + g.grid_kick[j], v_before + g.grid_kick[j]);
        }
        g.base[j] = x * current - g.previous_positions[j] * previous;
        // Drag on the carried velocity only, so that at rest the springs carry the whole
        // weight: the static balance does not depend on the air.
        let carried = (v * current - v_before * previous) * drag + g.accel[j] * step;
        g.velocities[j] = if g.grid_feedback {
            // `1 − ρ` rather than `ρ · step · rate`: the rate may be large.
            let keep = (Wide::one() + step * g.friction_rate[j]).recip();
            g.mobility[j] = keep;
            carried * keep + g.friction_toward[j] * (Wide::one() - keep)
        } else {
            carried
        };
        g.previous_positions[j] = x;
        g.previous_velocities[j] = v;
        g.positions[j] = g.base[j] + g.velocities[j] * step;
    }
    g.base[0] = g.start[0];
    g.history_step = h;
    g.step = step;

    // The segments at the predicted positions. The root is pinned where the head put it;
    // its velocity enters the first segment's damping.
    let root_velocity = (g.positions[0] - g.start[0]) * h.recip();
    let (k, d) = (c.spring_k, c.spring_d);
    let tolerance = Wide::splat(p.length_tolerance);
    for j in 1..n {
        let segment = g.positions[j] - g.positions[j - 1];
        let l = segment.length();
        // A collapsed segment has no direction to pull along.
        g.directions[j] = V3::select(l.cmpgt(Wide::splat(1e-9)), segment * l.recip(), V3::zero());
        g.stretch[j] = l - g.lengths[j];
        let parent_velocity = if j == 1 { root_velocity } else { g.velocities[j - 1] };
        g.spring_rhs[j] = -(k * g.stretch[j] + d * g.directions[j].dot(g.velocities[j] - parent_velocity));
    }
    let w = Wide::splat(1.0 / p.particle_mass);
    let coupling = (k * step + d) * step * w;
    g.rigid.fill(Mask::from_bits(0));
    solve_tensions(g, coupling, step * step * w);

    // Segments this leaves beyond the tolerance are held at their bound, and the tensions
    // solved again; holding some may push others past theirs, so repeat while that adds
    // segments (each pass adds at least one, and rarely more than two passes are needed).
    for _ in 0..MAX_ACTIVE_SET_PASSES {
        let mut added = 0;
        let mut parent = g.positions[0];
        for j in 1..n {
            let x = g.positions[j] + pull(g, j) * (step * step * w * g.mobility[j]);
            let stretch = (x - parent).length() - g.lengths[j];
            parent = x;
            // A segment resting on its bound, which this solve would leave there, counts too.
            let beyond = stretch.abs().cmpgt(g.lengths[j] * tolerance * Wide::splat(1.0 - BOUND_SLACK));
            let new = beyond.bitmask() & !g.rigid[j].bitmask();
            if new != 0 {
                // The bound on the side the segment went past.
                let signed =
                    Wide::select(stretch.cmpgt(Wide::zero()), g.lengths[j] * tolerance, -(g.lengths[j] * tolerance));
                let new = Mask::from_bits(new);
                g.bound[j] = Wide::select(new, signed, g.bound[j]);
                g.rigid[j] = Mask::from_bits(g.rigid[j].bitmask() | new.bitmask());
                added |= 1;
            }
        }
        if added == 0 {
            break;
        }
        solve_tensions(g, coupling, step * step * w);
    }
    let max_speed = Wide::splat(p.max_speed);
    for j in 1..n {
        g.velocities[j] = (g.velocities[j] + pull(g, j) * (step * w * g.mobility[j])).clamp_length_max(max_speed);
        g.positions[j] = g.base[j] + g.velocities[j] * step;
    }
}

/// How far inside its bound, as a share of the bound, a segment counts as resting on it.
pub(super) const BOUND_SLACK: f32 = 1e-3;

/// Most solves that add segments held at their bound, per substep.
pub(super) const MAX_ACTIVE_SET_PASSES: usize = 4;

/// The net force of the tensions on particle `j`: its own segment pulls it toward the
/// parent, the next one toward the child.
#[inline(always)]
pub(super) fn pull<S: Simd>(g: &GroupState<S>, j: usize) -> V3<S> {
    let child = if j + 1 < g.positions.len() { g.directions[j + 1] * g.tension[j + 1] } else { V3::zero() };
    g.directions[j] * g.tension[j] - child
}

/// Solves for the segment tensions by Thomas' algorithm (one sweep down the strand, one
/// back up); segment `j` couples to `j + 1` through their shared particle, the pinned
/// root to nothing. A spring row is the implicit force law (see [`implicit_springs`]);
/// a rigid row (`g.rigid`) asks that the segment end at its bound,
/// `(1 ± length_tolerance) l0`, where `displacement` (step² / m) turns a tension into
/// how far it moves a particle of `g.mobility` 1.
#[inline(always)]
pub(super) fn solve_tensions<S: Simd>(g: &mut GroupState<S>, coupling: Wide<S>, displacement: Wide<S>) {
    let n = g.positions.len();
    let mut upper_before = Wide::zero();
    for j in 1..n {
        // J M⁻¹ Jᵀ in units of 1/m, each particle's inverse mass its mobility: on the
        // diagonal the two ends' (the first segment's parent is pinned), to each neighbour
        // −cos(angle) times the shared particle's.
        let m = &g.mobility;
        let own = if j == 1 { m[1] } else { m[j - 1] + m[j] };
        let lower = if j == 1 { Wide::zero() } else { -g.directions[j].dot(g.directions[j - 1]) * m[j - 1] };
        let upper = if j + 1 < n { -g.directions[j].dot(g.directions[j + 1]) * m[j] } else { Wide::zero() };
        let rigid = g.rigid[j];
        // A rigid row: the linearised length change equals the way to the bound.
        let to_bound = g.bound[j] - g.stretch[j];
        let scale = Wide::select(rigid, Wide::one(), coupling);
        let diagonal = Wide::select(rigid, own, Wide::one() + coupling * own);
        let rhs = Wide::select(rigid, to_bound / displacement, g.spring_rhs[j]);
        let (lower, upper) = (lower * scale, upper * scale);
        let pivot = (diagonal - lower * upper_before).recip();
        g.sweep[j] = upper * pivot;
        let carried = if j == 1 { Wide::zero() } else { lower * g.tension[j - 1] };
        g.tension[j] = (rhs - carried) * pivot;
        upper_before = g.sweep[j];
    }
    for j in (1..n - 1).rev() {
        g.tension[j] = g.tension[j] - g.sweep[j] * g.tension[j + 1];
    }
}
