//! The particles the CPU places for drawing, written into each drawing's buffer from the
//! render world: a write queued from the main world would reach the queue before the render
//! thread submits the frame before, which would then draw this frame's hair.

use super::HairRenderSystems;
use super::timing::{RenderTime, RenderTimes};
use bevy::platform::time::Instant;
use bevy::prelude::*;
use bevy::render::render_asset::RenderAssets;
use bevy::render::renderer::RenderQueue;
use bevy::render::storage::{GpuShaderBuffer, ShaderBuffer};
use bevy::render::{ExtractSchedule, MainWorld, Render, RenderApp, RenderSystems};

/// Writes the particles of the grooms the CPU steps, queued in [`ParticleWrites`], in the
/// render world of the frame they were placed for.
pub(crate) struct ParticleWritesPlugin;

impl Plugin for ParticleWritesPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<ParticleWrites>();
    }

    fn finish(&self, app: &mut App) {
        let Some(render_app) = app.get_sub_app_mut(RenderApp) else { return };
        render_app
            .init_resource::<ParticleWrites>()
            .add_systems(ExtractSchedule, extract_writes.in_set(HairRenderSystems::Extract))
            .add_systems(
                Render,
                write_particles.in_set(HairRenderSystems::Write).in_set(RenderSystems::PrepareResources),
            );
    }
}

/// Each drawing's particles and frames placed this frame, for its buffer.
#[derive(Resource, Default)]
pub(crate) struct ParticleWrites(pub Vec<(AssetId<ShaderBuffer>, Vec<Vec4>)>);

/// [`ExtractSchedule`]: moves the frame's writes into the render world.
fn extract_writes(mut main_world: ResMut<MainWorld>, mut writes: ResMut<ParticleWrites>, times: Res<RenderTimes>) {
    let started = Instant::now();
    writes.0 = std::mem::take(&mut main_world.resource_mut::<ParticleWrites>().0);
    times.add(RenderTime::Extract, started);
}

/// [`RenderSystems::PrepareResources`]: queues the writes, which land before the frame's
/// passes.
fn write_particles(
    mut writes: ResMut<ParticleWrites>,
    buffers: Res<RenderAssets<GpuShaderBuffer>>,
    queue: Res<RenderQueue>,
    times: Res<RenderTimes>,
) {
    let started = Instant::now();
    for (buffer, particles) in writes.0.drain(..) {
        // (A buffer made this frame is prepared by now: `PrepareAssets` came first.)
        if let Some(buffer) = buffers.get(buffer) {
            queue.write_buffer(&buffer.buffer, 0, bytemuck::cast_slice(&particles));
        }
    }
    times.add(RenderTime::Render, started);
}
