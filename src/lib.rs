//! Strand hair for Bevy: grown from a painted scalp, simulated at a fixed timestep with
//! head-mesh collision, following the head as it moves.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use bevy_hair::prelude::*;
//!
//! fn setup(mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>) {
//!     // Any head mesh whose scalp is painted black in its vertex colours.
//!     let head = meshes.add(bevy_hair::procedural_head_mesh(4));
//!     commands.spawn((Mesh3d(head), Transform::default(), HairGroom::default()));
//! }
//! # fn main() {
//! App::new().add_plugins((DefaultPlugins, HairPlugin::default())).add_systems(Startup, setup).run();
//! # }
//! ```
//!
//! The plugin grows guide strands on the painted scalp (on a background task), then each
//! fixed step ([`HairSystems`], in `FixedPostUpdate` by default) moves the roots with the
//! head, steps the solver of the `hair_sim` crate in parallel, and keeps the last two
//! steps' positions in [`HairState`] for drawing.
//!
//! The head pose a step sees is the head's [`GlobalTransform`] at the start of the frame:
//! animation runs in `PostUpdate`, after the fixed steps, so hair lags the head by one
//! frame. Within a step the roots follow the pose interpolated across substeps.
//!
//! Errors a user can cause — a head without a mesh, an empty mesh, no painted scalp,
//! NaN settings — never panic: they arrive as [`HairError`] messages, a `warn!`, and a
//! [`GroomStatus::Failed`] on the head, and the groom stays inert.

#![warn(missing_docs)]

mod colliders;
mod convert;
mod diagnostics;
mod groom;
mod head_mesh;
#[cfg(feature = "render")]
pub mod render;
mod settings;
mod simulation;

pub use colliders::HairCollider;
pub use diagnostics::HairDiagnostics;
pub use groom::{GroomStatus, HairGroom, RootDistribution, ScalpPredicate, ScalpSource};
pub use hair_sim;
pub use hair_sim::groom::{ChildParams, Spiral};
pub use hair_sim::solver::{LengthMode, SimParams, StepReport, Wind};
pub use head_mesh::{ATTRIBUTE_SCALP, is_procedural_scalp, procedural_head_mesh};
#[cfg(feature = "render")]
pub use render::{HairLook, HairRenderStats, SpecularLobe};
pub use settings::{HairSettings, HairSettingsOverride};
pub use simulation::HairState;

use bevy::app::FixedPostUpdate;
use bevy::diagnostic::{Diagnostic, RegisterDiagnostic};
use bevy::ecs::intern::Interned;
use bevy::ecs::schedule::ScheduleLabel;
use bevy::prelude::*;
use bevy::transform::TransformSystems;
use std::time::Duration;

/// Everything needed to add hair to an app.
pub mod prelude {
    pub use crate::{
        ChildParams, GroomStatus, HairCollider, HairDiagnostics, HairError, HairGroom, HairPlugin, HairSettings,
        HairSettingsOverride, HairState, HairSystems, LengthMode, RootDistribution, ScalpPredicate, ScalpSource,
        SimParams, Spiral, Wind,
    };
    #[cfg(feature = "render")]
    pub use crate::{HairLook, HairRenderStats, SpecularLobe};
}

/// Adds hair growth and simulation, and drawing (feature `render`) when the app renders.
/// Needs `TransformPlugin`, an asset plugin with `Assets<Mesh>` (`MeshPlugin`) and a task
/// pool: `DefaultPlugins` has them all, and so do `MinimalPlugins` + `TransformPlugin` +
/// `AssetPlugin` + `MeshPlugin` for headless apps. Add it after `DefaultPlugins`: it draws
/// only if Bevy's `RenderPlugin` is already there.
pub struct HairPlugin {
    /// The schedule the simulation steps in: `FixedPostUpdate` by default.
    pub schedule: Interned<dyn ScheduleLabel>,
}

impl Default for HairPlugin {
    fn default() -> Self {
        HairPlugin { schedule: FixedPostUpdate.intern() }
    }
}

impl HairPlugin {
    /// Simulate in `schedule` instead of `FixedPostUpdate`.
    pub fn new(schedule: impl ScheduleLabel) -> Self {
        HairPlugin { schedule: schedule.intern() }
    }
}

/// The hair systems, in order. In the simulation schedule, chained:
/// [`SyncRoots`](HairSystems::SyncRoots) → [`Simulate`](HairSystems::Simulate) →
/// [`Writeback`](HairSystems::Writeback). [`Grow`](HairSystems::Grow) runs in `PostUpdate`
/// after transform propagation.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum HairSystems {
    /// Starts and collects background growth of new or changed grooms.
    Grow,
    /// Reads each head's pose for this step.
    SyncRoots,
    /// Steps the solver.
    Simulate,
    /// Publishes the new positions (previous and current, for interpolation).
    Writeback,
    /// Uploads interpolated guide positions for drawing (`PostUpdate`, after `Grow`;
    /// feature `render`).
    Draw,
}

/// Something is wrong with a groom: its head, its mesh, its description or its settings.
/// The groom stays inert (or runs with the bad settings replaced) until it is fixed.
#[derive(Message, Clone, Debug, PartialEq)]
pub struct HairError {
    /// The head entity whose groom has the problem.
    pub entity: Entity,
    /// What is wrong, in words.
    pub reason: String,
}

impl std::fmt::Display for HairError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "hair on {}: {}", self.entity, self.reason)
    }
}

/// Bevy's default fixed timestep (64 Hz): replaced by 60 Hz unless the app chose another.
const BEVY_DEFAULT_TIMESTEP: Duration = Duration::from_micros(15625);

impl Plugin for HairPlugin {
    fn build(&self, app: &mut App) {
        match app.world_mut().get_resource_mut::<Time<Fixed>>() {
            Some(mut fixed) if fixed.timestep() == BEVY_DEFAULT_TIMESTEP => fixed.set_timestep_hz(60.0),
            Some(_) => {}
            None => {
                app.insert_resource(Time::<Fixed>::from_hz(60.0));
            }
        }
        app.init_resource::<HairSettings>()
            .register_type::<HairSettings>()
            .register_type::<HairSettingsOverride>()
            .register_type::<HairGroom>()
            .register_type::<HairCollider>()
            .add_message::<HairError>()
            .configure_sets(
                self.schedule,
                (HairSystems::SyncRoots, HairSystems::Simulate, HairSystems::Writeback).chain(),
            )
            .add_systems(
                self.schedule,
                (
                    simulation::sync_roots.in_set(HairSystems::SyncRoots),
                    simulation::simulate.in_set(HairSystems::Simulate),
                    simulation::writeback.in_set(HairSystems::Writeback),
                ),
            )
            .add_systems(
                PostUpdate,
                (groom::request_growth, groom::start_growth, groom::finish_growth)
                    .chain()
                    .in_set(HairSystems::Grow)
                    .after(TransformSystems::Propagate),
            );
        for path in HairDiagnostics::ALL {
            app.register_diagnostic(Diagnostic::new(path));
        }
        #[cfg(feature = "render")]
        if app.is_plugin_added::<bevy::render::RenderPlugin>() {
            app.add_plugins(render::HairRenderPlugin);
        }
    }
}
