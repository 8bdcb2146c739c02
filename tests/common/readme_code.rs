use bevy::prelude::*;
use bevy_hair::prelude::*;

fn main() {
    App::new().add_plugins((DefaultPlugins, HairPlugin::default())).add_systems(Startup, setup).run();
}

fn setup(mut commands: Commands, assets: Res<AssetServer>) {
    let head = assets.load(GltfAssetLabel::Primitive { mesh: 0, primitive: 0 }.from_asset("my_head.glb"));
    // Comb toward the back of a +Z-facing head, so the fringe stays out of the face.
    let groom = HairGroom { comb: Vec3::new(0.0, 0.0, -1.5), ..default() };
    commands.spawn((Mesh3d(head), MeshMaterial3d(assets.add(StandardMaterial::default())), groom));
}
