//! One fixed step for a run of strands. Per substep and strand:
//!
//! 1. integrate free particles: gravity, wind across the segment, drag, the speed clamp;
//!    in the spring model the springs too, implicitly ([`implicit_springs`]);
//! 2. pin the root to the head pose interpolated for this substep;
//! 3. `iterations` × (global shape, local shape, length constraint);
//! 4. collision with the head (head-local) and the extra colliders, with friction, then a
//!    final length pass that may turn a segment about its parent but never moves a
//!    particle back inside a collider ([`keep_outside`]);
//! 5. velocities from the position change, slowed by Müller's FTL correction as a brake
//!    ([`ftl_brake`]).
//!
//! With volume on, the grid's feedback reaches each strand before its substeps, and after
//! the first what the grid's push left of speed along itself is taken back ([`GridPush`]). In
//! the spring model, a still step that the head's touch left a strand with more energy
//! than it started with is undone ([`contact_hold`]).
//!
//! Strands go through this 16, 32 or 64 at a time (by the SIMD path), side by side in
//! SIMD lanes ([`lanes`](super::lanes)); collision, whose path differs per particle, takes
//! them one by one. A strand whose root jumped more than `teleport_distance` is reset to
//! the rest pose instead; a strand that somehow produced a non-finite value is reset too.
//!
//! The stages live beside this driver, one file each: [`springs`], [`shape`],
//! [`contacts`], [`final_length`], [`segments`] and [`contact_hold`], each naming its GPU
//! twin in `hair_gpu`'s `step/` (this driver's: `substep.wgsl` and `entry.wgsl`).

mod contact_hold;
mod contacts;
mod final_length;
mod segments;
mod shape;
mod springs;

use super::detail::Role;
use super::lanes::{Baseline, M3, MAX_LANES, Mask, PoseLanes, Simd, V3, Wide};
use super::params::{CollisionResponse, LengthMode, stiffness_per_application};
use super::rest_lanes::{RestLanes, Row};
use super::sleep::{self, SleepWatch, Stillness};
use super::volume::{GridPush, SpringFeedback, VolumeGrid, VolumeStep};
use super::wind::wind_at;
use super::{ChunkState, RestShape, StepInput, StepReport};
#[cfg(target_arch = "x86_64")]
use super::{
    lanes::{Avx2, Avx512},
    params::SimdPath,
};
use crate::collide::{Contact, ContactHint};
use crate::math::{Pose, Quat, Vec3};
use contacts::collide;
use final_length::keep_outside;
use glam::{Mat3A, Vec3A};
use segments::keep_segments_outside;
use shape::{global_shape, length_pass, local_shape};
use springs::implicit_springs;

/// Longest step the solver takes in one go; longer ones (a frame hitch) are shortened,
/// because the head's motion over them is unknown anyway.
const MAX_STEP: f32 = 1.0 / 15.0;

/// Shortest step the solver takes. Shorter ones are skipped: nothing moves measurably in
/// a microsecond, and dividing a push-out by such a step would make huge velocities (and
/// below ~1e-38 s, non-finite ones).
pub const MIN_STEP: f32 = 1e-6;

/// A head pose as matrices: per particle a matrix–vector product is cheaper than a
/// quaternion rotation, and the inverse is a transpose computed once.
#[derive(Clone, Copy)]
struct PoseMatrix {
    rotation: Mat3A,
    inverse: Mat3A,
    translation: Vec3A,
}

impl PoseMatrix {
    fn new(pose: &Pose) -> Self {
        let rotation = Mat3A::from_quat(pose.rotation);
        PoseMatrix { rotation, inverse: rotation.transpose(), translation: pose.translation.into() }
    }

    /// World point → head-local.
    #[inline]
    fn local_point(&self, p: Vec3) -> Vec3 {
        (self.inverse * (Vec3A::from(p) - self.translation)).into()
    }

    /// Head-local point → world.
    #[inline]
    fn world_point(&self, p: Vec3) -> Vec3 {
        (self.rotation * Vec3A::from(p) + self.translation).into()
    }

    /// Head-local direction → world.
    #[inline]
    fn rotate(&self, v: Vec3) -> Vec3 {
        (self.rotation * Vec3A::from(v)).into()
    }

    /// A head-local contact → world.
    #[inline]
    fn world_contact(&self, contact: Contact) -> Contact {
        Contact {
            position: self.world_point(contact.position),
            normal: self.rotate(contact.normal),
            depth: contact.depth,
        }
    }
}

