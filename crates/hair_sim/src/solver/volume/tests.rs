use super::*;
use crate::solver::params::{LengthMode, Volume};

/// Three strands of 5 particles, 4 cm apart, hanging 1 cm per segment.
fn rest() -> RestShape {
    let mut positions = Vec::new();
    for s in 0..3 {
        for j in 0..5 {
            positions.push(Vec3::new(0.04 * s as f32, -0.01 * j as f32, 0.0));
        }
    }
    RestShape::new(positions, 5).unwrap()
}

/// One step's volume on every particle at once: [`prepare`], then the whole feedback.
fn apply(
    grid: &mut VolumeGrid,
    rest: &RestShape,
    positions: &[Vec3],
    velocities: &mut [Vec3],
    pose: Pose,
    volume: &Volume,
    dt: f32,
) {
    let step = prepare(
        grid,
        &mut None,
        rest,
        positions,
        velocities,
        (pose, pose),
        (volume, LengthMode::Inextensible),
        (dt, 1),
        (1, SimdPath::Baseline, |_: &mut [SplatPart]| {}),
    );
    grid.feed_back(&step, 0, velocities, &mut vec![GridPush::default(); velocities.len()]);
}

#[test]
fn the_splat_holds_every_particle_exactly_and_the_rest_pose_is_its_own_rest() {
    let rest = rest();
    let mut grid = VolumeGrid::new(&rest, 16, None);
    // Twelve particles (roots are pinned, not counted), each a whole unit, whatever the
    // order they were added in.
    assert_eq!(grid.rest_mass().iter().sum::<i64>(), 12 * PARTICLE_MASS_UNITS);
    let reversed: Vec<Vec3> = rest.positions.chunks(5).rev().flatten().copied().collect();
    let reversed_rest = RestShape::new(reversed.clone(), 5).unwrap();
    grid.splat(&reversed_rest, &reversed, None, Pose::IDENTITY);
    assert_eq!(grid.mass(), grid.rest_mass(), "the same particles in another order splat the same integers");
    let mut velocities = vec![Vec3::ZERO; rest.positions.len()];
    apply(&mut grid, &rest, &rest.positions, &mut velocities, Pose::IDENTITY, &Volume::default(), 1.0 / 60.0);
    assert!(grid.mass().iter().zip(grid.rest_mass()).all(|(m, r)| m == r), "at rest the density is the rest density");
    assert!(velocities.iter().all(|v| *v == Vec3::ZERO), "and nothing moves: {velocities:?}");
}

#[test]
fn a_uniform_velocity_round_trips() {
    let rest = rest();
    let mut grid = VolumeGrid::new(&rest, 16, None);
    let u = Vec3::new(0.37, -1.25, 2.5);
    let velocities = vec![u; rest.positions.len()];
    grid.splat(&rest, &rest.positions, Some(&velocities), Pose::IDENTITY);
    for (i, &x) in rest.positions.iter().enumerate().filter(|(i, _)| i % 5 != 0) {
        let (mean, _) = grid.sample(&grid.lattice.splats_of([x])[0].expect("inside the grid"));
        // Each component to half a unit of the fixed point.
        let half = 0.5 / (1u32 << VELOCITY_BITS) as f32;
        assert!((mean - u).abs().max_element() <= half, "particle {i}: {mean} for {u}");
    }
}

