//! Openings and watertightness: find the boundary loops of a cut mesh, close each with a
//! fan, and prove the result is one closed, consistently outward-wound surface.

use crate::geom::{TriMesh, add, dot, length};
use std::collections::HashMap;
use std::fmt;

/// What makes a mesh not a closed, consistently oriented surface. Vertex numbers are
/// indices into the mesh being checked.
#[derive(Clone, Debug, PartialEq)]
pub enum TopologyError {
    /// The mesh has no triangles.
    Empty,
    /// A triangle names the same vertex twice.
    DegenerateTriangle {
        /// The triangle.
        triangle: usize,
    },
    /// A vertex no triangle uses (it would break the Euler characteristic).
    UnusedVertex {
        /// The vertex.
        vertex: u32,
    },
    /// Two triangles traverse the same edge in the same direction: their windings disagree
    /// (or three or more triangles share the edge).
    DirectedEdgeRepeated {
        /// Start of the edge.
        from: u32,
        /// End of the edge.
        to: u32,
    },
    /// An edge is not shared by exactly two triangles.
    EdgeUseCount {
        /// One end of the edge.
        a: u32,
        /// The other end.
        b: u32,
        /// How many triangles use it.
        count: usize,
    },
    /// More than one opening meets at a vertex, so the boundary is not a set of simple loops.
    PinchedBoundary {
        /// The vertex.
        vertex: u32,
    },
    /// The triangles around a vertex form more than one fan (two surfaces touch there).
    NonManifoldVertex {
        /// The vertex.
        vertex: u32,
        /// How many separate fans meet there.
        fans: usize,
    },
    /// The mesh falls apart into several pieces.
    Components {
        /// How many connected pieces.
        count: usize,
    },
    /// The fan closing an opening folds over: one of its triangles faces against the rest.
    FoldedFill {
        /// Which opening (in the order found).
        hole: usize,
        /// How many edges its loop has.
        loop_len: usize,
    },
    /// The closed mesh encloses a negative (or no) volume: it is wound inside out.
    NotOutward {
        /// The signed volume, in the mesh's units cubed.
        volume: f64,
    },
}

impl fmt::Display for TopologyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TopologyError::Empty => write!(f, "the mesh has no triangles"),
            TopologyError::DegenerateTriangle { triangle } => write!(f, "triangle {triangle} repeats a vertex"),
            TopologyError::UnusedVertex { vertex } => write!(f, "vertex {vertex} belongs to no triangle"),
            TopologyError::DirectedEdgeRepeated { from, to } => {
                write!(f, "edge {from}→{to} is traversed twice in the same direction (inconsistent winding)")
            }
            TopologyError::EdgeUseCount { a, b, count } => {
                write!(f, "edge {a}–{b} is shared by {count} triangles instead of 2 (an opening or a fin)")
            }
            TopologyError::PinchedBoundary { vertex } => write!(f, "two openings touch at vertex {vertex}"),
            TopologyError::NonManifoldVertex { vertex, fans } => {
                write!(f, "{fans} separate fans of triangles meet at vertex {vertex}")
            }
            TopologyError::Components { count } => write!(f, "the mesh has {count} separate pieces instead of 1"),
            TopologyError::FoldedFill { hole, loop_len } => {
                write!(f, "the fan closing opening {hole} ({loop_len} edges) folds over; it needs a better fill")
            }
            TopologyError::NotOutward { volume } => {
                write!(f, "the signed volume is {volume}, not positive: the mesh is wound inside out")
            }
        }
    }
}

impl std::error::Error for TopologyError {}

/// The directed edges of a mesh, each mapped to the vertex opposite it in its triangle.
/// Fails if two triangles traverse an edge in the same direction.
fn directed_edges(mesh: &TriMesh) -> Result<HashMap<(u32, u32), u32>, TopologyError> {
    let mut edges = HashMap::with_capacity(mesh.triangles.len() * 3);
    for (t, &[a, b, c]) in mesh.triangles.iter().enumerate() {
        if a == b || b == c || c == a {
            return Err(TopologyError::DegenerateTriangle { triangle: t });
        }
        for (from, to, opposite) in [(a, b, c), (b, c, a), (c, a, b)] {
            if edges.insert((from, to), opposite).is_some() {
                return Err(TopologyError::DirectedEdgeRepeated { from, to });
            }
        }
    }
    Ok(edges)
}

