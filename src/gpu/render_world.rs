//! The render world's side of GPU grooms: their strands, made on a background task,
//! the main world's letters recorded into Bevy's frame, and the copies back mapped once
//! the frame is submitted.

use super::GpuSupport;
use super::letters::{Copied, GpuCommand, Inbox, ShadowMaps, SortedOrder};
use crate::HairState;
use crate::render::HairRenderSystems;
use crate::render::timing::{RenderTime, RenderTimes};
use bevy::core_pipeline::schedule::camera_driver;
use bevy::platform::collections::{HashMap, HashSet};
use bevy::platform::time::Instant;
use bevy::prelude::*;
use bevy::render::render_asset::RenderAssets;
use bevy::render::render_resource::{Buffer, BufferId};
use bevy::render::renderer::{RenderAdapterInfo, RenderContext, RenderDevice, RenderGraph, RenderQueue};
use bevy::render::storage::GpuShaderBuffer;
use bevy::render::{ExtractSchedule, MainWorld, Render, RenderApp, RenderSystems};
use bevy::tasks::{AsyncComputeTaskPool, Task, block_on, futures_lite::future};
use hair_gpu::{
    GpuContext, GpuDrawOrder, GpuDrawing, GpuError, GpuOpacityMap, GpuPasses, GpuStrands, PositionsCopy, ReportCopy,
    Submission,
};
use hair_sim::collide::HeadCollider;
use std::sync::{Arc, Mutex, PoisonError};

/// Steps and draws GPU grooms in the render world: added by the drawing plugin.
pub(crate) struct GpuRenderWorldPlugin;

impl Plugin for GpuRenderWorldPlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<super::HairReadback>();
    }

    fn finish(&self, app: &mut App) {
        let Some(render_app) = app.get_sub_app_mut(RenderApp) else { return };
        render_app
            .init_resource::<RenderGrooms>()
            .add_systems(ExtractSchedule, extract_letters.in_set(HairRenderSystems::Extract))
            .add_systems(RenderGraph, record_grooms.in_set(HairRenderSystems::Record).before(camera_driver))
            .add_systems(Render, collect_copies.in_set(HairRenderSystems::Collect).in_set(RenderSystems::Cleanup));
        app.insert_resource(GpuSupport(None));
    }
}

/// Every GPU groom's strands, by [`GpuSolver`](super::GpuSolver) key, and the letters
/// extracted this frame.
#[derive(Resource, Default)]
struct RenderGrooms {
    /// The render device as the GPU solver sees it, made at the first groom.
    context: Option<Result<Arc<GpuContext>, String>>,
    /// The drawing's, opacity maps' and sort's passes, compiled off the render thread at
    /// the first groom, for every groom: a groom is handed over once they and its strands
    /// are made, so no frame waits on a compile.
    passes: Option<Passes>,
    grooms: HashMap<u64, RenderGroom>,
    letters: Vec<(u64, GpuCommand)>,
    /// The keys the main world still holds.
    live: HashSet<u64>,
    /// Extraction ran and the render graph has not run since: Bevy renders
    /// nothing while its renderer is in error (a lost device, a validation error), and
    /// makes a new device if it recovers.
    unrecorded: bool,
}

impl RenderGrooms {
    /// The renderer stopped: every groom goes back to the CPU with `why`, and what was
    /// made on the device goes (a recovered renderer has a new one).
    fn stop(&mut self, why: &str) {
        let starting = self.letters.drain(..).filter_map(|(_, letter)| match letter {
            GpuCommand::Start { inbox, .. } => Some(inbox),
            _ => None,
        });
        let inboxes: Vec<_> = starting.chain(self.grooms.drain().map(|(_, groom)| groom.inbox)).collect();
        if !inboxes.is_empty() {
            warn!("hair: {why}; {} GPU grooms step on the CPU", inboxes.len());
        }
        for inbox in inboxes {
            inbox.lock().unwrap_or_else(PoisonError::into_inner).failed = Some(why.to_owned());
        }
        self.context = None;
        self.passes = None;
    }
}

