//! Named hairstyles: a groom, simulation settings and a look that go together.
//!
//! Guide counts stay moderate (≤ 2,000 guides, ≤ 16 children each) so that the demo keeps
//! an interactive frame rate even on a software renderer.

use bevy::prelude::*;
use bevy_hair::prelude::*;

/// Combing toward the back of the head (it faces +Z): the front hairline grows up and
/// over the crown instead of falling into the face.
const SWEPT_BACK: Vec3 = Vec3::new(0.0, 0.0, -1.5);

/// One hairstyle.
pub struct Preset {
    pub name: &'static str,
    pub groom: HairGroom,
    pub params: SimParams,
    pub look: HairLook,
}

/// Every preset, in the order the panel shows them; the first is the one the demo starts with.
pub fn all() -> [Preset; 6] {
    [shoulder(), short(), long(), curly(), windy(), reference()]
}

/// The preset called `name`, or the starting one ([`shoulder`]) if none is.
pub fn named(name: &str) -> Preset {
    all().into_iter().find(|p| p.name.eq_ignore_ascii_case(name)).unwrap_or_else(shoulder)
}

/// The starting style: shoulder length, straight, dark brown.
pub fn shoulder() -> Preset {
    Preset {
        name: "Shoulder",
        groom: HairGroom {
            guides: 1200,
            segments: 10,
            length: 0.22,
            comb: SWEPT_BACK,
            children: ChildParams { per_guide: 12, ..default() },
            ..default()
        },
        params: SimParams::default(),
        look: HairLook::default(),
    }
}

fn short() -> Preset {
    Preset {
        name: "Short",
        groom: HairGroom {
            guides: 2000,
            segments: 6,
            length: 0.07,
            length_variation: 0.15,
            comb: SWEPT_BACK,
            children: ChildParams { per_guide: 8, clumping: 0.1, tip_spread: 0.001, ..default() },
            ..default()
        },
        // Short hair holds its shape: stiff toward the groomed pose.
        params: SimParams { local_stiffness: 0.7, global_stiffness_root: 0.6, global_stiffness_tip: 0.3, ..default() },
        look: HairLook {
            root_color: Color::srgb(0.03, 0.025, 0.02),
            tip_color: Color::srgb(0.12, 0.09, 0.07),
            ..default()
        },
    }
}

fn long() -> Preset {
    Preset {
        name: "Long",
        groom: HairGroom {
            guides: 1200,
            segments: 16,
            length: 0.42,
            length_variation: 0.15,
            comb: SWEPT_BACK,
            children: ChildParams { per_guide: 12, clumping: 0.45, tip_spread: 0.004, ..default() },
            ..default()
        },
        // Long strands are soft; one more substep keeps fast shakes from overshooting.
        params: SimParams { substeps: 3, local_stiffness: 0.2, global_stiffness_root: 0.1, ..default() },
        look: HairLook {
            root_color: Color::srgb(0.12, 0.06, 0.03),
            tip_color: Color::srgb(0.38, 0.2, 0.1),
            ..default()
        },
    }
}

fn curly() -> Preset {
    Preset {
        name: "Curly",
        groom: HairGroom {
            guides: 1200,
            segments: 20,
            length: 0.24,
            curl: 0.6,
            comb: SWEPT_BACK * 0.7,
            settle_steps: 60,
            children: ChildParams { per_guide: 10, clumping: 0.6, tip_spread: 0.002, ..default() },
            ..default()
        },
        // Curls survive only with strong local shape keeping.
        params: SimParams {
            local_stiffness: 0.85,
            global_stiffness_root: 0.3,
            global_stiffness_tip: 0.1,
            iterations: 2,
            ..default()
        },
        look: HairLook {
            root_color: Color::srgb(0.18, 0.05, 0.02),
            tip_color: Color::srgb(0.45, 0.15, 0.06),
            ..default()
        },
    }
}

fn windy() -> Preset {
    let shoulder = shoulder();
    Preset {
        name: "Windy",
        groom: HairGroom { length: 0.3, ..shoulder.groom },
        // A breeze from the front left with strong gusts; less drag so the hair flutters.
        params: SimParams {
            drag: 0.5,
            wind: Wind { direction: [0.5, 0.0, -1.0], strength: 8.0, gust_strength: 0.9, gust_frequency: 1.3 },
            ..default()
        },
        look: HairLook {
            root_color: Color::srgb(0.32, 0.22, 0.11),
            tip_color: Color::srgb(0.72, 0.57, 0.35),
            ..default()
        },
    }
}

/// The reference's whole model: vertex roots along the normals, 10 segments, mass springs
/// with the ±10 % clamp and no shape keeping, the centre-ray push, spiral a = b = 2.
pub fn reference() -> Preset {
    Preset {
        name: "Reference",
        groom: HairGroom {
            guides: 1200,
            children: ChildParams { per_guide: 12, ..HairGroom::reference().children },
            ..HairGroom::reference()
        },
        params: SimParams::reference(),
        look: HairLook::default(),
    }
}
