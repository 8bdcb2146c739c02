//! Bevy diagnostics the plugin publishes: read them from `DiagnosticsStore` (a UI, a log).

use bevy::diagnostic::DiagnosticPath;

/// Paths of the hair diagnostics. The simulation ones are always published; the drawing
/// ones with the `render` feature.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// # use bevy::diagnostic::DiagnosticsStore;
/// fn hair_step_time(store: Res<DiagnosticsStore>) {
///     if let Some(ms) = store.get(&HairDiagnostics::STEP_TIME).and_then(|d| d.smoothed()) {
///         info!("hair step: {ms:.2} ms");
///     }
/// }
/// ```
///
/// Add Bevy's `DiagnosticsPlugin` (part of `DefaultPlugins`) to have them recorded.
pub struct HairDiagnostics;

impl HairDiagnostics {
    /// Wall time of the last fixed step's solver work, milliseconds, all grooms.
    pub const STEP_TIME: DiagnosticPath = DiagnosticPath::const_new("hair/step_ms");
    /// GPU time of the GPU solver's step, milliseconds, summed over the grooms the GPU
    /// steps ([`HairBackend::Gpu`](crate::HairBackend::Gpu)): for each, one of its latest
    /// steps, from its first pass's start (hair volume's, where it is on) to its last's end
    /// by timestamp queries (the GPU may run other work beside it meanwhile), copied back
    /// with its report a frame or two late. Published only where the render device has
    /// timestamp queries.
    pub const GPU_STEP_TIME: DiagnosticPath = DiagnosticPath::const_new("hair/gpu_step_ms");
    /// Of [`Self::GPU_STEP_TIME`], the hair volume grid's passes
    /// ([`SimParams::volume`](crate::SimParams::volume)), milliseconds, summed over the grooms
    /// whose step had volume. Published only where one did and the render device has
    /// timestamp queries.
    pub const GPU_VOLUME_TIME: DiagnosticPath = DiagnosticPath::const_new("hair/gpu_volume_ms");
    /// Wall time of the last fixed step's hand-over of the GPU solver's work to the render
    /// world (the step's input written down for extraction), milliseconds, summed over the
    /// grooms the GPU steps: all the main thread spends on their steps.
    pub const GPU_HANDOVER_TIME: DiagnosticPath = DiagnosticPath::const_new("hair/gpu_handover_ms");
    /// Guide strands the solver stepped in the last fixed step, all grooms (a level of
    /// detail, [`HairLod`](crate::HairLod), leaves out the guides that follow).
    pub const GUIDES: DiagnosticPath = DiagnosticPath::const_new("hair/guides");
    /// Particles of those guides.
    pub const PARTICLES: DiagnosticPath = DiagnosticPath::const_new("hair/particles");
    /// Strands drawn (guides and children).
    pub const RENDERED_STRANDS: DiagnosticPath = DiagnosticPath::const_new("hair/rendered_strands");
    /// Vertices of the strand meshes drawn.
    pub const RENDERED_VERTICES: DiagnosticPath = DiagnosticPath::const_new("hair/rendered_vertices");
    /// Bytes of guide data written to the GPU in the last frame.
    pub const UPLOADED_BYTES: DiagnosticPath = DiagnosticPath::const_new("hair/uploaded_bytes");
    /// Wall time of the last frame's drawing work on the CPU, milliseconds, all grooms:
    /// the guide particles interpolated and placed, their frames, the draw order and the
    /// opacity maps, written to the GPU.
    pub const UPLOAD_TIME: DiagnosticPath = DiagnosticPath::const_new("hair/upload_ms");
    /// Wall time the hair's extraction into the render world took since the last frame,
    /// milliseconds ([`HairRenderSystems::Extract`](crate::HairRenderSystems)).
    pub const EXTRACT_TIME: DiagnosticPath = DiagnosticPath::const_new("hair/extract_ms");
    /// Wall time the hair's other render-world systems took since the last frame,
    /// milliseconds (on the render thread where rendering is pipelined): the GPU grooms'
    /// passes recorded, the CPU grooms' particles written, copies back collected.
    pub const RENDER_TIME: DiagnosticPath = DiagnosticPath::const_new("hair/render_ms");

    /// Every path above, for registration.
    pub const ALL: [DiagnosticPath; 12] = [
        Self::STEP_TIME,
        Self::GPU_STEP_TIME,
        Self::GPU_VOLUME_TIME,
        Self::GPU_HANDOVER_TIME,
        Self::GUIDES,
        Self::PARTICLES,
        Self::RENDERED_STRANDS,
        Self::RENDERED_VERTICES,
        Self::UPLOADED_BYTES,
        Self::UPLOAD_TIME,
        Self::EXTRACT_TIME,
        Self::RENDER_TIME,
    ];
}
