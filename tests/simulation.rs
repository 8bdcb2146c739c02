//! Headless ECS tests of the simulation: each asserts a measured number.

mod common;

use bevy::animation::{AnimatedBy, AnimationTargetId, animated_field, prelude::*};
use bevy::prelude::*;
use bevy::render::renderer::RenderDevice;
use bevy::time::TimeUpdateStrategy;
use bevy_hair::prelude::*;
use common::*;
use std::f32::consts::TAU;
use std::time::Duration;

/// The head of [`spin_and_travel`] and the virtual time its motion starts at.
#[derive(Resource)]
struct Spinning(Entity, f64);

impl Spinning {
    fn start_now(app: &mut App, head: Entity) {
        let now = app.world().resource::<Time<Virtual>>().elapsed_secs_f64();
        app.insert_resource(Spinning(head, now)).add_systems(Update, spin_and_travel);
    }
}

/// 2 turns per second about a tilted axis while moving at 1 m/s, a function of the app's
/// virtual time.
fn spin_and_travel(time: Res<Time>, head: Res<Spinning>, mut transforms: Query<&mut Transform>) {
    let t = time.elapsed_secs_f64() - head.1;
    let mut transform = transforms.get_mut(head.0).unwrap();
    transform.rotation = Quat::from_axis_angle(Vec3::new(0.3, 1.0, 0.2).normalize(), (2.0 * TAU as f64 * t) as f32);
    transform.translation = Vec3::new(t as f32, 0.2, -0.1);
}

/// Each root's point on the head as Bevy draws it this frame: the head's final
/// `GlobalTransform` (scale included) applied to the root's rest position, with the scale
/// the groom baked into it taken back out. Nothing of the plugin's pose handling is used.
fn roots_on_drawn_head(app: &App, head: Entity) -> Vec<Vec3> {
    let state = state(app, head);
    let global = app.world().get::<GlobalTransform>(head).unwrap();
    let unscale = global.scale().recip();
    let n = state.particles_per_strand();
    let rest = &state.strands().rest().positions;
    rest.iter().step_by(n).map(|r| global.transform_point(Vec3::from_array(r.to_array()) * unscale)).collect()
}

/// The drawn root of each guide: what the renderer uploads this frame.
fn drawn_roots(app: &App, head: Entity) -> Vec<Vec3> {
    let state = state(app, head);
    let fraction = app.world().resource::<Time<Hair>>().overstep_fraction();
    state.interpolated_positions(fraction).step_by(state.particles_per_strand()).collect()
}

#[test]
fn roots_sit_on_the_drawn_head_at_every_frame_rate() {
    // A non-uniform scale, so the baked scale is part of what is checked.
    let mut app = app();
    let head = spawn_head(&mut app, groom(), Transform::from_scale(Vec3::new(1.1, 0.95, 1.0)));
    wait_until_ready(&mut app, head);
    Spinning::start_now(&mut app, head);
    for hz in [30.0, 60.0, 120.0] {
        app.world_mut().resource_mut::<Time<Hair>>().set_timestep_hz(hz);
        for fps in [20.0, 30.0, 60.0, 144.0] {
            app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(1.0 / fps)));
            let (mut worst, mut resets) = (0.0f32, 0);
            for _ in 0..(fps as usize / 2) {
                app.update();
                let expected = roots_on_drawn_head(&app, head);
                let drawn = drawn_roots(&app, head);
                worst = drawn.iter().zip(&expected).map(|(a, b)| a.distance(*b)).fold(worst, f32::max);
                resets += state(&app, head).last_report().teleport_resets;
            }
            println!("{fps} fps, {hz} Hz hair: drawn roots within {:.4} mm of the drawn scalp", worst * 1e3);
            assert!(worst <= 2e-4, "{fps} fps / {hz} Hz: a drawn root is {} mm off the drawn scalp", worst * 1e3);
            assert_eq!(resets, 0, "{fps} fps / {hz} Hz: the head's motion was taken for a teleport");
            assert!(all_finite(&app, head));
        }
    }
}

/// The hair-clock time and the head translation of every hair step.
#[derive(Resource, Default)]
struct StepLog(Vec<(f64, Vec3)>);

fn log_step(time: Res<Time>, head: Res<Spinning>, states: Query<&HairState>, mut log: ResMut<StepLog>) {
    let pose = states.get(head.0).unwrap().head_pose();
    log.0.push((time.elapsed_secs_f64(), Vec3::from_array(pose.translation.to_array())));
}

#[test]
fn every_step_moves_the_roots_by_its_own_interval() {
    let (mut app, head) = grown(groom());
    Spinning::start_now(&mut app, head);
    app.init_resource::<StepLog>().add_systems(HairSchedule, log_step.after(HairSystems::SyncRoots));
    let start = app.world().resource::<Spinning>().1;
    for (fps, hz) in [(20.0, 60.0), (144.0, 60.0), (30.0, 120.0), (60.0, 30.0), (50.0, 60.0)] {
        app.world_mut().resource_mut::<Time<Hair>>().set_timestep_hz(hz);
        app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(1.0 / fps)));
        app.world_mut().resource_mut::<StepLog>().0.clear();
        run(&mut app, fps as usize / 2);
        let log = std::mem::take(&mut app.world_mut().resource_mut::<StepLog>().0);
        let step = 1.0 / hz;
        // The head is at x = t (1 m/s): each step's pose is the head's at the step's end...
        let off = log.iter().map(|&(t, p)| (p.x as f64 - (t - start)).abs()).fold(0.0, f64::max);
        // ...so every step moves it by one step's worth, never by none or by two.
        let moves: Vec<f64> = log.windows(2).map(|w| (w[1].1.x - w[0].1.x) as f64).collect();
        let (least, most) = moves.iter().fold((f64::MAX, f64::MIN), |(lo, hi), &m| (lo.min(m), hi.max(m)));
        println!(
            "{fps} fps, {hz} Hz: {} steps, head pose within {:.4} mm of its path, moves {:.3}-{:.3} mm (step {:.3} mm)",
            log.len(),
            off * 1e3,
            least * 1e3,
            most * 1e3,
            step * 1e3
        );
        assert!((log.len() as f64 - 0.5 * hz).abs() <= 1.0, "{} steps in 0.5 s at {hz} Hz", log.len());
        assert!(off <= 1e-4, "a step saw the head {off} m from where it was at the step's time");
        assert!((least - step).abs() <= 1e-4 && (most - step).abs() <= 1e-4, "moves {least}..{most}, step {step}");
    }
}

