//! Renders hair for real (Vulkan; lavapipe on machines without a GPU) into an offscreen
//! image and checks pixels. Without a Vulkan adapter each test prints why it skipped, or
//! fails when `BEVY_HAIR_REQUIRE_ADAPTER` is set (as `.ci/run` sets it).
//! The PNGs land in `target/tmp/hair-renders/` for people to look at.

use bevy::camera::RenderTarget;
use bevy::camera::visibility::NoFrustumCulling;
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::image::Image;
use bevy::light::{CascadeShadowConfigBuilder, DirectionalLightShadowMap, GlobalAmbientLight, NotShadowCaster};
use bevy::log::LogPlugin;
use bevy::prelude::*;
use bevy::render::RenderPlugin;
use bevy::render::render_resource::{BufferInitDescriptor, BufferUsages, TextureFormat, TextureUsages};
use bevy::render::renderer::RenderDevice;
use bevy::render::storage::ShaderBuffer;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use bevy::window::ExitCondition;
use bevy::winit::WinitPlugin;
use bevy_hair::hair_sim::groom::{ChildParams, ChildRoot, child_curve, tessellate, transport_frames};
use bevy_hair::hair_sim::math::Vec3 as SimVec3;
use bevy_hair::prelude::*;
use bevy_hair::render::{HairDrawing, HairDrawnBy, HairMaterial, HairUniform, StrandLayout};
use bevy_hair::{is_procedural_scalp, procedural_head_mesh};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

mod common;

const SIZE: u32 = 256;
const BACKGROUND: Color = Color::srgb(0.05, 0.05, 0.4);

/// Set by `.ci/run`: there, a missing adapter is a failure (lavapipe broke), not a skip.
const REQUIRE_ADAPTER: &str = "BEVY_HAIR_REQUIRE_ADAPTER";

macro_rules! require_adapter {
    () => {
        if let Some(reason) = common::no_adapter() {
            if std::env::var_os(REQUIRE_ADAPTER).is_some() {
                panic!("{REQUIRE_ADAPTER} is set and there is {reason}");
            }
            eprintln!("SKIPPED {}: {reason}", module_path!());
            return;
        }
    };
}

/// Rendering serialises: each test builds its own renderer, one at a time.
static GPU: Mutex<()> = Mutex::new(());

struct Scene {
    app: App,
    target: Handle<Image>,
    camera: Entity,
    light: Entity,
}

impl Scene {
    fn new() -> Scene {
        let mut app = common::rendering_app();
        app.insert_resource(ClearColor(BACKGROUND));
        let mut image = Image::new_target_texture(SIZE, SIZE, TextureFormat::Rgba8UnormSrgb, None);
        image.texture_descriptor.usage |= TextureUsages::COPY_SRC;
        let target = app.world_mut().resource_mut::<Assets<Image>>().add(image);
        let camera = app
            .world_mut()
            .spawn((
                Camera3d::default(),
                RenderTarget::Image(target.clone().into()),
                Tonemapping::None,
                Transform::from_xyz(0.0, -0.02, 0.55).looking_at(Vec3::new(0.0, -0.02, 0.0), Vec3::Y),
            ))
            .id();
        let light = app
            .world_mut()
            .spawn((
                DirectionalLight { illuminance: 4000.0, shadow_maps_enabled: true, ..default() },
                Transform::from_xyz(0.3, 1.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y),
            ))
            .id();
        Scene { app, target, camera, light }
    }

    /// The procedural head with a short groom, red skin, green hair (for telling them apart),
    /// 2 subdivisions per segment (a 7 cm strand of 10 segments is still smooth at 256²).
    fn spawn_head(&mut self, groom: HairGroom) -> Entity {
        let world = self.app.world_mut();
        let mesh = world.resource_mut::<Assets<Mesh>>().add(procedural_head_mesh(4));
        let skin = world.resource_mut::<Assets<StandardMaterial>>().add(Color::srgb(0.8, 0.25, 0.2));
        let look = HairLook {
            root_color: Color::srgb(0.05, 0.5, 0.05),
            tip_color: Color::srgb(0.1, 0.7, 0.1),
            primary: SpecularLobe { color: Color::srgb(0.05, 0.3, 0.05), ..HairLook::default().primary },
            subdivisions: 2,
            ..default()
        };
        world.spawn((Mesh3d(mesh), MeshMaterial3d(skin), Transform::default(), groom, look)).id()
    }

    fn wait_until_ready(&mut self, head: Entity) {
        for _ in 0..3000 {
            self.app.update();
            match self.app.world().get::<GroomStatus>(head) {
                Some(GroomStatus::Ready { .. }) => {
                    // A few frames for the drawing entity and its pipeline.
                    self.frames(5);
                    return;
                }
                Some(GroomStatus::Failed(reason)) => panic!("growth failed: {reason}"),
                _ => std::thread::sleep(Duration::from_millis(5)),
            }
        }
        panic!("the groom did not grow");
    }

    fn frames(&mut self, n: usize) {
        for _ in 0..n {
            self.app.update();
        }
    }

    fn look_from(&mut self, eye: Vec3) {
        let target = Vec3::new(0.0, -0.02, 0.0);
        *self.app.world_mut().get_mut::<Transform>(self.camera).unwrap() =
            Transform::from_translation(eye).looking_at(target, Vec3::Y);
    }

    fn light_from(&mut self, direction_to_light: Vec3) {
        *self.app.world_mut().get_mut::<Transform>(self.light).unwrap() =
            Transform::from_translation(direction_to_light).looking_at(Vec3::ZERO, Vec3::Y);
    }

    /// Draws strands with the hair material directly, no groom: `data` is what the plugin
    /// uploads (positions, then frame vectors, then the scalp at each root and the head's
    /// centre where there are children), `uniform` the look and counts.
    fn draw_strands(&mut self, data: Vec<Vec4>, layout: &StrandLayout, uniform: HairUniform) -> Entity {
        let (particles, rest) = data.split_at((2 * layout.guides * layout.particles) as usize);
        // Up to the head's centre (zeros where the strands have no children), then the
        // pieces in the order they were grown.
        let mut guides = rest.to_vec();
        guides.resize((layout.guides + 1) as usize, Vec4::ZERO);
        guides.extend(StrandLayout::pack_order(&layout.grown_order()));
        let world = self.app.world_mut();
        let particles = world.resource::<RenderDevice>().create_buffer_with_data(&BufferInitDescriptor {
            label: None,
            contents: bytemuck::cast_slice(particles),
            usage: BufferUsages::STORAGE,
        });
        let guides = world.resource_mut::<Assets<ShaderBuffer>>().add(ShaderBuffer::from(guides));
        let material = world.resource_mut::<Assets<HairMaterial>>().add(HairMaterial { guides, uniform, particles });
        let mesh = world.resource_mut::<Assets<Mesh>>().add(layout.mesh());
        let entity = world.spawn((Mesh3d(mesh), MeshMaterial3d(material), NoFrustumCulling)).id();
        self.frames(5);
        entity
    }

