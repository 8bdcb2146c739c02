// One step of the strand solver on the GPU: one invocation per strand, every substep of
// the step in one dispatch (strands do not interact). It mirrors hair_sim's CPU solver
// (`solver/step.rs`) for the inextensible length model, operation for operation where it
// can, so that the two agree to rounding without collision. The head is the collider's
// baked distance grid, sampled trilinearly, with its gradient as the normal, where the CPU
// solver queries the exact mesh; whole segments are tested by sampling the grid along them.

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
}

@group(0) @binding(0) var<uniform> step: Step;
// Head poses, four vec4 each (rotation columns, translation) for substep boundaries
// 0..=substeps, then the global-shape alpha of each particle index, four per vec4.
@group(0) @binding(1) var<storage, read> tables: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> positions: array<vec4<f32>>;
// Per particle: velocity, position at the substep's start, FTL correction.
@group(0) @binding(3) var<storage, read_write> motion: array<vec4<f32>>;
// Per particle: head-local rest position with the rest length of the segment ending there
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
// The collider's signed distances, x fastest.
@group(0) @binding(7) var<storage, read> grid: array<f32>;
// The spring model's memory and scratch, six vec4 per particle (see `springs_*` below);
// the root's first holds, in w, the substep length the memory was taken at (0: none).
@group(0) @binding(8) var<storage, read_write> springs: array<vec4<f32>>;

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

fn velocity(i: u32) -> vec3<f32> { return motion[3u * i].xyz; }
fn start(i: u32) -> vec3<f32> { return motion[3u * i + 1u].xyz; }
fn correction(i: u32) -> vec3<f32> { return motion[3u * i + 2u].xyz; }
fn rest_position(i: u32) -> vec3<f32> { return rest[2u * i].xyz; }
fn rest_length(i: u32) -> f32 { return rest[2u * i].w; }
fn rest_direction(i: u32) -> vec3<f32> { return rest[2u * i + 1u].xyz; }

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

// --- The head: the baked distance grid ---

struct Surface {
    distance: f32,
    normal: vec3<f32>,
}

fn sample_index(x: u32, y: u32, z: u32) -> u32 {
    return (z * step.grid_dims.y + y) * step.grid_dims.x + x;
}

// Signed distance and gradient at head-local `p` by trilinear interpolation; far beyond the
// grid's margin outside it.
fn head_surface(p: vec3<f32>) -> Surface {
    let g = (p - step.centre.xyz - step.grid_origin.xyz) * step.grid_origin.w;
    let upper = vec3<f32>(step.grid_dims.xyz - vec3<u32>(1u));
    if step.grid_dims.w == 0u || !(all(g >= vec3<f32>(0.0)) && all(g < upper)) {
        return Surface(1e30, vec3<f32>(0.0, 1.0, 0.0));
    }
    let c = vec3<u32>(g);
    let t = g - vec3<f32>(c);
    let v000 = grid[sample_index(c.x, c.y, c.z)];
    let v100 = grid[sample_index(c.x + 1u, c.y, c.z)];
    let v010 = grid[sample_index(c.x, c.y + 1u, c.z)];
    let v110 = grid[sample_index(c.x + 1u, c.y + 1u, c.z)];
    let v001 = grid[sample_index(c.x, c.y, c.z + 1u)];
    let v101 = grid[sample_index(c.x + 1u, c.y, c.z + 1u)];
    let v011 = grid[sample_index(c.x, c.y + 1u, c.z + 1u)];
    let v111 = grid[sample_index(c.x + 1u, c.y + 1u, c.z + 1u)];
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
    return Surface(distance, normalize_or(vec3<f32>(gx, gy, gz), vec3<f32>(0.0, 1.0, 0.0)));
}

// Friction takes back part of the slide along the surface since the substep's start.
fn with_friction(position: vec3<f32>, normal: vec3<f32>, origin: vec3<f32>) -> vec3<f32> {
    let slide = position - origin;
    let tangential = slide - normal * dot(slide, normal);
    return position - tangential * step.limits.z;
}

