//! [`HairBackend::Gpu`](crate::HairBackend): a groom stepped by `hair_gpu`'s compute pass on
//! the app's render device, its positions read back after each step into the groom's
//! CPU [`Strands`], which everything else reads as before.
//!
//! The GPU keeps the strands' motion between steps; the CPU strands mirror its positions.
//! What moves the CPU strands from outside a step (the solver's origin following the head,
//! a skinned scalp's roots, a reset) is applied to both.

use bevy::prelude::*;
use hair_sim::math::{Pose, Vec3 as SimVec3};
use hair_sim::solver::{StepInput, Strands};

/// The render device's GPU solver context, made once a groom asks for the GPU; `Err` says
/// why there is none. Never inserted without the `render` feature.
#[derive(Resource)]
pub(crate) struct GpuDevice(#[cfg(feature = "render")] Result<std::sync::Arc<hair_gpu::GpuContext>, String>);

/// A groom's GPU strands, while it steps on the GPU, and what was last reported about it.
#[derive(Default)]
pub(crate) struct GpuSolver {
    #[cfg(feature = "render")]
    strands: Option<hair_gpu::GpuStrands>,
    /// Why the GPU last could not step the groom, as reported (`None`: it could, or was
    /// not asked to).
    pub issue: Option<String>,
}

#[cfg(feature = "render")]
impl GpuSolver {
    /// Steps `strands` on the GPU (made from them on the first step) and copies the
    /// positions back. `Err` says why the GPU cannot step them; the caller steps them on
    /// the CPU instead.
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
                gpu.set_positions(strands.positions());
                empty.insert(gpu)
            }
        };
        let positions = gpu.step(input).and_then(|()| gpu.positions()).map_err(|e| {
            self.strands = None;
            e.to_string()
        })?;
        // The GPU resets a strand that goes non-finite, so this holds.
        strands.set_positions(&positions).map_err(|e| e.to_string())
    }

    /// Forgets the GPU strands: the groom steps on the CPU from here (and starts on the GPU
    /// again from the CPU's positions).
    pub fn release(&mut self) {
        self.strands = None;
    }

    /// The solver's origin moved by `-offset`: see [`Strands::translate`].
    pub fn translate(&mut self, offset: SimVec3) {
        if let Some(gpu) = &mut self.strands {
            gpu.translate(offset);
        }
    }

    /// See [`Strands::set_rest_root`].
    pub fn set_rest_root(&mut self, strand: usize, root: SimVec3) {
        if let Some(gpu) = &mut self.strands {
            gpu.set_rest_root(strand, root);
        }
    }

    /// See [`Strands::reset`].
    pub fn reset(&mut self, pose: Pose) {
        if let Some(gpu) = &mut self.strands {
            gpu.reset(pose);
        }
    }
}

/// Without the `render` feature there is no GPU: every step is the CPU's, and nothing
/// holds GPU strands to keep in step.
#[cfg(not(feature = "render"))]
impl GpuSolver {
    pub fn step(&mut self, _: &mut Strands, _: &StepInput, _: Option<&GpuDevice>) -> Result<(), String> {
        Err("bevy_hair was built without its `render` feature".into())
    }

    pub fn release(&mut self) {}

    pub fn translate(&mut self, _: SimVec3) {}

    pub fn set_rest_root(&mut self, _: usize, _: SimVec3) {}

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
