//! The reference's roots: drawn from the scalp-labelled vertices themselves.

use super::{GroomError, RootBinding, SplitMix64};
use crate::mesh::HeadMesh;

/// Samples `count` roots from the vertices, each with probability proportional to its
/// weight (labels of 1 and 0: uniformly from the labelled vertices), as the reference
/// does. A root sits on its vertex, so it grows along the vertex normal
/// ([`RootBinding::normal`]). With `jitter` above 0 it moves off the vertex into one of
/// the triangles around it, up to `jitter` of the way to the far edge (1: anywhere in the
/// vertex's one-ring), and grows along the normal interpolated there.
///
/// The area-weighted samplers ([`sample_roots`](super::sample_roots),
/// [`sample_roots_poisson`](super::sample_roots_poisson)) are the better default: vertex
/// roots follow the tessellation (twice the vertices in a region, twice the hair there)
/// and repeat a vertex when there are more roots than labelled vertices, where the jitter
/// keeps them from growing as one.
///
/// Errors: the mesh is unusable, the weights do not match the vertices one to one, no
/// vertex of a triangle has a weight above 0, or `jitter` is not in 0..=1.
pub fn sample_roots_at_vertices(
    mesh: &HeadMesh,
    vertex_weights: &[f32],
    count: usize,
    jitter: f32,
    seed: u64,
) -> Result<Vec<RootBinding>, GroomError> {
    mesh.validate()?;
    if vertex_weights.len() != mesh.positions.len() {
        return Err(GroomError::VertexWeightCountMismatch {
            vertices: mesh.positions.len(),
            weights: vertex_weights.len(),
        });
    }
    if !(0.0..=1.0).contains(&jitter) {
        return Err(GroomError::Jitter(jitter));
    }
    // Each vertex's triangles, as (triangle, which corner it is).
    let mut ring: Vec<Vec<(u32, usize)>> = vec![Vec::new(); mesh.positions.len()];
    for (t, triangle) in mesh.triangles.iter().enumerate() {
        for (corner, &v) in triangle.iter().enumerate() {
            ring[v as usize].push((t as u32, corner));
        }
    }
    // Running sum of the weights of vertices on some triangle (a loose vertex has no normal).
    let mut cumulative = Vec::with_capacity(ring.len());
    let mut total = 0.0f64;
    for (w, triangles) in vertex_weights.iter().zip(&ring) {
        let w = if w.is_finite() && !triangles.is_empty() { w.clamp(0.0, 1.0) } else { 0.0 };
        total += f64::from(w);
        cumulative.push(total);
    }
    if total <= 0.0 {
        return Err(GroomError::NoScalp);
    }
    let mut rng = SplitMix64::new(seed ^ 0x7665_7274_6578);
    Ok((0..count)
        .map(|_| {
            let target = rng.next_f64() * total;
            let vertex = cumulative.partition_point(|&c| c <= target).min(cumulative.len() - 1);
            let triangles = &ring[vertex];
            if jitter == 0.0 {
                let (triangle, corner) = triangles[0];
                let mut barycentric = [0.0; 3];
                barycentric[corner] = 1.0;
                return RootBinding { triangle, barycentric };
            }
            let (triangle, corner) = triangles[(rng.next_u64() % triangles.len() as u64) as usize];
            // A uniform point of the triangle, pulled toward the vertex by `jitter`.
            let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            let mut barycentric = [0.0; 3];
            barycentric[corner] = 1.0 - jitter * (u + v);
            barycentric[(corner + 1) % 3] = jitter * u;
            barycentric[(corner + 2) % 3] = jitter * v;
            RootBinding { triangle, barycentric }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::groom::{GuideParams, grow_guides};
    use crate::mesh::test_head;

    /// Roots on the upper half's vertices of the procedural head.
    fn upper_half(mesh: &HeadMesh) -> Vec<f32> {
        mesh.positions.iter().map(|p| if p.y > 0.02 { 1.0 } else { 0.0 }).collect()
    }

    #[test]
    fn roots_sit_on_labelled_vertices_uniformly_and_grow_along_the_vertex_normal() {
        let mesh = test_head(3);
        let labels = upper_half(&mesh);
        let labelled = labels.iter().filter(|&&w| w > 0.0).count();
        let count = 40 * labelled;
        let roots = sample_roots_at_vertices(&mesh, &labels, count, 0.0, 7).unwrap();
        assert_eq!(roots, sample_roots_at_vertices(&mesh, &labels, count, 0.0, 7).unwrap(), "deterministic");
        let mut hits = vec![0usize; mesh.positions.len()];
        for root in &roots {
            let corner = root.barycentric.iter().position(|&b| b == 1.0).expect("on a corner");
            let vertex = mesh.triangles[root.triangle as usize][corner] as usize;
            assert_eq!(labels[vertex], 1.0, "an unlabelled vertex");
            assert!((root.position(&mesh) - mesh.positions[vertex]).length() < 1e-7);
            hits[vertex] += 1;
        }
        // Uniform over the labelled vertices: 40 expected each, a binomial's σ ≈ 6.3.
        let (fewest, most) = hits
            .iter()
            .zip(&labels)
            .filter(|(_, w)| **w > 0.0)
            .fold((usize::MAX, 0), |(lo, hi), (&h, _)| (lo.min(h), hi.max(h)));
        println!("{labelled} labelled vertices, {count} roots: {fewest}..{most} per vertex (40 expected)");
        assert!(fewest >= 15 && most <= 65, "{fewest}..{most}");
        // The first segment grows along the vertex normal.
        let guides = grow_guides(&mesh, &roots[..50], &GuideParams::default(), 1).unwrap();
        for (root, strand) in roots[..50].iter().zip(guides.chunks_exact(11)) {
            let corner = root.barycentric.iter().position(|&b| b == 1.0).unwrap();
            let normal = mesh.normals[mesh.triangles[root.triangle as usize][corner] as usize];
            let first = (strand[1] - strand[0]).normalize();
            assert!(first.dot(normal) > 1.0 - 1e-6, "{first} vs {normal}");
        }
    }

    #[test]
    fn jitter_stays_in_the_one_ring() {
        let mesh = test_head(3);
        let labels = upper_half(&mesh);
        let roots = sample_roots_at_vertices(&mesh, &labels, 2000, 0.5, 3).unwrap();
        let mut off_vertex = 0;
        for root in &roots {
            let b = root.barycentric;
            assert!(b.iter().all(|&x| (0.0..=1.0).contains(&x)) && (b.iter().sum::<f32>() - 1.0).abs() < 1e-6);
            // At most half way from a labelled corner to the far edge.
            let (corner, &nearest) = b.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).unwrap();
            assert!(nearest >= 0.5 - 1e-6, "{b:?}");
            assert_eq!(labels[mesh.triangles[root.triangle as usize][corner] as usize], 1.0);
            off_vertex += usize::from(nearest < 0.999);
        }
        assert!(off_vertex > 1900, "jitter moved only {off_vertex} of 2000 roots off their vertex");
    }

    #[test]
    fn bad_inputs_are_errors() {
        let mesh = test_head(1);
        let labels = upper_half(&mesh);
        assert_eq!(
            sample_roots_at_vertices(&mesh, &labels[1..], 5, 0.0, 1),
            Err(GroomError::VertexWeightCountMismatch {
                vertices: mesh.positions.len(),
                weights: mesh.positions.len() - 1
            })
        );
        assert_eq!(sample_roots_at_vertices(&mesh, &vec![0.0; labels.len()], 5, 0.0, 1), Err(GroomError::NoScalp));
        let nan = vec![f32::NAN; labels.len()];
        assert_eq!(sample_roots_at_vertices(&mesh, &nan, 5, 0.0, 1), Err(GroomError::NoScalp));
        for jitter in [f32::NAN, -0.1, 1.5] {
            assert!(matches!(sample_roots_at_vertices(&mesh, &labels, 5, jitter, 1), Err(GroomError::Jitter(_))));
        }
    }
}