    /// Renders a frame, saves it as `name.png`, and returns it.
    fn capture(&mut self, name: &str) -> Picture {
        let slot: Arc<Mutex<Option<Image>>> = Arc::default();
        let sink = slot.clone();
        self.app
            .world_mut()
            .spawn(Screenshot::image(self.target.clone()))
            .observe(move |captured: On<ScreenshotCaptured>| *sink.lock().unwrap() = Some(captured.image.clone()));
        for _ in 0..30 {
            self.app.update();
            if let Some(image) = slot.lock().unwrap().take() {
                let picture = Picture::from_image(&image);
                picture.save(&image, name);
                return picture;
            }
        }
        panic!("no screenshot arrived");
    }

    /// Where a world point lands in the picture.
    fn project(&self, point: Vec3) -> Option<(u32, u32)> {
        let world = self.app.world();
        let camera = world.get::<Camera>(self.camera)?;
        let transform = world.get::<GlobalTransform>(self.camera)?;
        let p = camera.world_to_viewport(transform, point).ok()?;
        (p.x >= 0.0 && p.y >= 0.0 && p.x < SIZE as f32 && p.y < SIZE as f32).then_some((p.x as u32, p.y as u32))
    }
}

/// A captured frame as linear-ish sRGB bytes, with the classification the tests use.
struct Picture {
    pixels: Vec<[f32; 3]>,
}

impl Picture {
    fn from_image(image: &Image) -> Picture {
        let mut pixels = Vec::with_capacity((SIZE * SIZE) as usize);
        for y in 0..SIZE {
            for x in 0..SIZE {
                let c = image.get_color_at(x, y).expect("readable screenshot").to_srgba();
                pixels.push([c.red, c.green, c.blue]);
            }
        }
        Picture { pixels }
    }

    fn save(&self, image: &Image, name: &str) {
        let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("hair-renders");
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(format!("{name}.png"));
        image.clone().try_into_dynamic().expect("convertible screenshot").to_rgb8().save(&path).unwrap();
        println!("wrote {}", path.display());
    }

    fn at(&self, (x, y): (u32, u32)) -> [f32; 3] {
        self.pixels[(y * SIZE + x) as usize]
    }

    /// Hair is green-dominant (the test look), skin red-dominant, background blue.
    fn is_hair(c: [f32; 3]) -> bool {
        c[1] > 1.2 * c[0] && c[1] > 1.2 * c[2] && c[1] > 0.02
    }

    fn is_background(c: [f32; 3]) -> bool {
        let bg = BACKGROUND.to_srgba();
        (c[0] - bg.red).abs() < 0.02 && (c[1] - bg.green).abs() < 0.02 && (c[2] - bg.blue).abs() < 0.02
    }

    /// Hair within one pixel of `p`.
    fn hair_near(&self, (x, y): (u32, u32)) -> bool {
        let xs = x.saturating_sub(1)..=(x + 1).min(SIZE - 1);
        xs.flat_map(|x| (y.saturating_sub(1)..=(y + 1).min(SIZE - 1)).map(move |y| (x, y)))
            .any(|p| Self::is_hair(self.at(p)))
    }

    fn hair_pixels(&self) -> usize {
        self.pixels.iter().filter(|&&c| Self::is_hair(c)).count()
    }

    /// Mean position of the brightest 3% of hair pixels.
    fn highlight_centroid(&self) -> Vec2 {
        let mut hair: Vec<(f32, u32)> = (0..SIZE * SIZE)
            .filter(|&i| Self::is_hair(self.pixels[i as usize]))
            .map(|i| (luminance(self.pixels[i as usize]), i))
            .collect();
        hair.sort_by(|a, b| b.0.total_cmp(&a.0));
        let top = &hair[..(hair.len() * 3 / 100).max(1)];
        top.iter().map(|&(_, i)| Vec2::new((i % SIZE) as f32, (i / SIZE) as f32)).sum::<Vec2>() / top.len() as f32
    }
}

fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// 600 guides with 4 children each, drawn with 2 subdivisions per segment (see
/// [`Scene::spawn_head`]): lavapipe's time per frame follows the vertex count, and the
/// default 16 children at 4 subdivisions make frames 5× slower without changing what
/// these tests measure.
fn short_groom() -> HairGroom {
    let children = ChildParams { per_guide: 4, ..default() };
    HairGroom { guides: 600, length: 0.07, settle_steps: 120, children, ..default() }
}