/// What one step asks of every strand, whatever steps it: each SIMD path here, and the
/// GPU solver (`hair_gpu` uploads it). `None` from [`StepConstants::new`] means no step.
#[derive(Clone, Debug, PartialEq)]
pub struct StepConstants {
    /// The step's length, seconds: what was asked, shortened to the longest step taken.
    pub dt: f32,
    /// Substep length, seconds.
    pub h: f32,
    /// The head's pose at each substep boundary: `substeps + 1` of them, from the step's
    /// start to its end.
    pub poses: Vec<Pose>,
    /// The share of its velocity a particle keeps per substep against drag.
    pub drag_factor: f32,
    /// The farthest a particle moves in one substep (the speed limit), metres.
    pub max_step_move: f32,
    /// Local shape's turn per application (the share of a joint's bend taken back).
    pub local_alpha: f32,
    /// Global shape's pull per application, per particle of a strand, root to tip.
    pub global_alpha: Vec<f32>,
    /// Where [`CollisionResponse::CentreRay`] pushes from, head-local; `None` for the
    /// normal push, and for a centre outside the head (no ray from there leads out).
    pub ray_from: Option<Vec3>,
    /// Follow-The-Leader's velocity correction per metre of correction.
    pub ftl_velocity: f32,
}

impl StepConstants {
    /// The constants of one step of `input` for strands of `n` particles; `None` when no
    /// step is taken (too short, not finite, or the head's pose is not valid).
    pub fn new(input: &StepInput, n: usize) -> Option<Self> {
        let p = input.params;
        let dt = step_length(input)?;
        let from = if input.head_from.is_valid() { input.head_from } else { input.head_to };
        let substeps = substeps_of(p.substeps, dt);
        let h = dt / substeps as f32;
        let poses = (0..=substeps).map(|s| from.lerp(&input.head_to, s as f32 / substeps as f32)).collect();
        // Shape constraints run `iterations` times per substep.
        let applications_per_second = p.iterations.max(1) as f32 / h;
        let global_alpha = (0..n)
            .map(|j| {
                let t = j as f32 / (n - 1) as f32;
                let s = p.global_stiffness_root + (p.global_stiffness_tip - p.global_stiffness_root) * t;
                stiffness_per_application(s, applications_per_second)
            })
            .collect();
        Some(StepConstants {
            dt,
            h,
            poses,
            drag_factor: (-p.drag * h).exp(),
            max_step_move: p.max_speed * h,
            local_alpha: stiffness_per_application(p.local_stiffness, applications_per_second),
            global_alpha,
            ray_from: match (p.collision_response, input.collider) {
                (CollisionResponse::CentreRay { offset }, Some(collider)) => {
                    Some(collider.centre() + Vec3::from_array(offset)).filter(|&c| collider.signed_distance(c) < 0.0)
                }
                _ => None,
            },
            ftl_velocity: p.ftl_damping / h,
        })
    }
}

/// How many substeps a step of `dt` seconds takes for `per_sixtieth` substeps per 1/60 s
/// ([`SimParams::substeps`](crate::solver::SimParams::substeps)):
/// enough that none is longer than `1 / (60 · per_sixtieth)` s, and at least one. Where hair
/// comes to rest depends on the substep's length (contacts, the length pass and the springs
/// act per substep), so the same settings give the same hair at any hair-clock rate.
pub(crate) fn substeps_of(per_sixtieth: u32, dt: f32) -> u32 {
    // The slack keeps a step of 1/60 s, not exact in binary, from taking one more.
    (per_sixtieth.max(1) as f32 * dt * 60.0 - 1e-3).ceil().max(1.0) as u32
}

/// The step `input` asks for, clamped to [`MAX_STEP`]; `None` when no step is taken (too
/// short, not finite, or the head's pose is not valid).
pub(super) fn step_length(input: &StepInput) -> Option<f32> {
    (input.dt >= MIN_STEP && input.dt.is_finite() && input.head_to.is_valid()).then(|| input.dt.min(MAX_STEP))
}

/// Per-step constants shared by every strand of a chunk: the [`StepConstants`], and what
/// the lanes need of them.
struct Constants<S: Simd> {
    shared: StepConstants,
    /// `poses` as matrices.
    matrices: Vec<PoseMatrix>,
    /// `matrices` splatted across the lanes.
    lane_poses: Vec<PoseLanes<S>>,
    spring_k: Wide<S>,
    spring_d: Wide<S>,
}

impl<S: Simd> Constants<S> {
    #[inline(always)]
    fn new(input: &StepInput, n: usize) -> Option<Self> {
        let shared = StepConstants::new(input, n)?;
        let matrices: Vec<PoseMatrix> = shared.poses.iter().map(PoseMatrix::new).collect();
        let lane_poses = matrices.iter().map(|m| PoseLanes::new(m.rotation, m.translation)).collect();
        // Implicit springs need no cap: any stiffness is stable.
        let p = input.params;
        Some(Constants {
            shared,
            matrices,
            lane_poses,
            spring_k: Wide::splat(p.spring_stiffness),
            spring_d: Wide::splat(p.spring_damping),
        })
    }
}

