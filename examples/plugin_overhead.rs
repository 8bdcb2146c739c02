//! What the plugin costs beyond the solver: one groom on the procedural head, stepped
//! through `HairPlugin` in a headless app (one 60 Hz hair step per update, the head turning),
//! timing each whole update against the solver's own share of it
//! (`HairState::last_step_time`). Prints one JSON line.
//!
//! ```text
//! cargo run --example plugin_overhead -- [--guides 2048] [--particles 16] [--updates 300]
//! ```

use bevy::mesh::MeshPlugin;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_hair::prelude::*;
use std::time::{Duration, Instant};

fn arg(name: &str, default: usize) -> usize {
    let args: Vec<String> = std::env::args().collect();
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).and_then(|v| v.parse().ok()).unwrap_or(default)
}

fn main() {
    let (guides, particles, updates) = (arg("--guides", 2048), arg("--particles", 16), arg("--updates", 300));
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin, AssetPlugin::default(), MeshPlugin, HairPlugin::default()))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_nanos(16_666_667)));
    let mesh = app.world_mut().resource_mut::<Assets<Mesh>>().add(bevy_hair::procedural_head_mesh(4));
    let groom = HairGroom { guides, segments: particles - 1, length: 0.2, settle_steps: 60, ..default() };
    let head = app.world_mut().spawn((Mesh3d(mesh), Transform::from_xyz(0.0, 1.6, 0.0), groom)).id();

    let start = Instant::now();
    while app.world().get::<HairState>(head).is_none() {
        if let Some(GroomStatus::Failed(kind)) = app.world().get::<GroomStatus>(head) {
            panic!("growth failed: {kind}");
        }
        assert!(start.elapsed() < Duration::from_secs(300), "growth took over 5 minutes");
        app.update();
        std::thread::sleep(Duration::from_millis(2));
    }

    let turn = |app: &mut App, k: usize| {
        let t = k as f32 / 60.0;
        app.world_mut().get_mut::<Transform>(head).unwrap().rotation =
            Quat::from_rotation_y(0.9 * (2.1 * t).sin()) * Quat::from_rotation_x(0.4 * (3.3 * t).sin());
    };
    for k in 0..60 {
        turn(&mut app, k);
        app.update();
    }
    let (mut frames, mut steps) = (Vec::with_capacity(updates), Vec::with_capacity(updates));
    for k in 60..60 + updates {
        turn(&mut app, k);
        let started = Instant::now();
        app.update();
        frames.push(started.elapsed().as_secs_f64() * 1e3);
        steps.push(app.world().get::<HairState>(head).unwrap().last_step_time().as_secs_f64() * 1e3);
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (frame, step) = (median(&mut frames), median(&mut steps));
    println!(
        "{{\"guides\":{guides},\"particles_per_strand\":{particles},\"updates\":{updates},\"ms_per_update\":{frame:.4},\
         \"ms_solver_step\":{step:.4},\"plugin_overhead\":{:.4}}}",
        frame / step - 1.0
    );
}
