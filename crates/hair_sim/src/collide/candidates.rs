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
use super::distance_grid::GridPoint;
use super::triangles::FlatTriangles;
use crate::math::Vec3;
use glam::Vec4;
use parry3d::bounding_volume::Aabb;
use parry3d::query::PointQuery;
use parry3d::shape::{TriMesh, TrianglePointLocation};

/// Collision thickness, metres, up to which every near query finds a list (thicker
/// settings still work; some of their queries take the BVH).
const LIST_THICKNESS: f32 = 0.01;
/// Cells entirely deeper inside the head than this many grid cells get no lists.
const INSIDE_CELLS: f32 = 2.0;
/// A cell with more candidates than this uses the BVH.
const MAX_CANDIDATES: usize = 96;
/// Triangles in a cell's search box beyond which its list is not even attempted: a box
/// holds a few times the triangles its ball does.
const BOX_LIMIT: usize = 4 * MAX_CANDIDATES;
/// Absorbs f32 rounding in the bake-time distances and the run-time bounds, metres.
pub(super) const SLACK: f32 = 1e-5;
/// How far beyond a particle's distance the gap certificate looks for rising triangles,
/// metres: the room it leaves the particle to move before the next search.
const GAP_MARGIN: f32 = 0.002;
/// Marks a cell without a list.
const NONE: u32 = u32::MAX;
/// Bits of a cell's range word that count its blocks: enough for [`MAX_CANDIDATES`].
pub(super) const COUNT_BITS: u32 = 5;
const _: () = assert!(MAX_CANDIDATES.div_ceil(4) < 1 << COUNT_BITS);

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
    /// The point lies inside the triangle's face, not on an edge or a corner.
    pub on_face: bool,
    /// Every triangle rising above `triangle`'s plane is at least this far from the query
    /// point (the gap certificate in `triangles.rs`); zero when not measured.
    pub gap: f32,
}

/// Four consecutive candidates of a list, one per SIMD lane: the run-time bounds test
/// all four at once, and the triangles of those that pass are in the same record.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
struct Block {
    /// Distances from the cell centre; `INFINITY` in the padding lanes of a list's last
    /// block, so they never pass a bound.
    centre_distance: Vec4,
    /// The gradients' x, y and z components.
    gradient: [Vec4; 3],
    /// The triangle of each lane.
    triangles: [u32; 4],
}

/// Candidate lists on the cells of the distance grid.
#[derive(Clone, Debug)]
pub(super) struct CandidateGrid {
    cell: f32,
    /// Per cell, by [`GridPoint::index`]: its first block and (low [`COUNT_BITS`] bits)
    /// how many, or [`NONE`] for "use the BVH". One word per cell keeps the table small
    /// enough to stay in cache.
    ranges: Vec<u32>,
    blocks: Vec<Block>,
}

impl CandidateGrid {
    pub fn bake(grid: &DistanceGrid, mesh: &TriMesh) -> Self {
        let dims = grid.dims();
        let upper = LIST_THICKNESS + grid.max_error();
        let lower = -INSIDE_CELLS * grid.cell_size();
        let mut out = CandidateGrid {
            cell: grid.cell_size(),
            ranges: vec![NONE; dims[0] * dims[1] * dims[2]],
            blocks: Vec::new(),
        };
        // The lists, a z-slice per work item on all cores; assembled in cell order below.
        let slices = crate::parallel::map(dims[2] - 1, |z| {
            let mut lists = Vec::new();
            for y in 0..dims[1] - 1 {
                for x in 0..dims[0] - 1 {
                    // Trilinear samples in a cell lie between its corner values: a cell
                    // whose corners are all far never lets a query through.
                    let (lo, hi) = grid.cell_range([x, y, z]);
                    if !(lo <= upper && hi >= lower) {
                        continue;
                    }
                    let list = cell_list(mesh, grid.origin(), grid.cell_size(), [x, y, z]);
                    if !list.is_empty() && list.len() <= MAX_CANDIDATES {
                        lists.push(((z * dims[1] + y) * dims[0] + x, list));
                    }
                }
            }
            lists
        });
        for (index, list) in slices.into_iter().flatten() {
            let first = u32::try_from(out.blocks.len()).ok().filter(|&f| f < NONE >> COUNT_BITS);
            let Some(first) = first else {
                continue; // a table this large is beyond any head; the BVH still answers
            };
            out.ranges[index] = (first << COUNT_BITS) | list.len().div_ceil(4) as u32;
            for four in list.chunks(4) {
                let lane = |i: usize, f: fn(&Candidate) -> f32, pad: f32| four.get(i).map_or(pad, f);
                let lanes = |f: fn(&Candidate) -> f32, pad: f32| {
                    Vec4::new(lane(0, f, pad), lane(1, f, pad), lane(2, f, pad), lane(3, f, pad))
                };
                out.blocks.push(Block {
                    centre_distance: lanes(|c| c.centre_distance, f32::INFINITY),
                    gradient: [
                        lanes(|c| c.gradient.x, 0.0),
                        lanes(|c| c.gradient.y, 0.0),
                        lanes(|c| c.gradient.z, 0.0),
                    ],
                    triangles: std::array::from_fn(|i| four.get(i).map_or(0, |c| c.triangle)),
                });
            }
        }
        out
    }

