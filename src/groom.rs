//! Growing a groom on a head entity: description, status, and the growth task.

use crate::convert::{pose_and_scale, to_sim};
use crate::head_mesh::{ScalpWeights, read_head_mesh, scalp_weights};
use crate::settings::{HairSettings, HairSettingsOverride, effective};
use crate::simulation::HairState;
use crate::skinning::ScalpJoint;
use crate::{HairError, HairErrorKind};
use bevy::asset::LoadState;
use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::prelude::*;
use bevy::tasks::{AsyncComputeTaskPool, Task, block_on, futures_lite::future};
use hair_sim::collide::{BAKE_TRIANGLE_BUDGET, DEFAULT_GRID_RESOLUTION, HeadCollider};
use hair_sim::groom::{
    ChildParams, GuideParams, grow_guides, sample_roots, sample_roots_at_vertices, sample_roots_poisson, settle,
};
use hair_sim::math::Pose;
use hair_sim::mesh::HeadMesh;
use hair_sim::solver::{RestShape, SimParams, Strands};
use std::sync::Arc;

/// Where on the head hair may grow.
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
#[derive(Component, Clone, Copy)]
pub struct ScalpPredicate(pub fn(Vec3) -> bool);

/// Put hair on this entity: the description of a groom. The entity needs a [`Mesh3d`]
/// (the head) and a transform. The plugin grows the strands once the mesh is loaded, and
/// again whenever this component changes.
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
    /// before it becomes the rest shape; 0 keeps the strands standing along the normals.
    pub settle_steps: u32,
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
        }
    }
}

