//! Smooth strands through guide particles: a C1 cubic Bézier (Catmull-Rom) curve, and
//! parallel-transport frames along it for placing child strands.
//!
//! These functions are the CPU reference for the hair vertex shader, which mirrors them
//! line by line: plain f32, few branches, and a finite, unit-length result for any finite
//! input (repeated particles, two-particle strands, strands folded back on themselves).
//!
//! Parameter `s` runs over particles: `s = j` is particle `j`, `s` in `[0, n − 1]`.

use crate::math::Vec3;

/// Squared length below which a vector has no usable direction.
const MIN_LENGTH_SQUARED: f32 = 1e-20;

/// `1 + cos` of a turn between two directions below which the turn counts as a full
/// reversal, whose minimal rotation is undefined.
const REVERSAL: f32 = 1e-4;

/// A point on a smoothed strand.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurvePoint {
    /// Position, in the space of the particles.
    pub position: Vec3,
    /// Unit tangent, pointing root → tip.
    pub tangent: Vec3,
}

/// `v` normalised, or `fallback` when `v` is (near) zero or not finite.
///
/// Mirrored in `crates/hair_gpu/src/curve.wgsl` (`fn unit_or`), which the renderer and the
/// GPU solver's drawing pass share.
#[inline]
pub(crate) fn unit_or(v: Vec3, fallback: Vec3) -> Vec3 {
    unit_or_else(v, || fallback)
}

/// [`unit_or`] with the fallback worked out only when it is needed (it is rarely, and a
/// fallback direction costs a square root of its own).
#[inline]
fn unit_or_else(v: Vec3, fallback: impl FnOnce() -> Vec3) -> Vec3 {
    let len2 = v.length_squared();
    if len2 > MIN_LENGTH_SQUARED && len2.is_finite() { v / len2.sqrt() } else { fallback() }
}

/// A unit vector perpendicular to the unit vector `axis`: the world axis least aligned with
/// it, made perpendicular. Used where a direction is undefined, so frames never go NaN.
///
/// Mirrored in `crates/hair_gpu/src/curve.wgsl` (`fn fallback_axis`), which the renderer and the
/// GPU solver's drawing pass share.
#[inline]
pub(crate) fn fallback_axis(axis: Vec3) -> Vec3 {
    let world = if axis.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
    unit_or(world - axis * axis.dot(world), Vec3::Z)
}

/// The part of `v` perpendicular to the unit vector `axis`, normalised (Gram-Schmidt);
/// [`fallback_axis`] when `v` is (nearly) parallel to `axis`.
///
/// Mirrored in `crates/hair_gpu/src/curve.wgsl` (`fn perpendicular_unit`), which the renderer and the
/// GPU solver's drawing pass share.
#[inline]
pub(crate) fn perpendicular_unit(v: Vec3, axis: Vec3) -> Vec3 {
    unit_or_else(v - axis * axis.dot(v), || fallback_axis(axis))
}

/// Particle `i` of the strand, with the missing neighbours past either end mirrored:
/// `p[−1] = 2 p[0] − p[1]`, `p[n] = 2 p[n−1] − p[n−2]`. Needs `points.len() >= 2`.
#[inline]
fn particle(points: &[Vec3], i: isize) -> Vec3 {
    let n = points.len() as isize;
    if i < 0 {
        2.0 * points[0] - points[1]
    } else if i >= n {
        2.0 * points[(n - 1) as usize] - points[(n - 2) as usize]
    } else {
        points[i as usize]
    }
}

/// The four Bézier control points of the curve from particle `segment` to `segment + 1`
/// (clamped to the last segment), with Catmull-Rom inner controls
/// `c1 = p[i] + (p[i+1] − p[i−1]) / 6`, `c2 = p[i+1] − (p[i+2] − p[i]) / 6` and mirrored
/// neighbours at the ends. The pieces join with equal first derivatives (C1) and the
/// curve passes through every particle. Fewer than two particles give the one particle
/// (or the origin) four times.
///
/// Mirrored in `crates/hair_gpu/src/curve.wgsl` (inlined in `fn bezier_point`).
pub fn bezier_controls(points: &[Vec3], segment: usize) -> [Vec3; 4] {
    if points.len() < 2 {
        return [points.first().copied().unwrap_or(Vec3::ZERO); 4];
    }
    let i = segment.min(points.len() - 2) as isize;
    let (prev, p0, p1, next) =
        (particle(points, i - 1), particle(points, i), particle(points, i + 1), particle(points, i + 2));
    [p0, p0 + (p1 - prev) / 6.0, p1 - (next - p0) / 6.0, p1]
}

