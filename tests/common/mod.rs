//! Shared headless test harness: a MinimalPlugins app stepping exactly one fixed step
//! per update, and a procedural head with a painted scalp.
#![allow(dead_code)] // each test binary uses a different part

use bevy::mesh::MeshPlugin;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_hair::hair_sim::math::Vec3 as SimVec3;
use bevy_hair::prelude::*;
use bevy_hair::procedural_head_mesh;
use std::time::{Duration, Instant};

mod headless;
pub use headless::{finish_plugins, headless_plugins};

/// One frame: a hair longer than 1/60 s, so every update runs exactly one 60 Hz step.
pub const FRAME: Duration = Duration::from_nanos(16_666_667);

/// A headless app with the hair plugin; time advances by [`FRAME`] per update.
pub fn app() -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin, AssetPlugin::default(), MeshPlugin, HairPlugin::default()));
    app.insert_resource(TimeUpdateStrategy::ManualDuration(FRAME));
    app
}

/// A small groom that grows quickly.
pub fn groom() -> HairGroom {
    HairGroom { guides: 200, segments: 10, length: 0.2, settle_steps: 120, ..default() }
}

/// Spawns the procedural head (5,120 triangles) with `groom` at `transform`.
pub fn spawn_head(app: &mut App, groom: HairGroom, transform: Transform) -> Entity {
    let mesh = app.world_mut().resource_mut::<Assets<Mesh>>().add(procedural_head_mesh(4));
    app.world_mut().spawn((Mesh3d(mesh), transform, groom)).id()
}

/// Updates until the groom is simulating (growth runs on a background task). The wait is
/// wall-clock time, not a count of updates: test binaries run their tests side by side on
/// few cores, and a growth (collider bake and settle) then takes several seconds.
pub fn wait_until_ready(app: &mut App, head: Entity) {
    let start = Instant::now();
    while start.elapsed() < GROWTH_TIMEOUT {
        app.update();
        match app.world().get::<GroomStatus>(head) {
            Some(GroomStatus::Ready { .. }) if app.world().get::<HairState>(head).is_some() => return,
            Some(GroomStatus::Failed(reason)) => panic!("growth failed: {reason}"),
            _ => std::thread::sleep(Duration::from_millis(2)),
        }
    }
    panic!("the groom did not finish growing in {GROWTH_TIMEOUT:?}");
}

/// How long [`wait_until_ready`] waits.
const GROWTH_TIMEOUT: Duration = Duration::from_secs(60);

/// An app with a grown groom on a head at the origin.
pub fn grown(groom: HairGroom) -> (App, Entity) {
    let mut app = app();
    let head = spawn_head(&mut app, groom, Transform::default());
    wait_until_ready(&mut app, head);
    (app, head)
}

/// Runs `n` updates (= `n` fixed steps).
pub fn run(app: &mut App, n: usize) {
    for _ in 0..n {
        app.update();
    }
}

pub fn state(app: &App, head: Entity) -> &HairState {
    app.world().get::<HairState>(head).expect("the groom is simulating")
}

/// Root and tip of every strand.
pub fn roots_and_tips(app: &App, head: Entity) -> Vec<(Vec3, Vec3)> {
    let state = state(app, head);
    let n = state.particles_per_strand();
    state.current_positions().chunks_exact(n).map(|s| (s[0], s[n - 1])).collect()
}

/// Deepest particle below the head surface, metres (0 or less: none inside).
pub fn max_penetration(app: &App, head: Entity) -> f32 {
    let state = state(app, head);
    let n = state.particles_per_strand();
    state
        .current_local_positions()
        .iter()
        .enumerate()
        .filter(|(i, _)| i % n != 0)
        .map(|(_, &p)| -state.collider().signed_distance(SimVec3::from_array(p.to_array())))
        .fold(f32::MIN, f32::max)
}

/// Every position finite.
pub fn all_finite(app: &App, head: Entity) -> bool {
    state(app, head).strands().positions().iter().all(|p: &SimVec3| p.is_finite())
}

