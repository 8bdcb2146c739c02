use super::*;

#[test]
fn sphere_and_capsule_push_to_the_surface() {
    let sphere = ExtraCollider::Sphere { center: Vec3::ZERO, radius: 1.0 };
    let c = sphere.resolve(Vec3::new(0.5, 0.0, 0.0), 0.1).unwrap();
    assert!((c.position - Vec3::new(1.1, 0.0, 0.0)).length() < 1e-6);
    assert!((c.depth - 0.6).abs() < 1e-6);
    assert!(sphere.resolve(Vec3::new(2.0, 0.0, 0.0), 0.1).is_none());
    let capsule = ExtraCollider::Capsule { a: Vec3::ZERO, b: Vec3::Y, radius: 0.5 };
    let c = capsule.resolve(Vec3::new(0.2, 0.5, 0.0), 0.0).unwrap();
    assert!((c.position - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-6);
    assert!((c.normal - Vec3::X).length() < 1e-6);
}
