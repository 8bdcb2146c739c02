//! How the hair is lit: every kind of Bevy light, shade under other hair, fog, shadows.

use crate::scene::*;
use bevy::image::Image;
use bevy::light::{CascadeShadowConfigBuilder, DirectionalLightShadowMap, GlobalAmbientLight, NotShadowCaster};
use bevy::prelude::*;
use bevy_hair::prelude::*;
use bevy_hair::render::{HairDrawing, HairDrawnBy, HairUniform, StrandLayout};

/// A point light on the left, casting shadows, lights the hair through the clustered lights,
/// falling off with distance and shadowed by the head as `StandardMaterial` is: the left
/// half of the hair is at least twice as bright as the right (linear luminance).
#[test]
fn a_point_light_lights_the_hair_near_it() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let (mut scene, _) = settled_scene();
    let light = PointLight { intensity: 2_000.0, range: 3.0, shadow_maps_enabled: true, ..default() };
    let hair = lit_only_by(&mut scene, "point-light", (light, Transform::from_xyz(-0.3, 0.05, 0.12)));
    let half = |left: bool| mean(hair.iter().filter(|(i, _)| (i % SIZE < SIZE / 2) == left).map(|&(_, l)| l));
    let (left, right) = (half(true), half(false));
    println!("point light on the left: hair luminance {left:.3} left, {right:.3} right ({} hair pixels)", hair.len());
    assert!(hair.len() > 2000, "the hair is in the picture");
    assert!(left > 0.05, "the lit side is lit: {left}");
    assert!(left > 2.0 * right, "left {left} is not twice right {right}");
}

/// A narrow spot light aimed at the upper left of the hair lights the hair inside its cone
/// and nothing outside it.
#[test]
fn a_spot_light_lights_only_hair_inside_its_cone() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let (mut scene, _) = settled_scene();
    let (from, aim, angle) = (Vec3::new(0.0, 0.1, 0.5), Vec3::new(-0.05, 0.06, 0.05), 0.15);
    let light = SpotLight { intensity: 40_000.0, outer_angle: angle, inner_angle: angle * 0.8, ..default() };
    let hair =
        lit_only_by(&mut scene, "spot-light", (light, Transform::from_translation(from).looking_at(aim, Vec3::Y)));
    // Which pixels the cone covers, from where the hair at each pixel is: the camera ray
    // through the pixel meets the hair near the depth of the aim point.
    let (camera, eye) = {
        let world = scene.app.world();
        (world.get::<Camera>(scene.camera).unwrap().clone(), *world.get::<GlobalTransform>(scene.camera).unwrap())
    };
    let in_cone = |i: u32| {
        let pixel = Vec2::new((i % SIZE) as f32 + 0.5, (i / SIZE) as f32 + 0.5);
        let ray = camera.viewport_to_world(&eye, pixel).unwrap();
        // Depths from 2 cm in front of the aim point to 8 cm behind it: inside at any.
        (0..=10).any(|k| {
            let point = ray.origin + *ray.direction * ((aim - ray.origin).length() - 0.02 + 0.01 * k as f32);
            (point - from).normalize().angle_between((aim - from).normalize()) < angle
        })
    };
    let inside: Vec<f32> = hair.iter().filter(|(i, _)| in_cone(*i)).map(|&(_, l)| l).collect();
    let inside_mean = mean(inside.iter().copied());
    // Lit: a tenth of the cone's mean brightness or more (the cone's soft edge is counted
    // as inside by the depth range above).
    let lit = |l: f32| l > 0.1 * inside_mean;
    let outside = hair.len() - inside.len();
    let outside_lit = hair.iter().filter(|&&(i, l)| lit(l) && !in_cone(i)).count();
    let inside_lit = inside.iter().filter(|&&l| lit(l)).count();
    println!(
        "spot light: {inside_lit} of {} hair pixels in the cone lit (mean {inside_mean:.3}), {outside_lit} of \
         {outside} outside",
        inside.len(),
    );
    assert!(inside.len() > 100 && inside_lit * 2 > inside.len(), "the cone's hair is lit");
    assert!(outside > 500 && outside_lit * 100 <= outside, "{outside_lit} hair pixels outside the cone are lit");
}

