//! Collision: the head mesh (BVH + baked distance grid) and simple extra shapes.
//!
//! The head is tested in head-local space, so the collider is built once per mesh and
//! never rebuilt as the head moves. Per particle, the distance grid answers "far from the
//! head" with one trilinear lookup; only particles near the surface pay for the exact BVH
//! query, which also gives the closest point and hence the surface normal to push along.
//! A particle's [`ContactHint`] lets most queries skip even that: a resting particle
//! re-proves its last triangle with one projection, a far one stays inside the empty
//! ball the grid showed it last time.

mod candidates;
mod crossing;
mod distance_grid;
mod flat_bvh;
mod interior;
mod patch;
mod sag;
mod shapes;
mod triangles;

pub use distance_grid::DistanceGrid;
pub use flat_bvh::{FlatBvh, FlatBvhNode};
pub use interior::HeadInterior;
pub use patch::{PatchParts, SurfacePatch};
pub use shapes::ExtraCollider;

use crate::math::Vec3;
use crate::mesh::{HeadMesh, MeshError};
use candidates::{CandidateGrid, Closest, Near};
use crossing::CrossingLists;
use parry3d::query::{PointQueryWithLocation, Ray, RayCast};
use parry3d::shape::{TriMesh, TriMeshFlags, TrianglePointLocation};
pub use sag::SagCells;
use sag::SagGrid;
use std::sync::atomic::{AtomicU32, Ordering};
use triangles::{Certificate, FlatTriangles};

/// Distance-grid cells along the longest side of the head's bounding box.
pub const DEFAULT_GRID_RESOLUTION: u32 = 64;

/// The grid resolutions [`HeadCollider::new`] accepts. Below 8 cells the grid rejects
/// almost nothing and every query goes to the triangles; at 256 the grid alone holds up to
/// 256³ distances (64 MB), and finer buys nothing for a head.
pub const GRID_RESOLUTIONS: std::ops::RangeInclusive<u32> = 8..=256;

/// The most triangles a head should have for its collider to bake in a few seconds: the
/// bake's time and memory grow with the triangles (figures in `docs/collision.md`), and a
/// collider needs no finer detail than about a millimetre: decimate the collision mesh to
/// this.
pub const BAKE_TRIANGLE_BUDGET: usize = 350_000;

/// Why a collider cannot be built.
#[derive(Clone, Debug, PartialEq)]
pub enum ColliderError {
    /// The mesh is unusable.
    Mesh(MeshError),
    /// The grid resolution is outside [`GRID_RESOLUTIONS`].
    GridResolution(u32),
    /// The mesh encloses negative volume: it is wound inside out, and a collider built
    /// from it would call the inside outside. [`HeadMesh::repaired`] turns it over.
    InsideOut {
        /// The volume it encloses, m³ (negative).
        volume: f32,
    },
}

impl std::fmt::Display for ColliderError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ColliderError::Mesh(e) => e.fmt(f),
            ColliderError::GridResolution(r) => write!(
                f,
                "a collider grid of {r} cells per side was asked for; use {} to {} (default {DEFAULT_GRID_RESOLUTION})",
                GRID_RESOLUTIONS.start(),
                GRID_RESOLUTIONS.end()
            ),
            ColliderError::InsideOut { volume } => write!(
                f,
                "the head mesh is wound inside out (it encloses {volume} m³); turn its triangles over, \
                 or build it with HeadMesh::repaired"
            ),
        }
    }
}

impl std::error::Error for ColliderError {}

impl From<MeshError> for ColliderError {
    fn from(e: MeshError) -> Self {
        ColliderError::Mesh(e)
    }
}

/// A contact found by a collision query: where to put the particle and which way is out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    /// The particle position moved out to `thickness` above the surface.
    pub position: Vec3,
    /// Unit outward surface normal at the contact.
    pub normal: Vec3,
    /// How far below `thickness` above the surface the particle was (> 0).
    pub depth: f32,
}

/// What [`HeadCollider::resolve_measuring`] found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Resolution {
    /// The point is closer than the thickness to the surface, or inside: where to move it.
    Contact(Contact),
    /// No contact: the surface is at least this far from the point (metres, never less
    /// than the thickness asked for).
    Clear(f32),
}

