//! Deterministic solver tests with measured numbers (run with `--nocapture` to see them).

mod common;

use common::{Groom, GroomSpec, groom_on_upper_half, max_distance_from_rest, step_input as input};
use hair_sim::prelude::*;
use std::sync::OnceLock;

const DT: f32 = 1.0 / 60.0;

/// 48 strands × 12 particles, 20 cm long, on the upper half of a 1,280-triangle head.
fn groom() -> &'static Groom {
    static GROOM: OnceLock<Groom> = OnceLock::new();
    GROOM.get_or_init(|| {
        groom_on_upper_half(GroomSpec { subdivisions: 3, grid: 32, strands: 48, particles: 12, curl: 0.1, seed: 3 })
    })
}

/// The head turning, nodding and bobbing: a few rad/s and ~0.5 m/s, like a lively character.
fn moving_head(k: usize) -> Pose {
    let t = k as f32 * DT;
    Pose::new(
        Quat::from_rotation_y(0.9 * (2.1 * t).sin()) * Quat::from_rotation_x(0.4 * (3.3 * t).sin()),
        Vec3::new(0.08 * (1.7 * t).sin(), 1.6 + 0.03 * (4.0 * t).sin(), 0.0),
    )
}

/// Runs `steps` steps with the head still at the identity pose.
fn run_still(strands: &mut Strands, params: &SimParams, steps: usize, collider: Option<&HeadCollider>) {
    for k in 0..steps {
        strands.step(&input(k, Pose::IDENTITY, Pose::IDENTITY, collider, params));
    }
}

