use super::*;
use crate::math::Quat;
use crate::mesh::test_head;

#[test]
fn inside_and_outside_are_signed() {
    let collider = HeadCollider::new(&test_head(3), 32).unwrap();
    assert!(collider.signed_distance(Vec3::ZERO) < -0.07);
    let above = collider.signed_distance(Vec3::new(0.0, 0.2, 0.0));
    assert!((above - 0.09).abs() < 2e-3, "{above}");
}

/// Beyond the grid's exact band its values only bound the distance from below; a point
/// that deep in the head is still inside and still pushed out (the search for its
/// closest point once stopped at that bound and called points 5 cm deep clear).
#[test]
fn points_deep_in_the_head_are_pushed_out() {
    use crate::mesh::InsideTest;
    let head = test_head(4);
    let collider = HeadCollider::new(&head, 64).unwrap();
    let inside = InsideTest::new(&head);
    let thickness = 0.001;
    let mut tested = 0;
    for k in 0..200 {
        let t = k * 37 % head.triangles.len();
        let (surface, normal) = (head.point_at(t, [0.3, 0.3, 0.4]), head.normal_at(t, [0.3, 0.3, 0.4]));
        for depth in [0.001f32, 0.005, 0.01, 0.02, 0.03, 0.05] {
            let p = surface - normal * depth;
            // Measured by the independent inside test, not the collider's own distance.
            let Some(true_depth) = inside.depth(p).filter(|&d| d > 5e-4) else { continue };
            let contact = collider.resolve(p, thickness).unwrap_or_else(|| panic!("{p}, {true_depth} m deep: clear"));
            assert!((contact.depth - thickness - true_depth).abs() < 1e-4, "{p}: depth {}", contact.depth);
            assert!(!inside.contains(contact.position), "{p} pushed to {}, still inside", contact.position);
            tested += 1;
        }
    }
    assert!(tested > 1000, "{tested} points inside");
}

#[test]
fn pushes_out_along_the_normal_to_thickness() {
    let collider = HeadCollider::new(&test_head(4), 48).unwrap();
    let inside = Vec3::new(0.0, 0.10, 0.0); // 1 cm under the crown
    let contact = collider.resolve(inside, 0.005).expect("inside the head");
    assert!(contact.normal.y > 0.99, "normal {:?}", contact.normal);
    assert!((contact.position.y - 0.115).abs() < 1e-3, "{:?}", contact.position);
    assert!((contact.depth - 0.015).abs() < 1e-3);
    let after = collider.signed_distance(contact.position);
    assert!((after - 0.005).abs() < 1e-4, "ends at thickness: {after}");
    assert!(collider.resolve(Vec3::new(0.0, 0.3, 0.0), 0.005).is_none());
    assert!(collider.resolve(Vec3::new(0.0, 0.113, 0.0), 0.005).is_some(), "within thickness");
}

