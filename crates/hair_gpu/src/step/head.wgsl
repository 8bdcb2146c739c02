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
// the CPU's goes), and so does a segment's trace where it asks whether it is inside beyond
// a triangle it hit (`first_inside`: a thin part, an ear's rim, lies between the grid's
// samples, and read from the grid segments stayed through it); the turns and placements
// keep the grid there (with every triangle in them too, near-root hair stayed millimetres
// inside a skinned head blended into its neck, which `tests/characters.rs` checks; why is
// not understood).
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

// The least depth, as a share of the thickness, at which a contact looked up again from
// where the first pushed to counts as a second face of a crease (hair_sim's `CREASE_DEPTH`).
const CREASE_DEPTH: f32 = 1e-3;

// Where a collider pushes a point (if `hit`), along which normal, and how deep the point
// was in the collider's shell; world space, or head-local where said.
struct Contact {
    hit: bool,
    position: vec3<f32>,
    normal: vec3<f32>,
    depth: f32,
}

// Where the shells of two contacts meet: on both offset planes, the nearest such point to
// the first, with the mean normal and the first depth; two faces nearly parallel meet
// nowhere near: the second contact (hair_sim's `between_shells`).
fn between_shells(first: Contact, second: Contact) -> Contact {
    let c = dot(first.normal, second.normal);
    let sine_squared = 1.0 - c * c;
    if !(sine_squared > 1e-4) {
        return Contact(true, second.position, second.normal, first.depth);
    }
    let beta = dot(second.position - first.position, second.normal) / sine_squared;
    let position = first.position + (second.normal - first.normal * c) * beta;
    return Contact(true, position, normalize_or(first.normal + second.normal, second.normal), first.depth);
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
