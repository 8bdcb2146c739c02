//! The strand material: guide particles in a storage buffer, the look in a uniform, and
//! `hair.wgsl` for both stages.

use super::layout::ATTRIBUTE_HAIR_VERTEX;
use bevy::mesh::MeshVertexBufferLayoutRef;
use bevy::pbr::{MaterialPipeline, MaterialPipelineKey};
use bevy::prelude::*;
use bevy::render::render_resource::{AsBindGroup, RenderPipelineDescriptor, ShaderType, SpecializedMeshPipelineError};
use bevy::render::storage::ShaderBuffer;
use bevy::shader::ShaderRef;

/// Where the embedded shader lives.
pub(crate) const SHADER_PATH: &str = "embedded://bevy_hair/render/hair.wgsl";

/// The material of a drawn groom. The plugin creates and updates it from the groom's
/// [`HairLook`](super::HairLook) and layout; users edit the look, not this.
#[derive(Asset, TypePath, AsBindGroup, Clone, Debug)]
pub struct HairMaterial {
    /// Guide particle positions (one `vec4` each, strand-major), then each particle's
    /// transport frame vector `u` (same order, `w` = 0); rewritten every frame at the same
    /// size.
    #[storage(0, read_only)]
    pub guides: Handle<ShaderBuffer>,
    /// Colours, widths, specular lobes, child placement and counts.
    #[uniform(1)]
    pub uniform: HairUniform,
}

/// The uniform block of `hair.wgsl`, field for field.
#[derive(ShaderType, Clone, Copy, Debug, Default, PartialEq)]
pub struct HairUniform {
    /// Linear colour at the root.
    pub root_color: Vec4,
    /// Linear colour at the tip.
    pub tip_color: Vec4,
    /// Primary (shifted toward the tip, light-coloured) specular colour.
    pub primary_color: Vec4,
    /// Secondary (shifted toward the root, hair-tinted) specular colour.
    pub secondary_color: Vec4,
    /// Primary exponent, primary shift, secondary exponent, secondary shift.
    pub specular: Vec4,
    /// Spiral a, b, angle step (radians), scale (metres per unit).
    pub spiral: Vec4,
    /// Clumping, tip spread (m), root width (m), tip width (m).
    pub shape: Vec4,
    /// Tint variation, receive shadows (0 or 1), diffuse strength, unused.
    pub shading: Vec4,
    /// Guides, particles per guide, rendered strands per guide, subdivisions.
    pub counts: UVec4,
}

impl Material for HairMaterial {
    fn vertex_shader() -> ShaderRef {
        SHADER_PATH.into()
    }

    fn fragment_shader() -> ShaderRef {
        SHADER_PATH.into()
    }

    // The same shader has a depth-only variant for the shadow pass, so hair casts shadows
    // (on the head and on itself). It stays out of the camera's prepasses, which would
    // need normals and motion vectors it does not compute.
    fn prepass_vertex_shader() -> ShaderRef {
        SHADER_PATH.into()
    }

    fn prepass_fragment_shader() -> ShaderRef {
        SHADER_PATH.into()
    }

    fn enable_prepass() -> bool {
        false
    }

    fn specialize(
        _pipeline: &MaterialPipeline,
        descriptor: &mut RenderPipelineDescriptor,
        layout: &MeshVertexBufferLayoutRef,
        _key: MaterialPipelineKey<Self>,
    ) -> Result<(), SpecializedMeshPipelineError> {
        descriptor.vertex.buffers = vec![layout.0.get_layout(&[ATTRIBUTE_HAIR_VERTEX.at_shader_location(0)])?];
        // Ribbons are seen from both sides.
        descriptor.primitive.cull_mode = None;
        Ok(())
    }
}
