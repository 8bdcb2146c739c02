//! The strand solver on the GPU: [`hair_sim`]'s model stepped by a wgpu compute pass (a
//! few dispatches a substep, an invocation per strand, or per particle for the contacts),
//! the particles staying in GPU buffers between steps.
//!
//! [`GpuStrands`] mirrors [`hair_sim::solver::Strands`]: built from the same
//! [`RestShape`] and head pose, stepped with the same [`StepInput`], read back on demand
//! ([`GpuStrands::positions`], or without waiting, [`GpuStrands::copy_positions`]) with
//! what the steps did (the CPU's [`StepReport`] counts: [`GpuStrands::report`]), and
//! drawn without a read-back: [`GpuDrawing`] writes them, as a renderer draws them in a
//! frame, into the renderer's buffer. Without collision it follows the CPU solver operation for
//! operation (the same integration, shape keeping, Follow-The-Leader, wind and resets).
//! With collision the head is the collider's baked distance grid
//! ([`HeadCollider::grid`]), sampled trilinearly, which rejects points far from the
//! surface; near it the shader runs the collider's own exact query on the same tables
//! ([`HeadCollider::near_query_tables`]: the grid cell's candidate triangles), so it finds
//! the closest point the CPU solver finds. Deep inside the head, or in a cell with too many
//! candidates for a list, it walks the same BVH the CPU solver walks
//! ([`hair_sim::collide::FlatBvh`]). The tests in `tests/against_cpu/` measure how far the
//! two part.
//!
//! Both length models (Follow-The-Leader and the implicit mass-spring model), both
//! collision responses (along the surface normal, or along the ray from the head's centre),
//! the extra colliders and the skin that moves against the head's frame (a skinned scalp's
//! surface patch) are modelled. What differs is whole segments
//! (`SimParams::segment_collision`): a segment's crossing of a thin part is found from one
//! triangle it hits to the next through the BVH until it is inside beyond one, so a segment
//! that only touches the surface stays out, where the CPU solver counts any hit; crossings
//! are turned out by the CPU's rules.
//!
//! The per-particle buffers are laid out for the GPU, not strand by strand: strands in
//! groups of 32, particle `j` of a group's strands side by side (`layout.wgsl`). The calls
//! that queue work record it, uploads included, into one command encoder, which goes to
//! the GPU in one submission when something needs it there (a copy back, a wait, a frame's
//! drawing) or at [`GpuStrands::submit`].
//!
//! ```no_run
//! # use hair_sim::prelude::*;
//! # fn demo(rest: RestShape, collider: &HeadCollider, input: &StepInput) -> Result<(), hair_gpu::GpuError> {
//! let gpu = hair_gpu::GpuContext::headless()?;
//! let mut strands = hair_gpu::GpuStrands::new(&gpu, &rest, Pose::IDENTITY, Some(collider))?;
//! strands.step(input)?;
//! let positions: Vec<Vec3> = strands.positions()?;
//! # Ok(()) }
//! ```

#![warn(missing_docs)]

use bytemuck::Zeroable;
use hair_sim::collide::{HeadCollider, HeadInterior};
use hair_sim::math::{Pose, Vec3};
use hair_sim::solver::{LengthMode, RestShape, StepConstants, StepInput, StepReport, Stillness};
use layout::Slots;
use recorder::Recorder;
pub use recorder::{Submission, submissions};
use wgpu::util::DeviceExt;

mod compiled;
mod context;
mod draw;
mod layout;
mod live;
mod pass;
mod readback;
mod recorder;
mod shadow;
mod sort;
mod uniform;
mod volume;

pub use compiled::GpuPasses;
pub use context::{GpuContext, GpuError};
pub use draw::{CURVE_SHADER, DRAW_SHADER, DrawingPasses, GpuDrawing};
pub use live::live_objects;
pub(crate) use live::{Alive, LIVE_DRAWINGS, LIVE_STRANDS};
use readback::{BufferCopy, StagingPool};
pub use readback::{PositionsCopy, ReportCopy, StepTime};
pub use shadow::{GpuOpacityMap, MAP_FLOATS, OpacityMapPasses, SHADOW_SHADER};
pub use sort::{DrawOrderPasses, GpuDrawOrder, SORT_SHADER};
use uniform::{GridInfo, StepUniform, bits, pack_patch};
pub use volume::VolumeSums;
use volume::{GpuVolume, VolumePasses};
pub use wgpu;

/// The solver's WGSL source: `layout.wgsl`, then the step shader's sections in `step/` (common
/// declarations, wind, the head, whole segments, the final length pass, the skin, the
/// substep, the springs, the spring model's hold under a still head, the entry points),
/// assembled into one module.
pub const SHADER: &str = concat!(
    include_str!("layout.wgsl"),
    "\n",
    include_str!("step/common.wgsl"),
    "\n",
    include_str!("step/wind.wgsl"),
    "\n",
    include_str!("step/head.wgsl"),
    "\n",
    include_str!("step/segments.wgsl"),
    "\n",
    include_str!("step/final_length.wgsl"),
    "\n",
    include_str!("step/skin.wgsl"),
    "\n",
    include_str!("step/substep.wgsl"),
    "\n",
    include_str!("step/springs.wgsl"),
    "\n",
    include_str!("step/contact_hold.wgsl"),
    "\n",
    include_str!("step/entry.wgsl"),
);
/// The roots' pass (`layout.wgsl`, then `roots.wgsl`).
const ROOTS_SHADER: &str = concat!(include_str!("layout.wgsl"), "\n", include_str!("roots.wgsl"));
/// Invocations per workgroup, as `layout.wgsl` declares (a test checks).
const WORKGROUP_SIZE: u32 = 64;
/// Substeps the pose table holds room for at first ([`hair_sim::solver::SimParams`]'s own
/// limit); a step with more grows it.
const MAX_SUBSTEPS: u32 = 64;

