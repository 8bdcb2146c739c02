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
//! The plugin grows guide strands on the painted scalp (on a background task). Then, in
//! `PostUpdate` after animation and transform propagation, the hair clock (`Time<Hair>`,
//! [`HairTime`]) runs as many hair steps ([`HairSchedule`]) as the frame's time holds, at
//! the plugin's own timestep ([`HairPlugin::timestep`], 60 Hz by default; the app's
//! `Time<Fixed>` is left alone). Each step moves the roots with the head pose interpolated
//! between the last two frames over that step's own interval, steps the solver of the
//! `hair_sim` crate in parallel, and keeps the positions in head space in [`HairState`].
//! Drawing interpolates between the last two steps in head space and places the result on
//! the head as posed in the frame, so the roots sit on the drawn scalp at any frame rate.
//!
//! A head with [`HairLod`] simulates fewer of its guides while it is small on screen (the
//! others follow their simulated neighbours), so a crowd costs little more than its
//! nearest heads.
//!
//! A head that is a skinned mesh (`SkinnedMesh`) follows the joint that carries its scalp
//! ([`ScalpJoint`]). Hair is drawn by a child of the head, so it shares the head's
//! visibility and lifetime; [`HairCollider`]s in a character's hierarchy touch only that
//! character's hair.
//!
//! Errors a user can cause — a head without a mesh, an empty mesh, no painted scalp,
//! NaN settings — never panic: they arrive as [`HairError`] messages, a `warn!`, and a
//! [`GroomStatus::Failed`] on the head, and the groom stays inert.
//!
//! # Contents
//!
//! | to | see |
//! |---|---|
//! | describe a groom | [`HairGroom`], [`ScalpSource`], [`ChildParams`], [`HairPreset`] |
//! | tune how it moves | [`HairSettings`], [`HairSettingsOverride`], [`SimParams`], [`HairTime`] |
//! | choose where it steps | [`HairBackend`], [`HairLod`] |
//! | tune how it looks (feature `render`) | [`HairLook`], [`HairShading`], [`HairAntialias`] |
//! | read what it did | [`HairState`], [`StepReport`], [`HairDiagnostics`], [`HairError`] |
//! | collide with more | [`HairCollider`] |
//! | order systems against it | [`HairSystems`], [`HairSchedule`], `HairRenderSystems` (feature `render`) |
//! | save and load grooms | [`HairAsset`], [`HairState::to_hair_file`] |
//!
//! The repository's `docs/` holds the longer chapters (simulation, collision, rendering,
//! the GPU solver, benchmarks, testing).
//!
//! # Cargo features
//!
//! | feature | default | what |
//! |---|---|---|
//! | `render` | yes | drawing (the strand material, Bevy's lights and shadows) and the GPU solver ([`HairBackend::Gpu`]); without it the plugin grows and simulates only |
//!
//! # FAQ
//!
//! **Why optimise dependencies in dev builds?** The solver steps thousands of strands every
//! 1/60 s; unoptimised, a frame's hair takes several times as long. Add
//! `[profile.dev.package."*"] opt-level = 3` to your `Cargo.toml`.
//!
//! **CPU or GPU?** [`HairBackend::Cpu`] is the default and steps on Bevy's compute task
//! pool, with levels of detail. [`HairBackend::Gpu`] steps in Bevy's render world: the main
//! thread only writes each step down, and the groom's positions come back a few steps late
//! ([`HairState::gpu_lag`]). Without a renderer it falls back to the CPU and says so once.
//!
//! **What does it need on a small machine?** Two cores step a groom of a couple of thousand
//! guides × 16 in a few milliseconds; [`HairLod`] keeps a crowd's far heads cheap.
//!
//! **How do I read [`HairDiagnostics`]?** Add Bevy's diagnostics plugins and read the paths
//! from `DiagnosticsStore`: `hair/step_ms` is the solver's time per step, `hair/upload_ms`
//! the frame's drawing work on the main thread, `hair/gpu_step_ms` a GPU step on the GPU
//! (`hair/gpu_volume_ms` its hair volume's grid), `hair/extract_ms` and `hair/render_ms`
//! the hair's share of the render world.

#![warn(missing_docs)]

mod clock;
mod colliders;
mod convert;
mod description;
mod detail;
mod diagnostics;
mod gpu;
mod groom;
mod hair_asset;
mod head_mesh;
mod preset;
#[cfg(feature = "render")]
pub mod render;
mod settings;
mod simulation;
mod skinning;

pub use clock::{Hair, HairSchedule, HairTime};
pub use colliders::HairCollider;
pub use description::{
    GroomStatus, HairError, HairErrorKind, HairGroom, RootDistribution, ScalpPredicate, ScalpSource,
};
pub use detail::HairLod;
pub use diagnostics::HairDiagnostics;
#[cfg(feature = "render")]
pub use gpu::HairReadback;
pub use hair_asset::{HairAsset, HairAssetError, HairAssetLoader};
#[cfg(feature = "render")]
pub use hair_gpu;
pub use hair_sim;
pub use hair_sim::groom::{ChildParams, Spiral};
pub use hair_sim::solver::{CollisionResponse, LengthMode, SimParams, SimdPath, StepReport, Volume, Wind};
pub use head_mesh::{ATTRIBUTE_SCALP, is_procedural_scalp, procedural_head_mesh};
pub use preset::{HairPreset, PresetError};
#[cfg(feature = "render")]
pub use render::{HairAntialias, HairLook, HairRenderStats, HairRenderSystems, HairShading, SpecularLobe};
pub use settings::{HairBackend, HairSettings, HairSettingsOverride};
pub use simulation::{HairState, step_on_pool};
pub use skinning::ScalpJoint;

