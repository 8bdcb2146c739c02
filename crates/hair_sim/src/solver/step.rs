//! One fixed step for a run of strands. Per substep and strand:
//!
//! 1. integrate free particles: gravity, wind across the segment, springs (spring model),
//!    drag, the speed clamp;
//! 2. pin the root to the head pose interpolated for this substep;
//! 3. `iterations` × (global shape, local shape, length constraint);
//! 4. collision with the head (head-local) and the extra colliders, with friction, then a
//!    final length pass (inextensible mode);
//! 5. velocities from the position change, plus Müller's FTL correction.
//!
//! A strand whose root jumped more than `teleport_distance` is reset to the rest pose
//! instead; a strand that somehow produced a non-finite value is reset too.

use super::params::{LengthMode, SimParams, stiffness_per_application};
use super::wind::wind_at;
use super::{ChunkState, RestShape, StepInput, StepReport};
use crate::collide::{Contact, ContactHint};
use crate::math::{Pose, Quat, Vec3};
use glam::{Mat3A, Vec3A};

/// Longest step the solver takes in one go; longer ones (a frame hitch) are shortened,
/// because the head's motion over them is unknown anyway.
const MAX_STEP: f32 = 1.0 / 15.0;

/// A head pose as matrices: per particle a matrix–vector product is cheaper than a
/// quaternion rotation, and the inverse is a transpose computed once.
#[derive(Clone, Copy)]
struct PoseMatrix {
    rotation: Mat3A,
    inverse: Mat3A,
    translation: Vec3A,
}

impl PoseMatrix {
    fn new(pose: &Pose) -> Self {
        let rotation = Mat3A::from_quat(pose.rotation);
        PoseMatrix { rotation, inverse: rotation.transpose(), translation: pose.translation.into() }
    }

    /// Head-local point → world.
    #[inline]
    fn world_point(&self, p: Vec3) -> Vec3 {
        (self.rotation * Vec3A::from(p) + self.translation).into()
    }

    /// World point → head-local.
    #[inline]
    fn local_point(&self, p: Vec3) -> Vec3 {
        (self.inverse * (Vec3A::from(p) - self.translation)).into()
    }
}

/// Per-step constants shared by every strand of a chunk.
struct Constants {
    h: f32,
    poses: Vec<Pose>,
    /// `poses` as matrices.
    matrices: Vec<PoseMatrix>,
    drag_factor: f32,
    max_step_move: f32,
    local_alpha: f32,
    global_alpha: Vec<f32>,
    spring_k: f32,
    spring_d: f32,
    ftl_velocity: f32,
}

impl Constants {
    fn new(input: &StepInput, n: usize) -> Option<Self> {
        let p = input.params;
        if !(input.dt > 0.0 && input.dt.is_finite() && input.head_to.is_valid()) {
            return None;
        }
        let dt = input.dt.min(MAX_STEP);
        let from = if input.head_from.is_valid() { input.head_from } else { input.head_to };
        let substeps = p.substeps.max(1);
        let h = dt / substeps as f32;
        let poses: Vec<Pose> = (0..=substeps).map(|s| from.lerp(&input.head_to, s as f32 / substeps as f32)).collect();
        let matrices = poses.iter().map(PoseMatrix::new).collect();
        // Shape constraints run `iterations` times per substep.
        let applications_per_second = p.iterations.max(1) as f32 / h;
        let global_alpha = (0..n)
            .map(|j| {
                let t = j as f32 / (n - 1) as f32;
                let s = p.global_stiffness_root + (p.global_stiffness_tip - p.global_stiffness_root) * t;
                stiffness_per_application(s, applications_per_second)
            })
            .collect();
        // Explicit springs are stable while ω·h < 2; the stiffest mode of a chain has
        // ω = 2√(k/m). Cap k and the damping so a slider can never blow the solver up.
        let m = p.particle_mass;
        Some(Constants {
            h,
            poses,
            matrices,
            drag_factor: (-p.drag * h).exp(),
            max_step_move: p.max_speed * h,
            local_alpha: stiffness_per_application(p.local_stiffness, applications_per_second),
            global_alpha,
            spring_k: p.spring_stiffness.min(m * (1.5 / h).powi(2) / 4.0),
            spring_d: p.spring_damping.min(0.5 * m / h),
            ftl_velocity: p.ftl_damping / h,
        })
    }
}

