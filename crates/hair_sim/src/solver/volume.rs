//! Hair with volume: hair–hair interaction on a grid in head space (Petrovic et al. 2005;
//! Müller et al. 2012, §6). Once a step, every particle splats its share of mass and
//! momentum into the grid's eight cells around it; each particle's velocity then moves
//! toward the mean velocity of the hair around it (friction between strands) and away from
//! where the hair is denser than in its rest pose (the density push), so strands that
//! meet push each other apart instead of passing through. A pressure solve on the grid
//! (Unity's strand hair, Bridson's fluids) pushes the density beyond a cell's target out
//! into the room of the sparser cells around it, about a step's worth at a time, so that a
//! pile of hair keeps its volume instead of packing into a layer.
//!
//! The splat is in fixed point, so the sums are exact integers in any order: every thread
//! count, every SIMD path and the GPU (whose atomics add in any order) give the same grid.
//! Each particle adds at most 2^31 to a cell's sum, an `i32`, which the GPU adds into a
//! 64-bit sum held as two words. The rest density is the same splat of the rest pose, so
//! at rest the push is exactly zero.
//!
//! Cells inside the head that hold no hair are walls: the pressure does not push hair into
//! them (its gradient across a wall is zero), so a pile of hair on the skin is pushed along
//! the skin and off it instead of into the head, where the collision would only put it back.
//! (A cell inside the head that hair on the skin splats into is part of the hair.)

use super::RestShape;
use super::params::{LengthMode, SimdPath, Volume};
use crate::collide::HeadInterior;
use crate::math::{Pose, Vec3};
use glam::Vec4;
use splat::{CellSums, Lattice, Splat, add_share};
pub use splat::{SplatPart, fixed_velocity};

mod splat;

/// Fractional bits of a trilinear weight per axis: a particle's eight weights are
/// products of three, summing to exactly `1 << (3 · WEIGHT_BITS)`.
pub const WEIGHT_BITS: u32 = 5;
/// One particle's whole mass in a cell's integer sum.
pub const PARTICLE_MASS_UNITS: i64 = 1 << (3 * WEIGHT_BITS);
/// Fractional bits of a velocity component, m/s, in the momentum sums.
pub const VELOCITY_BITS: u32 = 11;
/// The largest velocity component the momentum sums hold, in their fixed point (about
/// 32 m/s): with a weight of at most [`PARTICLE_MASS_UNITS`], a particle's share of a
/// cell's momentum fits an `i32`.
pub const MAX_FIXED_VELOCITY: i32 = (1 << 16) - 1;

/// The grid a groom's particles splat into, in head space over the groom's reach.
#[derive(Clone, Debug)]
pub struct VolumeGrid {
    /// Cells along the longest side, as asked ([`Volume::resolution`]).
    resolution: u32,
    lattice: Lattice,
    /// Per cell: the particles' weights, summed (units of [`PARTICLE_MASS_UNITS`]), then
    /// weight × velocity (world axes, [`VELOCITY_BITS`] fixed point), summed.
    sums: Vec<CellSums>,
    /// Per cell: the rest pose's mass.
    rest_mass: Vec<i64>,
    /// The mean rest mass over the cells the rest pose reaches, what the push compares
    /// a density excess with.
    rest_scale: f32,
    /// Per cell, worked out once a step from the sums, for the pressure solve.
    values: Vec<CellValue>,
    /// Per cell, what the feedback reads, side by side: worked out from the sums, then
    /// (the potential) from the pressure.
    field: Vec<FieldCell>,
    /// Per cell, the pressure solve's answer, kept between steps as the next one's start.
    pressure: Vec<f32>,
    /// Per cell, the overflow the last step's pressure took away, whose positive part the
    /// next step adds a share of to its own while the cell is over its target
    /// ([`Self::resolve_overflow`]).
    backlog: Vec<f32>,
    /// The cells that hold hair and their coordinates, by colour (the parity of the
    /// coordinates' sum): the pressure's red–black sweeps visit no other cell.
    occupied: [Vec<(usize, [usize; 3])>; 2],
    /// The mass (in particles) any cell may fill up to before the pressure pushes, what
    /// it held at rest aside ([`Self::floor`]).
    floor: f32,
    /// Each particle's splat, kept from the sums for the feedback, and its velocity as
    /// splatted ([`fixed_velocity`]): what [`Self::resplat`] takes away again.
    splats: Vec<Option<Splat>>,
    fixed: Vec<[i32; 3]>,
    /// The sums of the splat's parts but the first, which adds into `sums` itself
    /// ([`Self::splat_on`]), kept for the next step.
    partials: Vec<Vec<CellSums>>,
    /// Per cell, whether it lies inside the head: without hair, a wall, which the pressure
    /// does not push into ([`Self::solid`]).
    solid: Vec<bool>,
    /// The cells inside the head and their coordinates: where a wall's potential is
    /// worked out ([`Self::resolve_potential`]).
    inside: Vec<(usize, [usize; 3])>,
    /// The collider whose head the walls are in ([`HeadInterior::collider`]).
    head: Option<u32>,
}

/// What a [`VolumeGrid`] carries from one step to the next besides its rest density,
/// which is made again from the rest pose ([`VolumeGrid::state`]): a solver that takes a
/// groom over (the GPU's, `GpuStrands::set_volume_state`) takes it with the particles, so
/// that its next step is the one the grid would have taken.
#[derive(Clone, Debug, PartialEq)]
pub struct VolumeState {
    /// The grid's resolution ([`VolumeGrid::resolution`]).
    pub resolution: u32,
    /// Each cell's pressure ([`VolumeGrid::pressure`]).
    pub pressure: Vec<f32>,
    /// Each cell's backlog ([`VolumeGrid::backlog`]).
    pub backlog: Vec<f32>,
}