// Head-local `p` pushed out to the collision shell along the grid's normal or out of the
// moving skin, whichever is deeper, or `p`.
fn out_of_head(p: vec3<f32>) -> vec3<f32> {
    let surface = head_surface(p);
    let skin = patch_contact(p);
    let head_depth = step.limits.y - surface.distance;
    if skin.hit && skin.depth > head_depth {
        return skin.position;
    }
    if head_depth > 0.0 {
        return p + surface.normal * head_depth;
    }
    return p;
}

// Where the head pushes head-local `p` (if `hit`), and the direction it pushes along.
struct Contact {
    hit: bool,
    position: vec3<f32>,
    normal: vec3<f32>,
}

// The head's contact for head-local `p`, by the response asked for: out along the grid's
// normal to the shell, or along the ray from `step.ray_from` (inside, to where the ray
// leaves the surface, plus the thickness; in the shell, by the shell's depth).
fn head_contact(p: vec3<f32>) -> Contact {
    let thickness = step.limits.y;
    let surface = head_surface(p);
    let depth = thickness - surface.distance;
    if !(depth > 0.0) {
        return Contact(false, p, surface.normal);
    }
    let normal_contact = Contact(true, p + surface.normal * depth, surface.normal);
    let direction = normalize_or(p - step.ray_from.xyz, vec3<f32>(0.0));
    if step.ray_from.w == 0.0 || all(direction == vec3<f32>(0.0)) {
        return normal_contact;
    }
    if depth <= thickness {
        return Contact(true, p + direction * depth, direction);
    }
    // Inside: march out along the ray. Inside the head the distance to the surface is at
    // least the grid's value less its error, so steps of that size cannot cross it.
    var t = 0.0;
    for (var march = 0u; march < 64u; march++) {
        let d = head_surface(p + direction * t).distance;
        if d >= 0.0 {
            return Contact(true, p + direction * (t + thickness), direction);
        }
        t += max(-d, 1e-4);
    }
    return normal_contact; // never left (a ray along a sliver): along the normal
}

// World `x` pushed out of the extra colliders, with friction against `origin`.
fn out_of_extras(x_in: vec3<f32>, origin: vec3<f32>) -> vec3<f32> {
    var x = x_in;
    for (var e = 0u; e < step.flags.y; e++) {
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
        if distance < reach {
            var normal = vec3<f32>(0.0, 1.0, 0.0);
            if distance > 1e-7 {
                normal = offset / distance;
            }
            x = with_friction(centre + normal * reach, normal, origin);
        }
    }
    return x;
}

// Whether head-local `local` lies deeper than half the shell in the head or the skin
// that moves against it.
fn too_deep(local: vec3<f32>) -> bool {
    let skin = patch_contact(local);
    return head_surface(local).distance < 0.5 * step.limits.y || (skin.hit && skin.depth > 0.5 * step.limits.y);
}

// --- Whole segments: hair_sim's `keep_segments_outside`, on the grid ---

// The deepest point of the segment between head-local `a` (`a_distance` from the surface)
// and `b`, with its signed distance in w: the grid sampled every half cell along the
// segment. A segment whose ends both clear half its length cannot reach the surface (every
// point of it is within half its length of an end); it is not sampled, and w is that
// clearance.
fn deepest_between(a: vec3<f32>, a_distance: f32, b: vec3<f32>) -> vec4<f32> {
    let span = length(b - a);
    let ends = min(a_distance, head_surface(b).distance);
    if ends > 0.5 * span {
        return vec4<f32>(a, ends);
    }
    let samples = clamp(u32(ceil(2.0 * span * step.grid_origin.w)), 1u, 32u);
    var deepest = vec4<f32>(a, ends);
    for (var k = 0u; k < samples; k++) {
        let x = mix(a, b, (f32(k) + 0.5) / f32(samples));
        let d = head_surface(x).distance;
        if d < deepest.w {
            deepest = vec4<f32>(x, d);
        }
    }
    return deepest;
}