/// Strands stepped together. Follow-the-leader and local shape walk each strand root →
/// tip, every particle waiting on its parent (a square root and a division per link);
/// walking several independent strands in lockstep lets the CPU overlap those chains.
/// Each strand's arithmetic is unchanged, so results do not depend on the grouping.
const LANES: usize = 4;

/// Scratch buffers for one group of strands (lane `l`, particle `j` at `l * n + j`),
/// allocated once per chunk and step.
struct Scratch {
    start: Vec<Vec3>,
    force: Vec<Vec3>,
    ftl_correction: Vec<Vec3>,
}

pub(super) fn step_chunk(
    first_strand: usize,
    rest: &RestShape,
    state: &mut ChunkState,
    input: &StepInput,
) -> StepReport {
    let ChunkState { positions, velocities, hints } = state;
    let n = rest.particles_per_strand;
    let mut report = StepReport::default();
    let Some(c) = Constants::new(input, n) else {
        return report;
    };
    let p = input.params;
    let size = LANES * n;
    let mut scratch = Scratch {
        start: vec![Vec3::ZERO; size],
        force: vec![Vec3::ZERO; size],
        ftl_correction: vec![Vec3::ZERO; size],
    };
    let head_to = *c.poses.last().expect("at least one pose");

    // Chunk-local indices of the strands gathered for the next group.
    let mut group = [0usize; LANES];
    let mut lanes = 0;
    let strands = positions.len() / n;
    for k in 0..strands {
        let strand = first_strand + k;
        let rest_x = &rest.positions[strand * n..][..n];
        let (xs, vs) = (&mut positions[k * n..][..n], &mut velocities[k * n..][..n]);
        let root_jump = (head_to.transform_point(rest_x[0]) - xs[0]).length();
        if root_jump.is_nan() || root_jump > p.teleport_distance {
            reset_strand(xs, vs, &mut hints[k * n..][..n], rest_x, &head_to);
            report.teleport_resets += 1;
        } else {
            group[lanes] = k;
            lanes += 1;
        }
        if lanes == LANES || (k + 1 == strands && lanes > 0) {
            let g = Group { first_strand, n, strands: &group[..lanes] };
            let state = ChunkState { positions, velocities, hints };
            step_group(&g, rest, state, &mut scratch, &c, input, &mut report);
            lanes = 0;
        }
    }
    report
}

/// Which strands of a chunk a group steps.
struct Group<'a> {
    first_strand: usize,
    n: usize,
    /// Chunk-local strand indices, one per lane.
    strands: &'a [usize],
}

impl Group<'_> {
    /// Lane index, the strand's offset in the chunk's arrays, and in the whole groom's.
    fn lanes(&self) -> impl Iterator<Item = (usize, usize, usize)> + '_ {
        self.strands.iter().enumerate().map(|(l, &k)| (l, k * self.n, (self.first_strand + k) * self.n))
    }
}

#[allow(clippy::too_many_arguments)] // one call site; the arguments are the step's context
fn step_group(
    g: &Group,
    rest: &RestShape,
    state: ChunkState,
    scratch: &mut Scratch,
    c: &Constants,
    input: &StepInput,
    report: &mut StepReport,
) {
    let n = g.n;
    let ChunkState { positions, velocities, hints } = state;
    for s in 1..c.poses.len() {
        let (pose_before, pose) = (&c.matrices[s - 1], &c.matrices[s]);
        let frame = c.poses[s].rotation;
        let time = input.time + c.h * s as f32;
        let poses = SubstepPoses { before: pose_before, now: pose, frame };
        let state = ChunkState { positions, velocities, hints };
        substep(g, rest, state, scratch, c, time, &poses, input, report);
    }
    let head_to = c.poses.last().expect("at least one pose");
    for (_, at, rest_at) in g.lanes() {
        let (xs, vs) = (&mut positions[at..][..n], &mut velocities[at..][..n]);
        if !xs.iter().chain(vs.iter()).all(|v| v.is_finite()) {
            reset_strand(xs, vs, &mut hints[at..][..n], &rest.positions[rest_at..][..n], head_to);
            report.nan_resets += 1;
        }
    }
}