/// What [`HeadCollider`]'s exact near query reads, as plain numbers (from
/// [`HeadCollider::near_query_tables`]), for a copy of the query on another processor.
///
/// Near the surface (where the distance grid cannot reject a point), the collider finds
/// the closest triangle among its grid cell's candidates: sorted by their distance `D`
/// from the cell's centre `c`, a candidate is skipped when `D − |p − c|`, or its
/// tangent-plane bound `D + g · (p − c)`, is already beyond the best distance found (each
/// less [`Self::slack`]), and the walk stops at the first block whose nearest candidate
/// is. The sign comes from the pseudo-normal of the feature the closest point lies on.
#[derive(Clone, Debug)]
pub struct NearQueryTables {
    /// Per triangle of the collider's mesh (relative to [`HeadCollider::centre`], without
    /// duplicate corners or triangles without area): corners a, b, c; the unit face
    /// normal; the edges' pseudo-normals (ab, bc, ca); the corners' pseudo-normals (a, b,
    /// c). A point closest to a feature is inside where it lies on or behind the feature's
    /// normal; zero normals (a mesh parry could not orient) read every point as outside.
    pub triangles: Vec<[Vec3; 10]>,
    /// Per grid cell, by the index of its lowest sample in [`DistanceGrid::values`]: the
    /// cell's first block, shifted left by [`Self::count_bits`], with its block count in
    /// the low bits; `u32::MAX` for a cell without a list (deep inside the head, or too many
    /// candidates), where the collider walks its BVH.
    pub cell_ranges: Vec<u32>,
    /// The lists' candidates, four per block, nearest the cell's centre first: their
    /// distances from the centre (infinity in a list's padding lanes), the unit vectors
    /// from their closest points to the centre (x, then y, then z), as f32 bits, four
    /// words each; then the four triangles.
    pub blocks: Vec<[u32; 20]>,
    /// The low bits of a cell range that count its blocks.
    pub count_bits: u32,
    /// Taken off both skip bounds for f32 rounding, metres.
    pub slack: f32,
    /// A hierarchy over [`Self::triangles`], for what the lists do not answer: the closest
    /// point deep inside, and where a segment crosses the surface.
    pub bvh: FlatBvh,
}

/// What [`HeadCollider::rise_under`] reads, as plain numbers (from
/// [`HeadCollider::rise_table`]). For a segment of length `L` whose middle lies in cell `c`
/// (located by [`Self::cells`]), with `[κ, f]` the cell's values: infinite where `L` exceeds
/// [`Self::max_length`] or `κ L` exceeds [`Self::max_turn`], else `κ L² / 8 + f`.
#[derive(Clone, Debug)]
pub struct RiseTable {
    /// Where the cells lie, head-local.
    pub cells: SagCells,
    /// Cells along x, y and z.
    pub dims: [usize; 3],
    /// Per cell, x fastest: the largest convex curvature near it, 1/m, and the largest
    /// facet term, m.
    pub values: Vec<[f32; 2]>,
    /// Segments longer than this, metres, get no bound.
    pub max_length: f32,
    /// Where the surface's normal turns more than this many radians under a segment, no
    /// bound.
    pub max_turn: f32,
}

/// The head as a collision shape, in head-local space: a parry3d `TriMesh` (its BVH
/// answers exact closest-point queries) and a signed distance grid baked from it.
pub struct HeadCollider {
    /// The centre of the mesh's bounds, head-local. Everything below is baked relative to
    /// it, so a mesh whose vertices sit far from its own origin keeps `f32` precision.
    centre: Vec3,
    mesh: TriMesh,
    grid: DistanceGrid,
    candidates: CandidateGrid,
    triangles: FlatTriangles,
    /// How far the surface may rise under a segment near it, per region.
    sag: SagGrid,
    /// The triangles segments near sharp features can cross, per region of `sag`.
    crossing: CrossingLists,
    /// Tells colliders apart, so a hint measured on one is not trusted by another.
    id: u32,
}

