//! The head's triangles in a flat, query-ready form, and the *clearance certificate* that
//! lets a particle resting on the scalp skip the candidate search.
//!
//! # The certificate
//!
//! Let `p` lie on the outer side of triangle `T`, at height `h` above it, with its
//! projection inside `T`'s face, so `dist(p, T) = h`. Every triangle lying entirely on
//! or below `T`'s plane is at least `h` from `p`. Any other triangle `T'` (one poking above
//! the plane) is at least `dist(T, T') − h` away, because `dist(T, T') ≤ h + dist(p, T')`.
//! So if every such `T'` is at least `R` from `T` and `h ≤ R / 2`, then `T` holds the
//! closest point of the whole mesh. `R / 2` is baked per triangle as its clearance. On the
//! convex scalp no triangle nearby pokes above, the clearance is large, and one projection
//! onto the triangle a particle touched last substep settles its collision exactly.
//! In concave places (ear, neck) it is small or zero.
//!
//! # The gap certificate
//!
//! The same argument works from a measured point instead of the whole triangle. When a
//! search finds `T` closest to `p₀`, it can also bound the distance `g` from `p₀` to every
//! triangle rising above `T`'s plane. Later, at `p` over `T`'s face at height `h`, a rising
//! triangle is at least `g − |p − p₀|` away, so `h < g − |p − p₀|` proves `T` closest
//! again. A particle resting in a crease, where the clearance is too small for its
//! thickness, keeps that proof as long as it stays near where it was measured.
//!
//! # The edge certificate
//!
//! A particle beside a face, over an edge that `T` shares with `U`, is closest to a point
//! `q` of that edge. Where the edge is convex (neither triangle rises above the other's
//! plane), every triangle below both planes lies in the wedge under them. If `p`'s
//! projections onto both planes fall outside both triangles across the edge, `p` lies in
//! the cone of the two normals, whose nearest point of the wedge is `q`: those
//! triangles are all at least `d = |p − q|` away. Any other triangle rises above a
//! plane and is at least `dist(edge, T') − d` away, so a baked edge clearance `c` (half the
//! distance from the edge to the nearest such triangle) proves `q` closest while `d < c`.
//! On a convex scalp, a particle resting over a ridge between two triangles then needs no
//! search either.
//!
//! A triangle counts as lying below the plane when no corner rises more than
//! [`PLANE_TOLERANCE`] above it (rounding on flat patches); a certified distance may
//! therefore exceed the true one by at most that much.

use crate::math::{Vec3, bounds};
use glam::Vec3A;
use parry3d::math::Pose as Isometry;
use parry3d::query::PointQueryWithLocation;
use parry3d::shape::{Segment, Shape, TriMesh, TrianglePointLocation};

/// How far a neighbour's corner may rise above a triangle's plane and still count as
/// below it, metres.
pub const PLANE_TOLERANCE: f32 = 1e-6;
/// The largest clearance baked, metres: triangles poking above the plane are searched for
/// this far (twice it) around each triangle.
const MAX_CLEARANCE: f32 = 0.01;
/// The smallest clearance cap, metres: above the default 3 mm collision shell, so a particle
/// resting on the shell can still be certified.
const MIN_CLEARANCE_CAP: f32 = 0.004;
/// The clearance cap in a triangle's own sizes: on a fine mesh the search stays within a
/// few rings of neighbours (their number, not the search radius, is what costs), so the
/// bake stays linear in the triangle count.
const CLEARANCE_CAP_PER_SIZE: f32 = 2.0;
/// Taken off every baked triangle–triangle distance, metres, so it stays a lower bound.
const DISTANCE_SLACK: f32 = 1e-5;

/// Every triangle of the head as a [`FlatTriangle`], with its clearance, and its edges.
#[derive(Clone, Debug)]
pub(super) struct FlatTriangles {
    triangles: Vec<FlatTriangle>,
    /// Per triangle, its edges in parry's order (0 = ab, 1 = bc, 2 = ca).
    edges: Vec<[Edge; 3]>,
}

/// An edge as the edge certificate needs it.
#[derive(Clone, Copy, Debug)]
struct Edge {
    /// The triangle on the other side.
    neighbour: u32,
    /// The neighbour's corner opposite the edge (0, 1 or 2).
    opposite: u32,
    /// The distance from the edge up to which the certificate holds, metres; zero on a
    /// concave, open or non-manifold edge.
    clearance: f32,
}

