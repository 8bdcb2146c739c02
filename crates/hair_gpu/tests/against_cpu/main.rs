//! The GPU solver against the CPU solver on the same groom and head motion, on whatever
//! adapter there is (lavapipe on a machine without a GPU). Without an adapter each test
//! says why it skipped, or fails when `BEVY_HAIR_REQUIRE_ADAPTER` is set (as `.ci/run`
//! sets it).

use hair_gpu::{GpuContext, GpuError, GpuStrands, StepTime};
use hair_sim::collide::SurfacePatch;
use hair_sim::prelude::*;
use std::sync::{Mutex, MutexGuard};

mod drawing;
mod volume;

/// Head keyframes: (time s, yaw rad, pitch rad); a turn, a nod and a fast shake, as the
/// CPU bench moves its head.
const KEYS: [(f32, f32, f32); 6] =
    [(0.0, 0.0, 0.0), (0.5, 0.8, 0.0), (1.0, -0.8, 0.3), (1.25, 0.5, -0.2), (1.5, -0.5, 0.0), (2.0, 0.0, 0.0)];

fn head_pose(time: f32) -> Pose {
    let t = time.rem_euclid(KEYS[KEYS.len() - 1].0);
    let k = KEYS.windows(2).position(|w| t < w[1].0).unwrap_or(KEYS.len() - 2);
    let ((t0, yaw0, pitch0), (t1, yaw1, pitch1)) = (KEYS[k], KEYS[k + 1]);
    let f = (t - t0) / (t1 - t0);
    let s = f * f * (3.0 - 2.0 * f);
    let rotation =
        Quat::from_rotation_y(yaw0 + (yaw1 - yaw0) * s) * Quat::from_rotation_x(pitch0 + (pitch1 - pitch0) * s);
    Pose::new(rotation, Vec3::new(0.0, 1.6, 0.0))
}

/// The adapter, held by one test at a time: lavapipe already runs a dispatch on every core,
/// and tests that share them all slow each other down several times over.
struct Gpu {
    context: GpuContext,
    _turn: MutexGuard<'static, ()>,
}

impl std::ops::Deref for Gpu {
    type Target = GpuContext;
    fn deref(&self) -> &GpuContext {
        &self.context
    }
}

fn gpu() -> Option<Gpu> {
    static TURN: Mutex<()> = Mutex::new(());
    let turn = TURN.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    match GpuContext::headless() {
        Ok(gpu) => {
            eprintln!("adapter: {} ({:?})", gpu.adapter.name, gpu.adapter.backend);
            Some(Gpu { context: gpu, _turn: turn })
        }
        Err(e) if std::env::var_os("BEVY_HAIR_REQUIRE_ADAPTER").is_some() => {
            panic!("BEVY_HAIR_REQUIRE_ADAPTER is set and there is {e}")
        }
        Err(e) => {
            eprintln!("skipped: {e}");
            None
        }
    }
}

/// `guides` strands of 16 particles grown on the procedural head's scalp and settled on it.
fn groom(guides: usize) -> (HeadMesh, HeadCollider, RestShape) {
    let head = test_head(4);
    let collider = HeadCollider::new(&head, DEFAULT_GRID_RESOLUTION).expect("procedural head");
    let scalp = test_scalp(&head);
    let roots = sample_roots(&head, &scalp, guides, 7).expect("scalp");
    let params = GuideParams { segments: 15, length: 0.25, ..GuideParams::default() };
    let rest = RestShape::new(grow_guides(&head, &roots, &params, 7).expect("roots"), 16).expect("guides");
    let rest = settle(rest, Some(&collider), &SimParams::default(), 60, Vec3::ZERO).expect("settle");
    (head, collider, rest)
}

/// The step length, seconds: 60 Hz.
const DT: f32 = 1.0 / 60.0;

/// Step `k` of a head moving as `pose_at`, colliding with `collider` and nothing else.
fn input_at<'a>(
    k: usize,
    pose_at: impl Fn(f32) -> Pose,
    collider: &'a HeadCollider,
    params: &'a SimParams,
) -> StepInput<'a> {
    let time = k as f32 * DT;
    StepInput {
        dt: DT,
        time,
        head_from: pose_at(time),
        head_to: pose_at(time + DT),
        collider: Some(collider),
        extra_colliders: &[],
        surface_patch: None,
        params,
    }
}

/// Steps both solvers `steps` times at 60 Hz and returns both position sets.
fn run_both(
    gpu: &GpuContext,
    rest: &RestShape,
    collider: &HeadCollider,
    params: &SimParams,
    steps: usize,
    pose_at: impl Fn(f32) -> Pose,
) -> (Vec<Vec3>, Vec<Vec3>) {
    let [(cpu, _), (on_gpu, _)] = run_both_reporting(gpu, rest, collider, params, &[], steps, pose_at, None);
    (cpu, on_gpu)
}

/// [`run_both`] with extra colliders, and what each backend's steps reported, summed (the
/// CPU's reports merged step by step, the GPU's taken once at the end); `twins`, if any,
/// stepped alongside the CPU.
#[allow(clippy::too_many_arguments)]
fn run_both_reporting(
    gpu: &GpuContext,
    rest: &RestShape,
    collider: &HeadCollider,
    params: &SimParams,
    extra_colliders: &[ExtraCollider],
    steps: usize,
    pose_at: impl Fn(f32) -> Pose,
    mut twins: Option<&mut Twins>,
) -> [(Vec<Vec3>, StepReport); 2] {
    let mut cpu = Strands::new(rest.clone(), pose_at(0.0));
    let mut on_gpu = GpuStrands::new(gpu, rest, pose_at(0.0), Some(collider)).expect("GPU strands");
    let mut cpu_report = StepReport::default();
    for k in 0..steps {
        let input = StepInput { extra_colliders, ..input_at(k, &pose_at, collider, params) };
        cpu_report.merge(cpu.step(&input));
        on_gpu.step(&input).expect("GPU step");
        if let Some(twins) = twins.as_deref_mut() {
            twins.step(&input);
        }
    }
    let gpu_report = on_gpu.report().expect("report");
    [(cpu.positions().to_vec(), cpu_report), (on_gpu.positions().expect("read back"), gpu_report)]
}

/// The GPU's report against the CPU's: the same resets; contacts, segment turns and
/// contact stretches within 0.1 % (a contact at the margin goes either way in rounding);
/// the same deepest contact within 1 µm.
fn assert_reports_agree(cpu: &StepReport, gpu: &StepReport) {
    assert_eq!((gpu.teleport_resets, gpu.nan_resets), (cpu.teleport_resets, cpu.nan_resets), "resets");
    let near = |gpu: u32, cpu: u32| gpu.abs_diff(cpu) as f32 <= 1.0 + 1e-3 * cpu as f32;
    assert!(near(gpu.contacts, cpu.contacts), "contacts: GPU {}, CPU {}", gpu.contacts, cpu.contacts);
    assert!(near(gpu.segment_turns, cpu.segment_turns), "turns: GPU {}, CPU {}", gpu.segment_turns, cpu.segment_turns);
    let (g, c) = (gpu.contact_stretches, cpu.contact_stretches);
    assert!(near(g, c), "contact stretches: GPU {g}, CPU {c}");
    assert!((gpu.max_depth - cpu.max_depth).abs() <= 1e-6, "deepest: GPU {}, CPU {}", gpu.max_depth, cpu.max_depth);
}

