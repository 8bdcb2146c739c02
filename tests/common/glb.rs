//! Heads loaded from `.glb` files as a user loads them: a headless app with Bevy's glTF
//! loader and the hair plugin, and README's code run on a file copied as `my_head.glb`,
//! with its roots checked against the loaded mesh's own paint.
#![allow(dead_code)] // each test binary uses a different part

use super::common;
use bevy::animation::AnimationPlugin;
use bevy::gltf::GltfPlugin;
use bevy::mesh::{Indices, MeshPlugin, VertexAttributeValues};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::world_serialization::WorldSerializationPlugin;
use bevy_hair::prelude::*;
use std::time::Duration;

/// README's "The code", which [`readme_code_on`] runs and `tests/shipped_character.rs`
/// checks word for word.
mod readme {
    #![allow(dead_code)] // its `main` opens a window: the tests run `setup`
    include!("readme_code.rs");

    /// Schedules README's `setup`, private to this module.
    pub(super) fn add_setup(app: &mut App) {
        app.add_systems(Startup, setup);
    }
}

/// A headless app that loads glTF files and grows hair, its time advancing by `frame` per
/// update.
pub fn gltf_app(frame: Duration) -> App {
    gltf_app_in(frame, AssetPlugin::default())
}

/// [`gltf_app`] with its assets from `assets`.
pub fn gltf_app_in(frame: Duration, assets: AssetPlugin) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        assets,
        MeshPlugin,
        AnimationPlugin,
        WorldSerializationPlugin,
        GltfPlugin::default(),
        HairPlugin::default(),
    ));
    app.insert_resource(TimeUpdateStrategy::ManualDuration(frame));
    // `App::run` would do this; the glTF loader is registered in `GltfPlugin::finish`.
    app.finish();
    app.cleanup();
    app
}

/// What README's code grew on a head.
pub struct ReadmeRun {
    pub app: App,
    pub head: Entity,
    /// Strands grown.
    pub strands: usize,
    /// Roots not on a triangle with a painted corner ([`roots_off_paint`]).
    pub off_paint: usize,
    /// The deepest particle inside the head, metres (negative: all outside).
    pub deepest: f32,
    /// What the plugin reported (`HairError`s), in words.
    pub reports: Vec<String>,
}

/// Every `HairError` reported so far, in words.
#[derive(Resource, Default)]
struct Reports(Vec<String>);

fn collect_reports(mut errors: MessageReader<HairError>, mut reports: ResMut<Reports>) {
    reports.0.extend(errors.read().map(|e| e.kind.to_string()));
}

/// README's code as a user runs it, on the `.glb` file `path` copied as `my_head.glb`
/// into an asset folder of its own, one second of steps after it grew.
pub fn readme_code_on(path: &str) -> ReadmeRun {
    let name = std::path::Path::new(path).file_stem().unwrap().to_string_lossy().into_owned();
    let dir = std::env::temp_dir().join(format!("bevy_hair_readme_{name}_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::copy(path, dir.join("my_head.glb")).unwrap();
    let assets = AssetPlugin { file_path: dir.to_string_lossy().into_owned(), ..default() };
    let mut app = gltf_app_in(common::FRAME, assets);
    app.init_asset::<StandardMaterial>();
    readme::add_setup(&mut app);
    app.init_resource::<Reports>().add_systems(Last, collect_reports);
    app.update();
    let head = app.world_mut().query_filtered::<Entity, With<HairGroom>>().single(app.world()).unwrap();
    common::wait_until_ready(&mut app, head);
    for _ in 0..60 {
        app.update();
    }
    std::fs::remove_dir_all(&dir).ok();
    let strands = common::roots_and_tips(&app, head).len();
    let off_paint = roots_off_paint(&app, head);
    let deepest = common::max_penetration(&app, head);
    let reports = app.world().resource::<Reports>().0.clone();
    ReadmeRun { app, head, strands, off_paint, deepest, reports }
}

/// How many of `head`'s roots are not on the paint, checked against the loaded mesh
/// itself: a root must lie on a triangle with a painted corner (mean colour below one
/// half), within 0.1 mm of its plane.
pub fn roots_off_paint(app: &App, head: Entity) -> usize {
    let world = app.world();
    let mesh = world.resource::<Assets<Mesh>>().get(&world.get::<Mesh3d>(head).unwrap().0).unwrap();
    let Some(VertexAttributeValues::Float32x3(positions)) = mesh.attribute(Mesh::ATTRIBUTE_POSITION) else {
        panic!("float positions")
    };
    let painted: Vec<bool> = match mesh.attribute(Mesh::ATTRIBUTE_COLOR) {
        Some(VertexAttributeValues::Float32x4(colours)) => {
            colours.iter().map(|c| (c[0] + c[1] + c[2]) / 3.0 < 0.5).collect()
        }
        Some(VertexAttributeValues::Unorm16x4(colours)) => {
            colours.iter().map(|c| (u32::from(c[0]) + u32::from(c[1]) + u32::from(c[2])) < 3 * 32768).collect()
        }
        Some(VertexAttributeValues::Unorm8x4(colours)) => {
            colours.iter().map(|c| (u32::from(c[0]) + u32::from(c[1]) + u32::from(c[2])) < 3 * 128).collect()
        }
        other => panic!("vertex colours: {:?}", other.map(|o| o.len())),
    };
    let corners: Vec<[usize; 3]> = match mesh.indices().unwrap() {
        Indices::U16(i) => i.chunks_exact(3).map(|t| [t[0] as usize, t[1] as usize, t[2] as usize]).collect(),
        Indices::U32(i) => i.chunks_exact(3).map(|t| [t[0] as usize, t[1] as usize, t[2] as usize]).collect(),
    };
    let on_paint = |root: Vec3| {
        corners.iter().any(|t| {
            let [a, b, c] = t.map(|v| Vec3::from_array(positions[v]));
            let normal = (b - a).cross(c - a);
            let area = normal.length();
            if area < 1e-12 || (root - a).dot(normal / area).abs() > 1e-4 {
                return false;
            }
            // Barycentric weights: each the share of the area facing a corner.
            let weights = [(b - root).cross(c - root), (c - root).cross(a - root), (a - root).cross(b - root)]
                .map(|w| w.dot(normal) / (area * area));
            weights.iter().all(|&w| w >= -1e-4) && t.iter().any(|&v| painted[v])
        })
    };
    // Roots are placed in the head's frame; this head is not moved, so world is mesh space.
    common::roots_and_tips(app, head).iter().filter(|(root, _)| !on_paint(*root)).count()
}