/// The openings of a consistently wound mesh, each as the loop of vertices along its
/// boundary edges, in the direction the adjacent triangles traverse them. Loops come in the
/// order their first boundary edge appears in the triangle list.
pub fn boundary_loops(mesh: &TriMesh) -> Result<Vec<Vec<u32>>, TopologyError> {
    let edges = directed_edges(mesh)?;
    let mut boundary: Vec<(u32, u32)> = Vec::new();
    let mut next: HashMap<u32, u32> = HashMap::new();
    for &[a, b, c] in &mesh.triangles {
        for (from, to) in [(a, b), (b, c), (c, a)] {
            if !edges.contains_key(&(to, from)) {
                if next.insert(from, to).is_some() {
                    return Err(TopologyError::PinchedBoundary { vertex: from });
                }
                boundary.push((from, to));
            }
        }
    }
    let mut visited: HashMap<u32, ()> = HashMap::new();
    let mut loops = Vec::new();
    for &(start, _) in &boundary {
        if visited.contains_key(&start) {
            continue;
        }
        let mut ring = vec![start];
        visited.insert(start, ());
        let mut v = next[&start];
        while v != start {
            if visited.insert(v, ()).is_some() {
                return Err(TopologyError::PinchedBoundary { vertex: v });
            }
            ring.push(v);
            // Every boundary vertex has exactly one outgoing boundary edge: each vertex has as
            // many boundary edges in as out, and none has two out (checked above).
            v = next[&v];
        }
        loops.push(ring);
    }
    Ok(loops)
}

/// An opening closed by [`fill_holes`].
#[derive(Clone, Debug, PartialEq)]
pub struct FilledHole {
    /// The loop of boundary vertices, as [`boundary_loops`] found it.
    pub ring: Vec<u32>,
    /// The vertex added at the loop's centroid, the apex of the fan.
    pub apex: u32,
    /// The area of the fan, in the mesh's units squared.
    pub area: f64,
}

/// Closes every opening with a fan of triangles from a new vertex at the loop's centroid,
/// wound to continue the surrounding triangles' orientation. A fan is only right for a loop
/// that is star-shaped around its centroid (a neck cut, a socket rim): every fan triangle
/// must face the same way as the fan's total vector area, or this fails with
/// [`TopologyError::FoldedFill`].
pub fn fill_holes(mesh: &mut TriMesh) -> Result<Vec<FilledHole>, TopologyError> {
    let loops = boundary_loops(mesh)?;
    let mut filled = Vec::with_capacity(loops.len());
    for (hole, ring) in loops.into_iter().enumerate() {
        let n = ring.len() as f64;
        let centroid = ring.iter().fold([0.0; 3], |s, &v| add(s, mesh.positions[v as usize])).map(|c| c / n);
        let apex = mesh.positions.len() as u32;
        mesh.positions.push(centroid);
        let first = mesh.triangles.len();
        // The mesh traverses boundary edge a→b; the fill must traverse it b→a.
        for k in 0..ring.len() {
            let (a, b) = (ring[k], ring[(k + 1) % ring.len()]);
            mesh.triangles.push([b, a, apex]);
        }
        let fan: Vec<[f64; 3]> = (first..mesh.triangles.len()).map(|t| mesh.area_vector(t)).collect();
        let total = fan.iter().fold([0.0; 3], |s, &a| add(s, a));
        if length(total) <= 0.0 || fan.iter().any(|&a| dot(a, total) <= 0.0) {
            return Err(TopologyError::FoldedFill { hole, loop_len: ring.len() });
        }
        let area = fan.iter().map(|&a| 0.5 * length(a)).sum();
        filled.push(FilledHole { ring, apex, area });
    }
    Ok(filled)
}

/// The measures of a mesh that passed [`check_closed`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Closed {
    /// Vertex count.
    pub vertices: usize,
    /// Undirected edge count (1.5 × triangles for a closed mesh).
    pub edges: usize,
    /// Triangle count.
    pub triangles: usize,
    /// V − E + F: 2 for a closed surface without handles (a sphere), 2 − 2g with g handles.
    pub euler_characteristic: i64,
    /// The enclosed volume (positive), in the mesh's units cubed.
    pub volume: f64,
}

