//! Short lists of the triangles a segment near a sharp feature (an ear's rim, the nose)
//! can cross, so the exact crossing test there runs four triangles at a time through a
//! handful of blocks instead of walking the BVH.
//!
//! # Why the lists are exact
//!
//! They live in the cells of the curvature grid ([`SagGrid`]), where the rise bound sends
//! segments to the exact test. A segment of length `L ≤ 2 REACH` whose middle lies in a
//! cell with centre `c` and half diagonal `h` has every point within `L / 2 + h ≤ REACH +
//! h` of `c`; so a list of every triangle within that distance of `c` holds every triangle
//! the segment can cross. Longer segments, cells off the sharp features and cells whose
//! lists would be long take the BVH.
//!
//! The test is Möller–Trumbore's, two-sided, with a little slack on the barycentric
//! bounds: a segment grazing an edge counts as crossing, so the caller turns it out
//! rather than let it through.

use super::sag::{REACH, SagGrid};
use crate::math::Vec3;
use glam::Vec4;
use parry3d::query::PointQuery;
use parry3d::shape::Triangle;

/// Cells whose surface curves tighter than this (radius under 4 cm: rims, the nose, the
/// chin) get lists; the skull's segments rarely reach the exact test.
const MIN_CURVATURE: f32 = 25.0;
/// A cell with more triangles than this in reach uses the BVH.
const MAX_TRIANGLES: usize = 96;
/// Absorbs f32 rounding in the bake's distances, metres.
const SLACK: f32 = 1e-5;
/// How far outside a triangle's edges a hit still counts, in barycentric units.
const EDGE_SLACK: f32 = 1e-5;
/// Marks a cell without a list.
const NONE: u32 = u32::MAX;

/// Four triangles, lane by lane: a corner and the two edges from it.
#[derive(Clone, Copy, Debug)]
struct Block {
    corner: [Vec4; 3],
    first: [Vec4; 3],
    second: [Vec4; 3],
    /// The distance from the cell's centre to the nearest of the four (a list's blocks
    /// come nearest first).
    nearest: f32,
}

impl Block {
    /// No triangle: zero edges never hit.
    const EMPTY: Block =
        Block { corner: [Vec4::ZERO; 3], first: [Vec4::ZERO; 3], second: [Vec4::ZERO; 3], nearest: 0.0 };
}

/// Per cell of the curvature grid, the triangles a segment centred in it may cross.
#[derive(Clone, Debug)]
pub(super) struct CrossingLists {
    /// Per cell: the first block of its list and the number of blocks, or [`NONE`].
    cells: Vec<(u32, u32)>,
    blocks: Vec<Block>,
    /// A cell's half diagonal plus the bake's slack, metres.
    half_diagonal: f32,
}

