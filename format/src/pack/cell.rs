//! `cells/<id>.pack`: what the player draws from one view cell (DESIGN.md,
//! "Representations"; paper 000 §3 — the hybrid representation of a cell): the ids of
//! the instances drawn as Original geometry, and the proxies of the outside objects —
//! SvMesh (one capture, projective texturing, §3.1), Cluster (SV objects merged by
//! greedy clustering, §3.1.4), MvMesh (captures from the cell centre and its
//! neighbours with a per-triangle view mask, §3.2) — each as index buffers into the
//! members' model vertices plus capture matrices and textures — and LayeredImpostor
//! (paper 001 §3–4: one RGB + depth image sliced into depth layers, section
//! `layered-impostors`, [`ImpostorLayers`]). Culled objects are listed nowhere.

use super::base::{pack_triangles, BasePack};
use super::error::PackError;
use super::layout::{FileKind, SectionKind};
use super::reader::PackFile;
use super::texture::{Texture, TextureEncoding};
use super::texture_store;
use super::writer::{
    assemble_reusing, SectionData, RAW_ONLY, TRY_INDICES, TRY_TRIANGLES, TRY_ZSTD,
};
use super::{invalid, malformed};
pub use crate::limits::MAX_MV_VIEWS;
use bytemuck::{Pod, Zeroable};
use std::borrow::Cow;
use std::path::Path;

super::code_enum! {
    /// How a proxy is drawn.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
    pub enum ProxyKind {
        /// Simplified mesh, one capture from the cell centre, projective texturing.
        SvMesh = 1 => "SvMesh",
        /// Several SV objects merged into one proxy with one capture.
        Cluster = 2 => "Cluster",
        /// Simplified mesh with captures from the centre and up to 6 neighbours; each
        /// triangle carries a mask of the views that see it; the player blends two views.
        MvMesh = 3 => "MvMesh",
        /// Layered impostor (paper 001): one RGB + depth-code view sliced into quads;
        /// its layers live in the `layered-impostors` section ([`ImpostorLayers`]). Its
        /// members list the instances it stands for, with no triangles.
        LayeredImpostor = 4 => "LayeredImpostor",
    }
}

/// One instance's share of a proxy.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct ProxyMember {
    /// Index into the base pack's instance table.
    pub instance: u32,
    /// Triangles as indices into that instance's model vertices.
    pub triangles: Vec<[u32; 3]>,
    /// MvMesh only: per triangle, bit i set = view i of the proxy sees it. Empty for
    /// every other kind.
    pub view_masks: Vec<u8>,
}

/// One capture of a proxy.
#[derive(Clone, Debug, PartialEq)]
pub struct ProxyView {
    /// Where the capture was taken from (world space).
    pub eye: [f32; 3],
    /// World → texture coordinates (projective texturing), column-major.
    pub matrix: [f32; 16],
    pub texture: Texture,
}

/// One proxy of the cell.
#[derive(Clone, Debug, PartialEq)]
pub struct Proxy {
    pub kind: ProxyKind,
    pub members: Vec<ProxyMember>,
    pub views: Vec<ProxyView>,
    /// LayeredImpostor only (section `layered-impostors`): how its one view, an RGBA8
    /// image whose alpha holds depth codes, is sliced into layers. `None` for every
    /// other kind.
    pub layers: Option<ImpostorLayers>,
}

/// Most layers of one layered impostor (paper 001 §6 used up to 32; we allow twice
/// that so that a finer error angle stays representable).
pub const MAX_IMPOSTOR_LAYERS: usize = 64;

/// The layers of a layered impostor (paper 001 §3): one RGB + depth image captured
/// from the eye of the proxy's only view, drawn as a stack of quads perpendicular to
/// the capture axis. The view's texture is RGBA8 (never block-compressed): RGB the
/// colour, alpha a *depth code* — 0 where nothing was captured, else
/// `c ∈ 1..=255` standing for the eye-space depth `d` with
/// `1/d = 1/near − (c − 1)/254 · (1/near − 1/far)` (uniform in inverse depth, the
/// quantity the parallax error grows with). Layer `l` is the quad
/// `eye + depth_l · ray_k` (k = the four corners) drawing only the texels whose code
/// lies in `code_lo..=code_hi` (001 §4's alpha test); neighbouring layers overlap by a
/// code so that no crack opens between them (001 Fig. 2).
#[derive(Clone, Debug, PartialEq)]
pub struct ImpostorLayers {
    /// World-space vectors from the view's eye to the corners of its texture
    /// rectangle, texture coordinates (0,0), (1,0), (1,1), (0,1), at eye-space depth 1.
    pub corner_rays: [[f32; 3]; 4],
    /// Eye-space depth of code 1.
    pub near: f32,
    /// Eye-space depth of code 255 (≥ `near`).
    pub far: f32,
    /// Front to back.
    pub layers: Vec<ImpostorLayer>,
}

