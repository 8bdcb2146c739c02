// A deep opacity map built from particles in GPU memory: `hair_sim::shadow::OpacityMap::build`
// (its CPU twin) pass by pass. WGSL has atomics on integers only, so the bounds and each
// cell's nearest depth are kept as order-preserving integers of their floats, and the
// deposits in fixed point (whole sums, whatever the order the particles arrive in).
//
// Passes, each a dispatch: `prepare` (an invocation per cell), `sum_points` (per
// particle, a workgroup's sum each), `frame` (one), `bounds` (per particle), `fit` (one),
// `nearest` (per particle), `deposit` (per particle), `write_map` (per cell).

const MAP_SIZE: u32 = 32u;
const MAP_LAYERS: u32 = 16u;
const CELLS: u32 = MAP_SIZE * MAP_SIZE;
// Deposits are kept in units of 1/FIXED of a layer of fibres.
const FIXED: f32 = 65536.0;
const EMPTY: u32 = 0xffffffffu;

struct Light {
    // xyz: the unit vector toward a directional light (w 0) or a point light's position (w 1).
    source: vec4<f32>,
    // Ribbon width at the root and the tip, strands per guide.
    fibres: vec4<f32>,
    // Strands, particles per strand, where the map starts in `maps` (in floats).
    counts: vec4<u32>,
}

@group(0) @binding(0) var<uniform> light: Light;
// Strand-major positions (w unused): what the drawing pass writes.
@group(0) @binding(1) var<storage, read> points: array<vec4<f32>>;
// The frame, bounds and fit, then each cell's nearest depth, then the deposits.
@group(0) @binding(2) var<storage, read_write> work: array<atomic<u32>>;
// A workgroup's sum of the points (xyz) and their count (w).
@group(0) @binding(3) var<storage, read_write> partials: array<vec4<f32>>;
// The map, as the hair shader reads it.
@group(0) @binding(4) var<storage, read_write> maps: array<f32>;

// `work`'s layout: forward, right, up (9 floats) and a flag that the map exists; the
// bounds (low u, v, d, then high); the fit (corner u, v, cells per unit, first layer).
const FRAME: u32 = 0u;
const VALID: u32 = 9u;
const LOW: u32 = 12u;
const HIGH: u32 = 15u;
const FIT: u32 = 20u;
const NEAREST: u32 = 32u;
const DEPOSITS: u32 = NEAREST + CELLS;

var<workgroup> group_sum: array<vec4<f32>, WORKGROUP_SIZE>;

// Floats as integers in the same order.
fn sortable(f: f32) -> u32 {
    let b = bitcast<u32>(f);
    return select(b | 0x80000000u, ~b, (b & 0x80000000u) != 0u);
}

fn unsortable(u: u32) -> f32 {
    return bitcast<f32>(select(~u, u & 0x7fffffffu, (u & 0x80000000u) != 0u));
}

fn load_f32(i: u32) -> f32 {
    return bitcast<f32>(atomicLoad(&work[i]));
}

fn store_f32(i: u32, value: f32) {
    atomicStore(&work[i], bitcast<u32>(value));
}

fn load_vec3(i: u32) -> vec3<f32> {
    return vec3<f32>(load_f32(i), load_f32(i + 1u), load_f32(i + 2u));
}

fn particles() -> u32 {
    return light.counts.x * light.counts.y;
}

fn is_finite(v: f32) -> bool {
    return (bitcast<u32>(v) & 0x7f800000u) != 0x7f800000u;
}

// The fibre area particle `i` stands for (`fibre_areas`): its guide's strands along the
// segment to its parent; 0 at a root, and for a particle the map leaves out.
fn area(i: u32) -> f32 {
    let n = max(light.counts.y, 2u);
    let j = i % light.counts.y;
    if j == 0u {
        return 0.0;
    }
    let width = light.fibres.x + (light.fibres.y - light.fibres.x) * f32(j) / f32(n - 1u);
    let a = light.fibres.z * max(width, 0.0) * length(points[i].xyz - points[i - 1u].xyz);
    let p = points[i].xyz;
    if !(is_finite(a) && a > 0.0 && is_finite(p.x) && is_finite(p.y) && is_finite(p.z)) {
        return 0.0;
    }
    return a;
}

// (right, up, distance along the rays) of `p`, and whether the light sees it (a point
// light not behind it).
struct Projected {
    uvd: vec3<f32>,
    seen: bool,
}

fn project(p: vec3<f32>) -> Projected {
    let forward = load_vec3(FRAME);
    let right = load_vec3(FRAME + 3u);
    let up = load_vec3(FRAME + 6u);
    if light.source.w == 0.0 {
        return Projected(vec3<f32>(dot(p, right), dot(p, up), dot(p, forward)), true);
    }
    let d = p - light.source.xyz;
    let along = dot(d, forward);
    if along > 1e-4 {
        return Projected(vec3<f32>(dot(d, right) / along, dot(d, up) / along, length(d)), true);
    }
    return Projected(vec3<f32>(0.0), false);
}

