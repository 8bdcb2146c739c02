use super::*;

#[test]
fn gusts_vary_smoothly_around_the_mean() {
    let wind = Wind { direction: [2.0, 0.0, 0.0], strength: 3.0, gust_strength: 0.5, gust_frequency: 1.0 };
    let samples: Vec<f32> = (0..600).map(|k| wind_at(&wind, 7, k as f32 / 60.0).x).collect();
    let mean = samples.iter().sum::<f32>() / samples.len() as f32;
    assert!((mean - 3.0).abs() < 0.6, "mean {mean}");
    assert!(samples.iter().all(|&s| (1.5..=4.5).contains(&s)));
    let biggest_jump = samples.windows(2).map(|w| (w[1] - w[0]).abs()).fold(0.0, f32::max);
    assert!(biggest_jump < 0.2, "smooth: {biggest_jump}");
    assert!(samples.iter().any(|&s| (s - samples[0]).abs() > 0.3), "it does gust");
    assert_eq!(wind_at(&Wind { strength: 0.0, ..wind }, 1, 0.5), Vec3::ZERO);
}

#[test]
fn hash_is_uniform_enough() {
    let mean = (0..10_000).map(hash01).sum::<f32>() / 10_000.0;
    assert!((mean - 0.5).abs() < 0.01);
    assert!((0..10_000).map(hash01).all(|h| (0.0..1.0).contains(&h)));
}
