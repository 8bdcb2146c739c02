//! One submission where the calls of a step would make many: [`GpuStrands`](crate::GpuStrands)
//! records each call's uploads and passes into one command encoder, in the order of the
//! calls, and submits them together when something needs them on the GPU (a copy back, a
//! wait, a frame's drawing, or [`GpuStrands::submit`](crate::GpuStrands::submit)).
//!
//! A submission is not free: a driver may make it wait for the queue, which a renderer on
//! another thread shares (lavapipe runs each submission's work in the thread that submits
//! it, after the work submitted before). The uploads go through a staging belt into the
//! same encoder, so that each lands between the passes it was written for; the queue's own
//! `write_buffer` would land before every pass of the submission.

use crate::WORKGROUP_SIZE;

/// Bytes of each staging buffer: a step's uploads (a skinned neck's patch is 232 KB) in one.
const UPLOAD_CHUNK: u64 = 256 * 1024;

/// Commands recorded since the last submission, and the staging belt of their uploads.
pub(crate) struct Recorder {
    device: wgpu::Device,
    encoder: Option<wgpu::CommandEncoder>,
    belt: wgpu::util::StagingBelt,
    /// Solver steps recorded since the last submission.
    pub steps: u32,
}

impl Recorder {
    pub fn new(device: &wgpu::Device) -> Self {
        Recorder {
            device: device.clone(),
            encoder: None,
            belt: wgpu::util::StagingBelt::new(device.clone(), UPLOAD_CHUNK),
            steps: 0,
        }
    }

    /// The encoder the next commands go into.
    pub fn encoder(&mut self) -> &mut wgpu::CommandEncoder {
        open(&mut self.encoder, &self.device)
    }

    /// Writes `bytes` (a multiple of four) at the start of `target` (with `COPY_DST` use),
    /// after the commands recorded so far.
    pub fn upload(&mut self, target: &wgpu::Buffer, bytes: &[u8]) {
        let Some(size) = wgpu::BufferSize::new(bytes.len() as u64) else { return };
        let encoder = open(&mut self.encoder, &self.device);
        self.belt.write_buffer(encoder, target, 0, size).copy_from_slice(bytes);
    }

    /// One dispatch of `pipeline` over `invocations`, its bind group `group`.
    pub fn dispatch(
        &mut self,
        label: &str,
        pipeline: &wgpu::ComputePipeline,
        group: &wgpu::BindGroup,
        invocations: u32,
    ) {
        let mut pass = self
            .encoder()
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes: None });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, group, &[]);
        pass.dispatch_workgroups(invocations.div_ceil(WORKGROUP_SIZE), 1, 1);
    }

    /// Submits what was recorded, if anything, in one submission.
    pub fn submit(&mut self, queue: &wgpu::Queue) {
        let Some(encoder) = self.encoder.take() else { return };
        self.steps = 0;
        self.belt.finish();
        queue.submit([encoder.finish()]);
        self.belt.recall();
    }
}

/// The encoder in `encoder`, made if there is none.
fn open<'a>(encoder: &'a mut Option<wgpu::CommandEncoder>, device: &wgpu::Device) -> &'a mut wgpu::CommandEncoder {
    encoder.get_or_insert_with(|| {
        device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("hair_gpu") })
    })
}
