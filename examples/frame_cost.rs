//! What hair costs a frame, thread by thread: a headless app with Bevy's renderer and
//! pipelined rendering (the render world on its own thread), drawing into an image, with
//! the procedural head turning and a groom on the CPU or the GPU solver; and beside it,
//! frame for frame, the same app without hair.
//!
//! ```text
//! cargo run --example frame_cost -- [--solver gpu|cpu] [--guides 1200]
//!     [--particles 11] [--warmup 20] [--frames 100] [--size 320x180]
//! ```
//!
//! Prints one JSON line (medians over the measured frames, milliseconds):
//! - `main_thread_ms` (and `_p95`): the main world's hair systems, wall time
//!   ([`HairSystems`]: growth, the steps, the drawing's preparation), and
//!   `main_thread_cpu_ms` (and `_p95`) their thread's CPU time over the same spans: what
//!   wall time has beyond it is waiting (a lock, the queue, or other threads on the cores). `PostUpdate` runs single-threaded here, so
//!   those spans are the main thread's.
//! - `extract_ms`: the hair's extraction ([`HairDiagnostics::EXTRACT_TIME`]).
//! - `render_thread_ms`: the hair's other render-world systems ([`HairDiagnostics::RENDER_TIME`]:
//!   recording the GPU grooms' passes, writing the CPU grooms' particles, collecting
//!   copies back), measured in them: besides them, the render thread's submission runs
//!   what lavapipe does of the GPU's work.
//! - `upload_ms` and `step_ms` (and each `_p95`): the parts of the main thread's hair that
//!   [`HairDiagnostics::UPLOAD_TIME`] and [`HairDiagnostics::STEP_TIME`] publish.
//! - `gpu_step_ms`: one hair step on the GPU, from timestamp queries (`null` on the CPU
//!   solver or without timestamps).
//! - `frame_ms` and `frame_ms_without_hair`: a whole update of each app, and
//!   `main_thread_ms_without_hair` (and `_p95`) the same span in the app without hair (the
//!   plugin's systems with nothing to do, and whatever else the executor runs between them).

use bevy::camera::RenderTarget;
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::ecs::schedule::SingleThreadedExecutor;
use bevy::prelude::*;
use bevy::render::RenderPlugin;
use bevy::render::render_resource::{TextureFormat, TextureUsages};
use bevy::render::renderer::RenderAdapterInfo;
use bevy::time::TimeUpdateStrategy;
use bevy_hair::prelude::*;
use bevy_hair::procedural_head_mesh;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

#[path = "../tests/common/headless.rs"]
mod headless;

/// The main world's hair systems, measured from before the first to after the last:
/// wall time and the thread's CPU time, milliseconds, summed since last taken.
#[derive(Resource, Clone, Default)]
struct MainSpan(Arc<Mutex<MainSpanInner>>);

#[derive(Default)]
struct MainSpanInner {
    wall_and_cpu: [f64; 2],
    /// Where the open span started: wall time and thread CPU time.
    open: Option<(Instant, f64)>,
}

impl MainSpan {
    fn open(&self) {
        self.0.lock().unwrap().open = Some((Instant::now(), thread_cpu_ms()));
    }

    fn close(&self) {
        let mut inner = self.0.lock().unwrap();
        if let Some((wall, cpu)) = inner.open.take() {
            inner.wall_and_cpu[0] += wall.elapsed().as_secs_f64() * 1e3;
            inner.wall_and_cpu[1] += thread_cpu_ms() - cpu;
        }
    }

    fn take(&self) -> [f64; 2] {
        std::mem::take(&mut self.0.lock().unwrap().wall_and_cpu)
    }
}

/// The calling thread's CPU time, milliseconds.
fn thread_cpu_ms() -> f64 {
    let mut time = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: `clock_gettime` writes the timespec it is given and nothing else.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut time) };
    time.tv_sec as f64 * 1e3 + time.tv_nsec as f64 * 1e-6
}

fn arg<T: std::str::FromStr>(name: &str, default: T) -> T {
    let args: Vec<String> = std::env::args().collect();
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).and_then(|v| v.parse().ok()).unwrap_or(default)
}