/// A groom's strands in the render world.
struct RenderGroom {
    inbox: Arc<Mutex<Inbox>>,
    collider: Arc<HeadCollider>,
    strands: Strands,
    /// What draws them, and the buffer it draws into.
    drawing: Option<(BufferId, GpuDrawing)>,
    /// The opacity maps asked for with this frame's drawing, and the buffer it drew into.
    shadows: Option<(ShadowMaps, Buffer)>,
    /// One map builder per light, and the buffers it reads (the drawing) and writes (the
    /// guides).
    maps: Vec<(BufferId, BufferId, GpuOpacityMap)>,
    /// The blended order asked for with this frame's drawing, and the buffer it drew into.
    order: Option<(SortedOrder, Buffer)>,
    /// The sort, and the buffers it reads and writes.
    sort: Option<(BufferId, BufferId, GpuDrawOrder)>,
    /// Copies recorded this frame or on their way: number, positions (if asked for), report.
    copies: Vec<(u64, Option<PositionsCopy>, ReportCopy)>,
}

enum Strands {
    /// Pipelines compiling and buffers filling, off the render thread.
    Making(Task<Result<GpuStrands, GpuError>>),
    Made(Box<GpuStrands>),
}

enum Passes {
    /// Compiling, off the render thread.
    Making(Task<GpuPasses>),
    Made(Arc<GpuPasses>),
}

impl Passes {
    /// The passes, once made (polled here, without waiting).
    fn made(&mut self) -> Option<&Arc<GpuPasses>> {
        if let Passes::Making(task) = self
            && let Some(passes) = block_on(future::poll_once(task))
        {
            *self = Passes::Made(Arc::new(passes));
        }
        match self {
            Passes::Made(passes) => Some(passes),
            Passes::Making(_) => None,
        }
    }
}

impl RenderGroom {
    fn inbox(&self) -> std::sync::MutexGuard<'_, Inbox> {
        self.inbox.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn made(&mut self) -> Option<&mut GpuStrands> {
        match &mut self.strands {
            Strands::Made(strands) => Some(strands),
            Strands::Making(_) => None,
        }
    }

    /// Records `letter` (the strands and `passes` are made: the main world writes nothing
    /// else before they are); `Err` says why the GPU cannot step the groom.
    /// `buffers` holds the drawings' buffers.
    fn record(
        &mut self,
        letter: GpuCommand,
        passes: Option<&GpuPasses>,
        buffers: &RenderAssets<GpuShaderBuffer>,
    ) -> Result<(), GpuError> {
        let collider = Arc::clone(&self.collider);
        let Some(strands) = self.made() else { return Ok(()) };
        match letter {
            GpuCommand::Start { .. } => {}
            GpuCommand::TakeOver { positions, velocities, roots, pose, volume } => {
                strands.set_positions(&positions);
                strands.set_velocities(&velocities);
                strands.set_rest_roots(&roots);
                if let Some(volume) = volume {
                    strands.set_volume_state(&volume);
                }
                strands.publish(pose);
                strands.publish(pose);
            }
            GpuCommand::Step(step) => {
                let input = step.input(&collider);
                strands.step(&input)?;
                strands.publish(input.head_to);
            }
            GpuCommand::Translate(offset) => strands.translate(offset),
            GpuCommand::SetRestRoots(roots) => _ = strands.set_rest_roots(&roots),
            GpuCommand::Reset(pose) => strands.reset(pose),
            GpuCommand::CopyBack { copy, positions } => {
                let copied = (copy, positions.then(|| strands.copy_positions()), strands.copy_report());
                self.copies.push(copied);
            }
            GpuCommand::Draw { target, root_u, overstep, pose, shadows, order } => {
                let (Strands::Made(strands), Some(passes)) = (&self.strands, passes) else { return Ok(()) };
                // (Made this frame, a buffer is prepared by now: `PrepareAssets` came first.)
                let Some(target) = buffers.get(target).map(|b| b.buffer.clone()) else { return Ok(()) };
                if self.drawing.as_ref().is_none_or(|(id, _)| *id != target.id()) {
                    let drawing = GpuDrawing::with_passes(strands, &passes.drawing, &root_u, &target)?;
                    self.drawing = Some((target.id(), drawing));
                }
                if let Some((_, drawing)) = &self.drawing {
                    drawing.draw(strands, overstep, pose)?;
                }
                self.order = order.map(|order| (order, target.clone()));
                self.shadows = shadows.map(|maps| (maps, target));
            }
        }
        Ok(())
    }
}

