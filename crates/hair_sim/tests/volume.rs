//! Hair with volume ([`SimParams::volume`]): at rest it changes nothing and lets spring
//! hair come to rest, the grid's sums are exact, it is deterministic on every SIMD path, it
//! holds a groom that is squeezed against itself apart, its pressure keeps a bundle on a
//! floor from packing into a layer, it pushes hair piled on the skin off it and spreads
//! the piles a shake makes, and under motion the hair keeps the body it settled into. Run
//! with `--nocapture` to see the figures.

mod common;

use common::step_input;
use glam::IVec3;
use hair_sim::prelude::*;
use hair_sim::solver::PARTICLE_MASS_UNITS;

/// A settled groom of `strands` guides × 16, 25 cm, on the procedural head.
fn settled(strands: usize) -> (HeadCollider, RestShape) {
    settled_under(strands, &SimParams::default())
}

/// [`settled`], settled under `params`.
fn settled_under(strands: usize, params: &SimParams) -> (HeadCollider, RestShape) {
    let head = test_head(4);
    let collider = HeadCollider::new(&head, DEFAULT_GRID_RESOLUTION).expect("a head");
    let roots = sample_roots(&head, &test_scalp(&head), strands, 7).expect("scalp");
    let grow = GuideParams { segments: 15, length: 0.25, ..GuideParams::default() };
    let rest = RestShape::new(grow_guides(&head, &roots, &grow, 7).expect("roots"), 16).expect("guides");
    let rest = settle(rest, Some(&collider), params, 180, Vec3::ZERO).expect("settle");
    (collider, rest)
}

/// The default settings with hair volume on.
fn with_volume() -> SimParams {
    common::with_volume(SimParams::default(), true)
}

/// The 1 cm cube that `p` lies in.
fn cube(p: Vec3) -> [i32; 3] {
    (p / 0.01).floor().as_ivec3().to_array()
}

/// How many particles of strands of `n` (roots left out) each 1 cm cube holds, the
/// positions head-local by `pose`: a density counted independently of the grid.
fn particles_per_cube(positions: &[Vec3], n: usize, pose: Pose) -> std::collections::HashMap<[i32; 3], u32> {
    let mut cubes = std::collections::HashMap::new();
    for (_, &x) in positions.iter().enumerate().filter(|(i, _)| i % n != 0) {
        *cubes.entry(cube(pose.inverse_transform_point(x))).or_default() += 1;
    }
    cubes
}

/// A settled groom under a still head, volume on: the first step finds the hair exactly at
/// its rest density (every cell's integer sum equal), every particle counted whole, and
/// over 2 s it moves less than 0.5 mm further than it does with volume off. The pressure
/// stays in the few cells the hair settles a little over its target, and the cells around
/// them: under a quarter of the cells that hold hair hold pressure, where a pressure that
/// pressed through hair below its target as through a fluid that cannot be squeezed
/// stood in every one of them.
#[test]
fn at_rest_the_volume_changes_nothing() {
    let (collider, rest) = settled(256);
    let still = |params: &SimParams| {
        let mut strands = Strands::new(rest.clone(), Pose::IDENTITY);
        strands.step(&step_input(0, Pose::IDENTITY, Pose::IDENTITY, Some(&collider), params));
        if let Some(grid) = strands.volume_grid() {
            let counted = (rest.positions.len() - rest.strand_count()) as i64 * PARTICLE_MASS_UNITS;
            assert_eq!(grid.rest_mass().iter().sum::<i64>(), counted, "every particle but the roots, whole");
            assert_eq!(grid.mass(), grid.rest_mass(), "at the first step the density is the rest density");
        }
        for k in 1..120 {
            strands.step(&step_input(k, Pose::IDENTITY, Pose::IDENTITY, Some(&collider), params));
        }
        let pressed = strands.volume_grid().map(|grid| {
            let mass = grid.mass();
            let hair = mass.iter().filter(|&&m| m > 0).count();
            let held = mass.iter().zip(grid.pressure()).filter(|&(&m, &p)| m > 0 && p > 0.0).count();
            held as f32 / hair as f32
        });
        let moved = strands.positions().iter().zip(&rest.positions).map(|(a, b)| a.distance(*b));
        (moved.fold(0.0, f32::max), strands.positions().to_vec(), pressed)
    };
    let ((on, with, pressed), (off, without, _)) = (still(&with_volume()), still(&SimParams::default()));
    let apart = with.iter().zip(&without).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
    let pressed = pressed.expect("volume on");
    println!(
        "2 s under a still head, the largest move from the settled groom: {:.3} mm with volume, {:.3} mm without; \
         the two {:.3} mm apart; {:.1} % of the cells that hold hair hold pressure",
        on * 1e3,
        off * 1e3,
        apart * 1e3,
        pressed * 100.0
    );
    assert!(apart < 5e-4, "the volume moved resting hair {apart} m");
    assert!(pressed < 0.25, "{pressed} of the hair's cells hold pressure under a still head");
}

/// A groom settled in the spring model, under a still head, with the default volume, and
/// with the density push and the pressure without the friction to calm them, together and
/// each alone: within 10 s it comes to rest, as it does without volume. The push once
/// entered the integrator's memory as a trend, 4/3 of it, and kept the hair swinging at
/// 0.16 m/s; the pressure, made for the density as it stood rather than where the hair
/// was going, swung it at 0.23 m/s; and taking a cell's whole overflow in one step, it
/// bounced hair off the cell's target (0.19–0.53 m/s, the push and the pressure together).
#[test]
fn with_springs_the_volume_lets_hair_come_to_rest() {
    let without = SimParams { length_mode: LengthMode::Springs, ..SimParams::default() };
    let (collider, rest) = settled_under(256, &without);
    let calm = Volume { friction_root: 0.0, friction_tip: 0.0, ..with_volume().volume };
    let fastest_after_10_s = |volume: Volume| {
        let params = SimParams { volume, ..without };
        let mut strands = Strands::new(rest.clone(), Pose::IDENTITY);
        for k in 0..600 {
            strands.step(&step_input(k, Pose::IDENTITY, Pose::IDENTITY, Some(&collider), &params));
        }
        strands.velocities().iter().map(|v| v.length()).fold(0.0, f32::max)
    };
    let off = fastest_after_10_s(Volume::default());
    let default = fastest_after_10_s(with_volume().volume);
    let both = fastest_after_10_s(calm);
    let push = fastest_after_10_s(Volume { pressure_iterations: 0, ..calm });
    let pressure = fastest_after_10_s(Volume { density_push: 0.0, ..calm });
    println!(
        "springs, 10 s under a still head: the fastest particle {default:.1e} m/s with the default volume; without \
         friction {both:.1e} with the push and the pressure, {push:.1e} with the push, {pressure:.1e} with the \
         pressure; {off:.1e} without volume"
    );
    assert!(off < 1e-3, "without volume the groom still moves at {off} m/s: the test tests nothing");
    for (what, fastest) in
        [("default volume", default), ("push and pressure", both), ("push", push), ("pressure", pressure)]
    {
        assert!(fastest < 1e-3, "with the {what} the groom still moves at {fastest} m/s");
    }
}

