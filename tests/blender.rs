//! Heads and grooms made in Blender, as an artist brings them in: `assets/blender/` holds
//! what `tools/blender/make_test_groom.py` made in Debian's Blender (a UV-sphere head with
//! its scalp painted in a colour attribute, exported as `.glb`; combed particle hair and
//! the same hair as a hair-curves object, exported by the add-on
//! `tools/blender/bevy_hair_export.py`; Blender's own strand points in `strands.json`).
//! The heads load through README's code and grow hair on the paint; the grooms load as
//! `guides_from` and keep Blender's strands. Where Blender is installed, the script runs
//! again and must reproduce the committed files; without it that test says why it skipped,
//! or fails when `BEVY_HAIR_REQUIRE_BLENDER` is set (as `.ci/run` sets it).

mod common;
#[path = "common/glb.rs"]
mod glb;

use bevy::prelude::*;
use bevy_hair::hair_sim::groom::HairFile;
use bevy_hair::hair_sim::math::Vec3 as SimVec3;
use bevy_hair::prelude::*;
use std::path::Path;
use std::process::Command;

/// Where the files Blender made are committed.
const BLENDER_ASSETS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/blender");

/// The heads whose paint Blender's glTF exporter writes right: a colour attribute on the
/// point domain, float or byte (`summary.json`; on the corner domain it scrambles them).
const RIGHT_VARIANTS: [&str; 2] = ["head_point_float.glb", "head_point_byte.glb"];

/// Blender's own strands of the groom `kind` (`particles` or `curves`), from `strands.json`.
fn blender_strands(dir: &str, kind: &str) -> Vec<Vec<SimVec3>> {
    let text = std::fs::read_to_string(format!("{dir}/strands.json")).expect("strands.json");
    let json: serde_json::Value = serde_json::from_str(&text).expect("strands.json parses");
    let strands = json[kind]["strands"].as_array().expect("strands");
    let point = |p: &serde_json::Value| {
        let c: Vec<f32> = p.as_array().expect("a point").iter().map(|c| c.as_f64().expect("a number") as f32).collect();
        SimVec3::new(c[0], c[1], c[2])
    };
    strands.iter().map(|s| s.as_array().expect("a strand").iter().map(point).collect()).collect()
}

/// The distance from `p` to the polyline `line`.
fn to_polyline(p: SimVec3, line: &[SimVec3]) -> f32 {
    line.windows(2)
        .map(|s| {
            let (a, ab) = (s[0], s[1] - s[0]);
            let t = ((p - a).dot(ab) / ab.length_squared().max(1e-30)).clamp(0.0, 1.0);
            p.distance(a + ab * t)
        })
        .fold(f32::INFINITY, f32::min)
}

/// README's code on each head Blender paints right: every root on the paint (checked
/// against the loaded mesh's own colours), and after the head turns at up to 3 rad/s for a
/// second, no particle inside it. The UV sphere's seam splits its vertices: the collider
/// must still see one closed surface.
#[test]
fn heads_painted_in_blender_grow_hair_on_their_paint() {
    for variant in RIGHT_VARIANTS {
        let mut grown = glb::readme_code_on(&format!("{BLENDER_ASSETS}/{variant}"));
        for k in 0..60 {
            let turn = Quat::from_rotation_y(1.5 * (k as f32 / 30.0).sin()) * Quat::from_rotation_x(0.3);
            *grown.app.world_mut().get_mut::<Transform>(grown.head).unwrap() = Transform::from_rotation(turn);
            grown.app.update();
        }
        let deepest = common::max_penetration(&grown.app, grown.head);
        println!(
            "{variant}: {} strands, {} roots off the paint, deepest particle after a turn {:.3} mm inside",
            grown.strands,
            grown.off_paint,
            deepest.max(0.0) * 1e3
        );
        assert!(grown.strands > 100, "{variant}: {} strands grew", grown.strands);
        assert!(grown.reports.is_empty(), "{variant}: {:?}", grown.reports);
        assert_eq!(grown.off_paint, 0, "{variant}: roots off the painted scalp");
        assert!(deepest <= 1e-4, "{variant}: a particle {} mm inside the head", deepest * 1e3);
    }
}