#[test]
fn the_app_keeps_its_fixed_timestep() {
    let mut app = app();
    app.update();
    let fixed = app.world().resource::<Time<Fixed>>().timestep();
    assert_eq!(fixed, Time::<Fixed>::default().timestep(), "HairPlugin changed Time<Fixed>");
    let hair = app.world().resource::<Time<Hair>>().timestep();
    assert_eq!(hair, Hair::DEFAULT_TIMESTEP);
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin, AssetPlugin::default()));
    app.add_plugins((bevy::mesh::MeshPlugin, HairPlugin::from_hz(120.0)));
    assert_eq!(app.world().resource::<Time<Hair>>().timestep(), Duration::from_secs_f64(1.0 / 120.0));
    assert_eq!(app.world().resource::<Time<Fixed>>().timestep(), Time::<Fixed>::default().timestep());
}

#[test]
fn hanging_hair_keeps_its_length() {
    // Springs: the ±10 % clamp, plus f32 rounding of a segment held at its bound.
    for (mode, limit) in [(LengthMode::Inextensible, 1e-3), (LengthMode::Springs, 0.1 + 1e-5)] {
        let mut app = app();
        settings(&mut app, |p| p.length_mode = mode);
        let head = spawn_head(&mut app, groom(), Transform::default());
        wait_until_ready(&mut app, head);
        run(&mut app, 300); // 5 s
        let stretch = state(&app, head).strands().max_stretch();
        println!("{mode:?}: max stretch after 5 s hanging = {:.5}%", stretch * 100.0);
        assert!(stretch <= limit, "{mode:?} stretched {stretch}");
        assert!(all_finite(&app, head));
    }
}

#[test]
fn hair_hangs_below_its_roots() {
    // Grown standing out along the normals, with no shape keeping: gravity alone.
    let mut app = app();
    settings(&mut app, |p| {
        p.local_stiffness = 0.0;
        p.global_stiffness_root = 0.0;
    });
    let head = spawn_head(&mut app, HairGroom { settle_steps: 0, ..groom() }, Transform::default());
    wait_until_ready(&mut app, head);
    run(&mut app, 180);
    let strands = roots_and_tips(&app, head);
    let hanging = strands.iter().filter(|(root, tip)| tip.y < root.y).count() as f32 / strands.len() as f32;
    let drop = strands.iter().map(|(root, tip)| root.y - tip.y).sum::<f32>() / strands.len() as f32;
    println!("{:.1}% of tips below their roots, mean drop {drop:.3} m", hanging * 100.0);
    assert!(hanging >= 0.9, "only {hanging} of strands hang");
    assert!(drop > 0.05, "mean drop {drop}");
}

/// Mean distance of particles from the rest pose after 2 s, with the given global shape
/// stiffness, on a groom grown standing out along the normals (no settle pass).
fn deviation_from_rest(stiffness: f32) -> f32 {
    let mut app = app();
    settings(&mut app, |p| {
        p.global_stiffness_root = stiffness;
        p.global_stiffness_tip = stiffness;
        p.local_stiffness = stiffness;
    });
    let head = spawn_head(&mut app, HairGroom { settle_steps: 0, ..groom() }, Transform::default());
    wait_until_ready(&mut app, head);
    run(&mut app, 120);
    let state = state(&app, head);
    let rest = &state.strands().rest().positions;
    let positions = state.current_local_positions();
    positions.iter().zip(rest).map(|(p, r)| p.distance(Vec3::from_array(r.to_array()))).sum::<f32>()
        / positions.len() as f32
}

#[test]
fn shape_stiffness_keeps_the_groomed_shape() {
    let stiff = deviation_from_rest(0.9);
    let limp = deviation_from_rest(0.0);
    println!("mean deviation from rest: stiffness 0.9 → {stiff:.4} m, stiffness 0 → {limp:.4} m");
    assert!(stiff < 0.005, "stiff hair drifted {stiff} m");
    assert!(limp > 0.03, "limp hair should fall: {limp} m");
}