/// `count` random segments near `head` (ears included), from `seed`: from 0–6 mm off a
/// random point of a triangle, a segment up to 2.5 cm long in any direction; or (every
/// other one) a chord up to 2.5 cm long across the surface, centred 0–2 mm above it, which
/// crosses wherever the surface bends more than that. For the tests of the segment
/// filters.
#[cfg(test)]
pub(crate) fn segments_near(head: &HeadMesh, seed: u64, count: usize) -> Vec<(Vec3, Vec3)> {
    let mut rng = crate::groom::SplitMix64::new(seed);
    let mut unit = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    (0..count)
        .map(|k| {
            let t = k * 7919 % head.triangles.len();
            let [u, v, _] = unit().to_array();
            let bary = if u + v <= 1.0 { [u, v, 1.0 - u - v] } else { [1.0 - u, 1.0 - v, u + v - 1.0] };
            let [height, length, _] = unit().to_array();
            let (normal, on_surface) = (head.normal_at(t, bary), head.point_at(t, bary));
            let direction = (unit() * 2.0 - Vec3::ONE).normalize_or(Vec3::X);
            if k % 2 == 0 {
                let a = on_surface + normal * height * 0.006;
                (a, a + direction * length * 0.025)
            } else {
                let centre = on_surface + normal * height * 0.002;
                let across = (direction - normal * direction.dot(normal)).normalize_or(normal.any_orthonormal_vector());
                (centre - across * length * 0.0125, centre + across * length * 0.0125)
            }
        })
        .collect()
}

/// Per-particle memory of its last collision query, which lets the next query skip work
/// (see [`HeadCollider::resolve_hinted`]): a particle resting on the head remembers the
/// triangle it touched (and, in a crease, how far the surfaces around it were), one away
/// from it a ball around the spot it was tested at that holds no surface. Only a
/// shortcut: a stale or foreign hint changes no result.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactHint(Hint);

#[derive(Clone, Copy, Debug, Default, PartialEq)]
enum Hint {
    #[default]
    None,
    /// The closest triangle at the last full search, which was at `at`; every triangle of
    /// collider `collider` rising above its plane was at least `gap` from there.
    Touching { triangle: u32, at: Vec3, gap: f32, collider: u32 },
    /// No surface of collider `collider` within `distance` of the head-local point `at`.
    Clear { at: Vec3, distance: f32, collider: u32 },
}

impl ContactHint {
    /// Nothing remembered.
    pub const NONE: ContactHint = ContactHint(Hint::None);
}

impl HeadCollider {
    /// Builds the BVH and bakes the distance grid (`resolution` cells along the longest
    /// side, within [`GRID_RESOLUTIONS`]). The mesh should be closed and wound outward: one
    /// that encloses negative volume (wound inside out) is refused
    /// ([`ColliderError::InsideOut`]; [`HeadMesh::repaired`] turns it over). On an open
    /// mesh the inside test still works locally, near each surface, through parry's
    /// pseudo-normals.
    /// Triangles without area are left out: their normal is noise and would read points
    /// far away as inside.
    pub fn new(head: &HeadMesh, resolution: u32) -> Result<Self, ColliderError> {
        if !GRID_RESOLUTIONS.contains(&resolution) {
            return Err(ColliderError::GridResolution(resolution));
        }
        head.validate()?;
        let volume = head.signed_volume();
        if volume < 0.0 {
            return Err(ColliderError::InsideOut { volume });
        }
        let triangles: Vec<[u32; 3]> =
            head.triangles.iter().copied().filter(|t| !crate::mesh::is_degenerate(head.corners(t))).collect();
        let flags =
            TriMeshFlags::ORIENTED | TriMeshFlags::MERGE_DUPLICATE_VERTICES | TriMeshFlags::DELETE_DEGENERATE_TRIANGLES;
        let (low, high) = crate::math::bounds(&head.positions);
        let centre = 0.5 * (low + high);
        let positions: Vec<Vec3> = head.positions.iter().map(|&p| p - centre).collect();
        let mesh = TriMesh::with_flags(positions.clone(), triangles, flags).map_err(|_| MeshError::Degenerate)?;
        if mesh.indices().is_empty() {
            return Err(MeshError::Degenerate.into());
        }
        let grid = DistanceGrid::bake(&positions, resolution, |p| signed_distance_exact(&mesh, p));
        let candidates = CandidateGrid::bake(&grid, &mesh);
        let triangles = FlatTriangles::bake(&mesh);
        let sag = SagGrid::bake(mesh.vertices(), mesh.indices());
        let crossing = CrossingLists::bake(&sag, mesh.vertices(), mesh.indices());
        static NEXT_ID: AtomicU32 = AtomicU32::new(0);
        let id = NEXT_ID.fetch_add(1, Ordering::Relaxed);
        Ok(HeadCollider { centre, mesh, grid, candidates, triangles, sag, crossing, id })
    }