// Where to put world `placed`, `length` from world `parent`, so that the segment between them
// no longer runs through the head or deep into its shell: turned about the parent toward its
// deepest point pushed out onto the shell, a few turns at most (as on the CPU). `placed`
// itself where the segment stays out.
fn turn_segment_out(parent: vec3<f32>, placed: vec3<f32>, length: f32, now: Pose) -> vec3<f32> {
    let down = vec3<f32>(0.0, -1.0, 0.0);
    let local_parent = local_point(now, parent);
    let parent_distance = head_surface(local_parent).distance;
    var turned = placed;
    for (var turn = 0u; turn < 4u; turn++) {
        // Within a tenth of the shell of the surface counts as through: the grid is not
        // exact, and reads a segment cut by an ear's rim a little above zero. Over the
        // scalp a segment between two particles on the shell sags a fraction of a
        // millimetre below its ends, nowhere near that.
        let deepest = deepest_between(local_parent, parent_distance, local_point(now, turned));
        if deepest.w >= 0.1 * step.limits.y {
            break;
        }
        let through = world_point(now, out_of_head(deepest.xyz));
        turned = parent + normalize_or(through - parent, down) * length;
    }
    return turned;
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
    var normal = collider(best_triangle + 3u).xyz;
    if best.feature >= 4u {
        normal = collider(best_triangle + best.feature).xyz;
    } else if best.feature >= 1u {
        normal = collider(best_triangle + 6u + best.feature).xyz;
    }
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
    for (var j = 0u; j < n; j++) {
        let x = world_point(to, rest_position(first + j));
        positions[first + j] = vec4<f32>(x, 0.0);
        motion[3u * (first + j)] = vec4<f32>(0.0);
        // The spring model forgets the substep before (the root's w: no history).
        if step.spring_flags.x == 1u {
            springs[6u * (first + j)] = vec4<f32>(x, 0.0);
            springs[6u * (first + j) + 1u] = vec4<f32>(0.0);
        }
    }
}

