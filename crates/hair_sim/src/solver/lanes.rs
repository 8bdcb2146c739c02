//! Strands side by side. A particle quantity of a group of strands is one [`V3`]: its x,
//! y and z components as [`Wide`]s, one strand per lane. A `Wide` is four hardware
//! vectors of the path the step runs on ([`Simd`]): four SSE or NEON vectors (16 lanes)
//! on the portable [`Baseline`], four AVX2 vectors (32 lanes) or four AVX-512 vectors (64
//! lanes) where the CPU has them. Four independent vectors, whatever their width, let the
//! root → tip chains of shape and length (each particle waiting on its parent's square
//! root and division) run four deep at once instead of stalling; a wider vector then
//! steps more strands in the same time.
//!
//! Lanes never mix, and each lane does exactly the operations the one-strand formula
//! names, with IEEE rounding and no fused multiply-add, so a strand's result depends
//! neither on its lane, nor on its neighbours, nor on the path.

use crate::math::{Quat, Vec3};
use glam::{Mat3A, Vec3A};
use std::ops::{Add, AddAssign, BitAnd, Div, Mul, Neg, Sub, SubAssign};

/// Hardware vectors in a [`Wide`].
const VECTORS: usize = 4;

/// The most lanes any path has (AVX-512's).
pub(super) const MAX_LANES: usize = VECTORS * 16;

/// One SIMD instruction set: a vector of `f32` and the operations the solver uses, each
/// rounding exactly as IEEE 754 says (so every path gives the same bits). Comparisons are
/// ordered (false with a NaN) except `ne`, and `max`/`min` return `b` where either is
/// NaN, as SSE's `maxps` and `minps` do.
///
/// An implementation for a feature the baseline lacks runs only where the CPU has that
/// feature: the solver calls it from code compiled for it (`step/mod.rs` dispatches on
/// [`SimdPath`](super::SimdPath)), into which its `#[inline(always)]` bodies inline; the
/// lane tests call it out of line, after detecting the feature.
pub(super) trait Simd: Copy + 'static {
    /// A vector of `f32`.
    type F: Copy;
    /// The result of a comparison.
    type M: Copy;
    /// `f32` per vector.
    const WIDTH: usize;
    fn splat(v: f32) -> Self::F;
    /// Reads `WIDTH` values.
    fn load(v: &[f32]) -> Self::F;
    fn add(a: Self::F, b: Self::F) -> Self::F;
    fn sub(a: Self::F, b: Self::F) -> Self::F;
    fn mul(a: Self::F, b: Self::F) -> Self::F;
    fn div(a: Self::F, b: Self::F) -> Self::F;
    fn sqrt(a: Self::F) -> Self::F;
    fn abs(a: Self::F) -> Self::F;
    /// `-a`: the sign bit flipped.
    fn neg(a: Self::F) -> Self::F;
    fn max(a: Self::F, b: Self::F) -> Self::F;
    fn min(a: Self::F, b: Self::F) -> Self::F;
    fn gt(a: Self::F, b: Self::F) -> Self::M;
    fn lt(a: Self::F, b: Self::F) -> Self::M;
    fn ne(a: Self::F, b: Self::F) -> Self::M;
    fn and(a: Self::M, b: Self::M) -> Self::M;
    /// `a` where `m` is set, else `b`.
    fn select(m: Self::M, a: Self::F, b: Self::F) -> Self::F;
    /// Bit `i` set for each set lane `i`.
    fn bits(m: Self::M) -> u64;
    /// Lane `i` set where bit `i` of `bits` is.
    fn from_bits(bits: u64) -> Self::M;
}

/// The portable path: glam's `Vec4`, which is SSE2 on x86-64 (every such CPU has it),
/// NEON on aarch64, and scalar elsewhere.
#[derive(Clone, Copy, Debug)]
pub(super) struct Baseline;

