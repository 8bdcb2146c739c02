//! Hair with volume ([`SimParams::volume`]): at rest it changes nothing, the grid's sums are
//! exact, it is deterministic on every SIMD path, and it holds a groom that is squeezed
//! against itself apart. Run with `--nocapture` to see the figures.

mod common;

use common::step_input;
use hair_sim::prelude::*;
use hair_sim::solver::PARTICLE_MASS_UNITS;

/// A settled groom of `strands` guides × 16, 25 cm, on the procedural head.
fn settled(strands: usize) -> (HeadCollider, RestShape) {
    let head = test_head(4);
    let collider = HeadCollider::new(&head, DEFAULT_GRID_RESOLUTION).expect("a head");
    let roots = sample_roots(&head, &test_scalp(&head), strands, 7).expect("scalp");
    let grow = GuideParams { segments: 15, length: 0.25, ..GuideParams::default() };
    let rest = RestShape::new(grow_guides(&head, &roots, &grow, 7).expect("roots"), 16).expect("guides");
    let rest = settle(rest, Some(&collider), &SimParams::default(), 180, Vec3::ZERO).expect("settle");
    (collider, rest)
}

fn with_volume() -> SimParams {
    SimParams { volume: Volume { enabled: true, ..Volume::default() }, ..SimParams::default() }
}

/// A settled groom under a still head, volume on: the first step finds the hair exactly at
/// its rest density (every cell's integer sum equal), every particle counted whole, and
/// over 2 s it moves less than 0.5 mm further than it does with volume off.
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
        let moved = strands.positions().iter().zip(&rest.positions).map(|(a, b)| a.distance(*b));
        (moved.fold(0.0, f32::max), strands.positions().to_vec())
    };
    let ((on, with), (off, without)) = (still(&with_volume()), still(&SimParams::default()));
    let apart = with.iter().zip(&without).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
    println!(
        "2 s under a still head, the largest move from the settled groom: {:.3} mm with volume, {:.3} mm without; \
         the two {:.3} mm apart",
        on * 1e3,
        off * 1e3,
        apart * 1e3
    );
    assert!(apart < 5e-4, "the volume moved resting hair {apart} m");
}

/// The head turns and nods for a second with volume on: the same bits on every SIMD path
/// and in every run.
#[test]
fn the_volume_is_deterministic_on_every_path() {
    let (collider, rest) = settled(96);
    let run = |simd: SimdPath| {
        let params = SimParams { simd, ..with_volume() };
        let mut strands = Strands::new(rest.clone(), Pose::IDENTITY);
        let pose = |k: usize| {
            let t = k as f32 / 60.0;
            Pose::new(
                Quat::from_rotation_y(1.5 * (4.0 * t).sin()) * Quat::from_rotation_x(0.4 * (3.0 * t).sin()),
                Vec3::ZERO,
            )
        };
        for k in 0..60 {
            strands.step(&step_input(k, pose(k), pose(k + 1), Some(&collider), &params));
        }
        (strands.positions().to_vec(), strands.volume_grid().expect("on").momentum().to_vec())
    };
    let baseline = run(SimdPath::Baseline);
    assert!(baseline.0 == run(SimdPath::Baseline).0, "two runs differ");
    for simd in [SimdPath::Auto, SimdPath::Avx2] {
        let other = run(simd);
        assert!(other.0 == baseline.0 && other.1 == baseline.1, "{simd} differs from the baseline");
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
