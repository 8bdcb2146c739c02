//! The egui control panel: simulation settings, the groom, the look, the animation, and
//! what it all costs. Presets change many of them at once.
//!
//! Settings and the look apply as you drag. Groom sliders regrow the hair (on a background
//! task), so they apply when a drag ends, not on every frame of it.

use crate::motion::Motion;
use crate::presets::{self, Preset};
use crate::scene::{ANTIALIAS_MODES, BACKENDS, Head};
use bevy::diagnostic::{DiagnosticPath, DiagnosticsStore, FrameTimeDiagnosticsPlugin};
use bevy::prelude::*;
use bevy_egui::{EguiContexts, EguiPrimaryContextPass, egui};
use bevy_hair::prelude::*;
use hair_sim::solver::MAX_PRESSURE_ITERATIONS;
use std::ops::RangeInclusive;

pub fn plugin(app: &mut App) {
    app.add_systems(EguiPrimaryContextPass, panel);
}

/// What the panel reads and edits on the head.
type HeadQuery = (
    Entity,
    &'static mut HairGroom,
    &'static mut HairLook,
    &'static GroomStatus,
    Option<&'static mut HairState>,
    Option<&'static mut HairLod>,
    &'static mut HairBackend,
);

#[allow(clippy::too_many_arguments)] // one system that draws the whole panel
fn panel(
    mut contexts: EguiContexts,
    mut settings: ResMut<HairSettings>,
    mut motion: ResMut<Motion>,
    diagnostics: Res<DiagnosticsStore>,
    stats: Res<HairRenderStats>,
    mut head: Single<HeadQuery, With<Head>>,
    mut commands: Commands,
    mut clock: ResMut<Time<Hair>>,
    // The groom being edited: applied to the head (which regrows) when an edit is finished.
    mut draft: Local<Option<HairGroom>>,
) -> Result {
    let (entity, groom, look, status, state, lod, backend) = &mut *head;
    let ctx = contexts.ctx_mut()?;
    egui::Window::new("Hair").default_width(300.0).default_pos([12.0, 12.0]).show(ctx, |ui| {
        egui::ScrollArea::vertical().max_height(680.0).show(ui, |ui| {
            let gpu = (**backend == HairBackend::Gpu, settings.0.volume.enabled);
            stats_section(ui, &diagnostics, &stats, status, state.as_deref(), gpu);
            ui.horizontal_wrapped(|ui| {
                ui.label("Presets:");
                for preset in presets::all() {
                    if ui.button(preset.name).clicked() {
                        apply_preset(preset, groom, look, &mut settings);
                        *draft = None;
                    }
                }
            });
            ui.separator();
            egui::CollapsingHeader::new("Simulation").default_open(true).show(ui, |ui| {
                ui.horizontal(|ui| {
                    ui.label("solver");
                    for (choice, name) in BACKENDS {
                        ui.selectable_value(&mut **backend, choice, name);
                    }
                });
                simulation_section(ui, &mut settings.0);
                clock_section(ui, &mut clock);
                if ui.button("Reset hair to rest (R)").clicked()
                    && let Some(state) = state
                {
                    state.reset();
                }
            });
            egui::CollapsingHeader::new("Groom").default_open(false).show(ui, |ui| {
                let edited = draft.get_or_insert_with(|| groom.clone());
                if groom_section(ui, edited) && **groom != *edited {
                    **groom = edited.clone();
                }
                if **groom != *edited && !ui.ctx().egui_is_using_pointer() {
                    // Keep the draft in step with changes made elsewhere (a preset, a script).
                    *edited = groom.clone();
                }
            });
            egui::CollapsingHeader::new("Look").default_open(false).show(ui, |ui| look_section(ui, look));
            egui::CollapsingHeader::new("Level of detail").default_open(false).show(ui, |ui| {
                let mut on = lod.is_some();
                if ui.checkbox(&mut on, "fewer guides simulated when the head is small on screen").changed() {
                    if on {
                        commands.entity(*entity).insert(HairLod::default());
                    } else {
                        commands.entity(*entity).remove::<HairLod>();
                    }
                }
                if let Some(lod) = lod {
                    detail_section(ui, lod);
                }
            });
            egui::CollapsingHeader::new("Animation").default_open(true).show(ui, |ui| motion_section(ui, &mut motion));
        });
    });
    Ok(())
}

