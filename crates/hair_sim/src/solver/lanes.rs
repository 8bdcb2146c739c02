//! Sixteen strands side by side. A particle quantity of sixteen strands is one [`V3`]:
//! its x, y and z components as [`Wide`] vectors of sixteen lanes, one strand per lane.
//! Every instruction then steps four strands, and because a `Wide` is four independent SSE
//! vectors, the root → tip chains of shape and length (each particle waiting on its
//! parent's square root and division) run four deep at once instead of stalling.
//!
//! Lanes never mix, and each lane does exactly the operations the one-strand formula
//! names, so a strand's result does not depend on its lane or its neighbours.

use crate::math::{Quat, Vec3};
use glam::{BVec4A, Mat3A, Vec3A, Vec4};
use std::ops::{Add, AddAssign, BitAnd, Mul, Neg, Sub, SubAssign};

/// SSE vectors in a [`Wide`].
const WIDTH: usize = 4;
/// Strands stepped side by side.
pub(super) const LANES: usize = 4 * WIDTH;

/// One `f32` per lane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Wide([Vec4; WIDTH]);

/// One flag per lane.
#[derive(Clone, Copy, Debug)]
pub(super) struct Mask([BVec4A; WIDTH]);

impl Wide {
    pub const ZERO: Wide = Wide([Vec4::ZERO; WIDTH]);
    pub const ONE: Wide = Wide([Vec4::ONE; WIDTH]);

    #[inline]
    pub fn splat(v: f32) -> Self {
        Wide([Vec4::splat(v); WIDTH])
    }

    #[inline]
    pub fn from_array(v: [f32; LANES]) -> Self {
        Wide(std::array::from_fn(|i| Vec4::new(v[4 * i], v[4 * i + 1], v[4 * i + 2], v[4 * i + 3])))
    }

    #[inline]
    pub fn get(&self, l: usize) -> f32 {
        self.0[l / 4][l % 4]
    }

    #[inline]
    pub fn set(&mut self, l: usize, v: f32) {
        self.0[l / 4][l % 4] = v;
    }

    #[inline]
    fn map(self, f: impl Fn(Vec4) -> Vec4) -> Wide {
        Wide(self.0.map(f))
    }

    #[inline]
    fn zip(self, o: Wide, f: impl Fn(Vec4, Vec4) -> Vec4) -> Wide {
        Wide(std::array::from_fn(|i| f(self.0[i], o.0[i])))
    }

    #[inline]
    fn compare(self, o: Wide, f: impl Fn(Vec4, Vec4) -> BVec4A) -> Mask {
        Mask(std::array::from_fn(|i| f(self.0[i], o.0[i])))
    }

    #[inline]
    pub fn sqrt(self) -> Wide {
        self.map(Vec4::sqrt)
    }

    #[inline]
    pub fn abs(self) -> Wide {
        self.map(Vec4::abs)
    }

    #[inline]
    pub fn recip(self) -> Wide {
        self.map(Vec4::recip)
    }

    #[inline]
    pub fn max(self, o: Wide) -> Wide {
        self.zip(o, Vec4::max)
    }

    #[inline]
    pub fn min(self, o: Wide) -> Wide {
        self.zip(o, Vec4::min)
    }

    /// Per lane, as `f32::clamp` (`min ≤ max` assumed).
    #[inline]
    pub fn clamp(self, min: Wide, max: Wide) -> Wide {
        self.max(min).min(max)
    }

    #[inline]
    pub fn cmpgt(self, o: Wide) -> Mask {
        self.compare(o, Vec4::cmpgt)
    }

    #[inline]
    pub fn cmplt(self, o: Wide) -> Mask {
        self.compare(o, Vec4::cmplt)
    }

    #[inline]
    pub fn cmpne(self, o: Wide) -> Mask {
        self.compare(o, Vec4::cmpne)
    }

    #[inline]
    pub fn is_finite_mask(self) -> Mask {
        Mask(self.0.map(Vec4::is_finite_mask))
    }

    /// Per lane: `a` where `mask` is set, else `b`.
    #[inline]
    pub fn select(mask: Mask, a: Wide, b: Wide) -> Wide {
        Wide(std::array::from_fn(|i| Vec4::select(mask.0[i], a.0[i], b.0[i])))
    }
}

