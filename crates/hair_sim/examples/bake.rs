//! CLI benchmark of the collider bake: the procedural head at 1,280 to 81,920 triangles
//! (with `--largest 7`, also 327,680), baked at the default grid resolution; prints one
//! JSON line with, per size, the median bake time of `--runs` bakes, the memory the
//! collider holds once baked and the most the bake held at once (heap bytes, counted by
//! this program's allocator).
//!
//! ```text
//! cargo run --release -p hair_sim --example bake -- --runs 3 [--largest 7]
//! ```

use hair_sim::prelude::*;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// The system allocator, counting the bytes live now and the most live since a reset.
struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let live = LIVE.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
        PEAK.fetch_max(live, Ordering::Relaxed);
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        // SAFETY: `ptr` came from `alloc` above with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Bakes the head of `subdivisions` `runs` times; its JSON object.
fn measure(subdivisions: u32, runs: usize) -> String {
    let head = test_head(subdivisions);
    let mut times = Vec::with_capacity(runs);
    let (mut held, mut peak) = (0, 0);
    for _ in 0..runs {
        let before = LIVE.load(Ordering::Relaxed);
        PEAK.store(before, Ordering::Relaxed);
        let start = Instant::now();
        let collider = HeadCollider::new(&head, DEFAULT_GRID_RESOLUTION).expect("procedural head");
        times.push(start.elapsed().as_secs_f64());
        held = LIVE.load(Ordering::Relaxed) - before;
        peak = PEAK.load(Ordering::Relaxed) - before;
        drop(collider);
    }
    times.sort_by(f64::total_cmp);
    let median = times[times.len() / 2];
    let triangles = head.triangles.len();
    format!(
        "{{\"triangles\":{triangles},\"bake_s\":{median:.3},\"us_per_triangle\":{:.1},\"memory_mb\":{:.1},\"peak_mb\":{:.1}}}",
        median * 1e6 / triangles as f64,
        held as f64 / 1e6,
        peak as f64 / 1e6
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
    // its own.
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
