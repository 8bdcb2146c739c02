//! Levels of detail: which strands a far groom simulates, how the rest follow, and that
//! switching does not pop (run with `--nocapture` for the numbers).

mod common;

use common::{Groom, GroomSpec, groom_on_upper_half};
use hair_sim::prelude::*;
use hair_sim::solver::simulated_at_level;
use std::sync::OnceLock;

const DT: f32 = 1.0 / 60.0;

/// 256 strands × 12 particles, 20 cm long, on the upper half of a 1,280-triangle head,
/// settled.
fn groom() -> &'static (Groom, RestShape) {
    static GROOM: OnceLock<(Groom, RestShape)> = OnceLock::new();
    GROOM.get_or_init(|| {
        let groom = groom_on_upper_half(GroomSpec {
            subdivisions: 3,
            grid: 32,
            strands: 256,
            particles: 12,
            curl: 0.1,
            seed: 5,
        });
        let rest = settle(groom.rest.clone(), Some(&groom.collider), &SimParams::default(), 120, Vec3::ZERO).unwrap();
        (groom, rest)
    })
}

/// The head turning and nodding at up to about 2 rad/s, as a character looking around.
fn looking_around(k: usize) -> Pose {
    let t = k as f32 * DT;
    Pose::new(
        Quat::from_rotation_y(0.9 * (2.1 * t).sin()) * Quat::from_rotation_x(0.3 * (2.7 * t).sin()),
        Vec3::new(0.0, 1.6, 0.0),
    )
}

/// Step `k` of `dt` from head pose `from` to `to`.
fn input<'a>(
    k: usize,
    dt: f32,
    (from, to): (Pose, Pose),
    collider: &'a HeadCollider,
    params: &'a SimParams,
) -> StepInput<'a> {
    StepInput {
        dt,
        time: k as f32 * DT,
        head_from: from,
        head_to: to,
        collider: Some(collider),
        extra_colliders: &[],
        surface_patch: None,
        params,
    }
}

/// Step `k` of the head looking around.
fn step(strands: &mut Strands, k: usize, collider: &HeadCollider, params: &SimParams) -> StepReport {
    strands.step(&input(k, DT, (looking_around(k), looking_around(k + 1)), collider, params))
}

#[test]
fn a_far_groom_simulates_a_nested_fraction_and_the_rest_follow() {
    let (groom, rest) = groom();
    let params = SimParams::default();
    let mut strands = Strands::new(rest.clone(), looking_around(0));
    assert_eq!(strands.detail_level(), 0);
    assert_eq!(strands.simulated_strands(), 256);
    strands.set_detail_level(3, 0);
    assert_eq!(strands.detail_level(), 3);
    let mut followers_deepest = 0.0f32;
    for k in 0..120 {
        step(&mut strands, k, &groom.collider, &params);
        assert_eq!(strands.simulated_strands(), 32, "1/8 of 256 strands are simulated");
        assert!(strands.positions().iter().all(|p| p.is_finite()));
        let pose = looking_around(k + 1);
        for p in strands.positions() {
            followers_deepest =
                followers_deepest.max(-groom.collider.signed_distance(pose.inverse_transform_point(*p)));
        }
    }
    // Followers are placed, not simulated: their segments keep their rest lengths only as
    // far as their leaders' motion agrees (the leaders' own keep them exactly). Measured
    // and bounded, not zero: it follows how differently neighbouring leaders move.
    let stretch = strands.max_stretch();
    println!("level 3 of 256 strands: stretch {stretch:.4}, deepest particle {:.2} mm", followers_deepest * 1e3);
    assert!(stretch < 0.1, "a follower's segment is stretched by {stretch}");
    // Roots stay on the head.
    let n = strands.particles_per_strand();
    let pose = looking_around(120);
    for (s, root) in strands.positions().iter().step_by(n).enumerate() {
        assert!(root.distance(pose.transform_point(rest.positions[s * n])) < 1e-5, "root {s} left its place");
    }
    // Level 0 again: every strand is simulated once more.
    strands.set_detail_level(0, 30);
    step(&mut strands, 120, &groom.collider, &params);
    assert_eq!(strands.simulated_strands(), 256);
}

