//! A signed distance grid baked from the exact mesh distance, for the cheap far reject.

use crate::math::{Vec3, bounds};
use glam::Vec3A;

/// How far from the surface, in cells, every sample of a [`DistanceGrid`] is exact.
pub const EXACT_BAND_CELLS: f32 = 4.0;

/// The coarse lattice of exact samples the far bounds come from: every this many samples.
const COARSE_STRIDE: usize = 4;

/// Signed distances sampled on a regular grid around the head (negative inside).
///
/// Trilinear interpolation of a distance function is off by at most half a cell
/// diagonal: the function is 1-Lipschitz, so the error is at most the weighted mean
/// distance from the point to the cell's corners, which peaks at the cell centre.
/// [`DistanceGrid::max_error`] is that bound.
///
/// Only the samples within 4 cells (`EXACT_BAND_CELLS`) of the surface are exact. Farther
/// out a sample holds a bound from the nearest of a coarse lattice of exact samples (the
/// distance is 1-Lipschitz): the right sign, and never farther from zero than the truth.
/// There a sample still proves a point clear of the surface by at least its value less
/// the error, which is all a far point needs, and the bake pays for exact distances only
/// near the surface.
#[derive(Clone, Debug)]
pub struct DistanceGrid {
    origin: Vec3A,
    cell: f32,
    /// `1 / cell`, for the per-query scaling.
    inverse_cell: f32,
    dims: [usize; 3],
    /// Cells along each axis, as floats: a grid coordinate must stay below them.
    upper: Vec3A,
    values: Vec<f32>,
    /// The grid reaches at least this far beyond the mesh on every side.
    margin: f32,
    max_error: f32,
}

/// Where a point falls in the grid: its cell and its place inside it.
#[derive(Clone, Copy, Debug)]
pub(super) struct GridPoint {
    /// Index of the cell's lowest corner in the sample array; it also names the cell.
    pub index: usize,
    /// Position inside the cell, each coordinate in `[0, 1)`.
    pub fraction: Vec3A,
}

impl DistanceGrid {
    /// Samples `distance` on a grid with `resolution` cells along the longest side of the
    /// bounding box of `points`, padded on every side by a quarter of that side.
    pub fn bake(points: &[Vec3], resolution: u32, distance: impl Fn(Vec3) -> f32 + Sync) -> Self {
        let (min, max) = bounds(points);
        let margin = 0.25 * (max - min).max_element().max(1e-3);
        let (min, max) = (min - Vec3::splat(margin), max + Vec3::splat(margin));
        let cell = (max - min).max_element() / resolution as f32;
        let dims = ((max - min) / cell).ceil().to_array().map(|n| n as usize + 1);
        let position = |[x, y, z]: [usize; 3]| min + Vec3::new(x as f32, y as f32, z as f32) * cell;
        // First the coarse lattice, exact; x fastest, then y, then z, over all cores.
        let coarse_dims = dims.map(|n| (n - 1).div_ceil(COARSE_STRIDE) + 1);
        let coarse_index = |[x, y, z]: [usize; 3]| (z * coarse_dims[1] + y) * coarse_dims[0] + x;
        let coarse_node = |c: [usize; 3]| [0, 1, 2].map(|k| (c[k] * COARSE_STRIDE).min(dims[k] - 1));
        let coarse = crate::parallel::map(coarse_dims.iter().product(), |i| {
            let (cx, cy, cz) =
                (i % coarse_dims[0], i / coarse_dims[0] % coarse_dims[1], i / (coarse_dims[0] * coarse_dims[1]));
            distance(position(coarse_node([cx, cy, cz])))
        });
        // Then every sample: exact near the surface, bounded from the nearest coarse sample
        // where that proves it farther than the band.
        let band = EXACT_BAND_CELLS * cell;
        let values = crate::parallel::map(dims[0] * dims[1] * dims[2], |i| {
            let node = [i % dims[0], i / dims[0] % dims[1], i / (dims[0] * dims[1])];
            let nearest = [0, 1, 2].map(|k| {
                let c = (node[k] + COARSE_STRIDE / 2) / COARSE_STRIDE;
                c.min(coarse_dims[k] - 1)
            });
            let known = coarse[coarse_index(nearest)];
            let p = position(node);
            let bound = known.abs() - p.distance(position(coarse_node(nearest)));
            if bound > band { known.signum() * bound } else { distance(p) }
        });
        let upper = Vec3A::new((dims[0] - 1) as f32, (dims[1] - 1) as f32, (dims[2] - 1) as f32);
        let max_error = 0.5 * cell * 3f32.sqrt();
        DistanceGrid { origin: min.into(), cell, inverse_cell: 1.0 / cell, dims, upper, values, margin, max_error }
    }

