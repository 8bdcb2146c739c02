//! `.hair` files (Cem Yuksel's format) as Bevy assets: load one with the `AssetServer` and
//! give its handle to [`HairGroom::guides_from`](crate::HairGroom::guides_from) to take the
//! guides from it instead of growing them; write a groom out with
//! [`HairState::to_hair_file`](crate::HairState::to_hair_file).

use bevy::asset::io::Reader;
use bevy::asset::{AssetLoader, LoadContext};
use bevy::prelude::*;
use hair_sim::groom::{HairFile, HairFileError};

/// A hair model: strands as polylines in the head mesh's space (the file's units).
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// # use bevy_hair::HairAsset;
/// fn guides_from_a_file(mut commands: Commands, assets: Res<AssetServer>, mut meshes: ResMut<Assets<Mesh>>) {
///     let model: Handle<HairAsset> = assets.load("procedural.hair");
///     let head = meshes.add(bevy_hair::procedural_head_mesh(4));
///     commands.spawn((Mesh3d(head), HairGroom { guides_from: Some(model), ..default() }));
/// }
/// ```
///
/// `examples/hair_file.rs` saves a settled groom and grows another from the file.
#[derive(Asset, TypePath, Clone, Debug, Default, PartialEq)]
pub struct HairAsset(pub HairFile);

/// Loads `.hair` files as [`HairAsset`]s.
/// [`HairPlugin`](crate::HairPlugin) registers it: [`HairAsset`]'s example loads a file.
#[derive(Default, TypePath)]
pub struct HairAssetLoader;

/// Why a `.hair` file did not load.
/// The asset server reports it for a file that [`HairAsset`]'s example would load.
#[derive(thiserror::Error, Debug)]
pub enum HairAssetError {
    /// The bytes could not be read.
    #[error("could not read the .hair file: {0}")]
    Io(#[from] std::io::Error),
    /// The bytes are not a usable `.hair` file.
    #[error(transparent)]
    File(#[from] HairFileError),
}

impl AssetLoader for HairAssetLoader {
    type Asset = HairAsset;
    type Settings = ();
    type Error = HairAssetError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _settings: &Self::Settings,
        _context: &mut LoadContext<'_>,
    ) -> Result<Self::Asset, Self::Error> {
        let mut bytes = Vec::new();
        reader.read_to_end(&mut bytes).await?;
        Ok(HairAsset(HairFile::read(&bytes)?))
    }

    fn extensions(&self) -> &[&str] {
        &["hair"]
    }
}
