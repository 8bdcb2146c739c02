//! Simulation settings as Bevy sees them: a global resource and a per-groom override.

use bevy::prelude::*;
use hair_sim::solver::SimParams;

/// Simulation settings for every groom without a [`HairSettingsOverride`].
///
/// A thin `Reflect` wrapper around [`SimParams`], so inspectors and UIs can edit it.
/// Bad values (NaN, negative stiffness…) never reach the solver: they are replaced, and a
/// [`HairError`](crate::HairError) names each one.
#[derive(Resource, Reflect, Clone, Debug, Default, PartialEq, Deref, DerefMut)]
#[reflect(Resource, Default)]
pub struct HairSettings(pub SimParams);

/// Per-groom settings: put it on the head entity to override [`HairSettings`].
#[derive(Component, Reflect, Clone, Debug, Default, PartialEq, Deref, DerefMut)]
#[reflect(Component, Default)]
pub struct HairSettingsOverride(pub SimParams);

/// The settings that apply to a groom: its override, or the global ones.
pub(crate) fn effective<'a>(global: &'a HairSettings, local: Option<&'a HairSettingsOverride>) -> &'a SimParams {
    local.map_or(&global.0, |o| &o.0)
}
