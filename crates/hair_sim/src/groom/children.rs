//! Child strands: extra rendered strands around each simulated guide, placed on the
//! reference's Archimedean spiral `x = (a + bθ) cos θ`, `y = (a + bθ) sin θ`, drawn toward
//! the guide along its length (clumping) and fanned out at the tip by a per-child random
//! direction.
//!
//! At the root the spiral lies on the scalp (its tangent plane, bent down by the scalp's
//! curvature), so children grow out of the skin beside their guide instead of floating
//! over it or starting under it; within the first segment it turns into the guide's own
//! frame. Along the strand an offset never points into the head: where a guide lies on
//! the head, its children spread beside and over it, not through the skull.
//!
//! Only guides are simulated; children follow them. These functions are the CPU reference
//! for the hair vertex shader, which mirrors them line by line and receives the
//! parameters already sanitized.

use super::curve::{
    CurvePoint, frame_at, perpendicular_unit, tessellate, tessellation_parameter, transport_frames, unit_or,
};
use crate::math::Vec3;
use crate::solver::ParamIssue;
use std::f32::consts::TAU;

#[cfg(feature = "reflect")]
use bevy_reflect::Reflect;

/// Most children per guide [`ChildParams::sanitized`] allows.
pub const MAX_CHILDREN_PER_GUIDE: u32 = 256;

/// The golden angle, π(3 − √5) radians (≈ 137.5°): consecutive children this far apart
/// never line up in radial arms, so a handful of them fill the disk around the guide
/// evenly in every direction.
pub const GOLDEN_ANGLE: f32 = 2.399_963_3;

/// The reference's Archimedean spiral, in spiral units, and its size in metres.
///
/// Child `k` (0-based) sits at angle `θ = (k + 1)·angle_step` and radius
/// `scale·(a + b·θ)` metres. The default (a = b = 2 as in the reference, golden-angle
/// steps, 0.125 mm per unit) puts 16 children between 0.85 mm (child 0) and 9.85 mm
/// (child 15) from the guide: a disk of about 1 cm radius. The radius grows linearly with
/// the child index, so more children cover a wider disk rather than a denser one.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "reflect", derive(Reflect))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
// Fields a saved preset lacks take their defaults.
#[cfg_attr(feature = "serde", serde(default))]
pub struct Spiral {
    /// Radius at θ = 0, spiral units.
    pub a: f32,
    /// Radius gained per radian, spiral units.
    pub b: f32,
    /// Angle between consecutive children, radians.
    pub angle_step: f32,
    /// Metres per spiral unit.
    pub scale: f32,
}

impl Default for Spiral {
    fn default() -> Self {
        Spiral { a: 2.0, b: 2.0, angle_step: GOLDEN_ANGLE, scale: 1.25e-4 }
    }
}

impl Spiral {
    /// The spiral angle θ of child `child` (0-based), radians.
    #[inline]
    pub fn angle(&self, child: u32) -> f32 {
        (child as f32 + 1.0) * self.angle_step
    }

    /// The distance of child `child` from the guide at the root, metres.
    #[inline]
    pub fn radius(&self, child: u32) -> f32 {
        self.scale * (self.a + self.b * self.angle(child))
    }
}

/// How child strands are placed around their guide.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "reflect", derive(Reflect))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
// Fields a saved preset lacks take their defaults.
#[cfg_attr(feature = "serde", serde(default))]
pub struct ChildParams {
    /// Children per guide, not counting the guide: a renderer draws the guide and
    /// `per_guide` children (0 = guides only).
    pub per_guide: u32,
    /// Where children sit around the guide at the root.
    pub spiral: Spiral,
    /// 0..1: how far the spiral offset shrinks from root to tip (`1 − clumping·t`);
    /// 1 brings every child onto its guide at the tip.
    pub clumping: f32,
    /// Metres a child's tip strays from the clumped position, in a random direction per
    /// child, growing as `t²` from nothing at the root.
    pub tip_spread: f32,
}

impl Default for ChildParams {
    /// 16 children in a ~1 cm disk, drawn 30% toward the guide at the tip (so strands
    /// taper into locks without merging), tips fanned out by 3 mm (a third of the disk, so
    /// lock ends look frayed rather than cut).
    fn default() -> Self {
        ChildParams { per_guide: 16, spiral: Spiral::default(), clumping: 0.3, tip_spread: 0.003 }
    }
}

