//! What a step hands the step shader (`step/`) besides the buffers: the per-step constants
//! ([`StepUniform`]), the head's grid and tables as the shader reads them ([`GridInfo`]),
//! and the extra colliders and the moving skin packed as words.

use bytemuck::{Pod, Zeroable};
use hair_sim::collide::HeadCollider;
use hair_sim::math::Vec3;

/// The per-step constants, laid out as the step shader's `Step`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct StepUniform {
    pub(crate) counts: [u32; 4],
    pub(crate) flags: [u32; 4],
    pub(crate) gravity_h: [f32; 4],
    pub(crate) motion: [f32; 4],
    pub(crate) limits: [f32; 4],
    pub(crate) wind: [f32; 4],
    pub(crate) gusts: [f32; 4],
    pub(crate) grid_origin: [f32; 4],
    pub(crate) grid_dims: [u32; 4],
    pub(crate) centre: [f32; 4],
    pub(crate) near: [u32; 4],
    pub(crate) near_bounds: [f32; 4],
    pub(crate) rise: [f32; 4],
    pub(crate) rise_dims: [u32; 4],
    pub(crate) rise_limits: [f32; 4],
    pub(crate) springs: [f32; 4],
    pub(crate) spring_flags: [u32; 4],
    pub(crate) ray_from: [f32; 4],
    pub(crate) offset: [f32; 4],
    pub(crate) skin: [u32; 4],
    pub(crate) bvh: [u32; 4],
    pub(crate) sleep: [f32; 4],
    pub(crate) volume: [u32; 4],
}

/// The head as the shader reads it: its distance grid, and where the exact near query's
/// tables start in the same buffer.
#[derive(Clone, Copy)]
pub(crate) struct GridInfo {
    pub(crate) origin: Vec3,
    pub(crate) inverse_cell: f32,
    pub(crate) dims: [u32; 3],
    pub(crate) centre: Vec3,
    /// The step shader's `near`: where the cell ranges, blocks and triangles start, and the
    /// bits of a range that count its blocks (0: no tables, the grid alone).
    pub(crate) near: [u32; 4],
    /// The step shader's `near_bounds`: the grid's largest error, the bounds' slack, the cell.
    pub(crate) near_bounds: [f32; 4],
    /// The step shader's `rise`, `rise_dims` and `rise_limits`: the curvature table's corner and
    /// cells per metre, its cells along each axis and where it starts, the longest segment
    /// it bounds (0: no table) and the most its normal may turn.
    pub(crate) rise: [f32; 4],
    pub(crate) rise_dims: [u32; 4],
    pub(crate) rise_limits: [f32; 4],
    /// The step shader's `bvh`: the BVH over the tables' triangles, for the closest point where
    /// a cell has no list and for segment crossings: its node count (0: no tables), where
    /// its nodes and its triangle order start.
    pub(crate) bvh: [u32; 4],
}

impl GridInfo {
    /// `collider` as the step shader's `head` buffer holds it (words): the grid's samples,
    /// then, if they fit in `limit` bytes, the exact near query's cell ranges, blocks and
    /// triangles (ten vec4 each), the BVH over them (two vec4 a node, then its triangle
    /// order), and the curvature table (two words a cell).
    pub(crate) fn pack(collider: &HeadCollider, limit: u64) -> (Vec<u32>, GridInfo) {
        let g = collider.grid();
        let mut words: Vec<u32> = g.values().iter().map(|v| v.to_bits()).collect();
        let mut info = GridInfo {
            origin: g.origin(),
            inverse_cell: 1.0 / g.cell_size(),
            dims: g.dims().map(|d| d as u32),
            centre: collider.centre(),
            near: [0; 4],
            near_bounds: [g.max_error(), 0.0, g.cell_size(), 0.0],
            rise: [0.0; 4],
            rise_dims: [0; 4],
            rise_limits: [0.0; 4],
            bvh: [0; 4],
        };
        let tables = collider.near_query_tables();
        let rise = collider.rise_table();
        let extra = tables.cell_ranges.len()
            + 20 * tables.blocks.len()
            + 40 * tables.triangles.len()
            + 8 * tables.bvh.nodes.len()
            + tables.bvh.order.len()
            + 2 * rise.values.len();
        if ((words.len() + extra) * 4) as u64 > limit {
            return (words, info); // beyond the device: the grid alone still answers
        }
        let ranges = words.len() as u32;
        words.extend(&tables.cell_ranges);
        let blocks = words.len() as u32;
        words.extend(tables.blocks.iter().flatten());
        let triangles = words.len() as u32;
        for triangle in &tables.triangles {
            words.extend(triangle.iter().flat_map(|v| [v.x, v.y, v.z, 0.0]).map(f32::to_bits));
        }
        info.near = [ranges, blocks, triangles, tables.count_bits];
        // A leaf's count takes the low three bits beside its first triangle.
        const _: () = assert!(hair_sim::collide::FlatBvh::LEAF_SIZE < 8);
        let nodes = words.len() as u32;
        for node in &tables.bvh.nodes {
            let corner = |v: Vec3, w: u32| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits(), w];
            words.extend(corner(node.min, node.skip));
            words.extend(corner(node.max, node.first * 8 + node.count));
        }
        info.bvh = [tables.bvh.nodes.len() as u32, nodes, words.len() as u32, 0];
        words.extend(&tables.bvh.order);
        info.near_bounds[1] = tables.slack;
        let [x, y, z] = rise.dims.map(|d| d as u32);
        let origin = rise.cells.origin;
        info.rise = [origin.x, origin.y, origin.z, rise.cells.inverse_cell];
        info.rise_dims = [x, y, z, words.len() as u32];
        info.rise_limits = [rise.max_length, rise.max_turn, 0.0, 0.0];
        words.extend(rise.values.iter().flatten().map(|v| v.to_bits()));
        (words, info)
    }
}

/// A vec4 of floats as the step shader's `colliders` holds them: their bits.
pub(crate) fn bits(v: [f32; 4]) -> [u32; 4] {
    v.map(f32::to_bits)
}

/// Appends `patch` to `data` as the step shader (`step/`) reads it (after the extra colliders) and
/// returns its place: header + 1, triangles, bin starts, bin lists (vec4 indices).
pub(crate) fn pack_patch(data: &mut Vec<[u32; 4]>, patch: hair_sim::collide::PatchParts) -> [u32; 4] {
    let vec4 = |v: Vec3| bits([v.x, v.y, v.z, 0.0]);
    let header = data.len() as u32;
    data.push(bits([patch.origin.x, patch.origin.y, patch.origin.z, patch.reach]));
    let [nx, ny, nz] = patch.dims.map(|d| d as u32);
    data.push([nx, ny, nz, patch.cell.to_bits()]);
    let triangles = data.len() as u32;
    for (t, corners) in patch.triangles.iter().enumerate() {
        let face = patch.face_normals[t];
        data.extend(corners.map(|v| vec4(patch.positions[v as usize])));
        data.push(vec4(face));
        // An edge's normal is its two faces' (as `SurfacePatch::resolve`'s).
        data.extend(
            patch.across[t]
                .map(|other| vec4(other.map_or(face, |o| (face + patch.face_normals[o as usize]).normalize_or(face)))),
        );
        data.extend(corners.map(|v| vec4(patch.corner_normals[v as usize])));
    }
    let mut words = |list: &[u32]| {
        let at = data.len() as u32;
        data.extend(list.chunks(4).map(|w| std::array::from_fn(|i| w.get(i).copied().unwrap_or(0))));
        at
    };
    let starts = words(patch.starts);
    let bins = words(patch.bins);
    [header + 1, triangles, starts, bins]
}
