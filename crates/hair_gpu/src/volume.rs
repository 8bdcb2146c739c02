//! Hair with volume on the GPU (`volume.wgsl`): the GPU twin of hair_sim's
//! `solver/volume.rs`. Once a step, before the substeps, the particles splat into the grid
//! with integer atomics, each cell is resolved once, and each particle's velocity is fed
//! back, as [`hair_sim::solver::Strands::apply_volume`] does on the CPU. The grid's
//! geometry and rest mass are the CPU's own ([`VolumeGrid::new`]), so its integer sums are
//! the CPU's, bit for bit ([`GpuStrands::volume_sums`](crate::GpuStrands::volume_sums)).

use crate::pass::{SharedLayout, storage};
use crate::recorder::{Recorder, dispatch_over, workgroups};
use bytemuck::{Pod, Zeroable};
use hair_sim::collide::HeadInterior;
use hair_sim::math::Pose;
use hair_sim::solver::{Feedback, LengthMode, RestShape, VolumeGrid, VolumeState};

/// The volume shader's source: `layout.wgsl`, then `volume.wgsl`.
pub(crate) const VOLUME_SHADER: &str = concat!(include_str!("layout.wgsl"), "\n", include_str!("volume.wgsl"));

/// A grid's integer sums per cell: mass, and momentum along x, y and z (as
/// [`VolumeGrid::mass`] and [`VolumeGrid::momentum`] hold them).
pub type VolumeSums = (Vec<i64>, Vec<[i64; 3]>);

/// The query the volume's passes write their start time into, the end in the next one:
/// after the step's own two.
pub(crate) const VOLUME_BEGINS: u32 = 2;

/// Where the shader's `gate` counts the grids made (`GATE_MADE`), and where its dispatches'
/// workgroups start (`GATE_ARGS`), words.
pub(crate) const GATE_MADE: usize = 1;
const GATE_ARGS: usize = 2;

/// Bytes of the grid's dispatch workgroups: x, y and z over the slots, then over the cells.
const WORKGROUP_BYTES: u64 = 6 * 4;

/// What a grid was made under ([`GpuVolume::record`]): as the CPU's `MadeFrom`, a step
/// under anything else makes it again whatever moved.
#[derive(Clone, Copy, PartialEq)]
struct MadeUnder {
    pose: Pose,
    steps: (f32, u32),
    volume: hair_sim::solver::Volume,
    mode: LengthMode,
    counts: (u32, u32, u32),
}

/// Words per cell in the sums: mass and momentum along x, y and z, each 64 bits.
const WORDS_PER_CELL: usize = 8;

/// The volume shader's `Volume`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct VolumeUniform {
    counts: [u32; 4],
    dims: [u32; 4],
    origin: [f32; 4],
    inverse: [[f32; 4]; 3],
    translation: [f32; 4],
    rotation: [[f32; 4]; 3],
    feedback: [f32; 4],
    solve: [f32; 4],
    overflow: [f32; 4],
    workgroups: [u32; 4],
}

/// The volume shader's passes (`splat_particles`, `resolve_cells`, `predict_overflow`,
/// `relax_red`, `relax_black`, `resolve_potential`, `extend_potential`, `feed_back`, and
/// the gate's `compare_made_from`, `open_gate` and `clear_sums`) on one layout: compiled
/// with the strands, so that a step that first asks for volume does not wait for a
/// compiler.
pub(crate) struct VolumePasses {
    layout: SharedLayout,
    pipelines: Vec<wgpu::ComputePipeline>,
}

impl VolumePasses {
    pub fn new(device: &wgpu::Device) -> Self {
        let bindings = [
            (wgpu::BufferBindingType::Uniform, false),
            (storage(true), false),
            (storage(false), false),
            (storage(false), false),
            (storage(false), false),
            (storage(true), false),
            (storage(true), false),
            (storage(false), false),
            (storage(true), false),
            (storage(false), false),
            (storage(false), false),
            (storage(false), false),
        ];
        let (layout, pipelines) = SharedLayout::compile(
            device,
            "hair_gpu volume",
            VOLUME_SHADER,
            &bindings,
            [
                "splat_particles",
                "resolve_cells",
                "predict_overflow",
                "relax_red",
                "relax_black",
                "resolve_potential",
                "extend_potential",
                "feed_back",
                "compare_made_from",
                "open_gate",
                "clear_sums",
            ],
        );
        VolumePasses { layout, pipelines }
    }
}

