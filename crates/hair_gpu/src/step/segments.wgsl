// --- Whole segments: hair_sim's `keep_segments_outside`, by tracing ---

// The shortest step of the trace along a segment, metres: a stretch inside the head longer
// than this is found (a coarser step could step over one by an edge that the CPU, which
// intersects the triangles, turns).
const MIN_TRACE_STEP: f32 = 1e-6;

// Where the segment from head-local `a` (`a_distance` from the surface) to `b` runs inside the
// head: the fractions of the way at which it first enters and last leaves (x, y), with 1 in z;
// z is 0 where it stays out. hair_sim's `segment_crossing`, which intersects the triangles.
// A segment whose ends both clear half its length cannot reach the surface (every point of it
// is within half its length of an end); it is not traced.
fn crossed_stretch(a: vec3<f32>, a_distance: f32, b: vec3<f32>) -> vec3<f32> {
    let span = length(b - a);
    if !(span > 0.0) || min(a_distance, sure_clearance(b)) > 0.5 * span {
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
// exact query, by the BVH where a cell has no list: a segment that only touches the
// surface, or grazes an edge, stays out.
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
        let surface = head_surface_from(start_at + direction * at, by_hits);
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

// How far head-local `p` surely is from the surface: the distance, less the grid's error
// where the grid answers (a thin part, an ear's rim, can lie between its samples).
fn sure_clearance(p: vec3<f32>) -> f32 {
    let surface = head_surface(p);
    return surface.distance - select(0.0, step.near_bounds.x, surface.approximate);
}

// Whether the segment between head-local `a` and `b` runs through the head.
fn crosses(a: vec3<f32>, b: vec3<f32>) -> bool {
    return crossed_stretch(a, sure_clearance(a), b).z == 1.0;
}

// Where the segment ending in slot `i`, turned out of the head to `turned` (head-local,
// `span` from `parent`), goes instead: back to the direction it had at the step's start if
// that crosses nothing and lies within RIM_REST_REACH of the turn (hair_sim's
// `rest_on_rim`: a segment draped over an ear's rim rests there).
fn rest_on_rim(i: u32, parent: vec3<f32>, turned: vec3<f32>, span: f32) -> vec3<f32> {
    let start_pose = pose(0u);
    let direction = local_point(start_pose, step_start(i)) - local_point(start_pose, step_start(i - LANES));
    let rested = parent + normalize_or(direction, vec3<f32>(0.0, 1.0, 0.0)) * span;
    if distance(rested, turned) < RIM_REST_REACH && !crosses(parent, rested) {
        return rested;
    }
    return turned;
}

// hair_sim's `RIM_REST_REACH`, m.
const RIM_REST_REACH: f32 = 1e-2;

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
    let parent_distance = sure_clearance(parent);
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
