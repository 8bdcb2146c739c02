// One step of the strand solver on the GPU: a few dispatches a substep, one invocation per
// strand or, for the contacts, per particle (see the entry points at the end; strands do
// not interact). It mirrors hair_sim's CPU solver (`solver/step.rs`) for the inextensible
// length model, operation for operation where it can, so that the two agree to rounding.
// The head is the collider's baked distance grid, sampled trilinearly, far from the
// surface; near it the collider's exact query takes over (the same candidate triangles, the
// same closest point), and for a particle's own contact deep inside too, through the BVH
// the CPU walks; a whole segment goes from one triangle it hits to the next through that
// BVH (or, without the tables, sphere traces the grid).
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
    // whole-segment collision on (1/0).
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
}

@group(0) @binding(0) var<uniform> step: Step;
// Head poses, four vec4 each (rotation columns, translation) for substep boundaries
// 0..=substeps, then the global-shape alpha of each particle index, four per vec4.
@group(0) @binding(1) var<storage, read> tables: array<vec4<f32>>;
// The per-particle buffers are laid out as `layout.wgsl` (prepended) says: a plane of
// `slots()` slots for each value.
@group(0) @binding(2) var<storage, read_write> positions: array<vec4<f32>>;
// `PLANES` planes: velocity, position at the substep's start, FTL correction, position
// before collision, sleep anchor (the last two's root slots hold the strand's sleep watch).
// Then per strand two vec4: what its steps did since the report was last taken (`Tally`,
// added up).
@group(0) @binding(3) var<storage, read_write> motion: array<vec4<f32>>;
const PLANES: u32 = 5u;
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

// --- Wind: hair_sim's `wind_at`, bit for bit in integer hashing ---

fn hash01(seed: u32) -> f32 {
    var x = seed;
    x ^= x >> 16u;
    x *= 0x7feb352du;
    x ^= x >> 15u;
    x *= 0x846ca68bu;
    x ^= x >> 16u;
    return f32(x >> 8u) / 16777216.0;
}

fn value_noise(seed: u32, t: f32) -> f32 {
    let i = floor(t);
    let f = t - i;
    let k = bitcast<u32>(i32(i));
    let a = hash01(seed ^ (k * 0x9e3779b9u));
    let b = hash01(seed ^ ((k + 1u) * 0x9e3779b9u));
    let s = f * f * (3.0 - 2.0 * f);
    return (a + (b - a) * s) * 2.0 - 1.0;
}

fn wind_at(strand: u32, time: f32) -> vec3<f32> {
    if step.wind.w == 0.0 {
        return vec3<f32>(0.0);
    }
    let t = time * step.gusts.y;
    let shared_gust = value_noise(0x5eedu, t);
    let own = value_noise(strand * 0x2545f491u, t * 1.7 + hash01(strand) * 16.0);
    let gust = 0.7 * shared_gust + 0.3 * own;
    return step.wind.xyz * step.wind.w * max(1.0 + step.gusts.x * gust, 0.0);
}

// --- The head: the baked distance grid, and the exact query near the surface ---

struct Surface {
    distance: f32,
    normal: vec3<f32>,
    // Within the grid's error of the true distance, either way (false: exact).
    approximate: bool,
}

fn sample_index(x: u32, y: u32, z: u32) -> u32 {
    return (z * step.grid_dims.y + y) * step.grid_dims.x + x;
}

// Signed distance and outward normal at head-local `p`: by trilinear interpolation of the
// grid, with its gradient as the normal; far beyond the grid's margin outside it; and where
// the grid cannot tell `p` from the shell, the exact closest point of the mesh, as the CPU
// solver finds it.
fn head_surface(p: vec3<f32>) -> Surface {
    return head_surface_from(p, false);
}

// `head_surface`, and with `deep` the exact closest point where no candidate list reaches
// (deep inside, or a cell with too many candidates) too, by a walk of the BVH as the CPU
// walks its own; otherwise the grid's gradient answers there. A particle's own
// contact asks for it (`head_contact`: a particle deep inside after a hitch goes out where
// the CPU's goes); the turns, traces and placements keep the grid there (with every
// triangle in them too, near-root hair stayed 5.3 mm inside a skinned head blended into
// its neck, `tests/characters.rs`; not understood).
fn head_surface_from(p: vec3<f32>, deep: bool) -> Surface {
    let g = (p - step.centre.xyz - step.grid_origin.xyz) * step.grid_origin.w;
    let upper = vec3<f32>(step.grid_dims.xyz - vec3<u32>(1u));
    if step.grid_dims.w == 0u || !(all(g >= vec3<f32>(0.0)) && all(g < upper)) {
        return Surface(1e30, vec3<f32>(0.0, 1.0, 0.0), false);
    }
    let c = vec3<u32>(g);
    let t = g - vec3<f32>(c);
    let v000 = head_f32(sample_index(c.x, c.y, c.z));
    let v100 = head_f32(sample_index(c.x + 1u, c.y, c.z));
    let v010 = head_f32(sample_index(c.x, c.y + 1u, c.z));
    let v110 = head_f32(sample_index(c.x + 1u, c.y + 1u, c.z));
    let v001 = head_f32(sample_index(c.x, c.y, c.z + 1u));
    let v101 = head_f32(sample_index(c.x + 1u, c.y, c.z + 1u));
    let v011 = head_f32(sample_index(c.x, c.y + 1u, c.z + 1u));
    let v111 = head_f32(sample_index(c.x + 1u, c.y + 1u, c.z + 1u));
    let y0 = mix(v000, v100, t.x);
    let y1 = mix(v010, v110, t.x);
    let y2 = mix(v001, v101, t.x);
    let y3 = mix(v011, v111, t.x);
    let z0 = mix(y0, y1, t.y);
    let z1 = mix(y2, y3, t.y);
    let distance = mix(z0, z1, t.z);
    let gx = mix(mix(v100 - v000, v110 - v010, t.y), mix(v101 - v001, v111 - v011, t.y), t.z);
    let gy = mix(y1 - y0, y3 - y2, t.z);
    let gz = z1 - z0;
    let by_grid = Surface(distance, normalize_or(vec3<f32>(gx, gy, gz), vec3<f32>(0.0, 1.0, 0.0)), true);
    let error = step.near_bounds.x;
    if step.near.w == 0u || distance > step.limits.y + error {
        return by_grid;
    }
    let range = head[step.near.x + sample_index(c.x, c.y, c.z)];
    if range == 0xffffffffu && (step.bvh.x == 0u || !deep) {
        return by_grid; // deep inside, or too many candidates for a list
    }
    return exact_surface(p - step.centre.xyz, t, range, by_grid);
}

// hair_sim's exact near query (`HeadCollider::near_query_tables`) for `p` relative to the
// collider's centre, at `fraction` across its cell, whose list is `range`: the cell's
// candidate triangles nearest its centre first, each skipped where its distance from the
// centre less `p`'s, or its tangent-plane bound, is already beyond the best found, the walk
// ending at the first block whose nearest is. A cell without a list (`range` all ones)
// walks the BVH instead, unbounded at first (beyond its band the grid holds only a bound),
// into the boxes nearer than the best found, as the CPU's BVH walk finds the closest.
// Signed by the pseudo-normal of the feature the closest point lies on; the normal is the
// face's over a face, else along the offset.
fn exact_surface(p: vec3<f32>, fraction: vec3<f32>, range: u32, by_grid: Surface) -> Surface {
    let error = step.near_bounds.x;
    let slack = step.near_bounds.y;
    let offset = (fraction - vec3<f32>(0.5)) * step.near_bounds.z;
    let from_centre = length(offset);
    // Where the grid proves `p` outside, the closest triangle is within its value plus
    // the error; inside or unsure, anywhere.
    var best = 3.4e38;
    if by_grid.distance > error {
        best = by_grid.distance + error;
    }
    let listed = range != 0xffffffffu;
    if !listed {
        best = 3.4e38; // the grid's value may be clamped deep inside: no bound
    }
    var best_base = 0xffffffffu;
    var best_on = OnTriangle(p, 0u);
    let first = range >> step.near.w;
    let blocks = range & ((1u << step.near.w) - 1u);
    // The next candidate in the list; or the BVH's next node and the leaf's triangles left.
    var k = 0u;
    var node = 0u;
    var leaf_next = 0u;
    var leaf_end = 0u;
    loop {
        var triangle: u32;
        if listed {
            if k == 4u * blocks {
                break;
            }
            let block = step.near.y + 20u * (first + k / 4u);
            let lane = k % 4u;
            k++;
            if lane == 0u && head_f32(block) - (from_centre + slack) >= best {
                break; // sorted: no later triangle can be nearer
            }
            let centre_distance = head_f32(block + lane);
            let gradient = vec3<f32>(head_f32(block + 4u + lane), head_f32(block + 8u + lane), head_f32(block + 12u + lane));
            let bound = max(centre_distance - (from_centre + slack), centre_distance + dot(gradient, offset) - slack);
            if !(bound < best) {
                continue;
            }
            triangle = head[block + 16u + lane];
        } else {
            // Down to the next leaf whose box is nearer than the best found.
            while leaf_next == leaf_end && node < step.bvh.x {
                let bounds = bvh_node(node);
                let open = length(max(max(bounds.low - p, p - bounds.high), vec3<f32>(0.0))) < best;
                if open && bounds.count == 0u {
                    node++;
                    continue;
                }
                node = bounds.skip;
                if open {
                    leaf_next = bounds.first;
                    leaf_end = bounds.first + bounds.count;
                }
            }
            if leaf_next == leaf_end {
                break;
            }
            triangle = head[step.bvh.z + leaf_next];
            leaf_next++;
        }
        let base = step.near.z + 40u * triangle;
        let on = closest_on_triangle(p, head_vec3(base), head_vec3(base + 4u), head_vec3(base + 8u));
        let squared = dot(p - on.point, p - on.point);
        if squared < best * best {
            best = sqrt(squared);
            best_base = base;
            best_on = on;
        }
    }
    if best_base == 0xffffffffu {
        return Surface(best, by_grid.normal, false); // nothing within reach: at least that far
    }
    let face = head_vec3(best_base + 12u);
    let feature_normal = head_vec3(best_base + 4u * feature_slot(best_on.feature));
    let away = p - best_on.point;
    var signed = best;
    if any(feature_normal != vec3<f32>(0.0)) && dot(away, feature_normal) <= 0.0 {
        signed = -best;
    }
    var normal = face;
    if (best_on.feature != 0u || all(face == vec3<f32>(0.0))) && abs(signed) > 1e-7 {
        normal = away / signed;
    } else if all(face == vec3<f32>(0.0)) {
        normal = vec3<f32>(0.0, 1.0, 0.0);
    }
    return Surface(signed, normal, false);
}