impl Edge {
    const NONE: Edge = Edge { neighbour: u32::MAX, opposite: 0, clearance: 0.0 };
}

/// What a certificate settled about a point.
#[derive(Clone, Copy, Debug)]
pub(super) enum Certificate {
    /// The closest point of the mesh.
    Closest(Certified),
    /// Not which point is closest, but that none is nearer than this, metres: the point
    /// is over the face (or beside it, over a convex edge), farther than the clearance or
    /// the gap can name the closest point from, yet the triangles below the plane (the
    /// planes) are as far as the point is from the face (the edge), and the rising ones
    /// at least this far.
    Beyond(f32),
    /// Nothing: the point is not over the face, below it, or the triangle is unknown.
    Unsettled,
}

impl Certificate {
    /// The closest point, where the certificate names it.
    pub fn closest(self) -> Option<Certified> {
        match self {
            Certificate::Closest(certified) => Some(certified),
            _ => None,
        }
    }
}

/// The closest point a certificate proved.
#[derive(Clone, Copy, Debug)]
pub(super) struct Certified {
    /// The closest point of the mesh.
    pub point: Vec3,
    /// Distance from the query point to it (the point is outside).
    pub distance: f32,
    /// The unit direction from the closest point to the query point (over a face, the
    /// face normal).
    pub normal: Vec3,
}

impl FlatTriangles {
    pub fn bake(mesh: &TriMesh) -> Self {
        let mut triangles: Vec<FlatTriangle> = mesh.triangles().map(|t| FlatTriangle::new(t.a, t.b, t.c)).collect();
        let vertices = VertexBins::new(mesh);
        let clearances = crate::parallel::map(triangles.len(), |i| {
            let (base, t) = (&triangles[i], mesh.triangle(i as u32));
            if base.normal == Vec3::ZERO {
                0.0
            } else {
                clearance(mesh, &triangles, &vertices, &t, bounds(&[t.a, t.b, t.c]), &[base])
            }
        });
        triangles.iter_mut().zip(clearances).for_each(|(t, c)| t.clearance = c);
        let edges = bake_edges(mesh, &triangles, &vertices);
        FlatTriangles { triangles, edges }
    }

    #[inline]
    pub fn get(&self, triangle: u32) -> &FlatTriangle {
        &self.triangles[triangle as usize]
    }

    /// The closest point of the mesh to `p`, if a certificate of `triangle` proves it:
    /// `p` above the triangle's face, below its clearance or below `gap()`, the height up
    /// to which the caller's gap certificate holds (computed only when the clearance
    /// falls short). Higher over the face, the same argument still bounds the distance
    /// ([`Certificate::Beyond`]): a particle lifted off the scalp learns that it touches
    /// nothing without a search.
    ///
    /// This runs for most particles resting on the head, so it skips the general
    /// projection: the height is one dot product, and "above the face" is the sign of the
    /// projection's barycentric coordinates, without dividing by their sum.
    #[inline(always)]
    pub fn certify(&self, triangle: u32, p: Vec3, gap: impl FnOnce() -> f32) -> Certificate {
        let Some(t) = self.triangles.get(triangle as usize) else {
            return Certificate::Unsettled;
        };
        let ap = Vec3A::from(p) - t.a;
        let normal = Vec3A::from(t.normal);
        let height = normal.dot(ap);
        // Written to refuse a NaN height too.
        let outside = height >= 0.0;
        if !outside {
            return Certificate::Unsettled;
        }
        // The in-plane point a + v·ab + w·ac under `p` solves the 2×2 Gram system of the
        // edges; v, w and 1 − v − w, times its (positive) determinant, are all ≥ 0 over the face.
        let (aa, ab_ac, cc) = (t.ab.length_squared(), t.ab.dot(t.ac), t.ac.length_squared());
        let (d1, d2) = (t.ab.dot(ap), t.ac.dot(ap));
        let (v, w) = (cc * d1 - ab_ac * d2, aa * d2 - ab_ac * d1);
        if !(v >= 0.0 && w >= 0.0 && v + w <= aa * cc - ab_ac * ab_ac) {
            return self.certify_edge(triangle, p);
        }
        // Strict bounds: a sliver has no clearance, no gap and no normal.
        let closest =
            || Certified { point: (Vec3A::from(p) - normal * height).into(), distance: height, normal: t.normal };
        if height < t.clearance {
            return Certificate::Closest(closest());
        }
        // The rising triangles are at least `2 × clearance − height` away, or `gap()`.
        let rising = (2.0 * t.clearance - height).max(gap());
        if height < rising { Certificate::Closest(closest()) } else { Certificate::Beyond(rising) }
    }

