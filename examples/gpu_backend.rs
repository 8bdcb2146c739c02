//! A groom stepped on the GPU ([`HairBackend::Gpu`]): the procedural head turning, its hair
//! stepped and drawn by compute passes in Bevy's render world. Until the GPU's pipelines
//! have compiled the CPU steps it; the console says when the GPU takes over, how far the
//! copies back trail it, and, where the GPU cannot step it, why.
//!
//! `cargo run --example gpu_backend`
use bevy::prelude::*;
use bevy_hair::prelude::*;

fn main() {
    App::new()
        .add_plugins((DefaultPlugins, HairPlugin::default()))
        .add_systems(Startup, setup)
        .add_systems(Update, (turn_head, report))
        .run();
}

#[derive(Component)]
struct Head;

fn setup(mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>, mut materials: ResMut<Assets<StandardMaterial>>) {
    let head = meshes.add(bevy_hair::procedural_head_mesh(4));
    commands.spawn((
        Head,
        Mesh3d(head),
        MeshMaterial3d(materials.add(Color::srgb(0.8, 0.6, 0.5))),
        HairGroom::default(),
        HairBackend::Gpu,
    ));
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, 0.1, 0.6).looking_at(Vec3::new(0.0, 0.05, 0.0), Vec3::Y),
    ));
    commands.spawn((DirectionalLight::default(), Transform::from_xyz(1.0, 2.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y)));
}

fn turn_head(time: Res<Time>, mut heads: Query<&mut Transform, With<Head>>) {
    for mut transform in &mut heads {
        transform.rotation = Quat::from_rotation_y(1.2 * (time.elapsed_secs() * 1.5).sin());
    }
}

/// Once a second: on which solver the groom steps, and how old its copied-back positions are.
fn report(time: Res<Time>, mut last: Local<u64>, heads: Query<&HairState, With<Head>>) {
    let second = time.elapsed_secs() as u64;
    if second == *last {
        return;
    }
    *last = second;
    for state in &heads {
        match (state.gpu_lag(), state.gpu_fallback()) {
            (Some(lag), _) => info!("on the GPU; its positions here trail it by {lag} steps"),
            (None, Some(why)) => info!("on the CPU: {why}"),
            (None, None) => info!("on the CPU while the GPU's pipelines compile"),
        }
    }
}
