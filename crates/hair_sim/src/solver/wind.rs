//! Gusting wind: smooth 1-D value noise per strand, deterministic in (strand, time).
//! GPU twin: `hair_gpu`'s `step/wind.wgsl`, bit for bit.

use super::params::Wind;
use crate::math::Vec3;

/// A hash of an integer to [0, 1): cheap, stateless, the same on every machine.
#[inline]
pub(crate) fn hash01(mut x: u32) -> f32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    (x >> 8) as f32 / (1u32 << 24) as f32
}

/// Smooth noise in [−1, 1]: cubic interpolation between hashed values at integer `t`.
#[inline]
fn value_noise(seed: u32, t: f32) -> f32 {
    let i = t.floor();
    let f = t - i;
    let i = i as i64 as u32;
    let a = hash01(seed ^ i.wrapping_mul(0x9e37_79b9));
    let b = hash01(seed ^ i.wrapping_add(1).wrapping_mul(0x9e37_79b9));
    let s = f * f * (3.0 - 2.0 * f);
    (a + (b - a) * s) * 2.0 - 1.0
}

/// Whether `wind` blows nowhere, at no time: no strength or no direction.
pub fn is_calm(wind: &Wind) -> bool {
    wind.strength == 0.0 || Vec3::from_array(wind.direction).normalize_or_zero() == Vec3::ZERO
}

/// The wind acceleration felt by strand `strand` at `time`, before the perpendicular
/// projection: direction × strength × (1 + gust · noise). Neighbouring strands share most
/// of a gust (a slow shared term) and differ a little (a per-strand term).
#[inline]
pub fn wind_at(wind: &Wind, strand: u32, time: f32) -> Vec3 {
    if is_calm(wind) {
        return Vec3::ZERO;
    }
    let direction = Vec3::from_array(wind.direction).normalize_or_zero();
    let t = time * wind.gust_frequency;
    let shared = value_noise(0x5eed, t);
    let own = value_noise(strand.wrapping_mul(0x2545_f491), t * 1.7 + hash01(strand) * 16.0);
    let gust = 0.7 * shared + 0.3 * own;
    direction * wind.strength * (1.0 + wind.gust_strength * gust).max(0.0)
}

#[cfg(test)]
mod tests;
