//! Head motion: the clip in `assets/head.glb` (turn, nod, shake, whip; looped), loaded
//! through Bevy's glTF loader and played by the `AnimationPlayer` the loader puts on the
//! character; pause, speed and scrub from the panel; and a mode in which the mouse drags
//! the character instead.

use crate::scene::{Character, HEAD_GLB, OrbitCamera};
use bevy::input::mouse::AccumulatedMouseMotion;
use bevy::prelude::*;
use bevy::world_serialization::WorldInstanceReady;
use bevy_egui::input::EguiWantsInput;
use bevy_hair::prelude::*;

/// Playback controls, set by the panel and the keyboard, applied to the character's player.
#[derive(Resource)]
pub struct Motion {
    /// The clip's node in the animation graph.
    pub node: AnimationNodeIndex,
    /// The graph with the clip.
    pub graph: Handle<AnimationGraph>,
    /// The clip, for its length.
    pub clip: Handle<AnimationClip>,
    /// The clip's length, seconds, once it is loaded.
    pub duration: f32,
    /// The entity with the `AnimationPlayer`, once the character's scene is spawned.
    pub player: Option<Entity>,
    pub paused: bool,
    pub speed: f32,
    /// The mouse moves the character; the clip holds its pose meanwhile.
    pub drag_head: bool,
    /// Jump to this clip time next frame.
    pub seek: Option<f32>,
    /// Put the character back where it started (after dragging it away).
    pub reset_pose: bool,
    /// The clip time now, for the scrub slider.
    pub time: f32,
}

pub fn plugin(app: &mut App) {
    app.add_systems(Startup, setup).add_observer(start_the_clip).add_systems(Update, (keys, drag_head, apply).chain());
}

/// Loads the clip from the glTF and makes the graph that plays it.
fn setup(mut commands: Commands, asset_server: Res<AssetServer>, mut graphs: ResMut<Assets<AnimationGraph>>) {
    let clip = asset_server.load(GltfAssetLabel::Animation(0).from_asset(HEAD_GLB));
    let (graph, node) = AnimationGraph::from_clip(clip.clone());
    commands.insert_resource(Motion {
        node,
        graph: graphs.add(graph),
        clip,
        duration: 0.0,
        player: None,
        paused: false,
        speed: 1.0,
        drag_head: false,
        seek: None,
        reset_pose: false,
        time: 0.0,
    });
}

/// When the character's scene is in the world, gives the player the loader put on it our
/// graph and starts the clip, looping.
fn start_the_clip(
    ready: On<WorldInstanceReady>,
    mut commands: Commands,
    children: Query<&Children>,
    mut players: Query<&mut AnimationPlayer>,
    mut motion: ResMut<Motion>,
) {
    let Some(entity) = children.iter_descendants(ready.entity).find(|&e| players.contains(e)) else {
        error!("{HEAD_GLB} has no animated joints");
        return;
    };
    let mut player = players.get_mut(entity).expect("found above");
    player.play(motion.node).repeat();
    commands.entity(entity).insert(AnimationGraphHandle(motion.graph.clone()));
    motion.player = Some(entity);
}

/// Space pauses, D toggles dragging the head, R puts the hair back at rest.
fn keys(
    keys: Res<ButtonInput<KeyCode>>,
    // Absent without the panel (`--no-panel`).
    egui: Option<Res<EguiWantsInput>>,
    mut motion: ResMut<Motion>,
    mut hair: Query<&mut HairState>,
) {
    if egui.as_ref().is_some_and(|e| e.wants_any_keyboard_input()) {
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

/// In drag mode, the left button moves the character in the view plane (with Shift, turns
/// it), so you can fling it and watch the hair follow.
#[allow(clippy::too_many_arguments)] // one system, many small inputs
fn drag_head(
    motion: Res<Motion>,
    buttons: Res<ButtonInput<MouseButton>>,
    keys: Res<ButtonInput<KeyCode>>,
    mouse_motion: Res<AccumulatedMouseMotion>,
    // Absent without the panel (`--no-panel`).
    egui: Option<Res<EguiWantsInput>>,
    camera: Single<(&Transform, &OrbitCamera, &Projection), Without<Character>>,
    window: Single<&Window>,
    mut head: Single<&mut Transform, With<Character>>,
    mut dragging: Local<bool>,
) {
    if !motion.drag_head || !buttons.pressed(MouseButton::Left) {
        *dragging = false;
        return;
    }
    if buttons.just_pressed(MouseButton::Left) && !egui.as_ref().is_some_and(|e| e.wants_any_pointer_input()) {
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

/// Applies the controls to the character's player: drag mode holds the clip's pose (the
/// joints stay where they are while the character is dragged), leaving it resumes.
fn apply(
    mut motion: ResMut<Motion>,
    mut players: Query<&mut AnimationPlayer>,
    mut character: Single<&mut Transform, With<Character>>,
    clips: Res<Assets<AnimationClip>>,
) {
    if let Some(clip) = clips.get(&motion.clip) {
        motion.duration = clip.duration();
    }
    if motion.reset_pose {
        motion.reset_pose = false;
        **character = Transform::IDENTITY;
    }
    let node = motion.node;
    let Some(mut player) = motion.player.and_then(|e| players.get_mut(e).ok()) else { return };
    let Some(active) = player.animation_mut(node) else { return };
    if let Some(time) = motion.seek.take() {
        active.seek_to(time.clamp(0.0, motion.duration));
    }
    let paused = motion.paused || motion.drag_head;
    if active.is_paused() != paused {
        if paused {
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
