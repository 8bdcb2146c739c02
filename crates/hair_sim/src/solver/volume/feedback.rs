//! The grid's answer to each particle: the hair's mean velocity around it and the push
//! down the potential, fed into the velocities (Follow-The-Leader) or into the spring
//! model's implicit solve, and at the step's end the speed the push left taken back.

use super::splat::Splat;
use super::{PARTICLE_MASS_UNITS, VolumeGrid};
use crate::math::Vec3;
use crate::solver::params::{LengthMode, Volume};
use glam::Vec4;

impl VolumeGrid {
    /// The mean velocity of the hair where `splat` lies, and the gradient (per metre, head
    /// axes) of the potential there, interpolated from the cells' ([`Self::resolve_gradients`]):
    /// the velocity change the density and the pressure push by.
    #[inline(always)]
    pub(super) fn sample(&self, splat: &Splat) -> (Vec3, Vec3) {
        // The weighted sums of the mean velocities and of the weights where there is hair
        // (an empty cell's mean is zero), the integer weights as they are: their unit
        // cancels in the mean. The eight weights sum to one particle's mass.
        // (The slope's w sums the potentials, which nothing reads.)
        let (mut motion, mut slope) = (Vec4::ZERO, Vec4::ZERO);
        for (c, w) in splat.corners(self.lattice.dims) {
            let (cell, w) = (&self.field[c], w as f32);
            motion += cell.motion * w;
            slope += cell.slope * w;
        }
        let weight = motion.w;
        let velocity = if weight > 0.0 { motion.truncate() * weight.recip() } else { Vec3::ZERO };
        (velocity, slope.truncate() * (self.lattice.inverse_cell / PARTICLE_MASS_UNITS as f32))
    }
}

/// What [`prepare`](super::prepare) worked out for a step's feedback, besides the grid.
#[derive(Clone, Debug, PartialEq)]
pub(in crate::solver) struct VolumeStep {
    /// [`Feedback::shares`].
    shares: Vec<f32>,
    /// [`Feedback::rates`].
    rates: Vec<f32>,
    /// The head's rotation the grid's axes turn by.
    rotation: glam::Quat,
    /// [`Feedback::push_scale`].
    push_scale: f32,
}

impl VolumeStep {
    /// The step's `feedback` on a grid whose axes the head's `rotation` turns.
    pub(super) fn new(feedback: Feedback, rotation: glam::Quat) -> Self {
        VolumeStep { shares: feedback.shares, rates: feedback.rates, rotation, push_scale: feedback.push_scale }
    }
}

impl VolumeGrid {
    /// Moves the velocities of the particles from `first` on (whole strands; the particles
    /// [`prepare`] splatted) toward the hair's mean velocity around each (`volume.friction_root`
    /// at the root to `friction_tip` at the tip, per 1/60 s), down the density excess
    /// (`volume.density_push`, m/s² per unit of excess per cell) and down the pressure
    /// (`volume.pressure` of its gradient). Roots are left alone. Each particle reads only
    /// the grid, so chunks of strands take it on their own threads, in any order.
    /// Each particle's push is left in `pushes`, for the step's end ([`GridPush`]).
    /// Inlined, so that it runs on the instructions of the step that calls it.
    #[inline(always)]
    pub(in crate::solver) fn feed_back(
        &self,
        step: &VolumeStep,
        first: usize,
        velocities: &mut [Vec3],
        pushes: &mut [GridPush],
    ) {
        pushes.fill(GridPush::default());
        self.answer_each(step, first, velocities.len(), |j, a| {
            let v = &mut velocities[j];
            pushes[j] = GridPush::new(a.push, *v);
            *v += (a.mean - *v) * a.share + a.push;
        });
    }

    /// The same answer for the spring model, which takes it into its implicit solve
    /// (`implicit_springs`) instead of into the velocities: one [`SpringFeedback`] per
    /// particle from `first` on, and its push in `pushes`, the particles moving at
    /// `velocities` before it. Inlined, as [`Self::feed_back`].
    #[inline(always)]
    pub(in crate::solver) fn feed_back_to_springs(
        &self,
        step: &VolumeStep,
        first: usize,
        velocities: &[Vec3],
        out: &mut [SpringFeedback],
        pushes: &mut [GridPush],
    ) {
        out.fill(SpringFeedback::default());
        pushes.fill(GridPush::default());
        self.answer_each(step, first, out.len(), |j, a| {
            out[j] = SpringFeedback { toward: a.mean, rate: a.rate, kick: a.push };
            pushes[j] = GridPush::new(a.push, velocities[j]);
        });
    }

