//! Simulation settings, and how bad values are caught and replaced.

#[cfg(target_arch = "x86_64")]
use super::lanes::{Avx2, Avx512};
use super::lanes::{Baseline, Wide};
use std::fmt;

#[cfg(feature = "reflect")]
use bevy_reflect::Reflect;

/// How segment length is kept.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "reflect", derive(Reflect))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum LengthMode {
    /// Follow-The-Leader (Müller et al. 2012): every segment keeps its rest length exactly;
    /// the velocity correction `ftl_damping`, applied as a brake, removes the energy FTL's
    /// one-sided projection would add, and leaves hair at rest without velocity.
    #[default]
    Inextensible,
    /// The reference mass-spring model: `F_s = k_s (l − l0)`, `F_d = k_d v` along each
    /// segment, plus a clamp that keeps every segment within `length_tolerance` of its
    /// rest length. Integrated implicitly (BDF2), so any stiffness is stable: a hanging
    /// strand stretches by its weight over `k_s`, and a spring swings with the period
    /// `2π √(m / k_s)` while a substep resolves it (within 2.3 % at 20 substeps per
    /// period); faster modes are damped rather than resolved. In a still step (the head,
    /// the wind, the skin and the extra colliders as they were), a strand that the head's
    /// touch would leave with more energy than it had stays where it lay, as static
    /// friction holds hair on an ear's rim: contacts do not keep it swinging.
    Springs,
}

/// How a particle that entered the head (or its thickness shell) is moved out.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "reflect", derive(Reflect))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum CollisionResponse {
    /// Out along the surface normal at the closest point: the shortest way out, which
    /// also leads out of an ear from behind it.
    #[default]
    SurfaceNormal,
    /// The reference's response: out along the ray from a centre inside the head through
    /// the particle. Simple, and right on a convex head; behind an ear or under the chin
    /// the ray leaves through the wrong part of the surface. It is the collision pass's
    /// push; the final length pass, which keeps particles out while it restores lengths,
    /// turns segments about the surface's tangent plane in either mode.
    CentreRay {
        /// The centre, head-local metres from the centre of the head mesh's bounding box.
        /// It must lie inside the head; outside, the push falls back to the normal.
        offset: [f32; 3],
    },
}

/// Wind: a steady direction and strength with gusts.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "reflect", derive(Reflect))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
// Fields a saved preset lacks take their defaults.
#[cfg_attr(feature = "serde", serde(default))]
pub struct Wind {
    /// Direction the air moves towards, world space (need not be unit length; zero means
    /// no wind). Plain arrays here keep the settings reflectable from any glam version.
    pub direction: [f32; 3],
    /// Acceleration, m/s², felt by a segment lying across the wind.
    pub strength: f32,
    /// Gust amplitude as a fraction of `strength` (0 = steady).
    pub gust_strength: f32,
    /// Gusts per second.
    pub gust_frequency: f32,
}

impl Default for Wind {
    fn default() -> Self {
        Wind { direction: [1.0, 0.0, 0.0], strength: 0.0, gust_strength: 0.5, gust_frequency: 0.7 }
    }
}

/// Hair–hair interaction on a grid ([`VolumeGrid`](super::VolumeGrid)): strands that meet
/// share their motion and push apart where the hair is denser than in its rest pose, so
/// a groom keeps its volume and locks swept through each other do not interpenetrate.
/// The grid's cells are about a centimetre on a head: it stops bulk interpenetration, not
/// single strands crossing. The GPU solver (`hair_gpu`) has the same grid, with the same
/// integer sums.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "reflect", derive(Reflect))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default))]
pub struct Volume {
    /// Whether the hair interacts with itself.
    pub enabled: bool,
    /// Cells along the longest side of the grid (4 to 64).
    pub resolution: u32,
    /// Share of the difference between a particle's velocity and the hair's mean velocity
    /// around it removed per 1/60 s, at the root, 0..1.
    pub friction_root: f32,
    /// The same at the tip; linear in between.
    pub friction_tip: f32,
    /// Acceleration, m/s², away from where the hair is denser than at rest, per cell of a
    /// density excess as large as the mean rest density. It only pushes out of a denser
    /// cell, never pulls hair into a sparser one.
    pub density_push: f32,
    /// Sweeps of the pressure solve (0: none, up to 64): each a red and a black
    /// Gauss–Seidel pass over the grid. The pressure pushes hair out of a cell holding more
    /// than it held at rest, half the mean rest density or one strand's worth, whichever is
    /// most (and 5 % more), about as fast as a step lets it, into the room of sparser cells
    /// around it, and never pulls hair together ("density less than", as Unity's strand
    /// hair): what keeps a pile of hair from packing tighter than the groom. Left between
    /// steps, so that a few sweeps a step converge over a few steps.
    pub pressure_iterations: u32,
    /// Share, 0..1, of the pressure's velocity change applied.
    pub pressure: f32,
}

