//! What a user puts on a head and reads back: the groom's description ([`HairGroom`] and
//! how its scalp and roots are chosen), where it stands ([`GroomStatus`]), and what can be
//! wrong with it ([`HairError`], whose [`HairErrorKind`] `Display`s the sentence a user
//! reads). Every other module uses these; this one uses only the hair model asset.

use crate::hair_asset::HairAsset;
use bevy::prelude::*;
use hair_sim::collide::ColliderError;
use hair_sim::groom::{ChildParams, GroomError};
use hair_sim::mesh::MeshError;
use hair_sim::solver::{ParamIssue, StrandsError};

/// Something is wrong with a groom: its head, its mesh, its description or its settings.
/// The groom stays inert (or runs with the bad settings replaced) until it is fixed.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// fn log_hair_errors(mut errors: MessageReader<HairError>) {
///     for error in errors.read() {
///         warn!("{error}");
///     }
/// }
/// ```
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

/// What is wrong with a groom. Reflected as one opaque value (inspectors show its
/// `Debug`; its parts come from `hair_sim`, which knows nothing of reflection).
/// [`HairError`] and [`GroomStatus`] show how to read it.
#[derive(thiserror::Error, Reflect, Clone, Debug, PartialEq)]
#[reflect(opaque, Debug, PartialEq, Clone)]
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
    /// The hair model the groom takes its guides from failed to load.
    #[error("the hair model failed to load: {0}")]
    HairModel(String),
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
    /// The groom asks for [`HairBackend::Gpu`](crate::HairBackend) and the GPU cannot step
    /// it: it steps on the CPU.
    #[error("the GPU solver cannot step this groom ({0}); it steps on the CPU")]
    GpuFallback(String),
    /// The painted scalp is many separate patches, none of them most of the paint: often
    /// colours an exporter scrambled. The groom grows on the paint as it is.
    #[error(
        "the painted scalp is {patches} separate patches, the largest {:.0}% of the paint: if one scalp was painted, \
         the exporter may have scrambled its colours (Blender 3.4's glTF exporter does on the Face Corner domain: \
         paint on the Vertex domain)",
        largest_share * 100.0
    )]
    ScatteredScalp {
        /// How many patches (painted triangles joined where they share a corner).
        patches: usize,
        /// The largest patch's share of the painted area.
        largest_share: f32,
    },
    /// Fields of the groom's `HairLod` that had to be replaced (the groom runs with the
    /// replacements).
    #[error("invalid level-of-detail settings: {0}")]
    Detail(String),
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

/// Where on the head hair may grow.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// // Hair on every vertex above the head mesh's origin, whatever its paint.
/// fn above_the_origin(p: Vec3) -> bool {
///     p.y > 0.0
/// }
/// let groom = HairGroom { scalp: ScalpSource::Predicate, ..default() };
/// let rule = ScalpPredicate(above_the_origin);
/// # let _ = (groom, rule);
/// ```
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
pub enum ScalpSource {
    /// Vertices painted darker than `threshold` in `COLOR_0` (luminance of linear RGB):
    /// the reference's convention, and what Blender's vertex paint exports to glTF.
    VertexColor {
        /// Luminance below which a vertex is scalp.
        threshold: f32,
    },
    /// The float vertex attribute `_SCALP` ([`ATTRIBUTE_SCALP`](crate::ATTRIBUTE_SCALP)),
    /// a density weight 0..1.
    Attribute,
    /// The [`ScalpPredicate`] component on the same entity decides per vertex.
    Predicate,
    /// The whole mesh.
    Everywhere,
}

impl Default for ScalpSource {
    fn default() -> Self {
        ScalpSource::VertexColor { threshold: 0.5 }
    }
}

/// How roots are spread over the scalp.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// let groom = HairGroom { distribution: RootDistribution::Vertices { jitter: 0.5 }, ..default() };
/// # let _ = groom;
/// ```
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq)]
pub enum RootDistribution {
    /// The reference's roots: drawn uniformly from the scalp-labelled vertices, each
    /// growing along its vertex normal. Density follows the tessellation (a finely meshed
    /// region gets more hair); see [`sample_roots_at_vertices`](hair_sim::groom::sample_roots_at_vertices).
    Vertices {
        /// 0: on the vertex; up to 1: anywhere in the triangles around it (roots that
        /// repeat a vertex then spread out instead of growing as one).
        jitter: f32,
    },
    /// Independent samples, uniform by area: even on average over uneven tessellation,
    /// but some clump and some leave gaps.
    Uniform,
    /// Poisson-disk: uniform by area, but no two roots closer than about 0.7 of the mean
    /// spacing, so coverage is even.
    #[default]
    Poisson,
}

/// A user rule for [`ScalpSource::Predicate`]: `true` for head-local vertex positions
/// (in the mesh's own units, before the entity's scale) that are scalp.
/// See [`ScalpSource`]'s example.
#[derive(Component, Clone, Copy)]
pub struct ScalpPredicate(pub fn(Vec3) -> bool);

