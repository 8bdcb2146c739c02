//! Hair on a skinned glTF character playing its own clip: `assets/head.glb`'s scene is
//! spawned, the groom goes on its skinned mesh once the scene is in the world, and the
//! clip the glTF carries plays on the `AnimationPlayer` Bevy's loader gives it. The hair
//! grows on the bind-pose scalp, follows the joint that carries the scalp, and collides
//! with the neck as it is skinned.
//!
//! `cargo run --release --example character`
use bevy::mesh::skinning::SkinnedMesh;
use bevy::prelude::*;
use bevy::world_serialization::{WorldAssetRoot, WorldInstanceReady};
use bevy_hair::prelude::*;

const CHARACTER: &str = "head.glb";

fn main() {
    App::new().add_plugins((DefaultPlugins, HairPlugin::default())).add_systems(Startup, setup).run();
}

/// The clip's graph and node, for the player the loader makes.
#[derive(Resource)]
struct Clip {
    graph: Handle<AnimationGraph>,
    node: AnimationNodeIndex,
}

fn setup(mut commands: Commands, assets: Res<AssetServer>, mut graphs: ResMut<Assets<AnimationGraph>>) {
    let (graph, node) = AnimationGraph::from_clip(assets.load(GltfAssetLabel::Animation(0).from_asset(CHARACTER)));
    commands.insert_resource(Clip { graph: graphs.add(graph), node });
    let scene = assets.load(GltfAssetLabel::Scene(0).from_asset(CHARACTER));
    commands.spawn(WorldAssetRoot(scene)).observe(dress_and_play);
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, 1.65, 0.9).looking_at(Vec3::new(0.0, 1.6, 0.0), Vec3::Y),
    ));
    commands.spawn((DirectionalLight::default(), Transform::from_xyz(1.0, 3.0, 2.0).looking_at(Vec3::ZERO, Vec3::Y)));
}

/// Once the character is in the world: the groom on its skinned mesh, the clip on its
/// player, looping.
fn dress_and_play(
    ready: On<WorldInstanceReady>,
    mut commands: Commands,
    children: Query<&Children>,
    skinned: Query<(), With<SkinnedMesh>>,
    mut players: Query<&mut AnimationPlayer>,
    clip: Res<Clip>,
) {
    let mut descendants = children.iter_descendants(ready.entity);
    if let Some(head) = descendants.find(|&e| skinned.contains(e)) {
        // Combed back, so the fringe stays out of the face.
        commands.entity(head).insert(HairGroom { comb: Vec3::new(0.0, 0.0, -1.5), ..default() });
    }
    if let Some(entity) = children.iter_descendants(ready.entity).find(|&e| players.contains(e))
        && let Ok(mut player) = players.get_mut(entity)
    {
        player.play(clip.node).repeat();
        commands.entity(entity).insert(AnimationGraphHandle(clip.graph.clone()));
    }
}