#[test]
fn every_level_is_spread_over_the_scalp() {
    let (_, rest) = groom();
    let n = rest.particles_per_strand;
    let roots: Vec<Vec3> = rest.positions.iter().step_by(n).copied().collect();
    let width = roots.iter().map(|a| roots.iter().map(|b| a.distance(*b)).fold(0.0, f32::max)).fold(0.0, f32::max);
    let mut strands = Strands::new(rest.clone(), Pose::IDENTITY);
    let mut simulated_before: Vec<usize> = (0..256).collect();
    for level in 1..=5 {
        strands.set_detail_level(level, 0);
        let simulated: Vec<usize> = (0..256).filter(|&s| strands.is_simulated(s)).collect();
        assert_eq!(simulated.len(), simulated_at_level(256, level));
        assert!(
            simulated.iter().all(|s| simulated_before.contains(s)),
            "level {level} is not within level {}",
            level - 1
        );
        // The farthest any root is from its nearest simulated one, against a random pick
        // of as many (every k-th strand by index, as sampled) for scale.
        let gap = |chosen: &[usize]| {
            roots
                .iter()
                .map(|r| chosen.iter().map(|&c| r.distance(roots[c])).fold(f32::INFINITY, f32::min))
                .fold(0.0, f32::max)
        };
        let spread = gap(&simulated);
        let every_kth: Vec<usize> = (0..256).step_by(1 << level).collect();
        println!(
            "level {level}: {} simulated, every root within {:.1} mm of one (every {}-th strand: {:.1} mm; scalp {:.0} mm)",
            simulated.len(),
            spread * 1e3,
            1 << level,
            gap(&every_kth) * 1e3,
            width * 1e3
        );
        assert!(
            spread < gap(&every_kth),
            "level {level}: the order covers the scalp no better than taking every k-th strand"
        );
        simulated_before = simulated;
    }
}

/// Largest distance between the same particle in `a` and `b`.
fn farthest(a: &[Vec3], b: &[Vec3]) -> f32 {
    a.iter().zip(b).map(|(p, q)| p.distance(*q)).fold(0.0, f32::max)
}

/// Switching levels moves no strand by more than 2 mm in a step beyond where it would be
/// drawn otherwise, while the head looks around at up to 2 rad/s. Down to 1/8 at step 60,
/// back to all at step 150. At each switch the strands are compared, one step on, with the
/// same strands not switched (a strand rising into the simulation is pulled back toward
/// where it would follow, a pull that lets go over the fade). Over the fade out, with the
/// same strands switched at once: the gap between them may change by at most 2 mm a step
/// (the fade hands a strand from its solver to its leaders gradually). With no fade, the
/// switch must show (the test can fail).
#[test]
fn switching_levels_does_not_pop() {
    let (groom, rest) = groom();
    let params = SimParams::default();
    let start = Strands::new(rest.clone(), looking_around(0));
    // Per step: the strands after it; and the largest jump one step after each switch,
    // against the same state not switched.
    let run = |fade: u32| {
        let mut strands = start.clone();
        let (mut states, mut at_switch) = (Vec::new(), 0.0f32);
        for k in 0..240 {
            let switch = match k {
                60 => Some(3),
                150 => Some(0),
                _ => None,
            };
            if let Some(level) = switch {
                let mut unswitched = strands.clone();
                strands.set_detail_level(level, fade);
                step(&mut unswitched, k, &groom.collider, &params);
                step(&mut strands, k, &groom.collider, &params);
                at_switch = at_switch.max(farthest(strands.positions(), unswitched.positions()));
            } else {
                step(&mut strands, k, &groom.collider, &params);
            }
            states.push(strands.positions().to_vec());
        }
        (states, at_switch)
    };
    let ((faded, faded_switch), (at_once, at_once_switch)) = (run(30), run(0));
    // The gap between two runs changes by at most this much in a step over `steps`.
    let largest_change = |a: &[Vec<Vec3>], b: &[Vec<Vec3>], steps: std::ops::Range<usize>| {
        let gap = |k: usize| -> Vec<Vec3> { a[k].iter().zip(&b[k]).map(|(p, q)| *p - *q).collect() };
        steps.map(|k| farthest(&gap(k), &gap(k - 1))).fold(0.0, f32::max)
    };
    // The fade out takes steps 60 to 90; a few steps more.
    let fade_jump = largest_change(&faded, &at_once, 61..100);
    println!(
        "one step after a switch, against not switching: {:.2} mm with a 30-step fade, {:.2} mm with none; \
         the fade out's largest step {:.2} mm",
        faded_switch * 1e3,
        at_once_switch * 1e3,
        fade_jump * 1e3
    );
    assert!(
        at_once_switch > 0.002,
        "a switch with no fade should show ({} mm): the measure sees nothing",
        at_once_switch * 1e3
    );
    assert!(faded_switch <= 0.002, "a strand jumped {} mm at a switch", faded_switch * 1e3);
    assert!(fade_jump <= 0.002, "the fade out moved a strand {} mm in a step", fade_jump * 1e3);
}