/// One layer of a layered impostor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImpostorLayer {
    /// Eye-space depth of the layer's quad.
    pub depth: f32,
    /// The depth codes it draws, `1 ≤ code_lo ≤ code_hi ≤ 255`.
    pub code_lo: u8,
    pub code_hi: u8,
}

impl ImpostorLayers {
    /// The eye-space depth a code `1..=255` stands for (struct docs).
    pub fn depth_of_code(&self, code: u8) -> f32 {
        depth_of_code(self.near, self.far, code)
    }

    /// Whether the layers are well formed (finite, positive, ordered codes).
    pub fn validate(&self) -> Result<(), String> {
        if !self.corner_rays.iter().flatten().all(|v| v.is_finite()) {
            return Err("corner rays are not finite".into());
        }
        if !(self.near.is_finite()
            && self.far.is_finite()
            && self.near > 0.0
            && self.far >= self.near)
        {
            return Err(format!(
                "depth range {}..{} is not 0 < near <= far",
                self.near, self.far
            ));
        }
        if self.layers.is_empty() || self.layers.len() > MAX_IMPOSTOR_LAYERS {
            return Err(format!(
                "{} layers, expected 1..={MAX_IMPOSTOR_LAYERS}",
                self.layers.len()
            ));
        }
        for (i, l) in self.layers.iter().enumerate() {
            if !(l.depth.is_finite() && l.depth > 0.0) {
                return Err(format!("layer {i}: depth {} is not positive", l.depth));
            }
            if l.code_lo == 0 || l.code_lo > l.code_hi {
                return Err(format!(
                    "layer {i}: codes {}..={} are not 1 <= lo <= hi",
                    l.code_lo, l.code_hi
                ));
            }
        }
        Ok(())
    }
}

/// The eye-space depth of depth code `code` (1..=255) over `near..far`
/// ([`ImpostorLayers`]); code 0 (empty) maps to `far`.
pub fn depth_of_code(near: f32, far: f32, code: u8) -> f32 {
    let t = (code.max(1) - 1) as f32 / 254.0;
    let inv = 1.0 / near - t * (1.0 / near - 1.0 / far);
    1.0 / inv
}

/// The depth code (1..=255) of eye-space depth `depth` over `near..far`, clamped.
pub fn code_of_depth(near: f32, far: f32, depth: f32) -> u8 {
    let span = 1.0 / near - 1.0 / far;
    if span <= 0.0 || !span.is_finite() {
        return 1;
    }
    let t = ((1.0 / near - 1.0 / depth) / span).clamp(0.0, 1.0);
    1 + (t * 254.0).round() as u8
}

super::pod_records! {
    /// One record of section `layered-impostors` (64 bytes), followed by its
    /// `layer_count` [`ImpostorLayerRecord`]s; one per LayeredImpostor proxy, in proxy
    /// order.
    pub struct ImpostorRecord[64] {
        pub corner_rays: [[f32; 3]; 4],
        pub near: f32,
        pub far: f32,
        pub layer_count: u32,
        pub reserved: u32,
    }

    /// One layer in section `layered-impostors` (16 bytes).
    pub struct ImpostorLayerRecord[16] {
        pub depth: f32,
        pub code_lo: u32,
        pub code_hi: u32,
        pub reserved: u32,
    }
}

/// A proxy's layers agree with its kind and views (a LayeredImpostor has layers and
/// one lossless view; no other kind has layers).
fn check_layers(proxy: &Proxy) -> Result<(), String> {
    match (&proxy.layers, proxy.kind) {
        (Some(l), ProxyKind::LayeredImpostor) => {
            l.validate()?;
            if proxy.views.len() != 1 {
                return Err(format!(
                    "LayeredImpostor with {} views, expected 1",
                    proxy.views.len()
                ));
            }
            if proxy.views[0].texture.encoding.is_block() {
                return Err(
                    "LayeredImpostor texture is block-compressed (its alpha holds depth codes)"
                        .into(),
                );
            }
            Ok(())
        }
        (None, ProxyKind::LayeredImpostor) => Err("LayeredImpostor without layers".into()),
        (Some(_), k) => Err(format!("{} proxy with impostor layers", k.name())),
        (None, _) => Ok(()),
    }
}

