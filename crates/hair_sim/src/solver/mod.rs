//! The strand solver: state, settings and the fixed step.
//!
//! One [`Strands`] holds a whole groom in flat arrays, strand `i` particle `j` at
//! `i * n + j`. A step is independent per strand, so [`Strands::chunks_mut`] splits the
//! state into disjoint [`StrandChunk`]s that any thread pool can step in parallel; the
//! result is bit-identical to [`Strands::step`], whatever the chunking.

mod detail;
mod lanes;
mod params;
mod rest_lanes;
mod sleep;
mod step;

pub use detail::HeadSpaceFollowers;
use detail::{Detail, Role};
pub use detail::{FULL_DETAIL_HEIGHT, MAX_DETAIL_LEVEL, level_for_height, level_with_hysteresis, simulated_at_level};
use rest_lanes::RestLanes;

pub use step::{MIN_STEP, StepConstants};
pub use volume::{
    FTL_BACKLOG_KEPT, FTL_CATCH_UP, Feedback, LIVE_FLOOR, MAX_FIXED_VELOCITY, MIN_FRICTION_KEPT, PARTICLE_MASS_UNITS,
    PRESSURE_SLACK, SETTLING_FLOOR, SPRINGS_CATCH_UP, SplatPart, VELOCITY_BITS, VolumeGrid, VolumeState, WEIGHT_BITS,
    fixed_velocity,
};
mod volume;
mod wind;

pub use params::{
    CollisionResponse, LengthMode, MAX_PRESSURE_ITERATIONS, ParamIssue, SimParams, SimdPath, Volume, Wind,
    stiffness_per_application,
};
use sleep::SleepWatch;
pub use sleep::Stillness;
pub use wind::{is_calm, wind_at};

use crate::collide::{ContactHint, ExtraCollider, HeadCollider, SurfacePatch};
use crate::math::{Pose, Quat, Vec3};
use std::fmt;

/// Shortest segment the solver accepts, metres; shorter rest segments are lengthened.
pub const MIN_SEGMENT_LENGTH: f32 = 1e-5;

/// Why a set of strands cannot be simulated.
#[derive(Clone, Debug, PartialEq)]
pub enum StrandsError {
    /// Fewer than two particles per strand: there is no segment to simulate.
    TooFewParticles(usize),
    /// The number of rest positions is not a whole number of strands.
    RaggedStrands {
        /// Rest positions given.
        positions: usize,
        /// Particles per strand asked for.
        particles_per_strand: usize,
    },
    /// A rest position is NaN or infinite.
    NonFiniteRest {
        /// Its index.
        index: usize,
    },
    /// [`Strands::set_positions`] or [`Strands::set_velocities`] was given a different
    /// number of values than there are particles.
    PositionCount {
        /// Values given.
        given: usize,
        /// Particles in the strands.
        expected: usize,
    },
    /// A position given to [`Strands::set_positions`] is NaN or infinite.
    NonFinitePosition {
        /// Its index.
        index: usize,
    },
    /// A velocity given to [`Strands::set_velocities`] is NaN or infinite.
    NonFiniteVelocity {
        /// Its index.
        index: usize,
    },
}

impl fmt::Display for StrandsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StrandsError::TooFewParticles(n) => {
                write!(f, "a strand needs at least 2 particles, got {n}")
            }
            StrandsError::RaggedStrands { positions, particles_per_strand } => write!(
                f,
                "{positions} rest positions are not a whole number of {particles_per_strand}-particle strands"
            ),
            StrandsError::NonFiniteRest { index } => {
                write!(f, "rest position {index} is NaN or infinite")
            }
            StrandsError::PositionCount { given, expected } => {
                write!(f, "{given} values were given for {expected} particles")
            }
            StrandsError::NonFinitePosition { index } => write!(f, "position {index} is NaN or infinite"),
            StrandsError::NonFiniteVelocity { index } => write!(f, "velocity {index} is NaN or infinite"),
        }
    }
}

impl std::error::Error for StrandsError {}

/// The rest shape, fixed while simulating: what shape keeping and resets aim for.
#[derive(Clone, Debug)]
pub struct RestShape {
    /// Particles per strand.
    pub particles_per_strand: usize,
    /// Rest positions in head-local space.
    pub positions: Vec<Vec3>,
    /// Rest length of the segment ending at each particle (0 at roots).
    pub lengths: Vec<f32>,
    /// Rest direction of the segment ending at each particle, in its parent segment's
    /// frame (unused at roots).
    pub local_directions: Vec<Vec3>,
    /// Head-local frame at each root (maps +Y onto the first segment's rest direction).
    pub root_frames: Vec<Quat>,
}

