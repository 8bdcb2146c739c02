//! How far the head's surface can rise under a straight segment: what lets most hair
//! segments skip the exact crossing test.
//!
//! A segment whose two ends are outside the head can still cut through it between them,
//! where the surface bulges toward it by more than the ends clear it. Under a chord of
//! length `L`, a surface whose convex curvature is at most `κ` rises at most `κ L² / 8`
//! above the line between the ends' heights (a circular arc is the worst case). On a
//! skull (radii 5–16 cm) a 1.8 cm hair segment needs 0.3–0.8 mm of clearance at its ends;
//! by an ear's rim (radius of a few millimetres) only the exact test can tell.
//!
//! The mesh is flat between its vertices. Where it is convex its facets lie inside the
//! smooth surface through its vertices, where concave up to `κ e² / 8` outside it (`e` an
//! edge's length), and the bound adds that. The curvature along an edge `u`–`v` comes
//! from the vertex normals, `(n_v − n_u)·(v − u) / |v − u|²`: `1 / R` on a sphere of
//! radius `R`, negative where the surface is concave.
//!
//! Both terms are baked per cell of a coarse grid as the largest over the edges within
//! [`REACH`] of the cell, so a segment up to twice that long, looked up at its midpoint,
//! sees every edge under it. The bound is an estimate from the vertex normals, not a
//! proof; `tests::no_segment_it_clears_crosses_the_head` checks it against brute force on
//! the procedural head, ears included.

use crate::math::{Vec3, bounds};
use glam::Vec3A;

/// The neighbourhood each cell covers beyond itself, metres: segments up to twice this
/// long are judged; longer ones always get the exact test.
pub const REACH: f32 = 0.0125;
/// Cell size, metres.
const CELL: f32 = 0.008;
/// The most cells the grid may have; a mesh too large for [`CELL`]-sized cells at this
/// count gets larger cells.
const MAX_CELLS: f32 = 2.0e6;
/// Where the surface's normal turns by more than this many radians under a segment, it is
/// no longer a height field under it (an ear's rim), and the bound says nothing.
pub(super) const MAX_TURN: f32 = 1.0;

/// Per cell of a grid around the mesh, the largest convex curvature of the surface near
/// it and the largest facet term.
#[derive(Clone, Debug)]
pub(super) struct SagGrid {
    origin: Vec3A,
    inverse_cell: f32,
    dims: [usize; 3],
    /// Per cell: the largest convex curvature `κ`, 1/m, and the largest `|κ| e² / 8`, m.
    cells: Vec<(f32, f32)>,
}

impl SagGrid {
    /// Bakes the grid for a mesh of `positions` and `triangles` (indices into them).
    pub fn bake(positions: &[Vec3], triangles: &[[u32; 3]]) -> Self {
        let (low, high) = if positions.is_empty() { (Vec3::ZERO, Vec3::ZERO) } else { bounds(positions) };
        let padded = (high - low).max(Vec3::splat(1e-6)) + Vec3::splat(2.0 * REACH);
        let cell = CELL.max(1.01 * (padded.x * padded.y * padded.z / MAX_CELLS).cbrt());
        // Two cells more on each side than the filter below reaches: the outermost cells stay
        // empty, and a point beyond the grid reads the nearest of them.
        let origin = low - Vec3::splat(REACH + 2.0 * cell);
        let dims = (padded / cell).to_array().map(|n| n as usize + 5);
        let mut grid = SagGrid {
            origin: origin.into(),
            inverse_cell: 1.0 / cell,
            dims,
            cells: vec![(0.0, 0.0); dims[0] * dims[1] * dims[2]],
        };
        let normals = crate::mesh::area_weighted_normals(positions, triangles);
        // Each edge (twice, once from each side: the same value) into the cells it touches.
        for t in triangles {
            for k in 0..3 {
                let (u, v) = (t[k] as usize, t[(k + 1) % 3] as usize);
                let edge = positions[v] - positions[u];
                let length_squared = edge.length_squared();
                if length_squared == 0.0 {
                    continue;
                }
                let curvature = (normals[v] - normals[u]).dot(edge) / length_squared;
                let value = (curvature.max(0.0), curvature.abs() * length_squared / 8.0);
                let (lo, hi) =
                    (grid.cell_index(positions[u].min(positions[v])), grid.cell_index(positions[u].max(positions[v])));
                for z in lo[2]..=hi[2] {
                    for y in lo[1]..=hi[1] {
                        for x in lo[0]..=hi[0] {
                            let cell = &mut grid.cells[x + dims[0] * (y + dims[1] * z)];
                            *cell = (cell.0.max(value.0), cell.1.max(value.1));
                        }
                    }
                }
            }
        }
        // Spread each cell's values over the cells within `REACH`: a max filter, one axis
        // at a time.
        let radius = (REACH / cell).ceil() as usize;
        let strides = [1, dims[0], dims[0] * dims[1]];
        for axis in 0..3 {
            let before = grid.cells.clone();
            for (i, cell) in grid.cells.iter_mut().enumerate() {
                let along = i / strides[axis] % dims[axis];
                let (first, last) = (along.saturating_sub(radius), (along + radius).min(dims[axis] - 1));
                for other in first..=last {
                    let value = before[i - along * strides[axis] + other * strides[axis]];
                    *cell = (cell.0.max(value.0), cell.1.max(value.1));
                }
            }
        }
        grid
    }