#[test]
fn friction_moves_a_particle_toward_the_hair_around_it_and_the_push_away_from_a_crowd() {
    let rest = rest();
    let volume =
        Volume { enabled: true, friction_root: 0.5, friction_tip: 0.5, density_push: 0.0, ..Volume::default() };
    // Strand 1 moves, strands 0 and 2 do not: friction slows it toward their mean, and
    // speeds them toward its, by the same rule.
    let mut velocities: Vec<Vec3> = (0..15).map(|i| if i / 5 == 1 { Vec3::X } else { Vec3::ZERO }).collect();
    // Two cells across: every strand has a share of the middle one.
    let mut grid = VolumeGrid::new(&rest, 2, None);
    apply(&mut grid, &rest, &rest.positions, &mut velocities, Pose::IDENTITY, &volume, 1.0 / 60.0);
    assert!(velocities[7].x < 1.0 && velocities[7].x > 0.0, "the moving strand slows: {}", velocities[7]);
    assert!(velocities[2].x > 0.0, "a still one is dragged along: {}", velocities[2]);

    // Strand 1 pressed onto strand 0: the hair there is denser than at rest, and the push
    // separates them. Strand 1 is the crowd, near the middle of its own excess, where the
    // push is least: it is the two's speeds apart that tell.
    let pushed = Volume { density_push: 5.0, friction_root: 0.0, friction_tip: 0.0, ..volume };
    let mut crowded = rest.positions.clone();
    for x in &mut crowded[5..10] {
        x.x = 0.005;
    }
    let mut velocities = vec![Vec3::ZERO; 15];
    let mut grid = VolumeGrid::new(&rest, 8, None);
    apply(&mut grid, &rest, &crowded, &mut velocities, Pose::IDENTITY, &pushed, 1.0 / 60.0);
    let apart = velocities[7].x - velocities[2].x;
    assert!(apart > 0.05 && velocities[2].x < 0.0, "pushed apart: {} and {}", velocities[7], velocities[2]);
}

#[test]
fn velocities_round_as_the_gpu_rounds_them() {
    let unit = 1.0 / (1u32 << VELOCITY_BITS) as f32;
    for (v, fixed) in [
        (0.0, 0),
        (0.49 * unit, 0),
        (0.5 * unit, 1),
        (-0.5 * unit, 0),
        (-0.51 * unit, -1),
        (-1.5 * unit, -1),
        (-2.0 * unit, -2),
        (1e9, MAX_FIXED_VELOCITY),
        (-1e9, -MAX_FIXED_VELOCITY),
        (f32::NAN, 0),
        (f32::NEG_INFINITY, 0),
    ] {
        let floor = (v * (1u32 << VELOCITY_BITS) as f32 + 0.5).floor();
        assert_eq!(fixed_velocity(v), fixed, "{v} m/s (floor(x + 0.5) = {floor})");
    }
}

#[test]
fn particles_placed_side_by_side_are_placed_as_each_alone() {
    let rest = rest();
    let grid = VolumeGrid::new(&rest, 16, None);
    let (lattice, head_local) = (&grid.lattice, SplatPart::head_local(Pose::IDENTITY));
    let (low, cell) = (lattice.origin, lattice.cell);
    let high = low + Vec3::from_array(lattice.dims.map(|d| (d - 1) as f32)) * cell;
    // Inside, on the grid's low corner, just inside and on its high side, outside, and not
    // finite; velocities slow, fast beyond the fixed point's reach, and not finite.
    let x = [
        rest.positions[3],
        low,
        high - Vec3::splat(1e-4),
        high,
        low - Vec3::new(0.0, 1e-3, 0.0),
        Vec3::new(f32::NAN, 0.0, 0.0),
        Vec3::splat(f32::INFINITY),
        rest.positions[7] + Vec3::splat(0.3 * cell),
    ];
    let v = [
        Vec3::new(0.37, -1.25, 2.5),
        Vec3::new(-0.4999 / 2048.0, 1e9, -1e9),
        Vec3::new(f32::NAN, f32::NEG_INFINITY, 0.0),
        Vec3::ZERO,
        Vec3::splat(-3.0),
        Vec3::splat(1.0),
        Vec3::splat(-0.0),
        Vec3::new(33.0, -33.0, 0.001),
    ];
    let (splats, fixed) = lattice.place(head_local, x, Some(v));
    for l in 0..x.len() {
        let ([alone], [fixed_alone]) = lattice.place(head_local, [x[l]], Some([v[l]]));
        assert_eq!((splats[l], fixed[l]), (alone, fixed_alone), "lane {l}: {} at {}", v[l], x[l]);
        assert_eq!(fixed[l], v[l].to_array().map(fixed_velocity), "lane {l}");
    }
    let held: Vec<bool> = splats.iter().map(Option::is_some).collect();
    assert_eq!(held, [true, true, true, false, false, false, false, true], "which points the grid holds");
}