/// Put hair on this entity: the description of a groom. The entity needs a [`Mesh3d`]
/// (the head) and a transform. The plugin grows the strands once the mesh is loaded, and
/// again whenever this component changes.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// fn spawn_head(mut commands: Commands, assets: Res<AssetServer>) {
///     let head = assets.load(GltfAssetLabel::Primitive { mesh: 0, primitive: 0 }.from_asset("head.glb"));
///     let groom = HairGroom { guides: 800, length: 0.3, curl: 0.2, ..default() };
///     commands.spawn((Mesh3d(head), MeshMaterial3d(assets.add(StandardMaterial::default())), groom));
/// }
/// ```
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Default)]
#[require(GroomStatus, Transform)]
pub struct HairGroom {
    /// Number of guide strands (simulated).
    pub guides: usize,
    /// Segments per guide (the reference uses 10).
    pub segments: usize,
    /// Strand length, metres.
    pub length: f32,
    /// Random length variation, fraction of `length`.
    pub length_variation: f32,
    /// Curl, radians per segment.
    pub curl: f32,
    /// Combing, in the head mesh's frame: strands start along the surface normal tilted
    /// toward this direction (length 1 tilts by 45°), and the settle pass brushes them
    /// that way (`|g|·comb` added to gravity) before taking the rest shape. Zero grows
    /// straight out and lets the hair fall where gravity puts it, as the reference does.
    /// `Vec3::new(0.0, 0.0, -1.5)` on a +Z-facing head sweeps the hair back, out of the face.
    pub comb: Vec3,
    /// Seed: the same seed grows the same groom.
    pub seed: u64,
    /// Which part of the mesh is scalp.
    pub scalp: ScalpSource,
    /// How roots are spread over the scalp.
    pub distribution: RootDistribution,
    /// Child strands drawn around each guide (the Archimedean spiral, clumping, tip
    /// spread). Changing only this does not regrow the guides.
    pub children: ChildParams,
    /// Steps of the settle ("comb") pass that lets freshly grown hair fall onto the head
    /// before it becomes the rest shape; 0 keeps the strands standing along the normals,
    /// where shape keeping holds them against gravity and a few may never come to rest.
    pub settle_steps: u32,
    /// Take the guides from this hair model (a `.hair` file, in the head mesh's space)
    /// instead of growing them: each strand is resampled to `segments` and moved whole onto
    /// the nearest scalp point. `guides`, `length`, `curl`, `comb` and the root
    /// distribution are then unused; the settle pass still runs. Not saved in a
    /// [`HairPreset`](crate::HairPreset).
    #[reflect(skip_serializing)]
    pub guides_from: Option<Handle<HairAsset>>,
}

impl Default for HairGroom {
    fn default() -> Self {
        HairGroom {
            guides: 1024,
            segments: 10,
            length: 0.25,
            length_variation: 0.2,
            curl: 0.0,
            comb: Vec3::ZERO,
            seed: 1,
            scalp: ScalpSource::default(),
            distribution: RootDistribution::default(),
            children: ChildParams::default(),
            settle_steps: 180,
            guides_from: None,
        }
    }
}

impl HairGroom {
    /// The reference's groom: roots on the scalp-labelled vertices along their normals,
    /// 10 segments per guide, children on the spiral with a = b = 2. Pair it with
    /// [`SimParams::reference`](hair_sim::solver::SimParams::reference) for the
    /// reference's simulation.
    pub fn reference() -> Self {
        HairGroom {
            segments: 10,
            distribution: RootDistribution::Vertices { jitter: 0.0 },
            children: ChildParams { spiral: hair_sim::groom::Spiral { a: 2.0, b: 2.0, ..default() }, ..default() },
            ..default()
        }
    }

    /// Whether `other` grows the same guides: equal in everything but the children,
    /// which are placed at draw time.
    pub fn grows_like(&self, other: &HairGroom) -> bool {
        HairGroom { children: other.children, ..self.clone() } == *other
    }
}

/// Where a groom stands. Check it (or read [`HairError`] messages) to learn why a head
/// has no hair.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// fn report(grooms: Query<(Entity, &GroomStatus), Changed<GroomStatus>>) {
///     for (head, status) in &grooms {
///         match status {
///             GroomStatus::Ready { guides, .. } => info!("{head}: {guides} guides"),
///             GroomStatus::Failed(why) => warn!("{head} has no hair: {why}"),
///             _ => {}
///         }
///     }
/// }
/// ```
#[derive(Component, Reflect, Clone, Debug, Default, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq)]
pub enum GroomStatus {
    /// Waiting for the head's mesh asset to load.
    #[default]
    WaitingForMesh,
    /// Strands are being grown on a background task.
    Growing,
    /// Simulating.
    Ready {
        /// Guide strands.
        guides: usize,
        /// Particles per guide.
        particles_per_strand: usize,
    },
    /// Could not grow, and why. The groom stays inert until its description or mesh
    /// changes.
    Failed(HairErrorKind),
}