use bevy::diagnostic::{Diagnostic, RegisterDiagnostic};
use bevy::ecs::schedule::SingleThreadedExecutor;
use bevy::prelude::*;
use bevy::transform::TransformSystems;
use std::time::Duration;

/// Everything needed to add hair to an app.
pub mod prelude {
    pub use crate::{
        ChildParams, CollisionResponse, GroomStatus, Hair, HairBackend, HairCollider, HairDiagnostics, HairError,
        HairErrorKind, HairGroom, HairLod, HairPlugin, HairPreset, HairSchedule, HairSettings, HairSettingsOverride,
        HairState, HairSystems, HairTime, LengthMode, RootDistribution, ScalpPredicate, ScalpSource, SimParams,
        SimdPath, Spiral, StepReport, Volume, Wind,
    };
    #[cfg(feature = "render")]
    pub use crate::{
        HairAntialias, HairLook, HairReadback, HairRenderStats, HairRenderSystems, HairShading, SpecularLobe,
    };
}

/// Adds hair growth and simulation, and drawing (feature `render`) when the app renders.
/// Needs `TransformPlugin`, an asset plugin with `Assets<Mesh>` (`MeshPlugin`) and a task
/// pool: `DefaultPlugins` has them all, and so do `MinimalPlugins` + `TransformPlugin` +
/// `AssetPlugin` + `MeshPlugin` for headless apps. Add it after `DefaultPlugins`: it draws
/// only if Bevy's `RenderPlugin` is already there.
///
/// ```no_run
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// App::new().add_plugins((DefaultPlugins, HairPlugin::from_hz(90.0))).run();
/// ```
#[derive(Clone, Debug)]
pub struct HairPlugin {
    /// The length of one hair step (60 Hz by default). Hair keeps a clock of its own,
    /// `Time<Hair>` ([`HairTime`]), so this never changes the app's `Time<Fixed>`; change
    /// it at run time with [`HairTime::set_timestep`].
    pub timestep: Duration,
}

impl Default for HairPlugin {
    fn default() -> Self {
        HairPlugin { timestep: Hair::DEFAULT_TIMESTEP }
    }
}

impl HairPlugin {
    /// Hair steps `hz` times per second of virtual time (60 if `hz` is not a positive,
    /// finite rate of at most 1,000).
    pub fn from_hz(hz: f64) -> Self {
        HairPlugin { timestep: Hair::timestep_of_hz(hz).unwrap_or(Hair::DEFAULT_TIMESTEP) }
    }
}

/// The hair systems, in order. In `PostUpdate`, after transform propagation:
/// [`Grow`](HairSystems::Grow) → [`Step`](HairSystems::Step) → [`Draw`](HairSystems::Draw).
/// In [`HairSchedule`], once per hair step, chained: [`SyncRoots`](HairSystems::SyncRoots)
/// → [`Simulate`](HairSystems::Simulate) → [`Writeback`](HairSystems::Writeback).
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// # fn react_to_hair() {}
/// # let mut app = App::new();
/// // A system that reads what this frame's steps left, before the drawing reads it too.
/// app.add_systems(PostUpdate, react_to_hair.after(HairSystems::Step).before(HairSystems::Draw));
/// ```
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum HairSystems {
    /// Starts and collects background growth of new or changed grooms.
    Grow,
    /// Chooses each groom's level of detail ([`HairLod`]), advances the hair clock,
    /// records each head's pose of the frame, and runs [`HairSchedule`] once per whole
    /// hair step.
    Step,
    /// Moves the roots to the head pose at the end of the step.
    SyncRoots,
    /// Steps the solver.
    Simulate,
    /// Publishes the new positions (the last two steps', in head space, for drawing).
    Writeback,
    /// Uploads interpolated guide positions for drawing (feature `render`).
    Draw,
}

impl Plugin for HairPlugin {
    fn build(&self, app: &mut App) {
        // A timestep below the minimum is refused with a warning and the default stays.
        let mut clock = Time::<Hair>::default();
        clock.set_timestep(self.timestep);
        app.insert_resource(clock);
        app.init_schedule(HairSchedule);
        // Its systems form one chain, and the solver spreads itself over the compute pool:
        // a multi-threaded executor would only hand each system to another thread (and wake
        // it) in turn.
        app.edit_schedule(HairSchedule, |schedule| {
            schedule.set_executor(SingleThreadedExecutor::new());
        });
        app.register_type::<Hair>()
            .register_type::<HairPreset>()
            .register_type::<HairLod>()
            .configure_sets(
                PostUpdate,
                (HairSystems::Grow, HairSystems::Step, HairSystems::Draw).chain().after(TransformSystems::Propagate),
            )
            .add_systems(
                PostUpdate,
                (detail::choose_detail_levels, clock::advance_clock, clock::run_hair_schedule)
                    .chain()
                    .in_set(HairSystems::Step),
            )
            .add_plugins((groom::GroomPlugin, simulation::SimulationPlugin));
        for path in HairDiagnostics::ALL {
            app.register_diagnostic(Diagnostic::new(path));
        }
        #[cfg(feature = "render")]
        if app.is_plugin_added::<bevy::render::RenderPlugin>() {
            app.add_plugins(render::HairRenderPlugin);
        }
    }
}
