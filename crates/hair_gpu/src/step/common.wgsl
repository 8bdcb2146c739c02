// One step of the strand solver on the GPU: a few dispatches a substep, one invocation per
// strand or, for the contacts, per particle (see `entry.wgsl`; strands do not interact). It
// mirrors hair_sim's CPU solver (`solver/step/`, whose files these follow: `wind`,
// `head` for the contacts, `segments`, `final_length`, `skin`, `substep`, `springs`)
// operation for operation where it can, so that the two agree to rounding.
// The head is the collider's baked distance grid, sampled trilinearly, far from the
// surface; near it the collider's exact query takes over (the same candidate triangles, the
// same closest point), and for a particle's own contact deep inside too, through the BVH
// the CPU walks; a whole segment goes from one triangle it hits to the next through that
// BVH (or, without the tables, sphere traces the grid).
// This file holds what every stage shares: the step's constants, the bindings and small
// helpers. The stages follow it in one module (`SHADER` in `lib.rs`).
// `layout.wgsl` is prepended: where each particle's values live.

struct Step {
    // Strands, particles per strand, substeps, shape iterations.
    counts: vec4<u32>,
    // Collision on (1/0), extra colliders, the first alpha's index in `tables`, the index of
    // the groom's first strand (wind seeds are groom-wide).
    flags: vec4<u32>,
    // Gravity, substep length.
    gravity_h: vec4<f32>,
    // Drag factor per substep, largest move per substep, local shape per application,
    // FTL's velocity factor (damping / h).
    motion: vec4<f32>,
    // Speed limit, collision thickness, friction, teleport distance.
    limits: vec4<f32>,
    // Wind: unit direction, strength (0: none).
    wind: vec4<f32>,
    // Gust strength, gust frequency, the step's start time.
    gusts: vec4<f32>,
    // The grid's lowest corner relative to the collider's centre; inverse cell size.
    grid_origin: vec4<f32>,
    // Samples along x, y and z; 1 when there is a grid.
    grid_dims: vec4<u32>,
    // The collider's centre, head-local.
    centre: vec4<f32>,
    // The exact near query's tables in `head`: where the cell ranges, blocks and triangles
    // start, and the bits of a range that count its blocks (0: no tables).
    near: vec4<u32>,
    // The grid's largest error, the near query's slack, the grid's cell size.
    near_bounds: vec4<f32>,
    // hair_sim's `RiseTable` in `head`: its corner (head-local) and cells per metre; cells
    // along x, y, z and where they start; the longest segment it bounds (0: no table), the
    // most the normal may turn under one.
    rise: vec4<f32>,
    rise_dims: vec4<u32>,
    rise_limits: vec4<f32>,
    // The spring model: stiffness, damping, 1 / particle mass, length tolerance.
    springs: vec4<f32>,
    // The spring model on (1/0); whether the strands remember the step before (1/0);
    // whole-segment collision on (1/0); the head keeps its pose through the step (1/0:
    // segments rest on an ear's rim, `rest_on_rim`).
    spring_flags: vec4<u32>,
    // Where the centre-ray response pushes from (head-local), and 1 in w for that
    // response (0: along the surface normal).
    ray_from: vec4<f32>,
    // What `translate_particles` adds to every particle (xyz).
    offset: vec4<f32>,
    // The moving skin (`colliders` after the extras), vec4 indices: its header plus one
    // (0: no skin), its triangles, its bins' starts and lists.
    skin: vec4<u32>,
    // hair_sim's `FlatBvh` over the tables' triangles in `head`, walked where the CPU walks
    // its BVH (a particle's contact without a list, deep inside or in a cell with too many
    // candidates; the triangles a segment hits): its node count (0: no tables), where its
    // nodes (eight words each: lowest corner and the node after its subtree, highest corner
    // and a leaf's first triangle × 8 + count) and its triangle order start.
    bvh: vec4<u32>,
    // Sleeping (hair_sim's `solver/sleep.rs`): the sleep distance and time, 1 where the step
    // may keep strands asleep (still, under the settings of the step before; 0 wakes all),
    // and the step's length.
    sleep: vec4<f32>,
    // Hair volume: 1 in x where the spring model takes the grid's answer into its solve
    // (`grid_friction`, `grid_kick`); 1 in y where the grid pushed this step, whose speed
    // the end of its first substep takes back (`take_back_grid_push`).
    volume: vec4<u32>,
}

