//! Extra colliders for hair besides the head: spheres and capsules (neck, shoulders).

use crate::convert::to_sim;
use bevy::prelude::*;
use hair_sim::collide::ExtraCollider;

/// A simple shape hair collides with, placed by this entity's [`GlobalTransform`]
/// (its largest scale axis scales the radius).
///
/// Scope: a collider on a top-level entity touches every groom. A collider inside a
/// hierarchy (a child of a character, of its shoulder bone…) touches only the grooms of
/// that hierarchy, those whose head has the same root ancestor, so one character's
/// shoulders never push another character's hair.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// // Shoulders under a head, children of it so they touch only its hair.
/// fn shoulders(mut commands: Commands, heads: Query<Entity, Added<HairGroom>>) {
///     for head in &heads {
///         commands.entity(head).with_child((
///             HairCollider::Capsule { radius: 0.06, half_length: 0.15 },
///             Transform::from_xyz(0.0, -0.25, 0.0).with_rotation(Quat::from_rotation_z(std::f32::consts::FRAC_PI_2)),
///         ));
///     }
/// }
/// ```
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Component)]
#[require(Transform)]
pub enum HairCollider {
    /// A ball around the entity's origin.
    Sphere {
        /// Radius, metres.
        radius: f32,
    },
    /// A capsule along the entity's local Y axis.
    Capsule {
        /// Radius, metres.
        radius: f32,
        /// Half the length of the axis segment, metres.
        half_length: f32,
    },
}

impl HairCollider {
    /// This collider in world space, for the solver.
    pub(crate) fn to_world(self, transform: &GlobalTransform) -> ExtraCollider {
        let scale = transform.scale().abs().max_element();
        match self {
            HairCollider::Sphere { radius } => {
                ExtraCollider::Sphere { center: to_sim(transform.translation()), radius: radius * scale }
            }
            HairCollider::Capsule { radius, half_length } => ExtraCollider::Capsule {
                a: to_sim(transform.transform_point(Vec3::NEG_Y * half_length)),
                b: to_sim(transform.transform_point(Vec3::Y * half_length)),
                radius: radius * scale,
            },
        }
    }
}
