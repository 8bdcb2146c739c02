//! The blended strands' draw order sorted on the GPU ([`GpuDrawOrder`]) from particles
//! already in GPU memory: `hair_sim::draw_order::back_to_front` as a bitonic sort
//! (`sort.wgsl`), written where the hair shader reads the order.

use crate::pass::{SharedLayout, storage};
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

/// The sort's compiled passes, for any number of [`GpuDrawOrder`]s: compiling takes long,
/// binding buffers to them does not.
#[derive(Clone)]
pub struct DrawOrderPasses {
    layout: SharedLayout,
    keys_pass: wgpu::ComputePipeline,
    step_pass: wgpu::ComputePipeline,
    write_pass: wgpu::ComputePipeline,
}

impl DrawOrderPasses {
    /// Compiles the passes on `device`.
    pub fn new(device: &wgpu::Device) -> Self {
        let uniform_type = wgpu::BufferBindingType::Uniform;
        let bindings = [
            (uniform_type, false),
            (storage(true), false),
            (storage(false), false),
            (storage(false), false),
            (uniform_type, true),
        ];
        let entry_points = ["keys_of_pieces", "sort_step", "write_order"];
        let (layout, pipelines) =
            SharedLayout::compile(device, "hair_gpu draw order", SORT_SHADER, &bindings, entry_points);
        let [keys_pass, step_pass, write_pass] = pipelines.try_into().expect("three entry points");
        DrawOrderPasses { layout, keys_pass, step_pass, write_pass }
    }
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
    /// into `target` (`STORAGE` use, floats: the pieces' numbers), compiled for it alone.
    pub fn new(
        device: &wgpu::Device,
        points: &wgpu::Buffer,
        pieces: u32,
        target: &wgpu::Buffer,
    ) -> Result<Self, GpuError> {
        Self::with_passes(device, &DrawOrderPasses::new(device), points, pieces, target)
    }

    /// [`Self::new`] on passes compiled before.
    pub fn with_passes(
        device: &wgpu::Device,
        passes: &DrawOrderPasses,
        points: &wgpu::Buffer,
        pieces: u32,
        target: &wgpu::Buffer,
    ) -> Result<Self, GpuError> {
        if !target.usage().contains(wgpu::BufferUsages::STORAGE) {
            return Err(GpuError::DrawTarget { bytes: target.size(), needed: u64::from(pieces) * 4 });
        }
        let layout = &passes.layout;
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
        let resources = vec![
            uniform.as_entire_binding(),
            points.as_entire_binding(),
            keys.as_entire_binding(),
            target.as_entire_binding(),
            wgpu::BindingResource::Buffer(step_binding),
        ];
        let group = layout.bind(device, "hair_gpu draw order", resources);
        Ok(GpuDrawOrder {
            keys_pass: passes.keys_pass.clone(),
            step_pass: passes.step_pass.clone(),
            write_pass: passes.write_pass.clone(),
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
        assert_eq!(crate::pass::validated_struct_size(SORT_SHADER, "Order"), size_of::<OrderUniform>());
    }
}