impl HairGroom {
    /// The reference's groom: roots on the scalp-labelled vertices along their normals,
    /// 10 segments per guide, children on the spiral with a = b = 2. Pair it with
    /// [`SimParams::reference`] for the reference's simulation.
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
#[derive(Component, Clone, Debug, Default, PartialEq)]
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

/// Everything a background growth task hands back.
pub(crate) struct Grown {
    pub strands: Strands,
    pub collider: Arc<HeadCollider>,
    pub head: Arc<HeadMesh>,
    pub roots: Vec<hair_sim::groom::RootBinding>,
    pub scale: Vec3,
    pub groom: HairGroom,
}

#[derive(Component)]
pub(crate) struct GrowthTask {
    task: Task<Result<Grown, HairErrorKind>>,
    /// A skinned head's scalp joint, found before the task started.
    joint: Option<ScalpJoint>,
}

/// Where the head is drawn this frame: its own transform, or for a skinned head where its
/// scalp joint puts the bind-pose mesh.
pub(crate) fn head_frame(
    transform: &GlobalTransform,
    joint: Option<&ScalpJoint>,
    joints: &Query<&GlobalTransform>,
) -> Result<GlobalTransform, HairErrorKind> {
    match joint {
        None => Ok(*transform),
        Some(joint) => joint.frame(joints).ok_or_else(|| {
            HairErrorKind::Skin(format!("the skin's scalp joint {} has no GlobalTransform (despawned?)", joint.joint))
        }),
    }
}

/// A new or changed groom, a replaced mesh or a modified (hot-reloaded) mesh asset starts
/// over: waiting for its mesh. A change that only touches the children keeps the grown
/// guides.
#[allow(clippy::type_complexity)] // a query's filter list
pub(crate) fn request_growth(
    mut commands: Commands,
    mut mesh_events: MessageReader<AssetEvent<Mesh>>,
    heads: Query<(Entity, Ref<HairGroom>, Option<&HairState>, Ref<Mesh3d>)>,
    changed_without_mesh: Query<Entity, (Changed<HairGroom>, Without<Mesh3d>)>,
) {
    let modified: Vec<AssetId<Mesh>> = mesh_events
        .read()
        .filter_map(|event| match event {
            AssetEvent::Modified { id } => Some(*id),
            _ => None,
        })
        .collect();
    for (entity, groom, state, mesh) in &heads {
        let new_guides = groom.is_changed() && !state.is_some_and(|s| s.grown_from().grows_like(&groom));
        let regrow = new_guides || mesh.is_changed() || modified.contains(&mesh.id());
        if regrow {
            commands.entity(entity).remove::<(HairState, GrowthTask)>().insert(GroomStatus::WaitingForMesh);
        }
    }
    for entity in &changed_without_mesh {
        commands.entity(entity).remove::<(HairState, GrowthTask)>().insert(GroomStatus::WaitingForMesh);
    }
}

/// A head that loses its [`HairGroom`] loses its strands, its growth task and its status.
pub(crate) fn forget_groom(removed: On<Remove, HairGroom>, mut commands: Commands) {
    commands.entity(removed.entity).try_remove::<(HairState, GrowthTask, GroomStatus)>();
}

/// Once the head mesh (and a skinned head's inverse bind matrices) is available, reads it
/// and starts growing on the async pool.
#[allow(clippy::type_complexity, clippy::too_many_arguments)] // the head, its skin and their assets
pub(crate) fn start_growth(
    mut commands: Commands,
    meshes: Option<Res<Assets<Mesh>>>,
    server: Option<Res<AssetServer>>,
    settings: Res<HairSettings>,
    bindposes: Option<Res<Assets<SkinnedMeshInverseBindposes>>>,
    joints: Query<&GlobalTransform>,
    mut grooms: Query<(
        Entity,
        &HairGroom,
        &mut GroomStatus,
        Option<&Mesh3d>,
        &GlobalTransform,
        Option<&HairSettingsOverride>,
        Option<&ScalpPredicate>,
        Option<&SkinnedMesh>,
    )>,
    mut errors: MessageWriter<HairError>,
) {
    for (entity, groom, mut status, mesh3d, transform, local, predicate, skin) in &mut grooms {
        if *status != GroomStatus::WaitingForMesh {
            continue;
        }
        let mut fail = |kind: HairErrorKind| {
            warn!("hair on {entity}: {kind}");
            errors.write(HairError { entity, kind: kind.clone() });
            *status = GroomStatus::Failed(kind);
        };
        let Some(mesh3d) = mesh3d else {
            fail(HairErrorKind::NoMesh);
            continue;
        };
        let Some(meshes) = meshes.as_deref() else {
            fail(HairErrorKind::NoMeshAssets);
            continue;
        };
        let Some(mesh) = meshes.get(&mesh3d.0) else {
            if let Some(LoadState::Failed(e)) = server.as_ref().map(|s| s.load_state(&mesh3d.0)) {
                fail(HairErrorKind::MeshLoad(e.to_string()));
            }
            continue; // still loading
        };
        // A skinned head also waits for its inverse bind matrices.
        let skin = match skin.map(|s| (s, bindposes.as_deref().and_then(|b| b.get(&s.inverse_bindposes)))) {
            None => None,
            Some((skin, Some(bindposes))) => Some((skin, bindposes)),
            Some((skin, None)) => {
                match server.as_ref().map(|s| s.load_state(&skin.inverse_bindposes)) {
                    Some(LoadState::Loading) => {}
                    Some(LoadState::Failed(e)) => fail(HairErrorKind::Bindposes(format!("failed to load: {e}"))),
                    _ => fail(HairErrorKind::Bindposes("named by the SkinnedMesh are not in Assets".into())),
                }
                continue;
            }
        };
        let predicate = predicate.map(|p| p.0);
        let prepared = check_groom(groom).and_then(|()| {
            // A skinned head's frame is its scalp joint's, found on the bind-pose mesh.
            let joint = match skin {
                None => None,
                Some((skin, bindposes)) => {
                    let (bind, _) = read_head_mesh(mesh, Vec3::ONE)?;
                    let weights = scalp_weights(mesh, &bind, groom.scalp, predicate, Vec3::ONE)?;
                    Some(ScalpJoint::find(mesh, skin, bindposes, &bind, &weights.triangles)?)
                }
            };
            let frame = head_frame(transform, joint.as_ref(), &joints)?;
            let (pose, scale) = pose_and_scale(&frame);
            let (head, repairs) = read_head_mesh(mesh, scale)?;
            let weights = scalp_weights(mesh, &head, groom.scalp, predicate, scale)?;
            Ok((head, repairs, weights, pose, scale, joint))
        });
        match prepared {
            Err(reason) => fail(reason),
            Ok((head, repairs, weights, pose, scale, joint)) => {
                if repairs.any() {
                    warn!("hair on {entity}: the head mesh was repaired: {repairs}");
                }
                if head.triangles.len() > BAKE_TRIANGLE_BUDGET {
                    warn!(
                        "hair on {entity}: the head mesh has {} triangles; its collider bakes slowly above {} (4 s \
                         at 82k on two cores, 27 s at 328k): decimate it to {} or fewer",
                        head.triangles.len(),
                        BAKE_TRIANGLE_BUDGET,
                        BAKE_TRIANGLE_BUDGET
                    );
                }
                if let Some(joint) = joint.as_ref().filter(|j| j.share < 0.999) {
                    info!(
                        "hair on {entity}: joint {} carries {:.1}% of the scalp's skin weights; the strands follow it, the roots their skinned triangles",
                        joint.joint,
                        joint.share * 100.0
                    );
                }
                let (params, _) = effective(&settings, local).sanitized();
                let groom = groom.clone();
                let task =
                    AsyncComputeTaskPool::get().spawn(async move { grow(head, weights, groom, params, pose, scale) });
                commands.entity(entity).insert(GrowthTask { task, joint });
                *status = GroomStatus::Growing;
            }
        }
    }
}

/// Rejects descriptions that cannot grow anything, with a reason a user understands.
fn check_groom(groom: &HairGroom) -> Result<(), HairErrorKind> {
    let bad = |field: &'static str, message: String| Err(HairErrorKind::Groom { field, message });
    if groom.guides == 0 {
        return bad("guides", "the groom asks for 0 guides".into());
    }
    if groom.segments == 0 || groom.segments > 256 {
        return bad("segments", format!("the groom asks for {} segments per strand; use 1 to 256", groom.segments));
    }
    if !(groom.length.is_finite() && groom.length > 0.0) {
        return bad("length", format!("the groom length {} is not a positive number of metres", groom.length));
    }
    if !(groom.length_variation.is_finite() && (0.0..1.0).contains(&groom.length_variation)) {
        let message = format!("the groom length variation {} must be in 0..1", groom.length_variation);
        return bad("length_variation", message);
    }
    if !groom.curl.is_finite() {
        return bad("curl", format!("the groom curl {} is not a number", groom.curl));
    }
    if !groom.comb.is_finite() {
        return bad("comb", format!("the groom comb direction {} is not finite", groom.comb));
    }
    if let RootDistribution::Vertices { jitter } = groom.distribution
        && !(0.0..=1.0).contains(&jitter)
    {
        return bad("distribution", format!("the root jitter {jitter} must be in 0..=1 (0: on the vertex)"));
    }
    Ok(())
}

/// The growth itself, off the main thread: roots, guides, collider, settle.
fn grow(
    head: HeadMesh,
    weights: ScalpWeights,
    groom: HairGroom,
    params: SimParams,
    pose: Pose,
    scale: Vec3,
) -> Result<Grown, HairErrorKind> {
    let roots = match groom.distribution {
        RootDistribution::Vertices { jitter } => {
            sample_roots_at_vertices(&head, &weights.vertices, groom.guides, jitter, groom.seed)
        }
        RootDistribution::Uniform => sample_roots(&head, &weights.triangles, groom.guides, groom.seed),
        RootDistribution::Poisson => sample_roots_poisson(&head, &weights.triangles, groom.guides, groom.seed),
    }?;
    let guide_params = GuideParams {
        segments: groom.segments,
        length: groom.length,
        length_variation: groom.length_variation,
        curl: groom.curl,
        comb: to_sim(groom.comb),
    };
    let guides = grow_guides(&head, &roots, &guide_params, groom.seed)?;
    let rest = RestShape::new(guides, groom.segments + 1)?;
    let collider = HeadCollider::new(&head, DEFAULT_GRID_RESOLUTION)?;
    let rest = settle(rest, Some(&collider), &params, groom.settle_steps as usize, guide_params.comb)?;
    let strands = Strands::new(rest, pose);
    Ok(Grown { strands, collider: Arc::new(collider), head: Arc::new(head), roots, scale, groom })
}

/// Collects finished growth tasks: the groom starts simulating, or reports why not.
pub(crate) fn finish_growth(
    mut commands: Commands,
    mut tasks: Query<(Entity, &mut GrowthTask, &mut GroomStatus, &GlobalTransform)>,
    joints: Query<&GlobalTransform>,
    mut errors: MessageWriter<HairError>,
) {
    for (entity, mut task, mut status, transform) in &mut tasks {
        let Some(result) = block_on(future::poll_once(&mut task.task)) else {
            continue;
        };
        commands.entity(entity).remove::<GrowthTask>();
        // The head may have moved while the task ran: start from where it is now.
        let result = result.and_then(|grown| Ok((grown, head_frame(transform, task.joint.as_ref(), &joints)?)));
        match result {
            Ok((grown, frame)) => {
                *status = GroomStatus::Ready {
                    guides: grown.strands.strand_count(),
                    particles_per_strand: grown.strands.particles_per_strand(),
                };
                let (pose, _) = pose_and_scale(&frame);
                commands.entity(entity).insert(HairState::new(grown, pose, task.joint.take()));
            }
            Err(kind) => {
                warn!("hair on {entity}: {kind}");
                errors.write(HairError { entity, kind: kind.clone() });
                *status = GroomStatus::Failed(kind);
            }
        }
    }
}