impl Simd for Baseline {
    type F = glam::Vec4;
    type M = glam::BVec4A;
    const WIDTH: usize = 4;
    #[inline(always)]
    fn splat(v: f32) -> Self::F {
        glam::Vec4::splat(v)
    }
    #[inline(always)]
    fn load(v: &[f32]) -> Self::F {
        glam::Vec4::from_slice(v)
    }
    #[inline(always)]
    fn add(a: Self::F, b: Self::F) -> Self::F {
        a + b
    }
    #[inline(always)]
    fn sub(a: Self::F, b: Self::F) -> Self::F {
        a - b
    }
    #[inline(always)]
    fn mul(a: Self::F, b: Self::F) -> Self::F {
        a * b
    }
    #[inline(always)]
    fn div(a: Self::F, b: Self::F) -> Self::F {
        a / b
    }
    #[inline(always)]
    fn sqrt(a: Self::F) -> Self::F {
        a.sqrt()
    }
    #[inline(always)]
    fn abs(a: Self::F) -> Self::F {
        a.abs()
    }
    #[inline(always)]
    fn neg(a: Self::F) -> Self::F {
        -a
    }
    #[inline(always)]
    fn max(a: Self::F, b: Self::F) -> Self::F {
        a.max(b)
    }
    #[inline(always)]
    fn min(a: Self::F, b: Self::F) -> Self::F {
        a.min(b)
    }
    #[inline(always)]
    fn gt(a: Self::F, b: Self::F) -> Self::M {
        a.cmpgt(b)
    }
    #[inline(always)]
    fn lt(a: Self::F, b: Self::F) -> Self::M {
        a.cmplt(b)
    }
    #[inline(always)]
    fn ne(a: Self::F, b: Self::F) -> Self::M {
        a.cmpne(b)
    }
    #[inline(always)]
    fn and(a: Self::M, b: Self::M) -> Self::M {
        a & b
    }
    #[inline(always)]
    fn select(m: Self::M, a: Self::F, b: Self::F) -> Self::F {
        glam::Vec4::select(m, a, b)
    }
    #[inline(always)]
    fn bits(m: Self::M) -> u64 {
        m.bitmask() as u64
    }
    #[inline(always)]
    fn from_bits(bits: u64) -> Self::M {
        let bit = |i: u32| bits & (1 << i) != 0;
        glam::BVec4A::new(bit(0), bit(1), bit(2), bit(3))
    }
}

#[cfg(target_arch = "x86_64")]
pub(super) use x86::{Avx2, Avx512};

