//! Part of the head that moves against the collider's frame: on a skinned character, the
//! skin blended between the head joint and another (the lower neck, bending as the head
//! turns). The baked [`HeadCollider`](super::HeadCollider) holds those triangles as they
//! were at bind pose; a [`SurfacePatch`] holds them as they are now, updated every step,
//! and particles are kept out of both.

use super::Contact;
use crate::math::Vec3;
use parry3d::query::PointQueryWithLocation;
use parry3d::shape::{Triangle, TrianglePointLocation};

/// Side of a bin of the patch's lookup grid, metres.
const CELL: f32 = 0.01;

/// A few triangles in head-local space whose corners move from step to step, with what a
/// closest-point query needs: per-face, per-edge and per-corner normals (a point closest to
/// an edge or a corner is inside where it lies behind the normals of all faces there) and
/// a grid of bins listing the triangles within [`Self::reach`] of each.
///
/// It is an open piece of surface: a point is tested against it only within `reach` of it,
/// and is inside where it lies behind the closest point's normal. Deeper points are the
/// baked collider's.
#[derive(Clone, Debug, Default)]
pub struct SurfacePatch {
    triangles: Vec<[u32; 3]>,
    positions: Vec<Vec3>,
    /// Per triangle, the triangle across each edge (AB, BC, CA), if any.
    across: Vec<[Option<u32>; 3]>,
    face_normals: Vec<Vec3>,
    corner_normals: Vec<Vec3>,
    reach: f32,
    origin: Vec3,
    dims: [usize; 3],
    /// Triangles per bin, bins x-fastest: `bins[starts[c]..starts[c + 1]]`.
    starts: Vec<u32>,
    bins: Vec<u32>,
}

/// A [`SurfacePatch`]'s data as [`SurfacePatch::resolve`] reads it.
#[derive(Clone, Copy, Debug)]
pub struct PatchParts<'a> {
    /// Corner indices per triangle.
    pub triangles: &'a [[u32; 3]],
    /// Corner positions, head-local.
    pub positions: &'a [Vec3],
    /// Per triangle, the triangle across each edge (AB, BC, CA), if any.
    pub across: &'a [[Option<u32>; 3]],
    /// Unit face normals (zero for a triangle without area).
    pub face_normals: &'a [Vec3],
    /// Angle-weighted unit corner normals.
    pub corner_normals: &'a [Vec3],
    /// How far from the surface the patch answers, metres.
    pub reach: f32,
    /// Side of a bin, metres.
    pub cell: f32,
    /// The lowest corner of the bins.
    pub origin: Vec3,
    /// Bins along x, y and z.
    pub dims: [usize; 3],
    /// Where each bin's list starts in `bins` (one more than there are bins), x fastest.
    pub starts: &'a [u32],
    /// The bins' triangle lists, one after another.
    pub bins: &'a [u32],
}

impl SurfacePatch {
    /// A patch of `triangles` over `positions`, answering queries up to `reach` metres from
    /// its surface (a collision thickness larger than that skips the patch).
    pub fn new(triangles: Vec<[u32; 3]>, positions: Vec<Vec3>, reach: f32) -> Self {
        let mut across = vec![[None; 3]; triangles.len()];
        for [(t0, e0), (t1, e1)] in crate::mesh::edge_pairs(&triangles) {
            across[t0 as usize][e0 as usize] = Some(t1);
            across[t1 as usize][e1 as usize] = Some(t0);
        }
        let mut patch = SurfacePatch { triangles, across, reach: reach.max(0.0), ..SurfacePatch::default() };
        patch.update(&positions);
        patch
    }

    /// How far from the surface the patch answers, metres.
    pub fn reach(&self) -> f32 {
        self.reach
    }

