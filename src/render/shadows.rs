//! Self-shadowing: the shadow-casting lights a groom's deep opacity maps follow, and the
//! maps themselves, built on the CPU (`hair_sim::shadow`) for a groom the CPU steps; the
//! GPU builds a GPU groom's (`hair_gpu::GpuOpacityMap`, recorded in the render world).

use super::{HairLook, StrandLayout};
use crate::convert::{from_sim, to_sim};
use bevy::prelude::*;
use bevy::tasks::{ComputeTaskPool, TaskPool};
use hair_sim::shadow::{Fibres, LightSource, MAP_LAYERS, MAP_SIZE, OpacityMap, fibre_areas};
use hair_sim::solver::Strands;
use std::borrow::Cow;

/// Deep opacity maps per groom at most: toward the first shadow-casting lights
/// (directional, then point, then spot).
pub const MAX_OPACITY_MAPS: usize = 4;

/// `vec4`s of a map's header in the guide buffer (`strand.wgsl`'s `MAP_HEADER`).
const MAP_HEADER: usize = 5;

/// `vec4`s after the head's centre for `maps` opacity maps: their count, then per map its
/// header, each cell's nearest strand and the coverage (four values per `vec4`).
pub(super) fn opacity_maps_len(maps: usize) -> usize {
    if maps == 0 { 0 } else { 1 + maps * (MAP_HEADER + MAP_SIZE * MAP_SIZE * (1 + MAP_LAYERS) / 4) }
}

/// This frame's lights whose shadows self-shadowing follows: those casting shadows,
/// directional first, at most [`MAX_OPACITY_MAPS`]. Found once a frame for every groom.
#[derive(Resource, Default)]
pub(super) struct ShadowCastingLights(pub Vec<LightSource>);

/// Finds this frame's [`ShadowCastingLights`].
pub(super) fn find_shadow_casting_lights(
    directional: Query<(&DirectionalLight, &GlobalTransform)>,
    points: Query<(&PointLight, &GlobalTransform)>,
    spots: Query<(&SpotLight, &GlobalTransform)>,
    mut found: ResMut<ShadowCastingLights>,
) {
    let directional = directional
        .iter()
        .filter(|(light, _)| light.shadow_maps_enabled)
        .map(|(_, at)| LightSource::Direction(to_sim(at.back().as_vec3())));
    let points = points.iter().filter(|(light, _)| light.shadow_maps_enabled).map(|(_, at)| at.translation());
    let spots = spots.iter().filter(|(light, _)| light.shadow_maps_enabled).map(|(_, at)| at.translation());
    let positioned = points.chain(spots).map(|at| LightSource::Position(to_sim(at)));
    found.0.clear();
    found.0.extend(directional.chain(positioned).take(MAX_OPACITY_MAPS));
}

/// Room for `slots` opacity maps the GPU writes, and their count: one per light, as many
/// as there is room for.
pub(super) fn reserve_opacity_maps(data: &mut Vec<Vec4>, slots: usize, lights: usize) {
    if slots == 0 {
        return;
    }
    data.push(Vec4::new(lights.min(slots) as f32, 0.0, 0.0, 0.0));
    data.resize(data.len() + slots * (opacity_maps_len(1) - 1), Vec4::ZERO);
}

