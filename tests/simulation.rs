//! Headless ECS tests of the simulation: each asserts a measured number.

mod common;

use bevy::animation::{AnimatedBy, AnimationTargetId, animated_field, prelude::*};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_hair::hair_sim::math::Pose;
use bevy_hair::prelude::*;
use common::*;
use std::f32::consts::TAU;
use std::time::Duration;

fn root_error(app: &App, head: Entity, pose: Pose) -> f32 {
    let state = state(app, head);
    let n = state.particles_per_strand();
    let rest = &state.strands().rest().positions;
    state
        .current_positions()
        .iter()
        .step_by(n)
        .zip(rest.iter().step_by(n))
        .map(|(root, &r)| root.distance(Vec3::from_array(pose.transform_point(r).to_array())))
        .fold(0.0, f32::max)
}

#[test]
fn roots_follow_a_moving_head() {
    let (mut app, head) = grown(groom());
    let pose_of = |app: &App| {
        let global = app.world().get::<GlobalTransform>(head).unwrap();
        Pose::new(
            bevy_hair::hair_sim::math::Quat::from_array(global.rotation().to_array()),
            bevy_hair::hair_sim::math::Vec3::from_array(global.translation().to_array()),
        )
    };
    let mut worst = 0.0f32;
    for frame in 0..120 {
        // The fixed step runs before this frame's transform propagation, so it sees the
        // head where the previous frame left it: one frame of lag, by design.
        let seen = pose_of(&app);
        let t = frame as f32 / 60.0;
        let mut transform = app.world_mut().get_mut::<Transform>(head).unwrap();
        transform.translation = Vec3::new(0.3 * (TAU * t).sin(), 0.1 * t, 0.0);
        transform.rotation = Quat::from_rotation_y(1.5 * (TAU * 0.5 * t).sin());
        app.update();
        worst = worst.max(root_error(&app, head, seen));
    }
    let moved = pose_of(&app).translation.length();
    println!("head moved {moved:.3} m; worst root error {worst:e} m");
    assert!(moved > 0.1);
    assert!(worst <= 1e-4, "roots are {worst} m from where the head puts them");
}

#[test]
fn hanging_hair_keeps_its_length() {
    for (mode, limit) in [(LengthMode::Inextensible, 1e-3), (LengthMode::Springs, 0.1)] {
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
    let positions = state.strands().positions();
    positions.iter().zip(rest).map(|(p, r)| p.distance(*r)).sum::<f32>() / positions.len() as f32
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

#[test]
fn teleport_and_frame_hitch_stay_sane() {
    let (mut app, head) = grown(groom());
    run(&mut app, 30);
    app.world_mut().get_mut::<Transform>(head).unwrap().translation = Vec3::new(10.0, 0.0, 0.0);
    run(&mut app, 2);
    let state_now = state(&app, head);
    assert_eq!(state_now.last_report().teleport_resets, 200, "every strand was reset to the new place");
    let stretch = state_now.strands().max_stretch();
    let (root, tip) = roots_and_tips(&app, head)[0];
    println!("after a 10 m teleport: stretch {stretch:.5}, root at {root}, tip at {tip}");
    assert!(all_finite(&app, head));
    assert!(stretch <= 0.1, "a segment is stretched by {stretch}");
    assert!((root.x - 10.0).abs() < 0.2 && tip.distance(root) < 0.3, "the hair came along");

    // A one-second hitch while the head moves 30 cm and turns.
    app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs(1)));
    let mut transform = app.world_mut().get_mut::<Transform>(head).unwrap();
    transform.translation.y += 0.3;
    transform.rotation = Quat::from_rotation_y(1.0);
    app.update();
    app.insert_resource(TimeUpdateStrategy::ManualDuration(FRAME));
    run(&mut app, 5);
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