/// Scalp roots facing the camera (head-space normal toward `view_dir`) and their pixels.
fn visible_roots(scene: &Scene, head: Entity, toward_camera: Vec3) -> Vec<(u32, u32)> {
    let state = scene.app.world().get::<HairState>(head).unwrap();
    state
        .roots()
        .iter()
        .filter(|r| {
            let n = r.normal(state.head_mesh());
            Vec3::new(n.x, n.y, n.z).dot(toward_camera) > 0.5
        })
        .filter_map(|r| {
            let p = r.position(state.head_mesh());
            scene.project(Vec3::new(p.x, p.y, p.z))
        })
        .collect()
}

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
fn a_groom_the_gpu_steps_is_drawn_from_the_gpu_where_the_cpu_would_draw_it() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let mut scene = Scene::new();
    let head = scene.spawn_head(short_groom());
    scene.wait_until_ready(head);
    scene.look_from(Vec3::new(0.3, 0.1, 0.5));
    scene.frames(3);
    let on_cpu = scene.capture("backend-cpu");
    let cpu_bytes = scene.app.world().resource::<HairRenderStats>().uploaded_bytes;
    // And blended (sorted back to front), for the GPU's order below.
    let blended = |scene: &mut Scene, on: bool| {
        let mut look = scene.app.world_mut().get_mut::<HairLook>(head).unwrap();
        look.antialias = if on { HairAntialias::Blended } else { HairLook::default().antialias };
        scene.frames(3);
    };
    blended(&mut scene, true);
    let cpu_blended = scene.capture("backend-cpu-blended");
    blended(&mut scene, false);
    let drawing = scene.app.world().get::<HairDrawnBy>(head).unwrap().0;
    let aabb = |scene: &Scene| *scene.app.world().get::<bevy::camera::primitives::Aabb>(drawing).unwrap();
    let cpu_box = aabb(&scene);
    // The head is still and the hair settled: on the GPU it stays where it hangs.
    scene.app.world_mut().entity_mut(head).insert(HairBackend::Gpu);
    // The CPU steps it while the GPU's pipelines compile in the background.
    let on_gpu = |scene: &Scene| scene.app.world().get::<HairState>(head).unwrap().gpu_lag().is_some();
    let mut waited = 0;
    while !on_gpu(&scene) && waited < 600 {
        scene.frames(1);
        waited += 1;
    }
    println!("the GPU took the groom over after {waited} frames");
    scene.frames(3);
    let on_gpu = scene.capture("backend-gpu");
    let state = scene.app.world().get::<HairState>(head).unwrap();
    assert_eq!(state.gpu_fallback(), None, "the GPU steps the groom");
    assert!(state.gpu_lag().is_some(), "the GPU steps the groom");
    assert_eq!(bevy_hair::hair_gpu::submissions(), 0, "the hair code submitted work itself");
    // The particles and their frames (600 guides × 11 particles, two vec4 each) are
    // written on the GPU; only the rest travels.
    let gpu_bytes = scene.app.world().resource::<HairRenderStats>().uploaded_bytes;
    assert_eq!(cpu_bytes - gpu_bytes, 600 * 11 * 2 * 16, "{cpu_bytes} then {gpu_bytes} bytes uploaded");
    // Culling takes a GPU groom's strands as far as they reach from their roots: a box
    // holding the one around the particles themselves.
    let gpu_box = aabb(&scene);
    assert!(
        gpu_box.min().cmple(cpu_box.min()).all() && gpu_box.max().cmpge(cpu_box.max()).all(),
        "{gpu_box:?} holds {cpu_box:?}"
    );
    let (cpu_hair, gpu_hair) = (on_cpu.hair_pixels(), on_gpu.hair_pixels());
    let differing = (0..SIZE * SIZE)
        .filter(|i| {
            Picture::is_hair(on_cpu.at((i % SIZE, i / SIZE))) != Picture::is_hair(on_gpu.at((i % SIZE, i / SIZE)))
        })
        .count();
    println!("hair pixels: {cpu_hair} drawn from the CPU, {gpu_hair} from the GPU, {differing} differ");
    assert!(cpu_hair > 1000, "{cpu_hair} hair pixels");
    assert!(differing * 50 < cpu_hair, "{differing} of {cpu_hair} hair pixels differ");
    // The GPU builds the self-shadow maps from what it draws, as the CPU builds them: the
    // hair is as bright pixel for pixel, where without them it is brighter.
    let mean_apart = |a: &Picture, b: &Picture| {
        let both: Vec<usize> =
            (0..a.pixels.len()).filter(|&i| Picture::is_hair(a.pixels[i]) && Picture::is_hair(b.pixels[i])).collect();
        both.iter().map(|&i| (linear_luminance(a.pixels[i]) - linear_luminance(b.pixels[i])).abs()).sum::<f32>()
            / both.len().max(1) as f32
    };
    scene.app.world_mut().get_mut::<HairLook>(head).unwrap().self_shadow = 0.0;
    scene.frames(3);
    let unshadowed = scene.capture("backend-gpu-unshadowed");
    let (backends, shadow) = (mean_apart(&on_cpu, &on_gpu), mean_apart(&on_gpu, &unshadowed));
    println!(
        "hair luminance, mean difference: CPU against GPU {backends:.4}, GPU with and without self-shadow {shadow:.4}"
    );
    assert!(shadow > 0.01, "self-shadowing darkens the hair: {shadow}");
    assert!(backends < 0.2 * shadow, "the GPU's self-shadow differs from the CPU's by {backends}");
    // Blended, the GPU sorts the pieces it draws: the same picture as the CPU's sort.
    scene.app.world_mut().get_mut::<HairLook>(head).unwrap().self_shadow = HairLook::default().self_shadow;
    blended(&mut scene, true);
    let gpu_blended = scene.capture("backend-gpu-blended");
    let apart = mean_apart(&cpu_blended, &gpu_blended);
    let (cpu_hair, gpu_hair) = (cpu_blended.hair_pixels(), gpu_blended.hair_pixels());
    println!("blended: {cpu_hair} hair pixels from the CPU, {gpu_hair} from the GPU, luminance {apart:.4} apart");
    assert!(cpu_hair > 1000 && cpu_hair.abs_diff(gpu_hair) * 50 < cpu_hair, "{cpu_hair} and {gpu_hair}");
    assert!(apart < 0.2 * shadow, "the GPU's blended hair differs from the CPU's by {apart}");
}

/// Where the hair is, then how bright each of its pixels is (linear luminance) with `light`
/// as the only light
/// (no directional light, no ambient): the hair is found under the scene's own light (dark
/// hair would not read as hair), and the head stands still between the two frames.
fn lit_only_by(scene: &mut Scene, name: &str, light: impl Bundle) -> Vec<(u32, f32)> {
    let mask = scene.capture(&format!("{name}-mask"));
    let world = scene.app.world_mut();
    world.entity_mut(scene.light).despawn();
    world.insert_resource(GlobalAmbientLight { brightness: 0.0, ..default() });
    world.spawn(light);
    scene.frames(3);
    let lit = scene.capture(name);
    (0..SIZE * SIZE)
        .filter(|&i| Picture::is_hair(mask.pixels[i as usize]))
        .map(|i| (i, linear_luminance(lit.pixels[i as usize])))
        .collect()
}

/// Luminance of an sRGB-encoded colour, in linear light (what doubles when the light does).
fn linear_luminance([r, g, b]: [f32; 3]) -> f32 {
    let linear = Color::srgb(r, g, b).to_linear();
    luminance([linear.red, linear.green, linear.blue])
}

/// The groom on the procedural head (it grows settled), seen from the front, and the head.
fn settled_scene() -> (Scene, Entity) {
    let mut scene = Scene::new();
    let head = scene.spawn_head(short_groom());
    scene.wait_until_ready(head);
    (scene, head)
}

fn mean(values: impl Iterator<Item = f32>) -> f32 {
    let (sum, count) = values.fold((0.0, 0), |(s, n), v| (s + v, n + 1));
    sum / count.max(1) as f32
}

