//! Property tests for child strands and tessellation: whatever settings, guide shapes and
//! indices a caller (or a slider) hands them, children are finite, counted exactly, and
//! the tessellated curves have unit tangents.

mod common;

use common::{proptest_config, wild_f32};
use hair_sim::groom::{child_offset, evaluate, frame_at};
use hair_sim::prelude::*;
use proptest::prelude::*;

fn wild_params() -> impl Strategy<Value = ChildParams> {
    (prop_oneof![0u32..40, Just(u32::MAX)], wild_f32(), wild_f32(), wild_f32(), wild_f32(), wild_f32(), wild_f32())
        .prop_map(|(per_guide, a, b, angle_step, scale, clumping, tip_spread)| ChildParams {
            per_guide,
            spiral: Spiral { a, b, angle_step, scale },
            clumping,
            tip_spread,
        })
}

/// A guide of 2..12 particles, 2 cm apart, turning by up to ±180° per segment, with
/// occasional repeated particles (a collapsed segment).
fn wild_guide() -> impl Strategy<Value = Vec<Vec3>> {
    prop::collection::vec((prop::array::uniform3(-1.0f32..1.0), any::<bool>()), 1..12).prop_map(|turns| {
        let mut points = vec![Vec3::new(0.03, 0.1, -0.02)];
        let mut direction = Vec3::Y;
        for (turn, repeat) in turns {
            let axis = Vec3::from_array(turn).normalize_or(Vec3::X);
            direction = Quat::from_axis_angle(axis, turn[0] * std::f32::consts::PI) * direction;
            let last = *points.last().unwrap();
            points.push(if repeat { last } else { last + direction * 0.02 });
        }
        points
    })
}

fn wild_direction() -> impl Strategy<Value = Vec3> {
    prop_oneof![
        4 => prop::array::uniform3(-1.0f32..1.0).prop_map(Vec3::from_array),
        1 => Just(Vec3::ZERO),
        1 => Just(Vec3::Y),
        1 => Just(Vec3::NAN),
        1 => Just(Vec3::new(f32::INFINITY, 0.0, 0.0)),
    ]
}

/// Any root a caller could pass: wild directions, curvature and head centre.
fn wild_root() -> impl Strategy<Value = ChildRoot> {
    (wild_direction(), wild_direction(), wild_f32(), wild_direction())
        .prop_map(|(u, normal, curvature, head_centre)| ChildRoot { u, normal, curvature, head_centre })
}

proptest! {
    #![proptest_config(proptest_config(500))]

    #[test]
    fn children_are_finite_and_counted_exactly(
        guide in wild_guide(),
        root in wild_root(),
        params in wild_params(),
        guide_index in any::<u32>(),
        subdivisions in 0u32..6,
        t in wild_f32(),
    ) {
        let (clean, _) = params.sanitized();
        prop_assert!(clean.per_guide <= hair_sim::groom::MAX_CHILDREN_PER_GUIDE);
        let [x, y] = child_offset(&params, guide_index, guide_index.wrapping_mul(7), t);
        prop_assert!(x.is_finite() && y.is_finite(), "offset {x} {y}");

        let points_per_curve = (guide.len() - 1) * subdivisions.max(1) as usize + 1;
        let children = child_curves(&guide, &root, &params, guide_index, subdivisions);
        prop_assert_eq!(children.len(), clean.per_guide as usize);
        for child in children.iter().take(4).chain(children.last()) {
            prop_assert_eq!(child.len(), points_per_curve);
            for p in child {
                prop_assert!(p.position.is_finite(), "{:?}", p);
                prop_assert!((p.tangent.length() - 1.0).abs() <= 1e-4, "{:?}", p);
            }
        }
        let lone = child_curve(&guide, &root, &params, guide_index, u32::MAX, subdivisions);
        prop_assert!(lone.iter().all(|p| p.position.is_finite() && p.tangent.is_finite()));

        // The guide's own curve: through every particle, unit tangents, orthonormal frames.
        let curve = tessellate(&guide, subdivisions);
        prop_assert_eq!(curve.len(), points_per_curve);
        let frames = transport_frames(&guide, root.u);
        prop_assert_eq!(frames.len(), guide.len());
        for (j, &p) in guide.iter().enumerate() {
            prop_assert!((evaluate(&guide, j as f32).position - p).length() <= 1e-5);
        }
        let s_count = subdivisions.max(1) as f32;
        for (k, point) in curve.iter().enumerate() {
            prop_assert!((point.tangent.length() - 1.0).abs() <= 1e-4, "{:?}", point);
            let (u, v) = frame_at(&frames, k as f32 / s_count, point.tangent);
            prop_assert!((u.length() - 1.0).abs() <= 1e-4 && (v.length() - 1.0).abs() <= 1e-4);
            prop_assert!(u.dot(point.tangent).abs() <= 1e-4 && v.dot(point.tangent).abs() <= 1e-4);
            prop_assert!(u.dot(v).abs() <= 1e-4);
        }
    }
}

