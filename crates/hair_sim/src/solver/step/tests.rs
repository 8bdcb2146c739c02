use super::contacts::{self, with_friction};
use super::shape::{bend, clamp_lengths, follow_the_leader};
use super::*;
use crate::collide::{ContactHint, HeadCollider, Resolution};
use crate::mesh::HeadMesh;
use crate::solver::Strands;

/// A group holding one strand at `xs`, with rest shape `rest_positions`.
fn one(rest_positions: Vec<Vec3>, xs: &[Vec3]) -> GroupState<Baseline> {
    let mut strands = strands_at(RestShape::new(rest_positions, xs.len()).unwrap(), xs);
    let chunks = strands.chunks_mut(1);
    let mut g = GroupState::new(xs.len(), false, false);
    g.load(&[0], 0, chunks[0].rest, &chunks[0].state, false);
    g
}

/// Strands of rest shape `rest` whose particles are at `xs`.
fn strands_at(rest: RestShape, xs: &[Vec3]) -> Strands {
    let mut strands = Strands::new(rest, Pose::IDENTITY);
    strands.set_positions(xs).unwrap();
    strands
}

fn lane0(values: &[V3<Baseline>]) -> Vec<Vec3> {
    values.iter().map(|v| v.lane(0)).collect()
}

/// A straight strand hanging 1 m per segment.
fn hanging(n: usize) -> Vec<Vec3> {
    (0..n).map(|j| Vec3::new(0.0, -(j as f32), 0.0)).collect()
}

#[test]
fn ftl_restores_rest_lengths_and_records_corrections() {
    let mut g = one(hanging(3), &[Vec3::ZERO, Vec3::new(0.0, -2.0, 0.0), Vec3::new(0.0, -2.5, 0.0)]);
    follow_the_leader(&mut g);
    let xs = lane0(&g.positions);
    assert_eq!(xs[1], Vec3::new(0.0, -1.0, 0.0));
    assert_eq!(xs[2], Vec3::new(0.0, -2.0, 0.0));
    let corr = lane0(&g.ftl_correction);
    assert_eq!(corr[1], Vec3::new(0.0, 1.0, 0.0));
    assert_eq!(corr[2], Vec3::new(0.0, 0.5, 0.0));
}

#[test]
fn clamp_keeps_lengths_within_tolerance() {
    let mut g = one(hanging(3), &[Vec3::ZERO, Vec3::new(0.0, -1.5, 0.0), Vec3::new(0.0, -1.55, 0.0)]);
    clamp_lengths(&mut g, 0.1);
    let xs = lane0(&g.positions);
    assert!((xs[1].y + 1.1).abs() < 1e-6);
    assert!(((xs[2] - xs[1]).length() - 0.9).abs() < 1e-6);
    let mut within = one(hanging(3), &[Vec3::ZERO, Vec3::new(0.0, -1.05, 0.0), Vec3::new(0.0, -2.0, 0.0)]);
    clamp_lengths(&mut within, 0.1);
    assert_eq!(within.positions[1].lane(0).y, -1.05, "inside the tolerance nothing moves");
}

#[test]
fn local_shape_keeps_the_bend_relative_to_the_parent() {
    // Rest: an L (down, then +X).
    let l_shape = vec![Vec3::ZERO, Vec3::NEG_Y, Vec3::new(1.0, -1.0, 0.0)];
    let rest_frame = RestShape::new(l_shape.clone(), 3).unwrap().root_frames[0];
    // The head turned 90° about Z: the root frame turns, and full-stiffness local shape
    // must carry the bend along the strand, not just the first segment. Each pass takes
    // each joint all the way, and the reaction at the second joint turns the first
    // segment back a little: the passes converge on the turned L.
    let turn = Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
    let mut g = one(l_shape.clone(), &[Vec3::ZERO, Vec3::new(0.3, -0.2, 0.0), Vec3::new(5.0, 5.0, 0.0)]);
    for _ in 0..40 {
        local_shape(&mut g, 1.0, M3::splat(Mat3A::from_quat(turn * rest_frame)));
    }
    let xs = lane0(&g.positions);
    let first = xs[1].normalize();
    assert!((first - turn * Vec3::NEG_Y).length() < 1e-5, "first {first:?}");
    let second = (xs[2] - xs[1]).normalize();
    assert!((second - turn * Vec3::X).length() < 1e-5, "second segment {second:?}");
    // Half stiffness from a strand bent at the root: the child follows the parent's
    // actual direction, so the L stays an L (angle between segments stays 90°).
    let mut bent = one(l_shape, &[Vec3::ZERO, Vec3::new(1.0, -1.0, 0.0).normalize(), Vec3::new(9.0, 0.0, 0.0)]);
    for _ in 0..60 {
        local_shape(&mut bent, 0.5, M3::splat(Mat3A::from_quat(rest_frame)));
    }
    let xs = lane0(&bent.positions);
    let (a, b) = ((xs[1] - xs[0]).normalize(), (xs[2] - xs[1]).normalize());
    assert!(a.dot(b).abs() < 1e-3, "right angle kept: {}", a.dot(b));
}