/// The content of one cell pack.
#[derive(Clone, Debug, PartialEq)]
pub struct CellPack {
    pub cell_id: u32,
    /// The bake job fingerprint this cell was built with.
    pub fingerprint: [u8; 32],
    /// The far-field group whose pack (`groups/<id>.pack`, format version 2) holds
    /// the proxies this cell shares with its group; `None` for a cell without one
    /// (and for every version-1 pack). A group pack itself has `None`.
    pub far_group: Option<u32>,
    /// Instances drawn as original geometry (they intersect the cell's prism).
    pub originals: Vec<u32>,
    pub proxies: Vec<Proxy>,
}

/// `far_group` of a cell with no far-field group (version 2; version 1 stores 0,
/// which also reads as none).
pub const NO_FAR_GROUP: u32 = u32::MAX;

super::pod_records! {
    /// Section `cell-meta` (64 bytes).
    pub struct CellMetaRecord[64] {
        pub fingerprint: [u8; 32],
        pub cell_id: u32,
        pub original_count: u32,
        pub proxy_count: u32,
        pub member_count: u32,
        pub view_count: u32,
        /// Version 2: the cell's far-field group or [`NO_FAR_GROUP`]; reserved (0) in
        /// version 1.
        pub far_group: u32,
        pub reserved: [u32; 2],
    }

    /// One entry of section `proxies` (16 bytes). A proxy's members and views follow
    /// those of the proxies before it.
    pub struct ProxyRecord[16] {
        pub kind: u32,
        pub member_count: u32,
        pub view_count: u32,
        pub reserved: u32,
    }

    /// One entry of section `members` (16 bytes). A member's triangles (in
    /// `member-triangles`) and masks (in `view-masks`) follow those before it.
    pub struct MemberRecord[16] {
        pub instance: u32,
        pub triangle_count: u32,
        /// `triangle_count` for MvMesh members, 0 otherwise.
        pub mask_count: u32,
        pub reserved: u32,
    }

    /// One entry of section `views` (96 bytes). A view's texture data (in `textures`)
    /// follows that of the views before it.
    pub struct ViewRecord[96] {
        pub matrix: [f32; 16],
        pub eye: [f32; 3],
        pub width: u32,
        pub height: u32,
        pub encoding: u32,
        pub data_len: u64,
    }
}

/// A view's eye and matrix are finite (the player divides by them).
fn check_view(eye: &[f32; 3], matrix: &[f32; 16]) -> Result<(), String> {
    if !eye.iter().all(|x| x.is_finite()) {
        return Err(format!("eye {eye:?} is not finite"));
    }
    if !matrix.iter().all(|x| x.is_finite()) {
        return Err(format!("texture matrix {matrix:?} is not finite"));
    }
    if matrix.iter().all(|&x| x == 0.0) {
        return Err("texture matrix is all zeros (it maps every point to no texel)".into());
    }
    Ok(())
}

fn check_masks(kind: ProxyKind, member: &ProxyMember, view_count: usize) -> Result<(), String> {
    match kind {
        ProxyKind::MvMesh => {
            if view_count > MAX_MV_VIEWS {
                return Err(format!(
                    "MvMesh with {view_count} views, at most {MAX_MV_VIEWS}"
                ));
            }
            if member.view_masks.len() != member.triangles.len() {
                return Err(format!(
                    "MvMesh member of instance {}: {} view masks for {} triangles",
                    member.instance,
                    member.view_masks.len(),
                    member.triangles.len()
                ));
            }
            let allowed = if view_count >= 8 {
                0xff
            } else {
                (1u32 << view_count) as u8 - 1
            };
            if let Some(m) = member.view_masks.iter().find(|&&m| m & !allowed != 0) {
                return Err(format!(
                    "view mask {m:#010b} names a view past {view_count}"
                ));
            }
            Ok(())
        }
        _ if !member.view_masks.is_empty() => Err(format!(
            "{} member of instance {} has view masks (MvMesh only)",
            kind.name(),
            member.instance
        )),
        _ => Ok(()),
    }
}

/// The encoded bytes of every view's texture, concatenated in view order: the
/// `textures` section, or (version 6) the textures `texture-refs` names, read from
/// the store of the bake directory the pack lies in ([`texture_store`]).
fn view_textures<'a>(pack: &'a PackFile, views: &[ViewRecord]) -> Result<Cow<'a, [u8]>, PackError> {
    let file = pack.path();
    if pack.section_info(SectionKind::TEXTURE_REFS).is_none() {
        return pack.section(SectionKind::TEXTURES);
    }
    if pack.version() < 6 || pack.section_info(SectionKind::TEXTURES).is_some() {
        return Err(malformed(
            file,
            SectionKind::TEXTURE_REFS,
            0,
            "texture-refs needs format version 6 and a pack without a textures section",
        ));
    }
    let refs = texture_store::pack_refs(pack)?;
    if refs.len() != views.len() {
        return Err(malformed(
            file,
            SectionKind::TEXTURE_REFS,
            0,
            format!("{} references for {} views", refs.len(), views.len()),
        ));
    }
    let bake = texture_store::bake_dir_of(file).ok_or_else(|| {
        malformed(
            file,
            SectionKind::TEXTURE_REFS,
            0,
            "textures in the store can only be read from a pack at <bake>/cells/ or <bake>/groups/",
        )
    })?;
    let mut out = Vec::new();
    for (r, v) in refs.iter().zip(views) {
        out.extend_from_slice(&texture_store::read_texture(bake, r, v.data_len)?);
    }
    Ok(Cow::Owned(out))
}