fn reset_strand(xs: &mut [Vec3], vs: &mut [Vec3], hints: &mut [ContactHint], rest_x: &[Vec3], pose: &Pose) {
    for (x, &r) in xs.iter_mut().zip(rest_x) {
        *x = pose.transform_point(r);
    }
    vs.fill(Vec3::ZERO);
    hints.fill(ContactHint::NONE);
}

/// The head at the start and end of a substep.
struct SubstepPoses<'a> {
    before: &'a PoseMatrix,
    now: &'a PoseMatrix,
    /// The rotation of `now`, for the root frames of local shape.
    frame: Quat,
}

#[allow(clippy::too_many_arguments)] // one call site; the arguments are the step's context
fn substep(
    g: &Group,
    rest: &RestShape,
    state: ChunkState,
    scratch: &mut Scratch,
    c: &Constants,
    time: f32,
    poses: &SubstepPoses,
    input: &StepInput,
    report: &mut StepReport,
) {
    let ChunkState { positions, velocities, hints } = state;
    let p = input.params;
    let pose = poses.now;
    let n = g.n;
    let h = c.h;
    let inv_mass = 1.0 / p.particle_mass;
    let gravity = Vec3::from_array(p.gravity);

    // 1. Forces and integration of the free particles; 2. the root follows the head.
    for (l, at, base) in g.lanes() {
        let (xs, vs) = (&mut positions[at..][..n], &velocities[at..][..n]);
        let start = &mut scratch.start[l * n..][..n];
        let force = &mut scratch.force[l * n..][..n];
        start.copy_from_slice(xs);
        let wind = wind_at(&p.wind, (base / n) as u32, time);
        force.fill(Vec3::ZERO);
        if p.length_mode == LengthMode::Springs {
            for j in 1..n {
                let d = xs[j] - xs[j - 1];
                let l = d.length();
                if l > 1e-9 {
                    let dir = d / l;
                    let stretch = c.spring_k * (l - rest.lengths[base + j]);
                    let damping = c.spring_d * (vs[j] - vs[j - 1]).dot(dir);
                    let f = dir * (stretch + damping);
                    force[j] -= f;
                    force[j - 1] += f;
                }
            }
        }
        for j in 1..n {
            // Only the wind across the segment pushes; without wind, skip the normalize.
            let wind_across = if wind == Vec3::ZERO {
                Vec3::ZERO
            } else {
                let tangent = (xs[j] - xs[j - 1]).normalize_or_zero();
                wind - tangent * wind.dot(tangent)
            };
            let a = gravity + wind_across + force[j] * inv_mass;
            let v = (vs[j] + a * h) * c.drag_factor;
            let step = (v * h).clamp_length_max(c.max_step_move);
            xs[j] += step;
        }
        xs[0] = pose.world_point(rest.positions[base]);
    }

    // 3. Shape and length.
    scratch.ftl_correction[..g.strands.len() * n].fill(Vec3::ZERO);
    let root_frames: [Mat3A; LANES] = std::array::from_fn(|l| {
        g.strands
            .get(l)
            .map_or(Mat3A::IDENTITY, |&k| Mat3A::from_quat(poses.frame * rest.root_frames[g.first_strand + k]))
    });
    for _ in 0..p.iterations {
        for (_, at, base) in g.lanes() {
            global_shape(&rest.positions[base..][..n], &mut positions[at..][..n], &c.global_alpha, pose);
        }
        if c.local_alpha > 0.0 {
            local_shape(rest, g, positions, c.local_alpha, &root_frames);
        }
        length_pass(rest, g, positions, &mut scratch.ftl_correction, p);
    }

    // 4. Collision, then one more length pass: pushing particles out of the head
    //    stretches segments, and FTL only moves each particle along its parent segment,
    //    which leaves it outside the surface it was just pushed to (to first order).
    if p.collision {
        for (l, at, _) in g.lanes() {
            let (xs, hints) = (&mut positions[at..][..n], &mut hints[at..][..n]);
            collide(xs, hints, &scratch.start[l * n..][..n], p, poses, input, report);
        }
        // Both length models promise their bound after the step, whatever collision did.
        length_pass(rest, g, positions, &mut scratch.ftl_correction, p);
    }

    // 5. Velocities.
    for (l, at, _) in g.lanes() {
        let (xs, vs) = (&positions[at..][..n], &mut velocities[at..][..n]);
        let (start, correction) = (&scratch.start[l * n..][..n], &scratch.ftl_correction[l * n..][..n]);
        // The root moves with the head; its speed feeds spring damping, so it gets the same limit.
        vs[0] = ((xs[0] - start[0]) / h).clamp_length_max(p.max_speed);
        for j in 1..n {
            let next_correction = if j + 1 < n { correction[j + 1] } else { Vec3::ZERO };
            let v = (xs[j] - start[j]) / h - next_correction * c.ftl_velocity;
            vs[j] = v.clamp_length_max(p.max_speed);
        }
    }
}