/// Where the reference's centre-ray push goes wrong: every triangle centre of the
/// procedural head, 1 mm under the surface along its normal, pushed out both ways with
/// no shell. Both end on the surface; the normal push moves it 1 mm, the centre ray by
/// `1 mm / cos(angle between ray and normal)`, sliding it along the surface: on the
/// skull up to 1.08× the depth, on the flanks of the ears up to 1.9×. This
/// head is star-shaped about its centre; a real one is not, and there the ray can leave
/// through another part of the surface altogether.
#[test]
fn the_centre_ray_push_slides_along_the_ears() {
    let head = test_head(4);
    let collider = HeadCollider::new(&head, 64).unwrap();
    let ear = |p: Vec3| p.normalize().angle_between(Vec3::new(p.x.signum(), 0.05, -0.1).normalize()) < 0.54;
    let (mut skull, mut ears) = (Vec::new(), Vec::new());
    for t in 0..head.triangles.len() {
        let (centre, normal) = (head.point_at(t, [1.0 / 3.0; 3]), head.normal_at(t, [1.0 / 3.0; 3]));
        let p = centre - normal * 1e-3;
        let by_normal = collider.resolve(p, 0.0).unwrap();
        let mut hint = ContactHint::NONE;
        let by_ray = collider.resolve_along_ray(p, 0.0, &mut hint, collider.centre()).unwrap();
        assert!(collider.signed_distance(by_ray.position).abs() < 2e-5, "the ray push ends on the surface");
        let moved = ((by_normal.position - p).length(), (by_ray.position - p).length());
        if ear(centre) { ears.push(moved) } else { skull.push(moved) }
    }
    let worst = |v: &[(f32, f32)]| v.iter().map(|&(n, r)| r / n).fold(0.0f32, f32::max);
    let over_2 = |v: &[(f32, f32)]| v.iter().filter(|&&(n, r)| r > 2.0 * n).count();
    println!(
        "1 mm deep: skull ({} triangles) ray push up to {:.2}× the normal push, {} over 2×; \
         ears ({}) up to {:.2}×, {} over 2×",
        skull.len(),
        worst(&skull),
        over_2(&skull),
        ears.len(),
        worst(&ears),
        over_2(&ears)
    );
    assert!(worst(&skull) < 1.1, "on the skull the ray is close to the normal");
    assert!(worst(&ears) > 1.5, "by the ears the ray push slides");
    assert_eq!(over_2(&skull) + over_2(&ears), 0, "star-shaped: the ray always leaves nearby");
}

/// [`NearQueryTables`] walked as their docs say (as the GPU solver walks them), with
/// nothing of the collider's own code, give every point near the procedural head (ears
/// included, 6 mm inside to 6 mm out) the signed distance the independent inside test
/// measures.
#[test]
fn the_near_query_tables_find_the_exact_distance() {
    use crate::groom::SplitMix64;
    use crate::mesh::InsideTest;
    let head = test_head(4);
    let collider = HeadCollider::new(&head, 64).unwrap();
    let inside = InsideTest::new(&head);
    let tables = collider.near_query_tables();
    let grid = collider.grid();
    let f = |word: u32| f32::from_bits(word);
    // The closest listed triangle to `p` (relative to the centre): distance, closest
    // point, the feature's pseudo-normal. `None` for a cell without a list.
    let walk = |p: Vec3| -> Option<(f32, Vec3, Vec3)> {
        let g = (p - grid.origin()) / grid.cell_size();
        let [x, y, z] = g.to_array().map(|v| v.floor() as usize);
        let [dx, dy, _] = grid.dims();
        let range = tables.cell_ranges[(z * dy + y) * dx + x];
        if range == u32::MAX {
            return None;
        }
        let offset = (g - g.floor() - Vec3::splat(0.5)) * grid.cell_size();
        let (first, count) = (range >> tables.count_bits, range & ((1 << tables.count_bits) - 1));
        let mut best: (f32, Vec3, Vec3) = (f32::INFINITY, Vec3::ZERO, Vec3::ZERO);
        for block in &tables.blocks[first as usize..][..count as usize] {
            if f(block[0]) - (offset.length() + tables.slack) >= best.0 {
                break;
            }
            for lane in 0..4 {
                let gradient = Vec3::new(f(block[4 + lane]), f(block[8 + lane]), f(block[12 + lane]));
                let by_centre = f(block[lane]) - (offset.length() + tables.slack);
                if by_centre.max(f(block[lane]) + gradient.dot(offset) - tables.slack) >= best.0 {
                    continue;
                }
                let t = &tables.triangles[block[16 + lane] as usize];
                let triangle = parry3d::shape::Triangle::new(t[0], t[1], t[2]);
                let (projection, location) = triangle.project_local_point_and_get_location(p, false);
                let distance = (p - projection.point).length();
                if distance < best.0 {
                    let normal = match location {
                        TrianglePointLocation::OnEdge(i, _) => t[4 + i as usize],
                        TrianglePointLocation::OnVertex(i) => t[7 + i as usize],
                        _ => t[3],
                    };
                    best = (distance, projection.point, normal);
                }
            }
        }
        Some(best)
    };
    let mut rng = SplitMix64::new(5);
    let (mut walked, mut inside_count) = (0, 0);
    for k in 0..4000 {
        let t = k * 7919 % head.triangles.len();
        let [u, v, h] = [rng.next_f32(), rng.next_f32(), rng.next_f32()];
        let bary = if u + v <= 1.0 { [u, v, 1.0 - u - v] } else { [1.0 - u, 1.0 - v, u + v - 1.0] };
        let p = head.point_at(t, bary) + head.normal_at(t, bary) * (h * 0.012 - 0.006);
        let Some((distance, closest, normal)) = walk(p - collider.centre()) else { continue };
        let signed = if (p - collider.centre() - closest).dot(normal) <= 0.0 { -distance } else { distance };
        let exact = if inside.contains(p) { -inside.distance(p) } else { inside.distance(p) };
        assert!((signed - exact).abs() < 1e-6, "{p}: the tables give {signed}, the inside test {exact}");
        walked += 1;
        inside_count += usize::from(signed < 0.0);
    }
    println!("{walked} of 4000 points walked the tables, {inside_count} of them inside");
    assert!(walked > 3600 && inside_count > 1000, "the tables answer near the surface, inside and out");
}