/// Each view's `data_len` (its encoded texture's bytes), in view order.
pub(crate) fn view_data_lens(pack: &PackFile) -> Result<Vec<u64>, PackError> {
    let views: Vec<ViewRecord> = pack.section_vec(SectionKind::VIEWS)?;
    Ok(views.iter().map(|v| v.data_len).collect())
}

impl CellPack {
    /// The pack's bytes (deterministic).
    pub fn encode(&self) -> Result<Vec<u8>, PackError> {
        self.encode_as(FileKind::Cell, None, None)
    }

    /// [`CellPack::encode`] (or, for a group, [`CellPack::encode_group`]) copying
    /// every section whose content is unchanged from `previous`, an earlier pack of
    /// the same cell or group, instead of compressing it again
    /// ([`super::writer::assemble_reusing`]): the same bytes, faster.
    ///
    /// `store`: the bake directory whose texture store ([`super::texture_store`])
    /// receives the views' textures, which the pack then names in `texture-refs`
    /// (format version 6, what the worker writes); `None` keeps them inline in
    /// `textures`.
    pub fn encode_reusing(
        &self,
        group: bool,
        previous: Option<&PackFile>,
        store: Option<&Path>,
    ) -> Result<Vec<u8>, PackError> {
        if group {
            self.check_group()?;
            self.encode_as(FileKind::Group, previous, store)
        } else {
            self.encode_as(FileKind::Cell, previous, store)
        }
    }

    /// The bytes of a far-field group pack (`groups/<id>.pack`): the same sections as
    /// a cell pack with file kind `group`; `cell_id` is the group id. A group has no
    /// originals and no group of its own.
    pub fn encode_group(&self) -> Result<Vec<u8>, PackError> {
        self.encode_reusing(true, None, None)
    }

    fn check_group(&self) -> Result<(), PackError> {
        if !self.originals.is_empty() {
            return Err(invalid(format!(
                "group {}: a group pack has no originals",
                self.cell_id
            )));
        }
        // Version 5 (issue 27): a group's `far_group` is its parent, of a larger id.
        if self.far_group.is_some_and(|p| p <= self.cell_id) {
            return Err(invalid(format!(
                "group {}: its parent {:?} must have a larger id",
                self.cell_id, self.far_group
            )));
        }
        Ok(())
    }