/// The most sweeps of the pressure solve a step runs ([`Volume::pressure_iterations`]).
pub const MAX_PRESSURE_ITERATIONS: u32 = 64;

impl Default for Volume {
    fn default() -> Self {
        Volume {
            enabled: false,
            resolution: 32,
            friction_root: 0.05,
            friction_tip: 0.01,
            density_push: 2.0,
            pressure_iterations: 8,
            pressure: 1.0,
        }
    }
}

/// Which SIMD instructions the solver steps strands with. Every path gives the same
/// positions, bit for bit (IEEE rounding, no fused multiply-add); they differ in speed
/// only. Strands are stepped in groups of four vectors' worth of lanes, so a wider path
/// also steps more strands at once.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "reflect", derive(Reflect))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum SimdPath {
    /// The fastest path this CPU has, found at run time: AVX2 where there is AVX2, else
    /// the baseline. AVX-512 is not chosen: it measured no faster than AVX2 on the bench
    /// (`docs/benchmarks.md`), because a group of 64 strands keeps four 512-bit registers
    /// per component and spills.
    #[default]
    Auto,
    /// The portable path, 16 strands a group: SSE2 on x86-64, NEON on aarch64, scalar
    /// elsewhere.
    Baseline,
    /// AVX2 on x86-64, 32 strands a group.
    Avx2,
    /// AVX-512 (AVX-512F) on x86-64, 64 strands a group. In a build that does not
    /// optimise `hair_sim` (opt-level 0) its step needs 2–4 MiB of stack, more than a
    /// thread's default 2 MiB (the other paths need under 512 KiB; optimised, all need
    /// under 64 KiB): choose it only in optimised builds.
    Avx512,
}

impl SimdPath {
    /// Whether this CPU can run the path ([`SimdPath::Auto`] always can).
    pub fn is_available(self) -> bool {
        match self {
            SimdPath::Auto | SimdPath::Baseline => true,
            #[cfg(target_arch = "x86_64")]
            SimdPath::Avx2 => std::arch::is_x86_feature_detected!("avx2"),
            #[cfg(target_arch = "x86_64")]
            SimdPath::Avx512 => std::arch::is_x86_feature_detected!("avx512f"),
            #[cfg(not(target_arch = "x86_64"))]
            SimdPath::Avx2 | SimdPath::Avx512 => false,
        }
    }

    /// The path a step runs: this one if the CPU has it and it is not
    /// [`SimdPath::Auto`], else what `Auto` picks.
    pub fn resolved(self) -> SimdPath {
        if self != SimdPath::Auto && self.is_available() {
            return self;
        }
        if SimdPath::Avx2.is_available() { SimdPath::Avx2 } else { SimdPath::Baseline }
    }

    /// Strands the [resolved](Self::resolved) path steps side by side. Chunks of a
    /// multiple of this many strands (see [`Strands::chunks_mut`]) leave no lane idle.
    ///
    /// [`Strands::chunks_mut`]: super::Strands::chunks_mut
    pub fn strands_per_group(self) -> usize {
        match self.resolved() {
            #[cfg(target_arch = "x86_64")]
            SimdPath::Avx512 => Wide::<Avx512>::LANES,
            #[cfg(target_arch = "x86_64")]
            SimdPath::Avx2 => Wide::<Avx2>::LANES,
            _ => Wide::<Baseline>::LANES,
        }
    }
}

