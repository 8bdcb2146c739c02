//! Counting the GPU objects alive ([`live_objects`]): every buffer of this crate belongs
//! to a [`GpuStrands`](crate::GpuStrands) or a [`GpuDrawing`](crate::GpuDrawing).

/// [`GpuStrands`](crate::GpuStrands) alive, for [`live_objects`].
pub(crate) static LIVE_STRANDS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
/// [`GpuDrawing`](crate::GpuDrawing)s alive, for [`live_objects`].
pub(crate) static LIVE_DRAWINGS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// How many [`GpuStrands`](crate::GpuStrands) and [`GpuDrawing`](crate::GpuDrawing)s are alive in this process: every GPU buffer
/// of this crate belongs to one of them, so an engine that lets go of its grooms brings
/// both back to what they were (a test's count of leaks).
pub fn live_objects() -> [usize; 2] {
    [LIVE_STRANDS.load(std::sync::atomic::Ordering::Relaxed), LIVE_DRAWINGS.load(std::sync::atomic::Ordering::Relaxed)]
}

/// Counts its owner in a count of live objects while it lives.
pub(crate) struct Alive(&'static std::sync::atomic::AtomicUsize);

impl Alive {
    pub fn new(count: &'static std::sync::atomic::AtomicUsize) -> Self {
        count.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        Alive(count)
    }
}

impl Drop for Alive {
    fn drop(&mut self) {
        self.0.fetch_sub(1, std::sync::atomic::Ordering::Relaxed);
    }
}
