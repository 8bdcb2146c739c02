//! The simulation: head poses in, strands stepped in parallel, positions out.
//!
//! Each frame [`track_heads`] stamps every head's final pose with the hair clock's time;
//! each hair step ([`HairSchedule`](crate::HairSchedule)) moves the roots to the pose
//! interpolated for the step's end ([`sync_roots`]), steps the solver ([`simulate`]) and
//! keeps the positions in head space ([`writeback`]) for drawing on the head as it is
//! posed in the frame.

use crate::clock::{Hair, HairTime, advance_clock, run_hair_schedule};
use crate::colliders::HairCollider;
use crate::convert::{from_sim, pose_and_scale, to_sim};
use crate::description::{GroomStatus, HairError, HairErrorKind, HairGroom};
use crate::diagnostics::HairDiagnostics;
use crate::gpu::{GpuSolver, GpuSupport};
use crate::settings::{HairBackend, HairSettings, HairSettingsOverride, effective};
use crate::skinning::{RootSkin, ScalpJoint, SkinPatch, head_frame};
use crate::{HairSchedule, HairSystems};
use bevy::diagnostic::Diagnostics;
use bevy::platform::time::Instant;
use bevy::prelude::*;
use bevy::tasks::{ComputeTaskPool, TaskPool};
use hair_sim::collide::{ExtraCollider, HeadCollider};
use hair_sim::groom::{HairFile, RootBinding};
use hair_sim::math::{Pose, Vec3 as SimVec3};
use hair_sim::mesh::HeadMesh;
use hair_sim::solver::{SimParams, StepInput, StepReport, Strands};
use std::sync::{Arc, OnceLock};
use std::time::Duration;

/// A freshly grown groom, what a [`HairState`] starts from (handed back by the growth
/// task).
pub(crate) struct Grown {
    pub strands: Strands,
    pub collider: Arc<HeadCollider>,
    pub head: Arc<HeadMesh>,
    pub roots: Vec<hair_sim::groom::RootBinding>,
    pub scale: Vec3,
    pub groom: HairGroom,
    /// The painted scalp's patches, largest first (`hair_sim::groom::painted_patches`).
    pub scalp_patches: Vec<f32>,
}

/// Fewest simulated strands worth a task of their own.
const MIN_STRANDS_PER_TASK: usize = 64;
/// The fewest particles worth a task of their own when publishing positions.
const MIN_PARTICLES_PER_TASK: usize = 4096;

/// A grown, simulating groom: the strand state and what it collides with. The plugin
/// inserts it on the head entity once growth finishes.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// // The tip of each strand, where the last step left it.
/// fn tips(grooms: Query<&HairState>) {
///     for state in &grooms {
///         let n = state.particles_per_strand();
///         let tips = state.current_positions().chunks_exact(n).map(|strand| strand[n - 1]);
///         info!("{} strands, lowest tip at {:?}", state.roots().len(), tips.map(|t| t.y).reduce(f32::min));
///     }
/// }
/// ```
#[derive(Component)]
pub struct HairState {
    pub(crate) strands: Strands,
    collider: Arc<HeadCollider>,
    head: Arc<HeadMesh>,
    roots: Vec<RootBinding>,
    /// The description these strands were grown from.
    grown_from: HairGroom,
    /// The head scale baked into `head` and `collider`.
    baked_scale: Vec3,
    /// The head pose at the start and the end of the last step, world space.
    pose_from: Pose,
    pose_to: Pose,
    /// Where in the world the solver's space has its origin: the centre of the head mesh
    /// at the end of the last step. The strands are simulated relative to it, so their
    /// coordinates stay small (and `f32` precise) however far from the world origin the
    /// head is.
    origin: SimVec3,
    /// The head's final pose in the frame before this one and in this one, stamped with
    /// the hair clock's time: each step interpolates its head pose between them.
    frame_before: StampedPose,
    frame_now: StampedPose,
    time: f32,
    /// Positions after the step before the last and after the last, in head space.
    previous_local: Vec<Vec3>,
    current_local: Vec<Vec3>,
    /// Positions after the last step, world space: worked out from `current_local` when
    /// first asked for (drawing needs head space only; a crowd's copy-out would write
    /// twice as much), under the head pose and origin it was copied out with.
    current: OnceLock<Vec<Vec3>>,
    /// The head's pose (relative to the origin) and the origin, as `current_local` was
    /// copied out.
    published: (Pose, SimVec3),
    /// How many times positions were copied out ([`Self::published_count`]).
    published_count: u64,
    pub(crate) last_report: StepReport,
    last_step_time: Duration,
    /// A skinned head's scalp joint: the head's frame is the joint's.
    joint: Option<ScalpJoint>,
    /// A skinned head's root triangles, skinned every frame to pin the roots (empty when the
    /// scalp moves rigidly with its joint).
    root_skin: RootSkin,
    /// A skinned head's skin that moves against its scalp joint (a blended neck), skinned
    /// every frame and collided with as drawn.
    pub(crate) skin_patch: Option<SkinPatch>,
    /// Fields of the settings last reported as unusable (names, not values: NaN ≠ NaN).
    reported_issues: Vec<&'static str>,
    /// What was last reported unusable in the groom's [`HairLod`](crate::HairLod).
    pub(crate) detail_issue: Option<String>,
    /// The head's size, metres: the height of its mesh's bounding box (scale baked in).
    head_size: f32,
    /// The groom's GPU side, while it asks for the GPU ([`HairBackend::Gpu`]).
    pub(crate) gpu: GpuSolver,
}

