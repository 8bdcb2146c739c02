//! Head motion: an `AnimationClip` authored in code (a slow turn, a nod, a fast shake,
//! rest; looped) played by Bevy's animation system; pause, speed and scrub from the panel;
//! and a mode in which the mouse drags the head instead.

use crate::scene::{Head, OrbitCamera};
use bevy::animation::{AnimatedBy, AnimationTargetId, animated_field};
use bevy::input::mouse::AccumulatedMouseMotion;
use bevy::prelude::*;
use bevy_egui::input::EguiWantsInput;
use bevy_hair::prelude::*;

/// Length of the looped clip, seconds.
pub const CLIP_SECONDS: f32 = 8.0;

/// Key poses: (time s, yaw°, pitch° (+ nods down), roll°). Between keys the head eases in
/// and out, so it starts and stops smoothly like a person would.
const POSES: &[(f32, f32, f32, f32)] = &[
    (0.0, 0.0, 0.0, 0.0),
    (0.5, 0.0, 0.0, 0.0),
    (1.4, 40.0, -5.0, 4.0),   // turn left
    (2.5, -40.0, -5.0, -4.0), // turn right
    (3.2, 0.0, 0.0, 0.0),
    (3.6, 0.0, 24.0, 0.0), // nod
    (4.0, 0.0, -14.0, 0.0),
    (4.4, 0.0, 24.0, 0.0),
    (4.9, 0.0, 0.0, 0.0),
    (5.05, 28.0, 0.0, 0.0), // fast shake
    (5.2, -28.0, 0.0, 0.0),
    (5.35, 28.0, 0.0, 0.0),
    (5.5, -28.0, 0.0, 0.0),
    (5.65, 0.0, 0.0, 0.0),
    (CLIP_SECONDS, 0.0, 0.0, 0.0), // rest: watch the hair settle
];

/// Playback controls, set by the panel and the keyboard, applied to the head's player.
#[derive(Resource)]
pub struct Motion {
    /// The clip's node in the head's animation graph.
    pub node: AnimationNodeIndex,
    pub paused: bool,
    pub speed: f32,
    /// The mouse moves the head; the animation is stopped meanwhile.
    pub drag_head: bool,
    /// Jump to this clip time next frame.
    pub seek: Option<f32>,
    /// Put the head back where the animation starts (after dragging it away).
    pub reset_pose: bool,
    /// The clip time now, for the scrub slider.
    pub time: f32,
}

pub fn plugin(app: &mut App) {
    app.add_systems(Startup, setup.after(crate::scene::setup)).add_systems(Update, (keys, drag_head, apply).chain());
}

/// Samples the eased key poses at 60 Hz into a keyframe curve on the head's rotation, and
/// starts it looping. The head is its own animation player.
fn setup(
    mut commands: Commands,
    head: Single<(Entity, &Name), With<Head>>,
    mut clips: ResMut<Assets<AnimationClip>>,
    mut graphs: ResMut<Assets<AnimationGraph>>,
) {
    let (entity, name) = *head;
    let target = AnimationTargetId::from_name(name);
    let samples = (CLIP_SECONDS * 60.0) as usize;
    let keys = (0..=samples).map(|i| {
        let t = i as f32 / samples as f32 * CLIP_SECONDS;
        (t, pose_at(t))
    });
    let mut clip = AnimationClip::default();
    let curve = AnimatableKeyframeCurve::new(keys).expect("more than two increasing keyframes");
    clip.add_curve_to_target(target, AnimatableCurve::new(animated_field!(Transform::rotation), curve));
    let (graph, node) = AnimationGraph::from_clip(clips.add(clip));
    let mut player = AnimationPlayer::default();
    player.play(node).repeat();
    commands.entity(entity).insert((target, AnimatedBy(entity), player, AnimationGraphHandle(graphs.add(graph))));
    commands.insert_resource(Motion {
        node,
        paused: false,
        speed: 1.0,
        drag_head: false,
        seek: None,
        reset_pose: false,
        time: 0.0,
    });
}