/// CPU runs started a rounding's worth from the CPU's own (every particle nudged by about
/// an ulp of a coordinate near 1.5 m, each run in another direction), stepped alongside it.
/// Where hair brushes a surface, a contact or a segment's turn can go either way on such a
/// difference, and the two backends round differently: how far these part from the CPU run
/// is the floor under how closely the GPU can follow it.
struct Twins {
    runs: Vec<Strands>,
    /// What each run's steps reported, summed.
    reports: Vec<StepReport>,
}

impl Twins {
    fn new(rest: &RestShape, pose: Pose) -> Self {
        let nudges = [
            Vec3::new(1e-7, -1e-7, 1e-7),
            Vec3::new(-1e-7, 0.0, 1e-7),
            Vec3::new(0.0, 1e-7, -1e-7),
            Vec3::new(-1e-7, 1e-7, 0.0),
            Vec3::new(1e-7, 0.0, -1e-7),
            Vec3::new(0.0, -1e-7, -1e-7),
        ];
        let runs: Vec<Strands> = nudges
            .iter()
            .map(|&nudge| {
                let mut twin = Strands::new(rest.clone(), pose);
                let nudged: Vec<Vec3> = twin.positions().iter().map(|&p| p + nudge).collect();
                twin.set_positions(&nudged).expect("finite");
                twin
            })
            .collect();
        Twins { reports: vec![StepReport::default(); runs.len()], runs }
    }

    fn step(&mut self, input: &StepInput) {
        for (twin, report) in self.runs.iter_mut().zip(&mut self.reports) {
            report.merge(twin.step(input));
        }
    }

    /// The largest mean distance and the largest distance of a twin from `cpu`.
    fn spread(&self, cpu: &[Vec3]) -> (f32, f32) {
        let parted = self.runs.iter().map(|twin| apart(cpu, twin.positions()));
        parted.fold((0.0, 0.0), |(mean, max), (m, x)| (mean.max(m), max.max(x)))
    }

    /// How far a twin's deepest contact lies from `cpu`'s.
    fn depth_spread(&self, cpu: &StepReport) -> f32 {
        self.reports.iter().map(|r| (r.max_depth - cpu.max_depth).abs()).fold(0.0, f32::max)
    }
}

/// How much further from the CPU than its nudged twins the GPU may end: six twins are
/// few samples of how far rounding tips hair that brushes a surface, and the GPU is one more.
const SPREAD_FACTOR: f32 = 3.0;

/// The GPU's distance from the CPU (`apart`: mean, max) against the twins' spread: on
/// average within 10 µm and at the worst within 0.1 mm, or as far as the twins went
/// ([`SPREAD_FACTOR`]).
fn assert_follows(apart: (f32, f32), spread: (f32, f32)) {
    let (mean, max) = apart;
    assert!(
        mean <= 1e-5f32.max(SPREAD_FACTOR * spread.0) && max <= 1e-4f32.max(SPREAD_FACTOR * spread.1),
        "mean {mean} m, max {max} m apart (the CPU from itself nudged: mean {} m, max {} m)",
        spread.0,
        spread.1
    );
}

/// Mean and largest distance between matching particles.
fn apart(a: &[Vec3], b: &[Vec3]) -> (f32, f32) {
    assert_eq!(a.len(), b.len());
    let d: Vec<f32> = a.iter().zip(b).map(|(a, b)| a.distance(*b)).collect();
    (d.iter().sum::<f32>() / d.len() as f32, d.iter().copied().fold(0.0, f32::max))
}

/// How deep the deepest particle (roots aside) lies inside the head posed at `pose`, by
/// the exact mesh (not the grid the GPU collides with); 0 when none is inside.
fn deepest_in_head(positions: &[Vec3], n: usize, collider: &HeadCollider, pose: Pose) -> f32 {
    let depths = positions.iter().enumerate().filter(|(i, _)| i % n != 0);
    depths.map(|(_, &p)| -collider.signed_distance(pose.inverse_transform_point(p))).fold(0.0, f32::max)
}

/// How many segments run through the head (both ends outside, cutting a thin part between
/// them, as through an ear's rim), by the collider's exact test against the triangles. The
/// segment from the root, which sits on the scalp, is left out.
fn crossing_segments(positions: &[Vec3], n: usize, collider: &HeadCollider, pose: Pose) -> usize {
    let local: Vec<Vec3> = positions.iter().map(|&p| pose.inverse_transform_point(p)).collect();
    let segments = local.chunks(n).flat_map(|strand| strand[1..].windows(2));
    segments.filter(|s| collider.segment_crossing(s[0], s[1]).is_some()).count()
}

/// Largest |segment length / rest length − 1|.
fn max_stretch(positions: &[Vec3], rest: &RestShape) -> f32 {
    let n = rest.particles_per_strand;
    (0..positions.len())
        .filter(|i| i % n != 0)
        .map(|i| ((positions[i] - positions[i - 1]).length() / rest.lengths[i] - 1.0).abs())
        .fold(0.0, f32::max)
}

#[test]
fn without_collision_the_gpu_follows_the_cpu_to_rounding() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(256);
    // Wind too, so that the hashing of the gusts is compared.
    let params = SimParams {
        collision: false,
        wind: Wind { direction: [1.0, 0.0, 0.3], strength: 4.0, gust_strength: 0.6, gust_frequency: 1.5 },
        ..SimParams::default()
    };
    let (cpu, on_gpu) = run_both(&gpu, &rest, &collider, &params, 120, head_pose);
    let (mean, max) = apart(&cpu, &on_gpu);
    eprintln!("without collision, after 120 steps: mean {:.2e} m, max {:.2e} m apart", mean, max);
    assert!(on_gpu.iter().all(|p| p.is_finite()));
    // Rounding (the GPU may fuse a multiply and an add) grows along a whipping strand, most
    // at the tips: the bound on the worst particle is far looser than on the mean.
    assert!(mean < 1e-5 && max < 1e-3, "mean {mean} m, max {max} m");
    assert!(max_stretch(&on_gpu, &rest) < 1e-4, "stretch {}", max_stretch(&on_gpu, &rest));
}