/// Plays a looping 2 Hz head shake (±0.6 rad yaw, with a nod) from keyframes through
/// Bevy's animation system.
fn shake_with_keyframes(app: &mut App, head: Entity) {
    app.add_plugins(AnimationPlugin);
    let name = Name::new("head");
    let target = AnimationTargetId::from_name(&name);
    let keys = [(0.0, 0.0f32), (0.125, 0.6), (0.25, 0.0), (0.375, -0.6), (0.5, 0.0)];
    let curve = AnimatableKeyframeCurve::new(
        keys.map(|(t, yaw)| (t, Quat::from_rotation_y(yaw) * Quat::from_rotation_x(0.5 * yaw.abs()))),
    )
    .unwrap();
    let mut clip = AnimationClip::default();
    clip.add_curve_to_target(target, AnimatableCurve::new(animated_field!(Transform::rotation), curve));
    let clip = app.world_mut().resource_mut::<Assets<AnimationClip>>().add(clip);
    let (graph, node) = AnimationGraph::from_clip(clip);
    let graph = app.world_mut().resource_mut::<Assets<AnimationGraph>>().add(graph);
    let mut player = AnimationPlayer::default();
    player.play(node).repeat();
    app.world_mut().entity_mut(head).insert((name, target, AnimatedBy(head), player, AnimationGraphHandle(graph)));
}

#[test]
fn shaken_head_keeps_hair_outside() {
    let (mut app, head) = grown(groom());
    shake_with_keyframes(&mut app, head);
    let thickness = app.world().resource::<HairSettings>().collision_thickness;
    let mut deepest = f32::MIN;
    let mut turned = 0.0f32;
    for _ in 0..180 {
        app.update();
        deepest = deepest.max(max_penetration(&app, head));
        turned = turned.max(state(&app, head).head_pose().rotation.to_axis_angle().1.abs());
    }
    println!("2 Hz shake for 3 s: head turned up to {turned:.2} rad, deepest particle {:.2} mm inside", deepest * 1e3);
    assert!(turned > 0.5, "the keyframes did move the head: {turned}");
    assert!(deepest <= thickness, "a particle is {deepest} m inside the head (thickness {thickness})");
    assert!(all_finite(&app, head));
}

fn mean_tip_x(app: &App, head: Entity) -> f32 {
    let strands = roots_and_tips(app, head);
    strands.iter().map(|(_, tip)| tip.x).sum::<f32>() / strands.len() as f32
}

#[test]
fn wind_blows_tips_downwind() {
    let (mut calm, calm_head) = grown(groom());
    let (mut windy, windy_head) = grown(groom());
    settings(&mut windy, |p| {
        p.wind = Wind { direction: [1.0, 0.0, 0.0], strength: 8.0, gust_strength: 0.3, gust_frequency: 0.5 };
    });
    run(&mut calm, 120);
    run(&mut windy, 120);
    let shift = mean_tip_x(&windy, windy_head) - mean_tip_x(&calm, calm_head);
    println!("wind 8 m/s² along +X moved the mean tip {shift:.3} m downwind");
    assert!(shift > 0.02, "tips moved only {shift} m");
}

/// The head jumps 10 m along x in one frame.
fn teleport(app: &mut App, head: Entity) {
    app.world_mut().get_mut::<Transform>(head).unwrap().translation = Vec3::new(10.0, 0.0, 0.0);
    app.update();
}

/// A one-second frame while the head moves 30 cm and turns, then five ordinary frames.
fn hitch_while_turning(app: &mut App, head: Entity) {
    app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs(1)));
    let mut transform = app.world_mut().get_mut::<Transform>(head).unwrap();
    transform.translation.y += 0.3;
    transform.rotation = Quat::from_rotation_y(1.0);
    app.update();
    app.insert_resource(TimeUpdateStrategy::ManualDuration(FRAME));
    run(app, 5);
}

/// After [`teleport`]: the hair finite, no segment stretched past the tolerance, and the
/// first strand 10 m along with its root.
fn assert_came_along(app: &App, head: Entity, stretch: f32) {
    let (root, tip) = roots_and_tips(app, head)[0];
    assert!(all_finite(app, head));
    assert!(stretch <= 0.1, "a segment is stretched by {stretch}");
    assert!((root.x - 10.0).abs() < 0.2 && tip.distance(root) < 0.3, "the hair came along: root {root}, tip {tip}");
}

#[test]
fn teleport_and_frame_hitch_stay_sane() {
    let (mut app, head) = grown(groom());
    run(&mut app, 30);
    teleport(&mut app, head);
    // The step of the frame the head jumped in sees the jump.
    assert_eq!(state(&app, head).last_report().teleport_resets, 200, "every strand was reset to the new place");
    app.update();
    let stretch = state(&app, head).strands().max_stretch();
    println!("after a 10 m teleport: stretch {stretch:.5}");
    assert_came_along(&app, head, stretch);

    hitch_while_turning(&mut app, head);
    let stretch = state(&app, head).strands().max_stretch();
    println!("after a 1 s hitch: stretch {stretch:.5}");
    assert!(all_finite(&app, head));
    assert!(stretch <= 0.1, "a segment is stretched by {stretch}");
}

fn run_scripted() -> Vec<Vec3> {
    let (mut app, head) = grown(groom());
    for frame in 0..90 {
        let t = frame as f32 / 60.0;
        app.world_mut().get_mut::<Transform>(head).unwrap().rotation = Quat::from_rotation_y((TAU * t).sin());
        app.update();
    }
    state(&app, head).current_positions().to_vec()
}

#[test]
fn same_inputs_same_positions() {
    let a = run_scripted();
    let b = run_scripted();
    let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
    println!("{} particles compared, {differing} differ", a.len());
    assert_eq!(a.len(), 200 * 11);
    assert_eq!(differing, 0);
}

