//! Hair at rest and in motion on the procedural and the shipped head (`assets/head.glb`):
//! the speeds the solver keeps in hair under a still head, a released strand's swing, and a
//! whipped groom's energy once the head stops. Run with `--nocapture` to see the figures.

mod common;

use common::step_input;
use hair_sim::prelude::*;
use std::sync::OnceLock;

const DT: f32 = 1.0 / 60.0;

/// How a test groom grows: 25 cm guides, combed by `comb`.
#[derive(Clone, Copy)]
enum Recipe<'a> {
    /// 16 particles, roots sampled uniformly with this seed (7 unless a test asks for more).
    Test(u64),
    /// As the plugin grows its default `HairGroom`: 11 particles, lengths varied by 20 %,
    /// roots spaced by Poisson-disc sampling (seed 1).
    PluginDefault,
    /// As the plugin grows a `HairGroom` of these guides (roots spaced by Poisson-disc
    /// sampling, seed 1), settled for this many steps.
    Style(GuideParams, usize),
    /// The same with a root on each vertex these labels (1 per vertex of the scalp) mark,
    /// as `RootDistribution::Vertices` without jitter places them.
    StyleOnVertices(GuideParams, usize, &'a [f32]),
}

/// `strands` guides grown by `recipe` on the scalp `weights` of `head`, combed by `comb`
/// and settled under `params` as the plugin settles a groom (180 steps), with the head's
/// collider.
fn settled_groom(
    head: &HeadMesh,
    weights: &[f32],
    strands: usize,
    recipe: Recipe<'_>,
    comb: Vec3,
    params: &SimParams,
) -> (HeadCollider, RestShape) {
    let collider = HeadCollider::new(head, DEFAULT_GRID_RESOLUTION).expect("a head");
    let poisson = || hair_sim::groom::sample_roots_poisson(head, weights, strands, 1);
    let (roots, grow, seed, settle_steps) = match recipe {
        Recipe::Test(roots_seed) => {
            let grow = GuideParams { segments: 15, length: 0.25, comb, ..GuideParams::default() };
            (sample_roots(head, weights, strands, roots_seed), grow, 7, 180)
        }
        Recipe::PluginDefault => {
            let grow =
                GuideParams { segments: 10, length: 0.25, length_variation: 0.2, comb, ..GuideParams::default() };
            (poisson(), grow, 1, 180)
        }
        Recipe::Style(grow, settle_steps) => (poisson(), GuideParams { comb, ..grow }, 1, settle_steps),
        Recipe::StyleOnVertices(grow, settle_steps, labels) => {
            let roots = hair_sim::groom::sample_roots_at_vertices(head, labels, strands, 0.0, 1);
            (roots, GuideParams { comb, ..grow }, 1, settle_steps)
        }
    };
    let guides = grow_guides(head, &roots.expect("scalp"), &grow, seed).expect("roots");
    let rest = RestShape::new(guides, grow.segments + 1).expect("guides");
    let rest = settle(rest, Some(&collider), params, settle_steps, comb).expect("settle");
    (collider, rest)
}

/// A groom on the procedural head ([`settled_groom`]), uncombed.
fn procedural_groom(strands: usize, params: &SimParams) -> (HeadCollider, RestShape) {
    let head = test_head(4);
    settled_groom(&head, &test_scalp(&head), strands, Recipe::Test(7), Vec3::ZERO, params)
}

/// A groom on the shipped head, as its converter reads it, on its painted scalp.
fn shipped_groom(strands: usize, recipe: Recipe, comb: Vec3, params: &SimParams) -> (HeadCollider, RestShape) {
    let (head, weights) = common::shipped_head();
    settled_groom(&head, &weights, strands, recipe, comb, params)
}

/// How still hair is under a still head: over the watched steps, the largest move of any
/// particle in a step, the strands with a particle moving more than 10 µm in a step, the
/// particle-steps that go back where they were the step before (alternating between two
/// places), and the speeds the solver keeps at the end.
#[derive(Clone, Copy, Debug, Default)]
struct StillReport {
    max_move: f32,
    moving_strands: usize,
    alternations: usize,
    mean_speed: f32,
    max_speed: f32,
}

