//! CLI benchmark of the collider bake: the procedural head at 1,280 to 327,680 triangles,
//! baked at the default grid resolution; prints one JSON line with, per size, the median
//! bake time of `--runs` bakes and the memory the collider holds (resident set growth,
//! Linux only; `null` elsewhere).
//!
//! ```text
//! cargo run --release -p hair_sim --example bake -- --runs 3
//! ```

use hair_sim::prelude::*;
use std::time::Instant;

/// Resident memory of this process, bytes (Linux: `/proc/self/statm`).
fn resident_bytes() -> Option<u64> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: u64 = statm.split_whitespace().nth(1)?.parse().ok()?;
    Some(pages * 4096)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let runs = args
        .iter()
        .position(|a| a == "--runs")
        .and_then(|i| args.get(i + 1))
        .map(|v| v.parse::<usize>().expect("--runs takes a whole number"))
        .unwrap_or(3)
        .max(1);
    let mut sizes = Vec::new();
    for subdivisions in 3..=7 {
        let head = test_head(subdivisions);
        let mut times = Vec::with_capacity(runs);
        let mut held = None;
        for _ in 0..runs {
            let before = resident_bytes();
            let start = Instant::now();
            let collider = HeadCollider::new(&head, DEFAULT_GRID_RESOLUTION).expect("procedural head");
            times.push(start.elapsed().as_secs_f64());
            // The first bake's growth: later ones may reuse what the allocator kept.
            held = held.or(before.zip(resident_bytes()).map(|(b, a)| a.saturating_sub(b)));
            drop(collider);
        }
        times.sort_by(f64::total_cmp);
        let median = times[times.len() / 2];
        let triangles = head.triangles.len();
        let memory = held.map_or("null".to_owned(), |b| format!("{:.1}", b as f64 / 1e6));
        sizes.push(format!(
            "{{\"triangles\":{triangles},\"bake_s\":{median:.3},\"us_per_triangle\":{:.3},\"memory_mb\":{memory}}}",
            median * 1e6 / triangles as f64
        ));
    }
    println!("{{\"grid_resolution\":{DEFAULT_GRID_RESOLUTION},\"runs\":{runs},\"sizes\":[{}]}}", sizes.join(","));
}
