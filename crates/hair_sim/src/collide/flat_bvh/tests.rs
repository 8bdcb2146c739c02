use super::*;
use parry3d::query::PointQuery;
use parry3d::shape::Triangle;

/// A lumpy closed-ish sphere of triangles, and some slivers.
fn soup() -> Vec<[Vec3; 3]> {
    let mut triangles = Vec::new();
    let at = |u: f32, v: f32| {
        let r = 0.1 * (1.0 + 0.2 * (5.0 * u).sin() * (3.0 * v).cos());
        Vec3::new(r * v.sin() * u.cos(), r * v.cos(), r * v.sin() * u.sin())
    };
    let (nu, nv) = (40, 20);
    for i in 0..nu {
        for j in 0..nv {
            let (u0, u1) =
                (i as f32 / nu as f32 * std::f32::consts::TAU, (i + 1) as f32 / nu as f32 * std::f32::consts::TAU);
            let (v0, v1) =
                (j as f32 / nv as f32 * std::f32::consts::PI, (j + 1) as f32 / nv as f32 * std::f32::consts::PI);
            triangles.push([at(u0, v0), at(u1, v0), at(u1, v1)]);
            triangles.push([at(u0, v0), at(u1, v1), at(u0, v1)]);
        }
    }
    triangles.push([Vec3::new(0.3, 0.0, 0.0), Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.4, 1e-7, 0.0)]);
    triangles
}

fn points() -> impl Iterator<Item = Vec3> {
    (0..400).map(|k| {
        let k = k as f32;
        Vec3::new((k * 0.37).sin(), (k * 0.71).cos(), (k * 1.13).sin()) * (0.02 + 0.3 * ((k * 0.05).sin().abs()))
    })
}

#[test]
fn every_triangle_sits_in_one_leaf_inside_every_box_above_it() {
    let triangles = soup();
    let bvh = FlatBvh::new(&triangles);
    let mut sorted = bvh.order.clone();
    sorted.sort_unstable();
    assert_eq!(sorted, (0..triangles.len() as u32).collect::<Vec<_>>());
    let mut in_leaves = 0;
    for (k, node) in bvh.nodes.iter().enumerate() {
        assert!(node.skip as usize > k && node.skip as usize <= bvh.nodes.len());
        assert!(node.count as usize <= FlatBvh::LEAF_SIZE);
        // Every node of the subtree, and every corner of its leaves, lies in the box.
        for inner in &bvh.nodes[k..node.skip as usize] {
            assert!(inner.min.cmpge(node.min).all() && inner.max.cmple(node.max).all());
            for &t in &bvh.order[inner.first as usize..(inner.first + inner.count) as usize] {
                assert!(triangles[t as usize].iter().all(|c| c.cmpge(node.min).all() && c.cmple(node.max).all()));
            }
        }
        in_leaves += node.count;
    }
    assert_eq!(in_leaves as usize, triangles.len());
}

#[test]
fn the_nearest_triangle_is_the_one_every_triangle_tested_finds() {
    let triangles = &soup();
    let bvh = FlatBvh::new(triangles);
    let distance = |p: Vec3| {
        move |t: u32| {
            let [a, b, c] = triangles[t as usize];
            (p - Triangle::new(a, b, c).project_local_point(p, false).point).length()
        }
    };
    for p in points() {
        let (_, found) = bvh.nearest(p, distance(p)).expect("triangles");
        let every = (0..triangles.len() as u32).map(distance(p)).fold(f32::INFINITY, f32::min);
        assert_eq!(found, every, "at {p}");
    }
    assert_eq!(FlatBvh::new(&[]).nearest(Vec3::ZERO, |_| 0.0), None);
}

#[test]
fn the_first_hit_is_the_nearest_of_every_triangle_hit() {
    let triangles = &soup();
    let bvh = FlatBvh::new(triangles);
    // A ray against a triangle, both sides (Möller–Trumbore).
    let hit = |origin: Vec3, d: Vec3| {
        move |t: u32| -> Option<f32> {
            let [a, b, c] = triangles[t as usize];
            let (e1, e2) = (b - a, c - a);
            let q = d.cross(e2);
            let det = e1.dot(q);
            if det.abs() < 1e-12 {
                return None;
            }
            let s = origin - a;
            let u = s.dot(q) / det;
            let r = s.cross(e1);
            let v = d.dot(r) / det;
            let at = e2.dot(r) / det;
            (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && at >= 0.0).then_some(at)
        }
    };
    let mut hits = 0;
    for (p, q) in points().zip(points().skip(7)) {
        let Some(d) = (q - p).try_normalize() else { continue };
        let reach = (q - p).length();
        let found = bvh.first_hit(p, d, reach, hit(p, d));
        let every = (0..triangles.len() as u32).filter_map(hit(p, d)).filter(|&t| t <= reach).reduce(f32::min);
        assert_eq!(found, every, "from {p} to {q}");
        hits += usize::from(found.is_some());
    }
    // Along the axes too: directions with zero components (off the poles, where the
    // sphere's triangles are slivers along the axis).
    let origin = Vec3::new(0.01, 0.02, -0.015);
    for d in [Vec3::X, Vec3::NEG_Y, Vec3::Z] {
        let found = bvh.first_hit(origin, d, 1.0, hit(origin, d));
        let every = (0..triangles.len() as u32).filter_map(hit(origin, d)).reduce(f32::min);
        assert_eq!(found, every, "along {d}");
        assert!(found.is_some(), "from inside along {d}");
    }
    assert!(hits > 50, "{hits} of the segments hit the soup");
}
