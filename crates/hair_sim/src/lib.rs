//! Engine-free strand hair: growth, simulation and head-mesh collision.
//!
//! This crate knows nothing about Bevy; `bevy_hair` drives it. It builds in about a
//! minute, so everything algorithmic lives here, with its tests.
//!
//! ```
//! use hair_sim::prelude::*;
//!
//! let head = test_head(3); // a closed ellipsoid head with ears
//! let collider = HeadCollider::new(&head, 32).unwrap();
//! let crown: Vec<f32> = head.triangles.iter()
//!     .map(|t| if head.corners(t).iter().all(|p| p.y > 0.05) { 1.0 } else { 0.0 })
//!     .collect();
//! let roots = sample_roots(&head, &crown, 100, 1).unwrap();
//! let guides = grow_guides(&head, &roots, &GuideParams::default(), 1).unwrap();
//! let mut strands = Strands::new(RestShape::new(guides, 11).unwrap(), Pose::IDENTITY);
//! let params = SimParams::default();
//! for k in 0..60 {
//!     strands.step(&StepInput {
//!         dt: 1.0 / 60.0,
//!         time: k as f32 / 60.0,
//!         head_from: Pose::IDENTITY,
//!         head_to: Pose::IDENTITY,
//!         collider: Some(&collider),
//!         extra_colliders: &[],
//!         surface_patch: None,
//!         params: &params,
//!     });
//! }
//! assert!(strands.max_stretch() < 1e-3);
//! ```
//!
//! Layout: [`mesh`] (the head and its validation), [`groom`] (roots, guides, child
//! strands and Bézier tessellation),
//! [`solver`] (state, settings, the step), [`collide`] (BVH + distance grid, spheres,
//! capsules), [`shadow`] (how much hair lies between a point and a light), [`draw_order`]
//! (blended strands back to front). All public vectors are glam 0.33 ([`math`]), the version parry3d uses.

#![warn(missing_docs)]

pub mod collide;
pub mod draw_order;
pub mod groom;
pub mod math;
pub mod mesh;
mod parallel;
pub mod shadow;
pub mod solver;

/// The types most users need.
pub mod prelude {
    pub use crate::collide::{DEFAULT_GRID_RESOLUTION, ExtraCollider, HeadCollider};
    pub use crate::groom::{
        ChildParams, ChildRoot, CurvePoint, GroomError, GuideParams, HairFile, RootBinding, Spiral, child_curve,
        child_curves, grow_guides, sample_roots, sample_roots_at_vertices, sample_roots_poisson, settle, tessellate,
        transport_frames,
    };
    pub use crate::math::{Pose, Quat, Vec3};
    pub use crate::mesh::{HeadMesh, MeshError, test_head, test_scalp};
    pub use crate::solver::{
        CollisionResponse, LengthMode, RestShape, SimParams, SimdPath, StepInput, StepReport, Strands, Volume, Wind,
    };
}
