//! Drawing GPU strands without reading them back: after each step the particles are kept
//! in head space ([`Published`], the last two steps), and each frame [`GpuDrawing`] writes
//! them as drawn, with their parallel-transport frames, into a renderer's buffer
//! (`draw.wgsl`, with `curve.wgsl`'s geometry, which the renderer's shader shares).

use crate::pass::{bind_group, pipeline};
use crate::recorder::Recorder;
use crate::{Alive, GpuError, GpuStrands, LIVE_DRAWINGS, storage_buffer};
use bytemuck::{Pod, Zeroable};
use hair_sim::math::{Pose, Vec3};

/// The strand curve's WGSL (`curve.wgsl`): the Bézier through a strand's particles, its
/// frames and the helpers they need, for a renderer's shader to import (bevy_hair adds
/// `#define_import_path bevy_hair::curve`).
pub const CURVE_SHADER: &str = include_str!("curve.wgsl");
/// The drawing passes' WGSL (the solver's `layout.wgsl`, then `draw.wgsl`), which needs
/// [`CURVE_SHADER`] before it.
pub const DRAW_SHADER: &str = concat!(include_str!("layout.wgsl"), "\n", include_str!("draw.wgsl"));

/// `draw.wgsl`'s `Placement`: an affine map, the counts and the overstep.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Placement {
    columns: [[f32; 4]; 4],
    counts: [u32; 4],
    overstep: [f32; 4],
}

impl Placement {
    /// `p ↦ rotation · p + translation` for `strands` × `particles` particles.
    fn new(rotation: glam::Mat3, translation: Vec3, counts: [u32; 2], overstep: f32) -> Self {
        let column = |v: Vec3| [v.x, v.y, v.z, 0.0];
        Placement {
            columns: [column(rotation.x_axis), column(rotation.y_axis), column(rotation.z_axis), column(translation)],
            counts: [counts[0], counts[1], 0, 0],
            overstep: [overstep, 0.0, 0.0, 0.0],
        }
    }
}

/// The module with both drawing passes.
fn module(device: &wgpu::Device) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("hair_gpu draw.wgsl"),
        source: wgpu::ShaderSource::Wgsl(format!("{CURVE_SHADER}\n{DRAW_SHADER}").into()),
    })
}

fn uniform_buffer(device: &wgpu::Device) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("hair_gpu placement"),
        size: size_of::<Placement>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// The drawing pass compiled, for any number of [`GpuDrawing`]s: compiling takes long,
/// binding buffers to it does not.
#[derive(Clone)]
pub struct DrawingPasses {
    pipeline: wgpu::ComputePipeline,
}

impl DrawingPasses {
    /// Compiles the pass on `device`.
    pub fn new(device: &wgpu::Device) -> Self {
        DrawingPasses { pipeline: pipeline(device, &module(device), "draw_strands") }
    }
}

/// The particles of the last two steps in head space, which [`GpuDrawing`] interpolates:
/// two buffers that swap roles at each [`Published::publish`].
pub(crate) struct Published {
    pipeline: wgpu::ComputePipeline,
    uniform: wgpu::Buffer,
    locals: [wgpu::Buffer; 2],
    /// `groups[k]` writes `locals[k]`.
    groups: [wgpu::BindGroup; 2],
    /// Which of `locals` holds the last step.
    pub latest: usize,
    /// Slots in each of `locals`, as in the solver's planes.
    slots: u32,
}

impl Published {
    /// Room for two steps of the `slots` of `positions` (the solver's buffer), laid out as it is.
    pub fn new(device: &wgpu::Device, positions: &wgpu::Buffer, slots: usize) -> Self {
        let pipeline = pipeline(device, &module(device), "publish_local");
        let uniform = uniform_buffer(device);
        let locals = [0, 1].map(|k| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(if k == 0 { "hair_gpu head space A" } else { "hair_gpu head space B" }),
                size: (slots.max(1) * 16) as u64,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            })
        });
        let groups = [0, 1].map(|k| bind_group(device, &pipeline, &[(0, &uniform), (1, positions), (4, &locals[k])]));
        Published { pipeline, uniform, locals, groups, latest: 0, slots: slots as u32 }
    }

    /// Keeps the particles as they are now in the head's frame (the solver's positions
    /// under `pose`, its head pose) as the last step's; the last becomes the one before.
    pub fn publish(&mut self, recorder: &mut Recorder, counts: [u32; 2], pose: Pose) {
        self.latest = 1 - self.latest;
        let inverse = glam::Mat3::from_quat(pose.rotation).transpose();
        let placement = Placement::new(inverse, -(inverse * pose.translation), counts, 0.0);
        recorder.upload(&self.uniform, bytemuck::bytes_of(&placement));
        recorder.dispatch("hair_gpu publish", &self.pipeline, (&self.groups[self.latest], &[]), self.slots);
    }
}