// Friction takes back part of the slide along the surface since the substep's start.
fn with_friction(position: vec3<f32>, normal: vec3<f32>, origin: vec3<f32>) -> vec3<f32> {
    let slide = position - origin;
    let tangential = slide - normal * dot(slide, normal);
    return position - tangential * step.limits.z;
}

// Where a collider pushes a point (if `hit`), along which normal, and how deep the point
// was in the collider's shell; world space, or head-local where said.
struct Contact {
    hit: bool,
    position: vec3<f32>,
    normal: vec3<f32>,
    depth: f32,
}

// The head's contact for head-local `p` (head-local), by the response asked for: out along
// the normal to the shell, or along the ray from `step.ray_from` (inside, to where the ray
// leaves the surface, plus the thickness; in the shell, by the shell's depth).
fn head_contact(p: vec3<f32>) -> Contact {
    let thickness = step.limits.y;
    let normal_contact = onto_shell(p, head_surface_from(p, true), thickness);
    let depth = normal_contact.depth;
    let direction = normalize_or(p - step.ray_from.xyz, vec3<f32>(0.0));
    if !normal_contact.hit || step.ray_from.w == 0.0 || all(direction == vec3<f32>(0.0)) {
        return normal_contact;
    }
    if depth <= thickness {
        return Contact(true, p + direction * depth, direction, depth);
    }
    // Inside: march out along the ray. Inside the head the distance to the surface is at
    // least the grid's value less its error, so steps of that size cannot cross it; the
    // shortest step may, and the last one is halved back to the surface: 8 halvings once
    // outside. (One query in one loop for both: every call is inlined, and a GPU compiler's
    // time grows with the code; see `first_inside`.)
    var t = 0.0;
    var inside = 0.0;
    var march = 0u;
    var halvings = 0u;
    loop {
        let bisecting = halvings > 0u;
        if !bisecting && march == 64u {
            break;
        }
        let at = select(t, 0.5 * (inside + t), bisecting);
        let d = head_surface(p + direction * at).distance;
        if bisecting {
            if d < 0.0 {
                inside = at;
            } else {
                t = at;
            }
            halvings++;
            if halvings == 9u {
                return Contact(true, p + direction * (t + thickness), direction, depth);
            }
        } else if d >= 0.0 {
            halvings = 1u;
        } else {
            inside = t;
            t += max(-d, 1e-4);
            march++;
        }
    }
    return normal_contact; // never left (a ray along a sliver): along the normal
}

// Where extra collider `e` pushes world `x`: out onto its shell along the normal from its
// centre (or axis), as hair_sim's `ExtraCollider::resolve`.
fn extra_contact(e: u32, x: vec3<f32>) -> Contact {
    let a = collider(2u * e);
    let b = collider(2u * e + 1u);
    var centre = a.xyz;
    if b.w == 1.0 {
        let ab = b.xyz - a.xyz;
        let t = clamp(dot(x - a.xyz, ab) / max(dot(ab, ab), 1e-12), 0.0, 1.0);
        centre = a.xyz + ab * t;
    }
    let offset = x - centre;
    let distance = length(offset);
    let reach = a.w + step.limits.y;
    if !(distance < reach) {
        return Contact(false, x, vec3<f32>(0.0), 0.0);
    }
    var normal = vec3<f32>(0.0, 1.0, 0.0);
    if distance > 1e-7 {
        normal = offset / distance;
    }
    return Contact(true, centre + normal * reach, normal, reach - distance);
}

// World `x` pushed out of the extra colliders, with friction against `origin`.
fn out_of_extras(x_in: vec3<f32>, origin: vec3<f32>) -> vec3<f32> {
    var x = x_in;
    for (var e = 0u; e < step.flags.y; e++) {
        let contact = extra_contact(e, x);
        if contact.hit {
            x = with_friction(contact.position, contact.normal, origin);
            touch(contact.depth);
        }
    }
    return x;
}

// The deepest contact at world `x` with the head as baked or the skin that moved against
// it, else the first extra collider it is in; along the normal whatever the response
// (turning a segment onto the tangent plane needs the plane). hair_sim's `contact_at`.
fn contact_at(x: vec3<f32>, now: Pose) -> Contact {
    if step.grid_dims.w == 1u {
        let local = local_point(now, x);
        var head = head_push(local);
        let skin = patch_contact(local);
        if skin.hit && (!head.hit || skin.depth > head.depth) {
            head = Contact(true, skin.position, skin.normal, skin.depth);
        }
        if head.hit {
            return Contact(true, world_point(now, head.position), now.rotation * head.normal, head.depth);
        }
    }
    for (var e = 0u; e < step.flags.y; e++) {
        let contact = extra_contact(e, x);
        if contact.hit {
            return contact;
        }
    }
    return Contact(false, x, vec3<f32>(0.0), 0.0);
}

// The baked head's push for head-local `p` (head-local): out along the normal onto the
// shell, `reach` thick, if nearer than that.
fn head_push_within(p: vec3<f32>, reach: f32) -> Contact {
    return onto_shell(p, head_surface(p), reach);
}

// `p` out along `surface`'s normal onto the shell `reach` thick, if nearer than that.
fn onto_shell(p: vec3<f32>, surface: Surface, reach: f32) -> Contact {
    let depth = reach - surface.distance;
    if !(depth > 0.0) {
        return Contact(false, p, surface.normal, 0.0);
    }
    return Contact(true, p + surface.normal * depth, surface.normal, depth);
}

// `head_push_within` the collision shell.
fn head_push(p: vec3<f32>) -> Contact {
    return head_push_within(p, step.limits.y);
}

// --- Whole segments: hair_sim's `keep_segments_outside`, by tracing ---

// The shortest step of the trace along a segment, metres: a stretch inside the head longer
// than this is found (at 20 µm the trace stepped over one by an edge that the CPU, which
// intersects the triangles, turned).
const MIN_TRACE_STEP: f32 = 1e-6;

// Where the segment from head-local `a` (`a_distance` from the surface) to `b` runs inside the
// head: the fractions of the way at which it first enters and last leaves (x, y), with 1 in z;
// z is 0 where it stays out. hair_sim's `segment_crossing`, which intersects the triangles.
// A segment whose ends both clear half its length cannot reach the surface (every point of it
// is within half its length of an end); it is not traced.
fn crossed_stretch(a: vec3<f32>, a_distance: f32, b: vec3<f32>) -> vec3<f32> {
    let span = length(b - a);
    if !(span > 0.0) || min(a_distance, head_surface(b).distance) > 0.5 * span {
        return vec3<f32>(0.0);
    }
    // From `a` to `b`, then (where it goes in) back from `b`: one call site for both ways
    // (see `first_inside` on why).
    var enters = 0.0;
    for (var way = 0u; way < 2u; way++) {
        let found = first_inside(select(a, b, way == 1u), select(b, a, way == 1u), span);
        if way == 1u {
            return vec3<f32>(enters, 1.0 - found, 1.0);
        }
        if found > 1.0 {
            return vec3<f32>(0.0);
        }
        enters = found;
    }
    return vec3<f32>(0.0);
}

