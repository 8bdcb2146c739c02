//! What the plugin costs beyond the solver: one groom on the procedural head, stepped
//! through `HairPlugin` in a headless app (one 60 Hz hair step per update, the head turning),
//! the same strands stepped by the raw solver ([`step_on_pool`]: same head motion, same task
//! pool and chunks) without the app, and a second app with the same head and no groom (what
//! the app costs without hair). The three take turns, update by update, so that all see the
//! same machine. Prints one JSON line: median ms per update, the solver's share of an
//! update (`HairState::last_step_time`), the raw solver's ms per step, the update without
//! hair, and the plugin's overhead: what an update with hair costs beyond one without, over
//! the raw solver's step, less one.
//!
//! Bevy gives its compute pool what the IO and async pools leave (one thread on two cores);
//! this app gives it every core, as a game that simulates hair on a small machine should.
//!
//! With `--lod`, levels of detail through the plugin instead: sixteen heads wearing the
//! same groom at 1 to 20 m in front of a camera (Bevy's default projection, a 1,080-pixel
//! view), each at the level [`HairLod`] chooses from its size on screen, against one head at
//! 1 m, and a head with no groom; all heads turning, each with its own phase. Prints one
//! JSON line: median ms per update of each app, the levels chosen, and the ratio of what
//! the sixteen cost beyond the app without hair to what the one near head costs.
//!
//! ```text
//! cargo run --example plugin_overhead -- [--guides 2048] [--particles 16] [--updates 300] [--lod]
//! ```

use bevy::mesh::MeshPlugin;
use bevy::prelude::*;
use bevy::tasks::{ComputeTaskPool, TaskPoolBuilder};
use bevy::time::TimeUpdateStrategy;
use bevy_hair::hair_sim::math::{Pose, Quat as SimQuat, Vec3 as SimVec3};
use bevy_hair::hair_sim::solver::StepInput;
use bevy_hair::prelude::*;
use bevy_hair::step_on_pool;
use std::time::{Duration, Instant};

fn arg(name: &str, default: usize) -> usize {
    let args: Vec<String> = std::env::args().collect();
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).and_then(|v| v.parse().ok()).unwrap_or(default)
}

fn main() {
    let (guides, particles, updates) = (arg("--guides", 2048), arg("--particles", 16), arg("--updates", 300));
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    // Before TaskPoolPlugin, whose `get_or_init` then keeps this pool.
    ComputeTaskPool::get_or_init(|| TaskPoolBuilder::new().num_threads(cores).build());
    if std::env::args().any(|a| a == "--lod") {
        return crowd(guides, particles, updates);
    }
    let (mut app, head) =
        app_with_head(Some(HairGroom { guides, segments: particles - 1, length: 0.2, settle_steps: 60, ..default() }));
    let (mut bare_app, bare_head) = app_with_head(None);

    wait_for_growth(&mut app, &[head]);
    for k in 0..60 {
        turn(&mut app, head, k);
        app.update();
        turn(&mut bare_app, bare_head, k);
        bare_app.update();
    }

    // The raw solver: the groom's strands as the plugin has them now, the same motion onward.
    let state = app.world().get::<HairState>(head).unwrap();
    let origin = state.origin();
    let params = app.world().resource::<HairSettings>().0;
    let mut strands = state.strands().clone();
    let pose = |k: usize| {
        let (yaw, pitch) = angles(k);
        let rotation = SimQuat::from_rotation_y(yaw) * SimQuat::from_rotation_x(pitch);
        Pose::new(rotation, SimVec3::new(0.0, 1.6, 0.0) - origin)
    };
    let pool = ComputeTaskPool::get();
    let dt = 1.0 / 60.0;

    let (mut frames, mut steps) = (Vec::with_capacity(updates), Vec::with_capacity(updates));
    let (mut raw, mut bare) = (Vec::with_capacity(updates), Vec::with_capacity(updates));
    for k in 60..60 + updates {
        turn(&mut app, head, k);
        let started = Instant::now();
        app.update();
        frames.push(started.elapsed().as_secs_f64() * 1e3);
        steps.push(app.world().get::<HairState>(head).unwrap().last_step_time().as_secs_f64() * 1e3);

        // The plugin's own collider, borrowed while the app rests.
        let collider = app.world().get::<HairState>(head).unwrap().collider();
        let input = StepInput {
            dt,
            time: k as f32 * dt,
            head_from: pose(k - 1),
            head_to: pose(k),
            collider: Some(collider),
            extra_colliders: &[],
            surface_patch: None,
            params: &params,
        };
        let started = Instant::now();
        let report = step_on_pool(&mut strands, &input, pool);
        raw.push(started.elapsed().as_secs_f64() * 1e3);
        assert_eq!(report.nan_resets + report.teleport_resets, 0, "the raw solver reset strands");

        turn(&mut bare_app, bare_head, k);
        let started = Instant::now();
        bare_app.update();
        bare.push(started.elapsed().as_secs_f64() * 1e3);
    }

    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (frame, step, raw, bare) = (median(&mut frames), median(&mut steps), median(&mut raw), median(&mut bare));
    println!(
        "{{\"guides\":{guides},\"particles_per_strand\":{particles},\"updates\":{updates},\"threads\":{},\
         \"ms_per_update\":{frame:.4},\"ms_solver_step\":{step:.4},\"ms_raw_step\":{raw:.4},\
         \"ms_update_without_hair\":{bare:.4},\"plugin_overhead\":{:.4}}}",
        pool.thread_num(),
        (frame - bare) / raw - 1.0
    );
}

