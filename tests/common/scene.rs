//! The render tests' harness: an offscreen scene with a camera, a light and a head, the
//! pictures it takes, and the measures the tests read from them.
#![allow(dead_code)] // each render test file uses a different part

use crate::common;
use bevy::camera::RenderTarget;
use bevy::camera::visibility::NoFrustumCulling;
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::image::Image;
use bevy::light::GlobalAmbientLight;
use bevy::prelude::*;
use bevy::render::render_resource::{TextureFormat, TextureUsages};
use bevy::render::storage::ShaderBuffer;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use bevy_hair::hair_sim::groom::ChildParams;
use bevy_hair::prelude::*;
use bevy_hair::procedural_head_mesh;
use bevy_hair::render::{HairMaterial, HairUniform, StrandLayout};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

pub const SIZE: u32 = 256;

pub const BACKGROUND: Color = Color::srgb(0.05, 0.05, 0.4);

/// Set by `.ci/run`: there, a missing adapter is a failure (lavapipe broke), not a skip.
pub const REQUIRE_ADAPTER: &str = "BEVY_HAIR_REQUIRE_ADAPTER";

macro_rules! require_adapter {
    () => {
        if let Some(reason) = $crate::common::no_adapter() {
            if std::env::var_os($crate::scene::REQUIRE_ADAPTER).is_some() {
                panic!("{} is set and there is {reason}", $crate::scene::REQUIRE_ADAPTER);
            }
            eprintln!("SKIPPED {}: {reason}", module_path!());
            return;
        }
    };
}

/// Rendering serialises: each test builds its own renderer, one at a time.
pub static GPU: Mutex<()> = Mutex::new(());

pub struct Scene {
    pub app: App,
    pub target: Handle<Image>,
    pub camera: Entity,
    pub light: Entity,
}