    fn encode_as(
        &self,
        file_kind: FileKind,
        previous: Option<&PackFile>,
        store: Option<&Path>,
    ) -> Result<Vec<u8>, PackError> {
        if self.far_group == Some(NO_FAR_GROUP) {
            return Err(invalid(format!(
                "cell {}: far group {NO_FAR_GROUP} is the 'none' value",
                self.cell_id
            )));
        }
        let u32_of = |n: usize, what: &str| {
            u32::try_from(n).map_err(|_| invalid(format!("too many {what}")))
        };
        let mut proxies = Vec::new();
        let mut members = Vec::new();
        let mut views = Vec::new();
        let mut triangles: Vec<u8> = Vec::new();
        let mut masks = Vec::new();
        let mut textures = Vec::new();
        let mut refs = Vec::new();
        let mut impostors: Vec<u8> = Vec::new();
        for (p, proxy) in self.proxies.iter().enumerate() {
            check_layers(proxy).map_err(|e| invalid(format!("proxy {p}: {e}")))?;
            if let Some(l) = &proxy.layers {
                impostors.extend_from_slice(bytemuck::bytes_of(&ImpostorRecord {
                    corner_rays: l.corner_rays,
                    near: l.near,
                    far: l.far,
                    layer_count: l.layers.len() as u32,
                    reserved: 0,
                }));
                for layer in &l.layers {
                    impostors.extend_from_slice(bytemuck::bytes_of(&ImpostorLayerRecord {
                        depth: layer.depth,
                        code_lo: layer.code_lo.into(),
                        code_hi: layer.code_hi.into(),
                        reserved: 0,
                    }));
                }
            }
            proxies.push(ProxyRecord {
                kind: proxy.kind as u32,
                member_count: u32_of(proxy.members.len(), "members")?,
                view_count: u32_of(proxy.views.len(), "views")?,
                reserved: 0,
            });
            for m in &proxy.members {
                check_masks(proxy.kind, m, proxy.views.len())
                    .map_err(|e| invalid(format!("proxy {p}: {e}")))?;
                members.push(MemberRecord {
                    instance: m.instance,
                    triangle_count: u32_of(m.triangles.len(), "triangles")?,
                    mask_count: u32_of(m.view_masks.len(), "view masks")?,
                    reserved: 0,
                });
                triangles.extend_from_slice(bytemuck::cast_slice(&m.triangles));
                masks.extend_from_slice(&m.view_masks);
            }
            for (v, view) in proxy.views.iter().enumerate() {
                view.texture
                    .validate()
                    .map_err(|e| invalid(format!("proxy {p} view {v}: {e}")))?;
                check_view(&view.eye, &view.matrix)
                    .map_err(|e| invalid(format!("proxy {p} view {v}: {e}")))?;
                views.push(ViewRecord {
                    matrix: view.matrix,
                    eye: view.eye,
                    width: view.texture.width,
                    height: view.texture.height,
                    encoding: view.texture.encoding as u32,
                    data_len: view.texture.data.len() as u64,
                });
                match store {
                    Some(bake) => refs.extend_from_slice(&texture_store::write_texture(
                        bake,
                        &view.texture.data,
                    )?),
                    None => textures.extend_from_slice(&view.texture.data),
                }
            }
        }
        let meta = CellMetaRecord {
            fingerprint: self.fingerprint,
            cell_id: self.cell_id,
            original_count: u32_of(self.originals.len(), "originals")?,
            proxy_count: u32_of(proxies.len(), "proxies")?,
            member_count: u32_of(members.len(), "members")?,
            view_count: u32_of(views.len(), "views")?,
            far_group: self.far_group.unwrap_or(NO_FAR_GROUP),
            reserved: [0; 2],
        };
        let mut sections = vec![
            SectionData::of_records(SectionKind::CELL_META, &[meta], RAW_ONLY),
            SectionData::of_records(SectionKind::ORIGINALS, &self.originals, TRY_INDICES),
            SectionData::of_records(SectionKind::PROXIES, &proxies, TRY_ZSTD),
            SectionData::of_records(SectionKind::MEMBERS, &members, TRY_ZSTD),
            SectionData::new(SectionKind::MEMBER_TRIANGLES, triangles, TRY_TRIANGLES),
            SectionData::new(SectionKind::VIEW_MASKS, masks, TRY_ZSTD),
            SectionData::of_records(SectionKind::VIEWS, &views, TRY_ZSTD),
            match store {
                Some(_) => SectionData::new(SectionKind::TEXTURE_REFS, refs, RAW_ONLY),
                None => SectionData::new(SectionKind::TEXTURES, textures, TRY_ZSTD),
            },
        ];
        // Only packs with layered impostors carry the section, so packs without
        // them stay byte-identical to those of writers that never knew it.
        if !impostors.is_empty() {
            sections.push(SectionData::new(
                SectionKind::LAYERED_IMPOSTORS,
                impostors,
                TRY_ZSTD,
            ));
        }
        assemble_reusing(file_kind, &sections, previous)
    }

    /// Decodes a validated cell pack. Instance ids and vertex indices can only be
    /// checked against the base pack: see [`CellPack::check_against`].
    pub fn decode(pack: &PackFile) -> Result<CellPack, PackError> {
        pack.expect_kind(FileKind::Cell)?;
        CellPack::decode_any(pack)
    }

    /// Decodes a validated far-field group pack ([`CellPack::encode_group`]).
    pub fn decode_group(pack: &PackFile) -> Result<CellPack, PackError> {
        pack.expect_kind(FileKind::Group)?;
        let group = CellPack::decode_any(pack)?;
        // Version 5 (issue 27): a group's `far_group` is its parent group.
        if !group.originals.is_empty() || (pack.version() < 5 && group.far_group.is_some()) {
            return Err(malformed(
                pack.path(),
                SectionKind::CELL_META,
                36,
                "a group pack lists originals or (before version 5) a far group",
            ));
        }
        Ok(group)
    }