// Particle `i` as the passes after `frame` map it: its fibre area and where the light
// sees it; `mapped` false for a particle past the last, one the map leaves out, one a
// point light has behind it, and when there is no map.
struct Sample {
    area: f32,
    at: Projected,
    mapped: bool,
}

fn sample(i: u32) -> Sample {
    var out = Sample(0.0, Projected(vec3<f32>(0.0), false), false);
    if i >= particles() || atomicLoad(&work[VALID]) == 0u {
        return out;
    }
    out.area = area(i);
    if out.area == 0.0 {
        return out;
    }
    out.at = project(points[i].xyz);
    out.mapped = out.at.seen;
    return out;
}

// The four cells around cell coordinates `xy` and their bilinear weights; a cell off the
// grid is EMPTY.
struct Footprint {
    cells: vec4<u32>,
    weights: vec4<f32>,
}

fn footprint(xy: vec2<f32>) -> Footprint {
    let base = floor(xy);
    let f = xy - base;
    var out: Footprint;
    let offsets = array<vec2<i32>, 4>(vec2<i32>(0, 0), vec2<i32>(1, 0), vec2<i32>(0, 1), vec2<i32>(1, 1));
    out.weights = vec4<f32>((1.0 - f.x) * (1.0 - f.y), f.x * (1.0 - f.y), (1.0 - f.x) * f.y, f.x * f.y);
    for (var k = 0u; k < 4u; k++) {
        let c = vec2<i32>(base) + offsets[k];
        let inside = c.x >= 0 && c.y >= 0 && c.x < i32(MAP_SIZE) && c.y < i32(MAP_SIZE);
        out.cells[k] = select(EMPTY, u32(c.y) * MAP_SIZE + u32(c.x), inside);
    }
    return out;
}

fn cell_coordinates(uvd: vec3<f32>) -> vec2<f32> {
    return (uvd.xy - vec2<f32>(load_f32(FIT), load_f32(FIT + 1u))) * load_f32(FIT + 2u);
}