#[test]
fn a_splat_in_parts_sums_what_one_does() {
    let rest = rest();
    let velocities: Vec<Vec3> = (0..15).map(|i| Vec3::new(0.1 * i as f32, -0.3, 0.02 * (i * i) as f32)).collect();
    let moved: Vec<Vec3> = rest.positions.iter().map(|x| *x + Vec3::new(0.003, -0.002, 0.001)).collect();
    // Few cells, so that the splat splits into parts (each costs a grid's size to add up).
    let mut whole = VolumeGrid::new(&rest, 2, None);
    whole.splat(&rest, &moved, Some(&velocities), Pose::IDENTITY);
    let paths = [SimdPath::Baseline, SimdPath::Avx2, SimdPath::Avx512].into_iter().filter(|p| p.is_available());
    for (parts, simd) in [2, 3, 7].into_iter().flat_map(|parts| paths.clone().map(move |simd| (parts, simd))) {
        let mut grid = VolumeGrid::new(&rest, 2, None);
        // The first time the caller runs no part (they run here), the second time every one.
        for run_them in [false, true] {
            grid.splat_on(&rest, &moved, Some(&velocities), Pose::IDENTITY, (parts, simd), |jobs| {
                assert_eq!(jobs.len(), parts.min(3), "whole strands a part");
                if run_them {
                    jobs.iter_mut().rev().for_each(SplatPart::run);
                }
            });
            let sums = (grid.mass(), grid.momentum());
            assert_eq!(sums, (whole.mass(), whole.momentum()), "{parts} parts on {simd:?}");
        }
    }
}

#[test]
fn a_resplat_of_the_strands_that_moved_sums_what_a_whole_splat_does() {
    let rest = rest();
    let pose = Pose::new(glam::Quat::from_rotation_y(0.3), Vec3::new(0.01, 0.0, -0.02));
    let before: Vec<Vec3> = rest.positions.iter().map(|&x| pose.transform_point(x)).collect();
    let still = vec![Vec3::ZERO; 15];
    // Strand 1 swings, with a speed; strands 0 and 2 stay.
    let mut after = before.clone();
    let mut moving = still.clone();
    for j in 1..5 {
        after[5 + j] += Vec3::new(0.004 * j as f32, 0.002, -0.003);
        moving[5 + j] = Vec3::new(0.3, -0.1 * j as f32, 0.05);
    }
    let mut grid = VolumeGrid::new(&rest, 16, None);
    grid.splat(&rest, &before, Some(&still), pose);
    grid.resplat(5, &[1], &after, &moving, pose);
    let mut whole = VolumeGrid::new(&rest, 16, None);
    whole.splat(&rest, &after, Some(&moving), pose);
    assert_eq!((grid.mass(), grid.momentum()), (whole.mass(), whole.momentum()));
    assert!(grid.mass() != grid.rest_mass(), "the strand moved the grid");
}

#[test]
fn a_step_makes_the_grid_again_only_from_what_moved() {
    // Sixteen strands of 5 particles, 2 cm apart.
    let positions: Vec<Vec3> = (0..16)
        .flat_map(|s| (0..5).map(move |j| Vec3::new(0.02 * (s % 4) as f32, -0.01 * j as f32, 0.02 * (s / 4) as f32)))
        .collect();
    let rest = RestShape::new(positions.clone(), 5).unwrap();
    let (volume, dt, still) = (Volume { enabled: true, ..Volume::default() }, 1.0 / 60.0, vec![Vec3::ZERO; 80]);
    let mut grid = VolumeGrid::new(&rest, 16, None);
    let mut made_from = None;
    // Whether `prepare` splatted every strand (it hands the parts to the caller then).
    let mut step = |positions: &[Vec3], grid: &mut VolumeGrid| {
        let splatted = std::cell::Cell::new(false);
        let step = prepare(
            grid,
            &mut made_from,
            &rest,
            positions,
            &still,
            (Pose::IDENTITY, Pose::IDENTITY),
            (&volume, LengthMode::Inextensible),
            (dt, 1),
            (1, SimdPath::Baseline, |_: &mut [SplatPart]| splatted.set(true)),
        );
        (step, splatted.get())
    };
    let (first, splatted) = step(&positions, &mut grid);
    assert!(splatted, "the first step splats every strand");
    assert_eq!(step(&positions, &mut grid), (first, false), "nothing moved: the same feedback, no splat");
    // One strand of sixteen moves: its shares go out of the sums and back in.
    let mut moved = positions.clone();
    moved[5 * 6 + 3] += Vec3::new(0.004, 0.001, -0.002);
    let (_, splatted) = step(&moved, &mut grid);
    let mut whole = VolumeGrid::new(&rest, 16, None);
    whole.splat(&rest, &moved, Some(&still), Pose::IDENTITY);
    assert!(!splatted && grid.mass() == whole.mass() && grid.mass() != grid.rest_mass(), "resplatted as a whole splat");
    // Under a head that moves in the step, the next step starts under another pose: no
    // copy of the particles is kept for it.
    let turned = Pose::new(glam::Quat::from_rotation_y(0.1), Vec3::ZERO);
    let mut made_from = None;
    let mut step_under = |head: (Pose, Pose), made_from: &mut Option<MadeFrom>| {
        let settings = (&volume, LengthMode::Inextensible);
        prepare(
            &mut grid,
            made_from,
            &rest,
            &moved,
            &still,
            head,
            settings,
            (dt, 1),
            (1, SimdPath::Baseline, |_: &mut [SplatPart]| {}),
        );
    };
    step_under((Pose::IDENTITY, turned), &mut made_from);
    assert!(made_from.is_none(), "nothing kept under a moving head");
    step_under((turned, turned), &mut made_from);
    assert!(made_from.is_some(), "kept under a still one");
}

