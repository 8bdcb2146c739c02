//! CLI benchmark: a groom on the procedural head (5,120 triangles) while keyframes
//! turn, nod and shake it; prints one JSON line.
//!
//! ```text
//! cargo run --release -p hair_sim --example bench -- --guides 2048 --particles 16 --steps 600
//! # also: --threads T, --no-collision, --no-segment-collision,
//! #       --simd auto|baseline|avx2|avx512 (the SIMD path; all give the same positions)
//! # levels of detail: 16 heads at 1–20 m against one near head, on one thread
//! cargo run --release -p hair_sim --example bench -- --lod
//! ```

use hair_sim::prelude::*;
use hair_sim::solver::FULL_DETAIL_HEIGHT;
use hair_sim::solver::StrandChunk;
use std::sync::atomic::{AtomicU32, AtomicUsize, Ordering};
use std::time::Instant;

/// Head keyframes: (time s, yaw rad, pitch rad), looped; a turn, a nod, a fast shake.
const KEYS: [(f32, f32, f32); 9] = [
    (0.0, 0.0, 0.0),
    (0.6, 0.8, 0.0),
    (1.2, -0.8, 0.0),
    (1.8, 0.0, 0.35),
    (2.4, 0.0, -0.3),
    (2.65, 0.5, 0.0),
    (2.9, -0.5, 0.0),
    (3.15, 0.5, 0.0),
    (3.6, 0.0, 0.0),
];

fn head_pose(time: f32) -> Pose {
    let period = KEYS[KEYS.len() - 1].0;
    let t = time.rem_euclid(period);
    let k = KEYS.windows(2).position(|w| t < w[1].0).unwrap_or(KEYS.len() - 2);
    let ((t0, yaw0, pitch0), (t1, yaw1, pitch1)) = (KEYS[k], KEYS[k + 1]);
    let f = (t - t0) / (t1 - t0);
    let s = f * f * (3.0 - 2.0 * f); // ease in and out, as authored keyframes do
    let rotation =
        Quat::from_rotation_y(yaw0 + (yaw1 - yaw0) * s) * Quat::from_rotation_x(pitch0 + (pitch1 - pitch0) * s);
    Pose::new(rotation, Vec3::new(0.0, 1.6, 0.0))
}

fn arg(name: &str, default: usize) -> usize {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .map(|v| v.parse().unwrap_or_else(|_| panic!("{name} takes a whole number, got {v}")))
        .unwrap_or(default)
}

/// `--simd`: the path asked for (`auto` by default); one this CPU lacks is an error.
fn simd_path() -> SimdPath {
    let args: Vec<String> = std::env::args().collect();
    let Some(name) = args.iter().position(|a| a == "--simd").and_then(|i| args.get(i + 1)) else {
        return SimdPath::Auto;
    };
    let path = [SimdPath::Auto, SimdPath::Baseline, SimdPath::Avx2, SimdPath::Avx512]
        .into_iter()
        .find(|p| p.to_string() == *name)
        .unwrap_or_else(|| panic!("--simd takes auto, baseline, avx2 or avx512, got {name}"));
    assert!(path.is_available(), "--simd {name}: this CPU does not have it");
    path
}

/// Waits for `ready`, spinning first: a step is a few milliseconds, and waking a parked
/// thread would be timed with it (rayon's workers, too, spin and yield before they sleep).
fn wait_until(ready: impl Fn() -> bool) {
    let mut spins = 0u32;
    while !ready() {
        if spins < 100_000 {
            std::hint::spin_loop();
            spins += 1;
        } else {
            std::thread::yield_now();
        }
    }
}

