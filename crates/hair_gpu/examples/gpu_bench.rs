//! GPU benchmark: grooms of 2,048 × 16, 16,384 × 16 and 65,536 × 32 guides on the
//! procedural head, stepped on the GPU while keyframes turn and nod it; one JSON line per
//! size with the adapter's name and the median milliseconds per step, from timestamp
//! queries where the adapter has them, else wall time with a wait for each step, after a
//! second of untimed steps that brings the GPU's clocks up; then the
//! median milliseconds of the frame's drawing pass (`GpuDrawing`: the particles
//! interpolated and placed, their frames), wall time with a wait for each.
//!
//! With `--skin` the whole head is also a moving skin (a [`SurfacePatch`] that swells by up
//! to 6 mm and back), as a skinned character's neck and jaw are: what the patch's
//! closest-point queries cost.
//!
//! With `--volume` the hair has volume (`SimParams::volume`, its defaults: a 32³ grid and 8
//! pressure iterations; `--pressure N` for N): the line adds the median milliseconds of
//! the grid's passes and their median share of the step, from timestamp queries (none
//! without them).
//!
//! ```text
//! cargo run --release -p hair_gpu --example gpu_bench
//! # also: --steps N (default 60), --sizes 2048x16,16384x16 (guides × particles), --skin,
//! #       --no-segment-collision, --no-collision (what collision costs), --drape
//! #       (no shape keeping: the hair falls onto the head and slides over it, as a
//! #       character's does, where the exact queries and segment crossings run),
//! #       --volume, --pressure N, --still (the head still, the groom settled as the plugin
//! #       settles it and stepped 10 s untimed, in which it falls asleep: what a groom at
//! #       rest costs)
//! ```

use hair_gpu::{GpuContext, GpuDrawing, GpuStrands, wgpu};
use hair_sim::collide::SurfacePatch;
use hair_sim::prelude::*;
use std::time::Instant;

fn head_pose(time: f32) -> Pose {
    let yaw = 0.8 * (time * 2.0).sin();
    let pitch = 0.3 * (time * 3.1).sin();
    Pose::new(Quat::from_rotation_y(yaw) * Quat::from_rotation_x(pitch), Vec3::new(0.0, 1.6, 0.0))
}

fn arg(name: &str) -> Option<String> {
    let args: Vec<String> = std::env::args().collect();
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned()
}

