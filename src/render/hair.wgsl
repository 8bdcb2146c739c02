// Strand hair: the material's entry points. The vertex shader tessellates guide strands
// into rendered strands (`bevy_hair::strand`, in `strand.wgsl`, holds the geometry and the
// shading lobes); the fragment shader gathers Bevy's lights, shadows and environment map
// and shades each with the chosen hair model.
//
// The same file serves the shadow pass (`PREPASS_PIPELINE`): there only the strand's
// position matters, and the lights, shadows and tonemapping are not bound.

#import bevy_hair::strand::{
    HAIR_FLAGS_ANTIALIAS, HAIR_FLAGS_BLENDED, HAIR_FLAGS_RECEIVE_SHADOWS, coverage_samples, hair, hash_unit, self_shadow,
    strand_point, strand_response,
}
#import bevy_hair::curve::unit_or
#import bevy_pbr::{
    mesh_view_bindings::view,
    view_transformations::position_world_to_clip,
}
#ifndef PREPASS_PIPELINE
#import bevy_pbr::clustered_forward::ClusterableObjectIndexRanges
#import bevy_pbr::{
    clustered_forward as clustering,
    lighting::getDistanceAttenuation,
    mesh_view_bindings::{clustered_lights, lights},
    mesh_view_types::{
        DIRECTIONAL_LIGHT_FLAGS_SHADOWS_ENABLED_BIT, POINT_LIGHT_FLAGS_SHADOWS_ENABLED_BIT,
        POINT_LIGHT_FLAGS_SPOT_LIGHT_Y_NEGATIVE,
    },
    shadows::{fetch_directional_shadow, fetch_point_shadow, fetch_spot_shadow},
}
#ifdef ENVIRONMENT_MAP
#import bevy_pbr::{environment_map, lighting::LayerLightingInput}
#endif
#ifdef TONEMAP_IN_SHADER
#import bevy_core_pipeline::tonemapping::tone_mapping
#endif
#ifdef DISTANCE_FOG
#import bevy_pbr::{
    fog as distance_fog,
    mesh_view_bindings::fog,
    mesh_view_types::{FOG_MODE_ATMOSPHERIC, FOG_MODE_EXPONENTIAL, FOG_MODE_EXPONENTIAL_SQUARED, FOG_MODE_LINEAR},
}
#endif
#endif

struct Vertex {
    // x: drawn piece * strands per guide + child, y: curve sample in the piece * 2 + ribbon side
    @location(0) hair_vertex: vec2<u32>,
};

struct VertexOutput {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) world_position: vec4<f32>,
    @location(1) tangent: vec3<f32>,
    // root → tip parameter
    @location(2) t: f32,
    @location(3) @interpolate(flat) strand: u32,
    // ribbon normal (faces the camera)
    @location(4) normal: vec3<f32>,
    // the share of the drawn ribbon the strand really covers (thinner than a pixel)
    @location(5) coverage: f32,
};


#ifdef PREPASS_PIPELINE

// The shadow pass: depth only.
struct DepthOutput {
    @builtin(position) clip_position: vec4<f32>,
#ifdef UNCLIPPED_DEPTH_ORTHO_EMULATION
    @location(0) unclipped_depth: f32,
#endif
};

@vertex
fn vertex(in: Vertex) -> DepthOutput {
    var out: DepthOutput;
    out.clip_position = position_world_to_clip(strand_point(in.hair_vertex, view.world_position).position);
#ifdef UNCLIPPED_DEPTH_ORTHO_EMULATION
    // As Bevy's prepass does where the GPU cannot disable depth clipping: keep casters
    // behind the light's near plane, and write their true depth.
    out.unclipped_depth = out.clip_position.z;
    out.clip_position.z = min(out.clip_position.z, 1.0);
#endif
    return out;
}

// Defined whether or not the pipeline asks for it: Bevy's shadow pass wants a fragment
// stage for blended materials (`MAY_DISCARD`) even without `PREPASS_FRAGMENT`.
#ifdef UNCLIPPED_DEPTH_ORTHO_EMULATION
@fragment
fn fragment(in: DepthOutput) -> @builtin(frag_depth) f32 {
    return in.unclipped_depth;
}
#else
@fragment
fn fragment(in: DepthOutput) {}
#endif

#else // PREPASS_PIPELINE