#[test]
fn chunked_stepping_with_followers_matches_step() {
    let (groom, rest) = groom();
    let params = SimParams::default();
    let mut whole = Strands::new(rest.clone(), looking_around(0));
    let mut chunked = whole.clone();
    whole.set_detail_level(2, 5);
    chunked.set_detail_level(2, 5);
    for k in 0..30 {
        step(&mut whole, k, &groom.collider, &params);
        let input = input(k, DT, (looking_around(k), looking_around(k + 1)), &groom.collider, &params);
        for mut chunk in chunked.chunks_mut(48) {
            chunk.step(&input);
        }
        chunked.follow_leaders(&input);
    }
    let bits = |s: &Strands| s.positions().iter().map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    assert_eq!(bits(&whole), bits(&chunked));
}

/// Levels of detail under what a game throws at a groom: a 10 m teleport, a 1 s hitch, a
/// NaN pose and a level switch in the same steps. Every strand, followers included, stays
/// finite with its root on the head, and the followers come back with it: stepped with
/// [`Strands::step`], and with the followers left to the caller (placed in head space, then
/// in the strands).
#[test]
fn followers_survive_teleports_hitches_and_bad_poses() {
    for leave in [false, true] {
        followers_survive_teleports_hitches_and_bad_poses_with(leave);
    }
}

fn followers_survive_teleports_hitches_and_bad_poses_with(leave_followers: bool) {
    let (groom, rest) = groom();
    let params = SimParams::default();
    let n = rest.particles_per_strand;
    let mut strands = Strands::new(rest.clone(), looking_around(0));
    strands.set_detail_level(4, 10);
    let far = Pose::new(Quat::from_rotation_y(1.0), Vec3::new(10.0, 1.6, 3.0));
    let nan = Pose::new(Quat::IDENTITY, Vec3::splat(f32::NAN));
    // (step length, head pose after the step, level to switch to before it)
    let script: [(f32, Pose, Option<u32>); 6] = [
        (DT, looking_around(1), None),
        (DT, far, Some(2)),
        (1.0, far, None),
        (DT, nan, Some(5)),
        (DT, far, Some(0)),
        (DT, far, Some(3)),
    ];
    let mut from = looking_around(0);
    for (k, (dt, to, level)) in script.into_iter().enumerate() {
        if let Some(level) = level {
            strands.set_detail_level(level, 10);
        }
        let input = input(k, dt, (from, to), &groom.collider, &params);
        if leave_followers {
            strands.step_leaving_followers(&input);
            if to.is_valid() {
                let mut local: Vec<Vec3> = strands.positions().iter().map(|&p| to.inverse_transform_point(p)).collect();
                if let Some(followers) = strands.head_space_followers(|i| local[i]) {
                    for s in (0..local.len() / n).filter(|&s| followers.follows(s)) {
                        followers.place(s, &mut local[s * n..(s + 1) * n]);
                    }
                }
                assert!(local.iter().all(|p| p.is_finite()), "step {k}: a head-space particle is not finite");
            }
            strands.place_followers();
        } else {
            strands.step(&input);
        }
        assert!(strands.positions().iter().all(|p| p.is_finite()), "step {k}: a particle is not finite");
        if to.is_valid() {
            for (s, root) in strands.positions().iter().step_by(n).enumerate() {
                let pinned = to.transform_point(rest.positions[s * n]);
                assert!(root.distance(pinned) < 1e-4, "step {k}: root {s} is {} m off", root.distance(pinned));
            }
            from = to;
        }
    }
    // All strands near the head after the teleport: none left behind at the old place.
    let pose = far;
    let farthest = strands.positions().iter().map(|p| p.distance(pose.translation)).fold(0.0f32, f32::max);
    assert!(farthest < 0.5, "a particle is {farthest} m from the teleported head");
}

