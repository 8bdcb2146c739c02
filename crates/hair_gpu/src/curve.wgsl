// The strand curve's geometry, shared by the solver crate's drawing pass (`draw.wgsl`,
// prepended to it) and bevy_hair's material (imported as `bevy_hair::curve`, the import
// path added when the plugin loads it). Each function mirrors the Rust function in
// `hair_sim::groom::curve` named beside it; those are the unit-tested reference.

// Mirrors `hair_sim::groom::curve::unit_or`.
fn unit_or(v: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    let len2 = dot(v, v);
    if len2 > 1e-20 && len2 < 3.4e38 {
        return v * inverseSqrt(len2);
    }
    return fallback;
}

// Mirrors `hair_sim::groom::curve::fallback_axis`.
fn fallback_axis(axis: vec3<f32>) -> vec3<f32> {
    var world = vec3(0.0, 1.0, 0.0);
    if abs(axis.x) < 0.9 {
        world = vec3(1.0, 0.0, 0.0);
    }
    return unit_or(world - axis * dot(axis, world), vec3(0.0, 0.0, 1.0));
}

// Mirrors `hair_sim::groom::curve::perpendicular_unit`.
fn perpendicular_unit(v: vec3<f32>, axis: vec3<f32>) -> vec3<f32> {
    return unit_or(v - axis * dot(axis, v), fallback_axis(axis));
}

struct CurvePoint {
    position: vec3<f32>,
    tangent: vec3<f32>,
}

// Mirrors `hair_sim::groom::curve::evaluate` within one segment (with `bezier_controls`
// inlined): the C1 Catmull-Rom Bézier from `p0` to `p1`, with their neighbours `prev` and
// `next`, at `t` in 0..1.
fn bezier_point(prev: vec3<f32>, p0: vec3<f32>, p1: vec3<f32>, next: vec3<f32>, t: f32) -> CurvePoint {
    let c0 = p0;
    let c1 = p0 + (p1 - prev) / 6.0;
    let c2 = p1 - (next - p0) / 6.0;
    let c3 = p1;
    let r = 1.0 - t;
    var out: CurvePoint;
    out.position = c0 * (r * r * r) + c1 * (3.0 * r * r * t) + c2 * (3.0 * r * t * t) + c3 * (t * t * t);
    let derivative = (c1 - c0) * (3.0 * r * r) + (c2 - c1) * (6.0 * r * t) + (c3 - c2) * (3.0 * t * t);
    out.tangent = unit_or(derivative, unit_or(c3 - c0, vec3(0.0, 1.0, 0.0)));
    return out;
}

// Mirrors `hair_sim::groom::curve::transport`: `v` carried from tangent `a` to tangent `b`
// by the minimal rotation between them (left as it is when they are near opposite), made
// perpendicular to `b`.
fn transport(v: vec3<f32>, a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    let k = cross(a, b);
    let c = dot(a, b);
    var rotated = v;
    if 1.0 + c > 1e-4 {
        rotated = v * c + cross(k, v) + k * (dot(k, v) / (1.0 + c));
    }
    return perpendicular_unit(rotated, b);
}
