//! Screenshot mode (`--screenshot FILE --frames N`): a smoke test of the whole demo.
//!
//! Frames advance a fixed 1/60 s each, so a run is the same animation whatever the machine.
//! Once the groom is grown, N frames of the animation play; then time stops and two frames
//! are captured: one as drawn (saved to FILE), and one with the hair ribbons at zero width.
//! Nothing else changes between them, so the pixels that differ are exactly the hair. The
//! run passes (exit status 0) when hair covers most of the scalp roots that face the
//! camera, and fails with a reason otherwise.

use crate::scene::{Head, OffscreenTarget};
use bevy::app::AppExit;
use bevy::diagnostic::DiagnosticsStore;
use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use bevy::time::TimeUpdateStrategy;
use bevy_hair::prelude::*;
use bevy_hair::render::HairDrawing;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Fraction of the camera-facing roots that must be under hair for the run to pass.
const MIN_COVERED: f32 = 0.8;
/// Colour difference (0..255, any channel) that counts as "hair drawn here". Both frames
/// are rendered from identical state, so anything above rounding noise is the hair.
const MIN_DIFFERENCE: u8 = 3;
/// Wall-clock time growth may take before the run gives up.
const GROWTH_TIMEOUT: Duration = Duration::from_secs(300);

/// Renders `frames` frames once the hair is grown, saves the last to `path`, checks it, exits.
pub struct ScreenshotPlugin {
    pub path: PathBuf,
    pub frames: u32,
}

impl Plugin for ScreenshotPlugin {
    fn build(&self, app: &mut App) {
        app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(1.0 / 60.0)))
            .insert_resource(Shot {
                path: self.path.clone(),
                frames_left: self.frames,
                stage: Stage::Growing,
                started: Instant::now(),
                captured: Arc::default(),
                with_hair: None,
                roots: Vec::new(),
                root_count: 0,
                frame_ms: Vec::new(),
                frame_began: None,
                blended: false,
            })
            .add_systems(Update, drive);
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stage {
    Growing,
    Playing,
    /// Waiting for the frame with hair; then hair is hidden for a few frames.
    CapturingHair,
    /// Frames left before the hairless capture (the material change must reach the GPU).
    Hiding(u32),
    CapturingBare,
}

#[derive(Resource)]
struct Shot {
    path: PathBuf,
    frames_left: u32,
    stage: Stage,
    started: Instant,
    /// Where the screenshot observer puts the image it receives.
    captured: Arc<Mutex<Option<Image>>>,
    with_hair: Option<Image>,
    /// Pixels of the scalp roots that face the camera, at the moment time stopped, and
    /// how many roots the groom has.
    roots: Vec<UVec2>,
    root_count: usize,
    /// Wall time between the frames played, milliseconds, and when the last one began.
    frame_ms: Vec<f64>,
    frame_began: Option<Instant>,
    /// Whether the hair was drawn blended when time stopped ([`HairAntialias`]).
    blended: bool,
}

impl Shot {
    /// Captures the next frame of the window, or of the image with `--offscreen`.
    fn capture(&self, commands: &mut Commands, offscreen: Option<&OffscreenTarget>) {
        let sink = self.captured.clone();
        let screenshot = match offscreen {
            Some(OffscreenTarget(image)) => Screenshot::image(image.clone()),
            None => Screenshot::primary_window(),
        };
        commands
            .spawn(screenshot)
            .observe(move |captured: On<ScreenshotCaptured>| *sink.lock().unwrap() = Some(captured.image.clone()));
    }

    fn take(&self) -> Option<Image> {
        self.captured.lock().unwrap().take()
    }
}

