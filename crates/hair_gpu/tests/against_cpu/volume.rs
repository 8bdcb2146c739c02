//! Hair with volume (`SimParams::volume`) on the GPU against the CPU: the grid's integer
//! sums bit for bit, and the strands they push.

use super::*;
use hair_sim::solver::{VolumeGrid, VolumeState};

fn with_volume(collision: bool) -> SimParams {
    SimParams { collision, volume: Volume { enabled: true, ..Volume::default() }, ..SimParams::default() }
}

/// The head sways and bobs without turning: head-local positions are then the world's less
/// a translation, one correctly rounded subtraction on both sides, so both splat the same
/// points (a rotation's sums of products may round differently where the GPU fuses them).
fn swaying(time: f32) -> Pose {
    Pose::new(Quat::IDENTITY, Vec3::new(0.08 * (7.0 * time).sin(), 0.04 * (11.0 * time).sin(), 0.0))
}

/// The GPU's atomics add the particles in whatever order its threads run; the sums are
/// integers, so they must be the CPU's to the bit: at the first step, the rest pose's own
/// (the density excess exactly zero), and at later steps the CPU's splat of the positions
/// and velocities the GPU stepped from.
#[test]
fn the_grids_integer_sums_are_the_cpus_bit_for_bit() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(256);
    let params = with_volume(true);
    let mut strands = GpuStrands::new(&gpu, &rest, swaying(0.0), Some(&collider)).expect("GPU strands");
    let mut grid = VolumeGrid::new(&rest, params.volume.resolution, Some(&collider.interior()));
    let mut compared = 0;
    for k in 0..40 {
        let before = (strands.positions().expect("positions"), strands.velocities().expect("velocities"));
        strands.step(&input_at(k, swaying, &collider, &params)).expect("GPU step");
        if k % 13 != 0 {
            continue;
        }
        let (mass, momentum) = strands.volume_sums().expect("volume on").expect("read back");
        grid.splat(&rest, &before.0, Some(&before.1), swaying(k as f32 * DT));
        if k == 0 {
            assert_eq!(mass, grid.rest_mass(), "the first step is at the rest density");
        }
        let moving = momentum.iter().filter(|m| **m != [0; 3]).count();
        eprintln!("step {k}: {} cells hold hair, {moving} of them moving", mass.iter().filter(|&&m| m > 0).count());
        assert!(k == 0 || moving > 100, "step {k}: the swaying hair moves the grid ({moving} cells)");
        assert_eq!(mass, grid.mass(), "step {k}: mass sums");
        assert_eq!(momentum, grid.momentum(), "step {k}: momentum sums");
        compared += 1;
    }
    assert_eq!(compared, 4);
}

/// With volume on, the GPU follows the CPU as far as the CPU follows itself nudged by
/// 0.1 µm, with and without collision, and stays out of the head. (The grid couples every
/// strand to its neighbours, and a splat weight is a step function of position: rounding
/// that moves a particle across a weight's step changes the push on all the hair around
/// it, so the two part by more than without volume, and so do the CPU's own twins.) In
/// both length models: the spring model takes the grid's answer into its implicit solve.
#[test]
fn with_volume_the_gpu_follows_the_cpu() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(256);
    let n = rest.particles_per_strand;
    let steps = 60;
    let models = [LengthMode::Inextensible, LengthMode::Springs];
    for (collision, length_mode) in [false, true].into_iter().flat_map(|c| models.map(|m| (c, m))) {
        let params = SimParams { length_mode, ..with_volume(collision) };
        let mut twins = Twins::new(&rest, head_pose(0.0));
        let [(cpu, _), (on_gpu, _)] =
            run_both_reporting(&gpu, &rest, &collider, &params, &[], steps, head_pose, Some(&mut twins));
        let (mean, max) = apart(&cpu, &on_gpu);
        let spread = twins.spread(&cpu);
        let deepest = deepest_in_head(&on_gpu, n, &collider, head_pose(steps as f32 * DT));
        eprintln!(
            "volume, {length_mode:?}, collision {collision}, after {steps} steps: mean {:.4} mm, max {:.2} mm apart (the CPU \
             nudged: {:.4} mm, {:.2} mm); deepest {:.3} mm",
            mean * 1e3,
            max * 1e3,
            spread.0 * 1e3,
            spread.1 * 1e3,
            deepest * 1e3
        );
        assert!(on_gpu.iter().all(|p| p.is_finite()));
        assert_follows((mean, max), spread);
        if collision {
            assert!(deepest <= 5e-4, "{deepest} m inside the head");
        }
    }
}

