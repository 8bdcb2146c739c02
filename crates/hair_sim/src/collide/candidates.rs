//! Per-cell short lists of the triangles that can be closest to a point in the cell, so
//! the exact near query tests a handful of triangles instead of walking the BVH.
//!
//! # Why the lists are exact
//!
//! Take a distance-grid cell with centre `c` and half diagonal `r`, and let `D` be the
//! exact (unsigned) distance to the mesh. For a point `p` in the cell (`|p − c| ≤ r`) and
//! the triangle `T*` closest to `p`:
//!
//! `dist(c, T*) ≤ |c − p| + dist(p, T*) = |c − p| + D(p) ≤ |c − p| + D(c) + |p − c| ≤ D(c) + 2r`
//!
//! (the middle step because `D` is 1-Lipschitz). So every triangle within `D(c) + 2r` of
//! the centre is a candidate, and no other triangle can be the closest. `D(c)` and the
//! triangle distances are exact queries at bake time (BVH, then point–triangle); a small
//! slack absorbs f32 rounding.
//!
//! # Why skipping candidates at run time is exact
//!
//! The list is sorted by distance to the centre. `dist(p, T) ≥ dist(c, T) − |p − c|`, so
//! once that reaches the best distance found, no later triangle can be closer. And the
//! distance to a triangle is a convex function of the point, so it lies above its tangent
//! plane at `c`: `dist(p, T) ≥ dist(c, T) + g·(p − c)`, with `g` the unit vector from the
//! triangle's closest point to `c`. That bound (one dot product) skips most of the
//! triangles that are near `c` but on the wrong side of `p`.
//!
//! Lists exist only in the band where the grid's far reject lets queries through (and not
//! deep inside the head, where they would be long); elsewhere the caller uses the BVH.

use super::DistanceGrid;
use crate::math::Vec3;
use parry3d::bounding_volume::Aabb;
use parry3d::query::{PointQuery, PointQueryWithLocation};
use parry3d::shape::{TriMesh, TrianglePointLocation};

/// Collision thickness, metres, up to which every near query finds a list (thicker
/// settings still work; some of their queries take the BVH).
const LIST_THICKNESS: f32 = 0.01;
/// Cells entirely deeper inside the head than this many grid cells get no lists.
const INSIDE_CELLS: f32 = 2.0;
/// A cell with more candidates than this uses the BVH.
const MAX_CANDIDATES: usize = 96;
/// Absorbs f32 rounding in the bake-time distances and the run-time bounds, metres.
const SLACK: f32 = 1e-5;
/// Marks a cell without a list.
const NONE: u32 = u32::MAX;

#[derive(Clone, Copy, Debug)]
struct Candidate {
    /// Unit vector from the triangle's point closest to the cell centre to the centre.
    gradient: Vec3,
    /// Distance from the cell centre to the triangle.
    centre_distance: f32,
    triangle: u32,
}

/// The closest point of the mesh to a query point.
#[derive(Clone, Copy, Debug)]
pub(super) struct Closest {
    pub point: Vec3,
    pub triangle: u32,
    pub inside: bool,
}

/// Candidate lists on the cells of the distance grid.
#[derive(Clone, Debug)]
pub(super) struct CandidateGrid {
    origin: Vec3,
    cell: f32,
    /// Cells along each axis.
    cells: [usize; 3],
    /// Per cell: `[start, len]` in `entries`, or `[NONE, 0]` for "use the BVH".
    ranges: Vec<[u32; 2]>,
    entries: Vec<Candidate>,
    /// Every triangle's corners, flat: the near query reads them without the mesh's
    /// index indirection.
    corners: Vec<[Vec3; 3]>,
}