/// A groom's grid on the GPU at one resolution, bound for [`VolumePasses`].
pub(crate) struct GpuVolume {
    /// The resolution it was made at ([`hair_sim::solver::Volume::resolution`]).
    pub resolution: u32,
    grid: VolumeGrid,
    uniform: wgpu::Buffer,
    /// The cells' integer sums (the shader's `sums`), copied back by the tests.
    pub sums: wgpu::Buffer,
    shares: wgpu::Buffer,
    /// Each cell's pressure, kept between steps.
    pub pressure: wgpu::Buffer,
    /// Each cell's backlog of overflow ([`VolumeGrid::backlog`]), kept between steps.
    pub backlog: wgpu::Buffer,
    group: wgpu::BindGroup,
    /// The shader's `gate`: whether a particle moved since the grid was made, how many
    /// times it was made (`GpuStrands::volume_grids_made`), and its dispatches' workgroups.
    pub gate: wgpu::Buffer,
    /// The workgroups of the grid's dispatches, copied from `gate` for the indirect
    /// dispatches (a buffer the passes write cannot be dispatched from in the same pass).
    workgroups: wgpu::Buffer,
    /// What the last grid was made under: the head's pose at the step's start, the step's
    /// length and substeps, the settings, the length model and the counts; `None` where the
    /// next grid is made whatever moved (a new grid, or a pressure carried over).
    made_under: Option<MadeUnder>,
    /// Buffers made for it (kept alive with the bind group).
    _made_from: wgpu::Buffer,
    _cells: wgpu::Buffer,
    _rest_mass: wgpu::Buffer,
    _solid: wgpu::Buffer,
}

