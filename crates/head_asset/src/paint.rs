//! The painted scalp: a hairline rule over height and angle around the head, and the
//! vertex colours the plugin reads it from ("dark = scalp": luminance below 0.5).
//!
//! The rule works in the converted head's frame: metres, +Y up, +Z forward (the face),
//! origin at the centre of the neck cut. Landmarks of the MakeHuman base mesh in that
//! frame: eyebrows at y ≈ 0.148, ear from y ≈ 0.092 to 0.149 (|x| up to 0.088, z from
//! 0.006 to 0.032), crown at y ≈ 0.259, back of the skull at z ≈ −0.068.

/// Paint of the scalp: black (linear RGBA).
pub const SCALP_COLOR: [f32; 4] = [0.0, 0.0, 0.0, 1.0];

/// Paint of the rest of the head: a light skin tone (linear RGBA, luminance 0.66, so it
/// reads as "not scalp" under the plugin's default threshold of 0.5).
pub const SKIN_COLOR: [f32; 4] = [0.85, 0.62, 0.50, 1.0];

/// The luminance below which a colour counts as scalp (the plugin's default threshold).
pub const SCALP_LUMINANCE: f32 = 0.5;

/// The vertical axis the hairline's azimuth is measured around: x = 0, z = `HAIRLINE_AXIS_Z`
/// (metres), half-way between the back of the skull and the brow, just behind the ear canal.
pub const HAIRLINE_AXIS_Z: f64 = 0.02;

/// The hairline: (azimuth in degrees, 0 = face, 90 = over the ear, 180 = nape; height in
/// metres above the neck cut). Between keys the height follows a smoothstep.
const HAIRLINE: [(f64, f64); 9] = [
    (0.0, 0.199),   // forehead: ~5 cm above the eyebrows (0.148)
    (25.0, 0.195),  // the front hairline curves down a little towards the temples...
    (50.0, 0.176),  // ...and further at the temples
    (68.0, 0.157),  // sideburns stop above the ear's top (0.149)
    (85.0, 0.155),  // over the ear
    (105.0, 0.155), // to the back of the ear (the ear's rim is at ~99°)
    (125.0, 0.105), // behind the ear the hairline drops to the mastoid...
    (150.0, 0.068), // ...and along the back of the neck...
    (180.0, 0.056), // ...to the nape, ~5.6 cm above the neck cut
];

/// The ears, as one ellipsoid per side: centre |x|, y, z and radii, metres. The hairline
/// already runs above them; this keeps the helix unpainted whatever the hairline does.
const EAR_CENTRE: [f64; 3] = [0.085, 0.12, 0.02];
const EAR_RADII: [f64; 3] = [0.02, 0.034, 0.024];

/// Azimuth of a head-local point around the hairline axis, degrees: 0 straight ahead (the
/// face), 90 to either side, 180 straight back. Symmetric in x.
pub fn azimuth_degrees(p: [f64; 3]) -> f64 {
    p[0].abs().atan2(p[2] - HAIRLINE_AXIS_Z).to_degrees()
}

/// The hairline's height (metres above the neck cut) at an azimuth in degrees (0..=180).
pub fn hairline_height(azimuth: f64) -> f64 {
    let azimuth = azimuth.clamp(0.0, 180.0);
    for pair in HAIRLINE.windows(2) {
        let ((a0, h0), (a1, h1)) = (pair[0], pair[1]);
        if azimuth <= a1 {
            let t = (azimuth - a0) / (a1 - a0);
            return h0 + (h1 - h0) * t * t * (3.0 - 2.0 * t);
        }
    }
    HAIRLINE[HAIRLINE.len() - 1].1
}

/// Whether a head-local point lies in an ear (either side).
pub fn in_ear(p: [f64; 3]) -> bool {
    let d = [p[0].abs() - EAR_CENTRE[0], p[1] - EAR_CENTRE[1], p[2] - EAR_CENTRE[2]];
    (0..3).map(|k| (d[k] / EAR_RADII[k]).powi(2)).sum::<f64>() < 1.0
}