impl CandidateGrid {
    pub fn bake(grid: &DistanceGrid, mesh: &TriMesh) -> Self {
        let cells = grid.dims().map(|n| n - 1);
        let upper = LIST_THICKNESS + grid.max_error();
        let lower = -INSIDE_CELLS * grid.cell_size();
        let mut out = CandidateGrid {
            origin: grid.origin(),
            cell: grid.cell_size(),
            cells,
            ranges: Vec::with_capacity(cells[0] * cells[1] * cells[2]),
            entries: Vec::new(),
            corners: mesh.triangles().map(|t| [t.a, t.b, t.c]).collect(),
        };
        for z in 0..cells[2] {
            for y in 0..cells[1] {
                for x in 0..cells[0] {
                    // Trilinear samples in a cell lie between its corner values: a cell
                    // whose corners are all far never lets a query through.
                    let (lo, hi) = grid.cell_range([x, y, z]);
                    let list = if lo <= upper && hi >= lower { out.cell_list(mesh, [x, y, z]) } else { Vec::new() };
                    if list.is_empty() || list.len() > MAX_CANDIDATES {
                        out.ranges.push([NONE, 0]);
                    } else {
                        out.ranges.push([out.entries.len() as u32, list.len() as u32]);
                        out.entries.extend(list);
                    }
                }
            }
        }
        out
    }

    fn centre(&self, [x, y, z]: [usize; 3]) -> Vec3 {
        self.origin + (Vec3::new(x as f32, y as f32, z as f32) + 0.5) * self.cell
    }

    /// Every triangle within `D(c) + 2r` of the cell centre `c`, sorted by distance.
    fn cell_list(&self, mesh: &TriMesh, cell: [usize; 3]) -> Vec<Candidate> {
        let centre = self.centre(cell);
        let half_diagonal = 0.5 * self.cell * 3f32.sqrt();
        // Parry signs the distance on an oriented mesh; the bound needs its magnitude.
        let reach = mesh.distance_to_local_point(centre, false).abs() + 2.0 * half_diagonal + SLACK;
        let aabb = Aabb::new(centre - Vec3::splat(reach), centre + Vec3::splat(reach));
        let mut list: Vec<Candidate> = mesh
            .bvh()
            .intersect_aabb(&aabb)
            .map(|triangle| {
                let closest = mesh.triangle(triangle).project_local_point(centre, false).point;
                let offset = centre - closest;
                let centre_distance = offset.length();
                // At distance 0 the tangent plane is flat: a zero gradient is still a bound.
                let gradient = if centre_distance > 1e-9 { offset / centre_distance } else { Vec3::ZERO };
                Candidate { gradient, centre_distance, triangle }
            })
            .filter(|c| c.centre_distance <= reach)
            .collect();
        list.sort_by(|a, b| a.centre_distance.total_cmp(&b.centre_distance).then(a.triangle.cmp(&b.triangle)));
        list
    }

    /// The cell centre and candidate list for `p`, if it has one.
    #[inline]
    fn lookup(&self, p: Vec3) -> Option<(Vec3, &[Candidate])> {
        let g = (p - self.origin) / self.cell;
        let [cx, cy, cz] = self.cells;
        let inside = g.cmpge(Vec3::ZERO).all() && g.x < cx as f32 && g.y < cy as f32 && g.z < cz as f32;
        if !inside {
            return None;
        }
        // `g` is non-negative here, so truncation is the floor (through i32: one instruction).
        let cell = g.to_array().map(|v| v as i32 as usize);
        let [start, len] = self.ranges[(cell[2] * cy + cell[1]) * cx + cell[0]];
        if len == 0 {
            return None;
        }
        Some((self.centre(cell), &self.entries[start as usize..][..len as usize]))
    }

    /// The exact closest point of `mesh` to `p` if it is nearer than `max_distance`.
    #[inline]
    pub fn closest(&self, mesh: &TriMesh, p: Vec3, max_distance: f32) -> Near {
        let Some((centre, list)) = self.lookup(p) else {
            return Near::Unlisted;
        };
        let offset = p - centre;
        let from_centre = offset.length();
        let mut best_distance = max_distance;
        let mut best = None;
        for candidate in list {
            if candidate.centre_distance - from_centre - SLACK >= best_distance {
                break; // sorted: no later triangle can be closer either
            }
            if candidate.centre_distance + candidate.gradient.dot(offset) - SLACK >= best_distance {
                continue; // its tangent-plane bound already rules it out
            }
            let (point, location) = project_on_triangle(&self.corners[candidate.triangle as usize], p);
            // Most projections lose: compare squares and take the root only for a winner.
            let squared = (p - point).length_squared();
            if squared < best_distance * best_distance {
                best_distance = squared.sqrt();
                best = Some((candidate.triangle, point, location));
            }
        }
        match best {
            Some((triangle, point, location)) => {
                Near::Closest(Closest { point, triangle, inside: is_inside(mesh, triangle, location, p - point) })
            }
            None => Near::Beyond,
        }
    }
}

