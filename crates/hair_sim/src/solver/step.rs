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
//! Strands go through this 16, 32 or 64 at a time (by the SIMD path), side by side in
//! SIMD lanes ([`lanes`](super::lanes)); collision, whose path differs per particle, takes
//! them one by one. A strand whose root jumped more than `teleport_distance` is reset to
//! the rest pose instead; a strand that somehow produced a non-finite value is reset too.

use super::detail::Role;
use super::lanes::{Baseline, M3, MAX_LANES, Mask, PoseLanes, Simd, V3, Wide};
use super::params::{CollisionResponse, LengthMode, SimParams, stiffness_per_application};
use super::rest_lanes::{RestLanes, Row};
use super::sleep::{self, SleepWatch, Stillness};
use super::wind::wind_at;
use super::{ChunkState, RestShape, StepInput, StepReport};
#[cfg(target_arch = "x86_64")]
use super::{
    lanes::{Avx2, Avx512},
    params::SimdPath,
};
use crate::collide::{Contact, ContactHint, HeadCollider, Resolution};
use crate::math::{Pose, Quat, Vec3};
use glam::{Mat3A, Vec3A};

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
        let substeps = p.substeps.max(1);
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
}

impl<S: Simd> GroupState<S> {
    /// One bit per real lane, as [`Mask::bitmask`] numbers them: empty lanes and the bits
    /// beyond [`Wide::LANES`] are clear, so a mask of lanes still to do can reach zero.
    #[inline(always)]
    fn real_lanes(&self) -> u64 {
        u64::MAX.checked_shr(64 - self.lanes as u32).unwrap_or(0)
    }