/// The hair clock: its step rate (independent of the frame rate and of `Time<Fixed>`) and
/// a pause that freezes the hair on the moving head.
fn clock_section(ui: &mut egui::Ui, clock: &mut Time<Hair>) {
    let mut hz = 1.0 / clock.timestep().as_secs_f64();
    if ui.add(egui::Slider::new(&mut hz, 30.0..=240.0).text("hair steps per second")).changed() {
        clock.set_timestep_hz(hz);
    }
    let mut paused = clock.is_paused();
    if ui.checkbox(&mut paused, "pause the hair clock").changed() {
        if paused { clock.pause() } else { clock.unpause() }
    }
}

fn apply_preset(preset: Preset, groom: &mut HairGroom, look: &mut HairLook, settings: &mut HairSettings) {
    *groom = preset.groom;
    *look = preset.look;
    settings.0 = preset.params;
}

fn stats_section(
    ui: &mut egui::Ui,
    diagnostics: &DiagnosticsStore,
    stats: &HairRenderStats,
    status: &GroomStatus,
    state: Option<&HairState>,
    (gpu_asked, volume): (bool, bool),
) {
    let smoothed = |path: &DiagnosticPath| diagnostics.get(path).and_then(|d| d.smoothed()).unwrap_or(f64::NAN);
    let status = match status {
        GroomStatus::WaitingForMesh => "loading the head…".to_owned(),
        GroomStatus::Growing => "growing hair…".to_owned(),
        GroomStatus::Ready { guides, particles_per_strand } => {
            format!("{guides} guides × {particles_per_strand} particles")
        }
        GroomStatus::Failed(reason) => format!("failed: {reason}"),
    };
    egui::Grid::new("stats").num_columns(2).show(ui, |ui| {
        let mut row = |name: &str, value: String| {
            ui.label(name);
            ui.label(value);
            ui.end_row();
        };
        row("groom", status);
        row("fps", format!("{:.0}", smoothed(&FrameTimeDiagnosticsPlugin::FPS)));
        row("simulation", format!("{:.2} ms / step", smoothed(&HairDiagnostics::STEP_TIME)));
        // Only while the GPU steps the hair (its time on the GPU where it times its passes).
        let on_gpu = gpu_asked && state.is_some_and(|s| s.gpu_lag().is_some());
        let gpu_ms = |path: &bevy::diagnostic::DiagnosticPath| {
            diagnostics.get(path).and_then(|d| d.smoothed()).filter(|_| on_gpu)
        };
        if let Some(ms) = gpu_ms(&HairDiagnostics::GPU_STEP_TIME) {
            row("on the GPU", format!("{ms:.2} ms / step"));
        }
        if let Some(ms) = gpu_ms(&HairDiagnostics::GPU_VOLUME_TIME).filter(|_| volume) {
            row("of which volume", format!("{ms:.2} ms / step"));
        }
        if let Some(ms) = gpu_ms(&HairDiagnostics::GPU_HANDOVER_TIME) {
            row("handed to the GPU", format!("{ms:.2} ms / step"));
        }
        row("particles", format!("{:.0}", smoothed(&HairDiagnostics::PARTICLES)));
        if let Some(why) = state.and_then(HairState::gpu_fallback) {
            row("solver", format!("CPU: {why}"));
        }
        if let Some(strands) = state.map(HairState::strands) {
            let (simulated, all, level) = (strands.simulated_strands(), strands.strand_count(), strands.detail_level());
            row("simulated guides", format!("{simulated} of {all} (level of detail {level})"));
        }
        row("rendered strands", stats.rendered_strands.to_string());
        row("rendered vertices", stats.rendered_vertices.to_string());
        row("uploaded", format!("{:.1} KiB / frame", stats.uploaded_bytes as f64 / 1024.0));
    });
}

