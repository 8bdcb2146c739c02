//! The bevy_hair demo: the head from `assets/head.glb` with hair grown on its painted scalp,
//! turned, nodded and shaken by a keyframed animation, with an egui panel to tune the
//! simulation, the groom and the look live.
//!
//! ```text
//! cargo run --release --example demo
//! cargo run --example demo -- [--preset NAME] [--lights KIND] [--shading MODEL] [--self-shadow X]
//!     [--antialias MODE] [--solver cpu|gpu] [--volume on|off] [--camera Y,P,D] [--head FILE.glb] [--groom FILE.hair]
//!     [--screenshot FILE [--frames N] [--no-panel] [--size WxH] [--offscreen]]
//! ```
//!
//! Mouse: drag to orbit, wheel to zoom; in "drag the head" mode the left button moves the
//! head (Shift turns it) and the right button orbits. Keys: Space pauses the animation,
//! D toggles dragging the head, R puts the hair back at rest.
//!
//! `--screenshot FILE` (or `HAIR_DEMO_SCREENSHOT=FILE`) waits until the groom is grown,
//! plays `--frames N` (or `HAIR_DEMO_FRAMES`, default 60) frames of the animation at a fixed
//! 1/60 s per frame, saves the last one, checks that hair covers the scalp in it, and exits
//! (status 0 on success). See `screenshot.rs`. With `--offscreen` it draws into an image
//! instead of a window, so it runs where there is no display (a GPU server, say).

mod motion;
mod panel;
mod presets;
mod scene;
mod screenshot;

use bevy::app::ScheduleRunnerPlugin;
use bevy::diagnostic::FrameTimeDiagnosticsPlugin;
use bevy::gltf::GltfPlugin;
use bevy::prelude::*;
use bevy::render::RenderPlugin;
use bevy::render::diagnostic::RenderDiagnosticsPlugin;
use bevy::window::{ExitCondition, WindowResolution};
use bevy::winit::WinitPlugin;
use bevy_egui::EguiPlugin;
use bevy_hair::prelude::*;
use std::path::PathBuf;
use std::time::Duration;

