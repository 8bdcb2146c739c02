// Hair with volume: hair_sim's `VolumeGrid` (`solver/volume.rs`) on the GPU, once a step
// before its substeps. Every particle splats its mass and momentum into the eight cells
// around it with integer atomics (`splat_particles`); each cell's mean velocity and density
// excess are worked out once (`resolve_cells`), and how far it would overflow
// (`predict_overflow`); the pressure is relaxed in red and black sweeps (`relax_red`,
// `relax_black`); each cell's potential is worked out from its excess and pressure
// (`resolve_potential`) and carried into the walls, the cells inside the head without hair
// (`extend_potential`); each particle's velocity then moves toward the mean around it and
// down the potential (`feed_back`), or for the spring model that answer is left for its
// implicit solve; the push is left for the end of the step's first substep too, which
// takes back the speed it left (`take_back_grid_push` in `step/entry.wgsl`). The splat is
// the CPU's, integer for integer: a particle adds at most 2^31 to a cell's sum, and the
// sums are 64-bit, held as two words (low, high), so they are the same in any order.
// `layout.wgsl` is prepended: where each particle's values live.
//
// As on the CPU, the grid is worked out again only where something moved since it was
// last made: `compare_made_from` compares each particle's position and velocity with
// those it was made from, bit for bit, and `open_gate` writes the grid's dispatches'
// workgroups (none where nothing moved and the step's head pose, length and settings are
// the last grid's), which run from a copy of them as indirect dispatches. A groom asleep
// under a still head keeps its grid, and its step runs only the feedback.

struct Volume {
    // Strands, particles per strand, cells; 1 in w where the grid is worked out whatever
    // moved (the step's head pose, length or settings are not the last grid's, or the grid
    // is new: `open_gate`).
    counts: vec4<u32>,
    // Cells along x, y and z (x fastest).
    dims: vec4<u32>,
    // The grid's head-local corner; cells per metre.
    origin: vec4<f32>,
    // The head's pose at the step's start: world → head-local as a rotation's columns and
    // the translation it undoes; head-local → world as a rotation's columns.
    inverse: array<vec4<f32>, 3>,
    translation: vec4<f32>,
    rotation: array<vec4<f32>, 3>,
    // The push per unit of gradient (`Feedback::push`), the mean rest mass per cell as a
    // share of one particle (`rest_scale`), the share of the pressure's velocity change
    // applied (`Volume::pressure`), the cell's side squared.
    feedback: vec4<f32>,
    // 1 / the step's length (the pressure's source is an overflow per second); 1 in y where
    // the spring model takes the grid's answer into its implicit solve (`feed_back`); the
    // step's length; the share of the density beyond a cell's target the pressure takes
    // away in the step (`Feedback::catch_up`).
    solve: vec4<f32>,
    // The share of a cell's last overflow, where it was positive, that the step adds to its
    // own while the cell is over its target (`Feedback::backlog_kept`); the mass, in
    // particles, that any cell may fill up to before the pressure pushes
    // (`VolumeGrid::floor`); what the push's and the pressure's velocity change is scaled
    // by, as it acts over the step's first substep alone (`Feedback::push_scale`); w unused.
    overflow: vec4<f32>,
    // The workgroups along x and y of a dispatch over the slots, then over the cells
    // (`open_gate`).
    workgroups: vec4<u32>,
}

@group(0) @binding(0) var<uniform> volume: Volume;
@group(0) @binding(1) var<storage, read> positions: array<vec4<f32>>;
// The solver's `motion`: its first plane is the velocities.
@group(0) @binding(2) var<storage, read_write> motion: array<vec4<f32>>;
// Per cell, eight words: mass, then momentum along x, y and z, each low word then high.
@group(0) @binding(3) var<storage, read_write> sums: array<atomic<u32>>;
// Per cell, two vec4: the mean velocity and the density excess; the mass (0: empty), the
// mass over the pressure's target, the overflow (`predict_overflow`) and the potential
// (`resolve_potential`, `extend_potential`).
@group(0) @binding(4) var<storage, read_write> cells: array<vec4<f32>>;
// Per cell, the rest pose's mass, low word then high.
@group(0) @binding(5) var<storage, read> rest_mass: array<u32>;
// Per particle index, root to tip, the share of the difference to the mean taken; for the
// spring model, the friction's rate per second (`Feedback::rates`).
@group(0) @binding(6) var<storage, read> shares: array<f32>;
// Per cell, the pressure, kept between steps as the next one's start.
@group(0) @binding(7) var<storage, read_write> pressure: array<f32>;
// Per cell, 1 where it lies inside the head (without hair, a wall: `VolumeGrid::solid`),
// else 0.
@group(0) @binding(8) var<storage, read> solid: array<u32>;
// Per cell, the overflow the last step's pressure took away (`VolumeGrid::backlog`), kept
// between steps.
@group(0) @binding(9) var<storage, read_write> backlog: array<f32>;

