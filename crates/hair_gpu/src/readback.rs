//! Copies back to the CPU without waiting ([`PositionsCopy`], [`ReportCopy`]): a buffer
//! copied into a mappable one, mapped when the GPU has run what was submitted before it.

use crate::GpuError;
use crate::layout::Slots;
use hair_sim::math::Vec3;
use hair_sim::solver::StepReport;

/// Positions on their way back to the CPU ([`GpuStrands::copy_positions`](crate::GpuStrands::copy_positions)), in the slots
/// of their layout.
pub struct PositionsCopy(pub(crate) BufferCopy, pub(crate) Slots);

impl PositionsCopy {
    /// Whether the copy has arrived (or failed), waiting for it when `wait`. Where the
    /// caller submits ([`crate::Submission::Caller`]), ask only once it has submitted the
    /// commands the copy was recorded with.
    pub fn arrived(&self, wait: bool) -> bool {
        self.0.arrived(wait)
    }

    /// The positions, strand by strand, waiting for them if they have not arrived.
    pub fn into_positions(self) -> Result<Vec<Vec3>, GpuError> {
        let bytes = self.0.into_bytes()?;
        let vec4s: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
        Ok(self.1.gather(vec4s).iter().map(|v| Vec3::new(v[0], v[1], v[2])).collect())
    }
}

/// A step report on its way back to the CPU ([`GpuStrands::copy_report`](crate::GpuStrands::copy_report)).
pub struct ReportCopy {
    pub(crate) report: BufferCopy,
    /// The last step's timestamps and the queue's nanoseconds per tick, where it has them.
    pub(crate) time: Option<(BufferCopy, f32)>,
}

impl ReportCopy {
    /// Whether the copy has arrived (or failed), waiting for it when `wait`.
    pub fn arrived(&self, wait: bool) -> bool {
        // Both were queued together: both are asked for now, and arrive in the same poll.
        let report = self.report.arrived(wait);
        self.time.as_ref().is_none_or(|(time, _)| time.arrived(wait)) && report
    }

    /// The report and the GPU time of the last step before it (`None` where the device has
    /// no timestamp queries, or no step was timed yet), waiting for them if they have not
    /// arrived.
    pub fn into_timed_report(self) -> Result<(StepReport, Option<StepTime>), GpuError> {
        let time = match self.time {
            Some((time, period)) => StepTime::from_ticks(&time.into_bytes()?, period),
            None => None,
        };
        Ok((Self::sum(&self.report.into_bytes()?), time))
    }

    /// The report of every strand, summed, waiting for it if it has not arrived.
    pub fn into_report(self) -> Result<StepReport, GpuError> {
        Ok(Self::sum(&self.report.into_bytes()?))
    }

    /// Sums the strands' reports.
    fn sum(bytes: &[u8]) -> StepReport {
        let per_strand: &[[[f32; 4]; 2]] = bytemuck::cast_slice(bytes);
        let mut report = StepReport::default();
        for &[[teleports, nans, contacts, depth], [stretches, turns, sleeping, _]] in per_strand {
            report.merge(StepReport {
                teleport_resets: teleports as u32,
                nan_resets: nans as u32,
                contacts: contacts as u32,
                max_depth: depth,
                contact_stretches: stretches as u32,
                segment_turns: turns as u32,
                sleeping: sleeping as u32,
            });
        }
        report
    }
}

/// A buffer copied into a mappable one, on its way to the CPU.
pub(crate) struct BufferCopy {
    device: wgpu::Device,
    staging: wgpu::Buffer,
    /// Where the staging buffer goes once its bytes are taken.
    pool: StagingPool,
    /// Set when the GPU has mapped the copy (or failed to).
    mapped: std::sync::Arc<std::sync::OnceLock<Result<(), wgpu::BufferAsyncError>>>,
    /// Whether the mapping was asked for: on the first question whether the copy arrived,
    /// which comes after the copy's submission (a buffer being mapped may not be submitted,
    /// and where the caller submits, the copy is recorded before it is).
    asked: std::sync::Once,
}

