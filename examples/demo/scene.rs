//! The stage: the head with its groom, a key light with shadows, fill and rim lights, a
//! studio backdrop, and an orbit camera (drag to orbit, wheel to zoom).

use crate::motion::Motion;
use crate::presets;
use bevy::camera::RenderTarget;
use bevy::input::mouse::{AccumulatedMouseMotion, AccumulatedMouseScroll, MouseScrollUnit};
use bevy::light::{CascadeShadowConfigBuilder, DirectionalLightShadowMap, NotShadowCaster};
use bevy::mesh::skinning::SkinnedMesh;
use bevy::prelude::*;
use bevy::render::render_resource::{TextureFormat, TextureUsages};
use bevy::world_serialization::{WorldAssetRoot, WorldInstanceReady};
use bevy_egui::input::EguiWantsInput;
use bevy_hair::prelude::*;

/// The character: the root of the glTF scene (`assets/head.glb`: a `neck` → `head`
/// skeleton and the skinned head mesh). Dragging moves it.
#[derive(Component)]
pub struct Character;

/// The skinned head mesh inside the character: it wears the groom.
#[derive(Component)]
pub struct Head;

/// Where the orbit camera looks: the middle of the head with its hair (the head's origin is
/// the centre of the neck cut; the head is about 0.26 m tall and faces +Z).
const FOCUS: Vec3 = Vec3::new(0.0, 0.12, 0.02);

/// An orbit around `FOCUS`, angles in radians.
#[derive(Component, Clone, Copy, Debug)]
pub struct OrbitCamera {
    pub yaw: f32,
    pub pitch: f32,
    pub distance: f32,
}

impl OrbitCamera {
    fn transform(&self) -> Transform {
        let rotation = Quat::from_euler(EulerRot::YXZ, self.yaw, -self.pitch, 0.0);
        Transform::from_translation(FOCUS + rotation * Vec3::Z * self.distance).looking_at(FOCUS, Vec3::Y)
    }
}

/// The lights on the stage (`--lights`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Lights {
    /// A warm key light with shadows, a cool fill and a rim light from behind.
    #[default]
    Studio,
    /// A point light on the left and a spot light from the right, both casting shadows.
    Lamps,
    /// One light straight from above (self-shadowing shows best).
    Above,
    /// One light from behind the head (Marschner's transmission shows best).
    Behind,
}

impl Lights {
    /// The lights called `name` on the command line.
    pub fn named(name: &str) -> Option<Lights> {
        [("studio", Lights::Studio), ("lamps", Lights::Lamps), ("above", Lights::Above), ("behind", Lights::Behind)]
            .into_iter()
            .find_map(|(n, lights)| name.eq_ignore_ascii_case(n).then_some(lights))
    }
}

/// The ways to draw thin strands, by their names on the command line and in the panel.
pub const ANTIALIAS_MODES: [(HairAntialias, &str); 4] = [
    (HairAntialias::Auto, "auto"),
    (HairAntialias::Coverage, "coverage"),
    (HairAntialias::Blended, "blended"),
    (HairAntialias::Off, "off"),
];

/// The solver backends, as `--solver` and the panel name them.
pub const BACKENDS: [(HairBackend, &str); 2] = [(HairBackend::Cpu, "cpu"), (HairBackend::Gpu, "gpu")];

/// How the stage is set up from the command line: the lights, and changes to the preset's
/// look (`None`: the preset's own).
#[derive(Resource, Clone, Debug, Default)]
pub struct Stage {
    /// `--lights`.
    pub lights: Lights,
    /// `--shading`.
    pub shading: Option<HairShading>,
    /// `--self-shadow`.
    pub self_shadow: Option<f32>,
    /// `--antialias`.
    pub antialias: Option<HairAntialias>,
    /// `--solver`.
    pub backend: HairBackend,
    /// `--volume`: hair volume on or off instead of the preset's.
    pub volume: Option<bool>,
    /// `--camera`: where the orbit camera starts.
    pub camera: Option<OrbitCamera>,
    /// `--offscreen`: the camera draws into an image of this size ([`OffscreenTarget`])
    /// instead of the window.
    pub offscreen: Option<UVec2>,
    /// `--head`: a `.glb` file under the asset folder whose first primitive is the head
    /// (its scalp painted in its vertex colours), instead of the shipped character.
    pub head: Option<String>,
    /// `--groom`: a `.hair` file under the asset folder for the guides
    /// (`HairGroom::guides_from`), instead of growing them.
    pub groom: Option<String>,
}

/// The image the camera draws into with `--offscreen`.
#[derive(Resource, Clone, Debug)]
pub struct OffscreenTarget(pub Handle<Image>);

