//! Where a head's inside is, apart from the rest of its collider: what the hair–hair grid
//! needs to know of the head, small enough to keep beside a GPU groom.

use super::{DistanceGrid, HeadCollider};
use crate::math::Vec3;

/// The inside of a [`HeadCollider`]'s head, as its baked distance grid knows it (the
/// right sign everywhere, the exact distance near the surface). The hair–hair grid
/// ([`VolumeGrid`](crate::solver::VolumeGrid)) marks its cells inside the head with it:
/// hair piled on the skin is pushed out along the skin and off it, not into the head.
#[derive(Clone, Debug)]
pub struct HeadInterior {
    grid: DistanceGrid,
    /// The collider's centre ([`HeadCollider::centre`]), the grid's origin.
    centre: Vec3,
    /// The collider it was taken from ([`Self::collider`]).
    collider: u32,
}

impl HeadInterior {
    /// Whether the head-local point `p` lies inside the head (false beyond the grid, which
    /// reaches past the head on every side).
    pub fn contains(&self, p: Vec3) -> bool {
        self.grid.sample(p - self.centre).is_some_and(|d| d < 0.0)
    }

    /// A number that names the collider it was taken from, the same for its clones: a grid
    /// made with it is made again for another head.
    pub fn collider(&self) -> u32 {
        self.collider
    }
}

impl HeadCollider {
    /// The head's inside, for the hair–hair grid ([`HeadInterior`]).
    pub fn interior(&self) -> HeadInterior {
        HeadInterior { grid: self.grid.clone(), centre: self.centre, collider: self.id }
    }

    /// A number that names this collider, the same for its clones ([`HeadInterior::collider`]).
    pub fn id(&self) -> u32 {
        self.id
    }
}
