//! Sleeping strands: hair that has stopped under a still head is held exactly where it is,
//! and wakes for anything that could move it (`SimParams::sleep_distance`).

mod common;

use common::{Groom, GroomSpec, groom_on_upper_half, step_input};
use hair_sim::prelude::*;
use std::sync::OnceLock;

/// 48 strands × 12 particles, 20 cm long, on the upper half of a 1,280-triangle head.
fn groom() -> &'static Groom {
    static GROOM: OnceLock<Groom> = OnceLock::new();
    GROOM.get_or_init(|| {
        groom_on_upper_half(GroomSpec { subdivisions: 3, grid: 32, strands: 48, particles: 12, curl: 0.1, seed: 3 })
    })
}

/// The head where it stands still.
const STILL: Pose = Pose::IDENTITY;

/// Steps of 1/60 s under a still head after which the groom, grown stiff and let fall, is
/// asleep (four seconds; half its strands are asleep after two).
const STILL_STEPS: usize = 240;

/// The groom stepped under a still head for `steps` steps of 1/60 s, and the last report.
fn stilled(params: &SimParams, steps: usize) -> (Strands, StepReport) {
    let g = groom();
    let mut strands = Strands::new(g.rest.clone(), STILL);
    let mut report = StepReport::default();
    for k in 0..steps {
        report = strands.step(&step_input(k, STILL, STILL, Some(&g.collider), params));
    }
    (strands, report)
}

fn bits(v: &[Vec3]) -> Vec<[u32; 3]> {
    v.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

/// Under a still head every strand falls asleep within a few seconds, and then holds
/// its place bit for bit, with no velocity, touching nothing (it is not stepped).
#[test]
fn still_hair_falls_asleep_and_holds_its_place_exactly() {
    let params = SimParams::default();
    let g = groom();
    let (mut strands, _) = stilled(&params, STILL_STEPS);
    let asleep = strands.sleeping(&params);
    println!("after 4 s under a still head: {asleep} of {} strands asleep", g.rest.strand_count());
    assert_eq!(asleep, g.rest.strand_count());
    let held = strands.positions().to_vec();
    for k in STILL_STEPS..STILL_STEPS + 60 {
        let report = strands.step(&step_input(k, STILL, STILL, Some(&g.collider), &params));
        assert_eq!(report.sleeping as usize, g.rest.strand_count(), "step {k}");
        assert_eq!(report.contacts, 0, "a sleeping strand is not stepped");
    }
    assert_eq!(bits(strands.positions()), bits(&held), "held exactly");
    assert!(strands.velocities().iter().all(|v| *v == Vec3::ZERO), "asleep, motionless");
}

/// With `sleep_distance` 0 nothing sleeps.
#[test]
fn a_sleep_distance_of_zero_never_sleeps() {
    let params = SimParams { sleep_distance: 0.0, ..SimParams::default() };
    let (strands, report) = stilled(&params, 150);
    assert_eq!((strands.sleeping(&params), report.sleeping), (0, 0));
}

/// Something done to a sleeping groom, and how many strands the step after it left asleep.
type Wake<'a> = Box<dyn Fn(&mut Strands) -> u32 + 'a>;

/// From a sleeping groom, each thing that could move the hair wakes every strand in the
/// step it happens: the head turning a milliradian, the head moved a centimetre between
/// steps (still within the step), wind, gravity turned, a shoulder added, new positions
/// set, the groom reset.
#[test]
fn sleeping_hair_wakes_for_whatever_could_move_it() {
    let g = groom();
    let params = SimParams::default();
    let (asleep, _) = stilled(&params, STILL_STEPS);
    assert_eq!(asleep.sleeping(&params), g.rest.strand_count());
    let turned = Pose::new(Quat::from_rotation_y(1e-3), Vec3::ZERO);
    let moved = Pose::from_translation(Vec3::new(0.0, 0.0, 0.01));
    let mut windy = params;
    windy.wind.strength = 2.0;
    let upside_down = SimParams { gravity: [0.0, 9.81, 0.0], ..params };
    let shoulder = [ExtraCollider::Sphere { center: Vec3::new(0.12, -0.3, 0.0), radius: 0.08 }];
    let step = |strands: &mut Strands, from: Pose, to: Pose, params: &SimParams, extras: &[ExtraCollider]| {
        let input =
            StepInput { extra_colliders: extras, ..step_input(STILL_STEPS, from, to, Some(&g.collider), params) };
        strands.step(&input).sleeping
    };
    let cases: [(&str, Wake); 8] = [
        ("nothing", Box::new(|s| step(s, STILL, STILL, &params, &[]))),
        ("the head turning", Box::new(|s| step(s, STILL, turned, &params, &[]))),
        ("the head moved between steps", Box::new(|s| step(s, moved, moved, &params, &[]))),
        ("wind", Box::new(|s| step(s, STILL, STILL, &windy, &[]))),
        ("gravity turned", Box::new(|s| step(s, STILL, STILL, &upside_down, &[]))),
        ("a shoulder", Box::new(|s| step(s, STILL, STILL, &params, &shoulder))),
        (
            "positions set",
            Box::new(|s| {
                let here = s.positions().to_vec();
                s.set_positions(&here).expect("finite");
                step(s, STILL, STILL, &params, &[])
            }),
        ),
        (
            "a reset",
            Box::new(|s| {
                s.reset(STILL);
                step(s, STILL, STILL, &params, &[])
            }),
        ),
    ];
    for (name, wake) in cases {
        let mut strands = asleep.clone();
        let still_asleep = wake(&mut strands);
        println!("{name}: {still_asleep} strands left asleep");
        let expected = if name == "nothing" { g.rest.strand_count() as u32 } else { 0 };
        assert_eq!(still_asleep, expected, "{name}");
        if name != "nothing" {
            assert_eq!(strands.sleeping(&params), 0, "{name}: the watch starts over");
        }
    }
}

/// Stepping in chunks, on threads or not, falls asleep and wakes exactly as stepping whole:
/// a still head for 4 s, then a turn.
#[test]
fn chunks_sleep_and_wake_as_the_whole_groom_does() {
    let g = groom();
    let params = SimParams::default();
    let turn = |k: usize| Pose::new(Quat::from_rotation_y(0.02 * (k - STILL_STEPS) as f32), Vec3::ZERO);
    let pose = |k: usize| if k < STILL_STEPS { STILL } else { turn(k) };
    let mut whole = Strands::new(g.rest.clone(), STILL);
    let mut chunked = whole.clone();
    let mut slept = 0;
    for k in 0..STILL_STEPS + 30 {
        let input = step_input(k, pose(k), pose(k + 1), Some(&g.collider), &params);
        let expected = whole.step(&input);
        let mut report = StepReport::default();
        for mut chunk in chunked.chunks_mut(7).into_iter().rev() {
            report.merge(chunk.step(&input));
        }
        assert_eq!(report, expected, "step {k}");
        slept = slept.max(expected.sleeping);
    }
    assert_eq!(slept as usize, g.rest.strand_count(), "all asleep before the turn");
    assert_eq!(bits(chunked.positions()), bits(whole.positions()));
    assert_eq!(bits(chunked.velocities()), bits(whole.velocities()));
}
