//! The shipped character, as a game loads it: `assets/head.glb` through Bevy's glTF loader
//! (a `neck` → `head` skeleton, the skinned head, its clip), the clip played by the
//! `AnimationPlayer` the loader made, and a groom on the skinned mesh. Everything the
//! plugin does is checked against the skin computed here from the loaded assets alone:
//! joint `GlobalTransform`s × inverse bind matrices, blended by the mesh's own weights.

mod common;
#[path = "common/glb.rs"]
mod glb;

use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::mesh::{Indices, VertexAttributeValues};
use bevy::prelude::*;
use bevy::world_serialization::WorldAssetRoot;
use bevy_hair::hair_sim::math::Vec3 as SimVec3;
use bevy_hair::hair_sim::mesh::{HeadMesh, InsideTest};
use bevy_hair::prelude::*;
use common::wait_until_ready;
use std::time::{Duration, Instant};

/// Frames per second the clip is played at: not the hair's step rate.
const FPS: f64 = 30.0;

/// The skin as the loaded assets define it: bind-pose positions, per-vertex joint indices
/// and weights, the joints and their inverse bind matrices.
struct Skin {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    influences: Vec<[(usize, f32); 4]>,
    joints: Vec<Entity>,
    inverse_binds: Vec<Mat4>,
}

impl Skin {
    fn of(app: &App, head: Entity) -> Skin {
        let world = app.world();
        let mesh = world.resource::<Assets<Mesh>>().get(&world.get::<Mesh3d>(head).unwrap().0).unwrap();
        let skinned = world.get::<SkinnedMesh>(head).unwrap();
        let inverse_binds =
            world.resource::<Assets<SkinnedMeshInverseBindposes>>().get(&skinned.inverse_bindposes).unwrap().to_vec();
        let Some(VertexAttributeValues::Float32x3(positions)) = mesh.attribute(Mesh::ATTRIBUTE_POSITION) else {
            panic!("float positions")
        };
        let Some(VertexAttributeValues::Uint16x4(ids)) = mesh.attribute(Mesh::ATTRIBUTE_JOINT_INDEX) else {
            panic!("u16 joint indices")
        };
        let Some(VertexAttributeValues::Float32x4(weights)) = mesh.attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT) else {
            panic!("float joint weights")
        };
        let Some(Indices::U16(indices)) = mesh.indices() else { panic!("u16 indices") };
        Skin {
            positions: positions.iter().map(|&p| Vec3::from_array(p)).collect(),
            triangles: indices.chunks_exact(3).map(|t| [t[0] as u32, t[1] as u32, t[2] as u32]).collect(),
            influences: ids.iter().zip(weights).map(|(i, w)| std::array::from_fn(|k| (i[k] as usize, w[k]))).collect(),
            joints: skinned.joints.clone(),
            inverse_binds,
        }
    }

    /// The weight of the `head` joint (the skin's second) at vertex `v`.
    fn head_weight(&self, v: usize) -> f32 {
        self.influences[v].iter().filter(|(j, _)| *j == 1).map(|(_, w)| w).sum()
    }

    /// Every vertex skinned with the joints' `GlobalTransform`s now.
    fn skinned(&self, app: &App) -> Vec<Vec3> {
        let matrices: Vec<Mat4> = self
            .joints
            .iter()
            .zip(&self.inverse_binds)
            .map(|(&j, inverse_bind)| app.world().get::<GlobalTransform>(j).unwrap().to_matrix() * *inverse_bind)
            .collect();
        self.positions
            .iter()
            .zip(&self.influences)
            .map(|(&p, influences)| influences.iter().map(|&(j, w)| w * matrices[j].transform_point3(p)).sum())
            .collect()
    }
}