/// The head rotation at clip time `t`: between the surrounding key poses, eased with a
/// smoothstep so velocity is zero at each key.
fn pose_at(t: f32) -> Quat {
    let next = POSES.iter().position(|p| p.0 > t).unwrap_or(POSES.len() - 1).max(1);
    let (a, b) = (POSES[next - 1], POSES[next]);
    let s = ((t - a.0) / (b.0 - a.0)).clamp(0.0, 1.0);
    let s = s * s * (3.0 - 2.0 * s);
    let lerp = |x: f32, y: f32| (x + (y - x) * s).to_radians();
    Quat::from_euler(EulerRot::YXZ, lerp(a.1, b.1), lerp(a.2, b.2), lerp(a.3, b.3))
}

/// Space pauses, D toggles dragging the head, R puts the hair back at rest.
fn keys(
    keys: Res<ButtonInput<KeyCode>>,
    egui: Res<EguiWantsInput>,
    mut motion: ResMut<Motion>,
    mut hair: Query<&mut HairState>,
) {
    if egui.wants_any_keyboard_input() {
        return;
    }
    if keys.just_pressed(KeyCode::Space) {
        motion.paused = !motion.paused;
    }
    if keys.just_pressed(KeyCode::KeyD) {
        motion.drag_head = !motion.drag_head;
    }
    if keys.just_pressed(KeyCode::KeyR) {
        hair.iter_mut().for_each(|mut state| state.reset());
    }
}

/// In drag mode, the left button moves the head in the view plane (with Shift, turns it),
/// so you can fling it and watch the hair follow.
#[allow(clippy::too_many_arguments)] // one system, many small inputs
fn drag_head(
    motion: Res<Motion>,
    buttons: Res<ButtonInput<MouseButton>>,
    keys: Res<ButtonInput<KeyCode>>,
    mouse_motion: Res<AccumulatedMouseMotion>,
    egui: Res<EguiWantsInput>,
    camera: Single<(&Transform, &OrbitCamera, &Projection), Without<Head>>,
    window: Single<&Window>,
    mut head: Single<&mut Transform, With<Head>>,
    mut dragging: Local<bool>,
) {
    if !motion.drag_head || !buttons.pressed(MouseButton::Left) {
        *dragging = false;
        return;
    }
    if buttons.just_pressed(MouseButton::Left) && !egui.wants_any_pointer_input() {
        *dragging = true;
    }
    let delta = mouse_motion.delta;
    if !*dragging || delta == Vec2::ZERO {
        return;
    }
    let (camera_transform, orbit, projection) = *camera;
    let (right, up) = (camera_transform.right(), camera_transform.up());
    if keys.pressed(KeyCode::ShiftLeft) || keys.pressed(KeyCode::ShiftRight) {
        let turn = Quat::from_axis_angle(Vec3::Y, delta.x * 0.01) * Quat::from_axis_angle(*right, delta.y * 0.01);
        head.rotation = (turn * head.rotation).normalize();
    } else {
        // Metres per pixel at the focus distance, so the head stays under the pointer.
        let fov = match projection {
            Projection::Perspective(p) => p.fov,
            _ => 0.8,
        };
        let metres_per_pixel = 2.0 * orbit.distance * (fov / 2.0).tan() / window.height().max(1.0);
        let moved = head.translation + (*right * delta.x - *up * delta.y) * metres_per_pixel;
        head.translation = moved.clamp(Vec3::splat(-0.5), Vec3::splat(0.5));
    }
}

/// Applies the controls to the head's player: drag mode stops the clip (a stopped clip no
/// longer writes the transform), leaving it resumes where it was.
fn apply(mut motion: ResMut<Motion>, mut head: Single<(&mut AnimationPlayer, &mut Transform), With<Head>>) {
    let (player, transform) = &mut *head;
    let node = motion.node;
    if motion.reset_pose {
        motion.reset_pose = false;
        **transform = Transform::IDENTITY;
    }
    if motion.drag_head {
        player.stop(node);
        return;
    }
    if !player.is_playing_animation(node) {
        transform.translation = Vec3::ZERO; // the clip animates rotation only
        player.play(node).repeat().seek_to(motion.time);
    }
    let Some(active) = player.animation_mut(node) else { return };
    if let Some(time) = motion.seek.take() {
        active.seek_to(time.clamp(0.0, CLIP_SECONDS));
    }
    if active.is_paused() != motion.paused {
        if motion.paused {
            active.pause();
        } else {
            active.resume();
        }
    }
    if active.speed() != motion.speed {
        active.set_speed(motion.speed);
    }
    motion.time = active.seek_time();
}