#[test]
fn with_collision_the_gpu_stays_near_the_cpu_and_out_of_the_head() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(512);
    let n = rest.particles_per_strand;
    let steps = 120;
    // A shoulder and the neck, where the longest strands reach them (world space).
    let extras = [
        ExtraCollider::Sphere { center: Vec3::new(0.12, 1.28, 0.0), radius: 0.08 },
        ExtraCollider::Capsule { a: Vec3::new(0.0, 1.3, 0.0), b: Vec3::new(0.0, 1.48, 0.0), radius: 0.055 },
    ];
    let responses = [
        ("normal", CollisionResponse::SurfaceNormal),
        ("centre ray", CollisionResponse::CentreRay { offset: [0.0, 0.0, 0.0] }),
    ];
    for (name, collision_response) in responses {
        let params = SimParams { collision_response, ..SimParams::default() };
        let mut twins = Twins::new(&rest, head_pose(0.0));
        let [(cpu, cpu_report), (on_gpu, gpu_report)] =
            run_both_reporting(&gpu, &rest, &collider, &params, &extras, steps, head_pose, Some(&mut twins));
        let (mean, max) = apart(&cpu, &on_gpu);
        let spread = twins.spread(&cpu);
        eprintln!("{name} response, reported over {steps} steps: CPU {cpu_report:?}, GPU {gpu_report:?}");
        let pose = head_pose(steps as f32 * DT);
        let deepest = deepest_in_head(&on_gpu, n, &collider, pose);
        let in_extras = on_gpu
            .iter()
            .flat_map(|&p| extras.iter().filter_map(move |e| e.resolve(p, 0.0)))
            .fold(0.0f32, |deepest, contact| deepest.max(contact.depth));
        let stretch = max_stretch(&on_gpu, &rest);
        let crossing = crossing_segments(&on_gpu, n, &collider, pose);
        eprintln!(
            "{name} response, after {steps} steps: mean {:.4} mm, max {:.2} mm apart (the CPU \
             nudged: {:.4} mm, {:.2} mm), deepest {:.3} mm in the head, {:.3} mm in the extras; \
             stretch {stretch:.1e}; {crossing} segments through the head ({} on the CPU)",
            mean * 1e3,
            max * 1e3,
            spread.0 * 1e3,
            spread.1 * 1e3,
            deepest * 1e3,
            in_extras * 1e3,
            crossing_segments(&cpu, n, &collider, pose)
        );
        assert!(on_gpu.iter().all(|p| p.is_finite()));
        // The same contacts and turns on both, give or take the few that rounding tips.
        assert_reports_agree(&cpu_report, &gpu_report);
        assert!(gpu_report.contacts > 0 && gpu_report.segment_turns > 0, "{gpu_report:?}");
        // The GPU finds the closest points the CPU finds (the same candidate lists) and
        // places and turns segments by the same rules, so the two part by rounding, which
        // contact grows along a strand, and which can tip a contact one way or the other
        // as it tips the CPU's own nudged runs.
        // One strand in a few hundred can still tip where none of the twins does: the
        // GPU is one more sample of rounding. The rest follow as the twins do.
        let bound = 1e-4f32.max(SPREAD_FACTOR * spread.1);
        let tipped = cpu.chunks_exact(n).zip(on_gpu.chunks_exact(n)).filter(|(c, g)| apart(c, g).1 > bound).count();
        eprintln!("{name} response: {tipped} strands part by more than {:.3} mm", bound * 1e3);
        assert!(mean <= 1e-5f32.max(SPREAD_FACTOR * spread.0), "mean {mean} m apart (the twins {} m)", spread.0);
        // The furthest: within the twins' own reach, or a millimetre for the one that tips.
        assert!(tipped <= 1 && max <= bound.max(1e-3), "{tipped} strands tipped, the furthest {max} m");
        // Without the whole-segment test, 1 and 5 of the 7,168 segments below the roots cut
        // an ear's rim.
        assert_eq!(crossing, 0, "segments through the head");
        assert!(deepest <= 5e-4, "{deepest} m inside the head");
        assert!(in_extras <= 5e-4, "{in_extras} m inside a shoulder or the neck");
        assert!(stretch <= 1e-4, "stretch {stretch}");
    }
}

/// The mean drop of the tips below their roots, metres: how far the hair hangs.
fn mean_tip_drop(positions: &[Vec3], n: usize) -> f32 {
    let strands = positions.len() / n;
    positions.chunks_exact(n).map(|s| s[0].y - s[n - 1].y).sum::<f32>() / strands as f32
}

#[test]
fn the_spring_model_follows_the_cpu() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(256);
    let n = rest.particles_per_strand;
    // The reference's stiff springs (held within 10 %).
    let springs = SimParams {
        length_mode: LengthMode::Springs,
        spring_stiffness: 200.0,
        spring_damping: 0.05,
        collision: false,
        ..SimParams::default()
    };
    // Whipped by the head, hanging hair on springs is chaotic: on the CPU alone, a
    // 0.17 µm nudge of every particle grows to 39 mm apart on average in 120 steps (FTL
    // keeps it within 5 µm). So particle by particle the backends are compared over the
    // first 10 steps, where both still follow one trajectory (with collision too, whose
    // passes take the velocities over the spring model's own step) ...
    for collision in [false, true] {
        let params = SimParams { collision, ..springs };
        let (cpu, on_gpu) = run_both(&gpu, &rest, &collider, &params, 10, head_pose);
        let (mean, max) = apart(&cpu, &on_gpu);
        eprintln!("springs, collision {collision}, after 10 steps: mean {mean:.2e} m, max {max:.2e} m apart");
        // A GPU compiler may fuse multiply-adds that the CPU rounds twice, and the stiff
        // solve carries that rounding along the strand (docs/benchmarks.md has the figures
        // per adapter). Taking the velocities over the substep instead of the spring
        // model's step would part the two by millimetres.
        // Since local shape is a bend (lavapipe): 0.09 µm, 1.4 µm; with collision 0.1 µm,
        // 0.75 µm.
        assert!(mean < 3e-6 && max < 5e-4, "mean {mean} m, max {max} m");
    }
    // ... and after 120, with collision too, by what chaos leaves alone: the length bound,
    // how far the hair hangs, no particle inside the head.
    for collision in [false, true] {
        let params = SimParams { collision, ..springs };
        let steps = 120;
        let (cpu, on_gpu) = run_both(&gpu, &rest, &collider, &params, steps, head_pose);
        let stretch = max_stretch(&on_gpu, &rest);
        let (drop_cpu, drop_gpu) = (mean_tip_drop(&cpu, n), mean_tip_drop(&on_gpu, n));
        let pose = head_pose(steps as f32 * DT);
        let deepest = deepest_in_head(&on_gpu, n, &collider, pose);
        eprintln!(
            "springs, collision {collision}, after {steps} steps: stretch {stretch:.4}, tips {:.1} mm (CPU {:.1} mm) \
             below the roots, deepest in the head {:.3} mm",
            drop_gpu * 1e3,
            drop_cpu * 1e3,
            deepest * 1e3
        );
        assert!(on_gpu.iter().all(|p| p.is_finite()));
        assert!(stretch <= params.length_tolerance * 1.001, "stretch {stretch}");
        assert!((drop_gpu - drop_cpu).abs() < 0.005, "tips {drop_gpu} m below the roots, {drop_cpu} m on the CPU");
        if collision {
            assert!(deepest <= 5e-4, "{deepest} m inside the head");
        }
    }
}

