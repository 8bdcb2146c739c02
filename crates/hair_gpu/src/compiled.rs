//! The passes beside the solver's step, compiled once for every groom on a device: an
//! engine compiles them off its frame (they take long) and binds each groom's buffers to
//! them as it draws (which does not).

use crate::draw::DrawingPasses;
use crate::shadow::OpacityMapPasses;
use crate::sort::DrawOrderPasses;

/// The drawing pass, the opacity map's and the draw order's passes, compiled.
#[derive(Clone)]
pub struct GpuPasses {
    /// For [`GpuDrawing::with_passes`](crate::GpuDrawing::with_passes).
    pub drawing: DrawingPasses,
    /// For [`GpuOpacityMap::with_passes`](crate::GpuOpacityMap::with_passes).
    pub opacity_map: OpacityMapPasses,
    /// For [`GpuDrawOrder::with_passes`](crate::GpuDrawOrder::with_passes).
    pub draw_order: DrawOrderPasses,
}

impl GpuPasses {
    /// Compiles every pass on `device`.
    pub fn new(device: &wgpu::Device) -> Self {
        GpuPasses {
            drawing: DrawingPasses::new(device),
            opacity_map: OpacityMapPasses::new(device),
            draw_order: DrawOrderPasses::new(device),
        }
    }
}