/// Appends the opacity maps of `samples` (the guide particles, world space, and their
/// [`fibre_areas`]) toward `lights` to `data` in `slots` slots.
pub(super) fn write_opacity_maps(
    data: &mut Vec<Vec4>,
    slots: usize,
    lights: &[LightSource],
    (points, areas): (&[hair_sim::math::Vec3], &[f32]),
) {
    if slots == 0 {
        return;
    }
    // One task per light; the maps come back in the lights' order.
    let maps: Vec<OpacityMap> = ComputeTaskPool::get_or_init(TaskPool::default)
        .scope(|scope| {
            for &light in lights.iter().take(slots) {
                scope.spawn(async move { OpacityMap::build(light, points, areas) });
            }
        })
        .into_iter()
        .flatten()
        .collect();
    data.push(Vec4::new(maps.len() as f32, 0.0, 0.0, 0.0));
    let v = |v: hair_sim::math::Vec3, w: f32| from_sim(v).extend(w);
    for map in &maps {
        let source = match map.source {
            LightSource::Direction(d) => v(d, 0.0),
            LightSource::Position(p) => v(p, 1.0),
        };
        data.extend([
            source,
            v(map.right, map.corner[0]),
            v(map.up, map.corner[1]),
            v(map.forward, map.cells_per_unit),
            Vec4::new(map.first_layer, 0.0, 0.0, 0.0),
        ]);
        // Empty cells' nearest strand is infinitely far: WGSL has no infinity, so the
        // largest float (nothing lies behind it).
        let nearest = map.nearest.iter().map(|&d| d.min(f32::MAX));
        let tables: Vec<f32> = nearest.chain(map.coverage.iter().copied()).collect();
        data.extend(tables.chunks_exact(4).map(Vec4::from_slice));
    }
    // Unused slots keep the buffer its size.
    data.resize(data.len() + (slots - maps.len()) * (opacity_maps_len(1) - 1), Vec4::ZERO);
}

/// The fibres a groom's opacity maps count: its strands' widths, and the strands drawn per
/// guide.
pub(super) fn fibres(look: &HairLook, layout: &StrandLayout) -> Fibres {
    Fibres {
        root_width: look.root_width,
        tip_width: look.tip_width,
        strands_per_guide: layout.strands_per_guide as f32,
    }
}

/// What a groom's opacity maps are built from (`points`, strand-major, `n` per guide):
/// every guide particle with the fibre area it stands for, or, at a level of detail
/// ([`HairLod`](crate::HairLod)), the particles of the guides the solver steps alone, each
/// standing for its share of all of them: the same fibre area, spread as the simulated
/// guides are (coarser, which a head drawn a few dozen pixels tall does not show), for the
/// share of the work the level simulates (a map's cost follows its particles).
pub(super) fn shadow_samples<'a>(
    points: &'a [hair_sim::math::Vec3],
    n: usize,
    strands: &Strands,
    fibres: Fibres,
) -> (Cow<'a, [hair_sim::math::Vec3]>, Vec<f32>) {
    let all = strands.strand_count();
    let kept: Vec<usize> = (0..all).filter(|&s| !strands.is_following(s)).collect();
    if kept.len() == all || kept.is_empty() || points.len() != all * n {
        return (Cow::Borrowed(points), fibre_areas(points, n, fibres));
    }
    let kept_points: Vec<_> = kept.iter().flat_map(|&s| points[s * n..(s + 1) * n].iter().copied()).collect();
    let share = all as f32 / kept.len() as f32;
    let fibres = Fibres { strands_per_guide: fibres.strands_per_guide * share, ..fibres };
    let areas = fibre_areas(&kept_points, n, fibres);
    (Cow::Owned(kept_points), areas)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_far_groom_shadows_from_its_simulated_guides_with_the_same_fibre_area() {
        // 64 straight guides of 4 particles on a 8 × 8 grid of roots, 1 cm apart.
        let n = 4;
        let rest: Vec<_> = (0..64)
            .flat_map(|s| {
                (0..n).map(move |j| Vec3::new((s % 8) as f32 * 0.01, -0.02 * j as f32, (s / 8) as f32 * 0.01))
            })
            .map(to_sim)
            .collect();
        let rest = hair_sim::solver::RestShape::new(rest, n).unwrap();
        let mut strands = Strands::new(rest, hair_sim::math::Pose::IDENTITY);
        let fibres = Fibres { root_width: 1e-4, tip_width: 5e-5, strands_per_guide: 16.0 };
        let points = strands.positions().to_vec();
        let total = |areas: &[f32]| areas.iter().sum::<f32>();
        let (every, every_area) = shadow_samples(&points, n, &strands, fibres);
        assert_eq!(every.len(), 64 * n, "full detail: every guide");
        strands.set_detail_level(3, 0);
        let (few, few_area) = shadow_samples(&points, n, &strands, fibres);
        assert_eq!(few.len(), 8 * n, "level 3: the 8 simulated guides");
        let (a, b) = (total(&every_area), total(&few_area));
        assert!((a - b).abs() <= 1e-5 * a, "fibre area {a} at full detail, {b} at level 3");
    }
}