/// One group's state while it steps: its strands side by side (see [`lanes`](super::lanes)),
/// particle `j` of every lane at index `j`. Allocated once per chunk and step and reused
/// by each group; lanes without a strand copy lane 0 and are never written back.
struct GroupState<S: Simd> {
    /// Strand index of each real lane, within the chunk.
    strands: [usize; MAX_LANES],
    lanes: usize,
    positions: Vec<V3<S>>,
    velocities: Vec<V3<S>>,
    /// Positions at the start of the substep.
    start: Vec<V3<S>>,
    /// Positions at the start of the step.
    step_start: Vec<V3<S>>,
    /// Where each particle would be with no velocity this substep, and the time its
    /// velocity acts over: the integrator's `x = base + step · v`. Explicit Euler has
    /// `base = start`, `step = h`; BDF2 blends in the substep before ([`implicit_springs`]).
    base: Vec<V3<S>>,
    step: Wide<S>,
    /// Gravity and wind, per particle.
    accel: Vec<V3<S>>,
    /// The spring model's memory of the substep before: its start positions and
    /// velocities, and per lane the substep length they were taken at (0: none).
    previous_positions: Vec<V3<S>>,
    previous_velocities: Vec<V3<S>>,
    history_step: Wide<S>,
    /// Whether the hair–hair grid's answer enters the spring solve: then per particle
    /// the velocity its friction pulls toward, the rate, and the push's and the
    /// pressure's velocity change ([`SpringFeedback`]).
    grid_feedback: bool,
    friction_toward: Vec<V3<S>>,
    friction_rate: Vec<Wide<S>>,
    grid_kick: Vec<V3<S>>,
    /// Per particle, the share of its inverse mass the spring solve moves it by: 1, or
    /// less where the grid's friction holds it ([`implicit_springs`]).
    mobility: Vec<Wide<S>>,
    /// The spring solve's scratch: segment directions, and the tridiagonal sweep's
    /// coefficients and unknowns per segment.
    directions: Vec<V3<S>>,
    sweep: Vec<Wide<S>>,
    tension: Vec<Wide<S>>,
    /// Per segment: its length minus rest length at the predicted positions, the right
    /// side of its spring row, its bound (`± length_tolerance × l0`), and whether it is
    /// held there.
    stretch: Vec<Wide<S>>,
    spring_rhs: Vec<Wide<S>>,
    bound: Vec<Wide<S>>,
    rigid: Vec<Mask<S>>,
    ftl_correction: Vec<V3<S>>,
    /// Head-local positions during collision, and per particle the lanes it moved.
    local: Vec<V3<S>>,
    /// Where the head's contacts put each particle (head-local), and along which normal:
    /// written by the queries for the lanes in `moved`, read by friction.
    pushed: Vec<V3<S>>,
    normals: Vec<V3<S>>,
    /// Positions right after collision, before the final length pass.
    collided: Vec<V3<S>>,
    /// Positions before collision: what collision moved a particle by, it did.
    shaped: Vec<V3<S>>,
    /// Per particle, how far `collided` is at least from the head's surface: what the
    /// collision pass knows without asking again (the thickness, less any slide after).
    clearance: Vec<Wide<S>>,
    moved: Vec<u64>,
    rest_positions: Vec<V3<S>>,
    rest_directions: Vec<V3<S>>,
    lengths: Vec<Wide<S>>,
    /// Head-local root frame of each lane.
    root_frames: [Quat; MAX_LANES],
    /// Wind seeds: the strands' indices in the whole groom.
    seeds: [u32; MAX_LANES],
    /// The lanes a segment turn moved in the step ([`keep_segments_outside`], whose
    /// particles from the turn on have an unknown clearance): with the last substep's
    /// contacts (`moved`), where the head touched the strand ([`contact_hold`]).
    turned_lanes: u64,
}

impl<S: Simd> GroupState<S> {
    /// One bit per real lane, as [`Mask::bitmask`] numbers them: empty lanes and the bits
    /// beyond [`Wide::LANES`] are clear, so a mask of lanes still to do can reach zero.
    #[inline(always)]
    fn real_lanes(&self) -> u64 {
        u64::MAX.checked_shr(64 - self.lanes as u32).unwrap_or(0)
    }

