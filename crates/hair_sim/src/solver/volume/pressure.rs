//! The pressure: how far each cell would overflow its target in the step, a unilateral
//! solve on the cells that hold hair for the pressure that spreads that out, and the
//! potential whose gradient pushes each particle (with the density push's share).

use super::{VolumeGrid, VolumeState};
use crate::math::Vec3;

impl VolumeGrid {
    /// The divergence of the hair's mean velocity in cell `c` (at `at`), per second: how
    /// fast the hair there spreads out (below 0, packs together). Central differences
    /// along the grid's axes (`axes`, the head's, in world axes: the means are world
    /// velocities), a neighbour without hair taken as moving with the cell: the edge of a
    /// lock that moves as one does not spread or pack.
    pub(super) fn divergence(&self, c: usize, at: [usize; 3], axes: &[Vec3; 3]) -> f32 {
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
    /// [`Feedback::catch_up`](super::Feedback::catch_up); the head turned by `rotation`, which turns the grid's axes),
    /// plus, where the cell is over its target, `backlog_kept` of the last step's overflow
    /// where that was positive ([`Feedback::backlog_kept`](super::Feedback::backlog_kept)).
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
    pub(super) fn resolve_overflow(&mut self, dt: f32, rotation: glam::Quat, (catch_up, backlog_kept): (f32, f32)) {
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
    pub(super) fn relaxed(&self, c: usize, at: [usize; 3], h2: f32, inverse_dt: f32) -> f32 {
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
    pub(super) fn resolve_potential(&mut self, push: f32, share: f32) {
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
}