/// Half of a groom pressed into the other half's place and stepped once from the same
/// state on both, with the pressure solve as the volume's only effect (no friction toward
/// the mean, no push, no shape keeping, no collision), in either length model: the
/// velocities it leaves are the CPU's to rounding, and the pressure moved them (by more
/// than a hundred times that). The hair pressed toward the middle lies on and in the
/// head, so the grid's walls (its cells inside the head without hair) shape the answer:
/// with the GPU's walls left without a potential the two part by metres a second, and by
/// 2 m/s with the GPU's step not taking back the speed the push left (`GridPush`).
#[test]
fn the_pressure_pushes_as_on_the_cpu() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(256);
    let n = rest.particles_per_strand;
    let pressed: Vec<Vec3> = rest
        .positions
        .iter()
        .enumerate()
        .map(|(i, &x)| if i % n == 0 { x } else { x - Vec3::X * (0.01 * x.x.signum()) })
        .collect();
    let pressure_only =
        Volume { enabled: true, friction_root: 0.0, friction_tip: 0.0, density_push: 0.0, ..Volume::default() };
    // The spring model takes less of the overflow in a step (`SPRINGS_CATCH_UP`).
    for length_mode in [LengthMode::Inextensible, LengthMode::Springs] {
        let base = SimParams {
            length_mode,
            collision: false,
            global_stiffness_root: 0.0,
            local_stiffness: 0.0,
            ..SimParams::default()
        };
        let (apart, pushed) =
            one_step_beside_the_cpu(&gpu, (&rest, &collider), base, pressure_only, (Some(&pressed), None));
        eprintln!(
            "{length_mode:?}, one step of pressure: velocities {apart:.1e} m/s apart, the pressure changed them by up \
             to {pushed:.3} m/s"
        );
        assert!(
            pushed > 100.0 * apart.max(1e-6),
            "{length_mode:?}: the pressure moved nothing measurable: {pushed} m/s"
        );
        assert!(apart < 1e-4, "{length_mode:?}: {apart} m/s apart");
    }
}

/// A groom stepped once from `start` (its positions and its velocities where given, else
/// at rest) under `base` with `volume`, on the CPU and on the GPU: how far apart the two
/// leave the velocities, and how far `volume` moved the CPU's from where the same step
/// without volume leaves them (m/s, the largest of each).
fn one_step_beside_the_cpu(
    gpu: &GpuContext,
    (rest, collider): (&RestShape, &HeadCollider),
    base: SimParams,
    volume: Volume,
    start: (Option<&[Vec3]>, Option<&[Vec3]>),
) -> (f32, f32) {
    let step_both = |volume: Volume| {
        let params = SimParams { volume, ..base };
        let mut cpu = Strands::new(rest.clone(), Pose::IDENTITY);
        let mut on_gpu = GpuStrands::new(gpu, rest, Pose::IDENTITY, Some(collider)).expect("GPU strands");
        if let Some(positions) = start.0 {
            cpu.set_positions(positions).expect("one finite position per particle");
            assert!(on_gpu.set_positions(positions));
        }
        if let Some(velocities) = start.1 {
            cpu.set_velocities(velocities).expect("one finite velocity per particle");
            assert!(on_gpu.set_velocities(velocities));
        }
        let input = input_at(0, |_| Pose::IDENTITY, collider, &params);
        cpu.step(&input);
        on_gpu.step(&input).expect("GPU step");
        (cpu.velocities().to_vec(), on_gpu.velocities().expect("read back"))
    };
    let ((cpu, on_gpu), (cpu_off, _)) = (step_both(volume), step_both(Volume::default()));
    let largest = |a: &[Vec3], b: &[Vec3]| a.iter().zip(b).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
    (largest(&cpu, &on_gpu), largest(&cpu, &cpu_off))
}