/// The curve at parameter `s` (particle `j` at `s = j`; clamped to `[0, n − 1]`, NaN reads
/// as 0). The tangent is the normalised derivative; where that vanishes (repeated
/// particles), the segment's direction, then +Y, so it is never NaN for finite particles.
///
/// Mirrored in `src/render/strand.wgsl` (`fn evaluate`, with `curve.wgsl`'s `fn bezier_point`).
pub fn evaluate(points: &[Vec3], s: f32) -> CurvePoint {
    if points.len() < 2 {
        return CurvePoint { position: points.first().copied().unwrap_or(Vec3::ZERO), tangent: Vec3::Y };
    }
    let last = (points.len() - 1) as f32;
    let s = if s.is_nan() { 0.0 } else { s.clamp(0.0, last) };
    // At s = n − 1 this is the end (t = 1) of the last segment.
    let segment = (s.floor() as usize).min(points.len() - 2);
    let t = s - segment as f32;
    let [c0, c1, c2, c3] = bezier_controls(points, segment);
    let r = 1.0 - t;
    let position = c0 * (r * r * r) + c1 * (3.0 * r * r * t) + c2 * (3.0 * r * t * t) + c3 * (t * t * t);
    let derivative = (c1 - c0) * (3.0 * r * r) + (c2 - c1) * (6.0 * r * t) + (c3 - c2) * (3.0 * t * t);
    let tangent = unit_or(derivative, unit_or(c3 - c0, Vec3::Y));
    CurvePoint { position, tangent }
}

/// The parameter of tessellated point `k` with `subdivisions` points per segment.
#[inline]
pub(crate) fn tessellation_parameter(k: usize, subdivisions: u32) -> f32 {
    k as f32 / subdivisions as f32
}

/// `subdivisions` (at least 1) points per segment along the curve: `(n − 1)·S + 1` points
/// for `n >= 1` particles (none for none), point `k` at `s = k / S`, so every S-th point
/// is a particle.
///
/// Mirrored in `src/render/hair.wgsl` (the vertex index → `s` mapping in `fn vertex`).
pub fn tessellate(points: &[Vec3], subdivisions: u32) -> Vec<CurvePoint> {
    if points.is_empty() {
        return Vec::new();
    }
    let subdivisions = subdivisions.max(1);
    let count = (points.len() - 1) * subdivisions as usize + 1;
    (0..count).map(|k| evaluate(points, tessellation_parameter(k, subdivisions))).collect()
}

/// Turns `v` by the minimal rotation that takes the unit direction `a` onto the unit
/// direction `b` (Rodrigues with `k = a × b`, `c = a · b`:
/// `v c + k × v + k (k · v) / (1 + c)`), and returns it perpendicular to `b` and unit
/// length. For a full reversal (`c ≈ −1`, no unique minimal rotation) it turns by π about
/// `v` itself, i.e. keeps `v`.
///
/// Mirrored in `crates/hair_gpu/src/curve.wgsl` (`fn transport`).
#[inline]
fn transport(v: Vec3, a: Vec3, b: Vec3) -> Vec3 {
    let k = a.cross(b);
    let c = a.dot(b);
    let rotated = if 1.0 + c > REVERSAL { v * c + k.cross(v) + k * (k.dot(v) / (1.0 + c)) } else { v };
    perpendicular_unit(rotated, b)
}