    /// A group of strands of `n` particles; the spring model's memory and scratch only
    /// with `springs` (zeroing them for nothing is a cost each chunk pays every step), the
    /// grid's answer in its solve with `grid_feedback` too.
    #[inline(always)]
    fn new(n: usize, springs: bool, grid_feedback: bool) -> Self {
        let spring_n = if springs { n } else { 0 };
        let grid_n = if springs && grid_feedback { n } else { 0 };
        GroupState {
            strands: [0; MAX_LANES],
            lanes: 0,
            positions: vec![V3::zero(); n],
            velocities: vec![V3::zero(); n],
            start: vec![V3::zero(); n],
            step_start: vec![V3::zero(); n],
            base: vec![V3::zero(); n],
            step: Wide::zero(),
            accel: vec![V3::zero(); n],
            previous_positions: vec![V3::zero(); spring_n],
            previous_velocities: vec![V3::zero(); spring_n],
            history_step: Wide::zero(),
            grid_feedback: grid_n > 0,
            friction_toward: vec![V3::zero(); grid_n],
            friction_rate: vec![Wide::zero(); grid_n],
            grid_kick: vec![V3::zero(); grid_n],
            mobility: vec![Wide::one(); spring_n],
            directions: vec![V3::zero(); spring_n],
            sweep: vec![Wide::zero(); spring_n],
            tension: vec![Wide::zero(); spring_n],
            stretch: vec![Wide::zero(); spring_n],
            spring_rhs: vec![Wide::zero(); spring_n],
            bound: vec![Wide::zero(); spring_n],
            rigid: vec![Mask::from_bits(0); spring_n],
            ftl_correction: vec![V3::zero(); n],
            local: vec![V3::zero(); n],
            pushed: vec![V3::zero(); n],
            normals: vec![V3::zero(); n],
            shaped: vec![V3::zero(); n],
            collided: vec![V3::zero(); n],
            clearance: vec![Wide::zero(); n],
            moved: vec![0; n],
            rest_positions: vec![V3::zero(); n],
            rest_directions: vec![V3::zero(); n],
            lengths: vec![Wide::zero(); n],
            root_frames: [Quat::IDENTITY; MAX_LANES],
            seeds: [0; MAX_LANES],
            turned_lanes: 0,
        }
    }

    /// Loads the strands `strands` (chunk-local) of the chunk into the lanes, and their
    /// spring memory if `history`.
    #[inline(always)]
    fn load(&mut self, strands: &[usize], first_strand: usize, rest: Rest, state: &ChunkState, history: bool) {
        let n = self.positions.len();
        let lanes = Wide::<S>::LANES;
        self.lanes = strands.len();
        // Empty lanes repeat the first strand: finite work whose result is dropped.
        self.strands = std::array::from_fn(|l| strands.get(l).copied().unwrap_or(strands[0]));
        // Strand by strand, so each reads its particles in order.
        for (l, &k) in self.strands[..lanes].iter().enumerate() {
            let at = k * n;
            let positions = state.positions[at..][..n].iter().zip(&state.velocities[at..][..n]);
            for (j, (&x, &v)) in positions.enumerate() {
                self.positions[j].set_lane(l, x);
                self.velocities[j].set_lane(l, v);
            }
        }
        // The rest shape as whole vectors where the group is a run of strands that
        // `RestLanes` keeps side by side, else strand by strand.
        let first = first_strand + self.strands[0];
        let run = self.lanes == lanes
            && first.is_multiple_of(lanes)
            && self.strands.windows(2).take(lanes - 1).all(|w| w[1] == w[0] + 1);
        if run {
            let row = |j, row| Wide::from_slice(rest.lanes.row(first, j, row));
            for j in 0..n {
                self.rest_positions[j] =
                    V3 { x: row(j, Row::Position(0)), y: row(j, Row::Position(1)), z: row(j, Row::Position(2)) };
                self.rest_directions[j] =
                    V3 { x: row(j, Row::Direction(0)), y: row(j, Row::Direction(1)), z: row(j, Row::Direction(2)) };
                self.lengths[j] = row(j, Row::Length);
            }
        } else {
            let shape = rest.shape;
            for (l, &k) in self.strands[..lanes].iter().enumerate() {
                let global = (first_strand + k) * n;
                let rest_values = shape.positions[global..][..n].iter().zip(&shape.local_directions[global..][..n]);
                for (j, (&r, &d)) in rest_values.enumerate() {
                    self.rest_positions[j].set_lane(l, r);
                    self.rest_directions[j].set_lane(l, d);
                    self.lengths[j].set(l, shape.lengths[global + j]);
                }
            }
        }
        self.root_frames = self.strands.map(|k| rest.shape.root_frames[first_strand + k]);
        self.seeds = self.strands.map(|k| (first_strand + k) as u32);
        self.history_step = Wide::zero();
        if history {
            for (l, &k) in self.strands[..Wide::<S>::LANES].iter().enumerate() {
                let memory =
                    state.previous_positions[k * n..][..n].iter().zip(&state.previous_velocities[k * n..][..n]);
                for (j, (&x, &v)) in memory.enumerate() {
                    self.previous_positions[j].set_lane(l, x);
                    self.previous_velocities[j].set_lane(l, v);
                }
                self.history_step.set(l, state.history_step[k]);
            }
        }
    }

    /// Loads the grid's answer for the group's strands, `n` per lane in lane order (see
    /// [`VolumeGrid::feed_back_to_springs`]); empty lanes take the first strand's.
    #[inline(always)]
    fn load_grid(&mut self, answers: &[SpringFeedback]) {
        let n = self.positions.len();
        for l in 0..Wide::<S>::LANES {
            let strand = &answers[if l < self.lanes { l } else { 0 } * n..][..n];
            for (j, f) in strand.iter().enumerate() {
                self.friction_toward[j].set_lane(l, f.toward);
                self.friction_rate[j].set(l, f.rate);
                self.grid_kick[j].set_lane(l, f.kick);
            }
        }
    }