/// Strands stepped on the GPU; see the crate docs.
pub struct GpuStrands {
    device: wgpu::Device,
    queue: wgpu::Queue,
    /// The step's passes (the step shader's entry points).
    passes: StepPasses,
    /// Which substep each dispatch of a step works on.
    phases: Phases,
    layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
    uniform: wgpu::Buffer,
    tables: wgpu::Buffer,
    positions: wgpu::Buffer,
    motion: wgpu::Buffer,
    rest: wgpu::Buffer,
    root_frames: wgpu::Buffer,
    /// Extra colliders and the moving skin (see `step/skin.wgsl`).
    colliders: wgpu::Buffer,
    /// The head's distance grid and near query tables (the step shader's `head`).
    head: wgpu::Buffer,
    /// The spring model's memory and scratch: a placeholder until a step asks for springs.
    springs: wgpu::Buffer,
    /// Whether the last step used the spring model, so its memory is current.
    springs_remembered: bool,
    /// The last step's settings and extra colliders ([`Stillness::key`]): strands sleep
    /// through a step only under those they fell asleep under.
    last_settings: Option<u64>,
    grid_info: Option<GridInfo>,
    /// The translation pass (`translate_particles`).
    translate: wgpu::ComputePipeline,
    /// Head-local rest positions, as uploaded (roots moved by [`Self::set_rest_roots`]).
    rest_positions: Vec<Vec3>,
    strands: u32,
    particles_per_strand: u32,
    /// Where each particle's values live in the buffers.
    slots: Slots,
    timestamps: Option<Timestamps>,
    /// The last two steps in head space, for [`GpuDrawing`].
    published: draw::Published,
    /// Tells these strands from others (for [`GpuDrawing::draws`]).
    id: u64,
    /// The pass that moves every root at once, made on first use.
    roots: Option<RootsUpload>,
    /// Hair–hair interaction's passes, and its grid, made when a step first asks for it
    /// (and again when it asks for another resolution).
    volume_passes: VolumePasses,
    volume: Option<GpuVolume>,
    /// The head's inside, whose cells the hair–hair grid makes walls
    /// ([`hair_sim::collide::HeadInterior`]).
    head_interior: Option<HeadInterior>,
    /// The calls' commands since the last submission (locked by the calls that take
    /// `&self` and submit them: the copies, the waits, a [`GpuDrawing`]).
    recorder: std::sync::Mutex<Recorder>,
    /// The copies back's staging buffers, kept for the next copies.
    staging: StagingPool,
    _alive: Alive,
}

/// `roots.wgsl`: a root per strand uploaded, then written into the rest shape.
struct RootsUpload {
    roots: wgpu::Buffer,
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
}

impl RootsUpload {
    fn new(device: &wgpu::Device, rest: &wgpu::Buffer, strands: u32, particles_per_strand: usize) -> Self {
        let roots = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hair_gpu roots"),
            size: u64::from(strands.max(1)) * 16,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let counts = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("hair_gpu roots counts"),
            contents: bytemuck::cast_slice(&[strands, particles_per_strand as u32, 0, 0]),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("hair_gpu roots.wgsl"),
            source: wgpu::ShaderSource::Wgsl(ROOTS_SHADER.into()),
        });
        let pipeline = pass::pipeline(device, &module, "place_roots");
        let group = pass::bind_group(device, &pipeline, &[(0, &counts), (1, &roots), (2, rest)]);
        RootsUpload { roots, pipeline, group }
    }
}

/// The step shader's entry points: a step dispatches them in turn for each substep.
struct StepPasses {
    /// Integration, shape and length, an invocation per strand.
    move_strands: wgpu::ComputePipeline,
    /// Each particle's contacts, an invocation per particle (with collision).
    collide_particles: wgpu::ComputePipeline,
    /// The final length pass and the velocities, an invocation per strand (with collision).
    place_strands: wgpu::ComputePipeline,
    /// The segments turned out of the head, and the velocities, an invocation per strand
    /// (on the last substep, with the head and segment collision).
    turn_strands: wgpu::ComputePipeline,
}

/// Bytes of one entry of [`Phases`] (the step shader's `phase`, a vec4 of u32).
const PHASE_BYTES: u64 = 16;

/// Which substep each dispatch of a step works on (the step shader's `phase`): the substeps
/// 0, 1, 2, … written once, each at an offset a dynamic offset can point at.
struct Phases {
    buffer: wgpu::Buffer,
    /// Bytes from one entry to the next: the device's alignment for a uniform's offset.
    stride: u32,
}

impl Phases {
    /// Entries for the substeps up to `substeps`.
    fn new(device: &wgpu::Device, substeps: u32) -> Self {
        let stride = device.limits().min_uniform_buffer_offset_alignment.max(PHASE_BYTES as u32);
        let mut bytes = vec![0u8; (substeps as usize + 1) * stride as usize];
        for (k, entry) in bytes.chunks_exact_mut(stride as usize).enumerate() {
            entry[..4].copy_from_slice(&(k as u32).to_le_bytes());
        }
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("hair_gpu phases"),
            contents: &bytes,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        Phases { buffer, stride }
    }

    /// The last substep there is an entry for.
    fn substeps(&self) -> u32 {
        (self.buffer.size() / u64::from(self.stride)) as u32 - 1
    }

    /// The dynamic offset of substep `k`'s entry.
    fn offset(&self, k: u32) -> u32 {
        k * self.stride
    }
}

/// Bytes per slot in `motion`: velocity, substep start, FTL correction, position before
/// collision, sleep anchor, step start, and the grid's friction and push for the spring
/// model (the step shader's `PLANES`).
const MOTION_BYTES: u64 = 8 * 16;
/// Bytes per strand of the step report after the particles in `motion` (the step shader's
/// `Tally`, added up).
const REPORT_BYTES: u64 = 2 * 16;
/// Bytes per slot in `springs` (see `step/springs.wgsl`).
const SPRINGS_BYTES: u64 = 6 * 16;