/// Steps `rest` under a still head for `settle_steps` of 1/60 s, then watches
/// `watch_steps` more ([`StillReport`]).
fn still_report(
    rest: &RestShape,
    collider: &HeadCollider,
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
        strands.step(&step_input(k, Pose::IDENTITY, Pose::IDENTITY, Some(collider), params));
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

fn print(name: &str, r: &StillReport) {
    println!(
        "{name}: stored speed mean {:.5} m/s, max {:.3} m/s; largest move {:.1} µm, {} strands over 10 µm, \
         {} particle-steps alternating",
        r.mean_speed,
        r.max_speed,
        r.max_move * 1e6,
        r.moving_strands,
        r.alternations
    );
}

/// A settled groom under a still head, then watched for 1 s: 512 test guides on the
/// procedural and the shipped head (combed back too), and the plugin's default groom of
/// 600 guides on the shipped head, combed and not; inextensible and on springs, at 1, 2
/// and 8 substeps, friction on and off. The groom is settled as inextensible hair (a
/// groom settled on springs would take their stretch into its rest lengths), so the soft
/// default springs (20 N/m) first sag by up to their 10 % and are watched after 10 s; the
/// inextensible after 4 s.
///
/// Everywhere the stored speeds average under 0.01 m/s, and every strand falls asleep and
/// holds still exactly. (With sleep anchors left where the watch began, one strand of the
/// plugin's groom combed back stepped 2.7 mm to and fro for good: `docs/simulation.md`,
/// hair at rest.)
#[test]
fn hair_under_a_still_head_is_still() {
    let settled = SimParams::default();
    let back = Vec3::new(0.0, 0.0, -1.5);
    let grooms = [
        ("procedural head", procedural_groom(512, &settled)),
        ("shipped head", shipped_groom(512, Recipe::Test(7), Vec3::ZERO, &settled)),
        ("shipped head, combed back", shipped_groom(512, Recipe::Test(7), back, &settled)),
        ("plugin's groom", shipped_groom(600, Recipe::PluginDefault, Vec3::ZERO, &settled)),
        ("plugin's groom, combed back", shipped_groom(600, Recipe::PluginDefault, back, &settled)),
    ];
    let models =
        [("inextensible", settled, 240), ("springs", SimParams { length_mode: LengthMode::Springs, ..settled }, 600)];
    for (model, base, still_steps) in models {
        for (name, (collider, rest)) in &grooms {
            for substeps in [1, 2, 8] {
                for friction in [base.friction, 0.0] {
                    let params = SimParams { substeps, friction, ..base };
                    let report = still_report(rest, collider, &params, still_steps, 60);
                    let case = format!("{name}, {model}, {substeps} substeps, friction {friction}");
                    print(&case, &report);
                    assert!(report.mean_speed < 0.01, "{case}: hair at rest keeps {report:?}");
                    assert!(report.max_move <= 1e-5 && report.alternations == 0, "{case}: {report:?}");
                }
            }
        }
    }
}

/// Hair comes to rest whatever the hair clock's rate: 1,024 test guides on the shipped head
/// (roots seeds 3, 5 and 11), settled, then shaken for 1 s (yaw ±0.8 rad at 12 rad/s) or
/// kept still, stepped at 30 and at 120 Hz under the default settings: after 10 s every
/// strand is asleep. Substeps are counted per 1/60 s ([`SimParams::substeps`]); counted
/// per step, a 30 Hz clock took substeps twice as long, and in each of these grooms a
/// strand swung for good.
#[test]
fn hair_comes_to_rest_at_any_hair_rate() {
    let (head, weights) = common::shipped_head();
    let params = SimParams::default();
    for (roots_seed, shaken) in [(3, true), (5, false), (11, true)] {
        let (collider, rest) = settled_groom(&head, &weights, 1024, Recipe::Test(roots_seed), Vec3::ZERO, &params);
        for hz in [30.0, 120.0] {
            let dt = 1.0 / hz;
            let pose = |k: usize| if shaken { common::shake(k as f32 * dt) } else { Pose::IDENTITY };
            let (asleep, fastest) = common::asleep_after(&rest, &collider, &params, ((10.0 * hz) as usize, dt), pose);
            let case = format!("roots seed {roots_seed}{}, {hz} Hz", if shaken { ", shaken" } else { "" });
            println!("{case}: {asleep} of 1024 strands asleep after 10 s, the fastest particle at {fastest:.1e} m/s");
            assert!(asleep == 1024 && fastest == 0.0, "{case}: {asleep} asleep, the fastest at {fastest} m/s");
        }
    }
}

/// The demo's styles (`examples/demo/presets.rs`) as the plugin grows them, guides only
/// (children follow their guides), combed back, each settled and stepped under its own
/// settings: shoulder length (1,200 × 11, 22 cm), short and stiff (2,000 × 7, 7 cm), long
/// and soft (1,200 × 17, 42 cm, 3 substeps) and curly (1,200 × 21, 24 cm, curl 0.6, two
/// iterations). Settled and stepped with volume off and on; kept still, or shaken for 1 s
/// (yaw ±0.8 rad at 12 rad/s), each comes to rest: after 10 s every strand is asleep.
/// With volume on, strands lying over a pile of hair bounced on it for good while the
/// grid's push was carried through the substeps (long: 9 of 1,200, 10 after a shake;
/// shoulder: 3 after a shake); with the push within the first substep but the pressure
/// taking 1.5 times a cell's overflow a step, a curly strand lying on the forehead was
/// thrown about (1 of 1,200, still and shaken).
#[test]
fn the_demo_styles_come_to_rest() {
    let (head, weights) = common::shipped_head();
    let back = Vec3::new(0.0, 0.0, -1.5);
    let d = SimParams::default();
    let style = |segments, length, length_variation, curl| GuideParams {
        segments,
        length,
        length_variation,
        curl,
        comb: Vec3::ZERO,
    };
    let styles = [
        ("shoulder", 1200, style(10, 0.22, 0.2, 0.0), 180, back, d),
        (
            "short",
            2000,
            style(6, 0.07, 0.15, 0.0),
            180,
            back,
            SimParams { local_stiffness: 0.7, global_stiffness_root: 0.6, global_stiffness_tip: 0.3, ..d },
        ),
        (
            "long",
            1200,
            style(16, 0.42, 0.15, 0.0),
            180,
            back,
            SimParams { substeps: 3, local_stiffness: 0.2, global_stiffness_root: 0.1, ..d },
        ),
        (
            "curly",
            1200,
            style(20, 0.24, 0.2, 0.6),
            60,
            back * 0.7,
            SimParams {
                local_stiffness: 0.85,
                global_stiffness_root: 0.3,
                global_stiffness_tip: 0.1,
                iterations: 2,
                ..d
            },
        ),
    ];
    for (style, volume) in styles.iter().flat_map(|s| [(s, false), (s, true)]) {
        let (name, guides, grow, settle_steps, comb, params) = *style;
        let params = common::with_volume(params, volume);
        let recipe = Recipe::Style(grow, settle_steps);
        let (collider, rest) = settled_groom(&head, &weights, guides, recipe, comb, &params);
        for shaken in [false, true] {
            let pose = |k: usize| if shaken { common::shake(k as f32 * DT) } else { Pose::IDENTITY };
            let (asleep, fastest) = common::asleep_after(&rest, &collider, &params, (600, DT), pose);
            let case =
                format!("{name}{}{}", if volume { ", volume on" } else { "" }, if shaken { ", shaken" } else { "" });
            println!(
                "{case}: {asleep} of {guides} strands asleep after 10 s, the fastest particle at {fastest:.1e} m/s"
            );
            assert!(asleep == guides && fastest == 0.0, "{case}: {asleep} asleep, the fastest at {fastest} m/s");
        }
    }
}

/// The demo's "Reference" style as the plugin grows it: the spring model without shape
/// keeping (`SimParams::reference`), 1,200 guides of 11 particles (25 cm, lengths varied by
/// 20 %) on the scalp's vertices, uncombed, so that many hang over the ears' rims and the
/// nape; and the same guides on Poisson-disc roots; and those on the vertices settled and
/// stepped with volume on. Kept still, or shaken for 1 s, every strand is asleep after
/// 10 s. Strands on springs hanging over a rim swung through it and back for good, each
/// turn out of it or push off it adding energy, until the head's touch was made unable to
/// add any (`solver/step/contact_hold.rs`). With volume on, 18 (30 after a shake) still
/// swung while the grid's push was carried through the substeps (`Feedback::push_scale`).
#[test]
fn the_reference_style_on_springs_comes_to_rest() {
    let cases =
        [("on the vertices", true, false), ("Poisson-disc", false, false), ("on the vertices, volume on", true, true)];
    for (placement, on_vertices, volume) in cases {
        let (collider, rest) = reference_style(on_vertices, volume);
        let params = common::with_volume(SimParams::reference(), volume);
        for shaken in [false, true] {
            let pose = |k: usize| if shaken { common::shake(k as f32 * DT) } else { Pose::IDENTITY };
            let (asleep, fastest) = common::asleep_after(rest, collider, &params, (600, DT), pose);
            let case = format!("roots {placement}, {}", if shaken { "shaken" } else { "still" });
            println!("{case}: {asleep} of 1200 strands asleep after 10 s, the fastest particle at {fastest:.1e} m/s");
            assert!(asleep == 1200 && fastest == 0.0, "{case}: {asleep} asleep, the fastest at {fastest} m/s");
        }
    }
}

/// The demo's "Reference" style on the shipped head (1,200 guides of 11 particles, 25 cm,
/// lengths varied by 20 %, uncombed), its roots on the scalp's vertices or Poisson-disc
/// roots, settled under `SimParams::reference` with volume on or off ([`common::with_volume`]),
/// with the head's collider: grown once for the tests that share it.
fn reference_style(on_vertices: bool, volume: bool) -> &'static (HeadCollider, RestShape) {
    static GROOMS: [OnceLock<(HeadCollider, RestShape)>; 4] = [const { OnceLock::new() }; 4];
    GROOMS[usize::from(on_vertices) + 2 * usize::from(volume)].get_or_init(|| {
        let (head, labels) = common::shipped_head_by_vertex();
        let weights = hair_sim::groom::triangle_weights(&head, &labels);
        let grow = GuideParams { segments: 10, length: 0.25, length_variation: 0.2, ..GuideParams::default() };
        let recipe = if on_vertices { Recipe::StyleOnVertices(grow, 180, &labels) } else { Recipe::Style(grow, 180) };
        settled_groom(&head, &weights, 1200, recipe, Vec3::ZERO, &common::with_volume(SimParams::reference(), volume))
    })
}

