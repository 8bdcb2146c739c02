//! Math types: glam 0.33, the version parry3d 0.31 uses, re-exported so callers need no
//! glam of their own. Bevy 0.19 uses glam 0.32, a different `Vec3`: the Bevy glue converts
//! at the crate boundary with `to_array`/`from_array`, nowhere else.

pub use glam::{Quat, Vec3};

/// A rigid transform (rotation, then translation): where the head is in the world.
///
/// Scale is not part of the pose: the head's scale is baked into the collider and the
/// rest shape when they are built, so the solver only ever moves rigid bodies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Orientation of head-local axes in the world.
    pub rotation: Quat,
    /// World position of the head-local origin.
    pub translation: Vec3,
}

impl Default for Pose {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Pose {
    /// No rotation, no translation.
    pub const IDENTITY: Pose = Pose { rotation: Quat::IDENTITY, translation: Vec3::ZERO };

    /// A pose from its parts.
    pub fn new(rotation: Quat, translation: Vec3) -> Self {
        Pose { rotation, translation }
    }

    /// A pure translation.
    pub fn from_translation(translation: Vec3) -> Self {
        Pose { rotation: Quat::IDENTITY, translation }
    }

    /// Head-local point → world.
    #[inline]
    pub fn transform_point(&self, p: Vec3) -> Vec3 {
        self.rotation * p + self.translation
    }

    /// World point → head-local.
    #[inline]
    pub fn inverse_transform_point(&self, p: Vec3) -> Vec3 {
        self.rotation.inverse() * (p - self.translation)
    }

    /// Interpolates between two poses (lerp of translation, slerp of rotation), so roots
    /// sweep along the head's real path across substeps instead of cutting through it.
    pub fn lerp(&self, other: &Pose, t: f32) -> Pose {
        Pose {
            rotation: self.rotation.slerp(other.rotation, t).normalize(),
            translation: self.translation.lerp(other.translation, t),
        }
    }

    /// True when every component is finite and the rotation is (close to) unit length.
    pub fn is_valid(&self) -> bool {
        self.translation.is_finite() && self.rotation.is_finite() && (self.rotation.length() - 1.0).abs() < 1e-3
    }
}

/// The smallest and largest coordinates of `points`, per axis (`MAX` and `MIN` for none).
pub(crate) fn bounds(points: &[Vec3]) -> (Vec3, Vec3) {
    points.iter().fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), &p| (lo.min(p), hi.max(p)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_midpoint() {
        let a = Pose::IDENTITY;
        let b = Pose::new(Quat::from_rotation_y(1.0), Vec3::new(1.0, 2.0, 3.0));
        let p = Vec3::new(0.3, -0.2, 0.5);
        assert!((b.inverse_transform_point(b.transform_point(p)) - p).length() < 1e-6);
        let mid = a.lerp(&b, 0.5);
        assert!((mid.translation - Vec3::new(0.5, 1.0, 1.5)).length() < 1e-6);
        assert!(mid.rotation.angle_between(Quat::from_rotation_y(0.5)) < 1e-4);
        assert!(!Pose::new(Quat::from_xyzw(0.0, 0.0, 0.0, 0.0), Vec3::ZERO).is_valid());
    }
}
