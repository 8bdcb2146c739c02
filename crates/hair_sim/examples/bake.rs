//! CLI benchmark of the collider bake: the procedural head at 1,280 to 81,920 triangles
//! (with `--largest 7`, also 327,680), baked at the default grid resolution; prints one
//! JSON line with, per size, the median bake time of `--runs` bakes and the memory the
//! collider holds (resident set growth over its bake, measured in a fresh process per
//! size; Linux only, `null` elsewhere).
//!
//! ```text
//! cargo run --release -p hair_sim --example bake -- --runs 3 [--largest 7]
//! ```

use hair_sim::prelude::*;
use std::time::Instant;

/// Resident memory of this process, bytes (Linux: `/proc/self/statm`).
fn resident_bytes() -> Option<u64> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: u64 = statm.split_whitespace().nth(1)?.parse().ok()?;
    Some(pages * 4096)
}

/// Bakes the head of `subdivisions` `runs` times; its JSON object.
fn measure(subdivisions: u32, runs: usize) -> String {
    let head = test_head(subdivisions);
    let mut times = Vec::with_capacity(runs);
    let mut held = None;
    for _ in 0..runs {
        let before = resident_bytes();
        let start = Instant::now();
        let collider = HeadCollider::new(&head, DEFAULT_GRID_RESOLUTION).expect("procedural head");
        times.push(start.elapsed().as_secs_f64());
        // The first bake's growth: later ones reuse what the allocator kept.
        held = held.or(before.zip(resident_bytes()).map(|(b, a)| a.saturating_sub(b)));
        drop(collider);
    }
    times.sort_by(f64::total_cmp);
    let median = times[times.len() / 2];
    let triangles = head.triangles.len();
    let memory = held.map_or("null".to_owned(), |b| format!("{:.1}", b as f64 / 1e6));
    format!(
        "{{\"triangles\":{triangles},\"bake_s\":{median:.3},\"us_per_triangle\":{:.1},\"memory_mb\":{memory}}}",
        median * 1e6 / triangles as f64
    )
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let number = |name: &str, default: u32| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
            .map(|v| v.parse::<u32>().unwrap_or_else(|_| panic!("{name} takes a whole number, got {v}")))
            .unwrap_or(default)
    };
    let runs = number("--runs", 3).max(1) as usize;
    if args.iter().any(|a| a == "--only") {
        println!("{}", measure(number("--only", 4), runs));
        return;
    }
    // Subdivisions of the procedural head: 20 × 4^k triangles, each size in a process of
    // its own so that its memory is measured from a fresh allocator.
    let largest = number("--largest", 6).clamp(3, 8);
    let me = std::env::current_exe().expect("the benchmark's own path");
    let sizes: Vec<String> = (3..=largest)
        .map(|subdivisions| {
            let out = std::process::Command::new(&me)
                .args(["--only", &subdivisions.to_string(), "--runs", &runs.to_string()])
                .output()
                .expect("the benchmark runs itself");
            String::from_utf8_lossy(&out.stdout).trim().to_owned()
        })
        .collect();
    println!("{{\"grid_resolution\":{DEFAULT_GRID_RESOLUTION},\"runs\":{runs},\"sizes\":[{}]}}", sizes.join(","));
}