/// The wider x86-64 paths, through `std::arch`.
#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::Simd;
    use std::arch::x86_64::*;

    /// AVX2: eight `f32` per vector.
    #[derive(Clone, Copy, Debug)]
    pub(in crate::solver) struct Avx2;

    // SAFETY (every `unsafe` below): the intrinsics need AVX (AVX2 for the integer ones);
    // `step/mod.rs` runs this path only where `is_x86_feature_detected!("avx2")` said so.
    impl Simd for Avx2 {
        type F = __m256;
        type M = __m256;
        const WIDTH: usize = 8;
        #[inline(always)]
        fn splat(v: f32) -> Self::F {
            unsafe { _mm256_set1_ps(v) }
        }
        #[inline(always)]
        fn load(v: &[f32]) -> Self::F {
            assert!(v.len() >= 8);
            unsafe { _mm256_loadu_ps(v.as_ptr()) }
        }
        #[inline(always)]
        fn add(a: Self::F, b: Self::F) -> Self::F {
            unsafe { _mm256_add_ps(a, b) }
        }
        #[inline(always)]
        fn sub(a: Self::F, b: Self::F) -> Self::F {
            unsafe { _mm256_sub_ps(a, b) }
        }
        #[inline(always)]
        fn mul(a: Self::F, b: Self::F) -> Self::F {
            unsafe { _mm256_mul_ps(a, b) }
        }
        #[inline(always)]
        fn div(a: Self::F, b: Self::F) -> Self::F {
            unsafe { _mm256_div_ps(a, b) }
        }
        #[inline(always)]
        fn sqrt(a: Self::F) -> Self::F {
            unsafe { _mm256_sqrt_ps(a) }
        }
        #[inline(always)]
        fn abs(a: Self::F) -> Self::F {
            unsafe { _mm256_andnot_ps(_mm256_set1_ps(-0.0), a) }
        }
        #[inline(always)]
        fn neg(a: Self::F) -> Self::F {
            unsafe { _mm256_xor_ps(a, _mm256_set1_ps(-0.0)) }
        }
        #[inline(always)]
        fn max(a: Self::F, b: Self::F) -> Self::F {
            unsafe { _mm256_max_ps(a, b) }
        }
        #[inline(always)]
        fn min(a: Self::F, b: Self::F) -> Self::F {
            unsafe { _mm256_min_ps(a, b) }
        }
        #[inline(always)]
        fn gt(a: Self::F, b: Self::F) -> Self::M {
            unsafe { _mm256_cmp_ps::<_CMP_GT_OQ>(a, b) }
        }
        #[inline(always)]
        fn lt(a: Self::F, b: Self::F) -> Self::M {
            unsafe { _mm256_cmp_ps::<_CMP_LT_OQ>(a, b) }
        }
        #[inline(always)]
        fn ne(a: Self::F, b: Self::F) -> Self::M {
            unsafe { _mm256_cmp_ps::<_CMP_NEQ_UQ>(a, b) }
        }
        #[inline(always)]
        fn and(a: Self::M, b: Self::M) -> Self::M {
            unsafe { _mm256_and_ps(a, b) }
        }
        #[inline(always)]
        fn select(m: Self::M, a: Self::F, b: Self::F) -> Self::F {
            unsafe { _mm256_blendv_ps(b, a, m) }
        }
        #[inline(always)]
        fn bits(m: Self::M) -> u64 {
            unsafe { _mm256_movemask_ps(m) as u32 as u64 }
        }
        #[inline(always)]
        fn from_bits(bits: u64) -> Self::M {
            unsafe {
                let lane_bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
                let set = _mm256_and_si256(_mm256_set1_epi32(bits as i32), lane_bits);
                _mm256_castsi256_ps(_mm256_cmpeq_epi32(set, lane_bits))
            }
        }
    }

    /// AVX-512: sixteen `f32` per vector, comparisons as bit masks.
    #[derive(Clone, Copy, Debug)]
    pub(in crate::solver) struct Avx512;

    // SAFETY (every `unsafe` below): the intrinsics need AVX-512F; `step.rs` runs this
    // path only where `is_x86_feature_detected!("avx512f")` said so.
    impl Simd for Avx512 {
        type F = __m512;
        type M = __mmask16;
        const WIDTH: usize = 16;
        #[inline(always)]
        fn splat(v: f32) -> Self::F {
            unsafe { _mm512_set1_ps(v) }
        }
        #[inline(always)]
        fn load(v: &[f32]) -> Self::F {
            assert!(v.len() >= 16);
            unsafe { _mm512_loadu_ps(v.as_ptr()) }
        }
        #[inline(always)]
        fn add(a: Self::F, b: Self::F) -> Self::F {
            unsafe { _mm512_add_ps(a, b) }
        }
        #[inline(always)]
        fn sub(a: Self::F, b: Self::F) -> Self::F {
            unsafe { _mm512_sub_ps(a, b) }
        }
        #[inline(always)]
        fn mul(a: Self::F, b: Self::F) -> Self::F {
            unsafe { _mm512_mul_ps(a, b) }
        }
        #[inline(always)]
        fn div(a: Self::F, b: Self::F) -> Self::F {
            unsafe { _mm512_div_ps(a, b) }
        }
        #[inline(always)]
        fn sqrt(a: Self::F) -> Self::F {
            unsafe { _mm512_sqrt_ps(a) }
        }
        #[inline(always)]
        fn abs(a: Self::F) -> Self::F {
            unsafe { _mm512_abs_ps(a) }
        }
        #[inline(always)]
        fn neg(a: Self::F) -> Self::F {
            // (`_mm512_xor_ps` would need AVX-512DQ.)
            unsafe { _mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(a), _mm512_set1_epi32(i32::MIN))) }
        }
        #[inline(always)]
        fn max(a: Self::F, b: Self::F) -> Self::F {
            unsafe { _mm512_max_ps(a, b) }
        }
        #[inline(always)]
        fn min(a: Self::F, b: Self::F) -> Self::F {
            unsafe { _mm512_min_ps(a, b) }
        }
        #[inline(always)]
        fn gt(a: Self::F, b: Self::F) -> Self::M {
            unsafe { _mm512_cmp_ps_mask::<_CMP_GT_OQ>(a, b) }
        }
        #[inline(always)]
        fn lt(a: Self::F, b: Self::F) -> Self::M {
            unsafe { _mm512_cmp_ps_mask::<_CMP_LT_OQ>(a, b) }
        }
        #[inline(always)]
        fn ne(a: Self::F, b: Self::F) -> Self::M {
            unsafe { _mm512_cmp_ps_mask::<_CMP_NEQ_UQ>(a, b) }
        }
        #[inline(always)]
        fn and(a: Self::M, b: Self::M) -> Self::M {
            a & b
        }
        #[inline(always)]
        fn select(m: Self::M, a: Self::F, b: Self::F) -> Self::F {
            unsafe { _mm512_mask_blend_ps(m, b, a) }
        }
        #[inline(always)]
        fn bits(m: Self::M) -> u64 {
            m as u64
        }
        #[inline(always)]
        fn from_bits(bits: u64) -> Self::M {
            bits as u16
        }
    }
}

