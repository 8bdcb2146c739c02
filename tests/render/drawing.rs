//! Where the strands are drawn: the shader against the CPU's reference curves, and a groom
//! the GPU steps drawn where the CPU would draw it.

use crate::scene::*;
use bevy::prelude::*;
use bevy_hair::hair_sim::groom::{ChildParams, ChildRoot, child_curve, tessellate, transport_frames};
use bevy_hair::hair_sim::math::Vec3 as SimVec3;
use bevy_hair::prelude::*;
use bevy_hair::render::{HairDrawnBy, HairUniform, StrandLayout};

#[test]
fn a_groom_the_gpu_steps_is_drawn_from_the_gpu_where_the_cpu_would_draw_it() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let mut scene = Scene::new();
    let head = scene.spawn_head(short_groom());
    scene.wait_until_ready(head);
    scene.look_from(Vec3::new(0.3, 0.1, 0.5));
    scene.frames(3);
    let on_cpu = scene.capture("backend-cpu");
    let cpu_bytes = scene.app.world().resource::<HairRenderStats>().uploaded_bytes;
    // And blended (sorted back to front), for the GPU's order below.
    let blended = |scene: &mut Scene, on: bool| {
        let mut look = scene.app.world_mut().get_mut::<HairLook>(head).unwrap();
        look.antialias = if on { HairAntialias::Blended } else { HairLook::default().antialias };
        scene.frames(3);
    };
    blended(&mut scene, true);
    let cpu_blended = scene.capture("backend-cpu-blended");
    blended(&mut scene, false);
    let drawing = scene.app.world().get::<HairDrawnBy>(head).unwrap().0;
    let aabb = |scene: &Scene| *scene.app.world().get::<bevy::camera::primitives::Aabb>(drawing).unwrap();
    let cpu_box = aabb(&scene);
    // The head is still and the hair settled: on the GPU it stays where it hangs.
    scene.app.world_mut().entity_mut(head).insert(HairBackend::Gpu);
    // The CPU steps it while the GPU's pipelines compile in the background.
    let on_gpu = |scene: &Scene| scene.app.world().get::<HairState>(head).unwrap().gpu_lag().is_some();
    let mut waited = 0;
    while !on_gpu(&scene) && waited < 600 {
        scene.frames(1);
        waited += 1;
    }
    println!("the GPU took the groom over after {waited} frames");
    scene.frames(3);
    let on_gpu = scene.capture("backend-gpu");
    let state = scene.app.world().get::<HairState>(head).unwrap();
    assert_eq!(state.gpu_fallback(), None, "the GPU steps the groom");
    assert!(state.gpu_lag().is_some(), "the GPU steps the groom");
    assert_eq!(bevy_hair::hair_gpu::submissions(), 0, "the hair code submitted work itself");
    // The particles and their frames (600 guides × 11 particles, two vec4 each) are
    // written on the GPU; only the rest travels.
    let gpu_bytes = scene.app.world().resource::<HairRenderStats>().uploaded_bytes;
    assert_eq!(cpu_bytes - gpu_bytes, 600 * 11 * 2 * 16, "{cpu_bytes} then {gpu_bytes} bytes uploaded");
    // Culling takes a GPU groom's strands as far as they reach from their roots: a box
    // holding the one around the particles themselves.
    let gpu_box = aabb(&scene);
    assert!(
        gpu_box.min().cmple(cpu_box.min()).all() && gpu_box.max().cmpge(cpu_box.max()).all(),
        "{gpu_box:?} holds {cpu_box:?}"
    );
    let (cpu_hair, gpu_hair) = (on_cpu.hair_pixels(), on_gpu.hair_pixels());
    let differing = (0..SIZE * SIZE)
        .filter(|i| {
            Picture::is_hair(on_cpu.at((i % SIZE, i / SIZE))) != Picture::is_hair(on_gpu.at((i % SIZE, i / SIZE)))
        })
        .count();
    println!("hair pixels: {cpu_hair} drawn from the CPU, {gpu_hair} from the GPU, {differing} differ");
    assert!(cpu_hair > 1000, "{cpu_hair} hair pixels");
    assert!(differing * 50 < cpu_hair, "{differing} of {cpu_hair} hair pixels differ");
    // The GPU builds the self-shadow maps from what it draws, as the CPU builds them: the
    // hair is as bright pixel for pixel, where without them it is brighter.
    let mean_apart = |a: &Picture, b: &Picture| {
        let both: Vec<usize> =
            (0..a.pixels.len()).filter(|&i| Picture::is_hair(a.pixels[i]) && Picture::is_hair(b.pixels[i])).collect();
        both.iter().map(|&i| (linear_luminance(a.pixels[i]) - linear_luminance(b.pixels[i])).abs()).sum::<f32>()
            / both.len().max(1) as f32
    };
    scene.app.world_mut().get_mut::<HairLook>(head).unwrap().self_shadow = 0.0;
    scene.frames(3);
    let unshadowed = scene.capture("backend-gpu-unshadowed");
    let (backends, shadow) = (mean_apart(&on_cpu, &on_gpu), mean_apart(&on_gpu, &unshadowed));
    println!(
        "hair luminance, mean difference: CPU against GPU {backends:.4}, GPU with and without self-shadow {shadow:.4}"
    );
    assert!(shadow > 0.01, "self-shadowing darkens the hair: {shadow}");
    assert!(backends < 0.2 * shadow, "the GPU's self-shadow differs from the CPU's by {backends}");
    // Blended, the GPU sorts the pieces it draws: the same picture as the CPU's sort.
    scene.app.world_mut().get_mut::<HairLook>(head).unwrap().self_shadow = HairLook::default().self_shadow;
    blended(&mut scene, true);
    let gpu_blended = scene.capture("backend-gpu-blended");
    let apart = mean_apart(&cpu_blended, &gpu_blended);
    let (cpu_hair, gpu_hair) = (cpu_blended.hair_pixels(), gpu_blended.hair_pixels());
    println!("blended: {cpu_hair} hair pixels from the CPU, {gpu_hair} from the GPU, luminance {apart:.4} apart");
    assert!(cpu_hair > 1000 && cpu_hair.abs_diff(gpu_hair) * 50 < cpu_hair, "{cpu_hair} and {gpu_hair}");
    assert!(apart < 0.2 * shadow, "the GPU's blended hair differs from the CPU's by {apart}");
}

