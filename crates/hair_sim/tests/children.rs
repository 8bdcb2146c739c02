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

fn wild_root_u() -> impl Strategy<Value = Vec3> {
    prop_oneof![
        4 => prop::array::uniform3(-1.0f32..1.0).prop_map(Vec3::from_array),
        1 => Just(Vec3::ZERO),
        1 => Just(Vec3::Y),
        1 => Just(Vec3::NAN),
        1 => Just(Vec3::new(f32::INFINITY, 0.0, 0.0)),
    ]
}

proptest! {
    #![proptest_config(proptest_config(500))]

    #[test]
    fn children_are_finite_and_counted_exactly(
        guide in wild_guide(),
        root_u in wild_root_u(),
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
        let children = child_curves(&guide, root_u, &params, guide_index, subdivisions);
        prop_assert_eq!(children.len(), clean.per_guide as usize);
        for child in children.iter().take(4).chain(children.last()) {
            prop_assert_eq!(child.len(), points_per_curve);
            for p in child {
                prop_assert!(p.position.is_finite(), "{:?}", p);
                prop_assert!((p.tangent.length() - 1.0).abs() <= 1e-4, "{:?}", p);
            }
        }
        let lone = child_curve(&guide, root_u, &params, guide_index, u32::MAX, subdivisions);
        prop_assert!(lone.iter().all(|p| p.position.is_finite() && p.tangent.is_finite()));

        // The guide's own curve: through every particle, unit tangents, orthonormal frames.
        let curve = tessellate(&guide, subdivisions);
        prop_assert_eq!(curve.len(), points_per_curve);
        let frames = transport_frames(&guide, root_u);
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
