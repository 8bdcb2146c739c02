//! Drawing grooms: GPU-tessellated strands with a Kajiya-Kay or Marschner material (feature `render`).
//!
//! Each groom gets a drawing entity of its own, a child of its head ([`ChildOf`], so it
//! inherits the head's visibility and goes when the head is despawned; its own
//! [`Visibility`] hides the hair alone), with a static [`StrandLayout`] mesh and a
//! [`HairMaterial`]. Every frame only the guide particles, interpolated between the last
//! two hair steps and placed on the head as posed in the frame, and each particle's
//! parallel-transport frame vector are written into the material's storage buffer; the
//! vertex shader tessellates the guides with Bézier curves and places the children around
//! them. The head's [`RenderLayers`] are copied to the drawing.

mod layout;
mod look;
mod material;
mod particles;
mod shadows;
pub(crate) mod timing;

pub use layout::{ATTRIBUTE_HAIR_VERTEX, SEGMENTS_PER_PIECE, StrandLayout};
pub use look::{HairAntialias, HairLook, HairShading, SpecularLobe};
pub use material::{HairMaterial, HairUniform, shader_path};
pub use shadows::MAX_OPACITY_MAPS;
use shadows::{
    ShadowCastingLights, fibres, find_shadow_casting_lights, opacity_maps_len, reserve_opacity_maps, shadow_samples,
    write_opacity_maps,
};

use crate::convert::{from_sim, quat_from_sim, to_sim};
use crate::detail::{UNKNOWN_VIEWPORT_HEIGHT, pixels_per_metre};
use crate::diagnostics::HairDiagnostics;
use crate::gpu::{ShadowMaps, SortedOrder};
use crate::settings::effective;
use crate::{Hair, HairGroom, HairSettings, HairSettingsOverride, HairState, HairSystems, HairTime};
use bevy::asset::embedded_asset;
use bevy::camera::primitives::Aabb;
use bevy::camera::visibility::{NoAutoAabb, RenderLayers, VisibilitySystems};
use bevy::diagnostic::Diagnostics;
use bevy::light::NotShadowCaster;
use bevy::prelude::*;
use bevy::render::renderer::RenderDevice;
use bevy::render::storage::ShaderBuffer;
use bevy::shader::load_shader_library;
use bevy::tasks::{ComputeTaskPool, TaskPool};
use bevy::utils::Parallel;
use hair_sim::draw_order::back_to_front;
use hair_sim::groom::{ChildParams, MAX_CURVATURE, transport_frames_of_strands};

/// Draws every groom: added by [`HairPlugin`](crate::HairPlugin) when the `render`
/// feature is on and the app renders.
/// Nothing to add by hand: [`HairPlugin`](crate::HairPlugin)'s example is all it takes.
pub struct HairRenderPlugin;

impl Plugin for HairRenderPlugin {
    fn build(&self, app: &mut App) {
        embedded_asset!(app, "hair.wgsl");
        load_shader_library!(app, "strand.wgsl");
        // The curve's geometry, shared with the GPU solver's drawing pass (which prepends
        // it to its own source, so the import path is added here).
        let curve = format!("#define_import_path bevy_hair::curve\n\n{}", hair_gpu::CURVE_SHADER);
        let curve =
            app.world_mut().resource_mut::<Assets<Shader>>().add(Shader::from_wgsl(curve, "bevy_hair/curve.wgsl"));
        app.insert_resource(CurveShader(curve));
        app.add_plugins((
            MaterialPlugin::<HairMaterial>::default(),
            crate::gpu::GpuRenderWorldPlugin,
            particles::ParticleWritesPlugin,
            timing::RenderTimingPlugin,
        ))
        .register_type::<HairLook>()
        .register_type::<HairAntialias>()
        .register_type::<HairRenderStats>()
        .register_required_components::<HairGroom, HairLook>()
        .init_resource::<HairRenderStats>()
        .init_resource::<ShadowCastingLights>()
        .add_systems(
            PostUpdate,
            (find_shadow_casting_lights, sync_drawing, choose_blending, draw_on_gpu, upload_guides, update_materials)
                .chain()
                .in_set(HairSystems::Draw)
                .after(VisibilitySystems::VisibilityPropagate)
                .before(VisibilitySystems::CheckVisibility),
        )
        .add_observer(forget_drawing);
    }
}