impl fmt::Display for SimdPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            SimdPath::Auto => "auto",
            SimdPath::Baseline => "baseline",
            SimdPath::Avx2 => "avx2",
            SimdPath::Avx512 => "avx512",
        })
    }
}

/// Every setting of the solver. Stiffnesses are "fraction of the error removed per 1/60 s":
/// they mean the same whatever the timestep, substep or iteration count.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "reflect", derive(Reflect))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
// Fields a saved preset lacks take their defaults.
#[cfg_attr(feature = "serde", serde(default))]
pub struct SimParams {
    /// Acceleration of gravity, world space, m/s².
    pub gravity: [f32; 3],
    /// Substeps per 1/60 s of hair time: a step is cut into substeps no longer than
    /// `1 / (60 · substeps)` s (at least one), so a hair clock at 30 Hz takes twice as many
    /// per step as one at 60 Hz, and the hair comes to rest alike at any rate. Roots follow
    /// the head's interpolated pose across them.
    pub substeps: u32,
    /// Constraint iterations per substep.
    pub iterations: u32,
    /// Air drag, 1/s: velocity decays as `exp(−drag·t)`. It acts on motion only: where
    /// hair hangs at rest does not depend on it.
    pub drag: f32,
    /// Inextensible (default) or the reference's mass-spring model.
    pub length_mode: LengthMode,
    /// Mass of one particle, kg (spring model).
    pub particle_mass: f32,
    /// Spring stiffness `k_s`, N/m (spring model), 0 to 10⁷; stable at any value.
    pub spring_stiffness: f32,
    /// Spring damping `k_d`, N·s/m, on the segment's relative velocity (spring model).
    pub spring_damping: f32,
    /// Allowed stretch or shrink of a segment as a fraction of rest length (spring model).
    pub length_tolerance: f32,
    /// Müller's FTL velocity correction, 0..1 (inextensible model): how much of the
    /// reaction of its child's correction slows a particle. It only ever slows (a brake
    /// along the particle's own motion), so it never stores a velocity in hair at rest.
    pub ftl_damping: f32,
    /// Local shape stiffness, 0..1: each joint toward its rest bend, the segment turned toward
    /// its rest direction in its parent's frame and the parent turned back by the reaction.
    pub local_stiffness: f32,
    /// Global shape stiffness at the root, 0..1: toward the rest pose carried by the head.
    pub global_stiffness_root: f32,
    /// Global shape stiffness at the tip; linear in between.
    pub global_stiffness_tip: f32,
    /// Wind.
    pub wind: Wind,
    /// Collide with the head and the extra colliders.
    pub collision: bool,
    /// Distance, m, kept between particles and collider surfaces.
    pub collision_thickness: f32,
    /// Which way a particle is pushed out of the head.
    pub collision_response: CollisionResponse,
    /// Keep whole segments out of the head, not only particles: a segment whose two ends
    /// are outside can still cut through a thin part between them (an ear's rim). On (the
    /// default), at the end of each step every segment that may reach the head (see
    /// [`HeadCollider::rise_under`]) is tested exactly (a ray along it through the
    /// collider's BVH) and turned out where it crosses. That costs about a fifth of a step
    /// (`docs/benchmarks.md`); off saves it where no segment can cut through anything (a
    /// head without ears, hair that cannot reach them).
    ///
    /// [`HeadCollider::rise_under`]: crate::collide::HeadCollider::rise_under
    pub segment_collision: bool,
    /// Fraction, 0..1, of tangential sliding removed on contact.
    pub friction: f32,
    /// Speed limit, m/s, per particle (the per-step displacement clamp).
    pub max_speed: f32,
    /// A strand whose every particle stays within this distance, m, of where it has been on
    /// average (over about [`Self::sleep_time`]) for [`Self::sleep_time`] under a still
    /// head sleeps: it is no longer stepped, and holds
    /// its place exactly, until the head moves, the wind blows, the skin moves or a setting
    /// changes ([`Stillness`]). 0 never sleeps: for measuring where hair comes to rest
    /// more finely than this distance.
    ///
    /// The default is as wide as the default collision shell: a strand pressed into a
    /// crease or draped over an ear's rim can step between places a millimetre or two apart
    /// without ever settling, and a narrower distance left it buzzing there for good.
    /// Measured from the average, a cycle up to twice this distance across sleeps.
    ///
    /// [`Stillness`]: super::Stillness
    pub sleep_distance: f32,
    /// Seconds a strand must stay within [`Self::sleep_distance`] to fall asleep.
    pub sleep_time: f32,
    /// A root moving further than this in one step, m, resets its strand to the rest pose.
    pub teleport_distance: f32,
    /// The SIMD instructions to step with; the same results on every path. A path this
    /// CPU lacks runs as [`SimdPath::Auto`].
    pub simd: SimdPath,
    /// Hair–hair interaction on a grid (off by default).
    pub volume: Volume,
}

