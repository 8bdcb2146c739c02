// --- The spring model: hair_sim's `implicit_springs`, one strand at a time ---

fn springs_previous_position(i: u32) -> vec3<f32> { return springs[i].xyz; }
fn springs_previous_velocity(i: u32) -> vec3<f32> { return springs[slots() + i].xyz; }
// In w: the particle's mobility in the substep's solve (hair_sim's `GroupState::mobility`).
fn springs_mobility(i: u32) -> f32 { return springs[slots() + i].w; }
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
    // The grid's push, in the step's first substep: a change of the velocity and of its
    // memory alike, so that BDF2 does not read it as a trend.
    let kick = step.volume.x == 1u && phase.x == 1u;
    for (var j = 1u; j < n; j++) {
        let i = particle_slot(first, j);
        let x = start(i);
        var v = velocity(i);
        var v_before = springs_previous_velocity(i);
        if kick {
            v += grid_kick(i);
            v_before += grid_kick(i);
        }
        let base = x * current - springs_previous_position(i) * previous;
        var new_v = (v * current - v_before * previous) * drag + acceleration(i, wind) * step_length;
        // The hair–hair grid's friction, implicit (`implicit_springs` on the CPU).
        var keep = 1.0;
        if step.volume.x == 1u {
            let friction = grid_friction(i);
            keep = 1.0 / (1.0 + step_length * friction.w);
            new_v = new_v * keep + friction.xyz * (1.0 - keep);
        }
        springs[i] = vec4<f32>(x, 0.0);
        springs[slots() + i] = vec4<f32>(v, keep);
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
            let x = positions[i].xyz + pull(i, j, n) * (displacement * springs_mobility(i));
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
        let v = clamp_length_max(velocity(i) + pull(i, j, n) * (step_length * w * springs_mobility(i)), step.limits.x);
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
        var own = springs_mobility(i);
        var lower = 0.0;
        if j > 1u {
            own += springs_mobility(i - LANES);
            lower = -dot(springs_direction(i), springs_direction(i - LANES)) * springs_mobility(i - LANES);
        }
        var upper = 0.0;
        if j + 1u < n {
            upper = -dot(springs_direction(i), springs_direction(i + LANES)) * springs_mobility(i);
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