    /// The clearance baked for edge `edge` (0 = ab, 1 = bc, 2 = ca) of `triangle`.
    #[cfg(test)]
    pub fn edge_clearance(&self, triangle: u32, edge: usize) -> f32 {
        self.edges[triangle as usize][edge].clearance
    }

    /// [`Self::certify`] on the faces across `triangle`'s edges (by their own clearance),
    /// for a point that slid off `triangle`: the first that proves the closest point, and
    /// which face that is. Out of line: it runs only where the hinted face failed.
    #[inline(never)]
    pub fn certify_neighbours(&self, triangle: u32, p: Vec3) -> Option<(u32, Certified)> {
        let edges = self.edges.get(triangle as usize)?;
        edges.iter().filter(|edge| edge.neighbour != u32::MAX).find_map(|edge| {
            self.certify(edge.neighbour, p, || 0.0).closest().map(|certified| (edge.neighbour, certified))
        })
    }

    /// The edge certificate (module docs) for `p` beside `triangle`'s face; beyond the
    /// edge's clearance, as over a face, the bound it still proves. Out of line, so that
    /// [`Self::certify`] stays small enough to inline into the solver's loop.
    #[inline(never)]
    fn certify_edge(&self, triangle: u32, p: Vec3) -> Certificate {
        let t = &self.triangles[triangle as usize];
        let (q, TrianglePointLocation::OnEdge(i, _)) = t.project(p) else {
            return Certificate::Unsettled;
        };
        let edge = self.edges[triangle as usize][i as usize];
        // A concave, open or non-manifold edge has no certificate.
        let certified = edge.clearance > 0.0;
        if !certified {
            return Certificate::Unsettled;
        }
        // `p` over the neighbour's face (its projection on the near side of the edge) is
        // the neighbour's face certificate's business, not this one's.
        let offset = p - q;
        let neighbour = &self.triangles[edge.neighbour as usize];
        if offset.dot(Vec3::from(neighbour.corner(edge.opposite)) - q) > 0.0 {
            return Certificate::Unsettled;
        }
        let distance = offset.length();
        // Strict, and written to refuse NaN.
        let within = distance < edge.clearance;
        if !within {
            // The rising triangles are at least `2 × clearance − distance` away.
            return Certificate::Beyond(2.0 * edge.clearance - distance);
        }
        // Right on the edge the offset has no direction; the edge's pseudo-normal is out.
        let normal =
            if distance > 1e-7 { offset / distance } else { (t.normal + neighbour.normal).normalize_or(t.normal) };
        Certificate::Closest(Certified { point: q, distance, normal })
    }
}

/// Half the distance from `shape` (a triangle or an edge, within `bounds`) to the nearest
/// of the mesh's `triangles` that rises above the plane of any of `bases`, capped at
/// [`MAX_CLEARANCE`], or on a fine mesh at [`CLEARANCE_CAP_PER_SIZE`] times the shape's
/// size (but not below [`MIN_CLEARANCE_CAP`]).
fn clearance(
    mesh: &TriMesh,
    triangles: &[FlatTriangle],
    vertices: &VertexBins,
    shape: &dyn Shape,
    bounds: (Vec3, Vec3),
    bases: &[&FlatTriangle],
) -> f32 {
    let size = (bounds.1 - bounds.0).max_element();
    let reach = 2.0 * (CLEARANCE_CAP_PER_SIZE * size).clamp(MIN_CLEARANCE_CAP, MAX_CLEARANCE);
    // A triangle rises above a plane only through a corner, so the rising triangles are
    // among those around the rising corners near the shape, found by one tight loop over
    // the nearby vertices; on a convex stretch there are none. A triangle is no nearer
    // than its rising corner less the longest edge around that corner: corners nearest
    // first, and no exact distance once that bound passes the nearest found. (A walk over
    // the hundreds of triangles within reach of each triangle made the bake quadratic on
    // fine meshes.)
    let margin = Vec3::splat(reach + vertices.longest_edge);
    let mut corners: Vec<(f32, u32)> = vertices
        .rising_corners(bounds.0 - margin, bounds.1 + margin, bases)
        .map(|(p, v)| (shape.distance_to_local_point(p.into(), true) - vertices.span[v as usize], v))
        .filter(|&(bound, _)| bound < reach)
        .collect();
    corners.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    let mut nearest = reach;
    for (bound, v) in corners {
        // Touching (a concave fold) is as near as it gets.
        if bound >= nearest || nearest == 0.0 {
            break;
        }
        for i in vertices.triangles_around(v) {
            if !bases.iter().any(|base| triangles[i as usize].rises_above(base)) {
                continue;
            }
            // GJK converges to within rounding; the slack keeps the result a lower bound.
            let identity = Isometry::IDENTITY;
            let distance = parry3d::query::distance(&identity, shape, &identity, &mesh.triangle(i))
                .map_or(0.0, |d| (d.distance - DISTANCE_SLACK).max(0.0));
            nearest = nearest.min(distance);
        }
    }
    0.5 * nearest
}

