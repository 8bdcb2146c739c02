use super::*;

fn sample(i: usize) -> Vec3 {
    let f = i as f32 * 0.61;
    Vec3::new(f.sin(), (f * 1.7).cos(), (f * 0.3).sin() - 0.2)
}

/// Runs a generic test on every path this CPU has. Outside the dispatching step the
/// wider paths' intrinsics are called rather than inlined: slower, the same results.
macro_rules! on_every_path {
    ($test:ident) => {
        $test::<Baseline>();
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                $test::<Avx2>();
            }
            if std::arch::is_x86_feature_detected!("avx512f") {
                $test::<Avx512>();
            }
        }
    };
}

#[test]
fn lanes_compute_what_glam_computes_per_vector() {
    on_every_path!(lanes_compute_what_glam_computes);
}

fn lanes_compute_what_glam_computes<S: Simd>() {
    let lanes = Wide::<S>::LANES;
    let va: Vec<Vec3> = (0..lanes).map(sample).collect();
    let mut vb: Vec<Vec3> = (0..lanes).map(|l| sample(l + 7) * 3.0).collect();
    vb[3] = Vec3::new(0.0, f32::NAN, -0.0);
    let (a, b) = (V3::<S>::from_lanes(&va), V3::<S>::from_lanes(&vb));
    // Bits, but any NaN as one: LLVM keeps no NaN's sign or payload through its rewrites
    // (in one build `a - b` of a NaN `b` came out as `a + (-b)`'s negative NaN).
    let bit = |x: f32| if x.is_nan() { f32::NAN.to_bits() } else { x.to_bits() };
    let bits = |v: Vec3| v.to_array().map(bit);
    for l in 0..lanes {
        let (va, vb) = (va[l], vb[l]);
        assert_eq!(a.lane(l), va, "lane {l}");
        // Bit for bit, as the paths promise one another.
        assert_eq!(bits((a + b).lane(l)), bits(va + vb), "lane {l}");
        assert_eq!(bits((a - b).lane(l)), bits(va - vb), "lane {l}");
        assert_eq!(bits((-b).lane(l)), bits(-vb), "lane {l}");
        assert_eq!(bits(a.cross(b).lane(l)), bits(va.cross(vb)), "lane {l}");
        assert_eq!(bit(a.dot(b).get(l)), bit(va.dot(vb)), "lane {l}");
        assert_eq!(bit(a.length().get(l)), bit(va.length()), "lane {l}");
        assert_eq!(bit((a.x / b.x).get(l)), bit(va.x / vb.x), "lane {l}");
        assert_eq!(bits(a.max(b).lane(l)), bits(Vec3::from(glam::Vec3A::from(va).max(vb.into()))), "lane {l}");
        assert_eq!(bits(a.min(b).lane(l)), bits(Vec3::from(glam::Vec3A::from(va).min(vb.into()))), "lane {l}");
        assert!((a.normalize_or(V3::zero()).lane(l) - va.normalize()).length() < 1e-6);
        assert!((b.clamp_length_max(Wide::splat(1.0)).lane(l) - vb.clamp_length_max(1.0)).length() < 1e-6 || l == 3);
        assert_eq!(a.x.cmpgt(b.x).bitmask() >> l & 1 == 1, va.x > vb.x, "lane {l}");
        assert_eq!(a.y.cmplt(b.y).bitmask() >> l & 1 == 1, va.y < vb.y, "lane {l}");
        assert_eq!(a.y.cmpne(b.y).bitmask() >> l & 1 == 1, va.y != vb.y, "lane {l}: NaN is unequal");
    }
    let zero_or = V3::<S>::zero().normalize_or(V3::splat(Vec3::NEG_Y));
    assert_eq!(zero_or.lane(2), Vec3::NEG_Y, "a zero vector takes the fallback");
    let nan = V3::<S>::splat(Vec3::NAN).normalize_or(V3::splat(Vec3::X));
    assert_eq!(nan.lane(0), Vec3::X, "so does NaN");
    // Masks round-trip through bits, and select picks per lane.
    let pattern = 0x9a5c_3e71_c0de_b00f_u64 & (u64::MAX >> (64 - lanes));
    assert_eq!(Mask::<S>::from_bits(pattern).bitmask(), pattern);
    let picked = Wide::select(Mask::<S>::from_bits(pattern), a.x, b.x);
    for l in 0..lanes {
        let want = if pattern >> l & 1 == 1 { va[l].x } else { vb[l].x };
        assert_eq!(picked.get(l).to_bits(), want.to_bits(), "lane {l}");
    }
}

#[test]
fn rotation_arc_matches_the_quaternion_form() {
    on_every_path!(rotation_arc_matches_quaternions);
}

fn rotation_arc_matches_quaternions<S: Simd>() {
    let lanes = Wide::<S>::LANES;
    for i in 0..200 {
        let from: Vec<Vec3> = (0..lanes).map(|l| sample(i * 4 + l).normalize()).collect();
        let mut to: Vec<Vec3> = (0..lanes)
            .map(|l| {
                let f = (i * 4 + l) as f32;
                Vec3::new((f * 2.3).cos(), f.sin() * 0.5, (f * 1.1).cos()).normalize()
            })
            .collect();
        // One lane exactly opposite, to take the quaternion fallback.
        if i % 10 == 0 {
            to[1] = -from[1];
        }
        let m = M3::<S>::rotation_arc(V3::from_lanes(&from), V3::from_lanes(&to));
        let mapped = m.mul_vec(V3::from_lanes(&from));
        for l in 0..lanes {
            assert!((mapped.lane(l) - to[l]).length() < 1e-4, "{i}/{l}: maps from onto to");
            let q = Mat3A::from_quat(Quat::from_rotation_arc(from[l], to[l]));
            for (axis, column) in [(Vec3A::X, m.x_axis), (Vec3A::Y, m.y_axis), (Vec3A::Z, m.z_axis)] {
                assert!((column.lane(l) - Vec3::from(q * axis)).length() < 1e-3, "{i}/{l}");
            }
        }
    }
}
