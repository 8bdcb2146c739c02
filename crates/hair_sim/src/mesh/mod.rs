//! The head mesh the hair grows on and collides with, and its validation.
//!
//! [`HeadMesh`] is a plain indexed triangle list in head-local space (metres). Everything
//! that can be wrong with a mesh a user hands us is caught here, once, as a [`MeshError`]
//! with a readable reason, so the solver and the collider can assume clean input. What can
//! be repaired is ([`HeadMesh::repaired`]): triangles without area are dropped and a mesh
//! wound inside out is turned the right way, and the caller is told ([`MeshRepairs`]).

mod inside;
pub(crate) use inside::closest_barycentric;
mod procedural;

pub use inside::{InsideTest, StrandsInside};
pub use procedural::{test_head, test_scalp};

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

/// What [`HeadMesh::repaired`] changed. A user's mesh should not need either: report them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MeshRepairs {
    /// Triangles dropped for having no area: repeated corners, three corners on a line,
    /// or a triangle so thin that its normal is rounding noise.
    pub degenerate_triangles: usize,
    /// The mesh enclosed negative volume (wound clockwise seen from outside, so inside and
    /// outside were swapped); every triangle was turned over.
    pub flipped_winding: bool,
}

impl MeshRepairs {
    /// Whether anything was repaired.
    pub fn any(&self) -> bool {
        self.degenerate_triangles > 0 || self.flipped_winding
    }
}

impl fmt::Display for MeshRepairs {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = Vec::new();
        if self.degenerate_triangles > 0 {
            parts.push(format!("dropped {} triangles without area", self.degenerate_triangles));
        }
        if self.flipped_winding {
            parts.push("turned the mesh right side out (it was wound inside out: negative volume)".to_owned());
        }
        if parts.is_empty() { write!(f, "nothing repaired") } else { write!(f, "{}", parts.join("; ")) }
    }
}

/// A triangle is degenerate when twice its area is below this fraction of its longest
/// edge squared: its height is under 1e-6 of its length, so its normal is rounding noise.
const DEGENERATE_ASPECT: f32 = 1e-6;

impl HeadMesh {
    /// Builds a mesh and computes area-weighted vertex normals from the triangles.
    pub fn from_triangles(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<Self, MeshError> {
        let mut mesh = HeadMesh { normals: vec![Vec3::ZERO; positions.len()], positions, triangles };
        mesh.check_indices()?;
        mesh.recompute_normals();
        mesh.validate()?;
        Ok(mesh)
    }

    /// Like [`Self::from_triangles`], after repairing what can be repaired: triangles
    /// without area (repeated or collinear corners, slivers thinner than 1e-6 of their
    /// length, NaN corners) are dropped, and a closed mesh that encloses negative volume
    /// (wound inside out) has every triangle turned over. Returns what was repaired so the
    /// caller can report it.
    pub fn repaired(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<(Self, MeshRepairs), MeshError> {
        let mut mesh = HeadMesh { normals: vec![Vec3::ZERO; positions.len()], positions, triangles };
        if mesh.positions.is_empty() || mesh.triangles.is_empty() {
            return Err(MeshError::Empty);
        }
        mesh.check_indices()?;
        let before = mesh.triangles.len();
        let positions = &mesh.positions;
        mesh.triangles.retain(|t| !is_degenerate(t.map(|i| positions[i as usize])));
        let mut repairs = MeshRepairs { degenerate_triangles: before - mesh.triangles.len(), flipped_winding: false };
        if mesh.triangles.is_empty() {
            return Err(MeshError::Degenerate);
        }
        if mesh.signed_volume() < 0.0 {
            mesh.triangles.iter_mut().for_each(|t| t.swap(1, 2));
            repairs.flipped_winding = true;
        }
        mesh.recompute_normals();
        mesh.validate()?;
        Ok((mesh, repairs))
    }

    /// The volume the triangles enclose, m³: positive for a closed mesh wound
    /// counter-clockwise seen from outside, negative for one wound inside out.
    pub fn signed_volume(&self) -> f32 {
        let sum: f64 = self
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = self.corners(t).map(|p| p.as_dvec3());
                a.dot(b.cross(c))
            })
            .sum();
        (sum / 6.0) as f32
    }