/// One guide with four children drawn by the shader, checked against the CPU reference
/// (`hair_sim::groom::{tessellate, child_curve}`) that `hair.wgsl` mirrors: every reference
/// point must land on a drawn strand, and the reference points mirrored through the guide
/// (where a flipped frame or sign would put the children) that lie away from every strand
/// must stay background.
#[test]
fn the_shader_draws_guide_and_children_where_the_cpu_reference_puts_them() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let mut scene = Scene::new();
    scene.look_from(Vec3::new(0.0, 0.0, 0.55));
    scene.light_from(Vec3::new(0.2, 0.3, 1.0));
    let particles = 11u32;
    let subdivisions = 4;
    // A bent strand in the view plane, root at the top.
    let guide: Vec<SimVec3> = (0..particles)
        .map(|j| {
            let j = j as f32;
            SimVec3::new(-0.04 + 0.006 * j + 0.012 * (j * 0.6).sin(), 0.09 - 0.018 * j, 0.0)
        })
        .collect();
    let root_u = SimVec3::X;
    // A scalp tilted against the first segment, curved with an 8 cm radius, the head behind
    // it: the spiral starts on the scalp, turns into the guide's frame and is flattened
    // where it would point into the head, all of which the shader must mirror.
    let first = (guide[1] - guide[0]).normalize();
    let normal = (first + SimVec3::new(0.6, 0.0, 0.6)).normalize();
    let root = ChildRoot { u: root_u, normal, curvature: 12.5, head_centre: guide[0] - normal * 0.08 };
    let children =
        ChildParams { per_guide: 4, spiral: Spiral { scale: 3e-3, ..default() }, clumping: 0.3, tip_spread: 0.01 };
    let width = 0.003;

    let mut data: Vec<Vec4> = guide.iter().map(|p| Vec4::new(p.x, p.y, p.z, 1.0)).collect();
    data.extend(transport_frames(&guide, root_u).iter().map(|u| Vec4::new(u.x, u.y, u.z, 0.0)));
    data.push(Vec4::new(normal.x, normal.y, normal.z, root.curvature));
    let centre = root.head_centre;
    data.push(Vec4::new(centre.x, centre.y, centre.z, 1.0));
    let layout = StrandLayout { guides: 1, particles, strands_per_guide: children.per_guide + 1, subdivisions };
    let spiral = children.spiral;
    let uniform = HairUniform {
        spiral_a: spiral.a,
        spiral_b: spiral.b,
        spiral_angle_step: spiral.angle_step,
        spiral_scale: spiral.scale,
        clumping: children.clumping,
        tip_spread: children.tip_spread,
        ..plain_uniform(&layout, Vec4::new(0.8, 0.8, 0.8, 1.0), width)
    };
    scene.draw_strands(data, &layout, uniform);
    let picture = scene.capture("reference-children");

    let to_bevy = |p: SimVec3| Vec3::new(p.x, p.y, p.z);
    let guide_curve: Vec<Vec3> = tessellate(&guide, subdivisions).iter().map(|c| to_bevy(c.position)).collect();
    let mut reference = guide_curve.clone();
    let mut mirrored = Vec::new();
    for child in 0..children.per_guide {
        let curve = child_curve(&guide, &root, &children, 0, child, subdivisions);
        for (point, on_guide) in curve.iter().zip(&guide_curve) {
            let point = to_bevy(point.position);
            reference.push(point);
            mirrored.push(2.0 * *on_guide - point);
        }
    }
    let pixels = |points: &[Vec3]| -> Vec<(u32, u32)> {
        let pixels: Vec<(u32, u32)> = points.iter().filter_map(|&p| scene.project(p)).collect();
        assert_eq!(pixels.len(), points.len(), "a reference point is outside the picture");
        pixels
    };
    let reference = pixels(&reference);
    // Mirrored points more than 4 px from every reference point: no strand belongs there.
    let empty: Vec<(u32, u32)> = pixels(&mirrored)
        .into_iter()
        .filter(|&(x, y)| reference.iter().all(|&(rx, ry)| x.abs_diff(rx).max(y.abs_diff(ry)) > 4))
        .collect();
    assert!(empty.len() > 30, "only {} mirrored points are away from every strand", empty.len());
    let drawn = |pixels: &[(u32, u32)]| {
        let hit = pixels
            .iter()
            .filter(|&&(x, y)| {
                let near = (x.saturating_sub(1)..=(x + 1).min(SIZE - 1))
                    .flat_map(|x| (y.saturating_sub(1)..=(y + 1).min(SIZE - 1)).map(move |y| (x, y)));
                near.into_iter().any(|p| !Picture::is_background(picture.at(p)))
            })
            .count();
        hit as f32 / pixels.len() as f32
    };
    let (on_reference, on_mirror) = (drawn(&reference), drawn(&empty));
    println!(
        "{:.1}% of {} reference points drawn; {:.1}% of {} mirrored points",
        on_reference * 100.0,
        reference.len(),
        on_mirror * 100.0,
        empty.len()
    );
    assert!(on_reference > 0.97, "only {:.1}% of the CPU reference points are drawn", on_reference * 100.0);
    assert!(on_mirror < 0.05, "{:.1}% of the points away from the reference are drawn", on_mirror * 100.0);
}
