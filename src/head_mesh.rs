//! Reading a Bevy [`Mesh`] as a head: triangles, normals and scalp labels.

use crate::convert::{from_sim, to_sim};
use crate::description::{HairErrorKind, ScalpSource};
use bevy::asset::RenderAssetUsages;
use bevy::math::Vec3;
use bevy::mesh::{Indices, Mesh, MeshVertexAttribute, PrimitiveTopology, VertexAttributeValues, VertexFormat};
use hair_sim::groom::{labels_from_colors, triangle_weights};
use hair_sim::mesh::{HeadMesh, MeshRepairs, test_head};

/// Optional per-vertex scalp density (0..1) a head mesh may carry instead of painted
/// colours. In glTF it is the custom attribute `_SCALP`; register it with
/// `GltfPlugin::default().add_custom_vertex_attribute("_SCALP", ATTRIBUTE_SCALP)`.
pub const ATTRIBUTE_SCALP: MeshVertexAttribute =
    MeshVertexAttribute::new("_SCALP", 0x6861_6972_5f73_6361, VertexFormat::Float32);

/// Skin colour of the procedural head (linear RGBA); the scalp is painted black.
const SKIN: [f32; 4] = [0.8, 0.55, 0.45, 1.0];

/// Reads a Bevy mesh as a head (scaled by `scale`), repairing what can be repaired
/// (triangles without area, inside-out winding: see [`HeadMesh::repaired`]), or says why
/// it cannot be read.
pub(crate) fn read_head_mesh(mesh: &Mesh, scale: Vec3) -> Result<(HeadMesh, MeshRepairs), HairErrorKind> {
    if mesh.primitive_topology() != PrimitiveTopology::TriangleList {
        return Err(HairErrorKind::MeshFormat(format!(
            "the head mesh is a {:?}; a TriangleList is needed",
            mesh.primitive_topology()
        )));
    }
    let positions = match mesh.try_attribute(Mesh::ATTRIBUTE_POSITION) {
        Ok(VertexAttributeValues::Float32x3(p)) => p,
        Ok(_) => return Err(HairErrorKind::MeshFormat("the head mesh positions are not Float32x3".into())),
        Err(e) => {
            return Err(HairErrorKind::MeshFormat(format!(
                "cannot read the head mesh positions ({e}); keep the mesh in the main world (RenderAssetUsages::MAIN_WORLD)"
            )));
        }
    };
    let positions: Vec<_> = positions.iter().map(|&p| to_sim(Vec3::from_array(p) * scale)).collect();
    let indices: Vec<u32> = match mesh.try_indices_option() {
        Ok(Some(Indices::U16(i))) => i.iter().map(|&i| i as u32).collect(),
        Ok(Some(Indices::U32(i))) => i.clone(),
        Ok(None) => (0..positions.len() as u32).collect(),
        Err(e) => return Err(HairErrorKind::MeshFormat(format!("cannot read the head mesh indices ({e})"))),
    };
    let triangles = indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    let (mut head, repairs) = HeadMesh::repaired(positions, triangles)?;
    // Authored normals are smoother than recomputed ones across UV seams: prefer them.
    // Under non-uniform scale a normal transforms by the inverse scale.
    if let Ok(VertexAttributeValues::Float32x3(normals)) = mesh.try_attribute(Mesh::ATTRIBUTE_NORMAL)
        && normals.len() == head.positions.len()
    {
        let authored: Vec<_> =
            normals.iter().map(|&n| to_sim((Vec3::from_array(n) / scale).normalize_or_zero())).collect();
        // Authored normals of a mesh that was wound inside out point in: keep ours then.
        if authored.iter().all(|n| n.is_finite() && n.length() > 0.5) && !repairs.flipped_winding {
            head.normals = authored;
        }
    }
    Ok((head, repairs))
}

/// The scalp labels of a head mesh, 0..1: per vertex as painted, and per triangle (the
/// smallest of its corners, see [`triangle_weights`]).
pub(crate) struct ScalpWeights {
    pub vertices: Vec<f32>,
    pub triangles: Vec<f32>,
}

