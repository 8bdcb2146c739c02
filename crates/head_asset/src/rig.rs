//! The head's skeleton, skin weights and animation clip: what makes `assets/head.glb` a
//! skinned character a game would give hair to.
//!
//! Two joints, in the head's frame (metres, +Y up, +Z forward, origin at the centre of the
//! neck cut): `neck` at the origin and its child `head` at the top of the neck, where the
//! skull turns on the spine. The scalp and the face follow `head` alone; the neck blends
//! from `neck` at the cut to `head` under the chin ([`skin_weights`]). The clip
//! ([`clip`]) turns, nods, shakes and whips the head, each motion shared between the
//! two joints as a real neck shares it.

use hair_sim::math::{Quat, Vec3};

/// A joint of the skeleton: its name, its parent (an index into [`JOINTS`]) and where it
/// sits relative to the parent at rest, metres. No joint is rotated at rest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Joint {
    /// The glTF node's name.
    pub name: &'static str,
    /// The parent joint, `None` for the skeleton's root.
    pub parent: Option<usize>,
    /// The rest translation from the parent (or from the scene's origin for the root).
    pub translation: [f32; 3],
}

/// Index of the neck joint in [`JOINTS`] (and in the skin's joint list).
pub const NECK: usize = 0;
/// Index of the head joint in [`JOINTS`] (and in the skin's joint list).
pub const HEAD: usize = 1;

/// The skeleton, parents before children. The head joint is 9 cm above the neck cut and
/// 1 cm forward: between the ears (their canals are at y ≈ 0.12, z ≈ 0.02) and the top
/// of the spine, where the skull pivots.
pub const JOINTS: [Joint; 2] = [
    Joint { name: "neck", parent: None, translation: [0.0, 0.0, 0.0] },
    Joint { name: "head", parent: Some(NECK), translation: [0.0, 0.09, 0.01] },
];

/// Where each joint is at rest in the head's frame (the sum of the translations to it).
pub fn rest_positions() -> [[f32; 3]; 2] {
    let mut out = [[0.0; 3]; 2];
    for (j, joint) in JOINTS.iter().enumerate() {
        let base = joint.parent.map_or([0.0; 3], |p| out[p]);
        out[j] = std::array::from_fn(|k| base[k] + joint.translation[k]);
    }
    out
}

/// Height above the neck cut (metres) below which a vertex is part of the neck: the chin
/// comes down to y ≈ 0.026, the nape's hairline to y ≈ 0.056.
pub const NECK_TOP: f64 = 0.025;

/// The skin weights of a point of the head, `[neck, head]`, summing to 1: all `head` from
/// [`NECK_TOP`] up (the scalp and the face move rigidly with the skull), blending to all
/// `neck` at the cut with a smoothstep, so the neck bends without a crease.
pub fn skin_weights(p: [f64; 3]) -> [f32; 2] {
    let t = (p[1] / NECK_TOP).clamp(0.0, 1.0);
    let head = (t * t * (3.0 - 2.0 * t)) as f32;
    [1.0 - head, head]
}

/// Key poses of the head relative to the torso: (time s, yaw°, pitch° (+ nods down), roll°).
/// Between keys the motion eases in and out (a smoothstep), so it starts and stops like a
/// person's.
pub const KEY_POSES: &[(f32, f32, f32, f32)] = &[
    (0.0, 0.0, 0.0, 0.0),
    (0.5, 0.0, 0.0, 0.0),
    (1.4, 40.0, -5.0, 4.0),   // turn left
    (2.5, -40.0, -5.0, -4.0), // turn right
    (3.2, 0.0, 0.0, 0.0),
    (3.6, 0.0, 24.0, 0.0), // nod
    (4.0, 0.0, -14.0, 0.0),
    (4.4, 0.0, 24.0, 0.0),
    (4.9, 0.0, 0.0, 0.0),
    (5.05, 28.0, 0.0, 0.0), // shake
    (5.2, -28.0, 0.0, 0.0),
    (5.35, 28.0, 0.0, 0.0),
    (5.5, -28.0, 0.0, 0.0),
    (5.65, 0.0, 0.0, 0.0),
    (6.4, 0.0, 0.0, 0.0),
    (6.55, 75.0, -6.0, 0.0), // whip: 75° in 0.15 s, peaking near 13 rad/s
    (6.9, 75.0, -6.0, 0.0),
    (7.6, 0.0, 0.0, 0.0),
    (CLIP_SECONDS, 0.0, 0.0, 0.0), // rest: the hair settles before the clip loops
];