/// An environment map alone (no lights, no ambient) lights the hair, in its own colour: a
/// warm map makes the hair redder than a cool one does.
#[test]
fn environment_light_alone_lights_the_hair_in_its_colour() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let (mut scene, _) = settled_scene();
    let world = scene.app.world_mut();
    world.entity_mut(scene.light).despawn();
    world.insert_resource(GlobalAmbientLight { brightness: 0.0, ..default() });
    let mut redness = Vec::new();
    for (name, color) in
        [("environment-warm", Color::srgb(1.0, 0.5, 0.1)), ("environment-cool", Color::srgb(0.1, 0.5, 1.0))]
    {
        let world = scene.app.world_mut();
        let map = EnvironmentMapLight {
            intensity: 3000.0,
            ..EnvironmentMapLight::solid_color(&mut world.resource_mut::<Assets<Image>>(), color)
        };
        world.entity_mut(scene.camera).insert(map);
        scene.frames(3);
        let picture = scene.capture(name);
        let hair: Vec<[f32; 3]> = picture.pixels.iter().copied().filter(|&c| Picture::is_hair(c)).collect();
        let luminance = mean(hair.iter().map(|&c| luminance(c)));
        let red_over_blue = mean(hair.iter().map(|c| c[0])) / mean(hair.iter().map(|c| c[2])).max(1e-6);
        println!("{name}: {} hair pixels, luminance {luminance:.3}, red / blue {red_over_blue:.2}", hair.len());
        assert!(hair.len() > 2000 && luminance > 0.02, "{name}: the hair is lit");
        redness.push(red_over_blue);
    }
    assert!(redness[0] > 2.0 * redness[1], "red / blue {redness:?}: the hair does not follow the map");
}

/// Light from behind the head, no ambient: Marschner's TT lobe (light through the fibres)
/// makes the hair's silhouette glow brighter than Kajiya-Kay's highlights do.
#[test]
fn marschner_transmission_lights_the_silhouette_against_the_light() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let (mut scene, head) = settled_scene();
    // The silhouette: hair pixels within two pixels of the background, found under the
    // scene's own light.
    let mask = scene.capture("backlit-mask");
    let near_background = |i: u32| {
        let (x, y) = (i % SIZE, i / SIZE);
        (x.saturating_sub(2)..=(x + 2).min(SIZE - 1))
            .any(|x| (y.saturating_sub(2)..=(y + 2).min(SIZE - 1)).any(|y| Picture::is_background(mask.at((x, y)))))
    };
    let silhouette: Vec<u32> =
        (0..SIZE * SIZE).filter(|&i| Picture::is_hair(mask.pixels[i as usize]) && near_background(i)).collect();
    scene.light_from(Vec3::new(0.0, 0.35, -1.0));
    scene.app.world_mut().insert_resource(GlobalAmbientLight { brightness: 0.0, ..default() });
    let mut glow = Vec::new();
    for (name, shading) in
        [("backlit-kajiya-kay", HairShading::KajiyaKay), ("backlit-marschner", HairShading::MARSCHNER)]
    {
        scene.app.world_mut().get_mut::<HairLook>(head).unwrap().shading = shading;
        scene.frames(3);
        let picture = scene.capture(name);
        glow.push(mean(silhouette.iter().map(|&i| luminance(picture.pixels[i as usize]))));
    }
    println!("back-lit silhouette ({} pixels): Kajiya-Kay {:.4}, Marschner {:.4}", silhouette.len(), glow[0], glow[1]);
    assert!(silhouette.len() > 300, "the silhouette is in the picture");
    assert!(glow[1] > 1.2 * glow[0], "Marschner {} is not brighter than Kajiya-Kay {}", glow[1], glow[0]);
}