impl RestShape {
    /// Derives lengths and local directions from head-local rest positions.
    pub fn new(positions: Vec<Vec3>, particles_per_strand: usize) -> Result<Self, StrandsError> {
        let n = particles_per_strand;
        if n < 2 {
            return Err(StrandsError::TooFewParticles(n));
        }
        if !positions.len().is_multiple_of(n) {
            return Err(StrandsError::RaggedStrands { positions: positions.len(), particles_per_strand: n });
        }
        if let Some(index) = positions.iter().position(|p| !p.is_finite()) {
            return Err(StrandsError::NonFiniteRest { index });
        }
        let mut lengths = vec![0.0; positions.len()];
        let mut local_directions = vec![Vec3::Y; positions.len()];
        let mut root_frames = Vec::with_capacity(positions.len() / n);
        for (s, strand) in positions.chunks_exact(n).enumerate() {
            let first = (strand[1] - strand[0]).normalize_or(Vec3::Y);
            let frame = Quat::from_rotation_arc(Vec3::Y, first);
            root_frames.push(frame);
            // At rest no segment deviates from where its parent expects it, so every
            // frame along the strand equals the root frame (see `step::local_shape`).
            for j in 1..n {
                let segment = strand[j] - strand[j - 1];
                lengths[s * n + j] = segment.length().max(MIN_SEGMENT_LENGTH);
                local_directions[s * n + j] = frame.inverse() * segment.normalize_or(first);
            }
        }
        Ok(RestShape { particles_per_strand: n, positions, lengths, local_directions, root_frames })
    }

    /// Number of strands.
    pub fn strand_count(&self) -> usize {
        self.positions.len() / self.particles_per_strand
    }

    /// The length of the longest strand at rest, root to tip, m (0 for none).
    pub fn longest_strand(&self) -> f32 {
        self.lengths.chunks(self.particles_per_strand).map(|strand| strand.iter().sum::<f32>()).fold(0.0, f32::max)
    }

    /// The mean rest length of a segment, m (0 for none).
    pub fn mean_segment(&self) -> f32 {
        let segments = self.strand_count() * (self.particles_per_strand - 1);
        self.lengths.iter().sum::<f32>() / segments.max(1) as f32
    }
}

/// What one step did, summed over strands.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepReport {
    /// Strands reset to the rest pose because their root jumped (teleport).
    pub teleport_resets: u32,
    /// Strands reset because a non-finite value appeared (should stay 0).
    pub nan_resets: u32,
    /// Particle–collider contacts resolved, summed over the step's substeps.
    pub contacts: u32,
    /// Deepest penetration found (before resolving), metres below the thickness offset.
    pub max_depth: f32,
    /// Particles the final length pass could not keep both outside and at their
    /// segment's length (a crease tighter than a segment): collision won and the segment
    /// stretched. Summed over substeps.
    pub contact_stretches: u32,
    /// Segments turned because they cut through the head between two particles outside it
    /// (an ear's rim). Summed over substeps.
    pub segment_turns: u32,
    /// Strands left asleep through the step (see [`SimParams::sleep_distance`]).
    pub sleeping: u32,
}

impl StepReport {
    /// Adds another chunk's report to this one.
    pub fn merge(&mut self, other: StepReport) {
        self.teleport_resets += other.teleport_resets;
        self.nan_resets += other.nan_resets;
        self.contacts += other.contacts;
        self.max_depth = self.max_depth.max(other.max_depth);
        self.contact_stretches += other.contact_stretches;
        self.segment_turns += other.segment_turns;
        self.sleeping += other.sleeping;
    }
}