impl Mask {
    /// Bit `l` set for each set lane `l`.
    #[inline]
    pub fn bitmask(self) -> u32 {
        self.0.iter().enumerate().fold(0, |bits, (i, m)| bits | (m.bitmask() << (4 * i)))
    }
}

impl Mask {
    /// Lane `l` set where bit `l` of `bits` is.
    #[inline]
    pub fn from_bits(bits: u32) -> Mask {
        let bit = |l: usize| bits & (1 << l) != 0;
        Mask(std::array::from_fn(|i| BVec4A::new(bit(4 * i), bit(4 * i + 1), bit(4 * i + 2), bit(4 * i + 3))))
    }
}

impl BitAnd for Mask {
    type Output = Mask;
    #[inline]
    fn bitand(self, o: Mask) -> Mask {
        Mask(std::array::from_fn(|i| self.0[i] & o.0[i]))
    }
}

macro_rules! wide_op {
    ($trait:ident, $method:ident, $op:tt) => {
        impl $trait for Wide {
            type Output = Wide;
            #[inline]
            fn $method(self, o: Wide) -> Wide {
                self.zip(o, |a, b| a $op b)
            }
        }
    };
}
wide_op!(Add, add, +);
wide_op!(Sub, sub, -);
wide_op!(Mul, mul, *);

impl std::ops::Div for Wide {
    type Output = Wide;
    #[inline]
    fn div(self, o: Wide) -> Wide {
        self.zip(o, |a, b| a / b)
    }
}

impl Neg for Wide {
    type Output = Wide;
    #[inline]
    fn neg(self) -> Wide {
        self.map(|a| -a)
    }
}

/// A 3-vector per lane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct V3 {
    pub x: Wide,
    pub y: Wide,
    pub z: Wide,
}

impl V3 {
    pub const ZERO: V3 = V3 { x: Wide::ZERO, y: Wide::ZERO, z: Wide::ZERO };

    /// The same vector in every lane.
    #[inline]
    pub fn splat(v: Vec3) -> Self {
        V3 { x: Wide::splat(v.x), y: Wide::splat(v.y), z: Wide::splat(v.z) }
    }

    /// One vector per lane.
    #[inline]
    pub fn from_lanes(v: [Vec3; LANES]) -> Self {
        V3 {
            x: Wide::from_array(v.map(|v| v.x)),
            y: Wide::from_array(v.map(|v| v.y)),
            z: Wide::from_array(v.map(|v| v.z)),
        }
    }

    #[inline]
    pub fn lane(&self, l: usize) -> Vec3 {
        Vec3::new(self.x.get(l), self.y.get(l), self.z.get(l))
    }

    #[inline]
    pub fn set_lane(&mut self, l: usize, v: Vec3) {
        self.x.set(l, v.x);
        self.y.set(l, v.y);
        self.z.set(l, v.z);
    }

    /// Componentwise maximum.
    #[inline]
    pub fn max(self, o: V3) -> V3 {
        V3 { x: self.x.max(o.x), y: self.y.max(o.y), z: self.z.max(o.z) }
    }

    /// Componentwise minimum.
    #[inline]
    pub fn min(self, o: V3) -> V3 {
        V3 { x: self.x.min(o.x), y: self.y.min(o.y), z: self.z.min(o.z) }
    }