    /// Writes the real lanes back into the chunk, and their spring memory if `history`
    /// (without, the chunk is told it has none).
    #[inline(always)]
    fn store(&self, state: &mut ChunkState, history: bool) {
        let n = self.positions.len();
        for (l, &k) in self.strands[..self.lanes].iter().enumerate() {
            for j in 0..n {
                state.positions[k * n + j] = self.positions[j].lane(l);
                state.velocities[k * n + j] = self.velocities[j].lane(l);
            }
            state.history_step[k] = if history { self.history_step.get(l) } else { 0.0 };
            if history {
                for j in 0..n {
                    state.previous_positions[k * n + j] = self.previous_positions[j].lane(l);
                    state.previous_velocities[k * n + j] = self.previous_velocities[j].lane(l);
                }
            }
        }
    }
}

/// The rest shape as a chunk's step reads it: strand by strand, and transposed for its
/// SIMD groups.
#[derive(Clone, Copy)]
pub(super) struct Rest<'a> {
    pub shape: &'a RestShape,
    pub lanes: &'a RestLanes,
}

/// Steps the strands of a chunk on the SIMD path the settings ask for
/// ([`SimParams::simd`](crate::solver::SimParams::simd)).
pub(super) fn step_chunk(
    first_strand: usize,
    rest: Rest,
    roles: Option<&[Role]>,
    volume: Option<(&VolumeGrid, &VolumeStep)>,
    state: &mut ChunkState,
    input: &StepInput,
) -> StepReport {
    // Public fields allow any value: the step runs on what `sanitized` makes of them, so
    // that no setting panics or poisons a strand (a caller learns what was changed by
    // calling it first).
    let (params, _) = input.params.sanitized();
    let input = &StepInput { params: &params, ..*input };
    match input.params.simd.resolved() {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `resolved` picks a path only where the CPU has its instructions.
        SimdPath::Avx512 => unsafe { step_chunk_avx512(first_strand, rest, roles, volume, state, input) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above.
        SimdPath::Avx2 => unsafe { step_chunk_avx2(first_strand, rest, roles, volume, state, input) },
        _ => step_chunk_on::<Baseline>(first_strand, rest, roles, volume, state, input),
    }
}

/// [`step_chunk_on`] compiled for AVX-512: everything it inlines (the whole step but the
/// collider's out-of-line queries) may use it.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn step_chunk_avx512(
    first_strand: usize,
    rest: Rest,
    roles: Option<&[Role]>,
    volume: Option<(&VolumeGrid, &VolumeStep)>,
    state: &mut ChunkState,
    input: &StepInput,
) -> StepReport {
    step_chunk_on::<Avx512>(first_strand, rest, roles, volume, state, input)
}

/// [`step_chunk_on`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn step_chunk_avx2(
    first_strand: usize,
    rest: Rest,
    roles: Option<&[Role]>,
    volume: Option<(&VolumeGrid, &VolumeStep)>,
    state: &mut ChunkState,
    input: &StepInput,
) -> StepReport {
    step_chunk_on::<Avx2>(first_strand, rest, roles, volume, state, input)
}

