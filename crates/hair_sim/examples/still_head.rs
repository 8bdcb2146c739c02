//! Does hair come to rest under a still head? A groom on the procedural head, the head
//! never moving, no wind: prints one JSON line per substep count with how far the
//! particles moved in the step at 2 s and at 4 s (the largest move of any particle, and
//! the mean), how far a 0.17 µm nudge of every particle at 2 s has grown by 4 s, and the
//! speeds the solver keeps for the next step at 4 s (at rest they should be near zero).
//!
//! Drag alone takes 86 % of a motion's speed in 2 s (`drag` 1/s): hair whose motion does not
//! fall by about that much between the two is being driven by the solver itself.
//!
//! ```text
//! cargo run --release -p hair_sim --example still_head
//! # also: --substeps 1,2,4,8 (default 1,2,3,4,8), --local S (local shape stiffness),
//! #       --global S (global shape at the root), --no-collision, --guides N (default 64)
//! ```

use hair_sim::prelude::*;

/// Steps of 1/60 s before the nudge, and after it.
const STEPS: usize = 120;
const DT: f32 = 1.0 / 60.0;

fn arg(name: &str) -> Option<String> {
    let args: Vec<String> = std::env::args().collect();
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned()
}

/// The largest and the mean distance between matching particles of `a` and `b`.
fn apart(a: &[Vec3], b: &[Vec3]) -> (f32, f32) {
    let d: Vec<f32> = a.iter().zip(b).map(|(a, b)| a.distance(*b)).collect();
    (d.iter().copied().fold(0.0, f32::max), d.iter().sum::<f32>() / d.len() as f32)
}

fn main() {
    let defaults = SimParams::default();
    let number = |name: &str, default: f32| arg(name).map_or(default, |s| s.parse().expect("a number"));
    let substeps: Vec<u32> = arg("--substeps")
        .unwrap_or_else(|| "1,2,3,4,8".into())
        .split(',')
        .map(|s| s.parse().expect("--substeps takes whole numbers, e.g. 1,2,4"))
        .collect();
    let guides = number("--guides", 64.0) as usize;
    let head = test_head(4);
    let collider = HeadCollider::new(&head, DEFAULT_GRID_RESOLUTION).expect("procedural head");
    let roots = sample_roots(&head, &test_scalp(&head), guides, 7).expect("scalp");
    let grow = GuideParams { segments: 15, length: 0.25, ..GuideParams::default() };
    let rest = RestShape::new(grow_guides(&head, &roots, &grow, 7).expect("roots"), 16).expect("guides");
    let rest = settle(rest, Some(&collider), &defaults, 60, Vec3::ZERO).expect("settle");
    let pose = Pose::new(Quat::IDENTITY, Vec3::ZERO);
    for substeps in substeps {
        let params = SimParams {
            substeps,
            local_stiffness: number("--local", defaults.local_stiffness),
            global_stiffness_root: number("--global", defaults.global_stiffness_root),
            collision: !std::env::args().any(|a| a == "--no-collision"),
            ..defaults
        };
        let mut strands = Strands::new(rest.clone(), pose);
        let mut nudged: Option<Strands> = None;
        let mut moves = Vec::new();
        for k in 0..2 * STEPS {
            if k == STEPS {
                // Both restarted where the strands are (at rest), one of them nudged.
                let here = strands.positions().to_vec();
                let moved: Vec<Vec3> = here.iter().map(|p| *p + Vec3::new(1.7e-7, 0.0, 0.0)).collect();
                let mut copy = Strands::new(rest.clone(), pose);
                copy.set_positions(&moved).expect("finite");
                strands.set_positions(&here).expect("finite");
                nudged = Some(copy);
            }
            let input = StepInput {
                dt: DT,
                time: k as f32 * DT,
                head_from: pose,
                head_to: pose,
                collider: Some(&collider),
                extra_colliders: &[],
                surface_patch: None,
                params: &params,
            };
            let before = strands.positions().to_vec();
            strands.step(&input);
            if let Some(copy) = &mut nudged {
                copy.step(&input);
            }
            if k + 1 == STEPS || k + 1 == 2 * STEPS {
                moves.push(apart(&before, strands.positions()));
            }
        }
        let (grown_max, grown_mean) = apart(strands.positions(), nudged.expect("nudged").positions());
        // What the solver keeps as velocity for the next step, against the moves above: at
        // rest it should keep none (docs/simulation.md, hair at rest).
        let speeds: Vec<f32> = strands.velocities().iter().map(|v| v.length()).collect();
        let stored_max = speeds.iter().copied().fold(0.0, f32::max);
        let stored_mean = speeds.iter().sum::<f32>() / speeds.len() as f32;
        println!(
            "{{\"substeps\":{substeps},\"local_stiffness\":{},\"global_stiffness_root\":{},\"collision\":{},\
             \"max_move_m_at_2s\":{:.3e},\"max_move_m_at_4s\":{:.3e},\"mean_move_m_at_2s\":{:.3e},\
             \"mean_move_m_at_4s\":{:.3e},\"nudge_of_1.7e-7_m_after_2s_max\":{grown_max:.3e},\
             \"nudge_mean\":{grown_mean:.3e},\"stored_speed_m_s_at_4s_max\":{stored_max:.3e},\
             \"stored_speed_mean\":{stored_mean:.3e}}}",
            params.local_stiffness,
            params.global_stiffness_root,
            params.collision,
            moves[0].0,
            moves[1].0,
            moves[0].1,
            moves[1].1,
        );
    }
}