/// A bend is internal: the three particles it moves keep their centre and their angular
/// momentum about the joint (the reaction). The follower pull it replaces moved the
/// child alone.
#[test]
fn a_bend_keeps_the_centre_and_the_spin_of_the_particles_it_moves() {
    let rest = vec![Vec3::ZERO, Vec3::NEG_Y, Vec3::new(0.0, -2.0, 0.0), Vec3::new(0.0, -3.0, 0.0)];
    let bent = [Vec3::ZERO, Vec3::NEG_Y, Vec3::new(0.1, -1.995, 0.0), Vec3::new(0.3, -2.97, 0.05)];
    let g = one(rest, &bent);
    let turn = V3::splat(Vec3::new(-0.02, 0.001, -0.01));
    let [a, b, c] = bend(&g, 3, turn).map(|m| m.lane(0));
    assert!((a + b + c).length() < 1e-7, "centre moved {:?}", a + b + c);
    // Angular momentum of the moves about the middle particle (equal masses).
    let middle = bent[2];
    let spin = (bent[1] - middle).cross(a) + (bent[3] - middle).cross(c);
    // Only a twist about the parent segment is left (a chain of points has no twist).
    let axis = (bent[2] - bent[1]).normalize();
    let bend_spin = spin - axis * spin.dot(axis);
    assert!(bend_spin.length() < 1e-7, "the bend spins the joint: {bend_spin:?}");
    assert!(c.length() > 0.1 * 0.02, "the child moves: {c:?}");
    // Next to the root the root takes the reaction: the grandparent does not move.
    let [root, _, _] = bend(&g, 2, turn).map(|m| m.lane(0));
    assert_eq!(root, Vec3::ZERO);
}

#[test]
fn empty_lanes_repeat_the_first_strand_and_are_not_stored() {
    let n = 3;
    let rest = RestShape::new([hanging(n), hanging(n)].concat(), n).unwrap();
    let doubled: Vec<Vec3> = rest.positions.iter().map(|p| *p * 2.0).collect();
    let mut strands = strands_at(rest.clone(), &doubled);
    let mut chunks = strands.chunks_mut(2);
    let (rest, state) = (chunks[0].rest, &mut chunks[0].state);
    let mut g = GroupState::<Baseline>::new(n, false, false);
    g.load(&[1], 0, rest, state, false);
    assert_eq!((g.lanes, g.strands), (1, [1; MAX_LANES]));
    assert!((0..Wide::<Baseline>::LANES).all(|l| g.positions[2].lane(l) == Vec3::new(0.0, -4.0, 0.0)));
    follow_the_leader(&mut g);
    g.store(state, false);
    assert_eq!(state.positions[n + 2], Vec3::new(0.0, -2.0, 0.0), "strand 1 restored to rest length");
    assert_eq!(state.positions[2], Vec3::new(0.0, -4.0, 0.0), "strand 0 was not in the group");
}

#[test]
fn friction_takes_back_tangential_slide_only() {
    let contact = Contact { position: Vec3::new(1.0, 0.0, 0.0), normal: Vec3::Y, depth: 0.1 };
    let start = Vec3::new(0.0, -0.5, 0.0);
    assert_eq!(with_friction(contact, start, 0.0), contact.position);
    let full = with_friction(contact, start, 1.0);
    assert!((full - Vec3::new(0.0, 0.0, 0.0)).length() < 1e-6, "{full:?}");
}

/// A closed block, 4 cm wide, whose top is a valley along z: two faces rising steeply
/// (2 in 1) from y = 5 cm at x = 0 to y = 9 cm at x = ±2 cm.
fn valley() -> HeadCollider {
    let positions = vec![
        Vec3::new(-0.02, -0.1, -0.1),
        Vec3::new(0.02, -0.1, -0.1),
        Vec3::new(0.02, -0.1, 0.1),
        Vec3::new(-0.02, -0.1, 0.1),
        Vec3::new(-0.02, 0.09, -0.1),
        Vec3::new(0.0, 0.05, -0.1),
        Vec3::new(0.02, 0.09, -0.1),
        Vec3::new(-0.02, 0.09, 0.1),
        Vec3::new(0.0, 0.05, 0.1),
        Vec3::new(0.02, 0.09, 0.1),
    ];
    let triangles = vec![
        [0, 1, 2],
        [0, 2, 3], // bottom
        [4, 7, 8],
        [4, 8, 5],
        [5, 8, 9],
        [5, 9, 6], // the valley's two faces
        [0, 5, 1],
        [0, 4, 5],
        [1, 5, 6], // back
        [3, 2, 8],
        [3, 8, 7],
        [2, 9, 8], // front
        [0, 3, 7],
        [0, 7, 4],
        [1, 6, 9],
        [1, 9, 2], // sides
    ];
    let (mesh, _) = HeadMesh::repaired(positions, triangles).expect("a block");
    HeadCollider::new(&mesh, 32).expect("closed")
}