/// The mesh's vertices binned in a uniform grid, with the triangles around each, to find
/// the corners near a place that rise above some planes in a tight loop.
struct VertexBins {
    origin: Vec3A,
    inverse_cell: f32,
    dims: [usize; 3],
    /// Per cell, where its vertices start in `points` (one more entry at the end).
    starts: Vec<u32>,
    /// The vertices, by cell, and their indices in the mesh.
    points: Vec<(Vec3A, u32)>,
    /// Per mesh vertex, where its triangles start in `around` (one more at the end).
    around_starts: Vec<u32>,
    around: Vec<u32>,
    /// Per mesh vertex, the longest edge of the triangles around it: every point of those
    /// triangles is within this of the vertex.
    span: Vec<f32>,
    /// The longest edge of any triangle.
    longest_edge: f32,
}

impl VertexBins {
    /// Cell edge, metres: a clearance search box (1–4 cm across) spans a few cells.
    const CELL: f32 = 0.004;
    /// The most cells: a mesh too large for [`Self::CELL`] gets larger cells.
    const MAX_CELLS: f32 = 4.0e6;

    fn new(mesh: &TriMesh) -> Self {
        let vertices = mesh.vertices();
        let (low, high) = if vertices.is_empty() { (Vec3::ZERO, Vec3::ZERO) } else { bounds(vertices) };
        let extent = (high - low).max(Vec3::splat(1e-6));
        let cell = Self::CELL.max((extent.x * extent.y * extent.z / Self::MAX_CELLS).cbrt());
        let dims = (extent / cell).to_array().map(|n| n as usize + 1);
        let mut bins = VertexBins {
            origin: low.into(),
            inverse_cell: 1.0 / cell,
            dims,
            starts: Vec::new(),
            points: Vec::new(),
            around_starts: Vec::new(),
            around: Vec::new(),
            span: vec![0.0; vertices.len()],
            longest_edge: 0.0,
        };
        let cells: Vec<usize> = vertices.iter().map(|&v| bins.cell_of(v)).collect();
        (bins.starts, bins.points) =
            buckets(dims[0] * dims[1] * dims[2], &cells, |v| (Vec3A::from(vertices[v]), v as u32));
        let corners: Vec<(usize, u32)> = mesh
            .indices()
            .iter()
            .enumerate()
            .flat_map(|(t, corners)| corners.map(|v| (v as usize, t as u32)))
            .collect();
        let owners: Vec<usize> = corners.iter().map(|c| c.0).collect();
        (bins.around_starts, bins.around) = buckets(vertices.len(), &owners, |k| corners[k].1);
        for (t, corners) in mesh.triangles().zip(mesh.indices()) {
            let longest = t.a.distance(t.b).max(t.b.distance(t.c)).max(t.c.distance(t.a));
            corners.iter().for_each(|&v| bins.span[v as usize] = bins.span[v as usize].max(longest));
            bins.longest_edge = bins.longest_edge.max(longest);
        }
        bins
    }

    fn cell_index(&self, p: Vec3) -> [usize; 3] {
        let c = (Vec3A::from(p) - self.origin) * self.inverse_cell;
        [0, 1, 2].map(|i| (c[i].max(0.0) as usize).min(self.dims[i] - 1))
    }

    fn cell_of(&self, p: Vec3) -> usize {
        let [x, y, z] = self.cell_index(p);
        x + self.dims[0] * (y + self.dims[1] * z)
    }

