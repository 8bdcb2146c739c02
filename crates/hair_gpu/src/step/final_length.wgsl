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
// outside and reached without passing through the head, else the nearest outside at all,
// else the same over the sphere; failing that, onto the surface, stretching the segment.
// hair_sim's `outside_at_length`.
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
    // out of (w: the direction's rank; -2: none). Where none of those is out (that half of
    // space is all inside: the contact is on the far side of a cheek), the same over the
    // sphere (hair_sim's `sphere_nearest`).
    var reached = vec4<f32>(0.0, 0.0, 0.0, -2.0);
    var out_of_it = reached;
    for (var k = 0u; k <= TILTED + SPHERE_DIRECTIONS; k++) {
        let on_sphere = k > TILTED;
        if on_sphere && out_of_it.w > -2.0 {
            break;
        }
        var d = deep.normal;
        if on_sphere {
            d = sphere_direction(k - 1u - TILTED);
        } else if k > 0u {
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
        let lowest = min(sure_clearance(local_parent), sure_clearance(local_child));
        if lowest > rise_under(0.5 * (local_parent + local_child), span) {
            continue;
        }
        var local_turned = turn_out_of(local_parent, local_child, span);
        if all(local_turned == local_child) {
            continue;
        }
        if step.spring_flags.w == 1u {
            local_turned = rest_on_rim(i, local_parent, local_turned, span);
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
