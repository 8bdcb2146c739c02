// --- Static friction for the spring model under a still head: hair_sim's `contact_hold` ---
//
// In a still step under the extra colliders and settings of the step before, a strand
// that the head touched in the step (a segment turn, or a contact in the last substep)
// and that it left with more energy than it started with is put back where it lay,
// motionless, with the spring model's memory started over there. The energy at the
// step's start is kept in the root's slot of the step-start plane, in w.

// Whether the step may hold the strand whose root is in slot `first` (hair_sim's
// `contact_hold::applies` and `lanes_under`): the spring model, collision with the head,
// a step that may keep strands asleep (still, under the settings of the step before), and
// a strand whose sleep watch runs (not started over at rest). Asked before `watch`.
fn contact_hold_applies(first: u32) -> bool {
    return step.spring_flags.x == 1u && step.flags.x == 1u && step.grid_dims.w == 1u && step.sleep.z == 1.0
        && watching(first);
}

// The strand's energy per unit mass in its motion and its springs' stretch (hair_sim's
// `contact_hold::motion_and_stretch`).
fn motion_and_stretch(first: u32, n: u32) -> f32 {
    let stiffness_per_mass = step.springs.x * step.springs.z;
    var energy = 0.0;
    for (var j = 1u; j < n; j++) {
        let i = particle_slot(first, j);
        let stretch = length(positions[i].xyz - positions[i - LANES].xyz) - rest_length(i);
        let v = velocity(i);
        energy = energy + 0.5 * (dot(v, v) + stiffness_per_mass * stretch * stretch);
    }
    return energy;
}

// The energy at the step's start, kept once `move_strand` has written the step-start plane.
fn keep_start_energy(first: u32, energy: f32) {
    motion[5u * slots() + first].w = energy;
}

// At the step's end (hair_sim's `contact_hold::hold_where_touches_gained`); `turned`:
// whether the segments' pass turned the strand.
fn hold_where_touches_gained(first: u32, n: u32, turned: bool) {
    let gravity = step.gravity_h.xyz;
    var touched = turned;
    var fall = 0.0;
    for (var j = 1u; j < n; j++) {
        let i = particle_slot(first, j);
        // `collide_particle`'s mark: the head or the skin touched it in the last substep.
        touched = touched || motion[3u * slots() + i].w == 1.0;
        fall = fall + dot(gravity, positions[i].xyz - step_start(i));
    }
    if !touched || !(motion_and_stretch(first, n) - fall > motion[5u * slots() + first].w) {
        return;
    }
    for (var j = 1u; j < n; j++) {
        let i = particle_slot(first, j);
        let x = step_start(i);
        positions[i] = vec4<f32>(x, 0.0);
        motion[i] = vec4<f32>(vec3<f32>(0.0), motion[i].w);
        springs[i] = vec4<f32>(x, springs[i].w);
        springs[slots() + i] = vec4<f32>(vec3<f32>(0.0), springs[slots() + i].w);
    }
}