/// A dense block of hair: 24 × 24 strands 2 mm apart, 24 particles 2 mm apart, 4.6 cm
/// across; its positions, its rest shape, and its middle.
fn block() -> (Vec<Vec3>, RestShape, Vec3) {
    let n = 24;
    let positions: Vec<Vec3> = (0..24 * 24 * n)
        .map(|i| {
            let (s, j) = (i / n, i % n);
            Vec3::new((s % 24) as f32, -(j as f32), (s / 24) as f32) * 0.002
        })
        .collect();
    let rest = RestShape::new(positions.clone(), n).unwrap();
    (positions, rest, Vec3::new(0.023, -0.023, 0.023))
}

/// A dense block of hair ([`block`]), the head turned: moving as one it neither spreads nor packs
/// (divergence exactly 0 in every cell that holds hair), and swelling at `rate` per second about its
/// middle it spreads at three times that in the cells within it, whatever the head's turn.
#[test]
fn the_divergence_is_the_hairs_spreading_along_the_head_axes() {
    // Its cells about 6 mm.
    let (positions, rest, centre) = block();
    let mut grid = VolumeGrid::new(&rest, 12, None);
    let pose = Pose::new(glam::Quat::from_euler(glam::EulerRot::YXZ, 0.7, -0.4, 0.2), Vec3::new(0.1, 0.2, 0.0));
    let world: Vec<Vec3> = positions.iter().map(|&p| pose.transform_point(p)).collect();
    let middle = pose.transform_point(centre);
    let turn = glam::Mat3::from_quat(pose.rotation);
    let axes = [turn.x_axis, turn.y_axis, turn.z_axis];
    let dz = grid.dims()[2];
    let spreading = |grid: &VolumeGrid, c: usize| grid.divergence(c, grid.lattice.coordinates(c), &axes);

    let moving = vec![Vec3::new(0.3, -0.2, 0.1); world.len()];
    grid.splat(&rest, &world, Some(&moving), pose);
    let held: Vec<usize> = (0..grid.values.len()).filter(|&c| grid.values[c].occupied).collect();
    assert!(held.len() > 100 && held.iter().all(|&c| spreading(&grid, c) == 0.0), "hair moving as one spreads");

    let rate = 0.5;
    let swelling: Vec<Vec3> = world.iter().map(|&p| (p - middle) * rate).collect();
    grid.splat(&rest, &world, Some(&swelling), pose);
    // Cells whose neighbours all lie well within the block, head-local.
    let (cell, origin) = (grid.cell(), grid.origin());
    let mut inner = 0;
    for c in 0..grid.values.len() {
        let at = Vec3::from_array(grid.lattice.coordinates(c).map(|a| a as f32));
        if (origin + at * cell - centre).abs().max_element() + 2.0 * cell < 0.023 && dz > 0 {
            let divergence = spreading(&grid, c);
            assert!(
                (divergence - 3.0 * rate).abs() < 0.02,
                "cell {c}: divergence {divergence}, spreading at {}",
                3.0 * rate
            );
            inner += 1;
        }
    }
    assert!(inner >= 8, "{inner} cells within the block: the test tests too little");
}

