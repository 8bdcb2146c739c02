use super::*;

/// Settings survive a save and load unchanged, and a saved preset that names only some
/// fields takes the defaults for the rest.
#[cfg(feature = "serde")]
#[test]
fn settings_round_trip_through_serde() {
    let params = SimParams {
        gravity: [0.5, -3.0, 0.25],
        substeps: 5,
        length_mode: LengthMode::Springs,
        wind: Wind { direction: [0.0, 0.0, 1.0], strength: 2.5, ..Wind::default() },
        collision_response: CollisionResponse::CentreRay { offset: [0.0, 0.01, -0.02] },
        friction: 0.125,
        ..SimParams::default()
    };
    let text = serde_json::to_string(&params).unwrap();
    assert_eq!(serde_json::from_str::<SimParams>(&text).unwrap(), params);
    let partial: SimParams = serde_json::from_str(r#"{"substeps": 4, "wind": {"strength": 1.5}}"#).unwrap();
    let wind = Wind { strength: 1.5, ..Wind::default() };
    assert_eq!(partial, SimParams { substeps: 4, wind, ..SimParams::default() });
}

#[test]
fn bad_values_are_replaced_and_named() {
    let bad = SimParams {
        drag: f32::NAN,
        friction: -1.0,
        substeps: 0,
        gravity: [0.0, f32::INFINITY, 0.0],
        ..SimParams::default()
    };
    let (fixed, issues) = bad.sanitized();
    assert_eq!(fixed.drag, 1.0);
    assert_eq!(fixed.friction, 0.0);
    assert_eq!(fixed.substeps, 1);
    assert_eq!(fixed.gravity[1], -9.81);
    let fields: Vec<_> = issues.iter().map(|i| i.field).collect();
    assert_eq!(fields, ["drag", "friction", "gravity.y", "substeps"]);
    assert!(issues[1].to_string().contains("friction = -1"));
    assert!(SimParams::default().sanitized().1.is_empty());
}

#[test]
fn stiffness_decay_per_second_is_rate_independent() {
    let s = 0.3;
    let per_second = |n: f32| (1.0 - stiffness_per_application(s, n)).powf(n);
    assert!((per_second(60.0) - 0.7f32.powi(60)).abs() < 1e-9);
    assert!((per_second(240.0) - per_second(960.0)).abs() < 1e-6);
    assert_eq!(stiffness_per_application(1.0, 480.0), 1.0);
    assert_eq!(stiffness_per_application(0.0, 480.0), 0.0);
}
