//! Growing a groom: roots on the head surface, guide strands from them, and the child
//! strands and smooth curves a renderer draws around the guides.
//!
//! Pure functions of a [`HeadMesh`] and a seed: the same inputs always give the same
//! groom, bit for bit. The curve functions ([`tessellate`], [`transport_frames`]) and the
//! child functions ([`child_curve`]) are the CPU reference the hair vertex shader mirrors.

mod children;
mod curve;
mod hair_file;
mod labels;
mod poisson;
mod rng;
mod vertex_roots;

pub use children::{
    ChildParams, ChildRoot, GOLDEN_ANGLE, MAX_CHILDREN_PER_GUIDE, MAX_CURVATURE, Spiral, child_curve, child_curves,
    child_offset, hash_unit, pcg_hash, spiral_offset,
};
pub use curve::{
    CurvePoint, bezier_controls, evaluate, frame_at, tessellate, transport_frames, transport_frames_of_strands,
};
pub use hair_file::{HairFile, HairFileError};
pub use labels::{labels_from_colors, painted_patches, triangle_weights};
pub use poisson::sample_roots_poisson;
pub use rng::SplitMix64;
pub use vertex_roots::sample_roots_at_vertices;

use crate::collide::HeadCollider;
use crate::math::{Pose, Vec3};
use crate::mesh::{HeadMesh, MeshError};
use crate::solver::{RestShape, SimParams, StepInput, Strands, StrandsError, VolumeGrid};
use std::fmt;

/// Where a root sits on the head: a triangle and barycentric coordinates in it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RootBinding {
    /// Triangle index into [`HeadMesh::triangles`].
    pub triangle: u32,
    /// Barycentric coordinates (sum to 1).
    pub barycentric: [f32; 3],
}

impl RootBinding {
    /// The root's head-local position.
    pub fn position(&self, mesh: &HeadMesh) -> Vec3 {
        mesh.point_at(self.triangle as usize, self.barycentric)
    }

    /// The interpolated surface normal at the root.
    pub fn normal(&self, mesh: &HeadMesh) -> Vec3 {
        mesh.normal_at(self.triangle as usize, self.barycentric)
    }

    /// The surface's curvature at the root, 1/m, positive where it bulges outward: the
    /// mean over the root triangle's edges of the normal curvature each edge shows,
    /// `(n_a − n_b)·(a − b) / |a − b|²` from its corners' vertex normals. 0 on a flat or
    /// degenerate triangle.
    pub fn curvature(&self, mesh: &HeadMesh) -> f32 {
        let triangle = mesh.triangles[self.triangle as usize];
        let corner = |k: usize| (mesh.positions[triangle[k] as usize], mesh.normals[triangle[k] as usize]);
        let edges = [(0, 1), (1, 2), (2, 0)].map(|(i, j)| {
            let ((a, na), (b, nb)) = (corner(i), corner(j));
            let length2 = (a - b).length_squared();
            if length2 > 1e-12 { (na - nb).dot(a - b) / length2 } else { 0.0 }
        });
        let mean = edges.iter().sum::<f32>() / 3.0;
        if mean.is_finite() { mean } else { 0.0 }
    }

    /// A unit vector across the surface at the root, perpendicular to [`Self::normal`]: the
    /// root triangle's first edge with its normal part removed (a fixed axis if the edge
    /// is degenerate). It is the `root_u` of the guide's child frames
    /// ([`transport_frames`]): tied to the mesh, so it turns with the head.
    pub fn tangent(&self, mesh: &HeadMesh) -> Vec3 {
        let [a, b, _] = mesh.corners(&mesh.triangles[self.triangle as usize]);
        curve::perpendicular_unit(b - a, self.normal(mesh))
    }
}