/// The hold that rests strands on springs where the head touches them
/// (`solver/step/contact_hold.rs`) is for steps in which nothing else can feed them
/// energy. A ball (4 cm) swept at 0.25 m/s across the back of the still head, through the
/// Reference style's hair lying there, does: it pushes the hair aside and no particle is
/// ever inside it (measured as the distance from its centre). Held there, strands were put
/// back where the ball had come to (20 mm inside it).
#[test]
fn a_ball_swept_through_hair_on_springs_under_a_still_head_leaves_none_inside() {
    let params = SimParams::reference();
    let (collider, rest) = reference_style(false, false);
    let mut strands = Strands::new(rest.clone(), Pose::IDENTITY);
    let radius = 0.04;
    let (mut deepest, mut steps_inside) = (0.0f32, 0);
    for k in 0..120 {
        let t = k as f32 * DT;
        let centre = Vec3::new(-0.25 + 0.25 * t.min(2.0), 0.05, -0.09);
        let ball = [ExtraCollider::Sphere { center: centre, radius }];
        let still = step_input(k, Pose::IDENTITY, Pose::IDENTITY, Some(collider), &params);
        strands.step(&StepInput { extra_colliders: &ball, ..still });
        let depth = strands.positions().iter().map(|x| radius - x.distance(centre)).fold(f32::MIN, f32::max);
        deepest = deepest.max(depth);
        steps_inside += usize::from(depth > 0.0);
    }
    println!("deepest inside the ball {:.2} mm, {steps_inside} of 120 steps with a particle inside", deepest * 1e3);
    assert!(deepest <= 1e-4, "{deepest} m inside the ball");
}