impl Scene {
    pub fn new() -> Scene {
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
    pub fn spawn_head(&mut self, groom: HairGroom) -> Entity {
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

    pub fn wait_until_ready(&mut self, head: Entity) {
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

    pub fn frames(&mut self, n: usize) {
        for _ in 0..n {
            self.app.update();
        }
    }

    pub fn look_from(&mut self, eye: Vec3) {
        let target = Vec3::new(0.0, -0.02, 0.0);
        *self.app.world_mut().get_mut::<Transform>(self.camera).unwrap() =
            Transform::from_translation(eye).looking_at(target, Vec3::Y);
    }

    pub fn light_from(&mut self, direction_to_light: Vec3) {
        *self.app.world_mut().get_mut::<Transform>(self.light).unwrap() =
            Transform::from_translation(direction_to_light).looking_at(Vec3::ZERO, Vec3::Y);
    }

    /// Draws strands with the hair material directly, no groom: `data` is what the plugin
    /// uploads (positions, then frame vectors, then the scalp at each root and the head's
    /// centre where there are children), `uniform` the look and counts.
    pub fn draw_strands(&mut self, data: Vec<Vec4>, layout: &StrandLayout, uniform: HairUniform) -> Entity {
        let (particles, rest) = data.split_at((2 * layout.guides * layout.particles) as usize);
        // Up to the head's centre (zeros where the strands have no children), then the
        // pieces in the order they were grown.
        let mut guides = rest.to_vec();
        guides.resize((layout.guides + 1) as usize, Vec4::ZERO);
        guides.extend(StrandLayout::pack_order(&layout.grown_order()));
        let world = self.app.world_mut();
        let mut buffers = world.resource_mut::<Assets<ShaderBuffer>>();
        let particles = buffers.add(ShaderBuffer::new(bytemuck::cast_slice(particles), default()));
        let guides = buffers.add(ShaderBuffer::from(guides));
        let material = world.resource_mut::<Assets<HairMaterial>>().add(HairMaterial { guides, uniform, particles });
        let mesh = world.resource_mut::<Assets<Mesh>>().add(layout.mesh());
        let entity = world.spawn((Mesh3d(mesh), MeshMaterial3d(material), NoFrustumCulling)).id();
        self.frames(5);
        entity
    }

    /// Renders a frame, saves it as `name.png`, and returns it.
    pub fn capture(&mut self, name: &str) -> Picture {
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
    pub fn project(&self, point: Vec3) -> Option<(u32, u32)> {
        let world = self.app.world();
        let camera = world.get::<Camera>(self.camera)?;
        let transform = world.get::<GlobalTransform>(self.camera)?;
        let p = camera.world_to_viewport(transform, point).ok()?;
        (p.x >= 0.0 && p.y >= 0.0 && p.x < SIZE as f32 && p.y < SIZE as f32).then_some((p.x as u32, p.y as u32))
    }
}

/// A captured frame as linear-ish sRGB bytes, with the classification the tests use.
pub struct Picture {
    pub pixels: Vec<[f32; 3]>,
}

impl Picture {
    pub fn from_image(image: &Image) -> Picture {
        let mut pixels = Vec::with_capacity((SIZE * SIZE) as usize);
        for y in 0..SIZE {
            for x in 0..SIZE {
                let c = image.get_color_at(x, y).expect("readable screenshot").to_srgba();
                pixels.push([c.red, c.green, c.blue]);
            }
        }
        Picture { pixels }
    }

    pub fn save(&self, image: &Image, name: &str) {
        let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("hair-renders");
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(format!("{name}.png"));
        image.clone().try_into_dynamic().expect("convertible screenshot").to_rgb8().save(&path).unwrap();
        println!("wrote {}", path.display());
    }

    pub fn at(&self, (x, y): (u32, u32)) -> [f32; 3] {
        self.pixels[(y * SIZE + x) as usize]
    }

    /// Hair is green-dominant (the test look), skin red-dominant, background blue.
    pub fn is_hair(c: [f32; 3]) -> bool {
        c[1] > 1.2 * c[0] && c[1] > 1.2 * c[2] && c[1] > 0.02
    }

    pub fn is_background(c: [f32; 3]) -> bool {
        let bg = BACKGROUND.to_srgba();
        (c[0] - bg.red).abs() < 0.02 && (c[1] - bg.green).abs() < 0.02 && (c[2] - bg.blue).abs() < 0.02
    }

    /// Hair within one pixel of `p`.
    pub fn hair_near(&self, (x, y): (u32, u32)) -> bool {
        let xs = x.saturating_sub(1)..=(x + 1).min(SIZE - 1);
        xs.flat_map(|x| (y.saturating_sub(1)..=(y + 1).min(SIZE - 1)).map(move |y| (x, y)))
            .any(|p| Self::is_hair(self.at(p)))
    }

    pub fn hair_pixels(&self) -> usize {
        self.pixels.iter().filter(|&&c| Self::is_hair(c)).count()
    }

    /// Mean position of the brightest 3% of hair pixels.
    pub fn highlight_centroid(&self) -> Vec2 {
        let mut hair: Vec<(f32, u32)> = (0..SIZE * SIZE)
            .filter(|&i| Self::is_hair(self.pixels[i as usize]))
            .map(|i| (luminance(self.pixels[i as usize]), i))
            .collect();
        hair.sort_by(|a, b| b.0.total_cmp(&a.0));
        let top = &hair[..(hair.len() * 3 / 100).max(1)];
        top.iter().map(|&(_, i)| Vec2::new((i % SIZE) as f32, (i / SIZE) as f32)).sum::<Vec2>() / top.len() as f32
    }
}

pub fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// 600 guides with 4 children each, drawn with 2 subdivisions per segment (see
/// [`Scene::spawn_head`]): lavapipe's time per frame follows the vertex count, and the
/// default 16 children at 4 subdivisions make frames 5× slower without changing what
/// these tests measure.
pub fn short_groom() -> HairGroom {
    let children = ChildParams { per_guide: 4, ..default() };
    HairGroom { guides: 600, length: 0.07, settle_steps: 120, children, ..default() }
}

/// Scalp roots facing the camera (head-space normal toward `view_dir`) and their pixels.
pub fn visible_roots(scene: &Scene, head: Entity, toward_camera: Vec3) -> Vec<(u32, u32)> {
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

/// Where the hair is, then how bright each of its pixels is (linear luminance) with `light`
/// as the only light
/// (no directional light, no ambient): the hair is found under the scene's own light (dark
/// hair would not read as hair), and the head stands still between the two frames.
pub fn lit_only_by(scene: &mut Scene, name: &str, light: impl Bundle) -> Vec<(u32, f32)> {
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
pub fn linear_luminance([r, g, b]: [f32; 3]) -> f32 {
    let linear = Color::srgb(r, g, b).to_linear();
    luminance([linear.red, linear.green, linear.blue])
}

/// The groom on the procedural head (it grows settled), seen from the front, and the head.
pub fn settled_scene() -> (Scene, Entity) {
    let mut scene = Scene::new();
    let head = scene.spawn_head(short_groom());
    scene.wait_until_ready(head);
    (scene, head)
}

pub fn mean(values: impl Iterator<Item = f32>) -> f32 {
    let (sum, count) = values.fold((0.0, 0), |(s, n), v| (s + v, n + 1));
    sum / count.max(1) as f32
}

/// The pixels inside the hair (a pixel from its edge) in every one of `pictures`.
pub fn inside_hair(pictures: &[&Picture]) -> Vec<usize> {
    inside_where(pictures, Picture::is_hair)
}

/// The pixels whose 3 × 3 neighbourhood is all `what` in every one of `pictures`.
pub fn inside_where(pictures: &[&Picture], what: fn([f32; 3]) -> bool) -> Vec<usize> {
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
pub fn plain_uniform(layout: &StrandLayout, color: Vec4, width: f32) -> HairUniform {
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

pub fn red_pixels(picture: &Picture) -> usize {
    picture.pixels.iter().filter(|c| c[0] > 1.5 * c[1] && c[0] > 1.5 * c[2] && c[0] > 0.05).count()
}

pub(crate) use require_adapter;