#[test]
fn hair_on_the_shipped_character_follows_its_clip() {
    let mut app = glb::gltf_app(Duration::from_secs_f64(1.0 / FPS));
    let (scene, clip) = {
        let assets = app.world().resource::<AssetServer>();
        (
            assets.load(GltfAssetLabel::Scene(0).from_asset("head.glb")),
            assets.load::<AnimationClip>(GltfAssetLabel::Animation(0).from_asset("head.glb")),
        )
    };
    let character = app.world_mut().spawn(WorldAssetRoot(scene)).id();

    // The loader's entities: the skinned mesh and the player.
    let start = Instant::now();
    let head = loop {
        app.update();
        let mut skinned = app.world_mut().query_filtered::<Entity, With<SkinnedMesh>>();
        if let Some(head) = skinned.iter(app.world()).next() {
            break head;
        }
        if start.elapsed() > Duration::from_secs(60) {
            let assets = app.world().resource::<AssetServer>();
            let id = app.world().get::<WorldAssetRoot>(character).unwrap().id();
            panic!("head.glb did not load: {:?}", assets.get_load_state(id));
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let player = app.world_mut().query_filtered::<Entity, With<AnimationPlayer>>().single(app.world()).unwrap();
    let mut ancestors = app.world_mut().query::<&ChildOf>();
    let mut top = head;
    while let Ok(parent) = ancestors.get(app.world(), top) {
        top = parent.parent();
    }
    assert_eq!(top, character, "the mesh is inside the character's scene");

    app.world_mut().entity_mut(head).insert(HairGroom {
        guides: 200,
        segments: 10,
        length: 0.2,
        settle_steps: 120,
        ..default()
    });
    wait_until_ready(&mut app, head);
    let skin = Skin::of(&app, head);
    let state = app.world().get::<HairState>(head).unwrap();
    let joint = state.scalp_joint().expect("the head follows a joint").clone();
    assert_eq!(joint.share, 1.0, "the scalp is weighted to the head joint alone");
    assert_eq!(app.world().get::<Name>(joint.joint).map(Name::as_str), Some("head"));

    // Play the clip from its start, as the demo does.
    let (graph, node) = AnimationGraph::from_clip(clip.clone());
    let graph = app.world_mut().resource_mut::<Assets<AnimationGraph>>().add(graph);
    app.world_mut().entity_mut(player).insert(AnimationGraphHandle(graph));
    app.world_mut().get_mut::<AnimationPlayer>(player).unwrap().play(node);
    let duration = app.world().resource::<Assets<AnimationClip>>().get(&clip).unwrap().duration();
    assert!((8.0..10.0).contains(&duration), "the clip lasts {duration} s");

    let frames = (duration as f64 * FPS).ceil() as usize;
    let (mut worst_root, mut checked) = (0.0f32, 0usize);
    // (particle-frames inside, deepest) where the skin moves with the head joint alone, and
    // where it blends toward the neck joint.
    let (mut skull, mut neck) = ((0usize, 0.0f32), (0usize, 0.0f32));
    let mut largest_turn = 0.0f32;
    let rest_head = app.world().get::<GlobalTransform>(joint.joint).unwrap().rotation();
    for frame in 0..frames {
        app.update();
        let state = app.world().get::<HairState>(head).unwrap();
        let n = state.particles_per_strand();
        let fraction = app.world().resource::<Time<Hair>>().overstep_fraction();
        let drawn: Vec<Vec3> = state.interpolated_positions(fraction).collect();
        let skinned = skin.skinned(&app);
        largest_turn = largest_turn
            .max(app.world().get::<GlobalTransform>(joint.joint).unwrap().rotation().angle_between(rest_head));

        // Roots: each on its triangle of the skinned mesh, at its barycentric point.
        for (root, strand) in state.roots().iter().zip(drawn.chunks_exact(n)) {
            let corners = state.head_mesh().triangles[root.triangle as usize];
            let on_skin: Vec3 = corners.iter().zip(root.barycentric).map(|(&v, b)| b * skinned[v as usize]).sum();
            worst_root = worst_root.max(strand[0].distance(on_skin));
        }

        // No particle inside the skinned head: ray parity on the skinned triangles, the depth
        // by the exact distance to them (`InsideTest`, which shares nothing with the
        // collider). Every third frame (the test's own cost).
        if frame % 3 == 0 {
            let mesh = HeadMesh {
                positions: skinned.iter().map(|p| SimVec3::from_array(p.to_array())).collect(),
                normals: vec![SimVec3::Y; skinned.len()],
                triangles: skin.triangles.clone(),
            };
            let inside = InsideTest::new(&mesh);
            for (i, p) in drawn.iter().enumerate().filter(|(i, _)| i % n != 0) {
                assert!(p.is_finite(), "particle {i} at frame {frame}");
                checked += 1;
                let p = SimVec3::from_array(p.to_array());
                if !inside.contains(p) {
                    continue;
                }
                let (triangle, depth) = inside.nearest_triangle(p);
                // Where the skin blends toward the neck joint, the collider (the bind-pose
                // head carried rigidly by the scalp joint) is not where the skin is drawn.
                let rigid = skin.triangles[triangle].iter().all(|&v| skin.head_weight(v as usize) == 1.0);
                let region = if rigid { &mut skull } else { &mut neck };
                region.0 += 1;
                region.1 = region.1.max(depth);
            }
        }
    }
    println!(
        "head.glb, its clip at {FPS} fps ({frames} frames, head turned up to {:.0}°): drawn roots within {:.4} mm of \
         the skinned scalp; of {checked} particle-frames, {} inside the skinned skull (deepest {:.3} mm) and {} \
         inside the blended neck (deepest {:.3} mm)",
        largest_turn.to_degrees(),
        worst_root * 1e3,
        skull.0,
        skull.1 * 1e3,
        neck.0,
        neck.1 * 1e3
    );
    assert!(largest_turn.to_degrees() > 60.0, "the clip turned the head only {}°", largest_turn.to_degrees());
    assert!(worst_root <= 2e-4, "a drawn root is {} mm off the skinned scalp", worst_root * 1e3);
    assert!(skull.1 <= 1e-4, "a particle is {} mm inside the skinned skull", skull.1 * 1e3);
    // Where the neck blends away from the scalp joint, the skin is collided with as drawn.
    assert!(neck.1 <= 1e-4, "a particle is {} mm inside the skinned neck", neck.1 * 1e3);
}

/// The head primitive of `head.glb` loaded as a user loads a mesh
/// (`GltfAssetLabel::Primitive`), standing still, with the default groom at 600 guides,
/// combed and not, at the default 2 substeps and at 8: after 4 s at 60 fps, over the next
/// second, no particle moves more than 10 µm in a frame, none goes back to where it was two
/// frames before, and every strand is asleep. (`crates/hair_sim/tests/rest.rs` runs the same
/// groom at 1, 2 and 8 substeps, friction on and off, on both length models.)
#[test]
fn hair_on_the_still_shipped_head_is_still() {
    let back = Vec3::new(0.0, 0.0, -1.5);
    for (comb, substeps) in [(Vec3::ZERO, 2), (back, 2), (back, 8)] {
        let mut app = glb::gltf_app(common::FRAME);
        let mesh = app
            .world()
            .resource::<AssetServer>()
            .load::<Mesh>(GltfAssetLabel::Primitive { mesh: 0, primitive: 0 }.from_asset("head.glb"));
        let params = SimParams { substeps, ..default() };
        let groom = HairGroom { guides: 600, comb, ..default() };
        let head =
            app.world_mut().spawn((Mesh3d(mesh), Transform::default(), groom, HairSettingsOverride(params))).id();
        wait_until_ready(&mut app, head);
        for _ in 0..240 {
            app.update();
        }
        let n = app.world().get::<HairState>(head).unwrap().particles_per_strand();
        let positions = |app: &App| app.world().get::<HairState>(head).unwrap().current_positions().to_vec();
        let (mut before, mut earlier) = (positions(&app), None::<Vec<Vec3>>);
        let (mut largest, mut alternating) = (0.0f32, 0usize);
        let mut moving = vec![false; before.len() / n];
        for _ in 0..60 {
            app.update();
            let now = positions(&app);
            for (i, (x, b)) in now.iter().zip(&before).enumerate() {
                let moved = x.distance(*b);
                largest = largest.max(moved);
                moving[i / n] |= moved > 1e-5;
                if let Some(earlier) = &earlier {
                    alternating += usize::from(moved > 1e-6 && x.distance(earlier[i]) < 0.25 * moved);
                }
            }
            earlier = Some(std::mem::replace(&mut before, now));
        }
        let moving = moving.iter().filter(|&&m| m).count();
        let asleep = app.world().get::<HairState>(head).unwrap().last_report().sleeping;
        println!(
            "head.glb's head, still, comb {comb}, {substeps} substeps: largest move {:.2} µm in a frame, \
             {moving} strands moving more than 10 µm, {alternating} particle-frames alternating; {asleep} of \
             {} strands asleep",
            largest * 1e6,
            before.len() / n
        );
        let case = format!("comb {comb}, {substeps} substeps");
        assert!(largest <= 1e-5 && alternating == 0 && moving == 0, "{case}: {largest} m, {moving} strands moving");
        assert_eq!(asleep as usize, before.len() / n, "{case}: strands awake");
    }
}

/// The code block under README's "The code" is the file the next test runs.
#[test]
fn the_readme_shows_the_code_this_file_runs() {
    let readme = include_str!("../README.md");
    let block = readme
        .split_once("## The code")
        .and_then(|(_, after)| after.split_once("```rust\n"))
        .and_then(|(_, code)| code.split_once("```"))
        .map(|(code, _)| code)
        .expect("README.md has a rust block under \"## The code\"");
    assert_eq!(block, include_str!("common/readme_code.rs"), "README's code and tests/common/readme_code.rs differ");
}

/// README's code as a user runs it, on a `.glb` head painted as the README says (the
/// shipped head, copied as `my_head.glb`): hair grows on the paint and stays out of the
/// head ([`glb::readme_code_on`]).
#[test]
fn the_readme_code_grows_hair_on_a_painted_glb_head() {
    let grown = glb::readme_code_on(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/head.glb"));
    println!(
        "README's code: {} strands, {} roots off the paint, deepest particle {:.3} mm inside",
        grown.strands,
        grown.off_paint,
        grown.deepest.max(0.0) * 1e3
    );
    assert!(grown.strands > 0, "no hair grew");
    assert!(grown.reports.is_empty(), "{:?}", grown.reports);
    assert_eq!(grown.off_paint, 0, "roots off the painted scalp");
    assert!(grown.deepest <= 1e-4, "a particle is {} mm inside the head", grown.deepest * 1e3);
}