    /// A group of strands of `n` particles; the spring model's memory and scratch only
    /// with `springs` (zeroing them for nothing is a cost each chunk pays every step).
    #[inline(always)]
    fn new(n: usize, springs: bool) -> Self {
        let spring_n = if springs { n } else { 0 };
        GroupState {
            strands: [0; MAX_LANES],
            lanes: 0,
            positions: vec![V3::zero(); n],
            velocities: vec![V3::zero(); n],
            start: vec![V3::zero(); n],
            base: vec![V3::zero(); n],
            step: Wide::zero(),
            accel: vec![V3::zero(); n],
            previous_positions: vec![V3::zero(); spring_n],
            previous_velocities: vec![V3::zero(); spring_n],
            history_step: Wide::zero(),
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
/// ([`SimParams::simd`]).
pub(super) fn step_chunk(
    first_strand: usize,
    rest: Rest,
    roles: Option<&[Role]>,
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
        SimdPath::Avx512 => unsafe { step_chunk_avx512(first_strand, rest, roles, state, input) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above.
        SimdPath::Avx2 => unsafe { step_chunk_avx2(first_strand, rest, roles, state, input) },
        _ => step_chunk_on::<Baseline>(first_strand, rest, roles, state, input),
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
    state: &mut ChunkState,
    input: &StepInput,
) -> StepReport {
    step_chunk_on::<Avx512>(first_strand, rest, roles, state, input)
}

/// [`step_chunk_on`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn step_chunk_avx2(
    first_strand: usize,
    rest: Rest,
    roles: Option<&[Role]>,
    state: &mut ChunkState,
    input: &StepInput,
) -> StepReport {
    step_chunk_on::<Avx2>(first_strand, rest, roles, state, input)
}

/// The step on path `S`. It and everything it calls on lanes are `#[inline(always)]`, so
/// that the whole step is compiled for the instructions of the function that calls it.
#[inline(always)]
fn step_chunk_on<S: Simd>(
    first_strand: usize,
    rest: Rest,
    roles: Option<&[Role]>,
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
    let mut group_state = GroupState::<S>::new(n, history);

    let stillness = Stillness::of(input);

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
            group[lanes] = k;
            lanes += 1;
        }
        if lanes == Wide::<S>::LANES || (k + 1 == strands && lanes > 0) {
            group_state.load(&group[..lanes], first_strand, rest, state, history);
            step_group(&mut group_state, state, &c, input, &mut report);
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
    report: &mut StepReport,
) {
    for s in 1..c.shared.poses.len() {
        let poses = SubstepPoses {
            before: &c.matrices[s - 1],
            before_lanes: &c.lane_poses[s - 1],
            now: &c.lane_poses[s],
            now_one: &c.matrices[s],
            frame: c.shared.poses[s].rotation,
            last: s + 1 == c.shared.poses.len(),
        };
        let time = input.time + c.shared.h * s as f32;
        substep(g, state, c, time, &poses, input, report);
    }
}

/// The head at the start and end of a substep.
struct SubstepPoses<'a, S: Simd> {
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
    /// Whether this is the step's last substep.
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
        LengthMode::Springs => implicit_springs(g, c, p),
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
#[inline(always)]
fn implicit_springs<S: Simd>(g: &mut GroupState<S>, c: &Constants<S>, p: &SimParams) {
    let n = g.positions.len();
    let h = Wide::splat(c.shared.h);
    // BDF2 where a lane remembers a substep of the same length, else backward Euler.
    let first = g.history_step.cmpne(h);
    let (now, before) = (Wide::splat(4.0 / 3.0), Wide::splat(1.0 / 3.0));
    let current = Wide::select(first, Wide::one(), now);
    let previous = Wide::select(first, Wide::zero(), before);
    let step = Wide::select(first, h, h * Wide::splat(2.0 / 3.0));
    let drag = Wide::splat(c.shared.drag_factor);
    for j in 1..n {
        let (x, v) = (g.start[j], g.velocities[j]);
        g.base[j] = x * current - g.previous_positions[j] * previous;
        // Drag on the carried velocity only, so that at rest the springs carry the whole
        // weight: the static balance does not depend on the air.
        g.velocities[j] = (v * current - g.previous_velocities[j] * previous) * drag + g.accel[j] * step;
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
            let x = g.positions[j] + pull(g, j) * (step * step * w);
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
        g.velocities[j] = (g.velocities[j] + pull(g, j) * (step * w)).clamp_length_max(max_speed);
        g.positions[j] = g.base[j] + g.velocities[j] * step;
    }
}

/// How far inside its bound, as a share of the bound, a segment counts as resting on it.
const BOUND_SLACK: f32 = 1e-3;

/// Most solves that add segments held at their bound, per substep.
const MAX_ACTIVE_SET_PASSES: usize = 4;

/// The net force of the tensions on particle `j`: its own segment pulls it toward the
/// parent, the next one toward the child.
#[inline(always)]
fn pull<S: Simd>(g: &GroupState<S>, j: usize) -> V3<S> {
    let child = if j + 1 < g.positions.len() { g.directions[j + 1] * g.tension[j + 1] } else { V3::zero() };
    g.directions[j] * g.tension[j] - child
}

/// Solves for the segment tensions by Thomas' algorithm (one sweep down the strand, one
/// back up); segment `j` couples to `j + 1` through their shared particle, the pinned
/// root to nothing. A spring row is the implicit force law (see [`implicit_springs`]);
/// a rigid row (`g.rigid`) asks that the segment end at its bound,
/// `(1 ± length_tolerance) l0`, where `displacement` (step² / m) turns a tension into
/// how far it moves a particle.
#[inline(always)]
fn solve_tensions<S: Simd>(g: &mut GroupState<S>, coupling: Wide<S>, displacement: Wide<S>) {
    let n = g.positions.len();
    let mut upper_before = Wide::zero();
    for j in 1..n {
        // J M⁻¹ Jᵀ in units of 1/m: 1 on the diagonal of the first segment (its parent is
        // pinned), 2 elsewhere, −cos(angle) to each neighbour.
        let own = if j == 1 { Wide::one() } else { Wide::splat(2.0) };
        let lower = if j == 1 { Wide::zero() } else { -g.directions[j].dot(g.directions[j - 1]) };
        let upper = if j + 1 < n { -g.directions[j].dot(g.directions[j + 1]) } else { Wide::zero() };
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

/// The length constraint of `p.length_mode`.
#[inline(always)]
fn length_pass<S: Simd>(g: &mut GroupState<S>, p: &SimParams) {
    match p.length_mode {
        LengthMode::Inextensible => follow_the_leader(g),
        LengthMode::Springs => clamp_lengths(g, p.length_tolerance),
    }
}

/// Moves particles out of the head and the extra colliders, with friction. Queries are
/// per particle (their paths differ), on the real lanes only.
#[inline(always)]
fn collide<S: Simd>(
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
                match head_contact(collider, g.local[j].lane(l), thickness, c.shared.ray_from, hint) {
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
/// ([`CollisionResponse::CentreRay`]), or else along the surface normal.
#[inline]
fn head_contact(
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

/// How far outside the surface [`turn_out_of`] lifts the middle of a segment's crossed
/// stretch, m: just clear of it. Lifted onto the particles' collision shell, a segment
/// resting on an ear's rim rose further than gravity brings it back in a step, and fell
/// through the rim again a few steps later, over and over.
const SEGMENT_CLEARANCE: f32 = 1e-4;

/// How many times [`outside_at_length`] turns one segment before collision simply wins.
const MAX_TURNS: usize = 4;

/// Collision leaves a particle on (or beyond) its shell, `thickness` above the surface,
/// unless friction then slid it back along the tangent plane: by less than this share of
/// the thickness, that slide is not checked again.
const FRICTION_SLACK: f32 = 0.25;

/// The final length pass may move a particle by this share of the thickness unchecked: with
/// [`FRICTION_SLACK`] it adds up to the whole thickness, so the particle cannot reach the
/// surface.
const LENGTH_SLACK: f32 = 1.0 - FRICTION_SLACK;

/// How far the final length pass may move a particle that touched the head this substep
/// unchecked, m. Such a particle lies on the shell; moved into it by the full
/// [`LENGTH_SLACK`], a little more each step, a strand bent over an ear's rim or the jaw's
/// edge crept in until its segment crossed and was turned out again, over and over.
#[inline(always)]
fn contact_margin(p: &SimParams) -> f32 {
    CONTACT_SLACK * p.collision_thickness
}

/// [`contact_margin`] as a share of the collision thickness.
const CONTACT_SLACK: f32 = 0.1;

/// Redoes the final length pass, one lane at a time, from the first particle it moved by
/// more than [`LENGTH_SLACK`] of the collision thickness ([`contact_margin`] for one that
/// touched the head): only those can have gone back
/// inside, because collision left every particle at least `(1 - FRICTION_SLACK) ×
/// thickness` above every surface. From there, each particle is placed as the length pass
/// places it (the same rule, one lane at a time) and, if that is inside a collider, its
/// segment is turned about its parent until it is out ([`outside_at_length`]).
#[inline(always)]
fn keep_outside<S: Simd>(
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
fn place_outside<S: Simd>(
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
fn set_final<S: Simd>(g: &mut GroupState<S>, p: &SimParams, l: usize, j: usize, placed: Vec3) {
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
fn contact_at<S: Simd>(
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

/// Segments whose two ends are outside can still cut through a thin part of the head
/// between them (an ear's rim). A segment may reach the head only where its ends' clear
/// balls (what collision left them, [`GroupState::clearance`], less how far the final pass
/// moved them) do not cover it, and the lower end clears less than the surface can rise
/// under it ([`HeadCollider::rise_under`]); on a skull neither happens, so the test runs a
/// lane-wide sum and one table lookup per segment. What remains is tested exactly
/// ([`HeadCollider::segment_crossing`]: by a sharp feature, against the triangles listed
/// in reach; elsewhere, a ray through the BVH). Where it crosses, it turns about its
/// parent until the middle of the crossed stretch is just outside the surface (a few
/// turns at most), the strand below follows it as a leader, and the final pass places the rest
/// outside from there ([`place_outside`]).
#[inline(always)]
fn keep_segments_outside<S: Simd>(
    g: &mut GroupState<S>,
    state: &mut ChunkState,
    p: &SimParams,
    poses: &SubstepPoses<S>,
    input: &StepInput,
    report: &mut StepReport,
) {
    let Some(collider) = input.collider else { return };
    let n = g.positions.len();
    let real_lanes = g.real_lanes();
    // Lanes whose particles from here on were moved by a turn: their clearance is unknown.
    let mut turned_lanes = 0u64;
    // What collision knew, less how far the final pass moved each particle since.
    for j in 1..n {
        g.clearance[j] = (g.clearance[j] - (g.positions[j] - g.collided[j]).length()).max(Wide::zero());
    }
    let cells = collider.rise_cells();
    let (origin, inverse_cell, last) =
        (V3::splat(cells.origin), Wide::splat(cells.inverse_cell), V3::splat(cells.last));
    for j in 2..n {
        let length = (g.positions[j] - g.positions[j - 1]).length();
        let turned = Mask::from_bits(turned_lanes);
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
            turned_lanes |= 1 << l;
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

/// Where to put `child` (head-local, `length` from `parent`) so that the segment between
/// them no longer runs through the head: turned about the parent until the middle of the
/// crossed stretch is just outside the surface ([`SEGMENT_CLEARANCE`]), a few turns at most. Where that does not
/// clear it (a fold of the surface, an ear's rim seen edge-on), the segment turns toward
/// the surface's normal at the parent instead, as little as bisection finds enough.
/// Returns `child` itself when the segment crosses nothing.
fn turn_out_of(collider: &HeadCollider, parent: Vec3, child: Vec3, length: f32) -> Vec3 {
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
fn clear_direction(collider: &HeadCollider, parent: Vec3, out: Vec3, wanted: Vec3, length: f32) -> Option<Vec3> {
    let clear = |d: &Vec3| collider.segment_crossing(parent, parent + *d * length).is_none();
    around(out, wanted).find(clear).or_else(|| {
        let mut sphere: Vec<Vec3> = (0..SPHERE_DIRECTIONS).map(sphere_direction).collect();
        sphere.sort_by(|a, b| b.dot(wanted).total_cmp(&a.dot(wanted)));
        sphere.into_iter().find(clear)
    })
}

/// How many directions [`clear_direction`] tries over the whole sphere as its last resort.
const SPHERE_DIRECTIONS: usize = 96;

/// The `k`-th of [`SPHERE_DIRECTIONS`] unit vectors spread evenly over the sphere (a
/// Fibonacci lattice).
fn sphere_direction(k: usize) -> Vec3 {
    let golden_angle = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let y = 1.0 - 2.0 * (k as f32 + 0.5) / SPHERE_DIRECTIONS as f32;
    let radius = (1.0 - y * y).sqrt();
    let (sin, cos) = (golden_angle * k as f32).sin_cos();
    Vec3::new(radius * cos, y, radius * sin)
}

/// `out` and the directions tilted from it by 30°, 60° and 90° (eight around each), the
/// tilted ones nearest `wanted` first.
fn around(out: Vec3, wanted: Vec3) -> impl Iterator<Item = Vec3> {
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
const BISECTIONS: usize = 5;

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
/// that is outside it at all, and only where none is goes onto the surface, stretching the
/// segment.
fn outside_at_length(
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
    // surface instead, a strand below an ear's rim was left half as long again); failing
    // that, onto its surface (1 µm out), stretching the segment.
    let wanted = (placed - parent) / length;
    let mut out_of_it = None;
    for x in around(deep.normal, wanted).map(|d| parent + d * length) {
        if outside(&contact_at(x)) {
            if reaches(x) {
                return (x, true);
            }
            out_of_it.get_or_insert(x);
        }
    }
    match out_of_it {
        Some(x) => (x, true),
        None => (deep.position - deep.normal * (thickness - 1e-6), false),
    }
}

/// Pulls each particle toward the rest pose carried by the head, by `alpha[j]`.
#[inline(always)]
fn global_shape<S: Simd>(g: &mut GroupState<S>, alpha: &[f32], pose: &PoseLanes<S>) {
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
fn local_shape<S: Simd>(g: &mut GroupState<S>, alpha: f32, root_frame: M3<S>) {
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
fn bend<S: Simd>(g: &GroupState<S>, j: usize, turn: V3<S>) -> [V3<S>; 3] {
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
fn follow_the_leader<S: Simd>(g: &mut GroupState<S>) {
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
fn clamp_lengths<S: Simd>(g: &mut GroupState<S>, tolerance: f32) {
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

/// The contact position with a `friction` fraction of the tangential slide since `start`
/// taken back.
#[inline]
fn with_friction(contact: Contact, start: Vec3, friction: f32) -> Vec3 {
    let slide = contact.position - start;
    let tangential = slide - contact.normal * slide.dot(contact.normal);
    contact.position - tangential * friction
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::Strands;

    /// A group holding one strand at `xs`, with rest shape `rest_positions`.
    fn one(rest_positions: Vec<Vec3>, xs: &[Vec3]) -> GroupState<Baseline> {
        let mut strands = strands_at(RestShape::new(rest_positions, xs.len()).unwrap(), xs);
        let chunks = strands.chunks_mut(1);
        let mut g = GroupState::new(xs.len(), false);
        g.load(&[0], 0, chunks[0].rest, &chunks[0].state, false);
        g
    }

    /// Strands of rest shape `rest` whose particles are at `xs`.
    fn strands_at(rest: RestShape, xs: &[Vec3]) -> Strands {
        let mut strands = Strands::new(rest, Pose::IDENTITY);
        strands.set_positions(xs).unwrap();
        strands
    }

    fn lane0(values: &[V3<Baseline>]) -> Vec<Vec3> {
        values.iter().map(|v| v.lane(0)).collect()
    }

    /// A straight strand hanging 1 m per segment.
    fn hanging(n: usize) -> Vec<Vec3> {
        (0..n).map(|j| Vec3::new(0.0, -(j as f32), 0.0)).collect()
    }

    #[test]
    fn ftl_restores_rest_lengths_and_records_corrections() {
        let mut g = one(hanging(3), &[Vec3::ZERO, Vec3::new(0.0, -2.0, 0.0), Vec3::new(0.0, -2.5, 0.0)]);
        follow_the_leader(&mut g);
        let xs = lane0(&g.positions);
        assert_eq!(xs[1], Vec3::new(0.0, -1.0, 0.0));
        assert_eq!(xs[2], Vec3::new(0.0, -2.0, 0.0));
        let corr = lane0(&g.ftl_correction);
        assert_eq!(corr[1], Vec3::new(0.0, 1.0, 0.0));
        assert_eq!(corr[2], Vec3::new(0.0, 0.5, 0.0));
    }

    #[test]
    fn clamp_keeps_lengths_within_tolerance() {
        let mut g = one(hanging(3), &[Vec3::ZERO, Vec3::new(0.0, -1.5, 0.0), Vec3::new(0.0, -1.55, 0.0)]);
        clamp_lengths(&mut g, 0.1);
        let xs = lane0(&g.positions);
        assert!((xs[1].y + 1.1).abs() < 1e-6);
        assert!(((xs[2] - xs[1]).length() - 0.9).abs() < 1e-6);
        let mut within = one(hanging(3), &[Vec3::ZERO, Vec3::new(0.0, -1.05, 0.0), Vec3::new(0.0, -2.0, 0.0)]);
        clamp_lengths(&mut within, 0.1);
        assert_eq!(within.positions[1].lane(0).y, -1.05, "inside the tolerance nothing moves");
    }

    #[test]
    fn local_shape_keeps_the_bend_relative_to_the_parent() {
        // Rest: an L (down, then +X).
        let l_shape = vec![Vec3::ZERO, Vec3::NEG_Y, Vec3::new(1.0, -1.0, 0.0)];
        let rest_frame = RestShape::new(l_shape.clone(), 3).unwrap().root_frames[0];
        // The head turned 90° about Z: the root frame turns, and full-stiffness local shape
        // must carry the bend along the strand, not just the first segment. Each pass takes
        // each joint all the way, and the reaction at the second joint turns the first
        // segment back a little: the passes converge on the turned L.
        let turn = Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
        let mut g = one(l_shape.clone(), &[Vec3::ZERO, Vec3::new(0.3, -0.2, 0.0), Vec3::new(5.0, 5.0, 0.0)]);
        for _ in 0..40 {
            local_shape(&mut g, 1.0, M3::splat(Mat3A::from_quat(turn * rest_frame)));
        }
        let xs = lane0(&g.positions);
        let first = xs[1].normalize();
        assert!((first - turn * Vec3::NEG_Y).length() < 1e-5, "first {first:?}");
        let second = (xs[2] - xs[1]).normalize();
        assert!((second - turn * Vec3::X).length() < 1e-5, "second segment {second:?}");
        // Half stiffness from a strand bent at the root: the child follows the parent's
        // actual direction, so the L stays an L (angle between segments stays 90°).
        let mut bent = one(l_shape, &[Vec3::ZERO, Vec3::new(1.0, -1.0, 0.0).normalize(), Vec3::new(9.0, 0.0, 0.0)]);
        for _ in 0..60 {
            local_shape(&mut bent, 0.5, M3::splat(Mat3A::from_quat(rest_frame)));
        }
        let xs = lane0(&bent.positions);
        let (a, b) = ((xs[1] - xs[0]).normalize(), (xs[2] - xs[1]).normalize());
        assert!(a.dot(b).abs() < 1e-3, "right angle kept: {}", a.dot(b));
    }

    /// A bend is internal: the three particles it moves keep their centre and their angular
    /// momentum about the joint (the reaction). The follower pull it replaces moved the
    /// child alone.
    #[test]
    fn a_bend_keeps_the_centre_and_the_spin_of_the_particles_it_moves() {
        let rest = vec![Vec3::ZERO, Vec3::NEG_Y, Vec3::new(0.0, -2.0, 0.0), Vec3::new(0.0, -3.0, 0.0)];
        let bent = [Vec3::ZERO, Vec3::NEG_Y, Vec3::new(0.1, -1.995, 0.0), Vec3::new(0.3, -2.97, 0.05)];
        let g = one(rest, &bent);
        let turn = V3::splat(Vec3::new(-0.02, 0.001, -0.01));
        let [a, b, c] = bend(&g, 3, turn).map(|m| m.lane(0));
        assert!((a + b + c).length() < 1e-7, "centre moved {:?}", a + b + c);
        // Angular momentum of the moves about the middle particle (equal masses).
        let middle = bent[2];
        let spin = (bent[1] - middle).cross(a) + (bent[3] - middle).cross(c);
        // Only a twist about the parent segment is left (a chain of points has no twist).
        let axis = (bent[2] - bent[1]).normalize();
        let bend_spin = spin - axis * spin.dot(axis);
        assert!(bend_spin.length() < 1e-7, "the bend spins the joint: {bend_spin:?}");
        assert!(c.length() > 0.1 * 0.02, "the child moves: {c:?}");
        // Next to the root the root takes the reaction: the grandparent does not move.
        let [root, _, _] = bend(&g, 2, turn).map(|m| m.lane(0));
        assert_eq!(root, Vec3::ZERO);
    }

    #[test]
    fn empty_lanes_repeat_the_first_strand_and_are_not_stored() {
        let n = 3;
        let rest = RestShape::new([hanging(n), hanging(n)].concat(), n).unwrap();
        let doubled: Vec<Vec3> = rest.positions.iter().map(|p| *p * 2.0).collect();
        let mut strands = strands_at(rest.clone(), &doubled);
        let mut chunks = strands.chunks_mut(2);
        let (rest, state) = (chunks[0].rest, &mut chunks[0].state);
        let mut g = GroupState::<Baseline>::new(n, false);
        g.load(&[1], 0, rest, state, false);
        assert_eq!((g.lanes, g.strands), (1, [1; MAX_LANES]));
        assert!((0..Wide::<Baseline>::LANES).all(|l| g.positions[2].lane(l) == Vec3::new(0.0, -4.0, 0.0)));
        follow_the_leader(&mut g);
        g.store(state, false);
        assert_eq!(state.positions[n + 2], Vec3::new(0.0, -2.0, 0.0), "strand 1 restored to rest length");
        assert_eq!(state.positions[2], Vec3::new(0.0, -4.0, 0.0), "strand 0 was not in the group");
    }

    #[test]
    fn friction_takes_back_tangential_slide_only() {
        let contact = Contact { position: Vec3::new(1.0, 0.0, 0.0), normal: Vec3::Y, depth: 0.1 };
        let start = Vec3::new(0.0, -0.5, 0.0);
        assert_eq!(with_friction(contact, start, 0.0), contact.position);
        let full = with_friction(contact, start, 1.0);
        assert!((full - Vec3::new(0.0, 0.0, 0.0)).length() < 1e-6, "{full:?}");
    }
}
