//! The indexed triangle mesh the converter works on, and the little vector maths it needs.

/// An indexed triangle mesh in double precision (the converter's working form).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<[f64; 3]>,
    /// Triangles as indices into `positions`, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// The three corners of triangle `t`.
    pub fn corners(&self, t: usize) -> [[f64; 3]; 3] {
        self.triangles[t].map(|i| self.positions[i as usize])
    }

    /// Twice the vector area of triangle `t`: normal direction, length 2 × area.
    pub fn area_vector(&self, t: usize) -> [f64; 3] {
        let [a, b, c] = self.corners(t);
        cross(sub(b, a), sub(c, a))
    }

    /// The summed area of all triangles.
    pub fn area(&self) -> f64 {
        (0..self.triangles.len()).map(|t| 0.5 * length(self.area_vector(t))).sum()
    }

    /// The signed volume enclosed (divergence theorem): positive for a closed mesh wound
    /// counter-clockwise seen from outside.
    pub fn signed_volume(&self) -> f64 {
        (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.corners(t);
                dot(a, cross(b, c)) / 6.0
            })
            .sum()
    }

    /// Area-weighted vertex normals (unit length; +Y for a vertex no triangle uses).
    pub fn vertex_normals(&self) -> Vec<[f64; 3]> {
        let mut normals = vec![[0.0; 3]; self.positions.len()];
        for (t, tri) in self.triangles.iter().enumerate() {
            let face = self.area_vector(t); // length 2 × area: the area weighting
            for &i in tri {
                normals[i as usize] = add(normals[i as usize], face);
            }
        }
        normals.into_iter().map(|n| normalize(n).unwrap_or([0.0, 1.0, 0.0])).collect()
    }

    /// Axis-aligned bounds, `(min, max)`; zeros for an empty mesh.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        bounds(&self.positions)
    }
}

/// Axis-aligned bounds of points, `(min, max)`; zeros for no points.
pub fn bounds(points: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    if points.is_empty() {
        return ([0.0; 3], [0.0; 3]);
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

/// `a + b`.
pub fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `a − b`.
pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `a · b`.
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a × b`.
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// `|a|`.
pub fn length(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// `a / |a|`, or `None` for a zero or non-finite vector.
pub fn normalize(a: [f64; 3]) -> Option<[f64; 3]> {
    let l = length(a);
    (l > 0.0 && l.is_finite()).then(|| a.map(|c| c / l))
}

/// Small closed and open meshes for the unit tests.
#[cfg(test)]
pub(crate) mod fixtures {
    use super::TriMesh;

    /// A closed unit cube, outward wound.
    pub fn cube() -> TriMesh {
        let positions = (0..8).map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64]).collect();
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let triangles = quads.iter().flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]]).collect();
        TriMesh { positions, triangles }
    }

    /// The unit cube without its top (+y) face: one square hole.
    pub fn open_box() -> TriMesh {
        let mut mesh = cube();
        mesh.triangles.retain(|t| !t.iter().all(|&v| (v >> 1) & 1 == 1));
        mesh
    }

    /// A tube of radius 1 around the y axis from y = 0 to y = 2, `n` quads around, both
    /// ends open, wound outward.
    pub fn open_cylinder(n: u32) -> TriMesh {
        let mut positions = Vec::new();
        for ring in 0..2 {
            for k in 0..n {
                let a = std::f64::consts::TAU * k as f64 / n as f64;
                positions.push([a.cos(), 2.0 * ring as f64, -a.sin()]);
            }
        }
        let triangles = (0..n)
            .flat_map(|k| {
                let (a, b) = (k, (k + 1) % n);
                [[a, b, b + n], [a, b + n, a + n]]
            })
            .collect();
        TriMesh { positions, triangles }
    }
}

#[cfg(test)]
mod tests {
    use super::fixtures::*;

    #[test]
    fn cube_measures() {
        let cube = cube();
        assert!((cube.signed_volume() - 1.0).abs() < 1e-12);
        assert!((cube.area() - 6.0).abs() < 1e-12);
        let n = cube.vertex_normals();
        let s = 1.0 / 3f64.sqrt();
        assert!(n[7].iter().all(|&c| (c - s).abs() < 1e-12), "corner normal points out diagonally: {:?}", n[7]);
        assert_eq!(cube.bounds(), ([0.0; 3], [1.0; 3]));
    }

    #[test]
    fn open_fixtures_have_their_holes() {
        assert_eq!(open_box().triangles.len(), 10);
        let tube = open_cylinder(12);
        // Outward winding: the first triangle's normal points away from the axis (+x side).
        let n = tube.area_vector(0);
        assert!(n[0] > 0.0 && n[1].abs() < 1e-12, "{n:?}");
        assert!((tube.area() - 2.0 * 12.0 * 2.0 * (std::f64::consts::PI / 12.0).sin()).abs() < 1e-9);
    }
}