/// A sparse groom out of its rest pose: 8 strands, each moved 3 cm sideways into cells
/// that held no hair at rest, stepped once from the same state on both with the pressure
/// solve as the volume's only effect. A cell may hold what one strand leaves in it before
/// the pressure pushes (`VolumeGrid::floor`), so the pressure barely moves them (only
/// where a strand's particles bunch about a cell's node), and the GPU's velocities are the
/// CPU's to rounding. (With the floor at half the mean rest density alone, the pressure
/// moves them by metres a second, and a GPU that floors so parts from the CPU by as much.)
#[test]
fn a_strand_alone_is_barely_pressed_by_its_own_density() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(8);
    let n = rest.particles_per_strand;
    let moved: Vec<Vec3> =
        rest.positions.iter().enumerate().map(|(i, &x)| if i % n == 0 { x } else { x + Vec3::X * 0.03 }).collect();
    let pressure_only =
        Volume { enabled: true, friction_root: 0.0, friction_tip: 0.0, density_push: 0.0, ..Volume::default() };
    let base = SimParams { collision: false, global_stiffness_root: 0.0, local_stiffness: 0.0, ..SimParams::default() };
    let (apart, pushed) = one_step_beside_the_cpu(&gpu, (&rest, &collider), base, pressure_only, (Some(&moved), None));
    eprintln!(
        "a sparse groom moved sideways: the pressure changed velocities by up to {pushed:.1e} m/s, the GPU's \
         {apart:.1e} m/s apart"
    );
    assert!(pushed < 0.2, "the pressure pushed strands alone by {pushed} m/s");
    assert!(apart < 1e-4, "{apart} m/s apart");
}

/// The spring model, one step from the same moving state on both (strands in turn moving
/// one way and the other, so that each differs from the hair's mean velocity around it),
/// with the grid's friction and density push as the volume's only effect: the velocities
/// it leaves are the CPU's to rounding, and the volume moved them by more than a hundred
/// times that.
#[test]
fn in_the_spring_model_the_grids_answer_is_the_cpus() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(256);
    let n = rest.particles_per_strand;
    let swinging: Vec<Vec3> = (0..rest.positions.len())
        .map(|i| {
            if i % n == 0 {
                Vec3::ZERO
            } else {
                Vec3::new(0.3, 0.1, -0.2) * if (i / n).is_multiple_of(2) { 1.0 } else { -1.0 }
            }
        })
        .collect();
    let base = SimParams { length_mode: LengthMode::Springs, collision: false, ..SimParams::default() };
    let volume =
        Volume { enabled: true, friction_root: 0.3, friction_tip: 0.2, pressure_iterations: 0, ..Volume::default() };
    let (apart, changed) = one_step_beside_the_cpu(&gpu, (&rest, &collider), base, volume, (None, Some(&swinging)));
    eprintln!(
        "one spring step with volume: velocities {apart:.1e} m/s apart, the volume changed them by up to {changed:.3} m/s"
    );
    assert!(changed > 100.0 * apart.max(1e-6), "the volume moved nothing measurable: {changed} m/s");
    assert!(apart < 1e-4, "{apart} m/s apart");
}