// Per slot, the position the grid was last made from, then per slot the velocity.
@group(0) @binding(10) var<storage, read_write> made_from: array<vec4<f32>>;
// Whether a particle moved since the grid was made (`GATE_MOVED`), how many times it was
// made (`GATE_MADE`), and the workgroups of its dispatches over the slots and over the
// cells (`GATE_ARGS`, six words: x, y, z each), copied to where they are dispatched from.
@group(0) @binding(11) var<storage, read_write> gate: array<atomic<u32>>;

const GATE_MOVED: u32 = 0u;
const GATE_MADE: u32 = 1u;
const GATE_ARGS: u32 = 2u;

// hair_sim's `WEIGHT_BITS` (as a weight of one), `PARTICLE_MASS_UNITS`, `VELOCITY_BITS`
// (as a scale) and `MAX_FIXED_VELOCITY` (a test checks).
const WEIGHT_ONE: i32 = 32;
const PARTICLE_MASS_UNITS: f32 = 32768.0;
const VELOCITY_SCALE: f32 = 2048.0;
const MAX_FIXED_VELOCITY: f32 = 65535.0;
const WORDS_PER_CELL: u32 = 8u;
// hair_sim's `PRESSURE_SLACK`.
const PRESSURE_SLACK: f32 = 0.05;

// A point's cell (its lowest corner) and fixed-point weights per axis, as
// `VolumeGrid::splat_of` finds them; `inside` false outside the grid.
struct Splat {
    base: vec3<u32>,
    fixed: vec3<i32>,
    inside: bool,
}

fn splat_of(p: vec3<f32>) -> Splat {
    var splat: Splat;
    let g = (p - volume.origin.xyz) * volume.origin.w;
    let last = vec3<f32>(volume.dims.xyz - vec3<u32>(1u));
    // Compared as floats, so that a point far outside (or not finite) never becomes an
    // index.
    splat.inside = all(g >= vec3<f32>(0.0)) && all(g < last);
    if !splat.inside {
        return splat;
    }
    let base = floor(g);
    splat.base = vec3<u32>(base);
    let fraction = g - base;
    splat.fixed = clamp(vec3<i32>(floor(fraction * f32(WEIGHT_ONE) + 0.5)), vec3<i32>(0), vec3<i32>(WEIGHT_ONE));
    return splat;
}

// The cell of `corner` (bits x, y, z) of `splat`, and its integer weight.
fn corner_cell(splat: Splat, corner: u32) -> u32 {
    let at = splat.base + vec3<u32>(corner & 1u, (corner >> 1u) & 1u, (corner >> 2u) & 1u);
    return at.x + volume.dims.x * (at.y + volume.dims.y * at.z);
}

fn corner_weight(splat: Splat, corner: u32) -> i32 {
    let bits = vec3<bool>((corner & 1u) == 1u, ((corner >> 1u) & 1u) == 1u, ((corner >> 2u) & 1u) == 1u);
    let w = select(vec3<i32>(WEIGHT_ONE) - splat.fixed, splat.fixed, bits);
    return w.x * w.y * w.z;
}

// A velocity component in the sums' fixed point (`fixed_velocity` on the CPU).
fn fixed_velocity(v: f32) -> i32 {
    // Not finite (NaN fails every comparison): 0, as on the CPU.
    if !(abs(v) <= 3.0e38) {
        return 0;
    }
    return i32(clamp(floor(v * VELOCITY_SCALE + 0.5), -MAX_FIXED_VELOCITY, MAX_FIXED_VELOCITY));
}

// Adds `value`, sign-extended, to the 64-bit sum at word `at`: the low word's carry goes
// to the high word with the sign.
fn add_wide(at: u32, value: i32) {
    let low = bitcast<u32>(value);
    let old = atomicAdd(&sums[at], low);
    let high = select(0u, 0xffffffffu, value < 0) + select(0u, 1u, old + low < old);
    if high != 0u {
        atomicAdd(&sums[at + 1u], high);
    }
}

// The 64-bit integer (low, high) as the nearest float, near enough (two roundings).
fn wide_f32(low: u32, high: u32) -> f32 {
    return f32(bitcast<i32>(high)) * 4294967296.0 + f32(low);
}

fn loaded(at: u32) -> vec2<u32> {
    return vec2<u32>(atomicLoad(&sums[at]), atomicLoad(&sums[at + 1u]));
}