/// Parallel-transport frames: one unit `u` per particle, perpendicular to the curve's
/// tangent at that particle (the Catmull-Rom direction `p[j+1] − p[j−1]`, which at the
/// root is the first segment's direction). `u` at the root is `root_u` made perpendicular
/// to it (a fallback axis when `root_u` is parallel or not finite); each next `u` is the
/// previous one turned by the minimal rotation between the two tangents, so the frame
/// does not twist around the strand.
///
/// The renderer computes these on the CPU each frame and uploads them with the particles
/// (`src/render/strand.wgsl` reads them in `fn frame_u`, through
/// [`transport_frames_of_strands`]); for a groom the GPU steps, `hair_gpu`'s drawing pass
/// computes them on the GPU (`draw.wgsl`).
pub fn transport_frames(points: &[Vec3], root_u: Vec3) -> Vec<Vec3> {
    let mut frames = vec![Vec3::ZERO; points.len()];
    frames_side_by_side([points], [root_u], &mut frames);
    frames
}

/// Strands side by side in [`transport_frames_of_strands`]: each frame waits on the one
/// before it (a square root and two divisions), so one strand alone leaves the CPU idle
/// between them, and four let it work on the others meanwhile.
const STRANDS_SIDE_BY_SIDE: usize = 4;

/// [`transport_frames`] of every strand of `points` (strand-major, `n` particles each;
/// strand `s` starts from `root_u(s)`), appended to `frames` strand by strand: the same
/// frames to the bit, four strands at a time (their chains overlap).
pub fn transport_frames_of_strands(points: &[Vec3], n: usize, root_u: impl Fn(usize) -> Vec3, frames: &mut Vec<Vec3>) {
    if n == 0 {
        return;
    }
    let start = frames.len();
    frames.resize(start + points.len(), Vec3::ZERO);
    let out = &mut frames[start..];
    let side_by_side = n * STRANDS_SIDE_BY_SIDE;
    let whole = points.len() / side_by_side * side_by_side;
    for (batch, (strands, out)) in
        points[..whole].chunks_exact(side_by_side).zip(out.chunks_exact_mut(side_by_side)).enumerate()
    {
        let first = batch * STRANDS_SIDE_BY_SIDE;
        let strands: [&[Vec3]; STRANDS_SIDE_BY_SIDE] = std::array::from_fn(|k| &strands[k * n..][..n]);
        frames_side_by_side(strands, std::array::from_fn(|k| root_u(first + k)), out);
    }
    // The strands left over (and a last, short one), one at a time.
    let first = whole / n;
    for (k, (strand, out)) in points[whole..].chunks(n).zip(out[whole..].chunks_mut(n)).enumerate() {
        frames_side_by_side([strand], [root_u(first + k)], out);
    }
}

/// The frames of `K` strands of as many particles into `out` (strand by strand), stepped
/// side by side so that their chains overlap.
#[inline(always)]
fn frames_side_by_side<const K: usize>(strands: [&[Vec3]; K], root_u: [Vec3; K], out: &mut [Vec3]) {
    let n = strands[0].len();
    if n == 0 {
        return;
    }
    let mut tangents = strands.map(|strand| knot_tangent(strand, 0));
    let mut us = [Vec3::ZERO; K];
    for k in 0..K {
        us[k] = perpendicular_unit(root_u[k], tangents[k]);
        out[k * n] = us[k];
    }
    for j in 1..n {
        for k in 0..K {
            let next = knot_tangent(strands[k], j);
            us[k] = transport(us[k], tangents[k], next);
            tangents[k] = next;
            out[k * n + j] = us[k];
        }
    }
}

/// [`evaluate`]`(points, j).tangent` at particle `j`, to the bit for finite particles, for
/// a fraction of the work (the renderer asks it of every particle every frame): at a knot
/// the cubic's derivative is three times its first control leg (its last at the tip),
/// and the other terms are zero.
#[inline]
fn knot_tangent(points: &[Vec3], j: usize) -> Vec3 {
    if points.len() < 2 {
        return Vec3::Y;
    }
    let i = j.min(points.len() - 2) as isize;
    let (p0, p1) = (particle(points, i), particle(points, i + 1));
    let derivative = if j as isize == i {
        let c1 = p0 + (p1 - particle(points, i - 1)) / 6.0;
        (c1 - p0) * 3.0
    } else {
        let c2 = p1 - (particle(points, i + 2) - p0) / 6.0;
        (p1 - c2) * 3.0
    };
    unit_or_else(derivative, || unit_or(p1 - p0, Vec3::Y))
}