fn main() {
    let guides = arg("--guides", 2048);
    let particles = arg("--particles", 16).max(2);
    let steps = arg("--steps", 600).max(1);
    let threads = arg("--threads", std::thread::available_parallelism().map_or(1, |n| n.get())).max(1);

    let head = test_head(4);
    let collider = HeadCollider::new(&head, DEFAULT_GRID_RESOLUTION).expect("procedural head");
    let scalp = test_scalp(&head);
    let roots = sample_roots(&head, &scalp, guides, 1).expect("scalp");
    let guide_params = GuideParams { segments: particles - 1, length: 0.25, ..GuideParams::default() };
    let rest = RestShape::new(grow_guides(&head, &roots, &guide_params, 1).expect("roots on the head"), particles)
        .expect("guides");
    let params = SimParams::default();
    let rest = settle(rest, Some(&collider), &params, 120, Vec3::ZERO).expect("settle");
    // `--no-collision` measures the solver alone (the groom still settles on the head).
    // `--no-segment-collision` leaves out the whole-segment test (`SimParams::segment_collision`).
    let flag = |name: &str| std::env::args().any(|a| a == name);
    let simd = simd_path();
    let params = SimParams {
        collision: !flag("--no-collision"),
        segment_collision: !flag("--no-segment-collision"),
        simd,
        ..params
    };
    if flag("--lod") {
        return detail_bench(&head, &collider, &rest, &params, guides, particles, steps);
    }
    let mut strands = Strands::new(rest, head_pose(0.0));

    let chunk = strands.strand_count().div_ceil(threads * 4).next_multiple_of(params.simd.strands_per_group());
    let n = strands.particles_per_strand();
    let dt = 1.0 / 60.0;
    let input_at = |k: usize| {
        let time = k as f32 * dt;
        StepInput {
            dt,
            time,
            head_from: head_pose(time),
            head_to: head_pose(time + dt),
            collider: Some(&collider),
            extra_colliders: &[],
            surface_patch: None,
            params: &params,
        }
    };
    // Deepest particle below the head surface after step `k`, over some chunks.
    let penetration = |chunks: &[StrandChunk], k: usize| {
        let pose = head_pose((k + 1) as f32 * dt);
        let particles = chunks.iter().flat_map(|c| c.positions().iter().enumerate().filter(|(i, _)| i % n != 0));
        particles.fold(0.0f32, |deepest, (_, &p)| {
            debug_assert!(p.is_finite(), "a particle is not finite");
            deepest.max(-collider.signed_distance(pose.inverse_transform_point(p)))
        })
    };
    // Workers live for the whole run and keep the same chunks, as a game's task pool
    // would: spawning threads per step, or moving chunks between cores, would be timed
    // along with the solver. The calling thread steps the first share itself.
    let mut times = Vec::with_capacity(steps);
    let mut max_penetration = 0.0f32;
    let mut chunks = strands.chunks_mut(chunk);
    let per_thread = chunks.len().div_ceil(threads);
    // Steps released to the workers, steps they finished (summed), and the deepest
    // penetration they saw (f32 bits; non-negative floats order as their bits do).
    let (released, finished, deepest) = (AtomicUsize::new(0), AtomicUsize::new(0), AtomicU32::new(0));
    // Strands the solver had to reset (teleport, non-finite): both should stay 0 here.
    let (teleport_resets, nan_resets) = (AtomicU32::new(0), AtomicU32::new(0));
    let step = |chunk: &mut StrandChunk, k: usize| {
        let report = chunk.step(&input_at(k));
        teleport_resets.fetch_add(report.teleport_resets, Ordering::Relaxed);
        nan_resets.fetch_add(report.nan_resets, Ordering::Relaxed);
    };
    std::thread::scope(|scope| {
        let mut shares = chunks.chunks_mut(per_thread);
        let own = shares.next().expect("at least one chunk");
        let workers = shares.len();
        for share in shares {
            let (released, finished, deepest, step) = (&released, &finished, &deepest, &step);
            scope.spawn(move || {
                for k in 0..steps {
                    wait_until(|| released.load(Ordering::Acquire) > k);
                    share.iter_mut().for_each(|c| step(c, k));
                    if k % 10 == 9 {
                        deepest.fetch_max(penetration(share, k).max(0.0).to_bits(), Ordering::Relaxed);
                    }
                    finished.fetch_add(1, Ordering::Release);
                }
            });
        }
        for k in 0..steps {
            let start = Instant::now();
            released.store(k + 1, Ordering::Release);
            own.iter_mut().for_each(|c| step(c, k));
            wait_until(|| finished.load(Ordering::Acquire) == (k + 1) * workers);
            // Workers finish after their penetration check; the step itself ended earlier,
            // so time it only when there was no check.
            if k % 10 != 9 {
                times.push(start.elapsed().as_secs_f64() * 1e3);
            } else {
                max_penetration = max_penetration.max(penetration(own, k));
            }
        }
    });
    max_penetration = max_penetration.max(f32::from_bits(deepest.into_inner()));
    times.sort_by(f64::total_cmp);
    let median = times[times.len() / 2];
    let particle_steps = (guides * particles) as f64;
    println!(
        "{{\"guides\":{guides},\"particles_per_strand\":{particles},\"steps\":{steps},\"threads\":{threads},\
         \"simd\":\"{}\",\
         \"head_triangles\":{},\"ms_per_step\":{median:.4},\"ns_per_particle_step\":{:.2},\
         \"max_stretch\":{:.6},\"max_penetration_m\":{:.6},\"teleport_resets\":{},\"nan_resets\":{}}}",
        simd.resolved(),
        head.triangles.len(),
        median * 1e6 / particle_steps,
        strands.max_stretch(),
        max_penetration.max(0.0),
        teleport_resets.into_inner(),
        nan_resets.into_inner()
    );
}

/// The followers of a groom stepped with [`Strands::step_leaving_followers`] placed in head
/// space, as the plugin places them while it copies the strands out for drawing: the
/// simulated strands' positions into head space under `pose`, then the followers from those.
fn place_followers_in_head_space(strands: &mut Strands, pose: &Pose, local: &mut [Vec3]) {
    let n = strands.particles_per_strand();
    for s in (0..strands.strand_count()).filter(|&s| !strands.is_following(s)) {
        let strand = s * n..(s + 1) * n;
        for (l, &p) in local[strand.clone()].iter_mut().zip(&strands.positions()[strand]) {
            *l = pose.inverse_transform_point(p);
        }
    }
    if let Some(followers) = strands.head_space_followers(|i| local[i]) {
        for s in (0..local.len() / n).filter(|&s| followers.follows(s)) {
            followers.place(s, &mut local[s * n..(s + 1) * n]);
        }
    }
}