fn main() {
    let backend = match arg("--solver", "gpu".to_string()).as_str() {
        "cpu" => HairBackend::Cpu,
        _ => HairBackend::Gpu,
    };
    let (guides, particles) = (arg("--guides", 1200usize), arg("--particles", 11usize));
    let (warmup, frames) = (arg("--warmup", 20usize), arg("--frames", 100usize));
    let size = arg("--size", "320x180".to_string());
    let (width, height) =
        size.split_once('x').and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?))).unwrap_or((320, 180));
    // The guides alone, drawn plainly: lavapipe rasterises every strand on the CPU, inside
    // the render thread's submission, and children would bury the hair's own costs there.
    let children = ChildParams { per_guide: 0, ..default() };
    let groom = HairGroom { guides, segments: particles - 1, length: 0.2, settle_steps: 60, children, ..default() };
    let (mut app, head) = app_with_head(Some((groom, backend)), width, height);
    let (mut bare, bare_head) = app_with_head(None, width, height);

    // Grown, on its solver (the GPU's pipelines compile meanwhile), then warmed up.
    let started = Instant::now();
    let mut k = 0;
    loop {
        let state = app.world().get::<HairState>(head);
        let ready = state.is_some_and(|s| backend == HairBackend::Cpu || s.gpu_lag().is_some());
        if let Some(why) = state.and_then(HairState::gpu_fallback) {
            eprintln!("the GPU cannot step the groom: {why}");
            std::process::exit(1);
        }
        if ready || started.elapsed() > Duration::from_secs(300) {
            break;
        }
        step(&mut app, head, &mut k);
        step(&mut bare, bare_head, &mut 0);
    }
    for _ in 0..warmup {
        step(&mut bare, bare_head, &mut k.clone());
        step(&mut app, head, &mut k);
    }
    let span = app.world().resource::<MainSpan>().clone();
    span.take();
    let bare_span = bare.world().resource::<MainSpan>().clone();
    bare_span.take();
    let mut bare_main = Vec::new();
    let paths = [
        HairDiagnostics::EXTRACT_TIME,
        HairDiagnostics::RENDER_TIME,
        HairDiagnostics::UPLOAD_TIME,
        HairDiagnostics::STEP_TIME,
        HairDiagnostics::GPU_STEP_TIME,
    ];
    // Each frame: the main span (wall, CPU), then each path's latest value.
    let mut measured: Vec<Vec<f64>> = vec![Vec::new(); 2 + paths.len()];
    let (mut frame_ms, mut bare_ms) = (Vec::new(), Vec::new());
    for _ in 0..frames {
        let at = Instant::now();
        step(&mut bare, bare_head, &mut k.clone());
        bare_ms.push(at.elapsed().as_secs_f64() * 1e3);
        bare_main.push(bare_span.take()[0]);
        let at = Instant::now();
        step(&mut app, head, &mut k);
        frame_ms.push(at.elapsed().as_secs_f64() * 1e3);
        let store = app.world().resource::<bevy::diagnostic::DiagnosticsStore>();
        let latest = paths.iter().map(|path| store.get(path).and_then(|d| d.value()));
        for (all, value) in measured.iter_mut().zip(span.take().map(Some).into_iter().chain(latest)) {
            all.extend(value);
        }
    }
    let adapter = app.world().get_resource::<RenderAdapterInfo>().map(|a| a.name.clone());
    let [main, main_cpu, extract, render, upload, step_ms, gpu_steps]: [Vec<f64>; 7] =
        measured.try_into().expect("seven series");
    let line = serde_json::json!({
        "backend": if backend == HairBackend::Gpu { "gpu" } else { "cpu" },
        "adapter": adapter,
        "guides": guides,
        "particles_per_strand": particles,
        "frames": frames,
        "size": format!("{width}x{height}"),
        "pipelined": app.is_plugin_added::<bevy::render::pipelined_rendering::PipelinedRenderingPlugin>(),
        "main_thread_ms": median(main.clone()),
        "main_thread_ms_p95": percentile(main, 0.95),
        "main_thread_cpu_ms": median(main_cpu.clone()),
        "main_thread_cpu_ms_p95": percentile(main_cpu, 0.95),
        "extract_ms": median(extract),
        "render_thread_ms": median(render),
        "upload_ms": median(upload.clone()),
        "upload_ms_p95": percentile(upload, 0.95),
        "step_ms": median(step_ms.clone()),
        "step_ms_p95": percentile(step_ms, 0.95),
        "gpu_step_ms": (!gpu_steps.is_empty()).then(|| median(gpu_steps)),
        "frame_ms": median(frame_ms),
        "frame_ms_without_hair": median(bare_ms),
        "main_thread_ms_without_hair": median(bare_main.clone()),
        "main_thread_ms_without_hair_p95": percentile(bare_main, 0.95),
    });
    println!("{line}");
}

