//! Hair with volume: hair–hair interaction on a grid in head space (Petrovic et al. 2005;
//! Müller et al. 2012, §6). Once a step, every particle splats its share of mass and
//! momentum into the grid's eight cells around it; each particle's velocity then moves
//! toward the mean velocity of the hair around it (friction between strands) and away from
//! where the hair is denser than in its rest pose (the density push), so strands that
//! meet push each other apart instead of passing through. A pressure solve on the grid
//! (Unity's strand hair, Bridson's fluids) takes away in one step the density beyond a
//! cell's target, so that a pile of hair keeps its volume instead of packing into a layer.
//!
//! The splat is in fixed point, so the sums are exact integers in any order: every thread
//! count, every SIMD path and the GPU (whose atomics add in any order) give the same grid.
//! Each particle adds at most 2^31 to a cell's sum, an `i32`, which the GPU adds into a
//! 64-bit sum held as two words. The rest density is the same splat of the rest pose, so
//! at rest the push is exactly zero.

use super::RestShape;
use super::params::Volume;
use crate::math::{Pose, Vec3};
use glam::{Mat3A, Vec3A};

/// Fractional bits of a trilinear weight per axis: a particle's eight weights are
/// products of three, summing to exactly `1 << (3 · WEIGHT_BITS)`.
pub const WEIGHT_BITS: u32 = 5;
const WEIGHT_ONE: i64 = 1 << WEIGHT_BITS;
/// One particle's whole mass in a cell's integer sum.
pub const PARTICLE_MASS_UNITS: i64 = 1 << (3 * WEIGHT_BITS);
/// Fractional bits of a velocity component, m/s, in the momentum sums.
pub const VELOCITY_BITS: u32 = 11;
/// The largest velocity component the momentum sums hold, in their fixed point (about
/// 32 m/s): with a weight of at most [`PARTICLE_MASS_UNITS`], a particle's share of a
/// cell's momentum fits an `i32`.
pub const MAX_FIXED_VELOCITY: i64 = (1 << 16) - 1;

/// The grid a groom's particles splat into, in head space over the groom's reach.
#[derive(Clone, Debug)]
pub struct VolumeGrid {
    /// Cells along the longest side, as asked ([`Volume::resolution`]).
    resolution: u32,
    origin: Vec3,
    /// Cells per metre.
    inverse_cell: f32,
    cell: f32,
    dims: [usize; 3],
    /// Per cell, side by side (a particle adds to all four at once): the particles'
    /// weights, summed (units of [`PARTICLE_MASS_UNITS`]), then weight × velocity (world
    /// axes, [`VELOCITY_BITS`] fixed point), summed.
    sums: Vec<[i64; 4]>,
    /// Per cell: the rest pose's mass.
    rest_mass: Vec<i64>,
    /// The mean rest mass over the cells the rest pose reaches, what the push compares
    /// a density excess with.
    rest_scale: f32,
    /// Per cell, worked out once a step from the sums, for the feedback to read together.
    values: Vec<CellValue>,
    /// Per cell, the pressure solve's answer, kept between steps as the next one's start.
    pressure: Vec<f32>,
    /// The share of `rest_scale` any cell may fill up to before the pressure pushes
    /// ([`LIVE_FLOOR`], or [`SETTLING_FLOOR`] while a grown groom settles).
    floor: f32,
    /// Each particle's splat, kept from the sums for the feedback.
    splats: Vec<Option<Splat>>,
}

/// What the feedback reads of a cell: the hair's mean velocity (zero in an empty cell),
/// whether it holds hair, and its density excess over the rest pose's as a share of the
/// grid's `rest_scale`.
#[derive(Clone, Copy, Debug, Default)]
struct CellValue {
    mean_velocity: Vec3,
    occupied: bool,
    excess: f32,
    /// The density beyond the cell's target to take away per second
    /// ([`VolumeGrid::solve_pressure`]), as a share of the target.
    overflow: f32,
}

/// Where a point splats: its cell (the lowest of the eight around it), its fixed-point
/// weight toward the next cell along each axis, and where in its cell it lies. Kept small:
/// there is one per particle, written by the splat and read by the feedback.
#[derive(Clone, Copy, Debug)]
struct Splat {
    base: u32,
    fixed: [u8; 3],
    fraction: Vec3,
}