    #[inline]
    pub fn dot(self, o: V3) -> Wide {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    #[inline]
    pub fn cross(self, o: V3) -> V3 {
        V3 { x: self.y * o.z - o.y * self.z, y: self.z * o.x - o.z * self.x, z: self.x * o.y - o.x * self.y }
    }

    #[inline]
    pub fn length(self) -> Wide {
        self.dot(self).sqrt()
    }

    /// Per lane: `self` scaled to unit length, or `fallback` where it has none (zero,
    /// infinite or NaN), as glam's `normalize_or`.
    #[inline]
    pub fn normalize_or(self, fallback: V3) -> V3 {
        let recip = self.length().recip();
        let ok = recip.is_finite_mask() & recip.cmpgt(Wide::ZERO);
        V3::select(ok, self * recip, fallback)
    }

    /// Per lane: `self` shortened to at most `max`, as glam's `clamp_length_max`.
    #[inline]
    pub fn clamp_length_max(self, max: Wide) -> V3 {
        let squared = self.dot(self);
        let long = squared.cmpgt(max * max);
        V3::select(long, self * (max / squared.sqrt()), self)
    }

    /// Per lane: `a` where `mask` is set, else `b`.
    #[inline]
    pub fn select(mask: Mask, a: V3, b: V3) -> V3 {
        V3 { x: Wide::select(mask, a.x, b.x), y: Wide::select(mask, a.y, b.y), z: Wide::select(mask, a.z, b.z) }
    }
}

impl Add for V3 {
    type Output = V3;
    #[inline]
    fn add(self, o: V3) -> V3 {
        V3 { x: self.x + o.x, y: self.y + o.y, z: self.z + o.z }
    }
}

impl Sub for V3 {
    type Output = V3;
    #[inline]
    fn sub(self, o: V3) -> V3 {
        V3 { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }
}

impl Neg for V3 {
    type Output = V3;
    #[inline]
    fn neg(self) -> V3 {
        V3 { x: -self.x, y: -self.y, z: -self.z }
    }
}

/// Each lane scaled by its own factor.
impl Mul<Wide> for V3 {
    type Output = V3;
    #[inline]
    fn mul(self, s: Wide) -> V3 {
        V3 { x: self.x * s, y: self.y * s, z: self.z * s }
    }
}

impl AddAssign for V3 {
    #[inline]
    fn add_assign(&mut self, o: V3) {
        *self = *self + o;
    }
}

impl SubAssign for V3 {
    #[inline]
    fn sub_assign(&mut self, o: V3) {
        *self = *self - o;
    }
}

/// A 3×3 matrix per lane, by columns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct M3 {
    pub x_axis: V3,
    pub y_axis: V3,
    pub z_axis: V3,
}

impl M3 {
    /// One matrix per lane.
    pub fn from_lanes(m: [Mat3A; LANES]) -> Self {
        let column = |c: usize| V3::from_lanes(m.map(|m| Vec3::from(m.col(c))));
        M3 { x_axis: column(0), y_axis: column(1), z_axis: column(2) }
    }

    /// The same matrix in every lane.
    pub fn splat(m: Mat3A) -> Self {
        M3 {
            x_axis: V3::splat(m.x_axis.into()),
            y_axis: V3::splat(m.y_axis.into()),
            z_axis: V3::splat(m.z_axis.into()),
        }
    }

    #[inline]
    pub fn mul_vec(&self, v: V3) -> V3 {
        self.x_axis * v.x + self.y_axis * v.y + self.z_axis * v.z
    }

    #[inline]
    pub fn mul_mat(&self, o: &M3) -> M3 {
        M3 { x_axis: self.mul_vec(o.x_axis), y_axis: self.mul_vec(o.y_axis), z_axis: self.mul_vec(o.z_axis) }
    }

    /// The shortest-arc rotation taking unit `from` onto unit `to`, per lane (Rodrigues):
    /// `R = c·I + [v]× + v·vᵀ/(1 + c)` with `v = from × to`, `c = from · to`. Unlike the
    /// quaternion form it needs no square root, and it is orthonormal to rounding, so a
    /// frame chained along a strand needs no renormalising.
    #[inline]
    pub fn rotation_arc(from: V3, to: V3) -> M3 {
        let c = from.dot(to);
        let v = from.cross(to);
        let kv = v * (Wide::ONE + c).recip();
        let mut m = M3 {
            x_axis: V3 { x: c, y: v.z, z: -v.y } + kv * v.x,
            y_axis: V3 { x: -v.z, y: c, z: v.x } + kv * v.y,
            z_axis: V3 { x: v.y, y: -v.x, z: c } + kv * v.z,
        };
        // Nearly opposite: the axis is ill-defined; the quaternion form picks one.
        let opposite = c.cmplt(Wide::splat(-0.999)).bitmask();
        if opposite != 0 {
            for l in (0..LANES).filter(|l| opposite & (1 << l) != 0) {
                let q = Mat3A::from_quat(Quat::from_rotation_arc(from.lane(l), to.lane(l)));
                m.x_axis.set_lane(l, q.x_axis.into());
                m.y_axis.set_lane(l, q.y_axis.into());
                m.z_axis.set_lane(l, q.z_axis.into());
            }
        }
        m
    }
}

/// A rigid transform, the same in every lane: rotation columns and translation.
#[derive(Clone, Copy, Debug)]
pub(super) struct PoseLanes {
    rotation: M3,
    /// The inverse rotation (its transpose).
    inverse: M3,
    translation: V3,
}

impl PoseLanes {
    pub fn new(rotation: Mat3A, translation: Vec3A) -> Self {
        PoseLanes {
            rotation: M3::splat(rotation),
            inverse: M3::splat(rotation.transpose()),
            translation: V3::splat(translation.into()),
        }
    }