impl Default for SimParams {
    fn default() -> Self {
        SimParams {
            gravity: [0.0, -9.81, 0.0],
            substeps: 2,
            iterations: 1,
            drag: 1.0,
            length_mode: LengthMode::Inextensible,
            particle_mass: 1e-3,
            spring_stiffness: 20.0,
            spring_damping: 0.02,
            length_tolerance: 0.1,
            ftl_damping: 0.9,
            local_stiffness: 0.3,
            global_stiffness_root: 0.2,
            global_stiffness_tip: 0.0,
            wind: Wind::default(),
            collision: true,
            collision_thickness: 0.003,
            collision_response: CollisionResponse::SurfaceNormal,
            segment_collision: true,
            friction: 0.3,
            max_speed: 15.0,
            sleep_distance: 3e-3,
            sleep_time: 0.5,
            teleport_distance: 0.5,
            simd: SimdPath::Auto,
            volume: Volume::default(),
        }
    }
}

/// A setting that was NaN, infinite or out of range, and what was used instead.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamIssue {
    /// The field, e.g. `"wind.strength"`.
    pub field: &'static str,
    /// The value given.
    pub given: f32,
    /// The value used.
    pub used: f32,
}

impl fmt::Display for ParamIssue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} = {} is not usable; using {}", self.field, self.given, self.used)
    }
}

impl SimParams {
    /// The reference's simulation as written: mass springs (`k_s` = 20 N/m, `k_d` =
    /// 0.02 N·s/m on particles of 1 g) with the ±10 % length constraint, no shape keeping,
    /// and penetrating particles pushed out along the ray from the head's centre.
    pub fn reference() -> Self {
        SimParams {
            length_mode: LengthMode::Springs,
            spring_stiffness: 20.0,
            spring_damping: 0.02,
            particle_mass: 1e-3,
            length_tolerance: 0.1,
            local_stiffness: 0.0,
            global_stiffness_root: 0.0,
            global_stiffness_tip: 0.0,
            collision_response: CollisionResponse::CentreRay { offset: [0.0; 3] },
            ..SimParams::default()
        }
    }