impl Splat {
    /// The eight cells around the point (corner bits x, y, z, x fastest) and their integer
    /// weights, in a grid of `dims` cells.
    #[inline]
    fn corners(&self, dims: [usize; 3]) -> [(usize, i64); 8] {
        let (base, [fx, fy, fz]) = (self.base as usize, self.fixed.map(i64::from));
        let (wx, wy, wz) = ([WEIGHT_ONE - fx, fx], [WEIGHT_ONE - fy, fy], [WEIGHT_ONE - fz, fz]);
        let (sy, sz) = (dims[0], dims[0] * dims[1]);
        std::array::from_fn(|corner| {
            let (a, b, c) = (corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
            (base + a + sy * b + sz * c, wx[a] * wy[b] * wz[c])
        })
    }
}

impl VolumeGrid {
    /// A grid of `resolution` cells along the longest side of the box around `rest`'s
    /// particles (head space) grown by a quarter of the longest strand on every side: the
    /// reach of hair that swings away from its rest pose. Its rest density is `rest`'s.
    pub fn new(rest: &RestShape, resolution: u32) -> Self {
        Self::with_floor(rest, resolution, LIVE_FLOOR)
    }

    /// [`Self::new`] for settling a grown groom ([`crate::groom::settle`]): its pose is not
    /// a groom yet (strands straight out along the scalp's normals), so the hair may fill
    /// any cell up to [`SETTLING_FLOOR`] times the mean rest density before the pressure
    /// pushes, and hangs and combs as it falls instead of holding the grown pose.
    pub(crate) fn for_settling(rest: &RestShape, resolution: u32) -> Self {
        Self::with_floor(rest, resolution, SETTLING_FLOOR)
    }

    fn with_floor(rest: &RestShape, resolution: u32, floor: f32) -> Self {
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
            origin: min,
            inverse_cell: 1.0 / cell,
            cell,
            dims,
            sums: vec![[0; 4]; cells],
            rest_mass: vec![0; cells],
            rest_scale: 1.0,
            values: vec![CellValue::default(); cells],
            pressure: vec![0.0; cells],
            floor,
            splats: Vec::new(),
        };
        grid.splat(rest, &rest.positions, None, Pose::IDENTITY);
        grid.rest_mass = grid.mass();
        let reached: Vec<i64> = grid.rest_mass.iter().copied().filter(|&m| m > 0).collect();
        let mean = reached.iter().map(|&m| m as f64).sum::<f64>() / reached.len().max(1) as f64;
        grid.rest_scale = (mean / PARTICLE_MASS_UNITS as f64).max(1e-6) as f32;
        grid
    }

    /// The resolution it was made at ([`Volume::resolution`]).
    pub fn resolution(&self) -> u32 {
        self.resolution
    }

    /// Cells along each axis (x fastest in the cell arrays).
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// The head-local corner of cell 0.
    pub fn origin(&self) -> Vec3 {
        self.origin
    }

    /// A cell's side, m.
    pub fn cell(&self) -> f32 {
        self.cell
    }

    /// Cells per metre: what a head-local offset from [`Self::origin`] is multiplied by.
    pub fn inverse_cell(&self) -> f32 {
        self.inverse_cell
    }

    /// The mean rest mass over the cells the rest pose reaches, as a share of
    /// [`PARTICLE_MASS_UNITS`]: the unit of the density excess the push reads.
    pub fn rest_scale(&self) -> f32 {
        self.rest_scale
    }

    /// Each cell's mass, in units of [`PARTICLE_MASS_UNITS`] per particle (copied out).
    pub fn mass(&self) -> Vec<i64> {
        self.sums.iter().map(|s| s[0]).collect()
    }

    /// Each cell's mass in the rest pose.
    pub fn rest_mass(&self) -> &[i64] {
        &self.rest_mass
    }

    /// Each cell's momentum sums (fixed point: velocity × 2^[`VELOCITY_BITS`] × weight;
    /// copied out).
    pub fn momentum(&self) -> Vec<[i64; 3]> {
        self.sums.iter().map(|&[_, x, y, z]| [x, y, z]).collect()
    }