/// One `f32` per lane: [`VECTORS`] vectors of path `S`.
#[repr(C)]
pub(super) struct Wide<S: Simd>([S::F; VECTORS]);

/// One flag per lane.
pub(super) struct Mask<S: Simd>([S::M; VECTORS]);

// By hand: a derive would ask `S` to be `Clone`, not the vectors.
impl<S: Simd> Clone for Wide<S> {
    #[inline(always)]
    fn clone(&self) -> Self {
        *self
    }
}
impl<S: Simd> Copy for Wide<S> {}
impl<S: Simd> Clone for Mask<S> {
    #[inline(always)]
    fn clone(&self) -> Self {
        *self
    }
}
impl<S: Simd> Copy for Mask<S> {}

impl<S: Simd> std::fmt::Debug for Wide<S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries((0..Self::LANES).map(|l| self.get(l))).finish()
    }
}

/// Lane by lane, as `f32` compares (so a NaN lane is unequal).
impl<S: Simd> PartialEq for Wide<S> {
    fn eq(&self, o: &Self) -> bool {
        (0..Self::LANES).all(|l| self.get(l) == o.get(l))
    }
}

impl<S: Simd> Wide<S> {
    /// Lanes, strands stepped side by side on this path.
    pub const LANES: usize = VECTORS * S::WIDTH;

    #[inline(always)]
    pub fn splat(v: f32) -> Self {
        Wide([S::splat(v); VECTORS])
    }

    #[inline(always)]
    pub fn zero() -> Self {
        Self::splat(0.0)
    }

    #[inline(always)]
    pub fn one() -> Self {
        Self::splat(1.0)
    }

    /// Lane `l` from `v[l]`; `v` holds at least [`Self::LANES`] values.
    #[inline(always)]
    pub fn from_slice(v: &[f32]) -> Self {
        Wide(std::array::from_fn(|i| S::load(&v[i * S::WIDTH..])))
    }

    /// The lanes as one slice.
    #[inline(always)]
    fn as_slice(&self) -> &[f32] {
        // SAFETY: every `S::F` is `WIDTH` packed `f32`s, and `Wide` is `repr(C)`.
        unsafe { std::slice::from_raw_parts(self.0.as_ptr().cast::<f32>(), Self::LANES) }
    }

    #[inline(always)]
    fn as_mut_slice(&mut self) -> &mut [f32] {
        // SAFETY: as in `as_slice`.
        unsafe { std::slice::from_raw_parts_mut(self.0.as_mut_ptr().cast::<f32>(), Self::LANES) }
    }

    #[inline(always)]
    pub fn get(&self, l: usize) -> f32 {
        self.as_slice()[l]
    }

    #[inline(always)]
    pub fn set(&mut self, l: usize, v: f32) {
        self.as_mut_slice()[l] = v;
    }

    #[inline(always)]
    fn map(self, f: impl Fn(S::F) -> S::F) -> Self {
        Wide(self.0.map(f))
    }