/// Blender 3.4's glTF exporter scrambles colours on the face-corner domain: the head's
/// paint arrives as scattered patches, and the plugin says so (and what to do) instead of
/// growing on them silently.
#[test]
fn paint_blender_scrambled_is_reported() {
    for variant in ["head_corner_float.glb", "head_corner_byte.glb"] {
        let grown = glb::readme_code_on(&format!("{BLENDER_ASSETS}/{variant}"));
        println!("{variant}: {} strands, {} roots off the paint; {:?}", grown.strands, grown.off_paint, grown.reports);
        let scattered: Vec<&String> = grown.reports.iter().filter(|r| r.contains("separate patches")).collect();
        assert_eq!(scattered.len(), 1, "{variant}: {:?}", grown.reports);
        assert!(scattered[0].contains("Vertex domain"), "{}", scattered[0]);
    }
}

/// The grooms the add-on exported load as `guides_from` on their head: as many guides as
/// Blender's strands, each resampled guide within 0.1 mm of Blender's own strand and its
/// root within 0.1 mm of Blender's root, every root on the painted scalp.
#[test]
fn grooms_exported_from_blender_keep_blenders_strands() {
    for (file, kind) in [("groom_particles.hair", "particles"), ("groom_curves.hair", "curves")] {
        let assets = AssetPlugin { file_path: BLENDER_ASSETS.into(), ..default() };
        let mut app = glb::gltf_app_in(common::FRAME, assets);
        let server = app.world().resource::<AssetServer>().clone();
        let groom = HairGroom { guides_from: Some(server.load(file)), segments: 7, settle_steps: 0, ..default() };
        let mesh = server.load(GltfAssetLabel::Primitive { mesh: 0, primitive: 0 }.from_asset(RIGHT_VARIANTS[0]));
        let head = app.world_mut().spawn((Mesh3d(mesh), groom)).id();
        common::wait_until_ready(&mut app, head);

        let blender = blender_strands(BLENDER_ASSETS, kind);
        let state = common::state(&app, head);
        let rest = state.strands().rest();
        assert_eq!(rest.strand_count(), blender.len(), "{file}: one guide per strand");
        let n = rest.particles_per_strand;
        let (mut worst, mut worst_root) = (0.0f32, 0.0f32);
        for (guide, strand) in rest.positions.chunks_exact(n).zip(&blender) {
            worst_root = worst_root.max(guide[0].distance(strand[0]));
            worst = guide.iter().map(|&p| to_polyline(p, strand)).fold(worst, f32::max);
        }
        let off_paint = glb::roots_off_paint(&app, head);
        println!(
            "{file}: {} guides × {n}; farthest from Blender's strand {:.4} mm, root {:.4} mm; {off_paint} roots off \
             the paint",
            blender.len(),
            worst * 1e3,
            worst_root * 1e3
        );
        assert!(worst <= 1e-4 && worst_root <= 1e-4, "{file}: {worst} m from Blender's strands, roots {worst_root} m");
        assert_eq!(off_paint, 0, "{file}: roots off the painted scalp");
    }
}

/// Blender, where it is installed: `None` (saying why) where it is not, unless
/// `BEVY_HAIR_REQUIRE_BLENDER` is set.
fn blender() -> Option<Command> {
    match Command::new("blender").arg("--version").output() {
        Ok(out) if out.status.success() => Some(Command::new("blender")),
        other => {
            let why = match other {
                Ok(out) => format!("`blender --version` failed: {}", String::from_utf8_lossy(&out.stderr)),
                Err(e) => format!("no `blender` to run: {e}"),
            };
            assert!(std::env::var_os("BEVY_HAIR_REQUIRE_BLENDER").is_none(), "BEVY_HAIR_REQUIRE_BLENDER is set: {why}");
            eprintln!("skipped: {why}");
            None
        }
    }
}