/// Changes the global settings.
pub fn settings(app: &mut App, change: impl FnOnce(&mut SimParams)) {
    change(&mut app.world_mut().resource_mut::<HairSettings>().0);
}

/// Why rendering cannot run here, if it cannot: no Vulkan adapter.
pub fn no_adapter() -> Option<String> {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    bevy::tasks::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions::default()))
        .err()
        .map(|e| format!("no GPU adapter ({e}); install mesa-vulkan-drivers and libvulkan1 for lavapipe"))
}

/// An app with Bevy's renderer (no window; pipelines compiled when first used, so that no
/// frame is drawn without them) and the hair plugin, started as `App::run` starts one.
pub fn rendering_app() -> App {
    use bevy::render::RenderPlugin;
    let mut app = App::new();
    app.add_plugins(headless_plugins(RenderPlugin { synchronous_pipeline_compilation: true, ..default() }))
        .add_plugins(HairPlugin::default());
    finish_plugins(&mut app);
    app.cleanup();
    app
}

/// [`rendering_app`] with time advancing by [`FRAME`] per update: what the GPU backend
/// steps in (the render world), drawing nothing unless a test adds a camera. `Err` says why
/// there is none.
pub fn app_with_render_device() -> Result<App, String> {
    if let Some(reason) = no_adapter() {
        return Err(reason);
    }
    let mut app = rendering_app();
    app.insert_resource(TimeUpdateStrategy::ManualDuration(FRAME));
    Ok(app)
}

/// Updates with the hair clock paused until the groom on `head` steps on the GPU (its
/// pipelines compiled and its strands handed over), or it reports why it cannot.
pub fn wait_until_on_gpu(app: &mut App, head: Entity) {
    paused(app, |app| {
        let start = Instant::now();
        while state(app, head).gpu_lag().is_none() && state(app, head).gpu_fallback().is_none() {
            assert!(start.elapsed() < GROWTH_TIMEOUT, "the GPU did not take the groom over");
            app.update();
        }
    });
}

/// Updates with the hair clock paused until the positions of the groom on `head` are the
/// GPU's last step's (they come back a frame or two late); the reports that came back on
/// the way, summed.
pub fn wait_for_gpu(app: &mut App, head: Entity) -> StepReport {
    let mut reported = StepReport::default();
    paused(app, |app| {
        let start = Instant::now();
        while state(app, head).gpu_lag().is_some_and(|lag| lag > 0) {
            assert!(start.elapsed() < GROWTH_TIMEOUT, "the GPU's positions did not come back");
            app.update();
            reported.merge(state(app, head).last_report());
        }
    });
    reported
}

/// Runs `f` with the hair clock paused.
fn paused(app: &mut App, f: impl FnOnce(&mut App)) {
    app.world_mut().resource_mut::<Time<Hair>>().pause();
    f(app);
    app.world_mut().resource_mut::<Time<Hair>>().unpause();
}

/// [`app_with_render_device`], or `None` after saying why the test skips; without a device
/// it fails instead when `BEVY_HAIR_REQUIRE_ADAPTER` is set (as `.ci/run` sets it).
pub fn app_on_a_gpu() -> Option<App> {
    match app_with_render_device() {
        Ok(app) => Some(app),
        Err(reason) if std::env::var_os("BEVY_HAIR_REQUIRE_ADAPTER").is_some() => {
            panic!("BEVY_HAIR_REQUIRE_ADAPTER is set and there is {reason}")
        }
        Err(reason) => {
            eprintln!("SKIPPED: {reason}");
            None
        }
    }
}

/// Every `GpuFallback` reason reported so far ([`collect_gpu_fallbacks`] in `Last`).
#[derive(Resource, Default)]
pub struct GpuFallbacks(pub Vec<String>);

/// Collects the [`HairErrorKind::GpuFallback`] reasons into [`GpuFallbacks`].
pub fn collect_gpu_fallbacks(mut errors: MessageReader<HairError>, mut seen: ResMut<GpuFallbacks>) {
    seen.0.extend(errors.read().filter_map(|e| match &e.kind {
        HairErrorKind::GpuFallback(why) => Some(why.clone()),
        _ => None,
    }));
}