impl ChildParams {
    /// Returns settings that always give finite children, and the fields that had to
    /// change: NaN or infinite values take the default, others are clamped to their range
    /// (spiral `a`, `b` 0..1000, `angle_step` 0..2π, `scale` 0..0.01 m, `clumping` 0..1,
    /// `tip_spread` 0..0.1 m, `per_guide` ≤ [`MAX_CHILDREN_PER_GUIDE`]).
    pub fn sanitized(&self) -> (ChildParams, Vec<ParamIssue>) {
        let mut issues = Vec::new();
        let params = self.sanitize_with(|issue| issues.push(issue));
        (params, issues)
    }

    /// [`Self::sanitized`], telling `report` about each change (no allocation when
    /// nothing needs reporting, so the per-point functions can afford it).
    fn sanitize_with(&self, mut report: impl FnMut(ParamIssue)) -> ChildParams {
        let defaults = ChildParams::default();
        let mut p = *self;
        let mut fix = |field: &'static str, value: &mut f32, default: f32, min: f32, max: f32| {
            let used = if value.is_finite() { value.clamp(min, max) } else { default };
            if used != *value {
                report(ParamIssue { field, given: *value, used });
            }
            *value = used;
        };
        fix("spiral.a", &mut p.spiral.a, defaults.spiral.a, 0.0, 1e3);
        fix("spiral.b", &mut p.spiral.b, defaults.spiral.b, 0.0, 1e3);
        fix("spiral.angle_step", &mut p.spiral.angle_step, defaults.spiral.angle_step, 0.0, TAU);
        fix("spiral.scale", &mut p.spiral.scale, defaults.spiral.scale, 0.0, 0.01);
        fix("clumping", &mut p.clumping, defaults.clumping, 0.0, 1.0);
        fix("tip_spread", &mut p.tip_spread, defaults.tip_spread, 0.0, 0.1);
        if p.per_guide > MAX_CHILDREN_PER_GUIDE {
            report(ParamIssue { field: "per_guide", given: p.per_guide as f32, used: MAX_CHILDREN_PER_GUIDE as f32 });
            p.per_guide = MAX_CHILDREN_PER_GUIDE;
        }
        p
    }
}

/// The offset of child `child` (0-based) from its guide at the root, metres, in the
/// guide's (u, v) frame: `scale·(a + bθ)·(cos θ, sin θ)`, `θ = (child + 1)·angle_step`.
/// Uses the spiral as given: sanitize it first ([`ChildParams::sanitized`]).
///
/// Mirrored in `src/render/hair.wgsl` (`fn spiral_offset`).
#[inline]
pub fn spiral_offset(spiral: &Spiral, child: u32) -> [f32; 2] {
    let theta = spiral.angle(child);
    let radius = spiral.radius(child);
    [radius * theta.cos(), radius * theta.sin()]
}

/// Where a guide's children start and which way is out of the head, world space in the
/// head's current pose: what keeps child strands on the scalp.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChildRoot {
    /// The guide's root tangent ([`RootBinding::tangent`](super::RootBinding::tangent)):
    /// the transport frames start from it, so children do not spin about their guide.
    pub u: Vec3,
    /// The scalp's outward normal at the root ([`RootBinding::normal`](super::RootBinding::normal)).
    pub normal: Vec3,
    /// The scalp's curvature at the root, 1/m, positive where it bulges as a skull does
    /// ([`RootBinding::curvature`](super::RootBinding::curvature)): a child root `r` from
    /// the guide's drops by `curvature · r² / 2`, onto the scalp.
    pub curvature: f32,
    /// A point inside the head, which "into the head" means toward: the centre of the
    /// head mesh's bounds.
    pub head_centre: Vec3,
}

