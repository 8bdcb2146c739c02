//! An inside test that shares nothing with the collider: ray parity over the mesh's own
//! triangles, depth as the exact distance to the nearest of them, and segment–triangle
//! crossings. It is what tests (here and in the plugin) check the solver's "never inside"
//! promise with, so it must not inherit the collider's distance grid, BVH or certificates.
//!
//! Rays run along +X (tilted a hair, so they miss edges and vertices); the triangles are
//! binned by their extent across the ray, so one query visits a column of the mesh, not
//! all of it.

use super::HeadMesh;
use crate::math::Vec3;

/// The ray directions of the parity test: along +X, each tilted a hair differently. A ray
/// through an edge or a vertex counts it twice (or not at all); three tilts and a majority
/// vote make one such graze harmless.
const RAYS: [Vec3; 3] = [
    Vec3::new(1.0, 0.000_123, 0.000_045_7),
    Vec3::new(1.0, -0.000_311, 0.000_201),
    Vec3::new(1.0, 0.000_207, -0.000_389),
];

/// The largest tilt of [`RAYS`] across X.
const MAX_TILT: f32 = 0.000_389;

/// Bins across the ray (in y and z) per side.
const BINS: usize = 48;

/// A closed mesh prepared for many inside queries. Build it once per pose of the mesh.
pub struct InsideTest {
    corners: Vec<[Vec3; 3]>,
    /// Per (y, z) bin, the triangles whose extent (padded by the ray's tilt) overlaps it.
    bins: Vec<Vec<u32>>,
    lo: [f32; 2],
    cell: [f32; 2],
}

impl InsideTest {
    /// Prepares `mesh` (closed, any winding) for queries.
    pub fn new(mesh: &HeadMesh) -> Self {
        let corners: Vec<[Vec3; 3]> = mesh.triangles.iter().map(|t| mesh.corners(t)).collect();
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for p in corners.iter().flatten() {
            (lo, hi) = (lo.min(*p), hi.max(*p));
        }
        // The tilted ray drifts across bins over the mesh's length: pad by that drift.
        let length = (hi.x - lo.x).max(0.0);
        let pad = Vec3::new(0.0, MAX_TILT, MAX_TILT) * length * 2.0 + Vec3::splat(1e-6);
        let (lo, hi) = (lo - pad, hi + pad);
        let cell = [((hi.y - lo.y) / BINS as f32).max(1e-9), ((hi.z - lo.z) / BINS as f32).max(1e-9)];
        let mut test = InsideTest { corners, bins: vec![Vec::new(); BINS * BINS], lo: [lo.y, lo.z], cell };
        for (t, c) in test.corners.iter().enumerate() {
            let (tlo, thi) = (c[0].min(c[1]).min(c[2]) - pad, c[0].max(c[1]).max(c[2]) + pad);
            let (y0, z0) = test.bin_of(tlo);
            let (y1, z1) = test.bin_of(thi);
            for y in y0..=y1 {
                for z in z0..=z1 {
                    test.bins[y * BINS + z].push(t as u32);
                }
            }
        }
        test
    }

    fn bin_of(&self, p: Vec3) -> (usize, usize) {
        let at = |v: f32, k: usize| (((v - self.lo[k]) / self.cell[k]).floor().max(0.0) as usize).min(BINS - 1);
        (at(p.y, 0), at(p.z, 1))
    }

    /// Whether `p` is inside the closed mesh: an odd number of crossings along most of
    /// three slightly different rays.
    pub fn contains(&self, p: Vec3) -> bool {
        let (y, z) = self.bin_of(p);
        let odd = |ray: Vec3| {
            let dir = ray.normalize();
            let crossings = self.bins[y * BINS + z]
                .iter()
                .filter(|&&t| ray_hit(p, dir, &self.corners[t as usize]).is_some_and(|d| d > 0.0))
                .count();
            crossings % 2 == 1
        };
        let (first, second) = (odd(RAYS[0]), odd(RAYS[1]));
        if first == second { first } else { odd(RAYS[2]) }
    }

    /// How far `p` is from the nearest triangle (exact, every triangle).
    pub fn distance(&self, p: Vec3) -> f32 {
        self.nearest_triangle(p).1
    }

    /// The triangle nearest to `p` (its index in the mesh) and its distance.
    pub fn nearest_triangle(&self, p: Vec3) -> (usize, f32) {
        self.corners
            .iter()
            .map(|c| distance_to_triangle(p, c))
            .enumerate()
            .fold((0, f32::INFINITY), |best, (t, d)| if d < best.1 { (t, d) } else { best })
    }

    /// How deep `p` is inside the mesh, `None` when it is outside.
    pub fn depth(&self, p: Vec3) -> Option<f32> {
        self.contains(p).then(|| self.distance(p))
    }

    /// Whether the segment `a`–`b` passes through a triangle.
    pub fn segment_crosses(&self, a: Vec3, b: Vec3) -> bool {
        !self.segment_hits(a, b).is_empty()
    }

    /// How deep the segment `a`–`b`, whose ends are outside, runs through the mesh: the
    /// depth of the middle of each stretch between where it enters and where it leaves,
    /// the deepest of them (0 when it crosses no triangle). A segment grazing the surface
    /// within rounding crosses it by micrometres.
    pub fn segment_depth(&self, a: Vec3, b: Vec3) -> f32 {
        let hits = self.segment_hits(a, b);
        let direction = (b - a).normalize_or_zero();
        hits.chunks_exact(2).map(|pair| self.distance(a + direction * (0.5 * (pair[0] + pair[1])))).fold(0.0, f32::max)
    }