/// The distance of `p` above the valley's nearer face, measured on the planes themselves.
fn above_valley(p: Vec3) -> f32 {
    // Each face's plane: y = 0.05 ∓ 2 x, unit normals (±2, 1) / √5.
    let left = (p.y - 0.05 + 2.0 * p.x) / 5f32.sqrt();
    let right = (p.y - 0.05 - 2.0 * p.x) / 5f32.sqrt();
    left.min(right)
}

#[test]
fn a_contact_in_a_crease_leaves_the_particle_outside_both_shells() {
    let collider = valley();
    let thickness = 0.003;
    let mut worst_single = 0.0f32;
    for k in 0..20 {
        // Just above the valley's floor, off to one side or the other.
        let p = Vec3::new(-0.001 + 0.0001 * k as f32, 0.0515, 0.0);
        let mut hint = ContactHint::NONE;
        let Resolution::Contact(single) = contacts::head_contact(&collider, p, thickness, None, &mut hint) else {
            panic!("{p} is in the shell")
        };
        let mut hint = ContactHint::NONE;
        let Resolution::Contact(settled) = contacts::crease_contact(&collider, p, thickness, None, &mut hint) else {
            panic!("{p} is in the shell")
        };
        worst_single = worst_single.max(thickness - above_valley(single.position));
        // On (or outside) both shells, to a micrometre; the depth as measured.
        let left = thickness - above_valley(settled.position);
        assert!(left <= 1e-6, "{p}: {left} m inside the shell");
        assert_eq!(settled.depth, single.depth, "the depth is how far it had gone in");
    }
    // One projection alone leaves it well inside the other face's shell.
    println!("one projection leaves a particle in the crease up to {:.3} mm inside the shell", worst_single * 1e3);
    assert!(worst_single > 0.5e-3, "one projection left it {worst_single} m inside");
}

/// Substeps are counted per 1/60 s: the same substep length at any step, none longer than
/// asked, at least one, and a step of 1/60 s (not exact in binary, nor as the hair clock's
/// nanoseconds) takes exactly the count asked.
#[test]
fn substeps_keep_their_length_at_any_step() {
    let clock_sixtieth = std::time::Duration::from_nanos(16_666_667).as_secs_f32();
    for (per_sixtieth, dt, expected) in [
        (2, 1.0 / 60.0, 2),
        (2, clock_sixtieth, 2),
        (1, 1.0 / 60.0, 1),
        (2, 1.0 / 30.0, 4),
        (2, 1.0 / 120.0, 1),
        (3, 1.0 / 120.0, 2),
        (8, 1.0 / 144.0, 4),
        (0, 1.0 / 30.0, 2),
        (2, 1e-6, 1),
        (64, MAX_STEP, 256),
    ] {
        let substeps = substeps_of(per_sixtieth, dt);
        assert_eq!(substeps, expected, "{per_sixtieth} per 1/60 s, a step of {dt} s");
        assert!(dt / substeps as f32 <= 1.0001 / (60.0 * per_sixtieth.max(1) as f32), "longer than asked");
    }
}

/// Where the whole half of space around a deep contact's normal is inside the collider (a
/// contact on the far side of a cheek from the parent), the final length pass finds a
/// direction at full length over the sphere before it puts the particle onto the surface,
/// shortening the segment; it does that only where every direction is inside.
#[test]
fn the_final_length_pass_looks_over_the_sphere_before_shortening_a_segment() {
    let (parent, length, thickness) = (Vec3::ZERO, 0.02, 0.003);
    // Inside: all beyond the plane x = `plane`, the contact's normal along +x.
    let beyond = |plane: f32| {
        move |x: Vec3| {
            (x.x > plane).then(|| Contact { position: Vec3::new(plane, x.y, x.z), normal: Vec3::X, depth: 1.0 })
        }
    };
    let placed = Vec3::new(length, 0.0, 0.0);
    let (x, kept) = final_length::outside_at_length(placed, parent, length, thickness, beyond(-0.3 * length), |_| true);
    assert!(kept && x.x <= -0.3 * length && ((x - parent).length() - length).abs() < 1e-7, "{x}, kept {kept}");
    let (x, kept) = final_length::outside_at_length(placed, parent, length, thickness, beyond(-2.0 * length), |_| true);
    assert!(!kept && x.x == -2.0 * length - (thickness - 1e-6), "nowhere out at full length: {x}, kept {kept}");
}