impl HairState {
    pub(crate) fn new(grown: Grown, pose: Pose, joint: Option<ScalpJoint>) -> Self {
        let Grown { mut strands, collider, head, roots, scale, groom, .. } = grown;
        // A scalp skinned to its joint alone moves rigidly with it: nothing to skin per frame.
        let root_skin =
            joint.as_ref().filter(|j| j.share < 1.0).map(|j| j.root_skin(&head, scale, &roots)).unwrap_or_default();
        let skin_patch = joint.as_ref().and_then(|j| j.skin_patch(&head, scale));
        let origin = pose.transform_point(collider.centre());
        strands.reset(relative_to(pose, origin));
        let current_local: Vec<Vec3> = to_head_space(strands.positions(), relative_to(pose, origin)).collect();
        let frame = StampedPose { time: 0.0, pose };
        let head_size = head.height();
        HairState {
            strands,
            collider,
            head,
            roots,
            grown_from: groom,
            baked_scale: scale,
            pose_from: pose,
            pose_to: pose,
            origin,
            frame_before: frame,
            frame_now: frame,
            time: 0.0,
            previous_local: current_local.clone(),
            current_local,
            published_count: 0,
            current: OnceLock::new(),
            published: (relative_to(pose, origin), origin),
            last_report: StepReport::default(),
            last_step_time: Duration::ZERO,
            joint,
            root_skin,
            skin_patch,
            reported_issues: Vec::new(),
            detail_issue: None,
            head_size,
            gpu: GpuSolver::default(),
        }
    }

    /// The solver state: rest shape, velocities, and positions relative to
    /// [`Self::origin`] (world space shifted so the head is near zero).
    pub fn strands(&self) -> &Strands {
        &self.strands
    }

    /// Where the origin of [`Self::strands`]' positions is in the world: the centre of
    /// the head mesh at the end of the last step.
    pub fn origin(&self) -> SimVec3 {
        self.origin
    }

    /// The strands as they are now, as a hair model in the head mesh's own units and space
    /// (the head's scale taken out): write it with [`HairFile::write`] to get a `.hair`
    /// file, or load it back as a [`HairAsset`](crate::HairAsset) for
    /// [`HairGroom::guides_from`].
    pub fn to_hair_file(&self) -> HairFile {
        let n = self.particles_per_strand();
        let scale = self.baked_scale;
        let strands = self
            .current_local
            .chunks_exact(n)
            .map(|strand| strand.iter().map(|&p| to_sim(p / scale)).collect())
            .collect();
        HairFile { strands, info: "bevy_hair".into() }
    }

    /// The head mesh as the solver sees it (head-local, scale baked in).
    pub fn head_mesh(&self) -> &HeadMesh {
        &self.head
    }

