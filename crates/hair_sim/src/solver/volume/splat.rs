//! The splat: each particle's share of mass and momentum, added to the eight cells around
//! it in fixed point. A groom's strands split into parts that splat on threads of their
//! own, each into sums of its own, and the parts' sums add up to the same integers in any
//! order.
//!
//! The integers are held in `f64`: every share is an integer below 2^31 and every sum
//! stays below 2^53 while a cell holds fewer than 2^22 particles, so each add is exact and
//! the sums are the same in any order; and a CPU multiplies and adds `f64` lanes in SIMD,
//! where 64-bit integer products are scalar.

use super::{MAX_FIXED_VELOCITY, VELOCITY_BITS, WEIGHT_BITS};
use crate::math::{Pose, Vec3};
use crate::solver::SimdPath;
use glam::{Mat3A, Vec3A};

const WEIGHT_ONE: i32 = 1 << WEIGHT_BITS;

/// A cell's sums, side by side (a particle adds to all four at once): the particles'
/// weights, then weight × velocity per world axis; integers, held in `f64` (see above).
pub(super) type CellSums = [f64; 4];

/// Where the grid's cells lie: in head space, from `origin`, `dims` cells of side `cell`.
#[derive(Clone, Debug)]
pub(super) struct Lattice {
    pub origin: Vec3,
    /// Cells per metre.
    pub inverse_cell: f32,
    pub cell: f32,
    pub dims: [usize; 3],
}

impl Lattice {
    /// Cell `c`'s coordinates along the three axes (x fastest in the cell arrays).
    pub fn coordinates(&self, c: usize) -> [usize; 3] {
        let [dx, dy, _] = self.dims;
        [c % dx, c / dx % dy, c / (dx * dy)]
    }

    /// Cell `c`'s (at `at`) six neighbours, below and above along x, then y, then z;
    /// `None` beyond the grid.
    #[inline]
    pub fn neighbours(&self, c: usize, at: [usize; 3]) -> [Option<usize>; 6] {
        let [dx, dy, _] = self.dims;
        let strides = [1, dx, dx * dy];
        std::array::from_fn(|k| {
            let (axis, above) = (k / 2, k % 2 == 1);
            if above {
                (at[axis] + 1 < self.dims[axis]).then(|| c + strides[axis])
            } else {
                (at[axis] > 0).then(|| c - strides[axis])
            }
        })
    }

    /// The eight cells around each of `N` head-local points and their weights (`None`
    /// outside the grid), side by side: written lane by lane over arrays, so that the
    /// compiler runs the lanes in SIMD vectors.
    #[inline(always)]
    pub fn splats_of<const N: usize>(&self, points: [Vec3; N]) -> [Option<Splat>; N] {
        let [dx, dy, dz] = self.dims;
        let g: [[f32; N]; 3] =
            std::array::from_fn(|a| std::array::from_fn(|l| (points[l][a] - self.origin[a]) * self.inverse_cell));
        // Compared as floats, so that a point far outside (or not finite) never becomes
        // an index.
        let within: [bool; N] = std::array::from_fn(|l| {
            let inside = |a: usize, d: usize| g[a][l] >= 0.0 && g[a][l] < (d - 1) as f32;
            inside(0, dx) & inside(1, dy) & inside(2, dz)
        });
        // Non-negative and below a grid side where within, so truncation is the floor
        // (without SSE4.1, `floor` is a library call); 0 elsewhere.
        let cell: [[i32; N]; 3] =
            std::array::from_fn(|a| std::array::from_fn(|l| if within[l] { truncate(g[a][l]) } else { 0 }));
        // Rounded as the GPU rounds (`floor(x + 0.5)`, truncation of a non-negative value):
        // the product is exact, the sum correctly rounded on both. The fraction is within
        // [0, 1] (a float's `g - floor(g)`).
        let fixed: [[u8; N]; 3] = std::array::from_fn(|a| {
            std::array::from_fn(|l| {
                let fraction = if within[l] { g[a][l] - cell[a][l] as f32 } else { 0.0 };
                truncate(fraction * WEIGHT_ONE as f32 + 0.5).clamp(0, WEIGHT_ONE) as u8
            })
        });
        std::array::from_fn(|l| {
            let [i, j, k] = [0, 1, 2].map(|a| cell[a][l] as usize);
            let inside = within[l] && i + 1 < dx && j + 1 < dy && k + 1 < dz;
            inside.then(|| Splat { base: (i + dx * (j + dy * k)) as u32, fixed: [0, 1, 2].map(|a| fixed[a][l]) })
        })
    }