    fn decode_any(pack: &PackFile) -> Result<CellPack, PackError> {
        let file = pack.path();
        // 1. Metadata and record tables.
        let meta: CellMetaRecord = pack.section_record(SectionKind::CELL_META)?;
        if meta.reserved != [0; 2] || (pack.version() < 2 && meta.far_group != 0) {
            return Err(malformed(
                file,
                SectionKind::CELL_META,
                52,
                format!(
                    "reserved fields are {:?}, expected 0",
                    [meta.far_group, meta.reserved[0], meta.reserved[1]]
                ),
            ));
        }
        let far_group =
            (pack.version() >= 2 && meta.far_group != NO_FAR_GROUP).then_some(meta.far_group);
        if far_group.is_some_and(|g| u64::from(g) >= crate::manifest::MAX_CELLS) {
            return Err(malformed(
                file,
                SectionKind::CELL_META,
                52,
                format!("far group {} is past the largest grid", meta.far_group),
            ));
        }
        let originals: Vec<u32> = pack.section_vec(SectionKind::ORIGINALS)?;
        let proxies: Vec<ProxyRecord> = pack.section_vec(SectionKind::PROXIES)?;
        let members: Vec<MemberRecord> = pack.section_vec(SectionKind::MEMBERS)?;
        let views: Vec<ViewRecord> = pack.section_vec(SectionKind::VIEWS)?;
        for (kind, len, expected) in [
            (SectionKind::ORIGINALS, originals.len(), meta.original_count),
            (SectionKind::PROXIES, proxies.len(), meta.proxy_count),
            (SectionKind::MEMBERS, members.len(), meta.member_count),
            (SectionKind::VIEWS, views.len(), meta.view_count),
        ] {
            if len != expected as usize {
                return Err(malformed(
                    file,
                    kind,
                    0,
                    format!("{len} records, cell-meta says {expected}"),
                ));
            }
        }
        for (kind, size, reserved) in [
            (
                SectionKind::PROXIES,
                std::mem::size_of::<ProxyRecord>(),
                proxies.iter().map(|r| r.reserved).position(|r| r != 0),
            ),
            (
                SectionKind::MEMBERS,
                std::mem::size_of::<MemberRecord>(),
                members.iter().map(|r| r.reserved).position(|r| r != 0),
            ),
        ] {
            if let Some(i) = reserved {
                return Err(malformed(
                    file,
                    kind,
                    (i * size + 12) as u64,
                    format!("record {i}: reserved field is not 0"),
                ));
            }
        }
        let triangles = pack_triangles(pack, SectionKind::MEMBER_TRIANGLES)?;
        let masks = pack.section(SectionKind::VIEW_MASKS)?;
        let textures = view_textures(pack, &views)?;
        let impostors = match pack.section_info(SectionKind::LAYERED_IMPOSTORS) {
            Some(_) => pack.section(SectionKind::LAYERED_IMPOSTORS)?.into_owned(),
            None => Vec::new(),
        };
        let mut next_impostor = 0usize;

        // 2. Walk proxies, consuming members, triangles, masks, views and texture bytes
        //    in order; every count is checked against what is left.
        let (mut next_member, mut next_view, mut next_tri, mut next_mask, mut next_tex) =
            (0usize, 0usize, 0usize, 0usize, 0usize);
        let mut out = Vec::with_capacity(proxies.len());
        for (p, r) in proxies.iter().enumerate() {
            let rec_off = (p * std::mem::size_of::<ProxyRecord>()) as u64;
            let kind = ProxyKind::from_u32(r.kind).ok_or_else(|| {
                malformed(
                    file,
                    SectionKind::PROXIES,
                    rec_off,
                    format!("proxy {p}: unknown kind {}", r.kind),
                )
            })?;
            let member_recs = take(&members, &mut next_member, r.member_count as usize)
                .ok_or_else(|| {
                    malformed(
                        file,
                        SectionKind::PROXIES,
                        rec_off + 4,
                        format!(
                            "proxy {p}: member count {} past the members table",
                            r.member_count
                        ),
                    )
                })?;
            let view_recs =
                take(&views, &mut next_view, r.view_count as usize).ok_or_else(|| {
                    malformed(
                        file,
                        SectionKind::PROXIES,
                        rec_off + 8,
                        format!(
                            "proxy {p}: view count {} past the views table",
                            r.view_count
                        ),
                    )
                })?;
            let mut proxy_members = Vec::with_capacity(member_recs.len());
            for m in member_recs {
                let tris = take(&triangles, &mut next_tri, m.triangle_count as usize).ok_or_else(
                    || {
                        malformed(
                            file,
                            SectionKind::MEMBERS,
                            0,
                            format!(
                                "proxy {p}: triangle count {} past member-triangles",
                                m.triangle_count
                            ),
                        )
                    },
                )?;
                let mk = take(&masks, &mut next_mask, m.mask_count as usize).ok_or_else(|| {
                    malformed(
                        file,
                        SectionKind::MEMBERS,
                        0,
                        format!("proxy {p}: mask count {} past view-masks", m.mask_count),
                    )
                })?;
                let member = ProxyMember {
                    instance: m.instance,
                    triangles: tris.to_vec(),
                    view_masks: mk.to_vec(),
                };
                check_masks(kind, &member, view_recs.len()).map_err(|e| {
                    malformed(
                        file,
                        SectionKind::VIEW_MASKS,
                        next_mask as u64,
                        format!("proxy {p}: {e}"),
                    )
                })?;
                proxy_members.push(member);
            }
            let mut proxy_views = Vec::with_capacity(view_recs.len());
            for v in view_recs {
                let view_index = next_view - view_recs.len() + proxy_views.len();
                check_view(&v.eye, &v.matrix).map_err(|e| {
                    malformed(
                        file,
                        SectionKind::VIEWS,
                        (view_index * std::mem::size_of::<ViewRecord>()) as u64,
                        format!("proxy {p} view {view_index}: {e}"),
                    )
                })?;
                let len = usize::try_from(v.data_len).ok();
                let data = len
                    .and_then(|l| take(&textures, &mut next_tex, l))
                    .ok_or_else(|| {
                        malformed(
                            file,
                            SectionKind::VIEWS,
                            0,
                            format!(
                                "proxy {p}: texture of {} bytes past the textures section",
                                v.data_len
                            ),
                        )
                    })?;
                let encoding = TextureEncoding::from_u32_in_version(v.encoding, pack.version())
                    .ok_or_else(|| {
                        malformed(
                            file,
                            SectionKind::VIEWS,
                            (view_index * std::mem::size_of::<ViewRecord>() + 84) as u64,
                            format!(
                                "proxy {p}: unknown texture encoding {} in format version {}",
                                v.encoding,
                                pack.version()
                            ),
                        )
                    })?;
                let texture = Texture {
                    width: v.width,
                    height: v.height,
                    encoding,
                    data: data.to_vec(),
                };
                texture.validate().map_err(|e| {
                    malformed(
                        file,
                        SectionKind::TEXTURES,
                        (next_tex - data.len()) as u64,
                        format!("proxy {p}: {e}"),
                    )
                })?;
                proxy_views.push(ProxyView {
                    eye: v.eye,
                    matrix: v.matrix,
                    texture,
                });
            }
            let layers = if kind == ProxyKind::LayeredImpostor {
                Some(read_layers(file, &impostors, &mut next_impostor, p)?)
            } else {
                None
            };
            let proxy = Proxy {
                kind,
                members: proxy_members,
                views: proxy_views,
                layers,
            };
            check_layers(&proxy).map_err(|e| {
                malformed(
                    file,
                    SectionKind::LAYERED_IMPOSTORS,
                    next_impostor as u64,
                    format!("proxy {p}: {e}"),
                )
            })?;
            out.push(proxy);
        }
        // 3. Nothing may be left over.
        for (kind, used, len) in [
            (SectionKind::MEMBERS, next_member, members.len()),
            (SectionKind::VIEWS, next_view, views.len()),
            (SectionKind::MEMBER_TRIANGLES, next_tri, triangles.len()),
            (SectionKind::VIEW_MASKS, next_mask, masks.len()),
            (SectionKind::TEXTURES, next_tex, textures.len()),
            (
                SectionKind::LAYERED_IMPOSTORS,
                next_impostor,
                impostors.len(),
            ),
        ] {
            if used != len {
                return Err(malformed(
                    file,
                    kind,
                    used as u64,
                    format!("{} records not referenced by any proxy", len - used),
                ));
            }
        }
        Ok(CellPack {
            cell_id: meta.cell_id,
            fingerprint: meta.fingerprint,
            far_group,
            originals,
            proxies: out,
        })
    }