impl BufferCopy {
    /// `staging`, the target of a recorded copy, to be mapped once the copy is submitted;
    /// it goes back to `pool` once read.
    pub fn map(device: &wgpu::Device, staging: wgpu::Buffer, pool: &StagingPool) -> Self {
        let mapped = std::sync::Arc::new(std::sync::OnceLock::new());
        BufferCopy { device: device.clone(), staging, pool: pool.clone(), mapped, asked: std::sync::Once::new() }
    }

    /// Whether the copy has arrived (or failed), waiting for it when `wait`; call it only
    /// once the copy was submitted.
    pub fn arrived(&self, wait: bool) -> bool {
        self.asked.call_once(|| {
            let arrived = self.mapped.clone();
            self.staging.slice(..).map_async(wgpu::MapMode::Read, move |result| _ = arrived.set(result));
        });
        // Once mapped, no poll: a wait is for everything queued on the device (the steps and
        // the frames queued since), not for this copy alone.
        if self.mapped.get().is_some() {
            return true;
        }
        let poll = if wait { wgpu::PollType::wait_indefinitely() } else { wgpu::PollType::Poll };
        // A failed poll leaves the copy unarrived; `into_bytes` reports it.
        let _ = self.device.poll(poll);
        self.mapped.get().is_some()
    }

    /// The bytes, waiting for them if they have not arrived.
    pub fn into_bytes(self) -> Result<Vec<u8>, GpuError> {
        self.arrived(true);
        match self.mapped.get() {
            Some(Ok(())) => {}
            Some(Err(e)) => return Err(GpuError::ReadBack(e.to_string())),
            None => return Err(GpuError::ReadBack("the GPU did not map the copy".into())),
        }
        let bytes = self.staging.slice(..).get_mapped_range().to_vec();
        self.staging.unmap();
        self.pool.give(self.staging);
        Ok(bytes)
    }
}

/// A step's GPU time, from timestamp queries.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepTime {
    /// The whole step, milliseconds: from the start of its first pass (the volume's, where
    /// it is on) to the end of its last.
    pub total_ms: f64,
    /// The volume's grid (splat, cells, pressure, potential and feedback), milliseconds;
    /// `None` in a step without volume.
    pub volume_ms: Option<f64>,
}

impl StepTime {
    /// The time of a step from its resolved timestamps (`bytes`: u64 ticks of `period`
    /// nanoseconds, the step pass's start and end, then the volume's, 0 where not
    /// written); `None` before any step wrote them.
    pub(crate) fn from_ticks(bytes: &[u8], period: f32) -> Option<Self> {
        let tick = |i: usize| {
            let tick = u64::from_le_bytes(bytes.get(8 * i..8 * i + 8)?.try_into().ok()?);
            (tick != 0).then_some(tick)
        };
        let ms = |start: u64, end: u64| Some(end.checked_sub(start)? as f64 * f64::from(period) * 1e-6);
        let (start, end) = (tick(0)?, tick(1)?);
        let volume = tick(2).zip(tick(3));
        // The volume's pass runs before the step's.
        let first = volume.map_or(start, |(begins, _)| begins.min(start));
        Some(StepTime { total_ms: ms(first, end)?, volume_ms: volume.and_then(|(begins, ends)| ms(begins, ends)) })
    }
}

/// Staging buffers whose bytes were taken, for the next copies back: the plugin copies the
/// positions and the report back every step or two, and each copy would otherwise make a
/// mappable buffer and drop it.
#[derive(Clone, Default)]
pub(crate) struct StagingPool(std::sync::Arc<std::sync::Mutex<Vec<wgpu::Buffer>>>);

impl StagingPool {
    /// Buffers kept at most: a step's copies (positions, report, timestamps) and the next's.
    const KEPT: usize = 6;