/// The offset in the scalp's tangent plane, bent onto the scalp by its curvature: where a
/// child starts, relative to its guide's root. `u` is the guide's frame at the root.
///
/// Mirrored in `src/render/hair.wgsl` (`fn scalp_offset`).
#[inline]
fn scalp_offset(root: &ChildRoot, u: Vec3, [x, y]: [f32; 2]) -> Vec3 {
    let normal = unit_or(root.normal, Vec3::Y);
    let across = perpendicular_unit(u, normal);
    let curvature = if root.curvature.is_finite() { root.curvature.clamp(-MAX_CURVATURE, MAX_CURVATURE) } else { 0.0 };
    across * x + normal.cross(across) * y - normal * (0.5 * curvature * (x * x + y * y))
}

/// The most curvature [`ChildRoot::curvature`] is trusted with, 1/m (a 1 cm radius): a
/// sharper estimate comes from a sliver, not from a scalp.
pub const MAX_CURVATURE: f32 = 100.0;

/// How much of a child's offset is still the scalp's at particle parameter `s`: 1 at the
/// root, easing to 0 at the second particle.
///
/// Mirrored in `src/render/hair.wgsl` (`fn on_scalp`).
#[inline]
fn on_scalp(s: f32) -> f32 {
    let s = if s.is_nan() { 0.0 } else { s.clamp(0.0, 1.0) };
    1.0 - s * s * (3.0 - 2.0 * s)
}

/// `offset` without its part pointing from `at` toward the head centre.
///
/// Mirrored in `src/render/hair.wgsl` (`fn outside_only`).
#[inline]
fn outside_only(offset: Vec3, at: Vec3, root: &ChildRoot) -> Vec3 {
    let out = unit_or(at - root.head_centre, unit_or(root.normal, Vec3::Y));
    offset - out * offset.dot(out).min(0.0)
}