/// Writes [`GpuStrands`] into a renderer's buffer as they are drawn in a frame, on the GPU:
/// one `vec4` per particle (strand by strand, `w` = 1), interpolated between the last two
/// steps in the head's frame and placed on the head as posed in the frame (the roots where
/// the rest shape pins them), then one `vec4` per particle with its parallel-transport
/// frame vector `u` (`w` = 0), as `hair_sim::groom::transport_frames` makes them.
pub struct GpuDrawing {
    pipeline: wgpu::ComputePipeline,
    uniform: wgpu::Buffer,
    /// `groups[k]` reads `Published::locals[k]` as the last step.
    groups: [wgpu::BindGroup; 2],
    /// The strands it was made for ([`GpuStrands::id`]).
    strands: u64,
    _alive: Alive,
}

impl std::fmt::Debug for GpuDrawing {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuDrawing").field("strands", &self.strands).finish_non_exhaustive()
    }
}

impl GpuDrawing {
    /// Draws `strands` into `target`, which needs `STORAGE` use and room for two `vec4`
    /// per particle; `root_u` is each strand's frame vector at its root, in head space.
    /// Compiled for it alone.
    pub fn new(strands: &GpuStrands, root_u: &[Vec3], target: &wgpu::Buffer) -> Result<Self, GpuError> {
        Self::with_passes(strands, &DrawingPasses::new(&strands.device), root_u, target)
    }

    /// [`Self::new`] on passes compiled before.
    pub fn with_passes(
        strands: &GpuStrands,
        passes: &DrawingPasses,
        root_u: &[Vec3],
        target: &wgpu::Buffer,
    ) -> Result<Self, GpuError> {
        let [count, n] = strands.counts();
        let needed = 2 * u64::from(count * n) * 16;
        if target.size() < needed || !target.usage().contains(wgpu::BufferUsages::STORAGE) {
            return Err(GpuError::DrawTarget { bytes: target.size(), needed });
        }
        if root_u.len() != count as usize {
            return Err(GpuError::RootCount { given: root_u.len(), expected: count as usize });
        }
        let device = &strands.device;
        let pipeline = passes.pipeline.clone();
        let uniform = uniform_buffer(device);
        let roots: Vec<[f32; 4]> = root_u.iter().map(|u| [u.x, u.y, u.z, 0.0]).collect();
        let root_u =
            storage_buffer(device, "hair_gpu root frames u", bytemuck::cast_slice(&roots), wgpu::BufferUsages::empty());
        let published = &strands.published;
        let groups = [0, 1].map(|k| {
            bind_group(
                device,
                &pipeline,
                &[
                    (0, &uniform),
                    (2, &strands.rest),
                    (3, &published.locals[1 - k]),
                    (4, &published.locals[k]),
                    (5, &root_u),
                    (6, target),
                ],
            )
        });
        Ok(GpuDrawing { pipeline, uniform, groups, strands: strands.id, _alive: Alive::new(&LIVE_DRAWINGS) })
    }

    /// Whether this drawing was made for `strands`.
    pub fn draws(&self, strands: &GpuStrands) -> bool {
        self.strands == strands.id
    }

    /// Queues the frame's drawing of `strands` (those it was made for), `overstep` of the
    /// way (0..1) from the step before the last to the last, on the head as posed by
    /// `pose` (world from head): submitted with what the strands recorded before it, or
    /// left with it for the caller ([`crate::Submission::Caller`]).
    pub fn draw(&self, strands: &GpuStrands, overstep: f32, pose: Pose) -> Result<(), GpuError> {
        if !self.draws(strands) {
            return Err(GpuError::OtherStrands);
        }
        let placement =
            Placement::new(glam::Mat3::from_quat(pose.rotation), pose.translation, strands.counts(), overstep);
        // After whatever the strands recorded (a step, their roots moved), in one submission.
        let mut recorder = strands.lock();
        recorder.upload(&self.uniform, bytemuck::bytes_of(&placement));
        let group = &self.groups[strands.published.latest];
        recorder.dispatch("hair_gpu draw", &self.pipeline, (group, &[]), strands.counts()[0]);
        recorder.flush(&strands.queue);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_drawing_shader_validates_and_matches_its_uniform() {
        let source = format!("{CURVE_SHADER}\n{DRAW_SHADER}");
        assert_eq!(crate::pass::validated_struct_size(&source, "Placement"), size_of::<Placement>());
    }
}