/// Why a groom cannot be grown.
#[derive(Clone, Debug, PartialEq)]
pub enum GroomError {
    /// No triangle may carry hair: every weight is zero (nothing painted as scalp).
    NoScalp,
    /// The weights do not match the triangles one to one.
    WeightCountMismatch {
        /// Triangles in the mesh.
        triangles: usize,
        /// Weights given.
        weights: usize,
    },
    /// The strands could not be built.
    Strands(StrandsError),
    /// The head mesh is unusable.
    Mesh(MeshError),
    /// A root names a triangle the mesh does not have (roots from another mesh?).
    RootOutOfRange {
        /// The root's index.
        root: usize,
        /// The triangle it names.
        triangle: u32,
        /// Triangles in the mesh.
        triangles: usize,
    },
    /// A root's barycentric coordinates are not finite.
    NonFiniteRoot {
        /// The root's index.
        root: usize,
    },
    /// Per-vertex weights do not match the vertices one to one.
    VertexWeightCountMismatch {
        /// Vertices in the mesh.
        vertices: usize,
        /// Weights given.
        weights: usize,
    },
    /// A root jitter outside 0..=1 (or NaN).
    Jitter(f32),
    /// No strands were given to take guides from.
    NoStrands,
    /// A given strand has fewer than two points, no length, or a NaN point.
    BadStrand {
        /// Its index.
        strand: usize,
    },
}

impl fmt::Display for GroomError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GroomError::NoScalp => write!(f, "no triangle of the head is marked as scalp"),
            GroomError::WeightCountMismatch { triangles, weights } => {
                write!(f, "{weights} scalp weights for {triangles} triangles")
            }
            GroomError::Strands(e) => e.fmt(f),
            GroomError::Mesh(e) => e.fmt(f),
            GroomError::RootOutOfRange { root, triangle, triangles } => {
                write!(f, "root {root} is on triangle {triangle}, but the mesh has {triangles} triangles")
            }
            GroomError::NonFiniteRoot { root } => write!(f, "root {root} has non-finite barycentric coordinates"),
            GroomError::VertexWeightCountMismatch { vertices, weights } => {
                write!(f, "{weights} scalp weights for {vertices} vertices")
            }
            GroomError::Jitter(j) => write!(f, "a root jitter of {j} was asked for; use 0 (on the vertex) to 1"),
            GroomError::NoStrands => write!(f, "no strands were given to take guides from"),
            GroomError::BadStrand { strand } => {
                write!(f, "strand {strand} has fewer than two points, no length, or a NaN point")
            }
        }
    }
}

impl std::error::Error for GroomError {}

impl From<MeshError> for GroomError {
    fn from(e: MeshError) -> Self {
        GroomError::Mesh(e)
    }
}

impl From<StrandsError> for GroomError {
    fn from(e: StrandsError) -> Self {
        GroomError::Strands(e)
    }
}

/// Samples `count` roots uniformly by area over the triangles, each triangle's area
/// multiplied by its weight (0 = no hair, 1 = full density). Sampling by area, not per
/// vertex, keeps density even where the mesh is finely tessellated. Independent random
/// roots clump and leave gaps; [`sample_roots_poisson`] spaces them evenly.
pub fn sample_roots(mesh: &HeadMesh, weights: &[f32], count: usize, seed: u64) -> Result<Vec<RootBinding>, GroomError> {
    let sampler = AreaSampler::new(mesh, weights)?;
    let mut rng = SplitMix64::new(seed);
    Ok((0..count).map(|_| sampler.sample(&mut rng)).collect())
}

/// Draws points uniformly over the weighted area of a mesh.
struct AreaSampler {
    /// Running sum of weighted triangle areas.
    cumulative: Vec<f64>,
    /// Each triangle's weight, made finite and clamped to 0..1.
    weights: Vec<f32>,
}

impl AreaSampler {
    fn new(mesh: &HeadMesh, weights: &[f32]) -> Result<Self, GroomError> {
        mesh.validate()?;
        if weights.len() != mesh.triangles.len() {
            return Err(GroomError::WeightCountMismatch { triangles: mesh.triangles.len(), weights: weights.len() });
        }
        let weights: Vec<f32> = weights.iter().map(|&w| if w.is_finite() { w.clamp(0.0, 1.0) } else { 0.0 }).collect();
        let mut cumulative = Vec::with_capacity(weights.len());
        let mut total = 0.0f64;
        for (t, &w) in weights.iter().enumerate() {
            total += (mesh.triangle_area(t) * w) as f64;
            cumulative.push(total);
        }
        // NaN: an area from a mesh that skipped validation.
        if total.is_nan() || total <= 0.0 {
            return Err(GroomError::NoScalp);
        }
        Ok(AreaSampler { cumulative, weights })
    }

    /// The summed weighted area, m².
    fn weighted_area(&self) -> f64 {
        self.cumulative.last().copied().unwrap_or(0.0)
    }