/// Everything one step needs besides the strand state.
#[derive(Clone, Copy)]
pub struct StepInput<'a> {
    /// Step length, seconds. Non-finite or non-positive steps do nothing.
    pub dt: f32,
    /// Simulation time at the start of the step, seconds (drives wind gusts).
    pub time: f32,
    /// Head pose at the start of the step.
    pub head_from: Pose,
    /// Head pose at the end of the step; roots follow the interpolation between the two.
    pub head_to: Pose,
    /// The head collider, in head-local space (scale already baked in).
    pub collider: Option<&'a HeadCollider>,
    /// Extra world-space colliders.
    pub extra_colliders: &'a [ExtraCollider],
    /// The part of the head that moves against the collider's frame (a skinned neck
    /// bending), as it is at the end of the step, head-local like the collider.
    pub surface_patch: Option<&'a SurfacePatch>,
    /// Settings. The step runs on what [`SimParams::sanitized`] makes of them: call it
    /// first to learn (and report) which values were not usable.
    pub params: &'a SimParams,
}

/// The simulated state of a groom: positions and velocities in world space.
#[derive(Clone, Debug)]
pub struct Strands {
    rest: RestShape,
    /// The same, transposed for the SIMD groups.
    rest_lanes: RestLanes,
    positions: Vec<Vec3>,
    velocities: Vec<Vec3>,
    /// Per particle, the head triangle it touched last (a collision shortcut).
    hints: Vec<ContactHint>,
    /// The spring model's memory (BDF2 looks two substeps back): positions and velocities
    /// at the start of the last substep.
    previous_positions: Vec<Vec3>,
    previous_velocities: Vec<Vec3>,
    /// Per strand, the substep length that memory was taken at; 0 when there is none
    /// (after a reset, or in the inextensible model, which keeps none).
    history_step: Vec<f32>,
    /// Per strand, how long it has stayed where it is ([`sleep`]), and per particle where
    /// that watch began.
    sleep: Vec<SleepWatch>,
    anchors: Vec<Vec3>,
    /// Levels of detail, once asked for ([`Self::set_detail_level`]).
    detail: Option<Detail>,
    /// The hair–hair grid, while [`SimParams::volume`] is on.
    volume: Option<VolumeGrid>,
    /// The step's feedback from the grid, made by [`Self::apply_volume`] for the next
    /// [`Self::chunks_mut`]'s chunks to apply.
    volume_step: Option<volume::VolumeStep>,
    /// What the grid was last worked out from, and the feedback it gave.
    volume_made_from: Option<volume::MadeFrom>,
}

impl Strands {
    /// Strands at rest, placed by the head pose `pose`.
    pub fn new(rest: RestShape, pose: Pose) -> Self {
        let positions: Vec<Vec3> = rest.positions.iter().map(|&p| pose.transform_point(p)).collect();
        let velocities = vec![Vec3::ZERO; rest.positions.len()];
        let hints = vec![ContactHint::NONE; rest.positions.len()];
        Strands {
            previous_positions: positions.clone(),
            previous_velocities: velocities.clone(),
            history_step: vec![0.0; rest.strand_count()],
            sleep: vec![SleepWatch::default(); rest.strand_count()],
            anchors: positions.clone(),
            rest_lanes: RestLanes::new(&rest),
            rest,
            positions,
            velocities,
            hints,
            detail: None,
            volume: None,
            volume_step: None,
            volume_made_from: None,
        }
    }

    /// The rest shape.
    pub fn rest(&self) -> &RestShape {
        &self.rest
    }

    /// Moves strand `strand`'s root within the rest shape (head-local), for a root that
    /// rides a surface deforming against the head's frame (a blended skinned scalp): the
    /// next step pins the root there. The rest of the rest shape stays. A non-finite
    /// position or a strand out of range is ignored.
    pub fn set_rest_root(&mut self, strand: usize, root: Vec3) {
        let n = self.rest.particles_per_strand;
        if root.is_finite() && strand < self.rest.strand_count() {
            self.rest.positions[strand * n] = root;
            self.rest_lanes.set_root(strand, root);
        }
    }

    /// Particles per strand.
    pub fn particles_per_strand(&self) -> usize {
        self.rest.particles_per_strand
    }

    /// Number of strands.
    pub fn strand_count(&self) -> usize {
        self.rest.strand_count()
    }

    /// World positions, strand-major. After [`Self::fade_and_rise`] the followers of a
    /// level of detail are where they were last placed, until [`Self::place_followers`].
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// World velocities, strand-major.
    pub fn velocities(&self) -> &[Vec3] {
        &self.velocities
    }