/// The sweeps visit only the cells that hold hair, each colour's in the order they were
/// found: bit for bit the pressure of red–black sweeps over every cell in the grid's
/// order with a cell without hair held at 0. Between the two steps the squeezed block
/// moves two cells along, so cells that held pressure lose their hair: they must read 0
/// from the first sweep on, not what the last step left.
#[test]
fn the_sweeps_over_the_cells_with_hair_are_the_sweeps_over_every_cell() {
    let (positions, rest, centre) = block();
    let mut grid = VolumeGrid::new(&rest, 12, None);
    // Squeezed to half its width, and packing on.
    let squeezed: Vec<Vec3> = positions.iter().map(|&p| centre + (p - centre) * Vec3::new(0.5, 1.0, 0.5)).collect();
    let packing: Vec<Vec3> = squeezed.iter().map(|&p| (centre - p) * 0.5).collect();
    let (dt, turn, sweeps) = (1.0 / 60.0, glam::Quat::IDENTITY, 8);
    grid.splat(&rest, &squeezed, Some(&packing), Pose::IDENTITY);
    grid.solve_pressure(sweeps, dt, turn, (1.0, 0.0));
    let before = grid.pressure().to_vec();
    let shifted: Vec<Vec3> = squeezed.iter().map(|&p| p + Vec3::X * 2.0 * grid.cell()).collect();
    grid.splat(&rest, &shifted, Some(&packing), Pose::IDENTITY);
    let lost: Vec<usize> = (0..before.len()).filter(|&c| before[c] > 0.0 && !grid.values[c].occupied).collect();
    assert!(!lost.is_empty(), "no cell with pressure lost its hair: the test tests too little");

    // The reference: the last step's answer, 0 where there is no hair, then every cell.
    let mut every_cell = grid.clone();
    every_cell.pressure = before.clone();
    for c in 0..before.len() {
        if !every_cell.values[c].occupied {
            every_cell.pressure[c] = 0.0;
        }
    }
    every_cell.resolve_overflow(dt, turn, (1.0, 0.0));
    let (h2, inverse_dt) = (grid.cell() * grid.cell(), 1.0 / dt);
    for _ in 0..sweeps {
        for colour in 0..2 {
            for c in 0..before.len() {
                let at = every_cell.lattice.coordinates(c);
                if at.iter().sum::<usize>() % 2 == colour && every_cell.values[c].occupied {
                    every_cell.pressure[c] = every_cell.relaxed(c, at, h2, inverse_dt);
                }
            }
        }
    }

    grid.solve_pressure(sweeps, dt, turn, (1.0, 0.0));
    let bits = |p: &[f32]| p.iter().map(|p| p.to_bits()).collect::<Vec<_>>();
    assert!(grid.pressure().iter().any(|&p| p > 0.0), "no pressure: the test tests too little");
    assert!(lost.iter().all(|&c| grid.pressure()[c] == 0.0), "a cell that lost its hair keeps no pressure");
    assert_eq!(bits(grid.pressure()), bits(every_cell.pressure()), "the same pressure as sweeping every cell");
}

/// What the step's end takes back of the grid's push: the speed it left along itself, up
/// to its size, beyond how fast the particle was already leaving; never speed coming in,
/// nor speed across it.
#[test]
fn the_push_leaves_no_speed_of_its_own() {
    let up = Vec3::new(0.0, 0.2, 0.0);
    let after = |push: Vec3, before: Vec3, after: Vec3| after - GridPush::new(push, before).taken_back(after);
    // At rest, pushed and still moving at the push's speed: stopped, and the sideways
    // speed kept.
    assert_eq!(after(up, Vec3::ZERO, Vec3::new(0.1, 0.2, 0.0)), Vec3::new(0.1, 0.0, 0.0));
    // Coming in at the push's speed and stopped by it: nothing to take back.
    assert_eq!(after(up, -up, Vec3::ZERO), Vec3::ZERO);
    // Leaving at 0.1 m/s already: kept.
    assert!(after(up, Vec3::Y * 0.1, Vec3::Y * 0.3).distance(Vec3::Y * 0.1) < 1e-6);
    // Thrown along the push by more than it (the head's pull): only the push's share.
    assert!(after(up, Vec3::ZERO, Vec3::Y).distance(Vec3::Y * 0.8) < 1e-6);
    // No push, or one that is not finite: nothing taken.
    assert_eq!(after(Vec3::ZERO, Vec3::ZERO, Vec3::Y), Vec3::Y);
    assert_eq!(after(Vec3::NAN, Vec3::ZERO, Vec3::Y), Vec3::Y);
}