#[test]
fn a_teleport_resets_the_strands_as_on_the_cpu() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(64);
    let params = SimParams::default();
    // Ten metres in one step.
    let jump = |t: f32| {
        let pose = head_pose(t);
        if t >= 0.5 { Pose::new(pose.rotation, pose.translation + Vec3::new(10.0, 0.0, 0.0)) } else { pose }
    };
    // The 30th step ends at the jump: both put every strand back at rest there.
    let [(cpu, cpu_report), (on_gpu, gpu_report)] =
        run_both_reporting(&gpu, &rest, &collider, &params, &[], 30, jump, None);
    let (mean, max) = apart(&cpu, &on_gpu);
    eprintln!("reported over 30 steps: CPU {cpu_report:?}, GPU {gpu_report:?}");
    assert_eq!(gpu_report.teleport_resets, 64, "every strand reset once");
    assert_reports_agree(&cpu_report, &gpu_report);
    eprintln!("after a 10 m teleport: mean {:.2e} m, max {:.2e} m apart", mean, max);
    assert!(max < 1e-5, "both reset to the rest pose: {max} m apart");
    let rest_there: Vec<Vec3> = rest.positions.iter().map(|&p| jump(0.5).transform_point(p)).collect();
    assert!(apart(&on_gpu, &rest_there).1 < 1e-5, "at rest under the new pose");
}

/// Under a still head the strands fall asleep on both backends, within a strand of each
/// other at every step (a particle that moved the sleep distance, give or take rounding,
/// restarts one side's watch), all of them before the head moves, and stay where they fell
/// asleep; when the head moves again every one wakes on both.
#[test]
fn strands_fall_asleep_and_wake_as_on_the_cpu() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(64);
    let params = SimParams::default();
    // Two seconds still, then the keyframes.
    let pose_at = |t: f32| head_pose((t - 2.0).max(0.0));
    let mut cpu = Strands::new(rest.clone(), pose_at(0.0));
    let mut on_gpu = GpuStrands::new(&gpu, &rest, pose_at(0.0), Some(&collider)).expect("GPU strands");
    let (mut first_asleep, mut mismatched_steps, mut asleep_before_moving) = (None, 0, 0);
    for k in 0..132 {
        let input = input_at(k, pose_at, &collider, &params);
        let cpu_report = cpu.step(&input);
        on_gpu.step(&input).expect("GPU step");
        let gpu_report = on_gpu.report().expect("report");
        if cpu_report.sleeping > 0 && first_asleep.is_none() {
            first_asleep = Some(k);
        }
        if cpu_report.sleeping != gpu_report.sleeping {
            eprintln!("step {k}: {} asleep on the CPU, {} on the GPU", cpu_report.sleeping, gpu_report.sleeping);
            // A strand whose particle moved a sleep distance, give or take rounding, falls
            // asleep a step earlier or later on one of them.
            assert!(cpu_report.sleeping.abs_diff(gpu_report.sleeping) <= 1, "step {k}");
            mismatched_steps += 1;
        }
        if k == 110 {
            asleep_before_moving = gpu_report.sleeping;
            let (mean, max) = apart(cpu.positions(), &on_gpu.positions().expect("read back"));
            eprintln!(
                "still for 1.85 s: {} of 64 asleep on the GPU, {} on the CPU, {mean:.1e} m, {max:.1e} m apart",
                gpu_report.sleeping, cpu_report.sleeping
            );
            assert!(max < 1e-4, "{max} m apart");
        }
        if k >= 120 {
            assert_eq!((cpu_report.sleeping, gpu_report.sleeping), (0, 0), "the head moves: all awake");
        }
    }
    eprintln!("first asleep at step {first_asleep:?}; {mismatched_steps} steps where the counts differ");
    assert!(first_asleep.is_some_and(|k| k < 90), "asleep from step {first_asleep:?}");
    assert_eq!(asleep_before_moving, 64, "every strand asleep before the head moves");
    let (mean, max) = apart(cpu.positions(), &on_gpu.positions().expect("read back"));
    eprintln!("moving again for 12 steps: {mean:.1e} m, {max:.1e} m apart");
    assert!(mean < 1e-5 && max < 1e-4, "mean {mean} m, max {max} m apart");
}

/// The plugin's default groom of 600 guides, combed back, on the shipped head, still for
/// 4 s without sleeping: some strands lie with a segment over an ear's rim, turned out of
/// it in every step, and there the segment goes back to where it lay instead
/// (`rest_on_rim`). One step more from the CPU's state on both turns the same segments,
/// leaves none through the head (by the CPU's exact test), and lands every particle where
/// the CPU puts it but in at most one strand (a contact that goes one way or the other on
/// an ulp, `docs/simulation.md`). A GPU that kept the turn left those segments millimetres
/// away; one whose trace read a thin part's inside from the distance grid left segments
/// through the rim.
#[test]
fn a_segment_on_an_ears_rim_rests_as_on_the_cpu() {
    let Some(gpu) = gpu() else { return };
    let (head, labels, collider) = shipped_head();
    let weights = hair_sim::groom::triangle_weights(&head, &labels);
    let comb = Vec3::new(0.0, 0.0, -1.5);
    let roots = hair_sim::groom::sample_roots_poisson(&head, &weights, 600, 1).expect("scalp");
    let grow = GuideParams { segments: 10, length: 0.25, length_variation: 0.2, comb, ..GuideParams::default() };
    let n = grow.segments + 1;
    let rest = RestShape::new(grow_guides(&head, &roots, &grow, 1).expect("roots"), n).expect("guides");
    let rest = settle(rest, Some(&collider), &SimParams::default(), 180, comb).expect("settle");
    let params = SimParams { sleep_distance: 0.0, ..SimParams::default() };
    let pose = Pose::new(Quat::IDENTITY, Vec3::new(0.0, 1.6, 0.0));
    let mut cpu = Strands::new(rest.clone(), pose);
    for k in 0..240 {
        cpu.step(&input_at(k, |_| pose, &collider, &params));
    }
    let mut on_gpu = GpuStrands::new(&gpu, &rest, pose, Some(&collider)).expect("GPU strands");
    assert!(on_gpu.set_positions(cpu.positions()) && on_gpu.set_velocities(cpu.velocities()));
    let input = input_at(240, |_| pose, &collider, &params);
    let cpu_report = cpu.step(&input);
    on_gpu.step(&input).expect("GPU step");
    let gpu_report = on_gpu.report().expect("report");
    let on_gpu = on_gpu.positions().expect("read back");
    let local = |x: Vec3| pose.inverse_transform_point(x);
    // The root's segment starts on the scalp, so it is not asked.
    let through: usize = on_gpu
        .chunks_exact(n)
        .map(|s| s.windows(2).skip(1).filter(|w| collider.segment_crossing(local(w[0]), local(w[1])).is_some()).count())
        .sum();
    let apart: Vec<(usize, f32)> = cpu
        .positions()
        .chunks_exact(n)
        .zip(on_gpu.chunks_exact(n))
        .map(|(c, g)| c.iter().zip(g).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max))
        .enumerate()
        .filter(|&(_, d)| d > 1e-5)
        .collect();
    eprintln!(
        "one still step from the CPU's state: {} segments turned on the CPU, {} on the GPU; {through} through \
         the head on the GPU; strands more than 10 µm apart (strand, m): {apart:?}",
        cpu_report.segment_turns, gpu_report.segment_turns
    );
    assert!(cpu_report.segment_turns > 0, "no segment on a rim: the test tests nothing");
    assert_eq!(cpu_report.segment_turns, gpu_report.segment_turns, "segments turned");
    assert_eq!(through, 0, "segments through the head on the GPU");
    assert!(apart.len() <= 1, "{} strands apart", apart.len());
}