/// Length of the clip, seconds.
pub const CLIP_SECONDS: f32 = 9.0;

/// Keyframes per second of the sampled clip (linear interpolation between them).
pub const CLIP_RATE: f32 = 60.0;

/// The share of each motion the neck joint takes; the head joint turns by the rest.
pub const NECK_SHARE: f32 = 0.3;

/// The name of the clip in the glTF.
pub const CLIP_NAME: &str = "turn, nod, shake, whip";

/// The head's total rotation (neck and head joint together) at clip time `t`.
pub fn pose_at(t: f32) -> Quat {
    let (yaw, pitch, roll) = angles_at(t);
    euler(yaw, pitch, roll)
}

/// Yaw, pitch and roll (radians) at clip time `t`, eased between the key poses.
fn angles_at(t: f32) -> (f32, f32, f32) {
    let next = KEY_POSES.iter().position(|p| p.0 > t).unwrap_or(KEY_POSES.len() - 1).max(1);
    let (a, b) = (KEY_POSES[next - 1], KEY_POSES[next]);
    let s = ((t - a.0) / (b.0 - a.0)).clamp(0.0, 1.0);
    let s = s * s * (3.0 - 2.0 * s);
    let lerp = |x: f32, y: f32| (x + (y - x) * s).to_radians();
    (lerp(a.1, b.1), lerp(a.2, b.2), lerp(a.3, b.3))
}

/// Yaw about +Y, then pitch about +X, then roll about +Z (intrinsic), as a quaternion.
fn euler(yaw: f32, pitch: f32, roll: f32) -> Quat {
    Quat::from_rotation_y(yaw) * Quat::from_rotation_x(pitch) * Quat::from_rotation_z(roll)
}

/// The animation clip, sampled: keyframe times and, per keyframe, each joint's local
/// rotation (x, y, z, w).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Clip {
    /// The clip's name.
    pub name: String,
    /// Keyframe times, seconds, increasing from 0 to the clip's length.
    pub times: Vec<f32>,
    /// Per keyframe, the local rotation of each joint of [`JOINTS`], in order.
    pub rotations: Vec<[[f32; 4]; 2]>,
}

/// The clip: [`KEY_POSES`] sampled at [`CLIP_RATE`], the neck joint taking [`NECK_SHARE`]
/// of each angle and the head joint the rest of the pose.
pub fn clip() -> Clip {
    let frames = (CLIP_SECONDS * CLIP_RATE).round() as usize;
    let times: Vec<f32> = (0..=frames).map(|i| i as f32 / CLIP_RATE).collect();
    let rotations = times
        .iter()
        .map(|&t| {
            let (yaw, pitch, roll) = angles_at(t);
            let neck = euler(NECK_SHARE * yaw, NECK_SHARE * pitch, NECK_SHARE * roll).normalize();
            // The head joint turns by what the neck leaves: together they make the pose.
            let head = (neck.inverse() * pose_at(t)).normalize();
            [neck.to_array(), head.to_array()]
        })
        .collect();
    Clip { name: CLIP_NAME.into(), times, rotations }
}

