//! Growing a groom on a head entity: from its description ([`HairGroom`]) and mesh to a
//! simulating [`HairState`], on a background task; `GroomPlugin` wires it.

use crate::HairSystems;
use crate::convert::{pose_and_scale, to_sim};
use crate::description::{GroomStatus, HairError, HairErrorKind, HairGroom, RootDistribution, ScalpPredicate};
use crate::detail::HairLod;
use crate::hair_asset::{HairAsset, HairAssetLoader};
use crate::head_mesh::{ScalpWeights, read_head_mesh, scalp_weights};
use crate::settings::{HairSettings, HairSettingsOverride, effective};
use crate::simulation::Grown;
use crate::simulation::HairState;
use crate::skinning::{ScalpJoint, head_frame};
use bevy::asset::LoadState;
use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::prelude::*;
use bevy::tasks::{AsyncComputeTaskPool, Task, block_on, futures_lite::future};
use hair_sim::collide::{BAKE_TRIANGLE_BUDGET, DEFAULT_GRID_RESOLUTION, HeadCollider};
use hair_sim::groom::{
    GuideParams, grow_guides, guides_from_strands, painted_patches, sample_roots, sample_roots_at_vertices,
    sample_roots_poisson, settle,
};
use hair_sim::math::{Pose, Vec3 as SimVec3};
use hair_sim::mesh::HeadMesh;
use hair_sim::solver::{RestShape, SimParams, Strands};
use std::sync::Arc;

#[derive(Component)]
pub(crate) struct GrowthTask {
    task: Task<Result<Grown, HairErrorKind>>,
    /// A skinned head's scalp joint, found before the task started.
    joint: Option<ScalpJoint>,
}

/// Growth: a [`HairGroom`] on a head with a mesh becomes a simulating
/// [`HairState`](crate::HairState), in [`HairSystems::Grow`]. Part of
/// [`HairPlugin`](crate::HairPlugin), whose clock and sets it needs: crate-private.
pub(crate) struct GroomPlugin;

impl Plugin for GroomPlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<HairGroom>().register_type::<GroomStatus>().add_message::<HairError>();
        if app.is_plugin_added::<AssetPlugin>() {
            app.init_asset::<HairAsset>().init_asset_loader::<HairAssetLoader>();
        }
        app
            // Read to regrow hot-reloaded heads; present with `MeshPlugin`, added here so a
            // missing one is reported by growth instead of failing the system.
            .add_message::<AssetEvent<Mesh>>()
            .add_observer(forget_groom)
            .add_systems(PostUpdate, (request_growth, start_growth, finish_growth).chain().in_set(HairSystems::Grow));
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
    models: Option<Res<Assets<HairAsset>>>,
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
        Has<HairLod>,
    )>,
    mut errors: MessageWriter<HairError>,
) {
    for (entity, groom, mut status, mesh3d, transform, local, predicate, skin, detail) in &mut grooms {
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
        // Guides from a hair model wait for it to load.
        let model = match &groom.guides_from {
            None => None,
            Some(handle) => match models.as_deref().and_then(|m| m.get(handle)) {
                Some(model) => Some(model.0.strands.clone()),
                None => {
                    match server.as_ref().map(|s| s.load_state(handle)) {
                        Some(LoadState::Failed(e)) => fail(HairErrorKind::HairModel(e.to_string())),
                        Some(LoadState::Loading | LoadState::NotLoaded) => {}
                        _ => fail(HairErrorKind::HairModel("the handle names no loaded HairAsset".into())),
                    }
                    continue;
                }
            },
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
            Err(kind) => fail(kind),
            Ok((head, repairs, weights, pose, scale, joint)) => {
                if repairs.any() {
                    warn!("hair on {entity}: the head mesh was repaired: {repairs}");
                }
                if head.triangles.len() > BAKE_TRIANGLE_BUDGET {
                    warn!(
                        "hair on {entity}: the head mesh has {} triangles; its collider bakes slowly above {} (about \
                         0.3 s plus 11 µs per triangle on two cores): decimate it to {} or fewer",
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
                let task = AsyncComputeTaskPool::get()
                    .spawn(async move { grow(head, weights, model, groom, params, pose, scale, detail) });
                commands.entity(entity).insert(GrowthTask { task, joint });
                *status = GroomStatus::Growing;
            }
        }
    }
}

/// A painted scalp in more than this many patches, the largest holding less than
/// [`SCATTERED_SHARE`] of the paint, is reported ([`HairErrorKind::ScatteredScalp`]): one
/// scalp with sideburns or a beard is a few patches, one large.
const SCATTERED_PATCHES: usize = 4;
/// See [`SCATTERED_PATCHES`].
const SCATTERED_SHARE: f32 = 0.5;

/// The report for a scalp painted in scattered patches (`patches`, largest first), if it is.
fn scattered_scalp(patches: &[f32]) -> Option<HairErrorKind> {
    let total: f32 = patches.iter().sum();
    let largest_share = patches.first().map_or(1.0, |largest| largest / total.max(f32::MIN_POSITIVE));
    (patches.len() > SCATTERED_PATCHES && largest_share < SCATTERED_SHARE)
        .then_some(HairErrorKind::ScatteredScalp { patches: patches.len(), largest_share })
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

/// The growth itself, off the main thread: roots and guides (grown, or taken from a hair
/// `model` in the mesh's units), collider, settle.
#[allow(clippy::too_many_arguments)] // what the growth task moves in, each once
fn grow(
    head: HeadMesh,
    weights: ScalpWeights,
    model: Option<Vec<Vec<SimVec3>>>,
    groom: HairGroom,
    params: SimParams,
    pose: Pose,
    scale: Vec3,
    detail: bool,
) -> Result<Grown, HairErrorKind> {
    let comb = to_sim(groom.comb);
    let scalp_patches = painted_patches(&head, &weights.triangles);
    let (roots, guides) = match model {
        Some(strands) => {
            // The head mesh here is scaled by the entity's scale: so is the model.
            let scale = to_sim(scale);
            let scaled: Vec<Vec<SimVec3>> =
                strands.iter().map(|strand| strand.iter().map(|&p| p * scale).collect()).collect();
            guides_from_strands(&head, &weights.triangles, &scaled, groom.segments)?
        }
        None => {
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
                comb,
            };
            let guides = grow_guides(&head, &roots, &guide_params, groom.seed)?;
            (roots, guides)
        }
    };
    let rest = RestShape::new(guides, groom.segments + 1)?;
    let collider = HeadCollider::new(&head, DEFAULT_GRID_RESOLUTION)?;
    let rest = settle(rest, Some(&collider), &params, groom.settle_steps as usize, comb)?;
    let mut strands = Strands::new(rest, pose);
    if detail {
        // A head with levels of detail: their search here, not when the level first changes.
        strands.prepare_detail();
    }
    Ok(Grown { strands, collider: Arc::new(collider), head: Arc::new(head), roots, scale, groom, scalp_patches })
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
                if let Some(kind) = scattered_scalp(&grown.scalp_patches) {
                    warn!("hair on {entity}: {kind}");
                    errors.write(HairError { entity, kind });
                }
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