impl GpuStrands {
    /// Uploads `rest`, placed at rest under `pose` and motionless (as
    /// [`hair_sim::solver::Strands::new`]), and `collider`'s distance grid and near query
    /// tables if given.
    pub fn new(
        gpu: &GpuContext,
        rest: &RestShape,
        pose: Pose,
        collider: Option<&HeadCollider>,
    ) -> Result<Self, GpuError> {
        let device = &gpu.device;
        let particles = rest.positions.len();
        let n = rest.particles_per_strand;
        let slots = Slots::new(rest.strand_count(), n);
        let limit = device.limits().max_storage_buffer_binding_size;
        let bytes = slots.count() as u64 * MOTION_BYTES + slots.padded_strands() as u64 * REPORT_BYTES;
        if bytes > limit {
            return Err(GpuError::TooLarge { particles, bytes, limit });
        }
        let storage = |label: &str, contents: &[u8], usage| storage_buffer(device, label, contents, usage);
        let vec4 = |v: Vec3, w: f32| [v.x, v.y, v.z, w];
        let placed: Vec<[f32; 4]> = rest.positions.iter().map(|&p| vec4(pose.transform_point(p), 0.0)).collect();
        let positions = storage(
            "hair_gpu positions",
            bytemuck::cast_slice(&slots.spread(&placed, [0.0; 4])),
            wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        );
        let motion = storage(
            "hair_gpu motion",
            &vec![0u8; bytes as usize],
            wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        );
        let rest_positions: Vec<[f32; 4]> = (0..particles).map(|i| vec4(rest.positions[i], rest.lengths[i])).collect();
        let rest_directions: Vec<[f32; 4]> = rest.local_directions.iter().map(|&d| vec4(d, 0.0)).collect();
        let rest_data = [slots.spread(&rest_positions, [0.0; 4]), slots.spread(&rest_directions, [0.0; 4])].concat();
        let rest_buffer = storage("hair_gpu rest", bytemuck::cast_slice(&rest_data), wgpu::BufferUsages::COPY_DST);
        let frames: Vec<[f32; 4]> = rest.root_frames.iter().map(|q| q.to_array()).collect();
        let root_frames = storage("hair_gpu root frames", bytemuck::cast_slice(&frames), wgpu::BufferUsages::empty());
        let table_vec4s = 4 * (MAX_SUBSTEPS as usize + 1) + n.div_ceil(4);
        let tables = storage("hair_gpu tables", &vec![0u8; table_vec4s * 16], wgpu::BufferUsages::COPY_DST);
        let colliders = storage("hair_gpu colliders", &[0u8; 32], wgpu::BufferUsages::COPY_DST);
        let (head, grid_info) = match collider {
            Some(collider) => {
                let (words, info) = GridInfo::pack(collider, limit);
                (storage("hair_gpu head", bytemuck::cast_slice(&words), wgpu::BufferUsages::empty()), Some(info))
            }
            None => (storage("hair_gpu head", &[0u8; 16], wgpu::BufferUsages::empty()), None),
        };
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hair_gpu step"),
            size: std::mem::size_of::<StepUniform>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("hair_gpu step"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let entry = |binding: u32, ty: wgpu::BufferBindingType| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset: false, min_binding_size: None },
            count: None,
        };
        let read = wgpu::BufferBindingType::Storage { read_only: true };
        let write = wgpu::BufferBindingType::Storage { read_only: false };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hair_gpu"),
            entries: &[
                entry(0, wgpu::BufferBindingType::Uniform),
                entry(1, read),
                entry(2, write),
                entry(3, write),
                entry(4, read),
                entry(5, read),
                entry(6, read),
                entry(7, read),
                entry(8, write),
                wgpu::BindGroupLayoutEntry {
                    binding: 9,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: true,
                        min_binding_size: wgpu::BufferSize::new(PHASE_BYTES),
                    },
                    count: None,
                },
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hair_gpu"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let entry_point = |label, entry_point| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry_point),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let passes = StepPasses {
            move_strands: entry_point("hair_gpu move strands", "move_strands"),
            collide_particles: entry_point("hair_gpu collide particles", "collide_particles"),
            place_strands: entry_point("hair_gpu place strands", "place_strands"),
            turn_strands: entry_point("hair_gpu turn strands", "turn_strands"),
        };
        let phases = Phases::new(device, MAX_SUBSTEPS);
        let translate = entry_point("hair_gpu translate", "translate_particles");
        let springs = storage("hair_gpu springs", &[0u8; 16], wgpu::BufferUsages::COPY_DST);
        let bind_group = bind(
            device,
            &layout,
            [&uniform, &tables, &positions, &motion, &rest_buffer, &root_frames, &colliders, &head, &springs],
            &phases,
        );
        let timestamps = gpu.timestamps.then(|| Timestamps::new(device));
        let published = draw::Published::new(device, &positions, slots.count());
        static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let mut strands = GpuStrands {
            device: device.clone(),
            queue: gpu.queue.clone(),
            passes,
            phases,
            layout,
            bind_group,
            uniform,
            tables,
            positions,
            motion,
            rest: rest_buffer,
            root_frames,
            colliders,
            head,
            springs,
            springs_remembered: false,
            last_settings: None,
            grid_info,
            translate,
            rest_positions: rest.positions.clone(),
            strands: rest.strand_count() as u32,
            particles_per_strand: n as u32,
            slots,
            timestamps,
            published,
            id: NEXT_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            roots: None,
            volume_passes: VolumePasses::new(device),
            volume: None,
            head_interior: collider.map(HeadCollider::interior),
            recorder: std::sync::Mutex::new(Recorder::new(device)),
            staging: StagingPool::default(),
            _alive: Alive::new(&LIVE_STRANDS),
        };
        strands.publish(pose);
        strands.publish(pose);
        Ok(strands)
    }

    /// `[strands, particles per strand]`.
    fn counts(&self) -> [u32; 2] {
        [self.strands, self.particles_per_strand]
    }

    /// Keeps the positions as they are now in the frame of the head at `pose` (the pose the
    /// last step ended at, in the solver's frame) for [`GpuDrawing`], which draws between
    /// the last two positions kept. Call it after each step, and twice after
    /// [`Self::set_positions`], so that nothing is drawn between the positions before and
    /// after it ([`Self::reset`] does this itself).
    pub fn publish(&mut self, pose: Pose) {
        let counts = self.counts();
        self.published.publish(recording(&mut self.recorder), counts, pose);
    }

    /// Submits what the calls since the last submission queued, in one submission. The
    /// calls that queue work ([`Self::step`], [`Self::publish`], [`Self::translate`],
    /// [`Self::set_rest_roots`], [`Self::set_positions`], [`Self::reset`]) only record it;
    /// those that need it on the GPU (the copies back, the waits, [`GpuDrawing::draw`])
    /// submit it first. Call it after a step that copies nothing back.
    pub fn submit(&self) {
        self.lock().submit(&self.queue);
    }

    /// Who submits what the calls record: the strands themselves ([`Submission::Own`], as
    /// made) or the caller, who takes it with [`Self::take_commands`].
    pub fn set_submission(&mut self, submission: Submission) {
        recording(&mut self.recorder).submission = submission;
    }

    /// What the calls recorded since the last submission, as one command buffer, for a
    /// caller that submits ([`Submission::Caller`]; an engine adds it to its frame). The
    /// copies back started since arrive once it has run.
    pub fn take_commands(&self) -> Option<wgpu::CommandBuffer> {
        self.lock().take()
    }

    /// The recorder, for a call that takes `&self` (see [`recording`] for `&mut self`).
    fn lock(&self) -> std::sync::MutexGuard<'_, Recorder> {
        self.recorder.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Strands stepped.
    pub fn strand_count(&self) -> usize {
        self.strands as usize
    }

    /// Particles per strand.
    pub fn particles_per_strand(&self) -> usize {
        self.particles_per_strand as usize
    }

    /// The world positions, one `vec4<f32>` per particle (w unused), as `layout.wgsl` (the
    /// start of [`SHADER`]) lays them out: particle `j` of strand `s` at
    /// `particle_slot(root_slot(s, n), j)`. What a renderer reads without a trip through the
    /// CPU.
    pub fn positions_buffer(&self) -> &wgpu::Buffer {
        &self.positions
    }

    /// Puts every strand back at rest under `pose`, motionless, forgetting the spring
    /// model's memory (as [`hair_sim::solver::Strands::reset`]) and, for [`GpuDrawing`],
    /// the step before.
    pub fn reset(&mut self, pose: Pose) {
        let placed: Vec<Vec3> = self.rest_positions.iter().map(|&p| pose.transform_point(p)).collect();
        self.place(&placed);
        // Nothing is drawn between before and after.
        self.publish(pose);
        self.publish(pose);
    }

    /// Places every particle at `positions` (strand-major), motionless, forgetting the
    /// spring model's memory (as [`hair_sim::solver::Strands::set_positions`]): to carry
    /// on from a CPU solver's state. A wrong count or a non-finite position changes nothing
    /// and returns `false`.
    pub fn set_positions(&mut self, positions: &[Vec3]) -> bool {
        if positions.len() != self.rest_positions.len() || !positions.iter().all(|p| p.is_finite()) {
            return false;
        }
        self.place(positions);
        true
    }

    /// Gives every particle the velocity in `velocities` (strand-major, as
    /// [`hair_sim::solver::Strands::velocities`] holds them): with [`Self::set_positions`]
    /// first, to carry on from a CPU solver's state as it moves. A wrong count or a
    /// non-finite velocity changes nothing and returns `false`.
    pub fn set_velocities(&mut self, velocities: &[Vec3]) -> bool {
        if velocities.len() != self.rest_positions.len() || !velocities.iter().all(|v| v.is_finite()) {
            return false;
        }
        let plane: Vec<[f32; 4]> = velocities.iter().map(|v| [v.x, v.y, v.z, 0.0]).collect();
        // The first of `motion`'s planes (the step shader's `velocity`).
        let plane = self.slots.spread(&plane, [0.0; 4]);
        recording(&mut self.recorder).upload(&self.motion, bytemuck::cast_slice(&plane));
        true
    }

    fn place(&mut self, positions: &[Vec3]) {
        let placed: Vec<[f32; 4]> = positions.iter().map(|x| [x.x, x.y, x.z, 0.0]).collect();
        let placed = self.slots.spread(&placed, [0.0; 4]);
        let report_offset = self.report_offset();
        let recorder = recording(&mut self.recorder);
        recorder.upload(&self.positions, bytemuck::cast_slice(&placed));
        let encoder = recorder.encoder();
        // The particles' motion, not the report of the steps before.
        encoder.clear_buffer(&self.motion, 0, Some(report_offset));
        encoder.clear_buffer(&self.springs, 0, None);
        self.springs_remembered = false;
    }

    /// Moves every particle by `offset` (the solver's origin moved; see
    /// [`hair_sim::solver::Strands::translate`]). A zero or non-finite offset does nothing.
    pub fn translate(&mut self, offset: Vec3) {
        if offset == Vec3::ZERO || !offset.is_finite() {
            return;
        }
        let uniform = StepUniform {
            counts: [self.strands, self.particles_per_strand, 0, 0],
            spring_flags: [u32::from(self.springs_remembered), 0, 0, 0],
            offset: [offset.x, offset.y, offset.z, 0.0],
            ..StepUniform::zeroed()
        };
        let slots = self.slots.count() as u32;
        let recorder = recording(&mut self.recorder);
        recorder.upload(&self.uniform, bytemuck::bytes_of(&uniform));
        recorder.dispatch("hair_gpu translate", &self.translate, (&self.bind_group, &[0]), slots);
    }

    /// Moves every strand's root within the rest shape (head-local), for roots riding a
    /// surface that deforms against the head's frame (as
    /// [`hair_sim::solver::Strands::set_rest_root`] does one strand at a time), in one
    /// upload and one pass (a skinned scalp moves them all every frame). `roots` holds one
    /// per strand; a non-finite one leaves its strand's root where it was. A wrong count
    /// changes nothing and returns `false`.
    pub fn set_rest_roots(&mut self, roots: &[Vec3]) -> bool {
        let (strands, n) = (self.strands as usize, self.particles_per_strand as usize);
        if roots.len() != strands {
            return false;
        }
        let mut placed = Vec::with_capacity(strands);
        for (strand, &root) in roots.iter().enumerate() {
            let kept = &mut self.rest_positions[strand * n];
            if root.is_finite() {
                *kept = root;
            }
            placed.push([kept.x, kept.y, kept.z, 0.0]);
        }
        let upload = self.roots.get_or_insert_with(|| RootsUpload::new(&self.device, &self.rest, self.strands, n));
        let recorder = recording(&mut self.recorder);
        recorder.upload(&upload.roots, bytemuck::cast_slice(&placed));
        recorder.dispatch("hair_gpu roots", &upload.pipeline, (&upload.group, &[]), self.strands);
        true
    }

    /// Records one step of `input` (submitted with what needs it: [`Self::submit`]) (the same input a CPU [`hair_sim::solver::Strands`] takes;
    /// its collider must be the one these strands were built with). A step too short to
    /// take, or with an invalid pose, changes nothing, as on the CPU. Where the device has
    /// timestamp queries the step is timed, for [`Self::step_timed`] and the report
    /// ([`ReportCopy::into_timed_report`]).
    pub fn step(&mut self, input: &StepInput) -> Result<(), GpuError> {
        // At most one step waits for its submission: a caller that never submits holds one
        // step's commands and uploads, not all of them.
        let recorder = recording(&mut self.recorder);
        if recorder.steps > 0 {
            recorder.flush(&self.queue);
        }
        let timestamps = self.timestamps.take();
        let result = self.encode_step(input, timestamps.as_ref());
        self.timestamps = timestamps;
        result
    }

    /// [`Self::step`], and the GPU time of the last step that ran, where the device has
    /// timestamp queries (this waits for it).
    pub fn step_timed(&mut self, input: &StepInput) -> Result<Option<StepTime>, GpuError> {
        self.step(input)?;
        let Some(timestamps) = &self.timestamps else {
            self.submit();
            return Ok(None);
        };
        let bytes = self.copy_back(&timestamps.resolved).into_bytes()?;
        Ok(StepTime::from_ticks(&bytes, self.queue.get_timestamp_period()))
    }

    fn encode_step(&mut self, input: &StepInput, timestamps: Option<&Timestamps>) -> Result<(), GpuError> {
        // As on the CPU: the step runs on what `sanitized` makes of the settings.
        let (params, _) = input.params.sanitized();
        let input = &StepInput { params: &params, ..*input };
        let p = input.params;
        let collide_head = p.collision && input.collider.is_some();
        if collide_head && self.grid_info.is_none() {
            return Err(GpuError::NoCollider);
        }
        let Some(constants) = StepConstants::new(input, self.particles_per_strand as usize) else { return Ok(()) };
        let springs = p.length_mode == LengthMode::Springs;
        if springs {
            self.prepare_springs()?;
        }
        let substeps = (constants.poses.len() - 1) as u32;
        if substeps > self.phases.substeps() {
            self.phases = Phases::new(&self.device, substeps);
            self.rebind();
        }
        let patch = self.upload_colliders(input);
        let stillness = Stillness::of(input);
        let still = stillness.still && self.last_settings == Some(stillness.key);
        self.last_settings = Some(stillness.key);
        let (mut uniform, tables) = self.constants(input, &constants, collide_head, still);
        uniform.skin = patch;
        // What the shader decides from the uniform: whether particles collide, and whether
        // the last substep turns segments out of the head (`turns_segments`).
        let collide = uniform.flags[0] == 1;
        let turn_segments = collide && uniform.spring_flags[2] == 1 && uniform.grid_dims[3] == 1;
        self.upload_tables(&tables);
        // What the next step may remember: this one's spring memory, or none.
        self.springs_remembered = springs;
        let queries = timestamps.map(|t| &t.queries);
        if p.volume.enabled {
            let poses = (constants.poses[0], constants.poses[substeps as usize]);
            self.record_volume(&p.volume, poses, (constants.dt, substeps), springs, queries);
        }
        let recorder = recording(&mut self.recorder);
        recorder.upload(&self.uniform, bytemuck::bytes_of(&uniform));
        let encoder = recorder.encoder();
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("hair_gpu step"),
                timestamp_writes: timestamps.map(|t| wgpu::ComputePassTimestampWrites {
                    query_set: &t.queries,
                    beginning_of_pass_write_index: Some(0),
                    end_of_pass_write_index: Some(1),
                }),
            });
            let particles = self.slots.count() as u32;
            let passes = &self.passes;
            for k in 1..=substeps {
                let mut dispatch = |pipeline, invocations| {
                    pass.set_pipeline(pipeline);
                    pass.set_bind_group(0, &self.bind_group, &[self.phases.offset(k)]);
                    recorder::dispatch_over(&mut pass, invocations);
                };
                dispatch(&passes.move_strands, self.strands);
                if collide {
                    dispatch(&passes.collide_particles, particles);
                    dispatch(&passes.place_strands, self.strands);
                    if turn_segments && k == substeps {
                        dispatch(&passes.turn_strands, self.strands);
                    }
                }
            }
        }
        if let Some(t) = timestamps {
            // A step without volume leaves no time of the grid's behind it.
            let timed = if p.volume.enabled { 4 } else { 2 };
            encoder.resolve_query_set(&t.queries, 0..timed, &t.resolved, 0);
            if !p.volume.enabled {
                encoder.clear_buffer(&t.resolved, 16, None);
            }
        }
        recorder.steps += 1;
        Ok(())
    }

    /// Records the volume's effect on a step of `dt` in `substeps` substeps ([`GpuVolume`]),
    /// the head at `poses` at its start and end, making the grid first where there is none
    /// at `volume`'s resolution.
    fn record_volume(
        &mut self,
        volume: &hair_sim::solver::Volume,
        poses: (Pose, Pose),
        steps: (f32, u32),
        springs: bool,
        timestamps: Option<&wgpu::QuerySet>,
    ) {
        self.make_volume(volume.resolution);
        let grid = self.volume.as_mut().expect("made above");
        let counts = (self.strands, self.particles_per_strand, self.slots.count() as u32);
        let recorder = (recording(&mut self.recorder), timestamps);
        grid.record(&self.volume_passes, recorder, volume, poses, steps, springs, counts);
    }

    /// Makes the hair–hair grid at `resolution` where there is none at it.
    fn make_volume(&mut self, resolution: u32) {
        if self.volume.as_ref().is_none_or(|v| v.resolution != resolution) {
            // The rest shape as uploaded: the CPU's grid is made from the same positions.
            let n = self.particles_per_strand as usize;
            let rest = RestShape::new(self.rest_positions.clone(), n).expect("uploaded from a valid rest shape");
            let (positions, motion) = (&self.positions, &self.motion);
            let head = (&rest, self.head_interior.as_ref());
            self.volume = Some(GpuVolume::new(&self.device, &self.volume_passes, head, resolution, positions, motion));
        }
    }

    /// Carries on the CPU's hair–hair grid from `state`, what it keeps from step to step
    /// ([`hair_sim::solver::VolumeGrid::state`] of the grid of strands of this rest shape,
    /// [`hair_sim::solver::Strands::volume_grid`]): its pressure, which the next step's
    /// sweeps start from, and its backlog. `false` where it is not a grid of these strands
    /// (its cell count differs) or a value is not finite; the grid is then left as it was.
    pub fn set_volume_state(&mut self, state: &hair_sim::solver::VolumeState) -> bool {
        // A grid of another resolution is made for the state, and dropped if it is refused.
        let replaced =
            self.volume.as_ref().is_none_or(|v| v.resolution != state.resolution).then(|| self.volume.take());
        self.make_volume(state.resolution);
        let volume = self.volume.as_mut().expect("made above");
        let taken = volume.upload_state(recording(&mut self.recorder), state);
        if let (false, Some(previous)) = (taken, replaced) {
            self.volume = previous;
        }
        taken
    }

    /// The hair–hair grid's integer sums after the last step with volume on, as
    /// [`hair_sim::solver::VolumeGrid::mass`] and [`hair_sim::solver::VolumeGrid::momentum`]
    /// hold them (the same splat gives the same bits on the CPU); `None` before any such
    /// step. Waits for the queued steps.
    pub fn volume_sums(&self) -> Option<Result<VolumeSums, GpuError>> {
        let grid = self.volume.as_ref()?;
        Some(self.copy_back(&grid.sums).into_bytes().map(|bytes| GpuVolume::decode(bytemuck::cast_slice(&bytes))))
    }

    /// How many steps with volume on worked the hair–hair grid out: as on the CPU, a step
    /// whose particles are where the last grid was made from, under the same head pose,
    /// step and settings (a groom asleep under a still head), keeps that grid and runs only
    /// its feedback. `None` before any step with volume. Waits for the queued steps.
    pub fn volume_grids_made(&self) -> Option<Result<u32, GpuError>> {
        let grid = self.volume.as_ref()?;
        let words =
            self.copy_back(&grid.gate).into_bytes().map(|bytes| bytemuck::pod_collect_to_vec::<u8, u32>(&bytes));
        Some(words.map(|words| words[volume::GATE_MADE]))
    }

    /// What the hair–hair grid carries from step to step after the last step with volume
    /// on, as [`hair_sim::solver::VolumeGrid::state`] gives the CPU's: its pressure and
    /// backlog; `None` before any such step. Waits for the queued steps.
    pub fn volume_state(&self) -> Option<Result<hair_sim::solver::VolumeState, GpuError>> {
        let grid = self.volume.as_ref()?;
        let values = |buffer: &wgpu::Buffer| -> Result<Vec<f32>, GpuError> {
            Ok(bytemuck::pod_collect_to_vec(&self.copy_back(buffer).into_bytes()?))
        };
        let state = values(&grid.pressure).and_then(|pressure| {
            Ok(hair_sim::solver::VolumeState { resolution: grid.resolution, pressure, backlog: values(&grid.backlog)? })
        });
        Some(state)
    }

    /// The uniform and the pose and alpha table for one step with `c`'s constants (the
    /// CPU solver's own); `still`: whether the step may keep strands asleep.
    fn constants(
        &self,
        input: &StepInput,
        c: &StepConstants,
        collide_head: bool,
        still: bool,
    ) -> (StepUniform, Vec<[f32; 4]>) {
        let p = input.params;
        let substeps = (c.poses.len() - 1) as u32;
        let mut tables: Vec<[f32; 4]> = Vec::with_capacity(4 * c.poses.len() + c.global_alpha.len().div_ceil(4));
        for pose in &c.poses {
            // As the CPU solver turns a quaternion into a matrix (`PoseMatrix`).
            let m = glam::Mat3A::from_quat(pose.rotation);
            for column in [m.x_axis.into(), m.y_axis.into(), m.z_axis.into(), pose.translation] {
                tables.push([column.x, column.y, column.z, 0.0]);
            }
        }
        let alphas_at = tables.len() as u32;
        tables.extend(c.global_alpha.chunks(4).map(|a| std::array::from_fn(|i| a.get(i).copied().unwrap_or(0.0))));
        let direction = Vec3::from_array(p.wind.direction).normalize_or_zero();
        let strength = if direction == Vec3::ZERO { 0.0 } else { p.wind.strength };
        let grid = self.grid_info.filter(|_| collide_head);
        let uniform = StepUniform {
            counts: [self.strands, self.particles_per_strand, substeps, p.iterations],
            flags: [u32::from(p.collision), input.extra_colliders.len() as u32 * u32::from(p.collision), alphas_at, 0],
            gravity_h: [p.gravity[0], p.gravity[1], p.gravity[2], c.h],
            motion: [c.drag_factor, c.max_step_move, c.local_alpha, c.ftl_velocity],
            limits: [p.max_speed, p.collision_thickness, p.friction, p.teleport_distance],
            wind: [direction.x, direction.y, direction.z, strength],
            gusts: [p.wind.gust_strength, p.wind.gust_frequency, input.time, 0.0],
            grid_origin: grid.map_or([0.0; 4], |g| [g.origin.x, g.origin.y, g.origin.z, g.inverse_cell]),
            grid_dims: grid.map_or([0; 4], |g| [g.dims[0], g.dims[1], g.dims[2], 1]),
            centre: grid.map_or([0.0; 4], |g| [g.centre.x, g.centre.y, g.centre.z, 0.0]),
            near: grid.map_or([0; 4], |g| g.near),
            near_bounds: grid.map_or([0.0; 4], |g| g.near_bounds),
            rise: grid.map_or([0.0; 4], |g| g.rise),
            rise_dims: grid.map_or([0; 4], |g| g.rise_dims),
            rise_limits: grid.map_or([0.0; 4], |g| g.rise_limits),
            springs: [p.spring_stiffness, p.spring_damping, 1.0 / p.particle_mass, p.length_tolerance],
            spring_flags: [
                u32::from(p.length_mode == LengthMode::Springs),
                u32::from(self.springs_remembered),
                u32::from(p.segment_collision),
                u32::from(input.head_from == input.head_to),
            ],
            ray_from: c.ray_from.map_or([0.0; 4], |r| [r.x, r.y, r.z, 1.0]),
            offset: [0.0; 4],
            skin: [0; 4],
            bvh: grid.map_or([0; 4], |g| g.bvh),
            sleep: [p.sleep_distance, p.sleep_time, f32::from(u8::from(still)), input.dt],
            volume: [
                u32::from(p.volume.enabled && p.length_mode == LengthMode::Springs),
                u32::from(p.volume.enabled),
                0,
                0,
            ],
        };
        (uniform, tables)
    }

    /// Writes the step's extra colliders and the moving skin into `colliders` (growing it
    /// when they need more room), and returns the skin's place there for the uniform's
    /// `patch`: header + 1 (0: no skin), triangles, bin starts, bin lists (vec4 indices).
    fn upload_colliders(&mut self, input: &StepInput) -> [u32; 4] {
        use hair_sim::collide::ExtraCollider;
        let collide = input.params.collision;
        let extras = if collide { input.extra_colliders } else { &[] };
        let mut data: Vec<[u32; 4]> = extras
            .iter()
            .flat_map(|e| match *e {
                ExtraCollider::Sphere { center, radius } => {
                    [bits([center.x, center.y, center.z, radius]), bits([center.x, center.y, center.z, 0.0])]
                }
                ExtraCollider::Capsule { a, b, radius } => [bits([a.x, a.y, a.z, radius]), bits([b.x, b.y, b.z, 1.0])],
            })
            .collect();
        let patch = match input.surface_patch.filter(|_| collide && self.grid_info.is_some()) {
            Some(patch) => pack_patch(&mut data, patch.parts()),
            None => [0; 4],
        };
        if data.is_empty() {
            return patch;
        }
        if write_growing(
            (&self.device, recording(&mut self.recorder)),
            &mut self.colliders,
            "hair_gpu colliders",
            bytemuck::cast_slice(&data),
        ) {
            self.rebind();
        }
        patch
    }

    /// Writes the step's pose and alpha table, growing its buffer for more substeps than it
    /// was made for.
    fn upload_tables(&mut self, tables: &[[f32; 4]]) {
        if write_growing(
            (&self.device, recording(&mut self.recorder)),
            &mut self.tables,
            "hair_gpu tables",
            bytemuck::cast_slice(tables),
        ) {
            self.rebind();
        }
    }

    /// Makes the spring model's buffer (six planes) on its first step.
    fn prepare_springs(&mut self) -> Result<(), GpuError> {
        let particles = (self.strands * self.particles_per_strand) as usize;
        let bytes = self.slots.count() as u64 * SPRINGS_BYTES;
        if self.springs.size() >= bytes {
            return Ok(());
        }
        let limit = self.device.limits().max_storage_buffer_binding_size;
        if bytes > limit {
            return Err(GpuError::TooLarge { particles, bytes, limit });
        }
        self.springs = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hair_gpu springs"),
            size: bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        self.springs_remembered = false;
        self.rebind();
        Ok(())
    }

    /// The bind group again, after a buffer was replaced.
    fn rebind(&mut self) {
        self.bind_group = bind(
            &self.device,
            &self.layout,
            [
                &self.uniform,
                &self.tables,
                &self.positions,
                &self.motion,
                &self.rest,
                &self.root_frames,
                &self.colliders,
                &self.head,
                &self.springs,
            ],
            &self.phases,
        );
    }

    /// Waits for the queued steps and reads the world positions back, strand by strand.
    pub fn positions(&self) -> Result<Vec<Vec3>, GpuError> {
        self.copy_positions().into_positions()
    }

    /// Waits for the queued steps and reads the velocities back, strand by strand (as
    /// [`hair_sim::solver::Strands::velocities`]).
    pub fn velocities(&self) -> Result<Vec<Vec3>, GpuError> {
        // The first plane of `motion` is the velocities, in the positions' slots.
        PositionsCopy(self.copy_back(&self.motion), self.slots).into_positions()
    }

    /// Starts copying the positions back to the CPU, without waiting: they arrive when the
    /// GPU has run what was queued before ([`PositionsCopy::arrived`], [`PositionsCopy::into_positions`]).
    pub fn copy_positions(&self) -> PositionsCopy {
        PositionsCopy(self.copy_back(&self.positions), self.slots)
    }

    /// Starts copying `buffer` back after what was recorded, in the same submission.
    fn copy_back(&self, buffer: &wgpu::Buffer) -> BufferCopy {
        let mut recorder = self.lock();
        let staging = self.staging.record(&self.device, recorder.encoder(), buffer, 0);
        recorder.flush(&self.queue);
        BufferCopy::map(&self.device, staging, &self.staging)
    }

    /// Starts copying back what the steps since the last copy of the report did (summed as
    /// [`StepReport::merge`] sums chunks) and how long the last of them took, without
    /// waiting, and starts the next report afresh: [`ReportCopy::into_report`] gives it.
    pub fn copy_report(&self) -> ReportCopy {
        let offset = self.report_offset();
        let mut recorder = self.lock();
        let encoder = recorder.encoder();
        let report = self.staging.record(&self.device, encoder, &self.motion, offset);
        encoder.clear_buffer(&self.motion, offset, None);
        let time = self.timestamps.as_ref().map(|t| self.staging.record(&self.device, encoder, &t.resolved, 0));
        recorder.flush(&self.queue);
        let period = self.queue.get_timestamp_period();
        ReportCopy {
            report: BufferCopy::map(&self.device, report, &self.staging),
            time: time.map(|staging| (BufferCopy::map(&self.device, staging, &self.staging), period)),
        }
    }

    /// Waits for the queued steps and gives what they did since the report was last taken
    /// ([`Self::copy_report`]).
    pub fn report(&self) -> Result<StepReport, GpuError> {
        self.copy_report().into_report()
    }

    /// Where the report starts in `motion`, bytes.
    fn report_offset(&self) -> u64 {
        self.slots.count() as u64 * MOTION_BYTES
    }

    /// Waits for every step queued so far.
    pub fn finish(&self) -> Result<(), GpuError> {
        self.submit();
        self.device.poll(wgpu::PollType::wait_indefinitely()).map(|_| ()).map_err(|e| GpuError::ReadBack(e.to_string()))
    }
}

