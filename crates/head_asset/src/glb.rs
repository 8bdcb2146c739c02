//! glTF 2.0 binary (GLB) writing and reading for the head, through the `gltf` crate and its
//! `gltf-json` types (the ones Bevy's own glTF loader reads with).
//!
//! What is written: one scene with the skeleton ([`rig::JOINTS`], `neck` → `head`) and the
//! node `head` carrying mesh `head` (one indexed triangle primitive: POSITION, NORMAL,
//! COLOR_0, JOINTS_0, WEIGHTS_0) skinned to it, and the animation [`rig::CLIP_NAME`]
//! (linear rotation keyframes of both joints), and the eyes (mesh `eye`, nodes `eye.L` and
//! `eye.R` under the `head` joint). The same head always gives the same bytes:
//! the JSON's fields come in `gltf-json`'s fixed order and floats in Rust's shortest
//! round-trip form.

use crate::HeadAsset;
use crate::error::Error;
use crate::eyes;
use crate::rig::{self, Clip, JOINTS};
use gltf::json;
use json::validation::{Checked::Valid, USize64};
use json::{Index, Root, accessor, animation, buffer, mesh, scene};
use std::collections::BTreeMap;

/// Serialises the head as a GLB. `copyright` goes to `asset.copyright`; `extras` (key, text)
/// pairs go, in order, to `asset.extras` as strings. Indices are `u16` when the vertex count
/// allows, else `u32`.
pub fn write(head: &HeadAsset, copyright: &str, extras: &[(&str, &str)]) -> Result<Vec<u8>, Error> {
    let mut root = Root {
        asset: json::Asset {
            copyright: Some(copyright.into()),
            extensions: None,
            extras: raw_object(extras)?,
            generator: Some(concat!("bevy_hair head_asset ", env!("CARGO_PKG_VERSION")).into()),
            min_version: None,
            version: "2.0".into(),
        },
        ..Root::default()
    };
    let mut bin = Bin::default();
    let n = head.positions.len();

    let positions = bin.positions(&mut root, &head.positions);
    let normals = bin.accessor(&mut root, &head.normals, accessor::Type::Vec3, Some(buffer::Target::ArrayBuffer));
    let colors = bin.accessor(&mut root, &head.colors, accessor::Type::Vec4, Some(buffer::Target::ArrayBuffer));
    // Every vertex names both joints, in skin order; the weights say how much of each.
    let joint_ids: Vec<[u8; 4]> = vec![[rig::NECK as u8, rig::HEAD as u8, 0, 0]; n];
    let joints = bin.accessor(&mut root, &joint_ids, accessor::Type::Vec4, Some(buffer::Target::ArrayBuffer));
    let weights: Vec<[f32; 4]> = head.skin_weights.iter().map(|w| [w[0], w[1], 0.0, 0.0]).collect();
    let weights = bin.accessor(&mut root, &weights, accessor::Type::Vec4, Some(buffer::Target::ArrayBuffer));
    let indices = if n <= u16::MAX as usize + 1 {
        let short: Vec<u16> = head.triangles.iter().flatten().map(|&i| i as u16).collect();
        bin.accessor(&mut root, &short, accessor::Type::Scalar, Some(buffer::Target::ElementArrayBuffer))
    } else {
        let long: Vec<u32> = head.triangles.iter().flatten().copied().collect();
        bin.accessor(&mut root, &long, accessor::Type::Scalar, Some(buffer::Target::ElementArrayBuffer))
    };
    // Joints are not rotated at rest: each inverse bind matrix is a translation (column-major).
    let inverse_binds: Vec<[f32; 16]> = rig::rest_positions()
        .iter()
        .map(|p| [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -p[0], -p[1], -p[2], 1.0])
        .collect();
    let inverse_binds = bin.accessor(&mut root, &inverse_binds, accessor::Type::Mat4, None);

    let attributes = BTreeMap::from([
        (Valid(mesh::Semantic::Positions), positions),
        (Valid(mesh::Semantic::Normals), normals),
        (Valid(mesh::Semantic::Colors(0)), colors),
        (Valid(mesh::Semantic::Joints(0)), joints),
        (Valid(mesh::Semantic::Weights(0)), weights),
    ]);
    let head_mesh = push_mesh(&mut root, "head", 0.8, attributes, indices);

    // The skeleton: parents before children, so a joint's index is its place in JOINTS.
    let joint_nodes: Vec<Index<scene::Node>> = JOINTS
        .iter()
        .map(|joint| {
            root.push(scene::Node {
                name: Some(joint.name.into()),
                translation: (joint.translation != [0.0; 3]).then_some(joint.translation),
                ..Default::default()
            })
        })
        .collect();
    for (j, joint) in JOINTS.iter().enumerate() {
        if let Some(parent) = joint.parent {
            root.nodes[parent].children.get_or_insert_with(Vec::new).push(joint_nodes[j]);
        }
    }
    let skin = root.push(json::Skin {
        extensions: None,
        extras: Default::default(),
        inverse_bind_matrices: Some(inverse_binds),
        joints: joint_nodes.clone(),
        name: Some("head".into()),
        skeleton: Some(joint_nodes[rig::NECK]),
    });
    let head_node = root.push(scene::Node {
        name: Some("head mesh".into()),
        mesh: Some(head_mesh),
        skin: Some(skin),
        ..Default::default()
    });
    push_eyes(&mut root, &mut bin, &head.eyes, joint_nodes[rig::HEAD]);
    let scene_nodes = vec![joint_nodes[rig::NECK], head_node];
    let scene = root.push(json::Scene {
        extensions: None,
        extras: Default::default(),
        name: Some("head".into()),
        nodes: scene_nodes,
    });
    root.scene = Some(scene);

    push_clip(&mut root, &mut bin, &head.clip, &joint_nodes);

    root.buffers.push(json::Buffer {
        byte_length: USize64::from(bin.bytes.len()),
        extensions: None,
        extras: Default::default(),
        name: None,
        uri: None,
    });
    let json = root.to_vec().map_err(|e| Error::Glb(format!("the JSON could not be written: {e}")))?;
    let glb = gltf::binary::Glb {
        header: gltf::binary::Header { magic: *b"glTF", version: 2, length: 0 },
        json: json.into(),
        bin: Some(bin.bytes.into()),
    };
    glb.to_vec().map_err(|e| Error::Glb(format!("the container could not be written: {e}")))
}