/// What the pressure solve reads of a cell: whether it holds hair and its density beyond
/// the rest pose's (0 where it is sparser) as a share of the grid's `rest_scale`.
#[derive(Clone, Copy, Debug, Default)]
struct CellValue {
    occupied: bool,
    excess: f32,
    /// The mass over the pressure's target ([`VolumeGrid::resolve_cells`]).
    fill: f32,
    /// The density the step would leave beyond the target, were the hair to go on as it
    /// moves, as a share of the target: what the pressure takes away in the step
    /// ([`VolumeGrid::solve_pressure`]); below 0, the room the cell has.
    overflow: f32,
}

/// What the feedback reads of a cell, in one place for the eight reads per particle.
#[derive(Clone, Copy, Debug, Default)]
struct FieldCell {
    /// The hair's mean velocity (zero in an empty cell), then 1 where the cell holds hair,
    /// else 0: the mean velocity is averaged over those. One vector, so that a corner's
    /// weight scales both in one SIMD multiply.
    motion: Vec4,
    /// The potential's gradient at the cell (per cell, head axes), by central differences
    /// ([`VolumeGrid::resolve_gradients`]): what a particle's push interpolates; then the
    /// potential itself ([`Self::potential`]). One vector, as `motion`.
    slope: Vec4,
}

impl FieldCell {
    /// The velocity change whose gradient (per cell) pushes a particle: the density
    /// push's share of the excess less the pressure's share of the pressure, so that one
    /// gradient serves both ([`VolumeGrid::resolve_potential`]).
    #[inline]
    fn potential(&self) -> f32 {
        self.slope.w
    }
}

impl VolumeGrid {
    /// A grid of `resolution` cells along the longest side of the box around `rest`'s
    /// particles (head space) grown by a quarter of the longest strand on every side: the
    /// reach of hair that swings away from its rest pose. Its rest density is `rest`'s; its
    /// cells inside `head` are walls where they hold no hair.
    pub fn new(rest: &RestShape, resolution: u32, head: Option<&HeadInterior>) -> Self {
        Self::with_floor(rest, resolution, head, LIVE_FLOOR)
    }

    /// [`Self::new`] for settling a grown groom ([`crate::groom::settle`]): its pose is not
    /// a groom yet (strands straight out along the scalp's normals), so the hair may fill
    /// any cell up to [`SETTLING_FLOOR`] times the mean rest density before the pressure
    /// pushes, and hangs and combs as it falls instead of holding the grown pose.
    pub(crate) fn for_settling(rest: &RestShape, resolution: u32, head: Option<&HeadInterior>) -> Self {
        Self::with_floor(rest, resolution, head, SETTLING_FLOOR)
    }

    /// [`Self::new`] with the pressure's floor at `floor_share` of the mean rest density
    /// ([`Self::floor`]).
    fn with_floor(rest: &RestShape, resolution: u32, head: Option<&HeadInterior>, floor_share: f32) -> Self {
        let (mut min, mut max) = crate::math::bounds(&rest.positions);
        if rest.positions.is_empty() {
            (min, max) = (Vec3::ZERO, Vec3::ZERO);
        }
        let margin = 0.25 * rest.longest_strand() + 1e-3;
        let (min, max) = (min - Vec3::splat(margin), max + Vec3::splat(margin));
        let extent = (max - min).max_element().max(1e-3);
        let cell = extent / resolution.max(1) as f32;
        let dims = ((max - min) / cell).to_array().map(|e| e.ceil() as usize + 1);
        let cells = dims[0] * dims[1] * dims[2];
        let mut grid = VolumeGrid {
            resolution,
            lattice: Lattice { origin: min, inverse_cell: 1.0 / cell, cell, dims },
            sums: vec![[0.0; 4]; cells],
            rest_mass: vec![0; cells],
            rest_scale: 1.0,
            values: vec![CellValue::default(); cells],
            field: vec![FieldCell::default(); cells],
            pressure: vec![0.0; cells],
            backlog: vec![0.0; cells],
            occupied: Default::default(),
            floor: 0.0,
            splats: Vec::new(),
            fixed: Vec::new(),
            partials: Vec::new(),
            solid: vec![false; cells],
            inside: Vec::new(),
            head: head.map(HeadInterior::collider),
        };
        if let Some(head) = head {
            let lattice = &grid.lattice;
            let node = |at: [usize; 3]| lattice.origin + Vec3::from_array(at.map(|a| a as f32)) * lattice.cell;
            grid.inside =
                (0..cells).map(|c| (c, lattice.coordinates(c))).filter(|&(_, at)| head.contains(node(at))).collect();
            grid.inside.iter().for_each(|&(c, _)| grid.solid[c] = true);
        }
        grid.splat(rest, &rest.positions, None, Pose::IDENTITY);
        grid.rest_mass = grid.mass();
        let reached: Vec<i64> = grid.rest_mass.iter().copied().filter(|&m| m > 0).collect();
        let mean = reached.iter().map(|&m| m as f64).sum::<f64>() / reached.len().max(1) as f64;
        grid.rest_scale = (mean / PARTICLE_MASS_UNITS as f64).max(1e-6) as f32;
        // What a strand leaves, on average, in a cell it runs through: a cell's side of
        // it, a particle per segment.
        let one_strand = cell / rest.mean_segment().max(1e-6);
        grid.floor = (grid.rest_scale * floor_share).max(one_strand);
        grid
    }

    /// The resolution it was made at ([`Volume::resolution`]).
    pub fn resolution(&self) -> u32 {
        self.resolution
    }

    /// Cells along each axis (x fastest in the cell arrays).
    pub fn dims(&self) -> [usize; 3] {
        self.lattice.dims
    }

    /// The head-local corner of cell 0.
    pub fn origin(&self) -> Vec3 {
        self.lattice.origin
    }

    /// Per cell, whether it lies inside the head it was made with: where it holds no hair,
    /// a wall, which the pressure does not push into.
    pub fn solid(&self) -> &[bool] {
        &self.solid
    }

    /// The collider whose head its walls are ([`HeadInterior::collider`]); `None`: made
    /// without a head.
    pub fn head(&self) -> Option<u32> {
        self.head
    }