/// [`RiseTable`] read as its docs say gives the bound [`HeadCollider::rise_under`] gives,
/// for segments near the procedural head (ears included) and a few too long for it.
#[test]
fn the_rise_table_gives_the_colliders_bound() {
    let head = test_head(4);
    let collider = HeadCollider::new(&head, 64).unwrap();
    let table = collider.rise_table();
    let bound = |a: Vec3, b: Vec3| {
        let length = (b - a).length();
        let [x, y, z] = table.cells.locate(0.5 * (a + b)).to_array().map(|v| v as usize);
        let [convex, facet] = table.values[x + table.dims[0] * (y + table.dims[1] * z)];
        if length > table.max_length || convex * length > table.max_turn {
            f32::INFINITY
        } else {
            convex * length * length / 8.0 + facet
        }
    };
    let mut segments = segments_near(&head, 3, 2000);
    segments.extend((0..20).map(|k| (Vec3::new(0.0, 0.1, 0.0), Vec3::new(0.03 + 0.001 * k as f32, 0.1, 0.0))));
    let (mut finite, mut infinite) = (0, 0);
    for (a, b) in segments {
        let (ours, theirs) = (bound(a, b), collider.rise_under(0.5 * (a + b), (b - a).length()));
        assert_eq!(ours.to_bits(), theirs.to_bits(), "{a} to {b}: the table gives {ours}, the collider {theirs}");
        if ours.is_finite() { finite += 1 } else { infinite += 1 }
    }
    assert!(finite > 1000 && infinite > 20, "bounded and unbounded segments: {finite}, {infinite}");
}