    /// Returns settings the solver can always run with, and the list of fields that had to
    /// change: NaN or infinite values take the default, others are clamped to their range.
    pub fn sanitized(&self) -> (SimParams, Vec<ParamIssue>) {
        let defaults = SimParams::default();
        let mut p = *self;
        let mut issues = Vec::new();
        let mut fix = |field: &'static str, value: &mut f32, default: f32, min: f32, max: f32| {
            let used = if value.is_finite() { value.clamp(min, max) } else { default };
            if used != *value {
                issues.push(ParamIssue { field, given: *value, used });
                *value = used;
            }
        };
        fix("drag", &mut p.drag, defaults.drag, 0.0, 1e3);
        fix("particle_mass", &mut p.particle_mass, defaults.particle_mass, 1e-7, 1e3);
        fix("spring_stiffness", &mut p.spring_stiffness, defaults.spring_stiffness, 0.0, 1e7);
        fix("spring_damping", &mut p.spring_damping, defaults.spring_damping, 0.0, 1e5);
        fix("length_tolerance", &mut p.length_tolerance, defaults.length_tolerance, 0.0, 0.9);
        fix("ftl_damping", &mut p.ftl_damping, defaults.ftl_damping, 0.0, 1.0);
        fix("local_stiffness", &mut p.local_stiffness, defaults.local_stiffness, 0.0, 1.0);
        fix("global_stiffness_root", &mut p.global_stiffness_root, defaults.global_stiffness_root, 0.0, 1.0);
        fix("global_stiffness_tip", &mut p.global_stiffness_tip, defaults.global_stiffness_tip, 0.0, 1.0);
        fix("wind.strength", &mut p.wind.strength, defaults.wind.strength, -1e3, 1e3);
        fix("wind.gust_strength", &mut p.wind.gust_strength, defaults.wind.gust_strength, 0.0, 10.0);
        fix("wind.gust_frequency", &mut p.wind.gust_frequency, defaults.wind.gust_frequency, 0.0, 100.0);
        fix("collision_thickness", &mut p.collision_thickness, defaults.collision_thickness, 0.0, 0.1);
        fix("friction", &mut p.friction, defaults.friction, 0.0, 1.0);
        fix("max_speed", &mut p.max_speed, defaults.max_speed, 1e-3, 1e3);
        fix("sleep_distance", &mut p.sleep_distance, defaults.sleep_distance, 0.0, 1.0);
        fix("sleep_time", &mut p.sleep_time, defaults.sleep_time, 0.0, 1e3);
        fix("teleport_distance", &mut p.teleport_distance, defaults.teleport_distance, 1e-3, 1e4);
        let volume = defaults.volume;
        fix("volume.friction_root", &mut p.volume.friction_root, volume.friction_root, 0.0, 1.0);
        fix("volume.friction_tip", &mut p.volume.friction_tip, volume.friction_tip, 0.0, 1.0);
        fix("volume.density_push", &mut p.volume.density_push, volume.density_push, 0.0, 1e3);
        fix("volume.pressure", &mut p.volume.pressure, volume.pressure, 0.0, 1.0);
        if let CollisionResponse::CentreRay { offset: [x, y, z] } = &mut p.collision_response {
            for (field, v) in [
                ("collision_response.offset.x", x),
                ("collision_response.offset.y", y),
                ("collision_response.offset.z", z),
            ] {
                fix(field, v, 0.0, -1e3, 1e3);
            }
        }
        let [gx, gy, gz] = &mut p.gravity;
        let [wx, wy, wz] = &mut p.wind.direction;
        let [dgx, dgy, dgz] = defaults.gravity;
        for (field, v, d) in [
            ("gravity.x", gx, dgx),
            ("gravity.y", gy, dgy),
            ("gravity.z", gz, dgz),
            ("wind.direction.x", wx, 0.0),
            ("wind.direction.y", wy, 0.0),
            ("wind.direction.z", wz, 0.0),
        ] {
            fix(field, v, d, -1e3, 1e3);
        }
        let mut fix_count = |field: &'static str, value: &mut u32, max: u32| {
            let used = (*value).clamp(1, max);
            if used != *value {
                issues.push(ParamIssue { field, given: *value as f32, used: used as f32 });
                *value = used;
            }
        };
        fix_count("substeps", &mut p.substeps, 64);
        fix_count("iterations", &mut p.iterations, 32);
        let resolution = p.volume.resolution.clamp(4, 64);
        if resolution != p.volume.resolution {
            issues.push(ParamIssue {
                field: "volume.resolution",
                given: p.volume.resolution as f32,
                used: resolution as f32,
            });
            p.volume.resolution = resolution;
        }
        if p.volume.pressure_iterations > MAX_PRESSURE_ITERATIONS {
            issues.push(ParamIssue {
                field: "volume.pressure_iterations",
                given: p.volume.pressure_iterations as f32,
                used: MAX_PRESSURE_ITERATIONS as f32,
            });
            p.volume.pressure_iterations = MAX_PRESSURE_ITERATIONS;
        }
        (p, issues)
    }
}

/// Turns a "fraction of the error removed per 1/60 s" stiffness into the fraction to remove
/// per application, when it is applied `applications_per_second` times a second. The
/// error then decays by the same factor each second, whatever the step and iteration count.
#[inline]
pub fn stiffness_per_application(stiffness: f32, applications_per_second: f32) -> f32 {
    if stiffness >= 1.0 {
        return 1.0;
    }
    1.0 - (1.0 - stiffness).powf(60.0 / applications_per_second)
}

#[cfg(test)]
mod tests;