/// Names of the eye nodes, left then right.
pub const EYE_NODES: [&str; 2] = ["eye.L", "eye.R"];

/// The eyes: one mesh `eye` (the unit [`eyes::eyeball`], POSITION, NORMAL, COLOR_0) with a
/// glossy material, drawn by a node per eye under the `head` joint (so the clip turns
/// them with the head), moved and scaled to its socket.
fn push_eyes(root: &mut Root, bin: &mut Bin, eyes: &[eyes::Eye], head_joint: Index<scene::Node>) {
    if eyes.is_empty() {
        return;
    }
    let eyes::Eyeball { positions, colors, triangles } = eyes::eyeball();
    let position = bin.positions(root, &positions);
    // A unit sphere's normals are its positions.
    let normal = bin.accessor(root, &positions, accessor::Type::Vec3, Some(buffer::Target::ArrayBuffer));
    let color = bin.accessor(root, &colors, accessor::Type::Vec4, Some(buffer::Target::ArrayBuffer));
    let indices: Vec<u16> = triangles.iter().flatten().map(|&i| i as u16).collect();
    let indices = bin.accessor(root, &indices, accessor::Type::Scalar, Some(buffer::Target::ElementArrayBuffer));
    let attributes = BTreeMap::from([
        (Valid(mesh::Semantic::Positions), position),
        (Valid(mesh::Semantic::Normals), normal),
        (Valid(mesh::Semantic::Colors(0)), color),
    ]);
    let mesh = push_mesh(root, "eye", 0.15, attributes, indices);
    for (eye, name) in eyes.iter().zip(EYE_NODES) {
        let node = root.push(scene::Node {
            name: Some(name.into()),
            mesh: Some(mesh),
            translation: Some(eye.translation),
            scale: Some([eye.radius; 3]),
            ..Default::default()
        });
        root.nodes[head_joint.value()].children.get_or_insert_with(Vec::new).push(node);
    }
}

/// A mesh of one indexed triangle primitive named `name`, with a non-metallic material of
/// the same name and `roughness` (pushed first).
fn push_mesh(
    root: &mut Root,
    name: &str,
    roughness: f32,
    attributes: BTreeMap<json::validation::Checked<mesh::Semantic>, Index<json::Accessor>>,
    indices: Index<json::Accessor>,
) -> Index<json::Mesh> {
    let material = root.push(json::Material {
        name: Some(name.into()),
        pbr_metallic_roughness: json::material::PbrMetallicRoughness {
            metallic_factor: json::material::StrengthFactor(0.0),
            roughness_factor: json::material::StrengthFactor(roughness),
            ..Default::default()
        },
        ..Default::default()
    });
    root.push(json::Mesh {
        extensions: None,
        extras: Default::default(),
        name: Some(name.into()),
        primitives: vec![mesh::Primitive {
            attributes,
            extensions: None,
            extras: Default::default(),
            indices: Some(indices),
            material: Some(material),
            mode: Valid(mesh::Mode::Triangles),
            targets: None,
        }],
        weights: None,
    })
}

