//! Streaming and prefetching of cell data (paper 000 §3.2, "Prefetching").
//!
//! - A **timestamp**, initially 0, grows by 1 whenever the viewer has moved a fixed
//!   distance or turned a fixed angle since the last increment. At each increment the
//!   neighbouring cells of the current cell (the index's neighbour lists) that are not
//!   resident go into a **priority queue** with t-priority = timestamp + priority,
//!   priority ∈ [0, 1) from frustum membership, closeness to the aim vector and
//!   closeness to the viewpoint ([`cell_priority`]).
//! - A separate **prefetch thread** repeatedly removes the highest t-priority entry,
//!   drops it if it is out of date (t-priority < timestamp − 2), and otherwise maps,
//!   validates and prepares the cell pack, then makes its GPU proxies (vertex and
//!   view buffers, atlases; [`crate::gpu::ProxyMaker`]) with the renderer's device,
//!   which wgpu lets any thread use.
//! - The render thread takes the prepared cells and queues their
//!   textures in a **FIFO texture queue** served before each frame under a per-frame
//!   byte budget (§3.2: "an amount of texture constrained by a budget is loaded
//!   before each frame"; a texture that is not the first of the frame and is larger
//!   than the remaining budget is put back as the first in the queue; a single
//!   texture larger than the whole budget is uploaded alone, as the first of a
//!   frame, or it would never be). Prefetched cells' textures are thus uploaded
//!   progressively while the viewer is still in the previous cell.
//! - **Crossings never break the budget** (issue 7: a 723 ms crossing frame when
//!   the new cell's textures were uploaded at once): when the viewer enters a cell
//!   whose textures are still queued, they move to the front of the queue, keeping
//!   their order, and go up under the same budget. Until all of a proxy's textures
//!   are resident, the frame draws a **stand-in** for it: the ready proxy of the
//!   packs drawn before the crossing (the previous cell and its group) that shows
//!   the same objects, if there is one (of a batch, the members that do: its
//!   vertex ranges, `frame::stand_ins_for`) — a proxy made for the region next door,
//!   seen from just across its border, as a texture streamer shows a coarser mip
//!   until the finer one arrives — else the member objects as original geometry
//!   ([`ResidentCell::fallback_instances`]); with [`PendingDraw::Lit`], the proxy
//!   mesh with lit vertex colours. Never a hole, never an object twice. (Not in
//!   the paper, whose prefetching assumes the textures arrive before the crossing.)
//! - Resident cells are evicted least-recently-used first above a memory budget (never
//!   the current cell, its group or the stand-ins in use).
//! - A cell whose pack is missing or corrupt is logged once and drawn as original
//!   geometry.
//! - **Far field** (format version 2, issue 13): a cell whose index entry names a
//!   far-field group also draws that group's pack (`groups/<id>.pack`), shared by
//!   the group's cells, and (version 5, issue 27) the pack of each parent group
//!   of the chain the index lists (levels of 7, 49, 343 … cells). Groups stream like cells under keys after the cell ids
//!   ([`crate::bake::group_key`]): loaded on demand with the current cell,
//!   prefetched with each neighbour, uploaded under the same budget, evicted LRU
//!   (never the current cell's group). While a group is unavailable (missing or
//!   corrupt pack) the cell draws every object it has no proxy or original for as
//!   original geometry — never a hole.
//!
//! The thread is "low priority" in the paper's sense: it does I/O, decoding and the
//! creation of GPU objects, never a texture upload or a draw; the OS priority is
//! left as is. (Until issue 31 it did not touch the GPU: making a pack's GPU objects
//! on the render thread cost 10–33 ms a pack on lavapipe, the frames after each
//! crossing.)

use crate::bake::{load_cell, Bake, PreparedCell};
use crate::camera::{Aabb, Camera};
use crate::gpu::{GpuProxy, Renderer};
use format::pack::{BasePack, Index};
use glam::{Vec2, Vec3};
use std::cmp::Ordering;
use std::collections::{BTreeMap, BTreeSet, BinaryHeap, VecDeque};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering as AtomicOrdering};
use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::Instant;

/// Textures of packs not drawn yet (prefetched neighbours) are uploaded at the
/// slowest rate that empties their queue within [`AHEAD_DRAIN_FRAMES`] display
/// frames, and at least 1/`AHEAD_UPLOAD_SHARE` of
/// [`StreamConfig::upload_budget_bytes`] a frame (512 KiB of the default 4 MiB),
/// at most all of it. Uploading them a whole budget at a time made the frames
/// after a crossing 25–50 ms slower on park-2m's walk (lavapipe); a fixed 512 KiB
/// share left the city's larger cells (≈ 10–30 MB of textures) behind the walk.
pub const AHEAD_UPLOAD_SHARE: u64 = 8;

/// See [`AHEAD_UPLOAD_SHARE`]: 30 display frames, half a second at 60 Hz, less than
/// a viewer at 3× walking speed spends in a park-2m or city cell.
pub const AHEAD_DRAIN_FRAMES: u64 = 30;

/// Streaming parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct StreamConfig {
    /// Run the prefetch thread (`--no-prefetch` turns it off: cells load on demand).
    pub prefetch: bool,
    /// Texture bytes uploaded per frame from the FIFO queue.
    pub upload_budget_bytes: u64,
    /// Resident cell data (vertices + texels) kept before LRU eviction.
    pub memory_budget_bytes: u64,
    /// Timestamp step: distance moved, in units (default: cell size / 5).
    pub step_distance: Option<f32>,
    /// Timestamp step: angle turned, in degrees.
    pub step_angle_deg: f32,
    /// How a proxy whose textures are still queued is drawn.
    pub pending: PendingDraw,
    /// Display frames each drawn frame stands for (headless path renders: a path
    /// frame is 1 / frame_rate s of walking, in which a 60 Hz player draws 6
    /// frames). After a drawn hybrid frame, the other display frames advance the
    /// streaming (prefetch results, uploads under the per-frame budget) at the same
    /// pose without drawing; their time is not counted, as each costs what the drawn
    /// frame, its sample, costs. 1: every frame is drawn (`player view`).
    pub display_frames_per_step: u32,
    /// The cross-fade band at cell borders as a share of the hexagon's apothem
    /// (issue 31 item 2, [`crate::transition`]; `--fade`): within it a frame blends
    /// the current cell's representation with each neighbour's whose packs are
    /// resident and ready ([`Streamer::blend`]). 0: the current cell only.
    pub fade: f32,
}

