//! Grooms that travel: a groom written as a `.hair` file (Cem Yuksel's format) and read
//! back, and `assets/procedural.hair` (the default groom on the procedural head, written by
//! this test) loaded through Bevy's `AssetServer` and grown from.

mod common;

use bevy::asset::LoadState;
use bevy::prelude::*;
use bevy_hair::hair_sim::groom::HairFile;
use bevy_hair::prelude::*;
use bevy_hair::{HairAsset, procedural_head_mesh};
use common::*;
use std::time::{Duration, Instant};

/// The committed example, relative to the asset root.
const EXAMPLE: &str = "procedural.hair";

/// The default groom on the procedural head, 120 settle steps, as a `.hair` file.
fn written_groom() -> (HairFile, Vec<u8>) {
    let (app, head) = grown(groom());
    let file = state(&app, head).to_hair_file();
    let bytes = file.write().expect("a grown groom writes");
    (file, bytes)
}

#[test]
fn a_groom_written_to_a_hair_file_grows_back_the_same() {
    let (file, bytes) = written_groom();
    assert_eq!(HairFile::read(&bytes).unwrap(), file, "read back bit for bit");
    assert_eq!(file.strands.len(), 200);

    // A new head takes its guides from the file instead of growing them.
    let mut app = app();
    let model = app.world_mut().resource_mut::<Assets<HairAsset>>().add(HairAsset(file.clone()));
    let groom = HairGroom { guides_from: Some(model), settle_steps: 0, ..groom() };
    let head = spawn_head(&mut app, groom, Transform::default());
    wait_until_ready(&mut app, head);
    let state = state(&app, head);
    let rest = &state.strands().rest().positions;
    assert_eq!(rest.len(), 200 * 11);
    let mut worst = 0.0f32;
    for (strand, from_file) in rest.chunks_exact(11).zip(&file.strands) {
        for (p, q) in strand.iter().zip(from_file) {
            worst = worst.max((*p - *q).length());
        }
    }
    println!("guides from the file: {} strands, at most {:.4} mm from the file's points", rest.len() / 11, worst * 1e3);
    assert!(worst < 1e-4, "{worst}");
}

#[test]
fn the_example_hair_file_loads_through_the_asset_server_and_is_reproduced() {
    let (_, bytes) = written_groom();
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets").join(EXAMPLE);
    if std::env::var_os("BEVY_HAIR_WRITE_ASSETS").is_some() {
        std::fs::write(&path, &bytes).unwrap();
    }
    let committed = std::fs::read(&path).expect("assets/procedural.hair is committed");
    assert!(
        committed == bytes,
        "assets/{EXAMPLE} is not what the default groom writes now; regenerate it with \
         BEVY_HAIR_WRITE_ASSETS=1 cargo test --workspace --test hair_files"
    );

    let mut app = app();
    let model: Handle<HairAsset> = app.world().resource::<AssetServer>().load(EXAMPLE);
    let start = Instant::now();
    while app.world().resource::<Assets<HairAsset>>().get(&model).is_none() {
        let state = app.world().resource::<AssetServer>().load_state(&model);
        assert!(!matches!(state, LoadState::Failed(_)), "{state:?}");
        assert!(start.elapsed() < Duration::from_secs(30), "the .hair file did not load");
        app.update();
        std::thread::sleep(Duration::from_millis(2));
    }
    let strands = app.world().resource::<Assets<HairAsset>>().get(&model).unwrap().0.strands.len();
    assert_eq!(strands, 200);
    let mesh = app.world_mut().resource_mut::<Assets<Mesh>>().add(procedural_head_mesh(4));
    let head = app.world_mut().spawn((Mesh3d(mesh), HairGroom { guides_from: Some(model), ..groom() })).id();
    wait_until_ready(&mut app, head);
    assert_eq!(state(&app, head).strands().strand_count(), 200);
}

/// A truncated `.hair` file fails to load with the parser's reason, and the groom that
/// asked for it reports it (`HairErrorKind::HairModel`) instead of growing.
#[test]
fn a_bad_hair_file_is_reported() {
    let (_, bytes) = written_groom();
    let dir = std::env::temp_dir().join(format!("bevy_hair_files_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("truncated.hair"), &bytes[..bytes.len() / 2]).unwrap();
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin { file_path: dir.to_string_lossy().into_owned(), ..default() },
        bevy::mesh::MeshPlugin,
        HairPlugin::default(),
    ));
    let model: Handle<HairAsset> = app.world().resource::<AssetServer>().load("truncated.hair");
    let mesh = app.world_mut().resource_mut::<Assets<Mesh>>().add(procedural_head_mesh(3));
    let head = app.world_mut().spawn((Mesh3d(mesh), HairGroom { guides_from: Some(model), ..groom() })).id();
    let start = Instant::now();
    loop {
        app.update();
        if let Some(GroomStatus::Failed(kind)) = app.world().get::<GroomStatus>(head) {
            println!("{kind}");
            assert!(matches!(kind, HairErrorKind::HairModel(_)), "{kind:?}");
            assert!(kind.to_string().contains("header announces"), "{kind}");
            break;
        }
        assert!(start.elapsed() < Duration::from_secs(30), "no failure");
        std::thread::sleep(Duration::from_millis(2));
    }
    std::fs::remove_dir_all(dir).ok();
}
