//! How much hair lies between a point and a light: deep opacity maps (Yuksel & Keyser,
//! "Deep Opacity Maps", 2008), built from the guide strands on the CPU every frame and
//! looked up by the hair shader, so the inner and lower layers of a head of hair fall into
//! the shade of the outer ones. GPU twin: `hair_gpu`'s `GpuOpacityMap` (`shadow.wgsl`).
//!
//! A map covers the hair as the light sees it: a grid of `size × size` cells across the
//! light's view (orthographic for a directional light, perspective for a point or spot
//! light), each cut into `layers` slices along its rays from the first strand the light
//! meets in that cell, thin there (where the eye sees the detail) and thicker each slice
//! (the `k`-th is `k + 1` times the first), so the slices of every cell reach through the
//! whole groom. Each strand sample deposits the area its fibres cover (length × width ×
//! fibres), divided by the cell's area, into the cells and slices around it (bilinearly
//! across, linearly along the rays, so a map changes smoothly as the hair or the light
//! moves). Summed slice by slice from the light, a cell holds how many layers of fibres a
//! ray crosses before the far side of each slice; the shader's transmittance is
//! `exp(−opacity · coverage)` (the fibre-count approximation TressFX makes from its shadow
//! map, here with the count measured instead of inferred from depth).

use crate::math::Vec3;
use glam::Vec4;

/// Cells across a map, per side.
pub const MAP_SIZE: usize = 32;
/// Slices along the light's rays.
pub const MAP_LAYERS: usize = 16;
/// A footprint's cell that lies off the grid.
const OFF_GRID: usize = usize::MAX;

/// The four cells around a point and their bilinear weights ([`OpacityMap::footprint`]).
type Footprint = [(usize, f32); 4];

/// Where a light is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightSource {
    /// A directional light: the unit vector toward it.
    Direction(Vec3),
    /// A point or spot light at this position.
    Position(Vec3),
}

/// The fibre coverage of a groom toward one light. [`OpacityMap::coverage_at`] is the
/// lookup the shader mirrors.
#[derive(Clone, Debug, PartialEq)]
pub struct OpacityMap {
    /// The light the map was built for.
    pub source: LightSource,
    /// Across the light's view, to the right and up, and along its rays (unit vectors).
    pub right: Vec3,
    /// See [`Self::right`].
    pub up: Vec3,
    /// See [`Self::right`].
    pub forward: Vec3,
    /// The light-space (right, up) coordinates of the grid's corner: metres for a
    /// directional light, tangents of the angle off `forward` for a point light.
    pub corner: [f32; 2],
    /// Cells per unit of those coordinates.
    pub cells_per_unit: f32,
    /// Thickness of each cell's first slice, metres.
    pub first_layer: f32,
    /// Per cell (row by row): the distance along the rays of the first strand sample in it,
    /// where its slices start, metres (from the light for a point light, along `forward`
    /// from the origin for a directional one); infinite in a cell without hair.
    pub nearest: Vec<f32>,
    /// Per slice, row and cell (cells fastest): the layers of fibres a ray crosses from the
    /// light to the slice's far side.
    pub coverage: Vec<f32>,
}

/// How wide a groom's strands are drawn and how many each guide stands for: what turns
/// its guide particles into fibre areas for [`OpacityMap::build`] ([`fibre_areas`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fibres {
    /// Ribbon width at the root, metres.
    pub root_width: f32,
    /// Ribbon width at the tip, metres.
    pub tip_width: f32,
    /// Strands drawn per guide (the guide and its children).
    pub strands_per_guide: f32,
}

/// The fibre area each guide particle stands for in an opacity map (`positions`,
/// strand-major, `particles` per guide): its guide's strands along the segment to its
/// parent (none at the root).
pub fn fibre_areas(positions: &[Vec3], particles: usize, fibres: Fibres) -> Vec<f32> {
    let n = particles.max(2);
    (0..positions.len())
        .map(|i| {
            let j = i % n;
            if j == 0 {
                return 0.0;
            }
            let width = fibres.root_width + (fibres.tip_width - fibres.root_width) * j as f32 / (n - 1) as f32;
            fibres.strands_per_guide * width.max(0.0) * (positions[i] - positions[i - 1]).length()
        })
        .collect()
}