/// Far from the world origin `f32` world coordinates resolve only about a millimetre (at
/// 14 km), but the solver works relative to the head: hair 14 km out, moving at 1 m/s and
/// turning at a quarter turn per second, stays as inextensible and as outside the head as
/// at the origin. The same for a head mesh whose vertices sit 100 m from its own origin
/// (turning about its own centre). Measured with the independent inside test in head space.
#[test]
fn a_head_far_from_the_world_origin_keeps_its_hair_in_shape() {
    use bevy_hair::hair_sim::math::Vec3 as SimVec3;
    use bevy_hair::hair_sim::mesh::InsideTest;
    let mut results = Vec::new();
    let far_mesh = Vec3::new(100.0, 0.0, -50.0);
    for (base, mesh_offset) in
        [(Vec3::ZERO, Vec3::ZERO), (Vec3::new(10_000.0, 0.0, -10_000.0), Vec3::ZERO), (Vec3::ZERO, far_mesh)]
    {
        let mut app = app();
        let mesh = bevy_hair::procedural_head_mesh(4).translated_by(mesh_offset);
        let mesh = app.world_mut().resource_mut::<Assets<Mesh>>().add(mesh);
        let head = app.world_mut().spawn((Mesh3d(mesh), Transform::from_translation(base - mesh_offset), groom())).id();
        wait_until_ready(&mut app, head);
        let inside = InsideTest::new(state(&app, head).head_mesh());
        let (mut stretch, mut deepest) = (0.0f32, 0.0f32);
        for frame in 1..=120 {
            let t = frame as f32 / 60.0;
            let rotation = Quat::from_rotation_y(0.25 * TAU * t);
            let mut transform = app.world_mut().get_mut::<Transform>(head).unwrap();
            // The mesh's own centre walks at 1 m/s while the head turns about it.
            transform.translation = base + Vec3::new(t, 0.0, 0.3 * t) - rotation * mesh_offset;
            transform.rotation = rotation;
            app.update();
            let state = state(&app, head);
            stretch = stretch.max(state.strands().max_stretch());
            let n = state.particles_per_strand();
            for (i, p) in state.current_local_positions().iter().enumerate().filter(|(i, _)| i % n != 0) {
                assert!(p.is_finite(), "particle {i}");
                if let Some(depth) = inside.depth(SimVec3::from_array(p.to_array())) {
                    deepest = deepest.max(depth);
                }
            }
            assert_eq!(state.last_report().teleport_resets, 0, "frame {frame}");
        }
        println!(
            "head at {base}, mesh {mesh_offset} from its origin: max stretch {stretch:.2e}, deepest particle inside \
             {:.4} mm",
            deepest * 1e3
        );
        results.push((stretch, deepest));
    }
    for (stretch, deepest) in results {
        assert!(stretch <= 1e-4, "stretch {stretch}");
        assert!(deepest <= 1e-4, "a particle {} mm inside", deepest * 1e3);
    }
}

/// Levels of detail through the plugin: with [`HairLod`] on the head, a camera 1 m away
/// sees the head about 330 pixels tall and every guide is simulated; 20 m away, 16 pixels,
/// and 2 of the 200 (1/128) are; a fixed level holds whatever the camera sees; unusable
/// values are replaced and reported, and the hair stays finite with its roots on the head.
#[test]
fn a_far_head_simulates_a_fraction_of_its_guides() {
    let (mut app, head) = grown(groom());
    app.world_mut().entity_mut(head).insert(HairLod::default());
    let camera = app.world_mut().spawn((Camera3d::default(), Transform::from_xyz(0.0, 0.0, 1.0))).id();
    run(&mut app, 3);
    let size = state(&app, head).head_size();
    println!("head {size:.3} m tall: {:.0} px at 1 m", size / (2.0 * (std::f32::consts::FRAC_PI_8).tan()) * 1080.0);
    assert_eq!(state(&app, head).strands().detail_level(), 0);
    assert_eq!(state(&app, head).strands().simulated_strands(), 200);

    app.world_mut().get_mut::<Transform>(camera).unwrap().translation.z = 20.0;
    run(&mut app, 40);
    let strands = state(&app, head).strands();
    assert_eq!(strands.detail_level(), 7);
    assert_eq!(strands.simulated_strands(), 2, "1/128 of 200 guides, rounded up");
    // The diagnostics count what the solver steps.
    let diagnostics = app.world().resource::<bevy::diagnostic::DiagnosticsStore>();
    let latest = |path: bevy::diagnostic::DiagnosticPath| diagnostics.get(&path).and_then(|d| d.value());
    assert_eq!(latest(HairDiagnostics::GUIDES), Some(2.0));
    assert_eq!(latest(HairDiagnostics::PARTICLES), Some(2.0 * state(&app, head).particles_per_strand() as f64));
    assert!(all_finite(&app, head));
    let roots_before: Vec<Vec3> = roots_and_tips(&app, head).iter().map(|(root, _)| *root).collect();

    // Held at level 2 while the camera stays far.
    app.world_mut().entity_mut(head).insert(HairLod::fixed(2));
    run(&mut app, 40);
    assert_eq!(state(&app, head).strands().simulated_strands(), 50);
    let roots_after: Vec<Vec3> = roots_and_tips(&app, head).iter().map(|(root, _)| *root).collect();
    assert!(roots_before.iter().zip(&roots_after).all(|(a, b)| a.distance(*b) < 1e-5), "the head did not move");

    // Unusable values: reported once, replaced, and the groom runs on.
    app.world_mut().entity_mut(head).insert(HairLod {
        full_detail_height: f32::NAN,
        fade_seconds: -1.0,
        fixed_level: Some(99),
        ..default()
    });
    let mut all = Vec::new();
    for _ in 0..5 {
        app.update();
        let messages = app.world().resource::<Messages<HairError>>();
        all.extend(messages.iter_current_update_messages().map(|e| e.kind.to_string()));
    }
    let detail = all.iter().filter(|m| m.contains("level-of-detail")).count();
    assert_eq!(detail, 1, "one report: {all:?}");
    assert!(all.iter().any(|m| m.contains("full_detail_height is NaN") && m.contains("fade_seconds is -1")), "{all:?}");
    assert_eq!(state(&app, head).strands().detail_level(), 7, "the deepest level, for 99");
    assert!(all_finite(&app, head));
}

