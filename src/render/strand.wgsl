// The strand functions of bevy_hair's material, importable as `bevy_hair::strand` (by
// `hair.wgsl`, which holds the entry points, and by a custom hair shader).
//
// Only guide particles travel to the GPU: `particles` holds one vec4 per guide particle,
// then one vec4 per particle with its parallel-transport frame vector `u` (written by the
// CPU, in one pass per guide instead of every vertex walking its strand from the root, or
// on the GPU by `hair_gpu`'s drawing pass for a groom the GPU steps); `guides` holds one
// vec4 per guide with the scalp's normal and curvature at its root, then the head's
// centre, then the order the strands' pieces are drawn in, then the deep opacity maps.
// Every vertex of the static strand mesh knows its drawn piece, child and curve sample
// (`HairVertex`); from those `strand_point` evaluates the
// Bézier curve through the guide, offsets children along the Archimedean spiral in the
// guide's frame, and widens the curve into a ribbon facing the camera. The shading lobes
// (Kajiya-Kay, Marschner) follow.
//
// The geometry functions mirror Rust functions in `hair_sim::groom` (named in their
// comments): those are the unit-tested reference, and `tests/render.rs` renders the result.
// The curve's own geometry is `bevy_hair::curve` (`crates/hair_gpu/src/curve.wgsl`), which
// the GPU solver's drawing pass shares.

#define_import_path bevy_hair::strand

#import bevy_hair::curve::{CurvePoint, bezier_point, perpendicular_unit, unit_or}

struct HairUniform {
    root_color: vec4<f32>,
    tip_color: vec4<f32>,
    primary_color: vec4<f32>,
    secondary_color: vec4<f32>,
    primary_exponent: f32,
    primary_shift: f32,
    secondary_exponent: f32,
    secondary_shift: f32,
    // The Archimedean spiral r = scale (a + b θ), θ = (child + 1) angle_step.
    spiral_a: f32,
    spiral_b: f32,
    spiral_angle_step: f32,
    spiral_scale: f32,
    clumping: f32,
    tip_spread: f32,
    root_width: f32,
    tip_width: f32,
    tint_variation: f32,
    diffuse: f32,
    // HAIR_FLAGS_* bits.
    flags: u32,
    guides: u32,
    particles: u32,
    // The guide and its children.
    strands_per_guide: u32,
    subdivisions: u32,
    // Marschner: longitudinal roughness and cuticle tilt (radians).
    roughness: f32,
    cuticle_tilt: f32,
    // How much light one layer of fibres stops, per layer (0: no self-shadowing).
    self_shadow: f32,
}

// Mirror `bevy_hair::render::HairUniform::RECEIVE_SHADOWS`, `MARSCHNER`, `ANTIALIAS` and
// `BLENDED`.
const HAIR_FLAGS_RECEIVE_SHADOWS: u32 = 1u;
const HAIR_FLAGS_MARSCHNER: u32 = 2u;
const HAIR_FLAGS_ANTIALIAS: u32 = 4u;
const HAIR_FLAGS_BLENDED: u32 = 8u;

