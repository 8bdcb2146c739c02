//! Heads that are part of a skinned mesh ([`SkinnedMesh`]): hair grows on the bind-pose
//! scalp and follows the joint that carries it.
//!
//! A skinned vertex is drawn at `Σ wⱼ · (jointⱼ · inverse_bindⱼ) · v`; the entity's own
//! transform plays no part. A scalp weighted to one joint (the head joint, as characters
//! are rigged) therefore moves rigidly with `joint · inverse_bind`, and that product is
//! the head's frame here: the roots, the collider and the drawing follow it exactly. Where
//! the scalp is blended with other joints, those parts follow the dominant joint rigidly;
//! growth reports how much of the scalp that joint carries.

use bevy::math::Affine3A;
use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::mesh::{Mesh, VertexAttributeValues};
use bevy::prelude::*;
use hair_sim::mesh::HeadMesh;

/// The joint a skinned head's hair follows, found at growth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScalpJoint {
    /// The joint entity (one of [`SkinnedMesh::joints`]).
    pub joint: Entity,
    /// Its inverse bind matrix: bind-pose mesh space → the joint's space.
    pub inverse_bind: Affine3A,
    /// The share of the scalp's joint weight this joint carries, 0..1 (1: the whole scalp
    /// is skinned to it alone, and the roots ride the skin exactly).
    pub share: f32,
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
    ) -> Result<ScalpJoint, String> {
        let (Some(VertexAttributeValues::Uint16x4(indices)), Some(VertexAttributeValues::Float32x4(weights))) =
            (mesh.attribute(Mesh::ATTRIBUTE_JOINT_INDEX), mesh.attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT))
        else {
            return Err("the head has a SkinnedMesh but its mesh has no joint indices and weights (JOINTS_0, \
                        WEIGHTS_0 as Uint16x4 and Float32x4)"
                .into());
        };
        let mut per_joint = vec![0.0f64; skin.joints.len()];
        for (triangle, &w) in head.triangles.iter().zip(scalp).filter(|(_, w)| **w > 0.0) {
            for &v in triangle {
                let (Some(joints), Some(weights)) = (indices.get(v as usize), weights.get(v as usize)) else {
                    return Err("the head mesh has fewer joint weights than vertices".into());
                };
                for (&j, &jw) in joints.iter().zip(weights) {
                    if jw > 0.0 && jw.is_finite() {
                        let slot = per_joint.get_mut(j as usize).ok_or_else(|| {
                            format!("a scalp vertex names joint {j}, but the skin has {} joints", skin.joints.len())
                        })?;
                        *slot += f64::from(w * jw);
                    }
                }
            }
        }
        let total: f64 = per_joint.iter().sum();
        let Some((index, &best)) = per_joint.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)) else {
            return Err("the head's SkinnedMesh has no joints".into());
        };
        if total <= 0.0 {
            return Err("no scalp vertex of the skinned head has a joint weight above 0".into());
        }
        let inverse_bind = bindposes.get(index).ok_or_else(|| {
            format!("the skin has {} joints but {} inverse bind matrices", skin.joints.len(), bindposes.len())
        })?;
        Ok(ScalpJoint {
            joint: skin.joints[index],
            inverse_bind: Affine3A::from_mat4(*inverse_bind),
            share: (best / total) as f32,
        })
    }

    /// Where the skin puts the bind-pose head this frame: `joint · inverse_bind`, or `None`
    /// when the joint has no transform (despawned).
    pub(crate) fn frame(&self, joints: &Query<&GlobalTransform>) -> Option<GlobalTransform> {
        let joint = joints.get(self.joint).ok()?;
        Some(GlobalTransform::from(joint.affine() * self.inverse_bind))
    }
}
