//! Renders hair for real (Vulkan; lavapipe on machines without a GPU) into an offscreen
//! image and checks pixels. Without a Vulkan adapter each test prints why it skipped, or
//! fails when `BEVY_HAIR_REQUIRE_ADAPTER` is set (as `.ci/run` sets it).
//! The PNGs land in `target/tmp/hair-renders/` for people to look at.

#[path = "../common/mod.rs"]
mod common;
#[path = "../common/scene.rs"]
mod scene;

mod drawing;
mod lights;

use bevy::prelude::*;
use bevy::render::RenderPlugin;
use bevy::render::storage::ShaderBuffer;
use bevy_hair::prelude::*;
use bevy_hair::render::{HairDrawing, HairDrawnBy, HairMaterial};
use bevy_hair::{is_procedural_scalp, procedural_head_mesh};
use scene::*;
use std::time::Duration;

#[test]
fn hair_covers_the_scalp_front_and_back_and_leaves_face_and_background() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let mut scene = Scene::new();
    let head = scene.spawn_head(short_groom());
    scene.wait_until_ready(head);

    for (name, eye) in [("front", Vec3::new(0.0, 0.05, 0.55)), ("back", Vec3::new(0.0, 0.05, -0.55))] {
        scene.look_from(eye);
        let picture = scene.capture(name);
        let roots = visible_roots(&scene, head, eye.normalize());
        let covered = roots.iter().filter(|&&p| picture.hair_near(p)).count();
        let fraction = covered as f32 / roots.len() as f32;
        println!("{name}: {covered} of {} visible roots under hair ({:.0}%)", roots.len(), fraction * 100.0);
        assert!(roots.len() > 20, "{name}: only {} roots face the camera", roots.len());
        assert!(fraction > 0.9, "{name}: hair covers only {:.0}% of the visible scalp", fraction * 100.0);

        let corners = [(2, 2), (SIZE - 3, 2), (2, SIZE - 3), (SIZE - 3, SIZE - 3)];
        assert!(corners.iter().all(|&p| Picture::is_background(picture.at(p))), "{name}: a corner is not background");
    }

    // The lower face (mouth and chin of the procedural head) is skin, not hair.
    scene.look_from(Vec3::new(0.0, 0.05, 0.55));
    let picture = scene.capture("face");
    let head_mesh = procedural_head_mesh(4);
    let positions = head_mesh.attribute(Mesh::ATTRIBUTE_POSITION).unwrap().as_float3().unwrap();
    let face: Vec<(u32, u32)> = positions
        .iter()
        .map(|&p| Vec3::from_array(p))
        .filter(|p| p.z > 0.06 && p.x.abs() < 0.03 && (-0.07..-0.02).contains(&p.y) && !is_procedural_scalp(*p))
        .filter_map(|p| scene.project(p))
        .collect();
    let hair_on_face = face.iter().filter(|&&p| Picture::is_hair(picture.at(p))).count();
    println!("face: {hair_on_face} of {} lower-face points under hair", face.len());
    assert!(face.len() > 5);
    assert!(hair_on_face * 10 <= face.len(), "hair covers {hair_on_face} of {} lower-face points", face.len());
}

/// A head at a level of detail is drawn as at full detail: its followers, placed where the
/// strands are copied out, cover as many pixels, and its opacity map, built from the
/// simulated guides alone, shades them about as much (the settled hair at rest, so the
/// followers lie where their own strands would).
#[test]
fn a_head_at_a_level_of_detail_is_drawn_as_at_full_detail() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let mut scene = Scene::new();
    let head = scene.spawn_head(short_groom());
    scene.wait_until_ready(head);
    scene.look_from(Vec3::new(0.0, 0.25, 0.5));
    scene.frames(3);
    let full = scene.capture("detail-0");
    scene.app.world_mut().entity_mut(head).insert(HairLod { fixed_level: Some(3), fade_seconds: 0.0, ..default() });
    scene.frames(3);
    let far = scene.capture("detail-3");
    let state = scene.app.world().get::<HairState>(head).unwrap();
    assert_eq!(state.strands().simulated_strands(), 75, "1/8 of 600 guides");
    let hair_luminance =
        |picture: &Picture| mean(picture.pixels.iter().filter(|&&c| Picture::is_hair(c)).map(|&c| linear_luminance(c)));
    let (pixels, lit) = ([full.hair_pixels(), far.hair_pixels()], [hair_luminance(&full), hair_luminance(&far)]);
    println!("hair pixels {pixels:?}, mean hair luminance {lit:?} at levels 0 and 3");
    assert!(pixels[0] > 2000, "too little hair in view: {pixels:?}");
    let ratio = pixels[1] as f32 / pixels[0] as f32;
    assert!((0.95..=1.05).contains(&ratio), "level 3 covers {ratio:.3} of full detail's hair pixels");
    assert!((lit[1] / lit[0] - 1.0).abs() < 0.1, "level 3 lit {:.3} of full detail", lit[1] / lit[0]);
}

