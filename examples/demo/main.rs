//! The bevy_hair demo: the head from `assets/head.glb` with hair grown on its painted scalp,
//! turned, nodded and shaken by a keyframed animation, with an egui panel to tune the
//! simulation, the groom and the look live.
//!
//! ```text
//! cargo run --release --example demo
//! cargo run --example demo -- [--preset NAME] [--screenshot FILE [--frames N] [--no-panel]]
//! ```
//!
//! Mouse: drag to orbit, wheel to zoom; in "drag the head" mode the left button moves the
//! head (Shift turns it) and the right button orbits. Keys: Space pauses the animation,
//! D toggles dragging the head, R puts the hair back at rest.
//!
//! `--screenshot FILE` (or `HAIR_DEMO_SCREENSHOT=FILE`) waits until the groom is grown,
//! plays `--frames N` (or `HAIR_DEMO_FRAMES`, default 60) frames of the animation at a fixed
//! 1/60 s per frame, saves the last one, checks that hair covers the scalp in it, and exits
//! (status 0 on success). See `screenshot.rs`.

mod motion;
mod panel;
mod presets;
mod scene;
mod screenshot;

use bevy::diagnostic::FrameTimeDiagnosticsPlugin;
use bevy::gltf::GltfPlugin;
use bevy::prelude::*;
use bevy::render::RenderPlugin;
use bevy::window::WindowResolution;
use bevy_egui::EguiPlugin;
use bevy_hair::prelude::*;
use std::path::PathBuf;

const USAGE: &str = "usage: demo [--preset NAME] [--screenshot FILE [--frames N] [--no-panel]]
  --preset NAME      start with this hairstyle: Shoulder (default), Short, Long, Curly, Windy, Reference
  --screenshot FILE  render N frames once the hair is grown, save the last as FILE (PNG), check it, exit
  --frames N         frames of animation before the screenshot (default 60)
  --no-panel         hide the egui panel
environment: HAIR_DEMO_SCREENSHOT=FILE, HAIR_DEMO_FRAMES=N (the flags win)";

/// What the command line asked for.
struct Options {
    screenshot: Option<PathBuf>,
    frames: u32,
    panel: bool,
    preset: &'static str,
}

/// Parses `std::env::args` by hand (no argument crate for one flag pair), falling back to
/// the environment, so CI can set either.
fn parse_args() -> Result<Options, String> {
    let parse_frames = |s: &str| s.parse::<u32>().map_err(|_| format!("--frames wants a whole number, got {s:?}"));
    let mut options = Options {
        screenshot: std::env::var_os("HAIR_DEMO_SCREENSHOT").filter(|s| !s.is_empty()).map(PathBuf::from),
        frames: match std::env::var("HAIR_DEMO_FRAMES") {
            Ok(s) if !s.is_empty() => parse_frames(&s)?,
            _ => 60,
        },
        panel: true,
        preset: presets::shoulder().name,
    };
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--screenshot" => options.screenshot = Some(args.next().ok_or("--screenshot needs a file name")?.into()),
            "--frames" => options.frames = parse_frames(&args.next().ok_or("--frames needs a number")?)?,
            "--no-panel" => options.panel = false,
            "--preset" => {
                let name = args.next().ok_or("--preset needs a name")?;
                let preset = presets::all().into_iter().find(|p| p.name.eq_ignore_ascii_case(&name));
                options.preset = preset.ok_or(format!("no preset is called {name:?}"))?.name;
            }
            "-h" | "--help" => {
                println!("{USAGE}");
                std::process::exit(0);
            }
            other => return Err(format!("unknown argument {other:?}")),
        }
    }
    Ok(options)
}

fn main() -> AppExit {
    let options = match parse_args() {
        Ok(options) => options,
        Err(e) => {
            eprintln!("demo: {e}\n{USAGE}");
            return AppExit::error();
        }
    };
    let screenshot_mode = options.screenshot.is_some();
    // Screenshots get a fixed size (and scale factor) so that runs compare.
    let window = Window {
        title: "bevy_hair demo".into(),
        resolution: WindowResolution::new(1280, 720).with_scale_factor_override(1.0),
        resizable: !screenshot_mode,
        ..default()
    };
    let mut app = App::new();
    app.add_plugins(
        DefaultPlugins
            .set(WindowPlugin { primary_window: Some(window), ..default() })
            // What a user with a `_SCALP` density attribute in their glTF would do; this head
            // is painted in COLOR_0, which the default `ScalpSource::VertexColor` reads.
            .set(GltfPlugin::default().add_custom_vertex_attribute("_SCALP", bevy_hair::ATTRIBUTE_SCALP))
            // Compiling pipelines before the first draw keeps early screenshot frames from
            // missing meshes; interactively, asynchronous compilation shows the window sooner.
            .set(RenderPlugin { synchronous_pipeline_compilation: screenshot_mode, ..default() }),
    )
    .add_plugins((HairPlugin::default(), FrameTimeDiagnosticsPlugin::default()))
    .insert_resource(scene::StartingPreset(options.preset))
    .add_plugins((scene::plugin, motion::plugin));
    // egui only with its panel: an egui context nothing draws into fails its frame.
    if options.panel {
        app.add_plugins((EguiPlugin::default(), panel::plugin));
    }
    if let Some(path) = options.screenshot {
        app.add_plugins(screenshot::ScreenshotPlugin { path, frames: options.frames });
    }
    app.run()
}