/// The clip as one glTF animation: a shared input accessor (the keyframe times) and one
/// linear rotation sampler per joint.
fn push_clip(root: &mut Root, bin: &mut Bin, clip: &Clip, joint_nodes: &[Index<scene::Node>]) {
    if clip.times.is_empty() {
        return;
    }
    let times = bin.accessor(root, &clip.times, accessor::Type::Scalar, None);
    let (first, last) = (clip.times[0], clip.times[clip.times.len() - 1]);
    root.accessors[times.value()].min = Some(vec![first].into());
    root.accessors[times.value()].max = Some(vec![last].into());
    let mut channels = Vec::new();
    let mut samplers = Vec::new();
    for (j, &node) in joint_nodes.iter().enumerate() {
        let rotations: Vec<[f32; 4]> = clip.rotations.iter().map(|r| r[j]).collect();
        let output = bin.accessor(root, &rotations, accessor::Type::Vec4, None);
        let sampler = Index::push(
            &mut samplers,
            animation::Sampler {
                extensions: None,
                extras: Default::default(),
                input: times,
                interpolation: Valid(animation::Interpolation::Linear),
                output,
            },
        );
        channels.push(animation::Channel {
            sampler,
            target: animation::Target {
                extensions: None,
                extras: Default::default(),
                node,
                path: Valid(animation::Property::Rotation),
            },
            extensions: None,
            extras: Default::default(),
        });
    }
    root.push(json::Animation {
        extensions: None,
        extras: Default::default(),
        channels,
        name: Some(clip.name.clone()),
        samplers,
    });
}

/// `extras` as a JSON object with its keys in the given order (a map would sort them).
fn raw_object(pairs: &[(&str, &str)]) -> Result<json::Extras, Error> {
    if pairs.is_empty() {
        return Ok(None);
    }
    let quote = |s: &str| serde_json::to_string(s).expect("a string serialises");
    let members: Vec<String> = pairs.iter().map(|(k, v)| format!("{}:{}", quote(k), quote(v))).collect();
    let text = format!("{{{}}}", members.join(","));
    serde_json::value::RawValue::from_string(text)
        .map(Some)
        .map_err(|e| Error::Glb(format!("asset extras are not JSON: {e}")))
}

/// A plain value glTF stores in a buffer: its component type and little-endian bytes.
trait Component: Copy {
    const TYPE: accessor::ComponentType;
    fn extend_le(self, out: &mut Vec<u8>);
}

macro_rules! component {
    ($t:ty, $c:ident) => {
        impl Component for $t {
            const TYPE: accessor::ComponentType = accessor::ComponentType::$c;
            fn extend_le(self, out: &mut Vec<u8>) {
                out.extend_from_slice(&self.to_le_bytes());
            }
        }
    };
}
component!(f32, F32);
component!(u8, U8);
component!(u16, U16);
component!(u32, U32);

/// An element of an accessor: a component or a fixed array of them.
trait Element {
    type Of: Component;
    fn components(&self) -> &[Self::Of];
}
impl<C: Component> Element for C {
    type Of = C;
    fn components(&self) -> &[C] {
        std::slice::from_ref(self)
    }
}
impl<C: Component, const N: usize> Element for [C; N] {
    type Of = C;
    fn components(&self) -> &[C] {
        self
    }
}

/// The BIN chunk as it is filled: one tightly packed buffer view per accessor, each
/// starting on a 4-byte boundary.
#[derive(Default)]
struct Bin {
    bytes: Vec<u8>,
}

impl Bin {
    /// A POSITION accessor: `positions` as vertex data, with their exact bounds as its
    /// `min` and `max` (which glTF requires).
    fn positions(&mut self, root: &mut Root, positions: &[[f32; 3]]) -> Index<json::Accessor> {
        let (lo, hi) = position_bounds(positions);
        let accessor = self.accessor(root, positions, accessor::Type::Vec3, Some(buffer::Target::ArrayBuffer));
        root.accessors[accessor.value()].min = Some(lo.into());
        root.accessors[accessor.value()].max = Some(hi.into());
        accessor
    }