impl CrossingLists {
    /// Lists for the cells of `sag` on sharp features, from the mesh of `positions` and
    /// `triangles` (in `sag`'s frame).
    pub fn bake(sag: &SagGrid, positions: &[Vec3], triangles: &[[u32; 3]]) -> Self {
        let (dims, cell) = (sag.dims(), sag.cell_size());
        let reach = REACH + 0.5 * cell * 3f32.sqrt() + SLACK;
        let count = dims[0] * dims[1] * dims[2];
        let sharp: Vec<bool> = (0..count).map(|i| sag.convex_in(i) > MIN_CURVATURE).collect();
        // Each triangle into the sharp cells whose centre it comes within reach of.
        let mut found: Vec<Vec<(f32, u32)>> = vec![Vec::new(); count];
        for (t, corners) in triangles.iter().enumerate() {
            let [a, b, c] = corners.map(|v| positions[v as usize]);
            let (low, high) = (a.min(b).min(c) - Vec3::splat(reach), a.max(b).max(c) + Vec3::splat(reach));
            let (lo, hi) = (sag.cell_index(low), sag.cell_index(high));
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    for x in lo[0]..=hi[0] {
                        let i = x + dims[0] * (y + dims[1] * z);
                        if sharp[i] && found[i].len() <= MAX_TRIANGLES {
                            let distance =
                                Triangle::new(a, b, c).distance_to_local_point(sag.cell_centre([x, y, z]), false);
                            if distance <= reach {
                                found[i].push((distance, t as u32));
                            }
                        }
                    }
                }
            }
        }
        let mut lists =
            CrossingLists { cells: vec![(NONE, 0); count], blocks: Vec::new(), half_diagonal: reach - REACH };
        for (i, list) in found.iter_mut().enumerate() {
            if !sharp[i] || list.len() > MAX_TRIANGLES {
                continue;
            }
            // Nearest the centre first, so a short segment stops early.
            list.sort_by(|p, q| p.0.total_cmp(&q.0));
            let first = lists.blocks.len() as u32;
            for four in list.chunks(4) {
                let mut block = Block { nearest: four[0].0, ..Block::EMPTY };
                for (lane, &(_, t)) in four.iter().enumerate() {
                    let [a, b, c] = triangles[t as usize].map(|v| positions[v as usize]);
                    let (first_edge, second_edge) = (b - a, c - a);
                    for k in 0..3 {
                        block.corner[k][lane] = a[k];
                        block.first[k][lane] = first_edge[k];
                        block.second[k][lane] = second_edge[k];
                    }
                }
                lists.blocks.push(block);
            }
            lists.cells[i] = (first, lists.blocks.len() as u32 - first);
        }
        lists
    }

    /// Where the segment `a`–`b` (in the grid's frame, its middle in cell `cell`, grid
    /// coordinates) crosses the mesh: the fractions of the way from `a` where it first
    /// enters and last leaves; `None` when it crosses nothing. `Err(())` when this cell has
    /// no list or the segment is too long for one: ask the BVH.
    pub fn crossing(&self, cell: usize, a: Vec3, b: Vec3) -> Result<Option<(f32, f32)>, ()> {
        let (first, blocks) = self.cells[cell];
        let length = (b - a).length();
        if first == NONE || length > 2.0 * REACH {
            return Err(());
        }
        // No triangle farther than this from the cell's centre reaches the segment.
        let reach = 0.5 * length + self.half_diagonal;
        let d = b - a;
        let (dx, dy, dz) = (Vec4::splat(d.x), Vec4::splat(d.y), Vec4::splat(d.z));
        let (mut enters, mut leaves) = (Vec4::splat(f32::INFINITY), Vec4::splat(f32::NEG_INFINITY));
        for block in self.blocks[first as usize..(first + blocks) as usize].iter().take_while(|b| b.nearest <= reach) {
            let [e1x, e1y, e1z] = block.first;
            let [e2x, e2y, e2z] = block.second;
            // p = d × e2, det = e1 · p
            let (px, py, pz) = (dy * e2z - dz * e2y, dz * e2x - dx * e2z, dx * e2y - dy * e2x);
            let det = e1x * px + e1y * py + e1z * pz;
            let inverse = Vec4::ONE / det;
            // s = a − corner, u = (s · p) / det
            let (sx, sy, sz) = (
                Vec4::splat(a.x) - block.corner[0],
                Vec4::splat(a.y) - block.corner[1],
                Vec4::splat(a.z) - block.corner[2],
            );
            let u = (sx * px + sy * py + sz * pz) * inverse;
            // q = s × e1, v = (d · q) / det, t = (e2 · q) / det
            let (qx, qy, qz) = (sy * e1z - sz * e1y, sz * e1x - sx * e1z, sx * e1y - sy * e1x);
            let v = (dx * qx + dy * qy + dz * qz) * inverse;
            let t = (e2x * qx + e2y * qy + e2z * qz) * inverse;
            let low = Vec4::splat(-EDGE_SLACK);
            let hit = det.abs().cmpgt(Vec4::splat(1e-20))
                & u.cmpge(low)
                & v.cmpge(low)
                & (u + v).cmple(Vec4::splat(1.0 + EDGE_SLACK))
                & t.cmpge(Vec4::ZERO)
                & t.cmple(Vec4::ONE);
            enters = Vec4::select(hit, t.min(enters), enters);
            leaves = Vec4::select(hit, t.max(leaves), leaves);
        }
        let (enters, leaves) = (enters.min_element(), leaves.max_element());
        Ok((enters <= leaves).then_some((enters, leaves)))
    }
}