    /// Head-local points → world.
    #[inline]
    pub fn world_point(&self, p: V3) -> V3 {
        self.rotation.mul_vec(p) + self.translation
    }

    /// World points → head-local.
    #[inline]
    pub fn local_point(&self, p: V3) -> V3 {
        self.inverse.mul_vec(p - self.translation)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(i: usize) -> Vec3 {
        let f = i as f32 * 0.61;
        Vec3::new(f.sin(), (f * 1.7).cos(), (f * 0.3).sin() - 0.2)
    }

    #[test]
    fn lanes_compute_what_glam_computes_per_vector() {
        let (va, vb): ([Vec3; LANES], [Vec3; LANES]) =
            (std::array::from_fn(sample), std::array::from_fn(|l| sample(l + 7) * 3.0));
        let (a, b) = (V3::from_lanes(va), V3::from_lanes(vb));
        for l in 0..LANES {
            let (va, vb) = (va[l], vb[l]);
            assert_eq!(a.lane(l), va, "lane {l}");
            assert_eq!((a + b).lane(l), va + vb);
            assert_eq!(a.cross(b).lane(l), va.cross(vb));
            assert_eq!(a.dot(b).get(l), va.dot(vb));
            assert!((a.normalize_or(V3::ZERO).lane(l) - va.normalize()).length() < 1e-6);
            assert!((b.clamp_length_max(Wide::splat(1.0)).lane(l) - vb.clamp_length_max(1.0)).length() < 1e-6);
        }
        let zero_or = V3::ZERO.normalize_or(V3::splat(Vec3::NEG_Y));
        assert_eq!(zero_or.lane(2), Vec3::NEG_Y, "a zero vector takes the fallback");
        let nan = V3::splat(Vec3::NAN).normalize_or(V3::splat(Vec3::X));
        assert_eq!(nan.lane(0), Vec3::X, "so does NaN");
    }

    #[test]
    fn rotation_arc_matches_the_quaternion_form() {
        for i in 0..200 {
            let from: [Vec3; LANES] = std::array::from_fn(|l| sample(i * 4 + l).normalize());
            let to: [Vec3; LANES] = std::array::from_fn(|l| {
                let f = (i * 4 + l) as f32;
                Vec3::new((f * 2.3).cos(), f.sin() * 0.5, (f * 1.1).cos()).normalize()
            });
            // One lane exactly opposite, to take the quaternion fallback.
            let to = {
                let mut t = to;
                if i % 10 == 0 {
                    t[1] = -from[1];
                }
                t
            };
            let m = M3::rotation_arc(V3::from_lanes(from), V3::from_lanes(to));
            let mapped = m.mul_vec(V3::from_lanes(from));
            for l in 0..LANES {
                assert!((mapped.lane(l) - to[l]).length() < 1e-4, "{i}/{l}: maps from onto to");
                let q = Mat3A::from_quat(Quat::from_rotation_arc(from[l], to[l]));
                for (axis, column) in [(Vec3A::X, m.x_axis), (Vec3A::Y, m.y_axis), (Vec3A::Z, m.z_axis)] {
                    assert!((column.lane(l) - Vec3::from(q * axis)).length() < 1e-3, "{i}/{l}");
                }
            }
        }
    }
}