    /// Appends `data` as a new buffer view and returns the accessor reading all of it.
    fn accessor<E: Element>(
        &mut self,
        root: &mut Root,
        data: &[E],
        kind: accessor::Type,
        target: Option<buffer::Target>,
    ) -> Index<json::Accessor> {
        while !self.bytes.len().is_multiple_of(4) {
            self.bytes.push(0);
        }
        let offset = self.bytes.len();
        for element in data {
            element.components().iter().for_each(|c| c.extend_le(&mut self.bytes));
        }
        let view = root.push(buffer::View {
            buffer: Index::new(0),
            byte_length: USize64::from(self.bytes.len() - offset),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            extensions: None,
            extras: Default::default(),
            name: None,
            target: target.map(Valid),
        });
        root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(data.len()),
            component_type: Valid(accessor::GenericComponentType(E::Of::TYPE)),
            extensions: None,
            extras: Default::default(),
            type_: Valid(kind),
            min: None,
            max: None,
            name: None,
            normalized: false,
            sparse: None,
        })
    }
}

/// Component-wise min and max of the positions (zeros for none).
fn position_bounds(positions: &[[f32; 3]]) -> (Vec<f32>, Vec<f32>) {
    if positions.is_empty() {
        return (vec![0.0; 3], vec![0.0; 3]);
    }
    let (lo, hi) = positions.iter().fold(([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]), |(lo, hi), p| {
        (std::array::from_fn(|k| lo[k].min(p[k])), std::array::from_fn(|k| hi[k].max(p[k])))
    });
    (lo.to_vec(), hi.to_vec())
}

