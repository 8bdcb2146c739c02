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
// substep, does not carry its code (llvmpipe runs through a branch no invocation takes,
// and a placing pass carrying it took more than twice as long).
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
        // Left where it is: the step's other passes pass it by, as one started over. It
        // keeps the still velocities it fell asleep with: the volume's feedback, which
        // reaches every particle before the step, is for the strands that step (on the
        // CPU it reaches only those).
        for (var j = 0u; j < n; j++) {
            motion[particle_slot(first, j)] = vec4<f32>(0.0);
        }
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
// in a still step each anchor follows its particle by dt / sleep_time of the way (where it
// has been on average), and the watch goes on while every particle is near its anchor and
// starts over where one is not; in any other step it starts over with the anchors where
// the particles are. A strand that falls asleep keeps no velocity.
fn watch(first: u32, n: u32) {
    if !(step.sleep.z == 1.0 && watching(first)) {
        for (var j = 0u; j < n; j++) {
            let i = particle_slot(first, j);
            motion[4u * slots() + i] = vec4<f32>(positions[i].xyz, 0.0);
        }
        motion[3u * slots() + first].w = 1.0;
        return;
    }
    let follow = step.sleep.w / max(step.sleep.y, step.sleep.w);
    let limit = step.sleep.x * step.sleep.x;
    var near = true;
    for (var j = 0u; j < n; j++) {
        let i = particle_slot(first, j);
        let x = positions[i].xyz;
        let a = anchor(i) + (x - anchor(i)) * follow;
        // The root's slot keeps the watch's time in w.
        motion[4u * slots() + i] = vec4<f32>(a, motion[4u * slots() + i].w);
        let d = x - a;
        near = near && dot(d, d) <= limit;
    }
    if near {
        motion[4u * slots() + first].w = quiet(first) + step.sleep.w;
        if asleep(first) {
            for (var j = 0u; j < n; j++) {
                motion[particle_slot(first, j)] = vec4<f32>(0.0);
            }
        }
    } else {
        motion[4u * slots() + first].w = 0.0;
    }
}

// A strand's substep ends: on the step's first, the grid's push leaves no speed of its
// own; on its last, the contact hold may undo the step, and a particle or velocity that is
// not finite starts the strand over at rest; what the substep did goes into the strand's
// report.
fn end_substep(strand: u32, first: u32, n: u32, k: u32) {
    if k == 1u && step.volume.y == 1u {
        take_back_grid_push(first, n);
    }
    if k == step.counts.z {
        if contact_hold_applies(first) {
            hold_where_touches_gained(first, n, tally.segment_turns > 0.0);
        }
        if !reset_if_not_finite(first, n, pose(k)) {
            watch(first, n);
        }
    }
    add_to_report(strand);
}

// Takes back from each velocity what it leaves along the grid's push beyond how fast the
// particle was leaving before, up to the push's size (hair_sim's `GridPush::taken_back`),
// and the same from the spring model's memory of it, which took the push with the
// velocity (hair_sim's `take_back_grid_push`).
fn take_back_grid_push(first: u32, n: u32) {
    for (var j = 1u; j < n; j++) {
        let i = particle_slot(first, j);
        // In units of the push's size squared, as on the CPU.
        let push = grid_kick(i);
        let size_squared = dot(push, push);
        if finite(vec3<f32>(size_squared)) && size_squared > 0.0 {
            let v = velocity(i);
            let gained = clamp(dot(v, push) - grid_leaving_before(i), 0.0, size_squared);
            let taken = push * (gained / size_squared);
            motion[i] = vec4<f32>(v - taken, motion[i].w);
            if step.spring_flags.x == 1u {
                let memory = springs[slots() + i];
                springs[slots() + i] = vec4<f32>(memory.xyz - taken, memory.w);
            }
        }
    }
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