/// Proves the mesh is one closed, consistently outward-wound surface: no degenerate
/// triangle or unused vertex, each directed edge used once, every undirected edge shared by
/// exactly two triangles, one fan of triangles around each vertex, one connected piece, and
/// a positive signed volume. The first violation found is returned.
pub fn check_closed(mesh: &TriMesh) -> Result<Closed, TopologyError> {
    if mesh.triangles.is_empty() {
        return Err(TopologyError::Empty);
    }
    let edges = directed_edges(mesh)?;
    let vertex_count = mesh.positions.len();
    let mut used = vec![false; vertex_count];
    mesh.triangles.iter().flatten().for_each(|&v| used[v as usize] = true);
    if let Some(vertex) = used.iter().position(|u| !u) {
        return Err(TopologyError::UnusedVertex { vertex: vertex as u32 });
    }
    // Undirected use counts, walked in triangle order so the first bad edge is reproducible.
    let mut undirected: HashMap<(u32, u32), usize> = HashMap::with_capacity(edges.len());
    for &[a, b, c] in &mesh.triangles {
        for (u, v) in [(a, b), (b, c), (c, a)] {
            *undirected.entry((u.min(v), u.max(v))).or_default() += 1;
        }
    }
    for &[a, b, c] in &mesh.triangles {
        for (u, v) in [(a, b), (b, c), (c, a)] {
            let count = undirected[&(u.min(v), u.max(v))];
            if count != 2 {
                return Err(TopologyError::EdgeUseCount { a: u.min(v), b: u.max(v), count });
            }
        }
    }
    // Around vertex v, triangle (v, b, c) is followed by the one holding edge v→c: walk
    // those cycles; more than one means separate fans touching at v.
    let mut outgoing: Vec<Vec<u32>> = vec![Vec::new(); vertex_count];
    for &[a, b, c] in &mesh.triangles {
        outgoing[a as usize].push(b);
        outgoing[b as usize].push(c);
        outgoing[c as usize].push(a);
    }
    for (v, out) in outgoing.iter().enumerate() {
        let v = v as u32;
        let mut seen = vec![false; out.len()];
        let mut fans = 0;
        for start in 0..out.len() {
            if seen[start] {
                continue;
            }
            fans += 1;
            let mut b = out[start];
            loop {
                let k = out.iter().position(|&x| x == b).expect("every edge has a twin, checked above");
                if seen[k] {
                    break;
                }
                seen[k] = true;
                b = edges[&(v, b)];
            }
        }
        if fans != 1 {
            return Err(TopologyError::NonManifoldVertex { vertex: v, fans });
        }
    }
    let count = components(mesh);
    if count != 1 {
        return Err(TopologyError::Components { count });
    }
    let volume = mesh.signed_volume();
    if volume.is_nan() || volume <= 0.0 {
        return Err(TopologyError::NotOutward { volume });
    }
    let euler_characteristic = vertex_count as i64 - undirected.len() as i64 + mesh.triangles.len() as i64;
    Ok(Closed {
        vertices: vertex_count,
        edges: undirected.len(),
        triangles: mesh.triangles.len(),
        euler_characteristic,
        volume,
    })
}