// Node `k` of the BVH in `head` (`Step::bvh`): its box, the node after its subtree, and a
// leaf's `count` triangles from `first` in the BVH's order (0: a node with children, the
// first of them next).
struct BvhNode {
    low: vec3<f32>,
    high: vec3<f32>,
    skip: u32,
    first: u32,
    count: u32,
}

fn bvh_node(k: u32) -> BvhNode {
    let at = step.bvh.y + 8u * k;
    let leaf = head[at + 7u];
    return BvhNode(head_vec3(at), head_vec3(at + 4u), head[at + 3u], leaf >> 3u, leaf & 7u);
}

// The distance along the ray from `origin` (relative to the collider's centre) along unit
// `direction` to the nearest triangle it hits, either side, from `beyond` to `reach`; beyond
// `reach` where it hits none. A walk of the BVH into the boxes the ray enters within that
// stretch before the nearest hit found (a box it runs along a face of: by whether it lies
// in that face's slab).
fn first_hit(origin: vec3<f32>, direction: vec3<f32>, beyond: f32, reach: f32) -> f32 {
    let along = direction == vec3<f32>(0.0);
    let inverse = select(vec3<f32>(1.0) / select(direction, vec3<f32>(1.0), along), vec3<f32>(0.0), along);
    var nearest = 2.0 * reach + 1.0;
    var node = 0u;
    while node < step.bvh.x {
        let bounds = bvh_node(node);
        let t0 = (bounds.low - origin) * inverse;
        let t1 = (bounds.high - origin) * inverse;
        let all = select(vec3<f32>(3.4e38), vec3<f32>(-3.4e38), (origin >= bounds.low) & (origin <= bounds.high));
        let near = select(min(t0, t1), all, along);
        let far = select(max(t0, t1), -all, along);
        let enters = max(max(near.x, near.y), near.z);
        let leaves = min(min(far.x, far.y), far.z);
        let open = enters <= min(leaves, min(nearest, reach)) && leaves >= beyond;
        if open && bounds.count == 0u {
            node++;
            continue;
        }
        node = bounds.skip;
        for (var l = bounds.first; open && l < bounds.first + bounds.count; l++) {
            let base = step.near.z + 40u * head[step.bvh.z + l];
            let t = ray_on_triangle(origin, direction, head_vec3(base), head_vec3(base + 4u), head_vec3(base + 8u));
            if t >= beyond && t <= min(nearest, reach) {
                nearest = t;
            }
        }
    }
    return nearest;
}

// How far along the ray from `origin` along `direction` it hits triangle `a`, `b`, `c`, from
// either side; negative where it misses (Möller and Trumbore 1997). A ray grazing an edge
// hits (as hair_sim's crossing lists count it): rounding lets no crossing through unseen.
const EDGE_SLACK: f32 = 1e-5;