/// How the hybrid draws a proxy whose textures are not resident yet (never a hole).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PendingDraw {
    /// A ready proxy of the packs drawn before the crossing that shows the same
    /// objects (module docs), else its member objects as original geometry.
    #[default]
    StandIns,
    /// Its member objects as original geometry (exact, more triangles).
    Originals,
    /// The proxy mesh itself with lit vertex colours (DESIGN.md shading, no texture).
    Lit,
}

impl std::str::FromStr for PendingDraw {
    type Err = String;
    fn from_str(s: &str) -> Result<PendingDraw, String> {
        crate::mode::parse_named(
            "pending draw",
            s,
            [
                ("stand-ins", PendingDraw::StandIns),
                ("originals", PendingDraw::Originals),
                ("lit", PendingDraw::Lit),
            ],
        )
    }
}

/// [`StreamConfig::fade`]'s default: a band of 0.15 apothem on each side of an
/// edge (player README "Cross-fades at cell borders"). Chosen on four scene
/// families (the demo's primitives, the textured plaza, park-2m's statues, the
/// city's blocks; park-4m and the terrain checked after): there it left object
/// PSNR(Y) within 0.21 dB of no fade and raised every walk's mean crossing pop
/// above the one-pixel turn; 0.3 cost the plaza 1.1 dB. A frame in the band draws both cells' lists (≈ 1.7× the frame
/// time on lavapipe, park-2m).
pub const DEFAULT_FADE: f32 = 0.15;

impl Default for StreamConfig {
    fn default() -> Self {
        StreamConfig {
            prefetch: true,
            upload_budget_bytes: 4 << 20,
            // 1 GiB: the city walk's cell with its ring of neighbours holds more
            // than 512 MiB (8 of 39 crossings into an evicted cell at walking
            // speed); park-2m's and park-4m's fit either.
            memory_budget_bytes: 1 << 30,
            step_distance: None,
            step_angle_deg: 15.0,
            pending: PendingDraw::StandIns,
            display_frames_per_step: 1,
            fade: DEFAULT_FADE,
        }
    }
}

/// An entry of the prefetch queue.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QueueEntry {
    pub t_priority: f64,
    pub cell: u32,
}

impl Eq for QueueEntry {}
impl Ord for QueueEntry {
    fn cmp(&self, o: &Self) -> Ordering {
        self.t_priority
            .total_cmp(&o.t_priority)
            .then_with(|| o.cell.cmp(&self.cell))
    }
}
impl PartialOrd for QueueEntry {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

/// The timestamped priority queue of §3.2.
#[derive(Debug, Default)]
pub struct PrefetchQueue {
    heap: BinaryHeap<QueueEntry>,
}

impl PrefetchQueue {
    pub fn push(&mut self, timestamp: u64, priority: f64, cell: u32) {
        let p = priority.clamp(0.0, 0.999_999);
        self.heap.push(QueueEntry {
            t_priority: timestamp as f64 + p,
            cell,
        });
    }

    /// The highest t-priority entry that is not out of date at `timestamp`
    /// (t-priority ≥ timestamp − 2); stale entries met on the way are dropped.
    pub fn pop(&mut self, timestamp: u64) -> Option<QueueEntry> {
        while let Some(e) = self.heap.pop() {
            if e.t_priority >= timestamp as f64 - 2.0 {
                return Some(e);
            }
        }
        None
    }

    pub fn len(&self) -> usize {
        self.heap.len()
    }

    pub fn is_empty(&self) -> bool {
        self.heap.is_empty()
    }
}

/// Priority in [0, 1) of prefetching a cell (§3.2): cells within the view frustum
/// first (0.5), then closeness of the direction to the cell to the aim vector (0.3),
/// then closeness to the viewpoint (0.2).
pub fn cell_priority(camera: &Camera, prism: &Aabb, cell_size: f32) -> f64 {
    let in_frustum = if camera.frustum().intersects(prism) {
        1.0
    } else {
        0.0
    };
    let to_cell = prism.centre() - camera.eye;
    let to_cell = Vec3::new(to_cell.x, 0.0, to_cell.z);
    let aim = Vec3::new(camera.dir.x, 0.0, camera.dir.z);
    let angle = if to_cell.length_squared() < 1e-12 || aim.length_squared() < 1e-12 {
        0.0
    } else {
        to_cell.angle_between(aim)
    };
    let aim_term = 1.0 - angle as f64 / std::f64::consts::PI;
    let dist_term = 1.0 / (1.0 + to_cell.length() as f64 / cell_size.max(1e-6) as f64);
    (0.5 * in_frustum + 0.3 * aim_term + 0.2 * dist_term) * 0.999_999
}

struct Shared {
    queue: Mutex<PrefetchQueue>,
    wake: Condvar,
    timestamp: AtomicU64,
    stop: AtomicBool,
    /// Cells resident, or prepared and on their way to the render thread: the
    /// prefetch thread skips both.
    resident: Mutex<BTreeSet<u32>>,
    /// The renderer's tile size, for [`crate::bake::cluster_cell`] on the prefetch
    /// thread (0 until the first frame says it).
    tile: std::sync::atomic::AtomicUsize,
    /// What creating GPU proxies needs of the renderer (set by each frame): with
    /// it the prefetch thread sends packs with their GPU objects made.
    maker: Mutex<Option<crate::gpu::ProxyMaker>>,
}

/// A pack from the prefetch thread: decoded and grouped, and — once a frame has
/// given it a [`crate::gpu::ProxyMaker`] — with its GPU proxies made
/// ([`Streamer::build`]), so that accepting it costs the render thread no GPU work.
enum Incoming {
    Prepared(PreparedCell),
    Built(Box<ResidentCell>),
}

/// A view texture waiting for upload: width, height, encoding, texel bytes.
type PendingTexture = (u32, u32, format::pack::TextureEncoding, Vec<u8>);

/// A resident cell.
pub struct ResidentCell {
    pub cell_id: u32,
    pub originals: Vec<u32>,
    /// The pack's proxies as drawn: one per pack proxy, except that a batch of
    /// layered impostors or of mesh proxies (`Renderer::create_pack_proxies`) is
    /// one, culled, ordered and replaced by originals as a whole, and stood in for
    /// member by member (`frame::stand_ins_for`).
    pub proxies: Vec<GpuProxy>,
    /// Per proxy: its world bounds (a batch's: the union of its members').
    pub bounds: Vec<Aabb>,
    /// Per proxy, per batch member (`GpuProxy::member_spans` order; one for a lone
    /// proxy): that member's instances (drawn as originals until the proxy is
    /// ready).
    pub member_objects: Vec<Vec<Vec<u32>>>,
    /// Texels still waiting in the upload queue: (proxy, slot) → texels (a batch's
    /// slot k: its member k's one view).
    pending: BTreeMap<(usize, usize), PendingTexture>,
    pub bytes: u64,
    last_used: u64,
}

impl ResidentCell {
    /// Every texture of the cell is resident.
    pub fn is_ready(&self) -> bool {
        self.pending.is_empty()
    }