fn substep(strand: u32, first: u32, n: u32, k: u32) {
    let h = step.gravity_h.w;
    let time = step.gusts.z + h * f32(k);
    let before = pose(k - 1u);
    let now = pose(k);
    let down = vec3<f32>(0.0, -1.0, 0.0);

    // 1. Forces and integration; 2. the root follows the head.
    for (var j = 0u; j < n; j++) {
        let i = first + j;
        motion[3u * i + 1u] = vec4<f32>(positions[i].xyz, 0.0);
        motion[3u * i + 2u] = vec4<f32>(0.0);
    }
    let wind = wind_at(step.flags.w + strand, time);
    positions[first] = vec4<f32>(world_point(now, rest_position(first)), 0.0);
    // The integrator's step: the particles end at `base + step_length · velocity`.
    var step_length = h;
    if step.spring_flags.x == 1u {
        step_length = implicit_springs(first, n, h, wind);
    } else {
        for (var j = 1u; j < n; j++) {
            let i = first + j;
            let v = (velocity(i) + acceleration(i, wind) * h) * step.motion.x;
            positions[i] = vec4<f32>(positions[i].xyz + clamp_length_max(v * h, step.motion.y), 0.0);
        }
    }

    // 3. Shape and length.
    let root_frame = now.rotation * quat_mat(root_frames[strand]);
    for (var iteration = 0u; iteration < step.counts.w; iteration++) {
        for (var j = 1u; j < n; j++) {
            let a = alpha(j);
            if a > 0.0 {
                let i = first + j;
                let x = positions[i].xyz;
                positions[i] = vec4<f32>(x + (world_point(now, rest_position(i)) - x) * a, 0.0);
            }
        }
        if step.motion.z > 0.0 {
            var frame = root_frame;
            for (var j = 1u; j < n; j++) {
                let i = first + j;
                let expected = normalize_or(frame * rest_direction(i), rest_direction(i));
                let parent = positions[i - 1u].xyz;
                let target_point = parent + expected * rest_length(i);
                let x = positions[i].xyz + (target_point - positions[i].xyz) * step.motion.z;
                positions[i] = vec4<f32>(x, 0.0);
                let actual = normalize_or(x - parent, expected);
                frame = rotation_arc(expected, actual) * frame;
            }
        }
        if step.spring_flags.x == 1u {
            clamp_lengths(first, n, down);
        } else {
            follow_the_leader(first, n, down);
        }
    }

    // 4. Collision, with friction, then the length pass once more, which turns a segment
    //    about its parent where it would put the particle back inside.
    if step.flags.x == 1u {
        for (var j = 1u; j < n; j++) {
            let i = first + j;
            var x = positions[i].xyz;
            if step.grid_dims.w == 1u {
                let contact = head_contact(local_point(now, x));
                if contact.hit {
                    // Friction slides back along the tangent plane, which in a hollow dips
                    // under the surface: out again from there, unless the slide is too
                    // short to reach the surface (a quarter of the shell, as on the CPU).
                    var held = with_friction(contact.position, contact.normal, local_point(before, start(i)));
                    if length(held - contact.position) > 0.25 * step.limits.y {
                        let again = head_contact(held);
                        if again.hit {
                            held = again.position;
                        }
                    }
                    x = world_point(now, held);
                }
                // The skin that moved against the head's frame, as it is now.
                let local = local_point(now, x);
                let skin = patch_contact(local);
                if skin.hit {
                    x = world_point(now, with_friction(skin.position, skin.normal, local_point(before, start(i))));
                }
            }
            positions[i] = vec4<f32>(out_of_extras(x, start(i)), 0.0);
        }
        for (var j = 1u; j < n; j++) {
            let i = first + j;
            let parent = positions[i - 1u].xyz;
            let towards = positions[i].xyz - parent;
            let length = final_length(i, towards);
            var placed = parent + normalize_or(towards, down) * length;
            for (var turn = 0u; turn < 4u && step.grid_dims.w == 1u; turn++) {
                let local = local_point(now, placed);
                if !too_deep(local) {
                    break;
                }
                let out = world_point(now, out_of_head(local));
                placed = parent + normalize_or(out - parent, down) * length;
            }
            // On the step's last substep, a segment must not cut through a thin part either
            // (the root's, which starts on the scalp, is the head's own business).
            if step.spring_flags.z == 1u && k == step.counts.z && j >= 2u && step.grid_dims.w == 1u {
                placed = turn_segment_out(parent, placed, length, now);
            }
            let local = local_point(now, placed);
            if step.grid_dims.w == 1u && too_deep(local) {
                placed = world_point(now, out_of_head(local)); // collision wins over length
            }
            if step.spring_flags.x == 0u {
                motion[3u * i + 2u] = vec4<f32>(correction(i) + placed - positions[i].xyz, 0.0);
            }
            positions[i] = vec4<f32>(placed, 0.0);
        }
    }

    // 5. Velocities from where the particles ended up, less FTL's correction.
    let root_velocity = (positions[first].xyz - start(first)) * (1.0 / h);
    motion[3u * first] = vec4<f32>(clamp_length_max(root_velocity, step.limits.x), 0.0);
    let inverse_step = 1.0 / step_length;
    for (var j = 1u; j < n; j++) {
        let i = first + j;
        var next = vec3<f32>(0.0);
        if j + 1u < n {
            next = correction(i + 1u);
        }
        var base = start(i);
        if step.spring_flags.x == 1u {
            base = springs_base(i);
        }
        let v = (positions[i].xyz - base) * inverse_step - next * step.motion.w;
        motion[3u * i] = vec4<f32>(clamp_length_max(v, step.limits.x), 0.0);
    }
}