fn ray_on_triangle(origin: vec3<f32>, direction: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> f32 {
    let e1 = b - a;
    let e2 = c - a;
    let q = cross(direction, e2);
    let det = dot(e1, q);
    if abs(det) < 1e-20 {
        return -1.0; // along the triangle's plane
    }
    let s = origin - a;
    let u = dot(s, q) / det;
    let r = cross(s, e1);
    let v = dot(direction, r) / det;
    if !(u >= -EDGE_SLACK && v >= -EDGE_SLACK && u + v <= 1.0 + EDGE_SLACK) {
        return -1.0;
    }
    return dot(e2, r) / det;
}

// The fraction of the way from head-local `start_at` to `to` (`span` apart) at which the segment
// first goes inside the head, or 2 where it stays out. With the BVH, from one triangle the
// segment hits to the next until it is inside just beyond one (`MIN_TRACE_STEP`), by the
// exact query: a segment that only touches the surface, or grazes an edge, stays out.
// Without it, sphere tracing: each step the distance to the surface (less the grid's error,
// where the grid answers), which cannot step over any part of the surface, and at least
// `MIN_TRACE_STEP`; the crossing refined by bisection. A walk not done in 1,024 steps (a
// trace along the surface within micrometres: a trace grazing the surface took that many
// in the demo, where the BVH takes a few boxes) counts as staying out.
//
// Every way shares one query in one loop: a GPU compiler inlines every call, and its time
// grows faster than the code (a query for each made the shader take minutes to compile).
fn first_inside(start_at: vec3<f32>, to: vec3<f32>, span: f32) -> f32 {
    let direction = (to - start_at) / span;
    let by_hits = step.bvh.x > 0u;
    var outside = 0.0;
    var t = 0.0;
    var steps = 0u;
    var inside = -1.0; // where the bisection found the segment inside (< 0: tracing)
    var halvings = 0u;
    var hit = 0.0; // by hits: the last triangle hit, whose far side is tested
    loop {
        let bisecting = inside >= 0.0;
        if !bisecting && (steps == 1024u || !(t <= span)) {
            break;
        }
        if by_hits && steps > 0u {
            hit = first_hit(start_at - step.centre.xyz, direction, t, span);
            if hit > span {
                break;
            }
            t = min(hit + MIN_TRACE_STEP, span);
        }
        let at = select(t, 0.5 * (outside + inside), bisecting);
        let surface = head_surface(start_at + direction * at);
        if by_hits {
            // The start inside (t = 0), or the far side of a hit.
            if surface.distance < 0.0 {
                return hit / span;
            }
            steps++;
        } else if bisecting {
            if surface.distance < 0.0 {
                inside = at;
            } else {
                outside = at;
            }
            halvings++;
            if halvings == 12u {
                return 0.5 * (outside + inside) / span;
            }
        } else if surface.distance < 0.0 {
            inside = t;
        } else {
            outside = t;
            t += max(surface.distance - select(0.0, step.near_bounds.x, surface.approximate), MIN_TRACE_STEP);
            steps++;
        }
    }
    return 2.0;
}

// How far the surface may rise above a straight segment `segment` long around head-local
// `middle`, from the curvature baked around it (hair_sim's `HeadCollider::rise_under`): where
// both ends clear more than that, the segment cannot cross the surface. Unbounded by an
// ear's rim, and for segments longer than the table covers.
fn rise_under(middle: vec3<f32>, segment: f32) -> f32 {
    if !(segment <= step.rise_limits.x) {
        return 3.4e38;
    }
    let last = vec3<f32>(step.rise_dims.xyz - vec3<u32>(1u));
    let c = vec3<u32>(clamp((middle - step.rise.xyz) * step.rise.w, vec3<f32>(0.0), last));
    let at = step.rise_dims.w + 2u * (c.x + step.rise_dims.x * (c.y + step.rise_dims.y * c.z));
    let convex = head_f32(at);
    if convex * segment > step.rise_limits.y {
        return 3.4e38;
    }
    return convex * segment * segment / 8.0 + head_f32(at + 1u);
}

// Whether the segment between head-local `a` and `b` runs through the head.
fn crosses(a: vec3<f32>, b: vec3<f32>) -> bool {
    return crossed_stretch(a, head_surface(a).distance, b).z == 1.0;
}

// How many times a segment turns before collision simply wins (hair_sim's `MAX_TURNS`).
const MAX_TURNS: u32 = 4u;
// How far outside the surface a turn lifts the middle of the crossed stretch, m (hair_sim's
// `SEGMENT_CLEARANCE`).
const SEGMENT_CLEARANCE: f32 = 1e-4;
// Halvings of the angle between a crossing direction and a clear one in `turn_out_of`.
const BISECTIONS: u32 = 5u;
// Directions `clear_direction` tries over the whole sphere as its last resort.
const SPHERE_DIRECTIONS: u32 = 96u;

// Where to put head-local `child`, `segment` from head-local `parent`, so that the segment
// between them no longer runs through the head: turned about the parent until the middle of
// the stretch it runs inside is out on the shell, a few turns at most; where that does not
// clear it (a fold, an ear's rim seen edge-on), turned toward the surface's normal at the
// parent instead, as little as bisection finds enough. `child` where it crosses nothing.
// hair_sim's `turn_out_of`.
fn turn_out_of(parent: vec3<f32>, child: vec3<f32>, segment: f32) -> vec3<f32> {
    let parent_distance = head_surface(parent).distance;
    var turned = child;
    // MAX_TURNS turns, each segment tested, the last turned one too.
    for (var turn = 0u; turn <= MAX_TURNS; turn++) {
        let stretch = crossed_stretch(parent, parent_distance, turned);
        if stretch.z == 0.0 {
            return turned;
        }
        if turn == MAX_TURNS {
            break;
        }
        let contact = head_push_within(mix(parent, turned, 0.5 * (stretch.x + stretch.y)), SEGMENT_CLEARANCE);
        if !contact.hit {
            break;
        }
        turned = parent + normalize_or(contact.position - parent, vec3<f32>(0.0, 1.0, 0.0)) * segment;
    }
    // The parent is outside, so within `segment` of the surface a contact that reaches that
    // far has the outward normal nearest it.
    let out = head_push_within(parent, segment);
    if !out.hit {
        return turned;
    }
    var crossing = (turned - parent) / segment;
    let found = clear_direction(parent, out.normal, crossing, segment);
    if found.w == 0.0 {
        return turned;
    }
    var clear = found.xyz;
    for (var k = 0u; k < BISECTIONS; k++) {
        let middle = normalize_or(crossing + clear, clear);
        if crosses(parent, parent + middle * segment) {
            crossing = middle;
        } else {
            clear = middle;
        }
    }
    return parent + clear * segment;
}

// A direction from head-local `parent` in which a segment of `segment` crosses nothing (w 1;
// w 0: none): `out` itself, else the nearest to `wanted` of those tilted around it, else the
// nearest to `wanted` of `SPHERE_DIRECTIONS` spread over the sphere (a pocket of the
// surface, an eye socket). hair_sim's `clear_direction`.
fn clear_direction(parent: vec3<f32>, out: vec3<f32>, wanted: vec3<f32>, segment: f32) -> vec4<f32> {
    var best = vec4<f32>(0.0, 0.0, 0.0, -2.0);
    // Direction 0 is `out`, then the tilted ones, then (while none is clear) the sphere's.
    for (var k = 0u; k < 1u + TILTED + SPHERE_DIRECTIONS; k++) {
        let on_sphere = k > TILTED;
        if on_sphere && best.w != -2.0 {
            break;
        }
        var d = out;
        if on_sphere {
            d = sphere_direction(k - 1u - TILTED);
        } else if k > 0u {
            d = tilted(out, k - 1u);
        }
        if (k == 0u || dot(d, wanted) > best.w) && !crosses(parent, parent + d * segment) {
            if k == 0u {
                return vec4<f32>(out, 1.0);
            }
            best = vec4<f32>(d, dot(d, wanted));
        }
    }
    // (No best found: the loop over the sphere ran to its end and w is still -2.)
    return vec4<f32>(best.xyz, select(1.0, 0.0, best.w == -2.0));
}

// Directions tilted from `out` by 30°, 60° and 90°, eight around each (hair_sim's `around`,
// before its sort by nearness to a wanted direction).
const TILTED: u32 = 24u;

fn tilted(out: vec3<f32>, k: u32) -> vec3<f32> {
    let tilt = radians(30.0 * f32(k / 8u + 1u));
    let around = f32(k % 8u) * 0.7853982;
    let basis = orthonormal_pair(out);
    return out * cos(tilt) + (basis[0] * cos(around) + basis[1] * sin(around)) * sin(tilt);
}

// The `k`-th of `SPHERE_DIRECTIONS` unit vectors spread evenly over the sphere (a Fibonacci
// lattice, as hair_sim's `sphere_direction`).
fn sphere_direction(k: u32) -> vec3<f32> {
    let golden_angle = 3.14159265 * (3.0 - sqrt(5.0));
    let y = 1.0 - 2.0 * (f32(k) + 0.5) / f32(SPHERE_DIRECTIONS);
    let radius = sqrt(1.0 - y * y);
    let angle = golden_angle * f32(k);
    return vec3<f32>(radius * cos(angle), y, radius * sin(angle));
}

// Two unit vectors that make a right-handed orthonormal basis with unit `n` (Duff et al.
// 2017, as glam's `any_orthonormal_pair`; the second is its `any_orthonormal_vector`).
fn orthonormal_pair(n: vec3<f32>) -> array<vec3<f32>, 2> {
    let sign = select(1.0, -1.0, (bitcast<u32>(n.z) >> 31u) == 1u);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    return array<vec3<f32>, 2>(
        vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        vec3<f32>(b, sign + n.y * n.y * a, -n.y),
    );
}

// --- The final length pass: hair_sim's `keep_outside` and `outside_at_length` ---

// The final length pass may move a particle by this share of the thickness unchecked
// (hair_sim's `LENGTH_SLACK`): collision left it at least three quarters of the thickness
// above every surface, so it cannot reach one.
const LENGTH_SLACK: f32 = 0.75;
// The same for a particle the head or the skin touched in the substep (hair_sim's
// `CONTACT_SLACK`).
const CONTACT_SLACK: f32 = 0.1;

// How far, as a share of the collision thickness, the final pass may move particle `i`
// unchecked.
fn unchecked_slack(i: u32) -> f32 {
    return select(LENGTH_SLACK, CONTACT_SLACK, motion[3u * slots() + i].w == 1.0);
}

// Particle `i` placed at its segment's length from its (placed) parent, toward world
// `toward`; where that is more than `unchecked` from `toward`, turned out of whatever
// collider it is in (`outside_at_length`). FTL's correction counts the move. Returns
// where it is placed.
fn place_at_length(i: u32, toward: vec3<f32>, unchecked: f32, now: Pose) -> vec3<f32> {
    let parent = positions[i - LANES].xyz;
    let segment = final_length(i, toward - parent);
    var placed = parent + normalize_or(toward - parent, vec3<f32>(0.0, -1.0, 0.0)) * segment;
    if distance(placed, toward) > unchecked {
        placed = outside_at_length(placed, parent, segment, now);
    }
    set_final(i, placed);
    return placed;
}

// Moves particle `i` to `placed` in the final pass; FTL's velocity correction counts the move.
fn set_final(i: u32, placed: vec3<f32>) {
    if step.spring_flags.x == 0u {
        motion[2u * slots() + i] = vec4<f32>(correction(i) + placed - positions[i].xyz, 0.0);
    }
    positions[i] = vec4<f32>(placed, 0.0);
}

// Where to put world `placed_in`, which should sit `segment` from world `parent` (itself
// outside) but may be within the shell of a collider: turned about the parent toward the
// contact's normal until it lies on the tangent plane of the shell there (1 µm above), a few
// turns at most, or straight out along the normal where the parent lies behind that plane.
// Where that ends inside a collider itself, the nearest direction around the normal that is
// outside and reached without passing through the head, else the nearest outside at all;
// failing that, onto the surface, stretching the segment. hair_sim's `outside_at_length`.
fn outside_at_length(placed_in: vec3<f32>, parent: vec3<f32>, segment: f32, now: Pose) -> vec3<f32> {
    var placed = placed_in;
    // MAX_TURNS turns, each place tested, the last turned one too.
    var contact: Contact;
    for (var turn = 0u; turn <= MAX_TURNS; turn++) {
        contact = contact_at(placed, now);
        if !contact.hit {
            return placed;
        }
        if turn == MAX_TURNS {
            break;
        }
        let normal = contact.normal;
        let direction = (placed - parent) / segment;
        let lowest = (dot(normal, contact.position - parent) + 1e-6) / segment;
        let along = dot(normal, direction);
        if !(lowest < 1.0 && lowest > along) {
            placed = parent + normal * segment;
            continue;
        }
        let across = normalize_or(direction - normal * along, orthonormal_pair(normal)[1]);
        placed = parent + (normal * lowest + across * sqrt(1.0 - lowest * lowest)) * segment;
    }
    let deep = contact;
    if deep.depth <= step.limits.y {
        return placed; // inside the shell, outside the collider: the length stands
    }
    let wanted = (placed - parent) / segment;
    // In one pass over the normal and the directions tilted around it (the normal first,
    // then the nearest to `wanted`; hair_sim's `around`): the first out of every collider
    // that the segment reaches without passing through the head, and the first out of every
    // collider at all, reached only through a thin part that the segment pass then turns it
    // out of (w: the direction's rank; -2: none).
    var reached = vec4<f32>(0.0, 0.0, 0.0, -2.0);
    var out_of_it = reached;
    for (var k = 0u; k <= TILTED; k++) {
        var d = deep.normal;
        if k > 0u {
            d = tilted(deep.normal, k - 1u);
        }
        let rank = select(dot(d, wanted), 2.0, k == 0u);
        if !(rank > reached.w) {
            continue;
        }
        let x = parent + d * segment;
        let there = contact_at(x, now);
        if there.hit && there.depth > step.limits.y {
            continue;
        }
        if rank > out_of_it.w {
            out_of_it = vec4<f32>(d, rank);
        }
        if step.grid_dims.w == 0u || !crosses(local_point(now, parent), local_point(now, x)) {
            reached = vec4<f32>(d, rank);
        }
    }
    if reached.w > -2.0 {
        return parent + reached.xyz * segment;
    }
    if out_of_it.w > -2.0 {
        return parent + out_of_it.xyz * segment;
    }
    tally.contact_stretches += 1.0;
    return deep.position - deep.normal * (step.limits.y - 1e-6);
}

// On the step's last substep, segments (below the root's, which starts on the scalp) that run
// through the head between two particles outside it, as across an ear's rim: each turns
// about its parent until it is out (`turn_out_of`), the strand below follows it as a leader
// and is placed again, every particle checked; where placing the turned particle on the
// shell takes the segment back through (a fold), the turned segment stands. hair_sim's
// `keep_segments_outside`.
fn keep_segments_outside(first: u32, n: u32, now: Pose) {
    for (var j = 2u; j < n; j++) {
        let i = particle_slot(first, j);
        let parent = positions[i - LANES].xyz;
        let child = positions[i].xyz;
        let local_parent = local_point(now, parent);
        let local_child = local_point(now, child);
        let span = distance(parent, child);
        // Both ends clear more than the surface can rise between them (the skull): out.
        let lowest = min(head_surface(local_parent).distance, head_surface(local_child).distance);
        if lowest > rise_under(0.5 * (local_parent + local_child), span) {
            continue;
        }
        let local_turned = turn_out_of(local_parent, local_child, span);
        if all(local_turned == local_child) {
            continue;
        }
        // Only the turn's direction comes back from head-local space (hair_sim's
        // `keep_segments_outside`).
        let turned = parent + now.rotation * normalize_or(local_turned - local_parent, vec3<f32>(0.0, 1.0, 0.0)) * span;
        tally.segment_turns += 1.0;
        // The strand placed again from the turned particle; where placing it on the shell
        // took the segment back through (a fold), once more from the turned particle as it
        // was turned.
        var from_particle = j;
        for (var round = 0u; round < 2u; round++) {
            for (var k = from_particle; k < n; k++) {
                let at = particle_slot(first, k);
                place_at_length(at, select(positions[at].xyz, turned, k == j), -1.0, now);
            }
            if round == 1u {
                break;
            }
            let placed = local_point(now, positions[i].xyz);
            let turned_contact = contact_at(turned, now);
            let turned_outside = !turned_contact.hit || turned_contact.depth <= step.limits.y;
            if !(any(placed != local_turned) && crosses(local_parent, placed) && turned_outside) {
                break;
            }
            set_final(i, turned);
            from_particle = j + 1u;
        }
    }
}

// --- The skin that moves against the head: hair_sim's `SurfacePatch::resolve` ---

struct PatchContact {
    hit: bool,
    position: vec3<f32>,
    normal: vec3<f32>,
    depth: f32,
}

fn patch_u32(start: u32, k: u32) -> u32 {
    return colliders[start + k / 4u][k % 4u];
}

// The point of triangle `a b c` closest to `p` (Ericson, Real-Time Collision Detection
// 5.1.5), and where it lies: 0 the face, 1–3 corner a, b, c, 4–6 edge ab, bc, ca.
struct OnTriangle {
    point: vec3<f32>,
    feature: u32,
}

// Where a triangle's ten-vec4 record (corners, face normal, edge normals ab bc ca, corner
// normals a b c) holds the normal of `OnTriangle` feature `feature`.
fn feature_slot(feature: u32) -> u32 {
    if feature >= 4u {
        return feature; // an edge
    }
    if feature >= 1u {
        return 6u + feature; // a corner
    }
    return 3u; // the face
}

fn closest_on_triangle(p: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> OnTriangle {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return OnTriangle(a, 1u);
    }
    let bp = p - b;
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return OnTriangle(b, 2u);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return OnTriangle(a + ab * (d1 / (d1 - d3)), 4u);
    }
    let cp = p - c;
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return OnTriangle(c, 3u);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return OnTriangle(a + ac * (d2 / (d2 - d6)), 6u);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return OnTriangle(b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))), 5u);
    }
    let denominator = 1.0 / (va + vb + vc);
    return OnTriangle(a + ab * (vb * denominator) + ac * (vc * denominator), 0u);
}

