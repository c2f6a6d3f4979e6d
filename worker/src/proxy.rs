//! A baked proxy ([`BakedProxy`]: the members' simplified triangles, captures, an
//! impostor) and its content key ([`proxy_key`], issue 13's per-proxy
//! content-addressed cache): equal keys mean byte-equal proxies, so a rebake derives
//! only the proxies whose key changed ([`ProxyReuse`]).

use crate::impostor::LayeredImpostor;
use crate::raster::ProjectedTexture;
use crate::select::Measured;
use format::pack::{Proxy, ProxyKind};
use format::schema::job::ProxyFacts;
use format::Scene;
use glam::Vec3;
use std::collections::BTreeMap;

/// One member of a baked proxy.
#[derive(Clone, Debug, PartialEq)]
pub struct BakedMember {
    pub instance: u32,
    /// Triangles given to the simplifier (for `simplify::validate`).
    pub input_triangles: Vec<[u32; 3]>,
    /// Simplified triangles (original vertex ids of the instance's model).
    pub triangles: Vec<[u32; 3]>,
    /// MvMesh: per triangle, bit i = `views[i]` sees it; empty otherwise.
    pub view_masks: Vec<u8>,
    /// MvMesh: per model vertex, the views it is visible in (same bits); empty
    /// otherwise (for `simplify::validate_view_masks`).
    pub vertex_view_sets: Vec<u8>,
}

/// One proxy of the cell.
#[derive(Clone, Debug, PartialEq)]
pub struct BakedProxy {
    pub kind: ProxyKind,
    pub members: Vec<BakedMember>,
    /// The captures (empty for a proxy reused from an earlier bake: see `packed`).
    pub views: Vec<ProjectedTexture>,
    /// Content key: the hash of exactly what the proxy depends on ([`proxy_key`]).
    pub key: ProxyKey,
    /// Reused from an earlier bake of the cell (its key matched): the pack form,
    /// written as it is. Its members carry triangles and masks, no collapse inputs.
    pub packed: Option<Proxy>,
    /// LayeredImpostor (issue 16): its image and layers (`views` holds its texture
    /// too); `None` for every other kind.
    pub impostor: Option<LayeredImpostor>,
    /// The objective selection's measurement of the kept candidate
    /// ([`crate::select`]), where one was measured.
    pub quality: Option<Measured>,
    /// A reused proxy: its earlier bake's texture bytes as derived (what
    /// [`BakedProxy::texture_bytes`] counts for it), where the record had them.
    pub reused_texture_bytes: Option<u64>,
}

impl BakedProxy {
    /// A layered impostor of `members` (their meshes are not drawn: no triangles).
    pub fn impostor(
        members: &[u32],
        imp: LayeredImpostor,
        key: ProxyKey,
        quality: Option<Measured>,
    ) -> BakedProxy {
        BakedProxy {
            kind: ProxyKind::LayeredImpostor,
            members: members
                .iter()
                .map(|&instance| BakedMember {
                    instance,
                    input_triangles: Vec::new(),
                    triangles: Vec::new(),
                    view_masks: Vec::new(),
                    vertex_view_sets: Vec::new(),
                })
                .collect(),
            views: vec![imp.texture.clone()],
            key,
            packed: None,
            impostor: Some(imp),
            quality,
            reused_texture_bytes: None,
        }
    }

    /// Triangles drawn: the members' (mesh proxies) or two per layer (impostors).
    pub fn triangle_count(&self) -> u64 {
        let layers = match (&self.impostor, &self.packed) {
            (Some(i), _) => i.layers.layers.len() as u64,
            (None, Some(p)) => p.layers.as_ref().map_or(0, |l| l.layers.len() as u64),
            (None, None) => 0,
        };
        2 * layers
            + self
                .members
                .iter()
                .map(|m| m.triangles.len() as u64)
                .sum::<u64>()
    }

    pub fn view_count(&self) -> usize {
        self.packed
            .as_ref()
            .map_or(self.views.len(), |p| p.views.len())
    }