/// The length constraint of `p.length_mode` on every strand of the group.
fn length_pass(rest: &RestShape, g: &Group, positions: &mut [Vec3], corrections: &mut [Vec3], p: &SimParams) {
    match p.length_mode {
        LengthMode::Inextensible => follow_the_leader(&rest.lengths, g, positions, corrections),
        LengthMode::Springs => clamp_lengths(&rest.lengths, g, positions, p.length_tolerance),
    }
}

/// Moves particles out of the head and the extra colliders, with friction.
fn collide(
    xs: &mut [Vec3],
    hints: &mut [ContactHint],
    start: &[Vec3],
    p: &SimParams,
    poses: &SubstepPoses,
    input: &StepInput,
    report: &mut StepReport,
) {
    for j in 1..xs.len() {
        if let Some(collider) = input.collider {
            let local = poses.now.local_point(xs[j]);
            if let Some(contact) = collider.resolve_hinted(local, p.collision_thickness, &mut hints[j]) {
                // Friction acts on sliding relative to the head, so compare in head space.
                let local_start = poses.before.local_point(start[j]);
                xs[j] = poses.now.world_point(with_friction(contact, local_start, p.friction));
                report.contacts += 1;
                report.max_depth = report.max_depth.max(contact.depth);
            }
        }
        for extra in input.extra_colliders {
            if let Some(contact) = extra.resolve(xs[j], p.collision_thickness) {
                xs[j] = with_friction(contact, start[j], p.friction);
                report.contacts += 1;
                report.max_depth = report.max_depth.max(contact.depth);
            }
        }
    }
}

/// Pulls each particle toward the rest pose carried by the head, by `alpha[j]`.
fn global_shape(rest_x: &[Vec3], xs: &mut [Vec3], alpha: &[f32], pose: &PoseMatrix) {
    for j in 1..xs.len() {
        if alpha[j] > 0.0 {
            xs[j] += (pose.world_point(rest_x[j]) - xs[j]) * alpha[j];
        }
    }
}

/// Pulls each segment toward its rest direction in its parent segment's frame.
///
/// The frame starts as the head-carried root frame; each segment's deviation from where
/// its parent expected it rotates the frame handed to its child, so a bent strand keeps
/// its curl relative to the bend instead of snapping back to the head's orientation.
/// The group's strands walk root → tip in lockstep (see [`LANES`]).
fn local_shape(rest: &RestShape, g: &Group, positions: &mut [Vec3], alpha: f32, root_frames: &[Mat3A; LANES]) {
    let mut frames = *root_frames;
    for j in 1..g.n {
        for (l, at, base) in g.lanes() {
            let frame = &mut frames[l];
            let expected = *frame * Vec3A::from(rest.local_directions[base + j]);
            let parent = positions[at + j - 1];
            let target = parent + Vec3::from(expected) * rest.lengths[base + j];
            let x = &mut positions[at + j];
            *x += (target - *x) * alpha;
            let actual = Vec3A::from(*x - parent).normalize_or(expected);
            *frame = rotation_arc(expected, actual) * *frame;
        }
    }
}

