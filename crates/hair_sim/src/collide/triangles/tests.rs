use super::*;
use crate::collide::{ContactHint, HeadCollider, Hint};
use crate::groom::{SplitMix64, sample_roots};
use crate::mesh::{HeadMesh, test_head};
use parry3d::shape::TriMeshFlags;

/// A 10 cm floor triangle (up = +Y) and a wall rising 4 mm beside it.
fn floor_and_wall() -> TriMesh {
    let vertices = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(0.1, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -0.1),
        // The wall, in the plane x = 0.104, facing the floor.
        Vec3::new(0.104, 0.0, 0.0),
        Vec3::new(0.104, 0.05, 0.0),
        Vec3::new(0.104, 0.0, -0.1),
    ];
    TriMesh::with_flags(vertices, vec![[0, 1, 2], [3, 4, 5]], TriMeshFlags::empty()).unwrap()
}

#[test]
fn clearance_is_half_the_gap_to_a_triangle_rising_above_the_plane() {
    let flat = FlatTriangles::bake(&floor_and_wall());
    assert!((flat.triangles[0].clearance - 0.002).abs() < 2e-5, "floor: {}", flat.triangles[0].clearance);
    // The floor lies in front of the wall, so the wall's clearance is the same.
    assert!((flat.triangles[1].clearance - 0.002).abs() < 2e-5, "wall: {}", flat.triangles[1].clearance);
}

#[test]
fn certificate_refuses_where_another_triangle_may_be_closer() {
    let flat = FlatTriangles::bake(&floor_and_wall());
    // 1.5 mm above the floor, far from the wall: the floor is certainly closest.
    let low = flat.certify(0, Vec3::new(0.02, 0.0015, -0.02), || 0.0).closest().expect("within the clearance");
    assert!((low.distance - 0.0015).abs() < 1e-7);
    // Over the floor's corner, 4.5 mm up and 4.1 mm from the wall: the wall is closer,
    // and 4.5 mm is beyond the floor's 2 mm clearance, so the floor is not claimed.
    let p = Vec3::new(0.0999, 0.0045, -0.00005);
    assert!(0.104 - p.x < p.y, "the wall is the closer triangle");
    assert!(matches!(flat.get(0).project(p).1, TrianglePointLocation::OnFace(0, _)), "over the face");
    assert!(flat.certify(0, p, || 0.0).closest().is_none());
    // Below the floor, or beside its face: no claim either.
    assert!(flat.certify(0, Vec3::new(0.02, -0.001, -0.02), || 0.0).closest().is_none());
    assert!(flat.certify(0, Vec3::new(-0.01, 0.001, 0.01), || 0.0).closest().is_none());
    assert!(flat.certify(7, Vec3::ZERO, || 0.0).closest().is_none(), "an unknown triangle proves nothing");
}

/// Two 10 cm triangles meeting along the X axis, sloping down to −Z (`t`) and +Z (`u`):
/// a ridge, or with `rise` > 0 a valley.
fn ridge(rise: f32) -> TriMesh {
    let vertices = vec![Vec3::ZERO, Vec3::new(0.1, 0.0, 0.0), Vec3::new(0.05, rise, -0.1), Vec3::new(0.05, rise, 0.1)];
    TriMesh::with_flags(vertices, vec![[0, 1, 2], [1, 0, 3]], TriMeshFlags::empty()).unwrap()
}

#[test]
fn edge_certificate_holds_over_a_ridge_and_nowhere_else() {
    let flat = FlatTriangles::bake(&ridge(-0.02));
    // 5 mm straight above the ridge: beside both faces, closest to the edge.
    let above = Vec3::new(0.05, 0.005, 0.0);
    for triangle in [0, 1] {
        let c = flat.certify(triangle, above, || 0.0).closest().expect("over the ridge");
        assert!((c.point - Vec3::new(0.05, 0.0, 0.0)).length() < 1e-7, "{:?}", c.point);
        assert!((c.distance - 0.005).abs() < 1e-7 && (c.normal - Vec3::Y).length() < 1e-5);
    }
    // Beside `t` but over `u`'s face: `u` is closer, and `t`'s edge claims nothing.
    let over_u = Vec3::new(0.05, 0.0, 0.03);
    assert!(matches!(flat.get(0).project(over_u).1, TrianglePointLocation::OnEdge(0, _)));
    assert!(flat.certify(0, over_u, || 0.0).closest().is_none());
    assert!(flat.certify(1, over_u, || 0.0).closest().is_some(), "u's face certificate takes it");
    // Beyond the (capped) edge clearance, and over a valley: no claim.
    assert!(flat.certify(0, Vec3::new(0.05, 0.011, 0.0), || 0.0).closest().is_none());
    let valley = FlatTriangles::bake(&ridge(0.02));
    assert!(valley.certify(0, Vec3::new(0.05, 0.005, 0.0), || 0.0).closest().is_none());
}