@vertex
fn vertex(in: Vertex) -> VertexOutput {
    var point = strand_point(in.hair_vertex, view.world_position);
    var out: VertexOutput;
    out.coverage = 1.0;
    // A ribbon thinner than `least` pixels is drawn that wide, and covers only that share of
    // it: with MSAA a pixel wide, by the share of its samples (alpha-to-coverage), or,
    // blended, two pixels wide, by its opacity. Distant hair keeps its density.
    var least = 0.0;
#ifdef MULTISAMPLED
    if (hair.flags & HAIR_FLAGS_ANTIALIAS) != 0u {
        least = 1.0;
    }
#endif
    if (hair.flags & HAIR_FLAGS_BLENDED) != 0u {
        least = 2.0;
    }
    if least > 0.0 {
        let centre = point.position - point.across * (point.side * 0.5 * point.width);
        let a = position_world_to_clip(centre);
        let b = position_world_to_clip(centre + point.across * point.width);
        let pixels = length((b.xy / b.w - a.xy / a.w) * 0.5 * view.viewport.zw);
        if pixels < least && pixels > 0.0 && a.w > 0.0 && b.w > 0.0 {
            out.coverage = pixels / least;
            point.position = centre + point.across * (point.side * 0.5 * point.width * least / pixels);
        }
    }
    out.clip_position = position_world_to_clip(point.position);
    out.world_position = vec4(point.position, 1.0);
    out.tangent = point.tangent;
    out.t = point.t;
    out.strand = point.strand;
    out.normal = normalize(cross(point.across, point.tangent));
    return out;
}


// Whether this material takes shadows, and the light casts them.
fn receives_shadow(light_flags: u32, light_bit: u32) -> bool {
    return (hair.flags & HAIR_FLAGS_RECEIVE_SHADOWS) != 0u && (light_flags & light_bit) != 0u;
}

// Point and spot lights: the clustered lights of this fragment's cluster (`ranges`),
// attenuated by distance (and cone) as `StandardMaterial` attenuates them.
fn clustered_light(in: VertexOutput, ranges: ClusterableObjectIndexRanges, tangent: vec3<f32>, normal: vec3<f32>,
    to_view: vec3<f32>, albedo: vec3<f32>) -> vec3<f32> {
    var light = vec3(0.0);
    for (var i = ranges.first_point_light_index_offset; i < ranges.first_reflection_probe_index_offset; i++) {
        let id = clustering::get_clusterable_object_id(i);
        let source = &clustered_lights.data[id];
        let to_source = (*source).position_radius.xyz - in.world_position.xyz;
        let to_light = normalize(to_source);
        var radiance = (*source).color_inverse_square_range.rgb
            * getDistanceAttenuation(dot(to_source, to_source), (*source).color_inverse_square_range.w);
        let spot = i >= ranges.first_spot_light_index_offset;
        var shadow = 1.0;
        if spot {
            // The cone, as `bevy_pbr::lighting::spot_light` takes it.
            var direction = vec3((*source).light_custom_data.x, 0.0, (*source).light_custom_data.y);
            direction.y = sqrt(max(0.0, 1.0 - direction.x * direction.x - direction.z * direction.z));
            if ((*source).flags & POINT_LIGHT_FLAGS_SPOT_LIGHT_Y_NEGATIVE) != 0u {
                direction.y = -direction.y;
            }
            let along = saturate(dot(-direction, to_light) * (*source).light_custom_data.z + (*source).light_custom_data.w);
            radiance *= along * along;
            if receives_shadow((*source).flags, POINT_LIGHT_FLAGS_SHADOWS_ENABLED_BIT) {
                shadow = fetch_spot_shadow(id, in.world_position, normal, (*source).shadow_map_near_z, in.clip_position.xy);
            }
        } else if receives_shadow((*source).flags, POINT_LIGHT_FLAGS_SHADOWS_ENABLED_BIT) {
            shadow = fetch_point_shadow(id, in.world_position, normal, in.clip_position.xy);
        }
        shadow *= self_shadow(1.0, (*source).position_radius.xyz, in.world_position.xyz);
        light += strand_response(tangent, normal, to_view, to_light, albedo) * radiance * shadow;
    }
    return light;
}

// The environment map, seen by a strand: its irradiance and its radiance looked up
// across the strand, along the normal of its cross-section that faces the viewer (a
// cylinder's diffuse response is the irradiance around it, and a Kajiya-Kay highlight
// lies where the view reflects off that normal), the radiance blurred to the primary
// lobe's width.
fn environment_light(in: VertexOutput, ranges: ptr<function, ClusterableObjectIndexRanges>, tangent: vec3<f32>,
    to_view: vec3<f32>, albedo: vec3<f32>) -> vec3<f32> {
#ifdef ENVIRONMENT_MAP
    let across = unit_or(to_view - tangent * dot(tangent, to_view), normalize(in.normal));
    var layer: LayerLightingInput;
    layer.N = across;
    layer.R = reflect(-to_view, across);
    layer.NdotV = max(dot(across, to_view), 1e-4);
    // The Blinn-Phong exponent n as a GGX roughness: α = sqrt(2 / (n + 2)).
    layer.roughness = sqrt(2.0 / (hair.primary_exponent + 2.0));
    layer.perceptual_roughness = sqrt(layer.roughness);
    let radiances = environment_map::compute_radiances(layer, ranges, in.world_position.xyz, false);
    let specular = hair.primary_color.rgb + hair.secondary_color.rgb * albedo;
    return hair.diffuse * albedo * radiances.irradiance + specular * radiances.radiance;
#else
    return vec3(0.0);
#endif
}