/// Vertical field of view of the camera the `--lod` heads are seen through: Bevy's default.
const FIELD_OF_VIEW: f32 = std::f32::consts::FRAC_PI_4;
/// Its viewport's height, pixels.
const VIEWPORT_HEIGHT: f32 = 1080.0;

/// `--lod`: 16 heads with the same groom at 1 to 20 m from the camera, each at the level of
/// detail its height on screen gives, every head moving (its own phase of the keyframes),
/// against one head at full detail; one thread, so the totals compare work. Prints one
/// JSON line: both medians, their ratio, the levels and the deepest particle below the
/// head's surface (followers are placed, not collided).
fn detail_bench(
    head: &HeadMesh,
    collider: &HeadCollider,
    rest: &RestShape,
    params: &SimParams,
    guides: usize,
    particles: usize,
    steps: usize,
) {
    let head_height = head.height();
    let pixels_at = |distance: f32| head_height / (2.0 * distance * (FIELD_OF_VIEW * 0.5).tan()) * VIEWPORT_HEIGHT;
    let distances: Vec<f32> = (0..16).map(|i| 1.0 + 19.0 * i as f32 / 15.0).collect();
    let levels: Vec<u32> =
        distances.iter().map(|&d| hair_sim::solver::level_for_height(pixels_at(d), FULL_DETAIL_HEIGHT)).collect();
    let dt = 1.0 / 60.0;
    let input = |k: usize, phase: f32| {
        let time = k as f32 * dt + phase;
        StepInput {
            dt,
            time,
            head_from: head_pose(time),
            head_to: head_pose(time + dt),
            collider: Some(collider),
            extra_colliders: &[],
            surface_patch: None,
            params,
        }
    };
    let phase = |h: usize| h as f32 * 0.37;
    // What a groom pays once, off the main thread, for its levels of detail.
    let prepare_ms = {
        let mut strands = Strands::new(rest.clone(), head_pose(0.0));
        let start = Instant::now();
        strands.prepare_detail();
        start.elapsed().as_secs_f64() * 1e3
    };
    let mut heads: Vec<Strands> = levels
        .iter()
        .enumerate()
        .map(|(h, &level)| {
            let mut strands = Strands::new(rest.clone(), head_pose(phase(h)));
            strands.set_detail_level(level, 0);
            strands
        })
        .collect();
    let mut near = Strands::new(rest.clone(), head_pose(0.0));
    // Alternate the two, step by step, so both see the same machine. The heads step as the
    // plugin steps them: followers are left to the copy-out for drawing, timed on its own.
    let (mut near_times, mut crowd_times) = (Vec::with_capacity(steps), Vec::with_capacity(steps));
    let mut placement_times = Vec::with_capacity(steps);
    let mut local = vec![Vec3::ZERO; guides * particles];
    for k in 0..steps {
        let start = Instant::now();
        near.step_leaving_followers(&input(k, 0.0));
        near_times.push(start.elapsed().as_secs_f64() * 1e3);
        let start = Instant::now();
        for (h, strands) in heads.iter_mut().enumerate() {
            strands.step_leaving_followers(&input(k, phase(h)));
        }
        crowd_times.push(start.elapsed().as_secs_f64() * 1e3);
        let start = Instant::now();
        for (h, strands) in heads.iter_mut().enumerate() {
            place_followers_in_head_space(strands, &input(k, phase(h)).head_to, &mut local);
        }
        placement_times.push(start.elapsed().as_secs_f64() * 1e3);
    }
    heads.iter_mut().for_each(Strands::place_followers);
    let median = |mut t: Vec<f64>| {
        t.sort_by(f64::total_cmp);
        t[t.len() / 2]
    };
    let (near_ms, crowd_ms, placement_ms) = (median(near_times), median(crowd_times), median(placement_times));
    let deepest = heads
        .iter()
        .enumerate()
        .flat_map(|(h, strands)| {
            let pose = head_pose(steps as f32 * dt + phase(h));
            strands.positions().iter().map(move |&p| -collider.signed_distance(pose.inverse_transform_point(p)))
        })
        .fold(0.0f32, f32::max);
    let simulated: Vec<usize> = heads.iter().map(Strands::simulated_strands).collect();
    println!(
        "{{\"lod\":true,\"guides\":{guides},\"particles_per_strand\":{particles},\"steps\":{steps},\"threads\":1,\
         \"near_head_ms\":{near_ms:.4},\"sixteen_heads_ms\":{crowd_ms:.4},\"ratio\":{:.3},\
         \"follower_placement_ms\":{placement_ms:.4},\"ratio_with_placement\":{:.3},\
         \"distances_m\":{distances:?},\"heights_px\":{:?},\"levels\":{levels:?},\"simulated\":{simulated:?},\
         \"max_penetration_m\":{:.6},\"prepare_ms\":{prepare_ms:.2}}}",
        crowd_ms / near_ms,
        (crowd_ms + placement_ms) / near_ms,
        distances.iter().map(|&d| pixels_at(d).round()).collect::<Vec<_>>(),
        deepest.max(0.0)
    );
}