    /// Proxies that cannot be drawn yet (textures still queued).
    pub fn pending_proxies(&self) -> usize {
        self.proxies.iter().filter(|p| !p.is_ready()).count()
    }

    /// The member instances of proxies whose textures are not all resident yet,
    /// sorted, without duplicates: the frame draws them as original geometry.
    pub fn fallback_instances(&self) -> Vec<u32> {
        let set: BTreeSet<u32> = self
            .proxies
            .iter()
            .zip(&self.member_objects)
            .filter(|(p, _)| !p.is_ready())
            .flat_map(|(_, m)| m.iter().flatten().copied())
            .collect();
        set.into_iter().collect()
    }
}

/// What the current frame draws for the hybrid configuration.
pub enum CurrentCell<'a> {
    /// The cell's pack is resident, with its far field and the stand-ins: the
    /// packs drawn before the last crossing, whose ready proxies stand in for the
    /// new packs' proxies still waiting for textures ([`Streamer`] docs).
    Pack(&'a ResidentCell, Far<'a>, Vec<&'a ResidentCell>),
    /// No usable pack (missing, corrupt, off the index): draw originals.
    Originals,
}

/// The current cell's far field.
pub enum Far<'a> {
    /// The cell has no far-field group (format version 1, or `bake.far_field` off).
    None,
    /// Its groups' packs, every level (level 1 first), resident.
    Packs(Vec<&'a ResidentCell>),
    /// A group's pack of its chain could not be loaded: the objects the cell has neither as
    /// originals nor as proxies are drawn as original geometry.
    Unavailable,
}

/// Per-frame streaming statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StreamStats {
    pub cell: Option<u32>,
    /// Cumulative cache hits / misses of current-cell lookups.
    pub hits: u64,
    pub misses: u64,
    /// Wall time spent on the render thread this frame on loading (demand misses)
    /// and uploading.
    pub stream_ms: f64,
    pub timestamp: u64,
    /// Texture bytes uploaded before this frame (at most the budget, unless one
    /// texture alone is larger).
    pub uploaded_bytes: u64,
    /// Proxies of the current cell drawn as original geometry this frame because
    /// their textures are still queued.
    pub pending_proxies: usize,
    /// Prefetched packs not drawn now that this frame accepted, and those left
    /// waiting for later frames ([`Streamer`]'s `accept_arrived`: any number whose
    /// GPU objects the prefetch thread made, at most one it did not).
    pub accepted_ahead: usize,
    pub held_back: usize,
    /// Packs whose GPU objects this frame made on the render thread: demand loads,
    /// and packs prepared before the prefetch thread had a renderer to make them with.
    pub built_here: usize,
    /// Texture bytes of packs not drawn now uploaded before this frame, and what
    /// the frame allowed them ([`AHEAD_UPLOAD_SHARE`]; one texture larger than that
    /// goes alone).
    pub uploaded_ahead_bytes: u64,
    pub ahead_budget_bytes: u64,
    /// The frame fell back to original geometry for the cell (its pack missing,
    /// corrupt or off the index), or for the far objects of a group of its chain
    /// whose pack could not be loaded (issue 32 item 3).
    pub fallback: bool,
}

/// The cell cache, upload queue and prefetch thread.
pub struct Streamer {
    config: StreamConfig,
    shared: Arc<Shared>,
    rx: Receiver<(u32, Result<Incoming, String>)>,
    /// Packs the prefetch thread has sent, not yet accepted ([`Self::accept_arrived`]).
    arrived: VecDeque<(u32, Result<Incoming, String>)>,
    thread: Option<JoinHandle<()>>,
    cells: BTreeMap<u32, ResidentCell>,
    failed: BTreeSet<u32>,
    uploads: VecDeque<(u32, usize, usize)>,
    clock: u64,
    last_step: Option<(Vec3, Vec3)>,
    current: Option<u32>,
    /// The eye (x, z) of the last [`Streamer::advance`] ([`Streamer::blend`]).
    eye: Option<Vec2>,
    /// Streaming keys of the current cell's far-field groups (level 1 first).
    current_groups: Vec<u32>,
    /// Keys of the packs drawn before the last crossing (cell, group), kept as
    /// stand-ins until the current packs are ready.
    previous: Vec<u32>,
    /// Keys of the current cell's neighbours and their groups: what the prefetch
    /// fetched for the next crossing, evicted only when nothing else is left.
    ring: BTreeSet<u32>,
    /// The warning that the ring does not fit the memory budget was given.
    ring_warned: bool,
    stats: StreamStats,
}

