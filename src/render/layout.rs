//! The static strand mesh: which rendered strand and curve sample each vertex is.
//!
//! Built once per groom layout. The vertex shader turns (strand, sample, side) into a
//! position from the guide particles it reads each frame, so this mesh never changes
//! while the hair moves.

use bevy::asset::RenderAssetUsages;
use bevy::mesh::{Indices, Mesh, MeshVertexAttribute, PrimitiveTopology, VertexAttributeValues, VertexFormat};

/// The only vertex attribute of a strand mesh: `(rendered strand, curve sample · 2 + side)`.
/// Rendered strand `r` is child `r % strands_per_guide` of guide `r / strands_per_guide`,
/// child 0 being the guide itself.
pub const ATTRIBUTE_HAIR_VERTEX: MeshVertexAttribute =
    MeshVertexAttribute::new("HairVertex", 0x6861_6972_5f76_7478, VertexFormat::Uint32x2);

/// How many strands, samples and vertices a groom draws.
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

    /// Strands drawn.
    pub fn strands(&self) -> u32 {
        self.guides * self.strands_per_guide
    }

    /// Vertices of the ribbon mesh (two per sample).
    pub fn vertices(&self) -> u32 {
        self.strands() * self.samples() * 2
    }

    /// Triangles of the ribbon mesh (two per curve piece).
    pub fn triangles(&self) -> u32 {
        self.strands() * (self.samples() - 1) * 2
    }

    /// The ribbon mesh: every strand a strip of quads, as a triangle list (strips would
    /// need a restart index between strands).
    pub fn mesh(&self) -> Mesh {
        let samples = self.samples();
        let mut vertices = Vec::with_capacity(self.vertices() as usize);
        let mut indices = Vec::with_capacity(self.triangles() as usize * 3);
        for strand in 0..self.strands() {
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
        let mesh = layout.mesh();
        assert_eq!(mesh.count_vertices() as u32, layout.vertices());
        assert_eq!(mesh.indices().unwrap().len() as u32, layout.triangles() * 3);
        // Every index stays inside its own strand's vertices.
        let per_strand = layout.samples() * 2;
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