/// The shortest-arc rotation taking unit `from` onto unit `to`, as a matrix (Rodrigues):
/// `R = c·I + [v]× + v·vᵀ/(1 + c)` with `v = from × to`, `c = from · to`. Unlike the
/// quaternion form it needs no square root, and it is orthonormal to rounding, so the
/// frame chained along a strand needs no renormalising.
#[inline]
fn rotation_arc(from: Vec3A, to: Vec3A) -> Mat3A {
    let c = from.dot(to);
    if c < -0.999 {
        // Nearly opposite: the axis is ill-defined; the quaternion form picks one.
        return Mat3A::from_quat(Quat::from_rotation_arc(from.into(), to.into()));
    }
    let v = from.cross(to);
    let kv = v / (1.0 + c);
    Mat3A::from_cols(
        Vec3A::new(c, v.z, -v.y) + kv * v.x,
        Vec3A::new(-v.z, c, v.x) + kv * v.y,
        Vec3A::new(v.y, -v.x, c) + kv * v.z,
    )
}

/// Follow-The-Leader: walk root → tip, putting each particle at rest length from its
/// parent. Records each particle's correction (lane `l` at `l * n + j`) for Müller's
/// velocity term. The group's strands walk in lockstep (see [`LANES`]).
fn follow_the_leader(lengths: &[f32], g: &Group, positions: &mut [Vec3], corrections: &mut [Vec3]) {
    for j in 1..g.n {
        for (l, at, base) in g.lanes() {
            let parent = positions[at + j - 1];
            let d = positions[at + j] - parent;
            let placed = parent + d.normalize_or(Vec3::NEG_Y) * lengths[base + j];
            corrections[l * g.n + j] += placed - positions[at + j];
            positions[at + j] = placed;
        }
    }
}

/// The reference's length constraint: no segment longer or shorter than `tolerance` ×
/// its rest length. Root → tip, so each fix rests on an already-fixed parent.
fn clamp_lengths(lengths: &[f32], g: &Group, positions: &mut [Vec3], tolerance: f32) {
    for j in 1..g.n {
        for (_, at, base) in g.lanes() {
            let parent = positions[at + j - 1];
            let d = positions[at + j] - parent;
            let l = d.length();
            let rest = lengths[base + j];
            let clamped = l.clamp(rest * (1.0 - tolerance), rest * (1.0 + tolerance));
            if clamped != l {
                positions[at + j] = parent + d.normalize_or(Vec3::NEG_Y) * clamped;
            }
        }
    }
}