impl OpacityMap {
    /// The map of `points` (world space), each covering `areas[i]` square metres of fibre
    /// (its segment's length × ribbon width × the strands it stands for), toward `source`.
    /// `None` without points in front of the light.
    pub fn build(source: LightSource, points: &[Vec3], areas: &[f32]) -> Option<OpacityMap> {
        let finite: Vec<(Vec3, f32)> = points
            .iter()
            .zip(areas)
            .filter(|(p, a)| p.is_finite() && a.is_finite() && **a > 0.0)
            .map(|(&p, &a)| (p, a))
            .collect();
        if finite.is_empty() {
            return None;
        }
        let centre = finite.iter().map(|(p, _)| *p).sum::<Vec3>() / finite.len() as f32;
        let forward = match source {
            LightSource::Direction(to_light) => -to_light.try_normalize()?,
            LightSource::Position(at) => (centre - at).try_normalize()?,
        };
        let (right, up) = forward.any_orthonormal_pair();
        let mut map = OpacityMap {
            source,
            right,
            up,
            forward,
            corner: [0.0; 2],
            cells_per_unit: 1.0,
            first_layer: 1.0,
            nearest: vec![f32::INFINITY; MAP_SIZE * MAP_SIZE],
            coverage: vec![0.0; MAP_SIZE * MAP_SIZE * MAP_LAYERS],
        };
        // Fit the grid to the points, a cell of margin across and half a slice along.
        let projected: Vec<([f32; 3], f32)> =
            finite.iter().filter_map(|&(p, a)| map.project(p).map(|uvd| (uvd, a))).collect();
        if projected.is_empty() {
            return None;
        }
        let (mut low, mut high) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for (uvd, _) in &projected {
            for k in 0..3 {
                low[k] = low[k].min(uvd[k]);
                high[k] = high[k].max(uvd[k]);
            }
        }
        let span = (high[0] - low[0]).max(high[1] - low[1]).max(1e-6);
        map.cells_per_unit = (MAP_SIZE - 2) as f32 / span;
        let margin = 1.0 / map.cells_per_unit;
        let middle = [0.5 * (low[0] + high[0]), 0.5 * (low[1] + high[1])];
        map.corner = [middle[0] - 0.5 * span - margin, middle[1] - 0.5 * span - margin];
        // Slices `first_layer`, twice, three times… that thick span the groom's depth.
        let depth = (high[2] - low[2]).max(1e-4);
        map.first_layer = depth / (MAP_LAYERS * (MAP_LAYERS + 1) / 2) as f32;

        // Each sample's footprint, depth and layers of fibre, worked out once for the two
        // passes below.
        let footprints: Vec<(Footprint, f32, f32)> = projected
            .iter()
            .map(|&(uvd, area)| {
                let [x, y] = map.cell_coordinates(uvd);
                (Self::footprint(x, y), uvd[2], area / map.cell_area(uvd[2]))
            })
            .collect();
        // Where each cell's slices start: its first sample (bilinear footprints included).
        for (footprint, depth, _) in &footprints {
            for &(cell, _) in footprint.iter().filter(|(cell, _)| *cell != OFF_GRID) {
                map.nearest[cell] = map.nearest[cell].min(*depth);
            }
        }
        // Deposit each sample's coverage (bilinear across, linear along), then sum from the
        // light. Cell by cell, so that a sample's two slices share a cache line.
        let mut deposits = vec![0.0f32; map.coverage.len()];
        for &(footprint, depth, layers) in &footprints {
            // The four cells of the footprint side by side: their slice coordinates (a
            // square root each, which `slice_coordinate` spells out) in one vector.
            let nearest = Vec4::from_array(footprint.map(|(cell, _)| map.nearest.get(cell).copied().unwrap_or(0.0)));
            // Every cell of a sample's footprint starts at or before it (the pass above).
            let behind = ((Vec4::splat(depth) - nearest) / map.first_layer).max(Vec4::ZERO);
            let z = (((Vec4::ONE + behind * 8.0).sqrt() - Vec4::ONE) * 0.5).to_array();
            for ((cell, weight), z) in footprint.into_iter().zip(z) {
                if cell == OFF_GRID {
                    continue;
                }
                let z0 = floor(z);
                let fz = z - z0;
                for (dz, wz) in [(0, 1.0 - fz), (1, fz)] {
                    let layer = (z0 as usize + dz).min(MAP_LAYERS - 1);
                    deposits[cell * MAP_LAYERS + layer] += layers * weight * wz;
                }
            }
        }
        let slice = MAP_SIZE * MAP_SIZE;
        for cell in 0..slice {
            let mut sum = 0.0;
            for (layer, deposit) in deposits[cell * MAP_LAYERS..][..MAP_LAYERS].iter().enumerate() {
                sum += deposit;
                map.coverage[layer * slice + cell] = sum;
            }
        }
        Some(map)
    }