/// Nor does the hold stop hair in the wind, which feeds it too: the Reference style under
/// a still head in a gusty 2 m/s wind across it keeps moving, every strand in nearly every
/// step of the fifth second. Held there, five strands in six stood still.
#[test]
fn hair_on_springs_blows_in_the_wind_under_a_still_head() {
    let mut params = SimParams::reference();
    params.wind = Wind { direction: [1.0, 0.0, 0.0], strength: 2.0, gust_strength: 0.5, gust_frequency: 1.0 };
    let (collider, rest) = reference_style(false, false);
    let n = rest.particles_per_strand;
    let mut strands = Strands::new(rest.clone(), Pose::IDENTITY);
    let (mut last, mut moving) = (strands.positions().to_vec(), 0);
    for k in 0..300 {
        strands.step(&step_input(k, Pose::IDENTITY, Pose::IDENTITY, Some(collider), &params));
        if k >= 240 {
            let strand_moved = |(a, b): (&[Vec3], &[Vec3])| a.iter().zip(b).any(|(x, y)| x.distance(*y) > 1e-5);
            moving += strands.positions().chunks(n).zip(last.chunks(n)).filter(|&pair| strand_moved(pair)).count();
        }
        last = strands.positions().to_vec();
    }
    println!("{moving} of {} strand-steps of the fifth second moving", 60 * 1200);
    assert!(moving >= 60 * 1200 * 99 / 100, "{moving} strand-steps moving");
}

/// One strand of `n` particles, 25 cm, from the origin along +X (horizontal).
fn horizontal(n: usize) -> RestShape {
    let positions = (0..n).map(|j| Vec3::new(0.25 * j as f32 / (n - 1) as f32, 0.0, 0.0)).collect();
    RestShape::new(positions, n).expect("strand")
}