/// Whole-segment collision clears a segment from its ends' clearances, so a clearance
/// must never exceed the true distance. Particles wander around the procedural head
/// (ears included, from inside to 6 cm out) carrying their hints; every clearance the
/// queries report is checked against the independent inside test's exact distance.
#[test]
fn a_reported_clearance_never_exceeds_the_true_distance() {
    use crate::groom::SplitMix64;
    use crate::mesh::InsideTest;
    let head = test_head(4);
    let collider = HeadCollider::new(&head, 64).unwrap();
    let inside = InsideTest::new(&head);
    let thickness = 0.003;
    let mut rng = SplitMix64::new(11);
    let mut unit = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - Vec3::ONE;
    let (mut cleared, mut beyond_thickness, mut tightness) = (0, 0, Vec::new());
    for walk in 0..300 {
        let t = walk * 7919 % head.triangles.len();
        let (on_surface, normal) = (head.point_at(t, [1.0 / 3.0; 3]), head.normal_at(t, [1.0 / 3.0; 3]));
        let mut p = on_surface + normal * (0.066 * (walk % 11) as f32 / 10.0 - 0.006);
        let mut hint = ContactHint::NONE;
        for _ in 0..30 {
            p += unit() * 0.003;
            if let Resolution::Clear(clearance) = collider.resolve_measuring(p, thickness, &mut hint) {
                let exact = inside.distance(p);
                assert!(!inside.contains(p), "{p} is inside, yet reported {clearance} clear");
                assert!(clearance >= thickness, "a clearance below the thickness: {clearance}");
                assert!(clearance <= exact + 2e-6, "{p}: reported {clearance}, true distance {exact}");
                cleared += 1;
                beyond_thickness += usize::from(clearance > 2.0 * thickness);
                tightness.push(clearance / exact);
            }
        }
    }
    tightness.sort_by(f32::total_cmp);
    let median = tightness[tightness.len() / 2];
    println!(
        "{cleared} clear answers, {beyond_thickness} beyond twice the thickness, median {median:.2} of the distance"
    );
    assert!(cleared > 4000 && beyond_thickness > 2000, "the walks test far and near answers");
    assert!(median > 0.4, "the clearance is a useful bound, not just the thickness");
}

/// Particles resting on the shell over 400 triangles' middles and over 400 edges'
/// middles, then lifted straight off the surface 0.5 mm a query up to 3 cm, carrying
/// their hints: beyond the clearance the face's or edge's certificate still bounds the
/// distance ([`Certificate::Beyond`]), so most answers there need no search, and none
/// reports more than the true distance (measured by the independent inside test).
#[test]
fn a_lifted_particle_is_cleared_without_a_search() {
    use crate::mesh::InsideTest;
    let head = test_head(4);
    let collider = HeadCollider::new(&head, 64).unwrap();
    let inside = InsideTest::new(&head);
    let thickness = 0.003;
    // Answers from the first hint's triangle or edge, beyond its clearance yet within
    // twice it less the thickness, and how many of those kept the hint (no search).
    let lift = |on_surface: Vec3, normal: Vec3, clearance: f32| {
        let (mut beyond, mut unsearched) = (0, 0);
        let mut hint = ContactHint::NONE;
        for step in 0..60 {
            let height = thickness + 0.0005 * step as f32;
            let p = on_surface + normal * height;
            let before = hint;
            let answer = collider.resolve_measuring(p, thickness, &mut hint);
            let exact = collider.resolve(p, thickness);
            match answer {
                Resolution::Clear(clearance) => {
                    assert!(exact.is_none(), "{p}: cleared, yet the exact query touches");
                    assert!(clearance <= inside.distance(p) + 2e-6, "{p}: reported {clearance}");
                }
                Resolution::Contact(contact) => {
                    let exact = exact.expect("touches as the exact query does");
                    assert!((contact.position - exact.position).length() < 1e-5);
                }
            }
            if matches!(before.0, Hint::Touching { .. }) && height > clearance && height < 2.0 * clearance - thickness {
                beyond += 1;
                // A search would have measured anew from here.
                unsearched += usize::from(hint == before);
            }
        }
        (beyond, unsearched)
    };
    let (mut faces, mut edges) = ((0, 0), (0, 0));
    for walk in 0..400 {
        let t = walk * 7919 % head.triangles.len();
        let (on_surface, normal) = (head.point_at(t, [1.0 / 3.0; 3]), head.normal_at(t, [1.0 / 3.0; 3]));
        let (beyond, unsearched) = lift(on_surface, normal, collider.triangles.get(t as u32).clearance());
        faces = (faces.0 + beyond, faces.1 + unsearched);
        // The middle of edge ab, lifted along the mean of its two faces' normals.
        let [a, b, _] = head.triangles[t];
        let middle = 0.5 * (head.positions[a as usize] + head.positions[b as usize]);
        let across = head.triangles.iter().position(|u| [[u[0], u[1]], [u[1], u[2]], [u[2], u[0]]].contains(&[b, a]));
        let across_normal = head.normal_at(across.expect("a closed head"), [1.0 / 3.0; 3]);
        let mean = (normal + across_normal).normalize();
        let (beyond, unsearched) = lift(middle, mean, collider.triangles.edge_clearance(t as u32, 0));
        edges = (edges.0 + beyond, edges.1 + unsearched);
    }
    println!("unsearched beyond the clearance: faces {} of {}, edges {} of {}", faces.1, faces.0, edges.1, edges.0);
    assert!(faces.0 > 2000 && edges.0 > 1000, "the lifts pass the clearance: {faces:?}, {edges:?}");
    assert!(faces.1 * 10 >= faces.0 * 9, "faces: {faces:?}");
    assert!(edges.1 * 10 >= edges.0 * 8, "edges: {edges:?}");
}

