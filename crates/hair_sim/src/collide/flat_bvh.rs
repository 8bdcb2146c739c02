//! A bounding volume hierarchy over a mesh's triangles, laid out for a walk without a stack
//! (depth first, every node saying where the walk goes when its box is missed), as a GPU
//! walks it: the GPU solver's closest point deep inside the head and its segment crossings,
//! where the CPU walks parry's BVH.

use crate::math::Vec3;

/// Added around every box, metres.
const PADDING: f32 = 1e-6;

/// One node of a [`FlatBvh`]: a box around its triangles; a leaf holds them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlatBvhNode {
    /// The box's lowest corner.
    pub min: Vec3,
    /// The box's highest corner.
    pub max: Vec3,
    /// The node the walk goes to when this box is missed or this leaf is done (the next
    /// node after the whole subtree; the node count at the end).
    pub skip: u32,
    /// A leaf's first triangle in [`FlatBvh::order`].
    pub first: u32,
    /// A leaf's triangle count, 1 to [`FlatBvh::LEAF_SIZE`]; 0 for a node with children,
    /// whose first child is the next node.
    pub count: u32,
}

/// A BVH over triangles, depth first: a node's first child follows it, and
/// [`FlatBvhNode::skip`] passes over its subtree. Split at the median of the longest axis
/// of the triangles' centroids.
#[derive(Clone, Debug, Default)]
pub struct FlatBvh {
    /// The nodes, the root first (none for no triangles).
    pub nodes: Vec<FlatBvhNode>,
    /// Triangle indices, each leaf's together.
    pub order: Vec<u32>,
}

impl FlatBvh {
    /// Triangles per leaf, at most.
    pub const LEAF_SIZE: usize = 4;

    /// The hierarchy over `triangles`' corners.
    pub fn new(triangles: &[[Vec3; 3]]) -> Self {
        let mut bvh = FlatBvh { nodes: Vec::new(), order: (0..triangles.len() as u32).collect() };
        if !triangles.is_empty() {
            let centroids: Vec<Vec3> = triangles.iter().map(|[a, b, c]| (*a + *b + *c) / 3.0).collect();
            bvh.build(triangles, &centroids, 0, triangles.len());
        }
        bvh
    }

