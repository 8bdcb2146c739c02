//! Heads that are part of a skinned mesh ([`SkinnedMesh`]): hair grows on the bind-pose
//! scalp and follows the joint that carries it.
//!
//! A skinned vertex is drawn at `Σ wⱼ · (jointⱼ · inverse_bindⱼ) · v`; the entity's own
//! transform plays no part. A scalp weighted to one joint (the head joint, as characters
//! are rigged) therefore moves rigidly with `joint · inverse_bind`, and that product is
//! the head's frame here: the collider and the strands follow it. Where the scalp is
//! blended with other joints, each root also rides its skinned triangle: every frame the
//! root triangles alone are skinned on the CPU ([`RootSkin`]) and the roots are pinned
//! there, in the dominant joint's frame. Likewise the skin that moves against that joint
//! (a neck blended toward another joint, bending as the head turns) is skinned every frame
//! ([`SkinPatch`]) and collided with as it is drawn, beside the collider baked at bind pose.

use crate::convert::to_sim;
use crate::description::HairErrorKind;
use bevy::math::Affine3A;
use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::mesh::{Mesh, VertexAttributeValues};
use bevy::prelude::*;
use hair_sim::collide::SurfacePatch;
use hair_sim::groom::RootBinding;
use hair_sim::math::Pose;
use hair_sim::mesh::HeadMesh;

/// How far from the moving skin its patch answers collision queries, metres: beyond any
/// sane collision thickness; deeper points are the baked collider's.
const PATCH_REACH: f32 = 0.02;

/// The joint a skinned head's hair follows, found at growth.
/// Read it from [`HairState::scalp_joint`](crate::HairState::scalp_joint); `examples/character.rs`
/// grows hair on a skinned head.
#[derive(Clone, Debug, PartialEq)]
pub struct ScalpJoint {
    /// The joint entity (one of [`SkinnedMesh::joints`]).
    pub joint: Entity,
    /// Its inverse bind matrix: bind-pose mesh space → the joint's space.
    pub inverse_bind: Affine3A,
    /// The share of the scalp's joint weight this joint carries, 0..1 (1: the whole scalp
    /// is skinned to it alone and moves rigidly with it).
    pub share: f32,
    /// Its index in the skin's joints (`JOINTS_0` values).
    index: usize,
    /// Every joint of the skin with its inverse bind matrix, for skinning the roots.
    joints: Vec<(Entity, Affine3A)>,
    /// Each vertex's joints and weights (the mesh's JOINTS_0 and WEIGHTS_0).
    vertex_joints: Vec<Influences>,
}

/// Up to four (joint, weight) pairs of a vertex.
type Influences = [(u16, f32); 4];

/// A skinned vertex: its bind-pose position and influences.
type SkinnedVertex = (Vec3, Influences);