/// Self-shadowing through the volume: under a light from above (Bevy's shadow maps off
/// for the hair, so only its opacity maps shade it; one layer of fibres stopping 70 % of the
/// light, as this thin cap of hair needs to show it), the hair low on the head, under the
/// crown's, keeps at most 60 % of the light it gets without self-shadowing, relative to
/// what the top layer keeps; and turning the light by 0.1° changes the luminance of at
/// most 1 % of the hair's pixels by more than 10 % (no acne).
#[test]
fn hair_under_other_hair_is_in_its_shade() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let (mut scene, head) = settled_scene();
    let mask = scene.capture("self-shadow-mask");
    let hair: Vec<u32> = (0..SIZE * SIZE).filter(|&i| Picture::is_hair(mask.pixels[i as usize])).collect();
    let rows = hair.iter().map(|&i| i / SIZE);
    let (top_row, bottom_row) = (rows.clone().min().unwrap_or(0), rows.max().unwrap_or(0));
    let height = (bottom_row - top_row).max(1) as f32;
    let depth = |i: u32| (i / SIZE - top_row) as f32 / height;

    scene.app.world_mut().insert_resource(GlobalAmbientLight { brightness: 0.0, ..default() });
    scene.app.world_mut().get_mut::<HairLook>(head).unwrap().receive_shadows = false;
    let render = |scene: &mut Scene, name: &str, self_shadow: f32, to_light: Vec3| -> Vec<f32> {
        scene.app.world_mut().get_mut::<HairLook>(head).unwrap().self_shadow = self_shadow;
        scene.light_from(to_light);
        scene.frames(3);
        let picture = scene.capture(name);
        hair.iter().map(|&i| linear_luminance(picture.pixels[i as usize])).collect()
    };
    let above = Vec3::new(0.0, 1.0, 0.25);
    let opacity = 0.7;
    let off = render(&mut scene, "self-shadow-off", 0.0, above);
    let on = render(&mut scene, "self-shadow-on", opacity, above);
    let turned_light = Quat::from_rotation_x(0.1f32.to_radians()) * above;
    let turned = render(&mut scene, "self-shadow-turned", opacity, turned_light);

    // What self-shadowing keeps of each region's light.
    let kept = |region: &dyn Fn(f32) -> bool| {
        let pixels: Vec<usize> = (0..hair.len()).filter(|&k| region(depth(hair[k])) && off[k] > 1e-3).collect();
        let sum = |values: &[f32]| pixels.iter().map(|&k| values[k]).sum::<f32>();
        (sum(&on) / sum(&off).max(1e-9), pixels.len())
    };
    let ((top, top_pixels), (low, low_pixels)) = (kept(&|d| d < 0.25), kept(&|d| d > 0.5));
    // Pixels bright enough that 8-bit rounding is under 3 %, that change by over 10 %.
    let bright: Vec<usize> = (0..hair.len()).filter(|&k| on[k] > 0.02).collect();
    let changed = bright.iter().filter(|&&k| (turned[k] - on[k]).abs() > 0.1 * on[k]).count();
    println!(
        "self-shadowing from above keeps {top:.3} of the top quarter's light ({top_pixels} pixels) and {low:.3} of \
         the lower half's ({low_pixels}); turning the light 0.1° changes {changed} of {} bright hair pixels by > 10 %",
        bright.len()
    );
    assert!(top_pixels > 300 && low_pixels > 300, "both regions are in the picture");
    assert!(low <= 0.6 * top, "the lower hair keeps {low}, not under 60 % of the top's {top}");
    assert!(bright.len() > 500, "the lit hair is in the picture");
    assert!(changed * 100 <= bright.len(), "{changed} of {} pixels flicker", bright.len());
}