/// How many connected pieces the triangles form (union–find over shared vertices).
fn components(mesh: &TriMesh) -> usize {
    let mut parent: Vec<u32> = (0..mesh.positions.len() as u32).collect();
    fn root(parent: &mut [u32], mut v: u32) -> u32 {
        while parent[v as usize] != v {
            parent[v as usize] = parent[parent[v as usize] as usize];
            v = parent[v as usize];
        }
        v
    }
    for &[a, b, c] in &mesh.triangles {
        let ra = root(&mut parent, a);
        for v in [b, c] {
            let rv = root(&mut parent, v);
            parent[rv as usize] = ra;
        }
    }
    let mut roots: Vec<u32> = mesh.triangles.iter().flatten().map(|&v| root(&mut parent, v)).collect();
    roots.sort_unstable();
    roots.dedup();
    roots.len()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::fixtures::{cube, open_box, open_cylinder};

    #[test]
    fn a_closed_cube_passes() {
        let closed = check_closed(&cube()).unwrap();
        assert_eq!((closed.vertices, closed.edges, closed.triangles), (8, 18, 12));
        assert_eq!(closed.euler_characteristic, 2);
        assert!((closed.volume - 1.0).abs() < 1e-12);
        assert!(boundary_loops(&cube()).unwrap().is_empty());
    }

    #[test]
    fn the_open_box_is_closed_flat_and_outward() {
        let mut mesh = open_box();
        assert!(matches!(check_closed(&mesh), Err(TopologyError::EdgeUseCount { count: 1, .. })));
        let loops = boundary_loops(&mesh).unwrap();
        assert_eq!(loops.len(), 1);
        let mut ring = loops[0].clone();
        ring.sort_unstable();
        assert_eq!(ring, [2, 3, 6, 7], "the hole is the top face");
        let filled = fill_holes(&mut mesh).unwrap();
        assert_eq!(filled.len(), 1);
        assert_eq!(filled[0].apex, 8);
        assert_eq!(mesh.positions[8], [0.5, 1.0, 0.5], "the apex sits at the loop centroid");
        assert!((filled[0].area - 1.0).abs() < 1e-12);
        let closed = check_closed(&mesh).unwrap();
        assert_eq!((closed.vertices, closed.triangles, closed.euler_characteristic), (9, 14, 2));
        assert!((closed.volume - 1.0).abs() < 1e-12, "the flat cap restores the cube's volume");
        // Every cap triangle faces up, out of the box.
        for t in 10..14 {
            let n = mesh.area_vector(t);
            assert!(n[1] > 0.0 && n[0].abs() < 1e-12 && n[2].abs() < 1e-12, "{n:?}");
        }
    }

    #[test]
    fn a_tube_gets_both_ends_capped() {
        let n = 16;
        let mut tube = open_cylinder(n);
        let filled = fill_holes(&mut tube).unwrap();
        assert_eq!(filled.iter().map(|h| h.ring.len()).collect::<Vec<_>>(), [n as usize, n as usize]);
        let closed = check_closed(&tube).unwrap();
        assert_eq!(closed.euler_characteristic, 2);
        assert_eq!(closed.triangles, 4 * n as usize);
        // A regular 16-gon prism of height 2: volume = 2 × ½ n sin(2π/n).
        let expected = 2.0 * 0.5 * n as f64 * (std::f64::consts::TAU / n as f64).sin();
        assert!((closed.volume - expected).abs() < 1e-9, "{} vs {expected}", closed.volume);
        let bottom = &tube.positions[filled[0].apex as usize];
        let top = &tube.positions[filled[1].apex as usize];
        assert!(bottom[1].abs() < 1e-12 && (top[1] - 2.0).abs() < 1e-12, "{bottom:?} {top:?}");
    }

    #[test]
    fn bad_meshes_are_caught() {
        let mut inside_out = cube();
        inside_out.triangles.iter_mut().for_each(|t| t.swap(1, 2));
        assert!(matches!(check_closed(&inside_out), Err(TopologyError::NotOutward { volume }) if volume < -0.99));

        let mut flipped_one = cube();
        flipped_one.triangles[0].swap(1, 2);
        assert!(matches!(check_closed(&flipped_one), Err(TopologyError::DirectedEdgeRepeated { .. })));

        let mut two = cube();
        let more = cube();
        two.triangles.extend(more.triangles.iter().map(|t| t.map(|v| v + 8)));
        two.positions.extend(more.positions.iter().map(|p| [p[0] + 3.0, p[1], p[2]]));
        assert_eq!(check_closed(&two), Err(TopologyError::Components { count: 2 }));

        let mut extra = cube();
        extra.positions.push([5.0; 3]);
        assert_eq!(check_closed(&extra), Err(TopologyError::UnusedVertex { vertex: 8 }));
    }

    #[test]
    fn touching_fans_are_non_manifold() {
        // Two closed cubes glued at a single vertex (cube B's corner 0 is cube A's corner 7).
        let a = cube();
        let b = cube();
        let mut mesh = a.clone();
        let remap = |v: u32| if v == 0 { 7 } else { v + 7 };
        mesh.positions.extend(b.positions.iter().skip(1).map(|p| [p[0] + 1.0, p[1] + 1.0, p[2] + 1.0]));
        mesh.triangles.extend(b.triangles.iter().map(|t| t.map(remap)));
        assert_eq!(check_closed(&mesh), Err(TopologyError::NonManifoldVertex { vertex: 7, fans: 2 }));
    }

    #[test]
    fn a_folded_fill_is_refused() {
        // A flat annulus whose openings are darts (arrowheads): the centroid of a dart's
        // corners lies outside it, so a fan from there turns triangles over.
        let dart = [[-4.0, 4.0], [0.0, -1.0], [4.0, 4.0], [0.0, 1.0]];
        let ring = |s: f64| dart.iter().map(move |&[x, z]| [s * x, 0.0, s * z]);
        let positions: Vec<[f64; 3]> = ring(1.0).chain(ring(3.0)).collect();
        let triangles = (0..4).flat_map(|k| [[k, (k + 1) % 4, (k + 1) % 4 + 4], [k, (k + 1) % 4 + 4, k + 4]]).collect();
        let mut mesh = TriMesh { positions, triangles };
        assert_eq!(boundary_loops(&mesh).unwrap().len(), 2);
        assert_eq!(fill_holes(&mut mesh), Err(TopologyError::FoldedFill { hole: 0, loop_len: 4 }));

        // The same annulus around squares fills fine (a square is star-shaped about its centre).
        let square = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
        let ring = |s: f64| square.iter().map(move |&[x, z]| [s * x, 0.0, s * z]);
        mesh.positions = ring(1.0).chain(ring(3.0)).collect();
        mesh.triangles.truncate(8);
        let filled = fill_holes(&mut mesh).unwrap();
        assert_eq!(filled.iter().map(|h| h.area).collect::<Vec<_>>(), [4.0, 36.0]);
    }
}