/// A caller that places the followers itself ([`Strands::step_leaving_followers`]) gets
/// them where [`Strands::step`] puts them: through level switches with fades and rises in
/// flight, followers left unplaced across them, and a move of the strands' origin. Placed in the strands, to the bit; placed in
/// head space from head-space leaders (the plugin's copy-out), to 1 µm.
#[test]
fn followers_left_for_the_caller_land_where_step_puts_them() {
    let (groom, rest) = groom();
    let params = SimParams::default();
    let n = rest.particles_per_strand;
    let mut placed = Strands::new(rest.clone(), looking_around(0));
    let mut left = placed.clone();
    let (mut in_head_space, mut followers_checked) = (0.0f32, 0);
    // The strands' origin moves by this at step 50.
    let shift = Vec3::new(0.3, -0.1, 0.2);
    for k in 0..80 {
        let level = match k {
            0 => Some(3),
            30 => Some(1),
            45 => Some(4),
            _ => None,
        };
        if let Some(level) = level {
            placed.set_detail_level(level, 20);
            left.set_detail_level(level, 20);
        }
        if k == 50 {
            placed.translate(shift);
            left.translate(shift);
        }
        let shift = if k >= 50 { shift } else { Vec3::ZERO };
        let pose = |k: usize| {
            let p = looking_around(k);
            Pose::new(p.rotation, p.translation + shift)
        };
        let input = input(k, DT, (pose(k), pose(k + 1)), &groom.collider, &params);
        placed.step(&input);
        left.step_leaving_followers(&input);
        assert!(left.followers_pending(), "step {k}: followers were placed");
        // Head space, as the plugin copies the strands out: the simulated strands' positions
        // under the inverse pose, the followers placed from those.
        let head = pose(k + 1);
        let mut local: Vec<Vec3> = left.positions().iter().map(|&p| head.inverse_transform_point(p)).collect();
        let following: Vec<usize> = (0..left.strand_count()).filter(|&s| left.is_following(s)).collect();
        let followers = left.head_space_followers(|i| local[i]).expect("a level of detail");
        for &s in &following {
            assert!(followers.follows(s));
            followers.place(s, &mut local[s * n..(s + 1) * n]);
        }
        for &s in &following {
            let strand = s * n..(s + 1) * n;
            for (l, &p) in local[strand.clone()].iter().zip(&placed.positions()[strand]) {
                in_head_space = in_head_space.max(l.distance(head.inverse_transform_point(p)));
            }
        }
        followers_checked += following.len();
        // Placed every fifth step only: the switches at 30 and 45 place the rest first.
        if k % 5 == 0 {
            left.place_followers();
            assert!(!left.followers_pending());
            let apart = placed.positions().iter().zip(left.positions()).filter(|(p, q)| p != q).count();
            assert_eq!(apart, 0, "step {k}: placed later, {apart} particles differ");
        }
    }
    // Stepped the usual way again, nothing is left waiting to be placed at an old pose.
    let shifted = |k: usize| Pose::new(looking_around(k).rotation, looking_around(k).translation + shift);
    left.step(&input(80, DT, (shifted(80), shifted(81)), &groom.collider, &params));
    assert!(!left.followers_pending(), "step placed the followers, yet some wait");
    println!("{followers_checked} follower placements in head space, at most {:.3} µm apart", in_head_space * 1e6);
    assert!(followers_checked > 5_000, "too few followers to check: {followers_checked}");
    assert!(in_head_space <= 1e-6, "in head space a follower lands {} µm from step's", in_head_space * 1e6);
}
