//! Criterion benches of the solver's pieces. Small samples, so the whole run takes about a
//! minute: `cargo bench -p hair_sim` (or `-- step` to pick some).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use hair_sim::collide::ContactHint;
use hair_sim::groom::SplitMix64;
use hair_sim::prelude::*;
use hair_sim::solver::SplatPart;
use std::hint::black_box;
use std::time::Duration;

const DT: f32 = 1.0 / 60.0;

/// The head of `examples/bench.rs`: 5,120 triangles.
fn head() -> HeadMesh {
    test_head(4)
}

/// A head turning and nodding, one pose per frame.
fn head_pose(frame: u64) -> Pose {
    let t = frame as f32 * DT;
    Pose::new(
        Quat::from_rotation_y(0.8 * (2.0 * t).sin()) * Quat::from_rotation_x(0.3 * (3.0 * t).sin()),
        Vec3::new(0.0, 1.6, 0.0),
    )
}

fn collider_build(c: &mut Criterion) {
    let head = head();
    c.bench_function("HeadCollider::new test_head(4) res 64", |b| {
        b.iter(|| HeadCollider::new(black_box(&head), DEFAULT_GRID_RESOLUTION).unwrap())
    });
}

fn collider_resolve(c: &mut Criterion) {
    let head = head();
    let collider = HeadCollider::new(&head, DEFAULT_GRID_RESOLUTION).unwrap();
    let everywhere = vec![1.0; head.triangles.len()];
    let roots = sample_roots(&head, &everywhere, 10_000, 9).unwrap();
    let mut rng = SplitMix64::new(9);
    let mut offset = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
    // Within ±5 mm of the surface: every point pays for the exact BVH query.
    let near: Vec<Vec3> = roots.iter().map(|r| r.position(&head) + r.normal(&head) * offset(-0.005, 0.005)).collect();
    // 2–4 cm off the surface: inside the distance grid, rejected by one lookup.
    let grid: Vec<Vec3> = roots.iter().map(|r| r.position(&head) + r.normal(&head) * offset(0.02, 0.04)).collect();
    // 0.5–1 m out: outside the grid, rejected by the bounds test.
    let far: Vec<Vec3> = roots.iter().map(|r| r.normal(&head) * offset(0.5, 1.0)).collect();
    let mut group = c.benchmark_group("HeadCollider::resolve 10k");
    group.throughput(Throughput::Elements(10_000));
    for (name, points) in [("near surface", &near), ("grid reject", &grid), ("far away", &far)] {
        group.bench_function(name, |b| {
            b.iter(|| points.iter().filter(|&&p| collider.resolve(black_box(p), 0.003).is_some()).count())
        });
        // The same points queried again with the hints of the previous pass, as a
        // particle that stays put (resting, or hanging clear of the head) is.
        let mut hints = vec![ContactHint::NONE; points.len()];
        group.bench_function(format!("{name}, hinted"), |b| {
            b.iter(|| {
                let hits = points.iter().zip(&mut hints);
                hits.map(|(&p, hint)| collider.resolve_hinted(black_box(p), 0.003, hint).is_some())
                    .filter(|&hit| hit)
                    .count()
            })
        });
    }
    group.finish();
}

/// `guides` guides of 16 particles, 25 cm, on the scalp of [`head`], settled for
/// `settle_steps` steps against its collider (returned with them).
fn settled_groom(guides: usize, settle_steps: usize) -> (HeadCollider, RestShape) {
    settled_groom_of(guides, 16, settle_steps)
}

/// [`settled_groom`] with `particles` per strand (25 cm long whatever their number).
fn settled_groom_of(guides: usize, particles: usize, settle_steps: usize) -> (HeadCollider, RestShape) {
    let head = head();
    let collider = HeadCollider::new(&head, DEFAULT_GRID_RESOLUTION).unwrap();
    let roots = sample_roots(&head, &test_scalp(&head), guides, 1).unwrap();
    let guide = GuideParams { segments: particles - 1, length: 0.25, ..GuideParams::default() };
    let rest = RestShape::new(grow_guides(&head, &roots, &guide, 1).unwrap(), particles).unwrap();
    let rest = settle(rest, Some(&collider), &SimParams::default(), settle_steps, Vec3::ZERO).unwrap();
    (collider, rest)
}