// Where the particle of slot `i` splats: `inside` false for padding, a root (pinned, not
// counted) or a particle outside the grid. Head-local by the head's pose at the step's start.
fn particle_splat(i: u32) -> Splat {
    var none: Splat;
    let particle = slot_particle(i, volume.counts.y);
    if i >= slot_count(volume.counts.x, volume.counts.y) || particle.x >= volume.counts.x || particle.y == 0u {
        return none;
    }
    let x = positions[i].xyz - volume.translation.xyz;
    return splat_of(volume.inverse[0].xyz * x.x + volume.inverse[1].xyz * x.y + volume.inverse[2].xyz * x.z);
}

// Whether the particle of slot `i` moved since the grid was made, bit for bit as the CPU
// compares (`MadeFrom::moved`); where it did, what it is now is kept for the next step.
@compute @workgroup_size(WORKGROUP_SIZE)
fn compare_made_from(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(id, groups);
    let slots = slot_count(volume.counts.x, volume.counts.y);
    if i >= slots {
        return;
    }
    let x = positions[i].xyz;
    let v = motion[i].xyz;
    let was_x = bitcast<vec3<u32>>(made_from[i].xyz);
    let was_v = bitcast<vec3<u32>>(made_from[slots + i].xyz);
    if any(bitcast<vec3<u32>>(x) != was_x) || any(bitcast<vec3<u32>>(v) != was_v) {
        atomicOr(&gate[GATE_MOVED], 1u);
        made_from[i] = vec4<f32>(x, 0.0);
        made_from[slots + i] = vec4<f32>(v, 0.0);
    }
}

// The grid's dispatches: their workgroups where a particle moved or the step asks
// (`volume.counts.w`), else none. One invocation.
@compute @workgroup_size(WORKGROUP_SIZE)
fn open_gate(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    if invocation(id, groups) != 0u {
        return;
    }
    let open = atomicExchange(&gate[GATE_MOVED], 0u) != 0u || volume.counts.w == 1u;
    if open {
        atomicAdd(&gate[GATE_MADE], 1u);
    }
    // x, y and z over the slots, then over the cells; all 0 where closed.
    let on = select(0u, 1u, open);
    let w = volume.workgroups * on;
    let args = array<u32, 6>(w.x, w.y, on, w.z, w.w, on);
    for (var k = 0u; k < 6u; k++) {
        atomicStore(&gate[GATE_ARGS + k], args[k]);
    }
}

