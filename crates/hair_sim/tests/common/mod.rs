//! Fixtures shared by the integration tests.
#![allow(dead_code)] // each test binary uses a different part

pub mod picture;

use hair_sim::prelude::*;
use proptest::prelude::*;

/// The shipped head as its converter reads `assets/head.glb`, and the weights per triangle
/// of its painted scalp (for `sample_roots`).
pub fn shipped_head() -> (HeadMesh, Vec<f32>) {
    let (head, labels) = shipped_head_by_vertex();
    let weights = hair_sim::groom::triangle_weights(&head, &labels);
    (head, weights)
}

/// The shipped head, and 1 on each vertex of its painted scalp, 0 elsewhere (for
/// `sample_roots_at_vertices`).
pub fn shipped_head_by_vertex() -> (HeadMesh, Vec<f32>) {
    let asset = head_asset::read_committed().expect("assets/head.glb is committed and parses");
    let labels = asset.scalp_vertices().iter().map(|&s| f32::from(u8::from(s))).collect();
    (asset.head_mesh(), labels)
}

/// A groom on the procedural head, with the collider it was grown against.
pub struct Groom {
    pub head: HeadMesh,
    pub collider: HeadCollider,
    pub rest: RestShape,
}

/// What a [`Groom`] is grown from.
pub struct GroomSpec {
    /// `test_head` subdivisions.
    pub subdivisions: u32,
    /// Distance grid resolution.
    pub grid: u32,
    pub strands: usize,
    pub particles: usize,
    pub curl: f32,
    pub seed: u64,
}

/// `spec.strands` guides, 20 cm ±20%, rooted on the upper half (y > 0) of the head.
pub fn groom_on_upper_half(spec: GroomSpec) -> Groom {
    let head = test_head(spec.subdivisions);
    let collider = HeadCollider::new(&head, spec.grid).expect("procedural head");
    let scalp: Vec<f32> =
        head.triangles.iter().map(|t| if head.corners(t).iter().all(|p| p.y > 0.0) { 1.0 } else { 0.0 }).collect();
    let roots = sample_roots(&head, &scalp, spec.strands, spec.seed).expect("scalp");
    let guide = GuideParams {
        segments: spec.particles - 1,
        length: 0.2,
        length_variation: 0.2,
        curl: spec.curl,
        ..GuideParams::default()
    };
    let rest =
        RestShape::new(grow_guides(&head, &roots, &guide, spec.seed).expect("roots on the head"), spec.particles)
            .expect("guides");
    Groom { head, collider, rest }
}

/// Largest distance of a particle from its rest position carried by `pose`.
pub fn max_distance_from_rest(strands: &Strands, rest: &RestShape, pose: Pose) -> f32 {
    strands
        .positions()
        .iter()
        .zip(&rest.positions)
        .map(|(&p, &r)| (p - pose.transform_point(r)).length())
        .fold(0.0f32, f32::max)
}

/// Any f32 a slider, a file or a bug could produce: NaN, ±inf, ±0, subnormals, negatives,
/// huge values, and (most often) ordinary ones.
pub fn wild_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(0.0f32),
        1 => Just(-0.0f32),
        1 => Just(f32::MAX),
        1 => Just(f32::MIN),
        1 => Just(1e-40f32), // subnormal
        2 => -1e6f32..0.0,
        2 => 1e3f32..1e30,
        6 => 0.0f32..1.0,
        4 => 0.0f32..100.0,
    ]
}

/// `cases` cases (a fraction of a second), or `PROPTEST_CASES` for a longer hunt. Failures
/// print their minimal input; nothing is written next to the tests.
pub fn proptest_config(cases: u32) -> ProptestConfig {
    let mut config = ProptestConfig::default();
    if std::env::var_os("PROPTEST_CASES").is_none() {
        config.cases = cases;
    }
    config.failure_persistence = None;
    config
}

/// Step `k` of 1/60 s, the head moving from `from` to `to`, with the head collider only.
pub fn step_input<'a>(
    k: usize,
    from: Pose,
    to: Pose,
    collider: Option<&'a HeadCollider>,
    params: &'a SimParams,
) -> StepInput<'a> {
    let dt = 1.0 / 60.0;
    StepInput {
        dt,
        time: k as f32 * dt,
        head_from: from,
        head_to: to,
        collider,
        extra_colliders: &[],
        surface_patch: None,
        params,
    }
}

/// The head's pose `t` seconds into a 1 s shake (yaw ±0.8 rad at 12 rad/s), still before
/// and after it.
pub fn shake(t: f32) -> Pose {
    let angle = if (0.0..1.0).contains(&t) { 0.8 * (12.0 * t).sin() } else { 0.0 };
    Pose::new(Quat::from_rotation_y(angle), Vec3::ZERO)
}

/// `params` with hair volume on (at its defaults) or off.
pub fn with_volume(params: SimParams, on: bool) -> SimParams {
    SimParams { volume: Volume { enabled: on, ..Volume::default() }, ..params }
}

/// `rest` stepped from its rest pose with `collider` for `steps` steps of `dt` seconds,
/// the head at `pose(k)` at the start of step `k`: the strands asleep after the last step,
/// and the fastest particle's speed then.
pub fn asleep_after(
    rest: &RestShape,
    collider: &HeadCollider,
    params: &SimParams,
    (steps, dt): (usize, f32),
    pose: impl Fn(usize) -> Pose,
) -> (usize, f32) {
    let mut strands = Strands::new(rest.clone(), Pose::IDENTITY);
    let mut asleep = 0;
    for k in 0..steps {
        let input =
            StepInput { dt, time: k as f32 * dt, ..step_input(k, pose(k), pose(k + 1), Some(collider), params) };
        asleep = strands.step(&input).sleeping as usize;
    }
    (asleep, strands.velocities().iter().map(|v| v.length()).fold(0.0, f32::max))
}