/// The step on path `S`. It and everything it calls on lanes are `#[inline(always)]`, so
/// that the whole step is compiled for the instructions of the function that calls it.
#[inline(always)]
fn step_chunk_on<S: Simd>(
    first_strand: usize,
    rest: Rest,
    roles: Option<&[Role]>,
    volume: Option<(&VolumeGrid, &VolumeStep)>,
    state: &mut ChunkState,
    input: &StepInput,
) -> StepReport {
    let n = rest.shape.particles_per_strand;
    let mut report = StepReport::default();
    let Some(c) = Constants::<S>::new(input, n) else {
        return report;
    };
    let p = input.params;
    let head_to = *c.shared.poses.last().expect("at least one pose");
    // Only the spring model integrates with memory of the substep before.
    let history = p.length_mode == LengthMode::Springs;
    // The spring model takes the grid's answer into its implicit solve: the feedback
    // leaves it in `for_springs`, strand by strand in lane order, for the group to load.
    let to_springs = history && volume.is_some();
    let mut group_state = GroupState::<S>::new(n, history, to_springs);
    let mut for_springs = vec![SpringFeedback::default(); if to_springs { MAX_LANES * n } else { 0 }];
    // The grid's push on each particle of the group, strand by strand in lane order, taken
    // back from the velocities after the first substep where it left them faster
    // ([`GridPush`]).
    let mut pushes = vec![GridPush::default(); if volume.is_some() { MAX_LANES * n } else { 0 }];

    let stillness = Stillness::of(input);
    let hold = contact_hold::applies(input, stillness).then_some(stillness.key);

    // Chunk-local indices of the strands gathered for the next group.
    let mut group = [0usize; MAX_LANES];
    let mut lanes = 0;
    let strands = state.positions.len() / n;
    for k in 0..strands {
        let rest_x = &rest.shape.positions[(first_strand + k) * n..][..n];
        let (root, pinned) = (state.positions[k * n], head_to.transform_point(rest_x[0]));
        let root_jump = (pinned - root).length();
        if roles.is_some_and(|r| !r[k].stepped()) {
            // Placed from its leaders after the step (`Strands::follow_leaders`).
        } else if root_jump.is_nan() || root_jump > p.teleport_distance {
            reset_strand(state, k, n, rest_x, &head_to);
            report.teleport_resets += 1;
        } else if sleep::stays_asleep(&state.sleep[k], stillness, p, root, pinned) {
            report.sleeping += 1;
        } else {
            // The hair–hair grid's feedback, for the strands that step: a sleeping one
            // keeps its velocity as it fell asleep with.
            if let Some((grid, step)) = volume {
                let (velocities, pushes) = (&mut state.velocities[k * n..][..n], &mut pushes[lanes * n..][..n]);
                if to_springs {
                    let answers = &mut for_springs[lanes * n..][..n];
                    grid.feed_back_to_springs(step, (first_strand + k) * n, velocities, answers, pushes);
                } else {
                    grid.feed_back(step, (first_strand + k) * n, velocities, pushes);
                }
            }
            group[lanes] = k;
            lanes += 1;
        }
        if lanes == Wide::<S>::LANES || (k + 1 == strands && lanes > 0) {
            group_state.load(&group[..lanes], first_strand, rest, state, history);
            if to_springs {
                group_state.load_grid(&for_springs[..lanes * n]);
            }
            let group_pushes = pushes.get(..lanes * n).unwrap_or_default();
            step_group(&mut group_state, state, &c, input, (hold, group_pushes), &mut report);
            group_state.store(state, history);
            for &k in &group[..lanes] {
                let (xs, vs) = (&state.positions[k * n..][..n], &mut state.velocities[k * n..][..n]);
                if !xs.iter().chain(vs.iter()).all(|v| v.is_finite()) {
                    reset_strand(state, k, n, &rest.shape.positions[(first_strand + k) * n..][..n], &head_to);
                    report.nan_resets += 1;
                } else {
                    let anchors = &mut state.anchors[k * n..][..n];
                    sleep::watch(&mut state.sleep[k], anchors, xs, vs, stillness, p, input.dt);
                }
            }
            lanes = 0;
        }
    }
    report
}

/// Puts chunk strand `k` back at rest under `pose`, motionless.
fn reset_strand(state: &mut ChunkState, k: usize, n: usize, rest_x: &[Vec3], pose: &Pose) {
    for (x, &r) in state.positions[k * n..][..n].iter_mut().zip(rest_x) {
        *x = pose.transform_point(r);
    }
    state.velocities[k * n..][..n].fill(Vec3::ZERO);
    state.hints[k * n..][..n].fill(ContactHint::NONE);
    state.previous_positions[k * n..][..n].copy_from_slice(&state.positions[k * n..][..n]);
    state.previous_velocities[k * n..][..n].fill(Vec3::ZERO);
    state.history_step[k] = 0.0;
    state.sleep[k] = SleepWatch::default();
    state.anchors[k * n..][..n].copy_from_slice(&state.positions[k * n..][..n]);
}

#[inline(always)]
fn step_group<S: Simd>(
    g: &mut GroupState<S>,
    state: &mut ChunkState,
    c: &Constants<S>,
    input: &StepInput,
    (hold, pushes): (Option<u64>, &[GridPush]),
    report: &mut StepReport,
) {
    g.step_start.copy_from_slice(&g.positions);
    // The spring model's hold where the head touches it ([`contact_hold`]) compares with
    // the step's start.
    let held = hold.map(|key| contact_hold::lanes_under(g, state, key)).filter(|&lanes| lanes != 0);
    let start_energy = held.map(|lanes| (lanes, contact_hold::motion_and_stretch(g, c, input.params.particle_mass)));
    g.turned_lanes = 0;
    for s in 1..c.shared.poses.len() {
        let poses = SubstepPoses {
            step_start: &c.matrices[0],
            before: &c.matrices[s - 1],
            before_lanes: &c.lane_poses[s - 1],
            now: &c.lane_poses[s],
            now_one: &c.matrices[s],
            frame: c.shared.poses[s].rotation,
            first: s == 1,
            last: s + 1 == c.shared.poses.len(),
        };
        let time = input.time + c.shared.h * s as f32;
        substep(g, state, c, time, &poses, input, report);
        if poses.first {
            take_back_grid_push(g, pushes);
        }
    }
    if let Some((lanes, start)) = start_energy {
        contact_hold::hold_where_touches_gained(g, c, input, lanes, start);
    }
}