    /// The vertices in the cells overlapping `low`–`high` that lie above the plane of any
    /// of `bases` by more than [`PLANE_TOLERANCE`], less a rounding margin (so every
    /// corner [`FlatTriangle::rises_above`] counts is among them).
    fn rising_corners(&self, low: Vec3, high: Vec3, bases: &[&FlatTriangle]) -> impl Iterator<Item = (Vec3A, u32)> {
        let tolerance = PLANE_TOLERANCE * 0.9;
        let (lo, hi) = (self.cell_index(low), self.cell_index(high));
        let rows =
            (lo[2]..=hi[2]).flat_map(move |z| (lo[1]..=hi[1]).map(move |y| self.dims[0] * (y + self.dims[1] * z)));
        rows.flat_map(move |row| &self.points[self.starts[row + lo[0]] as usize..self.starts[row + hi[0] + 1] as usize])
            .filter(move |(p, _)| bases.iter().any(|base| Vec3A::from(base.normal).dot(*p - base.a) > tolerance))
            .copied()
    }

    /// The triangles with mesh vertex `v` as a corner.
    fn triangles_around(&self, v: u32) -> impl Iterator<Item = u32> + '_ {
        let range = self.around_starts[v as usize] as usize..self.around_starts[v as usize + 1] as usize;
        self.around[range].iter().copied()
    }
}

/// A counting sort: the items `0..keys.len()` grouped by their key (below `count`), as
/// `(starts, values)` with key `k`'s values at `starts[k]..starts[k + 1]`.
fn buckets<T: Copy + Default>(count: usize, keys: &[usize], value: impl Fn(usize) -> T) -> (Vec<u32>, Vec<T>) {
    let mut starts = vec![0u32; count + 1];
    keys.iter().for_each(|&k| starts[k + 1] += 1);
    (1..starts.len()).for_each(|k| starts[k] += starts[k - 1]);
    let mut next = starts.clone();
    let mut values = vec![T::default(); keys.len()];
    for (item, &k) in keys.iter().enumerate() {
        values[next[k] as usize] = value(item);
        next[k] += 1;
    }
    (starts, values)
}

/// Pairs the triangles across each edge and bakes the edge clearances. An edge with one
/// triangle (an open mesh) or more than two gets none.
fn bake_edges(mesh: &TriMesh, triangles: &[FlatTriangle], vertices: &VertexBins) -> Vec<[Edge; 3]> {
    // Edges shared by exactly two triangles: (triangle, its edge), twice.
    let pairs = crate::mesh::edge_pairs(mesh.indices());
    let clearances = crate::parallel::map(pairs.len(), |k| {
        let [(t, i), (u, _)] = pairs[k];
        let (ft, fu) = (&triangles[t as usize], &triangles[u as usize]);
        // Concave or folded: the neighbour itself rises above the plane.
        let convex = ft.normal != Vec3::ZERO && fu.normal != Vec3::ZERO && !fu.rises_above(ft) && !ft.rises_above(fu);
        if convex {
            let (a, b) = (ft.corner(i).into(), ft.corner((i + 1) % 3).into());
            clearance(mesh, triangles, vertices, &Segment::new(a, b), bounds(&[a, b]), &[ft, fu])
        } else {
            0.0
        }
    });
    let mut edges = vec![[Edge::NONE; 3]; triangles.len()];
    for ([(t, i), (u, j)], clearance) in pairs.into_iter().zip(clearances) {
        edges[t as usize][i as usize] = Edge { neighbour: u, opposite: (j + 2) % 3, clearance };
        edges[u as usize][j as usize] = Edge { neighbour: t, opposite: (i + 2) % 3, clearance };
    }
    edges
}

/// A triangle as its first corner, two edges and its unit normal, the form the projection
/// works on, and its clearance: one 64-byte line per query.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct FlatTriangle {
    a: Vec3A,
    ab: Vec3A,
    ac: Vec3A,
    /// Unit face normal (zero for a sliver without one).
    normal: Vec3,
    /// The height above the face up to which the certificate holds, metres.
    clearance: f32,
}

impl FlatTriangle {
    fn new(a: Vec3, b: Vec3, c: Vec3) -> Self {
        let (a, ab, ac) = (Vec3A::from(a), Vec3A::from(b - a), Vec3A::from(c - a));
        FlatTriangle { a, ab, ac, normal: ab.cross(ac).normalize_or_zero().into(), clearance: 0.0 }
    }