/// A point light on the left, casting shadows, lights the hair through the clustered lights,
/// falling off with distance and shadowed by the head as `StandardMaterial` is: the left
/// half of the hair is at least twice as bright as the right (linear luminance).
#[test]
fn a_point_light_lights_the_hair_near_it() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let (mut scene, _) = settled_scene();
    let light = PointLight { intensity: 2_000.0, range: 3.0, shadow_maps_enabled: true, ..default() };
    let hair = lit_only_by(&mut scene, "point-light", (light, Transform::from_xyz(-0.3, 0.05, 0.12)));
    let half = |left: bool| mean(hair.iter().filter(|(i, _)| (i % SIZE < SIZE / 2) == left).map(|&(_, l)| l));
    let (left, right) = (half(true), half(false));
    println!("point light on the left: hair luminance {left:.3} left, {right:.3} right ({} hair pixels)", hair.len());
    assert!(hair.len() > 2000, "the hair is in the picture");
    assert!(left > 0.05, "the lit side is lit: {left}");
    assert!(left > 2.0 * right, "left {left} is not twice right {right}");
}

/// A narrow spot light aimed at the upper left of the hair lights the hair inside its cone
/// and nothing outside it.
#[test]
fn a_spot_light_lights_only_hair_inside_its_cone() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let (mut scene, _) = settled_scene();
    let (from, aim, angle) = (Vec3::new(0.0, 0.1, 0.5), Vec3::new(-0.05, 0.06, 0.05), 0.15);
    let light = SpotLight { intensity: 40_000.0, outer_angle: angle, inner_angle: angle * 0.8, ..default() };
    let hair =
        lit_only_by(&mut scene, "spot-light", (light, Transform::from_translation(from).looking_at(aim, Vec3::Y)));
    // Which pixels the cone covers, from where the hair at each pixel is: the camera ray
    // through the pixel meets the hair near the depth of the aim point.
    let (camera, eye) = {
        let world = scene.app.world();
        (world.get::<Camera>(scene.camera).unwrap().clone(), *world.get::<GlobalTransform>(scene.camera).unwrap())
    };
    let in_cone = |i: u32| {
        let pixel = Vec2::new((i % SIZE) as f32 + 0.5, (i / SIZE) as f32 + 0.5);
        let ray = camera.viewport_to_world(&eye, pixel).unwrap();
        // Depths from 2 cm in front of the aim point to 8 cm behind it: inside at any.
        (0..=10).any(|k| {
            let point = ray.origin + *ray.direction * ((aim - ray.origin).length() - 0.02 + 0.01 * k as f32);
            (point - from).normalize().angle_between((aim - from).normalize()) < angle
        })
    };
    let inside: Vec<f32> = hair.iter().filter(|(i, _)| in_cone(*i)).map(|&(_, l)| l).collect();
    let inside_mean = mean(inside.iter().copied());
    // Lit: a tenth of the cone's mean brightness or more (the cone's soft edge is counted
    // as inside by the depth range above).
    let lit = |l: f32| l > 0.1 * inside_mean;
    let outside = hair.len() - inside.len();
    let outside_lit = hair.iter().filter(|&&(i, l)| lit(l) && !in_cone(i)).count();
    let inside_lit = inside.iter().filter(|&&l| lit(l)).count();
    println!(
        "spot light: {inside_lit} of {} hair pixels in the cone lit (mean {inside_mean:.3}), {outside_lit} of \
         {outside} outside",
        inside.len(),
    );
    assert!(inside.len() > 100 && inside_lit * 2 > inside.len(), "the cone's hair is lit");
    assert!(outside > 500 && outside_lit * 100 <= outside, "{outside_lit} hair pixels outside the cone are lit");
}

/// An environment map alone (no lights, no ambient) lights the hair, in its own colour: a
/// warm map makes the hair redder than a cool one does.
#[test]
fn environment_light_alone_lights_the_hair_in_its_colour() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let (mut scene, _) = settled_scene();
    let world = scene.app.world_mut();
    world.entity_mut(scene.light).despawn();
    world.insert_resource(GlobalAmbientLight { brightness: 0.0, ..default() });
    let mut redness = Vec::new();
    for (name, color) in
        [("environment-warm", Color::srgb(1.0, 0.5, 0.1)), ("environment-cool", Color::srgb(0.1, 0.5, 1.0))]
    {
        let world = scene.app.world_mut();
        let map = EnvironmentMapLight {
            intensity: 3000.0,
            ..EnvironmentMapLight::solid_color(&mut world.resource_mut::<Assets<Image>>(), color)
        };
        world.entity_mut(scene.camera).insert(map);
        scene.frames(3);
        let picture = scene.capture(name);
        let hair: Vec<[f32; 3]> = picture.pixels.iter().copied().filter(|&c| Picture::is_hair(c)).collect();
        let luminance = mean(hair.iter().map(|&c| luminance(c)));
        let red_over_blue = mean(hair.iter().map(|c| c[0])) / mean(hair.iter().map(|c| c[2])).max(1e-6);
        println!("{name}: {} hair pixels, luminance {luminance:.3}, red / blue {red_over_blue:.2}", hair.len());
        assert!(hair.len() > 2000 && luminance > 0.02, "{name}: the hair is lit");
        redness.push(red_over_blue);
    }
    assert!(redness[0] > 2.0 * redness[1], "red / blue {redness:?}: the hair does not follow the map");
}

/// Light from behind the head, no ambient: Marschner's TT lobe (light through the fibres)
/// makes the hair's silhouette glow brighter than Kajiya-Kay's highlights do.
#[test]
fn marschner_transmission_lights_the_silhouette_against_the_light() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let (mut scene, head) = settled_scene();
    // The silhouette: hair pixels within two pixels of the background, found under the
    // scene's own light.
    let mask = scene.capture("backlit-mask");
    let near_background = |i: u32| {
        let (x, y) = (i % SIZE, i / SIZE);
        (x.saturating_sub(2)..=(x + 2).min(SIZE - 1))
            .any(|x| (y.saturating_sub(2)..=(y + 2).min(SIZE - 1)).any(|y| Picture::is_background(mask.at((x, y)))))
    };
    let silhouette: Vec<u32> =
        (0..SIZE * SIZE).filter(|&i| Picture::is_hair(mask.pixels[i as usize]) && near_background(i)).collect();
    scene.light_from(Vec3::new(0.0, 0.35, -1.0));
    scene.app.world_mut().insert_resource(GlobalAmbientLight { brightness: 0.0, ..default() });
    let mut glow = Vec::new();
    for (name, shading) in
        [("backlit-kajiya-kay", HairShading::KajiyaKay), ("backlit-marschner", HairShading::MARSCHNER)]
    {
        scene.app.world_mut().get_mut::<HairLook>(head).unwrap().shading = shading;
        scene.frames(3);
        let picture = scene.capture(name);
        glow.push(mean(silhouette.iter().map(|&i| luminance(picture.pixels[i as usize]))));
    }
    println!("back-lit silhouette ({} pixels): Kajiya-Kay {:.4}, Marschner {:.4}", silhouette.len(), glow[0], glow[1]);
    assert!(silhouette.len() > 300, "the silhouette is in the picture");
    assert!(glow[1] > 1.2 * glow[0], "Marschner {} is not brighter than Kajiya-Kay {}", glow[1], glow[0]);
}

