//! The time the hair's render-world systems take, measured in them and published in the
//! main world's diagnostics ([`HairDiagnostics::EXTRACT_TIME`],
//! [`HairDiagnostics::RENDER_TIME`]): the render world runs on a thread of its own, and its
//! frame ends after the main world's.

use crate::diagnostics::HairDiagnostics;
use bevy::diagnostic::Diagnostics;
use bevy::platform::time::Instant;
use bevy::prelude::*;
use bevy::render::RenderApp;
use std::sync::{Arc, Mutex, PoisonError};

/// Publishes the render world's hair times.
pub(crate) struct RenderTimingPlugin;

impl Plugin for RenderTimingPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<RenderTimes>().add_systems(PostUpdate, publish_render_times);
    }

    fn finish(&self, app: &mut App) {
        let times = app.world().resource::<RenderTimes>().clone();
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app.insert_resource(times);
        }
    }
}

/// What the hair's render-world systems took since the main world last published it,
/// milliseconds: extraction, then the rest. Shared by both worlds.
#[derive(Resource, Clone, Default)]
pub(crate) struct RenderTimes(Arc<Mutex<[f64; 2]>>);

/// Which of [`RenderTimes`] a system adds to.
#[derive(Clone, Copy)]
pub(crate) enum RenderTime {
    Extract,
    Render,
}

impl RenderTimes {
    /// Adds the time since `started` to `what`.
    pub fn add(&self, what: RenderTime, started: Instant) {
        let elapsed = started.elapsed().as_secs_f64() * 1e3;
        self.0.lock().unwrap_or_else(PoisonError::into_inner)[what as usize] += elapsed;
    }

    fn take(&self) -> [f64; 2] {
        std::mem::take(&mut *self.0.lock().unwrap_or_else(PoisonError::into_inner))
    }
}

/// Publishes what the render world's hair systems took since the last frame.
fn publish_render_times(times: Res<RenderTimes>, mut diagnostics: Diagnostics) {
    let [extract, render] = times.take();
    diagnostics.add_measurement(&HairDiagnostics::EXTRACT_TIME, || extract);
    diagnostics.add_measurement(&HairDiagnostics::RENDER_TIME, || render);
}
