//! What can be wrong with a groom, as types: a [`HairError`] message names the head and one
//! [`HairErrorKind`], whose `Display` is the sentence a user reads.

use crate::groom::ScalpSource;
use bevy::prelude::*;
use hair_sim::collide::ColliderError;
use hair_sim::groom::GroomError;
use hair_sim::mesh::MeshError;
use hair_sim::solver::{ParamIssue, StrandsError};

/// Something is wrong with a groom: its head, its mesh, its description or its settings.
/// The groom stays inert (or runs with the bad settings replaced) until it is fixed.
#[derive(Message, Clone, Debug, PartialEq)]
pub struct HairError {
    /// The head entity whose groom has the problem.
    pub entity: Entity,
    /// What is wrong.
    pub kind: HairErrorKind,
}

impl std::fmt::Display for HairError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "hair on {}: {}", self.entity, self.kind)
    }
}

impl std::error::Error for HairError {}

/// What is wrong with a groom.
#[derive(thiserror::Error, Clone, Debug, PartialEq)]
pub enum HairErrorKind {
    /// The entity has a `HairGroom` but no `Mesh3d`.
    #[error("the entity has a HairGroom but no Mesh3d to grow on")]
    NoMesh,
    /// The app has no `Assets<Mesh>`.
    #[error("there is no Assets<Mesh>: add MeshPlugin (part of DefaultPlugins)")]
    NoMeshAssets,
    /// The head's mesh asset failed to load.
    #[error("the head mesh failed to load: {0}")]
    MeshLoad(String),
    /// The skin's inverse bind matrices failed to load, or are not in `Assets`.
    #[error("the head's inverse bind matrices {0}")]
    Bindposes(String),
    /// The mesh cannot be read as a triangle mesh (topology, attribute formats).
    #[error("{0}")]
    MeshFormat(String),
    /// The mesh's triangles are unusable.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// The scalp labels cannot be read from the mesh.
    #[error("{0}")]
    ScalpLabels(String),
    /// The labels mark no triangle as scalp.
    #[error("{}", no_scalp(.0))]
    NoScalp(ScalpSource),
    /// A field of the `HairGroom` is unusable.
    #[error("{message}")]
    Groom {
        /// The field (`"length"`, `"distribution"`).
        field: &'static str,
        /// What is wrong with its value, in words.
        message: String,
    },
    /// The skin's joints or weights do not fit the mesh.
    #[error("{0}")]
    Skin(String),
    /// Growing the strands failed.
    #[error(transparent)]
    Growth(#[from] GroomError),
    /// The strands could not be built.
    #[error(transparent)]
    Strands(#[from] StrandsError),
    /// The collider could not be built.
    #[error(transparent)]
    Collider(#[from] ColliderError),
    /// Settings that had to be replaced to simulate (the groom runs with the replacements).
    #[error("invalid hair settings: {}", settings_list(.0))]
    Settings(Vec<ParamIssue>),
}

fn no_scalp(source: &ScalpSource) -> String {
    match source {
        ScalpSource::VertexColor { threshold } => format!(
            "no triangle of the head mesh is painted as scalp: COLOR_0 has no three-vertex region darker than {threshold}"
        ),
        ScalpSource::Attribute => "no triangle of the head mesh has a _SCALP weight above 0".into(),
        ScalpSource::Predicate => "the scalp predicate accepted no triangle of the head mesh".into(),
        ScalpSource::Everywhere => "the head mesh has no usable triangles".into(),
    }
}

fn settings_list(issues: &[ParamIssue]) -> String {
    issues.iter().map(ToString::to_string).collect::<Vec<_>>().join("; ")
}
