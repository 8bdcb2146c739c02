//! One submission where the calls of a step would make many: [`GpuStrands`](crate::GpuStrands)
//! records each call's uploads and passes into one command encoder, in the order of the
//! calls, and submits them together when something needs them on the GPU (a copy back, a
//! wait, a frame's drawing, or [`GpuStrands::submit`](crate::GpuStrands::submit)), or,
//! where an engine submits ([`Submission::Caller`]), hands them over as one command buffer
//! ([`GpuStrands::take_commands`](crate::GpuStrands::take_commands)).
//!
//! A submission is not free: a driver may make it wait for the queue, which a renderer on
//! another thread shares (lavapipe runs each submission's work in the thread that submits
//! it, after the work submitted before). The uploads go through a staging belt into the
//! same encoder, so that each lands between the passes it was written for; the queue's own
//! `write_buffer` would land before every pass of the submission.

use crate::WORKGROUP_SIZE;

/// Bytes of each staging buffer: a step's uploads (a skinned neck's patch is 232 KB) in one.
const UPLOAD_CHUNK: u64 = 256 * 1024;

/// Submissions any strands made themselves ([`Submission::Own`]), for [`submissions`].
static SUBMISSIONS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// How many times strands in this process submitted their own work to a queue: zero where
/// every caller submits ([`Submission::Caller`], as an engine's render graph does).
pub fn submissions() -> u64 {
    SUBMISSIONS.load(std::sync::atomic::Ordering::Relaxed)
}

/// Who submits what [`GpuStrands`](crate::GpuStrands) records.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Submission {
    /// The strands submit their work themselves when something needs it on the GPU (a
    /// copy back, a wait, a drawing): the standalone API.
    #[default]
    Own,
    /// The caller takes the recorded work ([`GpuStrands::take_commands`](crate::GpuStrands::take_commands))
    /// and submits it with its own (an engine's render graph); the strands never touch the
    /// queue, and a copy back starts mapping only once it is asked whether it arrived,
    /// after that submission.
    Caller,
}

/// Commands recorded since the last submission, and the staging belt of their uploads.
pub(crate) struct Recorder {
    device: wgpu::Device,
    encoder: Option<wgpu::CommandEncoder>,
    belt: wgpu::util::StagingBelt,
    /// Solver steps recorded since the last submission.
    pub steps: u32,
    pub submission: Submission,
    /// The belt's buffers went out with commands the caller submits: they come back
    /// (`StagingBelt::recall`) before the next upload, by when the caller has submitted.
    recall_due: bool,
}

impl Recorder {
    pub fn new(device: &wgpu::Device) -> Self {
        Recorder {
            device: device.clone(),
            encoder: None,
            belt: wgpu::util::StagingBelt::new(device.clone(), UPLOAD_CHUNK),
            steps: 0,
            submission: Submission::Own,
            recall_due: false,
        }
    }

    /// The encoder the next commands go into.
    pub fn encoder(&mut self) -> &mut wgpu::CommandEncoder {
        self.recall();
        open(&mut self.encoder, &self.device)
    }

    /// Writes `bytes` (a multiple of four) at the start of `target` (with `COPY_DST` use),
    /// after the commands recorded so far.
    pub fn upload(&mut self, target: &wgpu::Buffer, bytes: &[u8]) {
        let Some(size) = wgpu::BufferSize::new(bytes.len() as u64) else { return };
        self.recall();
        let encoder = open(&mut self.encoder, &self.device);
        self.belt.write_buffer(encoder, target, 0, size).copy_from_slice(bytes);
    }

    /// One dispatch of `pipeline` over `invocations`, its bind group `group` (with its
    /// dynamic `offsets`, if any).
    pub fn dispatch(
        &mut self,
        label: &str,
        pipeline: &wgpu::ComputePipeline,
        (group, offsets): (&wgpu::BindGroup, &[u32]),
        invocations: u32,
    ) {
        let mut pass = self
            .encoder()
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes: None });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, group, offsets);
        dispatch_over(&mut pass, invocations);
    }

    /// Submits what was recorded, if anything, in one submission.
    pub fn submit(&mut self, queue: &wgpu::Queue) {
        let Some(encoder) = self.encoder.take() else { return };
        self.steps = 0;
        self.belt.finish();
        SUBMISSIONS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        queue.submit([encoder.finish()]);
        self.belt.recall();
    }

    /// Submits what was recorded if the strands submit their own work; else leaves it for
    /// the caller ([`Self::take`]).
    pub fn flush(&mut self, queue: &wgpu::Queue) {
        if self.submission == Submission::Own {
            self.submit(queue);
        }
    }

    /// What was recorded, if anything, as one command buffer for the caller to submit.
    pub fn take(&mut self) -> Option<wgpu::CommandBuffer> {
        let encoder = self.encoder.take()?;
        self.steps = 0;
        self.belt.finish();
        self.recall_due = true;
        Some(encoder.finish())
    }

    /// Takes the belt's buffers back once the commands that used them went out.
    fn recall(&mut self) {
        if std::mem::take(&mut self.recall_due) {
            self.belt.recall();
        }
    }
}

/// Workgroups a dimension of a dispatch holds on every device (WebGPU's minimum).
const MAX_WORKGROUPS_PER_DIMENSION: u32 = 65_535;

/// Dispatches the pipeline set in `pass` over `invocations` (a shader's `invocation`),
/// in rows of workgroups where one row cannot hold them (65,536 strands of 64 particles
/// are 65,536 workgroups of particles).
pub(crate) fn dispatch_over(pass: &mut wgpu::ComputePass<'_>, invocations: u32) {
    let [x, y] = workgroups(invocations);
    pass.dispatch_workgroups(x, y, 1);
}

/// Workgroups along x and y for `invocations`: as few rows as hold them, as short as they
/// can be.
pub(crate) fn workgroups(invocations: u32) -> [u32; 2] {
    let groups = invocations.div_ceil(WORKGROUP_SIZE);
    let rows = groups.div_ceil(MAX_WORKGROUPS_PER_DIMENSION).max(1);
    [groups.div_ceil(rows), rows]
}

/// The encoder in `encoder`, made if there is none.
fn open<'a>(encoder: &'a mut Option<wgpu::CommandEncoder>, device: &wgpu::Device) -> &'a mut wgpu::CommandEncoder {
    encoder.get_or_insert_with(|| {
        device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("hair_gpu") })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_dispatch_covers_its_invocations_in_rows_a_device_can_take() {
        for invocations in [0, 1, 64, 65, 4_194_240, 4_194_304, 65_536 * 64 * 3 + 5, u32::MAX / 2] {
            let [x, y] = workgroups(invocations);
            assert!(x <= MAX_WORKGROUPS_PER_DIMENSION && y <= MAX_WORKGROUPS_PER_DIMENSION, "{invocations}: {x} × {y}");
            let covered = u64::from(x) * u64::from(y) * u64::from(WORKGROUP_SIZE);
            assert!(covered >= u64::from(invocations), "{invocations}: {covered}");
            // Past the workgroups needed, at most one in each row.
            assert!(covered - u64::from(invocations) < u64::from(y + 1) * u64::from(WORKGROUP_SIZE), "{invocations}");
        }
        assert_eq!(workgroups(64 * 65_535), [65_535, 1]);
        assert_eq!(workgroups(64 * 65_536), [32_768, 2]);
    }
}