/// Children on the procedural head, drawn as the renderer draws them (the CPU reference
/// `child_curves`): 256 settled guides on the upper half but the ears, 16 children each
/// (up to 9.85 mm from their guide), 4 curve points
/// per segment. Child roots lie on the scalp, and almost no child point is inside the head,
/// at rest and while the head turns. Measured with [`InsideTest`], not the collider.
#[test]
fn children_grow_from_the_scalp_and_stay_out_of_the_head() {
    use hair_sim::groom::{ChildRoot, child_curves, sample_roots_poisson, settle};
    use hair_sim::mesh::InsideTest;
    let head = test_head(4);
    let collider = HeadCollider::new(&head, 64).unwrap();
    let test = InsideTest::new(&head);
    // The upper half, less the ears (3 cm bumps, no scalp on a real head).
    let on_ear = |p: Vec3| p.normalize().angle_between(Vec3::new(p.x.signum(), 0.05, -0.1).normalize()) < 0.54;
    let scalp: Vec<f32> = head
        .triangles
        .iter()
        .map(|t| if head.corners(t).iter().all(|&p| p.y > 0.0 && !on_ear(p)) { 1.0 } else { 0.0 })
        .collect();
    let roots = sample_roots_poisson(&head, &scalp, 256, 4).unwrap();
    let guide = GuideParams { segments: 10, length: 0.2, ..GuideParams::default() };
    let rest = RestShape::new(grow_guides(&head, &roots, &guide, 4).unwrap(), 11).unwrap();
    let rest = settle(rest, Some(&collider), &SimParams::default(), 120, Vec3::ZERO).unwrap();
    let params = ChildParams::default();
    let n = 11;

    // Per measured frame: child points, those inside deeper than 0.1 mm, the worst root.
    let measure = |positions: &[Vec3], pose: Pose| -> (usize, usize, f32) {
        let (mut points, mut inside, mut worst_root) = (0, 0, 0.0f32);
        for (g, (strand, binding)) in positions.chunks_exact(n).zip(&roots).enumerate() {
            let root = ChildRoot {
                u: pose.rotation * binding.tangent(&head),
                normal: pose.rotation * binding.normal(&head),
                curvature: binding.curvature(&head),
                head_centre: pose.transform_point(collider.centre()),
            };
            for curve in child_curves(strand, &root, &params, g as u32, 4) {
                let local: Vec<Vec3> = curve.iter().map(|c| pose.inverse_transform_point(c.position)).collect();
                worst_root = worst_root.max(test.distance(local[0]));
                points += local.len();
                inside += local.iter().filter(|&&p| test.depth(p).is_some_and(|d| d > 1e-4)).count();
            }
        }
        (points, inside, worst_root)
    };

    // At most 0.5 mm off the scalp, at most 0.5 % of points inside.
    let check = |when: &str, (points, inside, worst_root): (usize, usize, f32)| {
        println!(
            "{when}: {inside} of {points} child points inside ({:.3} %), child roots up to {:.3} mm off the scalp",
            100.0 * inside as f32 / points as f32,
            worst_root * 1e3
        );
        assert!(worst_root <= 5e-4, "{when}: a child root is {} mm off the scalp", worst_root * 1e3);
        assert!(inside as f32 <= 0.005 * points as f32, "{when}: {inside} of {points} inside");
    };
    check("at rest", measure(&rest.positions, Pose::IDENTITY));

    // The head turning and nodding for a second, a few rad/s.
    let pose = |t: f32| {
        Pose::new(
            Quat::from_rotation_y(1.2 * (5.0 * t).sin()) * Quat::from_rotation_x(0.5 * (7.0 * t).sin()),
            Vec3::new(0.0, 1.6, 0.0),
        )
    };
    let mut strands = Strands::new(rest.clone(), pose(0.0));
    let params_sim = SimParams::default();
    let (mut all_points, mut all_inside, mut all_worst) = (0, 0, 0.0f32);
    for k in 0..60 {
        let dt = 1.0 / 60.0;
        strands.step(&StepInput {
            dt,
            time: k as f32 * dt,
            head_from: pose(k as f32 * dt),
            head_to: pose((k + 1) as f32 * dt),
            collider: Some(&collider),
            extra_colliders: &[],
            surface_patch: None,
            params: &params_sim,
        });
        if k % 6 == 5 {
            let (points, inside, worst) = measure(strands.positions(), pose((k + 1) as f32 * dt));
            all_points += points;
            all_inside += inside;
            all_worst = all_worst.max(worst);
        }
    }
    check("moving", (all_points, all_inside, all_worst));
}