/// Self-shadowing through the volume: under a light from above (Bevy's shadow maps off
/// for the hair, so only its opacity maps shade it; one layer of fibres stopping 70 % of the
/// light, as this thin cap of hair needs to show it), the hair low on the head, under the
/// crown's, keeps at most 60 % of the light it gets without self-shadowing, relative to
/// what the top layer keeps; and turning the light by 0.1° changes the luminance of at
/// most 1 % of the hair's pixels by more than 10 % (no acne).
#[test]
fn hair_under_other_hair_is_in_its_shade() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let (mut scene, head) = settled_scene();
    let mask = scene.capture("self-shadow-mask");
    let hair: Vec<u32> = (0..SIZE * SIZE).filter(|&i| Picture::is_hair(mask.pixels[i as usize])).collect();
    let rows = hair.iter().map(|&i| i / SIZE);
    let (top_row, bottom_row) = (rows.clone().min().unwrap_or(0), rows.max().unwrap_or(0));
    let height = (bottom_row - top_row).max(1) as f32;
    let depth = |i: u32| (i / SIZE - top_row) as f32 / height;

    scene.app.world_mut().insert_resource(GlobalAmbientLight { brightness: 0.0, ..default() });
    scene.app.world_mut().get_mut::<HairLook>(head).unwrap().receive_shadows = false;
    let render = |scene: &mut Scene, name: &str, self_shadow: f32, to_light: Vec3| -> Vec<f32> {
        scene.app.world_mut().get_mut::<HairLook>(head).unwrap().self_shadow = self_shadow;
        scene.light_from(to_light);
        scene.frames(3);
        let picture = scene.capture(name);
        hair.iter().map(|&i| linear_luminance(picture.pixels[i as usize])).collect()
    };
    let above = Vec3::new(0.0, 1.0, 0.25);
    let opacity = 0.7;
    let off = render(&mut scene, "self-shadow-off", 0.0, above);
    let on = render(&mut scene, "self-shadow-on", opacity, above);
    let turned_light = Quat::from_rotation_x(0.1f32.to_radians()) * above;
    let turned = render(&mut scene, "self-shadow-turned", opacity, turned_light);

    // What self-shadowing keeps of each region's light.
    let kept = |region: &dyn Fn(f32) -> bool| {
        let pixels: Vec<usize> = (0..hair.len()).filter(|&k| region(depth(hair[k])) && off[k] > 1e-3).collect();
        let sum = |values: &[f32]| pixels.iter().map(|&k| values[k]).sum::<f32>();
        (sum(&on) / sum(&off).max(1e-9), pixels.len())
    };
    let ((top, top_pixels), (low, low_pixels)) = (kept(&|d| d < 0.25), kept(&|d| d > 0.5));
    // Pixels bright enough that 8-bit rounding is under 3 %, that change by over 10 %.
    let bright: Vec<usize> = (0..hair.len()).filter(|&k| on[k] > 0.02).collect();
    let changed = bright.iter().filter(|&&k| (turned[k] - on[k]).abs() > 0.1 * on[k]).count();
    println!(
        "self-shadowing from above keeps {top:.3} of the top quarter's light ({top_pixels} pixels) and {low:.3} of \
         the lower half's ({low_pixels}); turning the light 0.1° changes {changed} of {} bright hair pixels by > 10 %",
        bright.len()
    );
    assert!(top_pixels > 300 && low_pixels > 300, "both regions are in the picture");
    assert!(low <= 0.6 * top, "the lower hair keeps {low}, not under 60 % of the top's {top}");
    assert!(bright.len() > 500, "the lit hair is in the picture");
    assert!(changed * 100 <= bright.len(), "{changed} of {} pixels flicker", bright.len());
}

