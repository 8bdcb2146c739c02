//! [`HairBackend::Gpu`](crate::HairBackend): grooms stepped and drawn by `hair_gpu`'s compute
//! passes in Bevy's render world, as Bevy's own GPU work is.
//!
//! The main world never touches the device. Each hair step it only writes down what the
//! GPU is to do ([`GpuCommand`]s in the groom's outbox: the step's input, the origin moved,
//! roots moved, a reset, the frame's drawing, a copy back). Extraction moves the letters
//! into the render world, where [`render_world`]'s systems make each groom's GPU strands
//! (their pipelines compiled on a background task: until they are ready, the groom steps
//! on the CPU), record the frame's letters in order into Bevy's frame (the render graph
//! schedule, before the cameras draw: so a frame draws the hair its own steps made), and,
//! once Bevy has submitted the frame, map the copies back and post them to the groom's
//! [`Inbox`], which the main world reads a frame or two later ([`handover`]).

#[cfg(feature = "render")]
mod handover;
#[cfg(feature = "render")]
mod letters;
#[cfg(feature = "render")]
mod render_world;
#[cfg(not(feature = "render"))]
mod without_render;

#[cfg(feature = "render")]
pub use handover::HairReadback;
pub(crate) use handover::{GpuSolver, receive_from_gpu, request_copies};
#[cfg(feature = "render")]
pub(crate) use letters::{ShadowMaps, SortedOrder};
#[cfg(feature = "render")]
pub(crate) use render_world::GpuRenderWorldPlugin;
#[cfg(not(feature = "render"))]
pub(crate) use without_render::GpuSolver;

use bevy::prelude::*;

/// Whether the app can step hair on the GPU: `Some(why)` when it cannot (no renderer).
#[derive(Resource, Clone, Debug)]
pub(crate) struct GpuSupport(pub Option<String>);

impl Default for GpuSupport {
    fn default() -> Self {
        GpuSupport(Some("the app has no render device (a headless app, or no GPU adapter)".into()))
    }
}