/// A block squeezed and held still ([`block`]): each step the pressure's overflow is the
/// squeeze's own plus half the last step's, so over steps it grows to twice the first
/// step's (a geometric series), and the pressure with it; keeping none, every step's is the
/// first's. A cell below its target remembers nothing; let go back to its rest pose, the
/// block is under its targets everywhere and its backlog is a fresh grid's, and a cell
/// that loses its hair forgets its backlog at once.
#[test]
fn a_cell_held_over_its_target_is_pushed_harder_step_by_step() {
    let (positions, rest, centre) = block();
    let squeezed: Vec<Vec3> = positions.iter().map(|&p| centre + (p - centre) * Vec3::new(0.5, 1.0, 0.5)).collect();
    let still = vec![Vec3::ZERO; squeezed.len()];
    let (dt, turn, sweeps) = (1.0 / 60.0, glam::Quat::IDENTITY, 8);
    let steps = |kept: f32, count: usize| {
        let mut grid = VolumeGrid::new(&rest, 12, None);
        let mut first = Vec::new();
        for k in 0..count {
            grid.splat(&rest, &squeezed, Some(&still), Pose::IDENTITY);
            grid.solve_pressure(sweeps, dt, turn, (1.5, kept));
            if k == 0 {
                first = grid.backlog().to_vec();
            }
        }
        (grid, first)
    };
    let (kept, first) = steps(0.5, 40);
    let (none, _) = steps(0.0, 40);
    let over: Vec<usize> = (0..first.len()).filter(|&c| first[c] > 0.01).collect();
    assert!(over.len() >= 8, "{} cells over their target: the test tests too little", over.len());
    for &c in &over {
        let (once, now) = (first[c], kept.backlog()[c]);
        assert!((now - 2.0 * once).abs() <= 1e-5 * once, "cell {c}: {now} after 40 steps, {once} after one");
        assert_eq!(none.backlog()[c].to_bits(), once.to_bits(), "cell {c}: kept none, it changed");
    }
    let room: Vec<usize> = (0..first.len()).filter(|&c| kept.values[c].occupied && first[c] < 0.0).collect();
    assert!(!room.is_empty(), "no cell below its target: the test tests too little");
    assert!(room.iter().all(|&c| kept.backlog()[c] == first[c]), "a cell with room remembered it");
    let sum = |g: &VolumeGrid| over.iter().map(|&c| g.pressure()[c]).sum::<f32>();
    assert!(sum(&kept) > 1.5 * sum(&none), "pressure {} remembering, {} not", sum(&kept), sum(&none));

    let mut released = kept.clone();
    released.splat(&rest, &positions, Some(&still), Pose::IDENTITY);
    released.solve_pressure(sweeps, dt, turn, (1.5, 0.5));
    let mut fresh = VolumeGrid::new(&rest, 12, None);
    fresh.splat(&rest, &positions, Some(&still), Pose::IDENTITY);
    fresh.solve_pressure(sweeps, dt, turn, (1.5, 0.5));
    let remembering =
        released.backlog().iter().zip(fresh.backlog()).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
    assert_eq!(remembering, 0, "back under its targets, cells of the block remembered its squeeze");

    let mut moved = kept.clone();
    let shifted: Vec<Vec3> = squeezed.iter().map(|&p| p + Vec3::X * 3.0 * moved.cell()).collect();
    moved.splat(&rest, &shifted, Some(&still), Pose::IDENTITY);
    let lost: Vec<usize> = over.iter().copied().filter(|&c| !moved.values[c].occupied).collect();
    assert!(!lost.is_empty(), "no cell lost its hair: the test tests too little");
    assert!(lost.iter().all(|&c| moved.backlog()[c] == 0.0), "a cell without hair kept its backlog");
}
