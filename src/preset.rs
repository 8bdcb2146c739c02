//! Presets: what a groom grows, how it is drawn and how it moves, saved as text and loaded
//! back.

use crate::HairGroom;
#[cfg(feature = "render")]
use crate::HairLook;
use bevy::prelude::*;
use bevy::reflect::serde::{TypedReflectDeserializer, TypedReflectSerializer};
use bevy::reflect::{FromReflect, TypeRegistry};
use hair_sim::solver::SimParams;
use serde::de::DeserializeSeed;

/// A groom's [`HairGroom`], [`HairLook`] (feature `render`) and simulation settings
/// ([`SimParams`], as in [`HairSettings`](crate::HairSettings) or
/// [`HairSettingsOverride`](crate::HairSettingsOverride)) as one value that saves as RON
/// and loads back: a look tuned in the demo's panel, kept for a game.
///
/// It goes through Bevy's reflection, as scenes do, so it needs no serialisation feature
/// of Bevy's (the engine-free [`hair_sim`] settings also have a `serde` feature). A preset
/// does not carry [`HairGroom::guides_from`]: an asset handle is not text; set it again
/// after loading.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::{HairPlugin, HairPreset};
/// # let mut app = App::new();
/// # app.add_plugins((MinimalPlugins, TransformPlugin, AssetPlugin::default(), bevy::mesh::MeshPlugin, HairPlugin::default()));
/// let registry = app.world().resource::<AppTypeRegistry>().read();
/// let mut preset = HairPreset::default();
/// preset.groom.curl = 0.5;
/// let text = preset.to_ron(&registry).unwrap();
/// assert_eq!(HairPreset::from_ron(&text, &registry).unwrap(), preset);
/// ```
#[derive(Reflect, Clone, Debug, Default, PartialEq)]
#[reflect(Default)]
pub struct HairPreset {
    /// What grows: guide count, length, curl, children…
    pub groom: HairGroom,
    /// How it is drawn.
    #[cfg(feature = "render")]
    pub look: HairLook,
    /// How it moves.
    pub settings: SimParams,
}

/// Why a preset could not be saved or loaded.
/// [`HairPreset`]'s example saves and loads one.
#[derive(thiserror::Error, Debug)]
pub enum PresetError {
    /// Writing RON failed.
    #[error("the hair preset could not be written as RON: {0}")]
    Write(ron::Error),
    /// The text is not RON, or not a preset: where and why.
    #[error("the text is not a hair preset: {0}")]
    Read(ron::error::SpannedError),
    /// The registry does not know the preset's type.
    #[error("HairPreset is not in the type registry: add HairPlugin to the app (it registers it) first")]
    NotRegistered,
}

impl HairPreset {
    /// The preset as pretty-printed RON, through `registry` (the app's
    /// [`AppTypeRegistry`], after [`HairPlugin`](crate::HairPlugin) registered the preset).
    pub fn to_ron(&self, registry: &TypeRegistry) -> Result<String, PresetError> {
        if registry.get(std::any::TypeId::of::<HairPreset>()).is_none() {
            return Err(PresetError::NotRegistered);
        }
        let serializer = TypedReflectSerializer::new(self, registry);
        ron::ser::to_string_pretty(&serializer, ron::ser::PrettyConfig::default()).map_err(PresetError::Write)
    }

    /// The preset written by [`Self::to_ron`]. Values are taken as written; the groom and
    /// the solver replace bad ones (NaN, negative) when they use them, and say so.
    pub fn from_ron(text: &str, registry: &TypeRegistry) -> Result<HairPreset, PresetError> {
        let registration = registry.get(std::any::TypeId::of::<HairPreset>()).ok_or(PresetError::NotRegistered)?;
        let mut deserializer = ron::de::Deserializer::from_str(text).map_err(PresetError::Read)?;
        let value = TypedReflectDeserializer::new(registration, registry)
            .deserialize(&mut deserializer)
            .map_err(|e| PresetError::Read(deserializer.span_error(e)))?;
        deserializer.end().map_err(|e| PresetError::Read(deserializer.span_error(e)))?;
        // The deserializer built the preset from its own registration: every field is there.
        Ok(HairPreset::from_reflect(&*value).expect("a deserialized HairPreset is a HairPreset"))
    }
}