    /// The lists as plain words for a copy of the query elsewhere (see
    /// [`super::NearQueryTables`]): the cell ranges, and each block as its distances,
    /// gradients (x, y, z; f32 bits) and triangles.
    pub fn words(&self) -> (Vec<u32>, Vec<[u32; 20]>) {
        let blocks = self.blocks.iter().map(|b| {
            let floats = [b.centre_distance, b.gradient[0], b.gradient[1], b.gradient[2]];
            let mut words = [0; 20];
            for (k, v) in floats.iter().enumerate() {
                words[4 * k..][..4].copy_from_slice(&v.to_array().map(f32::to_bits));
            }
            words[16..].copy_from_slice(&b.triangles);
            words
        });
        (self.ranges.clone(), blocks.collect())
    }

    /// The exact closest point of `mesh` to `p` (in the cell `at`) if it is nearer than
    /// `max_distance`.
    #[inline]
    pub fn closest(&self, flat: &FlatTriangles, mesh: &TriMesh, p: Vec3, at: GridPoint, max_distance: f32) -> Near {
        let range = self.ranges[at.index];
        if range == NONE {
            return Near::Unlisted;
        }
        let first = (range >> COUNT_BITS) as usize;
        let blocks = &self.blocks[first..][..(range & ((1 << COUNT_BITS) - 1)) as usize];
        // From the cell centre to `p`.
        let offset = Vec3::from((at.fraction - 0.5) * self.cell);
        let from = FromCentre { offset, distance: offset.length() };
        let mut best_distance = max_distance;
        let mut best = None;
        from.visit(blocks, &mut best_distance, |triangle, best_distance| {
            let (point, location) = flat.get(triangle).project(p);
            // Most projections lose: compare squares and take the root only for a winner.
            let squared = (p - point).length_squared();
            if squared < *best_distance * *best_distance {
                *best_distance = squared.sqrt();
                best = Some((triangle, point, location));
            }
        });
        let Some((triangle, point, location)) = best else {
            return Near::Beyond;
        };
        let inside = flat.get(triangle).is_inside(mesh, triangle, location, p - point);
        let on_face = matches!(location, TrianglePointLocation::OnFace(..));
        // Only a point outside, over a face with a normal, can use a gap certificate, and
        // it needs one only where the triangle's clearance does not reach it.
        let base = flat.get(triangle);
        let gap = if on_face && !inside && base.normal().is_some() && best_distance >= base.clearance() {
            let last = blocks.last().map_or(0.0, |b| b.centre_distance.x);
            // Unlisted triangles are farther from the centre than any listed one.
            let unlisted = last - from.distance - SLACK;
            let mut gap = (best_distance + GAP_MARGIN).min(unlisted);
            from.visit(blocks, &mut gap, |other, gap| {
                let other_triangle = flat.get(other);
                if other != triangle && other_triangle.rises_above(base) {
                    *gap = gap.min((p - other_triangle.project(p).0).length());
                }
            });
            gap.max(0.0)
        } else {
            0.0
        };
        Near::Closest(Closest { point, triangle, inside, on_face, gap })
    }
}

/// Where a query point lies relative to its cell's centre, for the run-time bounds.
#[derive(Clone, Copy)]
struct FromCentre {
    offset: Vec3,
    distance: f32,
}

impl FromCentre {
    /// Calls `visit` on each candidate of `blocks`, in list order, whose lower bound on
    /// the distance to the query point is below `bar`; `visit` may lower the bar (the
    /// best distance of a search, the gap found so far), and later candidates face it.
    #[inline]
    fn visit(self, blocks: &[Block], bar: &mut f32, mut visit: impl FnMut(u32, &mut f32)) {
        let (ox, oy, oz) = (Vec4::splat(self.offset.x), Vec4::splat(self.offset.y), Vec4::splat(self.offset.z));
        for block in blocks {
            let by_centre = block.centre_distance - (self.distance + SLACK);
            if by_centre.x >= *bar {
                break; // sorted: no later triangle can be nearer either
            }
            let [gx, gy, gz] = block.gradient;
            // The tangent-plane bound, and the larger (tighter) of the two.
            let by_plane = block.centre_distance + (gx * ox + gy * oy + gz * oz) - SLACK;
            let bound = by_centre.max(by_plane);
            let mut lanes = bound.cmplt(Vec4::splat(*bar)).bitmask();
            while lanes != 0 {
                let lane = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                // A bar lowered earlier in this block may rule the lane out.
                if bound[lane] < *bar {
                    visit(block.triangles[lane], bar);
                }
            }
        }
    }
}

/// Every triangle within `D(c) + 2r` of the centre `c` of `cell`, sorted by distance.
fn cell_list(mesh: &TriMesh, origin: Vec3, size: f32, [x, y, z]: [usize; 3]) -> Vec<Candidate> {
    let centre = origin + (Vec3::new(x as f32, y as f32, z as f32) + 0.5) * size;
    let half_diagonal = 0.5 * size * 3f32.sqrt();
    // Parry signs the distance on an oriented mesh; the bound needs its magnitude.
    let reach = mesh.distance_to_local_point(centre, false).abs() + 2.0 * half_diagonal + SLACK;
    let aabb = Aabb::new(centre - Vec3::splat(reach), centre + Vec3::splat(reach));
    let near: Vec<u32> = mesh.bvh().intersect_aabb(&aabb).collect();
    // Far more than a list may hold (a fine mesh): the list would be dropped anyway, so
    // spare projecting them all.
    if near.len() > BOX_LIMIT {
        return Vec::new();
    }
    let mut list: Vec<Candidate> = near
        .into_iter()
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

/// What a candidate-list query found.
pub(super) enum Near {
    /// `p` lies in a cell without a list: ask the BVH.
    Unlisted,
    /// Nothing nearer than the distance asked for.
    Beyond,
    /// The exact closest point.
    Closest(Closest),
}