    #[inline(always)]
    fn zip(self, o: Self, f: impl Fn(S::F, S::F) -> S::F) -> Self {
        Wide(std::array::from_fn(|i| f(self.0[i], o.0[i])))
    }

    #[inline(always)]
    fn compare(self, o: Self, f: impl Fn(S::F, S::F) -> S::M) -> Mask<S> {
        Mask(std::array::from_fn(|i| f(self.0[i], o.0[i])))
    }

    #[inline(always)]
    pub fn sqrt(self) -> Self {
        self.map(S::sqrt)
    }

    #[inline(always)]
    pub fn abs(self) -> Self {
        self.map(S::abs)
    }

    #[inline(always)]
    pub fn recip(self) -> Self {
        Self::one() / self
    }

    #[inline(always)]
    pub fn max(self, o: Self) -> Self {
        self.zip(o, S::max)
    }

    #[inline(always)]
    pub fn min(self, o: Self) -> Self {
        self.zip(o, S::min)
    }

    /// Per lane, as `f32::clamp` (`min ≤ max` assumed).
    #[inline(always)]
    pub fn clamp(self, min: Self, max: Self) -> Self {
        self.max(min).min(max)
    }

    #[inline(always)]
    pub fn cmpgt(self, o: Self) -> Mask<S> {
        self.compare(o, S::gt)
    }

    #[inline(always)]
    pub fn cmplt(self, o: Self) -> Mask<S> {
        self.compare(o, S::lt)
    }

    #[inline(always)]
    pub fn cmpne(self, o: Self) -> Mask<S> {
        self.compare(o, S::ne)
    }

    #[inline(always)]
    pub fn is_finite_mask(self) -> Mask<S> {
        self.abs().cmplt(Self::splat(f32::INFINITY))
    }

    /// Per lane: `a` where `mask` is set, else `b`.
    #[inline(always)]
    pub fn select(mask: Mask<S>, a: Self, b: Self) -> Self {
        Wide(std::array::from_fn(|i| S::select(mask.0[i], a.0[i], b.0[i])))
    }
}

impl<S: Simd> Mask<S> {
    /// Bit `l` set for each set lane `l`.
    #[inline(always)]
    pub fn bitmask(self) -> u64 {
        self.0.iter().enumerate().fold(0, |bits, (i, &m)| bits | (S::bits(m) << (i * S::WIDTH)))
    }

    /// Lane `l` set where bit `l` of `bits` is.
    #[inline(always)]
    pub fn from_bits(bits: u64) -> Self {
        Mask(std::array::from_fn(|i| S::from_bits(bits >> (i * S::WIDTH))))
    }
}

impl<S: Simd> BitAnd for Mask<S> {
    type Output = Self;
    #[inline(always)]
    fn bitand(self, o: Self) -> Self {
        Mask(std::array::from_fn(|i| S::and(self.0[i], o.0[i])))
    }
}

macro_rules! wide_op {
    ($trait:ident, $method:ident, $simd:ident) => {
        impl<S: Simd> $trait for Wide<S> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, o: Self) -> Self {
                self.zip(o, S::$simd)
            }
        }
    };
}
wide_op!(Add, add, add);
wide_op!(Sub, sub, sub);
wide_op!(Mul, mul, mul);
wide_op!(Div, div, div);

impl<S: Simd> Neg for Wide<S> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        self.map(S::neg)
    }
}

/// A 3-vector per lane.
#[derive(Debug)]
pub(super) struct V3<S: Simd> {
    pub x: Wide<S>,
    pub y: Wide<S>,
    pub z: Wide<S>,
}

impl<S: Simd> Clone for V3<S> {
    #[inline(always)]
    fn clone(&self) -> Self {
        *self
    }
}
impl<S: Simd> Copy for V3<S> {}
impl<S: Simd> PartialEq for V3<S> {
    fn eq(&self, o: &Self) -> bool {
        self.x == o.x && self.y == o.y && self.z == o.z
    }
}

impl<S: Simd> V3<S> {
    #[inline(always)]
    pub fn zero() -> Self {
        Self::splat(Vec3::ZERO)
    }

