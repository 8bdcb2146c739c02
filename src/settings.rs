//! Simulation settings as Bevy sees them: a global resource and a per-groom override.

use bevy::prelude::*;
use hair_sim::solver::SimParams;

/// Simulation settings for every groom without a [`HairSettingsOverride`].
///
/// A thin `Reflect` wrapper around [`SimParams`], so inspectors and UIs can edit it.
/// Bad values (NaN, negative stiffness…) never reach the solver: they are replaced, and a
/// [`HairError`](crate::HairError) names each one.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// # let mut app = App::new();
/// // Every groom: four substeps, a little wind.
/// let mut params = SimParams { substeps: 4, ..default() };
/// params.wind.strength = 0.5;
/// app.insert_resource(HairSettings(params));
/// ```
#[derive(Resource, Reflect, Clone, Debug, Default, PartialEq, Deref, DerefMut)]
#[reflect(Resource, Default)]
pub struct HairSettings(pub SimParams);

/// Per-groom settings: put it on the head entity to override [`HairSettings`].
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// // This head's hair on the reference's springs, whatever the global settings say.
/// fn springy(mut commands: Commands, heads: Query<Entity, Added<HairGroom>>) {
///     for head in &heads {
///         let params = SimParams { length_mode: LengthMode::Springs, ..default() };
///         commands.entity(head).insert(HairSettingsOverride(params));
///     }
/// }
/// ```
#[derive(Component, Reflect, Clone, Debug, Default, PartialEq, Deref, DerefMut)]
#[reflect(Component, Default)]
pub struct HairSettingsOverride(pub SimParams);

/// Which solver steps a groom: put it on the head entity (without it, the CPU).
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// fn on_the_gpu(mut commands: Commands, heads: Query<Entity, Added<HairGroom>>) {
///     for head in &heads {
///         commands.entity(head).insert(HairBackend::Gpu);
///     }
/// }
/// ```
///
/// `examples/gpu_backend.rs` runs it.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Component, Default, PartialEq)]
pub enum HairBackend {
    /// `hair_sim`'s solver on Bevy's [`ComputeTaskPool`](bevy::tasks::ComputeTaskPool): the
    /// reference, with every feature.
    #[default]
    Cpu,
    /// `hair_gpu`'s compute passes on the app's render device (feature `render`), recorded
    /// in Bevy's render world: the same model, colliding as the CPU does (the collider's
    /// exact query near the head, on the same candidate lists; the distance grid far from
    /// it and deep inside, where the CPU walks its BVH). The main thread only writes down
    /// each step's input; the render world records the frame's steps, then a pass that
    /// writes the particles, interpolated and placed on the drawn head, with their frames,
    /// into the drawing's buffer, and nothing waits for the GPU. Until the GPU's pipelines
    /// have compiled (on a background task) the CPU steps the groom, then hands it over.
    /// The groom's [`HairState`] positions are copies that come back without waiting, a
    /// frame or two late ([`HairState::gpu_lag`]); what the CPU computes from them (the
    /// blending choice, the blended draw order, self-shadow maps, `.hair` files) is as
    /// late. [`HairState::last_report`] comes back the same way.
    /// Every guide is simulated (levels of detail do not apply).
    /// Where the GPU cannot step the groom (no render device, an adapter without compute),
    /// it steps on the CPU and a
    /// [`HairError`](crate::HairError) says why, once.
    ///
    /// [`HairState`]: crate::HairState
    /// [`HairState::gpu_lag`]: crate::HairState::gpu_lag
    /// [`HairState::last_report`]: crate::HairState::last_report
    Gpu,
}

/// The settings that apply to a groom: its override, or the global ones.
pub(crate) fn effective<'a>(global: &'a HairSettings, local: Option<&'a HairSettingsOverride>) -> &'a SimParams {
    local.map_or(&global.0, |o| &o.0)
}