    /// The head collider.
    pub fn collider(&self) -> &HeadCollider {
        &self.collider
    }

    /// The description the strands were grown from.
    pub fn grown_from(&self) -> &HairGroom {
        &self.grown_from
    }

    /// Where each guide is rooted on the head mesh.
    pub fn roots(&self) -> &[RootBinding] {
        &self.roots
    }

    /// Particles per strand.
    pub fn particles_per_strand(&self) -> usize {
        self.strands.particles_per_strand()
    }

    /// Particle positions after the last fixed step, world space, strand-major: worked out
    /// from [`Self::current_local_positions`] on the first call after a step. For a
    /// groom the GPU steps ([`HairBackend::Gpu`]) these are a frame or two late, as copied
    /// back without waiting; [`Self::gpu_lag`] says by how many steps.
    pub fn current_positions(&self) -> &[Vec3] {
        self.current.get_or_init(|| {
            let (pose, origin) = self.published;
            self.current_local.iter().map(|&p| from_sim(pose.transform_point(to_sim(p)) + origin)).collect()
        })
    }

    /// Particle positions after the last step, head space (the head's rotation and
    /// translation undone; its scale stays, as in [`Self::head_mesh`]).
    pub fn current_local_positions(&self) -> &[Vec3] {
        &self.current_local
    }

    /// Particle positions after the step before the last, head space.
    pub fn previous_local_positions(&self) -> &[Vec3] {
        &self.previous_local
    }

