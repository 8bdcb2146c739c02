//! The one place where Bevy's glam (0.32) meets hair_sim's glam (0.33).

use bevy::math::{Quat, Vec3};
use bevy::transform::components::GlobalTransform;
use hair_sim::math as sim;

/// Bevy vector → solver vector.
#[inline]
pub(crate) fn to_sim(v: Vec3) -> sim::Vec3 {
    sim::Vec3::from_array(v.to_array())
}

/// Solver vector → Bevy vector.
#[inline]
pub(crate) fn from_sim(v: sim::Vec3) -> Vec3 {
    Vec3::from_array(v.to_array())
}

/// Bevy rotation → solver rotation.
#[inline]
pub(crate) fn quat_to_sim(q: Quat) -> sim::Quat {
    sim::Quat::from_array(q.to_array())
}

/// The rigid part of a global transform, and its scale (baked into the collider).
pub(crate) fn pose_and_scale(transform: &GlobalTransform) -> (sim::Pose, Vec3) {
    let (scale, rotation, translation) = transform.to_scale_rotation_translation();
    (sim::Pose::new(quat_to_sim(rotation.normalize()), to_sim(translation)), scale)
}

/// Solver rotation → Bevy rotation (for drawing).
#[cfg(feature = "render")]
#[inline]
pub(crate) fn quat_from_sim(q: sim::Quat) -> Quat {
    Quat::from_array(q.to_array())
}