/// The scalp rule: a point grows hair if it lies above the hairline at its azimuth and
/// not in an ear. The face is excluded by the forehead hairline, the neck by the nape one.
pub fn is_scalp(p: [f64; 3]) -> bool {
    p[1] > hairline_height(azimuth_degrees(p)) && !in_ear(p)
}

/// The vertex colour for a head-local position: [`SCALP_COLOR`] or [`SKIN_COLOR`].
pub fn paint(p: [f64; 3]) -> [f32; 4] {
    if is_scalp(p) { SCALP_COLOR } else { SKIN_COLOR }
}

/// Whether a vertex colour reads as scalp: relative luminance of linear RGB below
/// [`SCALP_LUMINANCE`] (the plugin's rule).
pub fn is_scalp_color(color: [f32; 4]) -> bool {
    0.2126 * color[0] + 0.7152 * color[1] + 0.0722 * color[2] < SCALP_LUMINANCE
}

/// The area of the triangles whose three corners are all scalp (where the plugin grows
/// hair), in the positions' units squared.
pub fn scalp_area(positions: &[[f64; 3]], triangles: &[[u32; 3]], scalp: &[bool]) -> f64 {
    let mesh = crate::geom::TriMesh { positions: positions.to_vec(), triangles: triangles.to_vec() };
    (0..triangles.len())
        .filter(|&t| triangles[t].iter().all(|&v| scalp[v as usize]))
        .map(|t| 0.5 * crate::geom::length(mesh.area_vector(t)))
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_hairline_passes_through_its_keys_and_is_monotone_at_the_back() {
        assert_eq!(hairline_height(0.0), 0.199);
        assert_eq!(hairline_height(90.0), 0.155);
        assert!((hairline_height(180.0) - 0.056).abs() < 1e-15);
        assert_eq!(hairline_height(-5.0), 0.199, "clamped");
        let mid = hairline_height(115.0);
        assert!((mid - 0.13).abs() < 1e-12, "smoothstep midpoint between 0.155 and 0.105: {mid}");
        let back: Vec<f64> = (105..=180).map(|a| hairline_height(a as f64)).collect();
        assert!(back.windows(2).all(|w| w[1] <= w[0]), "the hairline only drops behind the ear");
    }

    #[test]
    fn face_ears_and_neck_stay_skin() {
        assert_eq!(azimuth_degrees([0.0, 0.1, 0.12]), 0.0);
        assert!((azimuth_degrees([-0.08, 0.1, 0.02]) - 90.0).abs() < 1e-12);
        assert!(is_scalp([0.0, 0.25, 0.05]), "crown");
        assert!(is_scalp([0.0, 0.2, 0.11]), "above the forehead hairline");
        assert!(!is_scalp([0.0, 0.17, 0.12]), "forehead");
        assert!(!is_scalp([0.08, 0.14, 0.02]), "ear top");
        assert!(in_ear([-0.085, 0.10, 0.02]) && !in_ear([0.0, 0.10, 0.02]));
        assert!(is_scalp([0.0, 0.08, -0.06]) && !is_scalp([0.0, 0.04, -0.05]), "nape hairline at 5.6 cm");
        assert!(is_scalp_color(SCALP_COLOR) && !is_scalp_color(SKIN_COLOR));
        let [r, g, b, _] = SKIN_COLOR;
        assert!((0.2126 * r + 0.7152 * g + 0.0722 * b - 0.6602).abs() < 1e-4, "skin luminance 0.66");
    }

    #[test]
    fn scalp_area_counts_whole_triangles_only() {
        let positions = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]];
        let triangles = [[0, 1, 2], [1, 3, 2]];
        assert_eq!(scalp_area(&positions, &triangles, &[true, true, true, false]), 0.5);
        assert_eq!(scalp_area(&positions, &triangles, &[true; 4]), 1.0);
        assert_eq!(scalp_area(&positions, &triangles, &[false, true, true, true]), 0.5);
    }
}
