//! Bad input gets a readable error, no panic, and never a NaN position.

mod common;

use bevy::asset::RenderAssetUsages;
use bevy::ecs::message::Messages;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use bevy_hair::hair_sim::math::Vec3 as SimVec3;
use bevy_hair::hair_sim::mesh::HeadMesh;
use bevy_hair::prelude::*;
use common::*;

fn errors(app: &App) -> Vec<HairErrorKind> {
    let messages = app.world().resource::<Messages<HairError>>();
    messages.iter_current_update_messages().map(|e| e.kind.clone()).collect()
}

/// Updates until the groom fails, collecting every error message on the way.
fn failure(app: &mut App, head: Entity) -> (HairErrorKind, Vec<HairErrorKind>) {
    let mut seen = Vec::new();
    for _ in 0..50 {
        app.update();
        seen.extend(errors(app));
        if let Some(GroomStatus::Failed(reason)) = app.world().get::<GroomStatus>(head) {
            return (reason.clone(), seen);
        }
    }
    panic!("the groom did not fail: {:?}", app.world().get::<GroomStatus>(head));
}

#[test]
fn unpainted_head_names_the_missing_paint() {
    let mut app = app();
    let mut mesh = bevy_hair::procedural_head_mesh(3);
    let skin = vec![[0.8, 0.6, 0.5, 1.0]; mesh.count_vertices()];
    mesh.insert_attribute(Mesh::ATTRIBUTE_COLOR, skin);
    let mesh = app.world_mut().resource_mut::<Assets<Mesh>>().add(mesh);
    let head = app.world_mut().spawn((Mesh3d(mesh), groom())).id();
    let (reason, messages) = failure(&mut app, head);
    println!("{reason}");
    assert_eq!(reason, HairErrorKind::NoScalp(ScalpSource::VertexColor { threshold: 0.5 }));
    assert!(reason.to_string().contains("COLOR_0"), "{reason}");
    assert_eq!(messages, [reason]);
    assert!(app.world().get::<HairState>(head).is_none());
    run(&mut app, 5); // keeps running, stays inert
    assert!(app.world().get::<HairState>(head).is_none());
}

#[test]
fn mesh_without_colours_or_triangles_is_reported() {
    let mut app = app();
    let no_colours = bevy_hair::procedural_head_mesh(2).with_removed_attribute(Mesh::ATTRIBUTE_COLOR);
    let empty = Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::default())
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, Vec::<[f32; 3]>::new())
        .with_inserted_indices(Indices::U32(vec![]));
    let flat = Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::default())
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
        .with_inserted_indices(Indices::U32(vec![0, 1, 2]));
    let expectations = [(no_colours, "no vertex colours"), (empty, "no triangles"), (flat, "zero area")];
    for (mesh, expected) in expectations {
        let mesh = app.world_mut().resource_mut::<Assets<Mesh>>().add(mesh);
        let head = app.world_mut().spawn((Mesh3d(mesh), groom())).id();
        let (reason, _) = failure(&mut app, head);
        println!("{reason:?}: {reason}");
        assert!(matches!(reason, HairErrorKind::ScalpLabels(_) | HairErrorKind::Mesh(_)), "{reason:?}");
        assert!(reason.to_string().contains(expected), "{reason:?} should mention {expected:?}");
    }
    let bare = app.world_mut().spawn(groom()).id();
    let (reason, _) = failure(&mut app, bare);
    assert_eq!(reason, HairErrorKind::NoMesh);
    assert!(reason.to_string().contains("no Mesh3d"), "{reason}");
}

#[test]
fn bad_groom_description_is_reported() {
    let mut app = app();
    let head = spawn_head(&mut app, HairGroom { length: f32::NAN, ..groom() }, Transform::default());
    let (reason, _) = failure(&mut app, head);
    assert!(matches!(reason, HairErrorKind::Groom { field: "length", .. }), "{reason:?}");
    assert!(reason.to_string().contains("length NaN"), "{reason}");
    // Fixing the description regrows the groom.
    app.world_mut().get_mut::<HairGroom>(head).unwrap().length = 0.2;
    wait_until_ready(&mut app, head);
    assert_eq!(state(&app, head).strands().strand_count(), 200);
    // A root jitter outside 0..=1 is named too.
    let vertices = |jitter| HairGroom { distribution: RootDistribution::Vertices { jitter }, ..groom() };
    let head = spawn_head(&mut app, vertices(f32::NAN), Transform::default());
    let (reason, _) = failure(&mut app, head);
    assert!(matches!(reason, HairErrorKind::Groom { field: "distribution", .. }), "{reason:?}");
    assert!(reason.to_string().contains("root jitter NaN"), "{reason}");
    app.world_mut().get_mut::<HairGroom>(head).unwrap().distribution = RootDistribution::Vertices { jitter: 0.5 };
    wait_until_ready(&mut app, head);
    assert_eq!(state(&app, head).strands().strand_count(), 200);
}

#[test]
fn nan_settings_are_named_once_and_never_simulated() {
    let (mut app, head) = grown(groom());
    settings(&mut app, |p| {
        p.friction = f32::NAN;
        p.collision_thickness = -1.0;
        p.gravity = [0.0, f32::INFINITY, 0.0];
    });
    app.update();
    let reported = errors(&app);
    println!("{reported:?}");
    let [HairErrorKind::Settings(issues)] = reported.as_slice() else { panic!("one settings error: {reported:?}") };
    let fields: Vec<&str> = issues.iter().map(|i| i.field).collect();
    assert_eq!(fields, ["collision_thickness", "friction", "gravity.y"]);
    for field in fields {
        assert!(reported[0].to_string().contains(field), "{field} missing in {}", reported[0]);
    }
    run(&mut app, 60);
    assert!(errors(&app).is_empty(), "reported once, not every step");
    assert!(all_finite(&app, head));
    assert!(state(&app, head).strands().max_stretch() < 1e-3);
}

#[test]
fn a_head_wound_inside_out_is_turned_over_and_keeps_its_hair_outside() {
    let mut app = app();
    let mut mesh = bevy_hair::procedural_head_mesh(4);
    let Some(Indices::U32(indices)) = mesh.indices_mut() else { panic!("u32 indices") };
    indices.chunks_exact_mut(3).for_each(|t| t.swap(1, 2));
    // The mesh as given, for an inside test of its own (ray parity ignores the winding).
    let triangles = indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    let positions = mesh.attribute(Mesh::ATTRIBUTE_POSITION).unwrap().as_float3().unwrap();
    let given =
        HeadMesh { positions: positions.iter().map(|&p| SimVec3::from_array(p)).collect(), normals: vec![], triangles };
    let mesh = app.world_mut().resource_mut::<Assets<Mesh>>().add(mesh);
    let head = app.world_mut().spawn((Mesh3d(mesh), Transform::default(), groom())).id();
    wait_until_ready(&mut app, head);
    run(&mut app, 60);
    let state = state(&app, head);
    let n = state.particles_per_strand();
    let particles: Vec<Vec3> =
        state.current_positions().iter().enumerate().filter(|(i, _)| i % n != 0).map(|(_, p)| *p).collect();
    let inside = particles.iter().filter(|p| given.contains_by_ray_parity(SimVec3::from_array(p.to_array()))).count();
    println!("inside-out head: {inside} of {} particles inside after 1 s", particles.len());
    assert_eq!(inside, 0, "the collider took the inside for the outside");
    assert!(state.head_mesh().signed_volume() > 0.0, "the mesh the plugin uses is wound outward");
}