    /// Moves every particle by `offset`, velocities unchanged: the strands' space shifts
    /// by `-offset`. Keeping that space's origin near the head keeps the coordinates
    /// small, so `f32` resolves millimetres and less wherever in the world the head is.
    pub fn translate(&mut self, offset: Vec3) {
        if offset != Vec3::ZERO && offset.is_finite() {
            let moved = self.positions.iter_mut().chain(&mut self.previous_positions).chain(&mut self.anchors);
            moved.for_each(|p| *p += offset);
            if let Some(detail) = &mut self.detail {
                detail.translate(offset);
            }
        }
    }

    /// Places every particle at `positions` (strand-major, as [`Self::positions`]),
    /// motionless: to restore a saved state or start from a pose of one's own. Roots are
    /// pinned again by the next step.
    pub fn set_positions(&mut self, positions: &[Vec3]) -> Result<(), StrandsError> {
        self.check_one_each(positions, |index| StrandsError::NonFinitePosition { index })?;
        self.positions.copy_from_slice(positions);
        self.velocities.fill(Vec3::ZERO);
        self.hints.fill(ContactHint::NONE);
        self.previous_positions.copy_from_slice(positions);
        self.previous_velocities.fill(Vec3::ZERO);
        self.history_step.fill(0.0);
        self.wake();
        if let Some(detail) = &mut self.detail {
            detail.placed(positions);
        }
        Ok(())
    }

    /// Gives every particle the velocity in `velocities` (strand-major, as
    /// [`Self::velocities`]), after [`Self::set_positions`] to restore a moving state.
    /// Every strand wakes, and the spring model starts its memory again. Roots take the
    /// head's velocity at the next step.
    pub fn set_velocities(&mut self, velocities: &[Vec3]) -> Result<(), StrandsError> {
        self.check_one_each(velocities, |index| StrandsError::NonFiniteVelocity { index })?;
        self.velocities.copy_from_slice(velocities);
        self.history_step.fill(0.0);
        self.wake();
        Ok(())
    }

    /// Whether `values` hold one finite value per particle; else what is wrong, the first
    /// value that is not finite by `non_finite`.
    fn check_one_each(&self, values: &[Vec3], non_finite: fn(usize) -> StrandsError) -> Result<(), StrandsError> {
        if values.len() != self.positions.len() {
            return Err(StrandsError::PositionCount { given: values.len(), expected: self.positions.len() });
        }
        values.iter().position(|v| !v.is_finite()).map_or(Ok(()), |index| Err(non_finite(index)))
    }

    /// Puts every strand back at rest under `pose`, motionless.
    pub fn reset(&mut self, pose: Pose) {
        for (p, &r) in self.positions.iter_mut().zip(&self.rest.positions) {
            *p = pose.transform_point(r);
        }
        self.velocities.fill(Vec3::ZERO);
        self.hints.fill(ContactHint::NONE);
        self.previous_positions.copy_from_slice(&self.positions);
        self.previous_velocities.fill(Vec3::ZERO);
        self.history_step.fill(0.0);
        self.wake();
        if let Some(detail) = &mut self.detail {
            detail.placed(&self.positions);
        }
    }

    /// Wakes every sleeping strand ([`SimParams::sleep_distance`]): the next step steps it.
    pub fn wake(&mut self) {
        self.sleep.fill(SleepWatch::default());
        self.anchors.copy_from_slice(&self.positions);
    }

    /// Strands asleep under `params` ([`SimParams::sleep_distance`]).
    pub fn sleeping(&self, params: &SimParams) -> usize {
        let (params, _) = params.sanitized();
        self.sleep.iter().filter(|w| sleep::asleep(w, &params)).count()
    }

