//! A procedural stand-in head: an ellipsoid with two ears, closed and consistently wound.
//!
//! Tests and benchmarks need a head that is watertight (the collider's inside test depends
//! on it) and has concave places (where the ears meet the skull: pushing out from the head
//! centre fails there, pushing along the surface normal does not). Displacing an icosphere
//! radially gives both for free: every direction from the centre hits the surface once.

use super::HeadMesh;
use crate::math::Vec3;
use std::collections::HashMap;

/// Half-extents of the skull ellipsoid, metres: width, height, depth of a typical adult.
const SKULL_RADII: Vec3 = Vec3::new(0.075, 0.11, 0.095);
/// How far an ear stands out from the skull, metres.
const EAR_HEIGHT: f32 = 0.03;
/// Angular half-width of an ear, radians.
const EAR_WIDTH: f32 = 0.18;

/// An ellipsoid head with ears, centred at the origin, +Y up, +Z forward (the face).
///
/// `subdivisions` refines an icosahedron: 20·4ⁿ triangles (n = 4 gives 5,120, n = 5 gives
/// 20,480). The skull spans ±7.5 cm across, ±11 cm vertically and ±9.5 cm front to back;
/// each ear stands 3 cm out of the side of the skull.
pub fn test_head(subdivisions: u32) -> HeadMesh {
    let (directions, triangles) = icosphere(subdivisions);
    let positions = directions.iter().map(|&d| d * head_radius(d)).collect();
    HeadMesh::from_triangles(positions, triangles).expect("the procedural head is a valid closed mesh")
}

/// The scalp the benchmarks and tests paint on [`test_head`]: per triangle, 1 where its
/// centre lies above the ears' level (y > 1 cm) and behind the hairline (z < 6 cm), else 0.
pub fn test_scalp(head: &HeadMesh) -> Vec<f32> {
    head.triangles
        .iter()
        .map(|t| {
            let c = head.corners(t).iter().sum::<Vec3>() / 3.0;
            if c.y > 0.01 && c.z < 0.06 { 1.0 } else { 0.0 }
        })
        .collect()
}

/// Distance from the centre to the surface along the unit direction `d`.
fn head_radius(d: Vec3) -> f32 {
    let skull = 1.0 / (d / SKULL_RADII).length();
    let ear_axis = |side: f32| Vec3::new(side, 0.05, -0.1).normalize();
    let ear = |side: f32| {
        let angle = d.angle_between(ear_axis(side));
        EAR_HEIGHT * (-(angle / EAR_WIDTH).powi(2)).exp()
    };
    skull + ear(1.0) + ear(-1.0)
}

/// Unit-sphere vertices and outward-wound triangles of a subdivided icosahedron.
fn icosphere(subdivisions: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut vertices: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|&v| Vec3::from_array(v).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, vertices: &mut Vec<Vec3>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                vertices.push(((vertices[a as usize] + vertices[b as usize]) * 0.5).normalize());
                vertices.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let ab = midpoint(a, b, &mut vertices);
            let bc = midpoint(b, c, &mut vertices);
            let ca = midpoint(c, a, &mut vertices);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    (vertices, triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_outward_and_sized() {
        let head = test_head(4);
        assert_eq!(head.triangles.len(), 5120);
        // Euler characteristic of a closed sphere: V − E + F = 2, with E = 3F/2.
        let (v, f) = (head.positions.len() as i64, head.triangles.len() as i64);
        assert_eq!(v - 3 * f / 2 + f, 2);
        // Outward winding: every face normal points away from the centre.
        for tri in &head.triangles {
            let [a, b, c] = head.corners(tri);
            assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
        }
        let top = head.positions.iter().map(|p| p.y).fold(f32::MIN, f32::max);
        assert!((top - 0.11).abs() < 1e-3, "crown at {top}");
        let side = head.positions.iter().map(|p| p.x).fold(f32::MIN, f32::max);
        assert!(side > 0.075 + 0.02, "the ear stands out: {side}");
    }
}