    /// The positions to draw this frame, world space: interpolated between the last two
    /// steps in head space, then placed on the head as posed this frame
    /// ([`Self::drawn_head_pose`]), so the roots sit on the drawn scalp whatever the frame
    /// rate. Pass `Time<Hair>::overstep_fraction()` ([`HairTime::overstep_fraction`]).
    pub fn interpolated_positions(&self, overstep_fraction: f32) -> impl Iterator<Item = Vec3> + '_ {
        let pose = self.frame_now.pose;
        self.interpolated_local_positions(overstep_fraction).map(move |p| from_sim(pose.transform_point(to_sim(p))))
    }

    /// Where [`Self::interpolated_positions`] puts the roots this frame, without the
    /// other particles.
    pub fn root_positions(&self) -> impl Iterator<Item = Vec3> + '_ {
        let pose = self.frame_now.pose;
        let n = self.particles_per_strand().max(1);
        self.strands.rest().positions.iter().step_by(n).map(move |&r| from_sim(pose.transform_point(r)))
    }

    /// How many times the positions that [`Self::current_positions`] and
    /// [`Self::interpolated_positions`] read have changed: after each step on the CPU, and
    /// for a groom the GPU steps when a copy comes back ([`HairReadback`](crate::HairReadback)).
    pub fn published_count(&self) -> u64 {
        self.published_count
    }

    /// [`Self::interpolated_positions`] in head space. Roots are where the rest shape pins
    /// them this frame (on a skinned head, their skinned triangles).
    pub fn interpolated_local_positions(&self, overstep_fraction: f32) -> impl Iterator<Item = Vec3> + '_ {
        let t = overstep_fraction.clamp(0.0, 1.0);
        let n = self.particles_per_strand();
        let rest = &self.strands.rest().positions;
        self.previous_local
            .iter()
            .zip(&self.current_local)
            .zip(rest)
            .enumerate()
            .map(move |(i, ((a, b), r))| if i % n == 0 { from_sim(*r) } else { a.lerp(*b, t) })
    }

    /// The head's scale, baked into [`Self::head_mesh`], the collider and the head-space
    /// positions.
    pub fn head_scale(&self) -> Vec3 {
        self.baked_scale
    }

    /// The head pose (rotation and translation, scale baked into the mesh) the last step
    /// moved the roots to.
    pub fn head_pose(&self) -> Pose {
        self.pose_to
    }

    /// The head's pose as drawn this frame (its final `GlobalTransform`, without scale).
    pub fn drawn_head_pose(&self) -> Pose {
        self.frame_now.pose
    }

    /// The head pose at hair-clock time `step_end`, the end of a step that starts from the
    /// last step's pose at `step_start`: interpolated between the known poses around it (the
    /// last two frames' and, after the timestep was shortened, the last step's).
    fn head_pose_at(&self, step_start: f64, step_end: f64) -> Pose {
        let (before, now) = (self.frame_before, self.frame_now);
        let between = |a: StampedPose, b: StampedPose| {
            let s = ((step_end - a.time) / (b.time - a.time)).clamp(0.0, 1.0);
            a.pose.lerp(&b.pose, s as f32)
        };
        if step_end >= now.time {
            now.pose
        } else if step_end > before.time {
            between(before, now)
        } else if before.time > step_start {
            between(StampedPose { time: step_start, pose: self.pose_to }, before)
        } else {
            before.pose
        }
    }

    /// The head's size the level of detail sees ([`HairLod`](crate::HairLod)): the height
    /// of its mesh's bounding box, metres, its scale included.
    pub fn head_size(&self) -> f32 {
        self.head_size
    }

    /// Goes to level of detail `level`, strands fading over `fade_steps` hair steps
    /// ([`Strands::set_detail_level`]).
    pub(crate) fn set_detail_level(&mut self, level: u32, fade_steps: u32) {
        self.strands.set_detail_level(level, fade_steps);
    }

    /// What the last step did: contacts, resets. For a groom the GPU steps
    /// ([`HairBackend::Gpu`]), what the GPU's steps did that came back during the last
    /// frame (reports come back a frame or two late, without waiting, summed over the steps
    /// they cover; zero when none came back): summed over every frame, they count every
    /// step once [`Self::gpu_lag`] is 0.
    pub fn last_report(&self) -> StepReport {
        self.last_report
    }

    /// For a head that is a skinned mesh, the joint its hair follows.
    pub fn scalp_joint(&self) -> Option<&ScalpJoint> {
        self.joint.as_ref()
    }

    /// Wall time of this groom's last hair step (solver and collision, all threads
    /// together). The sum over grooms is published as [`HairDiagnostics::STEP_TIME`] per
    /// step; a frame costs this times the steps the hair clock ran in it.
    pub fn last_step_time(&self) -> Duration {
        self.last_step_time
    }

    /// Why the last step ran on the CPU although the groom asks for
    /// [`HairBackend::Gpu`] (as reported in a [`HairError`]); `None` when it ran where it
    /// asked to.
    pub fn gpu_fallback(&self) -> Option<&str> {
        self.gpu.issue.as_deref()
    }

    /// For a groom the GPU steps ([`HairBackend::Gpu`]): how many hair steps this state's
    /// positions ([`Self::current_positions`] and the rest) trail the GPU's last step. With
    /// `HairReadback` on the head (feature `render`) they come back without waiting, a
    /// frame or two late, and 0 means they are the last step's: to read exact positions,
    /// pause the hair clock ([`HairTime::pause`]) and update until it is 0. Without it they
    /// stay where the GPU took the groom over. `None` while the CPU steps the groom (the GPU's pipelines
    /// still compiling, or [`HairBackend::Cpu`]).
    pub fn gpu_lag(&self) -> Option<u64> {
        self.gpu.lag()
    }

    /// The pose of the head at the end of the last step, relative to [`Self::origin`] (the
    /// solver's frame).
    pub(crate) fn solver_pose(&self) -> Pose {
        relative_to(self.pose_to, self.origin)
    }

    /// Puts every strand back at rest on the head, motionless.
    pub fn reset(&mut self) {
        self.strands.reset(relative_to(self.pose_to, self.origin));
        self.gpu.reset(relative_to(self.pose_to, self.origin));
        self.publish(ComputeTaskPool::get_or_init(TaskPool::default));
        self.previous_local.clone_from(&self.current_local);
    }

    /// Copies the solver's positions out: world space, and head space for drawing, keeping
    /// the last step's as the one before.
    pub(crate) fn publish(&mut self, pool: &TaskPool) {
        std::mem::swap(&mut self.previous_local, &mut self.current_local);
        self.refresh(pool);
    }

    /// Copies the solver's positions out as the last step's, in head space, and places a
    /// level of detail's followers, which [`step_on_pool`] leaves, from their leaders'
    /// head-space positions on the way: one pass over a far head's particles instead of two.
    fn refresh(&mut self, pool: &TaskPool) {
        let pose = relative_to(self.pose_to, self.origin);
        self.published = (pose, self.origin);
        self.published_count += 1;
        self.current = OnceLock::new();
        let n = self.strands.particles_per_strand().max(1);
        let count = self.strands.positions().len();
        self.current_local.resize(count, Vec3::ZERO);
        // Whole strands per task, a share per thread of the pool.
        let share = count.div_ceil(pool.thread_num().max(1)).max(MIN_PARTICLES_PER_TASK).next_multiple_of(n);
        let strands = &self.strands;
        let pending = strands.followers_pending();
        pool.scope(|scope| {
            for (c, (positions, local)) in
                strands.positions().chunks(share).zip(self.current_local.chunks_mut(share)).enumerate()
            {
                scope.spawn(async move {
                    for (k, (positions, local)) in positions.chunks(n).zip(local.chunks_mut(n)).enumerate() {
                        if pending && strands.is_following(c * share / n + k) {
                            continue; // placed below
                        }
                        for (&p, local) in positions.iter().zip(local) {
                            *local = from_sim(pose.inverse_transform_point(p));
                        }
                    }
                });
            }
        });
        if !pending {
            return;
        }
        let current_local = &self.current_local;
        let Some(followers) = self.strands.head_space_followers(|i| to_sim(current_local[i])) else { return };
        let followers = &followers;
        pool.scope(|scope| {
            for (c, local) in self.current_local.chunks_mut(share).enumerate() {
                scope.spawn(async move {
                    let mut placed = vec![SimVec3::ZERO; n];
                    for (k, local) in local.chunks_mut(n).enumerate() {
                        let strand = c * share / n + k;
                        if followers.follows(strand) {
                            followers.place(strand, &mut placed);
                            for (&p, local) in placed.iter().zip(local) {
                                *local = from_sim(p);
                            }
                        }
                    }
                });
            }
        });
    }

    /// The solver's strands, the GPU solver, and the input of the next step of `dt`
    /// seconds (poses relative to the origin), borrowed side by side.
    fn next_step<'a>(
        &'a mut self,
        dt: f32,
        params: &'a SimParams,
        extra: &'a [ExtraCollider],
    ) -> (&'a mut Strands, &'a mut GpuSolver, StepInput<'a>) {
        let input = StepInput {
            dt,
            time: self.time,
            head_from: relative_to(self.pose_from, self.origin),
            head_to: relative_to(self.pose_to, self.origin),
            collider: Some(&self.collider),
            extra_colliders: extra,
            surface_patch: self.skin_patch.as_ref().map(SkinPatch::patch),
            params,
        };
        (&mut self.strands, &mut self.gpu, input)
    }

    /// Moves the solver's origin to the head's centre (its mesh's, which may sit far from
    /// the entity's origin) at the end of the coming step: the strands shift by the head's
    /// motion over one step, a small difference of nearby numbers, never by the head's
    /// distance from the world origin.
    fn recentre(&mut self) {
        let origin = self.pose_to.transform_point(self.collider.centre());
        if origin.is_finite() && origin != self.origin {
            self.strands.translate(self.origin - origin);
            self.gpu.translate(self.origin - origin);
            self.origin = origin;
        }
    }
}

