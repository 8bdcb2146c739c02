//! Evenly spaced roots: Poisson-disk sampling by dart throwing.
//!
//! Independent random roots clump and leave bald gaps (the nearest neighbour of some root
//! is always far closer than the average spacing). Here a candidate root is kept only if
//! no kept root lies within the spacing radius, which gives the even "blue noise" spacing
//! of real follicles while still following the weights.

use super::{AreaSampler, GroomError, RootBinding, SplitMix64};
use crate::math::Vec3;
use crate::mesh::HeadMesh;
use std::collections::HashMap;

/// Starting spacing radius as a fraction of `sqrt(weighted area / count)`. Random dart
/// throwing saturates at about 0.7·A/r² points (Torquato's 0.547 coverage of the r/2
/// disks), so at 0.7 the asked count is ~70% of saturation: reached without endless
/// misses, yet with a radius most of the mean spacing.
const SPACING: f64 = 0.7;

/// Consecutive rejected candidates after which the radius shrinks: by then under ~1/64 of
/// the surface is still free, and waiting for it costs more than it gains.
const MAX_MISSES: u32 = 64;

/// Factor the radius shrinks by after [`MAX_MISSES`] misses in a row.
const SHRINK: f32 = 0.9;

/// Largest spacing factor `1/√weight`: triangles weighted below 1/9 are spaced as if 1/9
/// (their candidates still come in proportion to the weight).
const MAX_SPACING_FACTOR: f32 = 3.0;

/// Samples exactly `count` roots like [`sample_roots`](super::sample_roots) (by weighted
/// area, deterministic for a seed), but evenly spaced: candidates from the same
/// area-weighted sampler are rejected when closer than `r·max(f_a, f_b)` to a kept root,
/// where `r` starts at 0.7·√(weighted area / count) and `f = 1/√weight` (≤ 3) keeps the
/// density proportional to the weight. After 64 rejections in a row `r` shrinks by 10%,
/// so the count is always reached. Distances are straight-line (a hash grid of cell `r`).
pub fn sample_roots_poisson(
    mesh: &HeadMesh,
    weights: &[f32],
    count: usize,
    seed: u64,
) -> Result<Vec<RootBinding>, GroomError> {
    let sampler = AreaSampler::new(mesh, weights)?;
    let radius = (SPACING * (sampler.weighted_area() / count.max(1) as f64).sqrt()) as f32;
    Ok(dart_throw(mesh, &sampler, count, seed, radius).0)
}

