//! Deep opacity maps built on the GPU ([`GpuOpacityMap`]) from particles already in GPU
//! memory (the drawing pass's positions): `hair_sim::shadow::OpacityMap::build` as
//! compute passes (`shadow.wgsl`), written where the hair shader reads the map, so a groom
//! the GPU steps needs no copy back to be shadowed.

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
    /// first), writing into `target` (`STORAGE` use, floats).
    pub fn new(
        device: &wgpu::Device,
        points: &wgpu::Buffer,
        capacity: u32,
        target: &wgpu::Buffer,
    ) -> Result<Self, GpuError> {
        if !target.usage().contains(wgpu::BufferUsages::STORAGE) {
            return Err(GpuError::DrawTarget { bytes: target.size(), needed: (MAP_FLOATS * 4) as u64 });
        }
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("hair_gpu shadow.wgsl"),
            source: wgpu::ShaderSource::Wgsl(SHADOW_SHADER.into()),
        });
        // One layout for every pass (each uses its share of the buffers), so that one bind
        // group serves them all.
        let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty,
            count: None,
        };
        let storage_entry = |binding, read_only| {
            entry(
                binding,
                wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
            )
        };
        let uniform_entry = entry(
            0,
            wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
        );
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hair_gpu opacity map"),
            entries: &[
                uniform_entry,
                storage_entry(1, true),
                storage_entry(2, false),
                storage_entry(3, false),
                storage_entry(4, false),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hair_gpu opacity map"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipelines = PASSES
            .iter()
            .map(|(entry_point, _)| {
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(entry_point),
                    layout: Some(&pipeline_layout),
                    module: &module,
                    entry_point: Some(entry_point),
                    compilation_options: Default::default(),
                    cache: None,
                })
            })
            .collect();
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
        let buffers = [(0, &uniform), (1, points), (2, &work), (3, &partials), (4, target)];
        let entries: Vec<_> = buffers
            .iter()
            .map(|&(binding, buffer)| wgpu::BindGroupEntry { binding, resource: buffer.as_entire_binding() })
            .collect();
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("hair_gpu opacity map"),
            layout: &layout,
            entries: &entries,
        });
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
        let module = naga::front::wgsl::parse_str(SHADOW_SHADER).expect("shadow.wgsl parses");
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
            .validate(&module)
            .expect("shadow.wgsl validates");
        let light = module.types.iter().find(|(_, t)| t.name.as_deref() == Some("Light")).expect("struct Light");
        let naga::TypeInner::Struct { span, .. } = light.1.inner else { panic!("Light is a struct") };
        assert_eq!(span as usize, size_of::<LightUniform>());
    }
}