/// A labelled slider.
fn slider<T: egui::emath::Numeric>(
    ui: &mut egui::Ui,
    value: &mut T,
    range: RangeInclusive<T>,
    text: &str,
) -> egui::Response {
    ui.add(egui::Slider::new(value, range).text(text))
}

fn simulation_section(ui: &mut egui::Ui, p: &mut SimParams) {
    slider(ui, &mut p.gravity[1], -30.0..=0.0, "gravity (m/s²)");
    slider(ui, &mut p.substeps, 1..=8, "substeps per 1/60 s");
    slider(ui, &mut p.iterations, 1..=8, "iterations");
    slider(ui, &mut p.drag, 0.0..=10.0, "air drag (1/s)");
    ui.horizontal(|ui| {
        ui.label("length");
        ui.selectable_value(&mut p.length_mode, LengthMode::Inextensible, "inextensible (FTL)");
        ui.selectable_value(&mut p.length_mode, LengthMode::Springs, "springs");
    });
    match p.length_mode {
        LengthMode::Inextensible => {
            slider(ui, &mut p.ftl_damping, 0.0..=1.0, "FTL velocity correction");
        }
        LengthMode::Springs => {
            ui.add(egui::Slider::new(&mut p.spring_stiffness, 0.1..=1e6).logarithmic(true).text("stiffness k_s (N/m)"));
            ui.add(egui::Slider::new(&mut p.spring_damping, 0.0..=1.0).text("damping k_d (N·s/m)"));
            slider(ui, &mut p.length_tolerance, 0.0..=0.5, "length tolerance");
        }
    }
    slider(ui, &mut p.local_stiffness, 0.0..=1.0, "local shape");
    slider(ui, &mut p.global_stiffness_root, 0.0..=1.0, "global shape, root");
    slider(ui, &mut p.global_stiffness_tip, 0.0..=1.0, "global shape, tip");
    ui.label("wind");
    ui.horizontal(|ui| {
        for (axis, value) in ["x", "y", "z"].iter().zip(p.wind.direction.iter_mut()) {
            ui.add(egui::DragValue::new(value).speed(0.02).range(-1.0..=1.0).prefix(format!("{axis} ")));
        }
    });
    slider(ui, &mut p.wind.strength, 0.0..=30.0, "wind strength (m/s²)");
    slider(ui, &mut p.wind.gust_strength, 0.0..=1.0, "gusts");
    slider(ui, &mut p.wind.gust_frequency, 0.0..=5.0, "gusts per second");
    ui.checkbox(&mut p.collision, "collide with the head");
    ui.add_enabled_ui(p.collision, |ui| {
        ui.add(egui::Slider::new(&mut p.collision_thickness, 0.0..=0.02).text("thickness (m)").fixed_decimals(3));
        slider(ui, &mut p.friction, 0.0..=1.0, "friction");
        ui.checkbox(&mut p.segment_collision, "whole segments (exact, ~1.2× the step)");
        ui.horizontal(|ui| {
            ui.selectable_value(&mut p.collision_response, CollisionResponse::SurfaceNormal, "push along the normal");
            ui.selectable_value(
                &mut p.collision_response,
                CollisionResponse::CentreRay { offset: [0.0; 3] },
                "push from the centre",
            );
        });
    });
    ui.add(egui::Slider::new(&mut p.sleep_distance, 0.0..=0.005).text("sleep within (m, 0: never)").fixed_decimals(4));
    // Hair–hair interaction on a grid.
    ui.checkbox(&mut p.volume.enabled, "hair volume (hair pushes hair)");
    ui.add_enabled_ui(p.volume.enabled, |ui| {
        slider(ui, &mut p.volume.resolution, 4..=64, "grid cells");
        slider(ui, &mut p.volume.friction_root, 0.0..=1.0, "friction between strands, root");
        slider(ui, &mut p.volume.friction_tip, 0.0..=1.0, "friction between strands, tip");
        slider(ui, &mut p.volume.density_push, 0.0..=50.0, "push out of dense hair (m/s²)");
        slider(ui, &mut p.volume.pressure_iterations, 0..=MAX_PRESSURE_ITERATIONS, "pressure sweeps (0: off)");
        slider(ui, &mut p.volume.pressure, 0.0..=1.0, "pressure applied");
    });
    // The same positions on every path; only the step time (in the diagnostics) changes.
    ui.horizontal(|ui| {
        ui.label("SIMD");
        for path in [SimdPath::Auto, SimdPath::Baseline, SimdPath::Avx2, SimdPath::Avx512] {
            ui.add_enabled_ui(path.is_available(), |ui| ui.selectable_value(&mut p.simd, path, path.to_string()));
        }
    });
}