#[test]
fn hinted_queries_match_the_exact_ones() {
    let head = test_head(4);
    let collider = HeadCollider::new(&head, 48).unwrap();
    let everywhere = vec![1.0; head.triangles.len()];
    let roots = sample_roots(&head, &everywhere, 3000, 5).unwrap();
    let mut rng = SplitMix64::new(5);
    let (mut certified, mut by_gap, mut contacts) = (0, 0, 0);
    let mut previous = ContactHint::NONE;
    for root in &roots {
        let surface = root.position(&head);
        let normal = root.normal(&head);
        // A particle resting within the thickness, then moving a little: the first
        // query leaves the hint, the second may use it.
        let first = surface + normal * (0.003 * rng.next_f32());
        let second = first + Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5) * 0.002;
        let mut hint = ContactHint::NONE;
        collider.resolve_hinted(first, 0.003, &mut hint);
        if let Hint::Touching { triangle, at, gap, .. } = hint.0 {
            if collider.triangles.certify(triangle, second, || 0.0).closest().is_some() {
                certified += 1;
            } else if collider.triangles.certify(triangle, second, || gap - (second - at).length()).closest().is_some()
            {
                by_gap += 1;
            }
        }
        let hinted = collider.resolve_hinted(second, 0.003, &mut hint);
        // Hints that belong to other particles must not change the answer either: a
        // random triangle, and the last particle's real hint (its gap included).
        let random = (rng.next_f32() * head.triangles.len() as f32) as u32;
        let mut foreign = ContactHint(Hint::Touching { triangle: random, at: second, gap: 0.0, collider: collider.id });
        let with_foreign = collider.resolve_hinted(second, 0.003, &mut foreign);
        let with_previous = collider.resolve_hinted(second, 0.003, &mut previous);
        previous = hint;
        let exact = collider.resolve(second, 0.003);
        for answer in [hinted, with_foreign, with_previous] {
            assert_eq!(answer.is_some(), exact.is_some(), "at {second:?}");
            if let (Some(a), Some(b)) = (answer, exact) {
                assert!((a.position - b.position).length() < 1e-5, "{a:?} vs {b:?}");
                assert!((a.depth - b.depth).abs() < 1e-5);
            }
        }
        contacts += exact.is_some() as u32;
    }
    assert!(contacts > 1500, "most second positions touch: {contacts}");
    // Not all: some moved inside, beside their triangle's face, or sit where the head is
    // concave (ears, neck), where the gap certificate takes over for some.
    assert!(certified > 1500, "most resting particles skip the search: {certified} of 3000");
    assert!(by_gap > 0, "the gap certificate settles some of the rest: {by_gap} of 3000");
}

#[test]
fn a_far_particle_is_answered_from_its_clear_ball_until_it_leaves_it() {
    let head = test_head(4);
    let collider = HeadCollider::new(&head, 48).unwrap();
    let everywhere = vec![1.0; head.triangles.len()];
    let roots = sample_roots(&head, &everywhere, 500, 8).unwrap();
    let (mut skipped, mut touched) = (0, 0);
    for root in &roots {
        // Falls from 4 cm out onto the surface and into the head, 1.5 mm at a time.
        let (surface, normal) = (root.position(&head), root.normal(&head));
        let mut hint = ContactHint::NONE;
        for step in 0..32 {
            let p = surface + normal * (0.04 - 0.0015 * step as f32);
            let before = hint;
            let hinted = collider.resolve_hinted(p, 0.003, &mut hint);
            let exact = collider.resolve(p, 0.003);
            assert_eq!(hinted.is_some(), exact.is_some(), "step {step} at {p:?}");
            if let (Some(a), Some(b)) = (hinted, exact) {
                touched += 1;
                assert!((a.position - b.position).length() < 1e-5);
            }
            if matches!(before.0, Hint::Clear { .. }) && before == hint {
                skipped += 1;
            }
        }
    }
    assert!(touched >= 500 * 7, "the last seven steps touch: {touched}");
    assert!(skipped > 500 * 15, "most of the 25 far steps need no lookup: {skipped}");
}

#[test]
fn a_hint_from_another_collider_changes_nothing() {
    // The same head at two sizes: a point clear of the small one is inside the big one.
    let small = test_head(3);
    let big =
        HeadMesh::from_triangles(small.positions.iter().map(|&p| p * 1.5).collect(), small.triangles.clone()).unwrap();
    let (small, big) = (HeadCollider::new(&small, 32).unwrap(), HeadCollider::new(&big, 32).unwrap());
    let p = Vec3::new(0.0, 0.14, 0.0); // 3 cm above the small crown, 2.5 cm inside the big one
    let mut hint = ContactHint::NONE;
    assert!(small.resolve_hinted(p, 0.003, &mut hint).is_none());
    assert!(matches!(hint.0, Hint::Clear { .. }));
    let on_big = big.resolve_hinted(p, 0.003, &mut hint).expect("inside the big head");
    assert_eq!(Some(on_big), big.resolve(p, 0.003));
}