    /// The same vector in every lane.
    #[inline(always)]
    pub fn splat(v: Vec3) -> Self {
        V3 { x: Wide::splat(v.x), y: Wide::splat(v.y), z: Wide::splat(v.z) }
    }

    /// Lane `l` from `v[l]`; `v` holds at least [`Wide::LANES`] vectors.
    #[cfg(test)]
    pub fn from_lanes(v: &[Vec3]) -> Self {
        Self::from_fn(|l| v[l])
    }

    /// Lane `l` from `f(l)`.
    #[inline(always)]
    pub fn from_fn(mut f: impl FnMut(usize) -> Vec3) -> Self {
        let mut components = [[0.0; MAX_LANES]; 3];
        for l in 0..Wide::<S>::LANES {
            let v = f(l);
            for (c, component) in components.iter_mut().enumerate() {
                component[l] = v[c];
            }
        }
        let [x, y, z] = components.map(|c| Wide::from_slice(&c));
        V3 { x, y, z }
    }

    #[inline(always)]
    pub fn lane(&self, l: usize) -> Vec3 {
        Vec3::new(self.x.get(l), self.y.get(l), self.z.get(l))
    }

    #[inline(always)]
    pub fn set_lane(&mut self, l: usize, v: Vec3) {
        self.x.set(l, v.x);
        self.y.set(l, v.y);
        self.z.set(l, v.z);
    }

    /// Componentwise maximum.
    #[inline(always)]
    pub fn max(self, o: Self) -> Self {
        V3 { x: self.x.max(o.x), y: self.y.max(o.y), z: self.z.max(o.z) }
    }

    /// Componentwise minimum.
    #[inline(always)]
    pub fn min(self, o: Self) -> Self {
        V3 { x: self.x.min(o.x), y: self.y.min(o.y), z: self.z.min(o.z) }
    }

    #[inline(always)]
    pub fn dot(self, o: Self) -> Wide<S> {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    #[inline(always)]
    pub fn cross(self, o: Self) -> Self {
        V3 { x: self.y * o.z - o.y * self.z, y: self.z * o.x - o.z * self.x, z: self.x * o.y - o.x * self.y }
    }

    #[inline(always)]
    pub fn length(self) -> Wide<S> {
        self.dot(self).sqrt()
    }

    /// Per lane: `self` scaled to unit length, or `fallback` where it has none (zero,
    /// infinite or NaN), as glam's `normalize_or`.
    #[inline(always)]
    pub fn normalize_or(self, fallback: Self) -> Self {
        let recip = self.length().recip();
        let ok = recip.is_finite_mask() & recip.cmpgt(Wide::zero());
        V3::select(ok, self * recip, fallback)
    }

    /// Per lane: `self` shortened to at most `max`, as glam's `clamp_length_max`.
    #[inline(always)]
    pub fn clamp_length_max(self, max: Wide<S>) -> Self {
        let squared = self.dot(self);
        let long = squared.cmpgt(max * max);
        V3::select(long, self * (max / squared.sqrt()), self)
    }

    /// Per lane: `a` where `mask` is set, else `b`.
    #[inline(always)]
    pub fn select(mask: Mask<S>, a: Self, b: Self) -> Self {
        V3 { x: Wide::select(mask, a.x, b.x), y: Wide::select(mask, a.y, b.y), z: Wide::select(mask, a.z, b.z) }
    }
}

impl<S: Simd> Add for V3<S> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        V3 { x: self.x + o.x, y: self.y + o.y, z: self.z + o.z }
    }
}

impl<S: Simd> Sub for V3<S> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        V3 { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }
}

impl<S: Simd> Neg for V3<S> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        V3 { x: -self.x, y: -self.y, z: -self.z }
    }
}

/// Each lane scaled by its own factor.
impl<S: Simd> Mul<Wide<S>> for V3<S> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, s: Wide<S>) -> Self {
        V3 { x: self.x * s, y: self.y * s, z: self.z * s }
    }
}

impl<S: Simd> AddAssign for V3<S> {
    #[inline(always)]
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}

