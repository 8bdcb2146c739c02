//! The fixed-step simulation: head pose in, strands stepped in parallel, positions out.

use crate::HairError;
use crate::colliders::HairCollider;
use crate::convert::{from_sim, pose_and_scale};
use crate::diagnostics::HairDiagnostics;
use crate::groom::{GroomStatus, Grown, HairGroom};
use crate::settings::{HairSettings, HairSettingsOverride, effective};
use bevy::diagnostic::Diagnostics;
use bevy::platform::time::Instant;
use bevy::prelude::*;
use bevy::tasks::{ComputeTaskPool, TaskPool};
use hair_sim::collide::{ExtraCollider, HeadCollider};
use hair_sim::groom::RootBinding;
use hair_sim::math::Pose;
use hair_sim::mesh::HeadMesh;
use hair_sim::solver::{STRANDS_PER_GROUP, StepInput, StepReport, Strands};
use std::sync::Arc;

/// Fewest strands worth a task of their own.
const MIN_STRANDS_PER_TASK: usize = 64;

/// A grown, simulating groom: the strand state and what it collides with. The plugin
/// inserts it on the head entity once growth finishes.
#[derive(Component)]
pub struct HairState {
    strands: Strands,
    collider: Arc<HeadCollider>,
    head: Arc<HeadMesh>,
    roots: Vec<RootBinding>,
    /// The description these strands were grown from.
    grown_from: HairGroom,
    /// The head scale baked into `head` and `collider`.
    baked_scale: Vec3,
    pose_from: Pose,
    pose_to: Pose,
    time: f32,
    previous: Vec<Vec3>,
    current: Vec<Vec3>,
    last_report: StepReport,
    /// Fields of the settings last reported as unusable (names, not values: NaN ≠ NaN).
    reported_issues: Vec<&'static str>,
}

impl HairState {
    pub(crate) fn new(grown: Grown, pose: Pose) -> Self {
        let Grown { mut strands, collider, head, roots, scale, groom } = grown;
        strands.reset(pose);
        let current: Vec<Vec3> = strands.positions().iter().map(|&p| from_sim(p)).collect();
        HairState {
            strands,
            collider,
            head,
            roots,
            grown_from: groom,
            baked_scale: scale,
            pose_from: pose,
            pose_to: pose,
            time: 0.0,
            previous: current.clone(),
            current,
            last_report: StepReport::default(),
            reported_issues: Vec::new(),
        }
    }

    /// The solver state (positions and velocities in world space, rest shape).
    pub fn strands(&self) -> &Strands {
        &self.strands
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

    /// Particle positions after the last fixed step, world space, strand-major.
    pub fn current_positions(&self) -> &[Vec3] {
        &self.current
    }

    /// Particle positions after the step before the last.
    pub fn previous_positions(&self) -> &[Vec3] {
        &self.previous
    }

    /// Positions between the last two steps, for drawing between fixed steps: pass
    /// `Time<Fixed>::overstep_fraction()`.
    pub fn interpolated_positions(&self, overstep_fraction: f32) -> impl Iterator<Item = Vec3> + '_ {
        let t = overstep_fraction.clamp(0.0, 1.0);
        self.previous.iter().zip(&self.current).map(move |(a, b)| a.lerp(*b, t))
    }

    /// The head pose (rotation and translation, scale baked into the mesh) the last step
    /// moved the roots to.
    pub fn head_pose(&self) -> Pose {
        self.pose_to
    }

    /// What the last step did: contacts, resets.
    pub fn last_report(&self) -> StepReport {
        self.last_report
    }

    /// Puts every strand back at rest on the head, motionless.
    pub fn reset(&mut self) {
        self.strands.reset(self.pose_to);
        self.current.clear();
        self.current.extend(self.strands.positions().iter().map(|&p| from_sim(p)));
        self.previous.clone_from(&self.current);
    }
}