/// The shipped head, 1 on each vertex of its painted scalp (0 elsewhere), and its collider.
fn shipped_head() -> (HeadMesh, Vec<f32>, HeadCollider) {
    let asset = head_asset::read_committed().expect("assets/head.glb is committed and parses");
    let head = asset.head_mesh();
    let labels = asset.scalp_vertices().iter().map(|&s| f32::from(u8::from(s))).collect();
    let collider = HeadCollider::new(&head, DEFAULT_GRID_RESOLUTION).expect("the shipped head");
    (head, labels, collider)
}

/// The demo's "Reference" style (the spring model without shape keeping, 1,200 guides of
/// 11 particles on the scalp's vertices, uncombed) on the shipped head, settled, then 5 s
/// still on both backends: strands that hang over an ear's rim or the nape would swing
/// through it and back, but the head's touch may not feed them (`contact_hold`). Both put
/// every strand to sleep, and end a tenth of a millimetre apart on average; the spring
/// model's settling is chaotic (`the_spring_model_follows_the_cpu`), so a few strands
/// come to rest millimetres apart. A GPU without the hold kept 14 strands swinging, and
/// ended most strands more than a millimetre from the CPU's.
#[test]
fn strands_on_springs_rest_where_the_head_holds_them_as_on_the_cpu() {
    let Some(gpu) = gpu() else { return };
    let (collider, rest) = reference_style(true);
    let params = SimParams::reference();
    let pose = |_| Pose::new(Quat::IDENTITY, Vec3::new(0.0, 1.6, 0.0));
    let mut cpu = Strands::new(rest.clone(), pose(0.0));
    let mut on_gpu = GpuStrands::new(&gpu, &rest, pose(0.0), Some(&collider)).expect("GPU strands");
    let steps = 300;
    let mut cpu_report = StepReport::default();
    for k in 0..steps {
        let input = input_at(k, pose, &collider, &params);
        if k + 1 == steps {
            // Only the last step's report.
            on_gpu.report().expect("report");
        }
        cpu_report = cpu.step(&input);
        on_gpu.step(&input).expect("GPU step");
    }
    let gpu_report = on_gpu.report().expect("report");
    let on_gpu = on_gpu.positions().expect("read back");
    let (mean, max) = apart(cpu.positions(), &on_gpu);
    let parted = cpu
        .positions()
        .chunks_exact(11)
        .zip(on_gpu.chunks_exact(11))
        .filter(|(c, g)| c.iter().zip(g.iter()).any(|(a, b)| a.distance(*b) > 1e-3))
        .count();
    eprintln!(
        "after 5 s still: {} of 1200 strands asleep on the CPU, {} on the GPU; {mean:.1e} m, {max:.1e} m apart, \
         {parted} strands by more than 1 mm",
        cpu_report.sleeping, gpu_report.sleeping
    );
    assert_eq!((cpu_report.sleeping, gpu_report.sleeping), (1200, 1200), "asleep on the CPU and the GPU");
    assert!(parted <= 120 && mean < 2e-4, "{parted} strands more than 1 mm apart, {mean} m on average");
}

/// The demo's "Reference" style on the shipped head (hair_sim's `rest.rs` grows the same):
/// 1,200 guides of 11 particles, 25 cm, lengths varied by 20 %, uncombed, its roots on the
/// scalp's vertices or Poisson-disc roots, settled under `SimParams::reference`; with the
/// head's collider.
fn reference_style(on_vertices: bool) -> (HeadCollider, RestShape) {
    let (head, labels, collider) = shipped_head();
    let roots = if on_vertices {
        hair_sim::groom::sample_roots_at_vertices(&head, &labels, 1200, 0.0, 1)
    } else {
        hair_sim::groom::sample_roots_poisson(&head, &hair_sim::groom::triangle_weights(&head, &labels), 1200, 1)
    };
    let grow = GuideParams { segments: 10, length: 0.25, length_variation: 0.2, ..GuideParams::default() };
    let rest =
        RestShape::new(grow_guides(&head, &roots.expect("scalp"), &grow, 1).expect("roots"), 11).expect("guides");
    let rest = settle(rest, Some(&collider), &SimParams::reference(), 180, Vec3::ZERO).expect("settle");
    (collider, rest)
}

/// hair_sim's `a_ball_swept_through_hair_on_springs_under_a_still_head_leaves_none_inside`
/// on the GPU: a ball (4 cm) swept at 0.25 m/s across the back of the still head through
/// the Reference style's hair feeds the strands energy, so the hold, whose step is the one
/// that may keep strands asleep, leaves them alone, and no particle is ever inside the
/// ball. Held, strands went back inside it.
#[test]
fn a_ball_swept_through_hair_on_springs_leaves_none_inside_as_on_the_cpu() {
    let Some(gpu) = gpu() else { return };
    let (collider, rest) = reference_style(false);
    let params = SimParams::reference();
    let head = Vec3::new(0.0, 1.6, 0.0);
    let pose = |_| Pose::from_translation(head);
    let mut on_gpu = GpuStrands::new(&gpu, &rest, pose(0.0), Some(&collider)).expect("GPU strands");
    let radius = 0.04;
    let mut deepest = 0.0f32;
    for k in 0..120 {
        let centre = head + Vec3::new(-0.25 + 0.25 * (k as f32 * DT).min(2.0), 0.05, -0.09);
        let ball = [ExtraCollider::Sphere { center: centre, radius }];
        on_gpu.step(&StepInput { extra_colliders: &ball, ..input_at(k, pose, &collider, &params) }).expect("GPU step");
        let positions = on_gpu.positions().expect("read back");
        deepest = positions.iter().map(|x| radius - x.distance(centre)).fold(deepest, f32::max);
    }
    eprintln!("deepest inside the ball on the GPU: {:.2} mm", deepest * 1e3);
    assert!(deepest <= 1e-4, "{deepest} m inside the ball");
}

