//! The fewest lines that put simulated, rendered hair on a mesh.
//!
//! `cargo run --example minimal`
use bevy::prelude::*;
use bevy_hair::prelude::*;

fn main() {
    App::new().add_plugins((DefaultPlugins, HairPlugin::default())).add_systems(Startup, setup).run();
}

fn setup(mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>, mut materials: ResMut<Assets<StandardMaterial>>) {
    // Your head mesh goes here: any mesh whose scalp is painted black in its vertex colours.
    let head = meshes.add(bevy_hair::procedural_head_mesh(4));
    commands.spawn((Mesh3d(head), MeshMaterial3d(materials.add(Color::srgb(0.8, 0.6, 0.5))), HairGroom::default()));

    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, 0.1, 0.6).looking_at(Vec3::new(0.0, 0.05, 0.0), Vec3::Y),
    ));
    commands.spawn((DirectionalLight::default(), Transform::from_xyz(1.0, 2.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y)));
}
