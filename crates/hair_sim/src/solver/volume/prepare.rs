//! A step's grid: made from every strand, made again from the strands that moved, or
//! kept as it is where nothing did (a groom asleep under a still head).

use super::{Feedback, SplatPart, VolumeGrid, VolumeStep};
use crate::math::{Pose, Vec3};
use crate::solver::RestShape;
use crate::solver::params::{LengthMode, SimdPath, Volume};

/// The volume's part of one step of `dt` seconds in `substeps` substeps, before the
/// strands move: the grid made from `positions` and `velocities` (head-local by `pose`, the
/// head's pose at the step's start; `next` is its pose at the step's end), its pressure
/// solved
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
pub(in crate::solver) fn prepare(
    grid: &mut VolumeGrid,
    made_from: &mut Option<MadeFrom>,
    rest: &RestShape,
    positions: &[Vec3],
    velocities: &[Vec3],
    (pose, next): (Pose, Pose),
    (volume, mode): (&Volume, LengthMode),
    (dt, substeps): (f32, u32),
    (parts, simd, run): (usize, SimdPath, impl FnOnce(&mut [SplatPart<'_>])),
) -> VolumeStep {
    let n = rest.particles_per_strand.max(1);
    let under: Under = (pose, (dt, substeps), *volume, mode);
    let moved = made_from.as_ref().and_then(|made| made.moved(positions, velocities, n, under));
    match moved {
        Some(moved) if moved.is_empty() => return made_from.as_ref().expect("compared with").step.clone(),
        Some(moved) if moved.len() * RESPLAT_SHARE <= rest.strand_count() => {
            grid.resplat(n, &moved, positions, velocities, pose)
        }
        _ => grid.splat_on(rest, positions, Some(velocities), pose, (parts, simd), run),
    }
    let feedback = Feedback::new(grid, volume, mode, n, (dt, substeps));
    grid.solve_pressure(volume.pressure_iterations, dt, pose.rotation, (feedback.catch_up, feedback.backlog_kept));
    grid.resolve_potential(feedback.push, volume.pressure);
    let step = VolumeStep::new(feedback, pose.rotation);
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

/// What a step's grid is made under: the head's pose at the step's start, the step's length
/// and substeps, the settings and the length model. A grid made under others is made again
/// from every strand.
type Under = (Pose, (f32, u32), Volume, LengthMode);

/// What a step's grid was last made from ([`prepare`]), and the feedback it gave.
#[derive(Clone, Debug)]
pub(in crate::solver) struct MadeFrom {
    positions: Vec<Vec3>,
    velocities: Vec<Vec3>,
    under: Under,
    step: VolumeStep,
}

impl MadeFrom {
    /// The strands (of `n` particles) whose positions or velocities changed since; `None`
    /// where the head, the step, the settings or the length model did (every strand then).
    fn moved(&self, positions: &[Vec3], velocities: &[Vec3], n: usize, under: Under) -> Option<Vec<usize>> {
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
    fn remember(slot: &mut Option<MadeFrom>, positions: &[Vec3], velocities: &[Vec3], under: Under, step: &VolumeStep) {
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