/// Anti-aliased strands: with the head at 2 m and at 4 m (strands a tenth and a twentieth of
/// a pixel wide), moving the camera by a quarter pixel changes the hair's pixels (mean
/// absolute change of linear luminance over the pixels inside the hair in both frames: the
/// edge really moves) by at most a third of what plain ribbons give when blended, and 80 %
/// with alpha-to-coverage, where which strand is in front at each MSAA sample (about 100
/// strands cross each pixel here) still changes. `Auto` blends here, and not up close.
#[test]
fn distant_hair_does_not_shimmer() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let (mut scene, head) = settled_scene();
    // The default density (16 children per guide), which is what shimmers; one
    // subdivision per segment, as the head is a few pixels tall.
    scene.app.world_mut().get_mut::<HairGroom>(head).unwrap().children.per_guide = 16;
    scene.app.world_mut().get_mut::<HairLook>(head).unwrap().subdivisions = 1;
    // The hair holds still: only the camera moves between the frames compared.
    scene.app.world_mut().resource_mut::<Time<Hair>>().pause();
    let target = Vec3::new(0.0, -0.02, 0.0);
    let place_camera = |scene: &mut Scene, distance: f32, offset: f32| {
        let eye = Vec3::new(offset, target.y, distance);
        *scene.app.world_mut().get_mut::<Transform>(scene.camera).unwrap() =
            Transform::from_translation(eye).looking_at(target + Vec3::X * offset, Vec3::Y);
        scene.frames(3);
    };
    let blended = |scene: &mut Scene| {
        let drawn_by = scene.app.world().get::<HairDrawnBy>(head).unwrap().0;
        scene.app.world().get::<HairDrawing>(drawn_by).unwrap().blended()
    };
    // World metres per pixel at distance `d` (Bevy's default vertical field of view, π/4).
    let pixel = |d: f32| 2.0 * d * (std::f32::consts::FRAC_PI_8).tan() / SIZE as f32;
    let modes = [HairAntialias::Off, HairAntialias::Coverage, HairAntialias::Blended];
    for distance in [2.0f32, 4.0] {
        let mut change = [0.0f32; 3];
        let mut still = Vec::new();
        for (k, mode) in modes.into_iter().enumerate() {
            scene.app.world_mut().get_mut::<HairLook>(head).unwrap().antialias = mode;
            let name = |moved: bool| format!("shimmer-{distance}m-{mode:?}-{moved}").to_lowercase();
            place_camera(&mut scene, distance, 0.0);
            let before = scene.capture(&name(false));
            place_camera(&mut scene, distance, 0.25 * pixel(distance));
            let after = scene.capture(&name(true));
            // Inside the hair in both frames (a pixel from its edge, which really moves).
            let hair = inside_hair(&[&before, &after]);
            assert!(hair.len() > 20, "the hair is in the picture at {distance} m");
            let luminance = |picture: &Picture, i: usize| linear_luminance(picture.pixels[i]);
            let mean = |f: &dyn Fn(usize) -> f32| hair.iter().map(|&i| f(i)).sum::<f32>() / hair.len() as f32;
            change[k] = mean(&|i| (luminance(&after, i) - luminance(&before, i)).abs());
            // What the move changes in a picture free of shimmer: `before` itself moved a
            // quarter pixel (the scene slides left as the camera goes right).
            let slid = mean(&|i| {
                let right = if (i as u32 % SIZE) + 1 < SIZE { i + 1 } else { i };
                (0.25 * (luminance(&before, right) - luminance(&before, i))).abs()
            });
            println!(
                "{distance} m, {mode:?}: {} hair pixels, mean luminance change {:.5} for a quarter-pixel move \
                 ({slid:.5} if the picture only slid)",
                hair.len(),
                change[k],
            );
            still.push(before);
        }
        let [plain, coverage, blend] = change;
        assert!(coverage <= 0.8 * plain, "{distance} m: alpha-to-coverage {coverage} against plain {plain}");
        assert!(blend <= plain / 3.0, "{distance} m: blended {blend} against plain {plain}");
        // Blending keeps the hair about as bright (plain ribbons, sampled 4 times a pixel,
        // are the unbiased reference): no jump where `Auto` switches. Over the pixels inside
        // the hair in every mode, as blended edges are softer.
        let common = inside_hair(&still.iter().collect::<Vec<_>>());
        let brightness: Vec<f32> = still
            .iter()
            .map(|picture| {
                common.iter().map(|&i| linear_luminance(picture.pixels[i])).sum::<f32>() / common.len() as f32
            })
            .collect();
        println!(
            "{distance} m: mean luminance of {} hair pixels plain, coverage, blended: {brightness:.4?}",
            common.len()
        );
        assert!(
            (brightness[2] - brightness[0]).abs() <= 0.12 * brightness[0],
            "{distance} m: blended hair's mean luminance {} against {} for plain ribbons",
            brightness[2],
            brightness[0]
        );
        scene.app.world_mut().get_mut::<HairLook>(head).unwrap().antialias = HairAntialias::Auto;
        place_camera(&mut scene, distance, 0.0);
        assert!(blended(&mut scene), "Auto blends strands a tenth of a pixel wide ({distance} m)");
    }
    // Close enough that the widest strands are over a pixel and a quarter wide.
    place_camera(&mut scene, 0.3, 0.0);
    assert!(!blended(&mut scene), "Auto does not blend strands wider than a pixel (0.3 m)");
}