fn cell_area(d: f32) -> f32 {
    let side = 1.0 / load_f32(FIT + 2u);
    if light.source.w == 0.0 {
        return side * side;
    }
    return (side * d) * (side * d);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn prepare(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let cell = invocation(id, groups);
    if cell < CELLS {
        atomicStore(&work[NEAREST + cell], EMPTY);
    }
    if cell < 3u {
        atomicStore(&work[LOW + cell], EMPTY);
        atomicStore(&work[HIGH + cell], 0u);
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn sum_points(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
) {
    let i = invocation(id, groups);
    var mine = vec4<f32>(0.0);
    if i < particles() && area(i) > 0.0 {
        mine = vec4<f32>(points[i].xyz, 1.0);
    }
    group_sum[local] = mine;
    workgroupBarrier();
    for (var half = WORKGROUP_SIZE / 2u; half > 0u; half /= 2u) {
        if local < half {
            group_sum[local] += group_sum[local + half];
        }
        workgroupBarrier();
    }
    if local == 0u {
        partials[i / WORKGROUP_SIZE] = group_sum[0];
    }
}

@compute @workgroup_size(1)
fn frame() {
    var total = vec4<f32>(0.0);
    let count = (particles() + WORKGROUP_SIZE - 1u) / WORKGROUP_SIZE;
    for (var k = 0u; k < count; k++) {
        total += partials[k];
    }
    atomicStore(&work[VALID], 0u);
    if total.w == 0.0 {
        return;
    }
    let centre = total.xyz / total.w;
    var toward = -light.source.xyz;
    if light.source.w != 0.0 {
        toward = centre - light.source.xyz;
    }
    let length_squared = dot(toward, toward);
    if !(length_squared > 0.0 && is_finite(length_squared)) {
        return;
    }
    let forward = toward / sqrt(length_squared);
    // glam's `any_orthonormal_pair` (Duff et al.), the sign of a zero z its sign bit's.
    let sign = select(1.0, -1.0, (bitcast<u32>(forward.z) & 0x80000000u) != 0u);
    let a = -1.0 / (sign + forward.z);
    let b = forward.x * forward.y * a;
    let right = vec3<f32>(1.0 + sign * forward.x * forward.x * a, sign * b, -sign * forward.x);
    let up = vec3<f32>(b, sign + forward.y * forward.y * a, -forward.y);
    for (var k = 0u; k < 3u; k++) {
        store_f32(FRAME + k, forward[k]);
        store_f32(FRAME + 3u + k, right[k]);
        store_f32(FRAME + 6u + k, up[k]);
    }
    atomicStore(&work[VALID], 1u);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn bounds(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let sampled = sample(invocation(id, groups));
    if !sampled.mapped {
        return;
    }
    let projected = sampled.at;
    for (var k = 0u; k < 3u; k++) {
        atomicMin(&work[LOW + k], sortable(projected.uvd[k]));
        atomicMax(&work[HIGH + k], sortable(projected.uvd[k]));
    }
}

@compute @workgroup_size(1)
fn fit() {
    if atomicLoad(&work[VALID]) == 0u || atomicLoad(&work[LOW]) == EMPTY {
        atomicStore(&work[VALID], 0u);
        return;
    }
    var low: vec3<f32>;
    var high: vec3<f32>;
    for (var k = 0u; k < 3u; k++) {
        low[k] = unsortable(atomicLoad(&work[LOW + k]));
        high[k] = unsortable(atomicLoad(&work[HIGH + k]));
    }
    let span = max(max(high.x - low.x, high.y - low.y), 1e-6);
    let cells_per_unit = f32(MAP_SIZE - 2u) / span;
    let margin = 1.0 / cells_per_unit;
    let middle = 0.5 * (low.xy + high.xy);
    store_f32(FIT, middle.x - 0.5 * span - margin);
    store_f32(FIT + 1u, middle.y - 0.5 * span - margin);
    store_f32(FIT + 2u, cells_per_unit);
    let depth = max(high.z - low.z, 1e-4);
    store_f32(FIT + 3u, depth / f32(MAP_LAYERS * (MAP_LAYERS + 1u) / 2u));
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn nearest(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let sampled = sample(invocation(id, groups));
    if !sampled.mapped {
        return;
    }
    let projected = sampled.at;
    let cells = footprint(cell_coordinates(projected.uvd)).cells;
    for (var k = 0u; k < 4u; k++) {
        if cells[k] != EMPTY {
            atomicMin(&work[NEAREST + cells[k]], sortable(projected.uvd.z));
        }
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn deposit(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let sampled = sample(invocation(id, groups));
    if !sampled.mapped {
        return;
    }
    let projected = sampled.at;
    let d = projected.uvd.z;
    let layers = sampled.area / cell_area(d);
    let first_layer = load_f32(FIT + 3u);
    let around = footprint(cell_coordinates(projected.uvd));
    for (var k = 0u; k < 4u; k++) {
        let cell = around.cells[k];
        if cell == EMPTY {
            continue;
        }
        let behind = max((d - unsortable(atomicLoad(&work[NEAREST + cell]))) / first_layer, 0.0);
        let z = (sqrt(1.0 + behind * 8.0) - 1.0) * 0.5;
        let z0 = floor(z);
        let fz = z - z0;
        let amounts = vec2<f32>(1.0 - fz, fz) * layers * around.weights[k];
        for (var dz = 0u; dz < 2u; dz++) {
            let layer = min(u32(z0) + dz, MAP_LAYERS - 1u);
            atomicAdd(&work[DEPOSITS + cell * MAP_LAYERS + layer], u32(round(amounts[dz] * FIXED)));
        }
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn write_map(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let cell = invocation(id, groups);
    if cell >= CELLS {
        return;
    }
    let base = light.counts.z;
    let valid = atomicLoad(&work[VALID]) != 0u;
    if cell == 0u {
        // The header: the light, the frame with the corner and the scale, the first layer;
        // a flag in the light's slot says whether the map exists.
        maps[base] = light.source.x;
        maps[base + 1u] = light.source.y;
        maps[base + 2u] = light.source.z;
        maps[base + 3u] = select(-1.0, light.source.w, valid);
        // Right with the corner's u, up with its v, forward with the cells per unit.
        let vectors = array<u32, 3>(FRAME + 3u, FRAME + 6u, FRAME);
        for (var k = 0u; k < 3u; k++) {
            for (var c = 0u; c < 3u; c++) {
                maps[base + 4u + 4u * k + c] = load_f32(vectors[k] + c);
            }
            maps[base + 7u + 4u * k] = load_f32(FIT + k);
        }
        maps[base + 16u] = load_f32(FIT + 3u);
        maps[base + 17u] = 0.0;
        maps[base + 18u] = 0.0;
        maps[base + 19u] = 0.0;
    }
    let nearest_at = base + 20u;
    let coverage_at = nearest_at + CELLS;
    let stored = atomicLoad(&work[NEAREST + cell]);
    // An empty cell's nearest strand is infinitely far: WGSL has no infinity, so the
    // largest float.
    maps[nearest_at + cell] = select(unsortable(stored), 3.40282347e38, stored == EMPTY || !valid);
    var sum = 0.0;
    for (var layer = 0u; layer < MAP_LAYERS; layer++) {
        if valid {
            sum += f32(atomicLoad(&work[DEPOSITS + cell * MAP_LAYERS + layer])) / FIXED;
        }
        maps[coverage_at + layer * CELLS + cell] = sum;
    }
}