    /// The centre of the mesh's bounds, head-local: the origin of [`Self::grid`].
    pub fn centre(&self) -> Vec3 {
        self.centre
    }

    /// The baked distance grid, relative to [`Self::centre`].
    pub fn grid(&self) -> &DistanceGrid {
        &self.grid
    }

    /// The exact near query's tables as plain numbers, for a copy of the query elsewhere
    /// (the GPU solver's), which then finds the same closest points as this collider.
    pub fn near_query_tables(&self) -> NearQueryTables {
        let pseudo = self.mesh.pseudo_normals_if_oriented();
        let triangles = (0..self.mesh.indices().len())
            .map(|t| {
                let corners = self.mesh.indices()[t].map(|v| self.mesh.vertices()[v as usize]);
                let face = self.triangles.get(t as u32).normal().unwrap_or(Vec3::ZERO);
                let edges = pseudo.and_then(|p| p.edges_pseudo_normal.get(t).copied()).unwrap_or([Vec3::ZERO; 3]);
                let vertex = |v: u32| pseudo.and_then(|p| p.vertices_pseudo_normal.get(v as usize).copied());
                let at_corners = self.mesh.indices()[t].map(|v| vertex(v).unwrap_or(Vec3::ZERO));
                let [[a, b, c], [e0, e1, e2], [v0, v1, v2]] = [corners, edges, at_corners];
                [a, b, c, face, e0, e1, e2, v0, v1, v2]
            })
            .collect::<Vec<[Vec3; 10]>>();
        let bvh = FlatBvh::new(&triangles.iter().map(|t| [t[0], t[1], t[2]]).collect::<Vec<_>>());
        let (cell_ranges, blocks) = self.candidates.words();
        NearQueryTables {
            triangles,
            cell_ranges,
            blocks,
            count_bits: candidates::COUNT_BITS,
            slack: candidates::SLACK,
            bvh,
        }
    }

    /// [`Self::rise_under`]'s table as plain numbers, for a copy of the bound elsewhere (the
    /// GPU solver's).
    pub fn rise_table(&self) -> RiseTable {
        RiseTable {
            cells: self.rise_cells(),
            dims: self.sag.dims(),
            values: self.sag.values().iter().map(|&(convex, facet)| [convex, facet]).collect(),
            max_length: 2.0 * sag::REACH,
            max_turn: sag::MAX_TURN,
        }
    }

    /// Exact signed distance from a head-local point to the surface (negative inside).
    pub fn signed_distance(&self, p: Vec3) -> f32 {
        signed_distance_exact(&self.mesh, p - self.centre)
    }

    /// If `p` (head-local) is closer than `thickness` to the surface, or inside the head,
    /// returns where to move it: `thickness` out along the surface normal.
    ///
    /// The grid rejects far points with one lookup. Near the surface an exact query finds
    /// the closest point (a short per-cell candidate list baked from the BVH, or the BVH
    /// itself); the push follows the normal there, not the line from the head's
    /// centre, which would push particles into an ear instead of out of it.
    #[inline]
    pub fn resolve(&self, p: Vec3, thickness: f32) -> Option<Contact> {
        let mut no_hint = ContactHint::NONE;
        self.resolve_hinted(p, thickness, &mut no_hint)
    }