    /// Splits the state into chunks of `strands_per_chunk` strands (the last may be
    /// shorter) that can be stepped on different threads. Multiples of
    /// [`SimdPath::strands_per_group`] use the SIMD lanes fully.
    pub fn chunks_mut(&mut self, strands_per_chunk: usize) -> Vec<StrandChunk<'_>> {
        let n = self.rest.particles_per_strand;
        let strands = strands_per_chunk.max(1);
        let size = strands * n;
        let roles = self.detail.as_ref().map(|d| d.roles.as_slice());
        // The feedback of the grid that `apply_volume` prepared, once.
        let volume_step = self.volume_step.take();
        let volume = self.volume.as_ref().zip(volume_step.as_ref());
        self.positions
            .chunks_mut(size)
            .zip(self.velocities.chunks_mut(size))
            .zip(self.hints.chunks_mut(size))
            .zip(self.previous_positions.chunks_mut(size).zip(self.previous_velocities.chunks_mut(size)))
            .zip(self.history_step.chunks_mut(strands))
            .zip(self.sleep.chunks_mut(strands).zip(self.anchors.chunks_mut(size)))
            .enumerate()
            .map(
                |(
                    c,
                    (
                        ((((positions, velocities), hints), (previous_positions, previous_velocities)), history_step),
                        (sleep, anchors),
                    ),
                )| {
                    StrandChunk {
                        first_strand: c * strands,
                        volume: volume.map(|(grid, step)| (grid, step.clone())),
                        rest: step::Rest { shape: &self.rest, lanes: &self.rest_lanes },
                        roles: roles.map(|r| &r[c * strands..((c + 1) * strands).min(r.len())]),
                        state: ChunkState {
                            positions,
                            velocities,
                            hints,
                            previous_positions,
                            previous_velocities,
                            history_step,
                            sleep,
                            anchors,
                        },
                    }
                },
            )
            .collect()
    }

    /// Advances every strand by one step on the calling thread ([`Self::apply_volume`],
    /// the chunks, then [`Self::follow_leaders`]).
    pub fn step(&mut self, input: &StepInput) -> StepReport {
        self.apply_volume(input);
        let report = self.step_chunks(input);
        self.follow_leaders(input);
        report
    }

    /// [`Self::step`], but a level of detail's followers stay where they were
    /// ([`Self::fade_and_rise`]), for a caller that places them as it copies the
    /// positions out.
    pub fn step_leaving_followers(&mut self, input: &StepInput) -> StepReport {
        self.apply_volume(input);
        let report = self.step_chunks(input);
        self.fade_and_rise(input);
        report
    }

    /// Hair–hair interaction for the step `input` asks for, where [`SimParams::volume`] is
    /// on: every particle's velocity moves toward the hair's around it and away from where
    /// the hair is denser than at rest ([`VolumeGrid`]). This splats the particles into the
    /// grid and solves its pressure; the chunks of the next [`Self::chunks_mut`] feed the
    /// answer back into their own strands as they step, side by side. A caller that steps
    /// the chunks itself calls this (or [`Self::apply_volume_on`]) first; [`Self::step`]
    /// does.
    pub fn apply_volume(&mut self, input: &StepInput) {
        self.apply_volume_on(input, 1, |_| {});
    }

    /// [`Self::apply_volume`] with the splat split into up to `parts` runs of whole
    /// strands, for `run` to take on threads of their own ([`SplatPart::run`]) before the
    /// grid's sums are added up here; any part it leaves is run on this thread. The grid
    /// is the same for any `parts`: its sums are integers.
    pub fn apply_volume_on(&mut self, input: &StepInput, parts: usize, run: impl FnOnce(&mut [SplatPart<'_>])) {
        self.volume_step = None;
        let (params, _) = input.params.sanitized();
        let Some(dt) = step::step_length(input).filter(|_| params.volume.enabled) else {
            if !params.volume.enabled {
                self.volume = None;
                self.volume_made_from = None;
            }
            return;
        };
        let resolution = params.volume.resolution;
        let head = input.collider.map(HeadCollider::id);
        if self.volume.as_ref().is_none_or(|grid| grid.resolution() != resolution || grid.head() != head) {
            let interior = input.collider.map(HeadCollider::interior);
            self.volume = Some(VolumeGrid::new(&self.rest, resolution, interior.as_ref()));
            self.volume_made_from = None;
        }
        let pose = if input.head_from.is_valid() { input.head_from } else { input.head_to };
        let head = (pose, input.head_to);
        let grid = self.volume.as_mut().expect("made above");
        let made_from = &mut self.volume_made_from;
        let (positions, velocities) = (&self.positions, &self.velocities);
        let settings = (&params.volume, params.length_mode);
        let step = volume::prepare(
            grid,
            made_from,
            &self.rest,
            positions,
            velocities,
            head,
            settings,
            (dt, step::substeps_of(params.substeps, dt)),
            (parts, params.simd, run),
        );
        self.volume_step = Some(step);
    }

    /// Settles with `grid` as the hair–hair grid while [`SimParams::volume`] is on (at
    /// `grid`'s resolution), instead of one made from the rest pose.
    pub(crate) fn use_volume_grid(&mut self, grid: VolumeGrid) {
        self.volume = Some(grid);
        self.volume_made_from = None;
    }

    /// The hair–hair grid as the last step left it, while [`SimParams::volume`] is on.
    pub fn volume_grid(&self) -> Option<&VolumeGrid> {
        self.volume.as_ref()
    }

    /// Steps every simulated strand, on this thread.
    fn step_chunks(&mut self, input: &StepInput) -> StepReport {
        let mut report = StepReport::default();
        let all = self.strand_count().max(1);
        for mut chunk in self.chunks_mut(all) {
            report.merge(chunk.step(input));
        }
        report
    }

    /// Chooses the level of detail: level `L` simulates [`simulated_at_level`] of the
    /// strands (`⌈N / 2^L⌉`, spread evenly over the scalp; at most
    /// [`MAX_DETAIL_LEVEL`]), and the others follow their simulated neighbours, placed by
    /// [`Self::follow_leaders`] after each step. A strand that stops being simulated fades
    /// out over `fade_steps` steps, and one that starts again rises in over as many,
    /// starting from where it was drawn, moving as its leaders do (0: both at once, which
    /// pops).
    /// The first call orders the strands and finds every level's leaders
    /// ([`Self::prepare_detail`], O(N²) in the strand count); later calls search nothing.
    pub fn set_detail_level(&mut self, level: u32, fade_steps: u32) {
        let level = level.min(MAX_DETAIL_LEVEL);
        if self.detail.as_ref().map_or(level == 0, |d| d.level() == level) {
            return;
        }
        self.prepare_detail();
        // Rising strands start from where they are drawn.
        self.place_followers();
        let detail = self.detail.as_mut().expect("prepared");
        let n = self.rest.particles_per_strand;
        detail.led_velocities(n, &mut self.velocities);
        for s in detail.set_level(level, fade_steps, &self.positions) {
            // Its solver memory is stale: start it from where it is drawn.
            let particles = s * n..(s + 1) * n;
            self.hints[particles.clone()].fill(ContactHint::NONE);
            self.previous_positions[particles.clone()].copy_from_slice(&self.positions[particles.clone()]);
            self.previous_velocities[particles.clone()].copy_from_slice(&self.velocities[particles]);
            self.history_step[s] = 0.0;
        }
    }

    /// Orders the strands for levels of detail and finds every level's leaders now (O(N²)
    /// in the strand count, on all cores), so that the first [`Self::set_detail_level`]
    /// does not: for a groom built off the main thread.
    pub fn prepare_detail(&mut self) {
        if self.detail.is_none() {
            self.detail = Some(Detail::new(&self.roots()));
        }
    }

    /// The level of detail ([`Self::set_detail_level`]); 0 simulates every strand.
    pub fn detail_level(&self) -> u32 {
        self.detail.as_ref().map_or(0, Detail::level)
    }

    /// Strands the solver steps in the next step: those of the level of detail (rising
    /// ones included), and those leaving it that take their last step.
    pub fn simulated_strands(&self) -> usize {
        self.detail.as_ref().map_or(self.strand_count(), |d| d.roles.iter().filter(|r| r.stepped()).count())
    }

    /// Whether the solver steps strand `strand` in the next step (as
    /// [`Self::simulated_strands`] counts); false for a strand placed from its neighbours
    /// (following, or fading out after its last step), or out of range.
    pub fn is_simulated(&self, strand: usize) -> bool {
        strand < self.strand_count() && self.detail.as_ref().is_none_or(|d| d.roles[strand].stepped())
    }

    /// After the chunks of a step: places the strands the level of detail does not
    /// simulate from their simulated neighbours, and fades those leaving the simulation
    /// toward that. [`Self::step`] calls it; a caller stepping [`Self::chunks_mut`] itself
    /// calls it once all chunks are done. Does nothing at level 0 with no strand fading.
    pub fn follow_leaders(&mut self, input: &StepInput) {
        self.finish_step(input, true);
    }

    /// [`Self::follow_leaders`], but the followers stay where they were, for a caller that
    /// places them as it copies the positions out ([`Self::head_space_followers`]): one
    /// pass over a far head's particles instead of two. [`Self::place_followers`] places
    /// them in [`Self::positions`].
    pub fn fade_and_rise(&mut self, input: &StepInput) {
        self.finish_step(input, false);
    }

    /// After the chunks: fades, rises, and the followers placed or left.
    fn finish_step(&mut self, input: &StepInput, place_followers: bool) {
        let Some(detail) = self.detail.as_mut() else { return };
        let Some(dt) = step::step_length(input) else { return };
        let n = self.rest.particles_per_strand;
        let (rest, pose) = (&self.rest.positions, &input.head_to);
        detail.follow(n, rest, pose, dt, &mut self.positions, &mut self.velocities, place_followers);
    }

    /// Places the followers left by [`Self::fade_and_rise`] in [`Self::positions`], where
    /// their leaders put them at the end of that step. Does nothing if none wait.
    pub fn place_followers(&mut self) {
        if let Some(detail) = self.detail.as_mut() {
            detail.place_pending(self.rest.particles_per_strand, &self.rest.positions, &mut self.positions);
        }
    }

    /// Whether strand `strand` is a follower: placed from its simulated neighbours, neither
    /// stepped nor fading out.
    #[inline]
    pub fn is_following(&self, strand: usize) -> bool {
        self.detail.as_ref().is_some_and(|d| d.follows(strand))
    }

    /// Whether followers wait to be placed ([`Self::fade_and_rise`]).
    pub fn followers_pending(&self) -> bool {
        self.detail.as_ref().is_some_and(Detail::pending)
    }

    /// The followers' placement in head space (the head's rotation and translation
    /// undone), for a caller copying the positions out in head space after
    /// [`Self::fade_and_rise`]: `local(i)` gives particle `i`'s head-space position, and is
    /// asked of the simulated strands' particles only (the followers' leaders). The same
    /// placement as [`Self::place_followers`], to rounding. `None` without a level of
    /// detail.
    pub fn head_space_followers(&mut self, local: impl Fn(usize) -> Vec3) -> Option<HeadSpaceFollowers<'_>> {
        let n = self.rest.particles_per_strand;
        let detail = self.detail.as_mut()?;
        Some(detail.head_space_placement(n, &self.rest.positions, local))
    }

    /// Head-local rest roots, one per strand.
    fn roots(&self) -> Vec<Vec3> {
        self.rest.positions.iter().step_by(self.rest.particles_per_strand).copied().collect()
    }

    /// Largest segment length divided by its rest length, minus one (0 = no stretch).
    pub fn max_stretch(&self) -> f32 {
        let n = self.rest.particles_per_strand;
        (0..self.positions.len())
            .filter(|i| i % n != 0)
            .map(|i| ((self.positions[i] - self.positions[i - 1]).length() / self.rest.lengths[i] - 1.0).abs())
            .fold(0.0, f32::max)
    }
}