    /// The distances from `a` at which the segment `a`–`b` meets a triangle, nearest first.
    fn segment_hits(&self, a: Vec3, b: Vec3) -> Vec<f32> {
        let (y0, z0) = self.bin_of(a.min(b));
        let (y1, z1) = self.bin_of(a.max(b));
        let length = (b - a).length();
        if length == 0.0 {
            return Vec::new();
        }
        let dir = (b - a) / length;
        let mut hits = Vec::new();
        for y in y0..=y1 {
            for z in z0..=z1 {
                let near = self.bins[y * BINS + z].iter().filter_map(|&t| ray_hit(a, dir, &self.corners[t as usize]));
                hits.extend(near.filter(|&d| d > 0.0 && d < length));
            }
        }
        // A triangle spanning several bins is met once.
        hits.sort_by(f32::total_cmp);
        hits.dedup();
        hits
    }
}

/// What [`InsideTest::strands`] found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StrandsInside {
    /// Particles deeper inside than the tolerance.
    pub particles: usize,
    /// The deepest particle, metres (0 when none is inside).
    pub deepest: f32,
    /// Segments passing through a triangle.
    pub crossings: usize,
    /// The particles deeper than the tolerance.
    pub found: Vec<Vec3>,
}

impl StrandsInside {
    /// Adds what another measurement found (of the same strands at another time).
    pub fn add(&mut self, other: StrandsInside) {
        self.particles += other.particles;
        self.deepest = self.deepest.max(other.deepest);
        self.crossings += other.crossings;
        self.found.extend(other.found);
    }
}

impl InsideTest {
    /// Measures strands of `particles_per_strand` particles each, root first, in the mesh's
    /// frame: the particles more than `tolerance` inside, the deepest, and the segments that
    /// run more than `tolerance` deep through the mesh ([`Self::segment_depth`]). Roots sit on the surface by construction, so they and the
    /// segments leaving them are not counted.
    pub fn strands(&self, positions: &[Vec3], particles_per_strand: usize, tolerance: f32) -> StrandsInside {
        let mut out = StrandsInside::default();
        for (i, &p) in positions.iter().enumerate() {
            let j = i % particles_per_strand.max(1);
            if j == 0 {
                continue;
            }
            if let Some(depth) = self.depth(p) {
                out.deepest = out.deepest.max(depth);
                if depth > tolerance {
                    out.particles += 1;
                    out.found.push(p);
                }
            }
            if j > 1 && self.segment_depth(positions[i - 1], p) > tolerance {
                out.crossings += 1;
            }
        }
        out
    }
}

/// Möller–Trumbore: the distance along `dir` from `origin` at which the ray meets the
/// triangle, if it does (either side).
pub(super) fn ray_hit(origin: Vec3, dir: Vec3, [a, b, c]: &[Vec3; 3]) -> Option<f32> {
    let (e1, e2) = (*b - *a, *c - *a);
    let q = dir.cross(e2);
    let det = e1.dot(q);
    if det.abs() < 1e-12 {
        return None; // the ray runs along the triangle's plane
    }
    let s = (origin - *a) / det;
    let r = s.cross(e1);
    let (u, v) = (s.dot(q), dir.dot(r));
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0).then(|| e2.dot(r))
}

/// The point of triangle `a, b, c` closest to `p`, as barycentric coordinates (Ericson,
/// *Real-Time Collision Detection*, 5.1.5).
pub(crate) fn closest_barycentric(p: Vec3, [a, b, c]: &[Vec3; 3]) -> [f32; 3] {
    let (a, b, c) = (*a, *b, *c);
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    [1.0 - v - w, v, w]
}

/// Closest distance from `p` to a triangle (Ericson, "Real-Time Collision Detection",
/// 5.1.5).
fn distance_to_triangle(p: Vec3, corners: &[Vec3; 3]) -> f32 {
    let [u, v, w] = closest_barycentric(p, corners);
    p.distance(corners[0] * u + corners[1] * v + corners[2] * w)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::test_head;

    #[test]
    fn agrees_with_brute_force_parity_and_measures_depth() {
        let head = test_head(3);
        let test = InsideTest::new(&head);
        let mut inside = 0;
        let mut state = 12_345u64;
        let mut next = || {
            // A linear congruential generator: a deterministic scatter, no dependency.
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (state >> 40) as f32 / (1u64 << 24) as f32 - 0.5
        };
        for _ in 0..2000 {
            // Through and around the head (radius ~0.1 m).
            let p = Vec3::new(next(), next(), next()) * 0.3;
            assert_eq!(test.contains(p), head.contains_by_ray_parity(p), "{p:?}");
            inside += usize::from(test.contains(p));
        }
        assert!((100..1500).contains(&inside), "{inside} of 2000 inside");
        // The centre is deeper than a point just under the surface.
        let top = head.positions.iter().copied().max_by(|a, b| a.y.total_cmp(&b.y)).unwrap();
        let shallow = test.depth(top * 0.99).expect("just under the top is inside");
        assert!(shallow > 0.0 && shallow < 0.01 * top.length() + 1e-4, "{shallow}");
        assert!(test.depth(Vec3::ZERO).unwrap() > 0.05);
        assert_eq!(test.depth(top * 1.1), None);
    }

    #[test]
    fn segments_through_the_surface_cross_it() {
        let test = InsideTest::new(&test_head(3));
        let far = Vec3::new(0.0, 0.5, 0.0);
        assert!(test.segment_crosses(Vec3::ZERO, far));
        assert!(test.segment_crosses(Vec3::new(-0.5, 0.01, 0.02), Vec3::new(0.5, 0.01, 0.02)), "through and out");
        assert!(!test.segment_crosses(far, far + Vec3::X));
        assert!(!test.segment_crosses(Vec3::ZERO, Vec3::new(0.01, 0.0, 0.0)), "inside, never reaching the surface");
    }
}