/// The PCG hash (Jarzynski & Olano 2020, "Hash Functions for GPU Rendering"): 32 well
/// mixed bits from 32, the same on the CPU and in WGSL.
///
/// Mirrored in `src/render/hair.wgsl` (`fn pcg_hash`).
#[inline]
pub fn pcg_hash(x: u32) -> u32 {
    let state = x.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// [`pcg_hash`] as a float uniform in [0, 1): its top 24 bits, which an f32 holds exactly.
///
/// Mirrored in `src/render/hair.wgsl` (`fn hash_unit`).
#[inline]
pub fn hash_unit(x: u32) -> f32 {
    (pcg_hash(x) >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// The offset of child `child` of guide `guide` from the guide, metres, in the guide's
/// (u, v) frame at `t` (0 root → 1 tip; clamped, NaN reads as 0):
/// `spiral_offset·(1 − clumping·t) + tip_spread·t²·(cos φ, sin φ)`, with the tip direction
/// `φ = 2π·hash_unit(guide·65536 + child)` (wrapping; unique per child while
/// `guide < 65536`, beyond that two children may merely share a tip direction).
/// Sanitizes `params` first, so the result is always finite.
///
/// Mirrored in `src/render/hair.wgsl` (`fn child_offset`).
pub fn child_offset(params: &ChildParams, guide: u32, child: u32, t: f32) -> [f32; 2] {
    sanitized_offset(&params.sanitize_with(|_| ()), guide, child, t)
}

/// [`child_offset`] with `params` already sanitized.
#[inline]
fn sanitized_offset(params: &ChildParams, guide: u32, child: u32, t: f32) -> [f32; 2] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let [x, y] = spiral_offset(&params.spiral, child);
    let shrink = 1.0 - params.clumping * t;
    let phi = TAU * hash_unit(guide.wrapping_mul(65_536).wrapping_add(child));
    let spread = params.tip_spread * t * t;
    [x * shrink + spread * phi.cos(), y * shrink + spread * phi.sin()]
}

/// Child `child` of guide `guide`, tessellated like the guide: [`tessellate`] the guide
/// particles, and move each point by [`child_offset`] `(x, y)`. Along the strand that
/// offset is `x·u + y·v` in the parallel-transport frame there ([`transport_frames`],
/// [`frame_at`]) less any part pointing into the head (toward `root.head_centre`); at the
/// root it lies on the scalp instead (in the tangent plane across `root.normal`, dropped
/// by the curvature), easing into the guide's frame by the second particle. `t` is the
/// particle parameter as a fraction of the strand (`s / (n − 1)`), not arc length:
/// simulated segments keep their length, so the two agree.
///
/// The tangent is the guide's at the same parameter, not the child's own: offsets are at
/// most about a centimetre on a strand of ~20 cm, so they differ by a few degrees at most,
/// and the shader saves a second curve evaluation per vertex.
///
/// Mirrored in `src/render/hair.wgsl` (`fn strand_point`).
pub fn child_curve(
    guide_points: &[Vec3],
    root: &ChildRoot,
    params: &ChildParams,
    guide: u32,
    child: u32,
    subdivisions: u32,
) -> Vec<CurvePoint> {
    let params = params.sanitize_with(|_| ());
    let frames = transport_frames(guide_points, root.u);
    child_curve_sanitized(guide_points, &frames, root, &params, guide, child, subdivisions)
}

/// All `per_guide` children of guide `guide` (see [`child_curve`]), after sanitizing
/// `params`; the frames are built once for all of them.
pub fn child_curves(
    guide_points: &[Vec3],
    root: &ChildRoot,
    params: &ChildParams,
    guide: u32,
    subdivisions: u32,
) -> Vec<Vec<CurvePoint>> {
    let params = params.sanitize_with(|_| ());
    let frames = transport_frames(guide_points, root.u);
    (0..params.per_guide)
        .map(|child| child_curve_sanitized(guide_points, &frames, root, &params, guide, child, subdivisions))
        .collect()
}

fn child_curve_sanitized(
    guide_points: &[Vec3],
    frames: &[Vec3],
    root: &ChildRoot,
    params: &ChildParams,
    guide: u32,
    child: u32,
    subdivisions: u32,
) -> Vec<CurvePoint> {
    let subdivisions = subdivisions.max(1);
    let last = guide_points.len().saturating_sub(1).max(1) as f32;
    let root_u = frames.first().copied().unwrap_or(Vec3::X);
    tessellate(guide_points, subdivisions)
        .into_iter()
        .enumerate()
        .map(|(k, point)| {
            let s = tessellation_parameter(k, subdivisions);
            let (u, v) = frame_at(frames, s, point.tangent);
            let offset = sanitized_offset(params, guide, child, s / last);
            let [x, y] = offset;
            let along_guide = outside_only(u * x + v * y, point.position, root);
            let w = on_scalp(s);
            let moved = scalp_offset(root, root_u, offset) * w + along_guide * (1.0 - w);
            CurvePoint { position: point.position + moved, tangent: point.tangent }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::groom::curve::evaluate;

    fn guide() -> Vec<Vec3> {
        (0..11)
            .map(|j| {
                let j = j as f32;
                Vec3::new(0.02 + 0.01 * (j * 0.5).sin(), 0.1 + 0.02 * j, 0.03 - 0.002 * j * j * 0.1)
            })
            .collect()
    }

    #[test]
    fn pcg_hash_matches_the_published_function() {
        // The published GLSL, in 64-bit arithmetic truncated to 32 bits.
        let reference = |x: u32| {
            let state = (x as u64 * 747_796_405 + 2_891_336_453) as u32;
            let word = (((state >> ((state >> 28) + 4)) ^ state) as u64 * 277_803_737) as u32;
            (word >> 22) ^ word
        };
        for x in [0u32, 1, 2, 65_536, 123_456_789, u32::MAX] {
            assert_eq!(pcg_hash(x), reference(x), "{x}");
        }
        assert_eq!([pcg_hash(0), pcg_hash(1)], [129_708_002, 2_831_084_092]); // from a Python transcription
        let units: Vec<f32> = (0..10_000).map(hash_unit).collect();
        assert!(units.iter().all(|u| (0.0..1.0).contains(u)));
        let mean = units.iter().sum::<f32>() / 10_000.0;
        assert!((mean - 0.5).abs() < 0.01, "{mean}");
    }

    #[test]
    fn the_default_spiral_fills_a_centimetre_disk() {
        let spiral = Spiral::default();
        let radii: Vec<f32> = (0..16).map(|k| spiral.radius(k)).collect();
        assert!((radii[0] - 0.85e-3).abs() < 1e-5, "{}", radii[0]);
        assert!((radii[15] - 9.85e-3).abs() < 1e-5, "{}", radii[15]);
        assert!(radii.windows(2).all(|w| w[1] > w[0]));
        // Golden-angle steps spread the 16 over all directions: every 90° quadrant holds
        // at least 3 of them.
        let mut quadrants = [0; 4];
        for k in 0..16 {
            let [x, y] = spiral_offset(&spiral, k);
            quadrants[(y.atan2(x).rem_euclid(TAU) / (TAU / 4.0)) as usize % 4] += 1;
        }
        assert!(quadrants.iter().all(|&q| q >= 3), "{quadrants:?}");
    }

    #[test]
    fn at_the_root_a_child_sits_on_the_spiral() {
        let params = ChildParams::default();
        for child in 0..16 {
            let theta = (child + 1) as f32 * GOLDEN_ANGLE;
            let radius = 1.25e-4 * (2.0 + 2.0 * theta);
            for guide in [0, 7, 1000] {
                let [x, y] = child_offset(&params, guide, child, 0.0);
                assert!(((x * x + y * y).sqrt() - radius).abs() <= 1e-6);
                assert!((x - radius * theta.cos()).abs() <= 1e-7 && (y - radius * theta.sin()).abs() <= 1e-7);
            }
        }
    }

    #[test]
    fn clumping_and_tip_spread_shape_the_offset() {
        let params = ChildParams { clumping: 1.0, tip_spread: 0.0, ..ChildParams::default() };
        assert_eq!(child_offset(&params, 3, 5, 1.0), [0.0, 0.0]);
        let half = child_offset(&params, 3, 5, 0.5);
        let root = child_offset(&params, 3, 5, 0.0);
        assert!((half[0] - root[0] / 2.0).abs() < 1e-9 && (half[1] - root[1] / 2.0).abs() < 1e-9);

        let params = ChildParams { clumping: 1.0, tip_spread: 0.004, ..ChildParams::default() };
        let tip = child_offset(&params, 3, 5, 1.0);
        assert!((tip[0].hypot(tip[1]) - 0.004).abs() < 1e-7);
        let phi = TAU * hash_unit(3 * 65_536 + 5);
        assert!((tip[0] - 0.004 * phi.cos()).abs() < 1e-7 && (tip[1] - 0.004 * phi.sin()).abs() < 1e-7);
        // Tip directions differ from child to child.
        let other = child_offset(&params, 3, 6, 1.0);
        assert!((tip[0] - other[0]).hypot(tip[1] - other[1]) > 1e-4);
    }

    #[test]
    fn bad_settings_are_replaced_and_named() {
        let bad = ChildParams {
            per_guide: 100_000,
            spiral: Spiral { a: f32::NAN, b: -1.0, angle_step: 100.0, scale: f32::INFINITY },
            clumping: 2.0,
            tip_spread: -0.0,
        };
        let (fixed, issues) = bad.sanitized();
        assert_eq!(fixed.per_guide, MAX_CHILDREN_PER_GUIDE);
        assert_eq!(fixed.spiral, Spiral { a: 2.0, b: 0.0, angle_step: TAU, scale: 1.25e-4 });
        assert_eq!((fixed.clumping, fixed.tip_spread), (1.0, 0.0));
        let fields: Vec<_> = issues.iter().map(|i| i.field).collect();
        assert_eq!(fields, ["spiral.a", "spiral.b", "spiral.angle_step", "spiral.scale", "clumping", "per_guide"]);
        assert!(ChildParams::default().sanitized().1.is_empty());
        // The per-point functions sanitize too.
        let [x, y] = child_offset(&bad, 1, 2, f32::NAN);
        assert!(x.is_finite() && y.is_finite());
    }

    /// A flat scalp across the first segment, the head far behind the root: the spiral
    /// and the guide's frame agree at the root, and nothing points into the head.
    fn flat_root(points: &[Vec3], u: Vec3) -> ChildRoot {
        let first = (points[1] - points[0]).normalize();
        ChildRoot { u, normal: first, curvature: 0.0, head_centre: points[0] - first * 1e3 }
    }

    #[test]
    fn a_child_curve_starts_on_the_spiral_around_the_guide_root() {
        let points = guide();
        let params = ChildParams::default();
        let first = (points[1] - points[0]).normalize();
        let root_u = Vec3::X;
        for child in [0, 7, 15] {
            let curve = child_curve(&points, &flat_root(&points, root_u), &params, 4, child, 4);
            assert_eq!(curve.len(), 41);
            let offset = curve[0].position - points[0];
            assert!((offset.length() - params.spiral.radius(child)).abs() <= 1e-6);
            assert!(offset.dot(first).abs() <= 1e-7, "in the plane across the first segment");
            // Along u = root_u made perpendicular to the first segment, at angle θ.
            let u = (root_u - first * first.dot(root_u)).normalize();
            let theta = params.spiral.angle(child);
            assert!((offset.dot(u) - params.spiral.radius(child) * theta.cos()).abs() <= 1e-6);
            for (k, p) in curve.iter().enumerate() {
                let guide_point = evaluate(&points, k as f32 / 4.0);
                assert!((p.tangent.length() - 1.0).abs() <= 1e-4);
                assert_eq!(p.tangent, guide_point.tangent);
                // Never further from the guide than the root offset plus the tip spread.
                let distance = (p.position - guide_point.position).length();
                assert!(distance <= params.spiral.radius(child) + params.tip_spread + 1e-6);
            }
        }
    }

    #[test]
    fn full_clumping_brings_the_tip_onto_the_guide_tip() {
        let points = guide();
        for tip_spread in [0.0, 0.002] {
            let params = ChildParams { clumping: 1.0, tip_spread, ..ChildParams::default() };
            for child in 0..16 {
                let tip =
                    child_curve(&points, &flat_root(&points, Vec3::Z), &params, 9, child, 3).last().unwrap().position;
                // The tip spread, less any part of it that would point into the head.
                let miss = (tip - points[10]).length();
                assert!(miss <= tip_spread + 1e-6 && miss >= 0.5 * tip_spread, "child {child}: {miss}");
            }
        }
    }

    #[test]
    fn child_curves_gives_per_guide_children() {
        let points = guide();
        let params = ChildParams { per_guide: 5, ..ChildParams::default() };
        let root = flat_root(&points, Vec3::X);
        let children = child_curves(&points, &root, &params, 2, 3);
        assert_eq!(children.len(), 5);
        for (child, curve) in children.iter().enumerate() {
            assert_eq!(curve, &child_curve(&points, &root, &params, 2, child as u32, 3));
        }
        assert!(child_curves(&points, &root, &ChildParams { per_guide: 0, ..params }, 2, 3).is_empty());
    }

    #[test]
    fn at_the_root_children_lie_on_the_scalp_and_never_point_into_the_head() {
        // A guide leaving a sphere of radius 8 cm at 45° to its normal, then lying along it.
        let radius = 0.08;
        let normal = Vec3::new(0.0, 1.0, 0.0);
        let root_point = normal * radius;
        let points: Vec<Vec3> = (0..11)
            .map(|j| {
                let angle = 0.02 * j as f32 / radius; // 2 cm per segment along a great circle
                Vec3::new(angle.sin(), angle.cos(), 0.0) * (radius + 0.003 * (j as f32).min(1.0))
            })
            .collect();
        let root = ChildRoot { u: Vec3::Z, normal, curvature: 1.0 / radius, head_centre: Vec3::ZERO };
        let params = ChildParams { per_guide: 16, tip_spread: 0.0, ..ChildParams::default() };
        for (child, curve) in child_curves(&points, &root, &params, 0, 4).iter().enumerate() {
            // Root: r from the guide's root, on the tangent plane dropped onto the sphere.
            let start = curve[0].position;
            let r = params.spiral.radius(child as u32);
            assert!(((start - root_point).length() - r).abs() < 1e-4 * r.max(1e-3) + 2e-5);
            let off_sphere = (start.length() - radius).abs();
            assert!(off_sphere < 5e-5, "child {child} root {:.3} mm off the scalp", off_sphere * 1e3);
            // Along the strand: never closer to the centre than the guide point is, less the
            // sagitta of a 1 cm step over the sphere.
            for (point, guide_point) in curve.iter().zip(tessellate(&points, 4)) {
                let sagitta = r * r / (2.0 * radius);
                assert!(point.position.length() >= guide_point.position.length() - sagitta - 1e-6);
            }
        }
    }
}
