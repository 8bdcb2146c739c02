//! Extra collision shapes in world space: spheres and capsules for neck and shoulders.

use super::Contact;
use crate::math::Vec3;

/// A simple world-space collider besides the head mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ExtraCollider {
    /// A ball.
    Sphere {
        /// World-space centre.
        center: Vec3,
        /// Radius, metres.
        radius: f32,
    },
    /// A segment swept by a ball.
    Capsule {
        /// One end of the axis, world space.
        a: Vec3,
        /// The other end of the axis, world space.
        b: Vec3,
        /// Radius, metres.
        radius: f32,
    },
}

impl ExtraCollider {
    /// The same shape moved by `offset` (into the space the strands are simulated in).
    pub fn translated(self, offset: Vec3) -> Self {
        match self {
            ExtraCollider::Sphere { center, radius } => ExtraCollider::Sphere { center: center + offset, radius },
            ExtraCollider::Capsule { a, b, radius } => ExtraCollider::Capsule { a: a + offset, b: b + offset, radius },
        }
    }

    /// If `p` is closer than `thickness` to the surface, where to move it.
    #[inline]
    pub fn resolve(&self, p: Vec3, thickness: f32) -> Option<Contact> {
        let (center, radius) = match *self {
            ExtraCollider::Sphere { center, radius } => (center, radius),
            ExtraCollider::Capsule { a, b, radius } => {
                let ab = b - a;
                let t = ((p - a).dot(ab) / ab.length_squared().max(1e-12)).clamp(0.0, 1.0);
                (a + ab * t, radius)
            }
        };
        let offset = p - center;
        let distance = offset.length();
        let reach = radius + thickness;
        if distance.is_nan() || distance >= reach {
            return None;
        }
        let normal = if distance > 1e-7 { offset / distance } else { Vec3::Y };
        Some(Contact { position: center + normal * reach, normal, depth: reach - distance })
    }
}

#[cfg(test)]
mod tests;