/// Where a point of the head's rest pose goes when the joints are rotated locally by
/// `rotations` (one per joint): linear blend skinning with [`skin_weights`]. What a glTF
/// viewer does with the asset, for tests.
pub fn skin_point(p: [f32; 3], weights: [f32; 2], rotations: [[f32; 4]; 2]) -> [f32; 3] {
    let rest = rest_positions().map(Vec3::from_array);
    let rotations = rotations.map(Quat::from_array);
    // World rotation and position of each joint (parents first).
    let mut world = [(Quat::IDENTITY, Vec3::ZERO); 2];
    for (j, joint) in JOINTS.iter().enumerate() {
        let (parent_rotation, parent_position) = joint.parent.map_or((Quat::IDENTITY, Vec3::ZERO), |p| world[p]);
        let position = parent_position + parent_rotation * Vec3::from_array(joint.translation);
        world[j] = (parent_rotation * rotations[j], position);
    }
    let p = Vec3::from_array(p);
    let skinned = (0..2).fold(Vec3::ZERO, |sum, j| {
        let (rotation, position) = world[j];
        sum + weights[j] * (position + rotation * (p - rest[j]))
    });
    skinned.to_array()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_blend_the_neck_and_hold_the_skull() {
        assert_eq!(skin_weights([0.0, 0.0, 0.0]), [1.0, 0.0]);
        assert_eq!(skin_weights([0.0, NECK_TOP, 0.05]), [0.0, 1.0]);
        assert_eq!(skin_weights([0.03, 0.2, -0.05]), [0.0, 1.0]);
        let mid = skin_weights([0.0, NECK_TOP / 2.0, 0.0]);
        assert!((mid[0] - 0.5).abs() < 1e-6 && (mid[1] - 0.5).abs() < 1e-6, "{mid:?}");
    }

    #[test]
    fn the_clip_composes_to_the_key_poses_and_stays_smooth() {
        let clip = clip();
        assert_eq!(clip.times.len(), 541);
        assert_eq!(*clip.times.last().unwrap(), CLIP_SECONDS);
        for (i, (&t, r)) in clip.times.iter().zip(&clip.rotations).enumerate() {
            let total = Quat::from_array(r[NECK]) * Quat::from_array(r[HEAD]);
            let want = pose_at(t);
            // Component-wise (the angle between nearly equal quaternions is all rounding).
            let apart = (total - want).length().min((total + want).length());
            assert!(apart < 1e-5, "keyframe {i}: {total:?} vs {want:?}");
        }
        // The whip is the fastest motion: its peak angular speed between keyframes.
        let speed = |i: usize| pose_at(clip.times[i]).angle_between(pose_at(clip.times[i + 1])) * CLIP_RATE;
        let fastest = (0..clip.times.len() - 1).max_by(|&a, &b| speed(a).total_cmp(&speed(b))).unwrap();
        assert!((6.4..6.55).contains(&clip.times[fastest]), "fastest at {} s", clip.times[fastest]);
        assert!((11.0..14.0).contains(&speed(fastest)), "peak {} rad/s", speed(fastest));
    }

    #[test]
    fn skinning_moves_the_skull_rigidly_about_the_head_joint() {
        let rotations = [euler(0.3, 0.0, 0.0).to_array(), euler(0.0, 0.5, 0.0).to_array()];
        let joint = rest_positions()[HEAD];
        let moved_joint = skin_point(joint, [0.0, 1.0], rotations);
        // The head joint itself only swings with the neck's yaw about the neck joint.
        let swung = Quat::from_array(rotations[NECK]) * Vec3::from_array(joint);
        assert!((Vec3::from_array(moved_joint) - swung).length() < 1e-6, "{moved_joint:?}");
        let joint = moved_joint;
        // A crown point keeps its distance from the head joint.
        let crown = [0.0, 0.25, 0.0];
        let moved = skin_point(crown, [0.0, 1.0], rotations);
        let d = |a: [f32; 3], b: [f32; 3]| (Vec3::from_array(a) - Vec3::from_array(b)).length();
        assert!((d(moved, joint) - d(crown, rest_positions()[HEAD])).abs() < 1e-6);
        assert!(d(moved, crown) > 0.05, "the crown moved {} m", d(moved, crown));
    }
}