#[test]
fn turning_the_light_moves_the_highlight_and_children_cover_more() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let mut scene = Scene::new();
    let head = scene.spawn_head(short_groom());
    scene.wait_until_ready(head);
    scene.look_from(Vec3::new(0.0, 0.05, 0.55));

    scene.light_from(Vec3::new(-1.0, 0.6, 0.6));
    let left = scene.capture("light-left").highlight_centroid();
    scene.light_from(Vec3::new(1.0, 0.6, 0.6));
    let right = scene.capture("light-right").highlight_centroid();
    println!("brightest hair: light from the left at x = {:.0}, from the right at x = {:.0}", left.x, right.x);
    assert!(right.x - left.x > 15.0, "the highlight moved from {left} to {right}");

    let mut coverage = Vec::new();
    for per_guide in [0, 4, 16] {
        scene.app.world_mut().get_mut::<HairGroom>(head).unwrap().children.per_guide = per_guide;
        scene.frames(3);
        let hair = scene.capture(&format!("children-{per_guide}")).hair_pixels();
        let stats = *scene.app.world().resource::<HairRenderStats>();
        println!("{per_guide} children per guide: {hair} hair pixels, {stats:?}");
        coverage.push(hair);
        // Only guide particles, their frame vectors, the scalp at each root, the head's
        // centre, the draw order of the 5 pieces of each guide and the opacity map of the
        // one shadow-casting light travel, whatever the children:
        // (600 × 11 × 2 + 600 + 1 + 600 × 5 / 4 + 1 + 5 + 32 × 32 × 17 / 4) × 16 bytes.
        assert_eq!(stats.uploaded_bytes, (600 * 11 * 2 + 600 + 1 + 600 * 5 / 4 + 1 + 5 + 32 * 32 * 17 / 4) * 16);
        assert_eq!(stats.rendered_strands, 600 * (per_guide as u64 + 1));
    }
    assert!(coverage[0] < coverage[1] && coverage[1] < coverage[2], "coverage {coverage:?} does not grow");
    assert!(coverage[2] as f32 > 1.3 * coverage[0] as f32, "coverage {coverage:?}");
    // The frame's drawing work on the CPU is published.
    let store = scene.app.world().resource::<bevy::diagnostic::DiagnosticsStore>();
    let upload_ms = store.get(&HairDiagnostics::UPLOAD_TIME).and_then(|d| d.value());
    println!("drawing work on the CPU: {upload_ms:?} ms in the last frame");
    assert!(upload_ms.is_some_and(|ms| ms > 0.0 && ms < 1e4), "no usable upload time published: {upload_ms:?}");
}