    /// The corners' positions now (head-local).
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// Everything [`Self::resolve`] reads, for a copy elsewhere (the GPU solver's).
    pub fn parts(&self) -> PatchParts<'_> {
        PatchParts {
            triangles: &self.triangles,
            positions: &self.positions,
            across: &self.across,
            face_normals: &self.face_normals,
            corner_normals: &self.corner_normals,
            reach: self.reach,
            cell: CELL,
            origin: self.origin,
            dims: self.dims,
            starts: &self.starts,
            bins: &self.bins,
        }
    }

    /// Moves the corners to `positions` (head-local, as many as before; otherwise, or if
    /// one is not finite, nothing changes), and rebuilds the normals and bins.
    pub fn update(&mut self, positions: &[Vec3]) {
        let fresh = self.positions.is_empty() && self.face_normals.is_empty();
        if !(fresh || positions.len() == self.positions.len()) || !positions.iter().all(|p| p.is_finite()) {
            return;
        }
        self.positions.clear();
        self.positions.extend_from_slice(positions);
        let corners = |t: &[u32; 3]| t.map(|v| positions[v as usize]);
        self.face_normals =
            self.triangles.iter().map(corners).map(|[a, b, c]| (b - a).cross(c - a).normalize_or_zero()).collect();
        // Angle-weighted corner normals (Bærentzen & Aanæs 2005).
        self.corner_normals = vec![Vec3::ZERO; positions.len()];
        for (t, normal) in self.triangles.iter().zip(&self.face_normals) {
            let p = corners(t);
            for k in 0..3 {
                let angle = (p[(k + 1) % 3] - p[k]).angle_between(p[(k + 2) % 3] - p[k]);
                if angle.is_finite() {
                    self.corner_normals[t[k] as usize] += *normal * angle;
                }
            }
        }
        self.corner_normals.iter_mut().for_each(|n| *n = n.normalize_or_zero());
        self.bin();
    }

    /// Lists each triangle in every bin its bounds, grown by `reach`, overlap.
    fn bin(&mut self) {
        let (low, high) = crate::math::bounds(&self.positions);
        self.origin = low - Vec3::splat(self.reach);
        let size = high - low + Vec3::splat(2.0 * self.reach);
        self.dims = size.to_array().map(|s| ((s / CELL).ceil() as usize).clamp(1, 256));
        let [nx, ny, nz] = self.dims;
        let cell_of = |p: Vec3| {
            let c = ((p - self.origin) / CELL).floor();
            [c.x as usize, c.y as usize, c.z as usize].map(|c| c.min(255))
        };
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); nx * ny * nz];
        for (t, tri) in self.triangles.iter().enumerate() {
            let p = tri.map(|v| self.positions[v as usize]);
            let (lo, hi) = crate::math::bounds(&p);
            let (lo, hi) = (cell_of(lo - Vec3::splat(self.reach)), cell_of(hi + Vec3::splat(self.reach)));
            for z in lo[2]..=hi[2].min(nz - 1) {
                for y in lo[1]..=hi[1].min(ny - 1) {
                    for x in lo[0]..=hi[0].min(nx - 1) {
                        lists[(z * ny + y) * nx + x].push(t as u32);
                    }
                }
            }
        }
        self.starts = Vec::with_capacity(lists.len() + 1);
        self.bins.clear();
        self.starts.push(0);
        for list in lists {
            self.bins.extend(list);
            self.starts.push(self.bins.len() as u32);
        }
    }

    /// The triangles that may lie within `reach` of `p`.
    fn candidates(&self, p: Vec3) -> &[u32] {
        let c = (p - self.origin) / CELL;
        let [nx, ny, nz] = self.dims;
        if !(c.cmpge(Vec3::ZERO).all() && c.x < nx as f32 && c.y < ny as f32 && c.z < nz as f32) {
            return &[];
        }
        let cell = (c.z as usize * ny + c.y as usize) * nx + c.x as usize;
        &self.bins[self.starts[cell] as usize..self.starts[cell + 1] as usize]
    }

    /// If `p` (head-local) is inside the patch's side of the surface or closer than
    /// `thickness` to it, within [`Self::reach`], where to move it: `thickness` out along
    /// the normal at the closest point.
    pub fn resolve(&self, p: Vec3, thickness: f32) -> Option<Contact> {
        if thickness > self.reach {
            return None;
        }
        let mut best: Option<(f32, u32, Vec3, TrianglePointLocation)> = None;
        for &t in self.candidates(p) {
            let [a, b, c] = self.triangles[t as usize].map(|v| self.positions[v as usize]);
            let (projection, location) = Triangle::new(a, b, c).project_local_point_and_get_location(p, false);
            let distance = (p - projection.point).length_squared();
            if best.is_none_or(|(d, ..)| distance < d) {
                best = Some((distance, t, projection.point, location));
            }
        }
        let (distance, t, closest, location) = best?;
        let distance = distance.sqrt();
        if distance > self.reach {
            return None;
        }
        let normal = self.feature_normal(t, location);
        let offset = p - closest;
        let signed = if offset.dot(normal) < 0.0 { -distance } else { distance };
        if signed >= thickness || normal == Vec3::ZERO {
            return None;
        }
        let out = if distance > 1e-7 { offset / signed } else { normal };
        Some(Contact { position: closest + out * thickness, normal: out, depth: thickness - signed })
    }

    /// The outward normal of the face, edge or corner of triangle `t` at `location`.
    fn feature_normal(&self, t: u32, location: TrianglePointLocation) -> Vec3 {
        let face = self.face_normals[t as usize];
        match location {
            TrianglePointLocation::OnVertex(k) => self.corner_normals[self.triangles[t as usize][k as usize] as usize],
            TrianglePointLocation::OnEdge(e, _) => match self.across[t as usize][e as usize] {
                Some(other) => (face + self.face_normals[other as usize]).normalize_or(face),
                None => face,
            },
            _ => face,
        }
    }
}

#[cfg(test)]
mod tests;