    /// Adds the subtree over `order[start..end]`.
    fn build(&mut self, triangles: &[[Vec3; 3]], centroids: &[Vec3], start: usize, end: usize) {
        let (mut min, mut max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        let (mut low, mut high) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for &t in &self.order[start..end] {
            for corner in triangles[t as usize] {
                (min, max) = (min.min(corner), max.max(corner));
            }
            (low, high) = (low.min(centroids[t as usize]), high.max(centroids[t as usize]));
        }
        // A little room: a ray grazing a flat box's face, rounded, still enters it.
        (min, max) = (min - Vec3::splat(PADDING), max + Vec3::splat(PADDING));
        let at = self.nodes.len();
        let leaf = end - start <= Self::LEAF_SIZE;
        let count = if leaf { (end - start) as u32 } else { 0 };
        self.nodes.push(FlatBvhNode { min, max, skip: 0, first: start as u32, count });
        if !leaf {
            let extent = high - low;
            let axis = if extent.x >= extent.y && extent.x >= extent.z {
                0
            } else if extent.y >= extent.z {
                1
            } else {
                2
            };
            let middle = (start + end) / 2;
            self.order[start..end].select_nth_unstable_by(middle - start, |&a, &b| {
                centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis])
            });
            self.build(triangles, centroids, start, middle);
            self.build(triangles, centroids, middle, end);
        }
        self.nodes[at].skip = self.nodes.len() as u32;
    }

    /// The triangle nearest `p` by `distance` (a triangle's distance from `p`) and that
    /// distance, visiting only the leaves whose boxes are nearer than the best found so far;
    /// `None` without triangles.
    pub fn nearest(&self, p: Vec3, distance: impl Fn(u32) -> f32) -> Option<(u32, f32)> {
        self.walk(
            None,
            |best: &Option<(u32, f32)>, node| {
                let gap = (node.min - p).max(p - node.max).max(Vec3::ZERO).length();
                best.is_none_or(|(_, d)| gap < d)
            },
            |best, t| {
                let d = distance(t);
                if best.is_none_or(|(_, b)| d < b) {
                    *best = Some((t, d));
                }
            },
        )
    }

    /// The nearest hit along the ray from `origin` along unit `direction` within `reach`:
    /// `hit` gives a triangle's distance along the ray, if it hits it.
    pub fn first_hit(
        &self,
        origin: Vec3,
        direction: Vec3,
        reach: f32,
        hit: impl Fn(u32) -> Option<f32>,
    ) -> Option<f32> {
        // Slabs the ray runs along (a zero component): all of the ray or none of it.
        let along = direction.cmpeq(Vec3::ZERO);
        let inverse = Vec3::select(along, Vec3::ZERO, direction.recip());
        let (nearest, found) = self.walk(
            (reach, false),
            |&(nearest, _), node| {
                let (t0, t1) = ((node.min - origin) * inverse, (node.max - origin) * inverse);
                let within = origin.cmpge(node.min) & origin.cmple(node.max);
                let all = Vec3::select(within, Vec3::NEG_INFINITY, Vec3::INFINITY);
                let near = Vec3::select(along, all, t0.min(t1)).max_element();
                let far = Vec3::select(along, -all, t0.max(t1)).min_element();
                near <= far.min(nearest) && far >= 0.0
            },
            |(nearest, found), t| {
                if let Some(at) = hit(t).filter(|at| at <= nearest) {
                    (*nearest, *found) = (at, true);
                }
            },
        );
        found.then_some(nearest)
    }

    /// Walks the tree from `state`: into the nodes `enter` accepts, each leaf's triangles
    /// to `visit`; the state at the end.
    fn walk<S>(&self, mut state: S, enter: impl Fn(&S, &FlatBvhNode) -> bool, mut visit: impl FnMut(&mut S, u32)) -> S {
        let mut at = 0;
        while let Some(node) = self.nodes.get(at) {
            if !enter(&state, node) {
                at = node.skip as usize;
                continue;
            }
            let first = node.first as usize;
            self.order[first..first + node.count as usize].iter().for_each(|&t| visit(&mut state, t));
            at = if node.count > 0 { node.skip as usize } else { at + 1 };
        }
        state
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use parry3d::query::PointQuery;
    use parry3d::shape::Triangle;

    /// A lumpy closed-ish sphere of triangles, and some slivers.
    fn soup() -> Vec<[Vec3; 3]> {
        let mut triangles = Vec::new();
        let at = |u: f32, v: f32| {
            let r = 0.1 * (1.0 + 0.2 * (5.0 * u).sin() * (3.0 * v).cos());
            Vec3::new(r * v.sin() * u.cos(), r * v.cos(), r * v.sin() * u.sin())
        };
        let (nu, nv) = (40, 20);
        for i in 0..nu {
            for j in 0..nv {
                let (u0, u1) =
                    (i as f32 / nu as f32 * std::f32::consts::TAU, (i + 1) as f32 / nu as f32 * std::f32::consts::TAU);
                let (v0, v1) =
                    (j as f32 / nv as f32 * std::f32::consts::PI, (j + 1) as f32 / nv as f32 * std::f32::consts::PI);
                triangles.push([at(u0, v0), at(u1, v0), at(u1, v1)]);
                triangles.push([at(u0, v0), at(u1, v1), at(u0, v1)]);
            }
        }
        triangles.push([Vec3::new(0.3, 0.0, 0.0), Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.4, 1e-7, 0.0)]);
        triangles
    }

    fn points() -> impl Iterator<Item = Vec3> {
        (0..400).map(|k| {
            let k = k as f32;
            Vec3::new((k * 0.37).sin(), (k * 0.71).cos(), (k * 1.13).sin()) * (0.02 + 0.3 * ((k * 0.05).sin().abs()))
        })
    }

    #[test]
    fn every_triangle_sits_in_one_leaf_inside_every_box_above_it() {
        let triangles = soup();
        let bvh = FlatBvh::new(&triangles);
        let mut sorted = bvh.order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..triangles.len() as u32).collect::<Vec<_>>());
        let mut in_leaves = 0;
        for (k, node) in bvh.nodes.iter().enumerate() {
            assert!(node.skip as usize > k && node.skip as usize <= bvh.nodes.len());
            assert!(node.count as usize <= FlatBvh::LEAF_SIZE);
            // Every node of the subtree, and every corner of its leaves, lies in the box.
            for inner in &bvh.nodes[k..node.skip as usize] {
                assert!(inner.min.cmpge(node.min).all() && inner.max.cmple(node.max).all());
                for &t in &bvh.order[inner.first as usize..(inner.first + inner.count) as usize] {
                    assert!(triangles[t as usize].iter().all(|c| c.cmpge(node.min).all() && c.cmple(node.max).all()));
                }
            }
            in_leaves += node.count;
        }
        assert_eq!(in_leaves as usize, triangles.len());
    }

    #[test]
    fn the_nearest_triangle_is_the_one_every_triangle_tested_finds() {
        let triangles = &soup();
        let bvh = FlatBvh::new(triangles);
        let distance = |p: Vec3| {
            move |t: u32| {
                let [a, b, c] = triangles[t as usize];
                (p - Triangle::new(a, b, c).project_local_point(p, false).point).length()
            }
        };
        for p in points() {
            let (_, found) = bvh.nearest(p, distance(p)).expect("triangles");
            let every = (0..triangles.len() as u32).map(distance(p)).fold(f32::INFINITY, f32::min);
            assert_eq!(found, every, "at {p}");
        }
        assert_eq!(FlatBvh::new(&[]).nearest(Vec3::ZERO, |_| 0.0), None);
    }

    #[test]
    fn the_first_hit_is_the_nearest_of_every_triangle_hit() {
        let triangles = &soup();
        let bvh = FlatBvh::new(triangles);
        // A ray against a triangle, both sides (Möller–Trumbore).
        let hit = |origin: Vec3, d: Vec3| {
            move |t: u32| -> Option<f32> {
                let [a, b, c] = triangles[t as usize];
                let (e1, e2) = (b - a, c - a);
                let q = d.cross(e2);
                let det = e1.dot(q);
                if det.abs() < 1e-12 {
                    return None;
                }
                let s = origin - a;
                let u = s.dot(q) / det;
                let r = s.cross(e1);
                let v = d.dot(r) / det;
                let at = e2.dot(r) / det;
                (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && at >= 0.0).then_some(at)
            }
        };
        let mut hits = 0;
        for (p, q) in points().zip(points().skip(7)) {
            let Some(d) = (q - p).try_normalize() else { continue };
            let reach = (q - p).length();
            let found = bvh.first_hit(p, d, reach, hit(p, d));
            let every = (0..triangles.len() as u32).filter_map(hit(p, d)).filter(|&t| t <= reach).reduce(f32::min);
            assert_eq!(found, every, "from {p} to {q}");
            hits += usize::from(found.is_some());
        }
        // Along the axes too: directions with zero components (off the poles, where the
        // sphere's triangles are slivers along the axis).
        let origin = Vec3::new(0.01, 0.02, -0.015);
        for d in [Vec3::X, Vec3::NEG_Y, Vec3::Z] {
            let found = bvh.first_hit(origin, d, 1.0, hit(origin, d));
            let every = (0..triangles.len() as u32).filter_map(hit(origin, d)).reduce(f32::min);
            assert_eq!(found, every, "along {d}");
            assert!(found.is_some(), "from inside along {d}");
        }
        assert!(hits > 50, "{hits} of the segments hit the soup");
    }
}