/// Grooms on springs with volume come to rest at any substep count: 1,024 guides on the
/// shipped head, on springs with the default shape keeping and without any
/// (`SimParams::reference`), settled with volume at 2, 3 and 4 substeps, kept still or
/// shaken for 1 s ([`shaking`]): after 10 s every strand is asleep. The grid's push acts
/// within the step's first substep, whose end takes its speed back from the velocity
/// and from the integrator's memory alike: left in the memory, BDF2 read the push's going
/// as a trend and sent the hair back into the cell it was pushed out of. Scaled by the
/// substep count, as under Follow-The-Leader, the kick threw strands without shape
/// keeping against their springs at 3 and 4 substeps ([`Feedback::push_scale`]).
#[test]
fn on_springs_grooms_with_volume_come_to_rest_at_any_substep_count() {
    let (_, collider, _, grown) = grown_on_the_shipped_head(1024, 7);
    let shaped = SimParams { length_mode: LengthMode::Springs, ..SimParams::default() };
    for (model, springs) in [("shape kept", shaped), ("the reference", SimParams::reference())] {
        for substeps in [2, 3, 4] {
            let params = SimParams { substeps, volume: with_volume().volume, ..springs };
            let rest = settle(grown.clone(), Some(&collider), &params, 180, Vec3::ZERO).expect("settle");
            for shaken in [false, true] {
                let yaw = |k: usize| if shaken { shaking(k, 0.0) } else { Pose::IDENTITY };
                let (asleep, fastest) = common::asleep_after(&rest, &collider, &params, (600, 1.0 / 60.0), yaw);
                let case = format!("{model}, {substeps} substeps{}", if shaken { ", shaken" } else { "" });
                println!("springs, {case}: {asleep} asleep after 10 s, the fastest particle {fastest:.1e} m/s");
                assert_eq!(asleep, 1024, "{case}: not all asleep, the fastest particle at {fastest} m/s");
            }
        }
    }
}

/// The spring model takes the grid's friction into its implicit solve, substep by
/// substep. In a weightless bundle whose strands move sideways one way and the other in a
/// checkerboard (the hair's mean velocity near zero everywhere), one step of 1/60 s keeps
/// the share of each particle's velocity that the FTL model keeps, which applies the
/// friction once a step in closed form, less what backward Euler's substeps lose of it
/// (at this friction's rate 0.021 over 2 substeps, 0.006 over 8, 0.037 over one).
#[test]
fn with_springs_the_grids_friction_takes_the_share_asked() {
    let n = 16;
    let mut positions = Vec::new();
    for (a, b) in (0..8).flat_map(|a| (0..8).map(move |b| (a, b))) {
        positions.extend((0..n).map(|j| Vec3::new(a as f32 * 0.002, -(j as f32) * 0.01, b as f32 * 0.002)));
    }
    let rest = RestShape::new(positions, n).expect("straight strands");
    let speed = 0.01;
    let sign = |strand: usize| if (strand / 8 + strand % 8).is_multiple_of(2) { 1.0 } else { -1.0 };
    let velocities: Vec<Vec3> = (0..rest.positions.len())
        .map(|i| if i % n == 0 { Vec3::ZERO } else { Vec3::X * speed * sign(i / n) })
        .collect();
    let kept = |length_mode: LengthMode, substeps: u32, volume: Volume| {
        let params = SimParams {
            length_mode,
            substeps,
            gravity: [0.0; 3],
            drag: 0.0,
            collision: false,
            global_stiffness_root: 0.0,
            global_stiffness_tip: 0.0,
            local_stiffness: 0.0,
            volume,
            ..SimParams::default()
        };
        let mut strands = Strands::new(rest.clone(), Pose::IDENTITY);
        strands.set_velocities(&velocities).expect("one per particle");
        strands.step(&step_input(0, Pose::IDENTITY, Pose::IDENTITY, None, &params));
        let along: f32 = strands
            .velocities()
            .iter()
            .enumerate()
            .filter(|(i, _)| i % n != 0)
            .map(|(i, v)| v.x * sign(i / n) / speed)
            .sum();
        along / (rest.positions.len() - rest.strand_count()) as f32
    };
    let friction = Volume {
        enabled: true,
        friction_root: 0.3,
        friction_tip: 0.3,
        density_push: 0.0,
        pressure_iterations: 0,
        ..Volume::default()
    };
    let once_a_step = kept(LengthMode::Inextensible, 2, friction);
    let without = kept(LengthMode::Springs, 8, Volume::default());
    println!("kept after 1/60 s: {once_a_step:.4} (FTL, friction once a step), {without:.4} (springs, no volume)");
    assert!((0.6..0.8).contains(&once_a_step), "the friction took {once_a_step} (asked 0.3 of the difference)");
    assert!(without > 0.99, "without volume the bundle kept {without}: the springs slow it by themselves");
    for (substeps, within) in [(1, 0.05), (2, 0.02), (8, 0.006)] {
        let in_solve = kept(LengthMode::Springs, substeps, friction);
        println!("springs, {substeps} substeps: kept {in_solve:.4}");
        assert!(
            (in_solve - once_a_step).abs() < within,
            "{substeps} substeps: kept {in_solve}, the closed form {once_a_step}"
        );
    }
}

/// The head turns and nods for a second with volume on: the same bits on every SIMD path,
/// thread count and run, in either length model.
#[test]
fn the_volume_is_deterministic_on_every_path() {
    let (collider, rest) = settled(96);
    // On this thread, or its splat's parts and chunks (each feeding the grid back into its
    // own strands) on `threads` threads.
    let run = |length_mode: LengthMode, simd: SimdPath, threads: usize| {
        // Cells few enough for the splat to split into parts here (each part's sums cost
        // a grid's size to add up).
        let coarse = Volume { resolution: 8, ..with_volume().volume };
        let params = SimParams { length_mode, simd, volume: coarse, ..SimParams::default() };
        let mut strands = Strands::new(rest.clone(), Pose::IDENTITY);
        let pose = |k: usize| {
            let t = k as f32 / 60.0;
            Pose::new(
                Quat::from_rotation_y(1.5 * (4.0 * t).sin()) * Quat::from_rotation_x(0.4 * (3.0 * t).sin()),
                Vec3::ZERO,
            )
        };
        for k in 0..60 {
            let input = step_input(k, pose(k), pose(k + 1), Some(&collider), &params);
            if threads == 1 {
                strands.step(&input);
                continue;
            }
            // The splat in `threads` parts too, each on its own thread.
            strands.apply_volume_on(&input, threads, |parts| {
                assert_eq!(parts.len(), threads, "a part for each thread");
                std::thread::scope(|scope| {
                    for part in parts {
                        scope.spawn(move || part.run());
                    }
                })
            });
            let per_chunk = strands.strand_count().div_ceil(threads);
            std::thread::scope(|scope| {
                for mut chunk in strands.chunks_mut(per_chunk) {
                    let input = &input;
                    scope.spawn(move || chunk.step(input));
                }
            });
            strands.follow_leaders(&input);
        }
        (strands.positions().to_vec(), strands.volume_grid().expect("on").momentum())
    };
    for mode in [LengthMode::Inextensible, LengthMode::Springs] {
        let baseline = run(mode, SimdPath::Baseline, 1);
        assert!(baseline.0 == run(mode, SimdPath::Baseline, 1).0, "{mode:?}: two runs differ");
        for (simd, threads) in [(SimdPath::Auto, 1), (SimdPath::Avx2, 1), (SimdPath::Auto, 2), (SimdPath::Baseline, 3)]
        {
            let other = run(mode, simd, threads);
            assert!(
                other.0 == baseline.0 && other.1 == baseline.1,
                "{mode:?}: {simd} on {threads} threads differs from the baseline"
            );
        }
    }
}