/// The hair's systems in Bevy's render world, for ordering against them or measuring them.
/// Each runs in its own schedule of the render app.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy::render::{Render, RenderApp};
/// # use bevy_hair::prelude::*;
/// # fn after_hair_recorded() {}
/// # let mut app = App::new();
/// # app.insert_sub_app(RenderApp, SubApp::new());
/// app.sub_app_mut(RenderApp).add_systems(Render, after_hair_recorded.after(HairRenderSystems::Write));
/// ```
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum HairRenderSystems {
    /// `ExtractSchedule`: the frame's letters to the GPU grooms and the CPU grooms'
    /// particles move into the render world.
    Extract,
    /// `Render`, in `RenderSystems::PrepareResources`: the CPU grooms' particles are
    /// written into their drawings' buffers.
    Write,
    /// The render graph schedule, before `camera_driver`: the GPU grooms' steps, drawing
    /// passes and copies back are recorded into the frame.
    Record,
    /// `Render`, in `RenderSystems::Cleanup`, after the frame's submission: the copies back
    /// that arrived are posted to the main world.
    Collect,
}

/// Keeps the shared curve shader (`bevy_hair::curve`) loaded.
#[derive(Resource)]
struct CurveShader(#[allow(dead_code)] Handle<Shader>);

/// What the hair drawing cost this frame, summed over grooms. Also published as Bevy
/// diagnostics ([`HairDiagnostics`]).
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// fn hair_load(stats: Res<HairRenderStats>) {
///     info!("{} strands, {} bytes uploaded", stats.rendered_strands, stats.uploaded_bytes);
/// }
/// ```
#[derive(Resource, Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Resource, Default, Debug, PartialEq)]
pub struct HairRenderStats {
    /// Strands drawn (guides and children).
    pub rendered_strands: u64,
    /// Vertices of the strand meshes.
    pub rendered_vertices: u64,
    /// Bytes written to the GPU for hair this frame.
    pub uploaded_bytes: u64,
}

/// On a groom's drawing entity (a child of the head): which head it draws and with what.
/// Read it to find a drawing's head, as `tests/render/` does; the plugin makes and keeps it.
#[derive(Component, Debug)]
pub struct HairDrawing {
    /// The head entity (with [`HairGroom`] and [`HairState`]).
    pub head: Entity,
    /// The storage buffer of what the CPU adds to the particles (the scalp at each root, the
    /// draw order, opacity maps).
    pub guides: Handle<ShaderBuffer>,
    /// The guide particles and their frames ([`HairMaterial::particles`]).
    pub particles: Handle<ShaderBuffer>,
    /// The strand material.
    pub material: Handle<HairMaterial>,
    /// The mesh layout drawn.
    pub layout: StrandLayout,
    /// Each guide's root in head space (rotated by the head each frame): its frame `u`,
    /// and the scalp's normal and curvature there.
    roots: Vec<DrawnRoot>,
    /// Deep opacity maps the buffer has room for.
    opacity_maps: usize,
    /// Where the guides are sorted from (back to front) when the strands are blended
    /// ([`HairAntialias`]); `None` when they are not.
    blended_from: Option<Vec3>,
    /// Each guide's root frame vector `u` (head space), for the GPU's drawing of a groom
    /// the GPU steps.
    root_u: std::sync::Arc<[hair_sim::math::Vec3]>,
}

impl HairDrawing {
    /// Whether the strands are drawn blended ([`HairAntialias::Blended`], or
    /// [`HairAntialias::Auto`] with every strand under a pixel wide).
    pub fn blended(&self) -> bool {
        self.blended_from.is_some()
    }
}

/// A guide's root as the children need it, head space.
#[derive(Clone, Copy, Debug)]
struct DrawnRoot {
    u: Vec3,
    normal: Vec3,
    curvature: f32,
}

/// On a drawing: the box around its strands as the CPU last had them, in the drawing's
/// frame, which the blending choice reads ([`choose_blending`]). The drawing's [`Aabb`]
/// (what culling reads) is the same box, except for a groom the GPU steps, whose
/// positions here do not follow the drawn ones: there it holds every strand as far as it
/// reaches from its root.
#[derive(Component, Clone, Copy, Debug, Default)]
struct StrandsBox {
    aabb: Aabb,
    /// The head's [`HairState::published_count`] the box was fitted to: a GPU groom's
    /// positions here change only when a copy comes back, and its box stands until then.
    fitted_to: Option<u64>,
}

/// On a head: the entity that draws its hair. Set that entity's [`Visibility`] to hide
/// the hair alone.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// # use bevy_hair::render::HairDrawnBy;
/// // Hide the hair of every head, keeping the heads.
/// fn bald(drawn: Query<&HairDrawnBy>, mut visibility: Query<&mut Visibility>) {
///     for HairDrawnBy(drawing) in &drawn {
///         if let Ok(mut visible) = visibility.get_mut(*drawing) {
///             *visible = Visibility::Hidden;
///         }
///     }
/// }
/// ```
#[derive(Component, Debug)]
pub struct HairDrawnBy(pub Entity);

/// A head that loses its [`HairGroom`] loses its drawing.
fn forget_drawing(removed: On<Remove, HairGroom>, mut commands: Commands, heads: Query<&HairDrawnBy>) {
    if let Ok(drawn_by) = heads.get(removed.entity) {
        commands.entity(drawn_by.0).try_despawn();
        commands.entity(removed.entity).try_remove::<HairDrawnBy>();
    }
}

fn layout_of(state: &HairState, groom: &HairGroom, look: &HairLook) -> StrandLayout {
    StrandLayout {
        guides: state.roots().len() as u32,
        particles: state.particles_per_strand() as u32,
        strands_per_guide: if look.guides_only { 1 } else { groom.children.sanitized().0.per_guide + 1 },
        subdivisions: look.subdivisions.clamp(1, 16),
    }
}

/// Spawns the drawing entity of each grown groom as a child of its head, rebuilds its
/// mesh, buffer and material when the groom regrew or its layout changed, stops drawing
/// while the groom regrows, and keeps its render layers those of the head. Its
/// [`Visibility`] is left to the user.
#[allow(clippy::type_complexity, clippy::too_many_arguments)] // the heads query; the assets it makes
fn sync_drawing(
    mut commands: Commands,
    heads: Query<(Entity, Option<Ref<HairState>>, &HairGroom, &HairLook, Option<&HairDrawnBy>, Option<&RenderLayers>)>,
    drawings: Query<(&HairDrawing, Has<Mesh3d>, Option<&RenderLayers>)>,
    lights: Res<ShadowCastingLights>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut buffers: ResMut<Assets<ShaderBuffer>>,
    mut materials: ResMut<Assets<HairMaterial>>,
    device: Option<Res<RenderDevice>>,
) {
    // Without a render device (an app rendering nothing) nothing is drawn.
    let Some(device) = device else { return };
    let renewed = device.is_changed();
    // Room for an opacity map per shadow-casting light: the buffer is rebuilt when their
    // number changes.
    let casting = lights.0.len();
    for (head, state, groom, look, drawn_by, layers) in &heads {
        let existing = drawn_by.and_then(|d| Some(d.0).zip(drawings.get(d.0).ok()));
        if let Some((entity, (_, _, drawing_layers))) = existing
            && drawing_layers != layers
        {
            match layers {
                Some(layers) => _ = commands.entity(entity).insert(layers.clone()),
                None => _ = commands.entity(entity).remove::<RenderLayers>(),
            }
        }
        let Some(state) = state else {
            if let Some((entity, (_, true, _))) = existing {
                commands.entity(entity).remove::<Mesh3d>();
            }
            continue;
        };
        let layout = layout_of(&state, groom, look);
        let opacity_maps = if look.self_shadow > 0.0 { casting } else { 0 };
        // A new render device (Bevy recovered its renderer) gets new buffers and materials.
        if let Some((_, (drawing, true, _))) = existing
            && drawing.layout == layout
            && drawing.opacity_maps == opacity_maps
            && !state.is_added()
            && !renewed
        {
            continue;
        }
        let mesh = state.head_mesh();
        let roots: Vec<DrawnRoot> = state
            .roots()
            .iter()
            .map(|r| DrawnRoot {
                u: from_sim(r.tangent(mesh)),
                normal: from_sim(r.normal(mesh)),
                curvature: r.curvature(mesh),
            })
            .collect();
        let bytes = (guide_buffer_len(&layout) + opacity_maps_len(opacity_maps)) * size_of::<Vec4>();
        let guides = buffers.add(ShaderBuffer::with_size(bytes, default()));
        // Written in the render world (by the CPU's writes or the GPU's drawing pass): the
        // main world holds no data for it.
        let particles = buffers.add(ShaderBuffer::with_size(particles_len(&layout) * size_of::<Vec4>(), default()));
        let material = materials.add(HairMaterial {
            guides: guides.clone(),
            uniform: uniform(&layout, groom, look, false),
            particles: particles.clone(),
        });
        let root_u = roots.iter().map(|root| to_sim(root.u)).collect();
        let drawing = HairDrawing {
            head,
            guides,
            particles,
            material: material.clone(),
            layout,
            roots,
            opacity_maps,
            blended_from: None,
            root_u,
        };
        let bundle = (Mesh3d(meshes.add(layout.mesh())), MeshMaterial3d(material), drawing, Transform::IDENTITY);
        match existing {
            Some((entity, _)) => _ = commands.entity(entity).insert(bundle),
            None => {
                // The box is fitted to the moving strands every frame ([`upload_guides`]).
                let mut entity = commands.spawn((
                    Name::new("hair"),
                    bundle,
                    ChildOf(head),
                    Visibility::Inherited,
                    NoAutoAabb,
                    Aabb::default(),
                    StrandsBox::default(),
                ));
                if let Some(layers) = layers {
                    entity.insert(layers.clone());
                }
                let entity = entity.id();
                commands.entity(head).insert(HairDrawnBy(entity));
            }
        }
    }
}

/// One `vec4` per guide particle for its position, then one per particle for its frame.
fn particles_len(layout: &StrandLayout) -> usize {
    (2 * layout.guides * layout.particles) as usize
}

/// One `vec4` per guide for the scalp at its root, then the head's centre, then the order
/// the strands' pieces are drawn in (four per `vec4`); the opacity maps follow.
fn guide_buffer_len(layout: &StrandLayout) -> usize {
    (layout.guides + 1 + (layout.guides * layout.pieces()).div_ceil(4)) as usize
}

/// [`HairAntialias::Auto`] blends a groom whose widest strand is under this many pixels…
const BLEND_BELOW_PIXELS: f32 = 1.0;
/// …and stops blending it above this many.
const UNBLEND_ABOVE_PIXELS: f32 = 1.25;

/// Chooses, per drawing, whether its strands are blended ([`HairAntialias`]) and from
/// which camera they are sorted: the nearest active one.
fn choose_blending(
    heads: Query<&HairLook>,
    cameras: Query<(&Camera, &Projection, &GlobalTransform)>,
    mut drawings: Query<(&mut HairDrawing, &GlobalTransform, &StrandsBox)>,
) {
    for (mut drawing, placed, StrandsBox { aabb, .. }) in &mut drawings {
        let Ok(look) = heads.get(drawing.head) else { continue };
        // The strands' bounding sphere, in the world.
        let centre = placed.transform_point(aabb.center.into());
        let m = placed.affine().matrix3;
        let scale = m.x_axis.length().max(m.y_axis.length()).max(m.z_axis.length());
        let radius = scale * aabb.half_extents.length();
        let width = look.root_width.max(look.tip_width);
        let active = || cameras.iter().filter(|(camera, ..)| camera.is_active);
        let blended = match look.antialias {
            HairAntialias::Off | HairAntialias::Coverage => false,
            HairAntialias::Blended => true,
            HairAntialias::Auto => {
                let widest = active()
                    .map(|(camera, projection, at)| strand_pixels(width, centre, radius, camera, projection, at))
                    .reduce(f32::max);
                let limit = if drawing.blended() { UNBLEND_ABOVE_PIXELS } else { BLEND_BELOW_PIXELS };
                widest.is_some_and(|w| w < limit)
            }
        };
        let nearest = active()
            .map(|(_, _, at)| at.translation())
            .min_by(|a, b| a.distance_squared(centre).total_cmp(&b.distance_squared(centre)));
        let blended_from = if blended { nearest.or(Some(centre)) } else { None };
        if drawing.blended_from != blended_from {
            drawing.blended_from = blended_from;
        }
    }
}

/// How many pixels wide a strand `width` metres across is drawn by a camera at most,
/// anywhere in the sphere of `radius` around `centre`: infinite when the camera is inside
/// the sphere, 0 when the sphere is behind it.
fn strand_pixels(
    width: f32,
    centre: Vec3,
    radius: f32,
    camera: &Camera,
    projection: &Projection,
    at: &GlobalTransform,
) -> f32 {
    let viewport = camera.physical_viewport_size().map_or(UNKNOWN_VIEWPORT_HEIGHT, |s| s.y as f32);
    let depth = (centre - at.translation()).dot(*at.forward());
    match projection {
        Projection::Perspective(_) if depth + radius <= 0.0 => 0.0,
        Projection::Perspective(_) if at.translation().distance(centre) <= radius || depth <= radius => f32::INFINITY,
        _ => width * pixels_per_metre(depth - radius, viewport, projection),
    }
}

/// A groom's buffer contents for this frame, written on a task of its own.
struct WrittenGuides {
    buffer: Handle<ShaderBuffer>,
    data: Vec<Vec4>,
    /// The particles and their frames, unless the GPU writes them.
    particles: Option<(AssetId<ShaderBuffer>, Vec<Vec4>)>,
    layout: StrandLayout,
}

/// For a groom the GPU steps, asks the GPU to write the frame's particles and their frames
/// straight into the drawing's buffer (`hair_gpu::GpuDrawing`, recorded in the render
/// world after the frame's steps); [`upload_guides`] writes the rest.
fn draw_on_gpu(
    clock: Res<Time<Hair>>,
    mut heads: Query<(&mut HairState, &HairLook)>,
    drawings: Query<(&HairDrawing, &InheritedVisibility), With<Mesh3d>>,
    lights: Res<ShadowCastingLights>,
) {
    let overstep = clock.overstep_fraction();
    for (drawing, visible) in &drawings {
        let Ok((mut state, look)) = heads.get_mut(drawing.head) else { continue };
        if !visible.get() || !drawn_on_gpu(drawing, &state) {
            continue;
        }
        // The opacity maps of what the GPU draws, built there after the drawing.
        let shadows = (look.self_shadow > 0.0 && drawing.opacity_maps > 0).then(|| {
            let map = opacity_maps_len(1) - 1;
            ShadowMaps {
                guides: drawing.guides.id(),
                first: ((guide_buffer_len(&drawing.layout) + 1) * 4) as u32,
                stride: (map * 4) as u32,
                lights: lights.0.iter().take(drawing.opacity_maps).copied().collect(),
                fibres: fibres(look, &drawing.layout),
            }
        });
        // The blended pieces' order, sorted there from what it draws.
        let order = drawing.blended_from.map(|eye| SortedOrder {
            guides: drawing.guides.id(),
            first: ((drawing.layout.guides + 1) * 4),
            eye: to_sim(eye),
            segments_per_piece: SEGMENTS_PER_PIECE,
        });
        let pose = state.drawn_head_pose();
        let gpu = &mut state.bypass_change_detection().gpu;
        gpu.draw(drawing.particles.id(), &drawing.root_u, (overstep, pose), (shadows, order));
    }
}

/// Whether the GPU writes `drawing`'s particles this frame ([`draw_on_gpu`]).
fn drawn_on_gpu(drawing: &HairDrawing, state: &HairState) -> bool {
    state.gpu.running() && state.roots().len() == drawing.roots.len()
}

/// Writes this frame's guide particles (interpolated between the last two hair steps, on
/// the head as posed this frame) and their transport frames into each drawing's particle
/// buffer, unless the GPU does ([`draw_on_gpu`]), then the scalp at each root, the draw
/// order and the opacity maps into its guide buffer, and fits its bounding box (in the
/// drawing's own frame: it is a child of the head, and a skinned head's hair follows a
/// joint instead; [`StrandsBox`]). The grooms are written in parallel. For a groom the
/// GPU steps, the order and the maps come from the positions last copied back (a frame or
/// two late).
#[allow(clippy::too_many_arguments)] // one system: the buffers, their inputs and the statistics
fn upload_guides(
    clock: Res<Time<Hair>>,
    heads: Query<(&HairState, &HairGroom, &HairLook, Option<&HairSettingsOverride>)>,
    settings: Res<HairSettings>,
    lights: Res<ShadowCastingLights>,
    mut drawings: Query<
        (&HairDrawing, &GlobalTransform, &mut Aabb, &mut StrandsBox, &InheritedVisibility),
        With<Mesh3d>,
    >,
    mut buffers: ResMut<Assets<ShaderBuffer>>,
    mut particle_writes: ResMut<particles::ParticleWrites>,
    mut stats: ResMut<HairRenderStats>,
    mut diagnostics: Diagnostics,
    mut written: Local<Parallel<Vec<WrittenGuides>>>,
) {
    let started = bevy::platform::time::Instant::now();
    // Extraction took the last frame's (without a render world, nothing would).
    particle_writes.0.clear();
    let overstep = clock.overstep_fraction();
    /// The particles and frames (unless the GPU writes them), the guide buffer, and the
    /// boxes the blending choice and culling read ([`StrandsBox`]).
    type Written = (Option<Vec<Vec4>>, Vec<Vec4>, Option<StrandsBox>, Option<Aabb>);
    let write = |drawing: &HairDrawing, placed: &GlobalTransform, fitted_before: &StrandsBox| -> Option<Written> {
        let (state, groom, look, local_settings) = heads.get(drawing.head).ok()?;
        if state.roots().len() != drawing.roots.len() {
            return None; // regrown with another guide count; sync_drawing rebuilds next frame
        }
        let rotation = quat_from_sim(state.drawn_head_pose().rotation);
        let to_drawing = placed.affine().inverse();
        let n = state.particles_per_strand();
        let on_gpu = drawn_on_gpu(drawing, state);
        // The GPU draws, shadows and sorts its own strands: their positions here matter
        // only for the box the blending choice reads, which changes only when a copy
        // comes back. Until then only the roots are placed.
        let refit = !on_gpu || fitted_before.fitted_to != Some(state.published_count());
        let positions: Vec<Vec3> = if refit { state.interpolated_positions(overstep).collect() } else { Vec::new() };
        // The box around the particles, and around the roots as placed this frame.
        let (mut min, mut max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for &p in &positions {
            let local = to_drawing.transform_point3(p);
            min = min.min(local);
            max = max.max(local);
        }
        let (mut roots_min, mut roots_max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for root in state.root_positions() {
            let local = to_drawing.transform_point3(root);
            roots_min = roots_min.min(local);
            roots_max = roots_max.max(local);
        }
        // The solver's vectors of the same positions, for the frames, the draw order and
        // the opacity maps, which the GPU makes of its own.
        let points: Vec<_> = if on_gpu { Vec::new() } else { positions.iter().map(|&p| to_sim(p)).collect() };
        // The particles with their frames on a task of their own, beside the guide data
        // (the opacity maps take longest): a frame waits for the longer, not for both.
        let particles_with_frames = || {
            let mut particles: Vec<Vec4> = Vec::with_capacity(particles_len(&drawing.layout));
            particles.extend(positions.iter().map(|p| p.extend(1.0)));
            // The frames are one root → tip pass per guide here, instead of a walk from the
            // root in every vertex of every child.
            let mut frames = Vec::with_capacity(points.len());
            let root_u = |guide: usize| drawing.roots.get(guide).map_or(Vec3::X, |root| rotation * root.u);
            transport_frames_of_strands(&points, n, |guide| to_sim(root_u(guide)), &mut frames);
            particles.extend(frames.into_iter().map(|u| from_sim(u).extend(0.0)));
            particles
        };
        let mut data: Vec<Vec4> = Vec::with_capacity(guide_buffer_len(&drawing.layout));
        let guide_data = |data: &mut Vec<Vec4>| {
            // The children's scalp: each root's normal and curvature, and the head's centre.
            data.extend(drawing.roots.iter().map(|root| (rotation * root.normal).extend(root.curvature)));
            let pose = state.drawn_head_pose();
            data.push(from_sim(pose.transform_point(state.collider().centre())).extend(1.0));
            // A groom the GPU draws is sorted there ([`draw_on_gpu`]): the order grown holds
            // its room.
            let eye = drawing.blended_from.filter(|_| !on_gpu);
            data.extend(StrandLayout::pack_order(&draw_order(&points, &drawing.layout, eye)));
            if look.self_shadow > 0.0 && on_gpu {
                // The GPU builds them from what it draws ([`draw_on_gpu`]): room and their count.
                reserve_opacity_maps(data, drawing.opacity_maps, lights.0.len());
            } else if look.self_shadow > 0.0 {
                let fibres = fibres(look, &drawing.layout);
                let (points, areas) = shadow_samples(&points, n, state.strands(), fibres);
                write_opacity_maps(data, drawing.opacity_maps, &lights.0, (&points, &areas));
            }
        };
        let particles = ComputeTaskPool::get_or_init(TaskPool::default)
            .scope(|scope| {
                if !on_gpu {
                    scope.spawn(async { particles_with_frames() });
                }
                guide_data(&mut data);
            })
            .pop();
        // Children sit at most the spiral's outer radius plus the tip spread from their
        // guide, and ribbons add half their width; in the drawing's frame that length is
        // stretched at most by the inverse's Frobenius norm (1.7 for a rigid frame).
        let stretch = to_drawing.matrix3.to_cols_array().iter().map(|c| c * c).sum::<f32>().sqrt();
        let reach = (child_reach(&groom.children.sanitized().0) + look.root_width.max(look.tip_width)) * stretch;
        let widened = |min: Vec3, max: Vec3, by: f32| {
            (min.is_finite() && max.is_finite())
                .then(|| Aabb::from_min_max(min - Vec3::splat(by), max + Vec3::splat(by)))
        };
        let fitted = if refit {
            widened(min, max, reach).map(|aabb| StrandsBox { aabb, fitted_to: Some(state.published_count()) })
        } else {
            Some(*fitted_before)
        };
        // The GPU's strands are drawn where they are now, which the positions here follow
        // only with `HairReadback`: culling takes every strand as far as it reaches from its
        // root (stretched as far as the length tolerance lets it), the blending choice the
        // strands' shape on the head as last copied.
        let culled = if on_gpu {
            let longest = state.strands().rest().longest_strand();
            let tolerance = effective(&settings, local_settings).sanitized().0.length_tolerance;
            widened(roots_min, roots_max, longest * (1.0 + tolerance) * stretch + reach)
        } else {
            fitted.map(|fitted| fitted.aabb)
        };
        Some((particles, data, fitted, culled))
    };
    // Each groom's buffer is written on a task of its own (a crowd's grooms on every core),
    // then handed to its asset here.
    drawings.par_iter_mut().for_each(|(drawing, placed, mut aabb, mut strands_box, inherited)| {
        // The head or the hair is hidden (the drawing's own `Visibility` is part of its
        // inherited one): nothing is drawn, so nothing is uploaded.
        if !inherited.get() {
            return;
        }
        if let Some((particles, data, fitted, culled)) = write(drawing, placed, &strands_box) {
            if let (Some(fitted), Some(culled)) = (fitted, culled) {
                *strands_box = fitted;
                *aabb = culled;
            }
            written.borrow_local_mut().push(WrittenGuides {
                buffer: drawing.guides.clone(),
                data,
                particles: particles.map(|p| (drawing.particles.id(), p)),
                layout: drawing.layout,
            });
        }
    });
    let mut frame = HairRenderStats::default();
    for WrittenGuides { buffer, data, particles, layout } in written.iter_mut().flat_map(|written| written.drain(..)) {
        frame.uploaded_bytes += (data.len() * size_of::<Vec4>()) as u64;
        frame.rendered_strands += layout.strands() as u64;
        frame.rendered_vertices += layout.vertices() as u64;
        if let Some(mut buffer) = buffers.get_mut(&buffer) {
            buffer.set_data(data);
        }
        if let Some((buffer, particles)) = particles {
            frame.uploaded_bytes += (particles.len() * size_of::<Vec4>()) as u64;
            particle_writes.0.push((buffer, particles));
        }
    }
    *stats = frame;
    diagnostics.add_measurement(&HairDiagnostics::UPLOADED_BYTES, || frame.uploaded_bytes as f64);
    diagnostics.add_measurement(&HairDiagnostics::RENDERED_STRANDS, || frame.rendered_strands as f64);
    diagnostics.add_measurement(&HairDiagnostics::RENDERED_VERTICES, || frame.rendered_vertices as f64);
    diagnostics.add_measurement(&HairDiagnostics::UPLOAD_TIME, || started.elapsed().as_secs_f64() * 1e3);
}

/// The order the strands' pieces are drawn in (`guide · pieces + piece`,
/// [`StrandLayout::pieces`]): back to front from `camera` when the strands are blended
/// ([`hair_sim::draw_order`]), else as grown. `positions` is strand-major.
fn draw_order(positions: &[hair_sim::math::Vec3], layout: &StrandLayout, camera: Option<Vec3>) -> Vec<u32> {
    match camera {
        Some(eye) => back_to_front(positions, layout.particles as usize, SEGMENTS_PER_PIECE as usize, to_sim(eye)),
        None => layout.grown_order(),
    }
}

/// How far a child can stray from its guide: the outermost spiral radius (clumping only
/// shrinks it) plus the tip spread.
fn child_reach(children: &ChildParams) -> f32 {
    match children.per_guide {
        0 => 0.0,
        n => {
            // At the root the spiral bends onto the scalp by at most `MAX_CURVATURE·r²/2`.
            let r = children.spiral.radius(n - 1);
            r + 0.5 * MAX_CURVATURE * r * r + children.tip_spread
        }
    }
}

/// Rewrites a drawing's uniform when its look or child placement changed, and makes it
/// cast shadows or not as its look says.
fn update_materials(
    mut commands: Commands,
    heads: Query<(&HairGroom, &HairLook)>,
    drawings: Query<(Entity, &HairDrawing, Has<NotShadowCaster>)>,
    mut materials: ResMut<Assets<HairMaterial>>,
) {
    for (entity, drawing, not_caster) in &drawings {
        let Ok((groom, look)) = heads.get(drawing.head) else { continue };
        match (look.cast_shadows, not_caster) {
            (true, true) => _ = commands.entity(entity).remove::<NotShadowCaster>(),
            (false, false) => _ = commands.entity(entity).insert(NotShadowCaster),
            _ => {}
        }
        let wanted = uniform(&drawing.layout, groom, look, drawing.blended());
        if materials.get(&drawing.material).is_some_and(|m| m.uniform != wanted)
            && let Some(mut material) = materials.get_mut(&drawing.material)
        {
            material.uniform = wanted;
        }
    }
}

/// The shader's uniform block from the look and the child placement, blended or not
/// ([`choose_blending`]). Values are sanitised here, so NaN or negative widths never reach
/// the GPU.
fn uniform(layout: &StrandLayout, groom: &HairGroom, look: &HairLook, blended: bool) -> HairUniform {
    let (children, _) = groom.children.sanitized();
    let finite = |x: f32, fallback: f32| if x.is_finite() { x } else { fallback };
    let non_negative = |x: f32, fallback: f32| finite(x, fallback).max(0.0);
    let linear = |c: Color| Vec4::from_array(c.to_linear().to_f32_array());
    let defaults = HairLook::default();
    let marschner = match look.shading {
        HairShading::KajiyaKay => None,
        HairShading::Marschner { roughness, cuticle_tilt } => {
            Some((finite(roughness, 0.35).clamp(0.05, 1.0), finite(cuticle_tilt, 0.035).clamp(-0.3, 0.3)))
        }
    };
    HairUniform {
        root_color: linear(look.root_color),
        tip_color: linear(look.tip_color),
        primary_color: linear(look.primary.color),
        secondary_color: linear(look.secondary.color),
        primary_exponent: non_negative(look.primary.exponent, defaults.primary.exponent).max(1.0),
        primary_shift: finite(look.primary.shift, 0.0).clamp(-1.0, 1.0),
        secondary_exponent: non_negative(look.secondary.exponent, defaults.secondary.exponent).max(1.0),
        secondary_shift: finite(look.secondary.shift, 0.0).clamp(-1.0, 1.0),
        spiral_a: children.spiral.a,
        spiral_b: children.spiral.b,
        spiral_angle_step: children.spiral.angle_step,
        spiral_scale: children.spiral.scale,
        clumping: children.clumping,
        tip_spread: children.tip_spread,
        root_width: non_negative(look.root_width, defaults.root_width),
        tip_width: non_negative(look.tip_width, defaults.tip_width),
        tint_variation: non_negative(look.tint_variation, 0.0).min(1.0),
        diffuse: non_negative(look.diffuse, defaults.diffuse),
        flags: if look.receive_shadows { HairUniform::RECEIVE_SHADOWS } else { 0 }
            | if marschner.is_some() { HairUniform::MARSCHNER } else { 0 }
            | match (look.antialias, blended) {
                (HairAntialias::Off, _) => 0,
                (_, true) => HairUniform::BLENDED,
                (_, false) => HairUniform::ANTIALIAS,
            },
        roughness: marschner.map_or(0.0, |(roughness, _)| roughness),
        cuticle_tilt: marschner.map_or(0.0, |(_, tilt)| tilt),
        self_shadow: non_negative(look.self_shadow, 0.0).min(1.0),
        ..default()
    }
    .with_layout(layout)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blended_pieces_are_drawn_back_to_front() {
        // Two guides of 4 particles (3 segments: pieces of 2 and 1) along the view axis, the
        // second farther: its pieces first, each guide's tip piece before its root piece.
        let layout = StrandLayout { guides: 2, particles: 4, strands_per_guide: 1, subdivisions: 1 };
        let positions: Vec<_> =
            (0..8).map(|k| to_sim(Vec3::new(0.0, 0.0, -1.0 - (k / 4) as f32 * 10.0 - (k % 4) as f32))).collect();
        assert_eq!(draw_order(&positions, &layout, None), [0, 1, 2, 3], "as grown");
        assert_eq!(draw_order(&positions, &layout, Some(Vec3::ZERO)), [3, 2, 1, 0], "back to front");
    }

    #[test]
    fn bad_look_values_never_reach_the_gpu() {
        let layout = StrandLayout { guides: 2, particles: 11, strands_per_guide: 5, subdivisions: 4 };
        let bad = HairLook {
            root_width: f32::NAN,
            tip_width: -1.0,
            tint_variation: f32::INFINITY,
            diffuse: f32::NEG_INFINITY,
            primary: SpecularLobe { exponent: f32::NAN, shift: 7.0, ..HairLook::default().primary },
            secondary: SpecularLobe { exponent: -3.0, shift: f32::NAN, ..HairLook::default().secondary },
            ..default()
        };
        let groom =
            HairGroom { children: ChildParams { clumping: f32::NAN, tip_spread: -1.0, ..default() }, ..default() };
        let u = uniform(&layout, &groom, &bad, false);
        let values = [
            u.primary_exponent,
            u.primary_shift,
            u.secondary_exponent,
            u.secondary_shift,
            u.spiral_a,
            u.spiral_b,
            u.spiral_angle_step,
            u.spiral_scale,
            u.clumping,
            u.tip_spread,
            u.root_width,
            u.tip_width,
            u.tint_variation,
            u.diffuse,
        ];
        assert!(values.iter().all(|v| v.is_finite()), "{u:?}");
        let defaults = HairLook::default();
        assert_eq!((u.root_width, u.tip_width), (defaults.root_width, 0.0), "NaN width → default, negative → 0");
        assert_eq!(
            (u.tint_variation, u.diffuse),
            (0.0, defaults.diffuse),
            "non-finite variation → 0, diffuse → default"
        );
        assert_eq!((u.primary_exponent, u.primary_shift), (defaults.primary.exponent, 1.0), "default, clamped");
        assert_eq!((u.secondary_exponent, u.secondary_shift), (1.0, 0.0), "exponent at least 1, NaN shift → 0");
        assert_eq!((u.clumping, u.tip_spread), (ChildParams::default().clumping, 0.0));
        assert_eq!((u.guides, u.particles, u.strands_per_guide, u.subdivisions), (2, 11, 5, 4));
        assert_eq!(
            u.flags,
            HairUniform::RECEIVE_SHADOWS | HairUniform::ANTIALIAS,
            "the default look receives shadows and is anti-aliased"
        );
    }
}