// Where the moving skin pushes head-local `p`: out to the shell along the normal at its
// closest point, if `p` is behind that normal or within the shell, within the patch's
// reach.
fn patch_contact(p: vec3<f32>) -> PatchContact {
    let none = PatchContact(false, p, vec3<f32>(0.0), 0.0);
    let thickness = step.limits.y;
    if step.skin.x == 0u {
        return none;
    }
    let header = step.skin.x - 1u;
    let origin = collider(header).xyz;
    let reach = collider(header).w;
    let dims = colliders[header + 1u].xyz;
    let cell = collider(header + 1u).w;
    if thickness > reach {
        return none;
    }
    let c = (p - origin) / cell;
    if !(all(c >= vec3<f32>(0.0)) && all(c < vec3<f32>(dims))) {
        return none;
    }
    let bin = vec3<u32>(c);
    let index = (bin.z * dims.y + bin.y) * dims.x + bin.x;
    var best_distance = 3.4e38;
    var best = OnTriangle(p, 0u);
    var best_triangle = 0u;
    for (var k = patch_u32(step.skin.z, index); k < patch_u32(step.skin.z, index + 1u); k++) {
        let t = patch_u32(step.skin.w, k);
        let base = step.skin.y + 10u * t;
        let on = closest_on_triangle(p, collider(base).xyz, collider(base + 1u).xyz, collider(base + 2u).xyz);
        let d = dot(p - on.point, p - on.point);
        if d < best_distance {
            best_distance = d;
            best = on;
            best_triangle = base;
        }
    }
    if best_distance > 3.0e38 {
        return none;
    }
    let distance = sqrt(best_distance);
    if distance > reach {
        return none;
    }
    // The face's normal, an edge's (the two faces'), or a corner's: the feature's.
    let normal = collider(best_triangle + feature_slot(best.feature)).xyz;
    let offset = p - best.point;
    var signed = distance;
    if dot(offset, normal) < 0.0 {
        signed = -distance;
    }
    if signed >= thickness || all(normal == vec3<f32>(0.0)) {
        return none;
    }
    var out = normal;
    if distance > 1e-7 {
        out = offset / signed;
    }
    return PatchContact(true, best.point + out * thickness, out, thickness - signed);
}

// --- The step ---

fn reset_strand(first: u32, n: u32, to: Pose) {
    motion[3u * slots() + first].w = 0.0;
    for (var j = 0u; j < n; j++) {
        let i = particle_slot(first, j);
        let x = world_point(to, rest_position(i));
        positions[i] = vec4<f32>(x, 0.0);
        motion[i] = vec4<f32>(0.0);
        // The spring model forgets the substep before (the root's w: no history).
        if step.spring_flags.x == 1u {
            springs[i] = vec4<f32>(x, 0.0);
            springs[slots() + i] = vec4<f32>(0.0);
        }
    }
}

// 1.-3. of substep `k`: forces and integration, the root following the head, shape and the
// length constraint; where nothing collides, the velocities too (5.).
fn move_strand(strand: u32, first: u32, n: u32, k: u32) {
    let h = step.gravity_h.w;
    let time = step.gusts.z + h * f32(k);
    let now = pose(k);

    // Each pass below goes over the strand once, root to tip, and does for each particle
    // in turn what the CPU does for the whole strand in turn, with the same arithmetic: a
    // particle's step reads only its own values and those of the particles just above it,
    // and where a later stage reads them as an earlier stage left them, they are carried.
    // Each pass reads and writes every particle: the fewer passes, the less the step waits
    // on memory.

    // 1. Forces and integration (the start of the substep kept first); 2. the root
    //    follows the head.
    let wind = wind_at(step.flags.w + strand, time);
    let integrate = step.spring_flags.x == 0u;
    for (var j = 0u; j < n; j++) {
        let i = particle_slot(first, j);
        let x = positions[i].xyz;
        motion[slots() + i] = vec4<f32>(x, 0.0);
        motion[2u * slots() + i] = vec4<f32>(0.0);
        if integrate && j > 0u {
            let v = velocity(i) * step.motion.x + acceleration(i, wind) * h;
            positions[i] = vec4<f32>(x + clamp_length_max(v * h, step.motion.y), 0.0);
        }
    }
    positions[first] = vec4<f32>(world_point(now, rest_position(first)), 0.0);
    // The integrator's step: the particles end at `base + step_length · velocity`.
    var step_length = h;
    if !integrate {
        step_length = implicit_springs(first, n, h, wind);
    }
    let inverse_step = 1.0 / step_length;
    // Where nothing collides, the velocities (5.) are taken in the last shape pass,
    // particle j - 1's once particle j, whose correction it needs, is placed; unless there
    // is no shape pass.
    let collide = step.flags.x == 1u;
    let settle_in_shape = !collide && step.counts.w > 0u;

    // 3. Shape and length: global shape, local shape (from the parent as local shape left
    //    it) and the length constraint (from the parent as the constraint left it). Local
    //    shape's bend at particle j moves j - 1 and j - 2 as well, so the shaped values of
    //    the last three ride along, and a particle is placed two behind the one shaped.
    let root_frame = now.rotation * quat_mat(root_frames[strand]);
    for (var iteration = 0u; iteration < step.counts.w; iteration++) {
        let settle = settle_in_shape && iteration + 1u == step.counts.w;
        var frame = root_frame;
        var grandparent = vec3<f32>(0.0);
        var parent = positions[first].xyz;
        var placed = parent;
        for (var j = 1u; j < n; j++) {
            let i = particle_slot(first, j);
            var x = positions[i].xyz;
            let a = alpha(j);
            if a > 0.0 {
                x = x + (world_point(now, rest_position(i)) - x) * a;
            }
            if step.motion.z > 0.0 {
                let expected = normalize_or(frame * rest_direction(i), rest_direction(i));
                let segment = x - parent;
                let direction = normalize_or(segment, expected);
                let turned = normalize_or(direction + (expected - direction) * step.motion.z, expected);
                let turn = parent + turned * length(segment) - x;
                if j == 1u {
                    x += turn;
                } else {
                    let moves = bend(i, j, grandparent, parent, x, turn);
                    grandparent += moves[0];
                    parent += moves[1];
                    x += moves[2];
                }
                let actual = normalize_or(x - parent, expected);
                frame = rotation_arc(expected, actual) * frame;
            }
            if j > 2u {
                placed = place_shaped(first, j - 2u, n, placed, grandparent, settle, inverse_step);
            }
            grandparent = parent;
            parent = x;
        }
        // The last two (one where the strand has but one segment).
        if n > 2u {
            placed = place_shaped(first, n - 2u, n, placed, grandparent, settle, inverse_step);
        }
        place_shaped(first, n - 1u, n, placed, parent, settle, inverse_step);
    }
    if settle_in_shape {
        set_root_velocity(first, h);
    } else if !collide {
        update_velocities(first, n, h, inverse_step);
    }
}