/// A far head's followers are placed as the plugin copies the strands out (in head space,
/// from their leaders' copied positions), not by the solver: copied out, they are where
/// the solver's own placement ([`Strands::place_followers`], world space) puts them, to
/// 1 µm, on a head turning at up to 3 rad/s through a switch of levels.
#[test]
fn a_far_heads_followers_are_copied_out_where_the_solver_places_them() {
    let (mut app, head) = grown(groom());
    // Fades of 6 steps, so that most steps have followers.
    let lod = |level: u32| HairLod { fixed_level: Some(level), fade_seconds: 0.1, ..default() };
    app.world_mut().entity_mut(head).insert(lod(3));
    let (mut apart, mut followers) = (0.0f32, 0);
    for k in 0..40 {
        if k == 20 {
            app.world_mut().entity_mut(head).insert(lod(5));
        }
        *app.world_mut().get_mut::<Transform>(head).unwrap() = turning(k);
        app.update();
        let state = state(&app, head);
        let mut placed = state.strands().clone();
        placed.place_followers();
        let (n, origin) = (placed.particles_per_strand(), state.origin());
        for s in (0..placed.strand_count()).filter(|&s| state.strands().is_following(s)) {
            followers += 1;
            for i in s * n..(s + 1) * n {
                let by_solver = Vec3::from_array((placed.positions()[i] + origin).to_array());
                apart = apart.max(by_solver.distance(state.current_positions()[i]));
            }
        }
    }
    println!("{followers} followers copied out, at most {:.3} µm from the solver's placement", apart * 1e6);
    assert!(followers >= 30 * 175, "too few followers seen: {followers}");
    assert!(apart <= 1e-6, "a follower was copied out {} µm from where the solver places it", apart * 1e6);
    assert!(all_finite(&app, head));
}

/// The grooms of a crowd step, and are copied out, side by side on the compute pool, each
/// split further (or, a far head's few strands, in one task): twins in a crowd of five,
/// reset together, step to the same bits, at full detail and at a level of detail.
#[test]
fn twins_in_a_crowd_step_to_the_same_bits() {
    let mut app = app();
    let fixed = |level| HairLod { fixed_level: Some(level), fade_seconds: 0.0, ..default() };
    let heads: Vec<Entity> = [0, 0, 2, 2, 7]
        .into_iter()
        .map(|level| {
            let head = spawn_head(&mut app, groom(), Transform::default());
            app.world_mut().entity_mut(head).insert(fixed(level));
            head
        })
        .collect();
    for &head in &heads {
        wait_until_ready(&mut app, head);
    }
    // Grown at different updates: from here on, the same steps.
    for &head in &heads {
        app.world_mut().get_mut::<HairState>(head).unwrap().reset();
    }
    for k in 0..40 {
        for &head in &heads {
            *app.world_mut().get_mut::<Transform>(head).unwrap() = turning(k);
        }
        app.update();
    }
    let bits = |head| -> Vec<[u32; 3]> {
        state(&app, head).current_local_positions().iter().map(|p| p.to_array().map(f32::to_bits)).collect()
    };
    let simulated: Vec<usize> = heads.iter().map(|&h| state(&app, h).strands().simulated_strands()).collect();
    assert_eq!(simulated, [200, 200, 50, 50, 2]);
    for twins in [[0, 1], [2, 3]] {
        let apart = bits(heads[twins[0]]).iter().zip(&bits(heads[twins[1]])).filter(|(a, b)| a != b).count();
        assert_eq!(apart, 0, "twins {twins:?}: {apart} particles differ");
    }
    // And the twins moved: the comparison is not of two heads at rest.
    let rest = &state(&app, heads[2]).strands().rest().positions;
    let local = state(&app, heads[2]).current_local_positions();
    let moved = rest.iter().zip(local).map(|(r, p)| (Vec3::from_array(r.to_array()) - *p).length()).fold(0.0, f32::max);
    assert!(moved > 0.001, "the hair barely moved: {moved} m");
    assert!(all_finite(&app, heads[4]));
}

/// The head's yaw at update `k`: a turn one way and back, 1.5 rad at 3 rad/s peaks.
fn turning(k: usize) -> Transform {
    Transform::from_rotation(Quat::from_rotation_y(1.5 * (k as f32 / 30.0).sin()))
}