/// Half of a groom is pressed into the other half's place (the strands' particles moved
/// 1 cm toward the head's middle plane and held there one step): with volume on the push
/// sends them apart, without it nothing does.
#[test]
fn hair_pressed_together_is_pushed_apart() {
    let (collider, rest) = settled(256);
    let n = rest.particles_per_strand;
    let spread = |params: &SimParams| {
        let mut strands = Strands::new(rest.clone(), Pose::IDENTITY);
        let pressed: Vec<Vec3> = strands
            .positions()
            .iter()
            .enumerate()
            .map(|(i, &x)| if i % n == 0 { x } else { x - Vec3::X * (0.01 * x.x.signum()) })
            .collect();
        strands.set_positions(&pressed).expect("finite");
        let width = |strands: &Strands| {
            let xs: Vec<f32> = strands.positions().iter().map(|x| x.x.abs()).collect();
            xs.iter().sum::<f32>() / xs.len() as f32
        };
        let before = width(&strands);
        let params = SimParams { collision: false, global_stiffness_root: 0.0, local_stiffness: 0.0, ..*params };
        strands.step(&step_input(0, Pose::IDENTITY, Pose::IDENTITY, Some(&collider), &params));
        width(&strands) - before
    };
    let (off, on) = (spread(&SimParams::default()), spread(&with_volume()));
    println!("mean distance from the middle plane after one step: {:+.3} mm off, {:+.3} mm on", off * 1e3, on * 1e3);
    assert!(on > off + 1e-5, "the volume pushed nothing apart: {on} m against {off} m");
}

/// A settled groom (256 × 16 on the procedural head) pressed onto the skin, every particle
/// within 3 cm of it (roots left out) moved along the head's normal to a fifth of its
/// height over the collision shell (3 mm), and stepped once without collision, gravity or
/// shape keeping: with the head known to the grid, its cells inside the head are walls
/// and the pressure moves the pile off the skin in a step at least 1.5 times as far as a
/// grid without the head, whose pressure spends half its push into the head, where the
/// collision would only put the hair back. Under 1 % of the pile moves toward the head by
/// more than 0.1 mm (hair sliding along the skin into the room beside the pile moves
/// toward it by less). The head's normal is the gradient of its exact signed distance,
/// not the grid's.
#[test]
fn hair_piled_on_the_skin_is_pushed_off_it_not_into_the_head() {
    let (collider, rest) = settled(256);
    let n = rest.particles_per_strand;
    let normal = |p: Vec3| {
        let d = |o: Vec3| collider.signed_distance(p + o) - collider.signed_distance(p - o);
        Vec3::new(d(Vec3::X * 1e-3), d(Vec3::Y * 1e-3), d(Vec3::Z * 1e-3)).normalize()
    };
    let mut pile = Vec::new();
    let pressed: Vec<Vec3> = (rest.positions.iter().enumerate())
        .map(|(i, &x)| {
            let d = collider.signed_distance(x);
            if i % n == 0 || d > 0.03 {
                return x;
            }
            let normal = normal(x);
            pile.push((i, normal));
            x - normal * (d - (0.003 + 0.2 * (d - 0.003).max(0.0)))
        })
        .collect();
    let params = SimParams {
        collision: false,
        gravity: [0.0; 3],
        global_stiffness_root: 0.0,
        local_stiffness: 0.0,
        ..with_volume()
    };
    // How far the pile moves off the skin in one step, on average, and the share of it
    // moved toward the head by more than 0.1 mm.
    let push = |head: Option<&HeadCollider>| {
        let mut strands = Strands::new(rest.clone(), Pose::IDENTITY);
        strands.set_positions(&pressed).expect("finite");
        strands.step(&step_input(0, Pose::IDENTITY, Pose::IDENTITY, head, &params));
        let off: Vec<f32> = pile.iter().map(|&(i, normal)| (strands.positions()[i] - pressed[i]).dot(normal)).collect();
        let inward = off.iter().filter(|&&s| s < -1e-4).count();
        (off.iter().sum::<f32>() / off.len() as f32, inward as f32 / off.len() as f32)
    };
    let (walled, open) = (push(Some(&collider)), push(None));
    println!(
        "a pile of {} particles on the skin, moved off it by {:.2} mm on average in a step with the head's cells as \
         walls, {:.2} mm without; {:.1} % and {:.1} % of it moved toward the head by more than 0.1 mm",
        pile.len(),
        walled.0 * 1e3,
        open.0 * 1e3,
        walled.1 * 100.0,
        open.1 * 100.0
    );
    assert!(walled.0 >= 1.5 * open.0 && open.0 > 0.0, "off the skin by {} m, {} m without walls", walled.0, open.0);
    assert!(walled.1 < 0.01, "{} of the pile pushed toward the head", walled.1);
}

/// The grid's walls are the cells inside the head the strands step against, checked
/// against the head's exact signed distance (every cell corner farther than 5 mm from the
/// surface on the right side), and they follow the collider: made again for another
/// collider and gone where a step has none.
#[test]
fn the_grids_walls_are_the_heads_inside() {
    let (collider, rest) = settled(64);
    let other = HeadCollider::new(&test_head(4), DEFAULT_GRID_RESOLUTION).expect("a head");
    let mut strands = Strands::new(rest, Pose::IDENTITY);
    let params = with_volume();
    let mut walls = |k: usize, head: Option<&HeadCollider>| {
        strands.step(&step_input(k, Pose::IDENTITY, Pose::IDENTITY, head, &params));
        let grid = strands.volume_grid().expect("volume on").clone();
        (grid.head(), grid)
    };
    let (first, grid) = walls(0, Some(&collider));
    let [dx, dy, _] = grid.dims();
    let (mut inside, mut wrong) = (0, 0);
    for (c, &solid) in grid.solid().iter().enumerate() {
        let at = Vec3::new((c % dx) as f32, (c / dx % dy) as f32, (c / (dx * dy)) as f32);
        let d = collider.signed_distance(grid.origin() + at * grid.cell());
        inside += usize::from(solid);
        wrong += usize::from(d.abs() > 5e-3 && solid != (d < 0.0));
    }
    println!("{inside} of the grid's {} cells are inside the head; {wrong} on the wrong side", grid.solid().len());
    assert!(inside > 100 && wrong == 0, "{inside} inside, {wrong} on the wrong side");
    assert_eq!(first, Some(collider.id()));
    let (again, regrown) = walls(1, Some(&other));
    assert_eq!(again, Some(other.id()), "made again for another collider");
    assert_eq!(regrown.solid(), grid.solid(), "of the same head: the same walls");
    let (none, open) = walls(2, None);
    assert!(none.is_none() && !open.solid().contains(&true), "without a collider, no walls");
}