    /// How many layers of fibres lie between `p` and the light: in each cell around it
    /// (bilinearly) the summed coverage a slice before `p`'s (so a strand does not shade
    /// itself), interpolated between slices; 0 outside the map's cells and in front of a
    /// cell's first strand.
    pub fn coverage_at(&self, p: Vec3) -> f32 {
        let Some(uvd) = self.project(p) else { return 0.0 };
        let [x, y] = self.cell_coordinates(uvd);
        let mut sum = 0.0;
        for (cell, weight) in Self::footprint(x, y).into_iter().filter(|(cell, _)| *cell != OFF_GRID) {
            let z = self.slice_coordinate(uvd[2], cell) - 1.0;
            if z < -1.0 {
                continue; // in front of the cell's first slice, or an empty cell
            }
            let z0 = floor(z);
            let fz = z - z0;
            for (dz, wz) in [(0, 1.0 - fz), (1, fz)] {
                // Beyond the last slice every fibre of the column is in front.
                let layer = z0 as i64 + dz;
                if layer >= 0 {
                    let layer = (layer as usize).min(MAP_LAYERS - 1);
                    sum += self.coverage[layer * MAP_SIZE * MAP_SIZE + cell] * weight * wz;
                }
            }
        }
        sum
    }

    /// The four cells a point at cell coordinates `(x, y)` touches and their bilinear
    /// weights (cell `i` is sampled at `i`); a cell off the grid is [`OFF_GRID`].
    #[inline]
    fn footprint(x: f32, y: f32) -> Footprint {
        let (x0, y0) = (floor(x), floor(y));
        let (fx, fy) = (x - x0, y - y0);
        [(0, 0, (1.0 - fx) * (1.0 - fy)), (1, 0, fx * (1.0 - fy)), (0, 1, (1.0 - fx) * fy), (1, 1, fx * fy)].map(
            |(dx, dy, w)| {
                let (cx, cy) = (x0 as i64 + dx, y0 as i64 + dy);
                let inside = |v: i64| (0..MAP_SIZE as i64).contains(&v);
                (if inside(cx) && inside(cy) { cy as usize * MAP_SIZE + cx as usize } else { OFF_GRID }, w)
            },
        )
    }

    /// Where distance `d` along the rays falls among cell `cell`'s slices: slice `k` spans
    /// `k..k + 1` (it starts `k (k + 1) / 2` first slices behind the cell's first strand);
    /// -1 in front of that strand and in an empty cell.
    fn slice_coordinate(&self, d: f32, cell: usize) -> f32 {
        let behind = (d - self.nearest[cell]) / self.first_layer;
        if behind < 0.0 {
            return -1.0;
        }
        0.5 * ((1.0 + 8.0 * behind).sqrt() - 1.0)
    }

    /// Light-space (right, up, distance along the rays) of `p`; `None` behind a point light.
    fn project(&self, p: Vec3) -> Option<[f32; 3]> {
        match self.source {
            LightSource::Direction(_) => Some([p.dot(self.right), p.dot(self.up), p.dot(self.forward)]),
            LightSource::Position(at) => {
                let d = p - at;
                let along = d.dot(self.forward);
                (along > 1e-4).then(|| [d.dot(self.right) / along, d.dot(self.up) / along, d.length()])
            }
        }
    }

    /// Cell coordinates (continuous; cell `i` is sampled at `i`) of a light-space point.
    fn cell_coordinates(&self, [u, v, _]: [f32; 3]) -> [f32; 2] {
        [(u - self.corner[0]) * self.cells_per_unit, (v - self.corner[1]) * self.cells_per_unit]
    }

    /// The area, square metres, a cell covers at distance `d` along the rays.
    fn cell_area(&self, d: f32) -> f32 {
        let side = 1.0 / self.cells_per_unit;
        match self.source {
            LightSource::Direction(_) => side * side,
            LightSource::Position(_) => (side * d) * (side * d),
        }
    }
}

