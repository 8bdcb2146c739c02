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
    /// Per cell: the particles' weights, summed (units of [`PARTICLE_MASS_UNITS`]).
    mass: Vec<i64>,
    /// Per cell: weight × velocity (world axes, [`VELOCITY_BITS`] fixed point), summed.
    momentum: Vec<[i64; 3]>,
    /// Per cell: the rest pose's mass.
    rest_mass: Vec<i64>,
    /// The mean rest mass over the cells the rest pose reaches, what the push compares
    /// a density excess with.
    rest_scale: f32,
    /// Per cell, worked out once a step from the sums, for the feedback to read together.
    values: Vec<CellValue>,
    /// Per cell, the pressure solve's answer, kept between steps as the next one's start.
    pressure: Vec<f32>,
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
    /// The eight cells around the point (corner bits x, y, z) and their integer weights,
    /// in a grid of `dims` cells.
    #[inline]
    fn corners(&self, dims: [usize; 3]) -> impl Iterator<Item = (usize, i64)> {
        let (base, fixed) = (self.base as usize, self.fixed.map(i64::from));
        (0..8).map(move |corner: usize| {
            let (a, b, c) = (corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
            let axis = |bit: usize, f: i64| if bit == 1 { f } else { WEIGHT_ONE - f };
            let cell = base + a + dims[0] * (b + dims[1] * c);
            (cell, axis(a, fixed[0]) * axis(b, fixed[1]) * axis(c, fixed[2]))
        })
    }
}

impl VolumeGrid {
    /// A grid of `resolution` cells along the longest side of the box around `rest`'s
    /// particles (head space) grown by a quarter of the longest strand on every side: the
    /// reach of hair that swings away from its rest pose. Its rest density is `rest`'s.
    pub fn new(rest: &RestShape, resolution: u32) -> Self {
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
            mass: vec![0; cells],
            momentum: vec![[0; 3]; cells],
            rest_mass: vec![0; cells],
            rest_scale: 1.0,
            values: vec![CellValue::default(); cells],
            pressure: vec![0.0; cells],
            splats: Vec::new(),
        };
        grid.splat(rest, &rest.positions, None, Pose::IDENTITY);
        grid.rest_mass.clone_from(&grid.mass);
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

    /// Each cell's mass, in units of [`PARTICLE_MASS_UNITS`] per particle.
    pub fn mass(&self) -> &[i64] {
        &self.mass
    }

    /// Each cell's mass in the rest pose.
    pub fn rest_mass(&self) -> &[i64] {
        &self.rest_mass
    }

    /// Each cell's momentum sums (fixed point: velocity × 2^[`VELOCITY_BITS`] × weight).
    pub fn momentum(&self) -> &[[i64; 3]] {
        &self.momentum
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
        self.mass.fill(0);
        self.momentum.fill([0; 3]);
        let n = rest.particles_per_strand.max(1);
        let mut splats = std::mem::take(&mut self.splats);
        splats.clear();
        // Head-local as a matrix, once (as the GPU's splat does), not a quaternion per particle.
        let (inverse, translation) = (Mat3A::from_quat(pose.rotation).transpose(), Vec3A::from(pose.translation));
        splats.extend(positions.iter().enumerate().map(|(i, &x)| {
            // Roots are pinned: they neither count nor move.
            (i % n != 0).then(|| self.splat_of((inverse * (Vec3A::from(x) - translation)).into())).flatten()
        }));
        for (i, splat) in splats.iter().enumerate() {
            let Some(splat) = splat else { continue };
            let v = velocities.map_or([0; 3], |v| v[i].to_array().map(fixed_velocity));
            for (c, w) in splat.corners(self.dims) {
                self.mass[c] += w;
                for (sum, v) in self.momentum[c].iter_mut().zip(v) {
                    *sum += w * v;
                }
            }
        }
        self.splats = splats;
        // Each cell's mean and excess, once, for every particle that reads it.
        let units = PARTICLE_MASS_UNITS as f32;
        for (c, ((&m, &r), momentum)) in self.mass.iter().zip(&self.rest_mass).zip(&self.momentum).enumerate() {
            let mean_velocity = if m > 0 {
                let scale = 1.0 / (m as f64 * f64::from(1u32 << VELOCITY_BITS));
                Vec3::from_array(momentum.map(|s| (s as f64 * scale) as f32))
            } else {
                Vec3::ZERO
            };
            let excess = (m - r) as f32 / units / self.rest_scale;
            // The target: what the cell held at rest, or half the mean rest density where
            // that is more (a cell the rest pose barely reaches, or hair far from its rest
            // pose, may fill up to it), with a little room, so that hair settling about
            // its rest pose is left alone.
            let target = (r as f32 / units).max(self.rest_scale * 0.5) * (1.0 + PRESSURE_SLACK);
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
        for (corner, (c, w)) in splat.corners(self.dims).enumerate() {
            let cell = self.values[c];
            if cell.occupied {
                let w = w as f32 / PARTICLE_MASS_UNITS as f32;
                velocity += cell.mean_velocity * w;
                weight += w;
            }
            // The trilinear interpolant's derivative along each axis.
            let bits = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
            let along = |axis: usize, t: f32| if bits[axis] == 1 { t } else { 1.0 - t };
            let slope = |axis: usize| if bits[axis] == 1 { 1.0 } else { -1.0 };
            let derivative = Vec3::new(
                slope(0) * along(1, f.y) * along(2, f.z),
                along(0, f.x) * slope(1) * along(2, f.z),
                along(0, f.x) * along(1, f.y) * slope(2),
            );
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

/// The volume's effect on one step of `dt` seconds: splats `positions` and `velocities`
/// (head-local by `pose`, the head's pose at the step's start) into `grid`, then moves each
/// particle's velocity toward the hair's mean velocity around it (`volume.friction_root`
/// at the root to `friction_tip` at the tip, per 1/60 s), down the density excess
/// (`volume.density_push`, m/s² per unit of excess per cell) and down the pressure
/// (`volume.pressure` of its gradient, after `volume.pressure_iterations` sweeps). Roots
/// are left alone.
pub(super) fn apply(
    grid: &mut VolumeGrid,
    rest: &RestShape,
    positions: &[Vec3],
    velocities: &mut [Vec3],
    pose: Pose,
    volume: &Volume,
    dt: f32,
) {
    grid.splat(rest, positions, Some(velocities), pose);
    grid.solve_pressure(volume.pressure_iterations, dt);
    let n = rest.particles_per_strand.max(1);
    let feedback = Feedback::new(grid, volume, n, dt);
    for (i, (splat, v)) in grid.splats.iter().zip(velocities.iter_mut()).enumerate() {
        let Some(splat) = splat else { continue };
        let (mean, gradient, pressure_gradient) = grid.sample(splat);
        let push = gradient * feedback.push - pressure_gradient * volume.pressure;
        *v += (mean - *v) * feedback.shares[i % n] + pose.rotation * push;
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