/// A particle placed as far out as an `f32` reaches (finite, so `set_positions` takes it)
/// makes its strand's velocity overflow in the first substep: both backends put every such
/// strand back at rest under the step's pose, and say so.
#[test]
fn a_strand_gone_non_finite_is_reset_and_reported_as_on_the_cpu() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(64);
    let n = rest.particles_per_strand;
    let params = SimParams { collision: false, ..SimParams::default() };
    let mut cpu = Strands::new(rest.clone(), head_pose(0.0));
    let mut on_gpu = GpuStrands::new(&gpu, &rest, head_pose(0.0), Some(&collider)).expect("GPU strands");
    // The roots stay (a root that far would be a teleport); every tip goes far out.
    let far: Vec<Vec3> = cpu
        .positions()
        .iter()
        .enumerate()
        .map(|(i, &p)| if i % n == n - 1 { Vec3::new(3e38, 0.0, 0.0) } else { p })
        .collect();
    cpu.set_positions(&far).expect("finite");
    assert!(on_gpu.set_positions(&far), "finite positions are taken");
    let input = input_at(0, head_pose, &collider, &params);
    let cpu_report = cpu.step(&input);
    on_gpu.step(&input).expect("GPU step");
    let gpu_report = on_gpu.report().expect("report");
    eprintln!("tips at 3e38 m: CPU {cpu_report:?}, GPU {gpu_report:?}");
    assert_eq!(cpu_report.nan_resets, 64, "every strand on the CPU");
    assert_reports_agree(&cpu_report, &gpu_report);
    let rest_there: Vec<Vec3> = rest.positions.iter().map(|&p| head_pose(DT).transform_point(p)).collect();
    let on_gpu = on_gpu.positions().expect("read back");
    assert!(apart(&on_gpu, &rest_there).1 < 1e-5, "at rest under the step's pose");
    assert!(apart(cpu.positions(), &rest_there).1 < 1e-5, "the CPU too");
}

/// Infinite gravity, which a public field allows: both backends step on its sanitized form
/// (the default gravity), so neither goes non-finite nor resets a strand, and they agree.
#[test]
fn infinite_gravity_steps_as_its_sanitized_form_on_both() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(64);
    let params = SimParams { gravity: [0.0, f32::NEG_INFINITY, 0.0], collision: false, ..SimParams::default() };
    let steps = 3;
    let [(cpu, cpu_report), (on_gpu, gpu_report)] =
        run_both_reporting(&gpu, &rest, &collider, &params, &[], steps, head_pose, None);
    eprintln!("infinite gravity, {steps} steps: CPU {cpu_report:?}, GPU {gpu_report:?}");
    assert_eq!(gpu_report.nan_resets, 0, "nothing went non-finite");
    assert_reports_agree(&cpu_report, &gpu_report);
    assert!(on_gpu.iter().all(|p| p.is_finite()));
    assert!(apart(&on_gpu, &cpu).1 < 1e-5, "the GPU follows the CPU: {:?}", apart(&on_gpu, &cpu));
    let rest_there: Vec<Vec3> =
        rest.positions.iter().map(|&p| head_pose(steps as f32 * DT).transform_point(p)).collect();
    assert!(apart(&on_gpu, &rest_there).1 > 1e-5, "the hair moved under gravity");
}

/// Where the device has timestamp queries, a step's GPU time comes back with the report
/// and from `step_timed`; before any step, and without them, there is none. With volume
/// the grid's passes are timed too, and counted in the step's time; without it, no grid
/// time is left over from a step that had one.
#[test]
fn a_step_is_timed_on_the_gpu_where_the_device_can_time_it() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(64);
    let params = SimParams::default();
    let with_volume = SimParams { volume: Volume { enabled: true, ..Volume::default() }, ..params };
    let mut strands = GpuStrands::new(&gpu, &rest, head_pose(0.0), Some(&collider)).expect("GPU strands");
    let (_, before) = strands.copy_report().into_timed_report().expect("report");
    assert_eq!(before, None, "no step ran yet");
    // The first step's pass may hold the shader's compile (lavapipe compiles at the first
    // dispatch: 20 s with an empty cache); the next ones are timed.
    for (k, params) in [&params, &with_volume].into_iter().enumerate() {
        strands.step(&input_at(k, head_pose, &collider, params)).expect("GPU step");
        strands.report().expect("report");
    }
    strands.step(&input_at(2, head_pose, &collider, &params)).expect("GPU step");
    let (report, reported) = strands.copy_report().into_timed_report().expect("report");
    let timed = strands.step_timed(&input_at(3, head_pose, &collider, &with_volume)).expect("GPU step");
    let without = strands.step_timed(&input_at(4, head_pose, &collider, &params)).expect("GPU step");
    eprintln!("timestamps {}: reported {reported:?}, timed {timed:?} with volume, {without:?} without", gpu.timestamps);
    assert!(report.contacts > 0, "the report came with the time");
    for (time, volume) in [(reported, false), (timed, true), (without, false)] {
        match time {
            // A step of 64 strands: more than nothing, less than a second even on lavapipe.
            Some(StepTime { total_ms, volume_ms }) => {
                assert!(gpu.timestamps && total_ms > 0.0 && total_ms < 1e3, "{total_ms} ms");
                match volume_ms {
                    Some(ms) => assert!(volume && ms > 0.0 && ms < total_ms, "the grid: {ms} of {total_ms} ms"),
                    None => assert!(!volume, "a step with volume, but no time for its grid"),
                }
            }
            None => assert!(!gpu.timestamps, "timestamps, but no time"),
        }
    }
}

#[test]
fn more_substeps_than_the_buffers_were_made_for_step_as_on_the_cpu() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(64);
    // The settings cap substeps at 64, which the pose table and the substeps' phases are
    // made for; a caller of `hair_gpu` may ask for more, and both grow. 66 substeps, with
    // collision and the segments' pass on the last. (Beyond ~70 substeps of a 60 Hz step
    // the two part by more than rounding within a step, and the CPU alone does too: at 100,
    // a 0.17 µm nudge of every particle ends a step tens of µm away on average, and the GPU
    // millimetres from the CPU, whether or not a substep is split in dispatches.)
    let params = SimParams { substeps: 66, ..SimParams::default() };
    let [(cpu, cpu_report), (on_gpu, gpu_report)] =
        run_both_reporting(&gpu, &rest, &collider, &params, &[], 1, head_pose, None);
    let (mean, max) = apart(&cpu, &on_gpu);
    eprintln!(
        "66 substeps, after a step: mean {mean:.2e} m, max {max:.2e} m apart; CPU {cpu_report:?}, GPU {gpu_report:?}"
    );
    assert!(on_gpu.iter().all(|p| p.is_finite()));
    // Within a step the two still agree to rounding, and count the same contacts.
    assert!(mean < 1e-5 && max < 1e-4, "mean {mean} m, max {max} m apart");
    assert_eq!(gpu_report.nan_resets + gpu_report.teleport_resets, 0, "{gpu_report:?}");
    let (g, c) = (gpu_report.contacts as f32, cpu_report.contacts as f32);
    assert!(c > 0.0 && (g - c).abs() <= 0.01 * c, "contacts: GPU {g}, CPU {c}");
}