fn bits(v: &[Vec3]) -> Vec<[u32; 3]> {
    v.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

// (a) -------------------------------------------------------------------------------------

#[test]
fn chunked_stepping_is_bit_identical_to_step() {
    let g = groom();
    // Soft hair that drapes onto the head and neck, so the run has contacts.
    let mut params = SimParams { global_stiffness_root: 0.02, local_stiffness: 0.1, ..SimParams::default() };
    params.wind.strength = 4.0; // per-strand gusts: a wrong `first_strand` would show
    params.wind.direction = [1.0, 0.0, 0.5];
    let neck = [ExtraCollider::Capsule { a: Vec3::new(0.0, 1.5, -0.01), b: Vec3::new(0.0, 1.3, -0.02), radius: 0.05 }];
    let strand_count = g.rest.strand_count();
    assert_eq!(strand_count % 7, 6, "7-strand chunks leave a short last chunk");

    let mut reference = Strands::new(g.rest.clone(), moving_head(0));
    let mut chunked: Vec<(usize, Strands)> =
        [1, 7, strand_count, 1000].iter().map(|&k| (k, reference.clone())).collect();
    let (mut contacts, mut teleports) = (0u32, 0u32);
    for k in 0..120 {
        let step = StepInput {
            extra_colliders: &neck,
            surface_patch: None,
            ..input(k, moving_head(k), moving_head(k + 1), Some(&g.collider), &params)
        };
        let expected = reference.step(&step);
        contacts += expected.contacts;
        teleports += expected.teleport_resets;
        for (size, strands) in &mut chunked {
            let mut report = StepReport::default();
            if *size == 7 {
                // On threads, as a renderer would.
                let reports: Vec<StepReport> = std::thread::scope(|s| {
                    let handles: Vec<_> =
                        strands.chunks_mut(7).into_iter().map(|mut chunk| s.spawn(move || chunk.step(&step))).collect();
                    handles.into_iter().map(|h| h.join().unwrap()).collect()
                });
                reports.into_iter().for_each(|r| report.merge(r));
            } else {
                // Backwards, to show the chunks do not depend on each other.
                for mut chunk in strands.chunks_mut(*size).into_iter().rev() {
                    report.merge(chunk.step(&step));
                }
            }
            assert_eq!(report, expected, "step {k}, chunks of {size}: merged report");
        }
    }
    for (size, strands) in &chunked {
        assert_eq!(bits(strands.positions()), bits(reference.positions()), "chunks of {size}: positions");
        assert_eq!(bits(strands.velocities()), bits(reference.velocities()), "chunks of {size}: velocities");
    }
    // The run exercised what could differ between chunkings: real motion and contacts.
    let pose = moving_head(120);
    let moved = max_distance_from_rest(&reference, &g.rest, pose);
    println!("chunking: 120 steps, {contacts} contacts, {teleports} teleports, max deviation from rest {moved:.4} m");
    assert!(contacts > 0, "no contacts: the test would not cover collision");
    assert_eq!(teleports, 0);
    assert!(moved > 0.01, "strands barely moved: {moved}");
}

/// Every SIMD path this CPU has steps the same bits as the portable one: both length
/// models, wind, a neck capsule, the head moving, one 1-second hitch and a 60 rad/s whip
/// (so that collision, turns and the final length pass all run). 48 strands also leave a
/// wide group partly empty.
#[test]
fn every_simd_path_steps_the_same_bits() {
    let g = groom();
    let neck = [ExtraCollider::Capsule { a: Vec3::new(0.0, 1.5, -0.01), b: Vec3::new(0.0, 1.3, -0.02), radius: 0.05 }];
    let paths: Vec<SimdPath> =
        [SimdPath::Baseline, SimdPath::Avx2, SimdPath::Avx512].into_iter().filter(|p| p.is_available()).collect();
    println!("SIMD paths on this CPU: {paths:?}");
    let whip = |k: usize| Pose::new(Quat::from_rotation_y(k as f32 * DT * 60.0), Vec3::new(0.0, 1.6, 0.0));
    for length_mode in [LengthMode::Inextensible, LengthMode::Springs] {
        let run = |simd: SimdPath| {
            let mut params = SimParams { length_mode, global_stiffness_root: 0.02, simd, ..SimParams::default() };
            params.wind.strength = 4.0;
            let mut strands = Strands::new(g.rest.clone(), moving_head(0));
            let mut reports = Vec::new();
            for k in 0..150 {
                let (from, to, dt) = match k {
                    0..60 => (moving_head(k), moving_head(k + 1), DT),
                    60 => (moving_head(60), moving_head(120), 1.0),
                    61..90 => (moving_head(k + 59), moving_head(k + 60), DT),
                    _ => (whip(k), whip(k + 1), DT),
                };
                let step = StepInput { dt, extra_colliders: &neck, ..input(k, from, to, Some(&g.collider), &params) };
                reports.push(strands.step(&step));
            }
            (strands, reports)
        };
        let (reference, reference_reports) = run(SimdPath::Baseline);
        let contacts: u32 = reference_reports.iter().map(|r| r.contacts).sum();
        assert!(contacts > 0, "{length_mode:?}: no contacts, collision would go untested");
        for &path in &paths[1..] {
            let (strands, reports) = run(path);
            assert_eq!(reports, reference_reports, "{length_mode:?} on {path}: reports");
            assert_eq!(bits(strands.positions()), bits(reference.positions()), "{length_mode:?} on {path}: positions");
            assert_eq!(bits(strands.velocities()), bits(reference.velocities()), "{length_mode:?} on {path}");
        }
        println!("{length_mode:?}: {} paths agree bit for bit over 150 steps, {contacts} contacts", paths.len());
    }
}

// (b) -------------------------------------------------------------------------------------

/// RMS distance between the strands and their rest pose (head at identity).
fn shape_error(strands: &Strands, rest: &RestShape) -> f32 {
    let sum: f32 = strands.positions().iter().zip(&rest.positions).map(|(&p, &r)| (p - r).length_squared()).sum();
    (sum / rest.positions.len() as f32).sqrt()
}

/// Shape error after each of 60 steps (1 s), from the same perturbed start.
fn recovery(
    perturbed: &Strands,
    rest: &RestShape,
    stiffness: f32,
    substeps: u32,
    iterations: u32,
    drag: f32,
) -> Vec<f32> {
    let params = SimParams {
        substeps,
        iterations,
        drag,
        gravity: [0.0; 3],
        local_stiffness: 0.0,
        global_stiffness_root: stiffness,
        global_stiffness_tip: stiffness,
        collision: false,
        ..SimParams::default()
    };
    let mut strands = perturbed.clone();
    let mut errors = vec![shape_error(&strands, rest)];
    for k in 0..60 {
        strands.step(&input(k, Pose::IDENTITY, Pose::IDENTITY, None, &params));
        errors.push(shape_error(&strands, rest));
    }
    errors
}

#[test]
fn global_stiffness_does_not_depend_on_substeps_or_iterations() {
    let g = groom();
    // Perturb: blow the hair sideways (20 m/s² along +X, no shape keeping, overdamped).
    let bend = SimParams {
        gravity: [20.0, 0.0, 0.0],
        local_stiffness: 0.0,
        global_stiffness_root: 0.0,
        global_stiffness_tip: 0.0,
        collision: false,
        drag: 8.0,
        ..SimParams::default()
    };
    let mut perturbed = Strands::new(g.rest.clone(), Pose::IDENTITY);
    run_still(&mut perturbed, &bend, 60, None);
    let e0 = shape_error(&perturbed, &g.rest);
    assert!(e0 > 0.05, "perturbation too small: {e0}");

    // The stiffness is "fraction removed per 1/60 s": 0.5 should halve the error about
    // once a frame however often it is applied. Measure: the mean per-frame decay of the
    // RMS shape error over the first 12 frames (0.2 s). After ~20 frames the error sits at
    // the f32 floor (1e-8..1e-7 m), so the error left at 1 s is noise, not a comparison.
    //
    // Overdamped (drag 1000) isolates the constraint: there the measure separates
    // stiffness 0.4 from 0.5 by ~20%. With inertia (default drag 1) corrections made in
    // one substep keep moving the hair in the next, so 4 × 3 recovers faster in the first
    // frames (error after 1 frame 1.8e-2 vs 7.5e-2 m) and then wobbles; the 0.2 s decay
    // rate still agrees within 10% but cannot tell 0.4 from 0.5 there, so that case only
    // guards against a missing conversion (applying 0.5 per application, emulated below).
    const WINDOW: usize = 12;
    let rate = |e: &[f32]| (e[WINDOW] / e[0]).powf(1.0 / WINDOW as f32);
    let show = |e: &[f32]| [1, 2, 4, 8, 12, 30, 60].map(|k| format!("{k}:{:.2e}", e[k])).join(" ");
    for drag in [1000.0, 1.0] {
        let one = recovery(&perturbed, &g.rest, 0.5, 1, 1, drag);
        let many = recovery(&perturbed, &g.rest, 0.5, 4, 3, drag);
        // Per-application stiffness 0.5 at 4 × 3 = 12 applications a frame.
        let naive = recovery(&perturbed, &g.rest, 1.0 - 0.5f32.powi(12), 4, 3, drag);
        let softer = recovery(&perturbed, &g.rest, 0.4, 1, 1, drag);
        let (r1, r12, r_naive, r_soft) = (rate(&one), rate(&many), rate(&naive), rate(&softer));
        let off = |r: f32| (r / r1 - 1.0).abs();
        println!("drag {drag}: initial error {e0:.4} m; error after k frames, per-frame decay over 0.2 s");
        println!("  1 substep  × 1 iteration : {}  decay {r1:.4}", show(&one));
        println!("  4 substeps × 3 iterations: {}  decay {r12:.4} ({:.1}% off)", show(&many), off(r12) * 100.0);
        println!("  naive per-application 0.5: decay {r_naive:.4} ({:.1}% off)", off(r_naive) * 100.0);
        println!("  stiffness 0.4, 1 × 1     : decay {r_soft:.4} ({:.1}% off)", off(r_soft) * 100.0);
        assert!(off(r12) < 0.10, "drag {drag}: decay per frame {r1} (1×1) vs {r12} (4×3)");
        assert!(off(r_naive) > 0.3, "drag {drag}: the measure misses a missing conversion: {r_naive}");
        if drag > 1.0 {
            assert!(off(r_soft) > 0.12, "the measure cannot tell 0.4 from 0.5: {r_soft} vs {r1}");
            assert!((r1 - 0.5).abs() < 0.03, "overdamped decay should be the nominal 0.5 per frame: {r1}");
        }
        // Nothing measurable is left after 1 s in either run.
        assert!(one[60] < 1e-5 * e0 && many[60] < 1e-5 * e0, "{} {}", one[60], many[60]);
    }
}

// (c) -------------------------------------------------------------------------------------

#[test]
fn springs_keep_every_segment_within_tolerance_while_hanging() {
    let g = groom();
    let params = SimParams { length_mode: LengthMode::Springs, ..SimParams::default() };
    assert_eq!(params.length_tolerance, 0.1);
    // Settled, so that the hair hangs (as grown it stands off the head, and local shape
    // holds much of its weight by bending).
    let rest = settle(g.rest.clone(), Some(&g.collider), &SimParams::default(), 60, Vec3::ZERO).expect("settle");
    let mut strands = Strands::new(rest.clone(), Pose::IDENTITY);
    let mut worst = 0.0f32;
    let mut contacts = 0;
    for k in 0..300 {
        contacts += strands.step(&input(k, Pose::IDENTITY, Pose::IDENTITY, Some(&g.collider), &params)).contacts;
        worst = worst.max(strands.max_stretch());
    }
    let n = strands.particles_per_strand();
    let mut stretched = 0usize;
    let mut sum = 0.0f32;
    for i in (0..strands.positions().len()).filter(|i| i % n != 0) {
        let ratio = (strands.positions()[i] - strands.positions()[i - 1]).length() / rest.lengths[i];
        sum += ratio - 1.0;
        stretched += usize::from(ratio > 1.05);
    }
    let mean = sum / (strands.positions().len() - strands.strand_count()) as f32;
    let end = strands.max_stretch();
    println!(
        "springs, 5 s hanging: max stretch over the run {worst:.6}, at the end {end:.6}, mean {mean:.4}, \
         {stretched} segments > 5%, {contacts} contacts"
    );
    assert!(worst <= 0.1 + 1e-5, "a segment left the tolerance: {worst}");
    // The bound is doing work: gravity stretched the springs right up to it, and at rest
    // they still carry the hair's weight (the head and local shape's bends carry the
    // rest, so the end is below the bound).
    assert!(worst > 0.099, "springs should sag to the clamp, got {worst}");
    assert!(end > 0.08, "springs at rest should carry the weight, the most stretched at {end}");
    assert!(mean > 0.01 && stretched > 0, "mean stretch {mean}");
}

/// Hair under a still head, without wind or collision, comes to rest at every substep
/// count: only drag and the constraints act, and the settled groom's swing into the
/// simulation's balance dies away (printed: the largest move in the step at 8 s).
/// Local shape as a follower force (the child pulled, its parent not pushed back) would
/// keep hair swinging for good, by centimetres at 8 substeps.
#[test]
fn hair_comes_to_rest_under_a_still_head_at_every_substep_count() {
    let g = groom();
    let rest = settle(g.rest.clone(), Some(&g.collider), &SimParams::default(), 60, Vec3::ZERO).expect("settle");
    for substeps in [1, 2, 3, 4, 8] {
        let params = SimParams { substeps, collision: false, ..SimParams::default() };
        let mut strands = Strands::new(rest.clone(), Pose::IDENTITY);
        let mut largest = 0.0f32;
        for k in 0..480 {
            let before = strands.positions().to_vec();
            strands.step(&input(k, Pose::IDENTITY, Pose::IDENTITY, None, &params));
            largest = before.iter().zip(strands.positions()).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
        }
        println!("{substeps} substeps: the largest move in the step at 8 s {:.2} µm", largest * 1e6);
        assert!(largest < 1e-5, "{substeps} substeps: hair still moves {largest} m a step after 8 s");
    }
}

// (d) -------------------------------------------------------------------------------------

fn mean_tip_x(strands: &Strands) -> f32 {
    let n = strands.particles_per_strand();
    strands.positions().chunks_exact(n).map(|s| s[n - 1].x).sum::<f32>() / strands.strand_count() as f32
}

#[test]
fn wind_along_x_moves_the_tips_along_x() {
    let g = groom();
    let run = |strength: f32| {
        let params = SimParams {
            wind: Wind { direction: [1.0, 0.0, 0.0], strength, ..Wind::default() },
            ..SimParams::default()
        };
        let mut strands = Strands::new(g.rest.clone(), Pose::IDENTITY);
        run_still(&mut strands, &params, 120, Some(&g.collider));
        mean_tip_x(&strands)
    };
    let (calm, windy, reverse) = (run(0.0), run(5.0), run(-5.0));
    println!("mean tip x after 2 s: no wind {calm:.4} m, +X wind 5 m/s² {windy:.4} m, −5 {reverse:.4} m");
    // Measured: +1.5 cm and −0.9 cm (the head is in the way on one side); assert half.
    assert!(windy - calm > 0.007, "+X wind moved tips by {}", windy - calm);
    assert!(calm - reverse > 0.004, "−X wind moved tips by {}", reverse - calm);
}

/// A root moved within the rest shape (a skinned scalp) is where the next step pins it, in
/// every kind of SIMD group: 48 strands make full groups, whose rest shape loads as whole
/// vectors, and a part-empty one, which loads strand by strand.
#[test]
fn moved_rest_roots_are_pinned_in_every_group() {
    let g = groom();
    let params = SimParams::default();
    let n = g.rest.particles_per_strand;
    let mut strands = Strands::new(g.rest.clone(), moving_head(0));
    let moved: Vec<(usize, Vec3)> = [0, 5, 17, 31, 32, 47]
        .into_iter()
        .map(|s| (s, g.rest.positions[s * n] + Vec3::new(0.004, -0.003, 0.002) * (1.0 + s as f32 / 48.0)))
        .collect();
    for &(strand, root) in &moved {
        strands.set_rest_root(strand, root);
    }
    for path in [SimdPath::Baseline, SimdPath::Auto] {
        let params = SimParams { simd: path, ..params };
        let mut stepped = strands.clone();
        stepped.step(&input(0, moving_head(0), moving_head(1), Some(&g.collider), &params));
        let pose = moving_head(1);
        for strand in 0..strands.strand_count() {
            let rest_root = moved.iter().find(|m| m.0 == strand).map_or(g.rest.positions[strand * n], |m| m.1);
            let off = stepped.positions()[strand * n].distance(pose.transform_point(rest_root));
            assert!(off < 1e-6, "{path:?}: strand {strand}'s root is {off} m from its rest root");
        }
    }
}

// Teleports -------------------------------------------------------------------------------

#[test]
fn a_ten_metre_jump_resets_every_strand_to_rest() {
    let g = groom();
    let params = SimParams::default();
    let mut strands = Strands::new(g.rest.clone(), Pose::IDENTITY);
    run_still(&mut strands, &params, 30, Some(&g.collider));
    let far = Pose::new(Quat::from_rotation_y(1.0), Vec3::new(10.0, 0.0, 0.0));
    let report = strands.step(&input(30, Pose::IDENTITY, far, Some(&g.collider), &params));
    let off = max_distance_from_rest(&strands, &g.rest, far);
    println!("10 m jump: {report:?}, max distance from the rest pose {off:e} m");
    assert_eq!(report.teleport_resets as usize, strands.strand_count());
    assert!(off < 1e-5, "{off}");
    assert!(strands.velocities().iter().all(|v| *v == Vec3::ZERO));
}

#[test]
fn tiny_steps_are_skipped_without_resets_or_fast_particles() {
    let g = groom();
    let params = SimParams::default();
    let mut strands = Strands::new(g.rest.clone(), Pose::IDENTITY);
    run_still(&mut strands, &params, 30, Some(&g.collider));
    let (before, speeds) = (strands.positions().to_vec(), strands.velocities().to_vec());
    // The head moved 1 mm: a 1e-40 s step reset every strand as non-finite, and a 1e-9 s
    // one turned a 1.3 mm push-out into 15 m/s. Both are skipped now.
    let moved = Pose::from_translation(Vec3::new(0.001, 0.0, 0.0));
    for dt in [1e-40, 1e-9, 5e-7] {
        let step = StepInput { dt, ..input(30, Pose::IDENTITY, moved, Some(&g.collider), &params) };
        let report = strands.step(&step);
        println!("dt = {dt:e} s: {report:?}");
        assert_eq!((report.teleport_resets, report.nan_resets), (0, 0), "dt = {dt:e}");
        assert_eq!(strands.positions(), &before[..], "dt = {dt:e}: skipped, nothing moves");
        assert_eq!(strands.velocities(), &speeds[..], "dt = {dt:e}: skipped, no velocity changes");
    }
    // From MIN_STEP up, steps run.
    let step = StepInput { dt: 2e-6, ..input(30, Pose::IDENTITY, moved, Some(&g.collider), &params) };
    strands.step(&step);
    assert!(strands.positions() != &before[..]);
    assert!(strands.positions().iter().all(|p| p.is_finite()));
}

/// `LengthMode::Springs` promises that every segment stays within `length_tolerance`,
/// also when collision pushes particles around: a head moving at 3 m/s through its own
/// hair once left segments 93% long, before the clamp ran again after collision.
#[test]
fn springs_keep_tolerance_when_the_head_moves_through_the_hair() {
    let g = groom();
    let params = SimParams { length_mode: LengthMode::Springs, ..SimParams::default() };
    let mut strands = Strands::new(g.rest.clone(), Pose::IDENTITY);
    let mut worst = 0.0f32;
    for k in 0..30 {
        let pose = |k: usize| Pose::from_translation(Vec3::new(0.0, 0.0, 0.05 * k as f32));
        strands.step(&input(k, pose(k), pose(k + 1), Some(&g.collider), &params));
        worst = worst.max(strands.max_stretch());
    }
    println!("springs, head moving 5 cm per step along +Z: worst stretch {worst}");
    assert!(worst <= params.length_tolerance + 1e-4, "stretch {worst} > tolerance 0.1");
}

/// `StepReport::contacts` sums the contacts of every substep, so draped hair reports
/// about as many more contacts as it has more substeps (awake: a sleeping strand is not
/// stepped, and touches nothing).
#[test]
fn contacts_sum_over_substeps() {
    let g = groom();
    let draped = |substeps: u32| {
        let params = SimParams {
            substeps,
            local_stiffness: 0.0,
            global_stiffness_root: 0.0,
            sleep_distance: 0.0,
            ..SimParams::default()
        };
        let mut strands = Strands::new(g.rest.clone(), Pose::IDENTITY);
        run_still(&mut strands, &params, 299, Some(&g.collider));
        strands.step(&input(299, Pose::IDENTITY, Pose::IDENTITY, Some(&g.collider), &params)).contacts
    };
    let (one, eight) = (draped(1), draped(8));
    println!("contacts reported in one step after draping: 1 substep {one}, 8 substeps {eight}");
    assert!(one > 0);
    assert!((eight as f32) > 4.0 * one as f32, "{eight} vs {one}");
}

/// Local shape chains a frame from root to tip. Along 64 particles, a frame whose
/// rounding were fed back into the next rotation would grow without bound within a few
/// steps (and the strands would keep being reset as non-finite).
#[test]
fn long_curly_strands_never_go_non_finite() {
    let long =
        groom_on_upper_half(GroomSpec { subdivisions: 3, grid: 32, strands: 32, particles: 64, curl: 0.3, seed: 9 });
    let params = SimParams::default();
    let mut strands = Strands::new(long.rest.clone(), moving_head(0));
    let (mut resets, mut worst) = (0, 0.0f32);
    for k in 0..120 {
        let report = strands.step(&input(k, moving_head(k), moving_head(k + 1), Some(&long.collider), &params));
        resets += report.nan_resets;
        worst = worst.max(strands.max_stretch());
    }
    println!("64-particle strands, 120 steps of a moving head: {resets} non-finite resets, worst stretch {worst}");
    assert_eq!(resets, 0, "strands went non-finite");
    assert!(strands.positions().iter().all(|p| p.is_finite()));
    assert!(worst <= 1e-3, "stretch {worst}");
}

// Friction ----------------------------------------------------------------------------------

/// The head turning back and forth about its vertical axis at up to 6 rad/s: the hair resting
/// on it slides over the scalp unless friction holds it. Measured in the head's frame: how
/// far the particles within 4 mm of the surface (on the 3 mm shell, touching) move along it
/// per step, on average, with friction off and full.
#[test]
fn friction_holds_the_hair_resting_on_a_turning_head() {
    let g = groom();
    // Settled, so that the hair lies on the head (as grown it stands off it).
    let rest = settle(g.rest.clone(), Some(&g.collider), &SimParams::default(), 60, Vec3::ZERO).expect("settle");
    let turning = |k: usize| Pose::new(Quat::from_rotation_y(0.6 * (10.0 * k as f32 * DT).sin()), Vec3::ZERO);
    let slide = |friction: f32| {
        let params = SimParams { friction, ..SimParams::default() };
        let mut strands = Strands::new(rest.clone(), turning(0));
        let n = strands.particles_per_strand();
        let (mut moved, mut count) = (0.0f32, 0usize);
        let mut before: Vec<Vec3> =
            strands.positions().iter().map(|&p| turning(0).inverse_transform_point(p)).collect();
        for k in 0..120 {
            strands.step(&input(k, turning(k), turning(k + 1), Some(&g.collider), &params));
            let now: Vec<Vec3> =
                strands.positions().iter().map(|&p| turning(k + 1).inverse_transform_point(p)).collect();
            for (i, (&a, &b)) in before.iter().zip(&now).enumerate() {
                // Settled by then, and resting on the head at both ends of the step.
                let resting = |p: Vec3| g.collider.signed_distance(p) < 0.004;
                if k >= 30 && i % n != 0 && resting(a) && resting(b) {
                    moved += (b - a).length();
                    count += 1;
                }
            }
            before = now;
        }
        (moved / count.max(1) as f32, count)
    };
    let ((free, free_count), (held, held_count)) = (slide(0.0), slide(1.0));
    println!(
        "mean slide per step of resting particles: friction 0 {:.3} mm ({free_count}), friction 1 {:.3} mm ({held_count})",
        free * 1e3,
        held * 1e3
    );
    assert!(free_count > 1000 && held_count > 1000, "particles rest on the head");
    // Friction cannot hold the resting part entirely: the bends of the hair off the head
    // drag it a little. Well under half the frictionless slide is what it must keep.
    assert!(held < 0.35 * free, "friction 1 slides {held} m a step, friction 0 {free} m");
}