@group(0) @binding(0) var<uniform> step: Step;
// Head poses, four vec4 each (rotation columns, translation) for substep boundaries
// 0..=substeps, then the global-shape alpha of each particle index, four per vec4.
@group(0) @binding(1) var<storage, read> tables: array<vec4<f32>>;
// The per-particle buffers are laid out as `layout.wgsl` (prepended) says: a plane of
// `slots()` slots for each value.
@group(0) @binding(2) var<storage, read_write> positions: array<vec4<f32>>;
// `PLANES` planes: velocity, position at the substep's start, FTL correction, position
// before collision, sleep anchor (the last two's root slots hold the strand's sleep watch),
// position at the step's start (its root slot's w: the strand's energy then, for
// `contact_hold.wgsl`), and the hair–hair grid's answer (`volume.wgsl` writes
// them): for the spring model, the mean velocity around the particle with the friction's
// rate in w; the velocity change of the density push and the pressure, with the
// particle's velocity before it, dotted with it (0 where coming in), in w. Then per
// strand two vec4: what its steps did since the report was last taken (`Tally`, added up).
@group(0) @binding(3) var<storage, read_write> motion: array<vec4<f32>>;
const PLANES: u32 = 8u;
// Two planes: head-local rest position with the rest length of the segment ending there
// in w, and the rest direction in the parent segment's frame.
@group(0) @binding(4) var<storage, read> rest: array<vec4<f32>>;
// Per strand: the head-local root frame, a quaternion.
@group(0) @binding(5) var<storage, read> root_frames: array<vec4<f32>>;
// Per extra collider: centre or first end and radius; second end and kind (0 sphere,
// 1 capsule), world space. Then the skin that moves against the head (a surface patch),
// head-local: a header (bins' origin and reach; bins along x, y, z and their side), ten
// vec4 per triangle (corners, face normal, edge normals, corner normals), and the bins'
// starts and lists, four per vec4. Held as u32 and read as floats by `collider`: small
// integers as float bits are denormals, which a GPU may flush to zero.
@group(0) @binding(6) var<storage, read> colliders: array<vec4<u32>>;

fn collider(i: u32) -> vec4<f32> {
    return bitcast<vec4<f32>>(colliders[i]);
}
// The head, as float bits and indices: the collider's signed distances (x fastest), then
// hair_sim's `NearQueryTables` (see `exact_surface`).
@group(0) @binding(7) var<storage, read> head: array<u32>;

fn head_f32(i: u32) -> f32 {
    return bitcast<f32>(head[i]);
}

fn head_vec3(i: u32) -> vec3<f32> {
    return vec3<f32>(head_f32(i), head_f32(i + 1u), head_f32(i + 2u));
}
// The spring model's memory and scratch, six planes (see `springs_*` below); the root's
// first holds, in w, the substep length the memory was taken at (0: none).
@group(0) @binding(8) var<storage, read_write> springs: array<vec4<f32>>;

// What one strand's step did, as hair_sim's `StepReport` counts it. Counts are floats:
// exact to 2^24, and kept as values, not bits (small integers as float bits are
// denormals, which a GPU may flush to zero).
struct Tally {
    teleport_resets: f32,
    nan_resets: f32,
    contacts: f32,
    max_depth: f32,
    contact_stretches: f32,
    segment_turns: f32,
    sleeping: f32,
}

var<private> tally: Tally;

// Slots in a plane of the per-particle buffers. From the uniform, not kept in a private
// variable: a compiler knows it is the same for every invocation (llvmpipe stepped 15
// times slower with a private one).
fn slots() -> u32 {
    return slot_count(step.counts.x, step.counts.y);
}

// A contact `depth` into a collider's shell.
fn touch(depth: f32) {
    tally.contacts += 1.0;
    tally.max_depth = max(tally.max_depth, depth);
}

// Adds this step's tally to the strand's report in `motion` (the deepest contact: the
// deeper of the two).
fn add_to_report(strand: u32) {
    let at = PLANES * slots() + 2u * strand;
    let kept = motion[at];
    motion[at] = vec4<f32>(
        kept.x + tally.teleport_resets,
        kept.y + tally.nan_resets,
        kept.z + tally.contacts,
        max(kept.w, tally.max_depth),
    );
    let more = motion[at + 1u];
    motion[at + 1u] = vec4<f32>(more.x + tally.contact_stretches, more.y + tally.segment_turns, more.z + tally.sleeping, 0.0);
}

struct Pose {
    rotation: mat3x3<f32>,
    translation: vec3<f32>,
}

fn pose(k: u32) -> Pose {
    let b = 4u * k;
    return Pose(mat3x3<f32>(tables[b].xyz, tables[b + 1u].xyz, tables[b + 2u].xyz), tables[b + 3u].xyz);
}

fn world_point(p: Pose, x: vec3<f32>) -> vec3<f32> {
    return p.rotation * x + p.translation;
}