// Gravity and the wind across particle `i`'s segment as the substep started.
fn acceleration(i: u32, wind: vec3<f32>) -> vec3<f32> {
    var accel = step.gravity_h.xyz;
    if any(wind != vec3<f32>(0.0)) {
        let tangent = normalize_or(start(i) - start(i - 1u), vec3<f32>(0.0));
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

fn springs_previous_position(i: u32) -> vec3<f32> { return springs[6u * i].xyz; }
fn springs_previous_velocity(i: u32) -> vec3<f32> { return springs[6u * i + 1u].xyz; }
fn springs_base(i: u32) -> vec3<f32> { return springs[6u * i + 2u].xyz; }
fn springs_direction(i: u32) -> vec3<f32> { return springs[6u * i + 3u].xyz; }
// Per segment: stretch at the predicted positions, spring row's right side, tension, the
// forward sweep's coefficient.
fn springs_stretch(i: u32) -> f32 { return springs[6u * i + 4u].x; }
fn springs_rhs(i: u32) -> f32 { return springs[6u * i + 4u].y; }
fn springs_tension(i: u32) -> f32 { return springs[6u * i + 4u].z; }
fn springs_sweep(i: u32) -> f32 { return springs[6u * i + 4u].w; }
// Per segment: the bound it is held at, and whether it is held (1/0).
fn springs_bound(i: u32) -> f32 { return springs[6u * i + 5u].x; }
fn springs_rigid(i: u32) -> bool { return springs[6u * i + 5u].y == 1.0; }

// How far inside its bound, as a share of the bound, a segment counts as resting on it.
const BOUND_SLACK: f32 = 1e-3;
// Most solves that add segments held at their bound, per substep.
const MAX_ACTIVE_SET_PASSES: u32 = 4u;

// The mass-spring model integrated implicitly (BDF2 where the strand remembers a substep
// of the same length, else backward Euler), segments beyond the tolerance held at their
// bound. Returns the integrator's step.
fn implicit_springs(first: u32, n: u32, h: f32, wind: vec3<f32>) -> f32 {
    let remembered = springs[6u * first].w == h;
    let current = select(1.0, 4.0 / 3.0, remembered);
    let previous = select(0.0, 1.0 / 3.0, remembered);
    let step_length = select(h, h * (2.0 / 3.0), remembered);
    let drag = step.motion.x;
    for (var j = 1u; j < n; j++) {
        let i = first + j;
        let x = start(i);
        let v = velocity(i);
        let base = x * current - springs_previous_position(i) * previous;
        let new_v = (v * current - springs_previous_velocity(i) * previous + acceleration(i, wind) * step_length) * drag;
        springs[6u * i] = vec4<f32>(x, 0.0);
        springs[6u * i + 1u] = vec4<f32>(v, 0.0);
        springs[6u * i + 2u] = vec4<f32>(base, 0.0);
        motion[3u * i] = vec4<f32>(new_v, 0.0);
        positions[i] = vec4<f32>(base + new_v * step_length, 0.0);
    }
    springs[6u * first] = vec4<f32>(springs[6u * first].xyz, h);
    springs[6u * first + 2u] = vec4<f32>(start(first), 0.0);

    // The segments at the predicted positions; the pinned root's velocity damps the first.
    let root_velocity = (positions[first].xyz - start(first)) * (1.0 / h);
    let k = step.springs.x;
    let d = step.springs.y;
    let tolerance = step.springs.w;
    for (var j = 1u; j < n; j++) {
        let i = first + j;
        let segment = positions[i].xyz - positions[i - 1u].xyz;
        let l = length(segment);
        var direction = vec3<f32>(0.0);
        if l > 1e-9 {
            direction = segment * (1.0 / l);
        }
        let stretch = l - rest_length(i);
        var parent_velocity = root_velocity;
        if j > 1u {
            parent_velocity = velocity(i - 1u);
        }
        let rhs = -(k * stretch + d * dot(direction, velocity(i) - parent_velocity));
        springs[6u * i + 3u] = vec4<f32>(direction, 0.0);
        springs[6u * i + 4u] = vec4<f32>(stretch, rhs, 0.0, 0.0);
        springs[6u * i + 5u] = vec4<f32>(0.0);
    }
    let w = step.springs.z;
    let coupling = (k * step_length + d) * step_length * w;
    let displacement = step_length * step_length * w;
    solve_tensions(first, n, coupling, displacement);
    for (var solve = 0u; solve < MAX_ACTIVE_SET_PASSES; solve++) {
        var added = false;
        var parent = positions[first].xyz;
        for (var j = 1u; j < n; j++) {
            let i = first + j;
            let x = positions[i].xyz + pull(i, j, n) * displacement;
            let stretch = length(x - parent) - rest_length(i);
            parent = x;
            let beyond = abs(stretch) > rest_length(i) * tolerance * (1.0 - BOUND_SLACK);
            if beyond && !springs_rigid(i) {
                let bound = select(-(rest_length(i) * tolerance), rest_length(i) * tolerance, stretch > 0.0);
                springs[6u * i + 5u] = vec4<f32>(bound, 1.0, 0.0, 0.0);
                added = true;
            }
        }
        if !added {
            break;
        }
        solve_tensions(first, n, coupling, displacement);
    }
    for (var j = 1u; j < n; j++) {
        let i = first + j;
        let v = clamp_length_max(velocity(i) + pull(i, j, n) * (step_length * w), step.limits.x);
        motion[3u * i] = vec4<f32>(v, 0.0);
        positions[i] = vec4<f32>(springs_base(i) + v * step_length, 0.0);
    }
    return step_length;
}

// The net force of the tensions on particle `i` (index `j` in its strand of `n`).
fn pull(i: u32, j: u32, n: u32) -> vec3<f32> {
    var child = vec3<f32>(0.0);
    if j + 1u < n {
        child = springs_direction(i + 1u) * springs_tension(i + 1u);
    }
    return springs_direction(i) * springs_tension(i) - child;
}

// The segment tensions by Thomas' algorithm, as the CPU's `solve_tensions`.
fn solve_tensions(first: u32, n: u32, coupling: f32, displacement: f32) {
    var upper_before = 0.0;
    for (var j = 1u; j < n; j++) {
        let i = first + j;
        let own = select(2.0, 1.0, j == 1u);
        var lower = 0.0;
        if j > 1u {
            lower = -dot(springs_direction(i), springs_direction(i - 1u));
        }
        var upper = 0.0;
        if j + 1u < n {
            upper = -dot(springs_direction(i), springs_direction(i + 1u));
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
            carried = lower * springs_tension(i - 1u);
        }
        let tension = (rhs - carried) * pivot;
        springs[6u * i + 4u] = vec4<f32>(springs_stretch(i), springs_rhs(i), tension, sweep);
        upper_before = sweep;
    }
    for (var j = n - 2u; j >= 1u; j--) {
        let i = first + j;
        let tension = springs_tension(i) - springs_sweep(i) * springs_tension(i + 1u);
        springs[6u * i + 4u] = vec4<f32>(springs_stretch(i), springs_rhs(i), tension, springs_sweep(i));
    }
}

// The reference's length constraint: no segment longer or shorter than the tolerance.
fn clamp_lengths(first: u32, n: u32, down: vec3<f32>) {
    let tolerance = step.springs.w;
    for (var j = 1u; j < n; j++) {
        let i = first + j;
        let parent = positions[i - 1u].xyz;
        let d = positions[i].xyz - parent;
        let l = length(d);
        let clamped = clamp(l, rest_length(i) * (1.0 - tolerance), rest_length(i) * (1.0 + tolerance));
        if clamped != l {
            positions[i] = vec4<f32>(parent + normalize_or(d, down) * clamped, 0.0);
        }
    }
}

// Follow-The-Leader: each particle at rest length from its parent, root to tip, its
// correction kept for the velocity term.
fn follow_the_leader(first: u32, n: u32, down: vec3<f32>) {
    for (var j = 1u; j < n; j++) {
        let i = first + j;
        let parent = positions[i - 1u].xyz;
        let x = positions[i].xyz;
        let placed = parent + normalize_or(x - parent, down) * rest_length(i);
        motion[3u * i + 2u] = vec4<f32>(correction(i) + placed - x, 0.0);
        positions[i] = vec4<f32>(placed, 0.0);
    }
}

@compute @workgroup_size(64)
fn step_strands(@builtin(global_invocation_id) id: vec3<u32>) {
    let strand = id.x;
    if strand >= step.counts.x {
        return;
    }
    let n = step.counts.y;
    let first = strand * n;
    let last = pose(step.counts.z);
    // A root that jumped (a teleport) or is not finite starts over at rest.
    let jump = length(world_point(last, rest_position(first)) - positions[first].xyz);
    if !(jump <= step.limits.w) {
        reset_strand(first, n, last);
        return;
    }
    // The spring model's memory is stale after a step without it.
    if step.spring_flags.x == 1u && step.spring_flags.y == 0u {
        springs[6u * first] = vec4<f32>(0.0);
    }
    for (var k = 1u; k <= step.counts.z; k++) {
        substep(strand, first, n, k);
    }
    for (var j = 0u; j < n; j++) {
        if !(finite(positions[first + j].xyz) && finite(velocity(first + j))) {
            reset_strand(first, n, last);
            return;
        }
    }
}

// Moves every particle, and the spring model's memory of where it was, by `step.offset`:
// the solver's origin moved (one invocation per particle).
@compute @workgroup_size(64)
fn translate_particles(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= step.counts.x * step.counts.y {
        return;
    }
    positions[i] = vec4<f32>(positions[i].xyz + step.offset.xyz, 0.0);
    if step.spring_flags.x == 1u {
        springs[6u * i] = vec4<f32>(springs[6u * i].xyz + step.offset.xyz, springs[6u * i].w);
    }
}
