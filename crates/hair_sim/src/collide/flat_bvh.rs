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
mod tests;
