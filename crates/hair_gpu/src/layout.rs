//! Where a particle's values live in the solver's buffers, as `layout.wgsl` (which every
//! shader here starts with) says: strands in groups of [`LANES`], and within a group
//! particle `j` of every strand side by side, each value in an array (a plane) of its own.
//!
//! An invocation steps one strand, and the invocations that run together step particle `j`
//! of neighbouring strands at the same time: laid out strand by strand, their reads land a
//! strand apart (512 bytes for 32 particles), each in a memory transaction of its own;
//! laid out this way they read one run of memory.

/// Strands in a group, as `layout.wgsl` declares (a test checks): an NVIDIA warp; half an
/// AMD wave, whose two halves still read a run each.
pub(crate) const LANES: usize = 32;

/// The slots of `strands` strands of `n` particles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Slots {
    strands: usize,
    n: usize,
}

impl Slots {
    pub fn new(strands: usize, n: usize) -> Self {
        Slots { strands, n }
    }

    /// Strands rounded up to whole groups: the strands a plane has room for.
    pub fn padded_strands(&self) -> usize {
        self.strands.div_ceil(LANES) * LANES
    }

    /// Slots in a plane (`slot_count`).
    pub fn count(&self) -> usize {
        self.padded_strands() * self.n
    }

    /// The slot of particle `j` of `strand` (`particle_slot(root_slot(strand, n), j)`).
    pub fn slot(&self, strand: usize, j: usize) -> usize {
        strand / LANES * LANES * self.n + j * LANES + strand % LANES
    }

    /// A plane of `values` given strand by strand (the padding `fill`).
    pub fn spread<T: Copy>(&self, values: &[T], fill: T) -> Vec<T> {
        let mut plane = vec![fill; self.count()];
        for (i, &value) in values.iter().enumerate().take(self.strands * self.n) {
            plane[self.slot(i / self.n, i % self.n)] = value;
        }
        plane
    }

    /// A plane's values strand by strand.
    pub fn gather<T: Copy>(&self, plane: &[T]) -> Vec<T> {
        (0..self.strands * self.n).map(|i| plane[self.slot(i / self.n, i % self.n)]).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `u32` constant of `layout.wgsl`.
    fn shader_constant(name: &str) -> u32 {
        let module = naga::front::wgsl::parse_str(include_str!("layout.wgsl")).expect("layout.wgsl parses");
        let (_, constant) = module.constants.iter().find(|(_, c)| c.name.as_deref() == Some(name)).expect(name);
        let naga::Expression::Literal(naga::Literal::U32(value)) = module.global_expressions[constant.init] else {
            panic!("{name} is a u32 literal")
        };
        value
    }

    #[test]
    fn the_shaders_lanes_and_workgroups_are_these() {
        assert_eq!(shader_constant("LANES") as usize, LANES);
        assert_eq!(shader_constant("WORKGROUP_SIZE"), crate::WORKGROUP_SIZE);
    }

    #[test]
    fn every_particle_has_a_slot_of_its_own_and_comes_back() {
        for (strands, n) in [(1, 2), (31, 5), (32, 16), (33, 3), (100, 11)] {
            let layout = Slots::new(strands, n);
            let values: Vec<usize> = (0..strands * n).collect();
            let plane = layout.spread(&values, usize::MAX);
            assert_eq!(plane.len(), strands.div_ceil(32) * 32 * n);
            // Each value once; the rest padding.
            let mut seen: Vec<usize> = plane.iter().copied().filter(|&v| v != usize::MAX).collect();
            seen.sort_unstable();
            assert_eq!(seen, values);
            assert_eq!(layout.gather(&plane), values);
            // Particle j of strands side by side in a group; a strand's particles LANES apart.
            assert_eq!(layout.slot(1, 0), layout.slot(0, 0) + 1);
            assert_eq!(layout.slot(0, 1), layout.slot(0, 0) + LANES);
        }
    }
}