/// Returns whether an edit was finished this frame (a drag released, a click, a typed value).
fn groom_section(ui: &mut egui::Ui, g: &mut HairGroom) -> bool {
    let mut finished = false;
    let mut track = |response: egui::Response| {
        finished |= response.drag_stopped() || (response.changed() && !response.dragged());
    };
    ui.label("Regrows when a slider is released.");
    track(slider(ui, &mut g.guides, 16..=4096, "guides"));
    track(slider(ui, &mut g.segments, 2..=24, "segments"));
    track(slider(ui, &mut g.length, 0.02..=0.6, "length (m)"));
    track(slider(ui, &mut g.length_variation, 0.0..=0.8, "length variation"));
    track(slider(ui, &mut g.curl, 0.0..=1.5, "curl (rad / segment)"));
    ui.horizontal(|ui| {
        for (axis, value) in ["x", "y", "z"].iter().zip(g.comb.as_mut()) {
            track(ui.add(egui::DragValue::new(value).speed(0.02).range(-3.0..=3.0).prefix(format!("{axis} "))));
        }
        ui.label("comb (head space)");
    });
    track(slider(ui, &mut g.settle_steps, 0..=600, "settle steps"));
    track(ui.add(egui::DragValue::new(&mut g.seed).prefix("seed ")));
    ui.horizontal(|ui| {
        track(ui.selectable_value(&mut g.distribution, RootDistribution::Poisson, "Poisson-disk roots"));
        track(ui.selectable_value(&mut g.distribution, RootDistribution::Uniform, "uniform roots"));
        track(ui.selectable_value(&mut g.distribution, RootDistribution::Vertices { jitter: 0.0 }, "vertex roots"));
    });
    ui.separator();
    ui.label("Children (drawn on the GPU; no regrowth)");
    let c = &mut g.children;
    track(slider(ui, &mut c.per_guide, 0..=32, "children per guide"));
    track(slider(ui, &mut c.spiral.a, 0.0..=10.0, "spiral a"));
    track(slider(ui, &mut c.spiral.b, 0.0..=10.0, "spiral b"));
    track(
        ui.add(egui::Slider::new(&mut c.spiral.scale, 1e-5..=1e-3).logarithmic(true).text("spiral scale (m / unit)")),
    );
    track(slider(ui, &mut c.spiral.angle_step, 0.0..=std::f32::consts::TAU, "spiral angle step (rad)"));
    track(slider(ui, &mut c.clumping, 0.0..=1.0, "clumping"));
    track(ui.add(egui::Slider::new(&mut c.tip_spread, 0.0..=0.02).text("tip spread (m)").fixed_decimals(3)));
    finished
}

fn color_edit(ui: &mut egui::Ui, color: &mut Color, text: &str) {
    let linear = color.to_linear();
    let mut rgb = [linear.red, linear.green, linear.blue];
    ui.horizontal(|ui| {
        if ui.color_edit_button_rgb(&mut rgb).changed() {
            *color = LinearRgba::rgb(rgb[0], rgb[1], rgb[2]).into();
        }
        ui.label(text);
    });
}