    /// A cell's side, m.
    pub fn cell(&self) -> f32 {
        self.lattice.cell
    }

    /// Cells per metre: what a head-local offset from [`Self::origin`] is multiplied by.
    pub fn inverse_cell(&self) -> f32 {
        self.lattice.inverse_cell
    }

    /// The mean rest mass over the cells the rest pose reaches, as a share of
    /// [`PARTICLE_MASS_UNITS`]: the unit of the density excess the push reads.
    pub fn rest_scale(&self) -> f32 {
        self.rest_scale
    }

    /// The mass, in particles, that any cell may fill up to before the pressure pushes,
    /// however little it held at rest: [`LIVE_FLOOR`] of [`Self::rest_scale`] (or
    /// [`SETTLING_FLOOR`] while a grown groom settles), and at least what one strand
    /// leaves, on average, in a cell it runs through (a cell's side over the mean
    /// segment). The grid is there to keep bulk hair apart, not single strands: with less,
    /// a strand that strayed from the groom, or any strand of a sparse one, was pushed by
    /// its own density wherever it went and never came to rest.
    pub fn floor(&self) -> f32 {
        self.floor
    }

    /// Each cell's mass, in units of [`PARTICLE_MASS_UNITS`] per particle (copied out).
    pub fn mass(&self) -> Vec<i64> {
        self.sums.iter().map(|s| s[0] as i64).collect()
    }

    /// Each cell's mass in the rest pose.
    pub fn rest_mass(&self) -> &[i64] {
        &self.rest_mass
    }

    /// Each cell's momentum sums (fixed point: velocity × 2^[`VELOCITY_BITS`] × weight;
    /// copied out).
    pub fn momentum(&self) -> Vec<[i64; 3]> {
        self.sums.iter().map(|&[_, x, y, z]| [x, y, z].map(|s| s as i64)).collect()
    }

    /// Clears the grid and splats the particles at `positions` (their velocities
    /// `velocities`, world axes; none: at rest), head-local by `pose`; roots are pinned and
    /// not counted. [`Self::mass`] and [`Self::momentum`] then hold the sums.
    pub fn splat(&mut self, rest: &RestShape, positions: &[Vec3], velocities: Option<&[Vec3]>, pose: Pose) {
        self.splat_on(rest, positions, velocities, pose, (1, SimdPath::Auto), |_| {});
    }