/// What a candidate-list query found.
pub(super) enum Near {
    /// `p` lies in a cell without a list: ask the BVH.
    Unlisted,
    /// Nothing nearer than the distance asked for.
    Beyond,
    /// The exact closest point.
    Closest(Closest),
}

/// Parry's point–triangle projection (`Triangle::project_local_point_and_get_location`,
/// not solid) on flat corners, step for step so the result is bit-identical; the rare
/// collinear triangle is handed to parry itself.
#[inline]
fn project_on_triangle([a, b, c]: &[Vec3; 3], p: Vec3) -> (Vec3, TrianglePointLocation) {
    let (a, b, c) = (*a, *b, *c);
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (ab_ap, ac_ap) = (ab.dot(ap), ac.dot(ap));
    if ab_ap <= 0.0 && ac_ap <= 0.0 {
        return (a, TrianglePointLocation::OnVertex(0));
    }
    let bp = p - b;
    let (ab_bp, ac_bp) = (ab.dot(bp), ac.dot(bp));
    if ab_bp >= 0.0 && ac_bp <= ab_bp {
        return (b, TrianglePointLocation::OnVertex(1));
    }
    let cp = p - c;
    let (ab_cp, ac_cp) = (ab.dot(cp), ac.dot(cp));
    if ac_cp >= 0.0 && ab_cp <= ac_cp {
        return (c, TrianglePointLocation::OnVertex(2));
    }
    let bc = c - b;
    let n = ab.cross(ac);
    let vc = n.dot(ab.cross(ap));
    if vc < 0.0 && ab_ap >= 0.0 && ab_bp <= 0.0 {
        let v = ab_ap / ab.length_squared();
        return (a + ab * v, TrianglePointLocation::OnEdge(0, [1.0 - v, v]));
    }
    let vb = -n.dot(ac.cross(cp));
    if vb < 0.0 && ac_ap >= 0.0 && ac_cp <= 0.0 {
        let w = ac_ap / ac.length_squared();
        return (a + ac * w, TrianglePointLocation::OnEdge(2, [1.0 - w, w]));
    }
    let va = n.dot(bc.cross(bp));
    if va < 0.0 && ac_bp - ab_bp >= 0.0 && ab_cp - ac_cp >= 0.0 {
        let w = bc.dot(bp) / bc.length_squared();
        return (b + bc * w, TrianglePointLocation::OnEdge(1, [1.0 - w, w]));
    }
    let denom = va + vb + vc;
    if denom == 0.0 {
        let (proj, location) = parry3d::shape::Triangle::new(a, b, c).project_local_point_and_get_location(p, false);
        return (proj.point, location);
    }
    let v = vb / denom;
    let w = vc / denom;
    let side = if n.dot(ap) >= 0.0 { 0 } else { 1 };
    (a + ab * v + ac * w, TrianglePointLocation::OnFace(side, [1.0 - v - w, v, w]))
}

/// Parry's inside test for an oriented mesh: a point behind the pseudo-normal of the
/// feature it projects onto (face, edge or vertex) is inside.
fn is_inside(mesh: &TriMesh, triangle: u32, location: TrianglePointLocation, offset: Vec3) -> bool {
    let Some(pseudo) = mesh.pseudo_normals_if_oriented() else {
        return false;
    };
    let normal = match location {
        TrianglePointLocation::OnFace(..) | TrianglePointLocation::OnSolid => {
            Some(mesh.triangle(triangle).scaled_normal())
        }
        TrianglePointLocation::OnEdge(i, _) => pseudo.edges_pseudo_normal.get(triangle as usize).map(|n| n[i as usize]),
        TrianglePointLocation::OnVertex(i) => {
            let vertex = mesh.indices()[triangle as usize][i as usize];
            pseudo.vertices_pseudo_normal.get(vertex as usize).copied()
        }
    };
    normal.is_some_and(|n| offset.dot(n) <= 0.0)
}
