//! Bevy's renderer without a window, started as `App::run` starts it: shared by the render
//! tests (`tests/common`) and the frame-cost example (`examples/frame_cost.rs`, through
//! `#[path]`).

use bevy::app::{PluginGroupBuilder, PluginsState};
use bevy::log::LogPlugin;
use bevy::prelude::*;
use bevy::render::RenderPlugin;
use bevy::window::ExitCondition;
use bevy::winit::WinitPlugin;

/// Bevy's default plugins without a window or a logger, with `render` as the renderer.
pub fn headless_plugins(render: RenderPlugin) -> PluginGroupBuilder {
    DefaultPlugins
        .build()
        .disable::<WinitPlugin>()
        // Each test builds an app; only the first could install the global logger.
        .disable::<LogPlugin>()
        .set(WindowPlugin { primary_window: None, exit_condition: ExitCondition::DontExit, ..default() })
        .set(render)
}

/// What `App::run` does before the first update: waits for the plugins (the renderer
/// starts asynchronously), then finishes them. The caller then runs `App::cleanup`.
pub fn finish_plugins(app: &mut App) {
    while app.plugins_state() == PluginsState::Adding {
        bevy::tasks::tick_global_task_pools_on_main_thread();
    }
    app.finish();
}