impl GpuVolume {
    /// The grid of `rest` at `resolution`, its cells inside `head` walls, over the
    /// solver's `positions` and `motion`.
    pub fn new(
        device: &wgpu::Device,
        passes: &VolumePasses,
        (rest, head): (&RestShape, Option<&HeadInterior>),
        resolution: u32,
        positions: &wgpu::Buffer,
        motion: &wgpu::Buffer,
    ) -> Self {
        let grid = VolumeGrid::new(rest, resolution, head);
        let cells = grid.rest_mass().len();
        let buffer = |label: &str, size: usize, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size.max(16) as u64,
                usage: wgpu::BufferUsages::STORAGE | usage,
                mapped_at_creation: false,
            })
        };
        let copy = wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let sums = buffer("hair_gpu volume sums", cells * WORDS_PER_CELL * 4, copy);
        let cell_values = buffer("hair_gpu volume cells", cells * 32, wgpu::BufferUsages::empty());
        let shares = buffer("hair_gpu volume shares", rest.particles_per_strand * 4, wgpu::BufferUsages::COPY_DST);
        // Zeroed at creation, as the CPU grid's.
        let pressure = buffer("hair_gpu volume pressure", cells * 4, copy);
        let backlog = buffer("hair_gpu volume backlog", cells * 4, copy);
        // Each rest mass as its two words, low then high.
        let words: Vec<u32> = grid.rest_mass().iter().flat_map(|&m| [m as u32, (m >> 32) as u32]).collect();
        let rest_mass = crate::storage_buffer(
            device,
            "hair_gpu volume rest mass",
            bytemuck::cast_slice(&words),
            wgpu::BufferUsages::empty(),
        );
        let walls: Vec<u32> = grid.solid().iter().map(|&s| u32::from(s)).collect();
        let solid = crate::storage_buffer(
            device,
            "hair_gpu volume walls",
            bytemuck::cast_slice(&walls),
            wgpu::BufferUsages::empty(),
        );
        // The positions and velocities the grid was made from: none yet (the first step
        // makes it whatever they are).
        let made_from = buffer("hair_gpu volume made from", 2 * positions.size() as usize, wgpu::BufferUsages::empty());
        let gate =
            buffer("hair_gpu volume gate", GATE_ARGS * 4 + WORKGROUP_BYTES as usize, wgpu::BufferUsages::COPY_SRC);
        let workgroups = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hair_gpu volume workgroups"),
            size: WORKGROUP_BYTES,
            usage: wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hair_gpu volume"),
            size: std::mem::size_of::<VolumeUniform>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let group = passes.layout.bind(
            device,
            "hair_gpu volume",
            [
                &uniform,
                positions,
                motion,
                &sums,
                &cell_values,
                &rest_mass,
                &shares,
                &pressure,
                &solid,
                &backlog,
                &made_from,
                &gate,
            ]
            .map(|b| b.as_entire_binding())
            .to_vec(),
        );
        GpuVolume {
            resolution,
            grid,
            uniform,
            sums,
            shares,
            pressure,
            backlog,
            group,
            gate,
            workgroups,
            made_under: None,
            _made_from: made_from,
            _cells: cell_values,
            _rest_mass: rest_mass,
            _solid: solid,
        }
    }

    /// Records the volume's effect on one step of `dt` seconds in `substeps` substeps under
    /// `volume`'s settings, the head at `pose` at the step's start and at `next` at its
    /// end, for `strands` strands
    /// of `n` particles in `slots` slots; with `implicit`, the friction is left for the
    /// spring model's solve (as [`hair_sim::solver::Feedback::rates`] says). Its passes are
    /// timed into `timestamps` where given ([`VOLUME_BEGINS`] and the query after it).
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &mut self,
        passes: &VolumePasses,
        (recorder, timestamps): (&mut Recorder, Option<&wgpu::QuerySet>),
        volume: &hair_sim::solver::Volume,
        (pose, next): (Pose, Pose),
        (dt, substeps): (f32, u32),
        implicit: bool,
        (strands, n, slots): (u32, u32, u32),
    ) {
        let mode = if implicit { LengthMode::Springs } else { LengthMode::Inextensible };
        let feedback = Feedback::new(&self.grid, volume, mode, n as usize, (dt, substeps));
        let cells = self.grid.rest_mass().len() as u32;
        let [dx, dy, dz] = self.grid.dims();
        let columns = |m: glam::Mat3| [m.x_axis, m.y_axis, m.z_axis].map(|c| [c.x, c.y, c.z, 0.0]);
        let rotation = glam::Mat3::from_quat(pose.rotation);
        let origin = self.grid.origin();
        let t = pose.translation;
        // As the CPU's `prepare`: under another pose, step or setting, made whatever moved.
        let under = MadeUnder { pose, steps: (dt, substeps), volume: *volume, mode, counts: (strands, n, slots) };
        let made_whatever_moved = self.made_under.replace(under) != Some(under);
        let ([slots_x, slots_y], [cells_x, cells_y]) = (workgroups(slots), workgroups(cells));
        let uniform = VolumeUniform {
            counts: [strands, n, cells, u32::from(made_whatever_moved)],
            dims: [dx as u32, dy as u32, dz as u32, 0],
            origin: [origin.x, origin.y, origin.z, self.grid.inverse_cell()],
            inverse: columns(rotation.transpose()),
            translation: [t.x, t.y, t.z, 0.0],
            rotation: columns(rotation),
            feedback: [feedback.push, self.grid.rest_scale(), volume.pressure, self.grid.cell() * self.grid.cell()],
            solve: [1.0 / dt.max(1e-6), f32::from(u8::from(implicit)), dt, feedback.catch_up],
            overflow: [feedback.backlog_kept, self.grid.floor(), feedback.push_scale, 0.0],
            workgroups: [slots_x, slots_y, cells_x, cells_y],
        };
        recorder.upload(&self.uniform, bytemuck::bytes_of(&uniform));
        let friction = if implicit { &feedback.rates } else { &feedback.shares };
        recorder.upload(&self.shares, bytemuck::cast_slice(friction));
        let encoder = recorder.encoder();
        let pressure = volume.pressure_iterations > 0;
        if !pressure {
            // Off: nothing left over from when it was on (`VolumeGrid::solve_pressure`).
            encoder.clear_buffer(&self.pressure, 0, None);
            encoder.clear_buffer(&self.backlog, 0, None);
        }
        let [splat, resolve, predict, red, black, potential, walls, feed_back, compare, open_gate, clear_sums] =
            std::array::from_fn(|k| &passes.pipelines[k]);
        let timed = |begins: bool| {
            timestamps.map(|queries| wgpu::ComputePassTimestampWrites {
                query_set: queries,
                beginning_of_pass_write_index: begins.then_some(VOLUME_BEGINS),
                end_of_pass_write_index: (!begins).then_some(VOLUME_BEGINS + 1),
            })
        };
        // What the grid is made from matters only to a next step under the same pose, as
        // on the CPU: under a head that moves in this step, made whatever moved, nothing
        // is compared.
        let compare = (!made_whatever_moved || next == pose).then_some(compare);
        self.open_gate(encoder, (compare, open_gate), slots, timed(true));
        // One pass, as the step's: each dispatch sees what the one before wrote.
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("hair_gpu volume"),
            timestamp_writes: timed(false),
        });
        pass.set_bind_group(0, &self.group, &[]);
        // The grid's own dispatches, over the slots or the cells (their workgroups' byte
        // offsets in `workgroups`): none where nothing moved.
        let mut grid = |pipeline: &wgpu::ComputePipeline, over: u64| {
            pass.set_pipeline(pipeline);
            pass.dispatch_workgroups_indirect(&self.workgroups, over);
        };
        const SLOTS: u64 = 0;
        const CELLS: u64 = WORKGROUP_BYTES / 2;
        grid(clear_sums, CELLS);
        grid(splat, SLOTS);
        grid(resolve, CELLS);
        if pressure {
            grid(predict, CELLS);
        }
        for _ in 0..volume.pressure_iterations {
            grid(red, CELLS);
            grid(black, CELLS);
        }
        grid(potential, CELLS);
        grid(walls, CELLS);
        // The strands that step take the grid's answer, worked out afresh or not.
        pass.set_pipeline(feed_back);
        dispatch_over(&mut pass, slots);
    }

    /// Records the gate before the grid's passes: whether a particle moved since the grid
    /// was made (`compare` over the `slots`, where given), and the workgroups of the grid's
    /// dispatches that follow from it (`open`), copied to where they are dispatched from.
    fn open_gate(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        (compare, open): (Option<&wgpu::ComputePipeline>, &wgpu::ComputePipeline),
        slots: u32,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("hair_gpu volume gate"),
                timestamp_writes,
            });
            pass.set_bind_group(0, &self.group, &[]);
            if let Some(compare) = compare {
                pass.set_pipeline(compare);
                dispatch_over(&mut pass, slots);
            }
            pass.set_pipeline(open);
            dispatch_over(&mut pass, 1);
        }
        encoder.copy_buffer_to_buffer(&self.gate, GATE_ARGS as u64 * 4, &self.workgroups, 0, WORKGROUP_BYTES);
    }

    /// Records `state`'s pressure and backlog (one value per cell each, as
    /// [`VolumeGrid::pressure`] and [`VolumeGrid::backlog`] hold them) as this grid's;
    /// `false` (and nothing recorded) where its cell count is not this grid's or a value is
    /// not finite.
    pub fn upload_state(&mut self, recorder: &mut Recorder, state: &VolumeState) -> bool {
        let cells = self.grid.rest_mass().len();
        let carried = [(&self.pressure, &state.pressure), (&self.backlog, &state.backlog)];
        if carried.iter().any(|(_, values)| values.len() != cells || !values.iter().all(|v| v.is_finite())) {
            return false;
        }
        // The next step's grid starts from this pressure, whatever moved.
        self.made_under = None;
        for (buffer, values) in carried {
            recorder.upload(buffer, bytemuck::cast_slice(values));
        }
        true
    }

    /// The sums as [`VolumeGrid::mass`] and [`VolumeGrid::momentum`] hold them, from the
    /// words of [`Self::sums`].
    pub fn decode(words: &[u32]) -> VolumeSums {
        let wide = |k: usize, cell: &[u32]| i64::from(cell[2 * k]) | (i64::from(cell[2 * k + 1]) << 32);
        words.chunks_exact(WORDS_PER_CELL).map(|cell| (wide(0, cell), [1, 2, 3].map(|k| wide(k, cell)))).unzip()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The value of constant `name` in the validated volume shader.
    fn constant(name: &str) -> f64 {
        let module = crate::pass::validated(VOLUME_SHADER);
        let (_, c) = module.constants.iter().find(|(_, c)| c.name.as_deref() == Some(name)).expect(name);
        match module.global_expressions[c.init] {
            naga::Expression::Literal(naga::Literal::I32(v)) => f64::from(v),
            naga::Expression::Literal(naga::Literal::U32(v)) => f64::from(v),
            naga::Expression::Literal(naga::Literal::F32(v)) => f64::from(v),
            ref other => panic!("{name} is {other:?}"),
        }
    }

    #[test]
    fn the_shader_splats_in_the_cpus_fixed_point() {
        use hair_sim::solver::{MAX_FIXED_VELOCITY, PARTICLE_MASS_UNITS, VELOCITY_BITS, WEIGHT_BITS};
        assert_eq!(constant("WEIGHT_ONE"), f64::from(1u32 << WEIGHT_BITS));
        assert_eq!(constant("PARTICLE_MASS_UNITS"), PARTICLE_MASS_UNITS as f64);
        assert_eq!(constant("VELOCITY_SCALE"), f64::from(1u32 << VELOCITY_BITS));
        assert_eq!(constant("MAX_FIXED_VELOCITY"), MAX_FIXED_VELOCITY as f64);
        assert_eq!(constant("WORDS_PER_CELL"), WORDS_PER_CELL as f64);
        assert_eq!(constant("PRESSURE_SLACK"), f64::from(hair_sim::solver::PRESSURE_SLACK));
        assert_eq!(constant("GATE_ARGS"), GATE_ARGS as f64);
        assert_eq!(constant("GATE_MADE"), GATE_MADE as f64);
        assert_eq!(std::mem::size_of::<VolumeUniform>(), crate::pass::validated_struct_size(VOLUME_SHADER, "Volume"));
    }

    #[test]
    fn wide_sums_decode_as_signed_64_bit_integers() {
        let words = [5, 0, u32::MAX, u32::MAX, 0, 1, 7, 0x8000_0000];
        let (mass, momentum) = GpuVolume::decode(&words);
        assert_eq!(mass, [5]);
        assert_eq!(momentum, [[-1, 1 << 32, i64::MIN + 7]]);
    }
}