/// `pose` with its translation taken relative to `origin`.
fn relative_to(pose: Pose, origin: SimVec3) -> Pose {
    Pose::new(pose.rotation, pose.translation - origin)
}

/// A head pose and the hair-clock time it was seen at.
#[derive(Clone, Copy, Debug)]
struct StampedPose {
    /// Seconds on the hair clock.
    time: f64,
    pose: Pose,
}

/// Positions → head space, both relative to the same origin.
fn to_head_space(positions: &[SimVec3], pose: Pose) -> impl Iterator<Item = Vec3> + '_ {
    positions.iter().map(move |&p| from_sim(pose.inverse_transform_point(p)))
}

/// Simulation: the settings, the extra colliders, and every hair step of every grown groom
/// ([`HairSchedule`](crate::HairSchedule): roots, solver, positions), with each head's pose
/// tracked once a frame. Part of [`HairPlugin`](crate::HairPlugin), which runs the clock:
/// crate-private.
pub(crate) struct SimulationPlugin;

impl Plugin for SimulationPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<HairSettings>()
            .register_type::<HairSettings>()
            .register_type::<HairSettingsOverride>()
            .register_type::<HairCollider>()
            .register_type::<HairBackend>()
            .configure_sets(
                HairSchedule,
                (HairSystems::SyncRoots, HairSystems::Simulate, HairSystems::Writeback).chain(),
            )
            .add_systems(
                HairSchedule,
                (
                    sync_roots.in_set(HairSystems::SyncRoots),
                    simulate.in_set(HairSystems::Simulate),
                    writeback.in_set(HairSystems::Writeback),
                ),
            )
            // Each frame's head pose, before the clock runs that frame's steps.
            .add_systems(
                PostUpdate,
                track_heads.in_set(HairSystems::Step).after(advance_clock).before(run_hair_schedule),
            );
        app.init_resource::<GpuSupport>();
        #[cfg(feature = "render")]
        app.add_systems(
            PostUpdate,
            (
                crate::gpu::receive_from_gpu.after(track_heads).before(run_hair_schedule),
                crate::gpu::request_copies.after(run_hair_schedule),
            )
                .in_set(HairSystems::Step),
        );
    }
}