/// Anti-aliased strands: with the head at 2 m and at 4 m (strands a tenth and a twentieth of
/// a pixel wide), moving the camera by a quarter pixel changes the hair's pixels (mean
/// absolute change of linear luminance over the pixels inside the hair in both frames: the
/// edge really moves) by at most a third of what plain ribbons give when blended, and 80 %
/// with alpha-to-coverage, where which strand is in front at each MSAA sample (about 100
/// strands cross each pixel here) still changes. `Auto` blends here, and not up close.
#[test]
fn distant_hair_does_not_shimmer() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let (mut scene, head) = settled_scene();
    // The default density (16 children per guide), which is what shimmers; one
    // subdivision per segment, as the head is a few pixels tall.
    scene.app.world_mut().get_mut::<HairGroom>(head).unwrap().children.per_guide = 16;
    scene.app.world_mut().get_mut::<HairLook>(head).unwrap().subdivisions = 1;
    // The hair holds still: only the camera moves between the frames compared.
    scene.app.world_mut().resource_mut::<Time<Hair>>().pause();
    let target = Vec3::new(0.0, -0.02, 0.0);
    let place_camera = |scene: &mut Scene, distance: f32, offset: f32| {
        let eye = Vec3::new(offset, target.y, distance);
        *scene.app.world_mut().get_mut::<Transform>(scene.camera).unwrap() =
            Transform::from_translation(eye).looking_at(target + Vec3::X * offset, Vec3::Y);
        scene.frames(3);
    };
    let blended = |scene: &mut Scene| {
        let drawn_by = scene.app.world().get::<HairDrawnBy>(head).unwrap().0;
        scene.app.world().get::<HairDrawing>(drawn_by).unwrap().blended()
    };
    // World metres per pixel at distance `d` (Bevy's default vertical field of view, π/4).
    let pixel = |d: f32| 2.0 * d * (std::f32::consts::FRAC_PI_8).tan() / SIZE as f32;
    let modes = [HairAntialias::Off, HairAntialias::Coverage, HairAntialias::Blended];
    for distance in [2.0f32, 4.0] {
        let mut change = [0.0f32; 3];
        let mut still = Vec::new();
        for (k, mode) in modes.into_iter().enumerate() {
            scene.app.world_mut().get_mut::<HairLook>(head).unwrap().antialias = mode;
            let name = |moved: bool| format!("shimmer-{distance}m-{mode:?}-{moved}").to_lowercase();
            place_camera(&mut scene, distance, 0.0);
            let before = scene.capture(&name(false));
            place_camera(&mut scene, distance, 0.25 * pixel(distance));
            let after = scene.capture(&name(true));
            // Inside the hair in both frames (a pixel from its edge, which really moves).
            let hair = inside_hair(&[&before, &after]);
            assert!(hair.len() > 20, "the hair is in the picture at {distance} m");
            let luminance = |picture: &Picture, i: usize| linear_luminance(picture.pixels[i]);
            let mean = |f: &dyn Fn(usize) -> f32| hair.iter().map(|&i| f(i)).sum::<f32>() / hair.len() as f32;
            change[k] = mean(&|i| (luminance(&after, i) - luminance(&before, i)).abs());
            // What the move changes in a picture free of shimmer: `before` itself moved a
            // quarter pixel (the scene slides left as the camera goes right).
            let slid = mean(&|i| {
                let right = if (i as u32 % SIZE) + 1 < SIZE { i + 1 } else { i };
                (0.25 * (luminance(&before, right) - luminance(&before, i))).abs()
            });
            println!(
                "{distance} m, {mode:?}: {} hair pixels, mean luminance change {:.5} for a quarter-pixel move \
                 ({slid:.5} if the picture only slid)",
                hair.len(),
                change[k],
            );
            still.push(before);
        }
        let [plain, coverage, blend] = change;
        assert!(coverage <= 0.8 * plain, "{distance} m: alpha-to-coverage {coverage} against plain {plain}");
        assert!(blend <= plain / 3.0, "{distance} m: blended {blend} against plain {plain}");
        // Blending keeps the hair about as bright (plain ribbons, sampled 4 times a pixel,
        // are the unbiased reference): no jump where `Auto` switches. Over the pixels inside
        // the hair in every mode, as blended edges are softer.
        let common = inside_hair(&still.iter().collect::<Vec<_>>());
        let brightness: Vec<f32> = still
            .iter()
            .map(|picture| {
                common.iter().map(|&i| linear_luminance(picture.pixels[i])).sum::<f32>() / common.len() as f32
            })
            .collect();
        println!(
            "{distance} m: mean luminance of {} hair pixels plain, coverage, blended: {brightness:.4?}",
            common.len()
        );
        assert!(
            (brightness[2] - brightness[0]).abs() <= 0.12 * brightness[0],
            "{distance} m: blended hair's mean luminance {} against {} for plain ribbons",
            brightness[2],
            brightness[0]
        );
        scene.app.world_mut().get_mut::<HairLook>(head).unwrap().antialias = HairAntialias::Auto;
        place_camera(&mut scene, distance, 0.0);
        assert!(blended(&mut scene), "Auto blends strands a tenth of a pixel wide ({distance} m)");
    }
    // Close enough that the widest strands are over a pixel and a quarter wide.
    place_camera(&mut scene, 0.3, 0.0);
    assert!(!blended(&mut scene), "Auto does not blend strands wider than a pixel (0.3 m)");
}

/// Bevy's distance fog covers the hair as it covers the head (`StandardMaterial`): in a
/// linear fog that is total from 30 cm, hair and skin pixels both take the fog's colour
/// (within 1/255); in one from 30 cm to 1 m, the hair (50–70 cm away) moves part of the way
/// toward it.
#[test]
fn fog_covers_the_hair_as_it_covers_the_head() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let (mut scene, _) = settled_scene();
    let clear = scene.capture("fog-none");
    let (hair, skin) =
        (inside_hair(&[&clear]), inside_where(&[&clear], |c| !Picture::is_hair(c) && !Picture::is_background(c)));
    assert!(hair.len() > 500 && skin.len() > 500, "{} hair and {} skin pixels", hair.len(), skin.len());
    let mean_colour = |picture: &Picture, pixels: &[usize]| {
        let sum = pixels.iter().fold(Vec3::ZERO, |sum, &i| sum + Vec3::from_array(picture.pixels[i]));
        sum / pixels.len() as f32
    };
    let fog = Color::srgb(0.3, 0.35, 0.9);
    let fog_srgb = Vec3::from_array(fog.to_srgba().to_f32_array_no_alpha());
    let fogged = |scene: &mut Scene, name: &str, start: f32, end: f32| {
        let falloff = FogFalloff::Linear { start, end };
        scene.app.world_mut().entity_mut(scene.camera).insert(DistanceFog { color: fog, falloff, ..default() });
        scene.frames(3);
        scene.capture(name)
    };
    // Behind the strands' blended coverage the background shows through, and Bevy does not
    // fog the clear colour: in total fog everything the hair can blend with is the fog's
    // colour, the background too.
    scene.app.insert_resource(ClearColor(fog));
    let total = fogged(&mut scene, "fog-total", 0.05, 0.3);
    scene.app.insert_resource(ClearColor(BACKGROUND));
    let (hair_colour, skin_colour) = (mean_colour(&total, &hair), mean_colour(&total, &skin));
    println!("total fog {fog_srgb}: hair {hair_colour}, skin {skin_colour}");
    assert!((hair_colour - fog_srgb).abs().max_element() <= 1.0 / 255.0, "hair {hair_colour} under fog {fog_srgb}");
    assert!((skin_colour - fog_srgb).abs().max_element() <= 1.0 / 255.0, "skin {skin_colour} under fog {fog_srgb}");

    let partial = fogged(&mut scene, "fog-partial", 0.3, 1.0);
    let (before, after) = (mean_colour(&clear, &hair), mean_colour(&partial, &hair));
    let moved = 1.0 - after.distance(fog_srgb) / before.distance(fog_srgb);
    println!("partial fog: hair {before} → {after}, {moved:.2} of the way to the fog");
    assert!((0.1..0.6).contains(&moved), "the hair moved {moved} of the way to the fog's colour");
}

/// The pixels inside the hair (a pixel from its edge) in every one of `pictures`.
fn inside_hair(pictures: &[&Picture]) -> Vec<usize> {
    inside_where(pictures, Picture::is_hair)
}

