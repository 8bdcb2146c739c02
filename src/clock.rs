//! The hair clock: hair steps at a timestep of its own, after the frame's animation and
//! transform propagation, so every step sees the head where it really was.
//!
//! Each frame the clock takes the frame's virtual time (`Time<Virtual>`, times
//! [`HairTime::relative_speed`]) and runs [`HairSchedule`] once for every whole timestep
//! that fits, leaving the remainder as overstep. Within those steps the head pose is
//! interpolated between the poses of the last two frames, so each step moves the roots by
//! the head's motion over that step's own interval, whatever the frame rate. Drawing then
//! places the strands, interpolated between the last two steps in head space, on the head
//! as posed this frame: the roots sit on the drawn scalp in every frame.
//!
//! The app's `Time<Fixed>` is left as the app set it.

use bevy::ecs::schedule::ScheduleLabel;
use bevy::prelude::*;
use std::time::Duration;

/// The hair clock's context: `Time<Hair>` is a resource the plugin inserts. Read and
/// change it through [`HairTime`]. While [`HairSchedule`] runs, the generic `Time` is the
/// hair clock, as `Time` is `Time<Fixed>` inside `FixedMain`.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// // Slow motion for the hair alone.
/// fn slow_hair(mut clock: ResMut<Time<Hair>>) {
///     clock.set_relative_speed(0.25);
/// }
/// ```
#[derive(Debug, Clone, Copy, Reflect)]
pub struct Hair {
    timestep: Duration,
    overstep: Duration,
    paused: bool,
    relative_speed: f64,
}

impl Hair {
    /// The default hair step: 60 Hz.
    pub const DEFAULT_TIMESTEP: Duration = Duration::from_nanos(16_666_667);

    /// The shortest hair step: 1 ms (1,000 steps per second). Shorter ones would run
    /// hundreds of steps a frame for no visible gain.
    pub const MIN_TIMESTEP: Duration = Duration::from_millis(1);

    /// The step of `hz` steps per second, if that is a positive finite rate of at most
    /// 1,000 ([`Self::MIN_TIMESTEP`]).
    pub fn timestep_of_hz(hz: f64) -> Option<Duration> {
        Duration::try_from_secs_f64(1.0 / hz).ok().filter(|step| hz > 0.0 && *step >= Self::MIN_TIMESTEP)
    }
}

impl Default for Hair {
    fn default() -> Self {
        Hair { timestep: Self::DEFAULT_TIMESTEP, overstep: Duration::ZERO, paused: false, relative_speed: 1.0 }
    }
}

/// Reading and steering the hair clock, `Time<Hair>`.
/// See [`Hair`]'s example.
pub trait HairTime {
    /// The length of one hair step.
    fn timestep(&self) -> Duration;
    /// Sets the length of one hair step. A step shorter than [`Hair::MIN_TIMESTEP`] is
    /// refused with a warning (the step stays).
    fn set_timestep(&mut self, timestep: Duration);
    /// Sets the step rate in steps per second. A rate that is not a positive finite number,
    /// or above 1,000, is refused with a warning.
    fn set_timestep_hz(&mut self, hz: f64);
    /// Time accumulated toward the next step.
    fn overstep(&self) -> Duration;
    /// [`Self::overstep`] as a fraction of the timestep, 0..1: how far drawing is between
    /// the last two steps.
    fn overstep_fraction(&self) -> f32;
    /// The hair clock's present: the last step's time plus the overstep.
    fn now(&self) -> Duration;
    /// Stops stepping: the hair keeps its shape and moves rigidly with the head. On
    /// [`Self::unpause`] the head's motion during the pause reaches the roots in one step
    /// (a large one resets the strands as a teleport).
    fn pause(&mut self);
    /// Steps again.
    fn unpause(&mut self);
    /// Whether the clock is paused.
    fn is_paused(&self) -> bool;
    /// How fast hair time runs against the app's virtual time (1: as fast).
    fn relative_speed(&self) -> f64;
    /// Sets [`Self::relative_speed`]. A speed that is not a finite number ≥ 0 is refused
    /// with a warning.
    fn set_relative_speed(&mut self, speed: f64);
}

impl HairTime for Time<Hair> {
    fn timestep(&self) -> Duration {
        self.context().timestep
    }

    fn set_timestep(&mut self, timestep: Duration) {
        if timestep < Hair::MIN_TIMESTEP {
            warn!(
                "hair clock: a timestep of {timestep:?} was refused (at least {:?}); it stays {:?}",
                Hair::MIN_TIMESTEP,
                self.timestep()
            );
            return;
        }
        self.context_mut().timestep = timestep;
    }

    fn set_timestep_hz(&mut self, hz: f64) {
        match Hair::timestep_of_hz(hz) {
            Some(step) => self.set_timestep(step),
            None => warn!("hair clock: a rate of {hz} Hz was refused; the step stays {:?}", self.timestep()),
        }
    }

    fn overstep(&self) -> Duration {
        self.context().overstep
    }