fn look_section(ui: &mut egui::Ui, look: &mut HairLook) {
    color_edit(ui, &mut look.root_color, "root colour");
    color_edit(ui, &mut look.tip_color, "tip colour");
    slider(ui, &mut look.tint_variation, 0.0..=1.0, "tint variation");
    ui.add(egui::Slider::new(&mut look.root_width, 0.0001..=0.004).text("root width (m)").fixed_decimals(4));
    ui.add(egui::Slider::new(&mut look.tip_width, 0.0..=0.004).text("tip width (m)").fixed_decimals(4));
    slider(ui, &mut look.diffuse, 0.0..=2.0, "diffuse");
    let mut marschner = matches!(look.shading, HairShading::Marschner { .. });
    if ui.checkbox(&mut marschner, "Marschner highlights (R, TT, TRT)").changed() {
        look.shading = if marschner { HairShading::MARSCHNER } else { HairShading::KajiyaKay };
    }
    if let HairShading::Marschner { roughness, cuticle_tilt } = &mut look.shading {
        slider(ui, roughness, 0.05..=1.0, "roughness");
        slider(ui, cuticle_tilt, -0.2..=0.2, "cuticle tilt (rad)");
    }
    for (name, lobe) in [("primary highlight", &mut look.primary), ("secondary highlight", &mut look.secondary)] {
        color_edit(ui, &mut lobe.color, name);
        ui.add(egui::Slider::new(&mut lobe.exponent, 1.0..=500.0).logarithmic(true).text("exponent"));
        slider(ui, &mut lobe.shift, -0.5..=0.5, "shift (− root, + tip)");
    }
    slider(ui, &mut look.subdivisions, 1..=8, "curve samples per segment");
    ui.checkbox(&mut look.receive_shadows, "shadows on hair");
    ui.checkbox(&mut look.cast_shadows, "hair casts shadows");
    slider(ui, &mut look.self_shadow, 0.0..=1.0, "self-shadowing (per fibre layer)");
    ui.horizontal(|ui| {
        ui.label("thin strands");
        for (mode, name) in ANTIALIAS_MODES {
            ui.selectable_value(&mut look.antialias, mode, name);
        }
    });
    ui.checkbox(&mut look.guides_only, "show guides only");
}

/// The level of detail: by the head's height on screen, or held at a level.
fn detail_section(ui: &mut egui::Ui, lod: &mut HairLod) {
    ui.add(
        egui::Slider::new(&mut lod.full_detail_height, 50.0..=2000.0)
            .logarithmic(true)
            .text("every guide from this height (px)"),
    );
    let mut fixed = lod.fixed_level.is_some();
    ui.checkbox(&mut fixed, "hold a level");
    let mut level = lod.fixed_level.unwrap_or(0);
    ui.add_enabled(
        fixed,
        egui::Slider::new(&mut level, 0..=bevy_hair::hair_sim::solver::MAX_DETAIL_LEVEL).text("level"),
    );
    lod.fixed_level = fixed.then_some(level);
    slider(ui, &mut lod.fade_seconds, 0.0..=2.0, "fade (s)");
}

fn motion_section(ui: &mut egui::Ui, motion: &mut Motion) {
    ui.horizontal(|ui| {
        ui.checkbox(&mut motion.paused, "pause (Space)");
        ui.checkbox(&mut motion.drag_head, "drag the head (D)");
    });
    ui.add_enabled_ui(!motion.drag_head, |ui| {
        slider(ui, &mut motion.speed, 0.0..=3.0, "speed");
        let mut time = motion.time;
        if slider(ui, &mut time, 0.0..=motion.duration, "time (s)").changed() {
            motion.seek = Some(time);
        }
    });
    if motion.drag_head {
        ui.label("Left drag moves the head, Shift + left drag turns it, right drag orbits.");
    }
    if ui.button("Put the head back").clicked() {
        motion.reset_pose = true;
    }
}