fn median(values: Vec<f64>) -> f64 {
    percentile(values, 0.5)
}

fn percentile(mut values: Vec<f64>, p: f64) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(((values.len() as f64 - 1.0) * p).round() as usize).copied().unwrap_or(f64::NAN)
}

/// One frame of 1/60 s (one hair step), the head turned to frame `k`'s yaw.
fn step(app: &mut App, head: Entity, k: &mut usize) {
    let yaw = 1.2 * (*k as f32 / 40.0).sin();
    *app.world_mut().get_mut::<Transform>(head).unwrap() = Transform::from_rotation(Quat::from_rotation_y(yaw));
    app.update();
    *k += 1;
}

/// A headless app drawing the procedural head into a `width` × `height` image, with a
/// groom on `backend` (or none), and the hair's spans measured.
fn app_with_head(groom: Option<(HairGroom, HairBackend)>, width: u32, height: u32) -> (App, Entity) {
    let mut app = App::new();
    // Every frame measured draws everything: none skips a pipeline still compiling.
    app.add_plugins(headless::headless_plugins(RenderPlugin { synchronous_pipeline_compilation: true, ..default() }))
        .add_plugins(HairPlugin::default())
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(1.0 / 60.0)))
        .init_resource::<MainSpan>();
    // One thread for the main world's late systems, so the hair's spans are its own.
    app.edit_schedule(PostUpdate, |schedule| {
        schedule.set_executor(SingleThreadedExecutor::new());
    });
    headless::finish_plugins(&mut app);
    let span = app.world().resource::<MainSpan>().clone();
    let closing = span.clone();
    app.add_systems(PostUpdate, (move || span.open()).before(HairSystems::Grow));
    app.add_systems(PostUpdate, (move || closing.close()).after(HairSystems::Draw));
    app.cleanup();
    let mut image = Image::new_target_texture(width, height, TextureFormat::Rgba8UnormSrgb, None);
    image.texture_descriptor.usage |= TextureUsages::COPY_SRC;
    let world = app.world_mut();
    let target = world.resource_mut::<Assets<Image>>().add(image);
    world.spawn((
        Camera3d::default(),
        RenderTarget::Image(target.into()),
        Tonemapping::None,
        Transform::from_xyz(0.0, 0.05, 0.7).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    world.spawn((
        // Shadow-casting, so the hair builds its opacity map for it; one small cascade,
        // since lavapipe draws every strand into each.
        DirectionalLight { illuminance: 4000.0, shadow_maps_enabled: true, ..default() },
        bevy::light::CascadeShadowConfigBuilder { num_cascades: 1, maximum_distance: 2.0, ..default() }.build(),
        Transform::from_xyz(0.3, 1.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    let mesh = world.resource_mut::<Assets<Mesh>>().add(procedural_head_mesh(4));
    let skin = world.resource_mut::<Assets<StandardMaterial>>().add(Color::srgb(0.8, 0.6, 0.5));
    let mut head = world.spawn((Mesh3d(mesh), MeshMaterial3d(skin), Transform::default()));
    if let Some((groom, backend)) = groom {
        head.insert((groom, backend, HairLook { subdivisions: 1, ..default() }));
    }
    let head = head.id();
    (app, head)
}