    /// [`resolve`](Self::resolve) for a particle that keeps a [`ContactHint`] between
    /// queries; the same result, to within 1 µm (the certificate's plane tolerance).
    ///
    /// A particle resting on the scalp touches the same triangle substep after substep. If
    /// it lies above that triangle's face within the triangle's baked clearance (or beside
    /// it, over a convex edge, within the edge's), no other triangle can be closer (the
    /// proof is in `collide/triangles.rs`), so one projection settles it without the grid
    /// or the candidate list. Where the clearance is too small (a crease by an ear), the
    /// hint carries the gap the last search measured to the triangles rising above that
    /// face, and the same projection settles the particle while it stays within that gap
    /// of where it was. A particle the grid found far from the head remembers where, and
    /// how far: until it has moved that far, less the thickness, it cannot touch anything,
    /// and it is answered without any lookup.
    #[inline]
    pub fn resolve_hinted(&self, p: Vec3, thickness: f32, hint: &mut ContactHint) -> Option<Contact> {
        match self.resolve_measuring(p, thickness, hint) {
            Resolution::Contact(contact) => Some(contact),
            Resolution::Clear(_) => None,
        }
    }

    /// [`Self::resolve_hinted`] that also says, when there is no contact, how far the
    /// surface is at least: the distance it measured, or the empty ball it proved (never
    /// less than `thickness`). Whole-segment collision uses it to clear most segments
    /// without looking at the mesh again.
    #[inline(always)]
    pub fn resolve_measuring(&self, p: Vec3, thickness: f32, hint: &mut ContactHint) -> Resolution {
        match self.resolve_centred(p - self.centre, thickness, hint) {
            Resolution::Contact(contact) => {
                Resolution::Contact(Contact { position: contact.position + self.centre, ..contact })
            }
            clear => clear,
        }
    }

    /// The reference's response: like [`Self::resolve_hinted`], but the particle leaves
    /// along the ray from `from` (head-local, inside the head) through it, not along the
    /// surface normal. Inside the head it goes to where that ray leaves the surface, plus
    /// `thickness` along the ray; within the thickness shell it moves along the ray by the
    /// shell's depth. The contact's normal is the ray's direction.
    ///
    /// On a convex head both agree; where the surface is not star-shaped around `from`
    /// (behind an ear, under the chin) the ray leaves through another part of the surface
    /// than the one the particle came through, and may leave the particle in a fold.
    pub fn resolve_along_ray(&self, p: Vec3, thickness: f32, hint: &mut ContactHint, from: Vec3) -> Option<Contact> {
        match self.resolve_measuring_along_ray(p, thickness, hint, from) {
            Resolution::Contact(contact) => Some(contact),
            Resolution::Clear(_) => None,
        }
    }

    /// [`Self::resolve_measuring`] with [`Self::resolve_along_ray`]'s response.
    pub fn resolve_measuring_along_ray(
        &self,
        p: Vec3,
        thickness: f32,
        hint: &mut ContactHint,
        from: Vec3,
    ) -> Resolution {
        match self.resolve_measuring(p, thickness, hint) {
            Resolution::Contact(contact) => Resolution::Contact(self.along_ray(contact, p, thickness, from)),
            clear => clear,
        }
    }

    /// Turns the normal response `contact` for `p` into the push along the ray from `from`.
    fn along_ray(&self, contact: Contact, p: Vec3, thickness: f32, from: Vec3) -> Contact {
        let Some(direction) = (p - from).try_normalize() else { return contact };
        let position = if contact.depth > thickness {
            // Inside: out along the ray to the surface (the first crossing from `p`).
            let ray = Ray::new(p - self.centre, direction);
            match self.mesh.cast_local_ray(&ray, f32::MAX, false) {
                Some(t) => p + direction * (t + thickness),
                // A ray grazing an edge can slip between triangles: push along the normal.
                None => return contact,
            }
        } else {
            p + direction * contact.depth
        };
        Contact { position, normal: direction, depth: contact.depth }
    }

    /// How far the surface can rise above a straight segment of `length` around `middle`
    /// (head-local), from the curvature baked around it (`collide/sag.rs`): where both ends
    /// are farther than this from the surface, the segment between them stays outside the
    /// head and [`Self::segment_crossing`] need not be asked. A few tenths of a millimetre
    /// for a segment of hair over the skull; infinite by an ear's rim, where only the exact
    /// test can tell.
    pub fn rise_under(&self, middle: Vec3, length: f32) -> f32 {
        self.sag.bound_in(self.rise_cells().locate(middle), length)
    }

