//! How the strands look: [`HairLook`] and the types it holds.

use bevy::prelude::*;

/// A specular highlight of Scheuermann's two-lobe hair model.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// let look = HairLook {
///     primary: SpecularLobe { color: Color::WHITE, exponent: 120.0, shift: -0.05 },
///     ..default()
/// };
/// # let _ = look;
/// ```
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
pub struct SpecularLobe {
    /// Highlight colour (the secondary lobe is also tinted by the hair colour).
    pub color: Color,
    /// Sharpness: larger is a narrower highlight.
    pub exponent: f32,
    /// Shifts the highlight along the strand: positive toward the tip, negative toward
    /// the root.
    pub shift: f32,
}

/// Which scattering model shades the strands' highlights (the diffuse term is Kajiya-Kay's
/// in both).
/// [`HairLook`]'s example sets one.
#[derive(Reflect, Clone, Copy, Debug, PartialEq, Default)]
pub enum HairShading {
    /// Scheuermann's two shifted Kajiya-Kay highlights ([`HairLook::primary`] and
    /// [`HairLook::secondary`]): the reference's model.
    #[default]
    KajiyaKay,
    /// Marschner et al.'s three lobes in Karis' real-time form: R, the white reflection off
    /// the cuticle (coloured by [`HairLook::primary`]); TT, light through the fibre, the
    /// glow of back-lit hair; TRT, the hair-coloured second highlight.
    Marschner {
        /// Longitudinal roughness: 0.2 sleek to 0.6 frizzy; the lobes are Gaussians of
        /// width `roughness²` (TT half, TRT twice that).
        roughness: f32,
        /// Tilt of the cuticle scales, radians (about 0.035): shifts R toward the root by
        /// twice this, TT toward the tip by it and TRT by four times it.
        cuticle_tilt: f32,
    },
}

impl HairShading {
    /// Marschner with typical values: roughness 0.35, cuticle tilt 0.035 rad.
    pub const MARSCHNER: HairShading = HairShading::Marschner { roughness: 0.35, cuticle_tilt: 0.035 };
}

/// How a groom looks. On the head entity next to [`HairGroom`](crate::HairGroom) (inserted with defaults
/// when missing); edit it at any time.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_hair::prelude::*;
/// fn auburn(mut commands: Commands, heads: Query<Entity, Added<HairGroom>>) {
///     for head in &heads {
///         commands.entity(head).insert(HairLook {
///             root_color: Color::srgb(0.25, 0.08, 0.03),
///             tip_color: Color::srgb(0.55, 0.2, 0.08),
///             shading: HairShading::MARSCHNER,
///             antialias: HairAntialias::Blended,
///             ..default()
///         });
///     }
/// }
/// ```
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Default)]
pub struct HairLook {
    /// Colour at the root.
    pub root_color: Color,
    /// Colour at the tip.
    pub tip_color: Color,
    /// Random per-strand brightness variation, 0..1.
    pub tint_variation: f32,
    /// Ribbon width at the root, metres.
    pub root_width: f32,
    /// Ribbon width at the tip, metres.
    pub tip_width: f32,
    /// Kajiya-Kay diffuse strength.
    pub diffuse: f32,
    /// The light-coloured highlight, shifted toward the tip.
    pub primary: SpecularLobe,
    /// The hair-tinted highlight, shifted toward the root.
    pub secondary: SpecularLobe,
    /// Curve samples per segment (Bézier tessellation), at least 1.
    pub subdivisions: u32,
    /// Sample the shadows of directional, point and spot lights (from the head, other
    /// casters and the hair itself).
    pub receive_shadows: bool,
    /// Cast shadows (of directional, point and spot lights) on the head and on the hair
    /// itself. Drawing the strands into each shadow map costs about as much as drawing
    /// them once more.
    pub cast_shadows: bool,
    /// Draw the simulated guides only, without children.
    pub guides_only: bool,
    /// The highlights' scattering model.
    pub shading: HairShading,
    /// Self-shadowing: how much of the light one layer of fibres stops on its way to the
    /// fibres behind it, 0..1 (0 turns it off). Toward each shadow-casting light (up to
    /// [`MAX_OPACITY_MAPS`](super::MAX_OPACITY_MAPS)) the guides are counted into a deep opacity map every frame
    /// (`hair_sim::shadow`), and a strand behind `n` layers of fibres gets
    /// `exp(−self_shadow · n)` of that light, whatever Bevy's shadow cascades.
    pub self_shadow: f32,
    /// How strands thinner than a pixel are drawn, so that distant hair keeps its density
    /// and does not shimmer.
    pub antialias: HairAntialias,
}

/// How strands thinner than a pixel are drawn ([`HairLook::antialias`]). Far hair drawn
/// as plain ribbons breaks up and shimmers as the camera moves; [`Coverage`](Self::Coverage)
/// calms that, [`Blended`](Self::Blended) most (the figures are in `docs/rendering.md`).
/// [`HairLook`]'s example sets one.
#[derive(Reflect, Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum HairAntialias {
    /// Solid ribbons however thin: far hair breaks up and shimmers as it moves.
    Off,
    /// With MSAA on the camera (Bevy's default): a strand thinner than a pixel is drawn a
    /// pixel wide and covers its true share of the samples (stochastic alpha-to-coverage,
    /// the same samples in every frame). Depth-exact, but which strand is in front at each
    /// sample still changes as the camera moves. Without MSAA, plain ribbons.
    Coverage,
    /// In Bevy's transparent pass: a strand thinner than two pixels is drawn two pixels
    /// wide with its true coverage as opacity, blended over what is behind it. The strands
    /// are cut into pieces of [`SEGMENTS_PER_PIECE`](super::SEGMENTS_PER_PIECE) segments, drawn back to front from
    /// the nearest active camera (sorted on the CPU every frame). Every pixel averages
    /// many strands, with or without MSAA, but the order is by piece, not by pixel: about
    /// 8 % darker than exact far away, and up close, where strands cross in depth, wrong
    /// where [`Coverage`](Self::Coverage) is exact.
    Blended,
    /// [`Blended`](Self::Blended) while the groom's widest strand is under a pixel wide on
    /// every active camera (back to [`Coverage`](Self::Coverage) above 1.25 pixels, so a
    /// head at the threshold does not flip), [`Coverage`](Self::Coverage) otherwise.
    #[default]
    Auto,
}

impl Default for HairLook {
    fn default() -> Self {
        HairLook {
            root_color: Color::srgb(0.09, 0.055, 0.03),
            tip_color: Color::srgb(0.32, 0.2, 0.11),
            tint_variation: 0.2,
            root_width: 0.0009,
            tip_width: 0.0003,
            diffuse: 1.0,
            primary: SpecularLobe { color: Color::srgb(0.3, 0.28, 0.25), exponent: 90.0, shift: 0.08 },
            secondary: SpecularLobe { color: Color::srgb(0.6, 0.5, 0.4), exponent: 24.0, shift: -0.12 },
            subdivisions: 4,
            receive_shadows: true,
            cast_shadows: true,
            guides_only: false,
            shading: HairShading::KajiyaKay,
            self_shadow: 0.5,
            antialias: HairAntialias::Auto,
        }
    }
}