/// The cell under `camera` and the streaming keys of its far-field groups.
fn cell_and_group(bake: &Bake, camera: &Camera) -> (Option<u32>, Vec<u32>) {
    let cell = bake
        .grid
        .nearest_cell(Vec2::new(camera.eye.x, camera.eye.z));
    (cell, cell.map_or(Vec::new(), |id| group_keys_of(bake, id)))
}

/// The pack [`Streamer::evict`] drops first among `resident` (key, last used):
/// never one `in_use`; the least recently used outside `ring`, else in it.
fn eviction_victim(
    resident: impl Iterator<Item = (u32, u64)>,
    in_use: &[u32],
    ring: &BTreeSet<u32>,
) -> Option<u32> {
    resident
        .filter(|(k, _)| !in_use.contains(k))
        .min_by_key(|&(k, used)| (ring.contains(&k), used, k))
        .map(|(k, _)| k)
}

/// The streaming keys of `cell`'s neighbours and of their far-field groups.
fn ring_of(bake: &Bake, cell: Option<u32>) -> BTreeSet<u32> {
    let (Some(id), Some(index)) = (cell, bake.index.as_ref()) else {
        return BTreeSet::new();
    };
    let Some(entry) = index.cell(id) else {
        return BTreeSet::new();
    };
    entry
        .neighbours
        .iter()
        .filter(|&&n| n < bake.grid.cell_count())
        .flat_map(|&n| std::iter::once(n).chain(group_keys_of(bake, n)))
        .collect()
}

/// The streaming keys of `cell`'s far-field groups: its group, then each parent
/// (format version 5, issue 27; parents have larger ids, so the walk ends).
fn group_keys_of(bake: &Bake, cell: u32) -> Vec<u32> {
    let Some(index) = bake.index.as_ref() else {
        return Vec::new();
    };
    let mut group = index.cell(cell).and_then(|e| e.group);
    let mut keys = Vec::new();
    while let Some(g) = group {
        keys.push(crate::bake::group_key(&bake.base, g));
        group = index.group(g).and_then(|e| e.group).filter(|&p| p > g);
    }
    keys
}

impl Streamer {
    pub fn new(bake: &Bake, config: StreamConfig) -> Streamer {
        let shared = Arc::new(Shared {
            queue: Mutex::new(PrefetchQueue::default()),
            wake: Condvar::new(),
            timestamp: AtomicU64::new(0),
            stop: AtomicBool::new(false),
            resident: Mutex::new(BTreeSet::new()),
            tile: std::sync::atomic::AtomicUsize::new(0),
            maker: Mutex::new(None),
        });
        let (tx, rx) = channel();
        let thread = if config.prefetch {
            let s = shared.clone();
            let dir = bake.dir.clone();
            let base = bake.base.clone();
            let index = bake.index.clone();
            std::thread::Builder::new()
                .name("prefetch".into())
                .spawn(move || prefetch_loop(s, dir, base, index, tx))
                .ok()
        } else {
            None
        };
        Streamer {
            config,
            shared,
            rx,
            arrived: VecDeque::new(),
            thread,
            cells: BTreeMap::new(),
            failed: BTreeSet::new(),
            uploads: VecDeque::new(),
            clock: 0,
            last_step: None,
            current: None,
            eye: None,
            current_groups: Vec::new(),
            previous: Vec::new(),
            ring: BTreeSet::new(),
            ring_warned: false,
            stats: StreamStats::default(),
        }
    }

    pub fn config(&self) -> &StreamConfig {
        &self.config
    }

    pub fn resident_cells(&self) -> Vec<u32> {
        self.cells.keys().copied().collect()
    }

    pub fn resident_bytes(&self) -> u64 {
        self.cells.values().map(|c| c.bytes).sum()
    }

    pub fn queued_uploads(&self) -> usize {
        self.uploads.len()
    }

    pub fn timestamp(&self) -> u64 {
        self.shared.timestamp.load(AtomicOrdering::SeqCst)
    }

    /// Advances streaming for a frame seen by `camera`; returns what to draw
    /// ([`Streamer::advance`], then [`Streamer::current`]).
    pub fn begin_frame(
        &mut self,
        renderer: &Renderer,
        bake: &Bake,
        camera: &Camera,
    ) -> (CurrentCell<'_>, StreamStats) {
        let stats = self.advance(renderer, bake, camera);
        (self.current(), stats)
    }

    /// Advances streaming for a frame seen by `camera` (arrivals, the current cell
    /// and its groups made resident, uploads under the budget, eviction) and
    /// returns the frame's statistics; [`Streamer::current`] and
    /// [`Streamer::blend`] then say what it draws.
    pub fn advance(&mut self, renderer: &Renderer, bake: &Bake, camera: &Camera) -> StreamStats {
        let t0 = Instant::now();
        self.clock += 1;
        self.shared
            .tile
            .store(renderer.tile_size(), AtomicOrdering::Relaxed);
        self.stats.built_here = 0;
        if self.thread.is_some() {
            *self.shared.maker.lock().unwrap_or_else(|e| e.into_inner()) =
                Some(renderer.proxy_maker());
        }
        // 1. Cells the prefetch thread has prepared (accepted below).
        while let Ok(arrived) = self.rx.try_recv() {
            self.arrived.push_back(arrived);
        }
        // 2. The current cell; timestamp and prefetch requests.
        let (cell, group) = cell_and_group(bake, camera);
        if cell != self.current {
            self.ring = ring_of(bake, cell);
            // A crossing: the packs drawn so far become the stand-ins.
            self.previous = self
                .current
                .iter()
                .chain(&self.current_groups)
                .copied()
                .filter(|k| !group.contains(k) && self.cells.contains_key(k))
                .collect();
        }
        self.current = cell;
        self.current_groups = group;
        self.accept_arrived(renderer);
        self.step_timestamp(bake, camera, cell);
        // 3. Make the current cell and its far-field group resident (demand load on
        //    a miss).
        for k in self.current_groups.clone() {
            self.load_now(renderer, bake, k);
            self.prioritise(k);
        }
        if let Some(id) = cell {
            if self.cells.contains_key(&id) {
                self.stats.hits += 1;
            } else if !self.failed.contains(&id) {
                self.stats.misses += 1;
            }
            self.load_now(renderer, bake, id);
            // The current cell's queued textures go first (then its group's), under
            // the same budget.
            self.prioritise(id);
        }
        // 4. The texture queue, FIFO under the per-frame budget.
        self.stats.uploaded_bytes = self.upload_budgeted(renderer);
        // 5. LRU eviction.
        self.evict();
        self.stats.cell = cell;
        self.stats.stream_ms = t0.elapsed().as_secs_f64() * 1e3;
        self.stats.timestamp = self.timestamp();
        let clock = self.clock;
        self.stats.pending_proxies = 0;
        for k in cell.iter().chain(&self.current_groups) {
            if let Some(c) = self.cells.get_mut(k) {
                c.last_used = clock;
                self.stats.pending_proxies += c.pending_proxies();
            }
        }
        if self.stats.pending_proxies == 0 {
            self.previous.clear();
        }
        match cell.map(|id| self.cells.contains_key(&id)) {
            Some(true) => {
                self.stats.fallback = matches!(
                    Self::far_of(&self.cells, &self.current_groups),
                    Far::Unavailable
                );
            }
            _ => {
                self.stats.pending_proxies = 0;
                self.stats.fallback = cell.is_some();
            }
        }
        self.eye = Some(Vec2::new(camera.eye.x, camera.eye.z));
        self.stats
    }