    /// Whether `p` is inside the closed mesh, by ray parity: a ray from `p` (along +X,
    /// tilted slightly so it misses edges and vertices) crosses the surface an odd number of
    /// times. Slow (every triangle) and independent of winding and of the collider: it is
    /// the inside test that checks the collider's.
    pub fn contains_by_ray_parity(&self, p: Vec3) -> bool {
        let dir = Vec3::new(1.0, 0.000_123, 0.000_045_7).normalize();
        let crossings =
            self.triangles.iter().filter(|t| inside::ray_hit(p, dir, &self.corners(t)).is_some_and(|d| d > 0.0));
        crossings.count() % 2 == 1
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
        self.normals = area_weighted_normals(&self.positions, &self.triangles);
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

    /// The height of the mesh's bounding box (its extent along y), in its units; 0 without
    /// vertices.
    pub fn height(&self) -> f32 {
        let (low, high) = crate::math::bounds(&self.positions);
        (high.y - low.y).max(0.0)
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

/// No area to speak of (see [`DEGENERATE_ASPECT`]), or not finite.
/// Per vertex, the area-weighted average of the adjacent face normals (+Y for a vertex
/// without any).
pub(crate) fn area_weighted_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; positions.len()];
    for tri in triangles {
        let [a, b, c] = tri.map(|i| positions[i as usize]);
        let face = (b - a).cross(c - a); // length = 2 × area: the area weighting
        for &i in tri {
            normals[i as usize] += face;
        }
    }
    normals.into_iter().map(|n| n.normalize_or(Vec3::Y)).collect()
}

/// The triangles on either side of each edge that exactly two share, as (triangle, its
/// side) pairs; side `k` runs from corner `k` to corner `k + 1` (mod 3). An edge of one
/// triangle (an open mesh) or of more than two is left out.
pub(crate) fn edge_pairs(triangles: &[[u32; 3]]) -> Vec<[(u32, u32); 2]> {
    // Every side as (its corners in order, triangle, side), sorted so that the sides of
    // one edge lie together.
    let mut sides: Vec<([u32; 2], u32, u32)> = triangles
        .iter()
        .enumerate()
        .flat_map(|(t, corners)| {
            (0..3).map(move |k| {
                let (a, b) = (corners[k], corners[(k + 1) % 3]);
                ([a.min(b), a.max(b)], t as u32, k as u32)
            })
        })
        .collect();
    sides.sort_unstable();
    sides
        .chunk_by(|x, y| x.0 == y.0)
        .filter_map(|edge| if let &[(_, t, i), (_, u, j)] = edge { Some([(t, i), (u, j)]) } else { None })
        .collect()
}

pub(crate) fn is_degenerate([a, b, c]: [Vec3; 3]) -> bool {
    let twice_area = (b - a).cross(c - a).length();
    let longest = (b - a).length_squared().max((c - b).length_squared()).max((a - c).length_squared());
    !(twice_area.is_finite() && twice_area > DEGENERATE_ASPECT * longest)
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
    fn slivers_are_dropped_and_inside_out_meshes_turned_over() {
        let head = test_head(2);
        let mut positions = head.positions.clone();
        let mut triangles = head.triangles.clone();
        // Three distinct collinear corners, a repeated corner, and a sliver 1e-8 thick.
        let base = positions.len() as u32;
        positions.extend([Vec3::ZERO, Vec3::new(0.01, 0.0, 0.0), Vec3::new(0.02, 0.0, 0.0)]);
        positions.push(Vec3::new(0.01, 1e-8, 0.0));
        triangles.extend([[base, base + 1, base + 2], [base, base, base + 1], [base, base + 2, base + 3]]);
        let (mesh, repairs) = HeadMesh::repaired(positions.clone(), triangles.clone()).unwrap();
        assert_eq!(repairs, MeshRepairs { degenerate_triangles: 3, flipped_winding: false });
        assert_eq!(mesh.triangles, head.triangles, "only the degenerate ones go");
        assert!(mesh.signed_volume() > 0.0);

        let inverted: Vec<[u32; 3]> = triangles.iter().map(|&[a, b, c]| [a, c, b]).collect();
        let (mesh, repairs) = HeadMesh::repaired(positions, inverted).unwrap();
        assert!(repairs.flipped_winding && repairs.degenerate_triangles == 3, "{repairs:?}");
        assert_eq!(mesh.triangles, head.triangles, "turned back to the original winding");
        assert!((mesh.signed_volume() - head.signed_volume()).abs() < 1e-9);
        assert!(repairs.to_string().contains("inside out"));
        assert_eq!(HeadMesh::repaired(vec![Vec3::ZERO; 3], vec![[0, 1, 2]]), Err(MeshError::Degenerate));
    }

    #[test]
    fn point_and_normal_interpolate() {
        let mesh = one_triangle();
        let p = mesh.point_at(0, [0.2, 0.3, 0.5]);
        assert!((p - Vec3::new(0.3, 0.5, 0.0)).length() < 1e-6);
        assert!((mesh.normal_at(0, [0.2, 0.3, 0.5]) - Vec3::Z).length() < 1e-6);
    }
}
