//! The order to draw blended strands in: back to front from the eye, piece by piece.
//! GPU twin: `hair_gpu`'s `GpuDrawOrder` (`sort.wgsl`).
//!
//! Blended hair (each strand thinner than a pixel drawn wider with its coverage as
//! opacity) is composited in the order it is drawn, so nearer hair must come later. Whole
//! strands cross in depth (a strand from the crown lies over the ones below it), so each
//! strand is cut into pieces of a few segments, and the pieces are sorted by the depth of
//! the particle in their middle: per piece, not per pixel, but every frame.

use crate::math::Vec3;

/// Pieces per strand of `particles` particles, `segments_per_piece` segments each (the
/// last perhaps fewer).
pub fn pieces_per_strand(particles: usize, segments_per_piece: usize) -> usize {
    particles.saturating_sub(1).div_ceil(segments_per_piece.max(1))
}

/// The pieces of the strands in `positions` (strand-major, `particles` per strand), each
/// `segments_per_piece` segments long and numbered `strand · pieces + piece`
/// ([`pieces_per_strand`]), from the farthest from `eye` to the nearest, by the particle in
/// each piece's middle. Ties keep the order grown.
pub fn back_to_front(positions: &[Vec3], particles: usize, segments_per_piece: usize, eye: Vec3) -> Vec<u32> {
    let segments_per_piece = segments_per_piece.max(1);
    let pieces = pieces_per_strand(particles, segments_per_piece);
    let strands = positions.len().checked_div(particles).unwrap_or(0);
    // Each piece's squared distance (a non-negative float, so its bits sort as it does),
    // inverted for back to front, above the piece's number: one integer sort.
    let mut keyed: Vec<u64> = (0..strands * pieces)
        .map(|piece| {
            let middle = ((piece % pieces) * segments_per_piece + segments_per_piece / 2).min(particles - 1);
            let depth = positions[(piece / pieces) * particles + middle].distance_squared(eye);
            (u64::from(!depth.to_bits()) << 32) | piece as u64
        })
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|key| key as u32).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pieces_are_sorted_back_to_front() {
        // Two strands of 4 particles (3 segments: pieces of 2 and 1), the first along the
        // view axis from 1 to 4 m in front of the eye, the second across it at 2.5 m.
        let along = (0..4).map(|j| Vec3::new(0.0, 0.0, -1.0 - j as f32));
        let across = (0..4).map(|j| Vec3::new(0.1 * j as f32, 0.0, -2.5));
        let positions: Vec<Vec3> = along.chain(across).collect();
        assert_eq!(pieces_per_strand(4, 2), 2);
        // Pieces' middles: 2 m and 4 m along (the second piece's middle is its tip), 2.5 m
        // aside by 0.1 m and 0.3 m across.
        assert_eq!(back_to_front(&positions, 4, 2, Vec3::ZERO), [1, 3, 2, 0]);
        // From behind: 3 m, 2.52 m (0.3 m aside), 2.50 m and 1 m.
        assert_eq!(back_to_front(&positions, 4, 2, Vec3::new(0.0, 0.0, -5.0)), [0, 3, 2, 1]);
        // Equal depths keep the order grown.
        let level = vec![Vec3::new(0.0, 0.0, -1.0); 8];
        assert_eq!(back_to_front(&level, 4, 2, Vec3::ZERO), [0, 1, 2, 3]);
        assert!(back_to_front(&[], 4, 2, Vec3::ZERO).is_empty());
    }
}