/// Reads the head back: the first primitive of the first mesh (an indexed triangle list
/// with POSITION, NORMAL and COLOR_0 of one length), the skin weights of the `neck` and
/// `head` joints, and the first animation's rotation keyframes (empty without one).
pub fn read(bytes: &[u8]) -> Result<HeadAsset, Error> {
    let gltf = gltf::Gltf::from_slice(bytes).map_err(|e| Error::Glb(e.to_string()))?;
    let blob = gltf.blob.as_deref();
    let buffers = |buffer: gltf::Buffer| (buffer.index() == 0).then_some(blob).flatten();
    let mesh = gltf.meshes().next().ok_or_else(|| Error::Glb("no mesh".into()))?;
    let primitive = mesh.primitives().next().ok_or_else(|| Error::Glb("no mesh primitive".into()))?;
    if primitive.mode() != gltf::mesh::Mode::Triangles {
        return Err(Error::Glb(format!("primitive mode {:?}, expected triangles", primitive.mode())));
    }
    let reader = primitive.reader(buffers);
    let missing = |what: &str| Error::Glb(format!("no {what} attribute"));
    let positions: Vec<[f32; 3]> = reader.read_positions().ok_or_else(|| missing("POSITION"))?.collect();
    let normals: Vec<[f32; 3]> = reader.read_normals().ok_or_else(|| missing("NORMAL"))?.collect();
    let colors: Vec<[f32; 4]> = reader.read_colors(0).ok_or_else(|| missing("COLOR_0"))?.into_rgba_f32().collect();
    let indices: Vec<u32> = reader.read_indices().ok_or_else(|| Error::Glb("no indices".into()))?.into_u32().collect();
    let n = positions.len();
    if normals.len() != n || colors.len() != n {
        return Err(Error::Glb("POSITION, NORMAL and COLOR_0 differ in length".into()));
    }
    if !indices.len().is_multiple_of(3) || indices.iter().any(|&i| i as usize >= n) {
        return Err(Error::Glb("indices are not whole triangles over the vertices".into()));
    }

    // Skin weights per vertex, summed per joint of the skin, mapped to [neck, head] by name.
    let mut skin_weights = Vec::new();
    let mut joint_nodes = Vec::new();
    if let Some(skin) = gltf.skins().next() {
        let names: Vec<String> = skin.joints().map(|j| j.name().unwrap_or_default().to_owned()).collect();
        let slot = |name: &str| names.iter().position(|n| n == name);
        let (Some(neck), Some(head)) = (slot(JOINTS[rig::NECK].name), slot(JOINTS[rig::HEAD].name)) else {
            return Err(Error::Glb(format!("the skin's joints are {names:?}, expected `neck` and `head`")));
        };
        joint_nodes = skin.joints().map(|j| j.index()).collect();
        let ids: Vec<[u16; 4]> = reader.read_joints(0).ok_or_else(|| missing("JOINTS_0"))?.into_u16().collect();
        let weights: Vec<[f32; 4]> = reader.read_weights(0).ok_or_else(|| missing("WEIGHTS_0"))?.into_f32().collect();
        if ids.len() != n || weights.len() != n {
            return Err(Error::Glb("JOINTS_0 and WEIGHTS_0 differ in length from POSITION".into()));
        }
        skin_weights = ids
            .iter()
            .zip(&weights)
            .map(|(ids, w)| {
                let of = |slot: usize| (0..4).filter(|&k| ids[k] as usize == slot).map(|k| w[k]).sum::<f32>();
                [of(neck), of(head)]
            })
            .collect();
    }

    let mut clip = Clip::default();
    if let Some(animation) = gltf.animations().next() {
        clip.name = animation.name().unwrap_or_default().to_owned();
        let mut per_joint: Vec<Vec<[f32; 4]>> = vec![Vec::new(); JOINTS.len()];
        for channel in animation.channels() {
            let target = channel.target();
            let Some(j) = joint_nodes.iter().position(|&node| node == target.node().index()) else { continue };
            let reader = channel.reader(buffers);
            let times: Vec<f32> = reader.read_inputs().ok_or_else(|| Error::Glb("no keyframe times".into()))?.collect();
            let Some(gltf::animation::util::ReadOutputs::Rotations(rotations)) = reader.read_outputs() else {
                return Err(Error::Glb(format!("channel on `{}` is not a rotation", JOINTS[j].name)));
            };
            if !clip.times.is_empty() && clip.times != times {
                return Err(Error::Glb("the joints' keyframe times differ".into()));
            }
            clip.times = times;
            per_joint[j] = rotations.into_f32().collect();
        }
        if per_joint.iter().any(|r| r.len() != clip.times.len()) {
            return Err(Error::Glb("the clip does not rotate both joints at every keyframe".into()));
        }
        clip.rotations = (0..clip.times.len()).map(|i| [per_joint[0][i], per_joint[1][i]]).collect();
    }

    // The eyes, by their nodes' names, in the order written.
    let eyes = EYE_NODES
        .iter()
        .filter_map(|&name| gltf.nodes().find(|n| n.name() == Some(name)))
        .map(|node| {
            let (translation, _, scale) = node.transform().decomposed();
            eyes::Eye { translation, radius: scale[0] }
        })
        .collect();

    Ok(HeadAsset {
        positions,
        normals,
        colors,
        triangles: indices.chunks(3).map(|c| [c[0], c[1], c[2]]).collect(),
        skin_weights,
        clip,
        eyes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetrahedron() -> HeadAsset {
        let positions = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.5]];
        HeadAsset {
            skin_weights: positions.iter().map(|p: &[f32; 3]| rig::skin_weights(p.map(f64::from))).collect(),
            positions,
            normals: vec![[0.0, 1.0, 0.0]; 4],
            colors: vec![[0.0, 0.0, 0.0, 1.0], [1.0; 4], [1.0; 4], [0.25, 0.5, 0.75, 1.0]],
            triangles: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
            clip: Clip {
                name: "wave".into(),
                times: vec![0.0, 0.5],
                rotations: vec![[[0.0, 0.0, 0.0, 1.0]; 2], [[0.0, 0.6, 0.0, 0.8], [0.8, 0.0, 0.0, 0.6]]],
            },
            eyes: Vec::new(),
        }
    }

    /// Eyes go out as two nodes of one mesh under the `head` joint and come back exactly.
    #[test]
    fn eyes_parse_back_under_the_head_joint() {
        let eyes = vec![
            eyes::Eye { translation: [0.03, 0.05, 0.086], radius: 0.015 },
            eyes::Eye { translation: [-0.03, 0.05, 0.086], radius: 0.015 },
        ];
        let head = HeadAsset { eyes, ..tetrahedron() };
        let bytes = write(&head, "CC0", &[]).unwrap();
        assert_eq!(read(&bytes).unwrap(), head);
        let gltf = gltf::Gltf::from_slice(&bytes).unwrap();
        let head_joint = gltf.nodes().find(|n| n.name() == Some("head")).unwrap();
        let children: Vec<&str> = head_joint.children().map(|c| c.name().unwrap()).collect();
        assert_eq!(children, EYE_NODES);
        assert!(
            head_joint.children().all(|c| c.mesh().and_then(|m| m.name().map(str::to_owned)) == Some("eye".into()))
        );
        assert_eq!(gltf.meshes().count(), 2, "one eye mesh for both eyes");
    }

    /// Reads a little-endian u32 (test helper independent of the reader).
    fn le(bytes: &[u8], at: usize) -> usize {
        u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize
    }

    #[test]
    fn the_container_is_well_formed() {
        let bytes = write(&tetrahedron(), "test \"copyright\"", &[("source", "unit test")]).unwrap();
        assert_eq!(&bytes[0..4], b"glTF");
        assert_eq!(le(&bytes, 4), 2, "version");
        assert_eq!(le(&bytes, 8), bytes.len(), "total length");
        let json_len = le(&bytes, 12);
        assert_eq!(&bytes[16..20], b"JSON");
        assert_eq!(json_len % 4, 0);
        let bin_at = 20 + json_len;
        let bin_len = le(&bytes, bin_at);
        assert_eq!(&bytes[bin_at + 4..bin_at + 8], b"BIN\0");
        assert_eq!(bin_len % 4, 0);
        assert_eq!(bin_at + 8 + bin_len, bytes.len());
        // 4 vertices × (12 + 12 + 16 + 4 + 16) bytes, 12 u16 indices (24 bytes), two 4×4
        // matrices (128), 2 times (8) and 2 × 2 rotations (64).
        assert_eq!(bin_len, 4 * 60 + 24 + 128 + 8 + 64);
        let text = std::str::from_utf8(&bytes[20..bin_at]).unwrap();
        assert!(text.contains(r#""extras":{"source":"unit test"}"#), "{text}");
        assert!(text.contains(r#""copyright":"test \"copyright\"""#), "{text}");
    }

    #[test]
    fn output_parses_back_exactly() {
        let head = tetrahedron();
        let bytes = write(&head, "CC0", &[]).unwrap();
        assert_eq!(read(&bytes).unwrap(), head);
        assert_eq!(write(&head, "CC0", &[]).unwrap(), bytes, "deterministic");

        let gltf = gltf::Gltf::from_slice(&bytes).unwrap();
        let counts: Vec<usize> = gltf.accessors().map(|a| a.count()).collect();
        assert_eq!(counts, [4, 4, 4, 4, 4, 12, 2, 2, 2, 2]);
        let max = gltf.accessors().next().unwrap().max().unwrap();
        assert_eq!(max, serde_json::json!([1.0, 1.0, 1.5]));
        let names: Vec<&str> = gltf.nodes().map(|n| n.name().unwrap()).collect();
        assert_eq!(names, ["neck", "head", "head mesh"]);
        let head_joint = gltf.nodes().nth(1).unwrap();
        assert_eq!(head_joint.transform().decomposed().0, [0.0, 0.09, 0.01]);
        assert_eq!(gltf.nodes().next().unwrap().children().map(|c| c.index()).collect::<Vec<_>>(), [1]);
        assert_eq!(gltf.document.as_json().asset.copyright.as_deref(), Some("CC0"));
    }

    #[test]
    fn big_meshes_use_u32_indices() {
        let n = 70_000u32;
        let head = HeadAsset {
            positions: (0..n).map(|i| [i as f32, 0.0, 0.0]).collect(),
            normals: vec![[0.0, 1.0, 0.0]; n as usize],
            colors: vec![[1.0; 4]; n as usize],
            skin_weights: vec![[0.0, 1.0]; n as usize],
            triangles: vec![[0, 1, n - 1]],
            clip: Clip::default(),
            eyes: Vec::new(),
        };
        let bytes = write(&head, "", &[]).unwrap();
        assert_eq!(read(&bytes).unwrap().triangles, [[0, 1, n - 1]]);
    }

    #[test]
    fn broken_files_are_refused() {
        let bytes = write(&tetrahedron(), "", &[]).unwrap();
        let mut wrong_magic = bytes.clone();
        wrong_magic[0] = b'x';
        assert!(matches!(read(&wrong_magic), Err(Error::Glb(_))));
        let truncated = &bytes[..bytes.len() - 4];
        assert!(matches!(read(truncated), Err(Error::Glb(_))));
        let mut renamed = tetrahedron();
        renamed.clip.times.clear();
        renamed.clip.rotations.clear();
        let without_clip = read(&write(&renamed, "", &[]).unwrap()).unwrap();
        assert_eq!(without_clip.clip, Clip::default());
    }
}
