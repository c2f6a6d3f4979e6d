//! Why a cell or a far-field group cannot be baked ([`BakeError`]), and how an error
//! names what a user can find in their scene (issue 29: the instance's label — glTF
//! node or model — and the cell).

use crate::svmesh::ProxyError;
use format::Scene;
use thiserror::Error;

/// Why a cell cannot be baked.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum BakeError {
    #[error("cell {cell} does not exist (the grid has {cells} cells)")]
    NoCell { cell: u32, cells: u32 },
    #[error("far-field group {group} does not exist (the grid has {groups} groups)")]
    NoGroup { group: u32, groups: u32 },
    #[error("cell {cell}: {source}")]
    Proxy {
        cell: u32,
        #[source]
        source: ProxyError,
    },
    #[error("cell {cell}: texture of a proxy of instance {instance}: {what}")]
    Texture {
        cell: u32,
        instance: u32,
        what: String,
    },
}

impl BakeError {
    /// The failure in the user's terms (issue 29 item 4), without the cell or group
    /// (the job names its unit): which instance failed — its glTF node or manifest
    /// entry and its model ([`Scene::describe_instance`]) —, what went wrong, and
    /// what to change in the scene or the manifest.
    pub fn explain(&self, scene: &Scene) -> String {
        use crate::capture::CaptureError;
        use crate::view::ViewError;
        let describe = |instances: &[u32]| -> String {
            let mut named: Vec<String> = instances
                .iter()
                .take(3)
                .map(|&i| scene.describe_instance(i as usize))
                .collect();
            if instances.len() > 3 {
                named.push(format!("{} more", instances.len() - 3));
            }
            named.join(", ")
        };
        let split_it = "split it into parts no wider than a cell (`cells.cell_size`), \
                        e.g. as separate nodes or meshes";
        match self {
            BakeError::NoCell { .. } | BakeError::NoGroup { .. } => self.to_string(),
            BakeError::Texture { instance, what, .. } => format!(
                "the texture of a proxy of {} cannot be stored: {what}; to change: check \
                 `bake.image_res`, and report it if the manifest is sound",
                describe(&[*instance])
            ),
            BakeError::Proxy { source, .. } => match source {
                ProxyError::NoModel { .. } | ProxyError::NoInstance { .. } => format!(
                    "the scene is inconsistent: {source}; to change: rebuild the scene \
                     (a scene loaded from a manifest never is: report it)"
                ),
                ProxyError::Capture { instances, source } => {
                    let what = describe(instances);
                    let advice = match source {
                        CaptureError::Empty => {
                            "check the model: none of its triangles has valid vertices".into()
                        }
                        CaptureError::View {
                            source: ViewError::TooLarge { .. },
                            ..
                        } => format!("lower `bake.image_res`, or {split_it}"),
                        CaptureError::View {
                            source: ViewError::BoxNotInFront { .. },
                            ..
                        } => format!(
                            "the object's box surrounds the capture point; {split_it}, or \
                             move it so that it does not enclose a cell's centre"
                        ),
                        CaptureError::View { .. } => {
                            format!("check the object's placement and size, or {split_it}")
                        }
                    };
                    format!("capture of {what} failed: {source}; to change: {advice}")
                }
                ProxyError::Simplify { instance, source } => format!(
                    "simplifying {} failed: {source}; to change: check the model's mesh \
                     (finite positions, valid triangles)",
                    describe(&[*instance])
                ),
            },
        }
    }
}