/// Linear blend skinning of the root triangles, for a groom on a skinned head.
#[derive(Clone, Debug, Default)]
pub(crate) struct RootSkin {
    /// Per root: its triangle's corners and the root's barycentric coordinates.
    roots: Vec<([SkinnedVertex; 3], [f32; 3])>,
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

impl ScalpJoint {
    /// Picks the joint carrying most of the scalp: each scalp triangle's weight (`scalp`, per
    /// triangle of `head`) times its corners' joint weights, summed per joint.
    pub(crate) fn find(
        mesh: &Mesh,
        skin: &SkinnedMesh,
        bindposes: &SkinnedMeshInverseBindposes,
        head: &HeadMesh,
        scalp: &[f32],
    ) -> Result<ScalpJoint, HairErrorKind> {
        let (Some(VertexAttributeValues::Uint16x4(indices)), Some(VertexAttributeValues::Float32x4(weights))) =
            (mesh.attribute(Mesh::ATTRIBUTE_JOINT_INDEX), mesh.attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT))
        else {
            return Err(HairErrorKind::Skin(
                "the head has a SkinnedMesh but its mesh has no joint indices and weights (JOINTS_0, WEIGHTS_0 as \
                 Uint16x4 and Float32x4)"
                    .into(),
            ));
        };
        let mut per_joint = vec![0.0f64; skin.joints.len()];
        for (triangle, &w) in head.triangles.iter().zip(scalp).filter(|(_, w)| **w > 0.0) {
            for &v in triangle {
                let (Some(joints), Some(weights)) = (indices.get(v as usize), weights.get(v as usize)) else {
                    return Err(HairErrorKind::Skin("the head mesh has fewer joint weights than vertices".into()));
                };
                for (&j, &jw) in joints.iter().zip(weights) {
                    if jw > 0.0 && jw.is_finite() {
                        let slot = per_joint.get_mut(j as usize).ok_or_else(|| {
                            let joints = skin.joints.len();
                            HairErrorKind::Skin(format!(
                                "a scalp vertex names joint {j}, but the skin has {joints} joints"
                            ))
                        })?;
                        *slot += f64::from(w * jw);
                    }
                }
            }
        }
        let total: f64 = per_joint.iter().sum();
        let Some((index, &best)) = per_joint.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)) else {
            return Err(HairErrorKind::Skin("the head's SkinnedMesh has no joints".into()));
        };
        if total <= 0.0 {
            return Err(HairErrorKind::Skin("no scalp vertex of the skinned head has a joint weight above 0".into()));
        }
        let inverse_bind = bindposes.get(index).ok_or_else(|| {
            let (joints, matrices) = (skin.joints.len(), bindposes.len());
            HairErrorKind::Skin(format!("the skin has {joints} joints but {matrices} inverse bind matrices"))
        })?;
        let joints = skin
            .joints
            .iter()
            .zip(bindposes.iter())
            .map(|(&joint, inverse_bind)| (joint, Affine3A::from_mat4(*inverse_bind)))
            .collect();
        let vertex_joints = indices.iter().zip(weights).map(|(j, w)| std::array::from_fn(|k| (j[k], w[k]))).collect();
        Ok(ScalpJoint {
            joint: skin.joints[index],
            inverse_bind: Affine3A::from_mat4(*inverse_bind),
            share: (best / total) as f32,
            index,
            joints,
            vertex_joints,
        })
    }

    /// The skinning data of each root's triangle, from the head mesh the groom grew on
    /// (scaled by `scale`, the scale of the joint's frame at growth).
    pub(crate) fn root_skin(&self, head: &HeadMesh, scale: Vec3, roots: &[RootBinding]) -> RootSkin {
        let corner = |v: u32| self.skinned_vertex(head, scale, v);
        let roots = roots.iter().map(|r| (head.triangles[r.triangle as usize].map(corner), r.barycentric)).collect();
        RootSkin { roots }
    }

    /// Vertex `v` of `head` (scaled by `scale`) as the skin sees it: its bind-pose position
    /// and its joints and weights.
    fn skinned_vertex(&self, head: &HeadMesh, scale: Vec3, v: u32) -> SkinnedVertex {
        let position = Vec3::from_array(head.positions[v as usize].to_array()) / scale;
        (position, self.vertex_joints.get(v as usize).copied().unwrap_or_default())
    }

    /// The skin that does not move rigidly with this joint, as a patch to collide with
    /// (`None` when all of the head does): every triangle of `head` (scaled by `scale`)
    /// with a corner weighted to another joint.
    pub(crate) fn skin_patch(&self, head: &HeadMesh, scale: Vec3) -> Option<SkinPatch> {
        let rigid = |v: u32| {
            let influences = self.vertex_joints.get(v as usize).copied().unwrap_or_default();
            let total: f32 = influences.iter().map(|(_, w)| w.max(0.0)).sum();
            let own: f32 = influences.iter().filter(|(j, _)| *j as usize == self.index).map(|(_, w)| w.max(0.0)).sum();
            total > 0.0 && own >= total * (1.0 - 1e-4)
        };
        let moving: Vec<[u32; 3]> = head.triangles.iter().copied().filter(|t| !t.iter().all(|&v| rigid(v))).collect();
        if moving.is_empty() {
            return None;
        }
        // The patch's own vertex numbering, over the corners it uses.
        let mut numbering = std::collections::HashMap::new();
        let (mut vertices, mut bind) = (Vec::new(), Vec::new());
        let triangles = moving
            .iter()
            .map(|t| {
                t.map(|v| {
                    *numbering.entry(v).or_insert_with(|| {
                        vertices.push(self.skinned_vertex(head, scale, v));
                        // At bind pose the skin is where the collider was baked.
                        bind.push(head.positions[v as usize]);
                        (vertices.len() - 1) as u32
                    })
                })
            })
            .collect();
        Some(SkinPatch { vertices, patch: SurfacePatch::new(triangles, bind, PATCH_REACH) })
    }

    /// Each joint's skinning matrix this frame (`joint · inverse_bind`); identity for a joint
    /// without a transform.
    pub(crate) fn skinning_matrices(&self, joints: &Query<&GlobalTransform>) -> Vec<Affine3A> {
        self.joints
            .iter()
            .map(|(joint, inverse_bind)| joints.get(*joint).map_or(Affine3A::IDENTITY, |g| g.affine() * *inverse_bind))
            .collect()
    }

    /// Where the skin puts the bind-pose head this frame: `joint · inverse_bind`, or `None`
    /// when the joint has no transform (despawned).
    pub(crate) fn frame(&self, joints: &Query<&GlobalTransform>) -> Option<GlobalTransform> {
        let joint = joints.get(self.joint).ok()?;
        Some(GlobalTransform::from(joint.affine() * self.inverse_bind))
    }
}