    /// Where each of the `N` particles at world `x` moving at `v` (none: at rest) splats,
    /// head-local by `head_local` ([`SplatPart::head_local`]), and its velocity in fixed
    /// point ([`fixed_velocity`]), side by side.
    #[inline(always)]
    pub fn place<const N: usize>(
        &self,
        (inverse, translation): (Mat3A, Vec3A),
        x: [Vec3; N],
        v: Option<[Vec3; N]>,
    ) -> ([Option<Splat>; N], [[i32; 3]; N]) {
        let splats = self.splats_of(x.map(|x| (inverse * (Vec3A::from(x) - translation)).into()));
        let fixed = v.map_or([[0; 3]; N], |v| fixed_velocities(v.map(|v| v.to_array())));
        (splats, fixed)
    }

    /// Adds to `sums` the share of the particle at world `x` moving at `v` ([`Self::place`]);
    /// returns where it splats and its velocity in fixed point, for [`add_share`] to take
    /// the share away again.
    #[inline(always)]
    pub fn add_particle(
        &self,
        sums: &mut [CellSums],
        head_local: (Mat3A, Vec3A),
        x: Vec3,
        v: Option<Vec3>,
    ) -> (Option<Splat>, [i32; 3]) {
        let ([splat], [fixed]) = self.place(head_local, [x], v.map(|v| [v]));
        if let Some(splat) = &splat {
            add_share(sums, self.dims, splat, fixed, 1.0);
        }
        (splat, fixed)
    }
}

/// Where a point splats: its cell (the lowest of the eight around it) and its fixed-point
/// weight toward the next cell along each axis. Kept small: there is one per particle,
/// written by the splat and read by the feedback.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Splat {
    base: u32,
    fixed: [u8; 3],
}

impl Splat {
    /// The eight cells around the point (corner bits x, y, z, x fastest) and their integer
    /// weights, in a grid of `dims` cells.
    #[inline]
    pub fn corners(&self, dims: [usize; 3]) -> [(usize, i32); 8] {
        let (base, [fx, fy, fz]) = (self.base as usize, self.fixed.map(i32::from));
        let (wx, wy, wz) = ([WEIGHT_ONE - fx, fx], [WEIGHT_ONE - fy, fy], [WEIGHT_ONE - fz, fz]);
        let (sy, sz) = (dims[0], dims[0] * dims[1]);
        std::array::from_fn(|corner| {
            let (a, b, c) = (corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
            (base + a + sy * b + sz * c, wx[a] * wy[b] * wz[c])
        })
    }
}

/// A run of whole strands' share of a step's splat, which a thread of its own can take
/// ([`Self::run`]): its particles' weights and momenta, summed into sums of its own, and
/// where each particle splats, for the feedback. Made by
/// [`Strands::apply_volume_on`](crate::solver::Strands::apply_volume_on).
pub struct SplatPart<'a> {
    pub(super) lattice: &'a Lattice,
    /// World → head-local ([`Self::head_local`]).
    pub(super) head_local: (Mat3A, Vec3A),
    /// Particles per strand.
    pub(super) n: usize,
    pub(super) positions: &'a [Vec3],
    pub(super) velocities: Option<&'a [Vec3]>,
    pub(super) sums: &'a mut [CellSums],
    pub(super) splats: &'a mut [Option<Splat>],
    /// Each particle's velocity as splatted ([`fixed_velocity`]).
    pub(super) fixed: &'a mut [[i32; 3]],
    /// The instructions it runs on (as [`SimdPath::resolved`] makes of it): the sums are
    /// integers, the same on every path.
    pub(super) simd: SimdPath,
    pub(super) done: bool,
}

impl SplatPart<'_> {
    /// The world → head-local transform of `pose` as the splat applies it: a matrix (as
    /// the GPU's splat does), not a quaternion per particle.
    pub(super) fn head_local(pose: Pose) -> (Mat3A, Vec3A) {
        (Mat3A::from_quat(pose.rotation).transpose(), Vec3A::from(pose.translation))
    }

    /// Clears this part's sums and adds its particles' shares; roots are pinned and not
    /// counted. Once only: a part already run is left as it is.
    pub fn run(&mut self) {
        if self.done {
            return;
        }
        self.done = true;
        match self.simd.resolved() {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `resolved` picks a wide path only where the CPU has its
            // instructions, and AVX-512F's CPUs have AVX2's.
            SimdPath::Avx2 | SimdPath::Avx512 => unsafe { self.add_shares_avx2() },
            _ => self.add_shares(),
        }
    }

    /// [`Self::add_shares`] compiled for AVX2: a cell's four sums are one register.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn add_shares_avx2(&mut self) {
        self.add_shares();
    }

    /// Clears this part's sums and adds its particles' shares ([`Self::run`]), [`BATCH`]
    /// particles of a strand side by side.
    #[inline(always)]
    fn add_shares(&mut self) {
        self.sums.fill([0.0; 4]);
        let n = self.n.max(1);
        let len = self.positions.len();
        for root in (0..len).step_by(n) {
            // Roots are pinned: they neither count nor move.
            self.splats[root] = None;
            for first in (root + 1..(root + n).min(len)).step_by(BATCH) {
                let count = BATCH.min((root + n).min(len) - first);
                // A short batch's spare lanes repeat its first particle; only `count` count.
                let at = |l: usize| first + if l < count { l } else { 0 };
                let x = std::array::from_fn::<_, BATCH, _>(|l| self.positions[at(l)]);
                let v = self.velocities.map(|v| std::array::from_fn(|l| v[at(l)]));
                let (splats, fixed) = self.lattice.place(self.head_local, x, v);
                for l in 0..count {
                    (self.splats[first + l], self.fixed[first + l]) = (splats[l], fixed[l]);
                    if let Some(splat) = &splats[l] {
                        add_share(self.sums, self.lattice.dims, splat, fixed[l], 1.0);
                    }
                }
            }
        }
    }
}