const USAGE: &str = "usage: demo [--preset NAME] [--lights KIND] [--shading MODEL] [--self-shadow X] [--antialias MODE]
            [--solver cpu|gpu] [--volume on|off] [--camera Y,P,D] [--head FILE.glb] [--groom FILE.hair]
            [--screenshot FILE [--frames N] [--no-panel] [--size WxH] [--offscreen]]
  --preset NAME      start with this hairstyle: Shoulder (default), Short, Long, Curly, Windy, Reference
  --lights KIND      studio (default: key, fill and rim lights), lamps (a point and a spot light),
                     above (one light from above), behind (one light from behind)
  --shading MODEL    kajiya-kay or marschner (default: the preset's)
  --self-shadow X    how much light a layer of hair stops, 0 to 1 (0: no self-shadowing)
  --antialias MODE   how strands thinner than a pixel are drawn: auto (default: blended when the
                     whole groom is that thin), coverage (MSAA alpha-to-coverage), blended, off
  --solver cpu|gpu   step the hair on the CPU (default) or with the GPU solver (drawn from the GPU)
  --volume on|off    hair volume (hair pushes hair) on or off (default: the preset's)
  --camera Y,P,D     start the orbit camera at yaw Y and pitch P (radians), D metres away
  --head FILE.glb    your head instead of the character: a .glb under assets/ whose first
                     primitive has its scalp painted black in its vertex colours
  --groom FILE.hair  guides from a .hair file under assets/ (the Blender add-on's) instead of grown
  --screenshot FILE  render N frames once the hair is grown, save the last as FILE (PNG), check it, exit
  --frames N         frames of animation before the screenshot (default 60)
  --no-panel         hide the egui panel
  --size WxH         the window's size (default 1280x720)
  --offscreen        with --screenshot: draw into an image of that size instead of a window (no
                     display needed, no panel)
environment: HAIR_DEMO_SCREENSHOT=FILE, HAIR_DEMO_FRAMES=N (the flags win)";

/// What the command line asked for.
struct Options {
    screenshot: Option<PathBuf>,
    frames: u32,
    panel: bool,
    preset: &'static str,
    size: UVec2,
    offscreen: bool,
    stage: scene::Stage,
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
        size: UVec2::new(1280, 720),
        offscreen: false,
        stage: scene::Stage::default(),
    };
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--screenshot" => options.screenshot = Some(args.next().ok_or("--screenshot needs a file name")?.into()),
            "--head" => options.stage.head = Some(args.next().ok_or("--head needs a .glb file under assets/")?),
            "--groom" => options.stage.groom = Some(args.next().ok_or("--groom needs a .hair file under assets/")?),
            "--frames" => options.frames = parse_frames(&args.next().ok_or("--frames needs a number")?)?,
            "--no-panel" => options.panel = false,
            "--offscreen" => options.offscreen = true,
            "--antialias" => {
                let name = args.next().ok_or("--antialias needs a mode")?;
                let mode = scene::ANTIALIAS_MODES.iter().find_map(|&(mode, n)| (n == name).then_some(mode));
                options.stage.antialias =
                    Some(mode.ok_or(format!("--antialias is auto, coverage, blended or off, not {name:?}"))?);
            }
            "--volume" => {
                options.stage.volume = Some(match args.next().ok_or("--volume needs on or off")?.as_str() {
                    "on" => true,
                    "off" => false,
                    other => return Err(format!("--volume is on or off, not {other:?}")),
                });
            }
            "--solver" => {
                let name = args.next().ok_or("--solver needs cpu or gpu")?;
                let backend = scene::BACKENDS.iter().find_map(|&(backend, n)| (n == name).then_some(backend));
                options.stage.backend = backend.ok_or(format!("--solver is cpu or gpu, not {name:?}"))?;
            }
            "--lights" => {
                let name = args.next().ok_or("--lights needs a kind")?;
                options.stage.lights = scene::Lights::named(&name).ok_or(format!("no lights are called {name:?}"))?;
            }
            "--shading" => {
                options.stage.shading = Some(match args.next().ok_or("--shading needs a model")?.as_str() {
                    "kajiya-kay" => HairShading::KajiyaKay,
                    "marschner" => HairShading::MARSCHNER,
                    other => return Err(format!("--shading is kajiya-kay or marschner, not {other:?}")),
                });
            }
            "--self-shadow" => {
                let text = args.next().ok_or("--self-shadow needs a number")?;
                let value = text.parse::<f32>().ok().filter(|v| (0.0..=1.0).contains(v));
                options.stage.self_shadow = Some(value.ok_or(format!("--self-shadow wants 0 to 1, got {text:?}"))?);
            }
            "--camera" => {
                let text = args.next().ok_or("--camera needs YAW,PITCH,DISTANCE")?;
                let numbers: Vec<f32> = text.split(',').filter_map(|n| n.parse().ok()).collect();
                let &[yaw, pitch, distance] = numbers.as_slice() else {
                    return Err(format!("--camera wants YAW,PITCH,DISTANCE (radians, metres), got {text:?}"));
                };
                options.stage.camera = Some(scene::OrbitCamera { yaw, pitch, distance: distance.max(0.1) });
            }
            "--size" => {
                let text = args.next().ok_or("--size needs WxH")?;
                let size = text.split_once('x').and_then(|(w, h)| Some(UVec2::new(w.parse().ok()?, h.parse().ok()?)));
                options.size = size.filter(|s| s.min_element() > 0).ok_or(format!("--size wants WxH, got {text:?}"))?;
            }
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
    if options.offscreen {
        if options.screenshot.is_none() {
            return Err("--offscreen draws only for --screenshot: nothing would be seen".into());
        }
        // egui draws into a window.
        options.panel = false;
    }
    Ok(options)
}

fn main() -> AppExit {
    let mut options = match parse_args() {
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
        resolution: WindowResolution::new(options.size.x, options.size.y).with_scale_factor_override(1.0),
        resizable: !screenshot_mode,
        ..default()
    };
    let plugins = DefaultPlugins
        // What a user with a `_SCALP` density attribute in their glTF would do; this head
        // is painted in COLOR_0, which the default `ScalpSource::VertexColor` reads.
        .set(GltfPlugin::default().add_custom_vertex_attribute("_SCALP", bevy_hair::ATTRIBUTE_SCALP))
        // Compiling pipelines before the first draw keeps early screenshot frames from
        // missing meshes; interactively, asynchronous compilation shows the window sooner.
        .set(RenderPlugin { synchronous_pipeline_compilation: screenshot_mode, ..default() });
    let plugins = if options.offscreen {
        // No window and no windowing system: the app loops by itself (as fast as it can)
        // and the camera draws into an image (`scene::Stage::offscreen`).
        options.stage.offscreen = Some(options.size);
        plugins
            .disable::<WinitPlugin>()
            .set(WindowPlugin { primary_window: None, exit_condition: ExitCondition::DontExit, ..default() })
            .add(ScheduleRunnerPlugin::run_loop(Duration::ZERO))
    } else {
        plugins.set(WindowPlugin { primary_window: Some(window), ..default() })
    };
    let mut app = App::new();
    app.add_plugins(plugins)
        .add_plugins((HairPlugin::default(), FrameTimeDiagnosticsPlugin::default()))
        .insert_resource(scene::StartingPreset(options.preset))
        .insert_resource(options.stage)
        .add_plugins((scene::plugin, motion::plugin));
    // egui only with its panel: an egui context nothing draws into fails its frame.
    if options.panel {
        app.add_plugins((EguiPlugin::default(), panel::plugin));
    }
    if let Some(path) = options.screenshot {
        // The render passes' times, for the run's summary of where a frame goes.
        app.add_plugins(RenderDiagnosticsPlugin);
        app.add_plugins(screenshot::ScreenshotPlugin { path, frames: options.frames });
    }
    app.run()
}
