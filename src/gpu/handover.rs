//! The main world's side of a GPU groom ([`GpuSolver`]): letters out, copies back in. No
//! device, no queue: everything here is plain data.

use super::GpuSupport;
use super::letters::{Copied, GpuCommand, Inbox, OwnedStep, ShadowMaps, SortedOrder};
use crate::HairState;
use crate::diagnostics::HairDiagnostics;
use bevy::diagnostic::Diagnostics;
use bevy::prelude::*;
use bevy::render::storage::ShaderBuffer;
use bevy::tasks::{ComputeTaskPool, TaskPool};
use hair_sim::collide::HeadCollider;
use hair_sim::math::{Pose, Vec3 as SimVec3};
use hair_sim::solver::{StepInput, StepReport, Strands, VolumeGrid};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};

/// A groom's GPU side, as the main world sees it.
#[derive(Default)]
pub(crate) struct GpuSolver {
    /// The groom's strands in the render world, while it asks for the GPU.
    link: Option<Link>,
    /// Why the GPU cannot step the groom, once the render world said so: the groom stays
    /// on the CPU until it asks for the CPU and then the GPU again.
    failed: Option<String>,
    /// Reports that came back and were not taken yet ([`Self::take_report`]), summed.
    arrived: Option<StepReport>,
    /// The GPU time of the last step of the latest report that came back, where the
    /// device times passes, until taken ([`Self::take_step_time`]).
    step_time: Option<hair_gpu::StepTime>,
    /// Wall time the last step spent writing its letters, milliseconds (see
    /// [`HairDiagnostics::GPU_HANDOVER_TIME`]).
    pub handover_ms: f64,
    /// Why the GPU last could not step the groom, as reported (`None`: it could, or was
    /// not asked to).
    pub issue: Option<String>,
}

/// A groom's strands in the render world: who they are, the letters on their way there,
/// and the copy on its way back.
struct Link {
    /// Tells these strands from any others in the render world (a regrown or restarted
    /// groom gets new ones).
    key: u64,
    inbox: Arc<Mutex<Inbox>>,
    /// Letters not yet extracted.
    outbox: Vec<GpuCommand>,
    /// Whether the GPU steps the groom (after [`GpuCommand::TakeOver`]); until then the CPU
    /// does.
    running: bool,
    /// The copy back on its way, if one is: its number, the steps sent before it, and how
    /// far the solver's origin moved the particles since it was asked for.
    copy: Option<(u64, u64, SimVec3)>,
    next_copy: u64,
    /// Steps sent to the GPU, how many of them the reports that came back cover, and how
    /// many the CPU's positions hold.
    steps_sent: u64,
    steps_reported: u64,
    steps_copied: u64,
}

/// Numbers for [`Link::key`].
static NEXT_KEY: AtomicU64 = AtomicU64::new(1);

impl Link {
    fn start(strands: &Strands, pose: Pose, collider: &Arc<HeadCollider>) -> Self {
        let inbox = Arc::default();
        let start = GpuCommand::Start {
            rest: strands.rest().clone(),
            pose,
            collider: Arc::clone(collider),
            inbox: Arc::clone(&inbox),
        };
        Link {
            key: NEXT_KEY.fetch_add(1, Ordering::Relaxed),
            inbox,
            outbox: vec![start],
            running: false,
            copy: None,
            next_copy: 0,
            steps_sent: 0,
            steps_reported: 0,
            steps_copied: 0,
        }
    }

    fn inbox(&self) -> std::sync::MutexGuard<'_, Inbox> {
        self.inbox.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

impl GpuSolver {
    /// Writes down a step of `strands` for the GPU, once the GPU has them; until then
    /// (their pipelines compiling) the CPU steps them. `Ok(true)`: the GPU takes the step;
    /// `Ok(false)`: the caller steps them on the CPU, as with `Err`, which says why the GPU
    /// cannot (reported once by the caller).
    /// `collider` is the one `input` holds, shared.
    pub fn step(
        &mut self,
        strands: &Strands,
        input: &StepInput,
        collider: &Arc<HeadCollider>,
        support: &GpuSupport,
    ) -> Result<bool, String> {
        let started = bevy::platform::time::Instant::now();
        if let Some(why) = support.0.as_ref().or(self.failed.as_ref()) {
            self.link = None;
            return Err(why.clone());
        }
        let link = self.link.get_or_insert_with(|| Link::start(strands, input.head_from, collider));
        if !link.running {
            return Ok(false);
        }
        link.outbox.push(GpuCommand::Step(Box::new(OwnedStep::new(input))));
        link.steps_sent += 1;
        self.handover_ms = started.elapsed().as_secs_f64() * 1e3;
        Ok(true)
    }