/// A bundle of 16 × 16 strands, 25 cm of 16 particles each, lying along +x from roots
/// pinned 4 cm above a floor (the top of a sphere of 100 m), `spacing` apart, falls for 3 s
/// without the head, shape keeping or anything but gravity, the floor and each other.
/// Returns the volume it keeps: over particles 4 to 15, each layer's cross-section (the
/// particles of one index, in the plane across the bundle) as the squares of side
/// `spacing` that hold a particle, at the end over the start (where each holds one).
fn bundle_on_a_floor(spacing: f32, volume: Volume) -> f32 {
    let (side, n, floor) = (16, 16, -0.04);
    let positions: Vec<Vec3> = (0..side * side)
        .flat_map(|s| {
            let root = Vec3::new(0.0, (s / side) as f32 * spacing, (s % side) as f32 * spacing);
            (0..n).map(move |j| root + Vec3::X * (0.25 * j as f32 / (n - 1) as f32))
        })
        .collect();
    let rest = RestShape::new(positions, n).expect("bundle");
    let floor_ball = [ExtraCollider::Sphere { center: Vec3::new(0.1, floor - 100.0, 0.0), radius: 100.0 }];
    let params = SimParams {
        global_stiffness_root: 0.0,
        global_stiffness_tip: 0.0,
        local_stiffness: 0.0,
        sleep_distance: 0.0,
        volume,
        ..SimParams::default()
    };
    let cross_section = |x: &[Vec3]| {
        let mut squares = std::collections::HashSet::new();
        for strand in x.chunks_exact(n) {
            for (j, p) in strand.iter().enumerate().skip(4) {
                squares.insert((j, (p.y / spacing).floor() as i32, (p.z / spacing).floor() as i32));
            }
        }
        squares.len() as f32
    };
    let mut strands = Strands::new(rest.clone(), Pose::IDENTITY);
    for k in 0..180 {
        let input =
            StepInput { extra_colliders: &floor_ball, ..step_input(k, Pose::IDENTITY, Pose::IDENTITY, None, &params) };
        strands.step(&input);
    }
    let lowest = strands.positions().iter().map(|p| p.y).fold(f32::MAX, f32::min);
    assert!(lowest > floor, "through the floor: {lowest} m");
    cross_section(strands.positions()) / cross_section(&rest.positions)
}

/// A bundle dropped onto a floor ([`bundle_on_a_floor`]), its strands 2, 4 and 6 mm apart:
/// without volume the strands land on each other and it collapses into a layer. With the
/// volume it keeps a tenth of its volume more, the pressure more than the push alone, and
/// 0.69 of it where the bundle (9 cm across) spans several of the grid's cells (about 1 cm
/// here; 0.64 without the pressure's backlog, which holds the bundle's weight nearer its
/// target). Packing within a cell the grid cannot see (`docs/simulation.md`,
/// hair with volume).
#[test]
fn a_bundle_on_a_floor_keeps_its_volume() {
    for spacing in [0.002, 0.004, 0.006] {
        let off = bundle_on_a_floor(spacing, Volume::default());
        let on = bundle_on_a_floor(spacing, Volume { enabled: true, ..Volume::default() });
        let push_only =
            bundle_on_a_floor(spacing, Volume { enabled: true, pressure_iterations: 0, ..Volume::default() });
        println!(
            "a bundle {:.0} mm apart on a floor keeps {on:.2} of its volume with volume on, {push_only:.2} with \
             the push alone, {off:.2} without",
            spacing * 1e3
        );
        assert!(on >= off + 0.1 && on > push_only, "{spacing} m apart: kept {on}, {push_only}, {off}");
        if spacing >= 0.006 {
            assert!(on >= 0.66, "{spacing} m apart: kept {on}");
        }
    }
}

/// `strands` guides × 16, 25 cm, grown (not settled) on the shipped head's painted scalp
/// from roots sampled with `seed`: the head, its collider, the roots and the guides.
fn grown_on_the_shipped_head(strands: usize, seed: u64) -> (HeadMesh, HeadCollider, Vec<RootBinding>, RestShape) {
    let (head, weights) = common::shipped_head();
    let collider = HeadCollider::new(&head, DEFAULT_GRID_RESOLUTION).expect("the shipped head");
    let (roots, grown) = grown_on(&head, &weights, strands, seed);
    (head, collider, roots, grown)
}

/// [`grown_on_the_shipped_head`] on `head` with its scalp's triangle `weights`, without
/// baking its collider again: the roots and the guides.
fn grown_on(head: &HeadMesh, weights: &[f32], strands: usize, seed: u64) -> (Vec<RootBinding>, RestShape) {
    let roots = sample_roots(head, weights, strands, seed).expect("scalp");
    let grow = GuideParams { segments: 15, length: 0.25, ..GuideParams::default() };
    let grown = RestShape::new(grow_guides(head, &roots, &grow, 7).expect("roots"), 16).expect("guides");
    (roots, grown)
}

/// The density of the hair at `positions` (head-local, strands of `n`, roots left out) at
/// any head-local point: its particles within `DENSITY_RADIUS`, each weighted
/// `(1 − r²/R²)³` (a smooth kernel, so that hair moving a little moves the density a
/// little). Counted independently of the grid.
fn density_of(positions: &[Vec3], n: usize) -> impl Fn(Vec3) -> f32 {
    let h = DENSITY_RADIUS;
    let key = move |x: Vec3| (x / h).floor().as_ivec3();
    let mut bins = std::collections::HashMap::<IVec3, Vec<Vec3>>::new();
    for (_, &x) in positions.iter().enumerate().filter(|(i, _)| i % n != 0) {
        bins.entry(key(x)).or_default().push(x);
    }
    move |x: Vec3| {
        let (at, mut density) = (key(x), 0.0);
        for offset in (0..27).map(|k| IVec3::new(k % 3 - 1, k / 3 % 3 - 1, k / 9 - 1)) {
            for &y in bins.get(&(at + offset)).map_or(&[][..], Vec::as_slice) {
                density += (1.0 - (y - x).length_squared() / (h * h)).max(0.0).powi(3);
            }
        }
        density
    }
}