/// `x.floor()` for the map's coordinates (far inside `i32`), without the library call that
/// `f32::floor` compiles to on CPUs before SSE4.1.
#[inline]
fn floor(x: f32) -> f32 {
    let truncated = x as i32 as f32;
    if truncated > x { truncated - 1.0 } else { truncated }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A slab of fibres 10 cm square, 4 cm thick (z from 0 to 0.04), lit from +Z: `rows`
    /// sheets of parallel strands, each sheet one layer of fibres (strands side by side).
    fn slab(rows: usize) -> (Vec<Vec3>, Vec<f32>) {
        let (mut points, mut areas) = (Vec::new(), Vec::new());
        let step = 0.0025;
        for row in 0..rows {
            let z = 0.04 * row as f32 / (rows - 1) as f32;
            for i in 0..40 {
                for j in 0..40 {
                    points.push(Vec3::new(i as f32 * step, j as f32 * step, z));
                    // A sample stands for a 2.5 mm piece of strand, 2.5 mm wide: one layer.
                    areas.push(step * step);
                }
            }
        }
        (points, areas)
    }

    #[test]
    fn each_particle_stands_for_its_segment_of_fibres() {
        // Two straight guides of 3 particles, 1 cm segments, 3 strands each, 1 mm wide at
        // the root and 0.5 mm at the tip.
        let positions: Vec<Vec3> =
            (0..6).map(|k| Vec3::new(0.01 * (k / 3) as f32, -0.01 * (k % 3) as f32, 0.0)).collect();
        let fibres = Fibres { root_width: 0.001, tip_width: 0.0005, strands_per_guide: 3.0 };
        let areas = fibre_areas(&positions, 3, fibres);
        let expected = [0.0, 3.0 * 0.00075 * 0.01, 3.0 * 0.0005 * 0.01];
        for (area, want) in areas.iter().zip(expected.iter().cycle()) {
            assert!((area - want).abs() < 1e-10, "{areas:?}");
        }
    }

    #[test]
    fn coverage_counts_the_layers_in_front() {
        let (points, areas) = slab(9);
        let map = OpacityMap::build(LightSource::Direction(Vec3::Z), &points, &areas).unwrap();
        // Above the slab nothing is in front; in its middle about half the sheets; below
        // it, all nine (within the ±12 % that 2.5 mm samples on 3.25 mm cells alias by).
        let at = |z: f32| map.coverage_at(Vec3::new(0.05, 0.05, z));
        let (top, middle, bottom) = (at(0.041), at(0.02), at(-0.004));
        assert!(top < 0.6, "above: {top}");
        assert!((3.0..6.0).contains(&middle), "middle: {middle}");
        assert!((7.9..10.1).contains(&bottom), "below: {bottom}");
        // Monotonic down through the slab.
        let samples: Vec<f32> = (0..=20).map(|k| at(0.045 - 0.0025 * k as f32)).collect();
        assert!(samples.windows(2).all(|w| w[1] >= w[0] - 1e-4), "{samples:?}");
    }

    #[test]
    fn a_point_light_sees_the_same_slab() {
        let (points, areas) = slab(9);
        let light = LightSource::Position(Vec3::new(0.05, 0.05, 2.0));
        let map = OpacityMap::build(light, &points, &areas).unwrap();
        let bottom = map.coverage_at(Vec3::new(0.05, 0.05, -0.004));
        assert!((7.9..10.1).contains(&bottom), "below: {bottom}");
        assert!(map.coverage_at(Vec3::new(0.05, 0.05, 0.041)) < 0.6);
        // Behind the light nothing is in front.
        assert_eq!(map.coverage_at(Vec3::new(0.0, 0.0, 3.0)), 0.0);
    }

    /// A light turned by 0.1° changes the coverage everywhere by a small fraction: the map
    /// is smooth in the light's direction (no acne).
    #[test]
    fn a_slightly_turned_light_changes_little() {
        let (points, areas) = slab(9);
        let to_light = Vec3::new(0.3, 0.2, 1.0).normalize();
        let turned = glam::Quat::from_rotation_x(0.1f32.to_radians()) * to_light;
        let a = OpacityMap::build(LightSource::Direction(to_light), &points, &areas).unwrap();
        let b = OpacityMap::build(LightSource::Direction(turned), &points, &areas).unwrap();
        for p in [Vec3::new(0.05, 0.05, 0.0), Vec3::new(0.03, 0.06, 0.02), Vec3::new(0.07, 0.04, 0.01)] {
            let (ca, cb) = (a.coverage_at(p), b.coverage_at(p));
            assert!((ca - cb).abs() <= 0.05 * ca.max(1.0), "{p}: {ca} vs {cb}");
        }
    }

    #[test]
    fn nothing_to_map_is_none() {
        assert!(OpacityMap::build(LightSource::Direction(Vec3::Z), &[], &[]).is_none());
        let nan = [Vec3::NAN];
        assert!(OpacityMap::build(LightSource::Direction(Vec3::Z), &nan, &[1.0]).is_none());
        assert!(OpacityMap::build(LightSource::Direction(Vec3::ZERO), &[Vec3::ONE], &[1.0]).is_none());
    }
}