    /// Takes in what the render world posted: the strands made (the GPU takes the groom
    /// over from `strands` as they are, `pose` the head's at their last step), a failure,
    /// the copies back (the latest positions into `strands`). Whether `strands` changed.
    fn receive(&mut self, strands: &mut Strands, pose: Pose) -> bool {
        let Some(link) = &mut self.link else { return false };
        let (ready, failed, copies) = {
            let mut inbox = link.inbox();
            (inbox.ready, inbox.failed.take(), std::mem::take(&mut inbox.copies))
        };
        if let Some(why) = failed {
            warn!("hair: the GPU stopped stepping a groom: {why}");
            self.failed = Some(why);
            self.link = None;
            return false;
        }
        if ready && !link.running {
            strands.place_followers();
            let n = strands.particles_per_strand().max(1);
            let roots = strands.rest().positions.iter().step_by(n).copied().collect();
            let (positions, velocities) = (strands.positions().to_vec(), strands.velocities().to_vec());
            let volume = strands.volume_grid().map(VolumeGrid::state);
            link.outbox.push(GpuCommand::TakeOver { positions, velocities, roots, pose, volume });
            link.running = true;
        }
        let mut changed = false;
        for Copied { copy, positions, report, time } in copies {
            self.arrived.get_or_insert_default().merge(report);
            self.step_time = time.or(self.step_time);
            let Some((awaited, steps, moved)) = link.copy else { continue };
            if copy != awaited {
                continue; // from before a reset
            }
            link.copy = None;
            link.steps_reported = steps;
            let Some(positions) = positions else { continue };
            let positions: Vec<SimVec3> = positions.into_iter().map(|p| p + moved).collect();
            // The GPU resets a strand that goes non-finite, so this holds.
            if strands.set_positions(&positions).is_ok() {
                link.steps_copied = steps;
                changed = true;
            }
        }
        changed
    }

    /// Asks for a copy back of the steps' report (and of the positions, if `positions`),
    /// unless one is on its way or there is nothing new to copy.
    fn request_copy(&mut self, positions: bool) {
        let Some(link) = self.link.as_mut().filter(|l| l.running) else { return };
        let behind = if positions { link.steps_copied } else { link.steps_reported };
        if link.copy.is_some() || behind == link.steps_sent {
            return;
        }
        let copy = link.next_copy;
        link.next_copy += 1;
        link.copy = Some((copy, link.steps_sent, SimVec3::ZERO));
        link.outbox.push(GpuCommand::CopyBack { copy, positions });
    }

    /// Whether the GPU steps the groom (and writes its drawing).
    pub fn running(&self) -> bool {
        self.link.as_ref().is_some_and(|l| l.running)
    }

    /// How many hair steps the CPU's positions trail the GPU's last step, while the GPU
    /// steps the groom.
    pub fn lag(&self) -> Option<u64> {
        self.link.as_ref().filter(|l| l.running).map(|l| l.steps_sent - l.steps_copied)
    }

    /// The key of the groom's strands in the render world and the letters written since
    /// the last call, while it asks for the GPU.
    pub fn take_letters(&mut self) -> Option<(u64, Vec<GpuCommand>)> {
        self.link.as_mut().map(|l| (l.key, std::mem::take(&mut l.outbox)))
    }

    /// Forgets the GPU strands: the groom steps on the CPU from here (and, asked to, starts
    /// on the GPU again from the CPU's positions).
    pub fn release(&mut self) {
        self.link = None;
        self.failed = None;
    }

    /// The solver's origin moved by `-offset`: see [`Strands::translate`].
    pub fn translate(&mut self, offset: SimVec3) {
        let Some(link) = self.link.as_mut().filter(|l| l.running) else { return };
        link.outbox.push(GpuCommand::Translate(offset));
        if let Some((_, _, moved)) = &mut link.copy {
            *moved += offset;
        }
    }

    /// Every strand's [`Strands::set_rest_root`] at once.
    pub fn set_rest_roots(&mut self, roots: &[SimVec3]) {
        if let Some(link) = self.link.as_mut().filter(|l| l.running) {
            link.outbox.push(GpuCommand::SetRestRoots(roots.to_vec()));
        }
    }