/// [`density_of`]' radius: two of the shipped head's grid cells at the default
/// resolution would blur a pile; much less than this and the density counts single strands.
const DENSITY_RADIUS: f32 = 0.02;

/// The largest ρ/ρ_rest where the hair at `positions` (head-local by `pose`) lies, and its
/// 99th percentile: at each particle (roots left out), ρ the density of the hair there and
/// ρ_rest the rest pose's density at the same place ([`density_of`]), as the grid
/// compares them, over the places the rest pose fills to at least half its mean density
/// (beside the rest pose any hair is many times denser than it was).
fn densest(rest: &RestShape, positions: &[Vec3], pose: Pose) -> (f32, f32) {
    let n = rest.particles_per_strand;
    let local: Vec<Vec3> = positions.iter().map(|&x| pose.inverse_transform_point(x)).collect();
    let (now, then) = (density_of(&local, n), density_of(&rest.positions, n));
    let counted =
        |x: &[Vec3]| -> Vec<Vec3> { x.iter().enumerate().filter(|(i, _)| i % n != 0).map(|(_, &p)| p).collect() };
    let at_rest: Vec<f32> = counted(&rest.positions).into_iter().map(&then).collect();
    let mean = at_rest.iter().sum::<f32>() / at_rest.len().max(1) as f32;
    let mut ratios: Vec<f32> = counted(&local)
        .into_iter()
        .map(|x| (now(x), then(x)))
        .filter(|&(_, r)| r >= 0.5 * mean)
        .map(|(a, r)| a / r)
        .collect();
    ratios.sort_by(f32::total_cmp);
    (ratios[ratios.len() - 1], ratios[(ratios.len() * 99) / 100])
}

/// The head's pose at step `k` (1/60 s) of a 1 s shake from `start` seconds on (yaw ±0.8
/// rad at 12 rad/s), still before and after it.
fn shaking(k: usize, start: f32) -> Pose {
    common::shake(k as f32 / 60.0 - start)
}

/// 1,024 guides × 16 on the shipped head, settled, then 2 s still, a 1 s shake
/// ([`shaking`]; none where `shake` is false) and 2 s still, under `params`: the largest
/// ρ/ρ_rest and its 99th percentile ([`densest`]).
fn density_after_a_shake(rest: &RestShape, collider: &HeadCollider, params: &SimParams, shake: bool) -> (f32, f32) {
    let yaw = |k: usize| if shake { shaking(k, 2.0) } else { Pose::IDENTITY };
    let mut strands = Strands::new(rest.clone(), Pose::IDENTITY);
    for k in 0..300 {
        strands.step(&step_input(k, yaw(k), yaw(k + 1), Some(collider), params));
    }
    densest(rest, strands.positions(), yaw(300))
}

/// `rest` with every particle but the roots moved by up to 0.1 µm along each axis, a
/// different way for each `nudge` (0: not moved).
fn nudged(rest: &RestShape, nudge: u32) -> RestShape {
    let mut nudged = rest.clone();
    let n = rest.particles_per_strand;
    for (i, p) in nudged.positions.iter_mut().enumerate().filter(|(i, _)| nudge > 0 && i % n != 0) {
        let bits = (i as u32).wrapping_mul(2_654_435_761).wrapping_add(nudge.wrapping_mul(40_503));
        let offset = |shift: u32| ((bits >> shift) & 255) as f32 / 255.0 - 0.5;
        *p += Vec3::new(offset(0), offset(8), offset(16)) * 2e-7;
    }
    nudged
}

/// The median over three runs, nudged and not ([`nudged`]), of the largest ρ/ρ_rest after
/// a shake with volume on and its 99th percentile ([`density_after_a_shake`]), and the runs.
fn shaken_with_volume(rest: &RestShape, collider: &HeadCollider) -> ((f32, f32), Vec<(f32, f32)>) {
    let runs: Vec<(f32, f32)> =
        (0..3).map(|k| density_after_a_shake(&nudged(rest, k), collider, &with_volume(), true)).collect();
    let median = |pick: fn(&(f32, f32)) -> f32| {
        let mut values: Vec<f32> = runs.iter().map(pick).collect();
        values.sort_by(f32::total_cmp);
        values[1]
    };
    ((median(|r| r.0), median(|r| r.1)), runs)
}

/// After a shake ([`density_after_a_shake`]) hair lies in piles where it landed, the
/// densest of hair near the roots lying on the skin at the sides of the head. The volume's
/// pressure, which does not push into the head's cells, spreads them along the skin and
/// off it: the largest ρ/ρ_rest drops from about 2 to under 1.25 (asked: 1.2), and the
/// 99th percentile from 1.25 to 1.05, as asked, on this groom. With the pressure the shake
/// is chaotic: nudging the groom by 0.1 µm moves the largest ratio by up to a tenth, so the
/// pressure's figures are the median of three runs, nudged and not. The measure itself is
/// sharp enough for the asked bounds (1.2, and 1.05 at the 99th percentile): the same
/// groom kept still meets both. Grooms of other roots read differently (over nine runs
/// each, largest 1.13–1.27 and 1.10–1.20, 99th percentile 1.04–1.07 and 1.03–1.05), so
/// two of them are held to about what they reach (1.3 and 1.08): a change tuned to this
/// groom must not lose the others. Without the pressure's backlog (`FTL_BACKLOG_KEPT`),
/// which pushes a cell that stays over its target harder step by step, the piles settle
/// over their targets by as much as they weigh: about 1.3 on this groom and 1.4 on
/// another.
#[test]
fn after_a_shake_the_volume_spreads_piled_hair() {
    let (head, weights) = common::shipped_head();
    let collider = HeadCollider::new(&head, DEFAULT_GRID_RESOLUTION).expect("the shipped head");
    let settled = |seed: u64| {
        let (_, grown) = grown_on(&head, &weights, 1024, seed);
        settle(grown, Some(&collider), &SimParams::default(), 180, Vec3::ZERO).expect("settle")
    };
    let rest = settled(7);
    let push_alone = SimParams {
        volume: Volume { enabled: true, pressure_iterations: 0, ..Volume::default() },
        ..SimParams::default()
    };
    let still = density_after_a_shake(&rest, &collider, &with_volume(), false);
    let off = density_after_a_shake(&rest, &collider, &SimParams::default(), true);
    let push = density_after_a_shake(&rest, &collider, &push_alone, true);
    let (on, runs) = shaken_with_volume(&rest, &collider);
    println!(
        "after a shake, largest ρ/ρ_rest and its 99th percentile: {:.2}, {:.2} off; {:.2}, {:.2} with the push alone; \
         {:.2}, {:.2} with the pressure (median of {runs:.2?}); kept still with volume {:.2}, {:.2}",
        off.0, off.1, push.0, push.1, on.0, on.1, still.0, still.1
    );
    assert!(still.0 <= 1.2 && still.1 <= 1.05, "kept still, the groom measures {still:?}: the measure is blunt");
    assert!(on.0 <= 1.25 && on.1 <= 1.05 && off.0 >= 1.8 && off.1 >= 1.2, "{on:?} with the pressure, {off:?} without");
    for seed in [3, 11] {
        let rest = settled(seed);
        let (on, runs) = shaken_with_volume(&rest, &collider);
        println!("roots seed {seed}: {:.2}, {:.2} with the pressure (median of {runs:.2?})", on.0, on.1);
        assert!(on.0 <= 1.3 && on.1 <= 1.08, "roots seed {seed}: {on:?}");
    }
}

