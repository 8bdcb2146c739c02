//! A crowd with levels of detail ([`HairLod`]): 25 heads in rows going back from the
//! camera, each simulating fewer of its guides the smaller it is drawn (the rest follow
//! their simulated neighbours). The console prints how many guides each row simulates.
//!
//! `cargo run --release --example crowd_lod`
use bevy::prelude::*;
use bevy_hair::prelude::*;

fn main() {
    App::new()
        .add_plugins((DefaultPlugins, HairPlugin::default()))
        .add_systems(Startup, setup)
        .add_systems(Update, report)
        .run();
}

/// The row a head stands in, nearest first.
#[derive(Component)]
struct Row(usize);

fn setup(mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>, mut materials: ResMut<Assets<StandardMaterial>>) {
    let head = meshes.add(bevy_hair::procedural_head_mesh(3));
    let skin = materials.add(Color::srgb(0.8, 0.6, 0.5));
    let groom = HairGroom { guides: 800, ..default() };
    for row in 0..5 {
        for column in 0..5 {
            let at = Vec3::new((column as f32 - 2.0) * 0.5, 0.0, -(row as f32) * 1.5);
            commands.spawn((
                Row(row),
                Mesh3d(head.clone()),
                MeshMaterial3d(skin.clone()),
                Transform::from_translation(at),
                groom.clone(),
                HairLod::default(),
            ));
        }
    }
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, 0.3, 1.2).looking_at(Vec3::new(0.0, 0.0, -3.0), Vec3::Y),
    ));
    commands.spawn((DirectionalLight::default(), Transform::from_xyz(1.0, 2.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y)));
}

/// Every two seconds: the guides each row simulates, of all it has.
fn report(time: Res<Time>, mut last: Local<u64>, heads: Query<(&Row, &HairState)>) {
    let tick = time.elapsed_secs() as u64 / 2;
    if tick == *last {
        return;
    }
    *last = tick;
    let mut rows = [(0, 0); 5];
    for (Row(row), state) in &heads {
        rows[*row].0 += state.strands().simulated_strands();
        rows[*row].1 += state.strands().strand_count();
    }
    info!("guides simulated per row, nearest first (of all): {rows:?}");
}