/// [`HairSystems::Step`](crate::HairSystems), before the steps: stamps each head's final
/// pose of this frame with the hair clock's present. A changed head scale regrows the
/// groom (the scale is baked into the collider).
pub(crate) fn track_heads(
    mut commands: Commands,
    clock: Res<Time<Hair>>,
    mut grooms: Query<(Entity, &mut HairState, &GlobalTransform)>,
    joints: Query<&GlobalTransform>,
) {
    let now = clock.now().as_secs_f64();
    for (entity, mut state, transform) in &mut grooms {
        // A skinned head whose joint is gone keeps its last pose.
        let Ok(frame) = head_frame(transform, state.joint.as_ref(), &joints) else { continue };
        let (pose, scale) = pose_and_scale(&frame);
        if !scale.abs_diff_eq(state.baked_scale, 1e-4 * state.baked_scale.abs().max_element()) {
            info!("hair on {entity}: the head scale changed from {} to {scale}; regrowing", state.baked_scale);
            commands.entity(entity).remove::<HairState>().insert(GroomStatus::WaitingForMesh);
            continue;
        }
        // A skinned head's roots ride their skinned triangles: pinned there, in head space;
        // and the skin that moves against the head is collided with where it is drawn.
        if let Some(joint) = &state.joint
            && (!state.root_skin.is_empty() || state.skin_patch.is_some())
        {
            let matrices = joint.skinning_matrices(&joints);
            let state = &mut *state;
            let roots: Vec<SimVec3> = state
                .root_skin
                .skinned_roots(&matrices)
                .map(|world| pose.inverse_transform_point(to_sim(world)))
                .collect();
            for (strand, &root) in roots.iter().enumerate() {
                state.strands.set_rest_root(strand, root);
            }
            if !roots.is_empty() {
                state.gpu.set_rest_roots(&roots);
            }
            if let Some(patch) = &mut state.skin_patch {
                patch.update(&matrices, pose);
            }
        }
        let frame = StampedPose { time: now, pose };
        // A new groom has no earlier frame: it starts from where the head is now.
        state.frame_before = if state.is_added() { frame } else { state.frame_now };
        state.frame_now = frame;
    }
}

/// [`HairSystems::SyncRoots`](crate::HairSystems): the head pose at the end of this step,
/// interpolated between the frames around it, so every step moves the roots by the
/// head's motion over its own interval.
pub(crate) fn sync_roots(time: Res<Time>, mut grooms: Query<&mut HairState>) {
    let step_end = time.elapsed_secs_f64();
    let step_start = step_end - time.delta_secs_f64();
    for mut state in &mut grooms {
        let pose = state.head_pose_at(step_start, step_end);
        state.pose_from = state.pose_to;
        state.pose_to = pose;
    }
}