/// A groom stepped on the CPU with volume on under a swaying head, then handed to the GPU
/// as the plugin hands one over (positions, velocities and what the grid keeps from step to
/// step: the pressure, which the next sweeps start from, and the backlog of overflow,
/// `GpuStrands::set_volume_state`): one more step on both leaves the same velocities within
/// 1 mm/s. Without the grid the GPU's sweeps start from zero, with no backlog, and the
/// velocities part by fifty times that at least. A state that is not of this grid (a cell
/// short, a NaN, another resolution) is refused and leaves the grid as it was.
#[test]
fn the_pressure_carries_over_to_the_gpu() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(256);
    let params = with_volume(false);
    let mut cpu = Strands::new(rest.clone(), swaying(0.0));
    for k in 0..20 {
        cpu.step(&input_at(k, swaying, &collider, &params));
    }
    let grid = cpu.volume_grid().expect("volume on").clone();
    assert!(grid.pressure().iter().any(|&p| p > 0.0), "no pressure to carry over: the test tests nothing");
    assert!(grid.backlog().iter().any(|&b| b > 0.0), "no backlog to carry over: the test tests too little");
    let handed_over = |with_grid: bool| {
        let mut on_gpu = GpuStrands::new(&gpu, &rest, swaying(0.0), Some(&collider)).expect("GPU strands");
        assert!(on_gpu.set_positions(cpu.positions()) && on_gpu.set_velocities(cpu.velocities()));
        if with_grid {
            assert!(on_gpu.set_volume_state(&grid.state()));
            // Refused, and the state taken above kept: a cell short, a NaN, another grid.
            let mut short = grid.state();
            short.pressure.pop();
            let mut not_finite = grid.state();
            not_finite.backlog[0] = f32::NAN;
            let coarser = VolumeState { resolution: grid.resolution() / 2, ..grid.state() };
            for refused in [short, not_finite, coarser] {
                assert!(!on_gpu.set_volume_state(&refused), "took a state of {} cells", refused.pressure.len());
            }
        }
        on_gpu.step(&input_at(20, swaying, &collider, &params)).expect("GPU step");
        on_gpu.velocities().expect("read back")
    };
    let (with_grid, without) = (handed_over(true), handed_over(false));
    cpu.step(&input_at(20, swaying, &collider, &params));
    let apart = |v: &[Vec3]| cpu.velocities().iter().zip(v).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
    let (apart_with, apart_without) = (apart(&with_grid), apart(&without));
    eprintln!(
        "one step after the hand-over: velocities {apart_with:.1e} m/s from the CPU's with the grid, \
         {apart_without:.1e} m/s without"
    );
    assert!(apart_with < 1e-3, "{apart_with} m/s apart");
    assert!(apart_without > 50.0 * apart_with.max(1e-6), "the pressure carried nothing: {apart_without} m/s");
}

/// Asleep under a still head with volume on, a strand keeps the still velocities it fell
/// asleep with on both backends: the grid's feedback is for the strands that step. (It once
/// built up in sleeping strands and threw the hair when the head moved.)
#[test]
fn asleep_with_volume_the_strands_keep_still_as_on_the_cpu() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(64);
    let params = with_volume(true);
    let still = |_: f32| head_pose(0.0);
    let mut cpu = Strands::new(rest.clone(), still(0.0));
    let mut on_gpu = GpuStrands::new(&gpu, &rest, still(0.0), Some(&collider)).expect("GPU strands");
    let (mut cpu_asleep, mut gpu_asleep) = (0, 0);
    for k in 0..240 {
        let input = input_at(k, still, &collider, &params);
        cpu_asleep = cpu.step(&input).sleeping;
        on_gpu.step(&input).expect("GPU step");
        gpu_asleep = on_gpu.report().expect("report").sleeping;
    }
    let fastest = |v: &[Vec3]| v.iter().map(|v| v.length()).fold(0.0, f32::max);
    let (cpu_fastest, gpu_fastest) = (fastest(cpu.velocities()), fastest(&on_gpu.velocities().expect("read back")));
    eprintln!(
        "4 s still with volume: {cpu_asleep} and {gpu_asleep} of 64 asleep; the fastest particle {cpu_fastest:.1e} \
         and {gpu_fastest:.1e} m/s (CPU, GPU)"
    );
    assert_eq!((cpu_asleep, gpu_asleep), (64, 64), "every strand asleep");
    assert!(cpu_fastest == 0.0 && gpu_fastest == 0.0, "asleep but moving: {cpu_fastest}, {gpu_fastest} m/s");
}

