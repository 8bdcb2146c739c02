//! The small compute passes beside the solver's step (drawing, roots, the translation):
//! a pipeline from one entry point and a bind group of whole buffers (dispatched through
//! the strands' `Recorder`).

/// A compute pipeline for `entry_point`, its bind group layout derived from the shader.
pub(crate) fn pipeline(device: &wgpu::Device, module: &wgpu::ShaderModule, entry_point: &str) -> wgpu::ComputePipeline {
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry_point),
        layout: None,
        module,
        entry_point: Some(entry_point),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// A bind group of whole buffers for `pipeline`'s group 0, by binding number.
pub(crate) fn bind_group(
    device: &wgpu::Device,
    pipeline: &wgpu::ComputePipeline,
    buffers: &[(u32, &wgpu::Buffer)],
) -> wgpu::BindGroup {
    let entries: Vec<_> = buffers
        .iter()
        .map(|&(binding, buffer)| wgpu::BindGroupEntry { binding, resource: buffer.as_entire_binding() })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("hair_gpu pass"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    })
}
