//! The device the strands step on ([`GpuContext`]) and what can go wrong there ([`GpuError`]).

use crate::WORKGROUP_SIZE;

/// What went wrong on the GPU path.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter could be found (no GPU, no driver, no Vulkan loader).
    #[error("no GPU adapter ({0}); install mesa-vulkan-drivers and libvulkan1 for lavapipe")]
    NoAdapter(String),
    /// The adapter would not open a device.
    #[error("the GPU adapter would not open a device: {0}")]
    Device(String),
    /// The adapter lacks compute shaders or storage buffers.
    #[error("the GPU adapter {0:?} cannot run compute shaders over storage buffers")]
    NoCompute(String),
    /// The step asks for head collision, but no collider was uploaded.
    #[error("the step collides with a head, but the GPU strands were built without its collider")]
    NoCollider,
    /// The groom is too large for one buffer on this device.
    #[error("{particles} particles need a {bytes}-byte buffer, above this device's limit of {limit}")]
    TooLarge {
        /// Particles in the groom.
        particles: usize,
        /// The buffer it needs, bytes.
        bytes: u64,
        /// The largest storage buffer the device binds, bytes.
        limit: u64,
    },
    /// A renderer's buffer is too small for [`GpuDrawing`](crate::GpuDrawing) (or cannot be bound for storage).
    #[error("the drawing buffer has {bytes} bytes where {needed} are needed, with storage use")]
    DrawTarget {
        /// The buffer's size, bytes.
        bytes: u64,
        /// What the strands need, bytes.
        needed: u64,
    },
    /// A [`GpuDrawing`](crate::GpuDrawing) was given a root frame per strand for another strand count.
    #[error("{given} root frames given for {expected} strands")]
    RootCount {
        /// Root frames given.
        given: usize,
        /// Strands drawn.
        expected: usize,
    },
    /// A [`GpuDrawing`](crate::GpuDrawing) was asked to draw strands other than those it was made for.
    #[error("this drawing was made for other GPU strands")]
    OtherStrands,
    /// Reading the positions back failed.
    #[error("reading the positions back from the GPU failed: {0}")]
    ReadBack(String),
}

/// A wgpu device and queue to step on, and the adapter's description.
pub struct GpuContext {
    /// The device the buffers and pipeline live on.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// The adapter (its name, driver and backend), for reports.
    pub adapter: wgpu::AdapterInfo,
    /// Whether the device can time passes with timestamp queries.
    pub timestamps: bool,
}

impl GpuContext {
    /// The default adapter without a window (lavapipe on a machine without a GPU), with
    /// timestamp queries where it has them.
    pub fn headless() -> Result<Self, GpuError> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = futures_lite::future::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            ..Default::default()
        }))
        .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        let info = adapter.get_info();
        let limits = adapter.limits();
        let downlevel = adapter.get_downlevel_capabilities();
        if !downlevel.flags.contains(wgpu::DownlevelFlags::COMPUTE_SHADERS) || !can_step(&limits) {
            return Err(GpuError::NoCompute(info.name));
        }
        let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let (device, queue) = futures_lite::future::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("hair_gpu"),
            required_features: if timestamps { wgpu::Features::TIMESTAMP_QUERY } else { wgpu::Features::empty() },
            // All the adapter has: large grooms want large storage buffers.
            required_limits: limits,
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device(e.to_string()))?;
        Ok(GpuContext { device, queue, adapter: info, timestamps })
    }

    /// A device someone else opened (an engine's render device), if its limits let the
    /// solver run: compute workgroups of 64 and eight storage buffers per stage. Steps are
    /// timed where it was opened with timestamp queries.
    pub fn new(device: wgpu::Device, queue: wgpu::Queue, adapter: wgpu::AdapterInfo) -> Result<Self, GpuError> {
        if !can_step(&device.limits()) {
            return Err(GpuError::NoCompute(adapter.name));
        }
        let timestamps = device.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        Ok(GpuContext { device, queue, adapter, timestamps })
    }
}

/// Whether `limits` let the step shader (`step/`) run: 64 invocations per workgroup and its eight
/// storage buffers (a device without compute reports zero invocations).
pub(crate) fn can_step(limits: &wgpu::Limits) -> bool {
    limits.max_compute_invocations_per_workgroup >= WORKGROUP_SIZE
        && limits.max_compute_workgroup_size_x >= WORKGROUP_SIZE
        && limits.max_storage_buffers_per_shader_stage >= 8
}