/// The frame `(u, v)` at parameter `s` (clamped, NaN reads as 0): the two neighbouring
/// particles' `u` lerped, made perpendicular to `tangent` (Gram-Schmidt), and
/// `v = tangent × u`. With the curve's unit tangent, `(u, v, tangent)` is orthonormal and
/// right-handed. Never NaN: degenerate cases fall back to a fixed axis.
///
/// Mirrored in `src/render/hair.wgsl` (`fn frame_at`).
pub fn frame_at(frames: &[Vec3], s: f32, tangent: Vec3) -> (Vec3, Vec3) {
    let tangent = unit_or(tangent, Vec3::Y);
    let lerped = match frames.len() {
        0 => fallback_axis(tangent),
        1 => frames[0],
        n => {
            let s = if s.is_nan() { 0.0 } else { s.clamp(0.0, (n - 1) as f32) };
            let j = (s.floor() as usize).min(n - 2);
            frames[j].lerp(frames[j + 1], s - j as f32)
        }
    };
    let u = perpendicular_unit(lerped, tangent);
    (u, tangent.cross(u))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Quat;

    #[test]
    fn knot_tangents_are_evaluates_to_the_bit() {
        // A curled strand, a straight one, one with repeated particles, and two particles.
        let curl: Vec<Vec3> = (0..16)
            .map(|j| Vec3::new((j as f32 * 0.7).cos() * 0.01, -0.013 * j as f32, (j as f32 * 0.7).sin() * 0.01))
            .collect();
        let straight: Vec<Vec3> = (0..9).map(|j| Vec3::new(0.0, -0.02 * j as f32, 0.0)).collect();
        let repeated = vec![Vec3::ZERO, Vec3::ZERO, Vec3::X, Vec3::X, Vec3::new(1.0, 1.0, 0.0)];
        let two = vec![Vec3::ZERO, Vec3::new(0.0, -0.1, 0.0)];
        for points in [curl, straight, repeated, two] {
            for j in 0..points.len() {
                let (fast, slow) = (knot_tangent(&points, j), evaluate(&points, j as f32).tangent);
                assert_eq!(fast.to_array().map(f32::to_bits), slow.to_array().map(f32::to_bits), "particle {j}");
            }
        }
    }

    #[test]
    fn strands_side_by_side_get_each_strands_own_frames_to_the_bit() {
        // Eleven strands of 7 (two batches of four and three left over), each curled its
        // own way, with repeated particles in one and a root direction along the strand in
        // another; then the same with a last strand short of particles.
        let n = 7;
        let strand = |s: usize| -> Vec<Vec3> {
            (0..n)
                .map(|j| {
                    let a = j as f32 * (0.3 + 0.1 * s as f32);
                    if s == 5 && j < 3 {
                        Vec3::ZERO
                    } else {
                        Vec3::new(a.cos() * 0.01, -0.02 * j as f32, a.sin() * 0.01)
                    }
                })
                .collect()
        };
        let root_u = |s: usize| if s == 2 { Vec3::NEG_Y } else { Quat::from_rotation_y(s as f32).mul_vec3(Vec3::X) };
        let points: Vec<Vec3> = (0..11).flat_map(strand).collect();
        let bits = |v: &[Vec3]| v.iter().map(|u| u.to_array().map(f32::to_bits)).collect::<Vec<_>>();
        for points in [&points[..], &points[..points.len() - 3]] {
            let mut frames = vec![Vec3::NAN]; // appended after what is there
            transport_frames_of_strands(points, n, root_u, &mut frames);
            let one_by_one: Vec<Vec3> =
                points.chunks(n).enumerate().flat_map(|(s, strand)| transport_frames(strand, root_u(s))).collect();
            assert_eq!(frames.len(), 1 + points.len());
            assert_eq!(bits(&frames[1..]), bits(&one_by_one));
        }
    }

    fn wavy() -> Vec<Vec3> {
        (0..11)
            .map(|j| Vec3::new((j as f32 * 0.9).sin() * 0.01, j as f32 * 0.02, (j as f32 * 0.4).cos() * 0.005))
            .collect()
    }

    fn assert_unit(v: Vec3, what: &str) {
        assert!((v.length() - 1.0).abs() <= 1e-4, "{what}: {v} has length {}", v.length());
    }

    #[test]
    fn passes_through_every_particle_with_unit_tangents() {
        let points = wavy();
        for (j, &p) in points.iter().enumerate() {
            let c = evaluate(&points, j as f32);
            assert!((c.position - p).length() <= 1e-5, "particle {j}: {} vs {p}", c.position);
        }
        for k in 0..=1000 {
            assert_unit(evaluate(&points, k as f32 * 0.01).tangent, "wavy");
        }
        // Clamped outside the range, NaN reads as the root.
        assert_eq!(evaluate(&points, -3.0).position, points[0]);
        assert_eq!(evaluate(&points, 99.0).position, points[10]);
        assert_eq!(evaluate(&points, f32::NAN).position, points[0]);
    }

    #[test]
    fn the_root_and_tip_tangents_follow_the_end_segments() {
        let points = wavy();
        let first = (points[1] - points[0]).normalize();
        let last = (points[10] - points[9]).normalize();
        assert!((evaluate(&points, 0.0).tangent - first).length() < 1e-5);
        assert!((evaluate(&points, 10.0).tangent - last).length() < 1e-5);
    }

    #[test]
    fn joints_are_c1() {
        let points = wavy();
        for i in 0..points.len() - 2 {
            let [_, _, a2, a3] = bezier_controls(&points, i);
            let [b0, b1, _, _] = bezier_controls(&points, i + 1);
            assert!((a3 - b0).length() < 1e-7, "C0 at joint {}", i + 1);
            // End derivative of one piece, 3 (c3 − c2), equals the start derivative of the
            // next, 3 (c1 − c0).
            let (left, right) = (3.0 * (a3 - a2), 3.0 * (b1 - b0));
            assert!((left - right).length() < 1e-6, "C1 at joint {}: {left} vs {right}", i + 1);
            assert!(left.length() > 0.01);
        }
        // Evaluated on both sides of a joint the tangent is continuous too.
        let before = evaluate(&points, 4.0 - 1e-3).tangent;
        let after = evaluate(&points, 4.0 + 1e-3).tangent;
        assert!((before - after).length() < 0.01, "{before} vs {after}");
    }

    #[test]
    fn tessellation_count_is_exact() {
        let points = wavy();
        for subdivisions in [0, 1, 2, 4, 7] {
            let curve = tessellate(&points, subdivisions);
            let s = subdivisions.max(1) as usize;
            assert_eq!(curve.len(), 10 * s + 1);
            for (j, p) in points.iter().enumerate() {
                assert!((curve[j * s].position - *p).length() <= 1e-5);
            }
        }
        assert_eq!(tessellate(&points[..2], 8).len(), 9);
        assert_eq!(tessellate(&points[..1], 8).len(), 1);
        assert!(tessellate(&[], 8).is_empty());
    }

    #[test]
    fn degenerate_strands_still_have_unit_tangents() {
        let a = Vec3::new(0.1, 0.2, 0.3);
        let b = a + Vec3::new(0.0, 0.0, 0.02);
        let cases: [&[Vec3]; 6] = [
            &[a, a, a, a],
            &[a, a, b, b],
            &[a, b],
            &[a, a],
            &[a, b, a, b],                // folded back on itself twice
            &[a, b, b + Vec3::X * 1e-12], // a vanishing last segment
        ];
        for points in cases {
            for k in 0..=300 {
                let c = evaluate(points, k as f32 * 0.01);
                assert!(c.position.is_finite());
                assert_unit(c.tangent, &format!("{points:?} at {}", k as f32 * 0.01));
            }
            for (j, &p) in points.iter().enumerate() {
                assert!((evaluate(points, j as f32).position - p).length() <= 1e-5);
            }
        }
        let two = evaluate(&[a, b], 0.5);
        assert!((two.position - (a + b) / 2.0).length() < 1e-6, "two particles: a straight line");
        assert!((two.tangent - Vec3::Z).length() < 1e-6);
        assert_eq!(evaluate(&[a, a], 0.3).tangent, Vec3::Y);
        assert_eq!(evaluate(&[a], 0.3), CurvePoint { position: a, tangent: Vec3::Y });
    }

    fn assert_orthonormal_frame(frames: &[Vec3], points: &[Vec3]) {
        for k in 0..=(points.len() - 1) * 8 {
            let s = k as f32 / 8.0;
            let tangent = evaluate(points, s).tangent;
            let (u, v) = frame_at(frames, s, tangent);
            assert_unit(u, "u");
            assert_unit(v, "v");
            assert!(u.dot(v).abs() < 1e-5 && u.dot(tangent).abs() < 1e-5 && v.dot(tangent).abs() < 1e-5);
            assert!((u.cross(v) - tangent).length() < 1e-4, "right-handed");
        }
    }

    #[test]
    fn frames_are_orthonormal_along_the_curve() {
        let points = wavy();
        let frames = transport_frames(&points, Vec3::X);
        assert_eq!(frames.len(), points.len());
        for (j, &u) in frames.iter().enumerate() {
            assert_unit(u, "particle u");
            assert!(u.dot(evaluate(&points, j as f32).tangent).abs() < 1e-5);
        }
        assert_orthonormal_frame(&frames, &points);
        // The root u is root_u with its along-strand part removed.
        let first = (points[1] - points[0]).normalize();
        assert!((frames[0] - (Vec3::X - first * first.x).normalize()).length() < 1e-6);
    }

    #[test]
    fn a_straight_guide_does_not_twist() {
        let dir = Vec3::new(0.3, 1.0, -0.2).normalize();
        let points: Vec<Vec3> = (0..11).map(|j| Vec3::new(0.05, 0.1, 0.0) + dir * (j as f32 * 0.02)).collect();
        let root_u = dir.any_orthonormal_vector();
        let frames = transport_frames(&points, root_u);
        for u in &frames {
            assert!((*u - root_u).length() < 1e-6, "{u} vs {root_u}");
        }
    }

    #[test]
    fn transport_follows_a_bend_without_twisting() {
        // A quarter circle in the y-z plane, leaving along +z and arriving along −y: u = x is
        // perpendicular to the whole bend and must stay x; u = y turns with the strand, by
        // exactly the turn between the root and tip tangents, to end up near +z.
        let points: Vec<Vec3> =
            (0..=20).map(|j| Quat::from_rotation_x(j as f32 * std::f32::consts::FRAC_PI_2 / 20.0) * Vec3::Y).collect();
        let along_x = transport_frames(&points, Vec3::X);
        assert!(along_x.iter().all(|u| (*u - Vec3::X).length() < 1e-5));
        let along_y = transport_frames(&points, Vec3::Y);
        let (root, tip) = (evaluate(&points, 0.0).tangent, evaluate(&points, 20.0).tangent);
        let expected = Quat::from_rotation_arc(root, tip) * along_y[0];
        assert!((along_y[20] - expected).length() < 1e-4, "{} vs {expected}", along_y[20]);
        assert!((along_y[20] - Vec3::Z).length() < 0.05, "{}", along_y[20]);
    }

    #[test]
    fn sharp_bends_and_reversals_give_finite_frames() {
        let bend = |degrees: f32| -> Vec<Vec3> {
            let back = Quat::from_rotation_z(degrees.to_radians()) * Vec3::Y;
            let mut points: Vec<Vec3> = (0..6).map(|j| Vec3::Y * (j as f32 * 0.02)).collect();
            let fold = points[5];
            points.extend((1..6).map(|j| fold + back * (j as f32 * 0.02)));
            points
        };
        for degrees in [170.0, 179.9, 180.0] {
            let points = bend(degrees);
            for root_u in [Vec3::X, Vec3::Z, Vec3::Y, Vec3::ZERO, Vec3::NAN] {
                let frames = transport_frames(&points, root_u);
                assert!(frames.iter().all(|u| u.is_finite()), "{degrees}° {root_u}");
                assert_orthonormal_frame(&frames, &points);
            }
        }
        let (u, v) = frame_at(&[], 0.5, Vec3::X);
        assert!(u.is_finite() && v.is_finite() && u.dot(Vec3::X).abs() < 1e-6);
        let (u, v) = frame_at(&[Vec3::NAN, Vec3::NAN], f32::NAN, Vec3::NAN);
        assert!(u.is_finite() && v.is_finite());
    }
}
