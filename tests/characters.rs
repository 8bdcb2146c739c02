//! Headless ECS tests of hair on game characters: Bevy's entity lifecycle (grooms removed,
//! heads despawned, meshes replaced or modified in place), many characters side by side,
//! and heads that are skinned meshes.

mod common;

use bevy::math::Affine3A;
use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::mesh::{Indices, VertexAttributeValues};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_hair::hair_sim::math::Vec3 as SimVec3;
use bevy_hair::hair_sim::mesh::{HeadMesh, InsideTest};
use bevy_hair::prelude::*;
use bevy_hair::{ScalpJoint, procedural_head_mesh};
use common::*;
use std::f32::consts::TAU;
use std::time::Duration;

/// A groom that grows fast, for tests with several heads.
fn small_groom(seed: u64) -> HairGroom {
    HairGroom { guides: 96, segments: 8, length: 0.2, settle_steps: 30, seed, ..default() }
}

/// Updates until every head is simulating.
fn wait_all(app: &mut App, heads: &[Entity]) {
    for &head in heads {
        wait_until_ready(app, head);
    }
}

#[test]
fn removing_the_groom_removes_its_state() {
    let (mut app, head) = grown(small_groom(1));
    app.world_mut().entity_mut(head).remove::<HairGroom>();
    app.update();
    let entity = app.world().entity(head);
    assert!(!entity.contains::<HairState>(), "the strands outlived their groom");
    assert!(!entity.contains::<GroomStatus>());
    assert!(entity.contains::<Mesh3d>(), "the head itself stays");
    run(&mut app, 3); // nothing steps or panics without it
}

#[test]
fn a_head_despawned_while_growing_leaves_nothing() {
    let mut app = app();
    app.update();
    let before = app.world().entities().count_spawned();
    let head = spawn_head(&mut app, small_groom(2), Transform::default());
    app.update();
    assert_eq!(app.world().get::<GroomStatus>(head), Some(&GroomStatus::Growing));
    app.world_mut().entity_mut(head).despawn();
    run(&mut app, 5);
    assert_eq!(app.world().entities().count_spawned(), before, "an entity outlived its head");
}

#[test]
fn a_replaced_or_modified_mesh_regrows() {
    let (mut app, head) = grown(small_groom(3));
    let triangles = |app: &App| state(app, head).head_mesh().triangles.len();
    let coarse = triangles(&app);

    // A new mesh handle: a finer head.
    let finer = app.world_mut().resource_mut::<Assets<Mesh>>().add(procedural_head_mesh(5));
    app.world_mut().entity_mut(head).insert(Mesh3d(finer.clone()));
    app.update();
    assert!(app.world().get::<HairState>(head).is_none(), "the old strands are gone at once");
    wait_until_ready(&mut app, head);
    let fine = triangles(&app);
    println!("replaced mesh: {coarse} → {fine} triangles");
    assert!(fine > coarse);

    // The same handle, its asset changed in place (as a hot reload does): 20% larger.
    let top = |app: &App| state(app, head).head_mesh().positions.iter().map(|p| p.y).fold(f32::MIN, f32::max);
    let before = top(&app);
    {
        let mut meshes = app.world_mut().resource_mut::<Assets<Mesh>>();
        let mut mesh = meshes.get_mut(&finer).unwrap();
        let Some(VertexAttributeValues::Float32x3(positions)) = mesh.attribute_mut(Mesh::ATTRIBUTE_POSITION) else {
            panic!("the procedural head has float positions")
        };
        positions.iter_mut().for_each(|p| *p = p.map(|c| c * 1.2));
    }
    app.update();
    app.update();
    assert!(app.world().get::<HairState>(head).is_none(), "a modified mesh regrows");
    wait_until_ready(&mut app, head);
    let after = top(&app);
    println!("modified mesh: top of the head {before:.4} → {after:.4} m");
    assert!((after / before - 1.2).abs() < 1e-4);
}

/// Heads at `x` positions, one groom each, plus `collider` spawned by the caller's rule.
/// Returns every head's particle positions, head space, after `steps` steps.
fn two_heads(collider: impl FnOnce(&mut App, [Entity; 2])) -> Vec<Vec<Vec3>> {
    let mut app = app();
    let heads = [0.0, 1.0].map(|x| spawn_head(&mut app, small_groom(4), Transform::from_xyz(x, 0.0, 0.0)));
    collider(&mut app, heads);
    wait_all(&mut app, &heads);
    // The heads finish growing in different frames: start both from rest together.
    for head in heads {
        app.world_mut().get_mut::<HairState>(head).unwrap().reset();
    }
    run(&mut app, 60);
    heads.iter().map(|&h| state(&app, h).current_local_positions().to_vec()).collect()
}

