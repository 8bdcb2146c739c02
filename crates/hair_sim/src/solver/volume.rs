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
//!
//! Here, the grid and each cell's values from its sums; the splat in `splat`, the pressure
//! and the potential in `pressure`, each particle's answer in `feedback`, and a step's
//! grid made, made again from what moved, or kept, in `prepare`.

use super::RestShape;
use super::params::SimdPath;
use crate::collide::HeadInterior;
use crate::math::{Pose, Vec3};
pub use feedback::{FTL_BACKLOG_KEPT, FTL_CATCH_UP, Feedback, MIN_FRICTION_KEPT, SPRINGS_CATCH_UP};
pub(in crate::solver) use feedback::{GridPush, SpringFeedback, VolumeStep};
use glam::Vec4;
pub(in crate::solver) use prepare::{MadeFrom, prepare};
use splat::{CellSums, Lattice, Splat, add_share};
pub use splat::{SplatPart, fixed_velocity};

mod feedback;
mod prepare;
mod pressure;
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
    /// Cells along the longest side, as asked ([`Volume::resolution`](super::Volume::resolution)).
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

    /// The resolution it was made at ([`Volume::resolution`](super::Volume::resolution)).
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

#[cfg(test)]
mod tests;