    /// What the frame [`Streamer::advance`] prepared draws: the current cell's pack
    /// with its far field and stand-ins, or originals.
    pub fn current(&self) -> CurrentCell<'_> {
        match self.current.and_then(|id| self.cells.get(&id)) {
            Some(c) => {
                let far = Self::far_of(&self.cells, &self.current_groups);
                let stand_ins = self
                    .previous
                    .iter()
                    .filter_map(|k| self.cells.get(k))
                    .collect();
                CurrentCell::Pack(c, far, stand_ins)
            }
            None => CurrentCell::Originals,
        }
    }

    /// The cells the frame [`Streamer::advance`] prepared blends (issue 31 item 2,
    /// [`crate::transition`]): with [`StreamConfig::fade`] > 0, the current cell
    /// and each neighbour within the band whose pack and far-field groups are
    /// resident with every texture uploaded (one still streaming is left out
    /// rather than drawn incomplete), each with its dither range; what each draws
    /// is [`Streamer::current`] for the current cell and [`Streamer::settled_cell`]
    /// for the others. Empty when the frame draws the current cell alone (no fade,
    /// no pack, or no neighbour in the band).
    pub fn blend(&self, bake: &Bake) -> Vec<(u32, (u32, u32))> {
        let (Some(cell), Some(eye)) = (self.current, self.eye) else {
            return Vec::new();
        };
        let band = crate::transition::band(&bake.grid, self.config.fade);
        if band <= 0.0 || !self.cells.contains_key(&cell) {
            return Vec::new();
        }
        let ready = |id: u32| {
            std::iter::once(id)
                .chain(group_keys_of(bake, id))
                .all(|k| self.cells.get(&k).is_some_and(|c| c.pending_proxies() == 0))
        };
        let weights: Vec<(u32, f32)> = crate::transition::weights(&bake.grid, cell, eye, band)
            .into_iter()
            .filter(|&(id, _)| id == cell || ready(id))
            .collect();
        let ranges = crate::transition::ranges(&weights);
        if ranges.len() < 2 {
            return Vec::new();
        }
        ranges
            .into_iter()
            .map(|(id, lo, hi)| (id, (lo, hi)))
            .collect()
    }

    /// `cell`'s packs as resident now, drawn as a viewer settled in it would
    /// (no stand-ins); `None` unless the cell's pack is resident.
    pub fn settled_cell(&self, bake: &Bake, cell: u32) -> Option<CurrentCell<'_>> {
        let c = self.cells.get(&cell)?;
        let groups = group_keys_of(bake, cell);
        Some(CurrentCell::Pack(
            c,
            Self::far_of(&self.cells, &groups),
            Vec::new(),
        ))
    }

    /// The loading screen before a walk's first frame: the cell at `camera` and its
    /// far-field group become resident and all their textures are uploaded, outside
    /// any frame's budget, so the first frame shows the cell as baked instead of
    /// every object as original geometry. Streaming goes on from there as usual.
    /// The cache statistics do not count it.
    pub fn prime(&mut self, renderer: &Renderer, bake: &Bake, camera: &Camera) {
        let (cell, groups) = cell_and_group(bake, camera);
        for key in cell.into_iter().chain(groups) {
            self.load_fully(renderer, bake, key);
        }
    }

    /// Loads `key`'s pack now and uploads all its textures, outside any budget
    /// ([`Streamer::prime`], [`Streamer::settled`]).
    fn load_fully(&mut self, renderer: &Renderer, bake: &Bake, key: u32) {
        self.load_now(renderer, bake, key);
        self.prioritise(key);
        while let Some(&(id, pi, vi)) = self.uploads.front().filter(|e| e.0 == key) {
            self.uploads.pop_front();
            self.upload_one(renderer, id, pi, vi);
        }
    }

    /// The far field drawn with a cell whose chain of group keys is `groups`, from
    /// the resident `cells`.
    fn far_of<'a>(cells: &'a BTreeMap<u32, ResidentCell>, groups: &[u32]) -> Far<'a> {
        let packs: Option<Vec<&ResidentCell>> = groups.iter().map(|k| cells.get(k)).collect();
        match packs {
            _ if groups.is_empty() => Far::None,
            Some(p) => Far::Packs(p),
            None => Far::Unavailable,
        }
    }

    /// `cell`'s packs as a viewer settled in it would draw them, whatever the
    /// camera: the cell and its whole chain of far-field groups resident with every
    /// texture uploaded (outside any budget), no stand-ins. The crossing pop metric
    /// (issue 31, `compare::compare`) draws one pose with the outgoing and the incoming
    /// cell this way. `None` when the cell's pack cannot be loaded.
    pub fn settled(
        &mut self,
        renderer: &Renderer,
        bake: &Bake,
        cell: u32,
    ) -> Option<CurrentCell<'_>> {
        let groups = group_keys_of(bake, cell);
        for key in std::iter::once(cell).chain(groups) {
            self.load_fully(renderer, bake, key);
        }
        self.settled_cell(bake, cell)
    }

    /// Whether pack `id` is drawn now: the current cell or one of its groups.
    fn drawn_now(&self, id: u32) -> bool {
        self.current == Some(id) || self.current_groups.contains(&id)
    }

    /// Accepts the packs that arrived: every one whose GPU objects the prefetch
    /// thread made ([`Incoming::Built`]: accepting it only files it), and of the
    /// others those drawn now (the current cell, its groups) and at most one more.
    /// Making a pack's GPU buffers and atlases costs the render thread 10–33 ms per
    /// park-2m or park-4m pack on lavapipe, and after a crossing the prefetch
    /// thread delivers the new neighbours in a burst: made in one frame, they made
    /// it 2–5× its cell's median; made one a frame, the frames after a crossing
    /// still reached 1.5–3.5×.
    fn accept_arrived(&mut self, renderer: &Renderer) {
        let mut made_here = false;
        let mut ahead = 0;
        let mut keep = VecDeque::with_capacity(self.arrived.len());
        while let Some((id, result)) = self.arrived.pop_front() {
            let now = self.drawn_now(id);
            let built = matches!(result, Ok(Incoming::Built(_)) | Err(_));
            if now || built || !made_here {
                made_here |= !now && !built;
                ahead += usize::from(!now);
                self.accept(renderer, id, result);
            } else {
                keep.push_back((id, result));
            }
        }
        self.arrived = keep;
        self.stats.accepted_ahead = ahead;
        self.stats.held_back = self.arrived.len();
    }

    /// Loads `key`'s pack on the render thread (a demand load) unless it is
    /// resident or known to fail.
    fn load_now(&mut self, renderer: &Renderer, bake: &Bake, key: u32) {
        if !self.cells.contains_key(&key) && !self.failed.contains(&key) {
            let result = bake
                .load_cell(key)
                .map(Incoming::Prepared)
                .map_err(|e| e.to_string());
            self.accept(renderer, key, result);
        }
    }

    /// The display frames after a drawn one ([`StreamConfig::display_frames_per_step`]):
    /// streaming advances at `camera` without drawing. Each one's uploads and new
    /// packs reach the GPU in that display frame ([`Renderer::flush_uploads`]), as
    /// a player drawing it would submit them, not in the next drawn frame.
    pub fn undrawn_frames(&mut self, renderer: &Renderer, bake: &Bake, camera: &Camera) {
        for _ in 1..self.config.display_frames_per_step.max(1) {
            self.begin_frame(renderer, bake, camera);
            renderer.flush_uploads();
        }
    }

    fn step_timestamp(&mut self, bake: &Bake, camera: &Camera, cell: Option<u32>) {
        let c = bake.grid.params().cell_size;
        let step = self.config.step_distance.unwrap_or(c / 5.0);
        let dir = camera.dir.normalize_or_zero();
        let stepped = match self.last_step {
            None => true,
            Some((eye, d)) => {
                eye.distance(camera.eye) >= step
                    || d.angle_between(dir).to_degrees() >= self.config.step_angle_deg
            }
        };
        if !stepped {
            return;
        }
        let ts = if self.last_step.is_none() {
            0
        } else {
            self.shared.timestamp.fetch_add(1, AtomicOrdering::SeqCst) + 1
        };
        self.last_step = Some((camera.eye, dir));
        if self.thread.is_none() {
            return;
        }
        let (Some(id), Some(index)) = (cell, bake.index.as_ref()) else {
            return;
        };
        let Some(entry) = index.cell(id) else {
            return;
        };
        let g = bake.grid.params();
        let mut q = self.shared.queue.lock().unwrap_or_else(|e| e.into_inner());
        let mut pushed = BTreeSet::new();
        for &n in &entry.neighbours {
            if n >= bake.grid.cell_count() {
                continue;
            }
            let centre = bake.grid.centre(n);
            let prism = Aabb {
                min: Vec3::new(centre.x - c, g.min_eye_height, centre.y - c),
                max: Vec3::new(centre.x + c, g.max_eye_height, centre.y + c),
            };
            let priority = cell_priority(camera, &prism, c);
            // The neighbour and its far-field group (often the current cell's own).
            for key in std::iter::once(n).chain(group_keys_of(bake, n)) {
                if pushed.insert(key)
                    && !self.cells.contains_key(&key)
                    && !self.failed.contains(&key)
                    && !self.arrived.iter().any(|(k, _)| *k == key)
                {
                    q.push(ts, priority, key);
                }
            }
        }
        drop(q);
        self.shared.wake.notify_one();
    }

    fn accept(&mut self, renderer: &Renderer, id: u32, result: Result<Incoming, String>) {
        if self.cells.contains_key(&id) || self.failed.contains(&id) {
            return;
        }
        match result {
            Ok(incoming) => {
                let mut cell = match incoming {
                    Incoming::Built(cell) => *cell,
                    Incoming::Prepared(cell) => {
                        self.stats.built_here += 1;
                        Self::build(&renderer.proxy_maker(), id, cell)
                    }
                };
                cell.last_used = self.clock;
                self.uploads
                    .extend(cell.pending.keys().map(|&(pi, vi)| (id, pi, vi)));
                self.cells.insert(id, cell);
                self.shared
                    .resident
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .insert(id);
            }
            Err(e) => {
                eprintln!("player: error: {e}; drawing this cell as original geometry");
                self.failed.insert(id);
            }
        }
    }

    /// Pack `id`'s GPU proxies made with `maker` (on the prefetch thread, or on the
    /// render thread for a demand load): each drawing one pack proxy or a batch of
    /// layered impostors or of mesh proxies (`Renderer::create_pack_proxies`; a
    /// batch is one proxy here too, with its members' union of bounds and each
    /// member's objects), their textures pending in proxy and slot order.
    fn build(maker: &crate::gpu::ProxyMaker, id: u32, cell: PreparedCell) -> ResidentCell {
        let bytes = cell.bytes();
        let views: Vec<Vec<crate::gpu::ViewInfo>> = cell
            .proxies
            .iter()
            .map(|p| {
                p.views
                    .iter()
                    .map(|v| crate::gpu::ViewInfo {
                        matrix: v.matrix,
                        eye: v.eye,
                        width: v.width,
                        height: v.height,
                        encoding: v.encoding,
                    })
                    .collect()
            })
            .collect();
        let tile = maker.tile_size();
        let sources: Vec<crate::gpu::ProxySource> = cell
            .proxies
            .iter()
            .zip(&views)
            .map(|(p, v)| crate::gpu::ProxySource {
                vertices: &p.vertices,
                views: v,
                // Grouped on the prefetch thread for this tile size.
                clusters: p
                    .clusters
                    .as_ref()
                    .filter(|(t, _)| *t == tile)
                    .map(|(_, c)| c.as_slice()),
            })
            .collect();
        let drawn = maker.create_pack_proxies(&sources);
        let mut packed: Vec<Option<crate::bake::PreparedProxy>> =
            cell.proxies.into_iter().map(Some).collect();
        let mut proxies = Vec::with_capacity(drawn.len());
        let mut bounds = Vec::with_capacity(drawn.len());
        let mut member_objects = Vec::with_capacity(drawn.len());
        let mut pending = BTreeMap::new();
        for (pi, (gpu, from)) in drawn.into_iter().enumerate() {
            let mut b = Aabb::EMPTY;
            let mut per_member = Vec::with_capacity(from.len());
            // Slot `vi` of the drawn proxy: a lone proxy's view vi; in a
            // batch, the members' views in member order (each member's
            // from its base slot on).
            let mut slots = Vec::new();
            for &i in &from {
                let Some(p) = packed.get_mut(i).and_then(Option::take) else {
                    continue;
                };
                b = b.union(&p.bounds);
                per_member.push(p.members);
                slots.extend(p.views);
            }
            proxies.push(gpu);
            bounds.push(b);
            member_objects.push(per_member);
            for (vi, v) in slots.into_iter().enumerate() {
                pending.insert((pi, vi), (v.width, v.height, v.encoding, v.data));
            }
        }
        ResidentCell {
            cell_id: id,
            originals: cell.originals,
            proxies,
            bounds,
            member_objects,
            pending,
            bytes,
            last_used: 0,
        }
    }

    fn upload_one(&mut self, renderer: &Renderer, id: u32, pi: usize, vi: usize) -> u64 {
        let Some(cell) = self.cells.get_mut(&id) else {
            return 0;
        };
        let Some((w, h, encoding, data)) = cell.pending.remove(&(pi, vi)) else {
            return 0;
        };
        renderer.upload_view_texels(&mut cell.proxies[pi], vi, w, h, encoding, &data);
        data.len() as u64
    }

    /// Moves cell `id`'s queued textures to the front of the texture queue, in
    /// their order (stable partition); no-op when they are already there.
    fn prioritise(&mut self, id: u32) {
        let Some(cell) = self.cells.get(&id) else {
            return;
        };
        if cell.pending.is_empty() {
            return;
        }
        let already_first = self
            .uploads
            .iter()
            .position(|&(c, _, _)| c != id)
            .is_none_or(|k| self.uploads.iter().skip(k).all(|&(c, _, _)| c != id));
        if already_first {
            return;
        }
        let (mine, rest): (VecDeque<_>, VecDeque<_>) =
            self.uploads.drain(..).partition(|&(c, _, _)| c == id);
        self.uploads = mine;
        self.uploads.extend(rest);
    }

    /// Serves the texture queue under the per-frame budget; returns the bytes
    /// uploaded. The textures of packs drawn now (the current cell and its groups,
    /// first in the queue: [`Self::prioritise`]) may take the whole budget; those of
    /// packs prefetched for later, the share [`AHEAD_UPLOAD_SHARE`] sets.
    fn upload_budgeted(&mut self, renderer: &Renderer) -> u64 {
        let budget = self.config.upload_budget_bytes;
        let mut left = budget;
        let size_of = |cells: &BTreeMap<u32, ResidentCell>, (id, pi, vi): (u32, usize, usize)| {
            cells
                .get(&id)
                .and_then(|c| c.pending.get(&(pi, vi)))
                .map(|(_, _, _, t)| t.len() as u64)
        };
        let queued_ahead: u64 = self
            .uploads
            .iter()
            .filter(|&&(id, _, _)| !self.drawn_now(id))
            .filter_map(|&u| size_of(&self.cells, u))
            .sum();
        let mut ahead_left = (queued_ahead.div_ceil(AHEAD_DRAIN_FRAMES))
            .clamp(budget / AHEAD_UPLOAD_SHARE, budget.max(1));
        self.stats.ahead_budget_bytes = ahead_left;
        let mut uploaded = 0;
        self.stats.uploaded_ahead_bytes = 0;
        let mut first = true;
        while let Some((id, pi, vi)) = self.uploads.pop_front() {
            let Some(size) = size_of(&self.cells, (id, pi, vi)) else {
                continue; // evicted or already uploaded
            };
            let now = self.drawn_now(id);
            let cap = if now { left } else { left.min(ahead_left) };
            if size > cap && !first {
                self.uploads.push_front((id, pi, vi));
                break;
            }
            let bytes = self.upload_one(renderer, id, pi, vi);
            uploaded += bytes;
            left = left.saturating_sub(size);
            if !now {
                ahead_left = ahead_left.saturating_sub(size);
                self.stats.uploaded_ahead_bytes += bytes;
            }
            first = false;
            if left == 0 || (!now && ahead_left == 0) {
                break;
            }
        }
        uploaded
    }

    /// Least recently used first, the current cell's ring ([`ring_of`]) last: a
    /// neighbour prefetched for the next crossing has not been used yet, and plain
    /// LRU evicted it for the next one prefetched (the city walk at walking speed
    /// under a 512 MiB budget: 8 of 39 crossings into an evicted cell). Evicting
    /// one of the ring is said once: the budget is then too small for the scene.
    fn evict(&mut self) {
        let mut total = self.resident_bytes();
        while total > self.config.memory_budget_bytes {
            let in_use: Vec<u32> = self
                .current
                .iter()
                .chain(&self.current_groups)
                .chain(&self.previous)
                .copied()
                .collect();
            let victim = eviction_victim(
                self.cells.values().map(|c| (c.cell_id, c.last_used)),
                &in_use,
                &self.ring,
            );
            let Some(v) = victim else {
                break;
            };
            if self.ring.contains(&v) && !self.ring_warned {
                self.ring_warned = true;
                eprintln!(
                    "player: warning: the memory budget ({} MiB) does not hold the current cell and its neighbours ({} MiB resident): cells prefetched for the next crossing are evicted before use; raise --memory-budget-mib",
                    self.config.memory_budget_bytes >> 20,
                    total >> 20
                );
            }
            if let Some(c) = self.cells.remove(&v) {
                total -= c.bytes;
            }
            self.uploads.retain(|&(c, _, _)| c != v);
            self.shared
                .resident
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .remove(&v);
        }
    }
}