/// Bevy's distance fog covers the hair as it covers the head (`StandardMaterial`): in a
/// linear fog that is total from 30 cm, hair and skin pixels both take the fog's colour
/// (within 1/255); in one from 30 cm to 1 m, the hair (50–70 cm away) moves part of the way
/// toward it.
#[test]
fn fog_covers_the_hair_as_it_covers_the_head() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let (mut scene, _) = settled_scene();
    let clear = scene.capture("fog-none");
    let (hair, skin) =
        (inside_hair(&[&clear]), inside_where(&[&clear], |c| !Picture::is_hair(c) && !Picture::is_background(c)));
    assert!(hair.len() > 500 && skin.len() > 500, "{} hair and {} skin pixels", hair.len(), skin.len());
    let mean_colour = |picture: &Picture, pixels: &[usize]| {
        let sum = pixels.iter().fold(Vec3::ZERO, |sum, &i| sum + Vec3::from_array(picture.pixels[i]));
        sum / pixels.len() as f32
    };
    let fog = Color::srgb(0.3, 0.35, 0.9);
    let fog_srgb = Vec3::from_array(fog.to_srgba().to_f32_array_no_alpha());
    let fogged = |scene: &mut Scene, name: &str, start: f32, end: f32| {
        let falloff = FogFalloff::Linear { start, end };
        scene.app.world_mut().entity_mut(scene.camera).insert(DistanceFog { color: fog, falloff, ..default() });
        scene.frames(3);
        scene.capture(name)
    };
    // Behind the strands' blended coverage the background shows through, and Bevy does not
    // fog the clear colour: in total fog everything the hair can blend with is the fog's
    // colour, the background too.
    scene.app.insert_resource(ClearColor(fog));
    let total = fogged(&mut scene, "fog-total", 0.05, 0.3);
    scene.app.insert_resource(ClearColor(BACKGROUND));
    let (hair_colour, skin_colour) = (mean_colour(&total, &hair), mean_colour(&total, &skin));
    println!("total fog {fog_srgb}: hair {hair_colour}, skin {skin_colour}");
    assert!((hair_colour - fog_srgb).abs().max_element() <= 1.0 / 255.0, "hair {hair_colour} under fog {fog_srgb}");
    assert!((skin_colour - fog_srgb).abs().max_element() <= 1.0 / 255.0, "skin {skin_colour} under fog {fog_srgb}");

    let partial = fogged(&mut scene, "fog-partial", 0.3, 1.0);
    let (before, after) = (mean_colour(&clear, &hair), mean_colour(&partial, &hair));
    let moved = 1.0 - after.distance(fog_srgb) / before.distance(fog_srgb);
    println!("partial fog: hair {before} → {after}, {moved:.2} of the way to the fog");
    assert!((0.1..0.6).contains(&moved), "the hair moved {moved} of the way to the fog's colour");
}

/// Two straight strands drawn with the hair material directly: one along the light, one
/// across it. Kajiya-Kay diffuse is sin(T, L): the first is dark, the second bright.
#[test]
fn a_strand_along_the_light_is_darker_than_one_across_it() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let mut scene = Scene::new();
    scene.look_from(Vec3::new(0.0, 0.0, 0.55));
    // Light from +x (and a little from the camera so both ribbons face it equally).
    scene.light_from(Vec3::new(1.0, 0.0, 0.15));
    let particles = 11u32;
    let mut guides = Vec::new();
    // Guide 0: vertical, left half. Guide 1: horizontal, right half.
    for i in 0..particles {
        guides.push(Vec4::new(-0.08, 0.1 - 0.02 * i as f32, 0.0, 1.0));
    }
    for i in 0..particles {
        guides.push(Vec4::new(0.01 + 0.016 * i as f32, 0.0, 0.0, 1.0));
    }
    // Each particle's frame vector: +z is perpendicular to both strands.
    guides.extend([Vec4::new(0.0, 0.0, 1.0, 0.0); 22]);
    let layout = StrandLayout { guides: 2, particles, strands_per_guide: 1, subdivisions: 2 };
    let uniform = plain_uniform(&layout, Vec4::new(0.6, 0.6, 0.6, 1.0), 0.01);
    scene.draw_strands(guides, &layout, uniform);
    let picture = scene.capture("kajiya-kay");

    let mean_brightness = |xs: std::ops::Range<u32>| {
        let lit: Vec<f32> = xs
            .flat_map(|x| (0..SIZE).map(move |y| (x, y)))
            .map(|p| picture.at(p))
            .filter(|&c| !Picture::is_background(c))
            .map(luminance)
            .collect();
        assert!(lit.len() > 50, "strand not drawn ({} pixels)", lit.len());
        lit.iter().sum::<f32>() / lit.len() as f32
    };
    let across = mean_brightness(0..SIZE / 2);
    let along = mean_brightness(SIZE / 2 + 8..SIZE);
    println!("mean luminance: strand across the light {across:.3}, along the light {along:.3}");
    assert!(across > 2.0 * along, "across {across} is not clearly brighter than along {along}");
}