fn strand_step(c: &mut Criterion) {
    let (collider, rest) = settled_groom(512, 120);
    let mut group = c.benchmark_group("Strands::step 512x16");
    group.throughput(Throughput::Elements(512 * 16));
    for collision in [true, false] {
        let params = SimParams { collision, ..SimParams::default() };
        let mut strands = Strands::new(rest.clone(), head_pose(0));
        let mut frame = 0u64;
        let name = if collision { "with collision" } else { "without collision" };
        group.bench_function(name, |b| {
            b.iter(|| {
                let input = StepInput {
                    dt: DT,
                    time: frame as f32 * DT,
                    head_from: head_pose(frame),
                    head_to: head_pose(frame + 1),
                    collider: Some(&collider),
                    extra_colliders: &[],
                    surface_patch: None,
                    params: &params,
                };
                frame += 1;
                strands.step(black_box(&input))
            })
        });
    }
    // The spring model under a still head, kept awake (no sleep): every step weighs the
    // strands the head touched for the energy it may not add (`contact_hold`).
    let springs = SimParams { length_mode: LengthMode::Springs, sleep_distance: 0.0, ..SimParams::default() };
    let mut strands = Strands::new(rest.clone(), head_pose(0));
    let mut frame = 0u64;
    group.bench_function("springs, still head, awake", |b| {
        b.iter(|| {
            let input =
                StepInput { time: frame as f32 * DT, head_to: head_pose(0), ..input_at(0, &collider, &springs) };
            frame += 1;
            strands.step(black_box(&input))
        })
    });
    group.finish();
}

/// A settled groom on a turning head (2,048 × 16 and 4,096 × 32), stepped on one thread
/// and on two (the chunks split between them, as the plugin's pool does), with and without
/// hair volume (and without its pressure solve), and the volume's serial grid work alone
/// (splat, cell values and pressure: `apply_volume`; the chunks feed it back as they step),
/// and the same groom asleep under a still head.
fn volume(c: &mut Criterion) {
    for (guides, particles) in [(2048, 16), (4096, 32)] {
        let (collider, rest) = settled_groom_of(guides, particles, 60);
        let mut group = c.benchmark_group(format!("volume {guides}x{particles}"));
        group.throughput(Throughput::Elements((guides * particles) as u64));
        let on = SimParams { volume: Volume { enabled: true, ..Volume::default() }, ..SimParams::default() };
        let without_pressure = SimParams {
            volume: Volume { enabled: true, pressure_iterations: 0, ..Volume::default() },
            ..SimParams::default()
        };
        for threads in [1, 2] {
            for (name, params) in [
                ("volume off", SimParams::default()),
                ("volume on", on),
                ("volume on without the pressure", without_pressure),
            ] {
                let mut strands = Strands::new(rest.clone(), head_pose(0));
                let mut frame = 0u64;
                group.bench_function(format!("step on {threads} threads, {name}"), |b| {
                    b.iter(|| {
                        let input = input_at(frame, &collider, &params);
                        frame += 1;
                        step_on_threads(&mut strands, black_box(&input), threads)
                    })
                });
            }
        }
        // A groom asleep under a still head, the most common state: with volume the grid
        // is not worked out again while nothing moves.
        for (name, params) in [("volume off", SimParams::default()), ("volume on", on)] {
            let mut strands = Strands::new(rest.clone(), head_pose(0));
            let still = |frame| StepInput {
                head_from: head_pose(0),
                head_to: head_pose(0),
                ..input_at(frame, &collider, &params)
            };
            let mut frame = 0u64;
            while strands.sleeping(&params) < strands.strand_count() && frame < 1200 {
                step_on_threads(&mut strands, &still(frame), 1);
                frame += 1;
            }
            group.bench_function(format!("step asleep, {name}"), |b| {
                b.iter(|| {
                    frame += 1;
                    step_on_threads(&mut strands, black_box(&still(frame)), 1)
                })
            });
        }
        let mut strands = Strands::new(rest.clone(), head_pose(0));
        let mut frame = 0u64;
        group.bench_function("apply_volume alone", |b| {
            b.iter(|| {
                strands.apply_volume(black_box(&input_at(frame, &collider, &on)));
                frame += 1;
            })
        });
        group.finish();
    }
}

/// One step of `strands` with its chunks split over `threads` scoped threads (this one
/// among them), as `bevy_hair::step_on_pool` splits them over Bevy's pool.
fn step_on_threads(strands: &mut Strands, input: &StepInput, threads: usize) -> StepReport {
    strands.apply_volume_on(input, threads, |parts| {
        on_threads(parts, SplatPart::run);
    });
    let per_chunk = strands.strand_count().div_ceil(threads).next_multiple_of(input.params.simd.strands_per_group());
    let mut chunks = strands.chunks_mut(per_chunk.max(1));
    let mut report = StepReport::default();
    on_threads(&mut chunks, |chunk| chunk.step(input)).into_iter().for_each(|r| report.merge(r));
    report
}