/// A contiguous run of strands borrowed from [`Strands`], steppable on its own thread.
pub struct StrandChunk<'a> {
    first_strand: usize,
    rest: step::Rest<'a>,
    /// Per strand of the chunk, its role at the level of detail; `None`: all simulated.
    roles: Option<&'a [Role]>,
    /// The hair–hair grid and the step's feedback from it, where volume is on.
    volume: Option<(&'a VolumeGrid, volume::VolumeStep)>,
    state: ChunkState<'a>,
}

/// The per-particle arrays of a chunk, strand-major.
struct ChunkState<'a> {
    positions: &'a mut [Vec3],
    velocities: &'a mut [Vec3],
    hints: &'a mut [ContactHint],
    previous_positions: &'a mut [Vec3],
    previous_velocities: &'a mut [Vec3],
    history_step: &'a mut [f32],
    sleep: &'a mut [SleepWatch],
    anchors: &'a mut [Vec3],
}

impl StrandChunk<'_> {
    /// World positions of this chunk's particles, strand-major (its first strand first).
    pub fn positions(&self) -> &[Vec3] {
        self.state.positions
    }

    /// Advances the strands of this chunk by one step (each strand that steps first taking
    /// the hair–hair grid's feedback, where [`Strands::apply_volume`] prepared it).
    pub fn step(&mut self, input: &StepInput) -> StepReport {
        let volume = self.volume.take();
        let volume = volume.as_ref().map(|(grid, step)| (*grid, step));
        step::step_chunk(self.first_strand, self.rest, self.roles, volume, &mut self.state, input)
    }
}