    /// How far the surface may rise above the straight line between `a` and `b` (in the
    /// mesh's frame): where both ends are farther than this from the surface, the segment
    /// between them does not reach it. Infinite where the grid cannot tell (a segment
    /// longer than twice [`REACH`], or a surface turning too fast under it).
    #[cfg(test)]
    pub fn bound(&self, a: Vec3, b: Vec3) -> f32 {
        self.bound_in(self.cells().locate(0.5 * (a + b)), (b - a).length())
    }

    /// Where the cells lie, to locate points in them: [`SagCells::locate`].
    pub fn cells(&self) -> SagCells {
        let last = self.dims.map(|n| (n - 1) as f32);
        SagCells { origin: self.origin.into(), inverse_cell: self.inverse_cell, last: Vec3::from_array(last) }
    }

    /// How far the surface may rise above a segment of `length` whose middle lies at
    /// `cell` (grid coordinates within the grid, from [`SagCells::locate`]): where both
    /// its ends are farther than this from the surface, the segment does not reach it.
    #[inline]
    pub fn bound_in(&self, cell: Vec3, length: f32) -> f32 {
        if length.is_nan() || length > 2.0 * REACH {
            return f32::INFINITY;
        }
        // (Through i32: a float converts to it in one instruction, and `cell` is in range.)
        let [x, y, z] = cell.to_array().map(|v| v as i32 as usize);
        let (convex, facet) = self.cells[x + self.dims[0] * (y + self.dims[1] * z)];
        if convex * length > MAX_TURN {
            return f32::INFINITY;
        }
        convex * length * length / 8.0 + facet
    }

    /// The cell holding `p` (the nearest one for a point beyond the grid).
    pub fn cell_index(&self, p: Vec3) -> [usize; 3] {
        self.cells().locate(p).to_array().map(|v| v as i32 as usize)
    }

    /// Cells along each axis.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// A cell's side, metres.
    pub fn cell_size(&self) -> f32 {
        1.0 / self.inverse_cell
    }

    /// The index of the cell holding `p`, cells in x-fastest order.
    pub fn index_of(&self, p: Vec3) -> usize {
        let [x, y, z] = self.cell_index(p);
        x + self.dims[0] * (y + self.dims[1] * z)
    }

    /// The centre of cell `[x, y, z]`.
    pub fn cell_centre(&self, [x, y, z]: [usize; 3]) -> Vec3 {
        Vec3::from(self.origin) + (Vec3::new(x as f32, y as f32, z as f32) + Vec3::splat(0.5)) * self.cell_size()
    }

    /// Per cell (x-fastest order): the largest convex curvature, 1/m, and facet term, m.
    pub fn values(&self) -> &[(f32, f32)] {
        &self.cells
    }

    /// The largest convex curvature near cell `index` (x-fastest order), 1/m.
    pub fn convex_in(&self, index: usize) -> f32 {
        self.cells[index].0
    }
}

/// Where the cells of the collider's curvature grid lie: `(p - origin) * inverse_cell`,
/// clamped to the grid, gives a point's cell coordinates. Lane-wide code can do that
/// arithmetic itself and hand each lane's coordinates to the grid's lookup.
#[derive(Clone, Copy, Debug)]
pub struct SagCells {
    /// The grid's corner.
    pub origin: Vec3,
    /// Cells per metre.
    pub inverse_cell: f32,
    /// The last cell's coordinates along each axis.
    pub last: Vec3,
}

impl SagCells {
    /// The coordinates of the cell holding `p`; a point beyond the grid gets the nearest of
    /// its outermost cells, which are empty.
    #[inline]
    pub fn locate(&self, p: Vec3) -> Vec3 {
        ((p - self.origin) * self.inverse_cell).clamp(Vec3::ZERO, self.last)
    }
}

#[cfg(test)]
mod tests;