/// `f` of each item, the first on this thread and each other on a scoped thread of its own.
fn on_threads<T: Send, R: Send>(items: &mut [T], f: impl Fn(&mut T) -> R + Sync) -> Vec<R> {
    let Some((mine, others)) = items.split_first_mut() else { return Vec::new() };
    let f = &f;
    std::thread::scope(|scope| {
        let others: Vec<_> = others.iter_mut().map(|item| scope.spawn(move || f(item))).collect();
        let mut results = vec![f(mine)];
        results.extend(others.into_iter().map(|other| other.join().expect("a bench thread panicked")));
        results
    })
}

/// The step of frame `frame` of the turning head.
fn input_at<'a>(frame: u64, collider: &'a HeadCollider, params: &'a SimParams) -> StepInput<'a> {
    StepInput {
        dt: DT,
        time: frame as f32 * DT,
        head_from: head_pose(frame),
        head_to: head_pose(frame + 1),
        collider: Some(collider),
        extra_colliders: &[],
        surface_patch: None,
        params,
    }
}

fn groom(c: &mut Criterion) {
    let head = head();
    let weights = test_scalp(&head);
    let params = GuideParams::default();
    c.bench_function("sample_roots + grow_guides 2048", |b| {
        b.iter(|| {
            let roots = sample_roots(&head, black_box(&weights), 2048, 5).unwrap();
            grow_guides(&head, &roots, &params, 5).unwrap()
        })
    });
}

/// One deep opacity map of a settled 2,048 × 16 groom (the plugin builds one per
/// shadow-casting light and frame).
fn opacity_map(c: &mut Criterion) {
    use hair_sim::shadow::{LightSource, OpacityMap};
    let (_, rest) = settled_groom(2048, 60);
    // Each sample stands for 9 strands, 0.6 mm wide, along its 1.7 cm segment.
    let areas = vec![9.0 * 0.0006 * 0.017; rest.positions.len()];
    let mut group = c.benchmark_group("OpacityMap::build 2048x16");
    group.throughput(Throughput::Elements(rest.positions.len() as u64));
    for (name, light) in [
        ("directional", LightSource::Direction(Vec3::new(0.3, 1.0, 0.2).normalize())),
        ("point", LightSource::Position(Vec3::new(-0.4, 0.3, 0.5))),
    ] {
        group.bench_function(name, |b| b.iter(|| OpacityMap::build(light, black_box(&rest.positions), &areas)));
    }
    group.finish();
}

/// The parallel-transport frames of a settled 2,048 × 16 groom (the renderer works them
/// out for every guide particle every frame), strand by strand and side by side.
fn frames(c: &mut Criterion) {
    use hair_sim::groom::{transport_frames, transport_frames_of_strands};
    let (_, rest) = settled_groom(2048, 60);
    let n = rest.particles_per_strand;
    let mut group = c.benchmark_group("transport frames 2048x16");
    group.throughput(Throughput::Elements(rest.positions.len() as u64));
    group.bench_function("strand by strand", |b| {
        b.iter(|| {
            let guides = black_box(&rest.positions).chunks_exact(n);
            guides.map(|guide| transport_frames(guide, Vec3::X).len()).sum::<usize>()
        })
    });
    group.bench_function("strands side by side", |b| {
        let mut frames = Vec::with_capacity(rest.positions.len());
        b.iter(|| {
            frames.clear();
            transport_frames_of_strands(black_box(&rest.positions), n, |_| Vec3::X, &mut frames);
            frames.len()
        })
    });
    group.finish();
}

/// The back-to-front order of a settled 2,048 × 16 groom's pieces of two segments (the
/// plugin sorts them every frame while a groom's strands are blended).
fn draw_order(c: &mut Criterion) {
    let (_, rest) = settled_groom(2048, 60);
    let eye = Vec3::new(0.3, 0.1, 2.0);
    c.bench_function("draw_order::back_to_front 2048x16, pieces of 2", |b| {
        b.iter(|| hair_sim::draw_order::back_to_front(black_box(&rest.positions), 16, 2, eye))
    });
}

fn config() -> Criterion {
    Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .without_plots()
}

criterion_group! {
    name = benches;
    config = config();
    targets = collider_build, collider_resolve, strand_step, volume, groom, opacity_map, frames, draw_order
}
criterion_main!(benches);
