//! What the GPU draws from its strands: the drawing pass's curves, the self-shadow's
//! opacity map and the blended pieces' order, each against the CPU's.

use super::*;

#[test]
fn the_gpu_draws_its_strands_as_the_cpu_draws_them() {
    use hair_gpu::wgpu;
    let Some(gpu) = gpu() else { return };
    let (_, collider, rest) = groom(64);
    let n = rest.particles_per_strand;
    let params = SimParams::default();
    let mut strands = GpuStrands::new(&gpu, &rest, head_pose(0.0), Some(&collider)).expect("GPU strands");
    // Each strand's frame vector at its root, head space: any unit vector will do.
    let root_u: Vec<Vec3> = rest.root_frames.iter().map(|q| *q * Vec3::X).collect();
    let target = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: (2 * rest.positions.len() * 16) as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let drawing = hair_gpu::GpuDrawing::new(&strands, &root_u, &target).expect("drawing");
    // The CPU's drawing from the solver's positions after the last two steps, each in the
    // frame of the head at the end of its step.
    let mut local = Vec::new();
    for k in 0..8 {
        strands.step(&input_at(k, head_pose, &collider, &params)).expect("GPU step");
        let pose = head_pose((k + 1) as f32 * DT);
        strands.publish(pose);
        let now: Vec<Vec3> = strands.positions().expect("read back");
        local.push(now.iter().map(|&p| pose.inverse_transform_point(p)).collect::<Vec<_>>());
    }
    let (previous, last) = (&local[local.len() - 2], &local[local.len() - 1]);
    let (overstep, drawn_pose) = (0.3, Pose::new(head_pose(0.14).rotation, Vec3::new(2.0, 1.5, -3.0)));
    drawing.draw(&strands, overstep, drawn_pose).expect("draw");
    let drawn = read_vec4s(&gpu, &target);
    let (positions, frames) = drawn.split_at(rest.positions.len());
    let mut expected = Vec::new();
    for i in 0..rest.positions.len() {
        let p = if i % n == 0 { rest.positions[i] } else { previous[i].lerp(last[i], overstep) };
        expected.push(drawn_pose.transform_point(p));
    }
    let position_error =
        positions.iter().zip(&expected).map(|(d, e)| Vec3::new(d[0], d[1], d[2]).distance(*e)).fold(0.0, f32::max);
    let expected_frames: Vec<Vec3> = expected
        .chunks(n)
        .zip(&root_u)
        .flat_map(|(strand, &u)| hair_sim::groom::transport_frames(strand, drawn_pose.rotation * u))
        .collect();
    // A frame carried through a fold near 180° turns about an axis that rounding picks (the
    // arc between opposite tangents has none of its own): strands folded past 170° are
    // left out.
    let folded =
        |strand: &[Vec3]| strand.windows(3).any(|w| (w[1] - w[0]).normalize().dot((w[2] - w[1]).normalize()) < -0.985);
    let unfolded: Vec<bool> = expected.chunks(n).map(|strand| !folded(strand)).collect();
    let frame_error = frames
        .chunks(n)
        .zip(expected_frames.chunks(n))
        .zip(&unfolded)
        .filter(|(_, unfolded)| **unfolded)
        .flat_map(|((drawn, expected), _)| drawn.iter().zip(expected))
        .map(|(d, e)| Vec3::new(d[0], d[1], d[2]).distance(*e))
        .fold(0.0, f32::max);
    let folds = unfolded.iter().filter(|u| !**u).count();
    assert!(folds * 8 < unfolded.len(), "{folds} of {} strands folded", unfolded.len());
    assert!(drawn.iter().all(|v| v.iter().all(|c| c.is_finite())));
    assert!(positions.iter().all(|v| v[3] == 1.0) && frames.iter().all(|v| v[3] == 0.0));
    eprintln!("drawn positions within {position_error:e} m, frames within {frame_error:e} ({folds} strands folded)");
    assert!(position_error < 2e-6, "positions {position_error} m apart");
    // A frame turns with each segment's tangent, so it carries the tangents' rounding (the
    // positions' over a 1.7 cm segment) summed along the strand, a few hundredths of a
    // degree at most.
    assert!(frame_error < 3e-4, "frames {frame_error} apart");
    // The hair moved between the two steps, so the interpolation was tested.
    let moved = previous.iter().zip(last.iter()).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
    assert!(moved > 1e-3, "the last step moved the hair {moved} m");
    // After a reset nothing is drawn between before and after: halfway is the rest shape.
    strands.reset(head_pose(1.0));
    drawing.draw(&strands, 0.5, drawn_pose).expect("draw");
    let after_reset = read_vec4s(&gpu, &target);
    let off_rest = after_reset[..rest.positions.len()]
        .iter()
        .zip(&rest.positions)
        .map(|(d, &r)| Vec3::new(d[0], d[1], d[2]).distance(drawn_pose.transform_point(r)))
        .fold(0.0, f32::max);
    assert!(off_rest < 2e-6, "drawn {off_rest} m off the rest shape after a reset");
    // Drawing other strands is refused; a buffer too small is refused.
    let other = GpuStrands::new(&gpu, &rest, head_pose(0.0), None).expect("GPU strands");
    assert!(matches!(drawing.draw(&other, 0.0, drawn_pose), Err(GpuError::OtherStrands)));
    let small = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: 64,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    assert!(matches!(hair_gpu::GpuDrawing::new(&strands, &root_u, &small), Err(GpuError::DrawTarget { .. })));
}