// 4. (first half) The contacts of the particle in slot `i` in substep `k`, with friction:
//    the head's, the skin's that moved against it, the extra colliders'. Where it ends is
//    written back, and its contacts (how many, the deepest) kept for `place_strand`.
fn collide_particle(i: u32, k: u32) {
    let before = pose(k - 1u);
    let now = pose(k);
    var x = positions[i].xyz;
    motion[3u * slots() + i] = vec4<f32>(x, 0.0);
    if step.grid_dims.w == 1u {
        // Friction slides back along the tangent plane, which in a hollow dips under the
        // surface: out again from there (a second query), unless the slide is too short to
        // reach the surface (a quarter of the shell, as on the CPU).
        var query = local_point(now, x);
        for (var again = 0u; again < 2u; again++) {
            let contact = head_contact(query);
            if !contact.hit {
                break;
            }
            if again == 1u {
                x = world_point(now, contact.position);
                break;
            }
            touch(contact.depth);
            let held = with_friction(contact.position, contact.normal, local_point(before, start(i)));
            x = world_point(now, held);
            if !(length(held - contact.position) > 0.25 * step.limits.y) {
                break;
            }
            query = held;
        }
        // The skin that moved against the head's frame, as it is now.
        let local = local_point(now, x);
        let skin = patch_contact(local);
        if skin.hit {
            touch(skin.depth);
            x = world_point(now, with_friction(skin.position, skin.normal, local_point(before, start(i))));
        }
    }
    // Whether the head or the skin touched it: the final pass checks such a particle more
    // closely (`CONTACT_SLACK`).
    motion[3u * slots() + i].w = select(0.0, 1.0, tally.contacts > 0.0);
    x = out_of_extras(x, start(i));
    positions[i] = vec4<f32>(x, 0.0);
    motion[slots() + i].w = tally.contacts;
    motion[2u * slots() + i].w = tally.max_depth;
}

// 4. (second half) Each particle, where `collide_particle` left it, given the length pass
//    once more, which turns its segment about its parent where it would put it back
//    inside. 5. The velocities, unless the segments' pass follows (`turn_segments`).
fn place_strand(first: u32, n: u32, k: u32) {
    let h = step.gravity_h.w;
    let now = pose(k);
    let inverse_step = 1.0 / integrator_step(first);
    let segments = turns_segments(k);
    var parent = positions[first].xyz;
    for (var j = 1u; j < n; j++) {
        let i = particle_slot(first, j);
        tally.contacts += motion[slots() + i].w;
        tally.max_depth = max(tally.max_depth, motion[2u * slots() + i].w);
        let placed = place_at_length(i, positions[i].xyz, unchecked_slack(i) * step.limits.y, now);
        if !segments {
            settle_behind(i, j, n, parent, placed, inverse_step);
        }
        parent = placed;
    }
    if !segments {
        set_root_velocity(first, h);
    }
}

// Whether substep `k` ends with the segments' pass: the step's last, with the head.
fn turns_segments(k: u32) -> bool {
    return step.spring_flags.z == 1u && k == step.counts.z && step.grid_dims.w == 1u;
}

// 4. (last) The segments that run through the head turned out of it, then 5. the velocities.
fn turn_segments(first: u32, n: u32, k: u32) {
    keep_segments_outside(first, n, pose(k));
    update_velocities(first, n, step.gravity_h.w, 1.0 / integrator_step(first));
}

// The integrator's step as `move_strand` took it for the strand whose root is in slot
// `first`: the substep, or the spring model's (kept with the root's base).
fn integrator_step(first: u32) -> f32 {
    if step.spring_flags.x == 1u {
        return springs[2u * slots() + first].w;
    }
    return step.gravity_h.w;
}

// hair_sim's `bend`: the moves of particles j - 2, j - 1 and j (slot `i`), at
// `grandparent`, `parent` and `x`, that take the joint at j - 1 as far toward its rest bend
// as moving particle j by `turn` alone would, the parent segment taking the reaction.
fn bend(i: u32, j: u32, grandparent: vec3<f32>, parent: vec3<f32>, x: vec3<f32>, turn: vec3<f32>) -> mat3x3<f32> {
    let child_length = rest_length(i);
    let parent_length = rest_length(i - LANES);
    let parent_segment = parent - grandparent;
    let torque = cross(x - parent, turn);
    let reaction = cross(torque, parent_segment) * (1.0 / (parent_length * parent_length));
    let grandparent_weight = select(1.0, 0.0, j == 2u);
    let ratio = child_length * (1.0 / parent_length);
    let share = 1.0 / (1.0 + ratio * ratio * grandparent_weight + (1.0 + ratio) * (1.0 + ratio));
    let child = turn * share;
    let moved_grandparent = reaction * (share * grandparent_weight);
    return mat3x3<f32>(moved_grandparent, -(child + moved_grandparent), child);
}

// The length constraint for particle `j`, shaped to `shaped`, below its parent placed at
// `parent`; where it is placed. In the last shape pass where nothing collides, the
// velocities it settles (`settle_behind`).
fn place_shaped(first: u32, j: u32, n: u32, parent: vec3<f32>, shaped: vec3<f32>, settle: bool, inverse_step: f32) -> vec3<f32> {
    let i = particle_slot(first, j);
    let placed = constrain_length(i, parent, shaped, vec3<f32>(0.0, -1.0, 0.0));
    if settle {
        settle_behind(i, j, n, parent, placed, inverse_step);
    }
    return placed;
}

// 5. Velocities from where the particles ended up, slowed by FTL's correction as a brake
// (hair_sim's `ftl_brake`: it only slows, so hair at rest keeps no speed); the integrator
// advanced them `1 / inverse_step` (the substep, or the spring model's). In the pass that
// places the particles last where it can, else in a pass of its own.
fn update_velocities(first: u32, n: u32, h: f32, inverse_step: f32) {
    set_root_velocity(first, h);
    for (var j = 1u; j < n; j++) {
        let i = particle_slot(first, j);
        var next = vec3<f32>(0.0);
        if j + 1u < n {
            next = correction(i + LANES);
        }
        set_velocity(i, positions[i].xyz, next, inverse_step);
    }
}

fn set_root_velocity(first: u32, h: f32) {
    let root_velocity = (positions[first].xyz - start(first)) * (1.0 / h);
    motion[first] = vec4<f32>(clamp_length_max(root_velocity, step.limits.x), 0.0);
}

// The velocities a placing pass can take once particle `j` (slot `i`) is placed at
// `placed` below its parent, placed at `parent`: the parent's, which needs this particle's
// correction, and at the tip its own.
fn settle_behind(i: u32, j: u32, n: u32, parent: vec3<f32>, placed: vec3<f32>, inverse_step: f32) {
    if j > 1u {
        set_velocity(i - LANES, parent, correction(i), inverse_step);
    }
    if j + 1u == n {
        set_velocity(i, placed, vec3<f32>(0.0), inverse_step);
    }
}

// Particle `i`'s velocity, it ending at `x` and the particle below it corrected by `next`
// (zero at the tip): the motion, slowed where Müller's term opposes it, by at most all of it.
fn set_velocity(i: u32, x: vec3<f32>, next: vec3<f32>, inverse_step: f32) {
    var base = start(i);
    if step.spring_flags.x == 1u {
        base = springs_base(i);
    }
    var moved = (x - base) * inverse_step;
    if step.flags.x == 1u {
        moved = without_rebound(i, x, base, moved, inverse_step);
    }
    let opposing = dot(next, moved) * step.motion.w;
    let share = clamp(opposing * (1.0 / max(dot(moved, moved), 1e-30)), 0.0, 1.0);
    var v = moved * (1.0 - share);
    // A correction gone non-finite leaves the velocity so (the clamp would hide it), and
    // the strand is reset, as on the CPU.
    if !finite(next) {
        v = next;
    }
    motion[i] = vec4<f32>(clamp_length_max(v, step.limits.x), 0.0);
}