/// A groom asleep under a still head leaves its grid as the last step that moved a strand
/// made it, on both backends: the CPU makes it again only where a strand moved
/// (`Strands::apply_volume`), and the GPU runs none of the grid's passes but the feedback
/// where its positions and velocities are those it was made from, bit for bit: through a
/// second of sleep it makes no grid, and its pressure and backlog stay as they were, to
/// the bit. While the groom settles, each step after one that moved a strand makes one,
/// and so does each step that the head moves in.
#[test]
fn a_groom_asleep_keeps_its_grid_as_on_the_cpu() {
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(64);
    let params = with_volume(true);
    // Still for 5.5 s, then turning.
    let pose = |time: f32| head_pose((time - 5.5).max(0.0));
    let mut cpu = Strands::new(rest.clone(), pose(0.0));
    let mut on_gpu = GpuStrands::new(&gpu, &rest, pose(0.0), Some(&collider)).expect("GPU strands");
    let mut states = Vec::new();
    let mut made = Vec::new();
    // Steps before the first check in which a strand stepped on the CPU.
    let mut stepping = 0;
    for k in 0..340 {
        let input = input_at(k, pose, &collider, &params);
        if k == 239 || k == 299 {
            // The report counts every step since it was last taken.
            on_gpu.report().expect("report");
        }
        let cpu_asleep = cpu.step(&input).sleeping;
        on_gpu.step(&input).expect("GPU step");
        stepping += u32::from(k < 240 && cpu_asleep < 64);
        if k == 239 || k == 299 {
            let gpu_asleep = on_gpu.report().expect("report").sleeping;
            assert_eq!((cpu_asleep, gpu_asleep), (64, 64), "step {k}: every strand asleep");
            let cpu_state = cpu.volume_grid().expect("volume on").state();
            let gpu_state = on_gpu.volume_state().expect("volume on").expect("read back");
            states.push((cpu_state, gpu_state));
        }
        if [239, 299, 339].contains(&k) {
            made.push(on_gpu.volume_grids_made().expect("volume on").expect("read back"));
        }
    }
    let changed = |a: &VolumeState, b: &VolumeState| {
        let values = |s: &VolumeState| [s.pressure.clone(), s.backlog.clone()].concat();
        values(a).iter().zip(&values(b)).filter(|(x, y)| x.to_bits() != y.to_bits()).count()
    };
    let held = states[0].0.pressure.iter().filter(|&&p| p > 0.0).count();
    let (cpu_changed, gpu_changed) = (changed(&states[0].0, &states[1].0), changed(&states[0].1, &states[1].1));
    let (asleep, moving) = (made[1] - made[0], made[2] - made[1]);
    eprintln!(
        "asleep for 1 s with volume: {cpu_changed} and {gpu_changed} of the grid's values changed (CPU, GPU), \
         {held} cells hold pressure; the GPU made the grid {asleep} times in the 60 steps asleep, {moving} in the \
         40 steps after, the last 10 of them under a turning head ({} before)",
        made[0]
    );
    assert!(held > 0, "no cell holds pressure: the test tests nothing");
    assert_eq!((cpu_changed, gpu_changed), (0, 0), "asleep, the grid changed");
    // The first step's grid, then one after each step in which a strand moved.
    assert_eq!(made[0], stepping + 1, "grids made while the groom settled, {stepping} steps stepping a strand");
    assert_eq!((asleep, moving), (0, 10), "grids made asleep, and under a moving head");
}