    /// The weight of triangle `t`, 0..1.
    fn weight(&self, t: u32) -> f32 {
        self.weights[t as usize]
    }

    fn sample(&self, rng: &mut SplitMix64) -> RootBinding {
        let target = rng.next_f64() * self.weighted_area();
        let triangle = self.cumulative.partition_point(|&c| c <= target).min(self.cumulative.len() - 1);
        // Uniform point in a triangle: fold the unit square onto it.
        let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        RootBinding { triangle: triangle as u32, barycentric: [1.0 - u - v, u, v] }
    }
}

/// How guide strands grow from their roots.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GuideParams {
    /// Segments per strand (the reference uses 10); particles = segments + 1.
    pub segments: usize,
    /// Strand length, metres.
    pub length: f32,
    /// Random length variation as a fraction of `length` (0.2 = ±20%).
    pub length_variation: f32,
    /// Curl: radians the growth direction turns per segment, around an axis across the
    /// strand (0 = straight).
    pub curl: f32,
    /// Combing, head-local: strands start along the surface normal tilted toward this
    /// direction (its part along the surface; length 1 tilts by 45°, zero keeps the
    /// normal). Pass the same vector to [`settle`] to brush the hair that way while it
    /// settles: combed back, the front hairline stays out of the face.
    pub comb: Vec3,
}

impl Default for GuideParams {
    fn default() -> Self {
        GuideParams { segments: 10, length: 0.2, length_variation: 0.2, curl: 0.0, comb: Vec3::ZERO }
    }
}

/// Grows one guide per root along the interpolated surface normal (the reference's
/// initial direction), tilted by `comb` and bending by `curl` per segment. Returns
/// head-local rest positions, strand-major, `segments + 1` per strand. Non-finite `comb`
/// components count as zero. The mesh and the roots are checked first: roots must lie on
/// this mesh's triangles.
pub fn grow_guides(
    mesh: &HeadMesh,
    roots: &[RootBinding],
    params: &GuideParams,
    seed: u64,
) -> Result<Vec<Vec3>, GroomError> {
    mesh.validate()?;
    for (root, binding) in roots.iter().enumerate() {
        if binding.triangle as usize >= mesh.triangles.len() {
            let triangles = mesh.triangles.len();
            return Err(GroomError::RootOutOfRange { root, triangle: binding.triangle, triangles });
        }
        if !binding.barycentric.iter().all(|b| b.is_finite()) {
            return Err(GroomError::NonFiniteRoot { root });
        }
    }
    let segments = params.segments.max(1);
    let mut rng = SplitMix64::new(seed ^ 0x6775_6964_6573);
    let comb = finite_or_zero(params.comb);
    let mut positions = Vec::with_capacity(roots.len() * (segments + 1));
    for root in roots {
        let variation = 1.0 + params.length_variation * (2.0 * rng.next_f32() - 1.0);
        let segment_length = (params.length * variation).max(1e-4) / segments as f32;
        let normal = root.normal(mesh);
        let mut direction = (normal + comb - normal * normal.dot(comb)).normalize_or(normal);
        let across = direction.any_orthonormal_vector();
        let mut p = root.position(mesh);
        positions.push(p);
        for _ in 0..segments {
            p += direction * segment_length;
            positions.push(p);
            direction = crate::math::Quat::from_axis_angle(across, params.curl) * direction;
        }
    }
    Ok(positions)
}