/// What the script reads and changes on the head.
type HeadHair = (&'static GroomStatus, Option<&'static HairState>, &'static mut HairLook);

#[allow(clippy::too_many_arguments)] // one system that runs the whole script
fn drive(
    mut commands: Commands,
    mut shot: ResMut<Shot>,
    mut time: ResMut<Time<Virtual>>,
    head: Option<Single<HeadHair, With<Head>>>,
    camera: Single<(&Camera, &GlobalTransform)>,
    drawings: Query<&HairDrawing>,
    offscreen: Option<Res<OffscreenTarget>>,
    diagnostics: Res<DiagnosticsStore>,
    mut exit: MessageWriter<AppExit>,
) {
    let mut fail = |reason: String| {
        error!("screenshot: {reason}");
        exit.write(AppExit::error());
    };
    // The head is in the character's glTF scene, which takes a few frames to load.
    let Some(mut head) = head else {
        if shot.started.elapsed() > GROWTH_TIMEOUT {
            fail(format!("no head with a groom after {GROWTH_TIMEOUT:?}"));
        }
        return;
    };
    let (status, state, look) = &mut *head;
    match shot.stage {
        Stage::Growing => match status {
            GroomStatus::Ready { guides, particles_per_strand } => {
                info!(
                    "screenshot: groom ready ({guides} guides × {particles_per_strand}); playing {} frames",
                    shot.frames_left
                );
                shot.stage = Stage::Playing;
            }
            GroomStatus::Failed(reason) => fail(format!("the groom failed to grow: {reason}")),
            _ if shot.started.elapsed() > GROWTH_TIMEOUT => fail(format!("no groom after {GROWTH_TIMEOUT:?}")),
            _ => {}
        },
        Stage::Playing if shot.frames_left > 0 => {
            shot.frames_left -= 1;
            let now = Instant::now();
            if let Some(began) = shot.frame_began.replace(now) {
                shot.frame_ms.push((now - began).as_secs_f64() * 1e3);
            }
            if shot.frames_left.is_multiple_of(10) {
                info!("screenshot: {} frames to go ({:.1?} since start)", shot.frames_left, shot.started.elapsed());
            }
        }
        Stage::Playing => {
            let Some(state) = state else { return fail("the groom disappeared".into()) };
            time.pause();
            let (camera, camera_transform) = *camera;
            shot.roots = facing_root_pixels(state, camera, camera_transform);
            shot.root_count = state.roots().len();
            shot.blended = drawings.iter().any(HairDrawing::blended);
            shot.capture(&mut commands, offscreen.as_deref());
            shot.stage = Stage::CapturingHair;
        }
        Stage::CapturingHair => {
            if let Some(image) = shot.take() {
                shot.with_hair = Some(image);
                (look.root_width, look.tip_width) = (0.0, 0.0);
                shot.stage = Stage::Hiding(3);
            }
        }
        Stage::Hiding(0) => {
            shot.capture(&mut commands, offscreen.as_deref());
            shot.stage = Stage::CapturingBare;
        }
        Stage::Hiding(n) => shot.stage = Stage::Hiding(n - 1),
        Stage::CapturingBare => {
            let Some(bare) = shot.take() else { return };
            let with_hair = shot.with_hair.take().expect("captured before");
            let mut frame_ms = std::mem::take(&mut shot.frame_ms);
            frame_ms.sort_by(f64::total_cmp);
            let median_ms = frame_ms.get(frame_ms.len() / 2).copied().unwrap_or(f64::NAN);
            let roots = (shot.roots.as_slice(), shot.root_count);
            match check_and_save(&with_hair, &bare, roots, &shot.path, median_ms, shot.blended) {
                Ok(summary) => {
                    info!("screenshot: {summary}");
                    println!("{summary}");
                    println!("{}", medians(&diagnostics));
                    exit.write(AppExit::Success);
                }
                Err(reason) => fail(reason),
            }
        }
    }
}

/// Every diagnostic's median over its history (Bevy's frame time, the hair's step time,
/// the render passes' CPU and GPU times where the adapter has timestamps), as one JSON line:
/// where the frame's time goes. Medians, since the history holds the groom's first steps
/// (the GPU solver's pipeline compiled on the first).
fn medians(diagnostics: &DiagnosticsStore) -> String {
    let mut fields: Vec<String> = diagnostics
        .iter()
        .filter_map(|d| {
            let mut values: Vec<f64> = d.values().copied().collect();
            values.sort_by(f64::total_cmp);
            let median = values.get(values.len() / 2)?;
            Some(format!("{:?}:{median:.4}", d.path().as_str()))
        })
        .collect();
    fields.sort();
    format!("{{\"diagnostics\":{{{}}}}}", fields.join(","))
}

/// Where the roots whose surface faces the camera land in the window, in physical pixels.
fn facing_root_pixels(state: &HairState, camera: &Camera, camera_transform: &GlobalTransform) -> Vec<UVec2> {
    let eye = camera_transform.translation();
    // The head as drawn in this frame; roots do not depend on the interpolation fraction.
    let rotation = Quat::from_array(state.drawn_head_pose().rotation.to_array());
    let n = state.particles_per_strand();
    let scale = camera.target_scaling_factor().unwrap_or(1.0);
    state
        .roots()
        .iter()
        .zip(state.interpolated_positions(1.0).step_by(n))
        .filter(|(root, drawn_root)| {
            let normal = rotation * Vec3::from_array(root.normal(state.head_mesh()).to_array());
            normal.dot((eye - *drawn_root).normalize_or_zero()) > 0.3
        })
        .filter_map(|(_, drawn_root)| camera.world_to_viewport(camera_transform, drawn_root).ok())
        .map(|p| (p * scale).as_uvec2())
        .collect()
}

/// Compares the two frames at the root pixels (those facing the camera, of the groom's
/// `root_count`), saves the one with hair, and says what it found
/// (with `frame_ms`, the median wall time of the frames played, and whether the hair was
/// `blended`).
fn check_and_save(
    with_hair: &Image,
    bare: &Image,
    (roots, root_count): (&[UVec2], usize),
    path: &PathBuf,
    frame_ms: f64,
    blended: bool,
) -> Result<String, String> {
    let rgb = |image: &Image| image.clone().try_into_dynamic().map(|i| i.to_rgb8()).map_err(|e| e.to_string());
    let (hair, bare) = (rgb(with_hair)?, rgb(bare)?);
    if hair.dimensions() != bare.dimensions() {
        return Err("the window changed size between the two captures".into());
    }
    let (width, height) = hair.dimensions();
    let differs = |x: u32, y: u32| {
        let (a, b) = (hair.get_pixel(x, y).0, bare.get_pixel(x, y).0);
        (0..3).any(|c| a[c].abs_diff(b[c]) >= MIN_DIFFERENCE)
    };
    let inside: Vec<UVec2> = roots.iter().copied().filter(|p| p.x < width && p.y < height).collect();
    // Enough to judge by: 50, or a quarter of a small groom's roots (a `--groom` file).
    if inside.len() < 50.min(root_count / 4) {
        return Err(format!("only {} scalp roots face the camera inside the window", inside.len()));
    }
    let covered = inside.iter().filter(|p| differs(p.x, p.y)).count();
    let hair_pixels = (0..height).flat_map(|y| (0..width).map(move |x| (x, y))).filter(|&(x, y)| differs(x, y)).count();
    let fraction = covered as f32 / inside.len() as f32;
    hair.save(path).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    let summary = format!(
        "{{\"screenshot\":{:?},\"facing_roots\":{},\"covered_roots\":{},\"hair_pixels\":{},\"width\":{},\"height\":{},\
         \"frame_ms\":{frame_ms:.2},\"blended\":{blended}}}",
        path.display().to_string(),
        inside.len(),
        covered,
        hair_pixels,
        width,
        height
    );
    if fraction < MIN_COVERED {
        return Err(format!("hair covers only {:.0}% of the camera-facing scalp: {summary}", fraction * 100.0));
    }
    Ok(summary)
}