// The velocity `moved` of particle `i` ending at `x`, less what collision's shove added along
// its own direction, relative to the head's surface there (hair_sim's `without_rebound`).
fn without_rebound(i: u32, x: vec3<f32>, base: vec3<f32>, moved: vec3<f32>, inverse_step: f32) -> vec3<f32> {
    let k = phase.x;
    let from_ = shaped(i);
    let shove = normalize_or(x - from_, vec3<f32>(0.0));
    let surface = (world_point(pose(k), local_point(pose(k - 1u), from_)) - from_) * (1.0 / step.gravity_h.w);
    let leaving_before = max(dot((from_ - base) * inverse_step - surface, shove), 0.0);
    let leaving = dot(moved - surface, shove);
    return moved - shove * max(leaving - leaving_before, 0.0);
}

// Gravity and the wind across particle `i`'s segment as the substep started.
fn acceleration(i: u32, wind: vec3<f32>) -> vec3<f32> {
    var accel = step.gravity_h.xyz;
    if any(wind != vec3<f32>(0.0)) {
        let tangent = normalize_or(start(i) - start(i - LANES), vec3<f32>(0.0));
        accel += wind - tangent * dot(wind, tangent);
    }
    return accel;
}

// The length the final pass gives particle `i`'s segment, pointing `towards`: its rest
// length, or with springs, its length held within the tolerance.
fn final_length(i: u32, towards: vec3<f32>) -> f32 {
    let rest_l = rest_length(i);
    if step.spring_flags.x == 1u {
        let tolerance = step.springs.w;
        return clamp(length(towards), rest_l * (1.0 - tolerance), rest_l * (1.0 + tolerance));
    }
    return rest_l;
}

// --- The spring model: hair_sim's `implicit_springs`, one strand at a time ---

fn springs_previous_position(i: u32) -> vec3<f32> { return springs[i].xyz; }
fn springs_previous_velocity(i: u32) -> vec3<f32> { return springs[slots() + i].xyz; }
fn springs_base(i: u32) -> vec3<f32> { return springs[2u * slots() + i].xyz; }
fn springs_direction(i: u32) -> vec3<f32> { return springs[3u * slots() + i].xyz; }
// Per segment: stretch at the predicted positions, spring row's right side, tension, the
// forward sweep's coefficient.
fn springs_stretch(i: u32) -> f32 { return springs[4u * slots() + i].x; }
fn springs_rhs(i: u32) -> f32 { return springs[4u * slots() + i].y; }
fn springs_tension(i: u32) -> f32 { return springs[4u * slots() + i].z; }
fn springs_sweep(i: u32) -> f32 { return springs[4u * slots() + i].w; }
// Per segment: the bound it is held at, and whether it is held (1/0).
fn springs_bound(i: u32) -> f32 { return springs[5u * slots() + i].x; }
fn springs_rigid(i: u32) -> bool { return springs[5u * slots() + i].y == 1.0; }

// How far inside its bound, as a share of the bound, a segment counts as resting on it.
const BOUND_SLACK: f32 = 1e-3;
// Most solves that add segments held at their bound, per substep.
const MAX_ACTIVE_SET_PASSES: u32 = 4u;

// The mass-spring model integrated implicitly (BDF2 where the strand remembers a substep
// of the same length, else backward Euler), segments beyond the tolerance held at their
// bound. Returns the integrator's step.
fn implicit_springs(first: u32, n: u32, h: f32, wind: vec3<f32>) -> f32 {
    let remembered = springs[first].w == h;
    let current = select(1.0, 4.0 / 3.0, remembered);
    let previous = select(0.0, 1.0 / 3.0, remembered);
    let step_length = select(h, h * (2.0 / 3.0), remembered);
    let drag = step.motion.x;
    for (var j = 1u; j < n; j++) {
        let i = particle_slot(first, j);
        let x = start(i);
        let v = velocity(i);
        let base = x * current - springs_previous_position(i) * previous;
        let new_v = (v * current - springs_previous_velocity(i) * previous) * drag + acceleration(i, wind) * step_length;
        springs[i] = vec4<f32>(x, 0.0);
        springs[slots() + i] = vec4<f32>(v, 0.0);
        springs[2u * slots() + i] = vec4<f32>(base, 0.0);
        motion[i] = vec4<f32>(new_v, 0.0);
        positions[i] = vec4<f32>(base + new_v * step_length, 0.0);
    }
    springs[first] = vec4<f32>(springs[first].xyz, h);
    // (The root's w: the integrator's step, for `place_strand`.)
    springs[2u * slots() + first] = vec4<f32>(start(first), step_length);

    // The segments at the predicted positions; the pinned root's velocity damps the first.
    let root_velocity = (positions[first].xyz - start(first)) * (1.0 / h);
    let k = step.springs.x;
    let d = step.springs.y;
    let tolerance = step.springs.w;
    for (var j = 1u; j < n; j++) {
        let i = particle_slot(first, j);
        let segment = positions[i].xyz - positions[i - LANES].xyz;
        let l = length(segment);
        var direction = vec3<f32>(0.0);
        if l > 1e-9 {
            direction = segment * (1.0 / l);
        }
        let stretch = l - rest_length(i);
        var parent_velocity = root_velocity;
        if j > 1u {
            parent_velocity = velocity(i - LANES);
        }
        let rhs = -(k * stretch + d * dot(direction, velocity(i) - parent_velocity));
        springs[3u * slots() + i] = vec4<f32>(direction, 0.0);
        springs[4u * slots() + i] = vec4<f32>(stretch, rhs, 0.0, 0.0);
        springs[5u * slots() + i] = vec4<f32>(0.0);
    }
    let w = step.springs.z;
    let coupling = (k * step_length + d) * step_length * w;
    let displacement = step_length * step_length * w;
    solve_tensions(first, n, coupling, displacement);
    for (var solve = 0u; solve < MAX_ACTIVE_SET_PASSES; solve++) {
        var added = false;
        var parent = positions[first].xyz;
        for (var j = 1u; j < n; j++) {
            let i = particle_slot(first, j);
            let x = positions[i].xyz + pull(i, j, n) * displacement;
            let stretch = length(x - parent) - rest_length(i);
            parent = x;
            let beyond = abs(stretch) > rest_length(i) * tolerance * (1.0 - BOUND_SLACK);
            if beyond && !springs_rigid(i) {
                let bound = select(-(rest_length(i) * tolerance), rest_length(i) * tolerance, stretch > 0.0);
                springs[5u * slots() + i] = vec4<f32>(bound, 1.0, 0.0, 0.0);
                added = true;
            }
        }
        if !added {
            break;
        }
        solve_tensions(first, n, coupling, displacement);
    }
    for (var j = 1u; j < n; j++) {
        let i = particle_slot(first, j);
        let v = clamp_length_max(velocity(i) + pull(i, j, n) * (step_length * w), step.limits.x);
        motion[i] = vec4<f32>(v, 0.0);
        positions[i] = vec4<f32>(springs_base(i) + v * step_length, 0.0);
    }
    return step_length;
}

// The net force of the tensions on particle `i` (index `j` in its strand of `n`).
fn pull(i: u32, j: u32, n: u32) -> vec3<f32> {
    var child = vec3<f32>(0.0);
    if j + 1u < n {
        child = springs_direction(i + LANES) * springs_tension(i + LANES);
    }
    return springs_direction(i) * springs_tension(i) - child;
}

// The segment tensions by Thomas' algorithm, as the CPU's `solve_tensions`.
fn solve_tensions(first: u32, n: u32, coupling: f32, displacement: f32) {
    var upper_before = 0.0;
    for (var j = 1u; j < n; j++) {
        let i = particle_slot(first, j);
        let own = select(2.0, 1.0, j == 1u);
        var lower = 0.0;
        if j > 1u {
            lower = -dot(springs_direction(i), springs_direction(i - LANES));
        }
        var upper = 0.0;
        if j + 1u < n {
            upper = -dot(springs_direction(i), springs_direction(i + LANES));
        }
        let rigid = springs_rigid(i);
        let to_bound = springs_bound(i) - springs_stretch(i);
        let scale = select(coupling, 1.0, rigid);
        let diagonal = select(1.0 + coupling * own, own, rigid);
        let rhs = select(springs_rhs(i), to_bound / displacement, rigid);
        lower *= scale;
        upper *= scale;
        let pivot = 1.0 / (diagonal - lower * upper_before);
        let sweep = upper * pivot;
        var carried = 0.0;
        if j > 1u {
            carried = lower * springs_tension(i - LANES);
        }
        let tension = (rhs - carried) * pivot;
        springs[4u * slots() + i] = vec4<f32>(springs_stretch(i), springs_rhs(i), tension, sweep);
        upper_before = sweep;
    }
    for (var j = n - 2u; j >= 1u; j--) {
        let i = particle_slot(first, j);
        let tension = springs_tension(i) - springs_sweep(i) * springs_tension(i + LANES);
        springs[4u * slots() + i] = vec4<f32>(springs_stretch(i), springs_rhs(i), tension, springs_sweep(i));
    }
}