#[test]
fn ear_is_escaped_sideways_not_towards_the_centre() {
    // A point 4 mm under the steep flank of an ear, measured along the ray from the
    // head's centre: pushing along that ray moves it 4 mm; the surface normal points
    // sideways here, and pushing along it leaves by a much shorter way.
    let collider = HeadCollider::new(&test_head(5), 64).unwrap();
    let ear_axis = Vec3::new(1.0, 0.05, -0.1).normalize();
    let ray = Quat::from_axis_angle(ear_axis.cross(Vec3::Y).normalize(), 0.127) * ear_axis;
    let surface =
        (0..5000).map(|i| ray * (0.05 + i as f32 * 2e-5)).find(|&q| collider.signed_distance(q) > 0.0).unwrap();
    let p = surface - ray * 0.004;
    let d = collider.signed_distance(p);
    assert!(d < 0.0, "the test point is inside the ear: {d}");
    let contact = collider.resolve(p, 0.0).unwrap();
    let normal_push = (contact.position - p).length();
    assert!(collider.signed_distance(contact.position).abs() < 1e-5, "ends on the surface");
    assert!(normal_push < 0.7 * 0.004, "normal push {normal_push} vs 4 mm along the centre ray");
    assert!(contact.normal.dot(ray) < 0.8, "the normal leans sideways: {}", contact.normal.dot(ray));
}

#[test]
fn grid_agrees_with_the_bvh() {
    let collider = HeadCollider::new(&test_head(3), 24).unwrap();
    let err = collider.grid().max_error();
    let band = distance_grid::EXACT_BAND_CELLS * collider.grid().cell_size();
    for i in 0..200 {
        let f = i as f32 * 0.37;
        let p = Vec3::new(f.sin() * 0.15, (f * 1.3).cos() * 0.18, (f * 0.7).sin() * 0.16);
        if let Some(approx) = collider.grid().sample(p - collider.centre()) {
            let exact = collider.signed_distance(p);
            if exact.abs() < band - err {
                assert!((approx - exact).abs() <= err, "at {p:?}");
            } else {
                assert!(approx.abs() <= exact.abs() + err && approx.signum() == exact.signum(), "at {p:?}");
            }
        }
    }
}

#[test]
fn candidate_lists_agree_with_the_bvh() {
    let collider = HeadCollider::new(&test_head(4), 48).unwrap();
    let mut listed = 0;
    for i in 0..4000 {
        let f = i as f32 * 0.731;
        let dir = Vec3::new(f.sin(), (f * 1.37).cos(), (f * 0.53).sin()).normalize();
        let radius = 0.06 + 0.06 * ((f * 3.1).sin() * 0.5 + 0.5);
        let p = dir * radius;
        let Some(at) = collider.grid.locate(p) else { continue };
        let Near::Closest(closest) =
            collider.candidates.closest(&collider.triangles, &collider.mesh, p, at, f32::INFINITY)
        else {
            continue;
        };
        listed += 1;
        // `p` is relative to the collider's centre, as its grid and lists are.
        let exact = collider.signed_distance(p + collider.centre());
        let signed = if closest.inside { -1.0 } else { 1.0 } * (p - closest.point).length();
        assert!((signed - exact).abs() < 1e-6, "at {p:?}: {signed} vs {exact}");
        let near =
            matches!(collider.candidates.closest(&collider.triangles, &collider.mesh, p, at, 0.003), Near::Closest(_));
        assert_eq!(near, exact.abs() < 0.003, "at {p:?}: {exact}");
    }
    assert!(listed > 500, "most near points have a list: {listed}");
}