// Zeroes cell `c`'s sums before the splat.
@compute @workgroup_size(WORKGROUP_SIZE)
fn clear_sums(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let c = invocation(id, groups);
    if c >= volume.counts.z {
        return;
    }
    for (var w = 0u; w < WORDS_PER_CELL; w++) {
        atomicStore(&sums[c * WORDS_PER_CELL + w], 0u);
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn splat_particles(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(id, groups);
    let splat = particle_splat(i);
    if !splat.inside {
        return;
    }
    let v = motion[i].xyz;
    let fixed = vec3<i32>(fixed_velocity(v.x), fixed_velocity(v.y), fixed_velocity(v.z));
    for (var corner = 0u; corner < 8u; corner++) {
        let at = corner_cell(splat, corner) * WORDS_PER_CELL;
        let w = corner_weight(splat, corner);
        add_wide(at, w);
        add_wide(at + 2u, w * fixed.x);
        add_wide(at + 4u, w * fixed.y);
        add_wide(at + 6u, w * fixed.z);
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn resolve_cells(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let c = invocation(id, groups);
    if c >= volume.counts.z {
        return;
    }
    let at = c * WORDS_PER_CELL;
    let mass = loaded(at);
    let rest = vec2<u32>(rest_mass[2u * c], rest_mass[2u * c + 1u]);
    // mass − rest in 64 bits, then as a float.
    let low = mass.x - rest.x;
    let high = mass.y - rest.y - select(0u, 1u, mass.x < rest.x);
    // Only where the hair is denser than at rest, as on the CPU.
    let excess = max(wide_f32(low, high), 0.0) / PARTICLE_MASS_UNITS / volume.feedback.y;
    let m = wide_f32(mass.x, mass.y);
    var mean = vec3<f32>(0.0);
    if m > 0.0 {
        let scale = 1.0 / (m * VELOCITY_SCALE);
        let px = loaded(at + 2u);
        let py = loaded(at + 4u);
        let pz = loaded(at + 6u);
        mean = vec3<f32>(wide_f32(px.x, px.y), wide_f32(py.x, py.y), wide_f32(pz.x, pz.y)) * scale;
    } else {
        // No hair, no pressure: the sweeps read it as such from their first pass. Nor a
        // backlog.
        pressure[c] = 0.0;
        backlog[c] = 0.0;
    }
    // The mass over the pressure's target, as `VolumeGrid::resolve_cells` works it out.
    let wanted = max(wide_f32(rest.x, rest.y) / PARTICLE_MASS_UNITS, volume.overflow.y) * (1.0 + PRESSURE_SLACK);
    cells[2u * c] = vec4<f32>(mean, excess);
    cells[2u * c + 1u] = vec4<f32>(m, m / PARTICLE_MASS_UNITS / wanted, 0.0, 0.0);
}

// Cell `c`'s coordinates along x, y and z (hair_sim's `Lattice::coordinates`).
fn coordinates(c: u32) -> vec3<u32> {
    let d = volume.dims.xyz;
    return vec3<u32>(c % d.x, (c / d.x) % d.y, c / (d.x * d.y));
}

// No cell: a neighbour beyond the grid.
const NONE: u32 = 0xffffffffu;

// Cell `c`'s (at `at`) neighbour below (`above` false) or above along `axis`, or `NONE`
// beyond the grid (hair_sim's `Lattice::neighbours`).
fn neighbour(c: u32, at: vec3<u32>, axis: u32, above: bool) -> u32 {
    let d = volume.dims.xyz;
    var strides = array<u32, 3>(1u, d.x, d.x * d.y);
    let stride = strides[axis];
    if above {
        return select(NONE, c + stride, at[axis] + 1u < d[axis]);
    }
    return select(NONE, c - stride, at[axis] > 0u);
}

// The mean velocity of cell `n` (a neighbour's, `NONE` beyond the grid), or `own` where
// that is beyond the grid or holds no hair (`VolumeGrid::divergence`).
fn mean_beside(n: u32, own: vec3<f32>) -> vec3<f32> {
    if n == NONE {
        return own;
    }
    return select(own, cells[2u * n].xyz, cells[2u * n + 1u].x > 0.0);
}

// Cell `c`'s overflow: the density beyond its target the step would leave were the hair
// to go on spreading or packing as it does, `catch_up` of what is beyond it now taken away
// (hair_sim's `VolumeGrid::resolve_overflow`), from the divergence of the mean velocity
// along the head's axes, and a share of the last step's, kept for the next.
@compute @workgroup_size(WORKGROUP_SIZE)
fn predict_overflow(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let c = invocation(id, groups);
    if c >= volume.counts.z {
        return;
    }
    let cell = cells[2u * c + 1u];
    if !(cell.x > 0.0) {
        cells[2u * c + 1u].z = 0.0;
        return;
    }
    let at = coordinates(c);
    let own = cells[2u * c].xyz;
    let inverse_2h = 0.5 * volume.origin.w;
    var divergence = 0.0;
    for (var a = 0u; a < 3u; a++) {
        let below = mean_beside(neighbour(c, at, a, false), own);
        let above = mean_beside(neighbour(c, at, a, true), own);
        divergence += dot(above - below, volume.rotation[a].xyz) * inverse_2h;
    }
    // Remembered only while the cell is over its target, as on the CPU.
    let held = select(0.0, volume.overflow.x * max(backlog[c], 0.0), cell.y > 1.0);
    let overflow = volume.solve.w * (cell.y - 1.0) - cell.y * volume.solve.z * divergence + held;
    backlog[c] = overflow;
    // Below the target, room the hair around may flow into; none inside the head.
    cells[2u * c + 1u].z = select(overflow, max(overflow, 0.0), solid[c] != 0u);
}

// Whether cell `c` is a wall: inside the head, without hair (`VolumeGrid::is_wall`).
fn is_wall(c: u32) -> bool {
    return solid[c] != 0u && !(cells[2u * c + 1u].x > 0.0);
}

// One Gauss–Seidel update of cell `c`'s pressure if it is of `colour` (its coordinates'
// sum, odd or even), from its six neighbours, which are all of the other colour (hair_sim's
// `VolumeGrid::relaxed`): 0 without hair, a wall beside it left out, never below 0.
fn relax(c: u32, colour: u32) {
    if c >= volume.counts.z {
        return;
    }
    let at = coordinates(c);
    if (at.x + at.y + at.z + colour) % 2u != 0u {
        return;
    }
    let cell = cells[2u * c + 1u];
    if !(cell.x > 0.0) {
        pressure[c] = 0.0;
        return;
    }
    // In the CPU's order.
    var around = 0.0;
    var open = 0.0;
    for (var k = 0u; k < 6u; k++) {
        let n = neighbour(c, at, k / 2u, k % 2u == 1u);
        if n == NONE {
            open += 1.0;
        } else if !is_wall(n) {
            around += pressure[n];
            open += 1.0;
        }
    }
    if open == 0.0 {
        pressure[c] = 0.0;
        return;
    }
    pressure[c] = max((around + volume.feedback.w * cell.z * volume.solve.x) / open, 0.0);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn relax_red(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    relax(invocation(id, groups), 0u);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn relax_black(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    relax(invocation(id, groups), 1u);
}

// Each cell's potential, but a wall's: the density push's share of the excess less the
// pressure's share of the pressure (`VolumeGrid::resolve_potential`).
@compute @workgroup_size(WORKGROUP_SIZE)
fn resolve_potential(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let c = invocation(id, groups);
    if c >= volume.counts.z || is_wall(c) {
        return;
    }
    cells[2u * c + 1u].w = volume.feedback.x * cells[2u * c].w - volume.feedback.z * pressure[c];
}

// A wall's potential: the mean of its neighbours' that hold hair, 0 where none does, so
// that nothing is pushed into the head (`VolumeGrid::wall_potential`).
@compute @workgroup_size(WORKGROUP_SIZE)
fn extend_potential(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let c = invocation(id, groups);
    if c >= volume.counts.z || !is_wall(c) {
        return;
    }
    let at = coordinates(c);
    // In the CPU's order.
    var sum = 0.0;
    var count = 0.0;
    for (var k = 0u; k < 6u; k++) {
        let n = neighbour(c, at, k / 2u, k % 2u == 1u);
        if n != NONE && cells[2u * n + 1u].x > 0.0 {
            sum += cells[2u * n + 1u].w;
            count += 1.0;
        }
    }
    cells[2u * c + 1u].w = select(0.0, sum / count, count > 0.0);
}

// The potential's gradient at cell `c` (per cell) by central differences, 0 beyond the grid
// (`VolumeGrid::resolve_gradients`).
fn node_gradient(c: u32) -> vec3<f32> {
    let at = coordinates(c);
    var g = vec3<f32>(0.0);
    for (var a = 0u; a < 3u; a++) {
        let below = neighbour(c, at, a, false);
        let above = neighbour(c, at, a, true);
        var down = 0.0;
        var up = 0.0;
        if below != NONE {
            down = cells[2u * below + 1u].w;
        }
        if above != NONE {
            up = cells[2u * above + 1u].w;
        }
        g[a] = (up - down) * 0.5;
    }
    return g;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn feed_back(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(id, groups);
    let splat = particle_splat(i);
    // The step shader's planes of the grid's answer for its springs (`grid_friction`,
    // `grid_kick`).
    let slots = slot_count(volume.counts.x, volume.counts.y);
    let implicit = volume.solve.y == 1.0;
    if !splat.inside {
        if i < slots {
            motion[7u * slots + i] = vec4<f32>(0.0);
            if implicit {
                motion[6u * slots + i] = vec4<f32>(0.0);
            }
        }
        return;
    }
    // `VolumeGrid::sample`: the mean velocity over the cells that hold hair, and the
    // cells' gradients of the potential, interpolated. A corner with weight holds hair.
    var velocity = vec3<f32>(0.0);
    var weight = 0.0;
    var gradient = vec3<f32>(0.0);
    for (var corner = 0u; corner < 8u; corner++) {
        let c = corner_cell(splat, corner);
        let weighed = corner_weight(splat, corner);
        if cells[2u * c + 1u].x > 0.0 {
            let w = f32(weighed) / PARTICLE_MASS_UNITS;
            velocity += cells[2u * c].xyz * w;
            weight += w;
        }
        if weighed != 0 {
            gradient += node_gradient(c) * f32(weighed);
        }
    }
    if weight > 0.0 {
        velocity /= weight;
    }
    let push = gradient * (volume.origin.w * volume.overflow.z / PARTICLE_MASS_UNITS);
    let world_push = volume.rotation[0].xyz * push.x + volume.rotation[1].xyz * push.y + volume.rotation[2].xyz * push.z;
    let j = slot_particle(i, volume.counts.y).y;
    let v = motion[i];
    // The push and how fast the particle was leaving along it, times its size, for the
    // end of the step's first substep (`take_back_grid_push`; hair_sim's `GridPush::new`).
    motion[7u * slots + i] = vec4<f32>(world_push, max(dot(v.xyz, world_push), 0.0));
    if implicit {
        motion[6u * slots + i] = vec4<f32>(velocity, shares[j]);
    } else {
        motion[i] = vec4<f32>(v.xyz + (velocity - v.xyz) * shares[j] + world_push, v.w);
    }
}
