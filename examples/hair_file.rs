//! Grooms that travel as `.hair` files: a groom grown on one head is saved with
//! [`HairState::to_hair_file`] once it has settled, and a second head grows its guides from
//! that file, loaded through the asset server as a [`HairAsset`]. The shipped
//! `assets/procedural.hair` was written the same way.
//!
//! `cargo run --example hair_file`
use bevy::prelude::*;
use bevy_hair::prelude::*;
use bevy_hair::{HairAsset, HairState};

fn main() {
    App::new()
        .add_plugins((DefaultPlugins, HairPlugin::default()))
        .add_systems(Startup, setup)
        .add_systems(Update, save_once_settled)
        .run();
}

/// The head whose groom is saved.
#[derive(Component)]
struct Original;

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    assets: Res<AssetServer>,
) {
    let head = meshes.add(bevy_hair::procedural_head_mesh(4));
    let skin = materials.add(Color::srgb(0.8, 0.6, 0.5));
    let curly = HairGroom { curl: 0.6, ..default() };
    commands.spawn((
        Original,
        Mesh3d(head.clone()),
        MeshMaterial3d(skin.clone()),
        Transform::from_xyz(-0.25, 0.0, 0.0),
        curly,
    ));
    // The shipped file: its guides, rooted where their first points lie on this head.
    let model: Handle<HairAsset> = assets.load("procedural.hair");
    let from_file = HairGroom { guides_from: Some(model), ..default() };
    commands.spawn((Mesh3d(head), MeshMaterial3d(skin), Transform::from_xyz(0.25, 0.0, 0.0), from_file));
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, 0.1, 1.0).looking_at(Vec3::new(0.0, 0.05, 0.0), Vec3::Y),
    ));
    commands.spawn((DirectionalLight::default(), Transform::from_xyz(1.0, 2.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y)));
}

/// Three seconds after the original head's groom has grown, writes it to `curly.hair` in
/// the working directory.
fn save_once_settled(time: Res<Time>, mut saved: Local<bool>, heads: Query<&HairState, With<Original>>) {
    let Ok(state) = heads.single() else { return };
    if *saved || time.elapsed_secs() < 3.0 {
        return;
    }
    *saved = true;
    match state.to_hair_file().write() {
        Ok(bytes) => match std::fs::write("curly.hair", bytes) {
            Ok(()) => info!("wrote curly.hair: load it as a HairAsset for HairGroom::guides_from"),
            Err(e) => warn!("could not write curly.hair: {e}"),
        },
        Err(e) => warn!("the groom cannot be written: {e}"),
    }
}