/// The script that made `assets/blender/` run again in Blender makes the same files: the
/// same strands within 1 µm (Blender moves points by about 1e-7 m from run to run, so not
/// to the byte), the same colour verdicts, and its own checks pass (it fails on a comb
/// that did not stick or an export that differs from Blender's strands).
#[test]
fn blender_reproduces_the_committed_files() {
    let Some(mut blender) = blender() else { return };
    let out = std::env::temp_dir().join(format!("bevy_hair_blender_{}", std::process::id()));
    std::fs::create_dir_all(&out).unwrap();
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tools/blender/make_test_groom.py");
    let run = blender
        .args(["-b", "--factory-startup", "--python-exit-code", "1", "--python", script, "--", "--out"])
        .arg(&out)
        .output()
        .expect("blender runs");
    assert!(run.status.success(), "the script failed:\n{}", String::from_utf8_lossy(&run.stdout));
    let made = out.to_string_lossy().into_owned();
    for file in ["groom_particles.hair", "groom_curves.hair"] {
        let read = |dir: &str| HairFile::read(&std::fs::read(Path::new(dir).join(file)).unwrap()).expect(file).strands;
        let (committed, again) = (read(BLENDER_ASSETS), read(&made));
        assert_eq!(committed.iter().map(Vec::len).collect::<Vec<_>>(), again.iter().map(Vec::len).collect::<Vec<_>>());
        let apart = committed.iter().flatten().zip(again.iter().flatten()).map(|(a, b)| a.distance(*b));
        let apart = apart.fold(0.0, f32::max);
        println!("{file}: reproduced within {:.2e} m", apart);
        assert!(apart <= 1e-6, "{file}: {apart} m from the committed file");
    }
    for kind in ["particles", "curves"] {
        let (committed, again) = (blender_strands(BLENDER_ASSETS, kind), blender_strands(&made, kind));
        let apart = committed.iter().flatten().zip(again.iter().flatten()).map(|(a, b)| a.distance(*b));
        assert!(apart.fold(0.0, f32::max) <= 1e-6, "strands.json's {kind}");
    }
    let verdicts = |dir: &str| {
        let text = std::fs::read_to_string(Path::new(dir).join("summary.json")).expect("summary.json");
        let json: serde_json::Value = serde_json::from_str(&text).expect("summary.json parses");
        let variants = json["colour_variants"].as_object().expect("colour_variants").clone();
        variants.into_iter().map(|(name, v)| (name, v["ok"].as_bool())).collect::<Vec<_>>()
    };
    assert_eq!(verdicts(BLENDER_ASSETS), verdicts(&made), "which paint variants Blender exports right");
    std::fs::remove_dir_all(&out).ok();
}

/// The add-on refuses what it cannot export, with a message that says why: no object, a
/// mesh without hair, an object that is neither a mesh nor hair curves, hair curves without
/// curves, a strand of fewer than 2 or more than 65,536 points, and through its menu entry
/// (`tools/blender/test_refusals.py`, run in Blender).
#[test]
fn the_add_on_refuses_what_it_cannot_export() {
    let Some(mut blender) = blender() else { return };
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tools/blender/test_refusals.py");
    let run = blender.args(["-b", "--factory-startup", "--python-exit-code", "1", "--python", script]).output();
    let run = run.expect("blender runs");
    let said = String::from_utf8_lossy(&run.stdout);
    let refusals: Vec<&str> = said.lines().filter(|l| l.starts_with("refused")).collect();
    println!("{}", refusals.join("\n"));
    assert!(run.status.success() && said.contains("all refusals OK"), "the refusals' check failed:\n{said}");
    assert_eq!(refusals.len(), 6, "every refusal said why");
}