    /// The largest difference between [`sample`](Self::sample) and the true distance.
    pub fn max_error(&self) -> f32 {
        self.max_error
    }

    /// Edge length of one cell.
    pub fn cell_size(&self) -> f32 {
        self.cell
    }

    /// Interpolated signed distance at `p`, or `None` outside the grid, which means at
    /// least [`margin`](Self::margin) away from the mesh (also for non-finite `p`).
    #[inline]
    pub fn sample(&self, p: Vec3) -> Option<f32> {
        self.locate(p).map(|at| self.sample_at(at))
    }

    /// The cell holding `p`, or `None` outside the grid (and for non-finite `p`).
    #[inline]
    pub(super) fn locate(&self, p: Vec3) -> Option<GridPoint> {
        let g = (Vec3A::from(p) - self.origin) * self.inverse_cell;
        if !(g.cmpge(Vec3A::ZERO) & g.cmplt(self.upper)).all() {
            return None;
        }
        // `g` is non-negative and below the dims here, so truncation is the floor; through
        // i32 it is one instruction (a direct f32 → usize cast is a slow saturating path).
        let [x, y, z] = g.to_array().map(|v| v as i32 as usize);
        let fraction = g - Vec3A::new(x as f32, y as f32, z as f32);
        Some(GridPoint { index: (z * self.dims[1] + y) * self.dims[0] + x, fraction })
    }

    /// Trilinear interpolation of the cell's eight corners.
    #[inline]
    pub(super) fn sample_at(&self, at: GridPoint) -> f32 {
        let [dx, dy, _] = self.dims;
        let plane = dx * dy;
        // The eight corners, in one bounds-checked slice starting at the lowest corner.
        let v = &self.values[at.index..][..plane + dx + 2];
        let t = at.fraction;
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let near = lerp(lerp(v[0], v[1], t.x), lerp(v[dx], v[dx + 1], t.x), t.y);
        let far = lerp(lerp(v[plane], v[plane + 1], t.x), lerp(v[plane + dx], v[plane + dx + 1], t.x), t.y);
        lerp(near, far, t.z)
    }

    /// The grid's lowest corner.
    pub fn origin(&self) -> Vec3 {
        self.origin.into()
    }

    /// Samples along each axis (one more than cells).
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// The samples, x fastest, then y, then z: sample `[x, y, z]` lies at
    /// `origin + [x, y, z] · cell_size` (for a copy on the GPU).
    pub fn values(&self) -> &[f32] {
        &self.values
    }

    /// The smallest and largest of the eight corner values of cell `[x, y, z]`: every
    /// trilinear sample inside the cell lies between them.
    pub(super) fn cell_range(&self, [x, y, z]: [usize; 3]) -> (f32, f32) {
        let [dx, dy, _] = self.dims;
        let mut range = (f32::INFINITY, f32::NEG_INFINITY);
        for corner in 0..8 {
            let (cx, cy, cz) = (x + (corner & 1), y + ((corner >> 1) & 1), z + (corner >> 2));
            let v = self.values[(cz * dy + cy) * dx + cx];
            range = (range.0.min(v), range.1.max(v));
        }
        range
    }

    /// How far beyond the mesh the grid reaches: a point outside the grid is at least
    /// this far from the surface.
    pub fn margin(&self) -> f32 {
        self.margin
    }
}

#[cfg(test)]
mod tests;