/// The opacity map built on the GPU from particles in GPU memory shades every particle as
/// the CPU's `OpacityMap::build` does: the light that reaches each particle,
/// `exp(−k·coverage)` with the default self-shadow k, within 0.02 on average and 0.1 at
/// most, toward a directional and a point light; and a map of nothing says so.
#[test]
fn the_gpu_builds_the_opacity_map_the_cpu_builds() {
    use hair_gpu::{GpuOpacityMap, MAP_FLOATS, wgpu};
    use hair_sim::shadow::{Fibres, LightSource, MAP_SIZE, OpacityMap, fibre_areas};
    use wgpu::util::DeviceExt;
    let Some(gpu) = gpu() else { return };
    let (_, _, rest) = groom(512);
    let n = rest.particles_per_strand;
    let pose = head_pose(0.3);
    let points: Vec<Vec3> = rest.positions.iter().map(|&p| pose.transform_point(p)).collect();
    let vec4s: Vec<[f32; 4]> = points.iter().map(|p| [p.x, p.y, p.z, 1.0]).collect();
    let source = gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: bytemuck::cast_slice(&vec4s),
        usage: wgpu::BufferUsages::STORAGE,
    });
    // Two maps side by side, the second at an offset, as a groom lit by two lights has them.
    let target = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: (2 * MAP_FLOATS * 4) as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let fibres = Fibres { root_width: 8e-5, tip_width: 2e-5, strands_per_guide: 5.0 };
    let counts = [rest.strand_count() as u32, n as u32];
    let lights =
        [LightSource::Direction(Vec3::new(0.3, 1.0, 1.0).normalize()), LightSource::Position(Vec3::new(0.5, 2.2, 1.0))];
    let maps = GpuOpacityMap::new(&gpu.device, &source, counts[0] * counts[1], &target).expect("passes");
    let other = GpuOpacityMap::new(&gpu.device, &source, counts[0] * counts[1], &target).expect("passes");
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    maps.record(&gpu.queue, &mut encoder, lights[0], counts, fibres, 0).expect("recorded");
    other.record(&gpu.queue, &mut encoder, lights[1], counts, fibres, MAP_FLOATS as u32).expect("recorded");
    gpu.queue.submit([encoder.finish()]);
    let floats: Vec<f32> = read_vec4s(&gpu, &target).into_iter().flatten().collect();
    let areas = fibre_areas(&points, n, fibres);
    let k = 0.5;
    for (light, map) in lights.into_iter().zip(floats.chunks_exact(MAP_FLOATS)) {
        let cpu = OpacityMap::build(light, &points, &areas).expect("a map");
        let v = |at: usize| Vec3::new(map[at], map[at + 1], map[at + 2]);
        let cells = MAP_SIZE * MAP_SIZE;
        assert_eq!(map[3], cpu_w(light), "{light:?}: the map exists");
        let on_gpu = OpacityMap {
            source: light,
            right: v(4),
            up: v(8),
            forward: v(12),
            corner: [map[7], map[11]],
            cells_per_unit: map[15],
            first_layer: map[16],
            nearest: map[20..20 + cells].iter().map(|&d| if d == f32::MAX { f32::INFINITY } else { d }).collect(),
            coverage: map[20 + cells..].to_vec(),
        };
        let apart: Vec<f32> = points
            .iter()
            .map(|&p| ((-k * cpu.coverage_at(p)).exp() - (-k * on_gpu.coverage_at(p)).exp()).abs())
            .collect();
        let mean = apart.iter().sum::<f32>() / apart.len() as f32;
        let max = apart.iter().copied().fold(0.0, f32::max);
        let shaded = points.iter().filter(|&&p| (-k * cpu.coverage_at(p)).exp() < 0.8).count();
        eprintln!(
            "{light:?}: light reaching each particle, GPU against CPU: mean {mean:.4}, max {max:.4} apart; \
             {shaded} of {} shaded below 0.8 on the CPU",
            points.len()
        );
        assert!(shaded > points.len() / 10, "a groom shades itself: {shaded} shaded");
        assert!(mean <= 0.02 && max <= 0.1, "{light:?}: mean {mean}, max {max} apart");
    }
    // Nothing to map: the light's slot says so.
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    maps.record(&gpu.queue, &mut encoder, lights[0], [0, counts[1]], fibres, 0).expect("recorded");
    gpu.queue.submit([encoder.finish()]);
    assert_eq!(read_vec4s(&gpu, &target)[0][3], -1.0, "an empty map is marked");
}