    /// Hands `then` the grid's answer for each of the `count` particles from `first` on
    /// (whole strands, root to tip), with its index from `first`; a particle the grid does
    /// not hold (a root) gets none. Inlined into each caller, so that no answer goes
    /// through memory.
    #[inline(always)]
    fn answer_each(&self, step: &VolumeStep, first: usize, count: usize, mut then: impl FnMut(usize, Answer)) {
        let VolumeStep { shares, rates, rotation, push_scale } = step;
        let n = shares.len().max(1);
        debug_assert_eq!(first % n, 0, "whole strands");
        let splats = self.splats.get(first..).unwrap_or_default();
        let splats = &splats[..count.min(splats.len())];
        // A matrix turns a vector in half the arithmetic of a quaternion, and scales it
        // for free.
        let turn = glam::Mat3A::from_quat(*rotation) * *push_scale;
        for (s, strand) in splats.chunks(n).enumerate() {
            for (j, ((splat, &share), &rate)) in strand.iter().zip(shares).zip(rates).enumerate() {
                if let Some(splat) = splat {
                    let (mean, push) = self.sample(splat);
                    let push = (turn * glam::Vec3A::from(push)).into();
                    then(s * n + j, Answer { mean, push, share, rate });
                }
            }
        }
    }
}

/// The density push's and the pressure's velocity change on one particle in a step, kept
/// for the end of the step's first substep, which takes back the speed it left along it
/// ([`Self::taken_back`]): the grid moves hair out of a full cell but, as a contact,
/// does not send it on. Counted whole, the push carried hair past the cell it was pushed
/// out of until gravity or the strand brought it back and it was pushed again: a strand at
/// the edge of a still groom never came to rest, and a pile held up by the pressure was
/// slower to. The push acts over the first substep alone, under Follow-The-Leader scaled
/// to move the hair as far as over the whole step ([`Feedback::push_scale`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(in crate::solver) struct GridPush {
    /// The push, m/s (zero: none).
    push: Vec3,
    /// How fast the particle was leaving along the push before it, times the push's size
    /// (0 where it was coming in): the particle's velocity before, dotted with the push.
    leaving_before: f32,
}

impl GridPush {
    /// The push `push` on a particle moving at `velocity` before it.
    #[inline]
    pub(in crate::solver) fn new(push: Vec3, velocity: Vec3) -> Self {
        GridPush { push, leaving_before: velocity.dot(push).max(0.0) }
    }

    /// What is taken back from `velocity`, the particle's at the end of the step's first
    /// substep: what it leaves along the push beyond how fast it was leaving before, up to
    /// the push's size; speed from elsewhere (the head's pull, gravity) is left alone. The
    /// GPU's `take_back_grid_push`.
    #[inline]
    pub(in crate::solver) fn taken_back(self, velocity: Vec3) -> Vec3 {
        // In units of the push's size squared, so that the push need not be normalized
        // where it is made, once per particle per step.
        let size_squared = self.push.length_squared();
        if !(size_squared > 0.0 && size_squared.is_finite()) {
            return Vec3::ZERO;
        }
        let gained = (velocity.dot(self.push) - self.leaving_before).clamp(0.0, size_squared);
        self.push * (gained / size_squared)
    }
}

/// The grid's answer for one particle ([`VolumeGrid::answer_each`]).
struct Answer {
    /// The hair's mean velocity around it.
    mean: Vec3,
    /// The density push's and the pressure's velocity change, world axes.
    push: Vec3,
    /// [`Feedback::shares`] and [`Feedback::rates`] at its index.
    share: f32,
    rate: f32,
}

/// The grid's answer for one particle as the spring model takes it into its implicit
/// solve: the friction as a force toward the hair's mean velocity, and the density push
/// and the pressure as a velocity change of the step's first substep that the integrator's
/// memory of the substep before does not carry forward (BDF2 would take it 4/3 times).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(in crate::solver) struct SpringFeedback {
    /// The velocity the friction pulls toward (world axes).
    pub toward: Vec3,
    /// The share of the difference the friction takes per second, as a rate (0: none).
    pub rate: f32,
    /// The velocity change of the density push and the pressure.
    pub kick: Vec3,
}