/// A ball on the crown of the head at x = 1 m: 10 cm in radius, 19 cm above its centre (the
/// skull reaches 11 cm up), so it presses the hair on top of the head.
const BALL: HairCollider = HairCollider::Sphere { radius: 0.1 };
const ON_SECOND_CROWN: Vec3 = Vec3::new(1.0, 0.19, 0.0);

fn largest_difference(a: &[Vec3], b: &[Vec3]) -> f32 {
    a.iter().zip(b).map(|(p, q)| p.distance(*q)).fold(0.0, f32::max)
}

#[test]
fn a_character_s_collider_touches_only_its_own_hair() {
    let free = two_heads(|_, _| {});
    // Top-level: every groom collides with it.
    let global = two_heads(|app, _| {
        app.world_mut().spawn((BALL, Transform::from_translation(ON_SECOND_CROWN)));
    });
    // The same ball, placed at the same spot, but a child of the first head.
    let first_heads = two_heads(|app, [first, _]| {
        app.world_mut().spawn((BALL, Transform::from_translation(ON_SECOND_CROWN), ChildOf(first)));
    });
    // A child of the second head, inside its own hierarchy.
    let second_heads = two_heads(|app, [_, second]| {
        app.world_mut().spawn((BALL, Transform::from_translation(ON_SECOND_CROWN - Vec3::X), ChildOf(second)));
    });
    let moved = |run: &[Vec<Vec3>]| largest_difference(&run[1], &free[1]);
    println!(
        "second head's hair moved by a ball on its crown: global {:.1} mm, the first head's {:.1} mm, its own {:.1} mm",
        moved(&global) * 1e3,
        moved(&first_heads) * 1e3,
        moved(&second_heads) * 1e3
    );
    assert!(moved(&global) > 3e-3, "a global collider pushes every groom");
    assert_eq!(moved(&first_heads), 0.0, "another character's collider touched this hair");
    assert!(moved(&second_heads) > 3e-3, "a character's own collider pushes its hair");
    assert_eq!(largest_difference(&first_heads[0], &free[0]), 0.0, "the ball is far from the first head's hair");
}

#[test]
fn eight_characters_each_with_their_own_groom_settings_and_collider() {
    let mut app = app();
    let heads: Vec<Entity> = (0..8)
        .map(|i| {
            let x = i as f32 * 1.0;
            let groom = HairGroom { length: 0.12 + 0.02 * i as f32, ..small_groom(10 + i as u64) };
            let head = spawn_head(&mut app, groom, Transform::from_xyz(x, 0.0, 0.0));
            // Wind blows the even heads' hair toward +X, the odd heads' toward −X.
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            let wind = Wind { direction: [sign, 0.0, 0.0], strength: 12.0, gust_strength: 0.0, ..default() };
            let settings = SimParams { wind, ..default() };
            app.world_mut().entity_mut(head).insert(HairSettingsOverride(settings));
            // A shoulder ball of its own, below and behind the head.
            let shoulder = Transform::from_xyz(0.0, -0.25, -0.05);
            app.world_mut().spawn((HairCollider::Sphere { radius: 0.1 }, shoulder, ChildOf(head)));
            head
        })
        .collect();
    wait_all(&mut app, &heads);
    for &head in &heads {
        app.world_mut().get_mut::<HairState>(head).unwrap().reset();
    }
    run(&mut app, 120);
    for (i, &head) in heads.iter().enumerate() {
        let state = state(&app, head);
        let n = state.particles_per_strand();
        let local = state.current_local_positions();
        let tip_x = local.iter().skip(n - 1).step_by(n).map(|p| p.x).sum::<f32>() / state.roots().len() as f32;
        // Independent of the solver's collider: distance to the ball's centre in head space.
        let centre = Vec3::new(0.0, -0.25, -0.05);
        let deepest = local.iter().map(|p| 0.1 - p.distance(centre)).fold(f32::MIN, f32::max);
        let length = state.grown_from().length;
        println!("head {i}: length {length:.2} m, mean tip x {tip_x:+.3} m, deepest in its shoulder {deepest:+.4} m");
        assert_eq!(state.strands().rest().positions.len(), 96 * 9, "head {i}");
        assert!(tip_x * if i % 2 == 0 { 1.0 } else { -1.0 } > 0.01, "head {i}'s wind is its own");
        // Its own shoulder holds its hair: without it the longer grooms hang through the ball.
        assert!(deepest <= 1e-4, "head {i}: a particle is {deepest} m inside its shoulder");
        assert!(all_finite(&app, head));
    }
}