/// Writes `bytes` at the start of `buffer` (a storage buffer), replacing it with a larger
/// one named `label` when they do not fit; whether it did (the bind group then needs
/// rebuilding).
fn write_growing(
    (device, recorder): (&wgpu::Device, &mut Recorder),
    buffer: &mut wgpu::Buffer,
    label: &str,
    bytes: &[u8],
) -> bool {
    if bytes.len() as u64 <= buffer.size() {
        recorder.upload(buffer, bytes);
        return false;
    }
    *buffer = storage_buffer(device, label, bytes, wgpu::BufferUsages::COPY_DST);
    true
}

/// A storage buffer (with `usage` besides) holding `contents`. A groom without strands
/// still binds its buffers, which may not be empty: at least a report's worth of zeros
/// (summed, it reports nothing; as root frames, no strand reads them).
pub(crate) fn storage_buffer(
    device: &wgpu::Device,
    label: &str,
    contents: &[u8],
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    let zeros = [0u8; REPORT_BYTES as usize];
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: if contents.len() < zeros.len() { &zeros } else { contents },
        usage: wgpu::BufferUsages::STORAGE | usage,
    })
}

/// The recorder of a [`GpuStrands`] borrowed mutably (no lock taken; a poisoned one is
/// still whole: nothing panics half-way through recording).
fn recording(recorder: &mut std::sync::Mutex<Recorder>) -> &mut Recorder {
    recorder.get_mut().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// The bind group over the solver's nine buffers, in binding order, and the phases.
fn bind(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    buffers: [&wgpu::Buffer; 9],
    phases: &Phases,
) -> wgpu::BindGroup {
    let mut entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .enumerate()
        .map(|(i, buffer)| wgpu::BindGroupEntry { binding: i as u32, resource: buffer.as_entire_binding() })
        .collect();
    entries.push(wgpu::BindGroupEntry {
        binding: buffers.len() as u32,
        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer: &phases.buffer,
            offset: 0,
            size: wgpu::BufferSize::new(PHASE_BYTES),
        }),
    });
    device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("hair_gpu"), layout, entries: &entries })
}

/// A step's timestamps: its own pass's start and end, then the volume's
/// ([`volume::VOLUME_BEGINS`]), and the buffer they are resolved into (the latest timed
/// step's, copied back from there; [`StepTime`]).
struct Timestamps {
    queries: wgpu::QuerySet,
    resolved: wgpu::Buffer,
}

impl Timestamps {
    fn new(device: &wgpu::Device) -> Self {
        let queries = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("hair_gpu step time"),
            ty: wgpu::QueryType::Timestamp,
            count: 4,
        });
        let resolved = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hair_gpu timestamps"),
            size: 32,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Timestamps { queries, resolved }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::pass::{validated, validated_struct_size};

    #[test]
    fn the_shader_validates() {
        validated(SHADER);
    }

    #[test]
    fn the_roots_shader_validates() {
        validated(ROOTS_SHADER);
    }

    #[test]
    fn the_uniform_matches_the_shader_layout() {
        assert_eq!(validated_struct_size(SHADER, "Step"), std::mem::size_of::<StepUniform>());
    }
}