#[test]
fn hair_follows_its_head_through_visibility_layers_and_despawn() {
    use bevy::camera::visibility::RenderLayers;
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let mut scene = Scene::new();
    let head = scene.spawn_head(short_groom());
    scene.wait_until_ready(head);
    let drawing = scene.app.world().get::<HairDrawnBy>(head).expect("a drawing").0;
    assert_eq!(scene.app.world().get::<ChildOf>(drawing).map(ChildOf::parent), Some(head), "drawn by a child");
    let look = |scene: &mut Scene, name: &str| {
        let picture = scene.capture(name);
        let counts = (picture.hair_pixels(), red_pixels(&picture));
        println!("{name}: {} hair pixels, {} skin pixels", counts.0, counts.1);
        counts
    };
    let (hair, skin) = look(&mut scene, "lifecycle-visible");
    assert!(hair > 500 && skin > 500);

    *scene.app.world_mut().get_mut::<Visibility>(head).unwrap() = Visibility::Hidden;
    assert_eq!(look(&mut scene, "lifecycle-head-hidden"), (0, 0), "hidden head, hidden hair");

    *scene.app.world_mut().get_mut::<Visibility>(head).unwrap() = Visibility::Inherited;
    *scene.app.world_mut().get_mut::<Visibility>(drawing).unwrap() = Visibility::Hidden;
    let (hair, skin) = look(&mut scene, "lifecycle-hair-hidden");
    assert!(hair == 0 && skin > 500, "the hair alone can be hidden");

    *scene.app.world_mut().get_mut::<Visibility>(drawing).unwrap() = Visibility::Inherited;
    scene.app.world_mut().entity_mut(head).insert(RenderLayers::layer(1));
    assert_eq!(look(&mut scene, "lifecycle-other-layer"), (0, 0), "the hair is on its head's layer");
    scene.app.world_mut().entity_mut(scene.camera).insert(RenderLayers::layer(1));
    let (hair, skin) = look(&mut scene, "lifecycle-camera-on-layer");
    assert!(hair > 500 && skin > 500, "a camera on the head's layer sees the hair");

    scene.app.world_mut().entity_mut(head).despawn();
    scene.frames(3);
    let world = scene.app.world_mut();
    let drawings = world.query::<&HairDrawing>().iter(world).count();
    let buffers = world.resource::<Assets<ShaderBuffer>>().len();
    let materials = world.resource::<Assets<HairMaterial>>().len();
    println!("after despawning the head: {drawings} drawings, {buffers} guide buffers, {materials} hair materials");
    assert_eq!((drawings, buffers, materials), (0, 0, 0), "the hair outlived its head");
}

/// A groom the GPU steps keeps one set of GPU strands and one drawing pass through all a
/// game does to it (hidden, regrown, moved to the CPU and back), and leaves none when its
/// head goes: `hair_gpu`'s live objects (which own all its buffers) counted at each turn.
#[test]
fn a_gpu_groom_leaks_no_gpu_buffers() {
    use bevy_hair::hair_gpu::live_objects;
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let mut scene = Scene::new();
    let before = live_objects();
    let head = scene.spawn_head(short_groom());
    scene.app.world_mut().entity_mut(head).insert(HairBackend::Gpu);
    scene.wait_until_ready(head);
    // Until `guides` grow on the GPU, then a few frames drawn.
    let on_gpu_with = |scene: &mut Scene, guides: usize| {
        for _ in 0..600 {
            let state = scene.app.world().get::<HairState>(head);
            if state.is_some_and(|s| s.roots().len() == guides && s.gpu_lag().is_some()) {
                scene.frames(3);
                return live_objects();
            }
            scene.frames(1);
            std::thread::sleep(Duration::from_millis(2));
        }
        panic!("the GPU did not take the groom of {guides} guides over");
    };
    let one = [before[0] + 1, before[1] + 1];
    let mut counts = vec![("on the GPU", on_gpu_with(&mut scene, 600))];
    let drawing = scene.app.world().get::<HairDrawnBy>(head).expect("a drawing").0;
    *scene.app.world_mut().get_mut::<Visibility>(drawing).unwrap() = Visibility::Hidden;
    scene.frames(3);
    counts.push(("hidden", live_objects()));
    *scene.app.world_mut().get_mut::<Visibility>(drawing).unwrap() = Visibility::Inherited;
    scene.app.world_mut().get_mut::<HairGroom>(head).unwrap().guides = 400;
    counts.push(("regrown", on_gpu_with(&mut scene, 400)));
    scene.app.world_mut().entity_mut(head).insert(HairBackend::Cpu);
    scene.frames(3);
    counts.push(("on the CPU", live_objects()));
    scene.app.world_mut().entity_mut(head).insert(HairBackend::Gpu);
    counts.push(("back on the GPU", on_gpu_with(&mut scene, 400)));
    scene.app.world_mut().entity_mut(head).despawn();
    scene.frames(3);
    counts.push(("despawned", live_objects()));
    println!("GPU strands and drawings alive (before: {before:?}): {counts:?}");
    let expected = [one, one, one, before, one, before];
    for ((turn, count), expected) in counts.iter().zip(expected) {
        assert_eq!(*count, expected, "{turn}");
    }
}