#[test]
fn a_one_second_hitch_is_taken_as_on_the_cpu() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(256);
    let params = SimParams::default();
    let n = rest.particles_per_strand;
    let mut cpu = Strands::new(rest.clone(), head_pose(0.0));
    let mut on_gpu = GpuStrands::new(&gpu, &rest, head_pose(0.0), Some(&collider)).expect("GPU strands");
    let mut twins = Twins::new(&rest, head_pose(0.0));
    // 20 steps at 60 Hz, then one frame that took a second while the head turned a radian
    // and a half, then 10 more steps.
    let turned = |t: f32| {
        let pose = head_pose(t);
        if t > 0.34 { Pose::new(Quat::from_rotation_y(1.5) * pose.rotation, pose.translation) } else { pose }
    };
    let mut time = 0.0;
    for k in 0..31 {
        let dt = if k == 20 { 1.0 } else { DT };
        let input = StepInput {
            dt,
            time,
            head_from: turned(time),
            head_to: turned(time + dt),
            collider: Some(&collider),
            extra_colliders: &[],
            surface_patch: None,
            params: &params,
        };
        cpu.step(&input);
        on_gpu.step(&input).expect("GPU step");
        twins.step(&input);
        time += dt;
    }
    let positions = on_gpu.positions().expect("read back");
    let (mean, max) = apart(cpu.positions(), &positions);
    let spread = twins.spread(cpu.positions());
    let depth = deepest_in_head(&positions, n, &collider, turned(time));
    let stretch = max_stretch(&positions, &rest);
    let crossing = crossing_segments(&positions, n, &collider, turned(time));
    eprintln!(
        "after a 1 s hitch: mean {:.4} mm, max {:.4} mm apart (the CPU nudged: {:.4} mm, {:.4} mm), \
         depth {depth:e} m, stretch {stretch:e}; {crossing} segments through the head ({} on the CPU)",
        mean * 1e3,
        max * 1e3,
        spread.0 * 1e3,
        spread.1 * 1e3,
        crossing_segments(cpu.positions(), n, &collider, turned(time))
    );
    assert!(positions.iter().all(|p| p.is_finite()));
    // The turn leaves particles deep inside the head, where no candidate list reaches: the
    // GPU answers a particle's contact there as the CPU does (every triangle tested, then
    // the BVH walked), not by the grid's gradient, which parted the two by millimetres. A
    // contact can still tip either way on rounding, which the nudged CPU's spread shows.
    assert_follows((mean, max), spread);
    assert!(depth <= 5e-4, "{depth} m inside the head");
    assert!(stretch <= 1e-4, "stretch {stretch}");
    assert_eq!(crossing, 0, "segments through the head");
}

#[test]
fn moving_the_origin_the_roots_and_resetting_match_the_cpu() {
    let Some(gpu) = gpu() else { return };
    // 100 strands: three whole groups of the GPU's layout (`layout.wgsl`) and part of one.
    let (_, collider, rest) = groom(100);
    let n = rest.particles_per_strand;
    let params = SimParams { collision: false, ..SimParams::default() };
    let mut cpu = Strands::new(rest.clone(), head_pose(0.0));
    let mut on_gpu = GpuStrands::new(&gpu, &rest, head_pose(0.0), Some(&collider)).expect("GPU strands");
    let step_both = |k: usize, pose_at: &dyn Fn(f32) -> Pose, cpu: &mut Strands, on_gpu: &mut GpuStrands| {
        let input = input_at(k, pose_at, &collider, &params);
        cpu.step(&input);
        on_gpu.step(&input).expect("GPU step");
    };
    for k in 0..10 {
        step_both(k, &head_pose, &mut cpu, &mut on_gpu);
    }
    // The origin moves; two roots slide over the scalp (a skinned scalp's blend).
    let offset = Vec3::new(0.5, -0.25, 2.0);
    cpu.translate(offset);
    on_gpu.translate(offset);
    // The GPU takes every root at once: those two moved, one not finite (left where it
    // was, as the CPU leaves it), the rest where they were.
    let mut roots: Vec<Vec3> = rest.positions.iter().step_by(n).copied().collect();
    for strand in [3, 40] {
        roots[strand] += Vec3::new(0.004, 0.0, -0.003);
        cpu.set_rest_root(strand, roots[strand]);
    }
    roots[7] = Vec3::NAN;
    cpu.set_rest_root(7, roots[7]);
    assert!(on_gpu.set_rest_roots(&roots));
    assert!(!on_gpu.set_rest_roots(&roots[1..]), "one root short");
    // The head is where the shifted strands expect it from here on.
    let shifted = |t: f32| {
        let pose = head_pose(t);
        Pose::new(pose.rotation, pose.translation + offset)
    };
    for k in 10..20 {
        step_both(k, &shifted, &mut cpu, &mut on_gpu);
    }
    let (mean, max) = apart(cpu.positions(), &on_gpu.positions().expect("read back"));
    eprintln!("moved and re-rooted: mean {mean:.2e} m, max {max:.2e} m apart");
    assert!(mean < 1e-6 && max < 1e-4, "mean {mean} m, max {max} m");
    let moved_root = on_gpu.positions().expect("read back")[40 * n];
    assert!(moved_root.distance(shifted(20.0 * DT).transform_point(rest.positions[40 * n])) > 0.004);
    cpu.reset(head_pose(1.0));
    on_gpu.reset(head_pose(1.0));
    let (_, max) = apart(cpu.positions(), &on_gpu.positions().expect("read back"));
    assert!(max < 1e-6, "both at rest: {max} m apart");
}