/// The preset the demo starts with, by name ([`presets::all`]).
#[derive(Resource, Clone, Copy, Debug)]
pub struct StartingPreset(pub &'static str);

impl Default for StartingPreset {
    fn default() -> Self {
        StartingPreset(presets::shoulder().name)
    }
}

pub fn plugin(app: &mut App) {
    app.init_resource::<StartingPreset>()
        .init_resource::<Stage>()
        .insert_resource(ClearColor(Color::srgb(0.36, 0.38, 0.42)))
        .insert_resource(GlobalAmbientLight { color: Color::srgb(0.85, 0.9, 1.0), brightness: 250.0, ..default() })
        // The scene is small: a fine shadow map keeps the head's shadow on the hair crisp.
        .insert_resource(DirectionalLightShadowMap { size: 4096 })
        .add_systems(Startup, setup)
        .add_systems(PostStartup, draw_offscreen)
        .add_systems(Update, orbit_camera);
}

pub fn setup(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    mut settings: ResMut<HairSettings>,
    start: Res<StartingPreset>,
    stage: Res<Stage>,
) {
    settings.0 = presets::named(start.0).params;
    if let Some(on) = stage.volume {
        settings.0.volume.enabled = on;
    }
    match &stage.head {
        // A user's head, loaded as README's code loads it, under a character root the
        // mouse turns (it has no clip to play), its origin where the camera looks.
        Some(path) => {
            let head = asset_server.load(GltfAssetLabel::Primitive { mesh: 0, primitive: 0 }.from_asset(path.clone()));
            let dressed = dressing(&asset_server, &mut materials, &start, &stage);
            let at = Transform::from_translation(FOCUS);
            commands
                .spawn((Character, Name::new("character"), at, Visibility::default()))
                .with_child((Mesh3d(head), dressed));
        }
        // The glTF scene, as a game would spawn a character. When it is in the world, its
        // skinned mesh gets the groom (`dress_the_head`); `motion.rs` plays its clip.
        None => {
            let scene = asset_server.load(GltfAssetLabel::Scene(0).from_asset(HEAD_GLB));
            commands.spawn((Character, Name::new("character"), WorldAssetRoot(scene))).observe(dress_the_head);
        }
    }

    spawn_lights(&mut commands, stage.lights);

    // A studio backdrop: a floor below the longest hair and a wall behind, one matte grey-blue.
    let backdrop = materials.add(StandardMaterial {
        base_color: Color::srgb(0.42, 0.45, 0.5),
        perceptual_roughness: 0.95,
        reflectance: 0.1,
        ..default()
    });
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(6.0, 6.0))),
        MeshMaterial3d(backdrop.clone()),
        Transform::from_xyz(0.0, -0.55, 0.0),
        NotShadowCaster,
    ));
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::new(Vec3::Z, Vec2::splat(3.0)).mesh())),
        MeshMaterial3d(backdrop),
        Transform::from_xyz(0.0, 0.0, -1.2),
        NotShadowCaster,
    ));

    let orbit = stage.camera.unwrap_or(OrbitCamera { yaw: 0.45, pitch: 0.12, distance: 0.62 });
    commands.spawn((Camera3d::default(), orbit.transform(), orbit));
}

/// With `--offscreen`, points the camera at an image of that size instead of the window.
fn draw_offscreen(
    mut commands: Commands,
    mut images: ResMut<Assets<Image>>,
    stage: Res<Stage>,
    camera: Single<Entity, With<OrbitCamera>>,
) {
    let Some(size) = stage.offscreen else { return };
    let mut image = Image::new_target_texture(size.x, size.y, TextureFormat::Rgba8UnormSrgb, None);
    // Screenshots copy from it.
    image.texture_descriptor.usage |= TextureUsages::COPY_SRC;
    let target = images.add(image);
    commands.entity(*camera).insert(RenderTarget::Image(target.clone().into()));
    commands.insert_resource(OffscreenTarget(target));
}

/// One short shadow cascade over the whole set.
fn one_cascade() -> bevy::light::CascadeShadowConfig {
    CascadeShadowConfigBuilder {
        num_cascades: 1,
        minimum_distance: 0.05,
        maximum_distance: 4.0,
        first_cascade_far_bound: 4.0,
        overlap_proportion: 0.2,
    }
    .build()
}

/// The stage's lights.
fn spawn_lights(commands: &mut Commands, lights: Lights) {
    match lights {
        Lights::Studio => {
            // Key light: warm, from the front left and above, casting the head's shadow on the
            // hair and the backdrop. One short cascade covers the whole set.
            commands.spawn((
                DirectionalLight {
                    illuminance: 9_000.0,
                    color: Color::srgb(1.0, 0.95, 0.88),
                    shadow_maps_enabled: true,
                    ..default()
                },
                Transform::from_xyz(-1.0, 1.6, 1.3).looking_at(Vec3::ZERO, Vec3::Y),
                one_cascade(),
            ));
            // Fill from the right, cool and soft, so the shadow side stays readable.
            commands.spawn((
                DirectionalLight { illuminance: 2_500.0, color: Color::srgb(0.8, 0.87, 1.0), ..default() },
                Transform::from_xyz(1.5, 0.4, 0.8).looking_at(Vec3::ZERO, Vec3::Y),
            ));
            // Rim light from behind and above: the highlight that separates hair from the backdrop.
            commands.spawn((
                DirectionalLight { illuminance: 4_000.0, ..default() },
                Transform::from_xyz(0.3, 1.0, -1.5).looking_at(Vec3::ZERO, Vec3::Y),
            ));
        }
        Lights::Lamps => {
            commands.spawn((
                PointLight { intensity: 60_000.0, range: 4.0, shadow_maps_enabled: true, ..default() },
                Transform::from_xyz(-0.45, 0.3, 0.35),
            ));
            commands.spawn((
                SpotLight {
                    intensity: 400_000.0,
                    color: Color::srgb(1.0, 0.85, 0.7),
                    outer_angle: 0.3,
                    inner_angle: 0.2,
                    shadow_maps_enabled: true,
                    ..default()
                },
                Transform::from_xyz(0.6, 0.6, 0.6).looking_at(FOCUS, Vec3::Y),
            ));
        }
        Lights::Above | Lights::Behind => {
            let from = if lights == Lights::Above { Vec3::new(0.0, 1.0, 0.25) } else { Vec3::new(0.0, 0.35, -1.0) };
            commands.spawn((
                DirectionalLight { illuminance: 9_000.0, shadow_maps_enabled: true, ..default() },
                Transform::from_translation(from).looking_at(Vec3::ZERO, Vec3::Y),
                one_cascade(),
            ));
        }
    }
}

