// --- The skin that moves against the head: hair_sim's `SurfacePatch::resolve` ---

struct PatchContact {
    hit: bool,
    position: vec3<f32>,
    normal: vec3<f32>,
    depth: f32,
}

fn patch_u32(start: u32, k: u32) -> u32 {
    return colliders[start + k / 4u][k % 4u];
}

// The point of triangle `a b c` closest to `p` (Ericson, Real-Time Collision Detection
// 5.1.5), and where it lies: 0 the face, 1–3 corner a, b, c, 4–6 edge ab, bc, ca.
struct OnTriangle {
    point: vec3<f32>,
    feature: u32,
}

// Where a triangle's ten-vec4 record (corners, face normal, edge normals ab bc ca, corner
// normals a b c) holds the normal of `OnTriangle` feature `feature`.
fn feature_slot(feature: u32) -> u32 {
    if feature >= 4u {
        return feature; // an edge
    }
    if feature >= 1u {
        return 6u + feature; // a corner
    }
    return 3u; // the face
}

fn closest_on_triangle(p: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> OnTriangle {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return OnTriangle(a, 1u);
    }
    let bp = p - b;
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return OnTriangle(b, 2u);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return OnTriangle(a + ab * (d1 / (d1 - d3)), 4u);
    }
    let cp = p - c;
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return OnTriangle(c, 3u);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return OnTriangle(a + ac * (d2 / (d2 - d6)), 6u);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return OnTriangle(b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))), 5u);
    }
    let denominator = 1.0 / (va + vb + vc);
    return OnTriangle(a + ab * (vb * denominator) + ac * (vc * denominator), 0u);
}

// Where the moving skin pushes head-local `p`: out to the shell along the normal at its
// closest point, if `p` is behind that normal or within the shell, within the patch's
// reach.
fn patch_contact(p: vec3<f32>) -> PatchContact {
    let none = PatchContact(false, p, vec3<f32>(0.0), 0.0);
    let thickness = step.limits.y;
    if step.skin.x == 0u {
        return none;
    }
    let header = step.skin.x - 1u;
    let origin = collider(header).xyz;
    let reach = collider(header).w;
    let dims = colliders[header + 1u].xyz;
    let cell = collider(header + 1u).w;
    if thickness > reach {
        return none;
    }
    let c = (p - origin) / cell;
    if !(all(c >= vec3<f32>(0.0)) && all(c < vec3<f32>(dims))) {
        return none;
    }
    let bin = vec3<u32>(c);
    let index = (bin.z * dims.y + bin.y) * dims.x + bin.x;
    var best_distance = 3.4e38;
    var best = OnTriangle(p, 0u);
    var best_triangle = 0u;
    for (var k = patch_u32(step.skin.z, index); k < patch_u32(step.skin.z, index + 1u); k++) {
        let t = patch_u32(step.skin.w, k);
        let base = step.skin.y + 10u * t;
        let on = closest_on_triangle(p, collider(base).xyz, collider(base + 1u).xyz, collider(base + 2u).xyz);
        let d = dot(p - on.point, p - on.point);
        if d < best_distance {
            best_distance = d;
            best = on;
            best_triangle = base;
        }
    }
    if best_distance > 3.0e38 {
        return none;
    }
    let distance = sqrt(best_distance);
    if distance > reach {
        return none;
    }
    // The face's normal, an edge's (the two faces'), or a corner's: the feature's.
    let normal = collider(best_triangle + feature_slot(best.feature)).xyz;
    let offset = p - best.point;
    var signed = distance;
    if dot(offset, normal) < 0.0 {
        signed = -distance;
    }
    if signed >= thickness || all(normal == vec3<f32>(0.0)) {
        return none;
    }
    var out = normal;
    if distance > 1e-7 {
        out = offset / signed;
    }
    return PatchContact(true, best.point + out * thickness, out, thickness - signed);
}
