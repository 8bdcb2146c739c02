//! Eyes for the head's sockets: where the source's eyeballs are, and a generated eyeball
//! with sclera, iris and pupil in its vertex colours.
//!
//! The MakeHuman base mesh has an eyeball for each socket (the `helper-l-eye` and
//! `helper-r-eye` groups, 70 quads each, a sphere of radius 1.495 cm): its centre and radius
//! place the generated eyeball, which is finer and coloured. The eyes are a mesh of their
//! own (not part of the head's mesh, so the head stays one closed surface and its dark
//! pupils are not read as scalp paint), drawn by two nodes under the `head` joint.

use crate::error::Error;
use crate::obj::Obj;

/// The source's eyeball groups, left then right.
pub const EYE_GROUPS: [&str; 2] = ["helper-l-eye", "helper-r-eye"];

/// One eye: the unit eyeball ([`eyeball`]) scaled by `radius` and moved by `translation`,
/// relative to the `head` joint at rest (metres; the eyeball looks along +Z).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Eye {
    /// The eyeball's centre relative to the `head` joint's rest position, metres.
    pub translation: [f32; 3],
    /// The eyeball's radius, metres.
    pub radius: f32,
}

/// A sphere in OBJ units: the mean of a group's vertices and their mean distance to it.
pub fn sphere_of_group(obj: &Obj, group: &str) -> Result<([f64; 3], f64), Error> {
    let faces = obj.group_faces(group)?;
    let mut vertices: Vec<u32> = faces.iter().flat_map(|f| f.vertices.iter().copied()).collect();
    vertices.sort_unstable();
    vertices.dedup();
    let points: Vec<[f64; 3]> = vertices.iter().map(|&v| obj.positions[v as usize]).collect();
    let n = points.len() as f64;
    let centre: [f64; 3] = std::array::from_fn(|k| points.iter().map(|p| p[k]).sum::<f64>() / n);
    let radius = points.iter().map(|p| (0..3).map(|k| (p[k] - centre[k]).powi(2)).sum::<f64>().sqrt()).sum::<f64>() / n;
    if radius.is_nan() || radius <= 0.0 {
        return Err(Error::Check(format!("the group `{group}` is not a sphere (radius {radius})")));
    }
    Ok((centre, radius))
}

/// Linear RGB of the eyeball's regions.
const PUPIL: [f32; 3] = [0.01, 0.01, 0.01];
const IRIS: [f32; 3] = [0.16, 0.08, 0.035];
const LIMBUS: [f32; 3] = [0.05, 0.03, 0.02];
const SCLERA: [f32; 3] = [0.80, 0.76, 0.72];

/// Rings of the eyeball by angle from its front (radians), with their colour: a pupil of
/// 0.14 rad (1.9 mm on a 1.5 cm eye), an iris to 0.48 rad (a 13.8 mm disc) darkening at its
/// rim, then the sclera. Close pairs of rings make the edges sharp.
const RINGS: [(f32, [f32; 3]); 14] = [
    (0.0, PUPIL),
    (0.12, PUPIL),
    (0.14, IRIS),
    (0.30, IRIS),
    (0.44, LIMBUS),
    (0.48, LIMBUS),
    (0.50, SCLERA),
    (0.8, SCLERA),
    (1.2, SCLERA),
    (1.6, SCLERA),
    (2.0, SCLERA),
    (2.4, SCLERA),
    (2.8, SCLERA),
    (std::f32::consts::PI, SCLERA),
];

/// Segments around the eyeball's axis.
const SEGMENTS: u32 = 32;

/// A unit sphere with colours.
#[derive(Clone, Debug, PartialEq)]
pub struct Eyeball {
    /// Positions on the unit sphere, which are also its normals.
    pub positions: Vec<[f32; 3]>,
    /// Linear RGBA vertex colours.
    pub colors: Vec<[f32; 4]>,
    /// Counter-clockwise triangles seen from outside.
    pub triangles: Vec<[u32; 3]>,
}

/// The unit eyeball, looking along +Z. The first and last vertices are the poles.
pub fn eyeball() -> Eyeball {
    let mut positions = vec![[0.0, 0.0, 1.0]];
    let mut colors = vec![with_alpha(RINGS[0].1)];
    for &(angle, color) in &RINGS[1..RINGS.len() - 1] {
        for s in 0..SEGMENTS {
            let around = s as f32 * std::f32::consts::TAU / SEGMENTS as f32;
            positions.push([angle.sin() * around.cos(), angle.sin() * around.sin(), angle.cos()]);
            colors.push(with_alpha(color));
        }
    }
    positions.push([0.0, 0.0, -1.0]);
    colors.push(with_alpha(RINGS[RINGS.len() - 1].1));

    let rings = RINGS.len() as u32 - 2;
    let ring = |r: u32, s: u32| 1 + r * SEGMENTS + s % SEGMENTS;
    let back = positions.len() as u32 - 1;
    let mut triangles = Vec::new();
    for s in 0..SEGMENTS {
        triangles.push([0, ring(0, s), ring(0, s + 1)]);
        for r in 0..rings - 1 {
            triangles.push([ring(r, s), ring(r + 1, s), ring(r + 1, s + 1)]);
            triangles.push([ring(r, s), ring(r + 1, s + 1), ring(r, s + 1)]);
        }
        triangles.push([ring(rings - 1, s), back, ring(rings - 1, s + 1)]);
    }
    Eyeball { positions, colors, triangles }
}

fn with_alpha([r, g, b]: [f32; 3]) -> [f32; 4] {
    [r, g, b, 1.0]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed, outward-wound unit sphere whose front is dark (the pupil) and whose sides
    /// are light (the sclera).
    #[test]
    fn the_eyeball_is_a_closed_outward_sphere_with_a_pupil_in_front() {
        let Eyeball { positions, colors, triangles } = eyeball();
        assert!(positions.iter().all(|p| ((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - 1.0).abs() < 1e-6));
        let mut volume = 0.0f64;
        let mut edges = std::collections::HashMap::new();
        for t in &triangles {
            let [a, b, c] = t.map(|i| positions[i as usize].map(f64::from));
            let cross = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
            volume += (cross[0] * c[0] + cross[1] * c[1] + cross[2] * c[2]) / 6.0;
            for k in 0..3 {
                *edges.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        assert!(edges.iter().all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1)), "closed, consistent");
        let sphere = 4.0 / 3.0 * std::f64::consts::PI;
        assert!(volume > 0.95 * sphere && volume < sphere, "outward, volume {volume}");
        let luminance = |c: [f32; 4]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
        assert!(luminance(colors[0]) < 0.02, "the pupil is dark");
        let side = positions.iter().position(|p| p[2].abs() < 0.05).unwrap();
        assert!(luminance(colors[side]) > 0.7, "the sclera is light");
    }
}