/// Particles of a strand whose splats [`SplatPart::run`] works out side by side: one AVX2
/// vector of `f32`.
const BATCH: usize = 8;

/// Adds to `sums` (`sign` 1) or takes away from them (−1) a particle's share: in each of
/// the eight cells around it, its weight there times one and times each component of its
/// fixed-point velocity `fixed`. Each product is an integer below 2^31 (see
/// `MAX_FIXED_VELOCITY`), exact in `f64`.
#[inline(always)]
pub(super) fn add_share(sums: &mut [CellSums], dims: [usize; 3], splat: &Splat, fixed: [i32; 3], sign: f64) {
    let [vx, vy, vz] = fixed.map(f64::from);
    let velocity = [sign, sign * vx, sign * vy, sign * vz];
    let (base, [fx, fy, fz]) = (splat.base as usize, splat.fixed.map(f64::from));
    let one = f64::from(WEIGHT_ONE);
    let (wx, wy, wz) = ([one - fx, fx], [one - fy, fy], [one - fz, fz]);
    let (sy, sz) = (dims[0], dims[0] * dims[1]);
    // Four rows of two cells side by side along x (corner bits y, z).
    let rows = [(0, wy[0] * wz[0]), (sy, wy[1] * wz[0]), (sz, wy[0] * wz[1]), (sy + sz, wy[1] * wz[1])];
    for (offset, weight) in rows {
        let at = base + offset;
        let [low, high] = &mut sums[at..at + 2] else { unreachable!("a range of two") };
        let (w0, w1) = (wx[0] * weight, wx[1] * weight);
        for k in 0..4 {
            low[k] += w0 * velocity[k];
            high[k] += w1 * velocity[k];
        }
    }
}

/// A velocity component in the momentum sums' fixed point, rounded as the GPU rounds
/// (`floor(x + 0.5)` in `f32`: the product is exact, the sum correctly rounded on both),
/// within [`MAX_FIXED_VELOCITY`]; not finite: 0 (such a strand is reset by the step).
#[inline]
pub fn fixed_velocity(v: f32) -> i32 {
    fixed_velocities::<1, 1>([[v]])[0][0]
}

/// [`fixed_velocity`] of each of `N` × `K` components, side by side: lane by lane over
/// arrays, so that the compiler runs the lanes in SIMD vectors.
#[inline(always)]
fn fixed_velocities<const N: usize, const K: usize>(v: [[f32; K]; N]) -> [[i32; K]; N] {
    let most = MAX_FIXED_VELOCITY as f32;
    v.map(|v| {
        v.map(|v| {
            let v = if v.is_finite() { v } else { 0.0 };
            // Clamped before the floor, the same as after it (the bounds are whole), and
            // then within an `i32`.
            let x = (v * (1u32 << VELOCITY_BITS) as f32 + 0.5).clamp(-most, most);
            // The floor without a library call: truncation, one less below zero where it cut.
            let t = truncate(x);
            t - i32::from(t as f32 > x)
        })
    })
}

/// `x` truncated toward zero, for a finite `x` within an `i32`: one instruction, without
/// the branches for NaN and for saturation at the `i32` bounds that an `as` cast adds to
/// each of the splat's nine casts a particle.
#[inline(always)]
fn truncate(x: f32) -> i32 {
    debug_assert!(x.is_finite() && x.abs() < i32::MAX as f32, "{x} is not within an i32");
    // SAFETY: every caller's `x` is finite and within an `i32`: `splat_of`'s a point it
    // found inside the grid (a float compare, false for NaN) and a fraction in [0, 1] of
    // it, `fixed_velocity`'s a finite velocity clamped to `MAX_FIXED_VELOCITY`. So the
    // truncation is defined.
    unsafe { x.to_int_unchecked() }
}