    /// The point of the triangle closest to `p`, and the feature it lies on (edges
    /// numbered as parry does: 0 = ab, 1 = bc, 2 = ca). Voronoi regions in barycentric
    /// form (Ericson, *Real-Time Collision Detection*, 5.1.5): six dot products, and the
    /// edges are given, not recomputed per query.
    #[inline]
    pub fn project(&self, p: Vec3) -> (Vec3, TrianglePointLocation) {
        let (ab, ac) = (self.ab, self.ac);
        let ap = Vec3A::from(p) - self.a;
        let (d1, d2) = (ab.dot(ap), ac.dot(ap));
        if d1 <= 0.0 && d2 <= 0.0 {
            return (self.a.into(), TrianglePointLocation::OnVertex(0));
        }
        let bp = ap - ab;
        let (d3, d4) = (ab.dot(bp), ac.dot(bp));
        if d3 >= 0.0 && d4 <= d3 {
            return ((self.a + ab).into(), TrianglePointLocation::OnVertex(1));
        }
        let vc = d1 * d4 - d3 * d2;
        if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            let v = d1 / (d1 - d3);
            return ((self.a + ab * v).into(), TrianglePointLocation::OnEdge(0, [1.0 - v, v]));
        }
        let cp = ap - ac;
        let (d5, d6) = (ab.dot(cp), ac.dot(cp));
        if d6 >= 0.0 && d5 <= d6 {
            return ((self.a + ac).into(), TrianglePointLocation::OnVertex(2));
        }
        let vb = d5 * d2 - d1 * d6;
        if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            let w = d2 / (d2 - d6);
            return ((self.a + ac * w).into(), TrianglePointLocation::OnEdge(2, [1.0 - w, w]));
        }
        let va = d3 * d6 - d5 * d4;
        if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
            let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
            return ((self.a + ab + (ac - ab) * w).into(), TrianglePointLocation::OnEdge(1, [1.0 - w, w]));
        }
        // Inside the face. A sliver too thin for the barycentrics goes to parry.
        let denom = va + vb + vc;
        if denom.abs() <= f32::MIN_POSITIVE {
            let b = self.a + ab;
            let c = self.a + ac;
            let (proj, location) = parry3d::shape::Triangle::new(self.a.into(), b.into(), c.into())
                .project_local_point_and_get_location(p, false);
            return (proj.point, location);
        }
        let (v, w) = (vb / denom, vc / denom);
        let side = if Vec3A::from(self.normal).dot(ap) >= 0.0 { 0 } else { 1 };
        ((self.a + ab * v + ac * w).into(), TrianglePointLocation::OnFace(side, [1.0 - v - w, v, w]))
    }

    /// Corner 0, 1 or 2 (a, b, c).
    #[inline]
    fn corner(&self, k: u32) -> Vec3A {
        match k {
            0 => self.a,
            1 => self.a + self.ab,
            _ => self.a + self.ac,
        }
    }

    /// Whether a corner of this triangle lies more than [`PLANE_TOLERANCE`] above the plane
    /// of `base` (the triangles that can limit `base`'s certificates).
    #[inline]
    pub fn rises_above(&self, base: &FlatTriangle) -> bool {
        let normal = Vec3A::from(base.normal);
        let a = normal.dot(self.a - base.a);
        a.max(a + normal.dot(self.ab)).max(a + normal.dot(self.ac)) > PLANE_TOLERANCE
    }

    /// The height above the face up to which the clearance certificate holds, metres.
    pub fn clearance(&self) -> f32 {
        self.clearance
    }

    /// The unit face normal, if the triangle has one.
    pub fn normal(&self) -> Option<Vec3> {
        (self.normal != Vec3::ZERO).then_some(self.normal)
    }

    /// Parry's inside test for an oriented mesh: a point behind the pseudo-normal of the
    /// feature it projects onto (face, edge or vertex) is inside.
    pub fn is_inside(&self, mesh: &TriMesh, triangle: u32, location: TrianglePointLocation, offset: Vec3) -> bool {
        let Some(pseudo) = mesh.pseudo_normals_if_oriented() else {
            return false;
        };
        let normal = match location {
            TrianglePointLocation::OnFace(..) | TrianglePointLocation::OnSolid => Some(self.normal),
            TrianglePointLocation::OnEdge(i, _) => {
                pseudo.edges_pseudo_normal.get(triangle as usize).map(|n| n[i as usize])
            }
            TrianglePointLocation::OnVertex(i) => {
                let vertex = mesh.indices()[triangle as usize][i as usize];
                pseudo.vertices_pseudo_normal.get(vertex as usize).copied()
            }
        };
        normal.is_some_and(|n: Vec3| offset.dot(n) <= 0.0)
    }
}

#[cfg(test)]
mod tests;