/// Updates `app` until every head's groom has grown.
fn wait_for_growth(app: &mut App, heads: &[Entity]) {
    let start = Instant::now();
    while heads.iter().any(|&head| app.world().get::<HairState>(head).is_none()) {
        for &head in heads {
            if let Some(GroomStatus::Failed(kind)) = app.world().get::<GroomStatus>(head) {
                panic!("growth failed: {kind}");
            }
        }
        assert!(start.elapsed() < Duration::from_secs(600), "growth took over 10 minutes");
        app.update();
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// The head's yaw and pitch at update `k`.
fn angles(k: usize) -> (f32, f32) {
    let t = k as f32 / 60.0;
    (0.9 * (2.1 * t).sin(), 0.4 * (3.3 * t).sin())
}

/// Turns `head` to its pose at update `k`.
fn turn(app: &mut App, head: Entity, k: usize) {
    let (yaw, pitch) = angles(k);
    app.world_mut().get_mut::<Transform>(head).unwrap().rotation =
        Quat::from_rotation_y(yaw) * Quat::from_rotation_x(pitch);
}

/// `--lod`: sixteen heads at 1 to 20 m at the levels of detail the plugin chooses, against
/// one near head, through the whole plugin (stepping, copying out, everything but drawing).
fn crowd(guides: usize, particles: usize, updates: usize) {
    let groom = HairGroom { guides, segments: particles - 1, length: 0.2, settle_steps: 60, ..default() };
    // Heads along the camera's view (−z), each turning with its own phase.
    let with_heads = |distances: &[f32], groom: Option<&HairGroom>| {
        let (mut app, first) = app_with_head(groom.cloned());
        app.world_mut().spawn((Camera3d::default(), Transform::from_xyz(0.0, 1.6, 0.0)));
        let mesh = app.world().get::<Mesh3d>(first).unwrap().clone();
        let mut heads = vec![first];
        for _ in 1..distances.len() {
            let mut head = app.world_mut().spawn((mesh.clone(), Transform::default()));
            if let Some(groom) = groom {
                head.insert(groom.clone());
            }
            heads.push(head.id());
        }
        for (&head, &distance) in heads.iter().zip(distances) {
            app.world_mut().entity_mut(head).insert((Transform::from_xyz(0.0, 1.6, -distance), HairLod::default()));
        }
        (app, heads)
    };
    let distances: Vec<f32> = (0..16).map(|i| 1.0 + 19.0 * i as f32 / 15.0).collect();
    let (mut near, near_heads) = with_heads(&distances[..1], Some(&groom));
    let (mut many, many_heads) = with_heads(&distances, Some(&groom));
    let (mut bare, bare_heads) = with_heads(&distances[..1], None);
    wait_for_growth(&mut near, &near_heads);
    wait_for_growth(&mut many, &many_heads);
    let phase = |h: usize| h * 23;
    let update = |app: &mut App, heads: &[Entity], k: usize| {
        for (h, &head) in heads.iter().enumerate() {
            turn(app, head, k + phase(h));
        }
        let started = Instant::now();
        app.update();
        started.elapsed().as_secs_f64() * 1e3
    };
    // Settle into the levels (switching fades over half a second) before timing.
    for k in 0..60 {
        update(&mut near, &near_heads, k);
        update(&mut many, &many_heads, k);
        update(&mut bare, &bare_heads, k);
    }
    let (mut near_ms, mut many_ms, mut bare_ms) = (Vec::new(), Vec::new(), Vec::new());
    let (mut near_steps, mut many_steps) = (Vec::new(), Vec::new());
    // The solver's share of an update: the wall time of its system, every groom.
    let stepping = |app: &App| {
        let store = app.world().resource::<bevy::diagnostic::DiagnosticsStore>();
        store.get(&HairDiagnostics::STEP_TIME).and_then(|d| d.value()).unwrap_or(f64::NAN)
    };
    for k in 60..60 + updates {
        near_ms.push(update(&mut near, &near_heads, k));
        near_steps.push(stepping(&near));
        many_ms.push(update(&mut many, &many_heads, k));
        many_steps.push(stepping(&many));
        bare_ms.push(update(&mut bare, &bare_heads, k));
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (near_ms, many_ms, bare_ms) = (median(near_ms), median(many_ms), median(bare_ms));
    let (near_step, many_step) = (median(near_steps), median(many_steps));
    let levels: Vec<u32> =
        many_heads.iter().map(|&h| many.world().get::<HairState>(h).unwrap().strands().detail_level()).collect();
    println!(
        "{{\"lod\":true,\"guides\":{guides},\"particles_per_strand\":{particles},\"updates\":{updates},\
         \"threads\":{},\"ms_near_head\":{near_ms:.4},\"ms_sixteen_heads\":{many_ms:.4},\
         \"ms_without_hair\":{bare_ms:.4},\"ms_near_solver\":{near_step:.4},\"ms_sixteen_solver\":{many_step:.4},\
         \"levels\":{levels:?},\"ratio\":{:.3},\"solver_ratio\":{:.3}}}",
        ComputeTaskPool::get().thread_num(),
        (many_ms - bare_ms) / (near_ms - bare_ms),
        many_step / near_step
    );
}

/// A headless app with the procedural head at 1.6 m, wearing `groom` if given.
fn app_with_head(groom: Option<HairGroom>) -> (App, Entity) {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin, AssetPlugin::default(), MeshPlugin, HairPlugin::default()))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_nanos(16_666_667)));
    let mesh = app.world_mut().resource_mut::<Assets<Mesh>>().add(bevy_hair::procedural_head_mesh(4));
    let mut head = app.world_mut().spawn((Mesh3d(mesh), Transform::from_xyz(0.0, 1.6, 0.0)));
    if let Some(groom) = groom {
        head.insert(groom);
    }
    let head = head.id();
    (app, head)
}