/// Takes back from the group's velocities what the grid's push left of speed along itself
/// ([`GridPush::taken_back`]): `pushes` holds each real lane's, strand by strand, or none
/// without volume. The spring model's memory of the substep before loses the same, as it
/// took the push with the velocity ([`implicit_springs`]): else BDF2 read the push's
/// going as a trend and sent the hair back into the cell it was pushed out of.
#[inline(always)]
fn take_back_grid_push<S: Simd>(g: &mut GroupState<S>, pushes: &[GridPush]) {
    let n = g.positions.len();
    let memory = !g.previous_velocities.is_empty();
    for (l, strand) in pushes.chunks_exact(n).enumerate() {
        for (j, push) in strand.iter().enumerate().skip(1) {
            let v = g.velocities[j].lane(l);
            let taken = push.taken_back(v);
            g.velocities[j].set_lane(l, v - taken);
            if memory {
                let before = g.previous_velocities[j].lane(l);
                g.previous_velocities[j].set_lane(l, before - taken);
            }
        }
    }
}

/// The head at the start and end of a substep.
struct SubstepPoses<'a, S: Simd> {
    /// At the start of the step (where a segment resting on an ear's rim lay).
    step_start: &'a PoseMatrix,
    /// For one particle at a time (friction against the moving skin).
    before: &'a PoseMatrix,
    /// The same, for whole lanes at once (friction against the head).
    before_lanes: &'a PoseLanes<S>,
    /// For whole lanes at once.
    now: &'a PoseLanes<S>,
    /// The same, for one particle at a time.
    now_one: &'a PoseMatrix,
    /// The rotation of `now`, for the root frames of local shape.
    frame: Quat,
    /// Whether this is the step's first substep, and its last.
    first: bool,
    last: bool,
}

#[inline(always)]
fn substep<S: Simd>(
    g: &mut GroupState<S>,
    state: &mut ChunkState,
    c: &Constants<S>,
    time: f32,
    poses: &SubstepPoses<S>,
    input: &StepInput,
    report: &mut StepReport,
) {
    let p = input.params;
    let n = g.positions.len();
    let h = Wide::splat(c.shared.h);

    // 1. Forces and integration of the free particles; 2. the root follows the head.
    g.start.copy_from_slice(&g.positions);
    let wind = V3::from_fn(|l| wind_at(&p.wind, g.seeds[l], time));
    let gravity = V3::splat(Vec3::from_array(p.gravity));
    let windless = wind == V3::zero();
    for j in 1..n {
        // Only the wind across the segment pushes; without wind, skip the normalize.
        let wind_across = if windless {
            V3::zero()
        } else {
            let tangent = (g.positions[j] - g.positions[j - 1]).normalize_or(V3::zero());
            wind - tangent * wind.dot(tangent)
        };
        g.accel[j] = gravity + wind_across;
    }
    g.positions[0] = poses.now.world_point(g.rest_positions[0]);
    match p.length_mode {
        LengthMode::Inextensible => {
            let (drag, max_move) = (Wide::splat(c.shared.drag_factor), Wide::splat(c.shared.max_step_move));
            for j in 1..n {
                // Drag takes its share of the velocity carried over, not of what gravity
                // adds this substep: at rest that would hold back part of the weight.
                let v = g.velocities[j] * drag + g.accel[j] * h;
                g.positions[j] += (v * h).clamp_length_max(max_move);
            }
            g.base.copy_from_slice(&g.start);
            g.step = h;
        }
        LengthMode::Springs => implicit_springs(g, c, p, poses.first),
    }

    // 3. Shape and length.
    g.ftl_correction.fill(V3::zero());
    let root_frame = M3::from_fn(|l| Mat3A::from_quat(poses.frame * g.root_frames[l]));
    for _ in 0..p.iterations {
        global_shape(g, &c.shared.global_alpha, poses.now);
        if c.shared.local_alpha > 0.0 {
            local_shape(g, c.shared.local_alpha, root_frame);
        }
        length_pass(g, p);
    }

    // 4. Collision, then one more length pass: pushing particles out of the head
    //    stretches segments, and both length models promise their bound after the step.
    //    That pass must not put a particle back inside, so it turns segments where it
    //    would.
    if p.collision {
        g.shaped.copy_from_slice(&g.positions);
        collide(g, state, p, c, poses, input, report);
        g.collided.copy_from_slice(&g.positions);
        length_pass(g, p);
        keep_outside(g, state, p, poses, input, report);

        if p.segment_collision && poses.last {
            keep_segments_outside(g, state, p, poses, input, report);
        }
    }

    // 5. Velocities: what the integrator's `x = base + step · v` makes of where the
    //    particles ended up, less FTL's brake ([`ftl_brake`]). The root moves with the
    //    head; its speed feeds spring damping, so it gets the same limit.
    let (max_speed, ftl_velocity) = (Wide::splat(p.max_speed), Wide::splat(c.shared.ftl_velocity));
    g.velocities[0] = ((g.positions[0] - g.start[0]) * h.recip()).clamp_length_max(max_speed);
    let inv_step = g.step.recip();
    for j in 1..n {
        let mut moved = (g.positions[j] - g.base[j]) * inv_step;
        if p.collision {
            moved = without_rebound(g, j, moved, inv_step, h, poses);
        }
        let next_correction = if j + 1 < n { g.ftl_correction[j + 1] } else { V3::zero() };
        g.velocities[j] = ftl_brake(moved, next_correction, ftl_velocity).clamp_length_max(max_speed);
        if p.collision && p.length_mode == LengthMode::Springs {
            restart_memory_if_shoved(g, j);
        }
    }
}