    /// [`Self::splat`] split into up to `parts` runs of whole strands, which `run` may take
    /// on threads of their own ([`SplatPart::run`]) on the instructions of `simd`;
    /// whatever it leaves is run here. The parts' sums are added in a fixed order, and
    /// integers: the grid is the same for any `parts` and any path.
    pub(super) fn splat_on(
        &mut self,
        rest: &RestShape,
        positions: &[Vec3],
        velocities: Option<&[Vec3]>,
        pose: Pose,
        (parts, simd): (usize, SimdPath),
        run: impl FnOnce(&mut [SplatPart<'_>]),
    ) {
        let n = rest.particles_per_strand.max(1);
        let strands = positions.len().div_ceil(n);
        let cells = self.sums.len();
        // Each part but the first adds its sums to the grid's here, on one thread: past
        // about √(SPLAT_PER_CELL_ADD × particles / cells) parts that costs more than the
        // parts save.
        let useful = ((SPLAT_PER_CELL_ADD * positions.len()) as f64 / cells.max(1) as f64).sqrt() as usize;
        let size = strands.div_ceil(parts.min(useful).clamp(1, strands.max(1))).max(1) * n;
        let parts = positions.len().div_ceil(size).max(1);
        self.partials.resize_with(parts - 1, || vec![[0.0; 4]; cells]);
        self.splats.resize(positions.len(), None);
        self.fixed.resize(positions.len(), [0; 3]);
        if positions.is_empty() {
            // No part to clear the sums.
            self.sums.fill([0.0; 4]);
        }
        let head_local = SplatPart::head_local(pose);
        let Self { lattice, sums, partials, splats, fixed, .. } = self;
        let mut jobs: Vec<SplatPart> = std::iter::once(sums.as_mut_slice())
            .chain(partials.iter_mut().map(Vec::as_mut_slice))
            .zip(splats.chunks_mut(size).zip(fixed.chunks_mut(size)))
            .enumerate()
            .map(|(k, (sums, (splats, fixed)))| {
                let range = k * size..k * size + splats.len();
                SplatPart {
                    lattice,
                    head_local,
                    n,
                    positions: &positions[range.clone()],
                    velocities: velocities.map(|v| &v[range]),
                    sums,
                    splats,
                    fixed,
                    simd,
                    done: false,
                }
            })
            .collect();
        run(&mut jobs);
        jobs.iter_mut().for_each(SplatPart::run);
        drop(jobs);
        for partial in &*partials {
            for (sum, part) in sums.iter_mut().zip(partial) {
                *sum = std::array::from_fn(|k| sum[k] + part[k]);
            }
        }
        self.resolve_cells();
    }

    /// The sums again after the strands `changed` (of `n` particles) moved since the last
    /// splat, which was under the same `pose`: each of their particles' old share taken
    /// away and its share at `positions` with `velocities` added, the same integers as a
    /// whole splat ([`Self::splat_on`]) of them all.
    pub(super) fn resplat(&mut self, n: usize, changed: &[usize], positions: &[Vec3], velocities: &[Vec3], pose: Pose) {
        let head_local = SplatPart::head_local(pose);
        for &strand in changed {
            for i in strand * n + 1..(strand + 1) * n {
                if let Some(old) = self.splats[i] {
                    add_share(&mut self.sums, self.lattice.dims, &old, self.fixed[i], -1.0);
                }
                (self.splats[i], self.fixed[i]) =
                    self.lattice.add_particle(&mut self.sums, head_local, positions[i], Some(velocities[i]));
            }
        }
        self.resolve_cells();
    }

    /// Each cell's mean velocity, excess and fill from the sums, and the cells that hold
    /// hair; a cell without hair has no pressure.
    fn resolve_cells(&mut self) {
        // Each cell's mean and excess, once, for every particle that reads it.
        let units = PARTICLE_MASS_UNITS as f32;
        self.occupied.iter_mut().for_each(Vec::clear);
        let cells = self.sums.iter().zip(&self.rest_mass).zip(self.values.iter_mut().zip(&mut self.field));
        for (c, ((sums, &r), (value, field))) in cells.enumerate() {
            let [m, mx, my, mz] = sums.map(|s| s as i64);
            if m > 0 {
                let at = self.lattice.coordinates(c);
                self.occupied[(at[0] + at[1] + at[2]) % 2].push((c, at));
            } else {
                (self.pressure[c], self.backlog[c]) = (0.0, 0.0);
            }
            if m == 0 && r == 0 {
                // No hair, now or at rest: what the general case below gives.
                (*value, *field) = Default::default();
                continue;
            }
            let momentum = [mx, my, mz];
            let mean_velocity = if m > 0 {
                let scale = 1.0 / (m as f64 * f64::from(1u32 << VELOCITY_BITS));
                Vec3::from_array(momentum.map(|s| (s as f64 * scale) as f32))
            } else {
                Vec3::ZERO
            };
            // Only where the hair is denser than at rest: a pull into a sparser cell fought
            // the pressure's push out of a full one, and kept a strand at the groom's edge
            // swinging between the two under a still head.
            let excess = (m - r).max(0) as f32 / units / self.rest_scale;
            // The target: what the cell held at rest, or the floor where that is more (a
            // cell the rest pose barely reaches, or hair far from its rest pose, may fill up
            // to it), with a little room, so that hair settling about its rest pose is left
            // alone.
            let target = (r as f32 / units).max(self.floor) * (1.0 + PRESSURE_SLACK);
            let fill = m as f32 / units / target;
            *value = CellValue { occupied: m > 0, excess, fill, overflow: 0.0 };
            *field = FieldCell { motion: mean_velocity.extend(if m > 0 { 1.0 } else { 0.0 }), slope: Vec4::ZERO };
        }
    }

    /// The divergence of the hair's mean velocity in cell `c` (at `at`), per second: how
    /// fast the hair there spreads out (below 0, packs together). Central differences
    /// along the grid's axes (`axes`, the head's, in world axes: the means are world
    /// velocities), a neighbour without hair taken as moving with the cell: the edge of a
    /// lock that moves as one does not spread or pack.
    fn divergence(&self, c: usize, at: [usize; 3], axes: &[Vec3; 3]) -> f32 {
        let own = self.field[c].motion.truncate();
        let side =
            |c: Option<usize>| c.filter(|&c| self.values[c].occupied).map_or(own, |c| self.field[c].motion.truncate());
        let neighbours = self.lattice.neighbours(c, at);
        let mut divergence = 0.0;
        for a in 0..3 {
            let (below, above) = (side(neighbours[2 * a]), side(neighbours[2 * a + 1]));
            divergence += (above - below).dot(axes[a]) * (0.5 * self.lattice.inverse_cell);
        }
        divergence
    }

    /// Each cell's pressure: `sweeps` red–black Gauss–Seidel sweeps of `−∇²p = overflow / dt`
    /// from the last step's answer, 0 in cells without hair (the air does not push back),
    /// no flow into a wall (a cell inside the head without hair: the pressure's gradient
    /// across it is 0) and clamped at 0 (it only pushes apart). The overflow is the
    /// density beyond the cell's target that the step would leave, were the hair to go on
    /// spreading or packing as it does, `catch_up` of what is beyond it now taken away
    /// (`catch_up × (fill − 1) − fill × dt × divergence`, as a share of the target;
    /// [`Feedback::catch_up`]; the head turned by `rotation`, which turns the grid's axes),
    /// plus, where the cell is over its target, `backlog_kept` of the last step's overflow
    /// where that was positive ([`Feedback::backlog_kept`]).
    /// The pressure's gradient, taken off a particle's velocity, spreads that out of the
    /// cell in the step of `dt` seconds. Below its target a cell's overflow is negative:
    /// room that the hair around may flow into, so the pressure stays where the hair is too
    /// dense (a unilateral solve, as Unity's strand hair's "density less than" mode) instead
    /// of pressing through the whole groom as through a fluid that cannot be squeezed. A
    /// cell inside the head has no room: the collision keeps hair out of it.
    pub fn solve_pressure(&mut self, sweeps: u32, dt: f32, rotation: glam::Quat, (catch_up, backlog_kept): (f32, f32)) {
        if sweeps == 0 {
            // Off: nothing left over from when it was on.
            self.pressure.fill(0.0);
            self.backlog.fill(0.0);
            return;
        }
        self.resolve_overflow(dt, rotation, (catch_up, backlog_kept));
        let h2 = self.lattice.cell * self.lattice.cell;
        let inverse_dt = 1.0 / dt.max(1e-6);
        let occupied = std::mem::take(&mut self.occupied);
        // Each colour's cells read only the other colour's: in any order, the same answer.
        for _ in 0..sweeps {
            for cells in &occupied {
                for &(c, at) in cells {
                    self.pressure[c] = self.relaxed(c, at, h2, inverse_dt);
                }
            }
        }
        self.occupied = occupied;
    }

    /// Each cell's overflow ([`CellValue::overflow`]) over a step of `dt` seconds, the head
    /// turned by `rotation`, `catch_up` of the density beyond the target taken away. Hair
    /// already spreading out of a full cell needs less push, and hair packing into one
    /// more: a push for the density as it stands overshoots, and where springs pull the
    /// hair back the two swing against each other. Where the cell is over its target,
    /// `backlog_kept` of the last step's overflow, where it was positive, is added; the sum
    /// is kept for the next step.
    fn resolve_overflow(&mut self, dt: f32, rotation: glam::Quat, (catch_up, backlog_kept): (f32, f32)) {
        let turn = glam::Mat3::from_quat(rotation);
        let axes = [turn.x_axis, turn.y_axis, turn.z_axis];
        let occupied = std::mem::take(&mut self.occupied);
        for &(c, at) in occupied.iter().flatten() {
            let spreading = self.divergence(c, at, &axes);
            let fill = self.values[c].fill;
            // In the GPU's order (`predict_overflow`).
            // A cell back under its target has let go of what it held up: remembered, it
            // pushed on, and hair at a groom's edge swung in and out of the cell for good.
            let held = if fill > 1.0 { backlog_kept * self.backlog[c].max(0.0) } else { 0.0 };
            let overflow = catch_up * (fill - 1.0) - fill * dt * spreading + held;
            self.backlog[c] = overflow;
            self.values[c].overflow = if self.solid[c] { overflow.max(0.0) } else { overflow };
        }
        self.occupied = occupied;
    }

    /// Cell `c`'s (at `at`, holding hair) pressure from its neighbours' (0 beyond the grid;
    /// a wall is left out, as if it held the cell's own pressure) and its overflow, `h2`
    /// the cell's side squared: one Gauss–Seidel update.
    #[inline]
    fn relaxed(&self, c: usize, at: [usize; 3], h2: f32, inverse_dt: f32) -> f32 {
        let value = self.values[c];
        let (mut around, mut open) = (0.0, 0.0);
        // In a fixed order, as the GPU adds them. Beyond the grid: air. A wall: left out.
        for n in self.lattice.neighbours(c, at) {
            match n {
                None => open += 1.0,
                Some(n) if self.is_wall(n) => {}
                Some(n) => (around, open) = (around + self.pressure[n], open + 1.0),
            }
        }
        if open == 0.0 {
            // Walled in on every side: nowhere to push.
            return 0.0;
        }
        ((around + h2 * value.overflow * inverse_dt) / open).max(0.0)
    }

    /// Each cell's pressure ([`Self::solve_pressure`]).
    pub fn pressure(&self) -> &[f32] {
        &self.pressure
    }

    /// Each cell's overflow as the last pressure solve took it, which the next adds a share
    /// of where it is positive and the cell still over its target ([`Self::solve_pressure`]):
    /// with [`Self::pressure`], what a grid carries from step to step.
    pub fn backlog(&self) -> &[f32] {
        &self.backlog
    }

    /// What it carries from step to step ([`VolumeState`]), copied out: for another solver
    /// that takes over its strands.
    pub fn state(&self) -> VolumeState {
        VolumeState { resolution: self.resolution, pressure: self.pressure.clone(), backlog: self.backlog.clone() }
    }

    /// Whether cell `c` is a wall: inside the head, without hair.
    #[inline]
    fn is_wall(&self, c: usize) -> bool {
        self.solid[c] && !self.values[c].occupied
    }

    /// Each cell's potential ([`FieldCell::potential`]): `push` times its density excess
    /// less `share` times its pressure, once the pressure is solved. A wall takes the mean
    /// of its neighbours' that hold hair (0 where none does), so that the potential's
    /// gradient across it is zero and nothing is pushed into the head.
    fn resolve_potential(&mut self, push: f32, share: f32) {
        for ((field, value), &p) in self.field.iter_mut().zip(&self.values).zip(&self.pressure) {
            field.slope.w = push * value.excess - share * p;
        }
        // A wall reads only cells that hold hair, none of them a wall: in any order.
        for &(c, at) in &self.inside {
            if !self.values[c].occupied {
                self.field[c].slope.w = self.wall_potential(c, at);
            }
        }
        self.resolve_gradients();
    }

    /// The potential's gradient at each cell that holds hair, by central differences (0
    /// beyond the grid, where the pressure solve takes the air to be), which [`Self::sample`]
    /// interpolates to each particle, as Unity's strand hair does. The exact derivative of
    /// the trilinear potential jumps at every cell face: a particle resting across one
    /// was pushed back and forth, and hair piled on the skin after a shake was held there
    /// by faces it could not cross. A cell without hair is read by no particle (every
    /// corner a particle reads has its weight in it), and keeps the zero
    /// [`Self::resolve_cells`] left.
    fn resolve_gradients(&mut self) {
        for &(c, at) in self.occupied.iter().flatten() {
            let potential = |n: Option<usize>| n.map_or(0.0, |n| self.field[n].potential());
            let [x0, x1, y0, y1, z0, z1] = self.lattice.neighbours(c, at).map(potential);
            // In the GPU's order (`node_gradient`).
            let gradient = Vec3::new(x1 - x0, y1 - y0, z1 - z0) * 0.5;
            let slope = &mut self.field[c].slope;
            *slope = gradient.extend(slope.w);
        }
    }

    /// Wall `c`'s (at `at`) potential: the mean of its neighbours' that hold hair, added in
    /// a fixed order, as the GPU adds them; 0 where none does.
    fn wall_potential(&self, c: usize, at: [usize; 3]) -> f32 {
        let (mut sum, mut count) = (0.0, 0.0f32);
        for n in self.lattice.neighbours(c, at).into_iter().flatten() {
            if self.values[n].occupied {
                (sum, count) = (sum + self.field[n].potential(), count + 1.0);
            }
        }
        if count > 0.0 { sum / count } else { 0.0 }
    }

    /// The mean velocity of the hair where `splat` lies, and the gradient (per metre, head
    /// axes) of the potential there, interpolated from the cells' ([`Self::resolve_gradients`]):
    /// the velocity change the density and the pressure push by.
    #[inline(always)]
    fn sample(&self, splat: &Splat) -> (Vec3, Vec3) {
        // The weighted sums of the mean velocities and of the weights where there is hair
        // (an empty cell's mean is zero), the integer weights as they are: their unit
        // cancels in the mean. The eight weights sum to one particle's mass.
        // (The slope's w sums the potentials, which nothing reads.)
        let (mut motion, mut slope) = (Vec4::ZERO, Vec4::ZERO);
        for (c, w) in splat.corners(self.lattice.dims) {
            let (cell, w) = (&self.field[c], w as f32);
            motion += cell.motion * w;
            slope += cell.slope * w;
        }
        let weight = motion.w;
        let velocity = if weight > 0.0 { motion.truncate() * weight.recip() } else { Vec3::ZERO };
        (velocity, slope.truncate() * (self.lattice.inverse_cell / PARTICLE_MASS_UNITS as f32))
    }
}

/// How many cells' sums are added in the time one particle splats (about, on a CPU):
/// what [`VolumeGrid::splat_on`] weighs a part's saving against.
const SPLAT_PER_CELL_ADD: usize = 20;

/// How far, as a share, a cell's density may exceed its target before the pressure
/// pushes ([`VolumeGrid::solve_pressure`]).
pub const PRESSURE_SLACK: f32 = 0.05;

/// The share of the mean rest density any cell may fill up to before the pressure pushes,
/// for a groom at its rest pose ([`VolumeGrid::floor`]).
pub const LIVE_FLOOR: f32 = 0.5;

/// [`LIVE_FLOOR`] while a grown groom settles: dense enough for hanging, combed hair,
/// sparse enough that the hair keeps a body instead of lying in one layer on the skull.
pub const SETTLING_FLOOR: f32 = 4.0;

/// The volume's part of one step of `dt` seconds, before the strands move: the grid made
/// from `positions` and `velocities` (head-local by `pose`, the head's pose at the step's
/// start; `next` is its pose at the step's end), its pressure solved
/// (`volume.pressure_iterations` sweeps, as much of the overflow as the length model
/// `mode` takes a step, [`Feedback::catch_up`]) and each cell's potential. The answer then
/// reaches each particle's velocity through [`VolumeGrid::feed_back`], strand by strand.
///
/// `made_from` is what the grid was last made from. Where nothing moved since, under the
/// same head, step and settings (a groom asleep under a still head), the grid is left as
/// it is and the step takes the same feedback; where a few strands moved, their shares
/// are taken out of the sums and put back ([`VolumeGrid::resplat`]); else every strand
/// splats again, in up to `parts` parts that `run` may take on threads of their own
/// ([`VolumeGrid::splat_on`]). The sums are the same integers every way. What the grid
/// was made from is kept only where the head ends the step where it started: elsewhere the
/// next step starts under another pose and splats every strand anyway.
#[allow(clippy::too_many_arguments)]
pub(super) fn prepare(
    grid: &mut VolumeGrid,
    made_from: &mut Option<MadeFrom>,
    rest: &RestShape,
    positions: &[Vec3],
    velocities: &[Vec3],
    (pose, next): (Pose, Pose),
    (volume, mode): (&Volume, LengthMode),
    dt: f32,
    (parts, simd, run): (usize, SimdPath, impl FnOnce(&mut [SplatPart<'_>])),
) -> VolumeStep {
    let n = rest.particles_per_strand.max(1);
    let under = (pose, dt, *volume, mode);
    let moved = made_from.as_ref().and_then(|made| made.moved(positions, velocities, n, under));
    match moved {
        Some(moved) if moved.is_empty() => return made_from.as_ref().expect("compared with").step.clone(),
        Some(moved) if moved.len() * RESPLAT_SHARE <= rest.strand_count() => {
            grid.resplat(n, &moved, positions, velocities, pose)
        }
        _ => grid.splat_on(rest, positions, Some(velocities), pose, (parts, simd), run),
    }
    let feedback = Feedback::new(grid, volume, mode, n, dt);
    grid.solve_pressure(volume.pressure_iterations, dt, pose.rotation, (feedback.catch_up, feedback.backlog_kept));
    grid.resolve_potential(feedback.push, volume.pressure);
    let step = VolumeStep { shares: feedback.shares, rates: feedback.rates, rotation: pose.rotation };
    if next == pose {
        MadeFrom::remember(made_from, positions, velocities, under, &step);
    } else {
        *made_from = None;
    }
    step
}

/// Up to one strand in this many moved since the last step: the grid takes their shares
/// out and puts them back ([`VolumeGrid::resplat`]) instead of splatting every strand.
const RESPLAT_SHARE: usize = 8;

/// What a step's grid was last made from ([`prepare`]), and the feedback it gave.
#[derive(Clone, Debug)]
pub(super) struct MadeFrom {
    positions: Vec<Vec3>,
    velocities: Vec<Vec3>,
    /// The head's pose, the step's length, the settings and the length model.
    under: (Pose, f32, Volume, LengthMode),
    step: VolumeStep,
}

impl MadeFrom {
    /// The strands (of `n` particles) whose positions or velocities changed since; `None`
    /// where the head, the step, the settings or the length model did (every strand then).
    fn moved(
        &self,
        positions: &[Vec3],
        velocities: &[Vec3],
        n: usize,
        under: (Pose, f32, Volume, LengthMode),
    ) -> Option<Vec<usize>> {
        if self.under != under || self.positions.len() != positions.len() {
            return None;
        }
        // Compared as bytes, which is one `memcmp` (a float at a time is several times
        // slower): a particle whose bits changed counts as moved, if only from 0 to −0.
        let same = |a: &[Vec3], b: &[Vec3]| bytemuck::cast_slice::<Vec3, u8>(a) == bytemuck::cast_slice::<Vec3, u8>(b);
        if same(&self.positions, positions) && same(&self.velocities, velocities) {
            // A groom asleep under a still head, the common case: two compares.
            return Some(Vec::new());
        }
        let was = self.positions.chunks(n).zip(self.velocities.chunks(n));
        let is = positions.chunks(n).zip(velocities.chunks(n));
        let moved = was.zip(is).enumerate().filter(|(_, ((wx, wv), (ix, iv)))| !(same(wx, ix) && same(wv, iv)));
        Some(moved.map(|(s, _)| s).collect())
    }

    /// Keeps in `slot` what the grid was made from, reusing its buffers.
    fn remember(
        slot: &mut Option<MadeFrom>,
        positions: &[Vec3],
        velocities: &[Vec3],
        under: (Pose, f32, Volume, LengthMode),
        step: &VolumeStep,
    ) {
        let made = slot.get_or_insert_with(|| MadeFrom {
            positions: Vec::new(),
            velocities: Vec::new(),
            under,
            step: step.clone(),
        });
        made.positions.clear();
        made.positions.extend_from_slice(positions);
        made.velocities.clear();
        made.velocities.extend_from_slice(velocities);
        (made.under, made.step) = (under, step.clone());
    }
}

/// What [`prepare`] worked out for a step's feedback, besides the grid.
#[derive(Clone, Debug, PartialEq)]
pub(in crate::solver) struct VolumeStep {
    /// [`Feedback::shares`].
    shares: Vec<f32>,
    /// [`Feedback::rates`].
    rates: Vec<f32>,
    /// The head's rotation the grid's axes turn by.
    rotation: glam::Quat,
}

impl VolumeGrid {
    /// Moves the velocities of the particles from `first` on (whole strands; the particles
    /// [`prepare`] splatted) toward the hair's mean velocity around each (`volume.friction_root`
    /// at the root to `friction_tip` at the tip, per 1/60 s), down the density excess
    /// (`volume.density_push`, m/s² per unit of excess per cell) and down the pressure
    /// (`volume.pressure` of its gradient). Roots are left alone. Each particle reads only
    /// the grid, so chunks of strands take it on their own threads, in any order.
    /// Each particle's push is left in `pushes`, for the step's end ([`GridPush`]).
    /// Inlined, so that it runs on the instructions of the step that calls it.
    #[inline(always)]
    pub(in crate::solver) fn feed_back(
        &self,
        step: &VolumeStep,
        first: usize,
        velocities: &mut [Vec3],
        pushes: &mut [GridPush],
    ) {
        pushes.fill(GridPush::default());
        self.answer_each(step, first, velocities.len(), |j, a| {
            let v = &mut velocities[j];
            pushes[j] = GridPush::new(a.push, *v);
            *v += (a.mean - *v) * a.share + a.push;
        });
    }

    /// The same answer for the spring model, which takes it into its implicit solve
    /// (`implicit_springs`) instead of into the velocities: one [`SpringFeedback`] per
    /// particle from `first` on, and its push in `pushes`, the particles moving at
    /// `velocities` before it. Inlined, as [`Self::feed_back`].
    #[inline(always)]
    pub(in crate::solver) fn feed_back_to_springs(
        &self,
        step: &VolumeStep,
        first: usize,
        velocities: &[Vec3],
        out: &mut [SpringFeedback],
        pushes: &mut [GridPush],
    ) {
        out.fill(SpringFeedback::default());
        pushes.fill(GridPush::default());
        self.answer_each(step, first, out.len(), |j, a| {
            out[j] = SpringFeedback { toward: a.mean, rate: a.rate, kick: a.push };
            pushes[j] = GridPush::new(a.push, velocities[j]);
        });
    }

    /// Hands `then` the grid's answer for each of the `count` particles from `first` on
    /// (whole strands, root to tip), with its index from `first`; a particle the grid does
    /// not hold (a root) gets none. Inlined into each caller, so that no answer goes
    /// through memory.
    #[inline(always)]
    fn answer_each(&self, step: &VolumeStep, first: usize, count: usize, mut then: impl FnMut(usize, Answer)) {
        let VolumeStep { shares, rates, rotation } = step;
        let n = shares.len().max(1);
        debug_assert_eq!(first % n, 0, "whole strands");
        let splats = self.splats.get(first..).unwrap_or_default();
        let splats = &splats[..count.min(splats.len())];
        // A matrix turns a vector in half the arithmetic of a quaternion.
        let turn = glam::Mat3A::from_quat(*rotation);
        for (s, strand) in splats.chunks(n).enumerate() {
            for (j, ((splat, &share), &rate)) in strand.iter().zip(shares).zip(rates).enumerate() {
                if let Some(splat) = splat {
                    let (mean, push) = self.sample(splat);
                    let push = (turn * glam::Vec3A::from(push)).into();
                    then(s * n + j, Answer { mean, push, share, rate });
                }
            }
        }
    }
}

/// The density push's and the pressure's velocity change on one particle in a step, kept
/// for the step's end, which takes back the speed it left along it
/// ([`Self::take_back`]): the grid moves hair out of a full cell but, as a contact,
/// does not send it on. Counted whole, the push carried hair past the cell it was pushed
/// out of until gravity or the strand brought it back and it was pushed again: a strand at
/// the edge of a still groom never came to rest, and a pile held up by the pressure was
/// slower to.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(in crate::solver) struct GridPush {
    /// The push, m/s (zero: none).
    push: Vec3,
    /// How fast the particle was leaving along the push before it, times the push's size
    /// (0 where it was coming in): the particle's velocity before, dotted with the push.
    leaving_before: f32,
}

impl GridPush {
    /// The push `push` on a particle moving at `velocity` before it.
    #[inline]
    pub(in crate::solver) fn new(push: Vec3, velocity: Vec3) -> Self {
        GridPush { push, leaving_before: velocity.dot(push).max(0.0) }
    }

    /// `velocity`, the particle's at the step's end, less what it leaves along the push
    /// beyond how fast it was leaving before, up to the push's size: speed from elsewhere
    /// (the head's pull, gravity) is left alone. The GPU's `take_back_grid_push`.
    #[inline]
    pub(in crate::solver) fn take_back(self, velocity: Vec3) -> Vec3 {
        // In units of the push's size squared, so that the push need not be normalized
        // where it is made, once per particle per step.
        let size_squared = self.push.length_squared();
        if !(size_squared > 0.0 && size_squared.is_finite()) {
            return velocity;
        }
        let gained = (velocity.dot(self.push) - self.leaving_before).clamp(0.0, size_squared);
        velocity - self.push * (gained / size_squared)
    }
}

/// The grid's answer for one particle ([`VolumeGrid::answer_each`]).
struct Answer {
    /// The hair's mean velocity around it.
    mean: Vec3,
    /// The density push's and the pressure's velocity change, world axes.
    push: Vec3,
    /// [`Feedback::shares`] and [`Feedback::rates`] at its index.
    share: f32,
    rate: f32,
}

/// The grid's answer for one particle as the spring model takes it into its implicit
/// solve: the friction as a force toward the hair's mean velocity, and the density push
/// and the pressure as a velocity change of the step's first substep that the integrator's
/// memory of the substep before does not carry forward (BDF2 would take it 4/3 times).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(in crate::solver) struct SpringFeedback {
    /// The velocity the friction pulls toward (world axes).
    pub toward: Vec3,
    /// The share of the difference the friction takes per second, as a rate (0: none).
    pub rate: f32,
    /// The velocity change of the density push and the pressure.
    pub kick: Vec3,
}

/// How much of the grid's answer a step of the volume feeds back into the velocities, the
/// same for the CPU and the GPU.
#[derive(Clone, Debug, PartialEq)]
pub struct Feedback {
    /// Per particle index, root to tip: the share of the difference to the hair's mean
    /// velocity taken in this step (`volume.friction_root` to `friction_tip` per 1/60 s,
    /// compounded over the step's length).
    pub shares: Vec<f32>,
    /// The velocity change per unit of density-excess gradient (per cell) in this step:
    /// `−density_push × cell × dt`.
    pub push: f32,
    /// Per particle index, root to tip: the same friction as a rate per second, for the
    /// spring model, whose implicit solve takes it substep by substep: over a step of
    /// `dt` with the mean held still, `1 − e^(−rate·dt)` is `shares`. A friction of 1
    /// (the whole difference at once) is taken as keeping [`MIN_FRICTION_KEPT`] of it
    /// per 1/60 s, so that the rate is finite.
    pub rates: Vec<f32>,
    /// The share of a cell's density beyond its target that the pressure takes away in
    /// this step ([`VolumeGrid::solve_pressure`]): [`FTL_CATCH_UP`] under
    /// Follow-The-Leader, [`SPRINGS_CATCH_UP`] in the spring model.
    pub catch_up: f32,
    /// The share of a cell's last overflow, where it was positive, that this step's adds
    /// to its own while the cell is over its target ([`VolumeGrid::solve_pressure`]):
    /// [`FTL_BACKLOG_KEPT`] under Follow-The-Leader, 0 in the spring model.
    pub backlog_kept: f32,
}

/// [`Feedback::catch_up`] under Follow-The-Leader: more than the whole overflow, because
/// the hair moves less than the grid asks. The push reaches a particle through its eight
/// cells' gradients, blurred over two cells, and the length pass then pulls each pushed
/// particle back toward its parent, so a pile taken away once a step shrank by only part
/// of its overflow and after a shake stayed denser than its target. The take-back
/// at the step's end leaves no speed for the extra push to carry on with.
pub const FTL_CATCH_UP: f32 = 1.5;

/// [`Feedback::catch_up`] in the spring model. Its integrator keeps every speed the
/// pressure gives, so hair pushed out of a full cell in one step flies on past its target
/// until the springs pull it back into the cell, and is pushed out again: the groom never
/// comes to rest. Taking half of it a step, as Baumgarte's stabilisation takes a contact's
/// overlap, the hair comes to the target slowing down.
pub const SPRINGS_CATCH_UP: f32 = 0.5;

/// [`Feedback::backlog_kept`] under Follow-The-Leader. Hair lying on hair is pulled into
/// it by gravity every step, and the pressure, pushing in proportion to a cell's overflow,
/// held it up only where the cell was dense enough for that push to match the pull: a
/// pile settled over its target by as much as it weighed (a bundle on a floor kept less of
/// its volume the stronger the gravity). Adding half the last step's overflow to the
/// next, a cell that stays over its target is pushed harder step by step until it holds
/// its load nearer the target (integral action, leaking, so that a load taken away is
/// forgotten in a few steps, and forgotten at once where the cell falls under its target).
/// Much more than half, and the pressure overshoots: hair pushed out of a cell by what it
/// remembers falls back into it, and a groom did not come to rest. The spring model keeps
/// none: it keeps every speed the pressure gives, so the pressure's memory threw the hair
/// again.
pub const FTL_BACKLOG_KEPT: f32 = 0.5;

/// What a friction of 1 keeps of the difference per 1/60 s, as a rate ([`Feedback::rates`]).
pub const MIN_FRICTION_KEPT: f32 = 1e-6;

impl Feedback {
    /// The feedback of a step of `dt` seconds on `grid`, for strands of `n` particles
    /// stepped in the length model `mode`.
    pub fn new(grid: &VolumeGrid, volume: &Volume, mode: LengthMode, n: usize, dt: f32) -> Self {
        let friction = |j: usize| {
            let t = j as f32 / (n - 1).max(1) as f32;
            volume.friction_root + (volume.friction_tip - volume.friction_root) * t
        };
        let shares = (0..n).map(|j| 1.0 - (1.0 - friction(j)).powf(dt * 60.0)).collect();
        let rates = (0..n).map(|j| -(1.0 - friction(j)).max(MIN_FRICTION_KEPT).ln() * 60.0).collect();
        let (catch_up, backlog_kept) = match mode {
            LengthMode::Inextensible => (FTL_CATCH_UP, FTL_BACKLOG_KEPT),
            LengthMode::Springs => (SPRINGS_CATCH_UP, 0.0),
        };
        Feedback { shares, push: -volume.density_push * grid.lattice.cell * dt, rates, catch_up, backlog_kept }
    }
}

#[cfg(test)]
mod tests;
