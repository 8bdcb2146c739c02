//! Without the `render` feature there is no GPU: every step is the CPU's, and nothing
//! holds GPU strands to keep in step.

use super::GpuSupport;
use hair_sim::collide::HeadCollider;
use hair_sim::math::{Pose, Vec3 as SimVec3};
use hair_sim::solver::{StepInput, StepReport, Strands};
use std::sync::Arc;

/// A groom's GPU side: never running.
#[derive(Default)]
pub(crate) struct GpuSolver {
    pub handover_ms: f64,
    pub issue: Option<String>,
}

impl GpuSolver {
    pub fn step(&mut self, _: &Strands, _: &StepInput, _: &Arc<HeadCollider>, _: &GpuSupport) -> Result<bool, String> {
        Err("bevy_hair was built without its `render` feature".into())
    }

    pub fn running(&self) -> bool {
        false
    }

    pub fn lag(&self) -> Option<u64> {
        None
    }

    pub fn release(&mut self) {}

    pub fn translate(&mut self, _: SimVec3) {}

    pub fn set_rest_roots(&mut self, _: &[SimVec3]) {}

    pub fn reset(&mut self, _: Pose) {}

    pub fn take_report(&mut self) -> Option<StepReport> {
        None
    }
}
