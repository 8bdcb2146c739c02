//! The letters between the worlds: what the main world asks of a groom's GPU strands
//! ([`GpuCommand`]) and what the render world posts back ([`Inbox`]).

use bevy::asset::AssetId;
use bevy::render::storage::ShaderBuffer;
use hair_sim::collide::{ExtraCollider, HeadCollider, SurfacePatch};
use hair_sim::math::{Pose, Vec3 as SimVec3};
use hair_sim::shadow::{Fibres, LightSource};
use hair_sim::solver::{RestShape, SimParams, StepInput, StepReport, VolumeState};
use std::sync::{Arc, Mutex};

/// What the main world asks of a groom's GPU strands, recorded in the render world in the
/// order written.
pub(crate) enum GpuCommand {
    /// Make the strands: `rest` placed at rest under `pose`, colliding with `collider`;
    /// the render world posts to `inbox`.
    Start { rest: RestShape, pose: Pose, collider: Arc<HeadCollider>, inbox: Arc<Mutex<Inbox>> },
    /// Carry on from the CPU's strands: their positions and velocities, their rest roots,
    /// the pose they were stepped to (nothing drawn between before and after), and where
    /// volume is on what their hair–hair grid carries from step to step.
    TakeOver {
        positions: Vec<SimVec3>,
        velocities: Vec<SimVec3>,
        roots: Vec<SimVec3>,
        pose: Pose,
        volume: Option<VolumeState>,
    },
    /// One step, then its positions kept for drawing.
    Step(Box<OwnedStep>),
    /// The solver's origin moved: every particle by this.
    Translate(SimVec3),
    /// Every strand's root in the rest shape (a skinned scalp).
    SetRestRoots(Vec<SimVec3>),
    /// Every strand back at rest under this pose.
    Reset(Pose),
    /// Copy the report back, and the positions if `positions`, as copy number `copy`.
    CopyBack { copy: u64, positions: bool },
    /// The frame's drawing into `target` ([`hair_gpu::GpuDrawing`]), then the opacity maps
    /// of what it drew, if asked for.
    Draw {
        target: AssetId<ShaderBuffer>,
        root_u: Arc<[SimVec3]>,
        overstep: f32,
        pose: Pose,
        shadows: Option<ShadowMaps>,
        order: Option<SortedOrder>,
    },
}

/// The deep opacity maps of a frame's drawing ([`hair_gpu::GpuOpacityMap`]), one per
/// light, written into the drawing's guide buffer where the hair shader reads them.
pub(crate) struct ShadowMaps {
    /// The guide buffer.
    pub guides: AssetId<ShaderBuffer>,
    /// Where the first map starts in it, and from one map to the next, in floats.
    pub first: u32,
    pub stride: u32,
    pub lights: Vec<LightSource>,
    pub fibres: Fibres,
}

/// The blended pieces' order of a frame's drawing ([`hair_gpu::GpuDrawOrder`]), back to
/// front from the eye, written into the drawing's guide buffer where the hair shader
/// reads it.
pub(crate) struct SortedOrder {
    /// The guide buffer.
    pub guides: AssetId<ShaderBuffer>,
    /// Where the order starts in it, in floats.
    pub first: u32,
    pub eye: SimVec3,
    pub segments_per_piece: u32,
}

/// A step's input, owned, to travel to the render world (the collider went with
/// [`GpuCommand::Start`]).
pub(crate) struct OwnedStep {
    dt: f32,
    time: f32,
    head_from: Pose,
    head_to: Pose,
    extra_colliders: Vec<ExtraCollider>,
    surface_patch: Option<SurfacePatch>,
    params: SimParams,
}

impl OwnedStep {
    pub fn new(input: &StepInput) -> Self {
        OwnedStep {
            dt: input.dt,
            time: input.time,
            head_from: input.head_from,
            head_to: input.head_to,
            extra_colliders: input.extra_colliders.to_vec(),
            surface_patch: input.surface_patch.cloned(),
            params: *input.params,
        }
    }

    /// The step's input, colliding with `collider`.
    pub fn input<'a>(&'a self, collider: &'a HeadCollider) -> StepInput<'a> {
        StepInput {
            dt: self.dt,
            time: self.time,
            head_from: self.head_from,
            head_to: self.head_to,
            collider: Some(collider),
            extra_colliders: &self.extra_colliders,
            surface_patch: self.surface_patch.as_ref(),
            params: &self.params,
        }
    }
}

/// What the render world posts to a groom's main-world side.
#[derive(Default)]
pub(crate) struct Inbox {
    /// The strands are made: the groom can move over.
    pub ready: bool,
    /// Why the GPU cannot step the groom (it steps on the CPU from here).
    pub failed: Option<String>,
    /// Copies back that arrived, oldest first.
    pub copies: Vec<Copied>,
}

/// A copy back that arrived.
pub(crate) struct Copied {
    /// Its number ([`GpuCommand::CopyBack`]).
    pub copy: u64,
    /// The positions, if they were asked for.
    pub positions: Option<Vec<SimVec3>>,
    /// What the steps since the last copy did.
    pub report: StepReport,
    /// The GPU time of the last of them, where the device times passes.
    pub time: Option<hair_gpu::StepTime>,
}