// Bevy's distance fog over a shaded fragment, as `bevy_pbr::pbr_functions::apply_fog` lays
// it over `StandardMaterial` (mirrored: that module also binds `StandardMaterial`'s own
// material), so hair and skin fade alike.
fn fogged(color: vec4<f32>, in: VertexOutput, view_z: f32) -> vec4<f32> {
#ifdef DISTANCE_FOG
    let to_fragment = in.world_position.xyz - view.world_position;
    let distance = length(to_fragment);
    // Light scattered toward the eye by the fog, from directional lights, unless shadowed.
    var scattering = vec3(0.0);
    if fog.directional_light_color.a > 0.0 {
        let along = to_fragment / distance;
        for (var i = 0u; i < lights.n_directional_lights; i++) {
            let directional = &lights.directional_lights[i];
            var shadow = 1.0;
            if ((*directional).flags & DIRECTIONAL_LIGHT_FLAGS_SHADOWS_ENABLED_BIT) != 0u {
                shadow = fetch_directional_shadow(i, in.world_position, -along, view_z, in.clip_position.xy);
            }
            scattering += pow(max(dot(along, (*directional).direction_to_light), 0.0), fog.directional_light_exponent)
                * (*directional).color.rgb * view.exposure * shadow;
        }
    }
    if fog.mode == FOG_MODE_LINEAR {
        return distance_fog::linear_fog(fog, color, distance, scattering);
    } else if fog.mode == FOG_MODE_EXPONENTIAL {
        return distance_fog::exponential_fog(fog, color, distance, scattering);
    } else if fog.mode == FOG_MODE_EXPONENTIAL_SQUARED {
        return distance_fog::exponential_squared_fog(fog, color, distance, scattering);
    } else if fog.mode == FOG_MODE_ATMOSPHERIC {
        return distance_fog::atmospheric_fog(fog, color, distance, scattering);
    }
#endif
    return color;
}

struct FragmentOutput {
    @location(0) color: vec4<f32>,
#ifdef MULTISAMPLED
    @builtin(sample_mask) samples: u32,
#endif
}

@fragment
fn fragment(in: VertexOutput) -> FragmentOutput {
    let tangent = normalize(in.tangent);
    let to_view = normalize(view.world_position - in.world_position.xyz);
    let normal = normalize(in.normal);
    let tint = 1.0 + hair.tint_variation * (hash_unit(in.strand) * 2.0 - 1.0);
    let albedo = mix(hair.root_color.rgb, hair.tip_color.rgb, in.t) * tint;

    let view_z = dot(vec4(view.view_from_world[0].z, view.view_from_world[1].z, view.view_from_world[2].z,
        view.view_from_world[3].z), in.world_position);

    var light = albedo * lights.ambient_color.rgb;
    for (var i = 0u; i < lights.n_directional_lights; i++) {
        let directional = &lights.directional_lights[i];
        var shadow = 1.0;
        if receives_shadow((*directional).flags, DIRECTIONAL_LIGHT_FLAGS_SHADOWS_ENABLED_BIT) {
            shadow = fetch_directional_shadow(i, in.world_position, normal, view_z, in.clip_position.xy);
        }
        shadow *= self_shadow(0.0, (*directional).direction_to_light, in.world_position.xyz);
        light += strand_response(tangent, normal, to_view, (*directional).direction_to_light, albedo)
            * (*directional).color.rgb * shadow;
    }
    // The point and spot lights (and light probes) of this fragment's cluster.
    let is_orthographic = view.clip_from_view[3].w == 1.0;
    let cluster = clustering::view_fragment_cluster_index(in.clip_position.xy, view_z, is_orthographic);
    var ranges = clustering::unpack_clusterable_object_index_ranges(cluster);
    light += clustered_light(in, ranges, tangent, normal, to_view, albedo);
    light += environment_light(in, &ranges, tangent, to_view, albedo);

    var color = fogged(vec4(light * view.exposure, 1.0), in, view_z);
#ifdef TONEMAP_IN_SHADER
    color = tone_mapping(color, view.color_grading);
#endif
    var out: FragmentOutput;
    out.color = color;
#ifdef MULTISAMPLED
    out.samples = coverage_samples(in.strand, in.coverage);
#endif
    if (hair.flags & HAIR_FLAGS_BLENDED) != 0u {
        // The strand's share of the wider ribbon it is drawn as. (An opacity falling from
        // the middle to the edges, with the same mean, measured darker and less steady.)
        out.color.a = in.coverage;
#ifdef MULTISAMPLED
        out.samples = 0xffffffffu;
#endif
    }
    return out;
}

#endif // PREPASS_PIPELINE