/// Two locks of 8 × 8 strands, 25 cm of 16 particles, rows 3 mm apart, A's roots between
/// B's rows and `raised` above B's: lock B hangs at rest, lock A starts straight out along
/// −x and swings down for 2 s (no head, shape keeping or collision), through B to where it
/// would hang inside it.
fn locks_crossing(volume: Volume, raised: f32) -> Locks {
    let (side, n, spacing) = (8, 16, 0.003);
    let lock = |x0: f32, y0: f32, along: Vec3| -> Vec<Vec3> {
        (0..side * side)
            .flat_map(|s| {
                let root = Vec3::new(x0 + (s / side) as f32 * spacing, y0, (s % side) as f32 * spacing);
                (0..n).map(move |j| root + along * (0.25 * j as f32 / (n - 1) as f32))
            })
            .collect()
    };
    // A's roots between B's rows.
    let (a, b) = (lock(0.025 + 0.5 * spacing, raised, Vec3::NEG_X), lock(0.025, 0.0, Vec3::NEG_Y));
    let a_particles = a.len();
    let rest = RestShape::new([a, b].concat(), n).expect("locks");
    let params = SimParams {
        global_stiffness_root: 0.0,
        global_stiffness_tip: 0.0,
        local_stiffness: 0.0,
        sleep_distance: 0.0,
        collision: false,
        volume,
        ..SimParams::default()
    };
    let momentum = |v: &[Vec3]| v.iter().copied().sum::<Vec3>().length();
    let mut strands = Strands::new(rest, Pose::IDENTITY);
    let (mut a_most, mut b_most) = (0.0f32, 0.0f32);
    let mut sweeping = Vec::new();
    for k in 0..120 {
        if k == LOCKS_SWEEPING {
            sweeping = strands.positions().to_vec();
        }
        strands.step(&step_input(k, Pose::IDENTITY, Pose::IDENTITY, None, &params));
        let (va, vb) = strands.velocities().split_at(a_particles);
        a_most = a_most.max(momentum(va));
        b_most = b_most.max(momentum(vb));
    }
    let (xa, xb) = strands.positions().split_at(a_particles);
    let b_cubes = particles_per_cube(xb, n, Pose::IDENTITY);
    let a_counted = xa.iter().enumerate().filter(|(i, _)| i % n != 0);
    let inside = a_counted.clone().filter(|(_, p)| b_cubes.get(&cube(**p)).is_some_and(|&c| c >= 4)).count();
    Locks {
        inside: inside as f32 / a_counted.count() as f32,
        passed: b_most / a_most,
        a_particles,
        sweeping,
        end: strands.positions().to_vec(),
    }
}

/// Step of [`locks_crossing`] whose positions [`Locks::sweeping`] keeps: lock A halfway down.
const LOCKS_SWEEPING: usize = 9;

/// How two locks crossed ([`locks_crossing`]).
struct Locks {
    /// The share of A's particles (roots left out) that end in 1 cm cubes holding 4 or
    /// more of B's.
    inside: f32,
    /// The largest momentum B reaches, as a share of the largest A has (per unit particle
    /// mass).
    passed: f32,
    /// A's particles come first in the positions.
    a_particles: usize,
    /// Both locks' positions while A sweeps down ([`LOCKS_SWEEPING`]), and at the end.
    sweeping: Vec<Vec3>,
    end: Vec<Vec3>,
}

/// Two locks swept through each other ([`locks_crossing`]): without volume much of A ends
/// inside B and B never moves (its momentum a millionth of A's); with it A pushes B aside
/// and B takes up momentum (at least 0.5 % of A's: the grid's push moves B but takes back
/// the speed it gave, and the friction between the locks passes the rest). With A's
/// roots among B's, the first of a strand's particles lie inside B wherever the strand
/// goes, and where A ends is chaotic (raising A's roots by a millimetre moves the share
/// left inside by a few points): over A's roots raised by 0 to 2 mm, the median share left
/// inside is at most a quarter. With A's roots 4 cm above B's, under a tenth, as the issue
/// asks.
/// Draws the two runs with the roots among B's side by side, while A sweeps and at the end
/// (`docs/volume-locks.png` is this picture).
#[test]
fn a_lock_swept_into_another_pushes_it_aside() {
    let crossing = |raised: f32| {
        let off = locks_crossing(Volume::default(), raised);
        let on = locks_crossing(Volume { enabled: true, ..Volume::default() }, raised);
        println!(
            "a lock swept into another, its roots {:.0} cm above the other's: {:.0} % of its particles end in the \
             other's dense cubes without volume, {:.0} % with; the other's momentum reaches {:.2} of the swept \
             lock's without, {:.2} with",
            raised * 100.0,
            off.inside * 100.0,
            on.inside * 100.0,
            off.passed,
            on.passed
        );
        assert!(
            off.passed < 1e-5 && on.passed >= 0.005,
            "momentum passed: {} without volume, {} with",
            off.passed,
            on.passed
        );
        (off, on)
    };
    let (off, on) = crossing(0.0);
    let mut among: Vec<f32> = [0.0005, 0.001, 0.002]
        .map(|raised| locks_crossing(Volume { enabled: true, ..Volume::default() }, raised).inside)
        .into_iter()
        .chain([on.inside])
        .collect();
    among.sort_by(f32::total_cmp);
    let median = 0.5 * (among[1] + among[2]);
    println!(
        "with A's roots among B's, raised by 0 to 2 mm: {:.0} % of A inside B (median of {:.0?} %)",
        median * 100.0,
        among.iter().map(|s| s * 100.0).collect::<Vec<_>>()
    );
    let (raised_off, raised_on) = crossing(0.04);
    let mut picture = common::picture::StrandPicture::new(2, 2, 320, Vec3::new(-0.24, 0.03, 0.0), 0.32);
    for (column, run) in [&off, &on].into_iter().enumerate() {
        for (row, positions) in [&run.sweeping, &run.end].into_iter().enumerate() {
            let (a, b) = positions.split_at(run.a_particles);
            let at = (column as u32, row as u32);
            picture.strands(at, b, 16, [40, 90, 200]);
            picture.strands(at, a, 16, [230, 120, 20]);
        }
    }
    println!("wrote {}", picture.save("volume-locks").display());
    assert!(
        off.inside > 0.7 && median <= 0.25,
        "roots among the other's: {} inside without volume, {among:?} with",
        off.inside
    );
    assert!(
        raised_off.inside > 0.3 && raised_on.inside < 0.1,
        "roots above the other's: {} inside without volume, {} with",
        raised_off.inside,
        raised_on.inside
    );
}