/// A character rigged as glTF rigs are: a root, a neck joint and a head joint, and the
/// procedural head as a skinned mesh under the root. Above `blend_top` (head-local y,
/// metres) vertices are weighted to the head joint alone; below, they blend into the neck
/// down to y = −0.08 m. The scalp starts at y = 0.035 m.
struct Rig {
    root: Entity,
    neck: Entity,
    head_joint: Entity,
    head: Entity,
    /// Bind-pose vertex positions and their (joint, weight) pairs, and the triangles.
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    weights: Vec<[(usize, f32); 2]>,
    inverse_binds: [Affine3A; 2],
}

const NECK_AT: Vec3 = Vec3::new(0.0, -0.15, 0.0);
const HEAD_JOINT_ABOVE_NECK: Vec3 = Vec3::new(0.0, 0.1, 0.0);

fn spawn_rig(app: &mut App, blend_top: f32) -> Rig {
    let mut mesh = procedural_head_mesh(4);
    let Some(VertexAttributeValues::Float32x3(positions)) = mesh.attribute(Mesh::ATTRIBUTE_POSITION) else {
        panic!("float positions")
    };
    let positions: Vec<Vec3> = positions.iter().map(|&p| Vec3::from_array(p)).collect();
    let Some(Indices::U32(indices)) = mesh.indices() else { panic!("u32 indices") };
    let triangles: Vec<[u32; 3]> = indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    let weights: Vec<[(usize, f32); 2]> = positions
        .iter()
        .map(|p| {
            let head = ((p.y + 0.08) / (blend_top + 0.08)).clamp(0.0, 1.0);
            [(1, head), (0, 1.0 - head)]
        })
        .collect();
    mesh.insert_attribute(
        Mesh::ATTRIBUTE_JOINT_INDEX,
        VertexAttributeValues::Uint16x4(weights.iter().map(|_| [1, 0, 0, 0]).collect()),
    );
    mesh.insert_attribute(
        Mesh::ATTRIBUTE_JOINT_WEIGHT,
        weights.iter().map(|w| [w[0].1, w[1].1, 0.0, 0.0]).collect::<Vec<_>>(),
    );
    // Joints' bind-pose globals (the root at the origin); the inverse bind matrices undo them.
    let neck_bind = Affine3A::from_translation(NECK_AT);
    let head_bind = neck_bind * Affine3A::from_translation(HEAD_JOINT_ABOVE_NECK);
    let inverse_binds = [neck_bind.inverse(), head_bind.inverse()];
    let world = app.world_mut();
    let mesh = world.resource_mut::<Assets<Mesh>>().add(mesh);
    let bindposes = world
        .resource_mut::<Assets<SkinnedMeshInverseBindposes>>()
        .add(SkinnedMeshInverseBindposes::from(inverse_binds.map(Mat4::from).to_vec()));
    let root = world.spawn(Transform::default()).id();
    let neck = world.spawn((Transform::from_translation(NECK_AT), ChildOf(root))).id();
    let head_joint = world.spawn((Transform::from_translation(HEAD_JOINT_ABOVE_NECK), ChildOf(neck))).id();
    let skin = SkinnedMesh { inverse_bindposes: bindposes, joints: vec![neck, head_joint] };
    let head = world.spawn((Mesh3d(mesh), skin, Transform::default(), ChildOf(root), small_groom(7))).id();
    Rig { root, neck, head_joint, head, positions, triangles, weights, inverse_binds }
}

impl Rig {
    /// Linear blend skinning of bind-pose point `v` with `weights`, from the joints'
    /// `GlobalTransform`s: what Bevy's skinning shader computes, written out here.
    fn skin(&self, app: &App, v: Vec3, weights: &[(usize, f32); 2]) -> Vec3 {
        let joints = [self.neck, self.head_joint];
        weights
            .iter()
            .map(|&(j, w)| {
                let joint = app.world().get::<GlobalTransform>(joints[j]).unwrap().affine();
                w * (joint * self.inverse_binds[j]).transform_point3(v)
            })
            .sum()
    }

