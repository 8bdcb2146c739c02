//! The static strand mesh: which piece of which rendered strand, and which curve sample
//! of it, each vertex is.
//!
//! Built once per groom layout. Every strand is cut into pieces of
//! [`SEGMENTS_PER_PIECE`] guide segments, and the mesh draws the guides' pieces in the
//! order the guide buffer gives (each with the same piece of the guide's children), so
//! that blended strands can be drawn back to front piece by piece. The vertex shader
//! turns (piece, child, sample, side) into a position from the guide particles it reads
//! each frame, so this mesh never changes while the hair moves.

use bevy::asset::RenderAssetUsages;
use bevy::math::Vec4;
use bevy::mesh::{Indices, Mesh, MeshVertexAttribute, PrimitiveTopology, VertexAttributeValues, VertexFormat};
use hair_sim::draw_order::pieces_per_strand;

/// Guide segments per drawn piece of a strand (`strand.wgsl`'s `SEGMENTS_PER_PIECE`).
pub const SEGMENTS_PER_PIECE: u32 = 2;

/// The only vertex attribute of a strand mesh: `(drawn piece · strands_per_guide + child,
/// curve sample in the piece · 2 + side)`. The `k`th piece drawn is piece
/// `order[k] % pieces` of guide `order[k] / pieces`, `order` being the guide buffer's draw
/// order; child 0 is the guide itself.
pub const ATTRIBUTE_HAIR_VERTEX: MeshVertexAttribute =
    MeshVertexAttribute::new("HairVertex", 0x6861_6972_5f76_7478, VertexFormat::Uint32x2);

/// How many strands, samples and vertices a groom draws.
/// The plugin sizes each drawing with it; `tests/render/drawing.rs` builds one by hand to
/// draw chosen strands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StrandLayout {
    /// Simulated guide strands.
    pub guides: u32,
    /// Particles per guide.
    pub particles: u32,
    /// Rendered strands per guide: the guide plus its children.
    pub strands_per_guide: u32,
    /// Curve samples per segment.
    pub subdivisions: u32,
}

impl StrandLayout {
    /// Samples along each rendered strand: `segments · subdivisions + 1`.
    pub fn samples(&self) -> u32 {
        (self.particles - 1) * self.subdivisions + 1
    }

    /// Pieces each strand is drawn in: [`SEGMENTS_PER_PIECE`] segments each, the last
    /// perhaps fewer (its extra samples fold onto the tip).
    pub fn pieces(&self) -> u32 {
        pieces_per_strand(self.particles as usize, SEGMENTS_PER_PIECE as usize) as u32
    }

    /// Samples along each piece, both ends included.
    pub fn piece_samples(&self) -> u32 {
        SEGMENTS_PER_PIECE * self.subdivisions + 1
    }

    /// Strands drawn.
    pub fn strands(&self) -> u32 {
        self.guides * self.strands_per_guide
    }

    /// Vertices of the ribbon mesh (two per sample of every piece).
    pub fn vertices(&self) -> u32 {
        self.strands() * self.pieces() * self.piece_samples() * 2
    }

    /// Triangles of the ribbon mesh (two per curve sample interval of every piece).
    pub fn triangles(&self) -> u32 {
        self.strands() * self.pieces() * (self.piece_samples() - 1) * 2
    }

    /// The pieces in the order they were grown: guide by guide, root to tip.
    pub fn grown_order(&self) -> Vec<u32> {
        (0..self.guides * self.pieces()).collect()
    }

    /// The guide buffer's draw order section (it follows the head's centre): the pieces,
    /// `guide · pieces + piece`, in the order to draw them, four to a `Vec4` (exact as
    /// floats below 2²⁴).
    pub fn pack_order(order: &[u32]) -> Vec<Vec4> {
        order
            .chunks(4)
            .map(|pieces| {
                let mut packed = Vec4::ZERO;
                for (k, &piece) in pieces.iter().enumerate() {
                    packed[k] = piece as f32;
                }
                packed
            })
            .collect()
    }

    /// The ribbon mesh: every piece of every strand a strip of quads, as a triangle list
    /// (strips would need a restart index between pieces).
    pub fn mesh(&self) -> Mesh {
        let samples = self.piece_samples();
        let mut vertices = Vec::with_capacity(self.vertices() as usize);
        let mut indices = Vec::with_capacity(self.triangles() as usize * 3);
        for strand in 0..self.guides * self.pieces() * self.strands_per_guide {
            let first = strand * samples * 2;
            for sample in 0..samples {
                vertices.push([strand, sample * 2]);
                vertices.push([strand, sample * 2 + 1]);
                if sample + 1 < samples {
                    let [a, b, c, d] = [0, 1, 2, 3].map(|k| first + sample * 2 + k);
                    indices.extend_from_slice(&[a, b, c, c, b, d]);
                }
            }
        }
        Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::RENDER_WORLD)
            .with_inserted_attribute(ATTRIBUTE_HAIR_VERTEX, VertexAttributeValues::Uint32x2(vertices))
            .with_inserted_indices(Indices::U32(indices))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_match_the_mesh() {
        let layout = StrandLayout { guides: 3, particles: 11, strands_per_guide: 5, subdivisions: 4 };
        assert_eq!(layout.samples(), 41);
        assert_eq!(layout.strands(), 15);
        // 10 segments: 5 pieces of 2; 13 segments would leave one folded onto the tip.
        assert_eq!((layout.pieces(), layout.piece_samples()), (5, 9));
        assert_eq!(StrandLayout { particles: 14, ..layout }.pieces(), 7);
        assert_eq!(layout.grown_order(), (0..15).collect::<Vec<_>>());
        assert_eq!(
            StrandLayout::pack_order(&[4, 1, 7, 2, 9]),
            [Vec4::new(4.0, 1.0, 7.0, 2.0), Vec4::new(9.0, 0.0, 0.0, 0.0)]
        );
        let mesh = layout.mesh();
        assert_eq!(mesh.count_vertices() as u32, layout.vertices());
        assert_eq!(mesh.indices().unwrap().len() as u32, layout.triangles() * 3);
        // Every index stays inside its own piece's vertices.
        let per_strand = layout.piece_samples() * 2;
        let indices: Vec<usize> = mesh.indices().unwrap().iter().collect();
        for tri in indices.chunks(3) {
            let strands: Vec<usize> = tri.iter().map(|&i| i / per_strand as usize).collect();
            assert!(strands.iter().all(|&s| s == strands[0]), "triangle {tri:?} spans strands");
        }
        let Some(VertexAttributeValues::Uint32x2(values)) = mesh.attribute(ATTRIBUTE_HAIR_VERTEX) else {
            panic!("no hair vertex attribute");
        };
        assert_eq!(values[per_strand as usize * 2 + 3], [2, 3]);
    }
}