    /// Where the cells of [`Self::rise_under`]'s table lie (head-local), for callers that
    /// locate many segments at once and look each up with [`Self::rise_in_cell`].
    pub fn rise_cells(&self) -> SagCells {
        let cells = self.sag.cells();
        SagCells { origin: cells.origin + self.centre, ..cells }
    }

    /// [`Self::rise_under`] for a segment of `length` whose middle lies at `cell`
    /// ([`SagCells::locate`] on [`Self::rise_cells`]).
    #[inline]
    pub fn rise_in_cell(&self, cell: Vec3, length: f32) -> f32 {
        self.sag.bound_in(cell, length)
    }

    /// Where the segment `a`–`b` (head-local) runs through the head: the distances from `a`
    /// along it to where it first enters and last leaves the surface, or `None` when it
    /// crosses no triangle. For a segment whose ends are both outside, a crossing means it
    /// cuts through a thin part (an ear's rim). By a sharp feature a segment up to 2.5 cm
    /// long is tested against the triangles listed in reach (`collide/crossing.rs`);
    /// elsewhere by a ray through the BVH each way.
    pub fn segment_crossing(&self, a: Vec3, b: Vec3) -> Option<(f32, f32)> {
        let length = (b - a).length();
        let direction = (b - a).try_normalize()?;
        let (a, b) = (a - self.centre, b - self.centre);
        // Near a sharp feature, the few triangles in reach (`collide/crossing.rs`).
        match self.crossing.crossing(self.sag.index_of(0.5 * (a + b)), a, b) {
            Ok(crossing) => crossing.map(|(enters, leaves)| (enters * length, leaves * length)),
            Err(()) => self.bvh_crossing(a, b, length, direction),
        }
    }

    /// [`Self::segment_crossing`] through the BVH, for `a`–`b` relative to
    /// [`Self::centre`], `length` long along `direction`.
    fn bvh_crossing(&self, a: Vec3, b: Vec3, length: f32, direction: Vec3) -> Option<(f32, f32)> {
        let enters = self.mesh.cast_local_ray(&Ray::new(a, direction), length, false)?;
        let leaves = self.mesh.cast_local_ray(&Ray::new(b, -direction), length, false).map_or(enters, |t| length - t);
        Some((enters, leaves.max(enters)))
    }

    /// [`Self::resolve_measuring`] for a point relative to [`Self::centre`].
    #[inline(always)]
    fn resolve_centred(&self, p: Vec3, thickness: f32, hint: &mut ContactHint) -> Resolution {
        match hint.0 {
            Hint::Touching { triangle, at, gap, collider, .. } => {
                // The gap was measured on one collider's triangles; the clearance is the
                // triangle's own and holds on whatever mesh asks.
                let gap = || if collider == self.id { gap - (p - at).length() } else { 0.0 };
                match self.triangles.certify(triangle, p, gap) {
                    Certificate::Closest(certified) => {
                        return contact(certified.point, certified.normal, certified.distance, thickness);
                    }
                    // Lifted off the face (or the ridge), too high to name the closest point,
                    // and too high to touch anything.
                    Certificate::Beyond(distance) if distance >= thickness => return Resolution::Clear(distance),
                    // Over the face (or the ridge), too high for its certificates and too low
                    // to be clear: the neighbouring faces cannot settle it either (across a
                    // convex edge the point is not over them, and beside a concave one they
                    // have no clearance), so straight to the search.
                    Certificate::Beyond(_) => return self.resolve_searching(p, thickness, hint),
                    Certificate::Unsettled => {}
                }
                // Slid onto a neighbouring face: its own certificate may hold.
                if let Some((neighbour, certified)) = self.triangles.certify_neighbours(triangle, p) {
                    hint.0 = Hint::Touching { triangle: neighbour, at: p, gap: 0.0, collider: self.id };
                    return contact(certified.point, certified.normal, certified.distance, thickness);
                }
            }
            // Moved less than the clearance it had, minus the thickness: still no contact.
            // (The ball belongs to the mesh it was measured on; a triangle hint needs no such
            // check, because the certificate proves itself on whatever mesh asks.)
            Hint::Clear { at, distance, collider } => {
                let left = distance - (p - at).length();
                if collider == self.id && thickness < left {
                    return Resolution::Clear(left);
                }
            }
            Hint::None => {}
        }
        self.resolve_searching(p, thickness, hint)
    }