/// [`HairSystems::Simulate`](crate::HairSystems): one solver step per groom, over the
/// hair clock's timestep (the generic `Time` inside [`HairSchedule`](crate::HairSchedule)),
/// its strands split into chunks on the [`ComputeTaskPool`].
#[expect(clippy::too_many_arguments, reason = "a system's parameters, each a different kind")]
pub(crate) fn simulate(
    time: Res<Time>,
    settings: Res<HairSettings>,
    colliders: Query<(Entity, &HairCollider, &GlobalTransform)>,
    parents: Query<&ChildOf>,
    mut grooms: Query<(Entity, &mut HairState, Option<&HairSettingsOverride>, Option<&HairBackend>)>,
    gpu_support: Res<GpuSupport>,
    mut errors: MessageWriter<HairError>,
    mut diagnostics: Diagnostics,
) {
    let started = Instant::now();
    let (mut guides, mut particles) = (0, 0);
    // The grooms the GPU steps: their steps handed over, where the GPU stepped any.
    let mut gpu_handover_ms: Option<f64> = None;
    let dt = time.delta_secs();
    // A collider in a hierarchy belongs to the character at its root; a top-level one to all.
    let scoped: Vec<(Option<Entity>, ExtraCollider)> = colliders
        .iter()
        .map(|(e, c, t)| (parents.contains(e).then(|| parents.root_ancestor(e)), c.to_world(t)))
        .collect();
    let pool = ComputeTaskPool::get_or_init(TaskPool::default);
    // The grooms the CPU steps, with what their steps need: stepped side by side below.
    let mut on_cpu = Vec::new();
    for (entity, mut state, local, backend) in &mut grooms {
        let groom_started = Instant::now();
        let (params, issues) = effective(&settings, local).sanitized();
        let fields: Vec<&'static str> = issues.iter().map(|i| i.field).collect();
        if fields != state.reported_issues {
            if !issues.is_empty() {
                let kind = HairErrorKind::Settings(issues);
                warn!("hair on {entity}: {kind}");
                errors.write(HairError { entity, kind });
            }
            state.reported_issues = fields;
        }
        state.recentre();
        // A collider in the groom's character, or a top-level one, near the origin.
        let character = parents.root_ancestor(entity);
        let extra: Vec<ExtraCollider> = scoped
            .iter()
            .filter(|(scope, _)| scope.is_none_or(|s| s == character))
            .map(|(_, c)| c.translated(-state.origin))
            .collect();
        // On the GPU if the groom asks for it and the GPU can step it, else on the CPU.
        let on_gpu = match backend.copied().unwrap_or_default() {
            HairBackend::Gpu => {
                let collider = Arc::clone(&state.collider);
                let (strands, gpu, input) = state.next_step(dt, &params, &extra);
                Some(gpu.step(strands, &input, &collider, &gpu_support))
            }
            HairBackend::Cpu => {
                state.gpu.release();
                None
            }
        };
        let gpu_issue = on_gpu.clone().and_then(Result::err);
        if gpu_issue != state.gpu.issue {
            if let Some(why) = &gpu_issue {
                let kind = HairErrorKind::GpuFallback(why.clone());
                warn!("hair on {entity}: {kind}");
                errors.write(HairError { entity, kind });
            }
            state.gpu.issue = gpu_issue;
        }
        if on_gpu == Some(Ok(true)) {
            // What came back from the GPU's earlier steps: `receive_from_gpu`.
            warn_of_resets(entity, &state.last_report);
            *gpu_handover_ms.get_or_insert(0.0) += state.gpu.handover_ms;
            state.last_step_time = groom_started.elapsed();
            state.time += dt;
            guides += state.strands.strand_count();
            particles += state.strands.strand_count() * state.strands.particles_per_strand();
        } else {
            let simulated = state.strands.simulated_strands();
            on_cpu.push((entity, state, params, extra, simulated));
        }
    }
    // What the solver steps: a level of detail leaves the followers out. The grooms step
    // side by side, each split into chunks of its own: a crowd of far heads, a few strands
    // each, keeps every core busy.
    pool.scope(|scope| {
        for (_, state, params, extra, _) in &mut on_cpu {
            scope.spawn(async move {
                let started = Instant::now();
                let (strands, _, input) = state.next_step(dt, params, extra);
                let report = step_on_pool(strands, &input, pool);
                state.last_report = report;
                state.last_step_time = started.elapsed();
            });
        }
    });
    for (entity, mut state, _, _, simulated) in on_cpu {
        warn_of_resets(entity, &state.last_report);
        state.time += dt;
        guides += simulated;
        particles += simulated * state.strands.particles_per_strand();
    }
    let elapsed_ms = started.elapsed().as_secs_f64() * 1e3;
    diagnostics.add_measurement(&HairDiagnostics::STEP_TIME, || elapsed_ms);
    if let Some(ms) = gpu_handover_ms {
        diagnostics.add_measurement(&HairDiagnostics::GPU_HANDOVER_TIME, || ms);
    }
    diagnostics.add_measurement(&HairDiagnostics::GUIDES, || guides as f64);
    diagnostics.add_measurement(&HairDiagnostics::PARTICLES, || particles as f64);
}