    /// Decoded RGBA8 bytes of the proxy's textures.
    pub fn texture_bytes(&self) -> u64 {
        if let Some(bytes) = self.reused_texture_bytes {
            return bytes;
        }
        match &self.packed {
            Some(p) => p
                .views
                .iter()
                .map(|v| u64::from(v.texture.width) * u64::from(v.texture.height) * 4)
                .sum(),
            None => self.views.iter().map(|v| v.rgba.len() as u64).sum(),
        }
    }

    /// A proxy of an earlier bake whose key matches, with that bake's measurement.
    pub(crate) fn reused(earlier: &Reused, key: ProxyKey) -> BakedProxy {
        let packed = &earlier.proxy;
        BakedProxy {
            kind: packed.kind,
            members: packed
                .members
                .iter()
                .map(|m| BakedMember {
                    instance: m.instance,
                    input_triangles: Vec::new(),
                    triangles: m.triangles.clone(),
                    view_masks: m.view_masks.clone(),
                    vertex_view_sets: Vec::new(),
                })
                .collect(),
            views: Vec::new(),
            key,
            packed: Some(packed.clone()),
            impostor: None,
            quality: earlier
                .facts
                .as_ref()
                .and_then(|f| f.quality.as_ref())
                .map(Measured::from_report),
            reused_texture_bytes: earlier.facts.as_ref().map(|f| f.texture_bytes),
        }
    }

    /// What its bake measured and counted, for the job record.
    pub fn facts(&self) -> ProxyFacts {
        ProxyFacts {
            texture_bytes: self.texture_bytes(),
            quality: self.quality.as_ref().map(Measured::to_report),
        }
    }
}

/// A proxy's content key (issue 13, "per-proxy content-addressed cache").
pub type ProxyKey = [u8; 32];

/// Proxies of an earlier bake of a cell, by key: a proxy whose key is here is taken
/// as it is instead of derived again.
pub type ProxyReuse = BTreeMap<ProxyKey, Reused>;

/// A proxy of an earlier bake: its pack form and what that bake measured and counted
/// of it (`None` for records written before issue 32).
#[derive(Clone, Debug, PartialEq)]
pub struct Reused {
    pub proxy: Proxy,
    pub facts: Option<ProxyFacts>,
}

/// The key of a proxy: blake3 of exactly what its derivation reads — the bake and
/// cell parameters with the format version and bake revision
/// ([`format::fingerprint::params_fingerprint`]) and the LOD chain builder's revision,
/// its kind, the region it serves
/// (the prism) and the eyes it is captured from, and per member (in order) the
/// instance id, its model's content hash (which also decides the model's LOD
/// chain), transform and tint. A proxy's derivation reads nothing else: captures show
/// its members alone, and collapses see only their own meshes. So equal keys mean
/// byte-equal proxies, and a rebake after a manifest change derives only proxies
/// whose key changed.
pub fn proxy_key(
    scene: &Scene,
    params: &format::fingerprint::Fingerprint,
    kind: ProxyKind,
    members: &[u32],
    prism: &crate::grid::Prism,
    eyes: &[Vec3],
) -> ProxyKey {
    let mut h = blake3::Hasher::new();
    h.update(b"hexbake proxy v1\0");
    h.update(params);
    h.update(&crate::lod_chain::CHAIN_REVISION.to_le_bytes());
    h.update(&[kind as u8]);
    let floats = |h: &mut blake3::Hasher, values: &[f32]| {
        for v in values {
            h.update(&v.to_le_bytes());
        }
    };
    floats(
        &mut h,
        &[
            prism.centre.x,
            prism.centre.y,
            prism.cell_size,
            prism.min_y,
            prism.max_y,
        ],
    );
    h.update(&(eyes.len() as u32).to_le_bytes());
    for e in eyes {
        floats(&mut h, &e.to_array());
    }
    h.update(&(members.len() as u32).to_le_bytes());
    for &i in members {
        h.update(&i.to_le_bytes());
        if let Some(inst) = scene.instances.get(i as usize) {
            if let Some(model) = scene.models.get(inst.model as usize) {
                h.update(&model.content_hash);
            }
            floats(&mut h, &inst.transform.to_cols_array());
            floats(&mut h, &inst.tint.to_array());
        }
    }
    *h.finalize().as_bytes()
}
