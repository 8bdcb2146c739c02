// The order blended strands are drawn in, sorted on the GPU: `hair_sim::draw_order::
// back_to_front` (its CPU twin). Each piece's key is its middle particle's squared
// distance from the eye, inverted so that the farthest sorts first, then the piece's
// number (so ties keep the order grown); a bitonic sort over the keys, padded to a power
// of two with keys that sort last; then the pieces' numbers, as floats, where the hair
// shader reads the order.
//
// Passes: `keys` (an invocation per padded key), `sort_step` once per step of the bitonic
// network (its `Step` at a dynamic offset), `write_order` (per piece).

struct Order {
    // The eye (xyz).
    eye: vec4<f32>,
    // Strands, particles per strand, segments per piece, pieces per strand.
    counts: vec4<u32>,
    // Keys (a power of two), where the order starts in `order` (in floats).
    extent: vec4<u32>,
}

struct Step {
    // The network's block size and compare distance.
    k: u32,
    j: u32,
}

@group(0) @binding(0) var<uniform> order_params: Order;
@group(0) @binding(1) var<storage, read> points: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> keys: array<vec2<u32>>;
@group(0) @binding(3) var<storage, read_write> order: array<f32>;
@group(0) @binding(4) var<uniform> network_step: Step;

fn pieces() -> u32 {
    return order_params.counts.x * order_params.counts.w;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn keys_of_pieces(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(id, groups);
    if i >= order_params.extent.x {
        return;
    }
    if i >= pieces() {
        keys[i] = vec2<u32>(0xffffffffu, 0xffffffffu);
        return;
    }
    let per_strand = order_params.counts.w;
    let n = order_params.counts.y;
    let segments = order_params.counts.z;
    let middle = min((i % per_strand) * segments + segments / 2u, n - 1u);
    let d = points[(i / per_strand) * n + middle].xyz - order_params.eye.xyz;
    let depth = d.x * d.x + d.y * d.y + d.z * d.z;
    keys[i] = vec2<u32>(~bitcast<u32>(depth), i);
}

fn before(a: vec2<u32>, b: vec2<u32>) -> bool {
    return a.x < b.x || (a.x == b.x && a.y < b.y);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn sort_step(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(id, groups);
    let l = i ^ network_step.j;
    if i >= order_params.extent.x || l <= i {
        return;
    }
    let a = keys[i];
    let b = keys[l];
    let ascending = (i & network_step.k) == 0u;
    if before(b, a) == ascending {
        keys[i] = b;
        keys[l] = a;
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn write_order(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(id, groups);
    if i >= pieces() {
        return;
    }
    order[order_params.extent.y + i] = f32(keys[i].y);
}