#[test]
fn the_measured_gap_never_exceeds_the_nearest_rising_triangle() {
    let collider = HeadCollider::new(&test_head(4), 48).unwrap();
    let all: Vec<u32> = (0..collider.mesh.indices().len() as u32).collect();
    let mut measured = 0;
    for i in 0..3000 {
        let f = i as f32 * 0.917;
        let dir = Vec3::new(f.sin(), (f * 1.29).cos(), (f * 0.61).sin()).normalize();
        let p = dir * (0.07 + 0.05 * ((f * 2.3).sin() * 0.5 + 0.5));
        let Some(at) = collider.grid.locate(p) else { continue };
        let Near::Closest(closest) =
            collider.candidates.closest(&collider.triangles, &collider.mesh, p, at, f32::INFINITY)
        else {
            continue;
        };
        if closest.gap == 0.0 {
            continue;
        }
        measured += 1;
        // Brute force over the whole mesh.
        let base = collider.triangles.get(closest.triangle);
        let nearest_rising = all
            .iter()
            .filter(|&&t| t != closest.triangle && collider.triangles.get(t).rises_above(base))
            .map(|&t| (p - collider.triangles.get(t).project(p).0).length())
            .fold(f32::INFINITY, f32::min);
        assert!(closest.gap <= nearest_rising + 1e-6, "at {p:?}: gap {} vs {nearest_rising}", closest.gap);
        assert!(closest.gap >= (p - closest.point).length(), "a measured gap covers the particle's own distance");
    }
    assert!(measured > 300, "points over a face outside get a gap: {measured}");
}

/// The crossing lists by the sharp features give what the BVH gives: random segments
/// near the procedural head at three resolutions (up to 2.5 cm long, 0–6 mm off the
/// surface, every other one a chord across it), those whose middle has a list. Where
/// the BVH sees a crossing, so do the lists, entering and leaving within 10 µm of it;
/// where the independent inside test sees one, so do they. A segment grazing an edge
/// may count for the lists and not the BVH (their slack), rarely.
#[test]
fn crossing_lists_agree_with_the_bvh() {
    use crate::mesh::InsideTest;
    for subdivisions in [3, 4, 5] {
        let head = test_head(subdivisions);
        let collider = HeadCollider::new(&head, 64).unwrap();
        let inside = InsideTest::new(&head);
        let (mut listed, mut crossing, mut only_lists) = (0, 0, 0);
        for (a, b) in segments_near(&head, 11, 40_000) {
            let (ca, cb) = (a - collider.centre, b - collider.centre);
            let Ok(lists) = collider.crossing.crossing(collider.sag.index_of(0.5 * (ca + cb)), ca, cb) else {
                continue;
            };
            listed += 1;
            let length = (b - a).length();
            let lists = lists.map(|(enters, leaves)| (enters * length, leaves * length));
            let bvh = collider.bvh_crossing(ca, cb, length, (b - a).normalize());
            assert_eq!(lists, collider.segment_crossing(a, b), "segment_crossing takes the list");
            match (lists, bvh) {
                (Some(l), Some(r)) => {
                    crossing += 1;
                    assert!(
                        (l.0 - r.0).abs() < 1e-5 && (l.1 - r.1).abs() < 1e-5,
                        "{subdivisions}: {a} – {b}: lists {l:?}, BVH {r:?}"
                    );
                }
                (None, Some(r)) => panic!("{subdivisions}: {a} – {b}: the BVH sees {r:?}, the lists nothing"),
                (Some(_), None) => only_lists += 1,
                (None, None) => {}
            }
            if inside.segment_crosses(a, b) {
                assert!(lists.is_some(), "{subdivisions}: {a} – {b} crosses the head; the lists miss it");
            }
        }
        println!(
            "subdivisions {subdivisions}: {listed} segments by sharp features, {crossing} crossing, {only_lists} only for the lists"
        );
        // Finer meshes (subdivision 5: 20,480 triangles) hold more triangles in reach
        // than a list takes, and mostly use the BVH.
        if subdivisions < 5 {
            assert!(listed > 1000, "{subdivisions}: only {listed} segments had lists");
            assert!(crossing > 100, "{subdivisions}: only {crossing} crossings to compare");
        }
        assert!(only_lists * 1000 <= listed, "{subdivisions}: {only_lists} grazing disagreements of {listed}");
    }
}

