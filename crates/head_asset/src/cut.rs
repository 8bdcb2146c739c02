//! Cutting the head out of the body: keep the polygons above a height, triangulate them and
//! drop the vertices nothing uses any more.

use crate::error::Error;
use crate::geom::{TriMesh, dot, sub};
use crate::obj::Face;

/// What [`cut_above`] kept.
#[derive(Clone, Debug, PartialEq)]
pub struct Cut {
    /// The kept polygons as triangles, over the kept vertices only.
    pub mesh: TriMesh,
    /// For each kept vertex, its index in the source positions.
    pub source_vertices: Vec<u32>,
    /// How many polygons lay entirely above the cut.
    pub polygons_kept: usize,
}

/// Keeps the polygons whose vertices all lie strictly above `height` (on the y axis),
/// triangulates them ([`triangulate`]) and renumbers the vertices they use, in source order.
/// Polygons crossing the cut are dropped whole, so the cut edge follows the mesh's edges.
pub fn cut_above(positions: &[[f64; 3]], faces: &[&Face], height: f64) -> Result<Cut, Error> {
    let kept: Vec<&Face> =
        faces.iter().copied().filter(|f| f.vertices.iter().all(|&v| positions[v as usize][1] > height)).collect();
    if kept.is_empty() {
        return Err(Error::EmptyCut { height });
    }
    let mut used = vec![false; positions.len()];
    kept.iter().flat_map(|f| &f.vertices).for_each(|&v| used[v as usize] = true);
    let source_vertices: Vec<u32> = (0..positions.len() as u32).filter(|&v| used[v as usize]).collect();
    let mut new_index = vec![u32::MAX; positions.len()];
    for (new, &old) in source_vertices.iter().enumerate() {
        new_index[old as usize] = new as u32;
    }
    let triangles = kept
        .iter()
        .flat_map(|f| triangulate(&f.vertices, positions))
        .map(|t| t.map(|v| new_index[v as usize]))
        .collect();
    let mesh = TriMesh { positions: source_vertices.iter().map(|&v| positions[v as usize]).collect(), triangles };
    Ok(Cut { mesh, source_vertices, polygons_kept: kept.len() })
}

/// Splits a polygon into triangles with the same winding. A quad is split along its shorter
/// diagonal (the first one, 0–2, on a tie), which keeps the triangles closest to the quad's
/// surface; larger polygons are fanned from their first vertex.
pub fn triangulate(polygon: &[u32], positions: &[[f64; 3]]) -> Vec<[u32; 3]> {
    match *polygon {
        [a, b, c] => vec![[a, b, c]],
        [a, b, c, d] => {
            let p = |v: u32| positions[v as usize];
            let length2 = |u: u32, v: u32| {
                let e = sub(p(u), p(v));
                dot(e, e)
            };
            if length2(b, d) < length2(a, c) { vec![[a, b, d], [b, c, d]] } else { vec![[a, b, c], [a, c, d]] }
        }
        _ => (1..polygon.len() - 1).map(|k| [polygon[0], polygon[k], polygon[k + 1]]).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quads_split_along_the_shorter_diagonal() {
        // A rhombus: the 1–3 diagonal (length 1) is shorter than 0–2 (length 4).
        let positions = [[0.0, 0.0, 0.0], [2.0, -0.5, 0.0], [4.0, 0.0, 0.0], [2.0, 0.5, 0.0]];
        assert_eq!(triangulate(&[0, 1, 2, 3], &positions), [[0, 1, 3], [1, 2, 3]]);
        assert_eq!(triangulate(&[1, 2, 3, 0], &positions), [[1, 2, 3], [1, 3, 0]]);
        let pentagon = triangulate(&[0, 1, 2, 3, 4], &[[0.0; 3]; 5]);
        assert_eq!(pentagon, [[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
    }

    #[test]
    fn keeps_only_polygons_entirely_above_and_renumbers() {
        // A vertical strip of two quads, y = 0, 1, 2; cut at 0.5 keeps the upper quad.
        let positions =
            [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 2.0, 0.0], [1.0, 2.0, 0.0]];
        let lower = Face { vertices: vec![0, 1, 3, 2], groups: vec![0] };
        let upper = Face { vertices: vec![2, 3, 5, 4], groups: vec![0] };
        let cut = cut_above(&positions, &[&lower, &upper], 0.5).unwrap();
        assert_eq!(cut.polygons_kept, 1);
        assert_eq!(cut.source_vertices, [2, 3, 4, 5]);
        assert_eq!(cut.mesh.triangles.len(), 2);
        assert!((cut.mesh.area() - 1.0).abs() < 1e-12);
        assert!(cut.mesh.triangles.iter().flatten().all(|&v| v < 4));
        assert!(matches!(cut_above(&positions, &[&lower, &upper], 2.0), Err(Error::EmptyCut { .. })));
    }
}