/// How far each strand (of `n` particles) stands off the scalp: the largest reach of its
/// particles along the scalp's normal at its root.
fn reach_along(positions: &[Vec3], normals: &[Vec3], n: usize) -> Vec<f32> {
    positions
        .chunks_exact(n)
        .zip(normals)
        .map(|(strand, &normal)| strand.iter().map(|&x| (x - strand[0]).dot(normal)).fold(0.0, f32::max))
        .collect()
}

/// The median of `values`.
fn median(mut values: Vec<f32>) -> f32 {
    values.sort_by(f32::total_cmp);
    values[values.len() / 2]
}

/// How far the hair stands off the scalp: the median over the strands of
/// [`reach_along`].
fn median_thickness(positions: &[Vec3], normals: &[Vec3], n: usize) -> f32 {
    median(reach_along(positions, normals, n))
}

/// The groom's thickness (its median reach along the scalp's normal) on the shipped head,
/// 1,024 × 16, settled as the plugin settles (180 steps) under the same settings it then
/// runs 2 s under, over the thickness as grown (straight out along the normal). With volume
/// off settling lays the hair into a helmet, under a twentieth of it; with volume on the
/// strands keep each other out as they fall and the hair keeps a body of several
/// centimetres, without holding the grown pose (which stood out like a shock while the
/// grown pose's density was the target while settling).
#[test]
fn the_thickness_of_a_groom_settled_with_and_without_volume() {
    let (head, collider, roots, grown) = grown_on_the_shipped_head(1024, 7);
    let normals: Vec<Vec3> = roots.iter().map(|r| r.normal(&head)).collect();
    let groomed = median_thickness(&grown.positions, &normals, 16);
    let thickness = |params: &SimParams| {
        let rest = settle(grown.clone(), Some(&collider), params, 180, Vec3::ZERO).expect("settle");
        let mut strands = Strands::new(rest, Pose::IDENTITY);
        for k in 0..120 {
            strands.step(&step_input(k, Pose::IDENTITY, Pose::IDENTITY, Some(&collider), params));
        }
        median_thickness(strands.positions(), &normals, 16) / groomed
    };
    let (off, on) = (thickness(&SimParams::default()), thickness(&with_volume()));
    println!(
        "thickness over groomed ({:.1} mm): {off:.2} with volume off, {on:.2} with volume on while settling and after",
        groomed * 1e3
    );
    assert!(off < 0.05 && (0.12..0.4).contains(&on), "off {off}, on {on}");
}

/// A groom that has a body keeps it: the groom settled with volume on (1,024 × 16 on the
/// shipped head, about 5 cm thick: a groom as a user would have modelled it) taken as
/// groomed, then 2 s still, a 1 s shake ([`shaking`]) and 2 s still. Per scalp sample, the
/// hair's reach along the scalp's normal over its groomed reach ([`reach_along`]): with
/// volume the median is within 0.85–1.15 and nine strands in ten are, as the issue asks;
/// without it the hair sags toward the skin under the shape keeping alone, and under
/// four in five are.
#[test]
fn a_groom_with_a_body_keeps_it_through_a_shake() {
    let (head, collider, roots, grown) = grown_on_the_shipped_head(1024, 7);
    let normals: Vec<Vec3> = roots.iter().map(|r| r.normal(&head)).collect();
    let groomed = settle(grown, Some(&collider), &with_volume(), 180, Vec3::ZERO).expect("settle");
    let before = reach_along(&groomed.positions, &normals, 16);
    let kept = |params: &SimParams| {
        let yaw = |k: usize| shaking(k, 2.0);
        let mut strands = Strands::new(groomed.clone(), Pose::IDENTITY);
        for k in 0..300 {
            strands.step(&step_input(k, yaw(k), yaw(k + 1), Some(&collider), params));
        }
        let after = reach_along(strands.positions(), &normals, 16);
        let ratios: Vec<f32> = after.iter().zip(&before).map(|(a, b)| a / b).collect();
        let within = ratios.iter().filter(|r| (0.85..=1.15).contains(*r)).count() as f32 / ratios.len() as f32;
        (median(ratios), within)
    };
    let (off, on) = (kept(&SimParams::default()), kept(&with_volume()));
    println!(
        "a groom with a body ({:.1} mm) after a shake, its reach over groomed: median {:.2} and {:.0} % of the \
         strands within 0.85-1.15 with volume, {:.2} and {:.0} % without",
        median(before) * 1e3,
        on.0,
        on.1 * 100.0,
        off.0,
        off.1 * 100.0
    );
    assert!((0.85..=1.15).contains(&on.0) && on.1 >= 0.9, "with volume: {on:?}");
    assert!(off.1 < 0.8, "without volume {off:?}: the test tests nothing");
}

/// The head-local 1 cm cubes that hold particles (roots left out) of strands of `n`.
fn occupied_cubes(positions: &[Vec3], n: usize, pose: Pose) -> usize {
    particles_per_cube(positions, n, pose).len()
}

/// The mean angle, radians, between each strand's consecutive segments: how far the
/// strands are from combed.
fn mean_bend(positions: &[Vec3], n: usize) -> f32 {
    let bends: Vec<f32> = positions
        .chunks_exact(n)
        .flat_map(|s| s.windows(3).map(|w| (w[1] - w[0]).angle_between(w[2] - w[1])))
        .collect();
    bends.iter().sum::<f32>() / bends.len() as f32
}

/// A groom on the shipped head (1,024 × 16, 25 cm) settled as the plugin settles, then
/// turned and nodded for 4 s (yaw ±0.7 rad at 3 rad/s, pitch ±0.3 rad at 5 rad/s): with
/// volume on, the hair under motion fills no more than a tenth more 1 cm cubes than it
/// settled into (the pressure does not blow it out), as without volume. The figures it
/// prints also show what settling with volume does: the hair fills about three times the
/// cubes, and its strands bend about three times as much from one segment to the next
/// (the pushes on single particles leave them tangled).
#[test]
fn under_motion_the_volume_keeps_the_groom_it_settled_into() {
    let (_, collider, _, grown) = grown_on_the_shipped_head(1024, 7);
    let motion = |k: usize| {
        let t = k as f32 / 60.0;
        Pose::new(
            Quat::from_rotation_y(0.7 * (3.0 * t).sin()) * Quat::from_rotation_x(0.3 * (5.0 * t).sin()),
            Vec3::ZERO,
        )
    };
    let run = |params: &SimParams| {
        let rest = settle(grown.clone(), Some(&collider), params, 180, Vec3::ZERO).expect("settle");
        let settled = occupied_cubes(&rest.positions, 16, Pose::IDENTITY);
        let mut strands = Strands::new(rest.clone(), Pose::IDENTITY);
        let mut most = 0.0f32;
        for k in 0..240 {
            strands.step(&step_input(k, motion(k), motion(k + 1), Some(&collider), params));
            if k >= 60 && k % 20 == 19 {
                let now = occupied_cubes(strands.positions(), 16, motion(k + 1));
                most = most.max(now as f32 / settled as f32);
            }
        }
        (settled, mean_bend(&rest.positions, 16), most)
    };
    let (off, on) = (run(&SimParams::default()), run(&with_volume()));
    println!(
        "settled into {} cubes without volume and {} with; bending {:.3} and {:.3} rad a joint; under motion at \
         most {:.2} and {:.2} of the settled cubes",
        off.0, on.0, off.1, on.1, off.2, on.2
    );
    assert!(
        on.2 <= 1.1 && off.2 <= 1.2,
        "under motion: {:.2} of the settled cubes with volume, {:.2} without",
        on.2,
        off.2
    );
}