/// The character's file: a skinned head with a painted scalp and its animation clip.
pub const HEAD_GLB: &str = "head.glb";

/// Once the character's scene is spawned, dresses its skinned mesh as the demo's head
/// ([`dressing`]).
fn dress_the_head(
    ready: On<WorldInstanceReady>,
    mut commands: Commands,
    children: Query<&Children>,
    meshes: Query<(), (With<Mesh3d>, With<SkinnedMesh>)>,
    (asset_server, mut materials): (Res<AssetServer>, ResMut<Assets<StandardMaterial>>),
    (start, stage): (Res<StartingPreset>, Res<Stage>),
) {
    let Some(mesh) = children.iter_descendants(ready.entity).find(|&e| meshes.contains(e)) else {
        error!("{HEAD_GLB} has no skinned mesh to grow hair on");
        return;
    };
    commands.entity(mesh).insert(dressing(&asset_server, &mut materials, &start, &stage));
}

/// What makes a mesh the demo's head: the groom (its guides from `--groom` if given) and
/// the look of the starting preset (with the command line's shading, self-shadow and
/// anti-aliasing), the backend, and a skin material that shows the painted vertex colours
/// (COLOR_0 paints the skin and, black, the scalp) as painted.
fn dressing(
    asset_server: &AssetServer,
    materials: &mut Assets<StandardMaterial>,
    start: &StartingPreset,
    stage: &Stage,
) -> impl Bundle {
    let start = presets::named(start.0);
    let mut look = start.look;
    look.shading = stage.shading.unwrap_or(look.shading);
    look.self_shadow = stage.self_shadow.unwrap_or(look.self_shadow);
    look.antialias = stage.antialias.unwrap_or(look.antialias);
    let groom = HairGroom { guides_from: stage.groom.clone().map(|path| asset_server.load(path)), ..start.groom };
    let skin = materials.add(StandardMaterial { base_color: Color::WHITE, perceptual_roughness: 0.55, ..default() });
    (Head, MeshMaterial3d(skin), groom, look, stage.backend)
}

/// Left drag (or right drag, which also works while the left button drags the head) orbits,
/// the wheel zooms. A drag that starts over the egui panel belongs to the panel.
fn orbit_camera(
    mut cameras: Query<(&mut OrbitCamera, &mut Transform)>,
    buttons: Res<ButtonInput<MouseButton>>,
    mouse_motion: Res<AccumulatedMouseMotion>,
    scroll: Res<AccumulatedMouseScroll>,
    // Absent without the panel (`--no-panel`).
    egui: Option<Res<EguiWantsInput>>,
    motion: Res<Motion>,
    mut dragging: Local<bool>,
) {
    let orbit_button = |b| b == MouseButton::Right || (b == MouseButton::Left && !motion.drag_head);
    if buttons.get_just_pressed().any(|&b| orbit_button(b))
        && !egui.as_ref().is_some_and(|e| e.wants_any_pointer_input())
    {
        *dragging = true;
    }
    if !buttons.get_pressed().any(|&b| orbit_button(b)) {
        *dragging = false;
    }
    let Ok((mut orbit, mut transform)) = cameras.single_mut() else { return };
    let mut changed = false;
    if *dragging && mouse_motion.delta != Vec2::ZERO {
        orbit.yaw -= mouse_motion.delta.x * 0.006;
        orbit.pitch = (orbit.pitch + mouse_motion.delta.y * 0.006).clamp(-1.2, 1.4);
        changed = true;
    }
    if scroll.delta.y != 0.0 && !egui.as_ref().is_some_and(|e| e.is_pointer_over_area()) {
        let lines = match scroll.unit {
            MouseScrollUnit::Line => scroll.delta.y,
            MouseScrollUnit::Pixel => scroll.delta.y / 40.0,
        };
        orbit.distance = (orbit.distance * 0.9f32.powf(lines)).clamp(0.25, 3.0);
        changed = true;
    }
    if changed {
        *transform = orbit.transform();
    }
}