    /// See [`Strands::reset`]; nothing is drawn between before and after.
    pub fn reset(&mut self, pose: Pose) {
        if let Some(link) = self.link.as_mut().filter(|l| l.running) {
            link.outbox.push(GpuCommand::Reset(pose));
            // A copy from before the reset would undo it on the CPU; the CPU's positions
            // are the GPU's now.
            link.copy = None;
            link.steps_copied = link.steps_sent;
            link.steps_reported = link.steps_sent;
        }
    }

    /// The frame's drawing of the strands into `target`, `overstep` of the way from the
    /// step before the last to the last, on the head at `pose`, then the opacity maps and
    /// the blended order of what it draws, where asked for.
    pub fn draw(
        &mut self,
        target: AssetId<ShaderBuffer>,
        root_u: &Arc<[SimVec3]>,
        (overstep, pose): (f32, Pose),
        (shadows, order): (Option<ShadowMaps>, Option<SortedOrder>),
    ) {
        if let Some(link) = self.link.as_mut().filter(|l| l.running) {
            let root_u = Arc::clone(root_u);
            link.outbox.push(GpuCommand::Draw { target, root_u, overstep, pose, shadows, order });
        }
    }

    /// The reports of the GPU's steps that came back since this was last called, summed.
    pub fn take_report(&mut self) -> Option<StepReport> {
        self.arrived.take()
    }

    /// The GPU time of one of the GPU's latest steps, if one came back since this was last
    /// called (only where the device has timestamp queries).
    pub fn take_step_time(&mut self) -> Option<hair_gpu::StepTime> {
        self.step_time.take()
    }
}

/// [`HairSystems::Step`](crate::HairSystems), before the steps: takes in what the render
/// world posted for each GPU groom (the GPU takes over a groom whose strands are made;
/// the latest positions copied back become its CPU positions, their reports its
/// [`HairState::last_report`]) and publishes the GPU's step time.
pub(crate) fn receive_from_gpu(mut grooms: Query<&mut HairState>, mut diagnostics: Diagnostics) {
    let pool = ComputeTaskPool::get_or_init(TaskPool::default);
    let (mut step_ms, mut volume_ms): (Option<f64>, Option<f64>) = (None, None);
    for mut state in &mut grooms {
        if state.gpu.link.is_none() {
            continue;
        }
        let state = &mut *state;
        let pose = state.solver_pose();
        if state.gpu.receive(&mut state.strands, pose) {
            // The copy before becomes the step before, for drawing between the two.
            state.publish(pool);
        }
        if state.gpu.running() {
            state.last_report = state.gpu.take_report().unwrap_or_default();
            if let Some(time) = state.gpu.take_step_time() {
                *step_ms.get_or_insert(0.0) += time.total_ms;
                if let Some(ms) = time.volume_ms {
                    *volume_ms.get_or_insert(0.0) += ms;
                }
            }
        }
    }
    if let Some(ms) = step_ms {
        diagnostics.add_measurement(&HairDiagnostics::GPU_STEP_TIME, || ms);
    }
    if let Some(ms) = volume_ms {
        diagnostics.add_measurement(&HairDiagnostics::GPU_VOLUME_TIME, || ms);
    }
}

/// [`HairSystems::Step`](crate::HairSystems), after the steps: asks for the report of each
/// GPU groom's last steps, and for their positions where the main world reads them (a
/// [`HairReadback`] on the head), unless a copy is on its way.
pub(crate) fn request_copies(mut grooms: Query<(&mut HairState, Has<HairReadback>)>) {
    for (mut state, read_back) in &mut grooms {
        if state.gpu.running() {
            state.bypass_change_detection().gpu.request_copy(read_back);
        }
    }
}

/// On a head whose groom the GPU steps ([`HairBackend::Gpu`](crate::HairBackend)): copy
/// its positions back to the main world, a frame or two late, without waiting
/// ([`HairState::current_positions`], [`HairState::gpu_lag`]). Without it only the steps'
/// reports come back: what the GPU draws, shadows and sorts never needs them.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// fn watch_gpu_hair(mut commands: Commands, heads: Query<Entity, Added<HairGroom>>) {
///     for head in &heads {
///         commands.entity(head).insert((HairBackend::Gpu, HairReadback));
///     }
/// }
/// ```
#[derive(Component, Reflect, Clone, Copy, Debug, Default)]
#[reflect(Component, Default)]
pub struct HairReadback;
