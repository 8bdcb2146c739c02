//! The rest shape as the SIMD groups read it: transposed once, when the strands are made,
//! instead of strand by strand into every group at every step.
//!
//! A group of strands steps with each particle quantity one [`V3`](super::lanes::V3) (a
//! strand per lane, [`lanes`](super::lanes)). [`RestShape`] keeps its particles strand by
//! strand, so loading a group's rest positions, rest directions and lengths is seven
//! scalar copies per particle and strand, each step. Here they are kept in blocks of
//! [`MAX_LANES`] strands, every row of a block holding one component of one particle for
//! all its strands side by side: a group whose strands run consecutively from a multiple
//! of its width (every group of a groom at full detail) loads each row as whole vectors.

use super::RestShape;
use super::lanes::MAX_LANES;
use crate::math::Vec3;

/// The rows of a particle in a block: position x, y, z, local direction x, y, z, length.
const ROWS: usize = 7;

/// One row of [`RestLanes`]: which component of the rest shape it holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Row {
    /// Component 0, 1 or 2 of the head-local rest position.
    Position(usize),
    /// Component 0, 1 or 2 of the rest direction in the parent segment's frame.
    Direction(usize),
    /// The rest length of the segment ending at the particle.
    Length,
}

impl Row {
    fn index(self) -> usize {
        match self {
            Row::Position(c) => c,
            Row::Direction(c) => 3 + c,
            Row::Length => 6,
        }
    }
}

/// [`RestShape`]'s per-particle data in blocks of [`MAX_LANES`] strands (module docs).
#[derive(Clone, Debug)]
pub(super) struct RestLanes {
    particles_per_strand: usize,
    /// Block `b`, particle `j`, row `r`, strand `k` of the block at
    /// `((b · n + j) · ROWS + r) · MAX_LANES + k`; lanes past the last strand hold zeros.
    values: Vec<f32>,
}

impl RestLanes {
    /// `rest` transposed.
    pub fn new(rest: &RestShape) -> Self {
        let n = rest.particles_per_strand;
        let blocks = rest.strand_count().div_ceil(MAX_LANES);
        let mut lanes = RestLanes { particles_per_strand: n, values: vec![0.0; blocks * n * ROWS * MAX_LANES] };
        for strand in 0..rest.strand_count() {
            for j in 0..n {
                let i = strand * n + j;
                let (position, direction) = (rest.positions[i], rest.local_directions[i]);
                for c in 0..3 {
                    *lanes.value_mut(strand, j, Row::Position(c)) = position[c];
                    *lanes.value_mut(strand, j, Row::Direction(c)) = direction[c];
                }
                *lanes.value_mut(strand, j, Row::Length) = rest.lengths[i];
            }
        }
        lanes
    }

    /// Moves strand `strand`'s root, as [`super::Strands::set_rest_root`] moves it in the
    /// rest shape.
    pub fn set_root(&mut self, strand: usize, root: Vec3) {
        for c in 0..3 {
            *self.value_mut(strand, 0, Row::Position(c)) = root[c];
        }
    }

    /// Row `row` of particle `j` from strand `strand` to the end of its block: lane `l`
    /// is strand `strand + l`. A group of `w` lanes (`w` dividing [`MAX_LANES`]) whose
    /// first strand is a multiple of `w` finds all its lanes here.
    #[inline(always)]
    pub fn row(&self, strand: usize, j: usize, row: Row) -> &[f32] {
        let (start, lane) = self.locate(strand, j, row);
        &self.values[start + lane..start + MAX_LANES]
    }

    fn value_mut(&mut self, strand: usize, j: usize, row: Row) -> &mut f32 {
        let (start, lane) = self.locate(strand, j, row);
        &mut self.values[start + lane]
    }

    /// Where row `row` of particle `j` starts in the block holding strand `strand`, and
    /// the strand's lane in it.
    #[inline(always)]
    fn locate(&self, strand: usize, j: usize, row: Row) -> (usize, usize) {
        let (block, lane) = (strand / MAX_LANES, strand % MAX_LANES);
        (((block * self.particles_per_strand + j) * ROWS + row.index()) * MAX_LANES, lane)
    }
}

#[cfg(test)]
mod tests;