/// The `w` of a map's light as `GpuOpacityMap` writes it where the map exists.
fn cpu_w(light: hair_sim::shadow::LightSource) -> f32 {
    match light {
        hair_sim::shadow::LightSource::Direction(_) => 0.0,
        hair_sim::shadow::LightSource::Position(_) => 1.0,
    }
}

/// The draw order sorted on the GPU is the CPU's `back_to_front` of the same positions: every
/// piece once, back to front (each piece no nearer the eye than the next, by the CPU's own
/// depths), and the same order where no two depths tie.
#[test]
fn the_gpu_sorts_the_pieces_as_the_cpu_does() {
    use hair_gpu::{GpuDrawOrder, wgpu};
    use hair_sim::draw_order::{back_to_front, pieces_per_strand};
    use wgpu::util::DeviceExt;
    let Some(gpu) = gpu() else { return };
    let (_, _, rest) = groom(700);
    let n = rest.particles_per_strand;
    let points: Vec<Vec3> = rest.positions.iter().map(|&p| head_pose(0.7).transform_point(p)).collect();
    let vec4s: Vec<[f32; 4]> = points.iter().map(|p| [p.x, p.y, p.z, 1.0]).collect();
    let source = gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: bytemuck::cast_slice(&vec4s),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let segments = 5;
    let pieces = rest.strand_count() * pieces_per_strand(n, segments);
    // The order written after 8 floats of something else, as the guide buffer holds it.
    let offset = 8;
    let target = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: ((offset + pieces).next_multiple_of(4) * 4) as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let sort = GpuDrawOrder::new(&gpu.device, &source, pieces as u32, &target).expect("passes");
    for eye in [Vec3::new(0.3, 1.7, 0.6), Vec3::new(-0.5, 1.2, -0.8)] {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        let counts = [rest.strand_count() as u32, n as u32];
        sort.record(&gpu.queue, &mut encoder, eye, counts, segments as u32, offset as u32).expect("recorded");
        gpu.queue.submit([encoder.finish()]);
        let floats: Vec<f32> = read_vec4s(&gpu, &target).into_iter().flatten().collect();
        let on_gpu: Vec<u32> = floats[offset..offset + pieces].iter().map(|&f| f as u32).collect();
        let on_cpu = back_to_front(&points, n, segments, eye);
        let mut seen = on_gpu.clone();
        seen.sort_unstable();
        assert!(seen.iter().copied().eq(0..pieces as u32), "every piece once");
        let depth = |piece: u32| {
            let (strand, k) =
                (piece as usize / pieces_per_strand(n, segments), piece as usize % pieces_per_strand(n, segments));
            points[strand * n + (k * segments + segments / 2).min(n - 1)].distance_squared(eye)
        };
        let out_of_order = on_gpu.windows(2).filter(|w| depth(w[0]) < depth(w[1]) * (1.0 - 1e-6)).count();
        let same = on_gpu.iter().zip(&on_cpu).filter(|(a, b)| a == b).count();
        eprintln!("eye {eye}: {pieces} pieces, {same} in the CPU's place, {out_of_order} nearer than the next");
        assert_eq!(out_of_order, 0, "back to front");
        assert!(same * 100 >= pieces * 99, "{same} of {pieces} pieces in the CPU's place");
    }
}