    fn overstep_fraction(&self) -> f32 {
        (self.overstep().as_secs_f64() / self.timestep().as_secs_f64()).clamp(0.0, 1.0) as f32
    }

    fn now(&self) -> Duration {
        self.elapsed() + self.overstep()
    }

    fn pause(&mut self) {
        self.context_mut().paused = true;
    }

    fn unpause(&mut self) {
        self.context_mut().paused = false;
    }

    fn is_paused(&self) -> bool {
        self.context().paused
    }

    fn relative_speed(&self) -> f64 {
        self.context().relative_speed
    }

    fn set_relative_speed(&mut self, speed: f64) {
        if speed.is_finite() && speed >= 0.0 {
            self.context_mut().relative_speed = speed;
        } else {
            warn!("hair clock: a relative speed of {speed} was refused; it stays {}", self.relative_speed());
        }
    }
}

/// The schedule of one hair step, run by the hair clock zero or more times a frame (in
/// `PostUpdate`, [`HairSystems::Step`](crate::HairSystems::Step)). It holds
/// [`HairSystems::SyncRoots`](crate::HairSystems::SyncRoots),
/// [`Simulate`](crate::HairSystems::Simulate) and
/// [`Writeback`](crate::HairSystems::Writeback); add systems here to see every step.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// # fn every_step() {}
/// # let mut app = App::new();
/// # app.init_schedule(HairSchedule);
/// app.add_systems(HairSchedule, every_step.after(HairSystems::Writeback));
/// ```
#[derive(ScheduleLabel, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct HairSchedule;

/// Adds this frame's virtual time to the hair clock's overstep.
pub(crate) fn advance_clock(virtual_time: Res<Time<Virtual>>, mut hair: ResMut<Time<Hair>>) {
    if hair.is_paused() {
        return;
    }
    let delta = virtual_time.delta().mul_f64(hair.relative_speed());
    hair.context_mut().overstep += delta;
}

/// Runs [`HairSchedule`] once per whole timestep in the overstep; the generic `Time` is the
/// hair clock meanwhile.
pub(crate) fn run_hair_schedule(world: &mut World) {
    let _ = world.try_schedule_scope(HairSchedule, |world, schedule| {
        loop {
            let mut hair = world.resource_mut::<Time<Hair>>();
            let step = hair.timestep();
            if hair.overstep() < step {
                break;
            }
            hair.context_mut().overstep -= step;
            hair.advance_by(step);
            let generic = hair.as_generic();
            *world.resource_mut::<Time>() = generic;
            schedule.run(world);
        }
    });
    *world.resource_mut::<Time>() = world.resource::<Time<Virtual>>().as_generic();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_rates_are_refused() {
        let mut time = Time::<Hair>::default();
        time.set_timestep_hz(f64::NAN);
        time.set_timestep_hz(-30.0);
        time.set_timestep_hz(0.0);
        time.set_timestep(Duration::ZERO);
        time.set_timestep(Duration::from_micros(999));
        time.set_timestep_hz(1e6);
        assert_eq!(time.timestep(), Hair::DEFAULT_TIMESTEP);
        time.set_timestep_hz(120.0);
        assert_eq!(time.timestep(), Duration::from_secs_f64(1.0 / 120.0));
        time.set_relative_speed(f64::INFINITY);
        time.set_relative_speed(-1.0);
        assert_eq!(time.relative_speed(), 1.0);
        time.set_relative_speed(0.5);
        assert_eq!(time.relative_speed(), 0.5);
    }

    #[test]
    fn steps_as_many_timesteps_as_fit() {
        #[derive(Resource, Default)]
        struct Steps(Vec<Duration>);
        let mut world = World::new();
        let mut clock = Time::<Hair>::default();
        clock.set_timestep(Duration::from_millis(10));
        world.insert_resource(clock);
        world.insert_resource(Time::<Virtual>::default());
        world.insert_resource(Time::<()>::default());
        world.init_resource::<Steps>();
        let mut schedule = Schedule::new(HairSchedule);
        schedule.add_systems(|time: Res<Time>, mut steps: ResMut<Steps>| steps.0.push(time.elapsed()));
        world.add_schedule(schedule);
        for frame_ms in [25, 5, 0, 31] {
            world.resource_mut::<Time<Virtual>>().advance_by(Duration::from_millis(frame_ms));
            world.run_system_cached(advance_clock).unwrap();
            run_hair_schedule(&mut world);
        }
        let steps: Vec<u64> = world.resource::<Steps>().0.iter().map(|d| d.as_millis() as u64).collect();
        // 25 ms → two steps (5 over), 5 ms → one more, 0 → none, 31 ms → three (1 over).
        assert_eq!(steps, [10, 20, 30, 40, 50, 60]);
        assert_eq!(world.resource::<Time<Hair>>().overstep(), Duration::from_millis(1));
        assert_eq!(world.resource::<Time>().elapsed(), world.resource::<Time<Virtual>>().elapsed());
    }
}
