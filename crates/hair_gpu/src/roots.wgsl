// Moves every strand's root within the rest shape at once (`GpuStrands::set_rest_roots`):
// one upload of a vec4 per strand, each written to its root's slot in the solver's `rest`
// (laid out as `layout.wgsl`, prepended, says; the head-local positions' plane first; w,
// the rest length of the segment ending there, is zero at a root).

// Strands, particles per strand.
@group(0) @binding(0) var<uniform> counts: vec4<u32>;
@group(0) @binding(1) var<storage, read> roots: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> rest: array<vec4<f32>>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn place_roots(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let strand = invocation(id, groups);
    if strand >= counts.x {
        return;
    }
    rest[root_slot(strand, counts.y)] = vec4(roots[strand].xyz, 0.0);
}