#[test]
fn the_skin_moving_against_the_head_pushes_as_on_the_cpu() {
    let Some(gpu) = gpu() else { return };
    let (head, collider, rest) = groom(512);
    let n = rest.particles_per_strand;
    // The whole skin swells out by up to 6 mm and back, against the head's frame, under the
    // resting hair (closed, so that no open border of the patch lies under the hair: there
    // a particle beyond the border but behind its face counts as inside).
    let triangles = head.triangles.clone();
    let bind: Vec<Vec3> = head.positions.clone();
    let normals: Vec<Vec3> = bind.iter().map(|p| p.normalize_or(Vec3::Y)).collect();
    let swollen = |t: f32| -> Vec<Vec3> {
        let out = 0.006 * (t * 4.0).sin().max(0.0);
        bind.iter().zip(&normals).map(|(p, n)| *p + *n * out).collect()
    };
    let mut skin = SurfacePatch::new(triangles, swollen(0.0), 0.02);
    let params = SimParams::default();
    let mut cpu = Strands::new(rest.clone(), head_pose(0.0));
    // The same without the skin: what the skin's push is measured against.
    let mut unpushed = Strands::new(rest.clone(), head_pose(0.0));
    let mut on_gpu = GpuStrands::new(&gpu, &rest, head_pose(0.0), Some(&collider)).expect("GPU strands");
    let mut twins = Twins::new(&rest, head_pose(0.0));
    let steps = 120;
    let mut deepest = 0.0f32;
    let (mut cpu_report, mut unpushed_report) = (StepReport::default(), StepReport::default());
    for k in 0..steps {
        let time = k as f32 * DT;
        skin.update(&swollen(time + DT));
        let input = StepInput { surface_patch: Some(&skin), ..input_at(k, head_pose, &collider, &params) };
        cpu_report.merge(cpu.step(&input));
        unpushed_report.merge(unpushed.step(&StepInput { surface_patch: None, ..input }));
        on_gpu.step(&input).expect("GPU step");
        twins.step(&input);
        // How deep behind the moving skin the GPU left a particle, by the CPU's patch
        // (every 10th step: each check reads the GPU back).
        if k % 10 != 9 {
            continue;
        }
        let pose = head_pose(time + DT);
        let positions = on_gpu.positions().expect("read back");
        for (_, &p) in positions.iter().enumerate().filter(|(i, _)| i % n != 0) {
            if let Some(contact) = skin.resolve(pose.inverse_transform_point(p), 0.0) {
                deepest = deepest.max(contact.depth);
            }
        }
    }
    let gpu_report = on_gpu.report().expect("report");
    let on_gpu = on_gpu.positions().expect("read back");
    let (mean, max) = apart(cpu.positions(), &on_gpu);
    let (push, ..) = apart(cpu.positions(), unpushed.positions());
    let spread = twins.spread(cpu.positions());
    let depth_spread = twins.depth_spread(&cpu_report);
    eprintln!("moving skin, reported: CPU {cpu_report:?}, GPU {gpu_report:?}, without the skin {unpushed_report:?}");
    eprintln!(
        "moving skin, after {steps} steps: mean {:.4} mm, max {:.2} mm apart (the CPU nudged: {:.4} mm, \
         {:.2} mm; its deepest contact {:.3} mm from the CPU's); the skin moved the hair {:.2} mm on \
         average; deepest behind the skin {:.3} mm",
        mean * 1e3,
        max * 1e3,
        spread.0 * 1e3,
        spread.1 * 1e3,
        depth_spread * 1e3,
        push * 1e3,
        deepest * 1e3
    );
    assert!(push > 10.0 * mean, "the skin pushes: {push} m on average");
    // The skin's contacts are counted, within a few per cent of each other: hair resting on
    // the moving shell, whose closest points the two compute each their own way, touches
    // it or not by rounding.
    let from_skin = |r: &StepReport| r.contacts as f32 - unpushed_report.contacts as f32;
    assert!(from_skin(&gpu_report) >= 0.9 * from_skin(&cpu_report), "contacts: GPU {gpu_report:?}, CPU {cpu_report:?}");
    assert!(gpu_report.contacts.abs_diff(cpu_report.contacts) as f32 <= 0.02 * cpu_report.contacts as f32);
    // The deepest contact of all, on one particle of hair that rounding places up to
    // millimetres apart (hair resting on the moving shell), as far as the nudged CPU's.
    let depth_apart = (gpu_report.max_depth - cpu_report.max_depth).abs();
    assert!(depth_apart <= 5e-4f32.max(SPREAD_FACTOR * depth_spread), "deepest: {gpu_report:?}");
    assert_follows((mean, max), spread);
    assert!(deepest <= 5e-4, "{deepest} m behind the moving skin");
}

#[test]
fn a_step_that_collides_needs_the_collider() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(16);
    let mut strands = GpuStrands::new(&gpu, &rest, head_pose(0.0), None).expect("GPU strands");
    let params = SimParams::default();
    // The head standing still.
    let input = input_at(0, |_| head_pose(0.0), &collider, &params);
    assert!(matches!(strands.step(&input), Err(GpuError::NoCollider)));
    let before = strands.positions().expect("read back");
    assert_eq!(before, Strands::new(rest, head_pose(0.0)).positions());
}

#[test]
fn an_empty_groom_steps_reads_back_and_draws_nothing() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, _) = groom(16);
    let rest = RestShape::new(Vec::new(), 16).expect("no strands is a groom");
    let mut strands = GpuStrands::new(&gpu, &rest, head_pose(0.0), Some(&collider)).expect("GPU strands");
    let params = SimParams::default();
    for k in 0..3 {
        strands.translate(Vec3::new(0.01, 0.0, 0.0));
        strands.step(&input_at(k, head_pose, &collider, &params)).expect("step");
        strands.publish(head_pose(0.0));
    }
    assert!(strands.set_rest_roots(&[]));
    strands.reset(head_pose(0.0));
    assert_eq!(strands.positions().expect("read back"), Vec::<Vec3>::new());
    assert_eq!(strands.report().expect("report"), StepReport::default());
    // A renderer's buffer with room for nothing (wgpu's smallest is 4 bytes).
    let target = gpu.device.create_buffer(&hair_gpu::wgpu::BufferDescriptor {
        label: None,
        size: 16,
        usage: hair_gpu::wgpu::BufferUsages::STORAGE | hair_gpu::wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let drawing = hair_gpu::GpuDrawing::new(&strands, &[], &target).expect("a drawing of nothing");
    drawing.draw(&strands, 0.5, head_pose(0.0)).expect("drawn");
    assert_eq!(read_vec4s(&gpu, &target), vec![[0.0; 4]]);
}

/// Where the caller submits (an engine's render graph), the strands never touch the queue:
/// several steps, a translation and a copy back recorded, taken as one command buffer and
/// submitted by the caller, give the bits the strands give when they submit themselves,
/// and the copies back arrive once asked after that submission.
#[test]
fn steps_the_caller_submits_give_the_same_bits() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(100);
    let params = SimParams::default();
    let mut own = GpuStrands::new(&gpu, &rest, head_pose(0.0), Some(&collider)).expect("GPU strands");
    let mut taken = GpuStrands::new(&gpu, &rest, head_pose(0.0), Some(&collider)).expect("GPU strands");
    taken.set_submission(hair_gpu::Submission::Caller);
    let offset = Vec3::new(0.01, 0.0, -0.02);
    let shifted = |t: f32| {
        let pose = head_pose(t);
        Pose::new(pose.rotation, pose.translation + offset)
    };
    let mut copies = Vec::new();
    for frame in 0..6 {
        // Three steps a frame, the origin moved half-way, a copy back after each frame.
        for k in 3 * frame..3 * frame + 3 {
            let pose_at: &dyn Fn(f32) -> Pose = if k >= 9 { &shifted } else { &head_pose };
            if k == 9 {
                own.translate(offset);
                taken.translate(offset);
            }
            let input = input_at(k, pose_at, &collider, &params);
            own.step(&input).expect("GPU step");
            taken.step(&input).expect("GPU step");
        }
        let copy = taken.copy_positions();
        let commands = taken.take_commands().expect("the frame's commands");
        assert!(taken.take_commands().is_none(), "taken once");
        gpu.queue.submit([commands]);
        copies.push(copy);
    }
    let last = copies.pop().expect("copies");
    let positions = last.into_positions().expect("read back");
    let expected = own.positions().expect("read back");
    let differing = positions.iter().zip(&expected).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 0, "{differing} particles differ from the self-submitted steps");
    assert!(copies.iter().all(|c| c.arrived(true)), "the earlier copies arrived too");
}

/// Waits for the GPU and reads `buffer` (with `COPY_SRC` use) as `vec4`s.
fn read_vec4s(gpu: &GpuContext, buffer: &hair_gpu::wgpu::Buffer) -> Vec<[f32; 4]> {
    use hair_gpu::wgpu;
    let staging = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: buffer.size(),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, buffer.size());
    gpu.queue.submit([encoder.finish()]);
    staging.slice(..).map_async(wgpu::MapMode::Read, |result| result.expect("mapped"));
    gpu.device.poll(wgpu::PollType::wait_indefinitely()).expect("GPU finished");
    bytemuck::cast_slice(&staging.slice(..).get_mapped_range()).to_vec()
}
