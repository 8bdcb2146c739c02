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
    // The spring model's hold where the head touches it compares with the step's start
    // (`contact_hold.wgsl`).
    let hold = k == 1u && contact_hold_applies(first);
    var start_energy = 0.0;
    if hold {
        start_energy = motion_and_stretch(first, n);
    }
    for (var j = 0u; j < n; j++) {
        let i = particle_slot(first, j);
        let x = positions[i].xyz;
        motion[slots() + i] = vec4<f32>(x, 0.0);
        motion[2u * slots() + i] = vec4<f32>(0.0);
        if k == 1u {
            motion[5u * slots() + i] = vec4<f32>(x, 0.0);
        }
        if integrate && j > 0u {
            let v = velocity(i) * step.motion.x + acceleration(i, wind) * h;
            positions[i] = vec4<f32>(x + clamp_length_max(v * h, step.motion.y), 0.0);
        }
    }
    if hold {
        keep_start_energy(first, start_energy);
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
        // In a crease the push out of one face can leave the particle within the shell of
        // the other: the contact is looked up again from where it pushed to, and where it
        // is still that deep the particle goes where the two shells meet (hair_sim's
        // `crease_contact`). Then friction slides back along the tangent plane, which in a
        // hollow dips under the surface: out again from there (one more query), unless the
        // slide is too short to reach the surface (a quarter of the shell, as on the CPU).
        // One query in one loop for all of them: every call is inlined.
        let thickness = step.limits.y;
        var query = local_point(now, x);
        var settled: Contact;
        var sliding = false;
        for (var q = 0u; q < 3u; q++) {
            let contact = head_contact(query);
            if sliding {
                if contact.hit {
                    x = world_point(now, contact.position);
                }
                break;
            }
            if !settled.hit {
                if !contact.hit {
                    break;
                }
                settled = contact;
                query = contact.position;
                continue;
            }
            if contact.hit && contact.depth > CREASE_DEPTH * thickness {
                settled = between_shells(settled, contact);
            }
            touch(settled.depth);
            let held = with_friction(settled.position, settled.normal, local_point(before, start(i)));
            x = world_point(now, held);
            if !(length(held - settled.position) > 0.25 * thickness) {
                break;
            }
            query = held;
            sliding = true;
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
    let stored = clamp_length_max(v, step.limits.x);
    motion[i] = vec4<f32>(stored, 0.0);
    if step.flags.x == 1u && step.spring_flags.x == 1u {
        restart_memory_if_shoved(i, x, stored);
    }
}

// Where collision shoved particle `i` to `x`, the spring model's memory of it starts over
// there, with velocity `v`, in part below FORGETTING_SHOVE (hair_sim's
// `restart_memory_if_shoved`): BDF2 would bring a remembered shove back as speed.
fn restart_memory_if_shoved(i: u32, x: vec3<f32>, v: vec3<f32>) {
    let restart = min(length(x - shaped(i)) * (1.0 / FORGETTING_SHOVE), 1.0);
    springs[i] = vec4<f32>(springs_previous_position(i) + (x - springs_previous_position(i)) * restart, 0.0);
    springs[slots() + i] = vec4<f32>(springs_previous_velocity(i) + (v - springs_previous_velocity(i)) * restart, 0.0);
}

// The shove, m, from which `restart_memory_if_shoved` forgets the substep before entirely.
const FORGETTING_SHOVE: f32 = 1e-6;

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