/// Dart throwing from `radius` down; returns the roots and the final radius.
fn dart_throw(mesh: &HeadMesh, sampler: &AreaSampler, count: usize, seed: u64, radius: f32) -> (Vec<RootBinding>, f32) {
    // A radius that is not positive and finite cannot space anything: accept every candidate.
    let mut radius = if radius.is_finite() && radius > 0.0 { radius } else { 0.0 };
    // The radius only shrinks, so cells of the starting radius stay valid (just coarser).
    let cell = if radius > 0.0 { radius } else { 1.0 };
    let cell_of = |p: Vec3| (p / cell).floor().as_ivec3().to_array();
    let mut rng = SplitMix64::new(seed);
    let mut roots = Vec::with_capacity(count);
    let mut kept: Vec<(Vec3, f32)> = Vec::with_capacity(count); // position, spacing factor
    let mut grid: HashMap<[i32; 3], Vec<u32>> = HashMap::new();
    let mut widest = 1.0f32; // the largest spacing factor kept so far
    let mut misses = 0;
    while roots.len() < count {
        let candidate = sampler.sample(&mut rng);
        let position = candidate.position(mesh);
        let factor = (1.0 / sampler.weight(candidate.triangle).sqrt()).min(MAX_SPACING_FACTOR);
        let [cx, cy, cz] = cell_of(position);
        let span = (radius * factor.max(widest) / cell).ceil() as i32;
        let mut crowded = false;
        'search: for dx in -span..=span {
            for dy in -span..=span {
                for dz in -span..=span {
                    let key = [cx.wrapping_add(dx), cy.wrapping_add(dy), cz.wrapping_add(dz)];
                    for &j in grid.get(&key).map_or(&[][..], Vec::as_slice) {
                        let (other, other_factor) = kept[j as usize];
                        let min_distance = radius * factor.max(other_factor);
                        if (other - position).length_squared() < min_distance * min_distance {
                            crowded = true;
                            break 'search;
                        }
                    }
                }
            }
        }
        if crowded {
            misses += 1;
            if misses >= MAX_MISSES {
                radius *= SHRINK;
                misses = 0;
            }
            continue;
        }
        misses = 0;
        grid.entry([cx, cy, cz]).or_default().push(kept.len() as u32);
        kept.push((position, factor));
        widest = widest.max(factor);
        roots.push(candidate);
    }
    (roots, radius)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::groom::sample_roots;
    use crate::mesh::test_head;

    fn top_half(mesh: &HeadMesh) -> Vec<f32> {
        mesh.triangles.iter().map(|t| if mesh.corners(t).iter().all(|p| p.y > 0.0) { 1.0 } else { 0.0 }).collect()
    }

    /// The smallest distance between two roots.
    fn min_neighbour_distance(mesh: &HeadMesh, roots: &[RootBinding]) -> f32 {
        let points: Vec<Vec3> = roots.iter().map(|r| r.position(mesh)).collect();
        let mut min = f32::MAX;
        for (i, a) in points.iter().enumerate() {
            for b in &points[i + 1..] {
                min = min.min((*a - *b).length());
            }
        }
        min
    }

    #[test]
    fn poisson_roots_are_exact_deterministic_and_on_the_scalp() {
        let mesh = test_head(3);
        let weights = top_half(&mesh);
        for count in [0, 1, 7, 300] {
            let roots = sample_roots_poisson(&mesh, &weights, count, 7).unwrap();
            assert_eq!(roots.len(), count);
            assert!(roots.iter().all(|r| weights[r.triangle as usize] == 1.0));
            assert!(roots.iter().all(|r| (r.barycentric.iter().sum::<f32>() - 1.0).abs() < 1e-5));
            assert!(roots.iter().all(|r| r.barycentric.iter().all(|&b| b >= 0.0)));
            assert_eq!(roots, sample_roots_poisson(&mesh, &weights, count, 7).unwrap());
        }
        let a = sample_roots_poisson(&mesh, &weights, 300, 7).unwrap();
        assert_ne!(a, sample_roots_poisson(&mesh, &weights, 300, 8).unwrap());
        let zero = vec![0.0; mesh.triangles.len()];
        assert_eq!(sample_roots_poisson(&mesh, &zero, 10, 0), Err(GroomError::NoScalp));
        assert!(matches!(sample_roots_poisson(&mesh, &[1.0], 10, 0), Err(GroomError::WeightCountMismatch { .. })));
    }

    #[test]
    fn poisson_roots_are_spaced_far_more_evenly_than_random_ones() {
        let mesh = test_head(4);
        let weights = top_half(&mesh);
        let count = 1000;
        let area: f64 = (0..mesh.triangles.len()).map(|t| (mesh.triangle_area(t) * weights[t]) as f64).sum();
        let mean_spacing = (area / count as f64).sqrt() as f32;
        let random = min_neighbour_distance(&mesh, &sample_roots(&mesh, &weights, count, 3).unwrap());
        let even = min_neighbour_distance(&mesh, &sample_roots_poisson(&mesh, &weights, count, 3).unwrap());
        println!(
            "{count} roots on test_head(4), top half ({area:.4} m², √(area/count) = {:.2} mm): \
             min nearest-neighbour distance uniform {:.3} mm, Poisson {:.3} mm",
            mean_spacing * 1e3,
            random * 1e3,
            even * 1e3
        );
        // Poisson keeps the starting radius unless it had to shrink it (by 10% steps).
        assert!(even >= 0.6 * mean_spacing, "Poisson {even} vs spacing {mean_spacing}");
        assert!(even > 10.0 * random, "Poisson {even} vs uniform {random}");
    }

    #[test]
    fn the_radius_shrinks_until_the_count_is_reached() {
        // A radius of a metre on a head 20 cm across fits one root; shrinking must get to 50.
        let mesh = test_head(2);
        let weights = top_half(&mesh);
        let sampler = AreaSampler::new(&mesh, &weights).unwrap();
        let (roots, radius) = dart_throw(&mesh, &sampler, 50, 1, 1.0);
        assert_eq!(roots.len(), 50);
        assert!(radius < 0.05, "{radius}");
        assert!(min_neighbour_distance(&mesh, &roots) >= radius);
        // And a useless radius degrades to plain sampling rather than looping.
        for bad in [f32::NAN, f32::INFINITY, 0.0, -1.0] {
            let (roots, _) = dart_throw(&mesh, &sampler, 20, 1, bad);
            assert_eq!(roots, sample_roots(&mesh, &weights, 20, 1).unwrap());
        }
    }

    #[test]
    fn density_follows_the_weights() {
        // A square of two equal halves weighted 1 and 0.25: about a fifth of the roots
        // belong on the light half.
        let positions = vec![
            Vec3::ZERO,
            Vec3::new(0.1, 0.0, 0.0),
            Vec3::new(0.2, 0.0, 0.0),
            Vec3::new(0.0, 0.2, 0.0),
            Vec3::new(0.1, 0.2, 0.0),
            Vec3::new(0.2, 0.2, 0.0),
        ];
        let triangles = vec![[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]];
        let mesh = HeadMesh::from_triangles(positions, triangles).unwrap();
        let roots = sample_roots_poisson(&mesh, &[1.0, 1.0, 0.25, 0.25], 1000, 5).unwrap();
        let light = roots.iter().filter(|r| r.triangle >= 2).count() as f32 / 1000.0;
        println!("fraction of Poisson roots on the 0.25-weighted half: {light:.3} (ideal 0.2)");
        assert!((light - 0.2).abs() < 0.05, "{light}");
    }
}