    /// Checks every instance id and vertex index against the base pack (what the
    /// player does before uploading index buffers).
    pub fn check_against(&self, base: &BasePack) -> Result<(), PackError> {
        let cells = u64::from(base.grid.n_cols) * u64::from(base.grid.n_rows);
        if u64::from(self.cell_id) >= cells {
            return Err(invalid(format!(
                "cell {} is outside the base pack's grid of {} × {} cells",
                self.cell_id, base.grid.n_cols, base.grid.n_rows
            )));
        }
        if let Some(g) = self.far_group.filter(|&g| u64::from(g) >= cells) {
            return Err(invalid(format!(
                "cell {}: far group {g} is past the grid's {cells} cells (a grid has at \
                 most as many groups as cells)",
                self.cell_id
            )));
        }
        let instance = |id: u32, what: &str| -> Result<u32, PackError> {
            let inst = base.instances.get(id as usize).ok_or_else(|| {
                invalid(format!(
                    "cell {}: {what} refers to instance {id} of {}",
                    self.cell_id,
                    base.instances.len()
                ))
            })?;
            let model = base
                .models
                .get(inst.model as usize)
                .ok_or_else(|| invalid(format!("instance {id}: bad model")))?;
            Ok(model.mesh.positions.len() as u32)
        };
        // An original is listed once, and is no member of the cell's proxies (issue
        // 32 item 3; the player would draw it twice). No bake writes either: a cell's
        // originals are the objects of its own region, its proxies those outside
        // (checked on the park-2m, park-other, plaza and demo bakes). The sample
        // packs shipped for versions 1–7 (tests/data) list instance 0 both ways and
        // are refused here, by design.
        let mut originals = std::collections::BTreeSet::new();
        for &o in &self.originals {
            instance(o, "an original")?;
            if !originals.insert(o) {
                return Err(invalid(format!(
                    "cell {}: instance {o} is listed twice as an original",
                    self.cell_id
                )));
            }
        }
        for (p, proxy) in self.proxies.iter().enumerate() {
            for m in &proxy.members {
                let vertices = instance(m.instance, "a proxy member")?;
                if originals.contains(&m.instance) {
                    return Err(invalid(format!(
                        "cell {} proxy {p}: instance {} is an original of the cell and a \
                         member of this proxy (it would be drawn twice)",
                        self.cell_id, m.instance
                    )));
                }

                if let Some(t) = m
                    .triangles
                    .iter()
                    .find(|t| t.iter().any(|&v| v >= vertices))
                {
                    return Err(invalid(format!(
                        "cell {} proxy {p}: triangle {t:?} of instance {} indexes past {vertices} vertices",
                        self.cell_id, m.instance
                    )));
                }
            }
        }
        Ok(())
    }