/// Guides taken from given strands (a `.hair` model, in the head mesh's space) instead of
/// grown: each resampled to `segments + 1` points evenly along its length, then moved
/// whole so that its root sits on the nearest point of the scalp (the triangles with a
/// weight above 0). Returns the roots and the rest positions, strand-major.
pub fn guides_from_strands(
    mesh: &HeadMesh,
    weights: &[f32],
    strands: &[Vec<Vec3>],
    segments: usize,
) -> Result<(Vec<RootBinding>, Vec<Vec3>), GroomError> {
    mesh.validate()?;
    if weights.len() != mesh.triangles.len() {
        return Err(GroomError::WeightCountMismatch { triangles: mesh.triangles.len(), weights: weights.len() });
    }
    let scalp: Vec<usize> = (0..weights.len()).filter(|&t| weights[t] > 0.0).collect();
    if scalp.is_empty() {
        return Err(GroomError::NoScalp);
    }
    if strands.is_empty() {
        return Err(GroomError::NoStrands);
    }
    let segments = segments.max(1);
    let mut roots = Vec::with_capacity(strands.len());
    let mut positions = Vec::with_capacity(strands.len() * (segments + 1));
    for (strand, points) in strands.iter().enumerate() {
        let resampled = resample(points, segments).ok_or(GroomError::BadStrand { strand })?;
        let root = resampled[0];
        let (triangle, barycentric) = scalp
            .iter()
            .map(|&t| {
                let bary = crate::mesh::closest_barycentric(root, &mesh.corners(&mesh.triangles[t]));
                (t, bary, mesh.point_at(t, bary).distance_squared(root))
            })
            .min_by(|a, b| a.2.total_cmp(&b.2))
            .map(|(t, bary, _)| (t as u32, bary))
            .expect("a scalp triangle");
        let binding = RootBinding { triangle, barycentric };
        let shift = binding.position(mesh) - root;
        positions.extend(resampled.iter().map(|&p| p + shift));
        roots.push(binding);
    }
    Ok((roots, positions))
}

/// `points` resampled to `segments + 1` points evenly spaced along the polyline; `None`
/// for fewer than two points, no length or a non-finite point.
fn resample(points: &[Vec3], segments: usize) -> Option<Vec<Vec3>> {
    if points.len() < 2 || !points.iter().all(|p| p.is_finite()) {
        return None;
    }
    let mut along = Vec::with_capacity(points.len());
    let mut total = 0.0f32;
    along.push(0.0);
    for pair in points.windows(2) {
        total += pair[0].distance(pair[1]);
        along.push(total);
    }
    if !(total > 0.0 && total.is_finite()) {
        return None;
    }
    let mut at = 0;
    Some(
        (0..=segments)
            .map(|k| {
                let target = total * k as f32 / segments as f32;
                while at + 2 < along.len() && along[at + 1] < target {
                    at += 1;
                }
                let span = (along[at + 1] - along[at]).max(f32::MIN_POSITIVE);
                points[at].lerp(points[at + 1], ((target - along[at]) / span).clamp(0.0, 1.0))
            })
            .collect(),
    )
}

/// `v` with its non-finite components replaced by zero.
fn finite_or_zero(v: Vec3) -> Vec3 {
    Vec3::from_array(v.to_array().map(|c| if c.is_finite() { c } else { 0.0 }))
}