@group(#{MATERIAL_BIND_GROUP}) @binding(0) var<storage, read> guides: array<vec4<f32>>;
@group(#{MATERIAL_BIND_GROUP}) @binding(1) var<uniform> hair: HairUniform;
@group(#{MATERIAL_BIND_GROUP}) @binding(2) var<storage, read> particles: array<vec4<f32>>;

const PI: f32 = 3.14159265;

fn particle(guide: u32, i: u32) -> vec3<f32> {
    return particles[guide * hair.particles + i].xyz;
}

// The transport frame vector `u` of particle `i` (`hair_sim::groom::transport_frames`).
fn frame_u(guide: u32, i: u32) -> vec3<f32> {
    return particles[(hair.guides + guide) * hair.particles + i].xyz;
}

// The scalp at guide `guide`'s root: outward normal (xyz) and curvature (w, 1/m).
fn root_scalp(guide: u32) -> vec4<f32> {
    return guides[guide];
}

// A point inside the head (`hair_sim::groom::ChildRoot::head_centre`).
fn head_centre() -> vec3<f32> {
    return guides[hair.guides].xyz;
}

// Guide segments per drawn piece of a strand. Mirrors
// `bevy_hair::render::SEGMENTS_PER_PIECE`.
const SEGMENTS_PER_PIECE: u32 = 2u;

// Pieces per strand (`StrandLayout::pieces`).
fn pieces() -> u32 {
    return (hair.particles - 1u + SEGMENTS_PER_PIECE - 1u) / SEGMENTS_PER_PIECE;
}

// The order the strands' pieces are drawn in follows the head's centre, four per vec4,
// each `guide · pieces + piece`: back to front when the strands are blended, else as grown.
fn order_start() -> u32 {
    return hair.guides + 1u;
}

// The piece drawn `slot`th.
fn drawn_piece(slot: u32) -> u32 {
    return u32(guides[order_start() + slot / 4u][slot % 4u]);
}

// The deep opacity maps follow the draw order: their count, then per map a header of
// `MAP_HEADER` vec4s, each cell's nearest strand, and its coverage, four values per vec4
// (`hair_sim::shadow`). Mirror `hair_sim::shadow::MAP_SIZE` and `MAP_LAYERS`.
const MAP_SIZE: i32 = 32;
const MAP_LAYERS: i32 = 16;
const MAP_HEADER: u32 = 5u;
const MAP_CELLS: u32 = 32u * 32u;
const MAP_STRIDE: u32 = 5u + 32u * 32u / 4u + 32u * 32u * 16u / 4u;

fn maps_start() -> u32 {
    return order_start() + (hair.guides * pieces() + 3u) / 4u;
}

fn map_header(map: u32, k: u32) -> vec4<f32> {
    return guides[maps_start() + 1u + map * MAP_STRIDE + k];
}

// Value `i` of map `map`'s tables (the nearest strands, then the coverage).
fn map_value(map: u32, i: u32) -> f32 {
    return guides[maps_start() + 1u + map * MAP_STRIDE + MAP_HEADER + i / 4u][i % 4u];
}

// Mirrors `hair_sim::shadow::OpacityMap::coverage_at`: the layers of fibres between `p`
// and map `map`'s light, in each of the four cells around it a slice before `p`'s.
fn coverage_at(map: u32, p: vec3<f32>) -> f32 {
    let source = map_header(map, 0u);
    let right = map_header(map, 1u);
    let up = map_header(map, 2u);
    let forward = map_header(map, 3u);
    let first_layer = map_header(map, 4u).x;
    var uvd: vec3<f32>;
    if source.w == 0.0 {
        uvd = vec3(dot(p, right.xyz), dot(p, up.xyz), dot(p, forward.xyz));
    } else {
        let d = p - source.xyz;
        let along = dot(d, forward.xyz);
        if along <= 1e-4 {
            return 0.0;
        }
        uvd = vec3(dot(d, right.xyz) / along, dot(d, up.xyz) / along, length(d));
    }
    let g = vec2((uvd.x - right.w) * forward.w, (uvd.y - up.w) * forward.w);
    let g0 = floor(g);
    let f = g - g0;
    var sum = 0.0;
    for (var dy = 0; dy < 2; dy++) {
        for (var dx = 0; dx < 2; dx++) {
            let x = i32(g0.x) + dx;
            let y = i32(g0.y) + dy;
            if x < 0 || y < 0 || x >= MAP_SIZE || y >= MAP_SIZE {
                continue;
            }
            let cell = u32(y * MAP_SIZE + x);
            // `OpacityMap::slice_coordinate`, less the slice that keeps a strand off itself.
            let behind = (uvd.z - map_value(map, cell)) / first_layer;
            if !(behind >= 0.0) {
                continue;
            }
            let z = 0.5 * (sqrt(1.0 + 8.0 * behind) - 1.0) - 1.0;
            let z0 = floor(z);
            let fz = z - z0;
            let weight = select(1.0 - f.x, f.x, dx == 1) * select(1.0 - f.y, f.y, dy == 1);
            for (var dz = 0; dz < 2; dz++) {
                let layer = i32(z0) + dz;
                if layer >= 0 {
                    let coverage = map_value(map, MAP_CELLS + u32(min(layer, MAP_LAYERS - 1)) * MAP_CELLS + cell);
                    sum += coverage * weight * select(1.0 - fz, fz, dz == 1);
                }
            }
        }
    }
    return sum;
}

// The light left at `p` after the hair between it and a light: that light's map (found by
// its direction, `kind` 0, or its position, `kind` 1), `exp(−self_shadow · coverage)`; 1
// without self-shadowing or a map.
fn self_shadow(kind: f32, source: vec3<f32>, p: vec3<f32>) -> f32 {
    if hair.self_shadow <= 0.0 {
        return 1.0;
    }
    let count = u32(guides[maps_start()].x);
    for (var map = 0u; map < count; map++) {
        let header = map_header(map, 0u);
        let same = select(distance(header.xyz, source) < 1e-3, dot(header.xyz, source) > 0.99999, kind == 0.0);
        if header.w == kind && same {
            return exp(-hair.self_shadow * coverage_at(map, p));
        }
    }
    return 1.0;
}

// Mirrors `hair_sim::groom::curve::particle`: neighbours past either end mirrored.
fn neighbour(guide: u32, i: i32) -> vec3<f32> {
    let n = i32(hair.particles);
    if i < 0 {
        return 2.0 * particle(guide, 0u) - particle(guide, 1u);
    }
    if i >= n {
        return 2.0 * particle(guide, u32(n - 1)) - particle(guide, u32(n - 2));
    }
    return particle(guide, u32(i));
}

// Mirrors `hair_sim::groom::curve::evaluate`: the C1 Catmull-Rom Bézier through the guide
// particles at `s` in particle units, [0, n - 1].
fn evaluate(guide: u32, s_in: f32) -> CurvePoint {
    let last = f32(hair.particles - 1u);
    let s = clamp(s_in, 0.0, last);
    let i = i32(min(floor(s), last - 1.0));
    let t = s - f32(i);
    return bezier_point(neighbour(guide, i - 1), neighbour(guide, i), neighbour(guide, i + 1), neighbour(guide, i + 2), t);
}

// Mirrors `hair_sim::groom::curve::frame_at`: the frame (u, v) at `s`.
fn frame_at(guide: u32, s_in: f32, tangent: vec3<f32>) -> mat2x3<f32> {
    let last = f32(hair.particles - 1u);
    let s = clamp(s_in, 0.0, last);
    let j = u32(min(floor(s), last - 1.0));
    let u = perpendicular_unit(mix(frame_u(guide, j), frame_u(guide, j + 1u), s - f32(j)), tangent);
    return mat2x3<f32>(u, cross(tangent, u));
}

// Mirrors `hair_sim::groom::children::pcg_hash`.
fn pcg_hash(x: u32) -> u32 {
    let state = x * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Mirrors `hair_sim::groom::children::hash_unit`.
fn hash_unit(x: u32) -> f32 {
    return f32(pcg_hash(x) >> 8u) / 16777216.0;
}

// Mirrors `hair_sim::groom::children::spiral_offset`: x = (a + bθ) cos θ, y = (a + bθ) sin θ.
fn spiral_offset(child: u32) -> vec2<f32> {
    let theta = f32(child + 1u) * hair.spiral_angle_step;
    let radius = hair.spiral_scale * (hair.spiral_a + hair.spiral_b * theta);
    return radius * vec2(cos(theta), sin(theta));
}

// Mirrors `hair_sim::groom::children::child_offset`: the spiral offset pulled toward the
// guide (clumping) and pushed out in a random direction (tip spread) toward the tip.
fn child_offset(guide: u32, child: u32, t: f32) -> vec2<f32> {
    let clumping = hair.clumping;
    let spread = hair.tip_spread;
    let phi = 2.0 * PI * hash_unit(guide * 65536u + child);
    return spiral_offset(child) * (1.0 - clumping * t) + spread * t * t * vec2(cos(phi), sin(phi));
}

// Mirrors `hair_sim::groom::children::MAX_CURVATURE`.
const MAX_CURVATURE: f32 = 100.0;

// Mirrors `hair_sim::groom::children::scalp_offset`: the offset in the scalp's tangent
// plane, bent onto the scalp by its curvature.
fn scalp_offset(scalp: vec4<f32>, u: vec3<f32>, offset: vec2<f32>) -> vec3<f32> {
    let normal = unit_or(scalp.xyz, vec3(0.0, 1.0, 0.0));
    let across = perpendicular_unit(u, normal);
    // The CPU passes finite curvature; clamp as the reference does.
    let curvature = clamp(scalp.w, -MAX_CURVATURE, MAX_CURVATURE);
    return across * offset.x + cross(normal, across) * offset.y
        - normal * (0.5 * curvature * dot(offset, offset));
}

// Mirrors `hair_sim::groom::children::on_scalp`.
fn on_scalp(s_in: f32) -> f32 {
    let s = clamp(s_in, 0.0, 1.0);
    return 1.0 - s * s * (3.0 - 2.0 * s);
}

// Mirrors `hair_sim::groom::children::outside_only`.
fn outside_only(offset: vec3<f32>, at: vec3<f32>, scalp: vec4<f32>) -> vec3<f32> {
    let out = unit_or(at - head_centre(), unit_or(scalp.xyz, vec3(0.0, 1.0, 0.0)));
    return offset - out * min(dot(offset, out), 0.0);
}

// A point of a rendered strand: on the curve (guide) or offset around it (child), moved
// across the strand to one side of a ribbon that faces `camera` and tapers root → tip.
struct StrandPoint {
    position: vec3<f32>,
    tangent: vec3<f32>,
    // ribbon direction across the strand
    across: vec3<f32>,
    // root → tip parameter
    t: f32,
    // ribbon width, metres
    width: f32,
    // -1 or 1: which edge of the ribbon
    side: f32,
    // the rendered strand (guide * strands per guide + child), whatever the draw order
    strand: u32,
}

fn strand_point(hair_vertex: vec2<u32>, camera: vec3<f32>) -> StrandPoint {
    let per_guide = hair.strands_per_guide;
    let piece = drawn_piece(hair_vertex.x / per_guide);
    let guide = piece / pieces();
    let child = hair_vertex.x % per_guide; // 0 is the guide itself
    // The last piece's samples past the tip fold onto it (empty triangles).
    let first_sample = (piece % pieces()) * SEGMENTS_PER_PIECE * hair.subdivisions;
    let sample_index = min(first_sample + (hair_vertex.y >> 1u), (hair.particles - 1u) * hair.subdivisions);
    let side = f32(hair_vertex.y & 1u) * 2.0 - 1.0;
    let s = f32(sample_index) / f32(hair.subdivisions);
    let t = s / f32(hair.particles - 1u);

    let curve = evaluate(guide, s);
    var position = curve.position;
    if child > 0u {
        // Mirrors `hair_sim::groom::children::child_curve`.
        let frame = frame_at(guide, s, curve.tangent);
        let offset = child_offset(guide, child - 1u, t);
        let scalp = root_scalp(guide);
        let along_guide = outside_only(offset.x * frame[0] + offset.y * frame[1], curve.position, scalp);
        let w = on_scalp(s);
        position += scalp_offset(scalp, frame_u(guide, 0u), offset) * w + along_guide * (1.0 - w);
    }

    // In the shadow pass the "camera" is the light: the ribbon faces it and casts its width.
    let to_camera = unit_or(camera - position, vec3(0.0, 0.0, 1.0));
    let across = perpendicular_unit(cross(curve.tangent, to_camera), curve.tangent);
    let width = mix(hair.root_width, hair.tip_width, t);
    var out: StrandPoint;
    out.position = position + across * side * 0.5 * width;
    out.tangent = curve.tangent;
    out.across = across;
    out.t = t;
    out.width = width;
    out.side = side;
    out.strand = guide * per_guide + child;
    return out;
}

// Kajiya-Kay diffuse: proportional to sin(T, L), zero when the light runs along the strand.
fn kajiya_diffuse(tangent: vec3<f32>, to_light: vec3<f32>) -> f32 {
    let c = dot(tangent, to_light);
    return sqrt(max(1.0 - c * c, 0.0));
}

// Kajiya-Kay specular in Scheuermann's form: sin(T, H)^exponent, faded when the light is
// behind the strand.
fn kajiya_specular(tangent: vec3<f32>, half_vector: vec3<f32>, exponent: f32) -> f32 {
    let c = dot(tangent, half_vector);
    let sin_th = sqrt(max(1.0 - c * c, 0.0));
    return smoothstep(-1.0, 0.0, c) * pow(sin_th, exponent);
}

// Scheuermann's shifted tangent: moves the highlight toward the root or the tip.
fn shifted_tangent(tangent: vec3<f32>, normal: vec3<f32>, shift: f32) -> vec3<f32> {
    return normalize(tangent + shift * normal);
}

// A normalised Gaussian of standard deviation `width`, at `x`.
fn gaussian(width: f32, x: f32) -> f32 {
    return exp(-0.5 * x * x / (width * width)) / (sqrt(2.0 * PI) * width);
}

// Schlick's Fresnel for a hair fibre (index of refraction 1.55).
fn fibre_fresnel(cos_theta: f32) -> f32 {
    let f0 = 0.0465;
    return f0 + (1.0 - f0) * pow(1.0 - saturate(cos_theta), 5.0);
}

// Marschner et al.'s three lobes in Karis' real-time form ("Physically Based Hair Shading
// in Unreal", 2016): R, the white reflection off the cuticle; TT, light through the fibre
// (the glow of back-lit hair); TRT, the coloured highlight reflected inside it. Each is a
// longitudinal Gaussian around the specular cone, shifted by the cuticle tilt, times an
// azimuthal term in the angle between light and view around the strand.
fn marschner(tangent: vec3<f32>, to_view: vec3<f32>, to_light: vec3<f32>, albedo: vec3<f32>) -> vec3<f32> {
    let sin_l = clamp(dot(tangent, to_light), -1.0, 1.0);
    let sin_v = clamp(dot(tangent, to_view), -1.0, 1.0);
    let cos_d = max(cos(0.5 * abs(asin(sin_v) - asin(sin_l))), 1e-3);
    let across_l = to_light - sin_l * tangent;
    let across_v = to_view - sin_v * tangent;
    let cos_phi = clamp(dot(across_l, across_v) * inverseSqrt(max(dot(across_l, across_l) * dot(across_v, across_v), 1e-12)), -1.0, 1.0);
    let cos_half_phi = sqrt(saturate(0.5 + 0.5 * cos_phi));
    let width = max(hair.roughness * hair.roughness, 1e-3);
    let tilt = hair.cuticle_tilt;

    // R: shifted back by twice the tilt, widening where the azimuth opens.
    let s = sin(-2.0 * tilt);
    let c = cos(-2.0 * tilt);
    let shift = 2.0 * s * (c * cos_half_phi * sqrt(max(1.0 - sin_v * sin_v, 0.0)) + s * sin_v);
    let r = gaussian(width * sqrt(2.0) * max(cos_half_phi, 1e-3), sin_l + sin_v - shift) * 0.25 * cos_half_phi
        * fibre_fresnel(sqrt(saturate(0.5 + 0.5 * dot(to_light, to_view))));

    // TT: through the fibre, coloured by two passes of its absorption.
    let refracted = 1.0 / (1.19 / cos_d + 0.36 * cos_d);
    let h = cos_half_phi * (1.0 + refracted * (0.6 - 0.8 * cos_phi));
    let f_tt = fibre_fresnel(cos_d * sqrt(saturate(1.0 - h * h)));
    let absorbed_tt = pow(albedo, vec3(0.5 * sqrt(max(1.0 - h * h * refracted * refracted, 0.0)) / cos_d));
    let tt = gaussian(0.5 * width, sin_l + sin_v - tilt) * exp(-3.65 * cos_phi - 3.98) * (1.0 - f_tt) * (1.0 - f_tt)
        * absorbed_tt;

    // TRT: reflected once inside.
    let f_trt = fibre_fresnel(0.5 * cos_d);
    let trt = gaussian(2.0 * width, sin_l + sin_v - 4.0 * tilt) * exp(17.0 * cos_phi - 16.78)
        * (1.0 - f_trt) * (1.0 - f_trt) * f_trt * pow(albedo, vec3(0.8 / cos_d));

    return hair.primary_color.rgb * r + tt + trt;
}

// What one strand returns toward the viewer of light arriving from `to_light`, per unit
// of the light's radiance: diffuse as Kajiya-Kay, and the highlights of the chosen model
// (Scheuermann's two shifted Kajiya-Kay lobes, or Marschner's three).
fn strand_response(tangent: vec3<f32>, normal: vec3<f32>, to_view: vec3<f32>, to_light: vec3<f32>,
    albedo: vec3<f32>) -> vec3<f32> {
    if (hair.flags & HAIR_FLAGS_MARSCHNER) != 0u {
        return hair.diffuse * albedo * kajiya_diffuse(tangent, to_light) / PI + marschner(tangent, to_view, to_light, albedo);
    }
    let half_vector = normalize(to_light + to_view);
    let diffuse = hair.diffuse * albedo * kajiya_diffuse(tangent, to_light) / PI;
    let primary = hair.primary_color.rgb
        * kajiya_specular(shifted_tangent(tangent, normal, hair.primary_shift), half_vector, hair.primary_exponent);
    let secondary = hair.secondary_color.rgb * albedo
        * kajiya_specular(shifted_tangent(tangent, normal, hair.secondary_shift), half_vector, hair.secondary_exponent);
    return diffuse + primary + secondary;
}

// The samples a strand of coverage `coverage` takes in each pixel: each with that
// probability, chosen by the strand and the sample (the same in every pixel and frame, so
// nothing flickers), so that many strands together cover their true share (stochastic
// alpha-to-coverage).
fn coverage_samples(strand: u32, coverage: f32) -> u32 {
    if coverage >= 1.0 {
        return 0xffffffffu;
    }
    var mask = 0u;
    for (var sample = 0u; sample < 8u; sample++) {
        if hash_unit(strand * 8u + sample + 0x9e3779b9u) < coverage {
            mask |= 1u << sample;
        }
    }
    return mask;
}