/// The scalp weights (0..1) from the labels `source` names, or why there are none. `predicate` is the user's rule for [`ScalpSource::Predicate`]; it sees positions
/// in the mesh's own units, so they are divided by the `scale` the mesh was read with.
pub(crate) fn scalp_weights(
    mesh: &Mesh,
    head: &HeadMesh,
    source: ScalpSource,
    predicate: Option<fn(Vec3) -> bool>,
    scale: Vec3,
) -> Result<ScalpWeights, HairErrorKind> {
    let vertex_weights: Vec<f32> = match source {
        ScalpSource::Predicate => {
            let predicate = predicate.ok_or_else(|| {
                HairErrorKind::ScalpLabels("ScalpSource::Predicate needs a ScalpPredicate component on the head".into())
            })?;
            head.positions.iter().map(|&p| if predicate(from_sim(p) / scale) { 1.0 } else { 0.0 }).collect()
        }
        ScalpSource::Everywhere => vec![1.0; head.positions.len()],
        ScalpSource::VertexColor { threshold } => match mesh.try_attribute(Mesh::ATTRIBUTE_COLOR) {
            Ok(VertexAttributeValues::Float32x4(colors)) => labels_from_colors(colors, threshold),
            Ok(_) => return Err(HairErrorKind::ScalpLabels("the head mesh COLOR_0 is not Float32x4".into())),
            Err(_) => {
                return Err(HairErrorKind::ScalpLabels(
                    "the head mesh has no vertex colours (COLOR_0) to read the painted scalp from".into(),
                ));
            }
        },
        ScalpSource::Attribute => match mesh.try_attribute(ATTRIBUTE_SCALP) {
            Ok(VertexAttributeValues::Float32(w)) => w.clone(),
            _ => {
                return Err(HairErrorKind::ScalpLabels(
                    "the head mesh has no _SCALP attribute to read scalp density from".into(),
                ));
            }
        },
    };
    if vertex_weights.len() != head.positions.len() {
        return Err(HairErrorKind::ScalpLabels(format!(
            "the scalp labels cover {} vertices but the mesh has {}",
            vertex_weights.len(),
            head.positions.len()
        )));
    }
    let weights = triangle_weights(head, &vertex_weights);
    if weights.iter().all(|&w| w <= 0.0) {
        return Err(HairErrorKind::NoScalp(source));
    }
    Ok(ScalpWeights { vertices: vertex_weights, triangles: weights })
}

/// The procedural test head as a Bevy mesh: an ellipsoid with ears, +Y up, +Z forward,
/// skin-coloured with the scalp (crown and back, above the ears) painted black in
/// `COLOR_0` — what a head painted in Blender's vertex paint mode looks like to the plugin.
///
/// `subdivisions` = 4 gives 5,120 triangles. Handy for examples and tests; real projects
/// use their own head mesh.
pub fn procedural_head_mesh(subdivisions: u32) -> Mesh {
    let head = test_head(subdivisions);
    let colors: Vec<[f32; 4]> = head
        .positions
        .iter()
        .map(|p| if is_procedural_scalp(from_sim(*p)) { [0.0, 0.0, 0.0, 1.0] } else { SKIN })
        .collect();
    Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::default())
        .with_inserted_attribute(
            Mesh::ATTRIBUTE_POSITION,
            head.positions.iter().map(|p| p.to_array()).collect::<Vec<_>>(),
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, head.normals.iter().map(|n| n.to_array()).collect::<Vec<_>>())
        .with_inserted_attribute(Mesh::ATTRIBUTE_COLOR, colors)
        .with_inserted_indices(Indices::U32(head.triangles.iter().flatten().copied().collect()))
}

/// The hairline of [`procedural_head_mesh`]: above the ears, and behind the forehead.
pub fn is_procedural_scalp(p: Vec3) -> bool {
    let above_ears = p.y > 0.035;
    let not_face = p.z < 0.05 || p.y > 0.075;
    above_ears && not_face
}