/// Hair volume runs on the GPU too: a groom asking for the GPU with volume on is stepped
/// there, reports nothing, and moves as the same groom on the CPU does. Where the device
/// has timestamp queries, the grid's GPU time is published, a share of the step's.
#[test]
fn a_gpu_groom_with_volume_steps_on_the_gpu() {
    let Some(mut app) = app_on_a_gpu() else { return };
    // Without the pressure solve: with it, hair under this turn is so sensitive that the
    // CPU's own groom nudged by 0.1 µm parts from itself by millimetres in 30 steps, and
    // no bound here could tell a fault from that. hair_gpu's `against_cpu` checks the
    // pressure against the CPU's nudged twins, and one step from one state (after the
    // CPU's pressure was handed over, as here at the take-over) to the bit.
    let volume = SimParams { volume: Volume { enabled: true, pressure_iterations: 0, ..default() }, ..default() };
    app.insert_resource(HairSettings(volume));
    let mut plain = common::app();
    plain.insert_resource(HairSettings(volume));
    app.init_resource::<GpuFallbacks>().add_systems(Last, collect_gpu_fallbacks);
    let heads = [(&mut app, HairBackend::Gpu), (&mut plain, HairBackend::Cpu)].map(|(app, backend)| {
        let head = spawn_head(app, groom(), Transform::default());
        app.world_mut().entity_mut(head).insert((backend, HairReadback));
        wait_until_ready(app, head);
        head
    });
    wait_until_on_gpu(&mut app, heads[0]);
    // Grown and handed over at different updates: from here on, the same steps.
    for (app, head) in [(&mut app, heads[0]), (&mut plain, heads[1])] {
        wait_for_gpu(app, head);
    }
    for k in 0..30 {
        for (app, head) in [(&mut app, heads[0]), (&mut plain, heads[1])] {
            *app.world_mut().get_mut::<Transform>(head).unwrap() = turning(k);
            app.update();
        }
    }
    wait_for_gpu(&mut app, heads[0]);
    let fallbacks = app.world().resource::<GpuFallbacks>().0.clone();
    assert!(fallbacks.is_empty(), "stepped on the GPU: {fallbacks:?}");
    assert!(state(&app, heads[0]).gpu_lag().is_some(), "the groom is on the GPU");
    let (on_gpu, on_cpu) = (state(&app, heads[0]).current_positions(), state(&plain, heads[1]).current_positions());
    let apart: Vec<f32> = on_gpu.iter().zip(on_cpu).map(|(a, b)| a.distance(*b)).collect();
    let mean = apart.iter().sum::<f32>() / apart.len() as f32;
    let max = apart.iter().copied().fold(0.0, f32::max);
    println!("volume on the GPU beside the CPU after 30 steps: mean {:.4} mm, max {:.3} mm", mean * 1e3, max * 1e3);
    assert!(on_gpu.iter().all(|p| p.is_finite()));
    // The grid couples neighbouring strands, so rounding parts the two more than without
    // volume (hair_gpu's against_cpu compares them with the CPU's own nudged twins).
    assert!(mean < 2e-4 && max < 0.01, "mean {mean} m, max {max} m apart");
    let diagnostics = app.world().resource::<bevy::diagnostic::DiagnosticsStore>();
    let latest = |path| diagnostics.get(path).and_then(|d| d.value());
    let (step, grid) = (latest(&HairDiagnostics::GPU_STEP_TIME), latest(&HairDiagnostics::GPU_VOLUME_TIME));
    let timestamps = app.world().resource::<RenderDevice>().features().contains(wgpu::Features::TIMESTAMP_QUERY);
    println!("GPU time, timestamps {timestamps}: the step {step:?} ms, its grid {grid:?} ms");
    match (step, grid) {
        (Some(step), Some(grid)) => assert!(timestamps && grid > 0.0 && grid < step, "{grid} of {step} ms"),
        (None, None) => assert!(!timestamps, "timestamps, but no GPU time"),
        times => panic!("the step's time and its grid's come together: {times:?}"),
    }
}

/// What [`beside_the_cpu`] saw.
struct Beside {
    /// The first app's positions as its state held them (for a GPU groom, the last copy
    /// that arrived without waiting)…
    copied: Vec<Vec3>,
    /// …and after waiting for the GPU's last step (`HairState::gpu_lag` 0).
    exact: Vec<Vec3>,
    /// The plain app's.
    on_cpu: Vec<Vec3>,
    /// The fallbacks the first app reported.
    fallbacks: Vec<String>,
    /// Every step's `HairState::last_report` summed, the first app's (with what its last
    /// read-back brought) and the plain app's.
    reported: [StepReport; 2],
    /// The first app's `HairDiagnostics::GPU_STEP_TIME`: every measurement, milliseconds.
    gpu_step_ms: Vec<f64>,
    /// Its `GPU_VOLUME_TIME`, likewise.
    gpu_volume_ms: Vec<f64>,
    /// Its `GPU_HANDOVER_TIME` and `STEP_TIME`, the measurements they both kept.
    submit_and_step_ms: Vec<(f64, f64)>,
}

