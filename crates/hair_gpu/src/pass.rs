//! The small compute passes beside the solver's step (drawing, roots, the translation,
//! opacity maps, the draw order): a pipeline from one entry point and a bind group of
//! whole buffers, either on the layout the shader implies or on one [`SharedLayout`] that
//! every entry point of a module binds the same way.

/// A compute pipeline for `entry_point`, its bind group layout derived from the shader.
pub(crate) fn pipeline(device: &wgpu::Device, module: &wgpu::ShaderModule, entry_point: &str) -> wgpu::ComputePipeline {
    pipeline_on(device, None, module, entry_point)
}

/// A compute pipeline for `entry_point` on `layout` (`None`: the one the shader implies).
fn pipeline_on(
    device: &wgpu::Device,
    layout: Option<&wgpu::PipelineLayout>,
    module: &wgpu::ShaderModule,
    entry_point: &str,
) -> wgpu::ComputePipeline {
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry_point),
        layout,
        module,
        entry_point: Some(entry_point),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// One bind group layout of buffers for every entry point of a module (each uses its
/// share of the buffers), so that one bind group serves all its passes: an implied layout
/// holds only what its own entry point uses, and fits no other pipeline.
#[derive(Clone)]
pub(crate) struct SharedLayout {
    group: wgpu::BindGroupLayout,
    pipeline: wgpu::PipelineLayout,
}

impl SharedLayout {
    /// Binding `k` is a buffer of `bindings[k]`'s type, with a dynamic offset where its flag
    /// says so.
    pub fn new(device: &wgpu::Device, label: &str, bindings: &[(wgpu::BufferBindingType, bool)]) -> Self {
        let entries: Vec<_> = bindings
            .iter()
            .enumerate()
            .map(|(binding, &(ty, has_dynamic_offset))| wgpu::BindGroupLayoutEntry {
                binding: binding as u32,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset, min_binding_size: None },
                count: None,
            })
            .collect();
        let group =
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries: &entries });
        let pipeline = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: &[Some(&group)],
            immediate_size: 0,
        });
        SharedLayout { group, pipeline }
    }

    /// `source` compiled as `label`, one pipeline per entry point of `entry_points`, all on
    /// one layout of `bindings` ([`Self::new`]).
    pub fn compile<'a>(
        device: &wgpu::Device,
        label: &str,
        source: &str,
        bindings: &[(wgpu::BufferBindingType, bool)],
        entry_points: impl IntoIterator<Item = &'a str>,
    ) -> (Self, Vec<wgpu::ComputePipeline>) {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(label),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        let layout = SharedLayout::new(device, label, bindings);
        let pipelines =
            entry_points.into_iter().map(|entry_point| layout.pipeline(device, &module, entry_point)).collect();
        (layout, pipelines)
    }

    /// The pipeline of `entry_point` on this layout.
    pub fn pipeline(
        &self,
        device: &wgpu::Device,
        module: &wgpu::ShaderModule,
        entry_point: &str,
    ) -> wgpu::ComputePipeline {
        pipeline_on(device, Some(&self.pipeline), module, entry_point)
    }

    /// The bind group of `resources`, binding `k` the `k`-th.
    pub fn bind(
        &self,
        device: &wgpu::Device,
        label: &str,
        resources: Vec<wgpu::BindingResource<'_>>,
    ) -> wgpu::BindGroup {
        let entries: Vec<_> = resources
            .into_iter()
            .enumerate()
            .map(|(binding, resource)| wgpu::BindGroupEntry { binding: binding as u32, resource })
            .collect();
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout: &self.group,
            entries: &entries,
        })
    }
}

/// The storage buffer type, read-only or not.
pub(crate) fn storage(read_only: bool) -> wgpu::BufferBindingType {
    wgpu::BufferBindingType::Storage { read_only }
}

/// `source` parsed and validated by naga, for the shaders' tests.
#[cfg(test)]
pub(crate) fn validated(source: &str) -> naga::Module {
    let module = naga::front::wgsl::parse_str(source).expect("the shader parses");
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
        .validate(&module)
        .expect("the shader validates");
    module
}

/// The size of struct `name` in a validated `source`: what a uniform packed on the CPU
/// must match.
#[cfg(test)]
pub(crate) fn validated_struct_size(source: &str, name: &str) -> usize {
    let module = validated(source);
    let found = module.types.iter().find(|(_, t)| t.name.as_deref() == Some(name)).expect("the struct");
    let naga::TypeInner::Struct { span, .. } = found.1.inner else { panic!("{name} is a struct") };
    span as usize
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