    /// Moves the character: the root walks at 1 m/s, the neck nods, the head turns at
    /// 2 turns per second.
    fn animate(&self, app: &mut App, t: f32) {
        let mut set = |entity: Entity, change: &dyn Fn(&mut Transform)| {
            change(&mut app.world_mut().get_mut::<Transform>(entity).unwrap());
        };
        set(self.root, &|tr| tr.translation = Vec3::new(t, 0.0, 0.3 * t));
        set(self.neck, &|tr| tr.rotation = Quat::from_rotation_x(0.3 * (TAU * t).sin()));
        set(self.head_joint, &|tr| tr.rotation = Quat::from_rotation_y(2.0 * TAU * t));
    }
}

/// Plays the rig for 2 s at 30 fps; returns the scalp joint's share of the scalp, how far
/// the drawn roots got from the scalp skinned independently (joint matrices × inverse bind
/// matrices, corner by corner), and the deepest drawn particle inside the head as skinned
/// (ray parity and exact distance on the skinned triangles, `InsideTest`).
fn ride(blend_top: f32) -> (ScalpJoint, f32, f32) {
    ride_in(app(), blend_top, HairBackend::Cpu)
}

/// [`ride`] in `app` on `backend`; a groom the GPU steps is read back every frame (its
/// last step, the one the frame draws nearest: two 60 Hz steps per 30 fps frame).
fn ride_in(mut app: App, blend_top: f32, backend: HairBackend) -> (ScalpJoint, f32, f32) {
    let rig = spawn_rig(&mut app, blend_top);
    app.world_mut().entity_mut(rig.head).insert((backend, HairReadback));
    wait_until_ready(&mut app, rig.head);
    let on_gpu = backend == HairBackend::Gpu;
    if on_gpu {
        wait_until_on_gpu(&mut app, rig.head);
    }
    let joint = state(&app, rig.head).scalp_joint().expect("a skinned head follows a joint").clone();
    app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(1.0 / 30.0)));
    let (mut worst_root, mut deepest) = (0.0f32, 0.0f32);
    for frame in 0..60 {
        rig.animate(&mut app, frame as f32 / 30.0);
        app.update();
        let fraction = app.world().resource::<Time<Hair>>().overstep_fraction();
        if on_gpu {
            wait_for_gpu(&mut app, rig.head);
            assert_eq!(state(&app, rig.head).gpu_lag(), Some(0));
            assert_eq!(state(&app, rig.head).gpu_fallback(), None);
        }
        let state = state(&app, rig.head);
        let n = state.particles_per_strand();
        let drawn: Vec<Vec3> = state.interpolated_positions(fraction).collect();
        let mesh = state.head_mesh();
        for (root, strand) in state.roots().iter().zip(drawn.chunks_exact(n)) {
            // The root's triangle, skinned corner by corner, at its barycentric point.
            let corners = mesh.triangles[root.triangle as usize];
            let skinned: Vec3 = corners
                .iter()
                .zip(root.barycentric)
                .map(|(&v, b)| b * rig.skin(&app, rig.positions[v as usize], &rig.weights[v as usize]))
                .sum();
            worst_root = worst_root.max(strand[0].distance(skinned));
        }
        // Penetration of the drawn strands into the head as it is skinned now.
        let sim = |p: Vec3| SimVec3::from_array(p.to_array());
        let skinned = HeadMesh {
            positions: rig.positions.iter().zip(&rig.weights).map(|(&p, w)| sim(rig.skin(&app, p, w))).collect(),
            normals: vec![SimVec3::Y; rig.positions.len()],
            triangles: rig.triangles.clone(),
        };
        let inside = InsideTest::new(&skinned);
        for (i, p) in drawn.iter().enumerate().filter(|(i, _)| i % n != 0) {
            assert!(p.is_finite(), "particle {i}");
            if let Some(depth) = inside.depth(sim(*p)) {
                deepest = deepest.max(depth);
            }
        }
    }
    (joint, worst_root, deepest)
}

