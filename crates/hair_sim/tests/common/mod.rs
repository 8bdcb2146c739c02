//! Fixtures shared by the integration tests.
#![allow(dead_code)] // each test binary uses a different part

use hair_sim::prelude::*;
use proptest::prelude::*;

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

/// `assets/head.glb` as the converter reads it: the head mesh and its painted scalp.
pub fn shipped_head() -> (HeadMesh, Vec<f32>) {
    let bytes = std::fs::read(head_asset::default_output_path()).expect("assets/head.glb is committed");
    let asset = head_asset::glb::read(&bytes).expect("assets/head.glb parses");
    let head = asset.head_mesh();
    let labels: Vec<f32> = asset.scalp_vertices().iter().map(|&s| f32::from(u8::from(s))).collect();
    let weights = hair_sim::groom::triangle_weights(&head, &labels);
    (head, weights)
}

/// `strands` guides × 16 particles, 25 cm, on the shipped head's scalp, settled as the
/// plugin settles a groom (180 steps, combed by `comb`), with the collider.
pub fn shipped_groom(strands: usize, comb: Vec3) -> (HeadCollider, RestShape) {
    let (head, weights) = shipped_head();
    let collider = HeadCollider::new(&head, DEFAULT_GRID_RESOLUTION).expect("shipped head");
    let roots = sample_roots(&head, &weights, strands, 7).expect("scalp");
    let grow = GuideParams { segments: 15, length: 0.25, comb, ..GuideParams::default() };
    let rest = RestShape::new(grow_guides(&head, &roots, &grow, 7).expect("roots"), 16).expect("guides");
    let rest = settle(rest, Some(&collider), &SimParams::default(), 180, comb).expect("settle");
    (collider, rest)
}

/// How still hair is under a still head: over the watched steps, the largest move of any
/// particle in a step, the strands with a particle moving more than 10 µm in a step, the
/// particle-steps that go back where they were the step before (alternating between two
/// places), and the speeds the solver keeps at the end.
#[derive(Clone, Copy, Debug, Default)]
pub struct StillReport {
    pub max_move: f32,
    pub moving_strands: usize,
    pub alternations: usize,
    pub mean_speed: f32,
    pub max_speed: f32,
}

/// Steps `rest` at rest under a still head for `settle_steps` of 1/60 s, then watches
/// `watch_steps` more ([`StillReport`]).
pub fn still_report(
    rest: &RestShape,
    collider: Option<&HeadCollider>,
    params: &SimParams,
    settle_steps: usize,
    watch_steps: usize,
) -> StillReport {
    let n = rest.particles_per_strand;
    let mut strands = Strands::new(rest.clone(), Pose::IDENTITY);
    let mut report = StillReport::default();
    let mut moving = vec![false; rest.strand_count()];
    let (mut before, mut earlier): (Vec<Vec3>, Option<Vec<Vec3>>) = (strands.positions().to_vec(), None);
    for k in 0..settle_steps + watch_steps {
        let input = StepInput {
            dt: 1.0 / 60.0,
            time: k as f32 / 60.0,
            head_from: Pose::IDENTITY,
            head_to: Pose::IDENTITY,
            collider,
            extra_colliders: &[],
            surface_patch: None,
            params,
        };
        strands.step(&input);
        let now = strands.positions();
        if k >= settle_steps {
            for (i, (&x, &b)) in now.iter().zip(&before).enumerate() {
                let step = x.distance(b);
                report.max_move = report.max_move.max(step);
                moving[i / n] |= step > 1e-5;
                // Back where it was two steps ago, after a step of more than 1 µm.
                if let Some(earlier) = &earlier {
                    let back = x.distance(earlier[i]);
                    report.alternations += usize::from(step > 1e-6 && back < 0.25 * step);
                }
            }
        }
        earlier = Some(std::mem::replace(&mut before, now.to_vec()));
    }
    report.moving_strands = moving.iter().filter(|&&m| m).count();
    let speeds: Vec<f32> = strands.velocities().iter().map(|v| v.length()).collect();
    report.mean_speed = speeds.iter().sum::<f32>() / speeds.len() as f32;
    report.max_speed = speeds.iter().copied().fold(0.0, f32::max);
    report
}