fn local_point(p: Pose, x: vec3<f32>) -> vec3<f32> {
    return transpose(p.rotation) * (x - p.translation);
}

fn alpha(j: u32) -> f32 {
    return tables[step.flags.z + j / 4u][j % 4u];
}

fn velocity(i: u32) -> vec3<f32> { return motion[i].xyz; }
fn start(i: u32) -> vec3<f32> { return motion[slots() + i].xyz; }
fn correction(i: u32) -> vec3<f32> { return motion[2u * slots() + i].xyz; }
// Where collision found particle `i` (before it moved it); in w, 1 where the head or the
// skin touched it in the substep, and at a root, 1 while the strand's sleep watch runs (0:
// begin it).
fn shaped(i: u32) -> vec3<f32> { return motion[3u * slots() + i].xyz; }
fn watching(first: u32) -> bool { return motion[3u * slots() + first].w == 1.0; }
// Where particle `i` was when its strand's sleep watch began; at a root, w: how long the
// watch has run, seconds.
fn anchor(i: u32) -> vec3<f32> { return motion[4u * slots() + i].xyz; }
fn quiet(first: u32) -> f32 { return motion[4u * slots() + first].w; }
fn step_start(i: u32) -> vec3<f32> { return motion[5u * slots() + i].xyz; }
fn grid_friction(i: u32) -> vec4<f32> { return motion[6u * slots() + i]; }
fn grid_kick(i: u32) -> vec3<f32> { return motion[7u * slots() + i].xyz; }
fn grid_leaving_before(i: u32) -> f32 { return motion[7u * slots() + i].w; }
fn rest_position(i: u32) -> vec3<f32> { return rest[i].xyz; }
fn rest_length(i: u32) -> f32 { return rest[i].w; }
fn rest_direction(i: u32) -> vec3<f32> { return rest[slots() + i].xyz; }

// Not infinite and not NaN, by the bits: a compiler may assume arithmetic never makes NaN.
fn finite(v: vec3<f32>) -> bool {
    let e = bitcast<vec3<u32>>(v) & vec3<u32>(0x7f800000u);
    return all(e != vec3<u32>(0x7f800000u));
}

fn normalize_or(v: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    let r = 1.0 / length(v);
    if finite(vec3<f32>(r)) && r > 0.0 {
        return v * r;
    }
    return fallback;
}

fn clamp_length_max(v: vec3<f32>, max_length: f32) -> vec3<f32> {
    let squared = dot(v, v);
    if squared > max_length * max_length {
        return v * (max_length / sqrt(squared));
    }
    return v;
}

fn quat_mat(q: vec4<f32>) -> mat3x3<f32> {
    let x2 = q.x + q.x;
    let y2 = q.y + q.y;
    let z2 = q.z + q.z;
    let xx = q.x * x2;
    let xy = q.x * y2;
    let xz = q.x * z2;
    let yy = q.y * y2;
    let yz = q.y * z2;
    let zz = q.z * z2;
    let wx = q.w * x2;
    let wy = q.w * y2;
    let wz = q.w * z2;
    return mat3x3<f32>(
        vec3<f32>(1.0 - (yy + zz), xy + wz, xz - wy),
        vec3<f32>(xy - wz, 1.0 - (xx + zz), yz + wx),
        vec3<f32>(xz + wy, yz - wx, 1.0 - (xx + yy)),
    );
}

// The rotation taking unit `from_` onto unit `to_`, as the CPU's `M3::rotation_arc`; nearly
// opposite, half a turn about an axis across `from_` (glam's `any_orthonormal_vector`).
fn rotation_arc(from_: vec3<f32>, to_: vec3<f32>) -> mat3x3<f32> {
    let c = dot(from_, to_);
    if c < -0.999 {
        let sign = select(-1.0, 1.0, from_.z >= 0.0);
        let a = -1.0 / (sign + from_.z);
        let u = vec3<f32>(from_.x * from_.y * a, sign + from_.y * from_.y * a, -from_.y);
        // Half a turn about unit `u`: 2 u uᵀ − I.
        let identity = mat3x3<f32>(vec3(1.0, 0.0, 0.0), vec3(0.0, 1.0, 0.0), vec3(0.0, 0.0, 1.0));
        return 2.0 * mat3x3<f32>(u * u.x, u * u.y, u * u.z) - identity;
    }
    let v = cross(from_, to_);
    let kv = v * (1.0 / (1.0 + c));
    return mat3x3<f32>(
        vec3<f32>(c, v.z, -v.y) + kv * v.x,
        vec3<f32>(-v.z, c, v.x) + kv * v.y,
        vec3<f32>(v.y, -v.x, c) + kv * v.z,
    );
}
