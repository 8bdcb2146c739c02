// Where a particle's values live in the solver's buffers (`layout.rs` on the CPU side):
// strands in groups of LANES, and within a group particle j of every strand side by side.
// An invocation steps one strand, so the invocations of a group, which step particle j of
// their strands together, read and write one run of memory instead of one place a strand
// apart. Each per-particle value is an array of its own (a plane of `slot_count` slots);
// the padding at the end of the last group is never read.

const LANES: u32 = 32u;

// The slot of particle 0 of `strand` (of strands with `n` particles).
fn root_slot(strand: u32, n: u32) -> u32 {
    return (strand / LANES) * LANES * n + strand % LANES;
}

// The slot of particle `j` of the strand whose root is at slot `root`; its parent's is
// LANES before it.
fn particle_slot(root: u32, j: u32) -> u32 {
    return root + j * LANES;
}

// Slots in a plane: the strands rounded up to whole groups, times `n`.
fn slot_count(strands: u32, n: u32) -> u32 {
    return (strands + LANES - 1u) / LANES * LANES * n;
}

// The strand (x) and the particle index within it (y) of slot `i`: `particle_slot`'s
// inverse. (For the padding at the end of the last group, a strand past the last.)
fn slot_particle(i: u32, n: u32) -> vec2<u32> {
    let group = i / (LANES * n);
    let within = i % (LANES * n);
    return vec2<u32>(group * LANES + within % LANES, within / LANES);
}

// Invocations per workgroup, in every pass here (`WORKGROUP_SIZE` in `lib.rs`).
const WORKGROUP_SIZE: u32 = 64u;

// The index of invocation `id` of a dispatch of `groups` workgroups: a dispatch over more
// workgroups than a dimension holds spreads them over rows of `groups.x` (`dispatch_over`
// in `recorder.rs`).
fn invocation(id: vec3<u32>, groups: vec3<u32>) -> u32 {
    return id.x + id.y * groups.x * WORKGROUP_SIZE;
}
