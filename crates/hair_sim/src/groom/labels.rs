//! Scalp labels: which vertices may grow hair, and how densely.

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

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
}
