//! The head mesh the hair grows on and collides with, and its validation.
//!
//! [`HeadMesh`] is a plain indexed triangle list in head-local space (metres). Everything
//! that can be wrong with a mesh a user hands us is caught here, once, as a [`MeshError`]
//! with a readable reason, so the solver and the collider can assume clean input.

mod procedural;

pub use procedural::test_head;

use crate::math::Vec3;
use std::fmt;

/// An indexed triangle mesh in head-local space, with one normal per vertex.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HeadMesh {
    /// Vertex positions, metres, head-local.
    pub positions: Vec<Vec3>,
    /// Unit vertex normals, pointing out of the head; same length as `positions`.
    pub normals: Vec<Vec3>,
    /// Triangles as indices into `positions`, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
}

/// Why a mesh cannot be used as a head.
#[derive(Clone, Debug, PartialEq)]
pub enum MeshError {
    /// The mesh has no vertices or no triangles.
    Empty,
    /// A triangle refers to a vertex that does not exist.
    IndexOutOfRange {
        /// The triangle with the bad index.
        triangle: usize,
        /// The index it holds.
        index: u32,
        /// How many vertices the mesh has.
        vertex_count: usize,
    },
    /// A vertex position or normal is NaN or infinite.
    NonFinite {
        /// The first vertex with a non-finite value.
        vertex: usize,
    },
    /// The normals do not match the positions one to one.
    NormalCountMismatch {
        /// Number of positions.
        positions: usize,
        /// Number of normals.
        normals: usize,
    },
    /// Every triangle has zero area, so there is no surface to grow on or collide with.
    Degenerate,
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MeshError::Empty => write!(f, "the head mesh has no triangles"),
            MeshError::IndexOutOfRange { triangle, index, vertex_count } => {
                write!(f, "triangle {triangle} uses vertex {index}, but the mesh has only {vertex_count} vertices")
            }
            MeshError::NonFinite { vertex } => {
                write!(f, "vertex {vertex} has a NaN or infinite position or normal")
            }
            MeshError::NormalCountMismatch { positions, normals } => {
                write!(f, "the mesh has {positions} positions but {normals} normals")
            }
            MeshError::Degenerate => write!(f, "every triangle of the head mesh has zero area"),
        }
    }
}

impl std::error::Error for MeshError {}

impl HeadMesh {
    /// Builds a mesh and computes area-weighted vertex normals from the triangles.
    pub fn from_triangles(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<Self, MeshError> {
        let mut mesh = HeadMesh { normals: vec![Vec3::ZERO; positions.len()], positions, triangles };
        mesh.check_indices()?;
        mesh.recompute_normals();
        mesh.validate()?;
        Ok(mesh)
    }

    /// Checks that the mesh is usable: non-empty, indices in range, finite values, and
    /// at least one triangle with area.
    pub fn validate(&self) -> Result<(), MeshError> {
        if self.positions.is_empty() || self.triangles.is_empty() {
            return Err(MeshError::Empty);
        }
        if self.normals.len() != self.positions.len() {
            return Err(MeshError::NormalCountMismatch {
                positions: self.positions.len(),
                normals: self.normals.len(),
            });
        }
        self.check_indices()?;
        let bad = self.positions.iter().zip(&self.normals).position(|(p, n)| !p.is_finite() || !n.is_finite());
        if let Some(vertex) = bad {
            return Err(MeshError::NonFinite { vertex });
        }
        if self.total_area() <= f32::EPSILON {
            return Err(MeshError::Degenerate);
        }
        Ok(())
    }

    fn check_indices(&self) -> Result<(), MeshError> {
        let vertex_count = self.positions.len();
        for (triangle, tri) in self.triangles.iter().enumerate() {
            if let Some(&index) = tri.iter().find(|&&i| i as usize >= vertex_count) {
                return Err(MeshError::IndexOutOfRange { triangle, index, vertex_count });
            }
        }
        Ok(())
    }

    /// Replaces the normals with area-weighted averages of the adjacent face normals.
    pub fn recompute_normals(&mut self) {
        let mut normals = vec![Vec3::ZERO; self.positions.len()];
        for tri in &self.triangles {
            let [a, b, c] = self.corners(tri);
            let face = (b - a).cross(c - a); // length = 2 × area: the area weighting
            for &i in tri {
                normals[i as usize] += face;
            }
        }
        self.normals = normals.into_iter().map(|n| n.normalize_or(Vec3::Y)).collect();
    }

    /// The three corner positions of a triangle.
    #[inline]
    pub fn corners(&self, tri: &[u32; 3]) -> [Vec3; 3] {
        tri.map(|i| self.positions[i as usize])
    }

    /// The area of triangle `t`.
    pub fn triangle_area(&self, t: usize) -> f32 {
        let [a, b, c] = self.corners(&self.triangles[t]);
        0.5 * (b - a).cross(c - a).length()
    }

    /// The summed area of all triangles.
    pub fn total_area(&self) -> f32 {
        (0..self.triangles.len()).map(|t| self.triangle_area(t)).sum()
    }

    /// Point on triangle `t` at barycentric coordinates `bary`.
    #[inline]
    pub fn point_at(&self, t: usize, bary: [f32; 3]) -> Vec3 {
        let [a, b, c] = self.corners(&self.triangles[t]);
        a * bary[0] + b * bary[1] + c * bary[2]
    }

    /// Interpolated unit normal on triangle `t` at barycentric coordinates `bary`.
    #[inline]
    pub fn normal_at(&self, t: usize, bary: [f32; 3]) -> Vec3 {
        let [a, b, c] = self.triangles[t].map(|i| self.normals[i as usize]);
        (a * bary[0] + b * bary[1] + c * bary[2]).normalize_or(Vec3::Y)
    }

    /// The mesh scaled about its origin: the collider is built in the head's scaled space.
    pub fn scaled(&self, scale: Vec3) -> HeadMesh {
        let mut mesh = self.clone();
        mesh.positions.iter_mut().for_each(|p| *p *= scale);
        mesh.recompute_normals();
        mesh
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one_triangle() -> HeadMesh {
        HeadMesh::from_triangles(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap()
    }

    #[test]
    fn normals_follow_winding() {
        let mesh = one_triangle();
        assert!((mesh.normals[0] - Vec3::Z).length() < 1e-6);
        assert!((mesh.triangle_area(0) - 0.5).abs() < 1e-6);
    }

    #[test]
    fn bad_meshes_are_named() {
        assert_eq!(HeadMesh::from_triangles(vec![], vec![]), Err(MeshError::Empty));
        let err = HeadMesh::from_triangles(vec![Vec3::ZERO; 3], vec![[0, 1, 7]]).unwrap_err();
        assert_eq!(err, MeshError::IndexOutOfRange { triangle: 0, index: 7, vertex_count: 3 });
        assert!(err.to_string().contains("vertex 7"));
        assert_eq!(
            HeadMesh::from_triangles(vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0], vec![[0, 1, 2]]),
            Err(MeshError::Degenerate)
        );
        let nan = HeadMesh::from_triangles(vec![Vec3::ZERO, Vec3::NAN, Vec3::Y], vec![[0, 1, 2]]);
        assert_eq!(nan, Err(MeshError::NonFinite { vertex: 1 }));
    }

    #[test]
    fn point_and_normal_interpolate() {
        let mesh = one_triangle();
        let p = mesh.point_at(0, [0.2, 0.3, 0.5]);
        assert!((p - Vec3::new(0.3, 0.5, 0.0)).length() < 1e-6);
        assert!((mesh.normal_at(0, [0.2, 0.3, 0.5]) - Vec3::Z).length() < 1e-6);
    }
}