/// Lets freshly grown strands fall under gravity onto the head for `steps` steps of
/// 1/60 s with no shape keeping, and returns where they came to rest: the "comb" pass
/// that makes a default groom drape instead of standing out like a hedgehog.
///
/// `comb` (head-local, as in [`GuideParams::comb`]) brushes the hair while it settles: it
/// adds `|gravity|·comb` to gravity, so hair combed back lies back over the crown instead of
/// sliding down into the face. The result is the rest shape that shape keeping then holds.
/// Non-finite components count as zero.
///
/// With [`SimParams::volume`] on, the strands keep each other out as they fall, so the
/// hair keeps a body instead of lying in one layer on the skull; the grown pose being no
/// groom yet, any cell may fill up to [`SETTLING_FLOOR`](crate::solver::SETTLING_FLOOR)
/// times the mean grown density before the pressure pushes.
pub fn settle(
    rest: RestShape,
    collider: Option<&HeadCollider>,
    params: &SimParams,
    steps: usize,
    comb: Vec3,
) -> Result<RestShape, GroomError> {
    let n = rest.particles_per_strand;
    let (mut params, _) = params.sanitized();
    params.local_stiffness = params.local_stiffness.min(0.05);
    params.global_stiffness_root = 0.0;
    params.global_stiffness_tip = 0.0;
    params.wind.strength = 0.0;
    params.drag = params.drag.max(8.0); // overdamped: settle, do not swing
    let gravity = Vec3::from_array(params.gravity);
    params.gravity = (gravity + finite_or_zero(comb) * gravity.length()).to_array();
    let volume = params.volume.enabled.then(|| {
        VolumeGrid::for_settling(&rest, params.volume.resolution, collider.map(HeadCollider::interior).as_ref())
    });
    let mut strands = Strands::new(rest, Pose::IDENTITY);
    if let Some(grid) = volume {
        strands.use_volume_grid(grid);
    }
    for k in 0..steps {
        let input = StepInput {
            dt: 1.0 / 60.0,
            time: k as f32 / 60.0,
            head_from: Pose::IDENTITY,
            head_to: Pose::IDENTITY,
            collider,
            extra_colliders: &[],
            surface_patch: None,
            params: &params,
        };
        strands.step(&input);
    }
    Ok(RestShape::new(strands.positions().to_vec(), n)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::test_head;

    fn top_half(mesh: &HeadMesh) -> Vec<f32> {
        mesh.triangles.iter().map(|t| if mesh.corners(t).iter().all(|p| p.y > 0.0) { 1.0 } else { 0.0 }).collect()
    }

    #[test]
    fn guides_from_strands_keep_their_shape_and_root_on_the_scalp() {
        let mesh = test_head(3);
        let scalp = top_half(&mesh);
        let roots = sample_roots(&mesh, &scalp, 40, 2).unwrap();
        let grown = grow_guides(&mesh, &roots, &GuideParams { curl: 0.2, ..GuideParams::default() }, 2).unwrap();
        // The same strands 2 mm off the scalp, at 21 points instead of 11.
        let strands: Vec<Vec<Vec3>> = grown
            .chunks_exact(11)
            .zip(&roots)
            .map(|(strand, root)| {
                let lift = root.normal(&mesh) * 0.002;
                let fine = resample(strand, 20).unwrap();
                fine.iter().map(|&p| p + lift).collect()
            })
            .collect();
        let (bound, rest) = guides_from_strands(&mesh, &scalp, &strands, 10).unwrap();
        assert_eq!((bound.len(), rest.len()), (40, 440));
        for ((binding, strand), original) in bound.iter().zip(rest.chunks_exact(11)).zip(grown.chunks_exact(11)) {
            assert!(scalp[binding.triangle as usize] > 0.0);
            assert!((strand[0] - binding.position(&mesh)).length() < 1e-6);
            // Back onto the scalp near where it grew (the nearest point to the lifted root),
            // the same shape (a curl resampled twice shortens its chords by a hair).
            assert!((strand[0] - original[0]).length() < 1e-3);
            for (p, q) in strand.iter().zip(original) {
                let (shape, expected) = (*p - strand[0], *q - original[0]);
                assert!((shape - expected).length() < 2e-4, "{shape} vs {expected}");
            }
        }
        assert_eq!(guides_from_strands(&mesh, &scalp, &[], 10), Err(GroomError::NoStrands));
        let bad = vec![vec![Vec3::ZERO]];
        assert_eq!(guides_from_strands(&mesh, &scalp, &bad, 10), Err(GroomError::BadStrand { strand: 0 }));
        let nowhere = vec![0.0; scalp.len()];
        assert_eq!(guides_from_strands(&mesh, &nowhere, &strands, 10), Err(GroomError::NoScalp));
    }

    #[test]
    fn roots_land_only_on_weighted_triangles_and_are_deterministic() {
        let mesh = test_head(3);
        let weights = top_half(&mesh);
        let roots = sample_roots(&mesh, &weights, 500, 7).unwrap();
        assert_eq!(roots.len(), 500);
        assert!(roots.iter().all(|r| weights[r.triangle as usize] == 1.0));
        assert!(roots.iter().all(|r| (r.barycentric.iter().sum::<f32>() - 1.0).abs() < 1e-5));
        assert!(roots.iter().all(|r| r.barycentric.iter().all(|&b| b >= 0.0)));
        assert_eq!(roots, sample_roots(&mesh, &weights, 500, 7).unwrap());
        assert_ne!(roots, sample_roots(&mesh, &weights, 500, 8).unwrap());
    }

    #[test]
    fn density_follows_area_not_vertex_count() {
        // Two triangles of equal area: one whole, the other split into 4 small ones.
        // Per-vertex sampling would favour the split half; area sampling gives ~50/50.
        let mut positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(3.0, 0.0, 0.0), Vec3::new(4.0, 0.0, 0.0)];
        positions.extend([
            Vec3::new(3.0, 1.0, 0.0),
            Vec3::new(3.5, 0.0, 0.0),
            Vec3::new(3.5, 0.5, 0.0),
            Vec3::new(3.0, 0.5, 0.0),
        ]);
        let triangles = vec![[0, 1, 2], [3, 6, 8], [6, 4, 7], [8, 7, 5], [6, 7, 8]];
        let mesh = HeadMesh::from_triangles(positions, triangles).unwrap();
        let roots = sample_roots(&mesh, &[1.0; 5], 4000, 1).unwrap();
        let on_big = roots.iter().filter(|r| r.triangle == 0).count() as f32 / 4000.0;
        assert!((on_big - 0.5).abs() < 0.03, "{on_big}");
    }

    #[test]
    fn no_scalp_is_an_error() {
        let mesh = test_head(1);
        let zero = vec![0.0; mesh.triangles.len()];
        assert_eq!(sample_roots(&mesh, &zero, 10, 0), Err(GroomError::NoScalp));
        assert!(matches!(sample_roots(&mesh, &[1.0], 10, 0), Err(GroomError::WeightCountMismatch { .. })));
    }

    #[test]
    fn bad_meshes_and_foreign_roots_are_errors_not_panics() {
        let mesh = test_head(2);
        let weights = vec![1.0; mesh.triangles.len()];
        // A triangle index out of range, and a mesh without normals.
        let mut broken = mesh.clone();
        broken.triangles[3] = [0, 1, 99_999];
        let no_normals = HeadMesh { normals: Vec::new(), ..mesh.clone() };
        for bad in [&broken, &no_normals] {
            assert!(matches!(sample_roots(bad, &weights, 10, 0), Err(GroomError::Mesh(_))));
            assert!(matches!(poisson::sample_roots_poisson(bad, &weights, 10, 0), Err(GroomError::Mesh(_))));
        }
        // Roots grown on a finer mesh handed to a coarser one.
        let finer = test_head(3);
        let foreign = sample_roots(&finer, &vec![1.0; finer.triangles.len()], 200, 1).unwrap();
        let err = grow_guides(&mesh, &foreign, &GuideParams::default(), 1).unwrap_err();
        assert!(matches!(err, GroomError::RootOutOfRange { .. }), "{err:?}");
        assert!(err.to_string().contains("but the mesh has 320 triangles"), "{err}");
        let nan = [RootBinding { triangle: 0, barycentric: [f32::NAN, 0.5, 0.5] }];
        assert_eq!(grow_guides(&mesh, &nan, &GuideParams::default(), 1), Err(GroomError::NonFiniteRoot { root: 0 }));
        assert!(matches!(grow_guides(&no_normals, &[], &GuideParams::default(), 1), Err(GroomError::Mesh(_))));
    }

    #[test]
    fn the_root_tangent_lies_in_the_surface_along_the_first_edge() {
        let flat = HeadMesh::from_triangles(vec![Vec3::ZERO, Vec3::X, Vec3::new(0.0, 0.0, -2.0)], vec![[0, 1, 2]]);
        let flat = flat.unwrap();
        let root = RootBinding { triangle: 0, barycentric: [0.2, 0.3, 0.5] };
        assert!((root.normal(&flat) - Vec3::Y).length() < 1e-6);
        assert!((root.tangent(&flat) - Vec3::X).length() < 1e-6);

        let mesh = test_head(3);
        for root in sample_roots(&mesh, &top_half(&mesh), 200, 4).unwrap() {
            let (t, n) = (root.tangent(&mesh), root.normal(&mesh));
            assert!((t.length() - 1.0).abs() < 1e-5 && t.dot(n).abs() < 1e-5, "{t} {n}");
            let [a, b, _] = mesh.corners(&mesh.triangles[root.triangle as usize]);
            assert!(t.dot((b - a).normalize()) > 0.9, "follows the first edge");
        }
    }

    #[test]
    fn guides_start_along_the_normal_with_the_asked_length() {
        let mesh = test_head(3);
        let roots = sample_roots(&mesh, &top_half(&mesh), 50, 3).unwrap();
        let params = GuideParams { segments: 10, length: 0.2, length_variation: 0.0, ..GuideParams::default() };
        let guides = grow_guides(&mesh, &roots, &params, 3).unwrap();
        assert_eq!(guides.len(), 50 * 11);
        for (strand, root) in guides.chunks_exact(11).zip(&roots) {
            assert!((strand[0] - root.position(&mesh)).length() < 1e-6);
            let dir = (strand[1] - strand[0]).normalize();
            assert!(dir.dot(root.normal(&mesh)) > 0.9999);
            assert!(((strand[10] - strand[0]).length() - 0.2).abs() < 1e-4);
        }
    }

    #[test]
    fn combing_tilts_the_start_along_the_surface_toward_the_comb() {
        let mesh = test_head(3);
        let roots = sample_roots(&mesh, &top_half(&mesh), 50, 3).unwrap();
        let back = Vec3::new(0.0, 0.0, -1.0);
        let combed = GuideParams { length_variation: 0.0, comb: back, ..GuideParams::default() };
        let bad = GuideParams { comb: Vec3::new(f32::NAN, f32::INFINITY, 0.0), ..combed };
        let guides = grow_guides(&mesh, &roots, &combed, 3).unwrap();
        let unharmed = grow_guides(&mesh, &roots, &bad, 3).unwrap();
        for ((strand, bad), root) in guides.chunks_exact(11).zip(unharmed.chunks_exact(11)).zip(&roots) {
            let n = root.normal(&mesh);
            let dir = (strand[1] - strand[0]).normalize();
            let along_surface = back - n * n.dot(back);
            if along_surface.length() > 0.5 {
                // Tilted by atan(|comb along the surface|) toward the back, still off the surface.
                let expected = along_surface.length().atan();
                assert!((dir.dot(n).acos() - expected).abs() < 1e-3, "tilt {} vs {expected}", dir.dot(n).acos());
                assert!(dir.dot(along_surface) > 0.0 && dir.dot(n) > 0.0);
            }
            assert!(bad.iter().all(|p| p.is_finite()), "a NaN comb grows finite strands");
            assert!(((strand[10] - strand[0]).length() - 0.2).abs() < 1e-4, "combing keeps the length");
        }
    }

    #[test]
    fn settling_drapes_the_hair_down_and_outside_the_head() {
        let mesh = test_head(3);
        let collider = HeadCollider::new(&mesh, 32).unwrap();
        let roots = sample_roots(&mesh, &top_half(&mesh), 40, 5).unwrap();
        let grown = grow_guides(&mesh, &roots, &GuideParams::default(), 5).unwrap();
        let rest = RestShape::new(grown, 11).unwrap();
        let mean_tip_y = |r: &RestShape| r.positions.chunks_exact(11).map(|s| s[10].y).sum::<f32>() / 40.0;
        let before = mean_tip_y(&rest);
        let settled = settle(rest, Some(&collider), &SimParams::default(), 240, Vec3::ZERO).unwrap();
        let after = mean_tip_y(&settled);
        assert!(after < before - 0.1, "tips fell from {before} to {after}");
        let deepest = settled.positions.iter().map(|&p| collider.signed_distance(p)).fold(f32::MAX, f32::min);
        assert!(deepest > -1e-3, "no particle inside the head: {deepest}");
    }

    #[test]
    fn combing_while_settling_lays_the_hair_toward_the_comb() {
        let mesh = test_head(3);
        let collider = HeadCollider::new(&mesh, 32).unwrap();
        let roots = sample_roots(&mesh, &top_half(&mesh), 40, 5).unwrap();
        let mean_tip_z = |comb: Vec3| {
            let grown = grow_guides(&mesh, &roots, &GuideParams { comb, ..GuideParams::default() }, 5).unwrap();
            let settled = settle(RestShape::new(grown, 11).unwrap(), Some(&collider), &SimParams::default(), 240, comb);
            let settled = settled.unwrap();
            let deepest = settled.positions.iter().map(|&p| collider.signed_distance(p)).fold(f32::MAX, f32::min);
            assert!(deepest > -1e-3, "no particle inside the head: {deepest}");
            settled.positions.chunks_exact(11).map(|s| s[10].z).sum::<f32>() / 40.0
        };
        let (plain, back) = (mean_tip_z(Vec3::ZERO), mean_tip_z(Vec3::new(0.0, 0.0, -1.5)));
        assert!(back < plain - 0.05, "combed back, tips at z = {back}; uncombed {plain}");
        assert!(mean_tip_z(Vec3::new(f32::NAN, 0.0, 0.0)).is_finite());
    }
}