    /// The eight cells around head-local `p` and their weights; `None` outside the grid.
    fn splat_of(&self, p: Vec3) -> Option<Splat> {
        let g = (p - self.origin) * self.inverse_cell;
        let [dx, dy, dz] = self.dims;
        // Compared as floats, so that a point far outside (or not finite) never becomes
        // an index.
        let within = |g: f32, d: usize| g >= 0.0 && g < (d - 1) as f32;
        if !(within(g.x, dx) && within(g.y, dy) && within(g.z, dz)) {
            return None;
        }
        // Non-negative here, so truncation is the floor (without SSE4.1, `floor` is a
        // library call).
        let [i, j, k] = g.to_array().map(|g| g as usize);
        if i + 1 >= dx || j + 1 >= dy || k + 1 >= dz {
            return None;
        }
        let fraction = g - Vec3::new(i as f32, j as f32, k as f32);
        // Rounded as the GPU rounds (`floor(x + 0.5)`, truncation of a non-negative value):
        // the product is exact, the sum correctly rounded on both.
        let fixed = fraction.to_array().map(|f| ((f * WEIGHT_ONE as f32 + 0.5) as i64).clamp(0, WEIGHT_ONE) as u8);
        Some(Splat { base: (i + dx * (j + dy * k)) as u32, fixed, fraction })
    }

    /// Clears the grid and splats the particles at `positions` (their velocities
    /// `velocities`, world axes; none: at rest), head-local by `pose`; roots are pinned and
    /// not counted. [`Self::mass`] and [`Self::momentum`] then hold the sums.
    pub fn splat(&mut self, rest: &RestShape, positions: &[Vec3], velocities: Option<&[Vec3]>, pose: Pose) {
        self.sums.fill([0; 4]);
        let n = rest.particles_per_strand.max(1);
        let mut splats = std::mem::take(&mut self.splats);
        splats.clear();
        // Head-local as a matrix, once (as the GPU's splat does), not a quaternion per particle.
        let (inverse, translation) = (Mat3A::from_quat(pose.rotation).transpose(), Vec3A::from(pose.translation));
        for (i, &x) in positions.iter().enumerate() {
            // Roots are pinned: they neither count nor move.
            let splat =
                (i % n != 0).then(|| self.splat_of((inverse * (Vec3A::from(x) - translation)).into())).flatten();
            splats.push(splat);
            let Some(splat) = splat else { continue };
            let [vx, vy, vz] = velocities.map_or([0; 3], |v| v[i].to_array().map(fixed_velocity));
            for (c, w) in splat.corners(self.dims) {
                let sum = &mut self.sums[c];
                *sum = [sum[0] + w, sum[1] + w * vx, sum[2] + w * vy, sum[3] + w * vz];
            }
        }
        self.splats = splats;
        // Each cell's mean and excess, once, for every particle that reads it.
        let units = PARTICLE_MASS_UNITS as f32;
        for (c, (&[m, mx, my, mz], &r)) in self.sums.iter().zip(&self.rest_mass).enumerate() {
            if m == 0 && r == 0 {
                // No hair, now or at rest: what the general case below gives.
                self.values[c] = CellValue::default();
                continue;
            }
            let momentum = [mx, my, mz];
            let mean_velocity = if m > 0 {
                let scale = 1.0 / (m as f64 * f64::from(1u32 << VELOCITY_BITS));
                Vec3::from_array(momentum.map(|s| (s as f64 * scale) as f32))
            } else {
                Vec3::ZERO
            };
            let excess = (m - r) as f32 / units / self.rest_scale;
            // The target: what the cell held at rest, or the floor's share of the mean rest
            // density where that is more (a cell the rest pose barely reaches, or hair far
            // from its rest pose, may fill up to it), with a little room, so that hair
            // settling about its rest pose is left alone.
            let target = (r as f32 / units).max(self.rest_scale * self.floor) * (1.0 + PRESSURE_SLACK);
            let overflow = ((m as f32 / units - target) / target).max(0.0);
            self.values[c] = CellValue { mean_velocity, occupied: m > 0, excess, overflow };
        }
    }