/// Says when a groom's strands went non-finite and were put back at rest (which should not
/// happen: a bug, or settings beyond what the solver can take).
fn warn_of_resets(entity: Entity, report: &StepReport) {
    if report.nan_resets > 0 {
        warn!("hair on {entity}: {} strands produced non-finite values and were reset", report.nan_resets);
    }
}

/// Steps `strands` once, split into chunks of whole SIMD groups on `pool`, as
/// [`HairSystems::Simulate`](crate::HairSystems) steps every groom: for stepping a
/// groom's [`Strands`] outside the plugin (a benchmark, a tool) exactly as the plugin does.
/// Like the plugin, it leaves a level of detail's followers where they were
/// ([`Strands::fade_and_rise`]): [`Strands::place_followers`] places them.
pub fn step_on_pool(strands: &mut Strands, input: &StepInput, pool: &TaskPool) -> StepReport {
    // The volume's splat, a part per thread: each part sums into a grid of its own.
    strands.apply_volume_on(input, pool.thread_num().max(1), |parts| {
        if parts.len() > 1 {
            pool.scope(|scope| {
                for part in parts {
                    scope.spawn(async move { part.run() });
                }
            });
        }
    });
    // Tasks of at least MIN_STRANDS_PER_TASK simulated strands each: a far head's few are
    // spread over all its strands (a task's SIMD groups gather its simulated ones), and
    // stepping them in one task fills the groups' lanes and spares the pool a round trip.
    let tasks = strands.simulated_strands().div_ceil(MIN_STRANDS_PER_TASK).clamp(1, pool.thread_num().max(1) * 4);
    let strands_per_task =
        strands.strand_count().div_ceil(tasks).next_multiple_of(input.params.simd.strands_per_group());
    let reports = if tasks == 1 {
        strands.chunks_mut(strands_per_task.max(1)).into_iter().map(|mut chunk| chunk.step(input)).collect()
    } else {
        pool.scope(|scope| {
            for mut chunk in strands.chunks_mut(strands_per_task) {
                scope.spawn(async move { chunk.step(input) });
            }
        })
    };
    // The strands a level of detail leaves out are placed from the simulated ones as they
    // are copied out for drawing (`HairState`'s writeback), or by `Strands::place_followers`.
    strands.fade_and_rise(input);
    let mut report = StepReport::default();
    reports.into_iter().for_each(|r| report.merge(r));
    report
}

/// [`HairSystems::Writeback`](crate::HairSystems): keeps the last two steps' positions
/// (in head space) for interpolated drawing.
pub(crate) fn writeback(mut grooms: Query<&mut HairState>) {
    let pool = ComputeTaskPool::get_or_init(TaskPool::default);
    // Side by side, each groom split further: a crowd keeps every core busy. A groom the
    // GPU steps has nothing new here: its positions change when a copy comes back
    // (`receive_from_gpu`), and the GPU draws from its own.
    pool.scope(|scope| {
        for mut state in grooms.iter_mut().filter(|state| !state.gpu.running()) {
            scope.spawn(async move { state.publish(pool) });
        }
    });
}
