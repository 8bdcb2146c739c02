//! `.hair` files (Cem Yuksel's format) as Bevy assets: load one with the `AssetServer` and
//! give its handle to [`HairGroom::guides_from`](crate::HairGroom::guides_from) to take the
//! guides from it instead of growing them; write a groom out with
//! [`HairState::to_hair_file`](crate::HairState::to_hair_file).

use bevy::asset::io::Reader;
use bevy::asset::{AssetLoader, LoadContext};
use bevy::prelude::*;
use hair_sim::groom::{HairFile, HairFileError};

/// A hair model: strands as polylines in the head mesh's space (the file's units).
#[derive(Asset, TypePath, Clone, Debug, Default, PartialEq)]
pub struct HairAsset(pub HairFile);

/// Loads `.hair` files as [`HairAsset`]s.
#[derive(Default, TypePath)]
pub struct HairAssetLoader;

/// Why a `.hair` file did not load.
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