/// Hair draws itself into the shadow maps: strands in front of a wall, lit from the front,
/// darken the wall where their shadows fall, and only when they cast shadows.
#[test]
fn strands_cast_shadows() {
    require_adapter!();
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let mut scene = Scene::new();
    scene.look_from(Vec3::new(0.0, 0.0, 0.55));
    // From the front, above and to the right: shadows fall below and left of the strands.
    scene.light_from(Vec3::new(0.35, 0.35, 1.0));
    // One cascade over the small scene, so shadow texels are finer than a strand is wide.
    let cascades = CascadeShadowConfigBuilder {
        num_cascades: 1,
        minimum_distance: 0.05,
        maximum_distance: 1.5,
        first_cascade_far_bound: 1.5,
        overlap_proportion: 0.2,
    };
    scene.app.world_mut().entity_mut(scene.light).insert(cascades.build());
    scene.app.insert_resource(DirectionalLightShadowMap { size: 4096 });
    let world = scene.app.world_mut();
    let wall = world.resource_mut::<Assets<Mesh>>().add(Plane3d::new(Vec3::Z, Vec2::splat(0.3)).mesh());
    let red = world.resource_mut::<Assets<StandardMaterial>>().add(Color::srgb(0.8, 0.25, 0.2));
    world.spawn((Mesh3d(wall), MeshMaterial3d(red), Transform::from_xyz(0.0, 0.0, -0.03)));

    // Twelve vertical strands, 1.5 cm apart, 4 mm wide.
    let (guides, particles) = (12u32, 11u32);
    let mut data = Vec::new();
    for g in 0..guides {
        data.extend((0..particles).map(|j| Vec4::new(-0.09 + 0.015 * g as f32, 0.1 - 0.02 * j as f32, 0.0, 1.0)));
    }
    data.extend(std::iter::repeat_n(Vec4::new(0.0, 0.0, 1.0, 0.0), (guides * particles) as usize));
    let layout = StrandLayout { guides, particles, strands_per_guide: 1, subdivisions: 2 };
    // Receiving shadows too, as the plugin's default look does.
    let uniform = HairUniform {
        flags: HairUniform::RECEIVE_SHADOWS,
        ..plain_uniform(&layout, Vec4::new(0.05, 0.6, 0.05, 1.0), 0.004)
    };
    let strands = scene.draw_strands(data, &layout, uniform);

    let mut walls = Vec::new();
    for cast in [false, true] {
        let mut entity = scene.app.world_mut().entity_mut(strands);
        if cast {
            entity.remove::<NotShadowCaster>();
        } else {
            entity.insert(NotShadowCaster);
        }
        scene.frames(3);
        walls.push(scene.capture(&format!("strand-shadows-{cast}")));
    }
    // Wall pixels (red-dominant) in both pictures, compared pixel by pixel.
    let is_wall = |c: [f32; 3]| c[0] > 1.2 * c[1] && c[0] > 1.2 * c[2];
    let (mut both, mut darker) = (0, 0);
    for (&off, &on) in walls[0].pixels.iter().zip(&walls[1].pixels) {
        if is_wall(off) && is_wall(on) {
            both += 1;
            darker += usize::from(luminance(on) < 0.7 * luminance(off));
        }
    }
    println!("wall pixels: {both}; {darker} darker by > 30% when the strands cast shadows");
    assert!(both > 5000, "only {both} wall pixels");
    assert!(darker > 300, "the strands' shadows darken only {darker} of {both} wall pixels");
}