#[test]
fn hair_on_a_skinned_head_rides_the_skin() {
    // Scalp and skull on the head joint alone: the roots move rigidly with it.
    let (joint, worst_root, deepest) = ride(-0.02);
    println!(
        "skinned head, scalp on the head joint: roots within {:.4} mm of the skinned scalp, deepest particle {:.2} mm",
        worst_root * 1e3,
        deepest * 1e3
    );
    assert_eq!(joint.share, 1.0, "the head joint carries the whole scalp");
    assert!(worst_root <= 2e-4, "a drawn root is {} mm off the skinned scalp", worst_root * 1e3);
    assert!(deepest <= 1e-4, "a particle is {} mm inside the skinned head", deepest * 1e3);

    // The neck blend reaching 4.5 cm into the scalp: the strands follow the head joint, the
    // roots their skinned triangles (following the joint rigidly they were 41 mm off).
    // The skin blended away from the head joint is collided with as it is drawn.
    ride_blended_into_the_neck(app(), HairBackend::Cpu, 1e-4);
}

/// [`ride_in`] with the scalp blended 4.5 cm into the neck: the roots stay on the skinned
/// scalp, and no particle goes deeper than `deepest_allowed` into the skinned head.
fn ride_blended_into_the_neck(app: App, backend: HairBackend, deepest_allowed: f32) {
    let (joint, worst_root, deepest) = ride_in(app, 0.08, backend);
    println!(
        "skinned head on {backend:?}, scalp blended into the neck ({:.1}% on the head joint): roots within {:.4} mm, deepest {:.2} mm",
        joint.share * 100.0,
        worst_root * 1e3,
        deepest * 1e3
    );
    assert!(joint.share < 0.95);
    assert!(worst_root <= 2e-4, "a drawn root is {} mm off the blended skinned scalp", worst_root * 1e3);
    assert!(deepest <= deepest_allowed, "a particle is {} mm inside the blended skinned head", deepest * 1e3);
}

#[test]
fn hair_on_a_skinned_head_rides_the_skin_on_the_gpu() {
    // Every root moves against the head joint each frame, all of them in one upload to the
    // GPU, which collides with the head's distance grid and the moving skin's patch.
    let Some(app) = app_on_a_gpu() else { return };
    ride_blended_into_the_neck(app, HairBackend::Gpu, 5e-4);
}

/// Spawns a skinned procedural head with one joint; `weights` adds joint attributes.
/// Returns the head and the joint.
fn spawn_skinned(app: &mut App, weights: Option<[f32; 4]>) -> (Entity, Entity) {
    let mut mesh = procedural_head_mesh(3);
    if let Some(weights) = weights {
        let count = mesh.count_vertices();
        mesh.insert_attribute(Mesh::ATTRIBUTE_JOINT_INDEX, VertexAttributeValues::Uint16x4(vec![[0; 4]; count]));
        mesh.insert_attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT, vec![weights; count]);
    }
    let world = app.world_mut();
    let mesh = world.resource_mut::<Assets<Mesh>>().add(mesh);
    let bindposes = SkinnedMeshInverseBindposes::from(vec![Mat4::IDENTITY]);
    let bindposes = world.resource_mut::<Assets<SkinnedMeshInverseBindposes>>().add(bindposes);
    let joint = world.spawn(Transform::default()).id();
    let skin = SkinnedMesh { inverse_bindposes: bindposes, joints: vec![joint] };
    (world.spawn((Mesh3d(mesh), skin, small_groom(8))).id(), joint)
}

#[test]
fn skins_the_hair_cannot_follow_are_reported() {
    let mut app = app();
    let (unweighted, _) = spawn_skinned(&mut app, Some([0.0; 4]));
    let (without_joints, _) = spawn_skinned(&mut app, None);
    let (joint_gone, joint) = spawn_skinned(&mut app, Some([1.0, 0.0, 0.0, 0.0]));
    app.world_mut().entity_mut(joint).despawn();
    run(&mut app, 3);
    let cases = [(unweighted, "joint weight"), (without_joints, "JOINTS_0"), (joint_gone, "no GlobalTransform")];
    for (head, expected) in cases {
        match app.world().get::<GroomStatus>(head) {
            Some(GroomStatus::Failed(reason)) => {
                println!("{reason}");
                assert!(matches!(reason, HairErrorKind::Skin(_)), "{reason:?}");
                assert!(reason.to_string().contains(expected), "{reason}");
            }
            other => panic!("expected a failure, got {other:?}"),
        }
    }
}
