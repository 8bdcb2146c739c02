//! The strand material: guide particles and their frames in one storage buffer, what the
//! CPU adds (the scalp, the draw order, opacity maps) in another, the look in a uniform,
//! and `hair.wgsl` for both stages.

use super::layout::{ATTRIBUTE_HAIR_VERTEX, StrandLayout};
use bevy::asset::io::AssetSourceId;
use bevy::asset::{AssetPath, embedded_path};
use bevy::mesh::MeshVertexBufferLayoutRef;
use bevy::pbr::{MaterialPipeline, MaterialPipelineKey};
use bevy::prelude::*;
use bevy::render::render_resource::{AsBindGroup, RenderPipelineDescriptor, ShaderType, SpecializedMeshPipelineError};
use bevy::render::storage::ShaderBuffer;
use bevy::shader::ShaderRef;

/// Where the hair shader lives: `hair.wgsl` beside this file, embedded in the binary by
/// [`HairRenderPlugin`](super::HairRenderPlugin) (`embedded://bevy_hair/render/hair.wgsl`).
pub fn shader_path() -> AssetPath<'static> {
    AssetPath::from_path_buf(embedded_path!("hair.wgsl")).with_source(AssetSourceId::from("embedded"))
}

/// The material of a drawn groom. The plugin creates and updates it from the groom's
/// [`HairLook`](super::HairLook) and layout; users edit the look, not this.
/// `tests/render/drawing.rs` makes one by hand to draw chosen strands.
#[derive(Asset, TypePath, AsBindGroup, Clone, Debug)]
pub struct HairMaterial {
    /// Per guide the scalp's normal and curvature at its root, then the head's centre, the
    /// order the strands' pieces are drawn in and the deep opacity maps; rewritten every
    /// frame at the same size.
    #[storage(0, read_only)]
    pub guides: Handle<ShaderBuffer>,
    /// Colours, widths, specular lobes, child placement and counts.
    #[uniform(1)]
    pub uniform: HairUniform,
    /// Guide particle positions (one `vec4` each, strand-major), then each particle's
    /// transport frame vector `u` (same order, `w` = 0): written every frame from the CPU,
    /// or on the GPU for a groom the GPU steps (`hair_gpu::GpuDrawing`).
    #[storage(2, read_only)]
    pub particles: Handle<ShaderBuffer>,
}

/// The uniform block of `strand.wgsl` (`bevy_hair::strand::HairUniform`), field for field.
/// `tests/render/drawing.rs` fills one by hand to draw chosen strands.
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
    /// Primary lobe exponent (≥ 1).
    pub primary_exponent: f32,
    /// Primary lobe shift along the normal, −1..1.
    pub primary_shift: f32,
    /// Secondary lobe exponent (≥ 1).
    pub secondary_exponent: f32,
    /// Secondary lobe shift along the normal, −1..1.
    pub secondary_shift: f32,
    /// Spiral radius at θ = 0, spiral units.
    pub spiral_a: f32,
    /// Spiral radius gained per radian, spiral units.
    pub spiral_b: f32,
    /// Angle between consecutive children, radians.
    pub spiral_angle_step: f32,
    /// Metres per spiral unit.
    pub spiral_scale: f32,
    /// How far children are drawn toward the guide at the tip, 0..1.
    pub clumping: f32,
    /// How far a child's tip strays, metres.
    pub tip_spread: f32,
    /// Ribbon width at the root, metres.
    pub root_width: f32,
    /// Ribbon width at the tip, metres.
    pub tip_width: f32,
    /// Per-strand brightness variation, 0..1.
    pub tint_variation: f32,
    /// Diffuse strength.
    pub diffuse: f32,
    /// [`Self::RECEIVE_SHADOWS`], [`Self::MARSCHNER`], [`Self::ANTIALIAS`],
    /// [`Self::BLENDED`].
    pub flags: u32,
    /// Guides drawn.
    pub guides: u32,
    /// Particles per guide.
    pub particles: u32,
    /// Rendered strands per guide: the guide and its children.
    pub strands_per_guide: u32,
    /// Curve points per guide segment.
    pub subdivisions: u32,
    /// Marschner's longitudinal roughness (with [`Self::MARSCHNER`]).
    pub roughness: f32,
    /// Marschner's cuticle tilt, radians (with [`Self::MARSCHNER`]).
    pub cuticle_tilt: f32,
    /// Light stopped per layer of fibres toward a light with an opacity map (0: none).
    pub self_shadow: f32,
}

impl HairUniform {
    /// Flag: the strands are darkened by the shadow maps of the lights that cast them
    /// (directional, point and spot).
    pub const RECEIVE_SHADOWS: u32 = 1;
    /// Flag: shade with Marschner's three lobes instead of Kajiya-Kay highlights.
    pub const MARSCHNER: u32 = 2;
    /// Flag: with MSAA, draw strands thinner than a pixel a pixel wide, covering their true
    /// share of its samples.
    pub const ANTIALIAS: u32 = 4;
    /// Flag: blend the strands over what is behind them (Bevy's transparent pass), those
    /// thinner than two pixels drawn two pixels wide with their coverage as opacity. The
    /// guide buffer's draw order should then be back to front.
    pub const BLENDED: u32 = 8;

    /// The same uniform drawing `layout` (its guide, particle, strand and subdivision counts).
    pub fn with_layout(self, layout: &StrandLayout) -> Self {
        HairUniform {
            guides: layout.guides,
            particles: layout.particles,
            strands_per_guide: layout.strands_per_guide,
            subdivisions: layout.subdivisions,
            ..self
        }
    }
}

impl Material for HairMaterial {
    fn alpha_mode(&self) -> AlphaMode {
        if self.uniform.flags & HairUniform::BLENDED != 0 { AlphaMode::Blend } else { AlphaMode::Opaque }
    }

    fn vertex_shader() -> ShaderRef {
        shader_path().into()
    }

    fn fragment_shader() -> ShaderRef {
        shader_path().into()
    }

    // The same shader has a depth-only variant for the shadow pass, so hair casts shadows
    // (on the head and on itself). It stays out of the camera's prepasses, which would
    // need normals and motion vectors it does not compute.
    fn prepass_vertex_shader() -> ShaderRef {
        shader_path().into()
    }

    fn prepass_fragment_shader() -> ShaderRef {
        shader_path().into()
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
