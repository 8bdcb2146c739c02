// What a renderer reads of GPU strands, written on the GPU (`draw.rs`): after each step
// the particles in head space (`publish_local`), and each frame the particles as drawn
// (interpolated between the last two steps, placed on the head as posed in the frame) with
// their parallel-transport frame vectors (`draw_strands`). `curve.wgsl` and `layout.wgsl`
// are prepended: the solver's buffers, and the head-space copies, are laid out as the
// latter says; the renderer's is strand by strand.
//
// Mirrors what bevy_hair does on the CPU for a CPU groom: `HairState::publish` and
// `interpolated_positions`, and `hair_sim::groom::curve::transport_frames`.

struct Placement {
    // An affine map, p ↦ x p.x + y p.y + z p.z + w (w of each unused): head ← solver for
    // `publish_local`, world ← head for `draw_strands`.
    x: vec4<f32>,
    y: vec4<f32>,
    z: vec4<f32>,
    w: vec4<f32>,
    // Strands, particles per strand.
    counts: vec4<u32>,
    // The fraction of the way from the previous step to the last, in x.
    overstep: vec4<f32>,
}

@group(0) @binding(0) var<uniform> placement: Placement;
// The solver's positions (the step shader's `positions`).
@group(0) @binding(1) var<storage, read> positions: array<vec4<f32>>;
// The solver's rest shape (the step shader's `rest`): two planes, the head-local rest position
// first.
@group(0) @binding(2) var<storage, read> rest: array<vec4<f32>>;
// Head-space particles after the step before the last, and after the last.
@group(0) @binding(3) var<storage, read> previous: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> current: array<vec4<f32>>;
// Per strand: the frame vector `u` at its root, head space.
@group(0) @binding(5) var<storage, read> root_u: array<vec4<f32>>;
// The renderer's buffer: one vec4 per particle (w = 1), then one per particle for its
// frame vector (w = 0).
@group(0) @binding(6) var<storage, read_write> drawn: array<vec4<f32>>;

fn place(p: vec3<f32>) -> vec3<f32> {
    return placement.x.xyz * p.x + placement.y.xyz * p.y + placement.z.xyz * p.z + placement.w.xyz;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn publish_local(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(id, groups);
    if i >= slot_count(placement.counts.x, placement.counts.y) {
        return;
    }
    current[i] = vec4(place(positions[i].xyz), 1.0);
}

// Drawn particle `j` of the strand starting at `first`, with the neighbours past either
// end mirrored (`hair_sim::groom::curve::particle`).
fn drawn_particle(first: u32, n: u32, j: i32) -> vec3<f32> {
    if j < 0 {
        return 2.0 * drawn[first].xyz - drawn[first + 1u].xyz;
    }
    if j >= i32(n) {
        return 2.0 * drawn[first + n - 1u].xyz - drawn[first + n - 2u].xyz;
    }
    return drawn[first + u32(j)].xyz;
}

// The curve's tangent at particle `j`: `evaluate(points, j).tangent`.
fn particle_tangent(first: u32, n: u32, j: u32) -> vec3<f32> {
    let segment = i32(min(j, n - 2u));
    let t = f32(j) - f32(segment);
    let prev = drawn_particle(first, n, segment - 1);
    let p0 = drawn_particle(first, n, segment);
    let p1 = drawn_particle(first, n, segment + 1);
    let next = drawn_particle(first, n, segment + 2);
    return bezier_point(prev, p0, p1, next, t).tangent;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn draw_strands(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let strand = invocation(id, groups);
    let strands = placement.counts.x;
    let n = placement.counts.y;
    if strand >= strands || n < 2u {
        return;
    }
    let slot = root_slot(strand, n);
    let first = strand * n;
    let t = clamp(placement.overstep.x, 0.0, 1.0);
    // The root where the rest shape pins it this frame; the rest interpolated.
    drawn[first] = vec4(place(rest[slot].xyz), 1.0);
    for (var j = 1u; j < n; j++) {
        let i = particle_slot(slot, j);
        drawn[first + j] = vec4(place(mix(previous[i].xyz, current[i].xyz, t)), 1.0);
    }
    // `transport_frames`, from the root's `u` turned with the head.
    let u0 = root_u[strand].xyz;
    let turned = placement.x.xyz * u0.x + placement.y.xyz * u0.y + placement.z.xyz * u0.z;
    let frames = strands * n;
    var tangent = particle_tangent(first, n, 0u);
    var u = perpendicular_unit(turned, tangent);
    drawn[frames + first] = vec4(u, 0.0);
    for (var j = 1u; j < n; j++) {
        let next = particle_tangent(first, n, j);
        u = transport(u, tangent, next);
        tangent = next;
        drawn[frames + first + j] = vec4(u, 0.0);
    }
}
