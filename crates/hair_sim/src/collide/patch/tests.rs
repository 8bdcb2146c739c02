use super::*;

/// A square of two triangles in the plane y = 0, facing +y.
fn floor() -> SurfacePatch {
    let positions = vec![Vec3::ZERO, Vec3::new(0.0, 0.0, 0.1), Vec3::new(0.1, 0.0, 0.1), Vec3::new(0.1, 0.0, 0.0)];
    SurfacePatch::new(vec![[0, 1, 2], [0, 2, 3]], positions, 0.02)
}

#[test]
fn pushes_out_of_the_side_behind_the_normal() {
    let patch = floor();
    let c = patch.resolve(Vec3::new(0.05, -0.004, 0.03), 0.001).unwrap();
    assert!((c.position - Vec3::new(0.05, 0.001, 0.03)).length() < 1e-6, "{:?}", c.position);
    assert!((c.normal - Vec3::Y).length() < 1e-6 && (c.depth - 0.005).abs() < 1e-6);
    // Within the shell outside, and clear of it.
    assert!(patch.resolve(Vec3::new(0.05, 0.0005, 0.03), 0.001).is_some());
    assert!(patch.resolve(Vec3::new(0.05, 0.002, 0.03), 0.001).is_none());
    // Beyond its reach, or beside it, the patch says nothing.
    assert!(patch.resolve(Vec3::new(0.05, -0.03, 0.03), 0.001).is_none());
    assert!(patch.resolve(Vec3::new(0.5, -0.004, 0.03), 0.001).is_none());
}

#[test]
fn follows_its_corners_when_they_move() {
    let mut patch = floor();
    let lifted: Vec<Vec3> = patch.positions().iter().map(|p| *p + Vec3::Y * 0.005).collect();
    patch.update(&lifted);
    let c = patch.resolve(Vec3::new(0.05, 0.002, 0.03), 0.001).unwrap();
    assert!((c.position.y - 0.006).abs() < 1e-6, "{:?}", c.position);
    // A list of another length, or a NaN, leaves it as it was.
    patch.update(&lifted[..3]);
    patch.update(&[Vec3::NAN; 4]);
    assert_eq!(patch.positions(), &lifted[..]);
}

#[test]
fn a_ridge_is_inside_only_behind_both_faces() {
    // Two faces meeting in a ridge along z at x = 0.05, y = 0.01.
    let positions = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 0.1),
        Vec3::new(0.05, 0.01, 0.1),
        Vec3::new(0.05, 0.01, 0.0),
        Vec3::new(0.1, 0.0, 0.1),
        Vec3::new(0.1, 0.0, 0.0),
    ];
    let patch = SurfacePatch::new(vec![[0, 1, 2], [0, 2, 3], [3, 2, 4], [3, 4, 5]], positions, 0.02);
    // Just above the ridge: outside; just below it: inside.
    assert!(patch.resolve(Vec3::new(0.05, 0.015, 0.05), 0.001).is_none());
    let below = patch.resolve(Vec3::new(0.05, 0.008, 0.05), 0.001).unwrap();
    assert!(below.normal.y > 0.9 && below.position.y > 0.01, "{below:?}");
}