// The length constraint on particle `i`, shaped to `x`, below its parent placed at
// `parent`: Follow-The-Leader (at rest length from the parent, its correction kept for
// the velocity term), or with springs the reference's (no segment longer or shorter than
// the tolerance). Writes the particle and returns where it is.
fn constrain_length(i: u32, parent: vec3<f32>, x: vec3<f32>, down: vec3<f32>) -> vec3<f32> {
    var placed = x;
    if step.spring_flags.x == 1u {
        let tolerance = step.springs.w;
        let d = x - parent;
        let l = length(d);
        let clamped = clamp(l, rest_length(i) * (1.0 - tolerance), rest_length(i) * (1.0 + tolerance));
        if clamped != l {
            placed = parent + normalize_or(d, down) * clamped;
        }
    } else {
        placed = parent + normalize_or(x - parent, down) * rest_length(i);
        motion[2u * slots() + i] = vec4<f32>(correction(i) + placed - x, 0.0);
    }
    positions[i] = vec4<f32>(placed, 0.0);
    return placed;
}

// --- The entry points: a step, a substep at a time ---
//
// `GpuStrands::step` dispatches, for each substep k (`phase.x`, 1 to substeps):
// `move_strands`, an invocation per strand; with collision, `collide_particles`, an
// invocation per particle, then `place_strands`, one per strand again; on the step's last
// substep, with the head and segment collision, `turn_strands`, one per strand. A
// particle's contacts depend on nothing else in its strand, so each gets an invocation of
// its own: 32 times the strands' invocations, which is what a GPU needs to hide the
// queries' memory waits behind other invocations' work (65,536 strands are ~15 warps a
// core on an H200); what goes root to tip stays one invocation per strand. The segments'
// pass has a dispatch of its own, run once a step, so that the placing pass, run every
// substep, does not carry its code (llvmpipe, which runs through a branch no invocation
// takes, stepped 512 strands resting on the head in 150 ms with it there, 62 without).
//
// What a dispatch leaves the next is kept in the motion planes' w, unused otherwise: at a
// root's substep start, 1 where the strand started over at rest this step (its substeps
// are skipped, as on the CPU); at another particle's, the contacts `collide_particle`
// found for it; in its correction, the deepest of them.

@group(0) @binding(9) var<uniform> phase: vec4<u32>;

// Whether the strand whose root is in slot `first` started over at rest this step.
fn started_over(first: u32) -> bool {
    return motion[slots() + first].w == 1.0;
}

// The strand that invocation `id` of a per-strand dispatch steps (x: none at or past
// `step.counts.x`) and its root's slot (y).
fn strand_of(id: vec3<u32>, groups: vec3<u32>) -> vec2<u32> {
    let strand = invocation(id, groups);
    return vec2<u32>(strand, root_slot(strand, step.counts.y));
}

// Whether strand `s` (`strand_of`) is one this step's later dispatches step on: a strand,
// and not started over.
fn stepping(s: vec2<u32>) -> bool {
    return s.x < step.counts.x && !started_over(s.y);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn move_strands(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let s = strand_of(id, groups);
    let n = step.counts.y;
    let k = phase.x;
    if s.x >= step.counts.x {
        return;
    }
    if k == 1u {
        if !begin_step(s.x, s.y, n) {
            return;
        }
    } else if started_over(s.y) {
        return;
    }
    move_strand(s.x, s.y, n, k);
    if step.flags.x == 0u {
        end_substep(s.x, s.y, n, k);
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn collide_particles(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(id, groups);
    if i >= slots() {
        return;
    }
    let particle = slot_particle(i, step.counts.y);
    // Roots follow the head; the padding is no strand's.
    if particle.y == 0u || particle.x >= step.counts.x || started_over(i - particle.y * LANES) {
        return;
    }
    collide_particle(i, phase.x);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn place_strands(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let s = strand_of(id, groups);
    if !stepping(s) {
        return;
    }
    place_strand(s.y, step.counts.y, phase.x);
    if turns_segments(phase.x) {
        add_to_report(s.x); // the substep ends in `turn_strands`
    } else {
        end_substep(s.x, s.y, step.counts.y, phase.x);
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn turn_strands(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let s = strand_of(id, groups);
    if !stepping(s) {
        return;
    }
    turn_segments(s.y, step.counts.y, phase.x);
    end_substep(s.x, s.y, step.counts.y, phase.x);
}

// A strand's step begins: a root that jumped (a teleport) or is not finite starts it over
// at rest under the step's last pose, with no substeps (false); the spring model's memory
// is forgotten after a step without it.
fn begin_step(strand: u32, first: u32, n: u32) -> bool {
    let last = pose(step.counts.z);
    let jump = length(world_point(last, rest_position(first)) - positions[first].xyz);
    if !(jump <= step.limits.w) {
        reset_strand(first, n, last);
        motion[slots() + first] = vec4<f32>(positions[first].xyz, 1.0);
        tally.teleport_resets = 1.0;
        add_to_report(strand);
        return false;
    }
    if asleep(first) && step.sleep.z == 1.0 && jump <= ROOT_TOLERANCE {
        // Left where it is: the step's other passes pass it by, as one started over.
        motion[slots() + first].w = 1.0;
        tally.sleeping = 1.0;
        add_to_report(strand);
        return false;
    }
    if step.spring_flags.x == 1u && step.spring_flags.y == 0u {
        springs[first] = vec4<f32>(0.0);
    }
    return true;
}

// How far a sleeping strand's root may be from where the head puts it (hair_sim's
// `sleep::ROOT_TOLERANCE`).
const ROOT_TOLERANCE: f32 = 1e-6;

// Whether the strand whose root is in slot `first` is asleep (hair_sim's `sleep::asleep`).
fn asleep(first: u32) -> bool {
    return watching(first) && step.sleep.x > 0.0 && quiet(first) >= step.sleep.y;
}

// After a step in which the strand was stepped, its sleep watch (hair_sim's `sleep::watch`):
// it goes on while every particle stays near its anchor in a still step; else it starts
// over from here. A strand that falls asleep keeps no velocity.
fn watch(first: u32, n: u32) {
    let limit = step.sleep.x * step.sleep.x;
    var near = true;
    for (var j = 0u; j < n; j++) {
        let i = particle_slot(first, j);
        let d = positions[i].xyz - anchor(i);
        near = near && dot(d, d) <= limit;
    }
    if step.sleep.z == 1.0 && watching(first) && near {
        motion[4u * slots() + first].w = quiet(first) + step.sleep.w;
        if asleep(first) {
            for (var j = 0u; j < n; j++) {
                motion[particle_slot(first, j)] = vec4<f32>(0.0);
            }
        }
    } else {
        for (var j = 0u; j < n; j++) {
            let i = particle_slot(first, j);
            motion[4u * slots() + i] = vec4<f32>(positions[i].xyz, 0.0);
        }
        motion[3u * slots() + first].w = 1.0;
    }
}

// A strand's substep ends: on the step's last, a particle or velocity that is not finite
// starts it over at rest; what the substep did goes into the strand's report.
fn end_substep(strand: u32, first: u32, n: u32, k: u32) {
    if k == step.counts.z && !reset_if_not_finite(first, n, pose(k)) {
        watch(first, n);
    }
    add_to_report(strand);
}

// A strand with a particle or velocity that is not finite starts over at rest under `pose`.
fn reset_if_not_finite(first: u32, n: u32, at: Pose) -> bool {
    for (var j = 0u; j < n; j++) {
        let i = particle_slot(first, j);
        if !(finite(positions[i].xyz) && finite(velocity(i))) {
            reset_strand(first, n, at);
            tally.nan_resets = 1.0;
            return true;
        }
    }
    return false;
}

// Moves every particle, and the spring model's memory of where it was, by `step.offset`:
// the solver's origin moved (one invocation per particle).
@compute @workgroup_size(WORKGROUP_SIZE)
fn translate_particles(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(id, groups);
    if i >= slot_count(step.counts.x, step.counts.y) {
        return; // (the padding moves too: it is never read)
    }
    positions[i] = vec4<f32>(positions[i].xyz + step.offset.xyz, 0.0);
    let anchor_at = 4u * slots() + i;
    motion[anchor_at] = vec4<f32>(motion[anchor_at].xyz + step.offset.xyz, motion[anchor_at].w);
    if step.spring_flags.x == 1u {
        springs[i] = vec4<f32>(springs[i].xyz + step.offset.xyz, springs[i].w);
    }
}