impl Drop for Streamer {
    fn drop(&mut self) {
        self.shared.stop.store(true, AtomicOrdering::SeqCst);
        self.shared.wake.notify_all();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn prefetch_loop(
    shared: Arc<Shared>,
    dir: PathBuf,
    base: Arc<BasePack>,
    index: Option<Arc<Index>>,
    tx: Sender<(u32, Result<Incoming, String>)>,
) {
    loop {
        let entry = {
            let mut q = shared.queue.lock().unwrap_or_else(|e| e.into_inner());
            loop {
                if shared.stop.load(AtomicOrdering::SeqCst) {
                    return;
                }
                let ts = shared.timestamp.load(AtomicOrdering::SeqCst);
                if let Some(e) = q.pop(ts) {
                    break e;
                }
                q = shared.wake.wait(q).unwrap_or_else(|e| e.into_inner());
            }
        };
        let resident = shared
            .resident
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .contains(&entry.cell);
        if resident {
            continue;
        }
        let tile = shared.tile.load(AtomicOrdering::Relaxed);
        let maker = shared
            .maker
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone();
        let result = load_cell(&dir, index.as_deref(), &base, entry.cell)
            .map(|mut cell| {
                if tile > 0 {
                    crate::bake::cluster_cell(&mut cell, tile);
                }
                // Its GPU objects made here, off the render thread, and its
                // atlases' clear texels handed to the GPU now.
                match &maker {
                    Some(m) => {
                        let built = Streamer::build(m, entry.cell, cell);
                        m.submit_writes();
                        Incoming::Built(Box::new(built))
                    }
                    None => Incoming::Prepared(cell),
                }
            })
            .map_err(|e| e.to_string());
        // On its way: not prepared again while it waits to be accepted (a frame
        // accepts one pack it does not draw yet, `Streamer::accept_arrived`; the
        // queue still holds older requests for it).
        shared
            .resident
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert(entry.cell);
        if tx.send((entry.cell, result)).is_err() {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eviction_spares_the_ring_and_what_is_drawn() {
        let ring: BTreeSet<u32> = [5, 6].into();
        // (key, last used): 5 and 6 prefetched early for the next crossing, 9
        // prefetched later for a cell farther on, 1 drawn now.
        let resident = || [(5, 10), (6, 11), (9, 20), (1, 3)].into_iter();
        assert_eq!(eviction_victim(resident(), &[1], &ring), Some(9));
        // Plain LRU would have taken 5: the case this rule is for.
        assert_eq!(eviction_victim(resident(), &[1], &BTreeSet::new()), Some(5));
        // Only the ring left: its least recently used.
        let only_ring = [(5, 10), (6, 11), (1, 3)].into_iter();
        assert_eq!(eviction_victim(only_ring, &[1], &ring), Some(5));
        assert_eq!(eviction_victim([(1, 3)].into_iter(), &[1], &ring), None);
    }

    #[test]
    fn queue_pops_highest_t_priority_and_drops_stale_entries() {
        let mut q = PrefetchQueue::default();
        q.push(0, 0.9, 1);
        q.push(3, 0.1, 2);
        q.push(3, 0.5, 3);
        q.push(1, 0.2, 4);
        // At timestamp 3: 3.5, 3.1, then 1.2 ≥ 1 kept, 0.9 < 1 dropped.
        assert_eq!(q.pop(3).map(|e| e.cell), Some(3));
        assert_eq!(q.pop(3).map(|e| e.cell), Some(2));
        assert_eq!(q.pop(3).map(|e| e.cell), Some(4));
        assert_eq!(q.pop(3), None);
        assert!(q.is_empty());
    }

    #[test]
    fn priority_prefers_cells_ahead_and_near() {
        let cam = Camera {
            eye: Vec3::new(0.0, 6.0, 0.0),
            dir: Vec3::new(1.0, 0.0, 0.0),
            fov_y_deg: 60.0,
            width: 64,
            height: 64,
            near: 0.5,
            far: 1000.0,
        };
        let prism = |x: f32, z: f32| Aabb {
            min: Vec3::new(x - 50.0, 6.0, z - 50.0),
            max: Vec3::new(x + 50.0, 12.0, z + 50.0),
        };
        let ahead = cell_priority(&cam, &prism(100.0, 0.0), 50.0);
        let behind = cell_priority(&cam, &prism(-100.0, 0.0), 50.0);
        let far_ahead = cell_priority(&cam, &prism(300.0, 0.0), 50.0);
        assert!(ahead > behind);
        assert!(ahead > far_ahead);
        for p in [ahead, behind, far_ahead] {
            assert!((0.0..1.0).contains(&p));
        }
    }
}
