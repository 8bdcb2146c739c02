//! [`HairBackend::Gpu`](crate::HairBackend): a groom stepped by `hair_gpu`'s compute pass on
//! the app's render device, and drawn from there (`hair_gpu::GpuDrawing`): nothing waits
//! for the GPU.
//!
//! The GPU keeps the strands between steps. The groom's CPU [`Strands`] mirror its
//! positions a frame or two late, copied back without waiting whenever the last copy has
//! arrived, for what the CPU still computes from them (the drawing's bounds, the blended
//! draw order, opacity maps, [`HairState`](crate::HairState)'s positions);
//! [`HairState::read_back_gpu`](crate::HairState::read_back_gpu) waits for the latest. The
//! steps' report (resets, contacts) comes back the same way, summed over the steps since
//! the last copy of it.
//! What moves the strands from outside a step (the solver's origin following the head, a
//! skinned scalp's roots, a reset) is applied to both.

use bevy::prelude::*;
use hair_sim::math::{Pose, Vec3 as SimVec3};
use hair_sim::solver::{StepInput, StepReport, Strands};

/// The render device's GPU solver context, made once a groom asks for the GPU; `Err` says
/// why there is none. Never inserted without the `render` feature.
#[derive(Resource)]
pub(crate) struct GpuDevice(#[cfg(feature = "render")] Result<std::sync::Arc<hair_gpu::GpuContext>, String>);

/// A groom's GPU strands, while it steps on the GPU, and what was last reported about it.
#[derive(Default)]
pub(crate) struct GpuSolver {
    #[cfg(feature = "render")]
    strands: Option<hair_gpu::GpuStrands>,
    /// The copy of the positions on its way back to the CPU, if one is.
    #[cfg(feature = "render")]
    copy: Option<PositionsCopy>,
    /// The report of the steps since the last one, on its way back, if it is.
    #[cfg(feature = "render")]
    report: Option<hair_gpu::ReportCopy>,
    /// Reports that have arrived and were not taken yet ([`Self::take_report`]), summed.
    arrived: Option<StepReport>,
    /// The GPU time of the last step before the latest report that arrived, milliseconds,
    /// where the device times steps, until taken ([`Self::take_step_ms`]).
    step_ms: Option<f64>,
    /// Wall time the last step spent handing its work to the queue, milliseconds (see
    /// [`HairDiagnostics::GPU_SUBMIT_TIME`](crate::HairDiagnostics::GPU_SUBMIT_TIME)).
    pub submit_ms: f64,
    /// Why the GPU last could not step the groom, as reported (`None`: it could, or was
    /// not asked to).
    pub issue: Option<String>,
}

/// Positions on their way back, and how far the solver's origin moved the particles
/// since they were copied.
#[cfg(feature = "render")]
struct PositionsCopy {
    copy: hair_gpu::PositionsCopy,
    moved: SimVec3,
}

#[cfg(feature = "render")]
impl GpuSolver {
    /// Queues a step of `strands` on the GPU (made from them on the first step), and
    /// brings the CPU mirror up to the last copy that has arrived. `Err` says why the GPU
    /// cannot step them; the caller steps them on the CPU instead.
    pub fn step(&mut self, strands: &mut Strands, input: &StepInput, device: Option<&GpuDevice>) -> Result<(), String> {
        let context = match device.map(|d| &d.0) {
            Some(Ok(context)) => context,
            Some(Err(why)) => return Err(why.clone()),
            None => return Err("the app has no render device".into()),
        };
        let gpu = match &mut self.strands {
            Some(gpu) => gpu,
            empty => {
                let mut gpu = hair_gpu::GpuStrands::new(context, strands.rest(), input.head_from, input.collider)
                    .map_err(|e| e.to_string())?;
                strands.place_followers();
                gpu.set_positions(strands.positions());
                // Nothing drawn between the rest pose and where the CPU left the strands.
                gpu.publish(input.head_from);
                gpu.publish(input.head_from);
                empty.insert(gpu)
            }
        };
        if let Err(e) = gpu.step(input) {
            self.release();
            return Err(e.to_string());
        }
        gpu.publish(input.head_to);
        // The copies that have arrived, if any, into the CPU mirror and the report; then
        // the next, which submits the step with them; else the step alone: one submission.
        self.take_copy(strands, false);
        self.take_arrived_report(false);
        let handing_over = bevy::platform::time::Instant::now();
        self.send();
        if let Some(gpu) = &self.strands {
            gpu.submit();
        }
        self.submit_ms = handing_over.elapsed().as_secs_f64() * 1e3;
        Ok(())
    }

    /// Copies the positions and the report toward the CPU, unless copies are on their way
    /// already.
    fn send(&mut self) {
        let Some(gpu) = &self.strands else { return };
        if self.copy.is_none() {
            self.copy = Some(PositionsCopy { copy: gpu.copy_positions(), moved: SimVec3::ZERO });
        }
        if self.report.is_none() {
            self.report = Some(gpu.copy_report());
        }
    }

    /// Adds the report on its way to those arrived if it has arrived (waiting for it when
    /// `wait`).
    fn take_arrived_report(&mut self, wait: bool) {
        if !self.report.as_ref().is_some_and(|r| r.arrived(wait)) {
            return;
        }
        if let Some(Ok((report, ms))) = self.report.take().map(hair_gpu::ReportCopy::into_timed_report) {
            self.arrived.get_or_insert_default().merge(report);
            self.step_ms = ms.or(self.step_ms);
        }
    }

    /// Takes the copy on its way into `strands` if it has arrived (waiting for it when
    /// `wait`); whether it did.
    fn take_copy(&mut self, strands: &mut Strands, wait: bool) -> bool {
        if !self.copy.as_ref().is_some_and(|c| c.copy.arrived(wait)) {
            return false;
        }
        let Some(PositionsCopy { copy, moved }) = self.copy.take() else { return false };
        let Ok(mut positions) = copy.into_positions() else { return false };
        positions.iter_mut().for_each(|p| *p += moved);
        // The GPU resets a strand that goes non-finite, so this holds.
        strands.set_positions(&positions).is_ok()
    }

    /// Waits for the GPU and copies its latest positions into `strands`; whether there were
    /// GPU strands to read.
    pub fn read_back(&mut self, strands: &mut Strands) -> bool {
        if self.strands.is_none() {
            return false;
        }
        // The copies on their way may predate the last step: wait for them, then copy again.
        self.take_copy(strands, true);
        self.take_arrived_report(true);
        self.send();
        self.take_arrived_report(true);
        self.take_copy(strands, true)
    }

    /// The GPU strands, while the GPU steps the groom.
    pub fn strands(&self) -> Option<&hair_gpu::GpuStrands> {
        self.strands.as_ref()
    }

    /// Forgets the GPU strands: the groom steps on the CPU from here (and starts on the GPU
    /// again from the CPU's positions).
    pub fn release(&mut self) {
        self.strands = None;
        self.copy = None;
        self.report = None;
    }

    /// The solver's origin moved by `-offset`: see [`Strands::translate`].
    pub fn translate(&mut self, offset: SimVec3) {
        if let Some(gpu) = &mut self.strands {
            gpu.translate(offset);
        }
        if let Some(copy) = &mut self.copy {
            copy.moved += offset;
        }
    }

    /// Every strand's [`Strands::set_rest_root`] at once, in one upload.
    pub fn set_rest_roots(&mut self, roots: &[SimVec3]) {
        if let Some(gpu) = &mut self.strands {
            gpu.set_rest_roots(roots);
        }
    }

    /// See [`Strands::reset`]; nothing is drawn between before and after.
    pub fn reset(&mut self, pose: Pose) {
        if let Some(gpu) = &mut self.strands {
            gpu.reset(pose);
        }
        // A copy from before the reset would undo it on the CPU.
        self.copy = None;
    }
}

impl GpuSolver {
    /// The reports of the GPU's steps that came back since this was last called, summed
    /// (a frame or two after their steps; `None`: none came back).
    pub fn take_report(&mut self) -> Option<StepReport> {
        self.arrived.take()
    }

    /// The GPU time of one of the GPU's latest steps, milliseconds, if one came back since
    /// this was last called (only where the device has timestamp queries).
    pub fn take_step_ms(&mut self) -> Option<f64> {
        self.step_ms.take()
    }
}

/// Without the `render` feature there is no GPU: every step is the CPU's, and nothing
/// holds GPU strands to keep in step.
#[cfg(not(feature = "render"))]
impl GpuSolver {
    pub fn step(&mut self, _: &mut Strands, _: &StepInput, _: Option<&GpuDevice>) -> Result<(), String> {
        Err("bevy_hair was built without its `render` feature".into())
    }

    pub fn read_back(&mut self, _: &mut Strands) -> bool {
        false
    }

    pub fn release(&mut self) {}

    pub fn translate(&mut self, _: SimVec3) {}

    pub fn set_rest_roots(&mut self, _: &[SimVec3]) {}

    pub fn reset(&mut self, _: Pose) {}
}

/// Opens the GPU solver on the render device the first time a groom asks for it.
#[cfg(feature = "render")]
pub(crate) fn prepare_gpu_device(
    mut commands: Commands,
    existing: Option<Res<GpuDevice>>,
    backends: Query<&crate::HairBackend>,
    device: Option<Res<bevy::render::renderer::RenderDevice>>,
    queue: Option<Res<bevy::render::renderer::RenderQueue>>,
    adapter: Option<Res<bevy::render::renderer::RenderAdapterInfo>>,
) {
    if existing.is_some() || !backends.iter().any(|b| *b == crate::HairBackend::Gpu) {
        return;
    }
    let context = match (device, queue, adapter) {
        (Some(device), Some(queue), Some(adapter)) => {
            hair_gpu::GpuContext::new(device.wgpu_device().clone(), (**queue.0).clone(), (*adapter.0).clone())
                .map(std::sync::Arc::new)
                .map_err(|e| e.to_string())
        }
        _ => Err("the app has no render device (a headless app, or no GPU adapter)".into()),
    };
    if let Ok(context) = &context {
        info!("hair: the GPU solver runs on {}", context.adapter.name);
    }
    commands.insert_resource(GpuDevice(context));
}