    /// Each cell's pressure: `sweeps` red–black Gauss–Seidel sweeps of `−∇²p = overflow / dt`
    /// from the last step's answer, 0 in cells without hair (the air does not push back) and
    /// clamped at 0 (it only pushes apart). Its gradient, taken off a particle's velocity,
    /// spreads the overflow out of the cell in the step of `dt` seconds.
    pub fn solve_pressure(&mut self, sweeps: u32, dt: f32) {
        if sweeps == 0 {
            // Off: nothing left over from when it was on.
            self.pressure.fill(0.0);
            return;
        }
        let [dx, dy, dz] = self.dims;
        let h2 = self.cell * self.cell;
        let inverse_dt = 1.0 / dt.max(1e-6);
        for _ in 0..sweeps {
            for colour in 0..2 {
                for k in 0..dz {
                    for j in 0..dy {
                        let first = (j + k + colour) % 2;
                        for i in (first..dx).step_by(2) {
                            let c = i + dx * (j + dy * k);
                            self.pressure[c] = self.relaxed(c, [i, j, k], h2, inverse_dt);
                        }
                    }
                }
            }
        }
    }

    /// Cell `c`'s (at `at`) pressure from its six neighbours' (0 beyond the grid) and its
    /// overflow, `h2` the cell's side squared: one Gauss–Seidel update.
    #[inline]
    fn relaxed(&self, c: usize, at: [usize; 3], h2: f32, inverse_dt: f32) -> f32 {
        let value = self.values[c];
        if !value.occupied {
            return 0.0;
        }
        let [dx, dy, dz] = self.dims;
        let [i, j, k] = at;
        let p = |c: usize| self.pressure[c];
        let (sx, sy) = (1, dx);
        let sz = dx * dy;
        // In a fixed order, as the GPU adds them.
        let mut around = 0.0;
        around += if i > 0 { p(c - sx) } else { 0.0 };
        around += if i + 1 < dx { p(c + sx) } else { 0.0 };
        around += if j > 0 { p(c - sy) } else { 0.0 };
        around += if j + 1 < dy { p(c + sy) } else { 0.0 };
        around += if k > 0 { p(c - sz) } else { 0.0 };
        around += if k + 1 < dz { p(c + sz) } else { 0.0 };
        ((around + h2 * value.overflow * inverse_dt) / 6.0).max(0.0)
    }

    /// Each cell's pressure ([`Self::solve_pressure`]).
    pub fn pressure(&self) -> &[f32] {
        &self.pressure
    }