/// [`ExtractSchedule`]: moves every groom's letters into the render world (in the order
/// written), and the keys of the grooms there still are.
fn extract_letters(
    mut main_world: ResMut<MainWorld>,
    mut grooms: ResMut<RenderGrooms>,
    mut states: Local<Option<QueryState<&mut HairState>>>,
    times: Res<RenderTimes>,
) {
    let started = Instant::now();
    let grooms = &mut *grooms;
    if grooms.unrecorded {
        grooms.stop("the renderer stopped (a render error or a lost device)");
    }
    grooms.live.clear();
    let states = states.get_or_insert_with(|| main_world.query::<&mut HairState>());
    for mut state in states.iter_mut(&mut main_world) {
        let Some((key, letters)) = state.bypass_change_detection().gpu.take_letters() else { continue };
        grooms.live.insert(key);
        grooms.letters.extend(letters.into_iter().map(|letter| (key, letter)));
    }
    grooms.unrecorded = true;
    times.add(RenderTime::Extract, started);
}

/// The render graph, before the cameras: makes the strands asked for, records the
/// frame's letters groom by groom in order (steps, drawing, copies back), and adds them to
/// Bevy's frame. Grooms the main world let go of go, and their buffers with them.
fn record_grooms(
    mut context: RenderContext,
    mut grooms: ResMut<RenderGrooms>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    adapter: Res<RenderAdapterInfo>,
    shader_buffers: Res<RenderAssets<GpuShaderBuffer>>,
    times: Res<RenderTimes>,
) {
    let started = Instant::now();
    let RenderGrooms { context: gpu, passes, grooms, letters, live, unrecorded } = &mut *grooms;
    *unrecorded = false;
    grooms.retain(|key, _| live.contains(key));
    // Only a groom handed over, which waited for the passes, gets letters besides its start.
    let made = passes.as_mut().and_then(Passes::made).map(Arc::clone);
    for (key, letter) in letters.drain(..) {
        if let GpuCommand::Start { rest, pose, collider, inbox } = letter {
            let gpu = gpu.get_or_insert_with(|| {
                let context = GpuContext::new(device.wgpu_device().clone(), (**queue.0).clone(), (*adapter.0).clone());
                context.map(Arc::new).map_err(|e| e.to_string())
            });
            let made = match gpu {
                Ok(gpu) => {
                    if passes.is_none() {
                        let device = gpu.device.clone();
                        *passes = Some(Passes::Making(
                            AsyncComputeTaskPool::get().spawn(async move { GpuPasses::new(&device) }),
                        ));
                    }
                    let gpu = Arc::clone(gpu);
                    let collider = Arc::clone(&collider);
                    AsyncComputeTaskPool::get().spawn(async move {
                        let mut strands = GpuStrands::new(&gpu, &rest, pose, Some(&collider))?;
                        strands.set_submission(Submission::Caller);
                        Ok(strands)
                    })
                }
                Err(why) => {
                    inbox.lock().unwrap_or_else(PoisonError::into_inner).failed = Some(why.clone());
                    continue;
                }
            };
            let groom = RenderGroom {
                inbox,
                collider,
                strands: Strands::Making(made),
                drawing: None,
                shadows: None,
                maps: Vec::new(),
                order: None,
                sort: None,
                copies: Vec::new(),
            };
            grooms.insert(key, groom);
            continue;
        }
        let Some(groom) = grooms.get_mut(&key) else { continue };
        if let Err(e) = groom.record(letter, made.as_deref(), &shader_buffers) {
            groom.inbox().failed = Some(e.to_string());
            grooms.remove(&key);
        }
    }
    let mut failed = Vec::new();
    let passes = passes.as_mut().and_then(Passes::made).map(Arc::clone);
    for (&key, groom) in grooms.iter_mut() {
        if let Strands::Making(task) = &mut groom.strands
            && passes.is_some()
            && let Some(made) = block_on(future::poll_once(task))
        {
            match made {
                Ok(strands) => {
                    groom.strands = Strands::Made(Box::new(strands));
                    groom.inbox().ready = true;
                }
                Err(e) => {
                    groom.inbox().failed = Some(e.to_string());
                    failed.push(key);
                }
            }
        }
        if let Some(commands) = groom.made().and_then(|strands| strands.take_commands()) {
            context.add_command_buffer(commands);
        }
        // After the drawing: the order of what it drew, and its opacity maps.
        if let Some((order, drawn)) = groom.order.take()
            && let Some(guides) = shader_buffers.get(order.guides)
            && let Some(passes) = &passes
            && let Some(strands) = groom.made()
        {
            let counts = [strands.strand_count() as u32, strands.particles_per_strand() as u32];
            let pieces = strands.pieces(order.segments_per_piece);
            let wanted = (drawn.id(), guides.buffer.id());
            if groom.sort.as_ref().is_none_or(|(d, g, _)| (*d, *g) != wanted) {
                groom.sort =
                    GpuDrawOrder::with_passes(device.wgpu_device(), &passes.draw_order, &drawn, pieces, &guides.buffer)
                        .inspect_err(|e| warn!("hair: no draw order on the GPU: {e}"))
                        .ok()
                        .map(|sort| (wanted.0, wanted.1, sort));
            }
            if let Some((_, _, sort)) = &groom.sort {
                let encoder = context.command_encoder();
                if let Err(e) = sort.record(&queue, encoder, order.eye, counts, order.segments_per_piece, order.first) {
                    warn!("hair: no draw order on the GPU: {e}");
                }
            }
        }
        if let Some((maps, drawn)) = groom.shadows.take()
            && let Some(guides) = shader_buffers.get(maps.guides)
            && let Some(passes) = &passes
            && let Some(strands) = groom.made()
        {
            let counts = [strands.strand_count() as u32, strands.particles_per_strand() as u32];
            let wanted = (drawn.id(), guides.buffer.id());
            // Builders made for other buffers go; one per light is made as needed.
            groom.maps.retain(|(d, g, _)| (*d, *g) == wanted);
            groom.maps.truncate(maps.lights.len());
            for (k, &light) in maps.lights.iter().enumerate() {
                if groom.maps.len() == k {
                    let particles = counts[0] * counts[1];
                    let map = GpuOpacityMap::with_passes(
                        device.wgpu_device(),
                        &passes.opacity_map,
                        &drawn,
                        particles,
                        &guides.buffer,
                    );
                    match map {
                        Ok(map) => groom.maps.push((wanted.0, wanted.1, map)),
                        Err(e) => {
                            warn!("hair: no opacity map on the GPU: {e}");
                            break;
                        }
                    }
                }
                let offset = maps.first + k as u32 * maps.stride;
                let encoder = context.command_encoder();
                if let Err(e) = groom.maps[k].2.record(&queue, encoder, light, counts, maps.fibres, offset) {
                    warn!("hair: no opacity map on the GPU: {e}");
                }
            }
        }
    }
    for key in failed {
        grooms.remove(&key);
    }
    times.add(RenderTime::Render, started);
}

/// [`RenderSystems::Cleanup`], after Bevy submitted the frame: asks for the copies back
/// recorded in it, and posts those that arrived to their grooms' inboxes. Nothing waits.
fn collect_copies(mut grooms: ResMut<RenderGrooms>, times: Res<RenderTimes>) {
    let started = Instant::now();
    for groom in grooms.grooms.values_mut() {
        for (copy, positions, report) in std::mem::take(&mut groom.copies) {
            // Both asked for at once: they went out together and arrive in the same poll.
            let arrived = report.arrived(false) & positions.as_ref().is_none_or(|p| p.arrived(false));
            if !arrived {
                groom.copies.push((copy, positions, report));
                continue;
            }
            match (positions.map(PositionsCopy::into_positions).transpose(), report.into_timed_report()) {
                (Ok(positions), Ok((report, time))) => {
                    groom.inbox().copies.push(Copied { copy, positions, report, time });
                }
                (Err(e), _) | (_, Err(e)) => groom.inbox().failed = Some(e.to_string()),
            }
        }
    }
    times.add(RenderTime::Render, started);
}
