//! Levels of detail: a groom far from every camera simulates a fraction of its guides and
//! carries the rest along with them ([`Strands::set_detail_level`]).

use crate::clock::{Hair, HairTime};
use crate::convert::from_sim;
use crate::description::{HairError, HairErrorKind};
use crate::simulation::HairState;
use bevy::camera::{Camera, Projection};
use bevy::prelude::*;
use hair_sim::solver::{FULL_DETAIL_HEIGHT, MAX_DETAIL_LEVEL, level_with_hysteresis};

/// Levels of detail for the groom on this head entity: put it next to the
/// [`HairGroom`](crate::HairGroom). Without it every guide is simulated.
///
/// By default the level follows the head's height on screen in the active camera that
/// shows it largest: every guide at [`full_detail_height`](Self::full_detail_height)
/// pixels and taller, half as many per halving of the head's area on screen, down to
/// 1/128. The guides left out follow their three nearest simulated neighbours, as drawn
/// children follow their guide (so, like children, they are not collided on their own);
/// strands fade out of and rise into the simulation over
/// [`fade_seconds`](Self::fade_seconds), without a pop.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// # fn spawn(mut commands: Commands, head: Handle<Mesh>) {
/// commands.spawn((Mesh3d(head), HairGroom::default(), HairLod::default()));
/// # }
/// ```
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Component, Default)]
pub struct HairLod {
    /// A head drawn this many pixels tall or taller simulates every guide (360 by
    /// default: a head filling a third of a 1080-pixel-high view).
    pub full_detail_height: f32,
    /// How far past a level's boundary the head's height must go before the level
    /// changes, as a fraction of the height (0.1): a head hovering at a boundary does not
    /// switch back and forth.
    pub hysteresis: f32,
    /// A level to hold whatever the cameras see: 0 simulates every guide, level `L`
    /// simulates `⌈guides / 2^L⌉` (at most 7). `None` (the default) chooses by size.
    pub fixed_level: Option<u32>,
    /// Seconds a strand takes to fade out of, or rise into, the simulation (0.5).
    pub fade_seconds: f32,
}

impl Default for HairLod {
    fn default() -> Self {
        HairLod { full_detail_height: FULL_DETAIL_HEIGHT, hysteresis: 0.1, fixed_level: None, fade_seconds: 0.5 }
    }
}

impl HairLod {
    /// Always level `level` (0: every guide).
    pub fn fixed(level: u32) -> Self {
        HairLod { fixed_level: Some(level), ..default() }
    }

    /// Its fields as the solver can use them, and what had to be replaced, in words.
    fn sanitized(&self) -> (HairLod, Vec<String>) {
        let defaults = HairLod::default();
        let mut issues = Vec::new();
        let mut usable = |name: &str, value: f32, fallback: f32, zero_ok: bool| {
            let fine = value.is_finite() && (value > 0.0 || zero_ok && value == 0.0);
            if !fine {
                issues.push(format!("HairLod::{name} is {value}, using {fallback}"));
            }
            if fine { value } else { fallback }
        };
        let lod = HairLod {
            full_detail_height: usable(
                "full_detail_height",
                self.full_detail_height,
                defaults.full_detail_height,
                false,
            ),
            hysteresis: usable("hysteresis", self.hysteresis, defaults.hysteresis, true),
            fade_seconds: usable("fade_seconds", self.fade_seconds, defaults.fade_seconds, true),
            fixed_level: self.fixed_level,
        };
        if let Some(level) = self.fixed_level.filter(|&l| l > MAX_DETAIL_LEVEL) {
            issues.push(format!("HairLod::fixed_level is {level}, using the deepest, {MAX_DETAIL_LEVEL}"));
        }
        (lod, issues)
    }
}

/// The height of a viewport whose size is not known (a camera before its first frame, or
/// in an app that does not render), pixels.
pub(crate) const UNKNOWN_VIEWPORT_HEIGHT: f32 = 1080.0;

/// How many pixels tall something `size` metres across at `centre` is drawn by a camera,
/// if the camera draws it (in front of it).
fn height_on_screen(size: f32, centre: Vec3, camera: &Camera, projection: &Projection, at: &GlobalTransform) -> f32 {
    let viewport = camera.logical_viewport_size().map_or(UNKNOWN_VIEWPORT_HEIGHT, |s| s.y);
    let depth = (centre - at.translation()).dot(*at.forward());
    if depth <= 0.0 && matches!(projection, Projection::Perspective(_)) {
        return 0.0;
    }
    size * pixels_per_metre(depth, viewport, projection)
}

/// How many pixels one metre across (facing the camera) spans at view depth `depth` (in
/// front of a perspective camera), in a viewport `viewport` pixels tall. Infinite for a
/// projection of the user's own: as near as can be.
pub(crate) fn pixels_per_metre(depth: f32, viewport: f32, projection: &Projection) -> f32 {
    match projection {
        Projection::Perspective(perspective) => viewport / (2.0 * depth * (perspective.fov * 0.5).tan()),
        Projection::Orthographic(orthographic) => viewport / orthographic.area.height(),
        Projection::Custom(_) => f32::INFINITY,
    }
}

/// Before the hair steps of a frame: each groom with a [`HairLod`] goes to the level its
/// size on screen (or its fixed level) asks for. With no active camera the level stays.
pub(crate) fn choose_detail_levels(
    mut grooms: Query<(Entity, &mut HairState, &HairLod)>,
    cameras: Query<(&Camera, &Projection, &GlobalTransform)>,
    clock: Res<Time<Hair>>,
    mut errors: MessageWriter<HairError>,
) {
    for (entity, mut state, lod) in &mut grooms {
        let (lod, issues) = lod.sanitized();
        let issue = (!issues.is_empty()).then(|| issues.join("; "));
        if issue != state.detail_issue {
            if let Some(message) = &issue {
                let kind = HairErrorKind::Detail(message.clone());
                warn!("hair on {entity}: {kind}");
                errors.write(HairError { entity, kind });
            }
            state.detail_issue = issue;
        }
        let current = state.strands().detail_level();
        let level = match lod.fixed_level {
            Some(level) => level.min(MAX_DETAIL_LEVEL),
            None => {
                let (size, centre) = (state.head_size(), from_sim(state.origin()));
                let tallest = cameras
                    .iter()
                    .filter(|(camera, ..)| camera.is_active)
                    .map(|(camera, projection, at)| height_on_screen(size, centre, camera, projection, at))
                    .reduce(f32::max);
                let Some(height) = tallest else { continue };
                level_with_hysteresis(height, lod.full_detail_height, current, lod.hysteresis)
            }
        };
        if level != current {
            let steps = (lod.fade_seconds / clock.timestep().as_secs_f32()).round() as u32;
            state.set_detail_level(level, steps);
        }
    }
}