#[test]
fn empty_mesh_and_bad_resolutions_are_errors() {
    assert_eq!(HeadCollider::new(&HeadMesh::default(), 8).err(), Some(MeshError::Empty.into()));
    for bad in [0, 1, 7, 257, u32::MAX] {
        let err = HeadCollider::new(&test_head(1), bad).err();
        assert_eq!(err, Some(ColliderError::GridResolution(bad)));
        assert!(err.unwrap().to_string().contains("use 8 to 256"));
    }
}

/// A closed head wound inside out would make a collider that calls the inside outside:
/// it is refused, by name, and the repaired mesh (turned over) collides as the original.
#[test]
fn an_inside_out_head_is_refused_and_its_repair_collides() {
    let head = test_head(2);
    let mut flipped = head.clone();
    flipped.triangles.iter_mut().for_each(|t| t.swap(1, 2));
    let err = HeadCollider::new(&flipped, 16).err();
    assert!(matches!(err, Some(ColliderError::InsideOut { volume }) if volume < 0.0), "{err:?}");
    assert!(err.unwrap().to_string().contains("inside out"));
    let (repaired, repairs) = HeadMesh::repaired(flipped.positions, flipped.triangles).unwrap();
    assert!(repairs.flipped_winding);
    let (original, fixed) = (HeadCollider::new(&head, 16).unwrap(), HeadCollider::new(&repaired, 16).unwrap());
    for p in [Vec3::ZERO, Vec3::new(0.0, 0.2, 0.0), Vec3::new(0.05, 0.03, 0.02)] {
        assert_eq!(original.signed_distance(p), fixed.signed_distance(p), "at {p}");
    }
    assert!(fixed.signed_distance(Vec3::ZERO) < 0.0, "the centre is inside");
}

#[test]
fn a_sliver_does_not_make_far_points_inside() {
    // A zero-area sliver (three distinct collinear corners) on the skull, as a user's
    // mesh may have: kept, its zero normal read points up to 0.47 m away as inside.
    let mut head = test_head(3);
    let base = head.positions.len() as u32;
    let top = Vec3::new(0.0, 0.11, 0.0);
    head.positions.extend([top, top + Vec3::X * 0.01, top + Vec3::X * 0.02]);
    head.normals.extend([Vec3::Y; 3]);
    head.triangles.push([base, base + 1, base + 2]);
    let collider = HeadCollider::new(&head, 32).unwrap();
    let mut wrong = 0;
    for i in 0..400 {
        // Points on a shell from 1 mm to 0.5 m around the head, and inside it.
        let t = i as f32 * 0.618_034;
        let dir = Vec3::new(t.sin() * (3.1 * t).cos(), (1.7 * t).cos(), t.cos() * (2.3 * t).sin()).normalize();
        for reach in [-0.02, 0.001, 0.05, 0.47] {
            let surface = dir * 0.1;
            let p = surface + dir * reach;
            let inside = collider.signed_distance(p) < 0.0;
            if inside != head.contains_by_ray_parity(p) {
                wrong += 1;
            }
        }
    }
    assert_eq!(wrong, 0, "points whose inside/outside the collider gets wrong");
}
