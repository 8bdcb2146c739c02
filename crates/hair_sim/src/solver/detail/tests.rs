use super::*;

#[test]
fn levels_halve_the_simulated_strands_and_nest() {
    assert_eq!(simulated_at_level(2048, 0), 2048);
    assert_eq!(simulated_at_level(2048, 3), 256);
    assert_eq!(simulated_at_level(5, 2), 2);
    assert_eq!(simulated_at_level(5, 9), 1);
    let roots: Vec<Vec3> = (0..200).map(|i| Vec3::new((i % 20) as f32, (i / 20) as f32, 0.0)).collect();
    let order = farthest_point_order(&roots);
    let mut sorted = order.clone();
    sorted.sort();
    assert_eq!(sorted, (0..200).collect::<Vec<u32>>(), "every strand once");
    // The first 8 of a 20 × 10 grid are spread out: no two within 4 cells.
    let first: Vec<Vec3> = order[..8].iter().map(|&s| roots[s as usize]).collect();
    for (a, p) in first.iter().enumerate() {
        for q in &first[a + 1..] {
            assert!(p.distance(*q) >= 4.0, "{p} and {q} are both among the first 8");
        }
    }
}

#[test]
fn the_level_follows_the_height_with_hysteresis() {
    // Two levels per halving of the height: half the strands per halving of the area.
    assert_eq!(level_for_height(400.0, 300.0), 0);
    assert_eq!(level_for_height(300.0, 300.0), 0);
    assert_eq!(level_for_height(212.0, 300.0), 1);
    assert_eq!(level_for_height(150.0, 300.0), 2);
    assert_eq!(level_for_height(149.0, 300.0), 2);
    assert_eq!(level_for_height(74.0, 300.0), 4);
    assert_eq!(level_for_height(1.0, 300.0), MAX_DETAIL_LEVEL);
    assert_eq!(level_for_height(0.0, 300.0), MAX_DETAIL_LEVEL);
    assert_eq!(level_for_height(f32::NAN, 300.0), MAX_DETAIL_LEVEL);
    assert_eq!(level_for_height(100.0, f32::NAN), 0);
    // Level 2 is 106–150 px: with a 10 % margin a head at 160 px stays, at 170 px goes
    // to 1; at 100 px stays, at 90 px goes to 3.
    assert_eq!(level_with_hysteresis(160.0, 300.0, 2, 0.1), 2);
    assert_eq!(level_with_hysteresis(170.0, 300.0, 2, 0.1), 1);
    assert_eq!(level_with_hysteresis(100.0, 300.0, 2, 0.1), 2);
    assert_eq!(level_with_hysteresis(90.0, 300.0, 2, 0.1), 3);
    assert_eq!(level_with_hysteresis(100.0, 300.0, 2, 0.0), 3);
}

#[test]
fn a_follower_takes_its_neighbours_weighted_motion() {
    let leaders = nearest(
        Vec3::ZERO,
        &[0, 1, 2, 3],
        &[Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 0.0, 4.0), Vec3::new(9.0, 0.0, 0.0)],
    );
    let ids: Vec<u32> = leaders.iter().map(|l| l.0).collect();
    assert_eq!(ids, [0, 1, 2]);
    let total: f32 = leaders.iter().map(|l| l.1).sum();
    assert!((total - 1.0).abs() < 1e-6);
    assert!(leaders[0].1 > leaders[1].1 && leaders[1].1 > leaders[2].1);
    // One leader only: it carries all the weight.
    let one = nearest(Vec3::ZERO, &[3], &[Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::X]);
    assert_eq!(one[0], (3, 1.0));
    assert_eq!(one[1].1 + one[2].1, 0.0);
}