    /// Validates and decodes group-pack bytes held in memory.
    pub fn group_from_bytes(bytes: &[u8]) -> Result<CellPack, PackError> {
        CellPack::decode_group(&PackFile::from_bytes(bytes)?)
    }

    pub fn triangle_count(&self) -> u64 {
        self.proxies
            .iter()
            .flat_map(|p| &p.members)
            .map(|m| m.triangles.len() as u64)
            .sum()
    }
}

super::pack_file_methods!(CellPack);

/// The next impostor record and its layers from section `layered-impostors`
/// (`bytes`, from offset `*next`), for proxy `p`.
fn read_layers(
    file: &Path,
    bytes: &[u8],
    next: &mut usize,
    p: usize,
) -> Result<ImpostorLayers, PackError> {
    const KIND: SectionKind = SectionKind::LAYERED_IMPOSTORS;
    let at = *next;
    let record = take(bytes, next, std::mem::size_of::<ImpostorRecord>()).ok_or_else(|| {
        malformed(
            file,
            KIND,
            at as u64,
            format!("proxy {p}: LayeredImpostor record past the section's end"),
        )
    })?;
    let r: ImpostorRecord = bytemuck::pod_read_unaligned(record);
    if r.reserved != 0 {
        return Err(malformed(
            file,
            KIND,
            at as u64 + 60,
            format!("proxy {p}: reserved field is not 0"),
        ));
    }
    if r.layer_count == 0 || r.layer_count as usize > MAX_IMPOSTOR_LAYERS {
        return Err(malformed(
            file,
            KIND,
            at as u64 + 56,
            format!(
                "proxy {p}: {} layers, expected 1..={MAX_IMPOSTOR_LAYERS}",
                r.layer_count
            ),
        ));
    }
    let size = std::mem::size_of::<ImpostorLayerRecord>();
    let mut layers = Vec::with_capacity(r.layer_count as usize);
    for i in 0..r.layer_count as usize {
        let at = *next;
        let bytes = take(bytes, next, size).ok_or_else(|| {
            malformed(
                file,
                KIND,
                at as u64,
                format!("proxy {p}: layer {i} past the section's end"),
            )
        })?;
        let l: ImpostorLayerRecord = bytemuck::pod_read_unaligned(bytes);
        if l.reserved != 0 || l.code_lo > 255 || l.code_hi > 255 {
            return Err(malformed(
                file,
                KIND,
                at as u64 + 4,
                format!(
                    "proxy {p}: layer {i}: codes {}..={} or reserved {} out of range",
                    l.code_lo, l.code_hi, l.reserved
                ),
            ));
        }
        layers.push(ImpostorLayer {
            depth: l.depth,
            code_lo: l.code_lo as u8,
            code_hi: l.code_hi as u8,
        });
    }
    Ok(ImpostorLayers {
        corner_rays: r.corner_rays,
        near: r.near,
        far: r.far,
        layers,
    })
}

/// The next `n` items of `items` from `*next`, advancing it; `None` if fewer remain.
fn take<'a, T>(items: &'a [T], next: &mut usize, n: usize) -> Option<&'a [T]> {
    let s = super::range_of(items, *next, n)?;
    *next += n;
    Some(s)
}