    /// Records the copy of the bytes of `buffer` from `offset` on into a mappable buffer of
    /// the pool's (or a new one), which [`BufferCopy::map`] maps once the copy is submitted.
    pub fn record(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        buffer: &wgpu::Buffer,
        offset: u64,
    ) -> wgpu::Buffer {
        let size = buffer.size() - offset;
        let kept = {
            let mut kept = self.0.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            kept.iter().position(|b| b.size() == size).map(|k| kept.swap_remove(k))
        };
        let staging = kept.unwrap_or_else(|| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("hair_gpu read-back"),
                size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        });
        encoder.copy_buffer_to_buffer(buffer, offset, &staging, 0, size);
        staging
    }

    /// Keeps `staging` (unmapped) for a later copy, unless the pool is full.
    fn give(&self, staging: wgpu::Buffer) {
        let mut kept = self.0.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if kept.len() < Self::KEPT {
            kept.push(staging);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::GpuContext;

    fn ticks(ticks: [u64; 4]) -> Vec<u8> {
        ticks.iter().flat_map(|t| t.to_le_bytes()).collect()
    }

    /// A step's time runs from its first pass's start, the volume's where it ran, to the
    /// step pass's end; ticks not written (0) are no time.
    #[test]
    fn a_steps_time_counts_the_volume_in_it() {
        let period = 0.5; // ns per tick
        let time = |t: [u64; 4]| StepTime::from_ticks(&ticks(t), period);
        assert_eq!(time([0; 4]), None, "no step timed yet");
        assert_eq!(time([1_000_000, 5_000_000, 0, 0]), Some(StepTime { total_ms: 2.0, volume_ms: None }));
        let with_volume = time([3_000_000, 5_000_000, 1_000_000, 2_000_000]);
        assert_eq!(with_volume, Some(StepTime { total_ms: 2.0, volume_ms: Some(0.5) }));
        assert_eq!(time([5_000_000, 1_000_000, 0, 0]), None, "ticks that run backward are no time");
    }

    /// The GPU context, or `None` (the test skipped, saying why) without an adapter.
    fn gpu() -> Option<GpuContext> {
        match GpuContext::headless() {
            Ok(gpu) => Some(gpu),
            Err(e) if std::env::var_os("BEVY_HAIR_REQUIRE_ADAPTER").is_some() => {
                panic!("BEVY_HAIR_REQUIRE_ADAPTER is set and there is {e}")
            }
            Err(e) => {
                eprintln!("skipped: {e}");
                None
            }
        }
    }

    /// Submits the copy of `buffer` (with `COPY_SRC` use) into a staging buffer of `pool`
    /// and asks for it mapped.
    fn start(gpu: &GpuContext, pool: &StagingPool, buffer: &wgpu::Buffer) -> BufferCopy {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        let staging = pool.record(&gpu.device, &mut encoder, buffer, 0);
        gpu.queue.submit([encoder.finish()]);
        BufferCopy::map(&gpu.device, staging, pool)
    }

    fn storage(gpu: &GpuContext, size: u64) -> wgpu::Buffer {
        gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        })
    }

    /// A copy that has arrived is taken without a wait: a wait is for all the device's
    /// queued work, so the frames queued since would stall whoever takes it (the plugin
    /// takes one nearly every frame).
    #[test]
    fn taking_an_arrived_copy_waits_for_nothing_queued_after_it() {
        let Some(gpu) = gpu() else { return };
        let buffer = storage(&gpu, 256);
        let pool = StagingPool::default();
        let first = start(&gpu, &pool, &buffer);
        assert!(first.arrived(true));
        let second = start(&gpu, &pool, &buffer);
        assert_eq!(first.into_bytes().expect("bytes"), vec![0; 256]);
        // Mapping callbacks run in a poll: taking the first polled the device for nothing.
        assert!(second.mapped.get().is_none(), "taking an arrived copy waited for the device");
        assert!(!second.asked.is_completed(), "a copy is mapped only once asked for");
        assert!(second.arrived(true));
    }

    /// A copy's staging buffer, once its bytes are taken, serves the next copy of the same
    /// size; one of another size gets its own.
    #[test]
    fn a_taken_copy_lends_its_staging_buffer_to_the_next() {
        let Some(gpu) = gpu() else { return };
        let (buffer, other) = (storage(&gpu, 256), storage(&gpu, 512));
        let pool = StagingPool::default();
        let copy = |source: &wgpu::Buffer| {
            let copy = start(&gpu, &pool, source);
            let staging = copy.staging.clone();
            copy.into_bytes().expect("bytes");
            staging
        };
        let first = copy(&buffer);
        assert_eq!(copy(&buffer), first);
        assert_ne!(copy(&other), first);
        assert_eq!(pool.0.lock().expect("pool").len(), 2);
    }
}
