//! Deep opacity maps built on the GPU ([`GpuOpacityMap`]) from particles already in GPU
//! memory (the drawing pass's positions): `hair_sim::shadow::OpacityMap::build` as
//! compute passes (`shadow.wgsl`), written where the hair shader reads the map, so a groom
//! the GPU steps needs no copy back to be shadowed.

use crate::pass::{SharedLayout, storage};
use crate::recorder::dispatch_over;
use crate::{GpuError, WORKGROUP_SIZE};
use bytemuck::{Pod, Zeroable};
use hair_sim::shadow::{Fibres, LightSource, MAP_LAYERS, MAP_SIZE};

/// The passes' WGSL (the solver's `layout.wgsl` for the dispatch helpers, then
/// `shadow.wgsl`).
pub const SHADOW_SHADER: &str = concat!(include_str!("layout.wgsl"), "\n", include_str!("shadow.wgsl"));

/// Floats of one map as [`GpuOpacityMap::record`] writes it: a header of five `vec4`
/// (the light, right with the corner's u, up with its v, forward with the cells per unit,
/// the first layer), each cell's nearest depth, then the coverage slice by slice. The
/// light's `w` is -1 where there was nothing to map.
pub const MAP_FLOATS: usize = 20 + MAP_SIZE * MAP_SIZE * (1 + MAP_LAYERS);

/// Words of `shadow.wgsl`'s `work` buffer: the frame, bounds and fit, each cell's nearest
/// depth, the deposits.
const WORK_WORDS: usize = 32 + MAP_SIZE * MAP_SIZE * (1 + MAP_LAYERS);

/// `shadow.wgsl`'s `Light`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct LightUniform {
    source: [f32; 4],
    fibres: [f32; 4],
    counts: [u32; 4],
}

/// The passes, in the order they run, and how many invocations each takes.
#[derive(Clone, Copy)]
enum Invocations {
    Cells,
    Particles,
    One,
}

const PASSES: [(&str, Invocations); 8] = [
    ("prepare", Invocations::Cells),
    ("sum_points", Invocations::Particles),
    ("frame", Invocations::One),
    ("bounds", Invocations::Particles),
    ("fit", Invocations::One),
    ("nearest", Invocations::Particles),
    ("deposit", Invocations::Particles),
    ("write_map", Invocations::Cells),
];

/// The opacity map's compiled passes, for any number of [`GpuOpacityMap`]s: compiling
/// takes long, binding buffers to them does not.
#[derive(Clone)]
pub struct OpacityMapPasses {
    layout: SharedLayout,
    pipelines: Vec<wgpu::ComputePipeline>,
}

impl OpacityMapPasses {
    /// Compiles the passes on `device`.
    pub fn new(device: &wgpu::Device) -> Self {
        let uniform_type = wgpu::BufferBindingType::Uniform;
        let bindings = [
            (uniform_type, false),
            (storage(true), false),
            (storage(false), false),
            (storage(false), false),
            (storage(false), false),
        ];
        let entry_points = PASSES.iter().map(|(entry_point, _)| *entry_point);
        let (layout, pipelines) =
            SharedLayout::compile(device, "hair_gpu opacity map", SHADOW_SHADER, &bindings, entry_points);
        OpacityMapPasses { layout, pipelines }
    }
}

/// Builds one light's opacity map of the particles in a buffer, into a buffer, on the GPU.
pub struct GpuOpacityMap {
    pipelines: Vec<wgpu::ComputePipeline>,
    group: wgpu::BindGroup,
    uniform: wgpu::Buffer,
    work: wgpu::Buffer,
    /// Room for this many particles.
    capacity: u32,
}

impl GpuOpacityMap {
    /// The passes for up to `capacity` particles read from `points` (one `vec4` per
    /// particle, strand-major, `xyz` the position: what [`crate::GpuDrawing`] writes
    /// first), writing into `target` (`STORAGE` use, floats), compiled for it alone.
    pub fn new(
        device: &wgpu::Device,
        points: &wgpu::Buffer,
        capacity: u32,
        target: &wgpu::Buffer,
    ) -> Result<Self, GpuError> {
        Self::with_passes(device, &OpacityMapPasses::new(device), points, capacity, target)
    }

    /// [`Self::new`] on passes compiled before.
    pub fn with_passes(
        device: &wgpu::Device,
        passes: &OpacityMapPasses,
        points: &wgpu::Buffer,
        capacity: u32,
        target: &wgpu::Buffer,
    ) -> Result<Self, GpuError> {
        if !target.usage().contains(wgpu::BufferUsages::STORAGE) {
            return Err(GpuError::DrawTarget { bytes: target.size(), needed: (MAP_FLOATS * 4) as u64 });
        }
        let OpacityMapPasses { layout, pipelines } = passes;
        let pipelines = pipelines.clone();
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hair_gpu opacity map light"),
            size: size_of::<LightUniform>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let storage = |label, bytes: u64| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes.max(16),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let work = storage("hair_gpu opacity map work", (WORK_WORDS * 4) as u64);
        let partials = storage("hair_gpu opacity map sums", u64::from(capacity.div_ceil(WORKGROUP_SIZE)) * 16);
        let buffers = [&uniform, points, &work, &partials, target];
        let group =
            layout.bind(device, "hair_gpu opacity map", buffers.iter().map(|b| b.as_entire_binding()).collect());
        Ok(GpuOpacityMap { pipelines, group, uniform, work, capacity })
    }

    /// Records the map of the `strands` × `particles_per_strand` particles toward `light`,
    /// each standing for `fibres`, written into the target from float `offset` on
    /// ([`MAP_FLOATS`] of them). The light goes to the GPU through `queue` (before the
    /// recorded passes run, as any write the queue takes before a submission).
    pub fn record(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        light: LightSource,
        [strands, particles_per_strand]: [u32; 2],
        fibres: Fibres,
        offset: u32,
    ) -> Result<(), GpuError> {
        let particles = strands * particles_per_strand;
        if particles > self.capacity {
            return Err(GpuError::RootCount { given: particles as usize, expected: self.capacity as usize });
        }
        let source = match light {
            LightSource::Direction(d) => [d.x, d.y, d.z, 0.0],
            LightSource::Position(p) => [p.x, p.y, p.z, 1.0],
        };
        let uniform = LightUniform {
            source,
            fibres: [fibres.root_width, fibres.tip_width, fibres.strands_per_guide, 0.0],
            counts: [strands, particles_per_strand, offset, 0],
        };
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&uniform));
        encoder.clear_buffer(&self.work, 0, None);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("hair_gpu opacity map"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &self.group, &[]);
        for (pipeline, (_, invocations)) in self.pipelines.iter().zip(PASSES) {
            pass.set_pipeline(pipeline);
            match invocations {
                Invocations::Cells => dispatch_over(&mut pass, (MAP_SIZE * MAP_SIZE) as u32),
                Invocations::Particles => dispatch_over(&mut pass, particles),
                Invocations::One => pass.dispatch_workgroups(1, 1, 1),
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shadow_shader_validates_and_matches_its_uniform() {
        let light = crate::pass::validated_struct_size(SHADOW_SHADER, "Light");
        assert_eq!(light, size_of::<LightUniform>());
    }
}