/// A strand released from horizontal (no shape keeping, no collision): seconds until its
/// tip stays within 1 cm of where it hangs, and the fastest any particle moved in a step.
fn swing(params: &SimParams) -> (f32, f32) {
    let mut strands = Strands::new(horizontal(16), Pose::IDENTITY);
    let hanging_tip = Vec3::new(0.0, -0.25, 0.0);
    let (mut swinging_until, mut fastest) = (0, 0.0f32);
    for k in 0..1200 {
        let before = strands.positions().to_vec();
        strands.step(&step_input(k, Pose::IDENTITY, Pose::IDENTITY, None, params));
        let moved = before.iter().zip(strands.positions()).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
        fastest = fastest.max(moved / DT);
        if strands.positions()[15].distance(hanging_tip) > 0.01 {
            swinging_until = k + 1;
        }
    }
    (swinging_until as f32 * DT, fastest)
}

/// The brake keeps what Müller's correction is for: a strand released from horizontal
/// swings down and settles in about a second and a half at any substep count, and its tip
/// does not whip (without the correction, FTL's one-sided projection throws the tip at
/// several times the speed a pendulum of that length reaches).
#[test]
fn a_released_strand_swings_and_settles_at_any_substep_count() {
    for substeps in [1, 2, 8] {
        let params = SimParams {
            substeps,
            collision: false,
            local_stiffness: 0.0,
            global_stiffness_root: 0.0,
            ..SimParams::default()
        };
        let (settled, fastest) = swing(&params);
        let (_, unbraked) = swing(&SimParams { ftl_damping: 0.0, ..params });
        println!(
            "{substeps} substeps: settles in {settled:.2} s, fastest {fastest:.2} m/s (no correction: {unbraked:.2} m/s)"
        );
        assert!((1.0..1.9).contains(&settled), "{substeps} substeps: settles in {settled} s");
        // A 25 cm pendulum dropped from horizontal reaches √(2 g l) = 2.2 m/s at its lowest.
        assert!(fastest < 4.0, "{substeps} substeps: the tip whips at {fastest} m/s");
        assert!(unbraked > 1.5 * fastest, "{substeps} substeps: the brake does not brake ({unbraked} m/s without)");
    }
}

/// Kinetic energy (from the solver's velocities) plus gravitational, per unit particle mass.
fn energy(strands: &Strands) -> f64 {
    let kinetic: f64 = strands.velocities().iter().map(|v| 0.5 * f64::from(v.length_squared())).sum();
    let potential: f64 = strands.positions().iter().map(|x| 9.81 * f64::from(x.y)).sum();
    kinetic + potential
}

/// A groom whipped at up to 60 rad/s for a second, then the head stops dead: with no drag
/// and no shape keeping, nothing may add energy after the stop (the brake only takes it
/// out), with and without collision, at 1, 2 and 8 substeps.
#[test]
fn a_whipped_groom_gains_no_energy_after_the_head_stops() {
    let (collider, rest) = procedural_groom(64, &SimParams::default());
    let pose = |k: usize| Pose::new(Quat::from_rotation_y(1.5 * (40.0 * k as f32 * DT).sin()), Vec3::ZERO);
    let stop = 60;
    for substeps in [1, 2, 8] {
        for collision in [false, true] {
            let params = SimParams {
                substeps,
                collision,
                drag: 0.0,
                local_stiffness: 0.0,
                global_stiffness_root: 0.0,
                ..SimParams::default()
            };
            let mut strands = Strands::new(rest.clone(), Pose::IDENTITY);
            let (mut at_stop, mut highest_after) = (0.0, f64::MIN);
            for k in 0..stop + 240 {
                let (from, to) = if k < stop { (pose(k), pose(k + 1)) } else { (pose(stop), pose(stop)) };
                strands.step(&step_input(k, from, to, Some(&collider), &params));
                if k + 1 == stop {
                    at_stop = energy(&strands);
                } else if k + 1 > stop {
                    highest_after = highest_after.max(energy(&strands));
                }
            }
            println!(
                "{substeps} substeps, collision {collision}: energy at the stop {at_stop:.2}, highest after {highest_after:.2}"
            );
            // f32 positions of a metre or so: rounding is a few 1e-7 of the energy.
            assert!(
                highest_after <= at_stop + 1e-5 * at_stop.abs(),
                "{substeps} substeps, collision {collision}: energy rose from {at_stop} to {highest_after}"
            );
        }
    }
}