/// The same groom settled with hair volume off and on, seen from the side: without it the
/// hair settles into a shell one strand thick on the skull; with it the strands keep each
/// other out and the hair stands off the head, covering more of the picture
/// (`docs/volume-off.png` and `docs/volume-on.png` are these pictures).
#[test]
fn hair_volume_keeps_a_groom_full() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let mut pictures = Vec::new();
    for enabled in [false, true] {
        let mut scene = Scene::new();
        let volume = Volume { enabled, ..default() };
        scene.app.insert_resource(HairSettings(SimParams { volume, ..default() }));
        let groom = HairGroom { length: 0.12, settle_steps: 240, ..short_groom() };
        let head = scene.spawn_head(groom);
        scene.wait_until_ready(head);
        scene.look_from(Vec3::new(0.55, 0.05, 0.1));
        let name = if enabled { "volume-on" } else { "volume-off" };
        let picture = scene.capture(name);
        pictures.push(picture.hair_pixels());
    }
    let [off, on] = pictures[..] else { unreachable!() };
    println!("hair pixels: {off} with volume off, {on} with it on");
    assert!(off > 2000, "too little hair in view: {off}");
    assert!(on as f32 > 1.25 * off as f32, "volume on covers {on} pixels, off {off}");
}

/// A renderer in error (a lost device, a validation error) while a groom steps on the GPU,
/// under an app whose renderer recovers on a new device ([`RenderErrorPolicy::Recover`];
/// Bevy's default quits): the groom says so once and steps on the CPU, its GPU strands go,
/// and the new device draws it as the old one did.
#[test]
fn a_renderer_in_error_moves_gpu_hair_to_the_cpu() {
    use bevy::render::error_handler::{RenderErrorHandler, RenderErrorPolicy};
    use bevy::render::render_resource::{BufferDescriptor, BufferUsages};
    use bevy::render::renderer::{RenderDevice, RenderQueue};
    use bevy::render::settings::RenderCreation;
    use bevy_hair::hair_gpu::live_objects;
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let mut scene = Scene::new();
    scene.app.insert_resource(RenderErrorHandler(|_, _, _| {
        RenderErrorPolicy::Recover(RenderCreation::Automatic(Box::default()))
    }));
    scene.app.init_resource::<common::GpuFallbacks>().add_systems(Last, common::collect_gpu_fallbacks);
    let before = live_objects();
    let head = scene.spawn_head(short_groom());
    scene.app.world_mut().entity_mut(head).insert(HairBackend::Gpu);
    scene.wait_until_ready(head);
    common::wait_until_on_gpu(&mut scene.app, head);
    scene.frames(3);
    let on_gpu = live_objects();
    assert_eq!(on_gpu, [before[0] + 1, before[1] + 1], "the GPU steps and draws the groom");
    let before_picture = scene.capture("device-before");
    let skin = red_pixels(&before_picture);
    assert!(before_picture.hair_pixels() > 500 && skin > 500, "the scene shows the head and its hair");

    // A validation error puts Bevy's renderer in error; on recovery it makes a new device,
    // as after a lost one. (`Device::destroy` cannot stand in for a lost device here: Bevy's
    // own clustering upload panics on the destroyed device's buffers before its error
    // handler runs.)
    let world = scene.app.world();
    let (device, queue) = (world.resource::<RenderDevice>(), world.resource::<RenderQueue>());
    let small = device.create_buffer(&BufferDescriptor {
        label: Some("too small"),
        size: 4,
        usage: BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    queue.write_buffer(&small, 64, &[0; 4]);
    let mut frames = 0;
    while scene.app.world().resource::<common::GpuFallbacks>().0.is_empty() && frames < 300 {
        scene.frames(1);
        frames += 1;
    }
    scene.frames(10);
    let after = scene.capture("device-after");
    let fallbacks = scene.app.world().resource::<common::GpuFallbacks>().0.clone();
    let state = scene.app.world().get::<HairState>(head).unwrap();
    println!(
        "renderer in error: reported after {frames} frames: {fallbacks:?}; GPU objects {on_gpu:?} -> {:?} \
         (before the groom {before:?}); skin pixels {skin} -> {}",
        live_objects(),
        red_pixels(&after)
    );
    assert_eq!(fallbacks.len(), 1, "said once: {fallbacks:?}");
    assert!(fallbacks[0].contains("renderer stopped"), "{}", fallbacks[0]);
    assert_eq!(state.gpu_lag(), None, "the CPU steps the groom");
    assert!(state.current_positions().iter().all(|p| p.is_finite()));
    assert_eq!(live_objects(), before, "the GPU strands and drawing went");
    // The new device draws it as the old one did.
    let (hair, redrawn) = (before_picture.hair_pixels(), after.hair_pixels());
    println!("hair pixels {hair} -> {redrawn}");
    assert!((0.95..=1.05).contains(&(redrawn as f32 / hair as f32)), "{redrawn} hair pixels after, {hair} before");
    // And the CPU steps it: a turn of the head swings the hair.
    let still = state.current_positions().to_vec();
    *scene.app.world_mut().get_mut::<Transform>(head).unwrap() = Transform::from_rotation(Quat::from_rotation_y(0.5));
    scene.frames(20);
    let state = scene.app.world().get::<HairState>(head).unwrap();
    let swing = state.current_positions().iter().zip(&still).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
    println!("turned on the CPU: the hair moved up to {:.1} mm", swing * 1e3);
    assert!(swing > 0.01 && state.current_positions().iter().all(|p| p.is_finite()), "moved {swing} m");
}

/// Every variant of the hair shader Bevy can ask for (main pass with and without MSAA, an
/// environment map and tonemapping in the shader; the shadow pass with and without its
/// fragment stage and unclipped-depth emulation) composes with Bevy's own shader modules
/// and passes naga's validation, with no GPU: a WGSL error fails `cargo test` on any
/// machine, not only where the render tests find an adapter.
#[test]
fn every_shader_variant_composes_and_validates_without_a_gpu() {
    use bevy::render::render_resource::{DownlevelFlags, WgpuFeatures};
    use bevy::render::settings::WgpuSettings;
    use bevy::shader::{ShaderCache, ShaderCacheError, ShaderCacheSource, ShaderDefVal, ValidateShader};

    // The app loads Bevy's shader libraries and the hair shader, and renders nothing.
    let mut app = App::new();
    let render = RenderPlugin { render_creation: WgpuSettings { backends: None, ..default() }.into(), ..default() };
    app.add_plugins(common::headless_plugins(render)).add_plugins(HairPlugin::default());
    app.finish();
    app.cleanup();
    let hair: Handle<Shader> = app.world().resource::<AssetServer>().load(bevy_hair::render::shader_path());
    let mut loaded = 0;
    for _ in 0..500 {
        app.update();
        let count = app.world().resource::<Assets<Shader>>().len();
        if app.world().resource::<AssetServer>().is_loaded(&hair) && count == loaded {
            break;
        }
        loaded = count;
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!(app.world().resource::<AssetServer>().is_loaded(&hair), "the hair shader did not load");

    // naga's full validation of each composed module (the composer validates too, but only
    // in debug builds of `bevy_shader`).
    fn validate(_: &(), source: ShaderCacheSource, _: &ValidateShader) -> Result<(), ShaderCacheError> {
        let module = match source {
            ShaderCacheSource::Naga(module) => module,
            ShaderCacheSource::Wgsl(text) => naga::front::wgsl::parse_str(&text)
                .map_err(|e| ShaderCacheError::CreateShaderModule(e.emit_to_string(&text)))?,
            ShaderCacheSource::SpirV(_) => unreachable!("the hair shader is WGSL"),
        };
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::default())
            .validate(&module)
            .map(|_| ())
            .map_err(|e| ShaderCacheError::CreateShaderModule(format!("{e:?}")))
    }
    let mut cache = ShaderCache::<(), ()>::new((), WgpuFeatures::empty(), DownlevelFlags::all(), validate);
    // As Bevy's pipeline cache does (a storage-buffer limit is needed by the mesh bindings).
    let global: ShaderDefVal = ShaderDefVal::UInt("AVAILABLE_STORAGE_BUFFER_BINDINGS".into(), 8);
    for (id, shader) in app.world().resource::<Assets<Shader>>().iter() {
        let mut shader = shader.clone();
        shader.shader_defs.push(global.clone());
        cache.set_shader(id, shader);
    }

    let common: Vec<ShaderDefVal> = vec![
        ShaderDefVal::UInt("MATERIAL_BIND_GROUP".into(), 3),
        "VERTEX_OUTPUT_INSTANCE_INDEX".into(),
        "VIEW_PROJECTION_PERSPECTIVE".into(),
    ];
    let main: Vec<ShaderDefVal> = vec![
        "MESH_PIPELINE".into(),
        "PCSS_SAMPLERS_AVAILABLE".into(),
        "SHADOW_FILTER_METHOD_GAUSSIAN".into(),
        ShaderDefVal::Int("SCREEN_SPACE_SPECULAR_TRANSMISSION_BLUR_TAPS".into(), 8),
    ];
    let tonemapping: Vec<ShaderDefVal> = vec![
        "TONEMAP_IN_SHADER".into(),
        ShaderDefVal::UInt("TONEMAPPING_LUT_TEXTURE_BINDING_INDEX".into(), 18),
        ShaderDefVal::UInt("TONEMAPPING_LUT_SAMPLER_BINDING_INDEX".into(), 19),
        "TONEMAP_METHOD_TONY_MC_MAPFACE".into(),
        "DEBAND_DITHER".into(),
    ];
    // Every combination of a pass's optional defs, named by the options it takes.
    let combinations = |pass: &str, base: Vec<ShaderDefVal>, options: &[(&str, Vec<ShaderDefVal>)]| {
        (0..1u32 << options.len())
            .map(|bits| {
                let (mut name, mut defs) = (String::from(pass), [common.clone(), base.clone()].concat());
                for (_, (option, extra)) in options.iter().enumerate().filter(|(k, _)| bits & 1 << k != 0) {
                    name += &format!(" + {option}");
                    defs.extend(extra.iter().cloned());
                }
                (name, defs)
            })
            .collect::<Vec<_>>()
    };
    let flag = |def: &str| vec![ShaderDefVal::from(def)];
    let main_options = [
        ("MULTISAMPLED", flag("MULTISAMPLED")),
        ("DISTANCE_FOG", flag("DISTANCE_FOG")),
        ("ENVIRONMENT_MAP", flag("ENVIRONMENT_MAP")),
        ("TONEMAP_IN_SHADER", tonemapping),
    ];
    let shadow_options = [
        ("PREPASS_FRAGMENT", flag("PREPASS_FRAGMENT")),
        ("UNCLIPPED_DEPTH_ORTHO_EMULATION", flag("UNCLIPPED_DEPTH_ORTHO_EMULATION")),
    ];
    let variants = [
        combinations("main", main, &main_options),
        combinations("shadow", vec!["PREPASS_PIPELINE".into(), "DEPTH_PREPASS".into()], &shadow_options),
    ]
    .concat();
    assert_eq!(variants.len(), 20);
    let failures: Vec<String> = variants
        .iter()
        .enumerate()
        .filter_map(|(pipeline, (name, defs))| match cache.get(pipeline, hair.id(), defs) {
            Ok(_) => None,
            Err(ShaderCacheError::ProcessShaderError(e)) => {
                Some(format!("{name}: {}", e.emit_to_string(&cache.composer)))
            }
            Err(e) => Some(format!("{name}: {e}")),
        })
        .collect();
    println!("{} shader variants composed and validated, {} failed", variants.len(), failures.len());
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}