impl<S: Simd> SubAssign for V3<S> {
    #[inline(always)]
    fn sub_assign(&mut self, o: Self) {
        *self = *self - o;
    }
}

/// A 3×3 matrix per lane, by columns.
#[derive(Debug)]
pub(super) struct M3<S: Simd> {
    pub x_axis: V3<S>,
    pub y_axis: V3<S>,
    pub z_axis: V3<S>,
}

impl<S: Simd> Clone for M3<S> {
    #[inline(always)]
    fn clone(&self) -> Self {
        *self
    }
}
impl<S: Simd> Copy for M3<S> {}

impl<S: Simd> M3<S> {
    /// Lane `l` from `f(l)`.
    #[inline(always)]
    pub fn from_fn(mut f: impl FnMut(usize) -> Mat3A) -> Self {
        let mut columns = [[Vec3::ZERO; MAX_LANES]; 3];
        for l in 0..Wide::<S>::LANES {
            let m = f(l);
            for (c, column) in columns.iter_mut().enumerate() {
                column[l] = m.col(c).into();
            }
        }
        let [x_axis, y_axis, z_axis] = columns.map(|c| V3::from_fn(|l| c[l]));
        M3 { x_axis, y_axis, z_axis }
    }

    /// The same matrix in every lane.
    #[inline(always)]
    pub fn splat(m: Mat3A) -> Self {
        M3 {
            x_axis: V3::splat(m.x_axis.into()),
            y_axis: V3::splat(m.y_axis.into()),
            z_axis: V3::splat(m.z_axis.into()),
        }
    }

    #[inline(always)]
    pub fn mul_vec(&self, v: V3<S>) -> V3<S> {
        self.x_axis * v.x + self.y_axis * v.y + self.z_axis * v.z
    }

    #[inline(always)]
    pub fn mul_mat(&self, o: &Self) -> Self {
        M3 { x_axis: self.mul_vec(o.x_axis), y_axis: self.mul_vec(o.y_axis), z_axis: self.mul_vec(o.z_axis) }
    }

    /// The shortest-arc rotation taking unit `from` onto unit `to`, per lane (Rodrigues):
    /// `R = c·I + [v]× + v·vᵀ/(1 + c)` with `v = from × to`, `c = from · to`. Unlike the
    /// quaternion form it needs no square root, and it is orthonormal to rounding, so a
    /// frame chained along a strand needs no renormalising.
    #[inline(always)]
    pub fn rotation_arc(from: V3<S>, to: V3<S>) -> Self {
        let c = from.dot(to);
        let v = from.cross(to);
        let kv = v * (Wide::one() + c).recip();
        let mut m = M3 {
            x_axis: V3 { x: c, y: v.z, z: -v.y } + kv * v.x,
            y_axis: V3 { x: -v.z, y: c, z: v.x } + kv * v.y,
            z_axis: V3 { x: v.y, y: -v.x, z: c } + kv * v.z,
        };
        // Nearly opposite: the axis is ill-defined; the quaternion form picks one.
        let opposite = c.cmplt(Wide::splat(-0.999)).bitmask();
        if opposite != 0 {
            for l in (0..Wide::<S>::LANES).filter(|l| opposite & (1 << l) != 0) {
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
#[derive(Debug)]
pub(super) struct PoseLanes<S: Simd> {
    rotation: M3<S>,
    /// The inverse rotation (its transpose).
    inverse: M3<S>,
    translation: V3<S>,
}

impl<S: Simd> PoseLanes<S> {
    #[inline(always)]
    pub fn new(rotation: Mat3A, translation: Vec3A) -> Self {
        PoseLanes {
            rotation: M3::splat(rotation),
            inverse: M3::splat(rotation.transpose()),
            translation: V3::splat(translation.into()),
        }
    }

    /// Head-local points → world.
    #[inline(always)]
    pub fn world_point(&self, p: V3<S>) -> V3<S> {
        self.rotation.mul_vec(p) + self.translation
    }

    /// World points → head-local.
    #[inline(always)]
    pub fn local_point(&self, p: V3<S>) -> V3<S> {
        self.inverse.mul_vec(p - self.translation)
    }
}

#[cfg(test)]
mod tests;