    /// [`Self::resolve_centred`] where the hint settles nothing: the grid, then the
    /// candidate list or the BVH, and a new hint. Kept out of line, so that the hinted
    /// answers most particles get stay small enough to inline into the solver's loop.
    #[inline(never)]
    fn resolve_searching(&self, p: Vec3, thickness: f32, hint: &mut ContactHint) -> Resolution {
        hint.0 = Hint::None;
        let Some(at) = self.grid.locate(p) else {
            // Outside the grid: at least as far from the mesh as from its bounding box.
            let bounds = self.mesh.local_aabb();
            let outside = (bounds.mins - p).max(p - bounds.maxs).max(Vec3::ZERO);
            let distance = outside.length().max(thickness);
            hint.0 = Hint::Clear { at: p, distance, collider: self.id };
            return Resolution::Clear(distance);
        };
        let approx = self.grid.sample_at(at);
        let error = self.grid.max_error();
        if approx > thickness + error {
            hint.0 = Hint::Clear { at: p, distance: approx - error, collider: self.id };
            return Resolution::Clear(approx - error);
        }
        // Where the grid proves `p` outside, the closest triangle is within `approx + error`;
        // inside or unsure, the search has no bound. Either way it finds the closest
        // triangle, which becomes the hint for the next query.
        let outside = approx > error;
        let reach = if outside { approx + error } else { f32::INFINITY };
        // Near the surface the decision is exact: the cell's candidate list holds every
        // triangle that can be closest; without one, ask the BVH.
        let closest = match self.candidates.closest(&self.triangles, &self.mesh, p, at, reach) {
            Near::Closest(closest) => closest,
            Near::Beyond => return Resolution::Clear(thickness),
            // `reach`, not the grid's value, bounds the search inside: beyond the grid's exact
            // band that value only bounds the distance from below.
            Near::Unlisted => match self.closest_by_bvh(p, reach + thickness) {
                Some(closest) => closest,
                None => return Resolution::Clear(thickness),
            },
        };
        let offset = p - closest.point;
        let distance = offset.length();
        let signed = if closest.inside { -distance } else { distance };
        hint.0 = Hint::Touching { triangle: closest.triangle, at: p, gap: closest.gap, collider: self.id };
        if signed >= thickness {
            return Resolution::Clear(signed);
        }
        // Outward normal. Over a face it is the face's (the offset's direction is only
        // rounding when the point sits on the surface); off an edge or a corner it points
        // away from the surface outside, towards it inside.
        let face_normal = self.triangles.get(closest.triangle).normal();
        let normal = match face_normal {
            Some(face) if closest.on_face => face,
            _ if signed.abs() > 1e-7 => offset / signed,
            _ => face_normal.unwrap_or(Vec3::Y),
        };
        contact(closest.point, normal, signed, thickness)
    }

    /// The closest point by a BVH walk; the true distance is within `max_dist`.
    fn closest_by_bvh(&self, p: Vec3, max_dist: f32) -> Option<Closest> {
        let (proj, (triangle, location)) =
            self.mesh.project_local_point_and_get_location_with_max_dist(p, false, max_dist)?;
        let (point, inside, on_face) =
            (proj.point, proj.is_inside, matches!(location, TrianglePointLocation::OnFace(..)));
        Some(Closest { point, triangle, inside, on_face, gap: 0.0 })
    }
}

/// The contact for a point `signed` distance from its closest surface point `on_surface`,
/// along the outward `normal`, if that is nearer than `thickness`.
#[inline]
fn contact(on_surface: Vec3, normal: Vec3, signed: f32, thickness: f32) -> Resolution {
    if signed < thickness {
        Resolution::Contact(Contact { position: on_surface + normal * thickness, normal, depth: thickness - signed })
    } else {
        Resolution::Clear(signed)
    }
}

fn signed_distance_exact(mesh: &TriMesh, p: Vec3) -> f32 {
    let (proj, _) = mesh.project_local_point_and_get_location(p, false);
    let distance = (p - proj.point).length();
    if proj.is_inside { -distance } else { distance }
}

#[cfg(test)]
mod tests;