/// Grows `groom()` in `app` (with `backend`) and in a plain app on the CPU, turns both
/// heads alike for `frames` updates, and returns what each holds.
fn beside_the_cpu(mut app: App, backend: HairBackend, frames: usize) -> Beside {
    app.init_resource::<GpuFallbacks>().add_systems(Last, collect_gpu_fallbacks);
    let head = spawn_head(&mut app, groom(), Transform::default());
    app.world_mut().entity_mut(head).insert((backend, HairReadback));
    let (mut cpu, cpu_head) = grown(groom());
    wait_until_ready(&mut app, head);
    let renders = app.world().contains_resource::<RenderDevice>();
    if backend == HairBackend::Gpu && renders {
        wait_until_on_gpu(&mut app, head);
    }
    // What the steps so far did, out of the way.
    wait_for_gpu(&mut app, head);
    let mut reported = [StepReport::default(); 2];
    for k in 0..frames {
        for (i, (app, head)) in [(&mut app, head), (&mut cpu, cpu_head)].into_iter().enumerate() {
            *app.world_mut().get_mut::<Transform>(head).unwrap() = turning(k);
            app.update();
            reported[i].merge(state(app, head).last_report());
        }
    }
    let positions = |app: &App, head| state(app, head).current_positions().to_vec();
    let copied = positions(&app, head);
    let on_gpu = state(&app, head).gpu_lag().is_some();
    assert_eq!(on_gpu, backend == HairBackend::Gpu && renders);
    reported[0].merge(wait_for_gpu(&mut app, head));
    let fallbacks = std::mem::take(&mut app.world_mut().resource_mut::<GpuFallbacks>().0);
    let diagnostics = app.world().resource::<bevy::diagnostic::DiagnosticsStore>();
    let values = |path: &bevy::diagnostic::DiagnosticPath| {
        diagnostics.get(path).map(|d| d.values().copied().collect::<Vec<f64>>()).unwrap_or_default()
    };
    let (gpu_step_ms, gpu_volume_ms) =
        (values(&HairDiagnostics::GPU_STEP_TIME), values(&HairDiagnostics::GPU_VOLUME_TIME));
    let (submit_ms, step_ms) = (values(&HairDiagnostics::GPU_HANDOVER_TIME), values(&HairDiagnostics::STEP_TIME));
    // The latest of each, side by side (each keeps its own history).
    let submit_and_step_ms = submit_ms.iter().rev().copied().zip(step_ms.iter().rev().copied()).collect();
    Beside {
        copied,
        exact: positions(&app, head),
        on_cpu: positions(&cpu, cpu_head),
        fallbacks,
        reported,
        gpu_step_ms,
        gpu_volume_ms,
        submit_and_step_ms,
    }
}

#[test]
fn the_gpu_backend_steps_a_groom_as_the_cpu_does() {
    let Some(app) = app_on_a_gpu() else { return };
    let timestamps = app.world().resource::<RenderDevice>().features().contains(wgpu::Features::TIMESTAMP_QUERY);
    let Beside { copied, exact: on_gpu, on_cpu, fallbacks, reported, gpu_step_ms, gpu_volume_ms, submit_and_step_ms } =
        beside_the_cpu(app, HairBackend::Gpu, 60);
    assert!(fallbacks.is_empty(), "stepped on the GPU: {fallbacks:?}");
    let apart: Vec<f32> = on_gpu.iter().zip(&on_cpu).map(|(a, b)| a.distance(*b)).collect();
    let mean = apart.iter().sum::<f32>() / apart.len() as f32;
    let max = apart.iter().copied().fold(0.0, f32::max);
    eprintln!(
        "GPU backend beside the CPU after a 1.5 rad turn (60 steps): mean {:.3} µm, max {:.3} µm",
        mean * 1e6,
        max * 1e6
    );
    assert!(on_gpu.iter().all(|p| p.is_finite()));
    // The GPU collides as the CPU does (see hair_gpu's tests): they part by rounding.
    assert!(mean < 1e-5 && max < 1e-3, "mean {mean} m, max {max} m apart");
    // And its reports, coming back late, add up to the CPU's.
    let [gpu, cpu] = reported;
    eprintln!("reported over 60 steps: GPU {gpu:?}, CPU {cpu:?}");
    assert!(cpu.contacts > 0, "the hair touches the head");
    assert_eq!((gpu.teleport_resets, gpu.nan_resets), (0, 0));
    assert!(gpu.contacts.abs_diff(cpu.contacts) as f32 <= 1.0 + 1e-3 * cpu.contacts as f32, "contacts");
    assert!(gpu.segment_turns.abs_diff(cpu.segment_turns) as f32 <= 1.0 + 1e-3 * cpu.segment_turns as f32);
    assert!((gpu.max_depth - cpu.max_depth).abs() <= 1e-6, "deepest contact");
    // Where the device times passes, the steps' GPU time came back with the reports. How
    // many depends on how far the GPU runs behind a loop that draws nothing: all of them on
    // a slow adapter, a few on a fast one.
    eprintln!("GPU time per step, timestamps {timestamps}: {gpu_step_ms:.3?} ms");
    if timestamps {
        assert!(!gpu_step_ms.is_empty(), "no GPU step time came back");
        // (The first may hold the shader's compile: lavapipe compiles at the first dispatch.)
        assert!(gpu_step_ms.iter().all(|ms| ms.is_finite() && *ms > 0.0), "{gpu_step_ms:?}");
    } else {
        assert!(gpu_step_ms.is_empty());
    }
    // Without volume, no grid was timed.
    assert!(gpu_volume_ms.is_empty(), "a grid's GPU time without volume: {gpu_volume_ms:?}");
    // Each step's hand-over to the render world was timed, within the step's own time;
    // the hair code submitted nothing itself: Bevy's frames carried its work.
    assert_eq!(bevy_hair::hair_gpu::submissions(), 0, "the hair code submitted work itself");
    eprintln!("hand-over and step, ms: {submit_and_step_ms:.3?}");
    assert!(!submit_and_step_ms.is_empty(), "no hand-over timed");
    assert!(submit_and_step_ms.iter().all(|&(submit, step)| submit >= 0.0 && submit <= step), "{submit_and_step_ms:?}");
    // And it moved: the turn swings the tips by centimetres.
    let still = beside_the_cpu(app_with_render_device().unwrap(), HairBackend::Gpu, 1).exact;
    let swing = on_gpu.iter().zip(&still).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
    assert!(swing > 0.05, "the GPU groom moved {swing} m");
    // The copies that came back without waiting moved with it, a step or two behind.
    let copied_swing = copied.iter().zip(&still).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
    let behind = copied.iter().zip(&on_gpu).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
    eprintln!("the copy without waiting: {:.2} mm from the last step", behind * 1e3);
    assert!(copied.iter().all(|p| p.is_finite()));
    assert!(copied_swing > 0.05, "the copied positions moved {copied_swing} m");
}

