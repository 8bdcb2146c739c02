use super::*;

/// Exact within the band (to the interpolation error), a bound of the right sign
/// beyond it, on a sphere sampled from its centre to beyond the grid.
#[test]
fn interpolates_a_sphere_within_the_error_bound() {
    let points = [Vec3::splat(-1.0), Vec3::splat(1.0)];
    let grid = DistanceGrid::bake(&points, 32, |p| p.length() - 1.0);
    assert!(grid.margin() >= 0.5);
    let (band, error) = (EXACT_BAND_CELLS * grid.cell_size(), grid.max_error());
    let (mut near, mut far, mut bounded) = (0, 0, 0);
    for i in 0..4000 {
        let direction = Vec3::new((i as f32 * 0.13).sin(), (i as f32 * 0.29).cos(), (i as f32 * 0.07).sin());
        let p = direction.normalize() * (i as f32 / 4000.0) * 1.6;
        let (Some(approx), exact) = (grid.sample(p), p.length() - 1.0) else { continue };
        if exact.abs() < band - error {
            near += 1;
            assert!((approx - exact).abs() <= error, "{approx} vs {exact}");
        } else {
            far += 1;
            assert!(approx.abs() <= exact.abs() + error && approx.signum() == exact.signum(), "{approx} vs {exact}");
            bounded += usize::from((approx - exact).abs() > error);
        }
    }
    println!("{near} samples in the band, {far} beyond it ({bounded} of them bounded, not exact)");
    assert!(near > 1000 && bounded > 100, "both kinds are tested");
    assert_eq!(grid.sample(Vec3::splat(5.0)), None);
    assert_eq!(grid.sample(Vec3::NAN), None);
}