/// A groom on the shipped head (1,024 × 16) settled without volume, 10 s under a still
/// head, then 3 steps of a slow turn (1 mrad a step), with and without volume: asleep with
/// volume, the strands keep still velocities (the grid's feedback reaches only the strands
/// that step), and they wake as they do without volume. The feedback once built up in
/// sleeping strands (1.3 m/s after 10 s; 56 m/s in a groom settled with volume) and threw
/// the hair when the head moved (33 mm and 396 mm in the 3 steps, against 7 mm).
#[test]
fn a_sleeping_groom_with_volume_wakes_as_without() {
    let (_, collider, _, grown) = grown_on_the_shipped_head(1024, 7);
    let rest = settle(grown, Some(&collider), &SimParams::default(), 180, Vec3::ZERO).expect("settle");
    let turn = |k: usize| Pose::new(Quat::from_rotation_y(0.001 * k.saturating_sub(600) as f32), Vec3::ZERO);
    let run = |params: &SimParams| {
        let mut strands = Strands::new(rest.clone(), Pose::IDENTITY);
        let mut asleep = 0;
        for k in 0..600 {
            asleep = strands.step(&step_input(k, turn(k), turn(k + 1), Some(&collider), params)).sleeping;
        }
        let fastest = strands.velocities().iter().map(|v| v.length()).fold(0.0, f32::max);
        let before: Vec<Vec3> = strands.positions().iter().map(|&x| turn(603).transform_point(x)).collect();
        for k in 600..603 {
            strands.step(&step_input(k, turn(k), turn(k + 1), Some(&collider), params));
        }
        let moved = strands.positions().iter().zip(&before).map(|(x, b)| x.distance(*b)).fold(0.0, f32::max);
        (asleep, fastest, moved)
    };
    let (off, on) = (run(&SimParams::default()), run(&with_volume()));
    println!(
        "after 10 s still: {} and {} strands asleep, the fastest particle {:.2e} and {:.2e} m/s; 3 steps of a slow \
         turn then move the hair at most {:.2} mm without volume and {:.2} mm with it",
        off.0,
        on.0,
        off.1,
        on.1,
        off.2 * 1e3,
        on.2 * 1e3
    );
    assert_eq!((off.0, on.0), (1024, 1024), "every strand asleep");
    assert!(on.1 < 1e-6, "a sleeping strand took up {} m/s", on.1);
    assert!(on.2 <= off.2 + 1e-3, "woken with volume the hair moved {} m, {} m without", on.2, off.2);
}

/// Grooms on the shipped head settled with volume, stepped with it under a still head
/// (one of them shaken first, [`shaking`]), come to rest: after 4 s every strand is
/// asleep. Once a pull of hair into cells sparser than at rest fought the pressure's push
/// out of full ones, and the push left its speed in the hair: a strand at the groom's edge
/// behind the head swung by millimetres for ever (one to three strands in each of these
/// grooms).
#[test]
fn grooms_settled_with_volume_come_to_rest_under_a_still_head() {
    let params = with_volume();
    // (strands, roots seed, shaken first)
    for (count, seed, shaken) in [(1024, 7, false), (2048, 5, false), (2048, 7, false), (1024, 3, true)] {
        let yaw = |k: usize| if shaken { shaking(k, 0.0) } else { Pose::IDENTITY };
        let (_, collider, _, grown) = grown_on_the_shipped_head(count, seed);
        let rest = settle(grown, Some(&collider), &params, 180, Vec3::ZERO).expect("settle");
        let steps = if shaken { 300 } else { 240 };
        let (asleep, fastest) = common::asleep_after(&rest, &collider, &params, (steps, 1.0 / 60.0), yaw);
        println!(
            "{count} strands (roots seed {seed}{}): {asleep} asleep after {:.0} s, the fastest particle {fastest:.1e} m/s",
            if shaken { ", shaken" } else { "" },
            steps as f32 / 60.0
        );
        assert_eq!(
            asleep, count,
            "{count} strands (seed {seed}) not all asleep: the fastest particle at {fastest} m/s"
        );
    }
}

/// Sparse grooms with volume come to rest: 1, 16 and 64 guides of long hair (42 cm of 17
/// particles, lengths varied by 15 %, combed back, soft shape keeping, 3 substeps) on the
/// shipped head, settled with volume, then kept still or shaken for 1 s ([`shaking`]):
/// after 10 s every strand is asleep. A cell may hold what one strand leaves in it before
/// the pressure pushes, whatever it held at rest ([`VolumeGrid::floor`]); with the floor
/// at half the mean rest density alone, a sparse groom's strands were pushed by their own
/// density wherever they went and swung by centimetres for ever.
#[test]
fn sparse_grooms_with_volume_come_to_rest() {
    let (head, weights) = common::shipped_head();
    let collider = HeadCollider::new(&head, DEFAULT_GRID_RESOLUTION).expect("the shipped head");
    let comb = Vec3::new(0.0, 0.0, -1.5);
    let params = SimParams {
        substeps: 3,
        local_stiffness: 0.2,
        global_stiffness_root: 0.1,
        volume: Volume { enabled: true, ..Volume::default() },
        ..SimParams::default()
    };
    for guides in [1, 16, 64] {
        let roots = hair_sim::groom::sample_roots_poisson(&head, &weights, guides, 1).expect("scalp");
        let grow = GuideParams { segments: 16, length: 0.42, length_variation: 0.15, comb, ..GuideParams::default() };
        let grown = RestShape::new(grow_guides(&head, &roots, &grow, 1).expect("roots"), 17).expect("guides");
        let rest = settle(grown, Some(&collider), &params, 180, comb).expect("settle");
        for shaken in [false, true] {
            let yaw = |k: usize| if shaken { shaking(k, 0.0) } else { Pose::IDENTITY };
            let (asleep, fastest) = common::asleep_after(&rest, &collider, &params, (600, 1.0 / 60.0), yaw);
            let case = format!("{guides} guides{}", if shaken { ", shaken" } else { "" });
            println!("{case}: {asleep} asleep after 10 s, the fastest particle {fastest:.1e} m/s");
            assert_eq!(asleep, guides, "{case}: not all asleep, the fastest particle at {fastest} m/s");
        }
    }
}