/// The pixels whose 3 × 3 neighbourhood is all `what` in every one of `pictures`.
fn inside_where(pictures: &[&Picture], what: fn([f32; 3]) -> bool) -> Vec<usize> {
    let hair = |j: usize| pictures.iter().all(|picture| what(picture.pixels[j]));
    let inside = |i: usize| {
        let (x, y) = ((i as u32 % SIZE) as i32, (i as u32 / SIZE) as i32);
        (-1..=1).all(|dy| {
            (-1..=1).all(|dx| {
                let (x, y) = ((x + dx).clamp(0, SIZE as i32 - 1), (y + dy).clamp(0, SIZE as i32 - 1));
                hair((y as u32 * SIZE + x as u32) as usize)
            })
        })
    };
    (0..(SIZE * SIZE) as usize).filter(|&i| inside(i)).collect()
}

/// The uniform for strands drawn with the material directly: one colour root to tip,
/// ribbons `width` wide, plain Kajiya-Kay shading (no tint variation, no shadows received),
/// no children placement.
fn plain_uniform(layout: &StrandLayout, color: Vec4, width: f32) -> HairUniform {
    HairUniform {
        root_color: color,
        tip_color: color,
        primary_exponent: 80.0,
        secondary_exponent: 20.0,
        root_width: width,
        tip_width: width,
        diffuse: 1.0,
        ..default()
    }
    .with_layout(layout)
}

/// Two straight strands drawn with the hair material directly: one along the light, one
/// across it. Kajiya-Kay diffuse is sin(T, L): the first is dark, the second bright.
#[test]
fn a_strand_along_the_light_is_darker_than_one_across_it() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let mut scene = Scene::new();
    scene.look_from(Vec3::new(0.0, 0.0, 0.55));
    // Light from +x (and a little from the camera so both ribbons face it equally).
    scene.light_from(Vec3::new(1.0, 0.0, 0.15));
    let particles = 11u32;
    let mut guides = Vec::new();
    // Guide 0: vertical, left half. Guide 1: horizontal, right half.
    for i in 0..particles {
        guides.push(Vec4::new(-0.08, 0.1 - 0.02 * i as f32, 0.0, 1.0));
    }
    for i in 0..particles {
        guides.push(Vec4::new(0.01 + 0.016 * i as f32, 0.0, 0.0, 1.0));
    }
    // Each particle's frame vector: +z is perpendicular to both strands.
    guides.extend([Vec4::new(0.0, 0.0, 1.0, 0.0); 22]);
    let layout = StrandLayout { guides: 2, particles, strands_per_guide: 1, subdivisions: 2 };
    let uniform = plain_uniform(&layout, Vec4::new(0.6, 0.6, 0.6, 1.0), 0.01);
    scene.draw_strands(guides, &layout, uniform);
    let picture = scene.capture("kajiya-kay");

    let mean_brightness = |xs: std::ops::Range<u32>| {
        let lit: Vec<f32> = xs
            .flat_map(|x| (0..SIZE).map(move |y| (x, y)))
            .map(|p| picture.at(p))
            .filter(|&c| !Picture::is_background(c))
            .map(luminance)
            .collect();
        assert!(lit.len() > 50, "strand not drawn ({} pixels)", lit.len());
        lit.iter().sum::<f32>() / lit.len() as f32
    };
    let across = mean_brightness(0..SIZE / 2);
    let along = mean_brightness(SIZE / 2 + 8..SIZE);
    println!("mean luminance: strand across the light {across:.3}, along the light {along:.3}");
    assert!(across > 2.0 * along, "across {across} is not clearly brighter than along {along}");
}

/// One guide with four children drawn by the shader, checked against the CPU reference
/// (`hair_sim::groom::{tessellate, child_curve}`) that `hair.wgsl` mirrors: every reference
/// point must land on a drawn strand, and the reference points mirrored through the guide
/// (where a flipped frame or sign would put the children) that lie away from every strand
/// must stay background.
#[test]
fn the_shader_draws_guide_and_children_where_the_cpu_reference_puts_them() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let mut scene = Scene::new();
    scene.look_from(Vec3::new(0.0, 0.0, 0.55));
    scene.light_from(Vec3::new(0.2, 0.3, 1.0));
    let particles = 11u32;
    let subdivisions = 4;
    // A bent strand in the view plane, root at the top.
    let guide: Vec<SimVec3> = (0..particles)
        .map(|j| {
            let j = j as f32;
            SimVec3::new(-0.04 + 0.006 * j + 0.012 * (j * 0.6).sin(), 0.09 - 0.018 * j, 0.0)
        })
        .collect();
    let root_u = SimVec3::X;
    // A scalp tilted against the first segment, curved with an 8 cm radius, the head behind
    // it: the spiral starts on the scalp, turns into the guide's frame and is flattened
    // where it would point into the head, all of which the shader must mirror.
    let first = (guide[1] - guide[0]).normalize();
    let normal = (first + SimVec3::new(0.6, 0.0, 0.6)).normalize();
    let root = ChildRoot { u: root_u, normal, curvature: 12.5, head_centre: guide[0] - normal * 0.08 };
    let children =
        ChildParams { per_guide: 4, spiral: Spiral { scale: 3e-3, ..default() }, clumping: 0.3, tip_spread: 0.01 };
    let width = 0.003;

    let mut data: Vec<Vec4> = guide.iter().map(|p| Vec4::new(p.x, p.y, p.z, 1.0)).collect();
    data.extend(transport_frames(&guide, root_u).iter().map(|u| Vec4::new(u.x, u.y, u.z, 0.0)));
    data.push(Vec4::new(normal.x, normal.y, normal.z, root.curvature));
    let centre = root.head_centre;
    data.push(Vec4::new(centre.x, centre.y, centre.z, 1.0));
    let layout = StrandLayout { guides: 1, particles, strands_per_guide: children.per_guide + 1, subdivisions };
    let spiral = children.spiral;
    let uniform = HairUniform {
        spiral_a: spiral.a,
        spiral_b: spiral.b,
        spiral_angle_step: spiral.angle_step,
        spiral_scale: spiral.scale,
        clumping: children.clumping,
        tip_spread: children.tip_spread,
        ..plain_uniform(&layout, Vec4::new(0.8, 0.8, 0.8, 1.0), width)
    };
    scene.draw_strands(data, &layout, uniform);
    let picture = scene.capture("reference-children");

    let to_bevy = |p: SimVec3| Vec3::new(p.x, p.y, p.z);
    let guide_curve: Vec<Vec3> = tessellate(&guide, subdivisions).iter().map(|c| to_bevy(c.position)).collect();
    let mut reference = guide_curve.clone();
    let mut mirrored = Vec::new();
    for child in 0..children.per_guide {
        let curve = child_curve(&guide, &root, &children, 0, child, subdivisions);
        for (point, on_guide) in curve.iter().zip(&guide_curve) {
            let point = to_bevy(point.position);
            reference.push(point);
            mirrored.push(2.0 * *on_guide - point);
        }
    }
    let pixels = |points: &[Vec3]| -> Vec<(u32, u32)> {
        let pixels: Vec<(u32, u32)> = points.iter().filter_map(|&p| scene.project(p)).collect();
        assert_eq!(pixels.len(), points.len(), "a reference point is outside the picture");
        pixels
    };
    let reference = pixels(&reference);
    // Mirrored points more than 4 px from every reference point: no strand belongs there.
    let empty: Vec<(u32, u32)> = pixels(&mirrored)
        .into_iter()
        .filter(|&(x, y)| reference.iter().all(|&(rx, ry)| x.abs_diff(rx).max(y.abs_diff(ry)) > 4))
        .collect();
    assert!(empty.len() > 30, "only {} mirrored points are away from every strand", empty.len());
    let drawn = |pixels: &[(u32, u32)]| {
        let hit = pixels
            .iter()
            .filter(|&&(x, y)| {
                let near = (x.saturating_sub(1)..=(x + 1).min(SIZE - 1))
                    .flat_map(|x| (y.saturating_sub(1)..=(y + 1).min(SIZE - 1)).map(move |y| (x, y)));
                near.into_iter().any(|p| !Picture::is_background(picture.at(p)))
            })
            .count();
        hit as f32 / pixels.len() as f32
    };
    let (on_reference, on_mirror) = (drawn(&reference), drawn(&empty));
    println!(
        "{:.1}% of {} reference points drawn; {:.1}% of {} mirrored points",
        on_reference * 100.0,
        reference.len(),
        on_mirror * 100.0,
        empty.len()
    );
    assert!(on_reference > 0.97, "only {:.1}% of the CPU reference points are drawn", on_reference * 100.0);
    assert!(on_mirror < 0.05, "{:.1}% of the points away from the reference are drawn", on_mirror * 100.0);
}