/// How much of the grid's answer a step of the volume feeds back into the velocities, the
/// same for the CPU and the GPU.
#[derive(Clone, Debug, PartialEq)]
pub struct Feedback {
    /// Per particle index, root to tip: the share of the difference to the hair's mean
    /// velocity taken in this step (`volume.friction_root` to `friction_tip` per 1/60 s,
    /// compounded over the step's length).
    pub shares: Vec<f32>,
    /// The velocity change per unit of density-excess gradient (per cell) in this step:
    /// `−density_push × cell × dt`.
    pub push: f32,
    /// Per particle index, root to tip: the same friction as a rate per second, for the
    /// spring model, whose implicit solve takes it substep by substep: over a step of
    /// `dt` with the mean held still, `1 − e^(−rate·dt)` is `shares`. A friction of 1
    /// (the whole difference at once) is taken as keeping [`MIN_FRICTION_KEPT`] of it
    /// per 1/60 s, so that the rate is finite.
    pub rates: Vec<f32>,
    /// The share of a cell's density beyond its target that the pressure takes away in
    /// this step ([`VolumeGrid::solve_pressure`]): [`FTL_CATCH_UP`] under
    /// Follow-The-Leader, [`SPRINGS_CATCH_UP`] in the spring model.
    pub catch_up: f32,
    /// The share of a cell's last overflow, where it was positive, that this step's adds
    /// to its own while the cell is over its target ([`VolumeGrid::solve_pressure`]):
    /// [`FTL_BACKLOG_KEPT`] under Follow-The-Leader, 0 in the spring model.
    pub backlog_kept: f32,
    /// What the density push's and the pressure's velocity change is scaled by. It acts
    /// over the step's first substep alone, whose end takes its speed back along the push.
    /// Carried through the later substeps, its speed met their length passes and contacts
    /// again, and at two substeps or more a strand lying over a pile of hair bounced on it
    /// for good. Under Follow-The-Leader it is scaled by the step's substep count, so that
    /// it moves the hair as far as it would over the whole step, and the hair answers it
    /// as at one substep. The spring model takes it unscaled: a kick that many times as
    /// large in one substep of its implicit solve threw strands against their springs
    /// (at four substeps the default spring groom kept strands swinging by centimetres).
    pub push_scale: f32,
}

/// [`Feedback::catch_up`] under Follow-The-Leader: a little more than the whole overflow,
/// because the hair moves a little less than the grid asks. The push reaches a particle
/// through its eight cells' gradients, blurred over two cells, and the length pass then
/// pulls each pushed particle back toward its parent, so a pile taken away once a step
/// shrank by only part of its overflow and after a shake stayed denser than its target.
/// Much more, and a strand lying over a pile was pushed past its place every step and
/// fell back: the push moves the hair all the way within the step's first substep
/// ([`Feedback::push_scale`]), and the take-back after it leaves no speed for the extra
/// push to carry on with.
pub const FTL_CATCH_UP: f32 = 1.1;

/// [`Feedback::catch_up`] in the spring model. Its integrator keeps every speed the
/// pressure gives, so hair pushed out of a full cell in one step flies on past its target
/// until the springs pull it back into the cell, and is pushed out again: the groom never
/// comes to rest. Taking half of it a step, as Baumgarte's stabilisation takes a contact's
/// overlap, the hair comes to the target slowing down.
pub const SPRINGS_CATCH_UP: f32 = 0.5;

/// [`Feedback::backlog_kept`] under Follow-The-Leader. Hair lying on hair is pulled into
/// it by gravity every step, and the pressure, pushing in proportion to a cell's overflow,
/// held it up only where the cell was dense enough for that push to match the pull: a
/// pile settled over its target by as much as it weighed (a bundle on a floor kept less of
/// its volume the stronger the gravity). Adding half the last step's overflow to the
/// next, a cell that stays over its target is pushed harder step by step until it holds
/// its load nearer the target (integral action, leaking, so that a load taken away is
/// forgotten in a few steps, and forgotten at once where the cell falls under its target).
/// Much more than half, and the pressure overshoots: hair pushed out of a cell by what it
/// remembers falls back into it, and a groom did not come to rest. The spring model keeps
/// none: it keeps every speed the pressure gives, so the pressure's memory threw the hair
/// again.
pub const FTL_BACKLOG_KEPT: f32 = 0.5;

/// What a friction of 1 keeps of the difference per 1/60 s, as a rate ([`Feedback::rates`]).
pub const MIN_FRICTION_KEPT: f32 = 1e-6;

impl Feedback {
    /// The feedback of a step of `dt` seconds in `substeps` substeps on `grid`, for strands
    /// of `n` particles stepped in the length model `mode`.
    pub fn new(grid: &VolumeGrid, volume: &Volume, mode: LengthMode, n: usize, (dt, substeps): (f32, u32)) -> Self {
        let friction = |j: usize| {
            let t = j as f32 / (n - 1).max(1) as f32;
            volume.friction_root + (volume.friction_tip - volume.friction_root) * t
        };
        let shares = (0..n).map(|j| 1.0 - (1.0 - friction(j)).powf(dt * 60.0)).collect();
        let rates = (0..n).map(|j| -(1.0 - friction(j)).max(MIN_FRICTION_KEPT).ln() * 60.0).collect();
        let (catch_up, backlog_kept) = match mode {
            LengthMode::Inextensible => (FTL_CATCH_UP, FTL_BACKLOG_KEPT),
            LengthMode::Springs => (SPRINGS_CATCH_UP, 0.0),
        };
        Feedback {
            shares,
            push: -volume.density_push * grid.lattice.cell * dt,
            rates,
            catch_up,
            backlog_kept,
            push_scale: match mode {
                LengthMode::Inextensible => substeps.max(1) as f32,
                LengthMode::Springs => 1.0,
            },
        }
    }
}