    /// The mean velocity of the hair where `splat` lies, the gradient (per metre, head
    /// axes) of its density excess over the rest pose's, as a share of the mean rest
    /// density, and the pressure's gradient (m/s, head axes).
    fn sample(&self, splat: &Splat) -> (Vec3, Vec3, Vec3) {
        let f = splat.fraction;
        let (mut velocity, mut weight, mut gradient) = (Vec3::ZERO, 0.0f32, Vec3::ZERO);
        let mut pressure_gradient = Vec3::ZERO;
        // The trilinear interpolant along each axis toward the lower and upper corner, and
        // its slope.
        let (ax, ay, az) = ([1.0 - f.x, f.x], [1.0 - f.y, f.y], [1.0 - f.z, f.z]);
        const SLOPE: [f32; 2] = [-1.0, 1.0];
        for (corner, (c, w)) in splat.corners(self.dims).into_iter().enumerate() {
            let cell = self.values[c];
            if cell.occupied {
                let w = w as f32 / PARTICLE_MASS_UNITS as f32;
                velocity += cell.mean_velocity * w;
                weight += w;
            }
            let (a, b, c3) = (corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
            let derivative = Vec3::new(SLOPE[a] * ay[b] * az[c3], ax[a] * SLOPE[b] * az[c3], ax[a] * ay[b] * SLOPE[c3]);
            gradient += derivative * cell.excess;
            pressure_gradient += derivative * self.pressure[c];
        }
        let velocity = if weight > 0.0 { velocity / weight } else { Vec3::ZERO };
        (velocity, gradient * self.inverse_cell, pressure_gradient * self.inverse_cell)
    }
}

/// How far, as a share, a cell's density may exceed its target before the pressure
/// pushes ([`VolumeGrid::solve_pressure`]).
pub const PRESSURE_SLACK: f32 = 0.05;

/// The share of the mean rest density any cell may fill up to before the pressure pushes,
/// for a groom at its rest pose (the GPU's `resolve_cells` uses the same).
pub const LIVE_FLOOR: f32 = 0.5;

/// [`LIVE_FLOOR`] while a grown groom settles: dense enough for hanging, combed hair,
/// sparse enough that the hair keeps a body instead of lying in one layer on the skull.
pub const SETTLING_FLOOR: f32 = 4.0;

/// A velocity component in the momentum sums' fixed point, rounded as the GPU rounds
/// (`floor(x + 0.5)` in `f32`: the product is exact, the sum correctly rounded on both),
/// within [`MAX_FIXED_VELOCITY`]; not finite: 0 (such a strand is reset by the step).
pub fn fixed_velocity(v: f32) -> i64 {
    if !v.is_finite() {
        return 0;
    }
    let x = v * (1u32 << VELOCITY_BITS) as f32 + 0.5;
    // The floor without a library call: truncation, one less below zero where it cut.
    let t = x as i64;
    let floor = if (t as f32) > x { t - 1 } else { t };
    floor.clamp(-MAX_FIXED_VELOCITY, MAX_FIXED_VELOCITY)
}

/// The volume's part of one step of `dt` seconds, before the strands move: splats
/// `positions` and `velocities` (head-local by `pose`, the head's pose at the step's start)
/// into `grid` and solves its pressure (`volume.pressure_iterations` sweeps). The answer
/// then reaches each particle's velocity through [`VolumeGrid::feed_back`], chunk by chunk.
pub(super) fn prepare(
    grid: &mut VolumeGrid,
    rest: &RestShape,
    positions: &[Vec3],
    velocities: &[Vec3],
    pose: Pose,
    volume: &Volume,
    dt: f32,
) -> VolumeStep {
    grid.splat(rest, positions, Some(velocities), pose);
    grid.solve_pressure(volume.pressure_iterations, dt);
    let n = rest.particles_per_strand.max(1);
    VolumeStep { feedback: Feedback::new(grid, volume, n, dt), rotation: pose.rotation, pressure: volume.pressure }
}

/// What [`prepare`] worked out for a step's feedback, besides the grid.
#[derive(Clone, Debug)]
pub(super) struct VolumeStep {
    feedback: Feedback,
    /// The head's rotation the grid's axes turn by.
    rotation: glam::Quat,
    /// [`Volume::pressure`].
    pressure: f32,
}

impl VolumeGrid {
    /// Moves the velocities of the particles from `first` on (whole strands; the particles
    /// [`prepare`] splatted) toward the hair's mean velocity around each (`volume.friction_root`
    /// at the root to `friction_tip` at the tip, per 1/60 s), down the density excess
    /// (`volume.density_push`, m/s² per unit of excess per cell) and down the pressure
    /// (`volume.pressure` of its gradient). Roots are left alone. Each particle reads only
    /// the grid, so chunks of strands take it on their own threads, in any order.
    pub(super) fn feed_back(&self, step: &VolumeStep, first: usize, velocities: &mut [Vec3]) {
        let VolumeStep { feedback, rotation, pressure } = step;
        let splats = self.splats.get(first..).unwrap_or_default();
        let n = feedback.shares.len();
        for (i, (splat, v)) in splats.iter().zip(velocities).enumerate() {
            let Some(splat) = splat else { continue };
            let (mean, gradient, pressure_gradient) = self.sample(splat);
            let push = gradient * feedback.push - pressure_gradient * *pressure;
            *v += (mean - *v) * feedback.shares[(first + i) % n] + *rotation * push;
        }
    }
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
}

impl Feedback {
    /// The feedback of a step of `dt` seconds on `grid`, for strands of `n` particles.
    pub fn new(grid: &VolumeGrid, volume: &Volume, n: usize, dt: f32) -> Self {
        let shares = (0..n)
            .map(|j| {
                let t = j as f32 / (n - 1).max(1) as f32;
                let friction = volume.friction_root + (volume.friction_tip - volume.friction_root) * t;
                1.0 - (1.0 - friction).powf(dt * 60.0)
            })
            .collect();
        Feedback { shares, push: -volume.density_push * grid.cell * dt }
    }
}

#[cfg(test)]
mod tests;