/// Hair draws itself into the shadow maps: strands in front of a wall, lit from the front,
/// darken the wall where their shadows fall, and only when they cast shadows.
#[test]
fn strands_cast_shadows() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let mut scene = Scene::new();
    scene.look_from(Vec3::new(0.0, 0.0, 0.55));
    // From the front, above and to the right: shadows fall below and left of the strands.
    scene.light_from(Vec3::new(0.35, 0.35, 1.0));
    // One cascade over the small scene, so shadow texels are finer than a strand is wide.
    let cascades = CascadeShadowConfigBuilder {
        num_cascades: 1,
        minimum_distance: 0.05,
        maximum_distance: 1.5,
        first_cascade_far_bound: 1.5,
        overlap_proportion: 0.2,
    };
    scene.app.world_mut().entity_mut(scene.light).insert(cascades.build());
    scene.app.insert_resource(DirectionalLightShadowMap { size: 4096 });
    let world = scene.app.world_mut();
    let wall = world.resource_mut::<Assets<Mesh>>().add(Plane3d::new(Vec3::Z, Vec2::splat(0.3)).mesh());
    let red = world.resource_mut::<Assets<StandardMaterial>>().add(Color::srgb(0.8, 0.25, 0.2));
    world.spawn((Mesh3d(wall), MeshMaterial3d(red), Transform::from_xyz(0.0, 0.0, -0.03)));

    // Twelve vertical strands, 1.5 cm apart, 4 mm wide.
    let (guides, particles) = (12u32, 11u32);
    let mut data = Vec::new();
    for g in 0..guides {
        data.extend((0..particles).map(|j| Vec4::new(-0.09 + 0.015 * g as f32, 0.1 - 0.02 * j as f32, 0.0, 1.0)));
    }
    data.extend(std::iter::repeat_n(Vec4::new(0.0, 0.0, 1.0, 0.0), (guides * particles) as usize));
    let layout = StrandLayout { guides, particles, strands_per_guide: 1, subdivisions: 2 };
    // Receiving shadows too, as the plugin's default look does.
    let uniform = HairUniform {
        flags: HairUniform::RECEIVE_SHADOWS,
        ..plain_uniform(&layout, Vec4::new(0.05, 0.6, 0.05, 1.0), 0.004)
    };
    let strands = scene.draw_strands(data, &layout, uniform);

    let mut walls = Vec::new();
    for cast in [false, true] {
        let mut entity = scene.app.world_mut().entity_mut(strands);
        if cast {
            entity.remove::<NotShadowCaster>();
        } else {
            entity.insert(NotShadowCaster);
        }
        scene.frames(3);
        walls.push(scene.capture(&format!("strand-shadows-{cast}")));
    }
    // Wall pixels (red-dominant) in both pictures, compared pixel by pixel.
    let is_wall = |c: [f32; 3]| c[0] > 1.2 * c[1] && c[0] > 1.2 * c[2];
    let (mut both, mut darker) = (0, 0);
    for (&off, &on) in walls[0].pixels.iter().zip(&walls[1].pixels) {
        if is_wall(off) && is_wall(on) {
            both += 1;
            darker += usize::from(luminance(on) < 0.7 * luminance(off));
        }
    }
    println!("wall pixels: {both}; {darker} darker by > 30% when the strands cast shadows");
    assert!(both > 5000, "only {both} wall pixels");
    assert!(darker > 300, "the strands' shadows darken only {darker} of {both} wall pixels");
}

fn red_pixels(picture: &Picture) -> usize {
    picture.pixels.iter().filter(|c| c[0] > 1.5 * c[1] && c[0] > 1.5 * c[2] && c[0] > 0.05).count()
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
    app.add_plugins(
        DefaultPlugins
            .build()
            .disable::<WinitPlugin>()
            .disable::<LogPlugin>()
            .set(WindowPlugin { primary_window: None, exit_condition: ExitCondition::DontExit, ..default() })
            .set(RenderPlugin { render_creation: WgpuSettings { backends: None, ..default() }.into(), ..default() }),
    )
    .add_plugins(HairPlugin::default());
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
