//! Scalp labels: which vertices may grow hair, and how densely.

use crate::math::Vec3;
use crate::mesh::HeadMesh;

/// The reference's labels from vertex colours: 1 where the paint is darker than
/// `threshold` (relative luminance of linear RGB), else 0. Scalp is painted black.
pub fn labels_from_colors(colors: &[[f32; 4]], threshold: f32) -> Vec<f32> {
    colors
        .iter()
        .map(|[r, g, b, _]| {
            let luminance = 0.2126 * r + 0.7152 * g + 0.0722 * b;
            if luminance < threshold { 1.0 } else { 0.0 }
        })
        .collect()
}

/// Per-triangle weights from per-vertex weights: the smallest of the three corners, so a
/// triangle grows hair only where all of it is scalp and roots never cross the hairline.
/// Non-finite weights count as 0; weights are clamped to 0..1.
pub fn triangle_weights(mesh: &HeadMesh, vertex_weights: &[f32]) -> Vec<f32> {
    let weight =
        |i: u32| vertex_weights.get(i as usize).copied().filter(|w| w.is_finite()).unwrap_or(0.0).clamp(0.0, 1.0);
    mesh.triangles.iter().map(|t| t.iter().map(|&i| weight(i)).fold(1.0, f32::min)).collect()
}

/// The painted patches of a head: its triangles with a weight above 0 joined where they
/// share a corner, as their areas (m²), largest first. Corners are compared by position, so
/// the two sides of a seam whose vertices the mesh splits (a UV sphere's, say) join. A
/// scalp painted as one region is one patch; paint an exporter scrambled (Blender 3.4's glTF
/// exporter does on the face-corner domain) is many small ones.
pub fn painted_patches(mesh: &HeadMesh, triangle_weights: &[f32]) -> Vec<f32> {
    fn root(parent: &mut [usize], mut t: usize) -> usize {
        while parent[t] != t {
            parent[t] = parent[parent[t]];
            t = parent[t];
        }
        t
    }
    let painted = |t: usize| triangle_weights.get(t).is_some_and(|&w| w > 0.0);
    let mut parent: Vec<usize> = (0..mesh.triangles.len()).collect();
    let mut first_at: std::collections::HashMap<[u32; 3], usize> = std::collections::HashMap::new();
    for (t, corners) in mesh.triangles.iter().enumerate().filter(|&(t, _)| painted(t)) {
        for &v in corners {
            let Some(p) = mesh.positions.get(v as usize) else { continue };
            let other = *first_at.entry(p.to_array().map(f32::to_bits)).or_insert(t);
            let (a, b) = (root(&mut parent, t), root(&mut parent, other));
            parent[a] = b;
        }
    }
    let mut areas: std::collections::HashMap<usize, f32> = std::collections::HashMap::new();
    for (t, corners) in mesh.triangles.iter().enumerate().filter(|&(t, _)| painted(t)) {
        let [a, b, c] = corners.map(|v| mesh.positions.get(v as usize).copied().unwrap_or(Vec3::ZERO));
        *areas.entry(root(&mut parent, t)).or_default() += 0.5 * (b - a).cross(c - a).length();
    }
    let mut areas: Vec<f32> = areas.into_values().collect();
    areas.sort_by(|a, b| b.total_cmp(a));
    areas
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dark_paint_is_scalp() {
        let labels = labels_from_colors(&[[0.0, 0.0, 0.0, 1.0], [1.0, 1.0, 1.0, 1.0], [0.3, 0.3, 0.3, 1.0]], 0.5);
        assert_eq!(labels, [1.0, 0.0, 1.0]);
    }

    #[test]
    fn a_triangle_needs_all_corners_on_the_scalp() {
        let mesh = HeadMesh::from_triangles(
            vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)],
            vec![[0, 1, 2], [1, 3, 2]],
        )
        .unwrap();
        assert_eq!(triangle_weights(&mesh, &[1.0, 1.0, 1.0, 0.0]), [1.0, 0.0]);
        assert_eq!(triangle_weights(&mesh, &[0.5, f32::NAN, 1.0, 1.0]), [0.0, 0.0]);
        assert_eq!(triangle_weights(&mesh, &[0.5, 0.7, 2.0, 1.0]), [0.5, 0.7]);
    }

    #[test]
    fn painted_triangles_join_into_patches_across_split_seams() {
        // A strip of four unit squares along x (two triangles each); the second square's
        // vertices are split from the first's (a seam: equal positions, other indices).
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for square in 0..4u32 {
            let at = positions.len() as u32;
            let x = square as f32;
            positions.extend([Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 0.0, 0.0), Vec3::new(x, 1.0, 0.0)]);
            positions.push(Vec3::new(x + 1.0, 1.0, 0.0));
            triangles.extend([[at, at + 1, at + 2], [at + 1, at + 3, at + 2]]);
        }
        let mesh = HeadMesh::from_triangles(positions, triangles).unwrap();
        // Squares 0 and 1 painted (joined across the seam), square 3 painted apart.
        let weights = [1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.5];
        let patches = painted_patches(&mesh, &weights);
        assert_eq!(patches, [2.0, 1.0]);
        assert!(painted_patches(&mesh, &[0.0; 8]).is_empty());
    }
}