/// The velocity `moved` that particle `j`'s positions give, less what collision's shove
/// (every move from `g.shaped` on: contacts, friction, the final length pass, segment
/// turns) added along its own direction: relative to the head's surface there, a shove may
/// stop a particle coming in, but not send it off faster than it was leaving before.
///
/// Contacts are inelastic. Counted whole, a shove becomes speed: a particle pushed out of
/// the head or turned off an ear's rim flew on past where it was put and fell back, and at
/// rest that repeated every few steps (the spring model swung strands by centimetres).
#[inline(always)]
fn without_rebound<S: Simd>(
    g: &GroupState<S>,
    j: usize,
    moved: V3<S>,
    inv_step: Wide<S>,
    h: Wide<S>,
    poses: &SubstepPoses<S>,
) -> V3<S> {
    let shaped = g.shaped[j];
    let shove = (g.positions[j] - shaped).normalize_or(V3::zero());
    let surface = (poses.now.world_point(poses.before_lanes.local_point(shaped)) - shaped) * h.recip();
    let leaving_before = ((shaped - g.base[j]) * inv_step - surface).dot(shove).max(Wide::zero());
    let leaving = (moved - surface).dot(shove);
    moved - shove * (leaving - leaving_before).max(Wide::zero())
}

/// Where collision shoved particle `j`, the spring model's memory of it starts over from
/// where it ended, as if it had been there the substep before too.
///
/// BDF2 extrapolates from the last two substeps' positions (`x + (x − x_before) / 3`), so
/// a remembered shove comes back as half its length again over the next substeps, which
/// [`without_rebound`] cannot see: on an ear's rim a strand on springs was thrown off by
/// its own contacts every step and swung by centimetres at rest. Shoves shorter than
/// [`FORGETTING_SHOVE`] restart it in part, so that rounding does not decide.
#[inline(always)]
fn restart_memory_if_shoved<S: Simd>(g: &mut GroupState<S>, j: usize) {
    let shove = (g.positions[j] - g.shaped[j]).length();
    let restart = (shove * Wide::splat(1.0 / FORGETTING_SHOVE)).min(Wide::one());
    let (x, v) = (g.previous_positions[j], g.previous_velocities[j]);
    g.previous_positions[j] = x + (g.positions[j] - x) * restart;
    g.previous_velocities[j] = v + (g.velocities[j] - v) * restart;
}

/// The shove, m, from which [`restart_memory_if_shoved`] forgets the substep before
/// entirely: far above rounding, far below a contact's push against gravity in a substep.
const FORGETTING_SHOVE: f32 = 1e-6;

/// Follow-The-Leader's velocity correction as a brake: the velocity `moved` a particle's
/// positions give, slowed by Müller's term `−ftl_velocity · next_correction` (its child's
/// correction, the reaction FTL's one-sided projection leaves out) where that term opposes
/// the motion, and by at most the whole speed; where it would push, nothing.
///
/// Müller adds the term whole. That keeps a whipped strand from gaining energy, but it
/// also turns the tension that holds hanging hair up into a velocity the hair does not
/// have (a still strand's child is pulled back up every substep, so its parent is sent
/// down): hair at rest kept speeds of about `9 g h` near the root, and contacts and
/// segment turns made that a jitter. As a brake it still slows a parent that drags its
/// child (what stops the whip), only ever takes energy out, and gives a particle that did
/// not move no velocity at all.
#[inline(always)]
fn ftl_brake<S: Simd>(moved: V3<S>, next_correction: V3<S>, ftl_velocity: Wide<S>) -> V3<S> {
    let opposing = next_correction.dot(moved) * ftl_velocity;
    let share = (opposing * moved.dot(moved).max(Wide::splat(1e-30)).recip()).clamp(Wide::zero(), Wide::one());
    // A correction gone non-finite leaves the velocity non-finite (the clamp would hide
    // it), so that the strand is reset: `× 0` is NaN for NaN and ±∞, and exactly 0 else.
    moved * (Wide::one() - share) + next_correction * Wide::zero()
}

#[cfg(test)]
mod tests;
