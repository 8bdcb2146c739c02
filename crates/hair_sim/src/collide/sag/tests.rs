use super::*;
use crate::mesh::{InsideTest, test_head};

/// Random segments near the procedural head (ears included), checked by brute force
/// with the independent inside test: none that the bound clears crosses the surface,
/// and on the skull it clears most of those resting on a 1–3 mm shell.
#[test]
fn no_segment_it_clears_crosses_the_head() {
    for subdivisions in [3, 4, 5] {
        let head = test_head(subdivisions);
        let sag = SagGrid::bake(&head.positions, &head.triangles);
        let inside = InsideTest::new(&head);
        let (mut cleared, mut crossing, mut skull, mut skull_cleared) = (0, 0, 0, 0);
        for (a, b) in crate::collide::segments_near(&head, 7, 10_000) {
            if inside.contains(a) || inside.contains(b) {
                continue;
            }
            let clear = inside.distance(a).min(inside.distance(b));
            let crosses = inside.segment_crosses(a, b);
            crossing += usize::from(crosses);
            let on_skull = a.y > 0.06 && clear > 0.001 && (a - b).length() < 0.02;
            skull += usize::from(on_skull);
            if clear > sag.bound(a, b) {
                cleared += 1;
                skull_cleared += usize::from(on_skull);
                assert!(!crosses, "{subdivisions}: {a} – {b} crosses, bound {}", sag.bound(a, b));
            }
        }
        println!(
            "{} triangles: {cleared} of 10,000 segments cleared, {crossing} crossing; on the crown \
             {skull_cleared} of {skull} clearing 1 mm",
            head.triangles.len()
        );
        assert!(crossing > 10, "the sample holds segments that cross");
        assert!(skull_cleared * 10 > skull * 9, "the bound clears 90 % of the crown's segments");
    }
}

#[test]
fn long_segments_and_far_ones() {
    let head = test_head(3);
    let sag = SagGrid::bake(&head.positions, &head.triangles);
    assert_eq!(sag.bound(Vec3::new(0.0, 0.12, 0.0), Vec3::new(0.0, 0.12, 0.04)), f32::INFINITY);
    assert_eq!(sag.bound(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.01)), 0.0);
}