fn main() {
    let flag = |name: &str| std::env::args().any(|a| a == name);
    // `--still`: the head kept at its first pose throughout.
    let still_head = flag("--still");
    let head_pose = |time: f32| head_pose(if still_head { 0.0 } else { time });
    let steps: usize = arg("--steps").map_or(60, |s| s.parse().expect("--steps takes a whole number"));
    let sizes: Vec<(usize, usize)> = arg("--sizes")
        .unwrap_or_else(|| "2048x16,16384x16,65536x32".into())
        .split(',')
        .map(|size| {
            let (g, p) = size.split_once('x').expect("--sizes takes guides x particles, e.g. 2048x16");
            (g.parse().expect("guides"), p.parse().expect("particles"))
        })
        .collect();
    let gpu = match GpuContext::headless() {
        Ok(gpu) => gpu,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    };
    let head = test_head(4);
    let collider = HeadCollider::new(&head, DEFAULT_GRID_RESOLUTION).expect("procedural head");
    let swollen = |time: f32| -> Vec<Vec3> {
        let out = 0.006 * (time * 4.0).sin().max(0.0);
        head.positions.iter().map(|p| *p + p.normalize_or(Vec3::Y) * out).collect()
    };
    let mut skin = flag("--skin").then(|| SurfacePatch::new(head.triangles.clone(), swollen(0.0), 0.02));
    let scalp = test_scalp(&head);
    // What collision costs: `--no-segment-collision` leaves out the whole-segment pass,
    // `--no-collision` all of it. `--drape` keeps no shape.
    let drape = flag("--drape");
    let defaults = SimParams::default();
    let params = SimParams {
        collision: !flag("--no-collision"),
        segment_collision: !flag("--no-segment-collision"),
        local_stiffness: if drape { 0.0 } else { defaults.local_stiffness },
        global_stiffness_root: if drape { 0.0 } else { defaults.global_stiffness_root },
        volume: Volume {
            enabled: flag("--volume"),
            pressure_iterations: arg("--pressure")
                .map_or(defaults.volume.pressure_iterations, |n| n.parse().expect("--pressure takes a whole number")),
            ..defaults.volume
        },
        ..defaults
    };
    let collision = match (params.collision, params.segment_collision) {
        (false, _) => "none",
        (true, false) => "particles",
        (true, true) => "particles and segments",
    };
    for (guides, particles) in sizes {
        let roots = sample_roots(&head, &scalp, guides, 1).expect("scalp");
        let guide_params = GuideParams { segments: particles - 1, length: 0.25, ..GuideParams::default() };
        let grown = grow_guides(&head, &roots, &guide_params, 1).expect("roots on the head");
        let rest = RestShape::new(grown, particles).expect("guides");
        // Under a still head, settled as the plugin settles a groom: a groom's rest shape
        // is where its hair comes to rest.
        let rest =
            if still_head { settle(rest, Some(&collider), &params, 180, Vec3::ZERO).expect("settle") } else { rest };
        let mut strands = GpuStrands::new(&gpu, &rest, head_pose(0.0), Some(&collider)).expect("GPU strands");
        let dt = 1.0 / 60.0;
        // A GPU idles at a low clock and raises it under load within a second or so (timed
        // cold, small grooms took several times longer): a second of steps under the first
        // pose before any is timed.
        let still = StepInput {
            dt,
            time: 0.0,
            head_from: head_pose(0.0),
            head_to: head_pose(0.0),
            collider: Some(&collider),
            extra_colliders: &[],
            surface_patch: skin.as_ref(),
            params: &params,
        };
        let warm_up = Instant::now();
        let mut warm_steps = 0;
        // Under a still head, the groom settles and falls asleep first.
        let settling = if still_head { 600 } else { 0 };
        while warm_up.elapsed().as_secs_f32() < 1.0 || warm_steps < settling {
            for _ in 0..8 {
                strands.step(&still).expect("GPU step");
            }
            warm_steps += 8;
            strands.finish().expect("GPU wait");
        }
        // What the timed steps did: how many strands slept through them.
        strands.report().expect("report");
        let mut times = Vec::with_capacity(steps);
        // The grid's milliseconds and share of each step, where the step was timed.
        let (mut volume_times, mut volume_shares) = (Vec::new(), Vec::new());
        let mut timed_on_gpu = true;
        for k in 0..steps {
            let time = k as f32 * dt;
            if let Some(skin) = &mut skin {
                skin.update(&swollen(time + dt));
            }
            let input = StepInput {
                dt,
                time,
                head_from: head_pose(time),
                head_to: head_pose(time + dt),
                collider: Some(&collider),
                extra_colliders: &[],
                surface_patch: skin.as_ref(),
                params: &params,
            };
            let start = Instant::now();
            match strands.step_timed(&input).expect("GPU step") {
                Some(time) => {
                    times.push(time.total_ms);
                    if let Some(ms) = time.volume_ms {
                        volume_times.push(ms);
                        volume_shares.push(ms / time.total_ms);
                    }
                }
                None => {
                    strands.finish().expect("GPU wait");
                    times.push(start.elapsed().as_secs_f64() * 1e3);
                    timed_on_gpu = false;
                }
            }
            strands.publish(input.head_to);
        }
        // The share of the strands asleep through the timed steps.
        let asleep = f64::from(strands.report().expect("report").sleeping) / (steps * guides) as f64;
        // The frame's drawing, into a buffer as a renderer's.
        let target = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("gpu_bench drawn"),
            size: (2 * rest.positions.len() * 16) as u64,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let root_u: Vec<Vec3> = rest.root_frames.iter().map(|q| *q * Vec3::X).collect();
        let drawing = GpuDrawing::new(&strands, &root_u, &target).expect("drawing");
        let draw_times: Vec<f64> = (0..steps)
            .map(|k| {
                let start = Instant::now();
                drawing.draw(&strands, k as f32 / steps as f32, head_pose(k as f32 * dt)).expect("draw");
                strands.finish().expect("GPU wait");
                start.elapsed().as_secs_f64() * 1e3
            })
            .collect();
        let positions = strands.positions().expect("read back");
        let pose = head_pose(steps as f32 * dt);
        let deepest = positions
            .iter()
            .enumerate()
            .filter(|(i, _)| i % particles != 0)
            .map(|(_, &p)| -collider.signed_distance(pose.inverse_transform_point(p)))
            .fold(0.0f32, f32::max);
        let stretch = (0..positions.len())
            .filter(|i| i % particles != 0)
            .map(|i| ((positions[i] - positions[i - 1]).length() / rest.lengths[i] - 1.0).abs())
            .fold(0.0f32, f32::max);
        let median = |mut values: Vec<f64>| {
            values.sort_by(f64::total_cmp);
            values.get(values.len() / 2).map_or("null".to_string(), |v| format!("{v:.4}"))
        };
        let volume = if params.volume.enabled {
            format!(
                "{{\"pressure_iterations\":{},\"ms_per_step\":{},\"share_of_step\":{}}}",
                params.volume.pressure_iterations,
                median(volume_times),
                median(volume_shares)
            )
        } else {
            "null".to_string()
        };
        println!(
            "{{\"guides\":{guides},\"particles_per_strand\":{particles},\"steps\":{steps},\"adapter\":\"{}\",\
             \"backend\":\"{:?}\",\"skin\":{},\"drape\":{drape},\"still\":{},\"asleep\":{asleep:.3},\"collision\":\"{collision}\",\"volume\":{volume},\"timing\":\"{}\",\"ms_per_step\":{},\"finite\":{},\"max_stretch\":{stretch:.6},\
             \"max_penetration_m\":{:.6},\"draw_ms_per_frame\":{},\"draw_timing\":\"wall time, waiting for each draw\"}}",
            gpu.adapter.name.replace('"', "'"),
            gpu.adapter.backend,
            skin.is_some(),
            still_head,
            if timed_on_gpu { "timestamp queries" } else { "wall time, waiting for each step" },
            median(times),
            positions.iter().all(|p| p.is_finite()),
            deepest.max(0.0),
            median(draw_times)
        );
    }
}