/// A GPU groom's positions come back only where asked for (`HairReadback`): without it the
/// steps' reports still arrive, and the positions stay where the GPU took the groom over
/// while the GPU turns it; with it they catch up with the last step.
/// The largest stretch of any segment of `positions` (strand-major), against the rest
/// lengths of `state`'s strands.
fn stretch_of(positions: &[Vec3], state: &HairState) -> f32 {
    let (n, lengths) = (state.particles_per_strand(), &state.strands().rest().lengths);
    (0..positions.len())
        .filter(|i| i % n != 0)
        .map(|i| (positions[i].distance(positions[i - 1]) / lengths[i] - 1.0).abs())
        .fold(0.0, f32::max)
}

/// [`teleport_and_frame_hitch_stay_sane`] on the GPU backend, read back: a 10 m teleport
/// resets every strand there and brings the hair along, a one-second hitch while the head
/// moves and turns leaves no segment stretched and nothing inside the head.
#[test]
fn a_gpu_groom_survives_a_teleport_and_a_frame_hitch() {
    let Some(mut app) = app_on_a_gpu() else { return };
    let head = spawn_head(&mut app, groom(), Transform::default());
    app.world_mut().entity_mut(head).insert((HairBackend::Gpu, HairReadback));
    wait_until_ready(&mut app, head);
    wait_until_on_gpu(&mut app, head);
    run(&mut app, 30);
    teleport(&mut app, head);
    let reported = wait_for_gpu(&mut app, head);
    let positions = state(&app, head).current_positions().to_vec();
    let stretch = stretch_of(&positions, state(&app, head));
    println!("GPU, after a 10 m teleport: {} strands reset, stretch {stretch:.5}", reported.teleport_resets);
    assert_eq!(reported.teleport_resets, 200, "every strand was reset to the new place");
    assert_came_along(&app, head, stretch);

    hitch_while_turning(&mut app, head);
    wait_for_gpu(&mut app, head);
    let positions = state(&app, head).current_positions().to_vec();
    let stretch = stretch_of(&positions, state(&app, head));
    let inside = max_penetration(&app, head);
    println!("GPU, after a 1 s hitch: stretch {stretch:.5}, deepest particle {:.3} mm", inside * 1e3);
    assert!(all_finite(&app, head));
    assert!(stretch <= 0.1, "a segment is stretched by {stretch}");
    assert!(inside <= 1e-4, "a particle is {} mm inside the head", inside * 1e3);
}

#[test]
fn a_gpu_groom_copies_its_positions_back_only_when_asked() {
    let Some(mut app) = app_on_a_gpu() else { return };
    let head = spawn_head(&mut app, groom(), Transform::default());
    app.world_mut().entity_mut(head).insert(HairBackend::Gpu);
    wait_until_ready(&mut app, head);
    wait_until_on_gpu(&mut app, head);
    let taken_over = state(&app, head).current_positions().to_vec();
    let mut reported = StepReport::default();
    for k in 0..30 {
        *app.world_mut().get_mut::<Transform>(head).unwrap() = turning(k);
        app.update();
        reported.merge(state(&app, head).last_report());
    }
    let unchanged = state(&app, head).current_positions().iter().zip(&taken_over).map(|(a, b)| a.distance(*b));
    let unchanged = unchanged.fold(0.0, f32::max);
    let lag = state(&app, head).gpu_lag();
    println!(
        "without HairReadback: {lag:?} steps behind, positions {unchanged:e} m from the hand-over, {} contacts reported",
        reported.contacts
    );
    assert!(lag.is_some_and(|lag| lag >= 30), "the positions trail every step: {lag:?}");
    assert!(unchanged < 1e-5, "positions came back unasked: {unchanged} m");
    assert!(reported.contacts > 0, "the reports come back");
    app.world_mut().entity_mut(head).insert(HairReadback);
    wait_for_gpu(&mut app, head);
    let moved = state(&app, head).current_positions().iter().zip(&taken_over).map(|(a, b)| a.distance(*b));
    let moved = moved.fold(0.0, f32::max);
    println!("with HairReadback: positions of the last step, {moved:.3} m from the hand-over");
    assert_eq!(state(&app, head).gpu_lag(), Some(0));
    assert!(moved > 0.01, "the turn moved the hair {moved} m");
}

#[test]
fn without_a_render_device_the_gpu_backend_says_why_once_and_steps_on_the_cpu() {
    let Beside {
        copied,
        exact: fell_back,
        on_cpu,
        fallbacks,
        reported,
        gpu_step_ms,
        gpu_volume_ms,
        submit_and_step_ms,
    } = beside_the_cpu(app(), HairBackend::Gpu, 30);
    assert_eq!(copied, fell_back, "nothing to wait for on the CPU");
    assert_eq!(fallbacks.len(), 1, "reported once: {fallbacks:?}");
    assert!(fallbacks[0].contains("no render device"), "{}", fallbacks[0]);
    // The CPU solver stepped it: the same bits as a groom that asked for the CPU.
    assert_eq!(fell_back, on_cpu);
    assert_eq!(reported[0], reported[1]);
    assert!(reported[0].contacts > 0);
    assert!(gpu_step_ms.is_empty() && gpu_volume_ms.is_empty(), "no GPU time without a GPU step");
    assert!(submit_and_step_ms.is_empty(), "no hand-over without a GPU step");
}