/// The part of a skinned head that moves against its scalp joint, skinned on the CPU every
/// frame and handed to the solver as a [`SurfacePatch`] in the joint's (head) frame.
#[derive(Clone, Debug)]
pub(crate) struct SkinPatch {
    vertices: Vec<SkinnedVertex>,
    patch: SurfacePatch,
}

impl SkinPatch {
    /// The patch as the skin was last drawn.
    pub(crate) fn patch(&self) -> &SurfacePatch {
        &self.patch
    }

    /// Skins the patch with this frame's `matrices` and brings it into the head frame `pose`.
    pub(crate) fn update(&mut self, matrices: &[Affine3A], pose: Pose) {
        let local: Vec<hair_sim::math::Vec3> =
            self.vertices.iter().map(|v| pose.inverse_transform_point(to_sim(skin_vertex(v, matrices)))).collect();
        self.patch.update(&local);
    }
}

/// Where linear blend skinning with `matrices` puts a vertex, world space. Weights that do
/// not sum to 1 are normalised, as the GPU's skinning expects.
fn skin_vertex((v, weights): &SkinnedVertex, matrices: &[Affine3A]) -> Vec3 {
    let blended: Vec3 = weights
        .iter()
        .filter(|(_, w)| *w > 0.0)
        .filter_map(|&(j, w)| matrices.get(j as usize).map(|m| w * m.transform_point3(*v)))
        .sum();
    let total: f32 = weights.iter().filter(|(_, w)| *w > 0.0).map(|(_, w)| w).sum();
    if total > 0.0 { blended / total } else { *v }
}

impl RootSkin {
    /// Whether there are no roots to skin.
    pub(crate) fn is_empty(&self) -> bool {
        self.roots.is_empty()
    }

    /// Each root where the skin puts it this frame, world space: its triangle's corners
    /// skinned with `matrices` ([`ScalpJoint::skinning_matrices`]), then interpolated.
    pub(crate) fn skinned_roots<'a>(&'a self, matrices: &'a [Affine3A]) -> impl Iterator<Item = Vec3> + 'a {
        self.roots
            .iter()
            .map(move |(corners, bary)| corners.iter().zip(bary).map(|(c, b)| *b * skin_vertex(c, matrices)).sum())
    }
}