/// The contact position with a `friction` fraction of the tangential slide since `start`
/// taken back.
#[inline]
fn with_friction(contact: Contact, start: Vec3, friction: f32) -> Vec3 {
    let slide = contact.position - start;
    let tangential = slide - contact.normal * slide.dot(contact.normal);
    contact.position - tangential * friction
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One strand of `n` particles as a group.
    fn one(n: usize) -> Group<'static> {
        Group { first_strand: 0, n, strands: &[0] }
    }

    fn frames(root: Quat) -> [Mat3A; LANES] {
        std::array::from_fn(|l| if l == 0 { Mat3A::from_quat(root) } else { Mat3A::IDENTITY })
    }

    #[test]
    fn ftl_restores_rest_lengths_and_records_corrections() {
        let lengths = [0.0, 1.0, 1.0];
        let mut xs = [Vec3::ZERO, Vec3::new(0.0, -2.0, 0.0), Vec3::new(0.0, -2.5, 0.0)];
        let mut corr = [Vec3::ZERO; 3];
        follow_the_leader(&lengths, &one(3), &mut xs, &mut corr);
        assert_eq!(xs[1], Vec3::new(0.0, -1.0, 0.0));
        assert_eq!(xs[2], Vec3::new(0.0, -2.0, 0.0));
        assert_eq!(corr[1], Vec3::new(0.0, 1.0, 0.0));
        assert_eq!(corr[2], Vec3::new(0.0, 0.5, 0.0));
    }

    #[test]
    fn clamp_keeps_lengths_within_tolerance() {
        let lengths = [0.0, 1.0, 1.0];
        let mut xs = [Vec3::ZERO, Vec3::new(0.0, -1.5, 0.0), Vec3::new(0.0, -1.55, 0.0)];
        clamp_lengths(&lengths, &one(3), &mut xs, 0.1);
        assert!((xs[1].y + 1.1).abs() < 1e-6);
        assert!(((xs[2] - xs[1]).length() - 0.9).abs() < 1e-6);
        let mut within = [Vec3::ZERO, Vec3::new(0.0, -1.05, 0.0), Vec3::new(0.0, -2.0, 0.0)];
        clamp_lengths(&lengths, &one(3), &mut within, 0.1);
        assert_eq!(within[1].y, -1.05, "inside the tolerance nothing moves");
    }

    #[test]
    fn local_shape_keeps_the_bend_relative_to_the_parent() {
        // Rest: an L (down, then +X). Rotate the whole strand 90° about Z by moving the
        // first segment: full-stiffness local shape must turn the second segment with it.
        let rest = RestShape::new(vec![Vec3::ZERO, Vec3::NEG_Y, Vec3::new(1.0, -1.0, 0.0)], 3).unwrap();
        // The head turned 90° about Z: the root frame turns, and full-stiffness local shape
        // must carry the bend along the strand, not just the first segment.
        let turn = Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
        let mut xs = [Vec3::ZERO, Vec3::new(0.3, -0.2, 0.0), Vec3::new(5.0, 5.0, 0.0)];
        local_shape(&rest, &one(3), &mut xs, 1.0, &frames(turn * rest.root_frames[0]));
        assert!((xs[1] - turn * Vec3::NEG_Y).length() < 1e-5, "first {:?}", xs[1]);
        let second = xs[2] - xs[1];
        assert!((second - turn * Vec3::X).length() < 1e-5, "second segment {second:?}");
        // Half stiffness from a strand bent at the root: the child follows the parent's
        // actual direction, so the L stays an L (angle between segments stays 90°).
        let mut bent = [Vec3::ZERO, Vec3::new(1.0, -1.0, 0.0).normalize(), Vec3::new(9.0, 0.0, 0.0)];
        for _ in 0..60 {
            local_shape(&rest, &one(3), &mut bent, 0.5, &frames(rest.root_frames[0]));
        }
        let (a, b) = ((bent[1] - bent[0]).normalize(), (bent[2] - bent[1]).normalize());
        assert!(a.dot(b).abs() < 1e-3, "right angle kept: {}", a.dot(b));
    }

    #[test]
    fn rotation_arc_matches_the_quaternion_form() {
        for i in 0..200 {
            let f = i as f32 * 0.61;
            let from = Vec3A::new(f.sin(), (f * 1.7).cos(), (f * 0.3).sin() - 0.2).normalize();
            let to = Vec3A::new((f * 2.3).cos(), f.sin() * 0.5, (f * 1.1).cos()).normalize();
            let m = rotation_arc(from, to);
            let q = Mat3A::from_quat(Quat::from_rotation_arc(from.into(), to.into()));
            assert!((m * from - to).length() < 1e-5, "maps from onto to");
            for axis in [Vec3A::X, Vec3A::Y, Vec3A::Z] {
                assert!((m * axis - q * axis).length() < 1e-4, "{i}: {:?} vs {:?}", m * axis, q * axis);
            }
        }
    }

    #[test]
    fn friction_takes_back_tangential_slide_only() {
        let contact = Contact { position: Vec3::new(1.0, 0.0, 0.0), normal: Vec3::Y, depth: 0.1 };
        let start = Vec3::new(0.0, -0.5, 0.0);
        assert_eq!(with_friction(contact, start, 0.0), contact.position);
        let full = with_friction(contact, start, 1.0);
        assert!((full - Vec3::new(0.0, 0.0, 0.0)).length() < 1e-6, "{full:?}");
    }
}
