//! The blended strands' draw order sorted on the GPU ([`GpuDrawOrder`]) from particles
//! already in GPU memory: `hair_sim::draw_order::back_to_front` as a bitonic sort
//! (`sort.wgsl`), written where the hair shader reads the order.

use crate::recorder::dispatch_over;
use crate::{GpuError, GpuStrands};
use bytemuck::{Pod, Zeroable};
use hair_sim::draw_order::pieces_per_strand;
use hair_sim::math::Vec3;

/// The passes' WGSL (the solver's `layout.wgsl` for the dispatch helpers, then `sort.wgsl`).
pub const SORT_SHADER: &str = concat!(include_str!("layout.wgsl"), "\n", include_str!("sort.wgsl"));

/// `sort.wgsl`'s `Order`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct OrderUniform {
    eye: [f32; 4],
    counts: [u32; 4],
    extent: [u32; 4],
}

/// Sorts the pieces of up to a number of strands back to front on the GPU.
pub struct GpuDrawOrder {
    keys_pass: wgpu::ComputePipeline,
    step_pass: wgpu::ComputePipeline,
    write_pass: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    uniform: wgpu::Buffer,
    /// The bitonic network's steps, one `(k, j)` per `stride` bytes.
    steps: u32,
    stride: u32,
    /// Keys sorted: the pieces it has room for, rounded up to a power of two.
    extent: u32,
}

impl GpuDrawOrder {
    /// The passes for up to `pieces` pieces of the strands in `points` (one `vec4` per
    /// particle, strand-major: what [`crate::GpuDrawing`] writes first), writing the order
    /// into `target` (`STORAGE` use, floats: the pieces' numbers).
    pub fn new(
        device: &wgpu::Device,
        points: &wgpu::Buffer,
        pieces: u32,
        target: &wgpu::Buffer,
    ) -> Result<Self, GpuError> {
        if !target.usage().contains(wgpu::BufferUsages::STORAGE) {
            return Err(GpuError::DrawTarget { bytes: target.size(), needed: u64::from(pieces) * 4 });
        }
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("hair_gpu sort.wgsl"),
            source: wgpu::ShaderSource::Wgsl(SORT_SHADER.into()),
        });
        let buffer_entry = |binding, ty, has_dynamic_offset| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset, min_binding_size: None },
            count: None,
        };
        let storage = |read_only| wgpu::BufferBindingType::Storage { read_only };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hair_gpu draw order"),
            entries: &[
                buffer_entry(0, wgpu::BufferBindingType::Uniform, false),
                buffer_entry(1, storage(true), false),
                buffer_entry(2, storage(false), false),
                buffer_entry(3, storage(false), false),
                buffer_entry(4, wgpu::BufferBindingType::Uniform, true),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hair_gpu draw order"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = |entry_point: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry_point),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry_point),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let extent = pieces.max(2).next_power_of_two();
        // The network: for each block size k, each compare distance j from k/2 down to 1.
        let mut network = Vec::new();
        let mut k = 2;
        while k <= extent {
            let mut j = k / 2;
            while j > 0 {
                network.push([k, j]);
                j /= 2;
            }
            k *= 2;
        }
        let stride = device.limits().min_uniform_buffer_offset_alignment.max(8);
        let mut bytes = vec![0u8; network.len() * stride as usize];
        for (entry, [k, j]) in bytes.chunks_exact_mut(stride as usize).zip(&network) {
            entry[..4].copy_from_slice(&k.to_le_bytes());
            entry[4..8].copy_from_slice(&j.to_le_bytes());
        }
        use wgpu::util::DeviceExt;
        let steps = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("hair_gpu draw order network"),
            contents: &bytes,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hair_gpu draw order"),
            size: size_of::<OrderUniform>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let keys = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hair_gpu draw order keys"),
            size: u64::from(extent) * 8,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let step_binding = wgpu::BufferBinding { buffer: &steps, offset: 0, size: wgpu::BufferSize::new(8) };
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("hair_gpu draw order"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: points.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: keys.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: target.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::Buffer(step_binding) },
            ],
        });
        Ok(GpuDrawOrder {
            keys_pass: pipeline("keys_of_pieces"),
            step_pass: pipeline("sort_step"),
            write_pass: pipeline("write_order"),
            group,
            uniform,
            steps: network.len() as u32,
            stride,
            extent,
        })
    }

    /// Records the order of the pieces (`segments_per_piece` segments each) of the
    /// `strands` × `particles_per_strand` particles, back to front from `eye`, written into
    /// the target from float `offset` on. The parameters go to the GPU through `queue`
    /// (before the recorded passes run).
    #[allow(clippy::too_many_arguments)] // the order's inputs, each its own
    pub fn record(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        eye: Vec3,
        [strands, particles_per_strand]: [u32; 2],
        segments_per_piece: u32,
        offset: u32,
    ) -> Result<(), GpuError> {
        let per_strand = pieces_per_strand(particles_per_strand as usize, segments_per_piece as usize) as u32;
        let pieces = strands * per_strand;
        if pieces > self.extent {
            return Err(GpuError::RootCount { given: pieces as usize, expected: self.extent as usize });
        }
        let uniform = OrderUniform {
            eye: [eye.x, eye.y, eye.z, 0.0],
            counts: [strands, particles_per_strand, segments_per_piece.max(1), per_strand],
            extent: [self.extent, offset, 0, 0],
        };
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&uniform));
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("hair_gpu draw order"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &self.group, &[0]);
        pass.set_pipeline(&self.keys_pass);
        dispatch_over(&mut pass, self.extent);
        pass.set_pipeline(&self.step_pass);
        for step in 0..self.steps {
            pass.set_bind_group(0, &self.group, &[step * self.stride]);
            dispatch_over(&mut pass, self.extent);
        }
        pass.set_bind_group(0, &self.group, &[0]);
        pass.set_pipeline(&self.write_pass);
        dispatch_over(&mut pass, pieces);
        Ok(())
    }
}

impl GpuStrands {
    /// Pieces of `segments_per_piece` segments these strands are cut into for sorting.
    pub fn pieces(&self, segments_per_piece: u32) -> u32 {
        let per_strand = pieces_per_strand(self.particles_per_strand(), segments_per_piece as usize);
        (self.strand_count() * per_strand) as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sort_shader_validates_and_matches_its_uniform() {
        let module = naga::front::wgsl::parse_str(SORT_SHADER).expect("sort.wgsl parses");
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
            .validate(&module)
            .expect("sort.wgsl validates");
        let order = module.types.iter().find(|(_, t)| t.name.as_deref() == Some("Order")).expect("struct Order");
        let naga::TypeInner::Struct { span, .. } = order.1.inner else { panic!("Order is a struct") };
        assert_eq!(span as usize, size_of::<OrderUniform>());
    }
}