/// [`HairSystems::SyncRoots`](crate::HairSystems): the head pose this step moves the
/// roots to. A changed head scale regrows the groom (the scale is baked into the collider).
pub(crate) fn sync_roots(mut commands: Commands, mut grooms: Query<(Entity, &mut HairState, &GlobalTransform)>) {
    for (entity, mut state, transform) in &mut grooms {
        let (pose, scale) = pose_and_scale(transform);
        if !scale.abs_diff_eq(state.baked_scale, 1e-4 * state.baked_scale.abs().max_element()) {
            info!("hair on {entity}: the head scale changed from {} to {scale}; regrowing", state.baked_scale);
            commands.entity(entity).remove::<HairState>().insert(GroomStatus::WaitingForMesh);
            continue;
        }
        state.pose_from = state.pose_to;
        state.pose_to = pose;
    }
}

/// [`HairSystems::Simulate`](crate::HairSystems): one solver step per groom, its strands
/// split into chunks on the [`ComputeTaskPool`].
pub(crate) fn simulate(
    time: Res<Time>,
    settings: Res<HairSettings>,
    colliders: Query<(&HairCollider, &GlobalTransform)>,
    mut grooms: Query<(Entity, &mut HairState, Option<&HairSettingsOverride>)>,
    mut errors: MessageWriter<HairError>,
    mut diagnostics: Diagnostics,
) {
    let started = Instant::now();
    let (mut guides, mut particles) = (0, 0);
    let dt = time.delta_secs();
    let extra: Vec<ExtraCollider> = colliders.iter().map(|(c, t)| c.to_world(t)).collect();
    let pool = ComputeTaskPool::get_or_init(TaskPool::default);
    for (entity, mut state, local) in &mut grooms {
        let (params, issues) = effective(&settings, local).sanitized();
        let fields: Vec<&'static str> = issues.iter().map(|i| i.field).collect();
        if fields != state.reported_issues {
            if !issues.is_empty() {
                let list: Vec<String> = issues.iter().map(ToString::to_string).collect();
                let reason = format!("invalid hair settings: {}", list.join("; "));
                warn!("hair on {entity}: {reason}");
                errors.write(HairError { entity, reason });
            }
            state.reported_issues = fields;
        }
        let state = &mut *state;
        let input = StepInput {
            dt,
            time: state.time,
            head_from: state.pose_from,
            head_to: state.pose_to,
            collider: Some(&state.collider),
            extra_colliders: &extra,
            params: &params,
        };
        let strands_per_task =
            state.strands.strand_count().div_ceil(pool.thread_num().max(1) * 4).max(MIN_STRANDS_PER_TASK);
        // Whole SIMD groups per task, so no task steps idle lanes.
        let strands_per_task = strands_per_task.next_multiple_of(STRANDS_PER_GROUP);
        let reports = pool.scope(|scope| {
            for mut chunk in state.strands.chunks_mut(strands_per_task) {
                scope.spawn(async move { chunk.step(&input) });
            }
        });
        let mut report = StepReport::default();
        reports.into_iter().for_each(|r| report.merge(r));
        if report.nan_resets > 0 {
            warn!("hair on {entity}: {} strands produced non-finite values and were reset", report.nan_resets);
        }
        state.last_report = report;
        state.time += dt;
        guides += state.strands.strand_count();
        particles += state.strands.positions().len();
    }
    let elapsed_ms = started.elapsed().as_secs_f64() * 1e3;
    diagnostics.add_measurement(&HairDiagnostics::STEP_TIME, || elapsed_ms);
    diagnostics.add_measurement(&HairDiagnostics::GUIDES, || guides as f64);
    diagnostics.add_measurement(&HairDiagnostics::PARTICLES, || particles as f64);
}

/// [`HairSystems::Writeback`](crate::HairSystems): keeps the last two steps' positions
/// for interpolated drawing.
pub(crate) fn writeback(mut grooms: Query<&mut HairState>) {
    for mut state in &mut grooms {
        let state = &mut *state;
        std::mem::swap(&mut state.previous, &mut state.current);
        state.current.clear();
        state.current.extend(state.strands.positions().iter().map(|&p| from_sim(p)));
    }
}
