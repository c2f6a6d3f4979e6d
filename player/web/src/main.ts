// hexbake's browser viewer (issue 33): streams a bake's packs over HTTP and draws
// them on WebGPU with the native player's WGSL (paper 000 §3.2 run-time rendering:
// the current cell's originals as geometry, its SV/MV proxies by projective
// texturing, the far field of its groups; format/README.md for the bytes).
//
// The shader is `/shader.wgsl` as `pipeline serve` serves it: the player's
// `player/src/shader.wgsl` after `format::shading::wgsl_constants()`, the same
// text `player::gpu::shader_source()` compiles. Pipelines, bind groups, vertex
// layouts, sampler and formats are those of player/src/gpu/setup.rs.
//
// URL parameters: `bake` (default `/bake/`), `pose=x,y,z,yaw,pitch` (degrees; y
// defaults to the bake's minimum eye height when empty), `size=WxH` (default
// 1024x768, the native `player view`'s), `path=URL` (a camera path .ron to walk),
// `budget=MiB` (texture bytes uploaded per frame, default 8), `prefetch=0|1`.

import { BaseStream } from "./base";
import {
  attachTextures,
  decodeCellRecords,
  decodeIndex,
  decodeTextureBundle,
  decodeVertices,
  packModels,
  proxyKinds,
  decodeTextureFile,
  NONE,
  PackError,
  PackFile,
  rgba8,
  texturePath,
  textureRefs,
  unframe,
} from "./pack";

/** Store textures kept decoded between cells (a crossing re-uses the neighbours'
 * shared captures); cleared whole past this many. */
const MAX_CACHED_TEXTURES = 4096;
/** Fewest missing textures for which a pack's bundle is fetched instead. */
const BUNDLE_MIN = 8;
const textureCache = new Map<string, Promise<Uint8Array>>();
import type { Base, CellPack, Index, IndexEntry } from "./pack";
import {
  clipFromWorld,
  groundVertices,
  GLOBALS,
  HexGrid,
  INSTANCE_RAW,
  MODEL_VERTEX,
  modelVertices,
  PROXY_SLOTS,
  PROXY_UNIFORM,
  PROXY_VERTEX,
  proxyVertexCount,
  proxyVertices,
  writeInstance,
  dir,
} from "./scene";
import type { Camera } from "./scene";
import { parsePath, walkPose } from "./path";
import type { CameraPath } from "./path";

const SKY = [150, 190, 235];
const MAX_VIEWS = 8;

interface Stats {
  ready: boolean;
  error: string | null;
  frames: number;
  fps: number;
  frameMs: number;
  triangles: number;
  cell: number | null;
  resident: number;
  fetched: number; // bytes downloaded so far
  requests: number;
  firstFrameMs: number | null; // page load → first frame drawing the current cell's pack
  firstFrameBytes: number | null;
  queuedUploads: number;
  pose: number[];
  settled: boolean; // the current cell and its far field are drawn from their packs, every texture uploaded
  walkDone: boolean;
  cellsVisited: number[];
  phases: Record<string, number>; // ms since navigation start: where a cold start goes
  // Frames after the first settled one that drew a stand-in (the last cell's packs)
  // because the current cell's were not in yet, and frames that drew a proxy's
  // members as originals while its textures waited.
  standInFrames: number;
  pendingFrames: number;
  // Per frame drawn during a ?path= walk (which starts once the first frame is
  // drawn): [the camera's cell, the cell whose pack was drawn (-1: none), its far
  // field drawn from its packs (1/0), proxies waiting for textures].
  walkLog: number[][];
}

const stats: Stats = {
  ready: false,
  error: null,
  frames: 0,
  fps: 0,
  frameMs: 0,
  triangles: 0,
  cell: null,
  resident: 0,
  fetched: 0,
  requests: 0,
  firstFrameMs: null,
  firstFrameBytes: null,
  queuedUploads: 0,
  pose: [],
  settled: false,
  walkDone: false,
  cellsVisited: [],
  phases: {},
  standInFrames: 0,
  pendingFrames: 0,
  walkLog: [],
};
const mark = (name: string) => (stats.phases[name] ??= Math.round(performance.now()));
(window as any).hexbake = { stats, setPose: (p: number[]) => setPose(p) };

const overlay = document.getElementById("overlay") as HTMLPreElement;
function fail(msg: string) {
  console.error(msg);
  if (stats.error) return; // the first error is the cause
  stats.error = msg;
  overlay.textContent = `error: ${msg}`;
  overlay.classList.add("error");
  console.error(msg);
}

async function fetchBytes(url: string): Promise<Uint8Array> {
  return (await fetchRange(url)).bytes;
}

/** Whether the server derives `<pack>.vertices` and `<pack>.textures` (`pipeline
 * serve`, or a static folder `pipeline web-export` wrote them into): until one
 * answers 404, after which the viewer reads base.pack ranges and single store files. */
let derivedFiles = true;

/** A derived file of a pack, or `null` when the server has none (404). */
async function fetchDerived(url: string): Promise<Uint8Array | null> {
  if (!derivedFiles) return null;
  const r = await respond(url);
  if (r.status === 404) {
    stats.requests++;
    derivedFiles = false;
    return null;
  }
  if (!r.ok) throw new PackError(`${url}: HTTP ${r.status} ${r.statusText}`);
  return unframe(url, await body(r));
}

/** The response to `url` (a request already `asked`, e.g. by index.html, or a new
 * one with `init`); a network failure is a PackError naming the URL. */
async function respond(url: string, init?: RequestInit, asked?: Promise<Response | Error>): Promise<Response> {
  try {
    const got = await (asked ?? fetch(url, init));
    if (got instanceof Error) throw got;
    return got;
  } catch (e) {
    throw new PackError(`${url}: ${e}`);
  }
}

/** A response's body, counted in `stats`: the bytes that crossed the network
 * (`Content-Length` when the server sent the body encoded, `Content-Encoding: zstd`,
 * which the browser decodes) and one request. */
async function body(r: Response): Promise<Uint8Array> {
  const b = new Uint8Array(await r.arrayBuffer());
  const sent = Number(r.headers.get("content-length"));
  stats.fetched += r.headers.get("content-encoding") && Number.isFinite(sent) && sent > 0 ? sent : b.length;
  stats.requests++;
  return b;
}

/** `url`, or its bytes `start..end` (end exclusive) by a `Range` request: `partial`
 * when the server answered 206 with them, not 200 with the whole file. */
async function fetchRange(url: string, start?: number, end?: number, asked?: Promise<Response | Error>): Promise<{ bytes: Uint8Array; partial: boolean }> {
  const ranged = start !== undefined && end !== undefined;
  const r = await respond(url, ranged ? { headers: { Range: `bytes=${start}-${end - 1}` } } : undefined, asked);
  if (!r.ok) throw new PackError(`${url}${ranged ? ` bytes ${start}-${end - 1}` : ""}: HTTP ${r.status} ${r.statusText}`);
  return { bytes: await body(r), partial: r.status === 206 };
}

// ---- GPU state ----

interface GpuProxy {
  vbuf: GPUBuffer;
  count: number;
  bind: GPUBindGroup | null;
  uniform: GPUBuffer;
  textures: (GPUTexture | null)[];
  slots: number; // index into the mesh pipelines (views - 1)
  layered: boolean;
  members: number[];
  texBytes: number;
  min: number[];
  max: number[];
}

interface Resident {
  key: string;
  entry: IndexEntry;
  state: "loading" | "ready" | "error";
  pack?: CellPack;
  proxies: GpuProxy[];
  lastUsed: number;
  bytes: number;
}

let device: GPUDevice;
let ctx: GPUCanvasContext;
let readback = false;
let ctx2d: CanvasRenderingContext2D;
let colourTex: GPUTexture;
let readBuf: GPUBuffer;
let rowBytes = 0;
let base: Base;
let baseStream: BaseStream;
let index: Index;
let grid: HexGrid;
let bakeUrl = "/bake/";
let pipes: {
  lit: GPURenderPipeline;
  ground: GPURenderPipeline;
  /** Proxy pipelines by `proxySlot`, compiled on first use (`proxyPipe`). */
  proxies: (GPURenderPipeline | Promise<void> | undefined)[];
  compileProxy: (slot: number) => Promise<GPURenderPipeline>;
  g0: GPUBindGroupLayout;
  g1: GPUBindGroupLayout;
  g2: GPUBindGroupLayout;
};
let globalsBuf: GPUBuffer;
let globalsBg: GPUBindGroup;
let whiteBg: GPUBindGroup;
let sampler: GPUSampler;
let dummyView: GPUTextureView;
let depthTex: GPUTexture;
let groundBuf: GPUBuffer;
let instBuf: GPUBuffer;
/** Models' GPU buffers, made once base.pack's ranges for them are in. */
let models: ({ vbuf: GPUBuffer; ibuf: GPUBuffer; indexCount: number; tris: number; albedo: GPUBindGroup } | undefined)[] = [];
const albedoGroups: GPUBindGroup[] = [];
const resident = new Map<string, Resident>();
const uploads: { res: Resident; proxy: GpuProxy; view: number; w: number; h: number; enc: number; data: Uint8Array }[] = [];
let uploadBudget = 8 << 20;
let prefetch = true;
const MAX_RESIDENT = 40;
const MAX_INFLIGHT = 4;
let inflight = 0;

const cam: Camera = { eye: [0, 0, 0], yaw: 0, pitch: 0, fovYDeg: 60, width: 1024, height: 768, near: 0.25, far: 1000 };

function setPose(p: number[]) {
  const [x, y, z, yaw, pitch] = p;
  cam.eye = [x, Number.isFinite(y) ? y : base.grid.minEye, z];
  cam.yaw = ((yaw ?? 0) * Math.PI) / 180;
  cam.pitch = Math.max(-1.4, Math.min(1.4, ((pitch ?? 0) * Math.PI) / 180));
}

function buffer(data: ArrayBuffer | ArrayBufferView, usage: number): GPUBuffer {
  const bytes = data instanceof ArrayBuffer ? new Uint8Array(data) : new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
  const b = device.createBuffer({ size: Math.max(4, (bytes.length + 3) & ~3), usage, mappedAtCreation: true });
  new Uint8Array(b.getMappedRange()).set(bytes);
  b.unmap();
  return b;
}

/** Reads the index and base table, sets the pose (`?pose=`, `?path=`), and starts
 * the start cell's packs with their derived files (`load`, cold). */
async function openScene(q: URLSearchParams, asked?: { index: Promise<Response | Error> }) {
  // The index first, then the base pack it names (format 7, issue 32: a rebake on the
  // server never mixes two generations in one session), by range: its table and
  // small sections now, the models' vertices as the packs drawn need them (src/base.ts).
  index = decodeIndex(new PackFile("index.pack", (await fetchRange(bakeUrl + "index.pack", undefined, undefined, asked?.index)).bytes));
  baseStream = await BaseStream.open(bakeUrl + index.baseFile, fetchRange);
  base = baseStream.base;
  grid = new HexGrid(base.grid);
  mark("base table decoded");
  const g = base.grid;
  const diag = Math.hypot(g.groundMax[0] - g.groundMin[0], Math.max(g.maxEye, 1), g.groundMax[1] - g.groundMin[1]);
  cam.far = diag * 2 + 100; // Bake::extent (the scene's diagonal is within the ground's for parks)
  setPose([0.5 * (g.groundMin[0] + g.groundMax[0]), g.minEye, 0.5 * (g.groundMin[1] + g.groundMax[1]), 0, 0]);
  const pose = q.get("pose");
  if (pose) {
    const p = pose.split(",").map((s) => (s.trim() === "" ? NaN : Number(s)));
    if (p.length !== 5 || [0, 2, 3, 4].some((i) => !Number.isFinite(p[i]))) throw new Error(`bad pose ${JSON.stringify(pose)} (x,y,z,yaw,pitch)`);
    setPose(p);
  }
  const pathUrl = q.get("path");
  if (pathUrl) {
    const r = await fetch(pathUrl);
    if (!r.ok) throw new Error(`${pathUrl}: HTTP ${r.status}`);
    walk = parsePath(await r.text());
    walkStart = null;
    const p0 = walkPose(walk, 0);
    cam.eye = p0.eye;
    cam.yaw = p0.yaw;
  }

  // The start cell's packs are fetched while the pipelines compile.
  const start = grid.cellAt(cam.eye[0], cam.eye[2]);
  if (start !== null)
    for (const w of chain(start)) {
      const p = load(w.key, w.entry, true);
      p.catch(() => {}); // reported when request() takes it
      early.set(w.key, p);
    }
}

async function init() {
  const q = new URLSearchParams(location.search);
  bakeUrl = q.get("bake") ?? "/bake/";
  if (!bakeUrl.endsWith("/")) bakeUrl += "/";
  const size = (q.get("size") ?? "1024x768").split("x").map(Number);
  if (size.length === 2 && size.every((v) => v >= 1 && v <= 8192)) [cam.width, cam.height] = size;
  uploadBudget = Number(q.get("budget") ?? 8) * (1 << 20);
  prefetch = q.get("prefetch") !== "0";

  // The index and shader requests index.html started, for this ?bake=.
  const asked: { index: Promise<Response | Error>; shader: Promise<Response | Error> } | undefined =
    (window as any).hexbakeEarly?.bake === bakeUrl ? (window as any).hexbakeEarly : undefined;
  // The scene (index, base table, pose, the start cell's packs) is fetched while
  // the browser starts its GPU process and device: none of it needs the device.
  const sceneReady = openScene(q, asked);
  sceneReady.catch(() => {}); // awaited below

  if (!navigator.gpu) throw new Error("this browser has no WebGPU (navigator.gpu missing)");
  const adapter = await navigator.gpu.requestAdapter();
  if (!adapter) throw new Error("no WebGPU adapter");
  const hasBc = adapter.features.has("texture-compression-bc");
  if (!hasBc) throw new Error("the WebGPU adapter lacks texture-compression-bc (the packs' BC1/BC3 captures)");
  device = await adapter.requestDevice({ requiredFeatures: ["texture-compression-bc"] });
  device.lost.then((i) => fail(`WebGPU device lost (${i.reason}): ${i.message}`));
  device.onuncapturederror = (e) => fail(`WebGPU: ${e.error.message}`);

  const canvas = document.getElementById("view") as HTMLCanvasElement;
  canvas.width = cam.width;
  canvas.height = cam.height;
  // Headless Chromium on SwiftShader destroys the device as soon as a WebGPU canvas
  // is configured (measured with Chromium 148 here), so under automation (or with
  // ?readback=1) frames are drawn into a texture and copied to a 2D canvas.
  readback = q.get("readback") === "1" || (navigator.webdriver && q.get("readback") !== "0");
  if (readback) {
    ctx2d = canvas.getContext("2d") as CanvasRenderingContext2D;
    colourTex = device.createTexture({
      size: [cam.width, cam.height],
      format: "rgba8unorm-srgb",
      usage: GPUTextureUsage.RENDER_ATTACHMENT | GPUTextureUsage.COPY_SRC,
    });
    rowBytes = Math.ceil((cam.width * 4) / 256) * 256;
    readBuf = device.createBuffer({ size: rowBytes * cam.height, usage: GPUBufferUsage.MAP_READ | GPUBufferUsage.COPY_DST });
  } else {
    ctx = canvas.getContext("webgpu") as GPUCanvasContext;
    ctx.configure({ device, format: "rgba8unorm", viewFormats: ["rgba8unorm-srgb"], alphaMode: "opaque" });
  }

  // The pipelines compile (in the GPU process) while the packs download and decode:
  // on SwiftShader their compilation is the largest part of a cold start.
  const pipelinesReady = (asked?.shader ?? fetch("/shader.wgsl"))
    .then((r) => {
      if (r instanceof Error) throw r;
      if (!r.ok) throw new Error(`/shader.wgsl: HTTP ${r.status}`);
      return r.text();
    })
    .then(async (shaderText) => {
      const module = device.createShaderModule({ code: shaderText });
      const info = await module.getCompilationInfo();
      const errs = info.messages.filter((m) => m.type === "error");
      if (errs.length) throw new Error(`shader.wgsl: ${errs.map((m) => `${m.lineNum}:${m.linePos} ${m.message}`).join("; ")}`);
      mark("shader compiled");
      await makePipelines(module);
      mark("pipelines");
    });
  pipelinesReady.catch(() => {}); // awaited below; no unhandled rejection meanwhile
  await sceneReady;
  await pipelinesReady;

  models = base.models.map(() => undefined);
  groundBuf = buffer(groundVertices(base.grid), GPUBufferUsage.VERTEX);
  instanceBounds = base.instances.map(() => undefined);
  instBuf = device.createBuffer({ size: INSTANCE_RAW * (base.instances.length + 1), usage: GPUBufferUsage.VERTEX | GPUBufferUsage.COPY_DST });
  depthTex = device.createTexture({ size: [cam.width, cam.height], format: "depth32float", usage: GPUTextureUsage.RENDER_ATTACHMENT });
  mark("models uploaded");

  stats.ready = true;
  installControls(canvas);
  requestAnimationFrame(frame);
}

async function makePipelines(module: GPUShaderModule) {
  const VF = GPUShaderStage.VERTEX | GPUShaderStage.FRAGMENT;
  const g0 = device.createBindGroupLayout({ entries: [{ binding: 0, visibility: VF, buffer: { type: "uniform" } }] });
  const g1Entries: GPUBindGroupLayoutEntry[] = [
    { binding: 0, visibility: VF, buffer: { type: "uniform" } },
    { binding: 1, visibility: GPUShaderStage.FRAGMENT, sampler: { type: "filtering" } },
  ];
  for (let i = 0; i < MAX_VIEWS; i++) g1Entries.push({ binding: 2 + i, visibility: GPUShaderStage.FRAGMENT, texture: { sampleType: "float" } });
  const g1 = device.createBindGroupLayout({ entries: g1Entries });
  const g2 = device.createBindGroupLayout({
    entries: [
      { binding: 0, visibility: GPUShaderStage.FRAGMENT, texture: { sampleType: "float" } },
      { binding: 1, visibility: GPUShaderStage.FRAGMENT, sampler: { type: "filtering" } },
    ],
  });
  const empty = device.createBindGroupLayout({ entries: [] });
  const litLayout = device.createPipelineLayout({ bindGroupLayouts: [g0, empty, g2] });
  const proxyLayout = device.createPipelineLayout({ bindGroupLayouts: [g0, g1] });
  const f = (i: number, format: GPUVertexFormat, offset: number): GPUVertexAttribute => ({ shaderLocation: i, format, offset });
  const litBuffers: GPUVertexBufferLayout[] = [
    { arrayStride: MODEL_VERTEX, stepMode: "vertex", attributes: [f(0, "float32x3", 0), f(1, "float32x3", 12), f(2, "unorm8x4", 24), f(11, "float32x2", 28)] },
    {
      arrayStride: INSTANCE_RAW,
      stepMode: "instance",
      attributes: [3, 4, 5, 6, 7, 8, 9, 10].map((loc, k) => f(loc, "float32x4", 16 * k)),
    },
  ];
  const proxyBuffers: GPUVertexBufferLayout[] = [
    {
      arrayStride: PROXY_VERTEX,
      stepMode: "vertex",
      attributes: [
        f(0, "float32x3", 0),
        f(1, "float32x3", 12),
        f(2, "unorm8x4", 24),
        f(3, "float32x3", 28),
        f(4, "uint32", 40),
        f(5, "float32x3", 44),
        f(6, "uint32", 56),
      ],
    },
  ];
  const pipe = (layout: GPUPipelineLayout, vs: string, fs: string, buffers: GPUVertexBufferLayout[], constants?: Record<string, number>) =>
    device.createRenderPipelineAsync({
      layout,
      vertex: { module, entryPoint: vs, buffers },
      primitive: { topology: "triangle-list", frontFace: "ccw", cullMode: "back" },
      depthStencil: { format: "depth32float", depthWriteEnabled: true, depthCompare: "less" },
      fragment: { module, entryPoint: fs, targets: [{ format: "rgba8unorm-srgb" }], constants },
    });
  // The two pipelines every frame uses now; the proxy pipelines (one for layered
  // impostors, one per view count of mesh proxies) when a pack's proxy first needs
  // one (`proxyPipe`), the rest after the first frame. On SwiftShader compiling all
  // ten at once took 0.7–1.7 s of a cold start; a first cell uses two to four.
  const [lit, ground] = await Promise.all([pipe(litLayout, "vs_lit", "fs_lit", litBuffers), pipe(litLayout, "vs_lit", "fs_ground", litBuffers)]);
  pipes = {
    lit,
    ground,
    proxies: new Array(MAX_VIEWS + 1).fill(undefined),
    compileProxy: (slot) =>
      slot === 0
        ? pipe(proxyLayout, "vs_proxy", "fs_proxy", proxyBuffers)
        : pipe(proxyLayout, "vs_proxy_mesh", "fs_proxy_mesh", proxyBuffers, { VIEW_SLOTS: slot }),
    g0,
    g1,
    g2,
  };
  for (const slot of earlySlots) proxyPipe(slot);
  globalsBuf = device.createBuffer({ size: GLOBALS, usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST });
  globalsBg = device.createBindGroup({ layout: g0, entries: [{ binding: 0, resource: { buffer: globalsBuf } }] });
  sampler = device.createSampler({ addressModeU: "clamp-to-edge", addressModeV: "clamp-to-edge", magFilter: "linear", minFilter: "linear" });
  const tex1 = (rgba: number[]) => {
    const t = device.createTexture({ size: [1, 1], format: "rgba8unorm-srgb", usage: GPUTextureUsage.TEXTURE_BINDING | GPUTextureUsage.COPY_DST });
    device.queue.writeTexture({ texture: t }, new Uint8Array(rgba), { bytesPerRow: 4 }, [1, 1]);
    return t;
  };
  dummyView = tex1([0, 0, 0, 0]).createView();
  const albedoSampler = device.createSampler({ addressModeU: "repeat", addressModeV: "repeat", magFilter: "linear", minFilter: "linear" });
  whiteBg = device.createBindGroup({
    layout: g2,
    entries: [
      { binding: 0, resource: tex1([255, 255, 255, 255]).createView() },
      { binding: 1, resource: albedoSampler },
    ],
  });
}

const earlySlots = new Set<number>();

/** The pipeline slot of a proxy: 0 for a layered impostor, else its view count
 * (1 to MAX_VIEWS; a proxy without views uses the one-view pipeline). */
function slotOf(layered: boolean, views: number): number {
  return layered ? 0 : Math.max(1, Math.min(views, MAX_VIEWS));
}

/** A GPU proxy's pipeline slot (`slotOf`; `slots` is its view count − 1). */
function proxySlot(p: GpuProxy): number {
  return slotOf(p.layered, p.slots + 1);
}

/** The pipeline of proxy slot `slot`, or `undefined` while it compiles (asked for
 * here the first time; a proxy waiting for it draws as its pack's stand-in would). */
function proxyPipe(slot: number): GPURenderPipeline | undefined {
  if (!pipes) {
    earlySlots.add(slot); // asked for before the layouts exist: compiled with them
    return undefined;
  }
  const have = pipes.proxies[slot];
  if (have instanceof GPURenderPipeline) return have;
  if (!have)
    pipes.proxies[slot] = pipes
      .compileProxy(slot)
      .then((pl) => {
        pipes.proxies[slot] = pl;
        mark(`proxy pipeline ${slot}`);
      })
      .catch((e) => fail(`compiling proxy pipeline ${slot}: ${e?.message ?? e}`));
  return undefined;
}

/** A textured model's group 2: its albedo texture (sRGB, no mipmaps) and a bilinear
 * sampler with its glTF wrap modes (player/src/gpu.rs `albedo_bind_group`). */
function albedoGroup(t: Base["textures"][number]): GPUBindGroup {
  const tex = device.createTexture({ size: [t.width, t.height], format: "rgba8unorm-srgb", usage: GPUTextureUsage.TEXTURE_BINDING | GPUTextureUsage.COPY_DST });
  device.queue.writeTexture({ texture: tex }, t.rgba, { bytesPerRow: 4 * t.width }, [t.width, t.height]);
  const mode = (w: number): GPUAddressMode => (w === 0 ? "repeat" : w === 1 ? "mirror-repeat" : "clamp-to-edge");
  const samp = device.createSampler({ addressModeU: mode(t.wrap[0]), addressModeV: mode(t.wrap[1]), magFilter: "linear", minFilter: "linear" });
  return device.createBindGroup({
    layout: pipes.g2,
    entries: [
      { binding: 0, resource: tex.createView() },
      { binding: 1, resource: samp },
    ],
  });
}

// ---- frustum culling (player/src/camera.rs Frustum; conservative, so the image is
// the same with or without it) ----

let instanceBounds: ({ min: number[]; max: number[] } | undefined)[] = [];

/** Model `m`'s GPU buffers, or `undefined` while base.pack's ranges for it are out
 * (a pack's originals are fetched with the pack; the rest after the first frame). */
function gpuModel(m: number) {
  const have = models[m];
  if (have) return have;
  if (!baseStream.ready(m, true)) return undefined;
  const model = base.models[m];
  return (models[m] = {
    vbuf: buffer(modelVertices(model), GPUBufferUsage.VERTEX),
    ibuf: buffer(model.triangles, GPUBufferUsage.INDEX),
    indexCount: model.triangles.length,
    tris: model.triangleCount,
    albedo: model.texture !== null ? (albedoGroups[model.texture] ??= albedoGroup(base.textures[model.texture])) : whiteBg,
  });
}

/** Instance `i`'s world bounds (its model's vertices must be in). */
function bounds(i: number) {
  return (instanceBounds[i] ??= (() => {
    const inst = base.instances[i];
    const m = base.models[inst.model];
    const lo = [Infinity, Infinity, Infinity];
    const hi = [-Infinity, -Infinity, -Infinity];
    for (let v = 0; v < m.vertexCount; v++)
      for (let k = 0; k < 3; k++) {
        lo[k] = Math.min(lo[k], m.positions[3 * v + k]);
        hi[k] = Math.max(hi[k], m.positions[3 * v + k]);
      }
    return transformBox(lo, hi, inst.transform);
  })());
}

function transformBox(lo: number[], hi: number[], t: ArrayLike<number>) {
  const min = [Infinity, Infinity, Infinity];
  const max = [-Infinity, -Infinity, -Infinity];
  if (!(lo[0] <= hi[0])) return { min, max };
  for (let i = 0; i < 8; i++) {
    const p = [i & 1 ? hi[0] : lo[0], i & 2 ? hi[1] : lo[1], i & 4 ? hi[2] : lo[2]];
    for (let k = 0; k < 3; k++) {
      const w = t[k] * p[0] + t[4 + k] * p[1] + t[8 + k] * p[2] + t[12 + k];
      min[k] = Math.min(min[k], w);
      max[k] = Math.max(max[k], w);
    }
  }
  return { min, max };
}

/** The six planes (a, b, c, d: a·x + b·y + c·z + d ≥ 0 inside) of a wgpu clip matrix. */
function planes(m: Float64Array): number[][] {
  const row = (r: number) => [m[r], m[4 + r], m[8 + r], m[12 + r]];
  const [r0, r1, r2, r3] = [row(0), row(1), row(2), row(3)];
  const add = (a: number[], b: number[], s: number) => a.map((v, i) => v + s * b[i]);
  return [add(r3, r0, 1), add(r3, r0, -1), add(r3, r1, 1), add(r3, r1, -1), r2, add(r3, r2, -1)];
}

function inside(ps: number[][], b: { min: number[]; max: number[] }): boolean {
  if (!(b.min[0] <= b.max[0])) return false;
  for (const p of ps) {
    const x = p[0] >= 0 ? b.max[0] : b.min[0];
    const y = p[1] >= 0 ? b.max[1] : b.min[1];
    const z = p[2] >= 0 ? b.max[2] : b.min[2];
    if (p[0] * x + p[1] * y + p[2] * z + p[3] < 0) return false;
  }
  return true;
}

// ---- streaming ----

const early = new Map<string, Promise<Loaded>>();
const keyOf = (kind: "c" | "g", id: number) => `${kind}${id}`;

/** The packs a cell draws: itself, then its far-field group and each parent. */
function chain(cell: number): { key: string; entry: IndexEntry }[] {
  const e = index.cells.get(cell);
  if (!e) return [];
  const out = [{ key: keyOf("c", cell), entry: e }];
  let g = e.group;
  const seen = new Set<number>();
  while (g !== NONE && !seen.has(g)) {
    seen.add(g);
    const ge = index.groups.get(g);
    if (!ge) break;
    out.push({ key: keyOf("g", g), entry: ge });
    g = ge.group;
  }
  return out;
}

/** A version-6 pack's textures from the bake's store (format/README.md
 * "textures/"), concatenated in view order; `undefined` for inline packs. A texture
 * shared by neighbouring cells is fetched once while it is cached here. */
async function storeTextures(file: PackFile, url: string, asked?: Promise<Uint8Array | null>): Promise<Uint8Array | undefined> {
  const refs = textureRefs(file);
  if (refs === null) return undefined;
  // Most of them missing (a cold start, a jump): the pack's bundle in one request
  // (each request costs ≈ 5 ms in headless Chromium here; a bundle re-sends the
  // textures already cached, so only when at least 9 in 10 are missing). `asked`:
  // the bundle, already requested.
  const missing = new Set(refs.filter((r) => !textureCache.has(r)));
  if (asked || (missing.size >= BUNDLE_MIN && 10 * missing.size >= 9 * new Set(refs).size)) {
    const bundle = await (asked ?? fetchDerived(url + ".textures"));
    if (bundle)
      for (const { ref, data } of decodeTextureBundle(url + ".textures", bundle))
        if (!textureCache.has(ref)) textureCache.set(ref, Promise.resolve(data));
  }
  const parts = await Promise.all(
    refs.map((r) => {
      let t = textureCache.get(r);
      if (!t) {
        const path = texturePath(r);
        t = fetchBytes(bakeUrl + path).then((b) => decodeTextureFile(path, b));
        textureCache.set(r, t);
        t.catch(() => textureCache.delete(r));
      }
      return t;
    }),
  );
  const out = new Uint8Array(parts.reduce((n, p) => n + p.length, 0));
  let o = 0;
  for (const p of parts) {
    out.set(p, o);
    o += p.length;
  }
  if (textureCache.size > MAX_CACHED_TEXTURES) textureCache.clear();
  return out;
}

interface Loaded {
  /** Decoded but for its views' texture bytes, which `textures` attaches. */
  pack: CellPack;
  bytes: number;
  textures: Promise<void>;
}

/** Fetches and decodes a cell or group pack with what it draws with: its store
 * textures and the base.pack ranges of its models (its proxies' members' vertices,
 * its originals' whole models), those two at once. Resolves once the pack's records
 * are decoded and its models are in, so that its proxies' vertices are built while
 * its textures still download. */
async function load(key: string, entry: IndexEntry, cold = false): Promise<Loaded> {
  const url = bakeUrl + entry.file;
  // A cold start lacks every texture and vertex: the pack's derived files are
  // asked for with it, not after it (one round trip instead of two).
  const early = cold ? { vertices: fetchDerived(url + ".vertices"), textures: fetchDerived(url + ".textures") } : undefined;
  early?.vertices.catch(() => {}); // awaited below
  early?.textures.catch(() => {});
  const bytes = await fetchBytes(url);
  mark(`${key} fetched`);
  const file = new PackFile(entry.file, bytes);
  // Its proxies' pipelines compile while its textures and vertices download.
  for (const { kind, views } of proxyKinds(file)) proxyPipe(slotOf(kind === 4, views));
  const { vertices, full } = packModels(file, base);
  const tex = storeTextures(file, url, early?.textures).then((t) => (mark(`${key} textures fetched`), t));
  tex.catch(() => {}); // awaited below
  // Models the pack draws whole (its originals) bring their vertices anyway.
  const models = fetchProxyVertices(url, new Set([...vertices].filter((m) => !full.has(m))), early?.vertices)
    .then(() => baseStream.ensure([], full))
    .then(() => mark(`${key} models fetched`));
  models.catch(() => {});
  const pack = decodeCellRecords(file, base);
  if (pack.id !== entry.id) throw new PackError(`${entry.file}: holds cell ${pack.id}, index.pack lists ${entry.id}`);
  mark(`${key} decoded`);
  await models;
  return { pack, bytes: bytes.length, textures: tex.then((t) => attachTextures(file, pack, t)) };
}

/** The vertices of models `vertices` that a pack's proxies use: its `.vertices`
 * file when the server has one, else those models' whole base.pack ranges. */
async function fetchProxyVertices(url: string, vertices: Set<number>, asked?: Promise<Uint8Array | null>) {
  if ([...vertices].every((m) => baseStream.ready(m))) return;
  const b = await (asked ?? fetchDerived(url + ".vertices"));
  if (!b) return baseStream.ensure(vertices);
  baseStream.scatter(decodeVertices(url + ".vertices", b), url + ".vertices");
  // Rent or buy: once the subsets fetched cost as much as the models' vertices
  // would, fetch those whole in the background (at most twice the bytes of the
  // better choice made in hindsight, on a short visit or a long walk; a world
  // whose models are large keeps renting).
  rentBytes += b.length; // decoded bytes: a little above what crossed the network
  if (!boughtVertices && rentBytes >= baseVertexBytes()) {
    boughtVertices = true;
    baseStream.ensure(base.models.map((_, m) => m)).catch((e) => fail(`${e.message ?? e}`));
  }
}

let rentBytes = 0;
let boughtVertices = false;

/** Bytes of all models' positions, normals and colours in base.pack. */
function baseVertexBytes(): number {
  return 28 * base.models.reduce((n, m) => n + m.vertexCount, 0);
}

function request(key: string, entry: IndexEntry, priority: boolean) {
  const r = resident.get(key);
  if (r) {
    r.lastUsed = stats.frames;
    return;
  }
  if (!priority && inflight >= MAX_INFLIGHT) return;
  const res: Resident = { key, entry, state: "loading", proxies: [], lastUsed: stats.frames, bytes: 0 };
  resident.set(key, res);
  inflight++;
  const loading = early.get(key) ?? load(key, entry);
  early.delete(key);
  loading
    .then(async ({ pack, bytes, textures }) => {
      // Vertex buffers first, while the textures are still on their way.
      const proxies = pack.proxies.map((p) => makeProxy(p));
      await textures.catch((e) => {
        for (const p of proxies) [p.vbuf, p.uniform].forEach((b) => b.destroy());
        throw e;
      });
      res.pack = pack;
      res.bytes = bytes;
      res.proxies = proxies;
      proxies.forEach((gp, i) => queueUploads(res, gp, pack.proxies[i]));
      res.state = "ready";
      mark(`first pack decoded`);
      mark(`${key} proxies built`);
    })
    .catch((e) => {
      res.state = "error";
      fail(`${e.message ?? e}`);
    })
    .finally(() => inflight--);
}

/** A proxy's vertex buffer and view uniforms; its textures follow (`queueUploads`). */
function makeProxy(p: CellPack["proxies"][number]): GpuProxy {
  // Written straight into the vertex buffer, mapped at creation.
  const vbuf = device.createBuffer({ size: Math.max(1, proxyVertexCount(p)) * PROXY_VERTEX, usage: GPUBufferUsage.VERTEX, mappedAtCreation: true });
  const v = proxyVertices(base, p, vbuf.getMappedRange());
  vbuf.unmap();
  const u = new ArrayBuffer(PROXY_UNIFORM);
  const dv = new DataView(u);
  const n = Math.min(p.views.length, MAX_VIEWS);
  let premult = 0;
  p.views.slice(0, n).forEach((view, i) => {
    for (let k = 0; k < 16; k++) dv.setFloat32(64 * i + 4 * k, view.matrix[k], true);
    for (let k = 0; k < 3; k++) dv.setFloat32(64 * PROXY_SLOTS + 16 * i + 4 * k, view.eye[k], true);
    dv.setFloat32(64 * PROXY_SLOTS + 16 * i + 12, 1, true);
    if (view.encoding === 2) premult |= 1 << i;
  });
  dv.setUint32(80 * PROXY_SLOTS, n, true);
  dv.setUint32(80 * PROXY_SLOTS + 4, premult, true);
  const gp: GpuProxy = {
    vbuf,
    count: v.count,
    bind: null,
    uniform: buffer(u, GPUBufferUsage.UNIFORM),
    textures: new Array(n).fill(null),
    slots: Math.max(0, n - 1),
    layered: p.kind === 4,
    members: p.members.map((m) => m.instance),
    texBytes: 0,
    min: v.min,
    max: v.max,
  };
  proxyPipe(proxySlot(gp));
  return gp;
}

/** Queues a proxy's view textures for upload (`runUploads`), once they are in. */
function queueUploads(res: Resident, gp: GpuProxy, p: CellPack["proxies"][number]) {
  p.views.slice(0, gp.textures.length).forEach((view, i) =>
    uploads.push({ res, proxy: gp, view: i, w: view.width, h: view.height, enc: view.encoding, data: view.encoding <= 1 ? rgba8(view) : view.data }),
  );
  tryBind(gp);
}

function tryBind(p: GpuProxy) {
  if (p.bind || p.textures.some((t) => t === null)) return;
  const entries: GPUBindGroupEntry[] = [
    { binding: 0, resource: { buffer: p.uniform } },
    { binding: 1, resource: sampler },
  ];
  for (let i = 0; i < MAX_VIEWS; i++) entries.push({ binding: 2 + i, resource: p.textures[i]?.createView() ?? dummyView });
  p.bind = device.createBindGroup({ layout: pipes.g1, entries });
}

/** Uploads queued capture textures, at most `uploadBudget` bytes per frame. */
function runUploads() {
  let spent = 0;
  while (uploads.length && (spent === 0 || spent + uploads[0].data.length <= uploadBudget)) {
    const u = uploads.shift()!;
    if (!resident.has(u.res.key)) continue; // evicted meanwhile
    const format: GPUTextureFormat = u.enc === 2 ? "bc1-rgba-unorm-srgb" : u.enc === 3 ? "bc3-rgba-unorm-srgb" : "rgba8unorm-srgb";
    const t = device.createTexture({ size: [u.w, u.h], format, usage: GPUTextureUsage.TEXTURE_BINDING | GPUTextureUsage.COPY_DST });
    const bytesPerRow = u.enc === 2 ? (u.w / 4) * 8 : u.enc === 3 ? (u.w / 4) * 16 : u.w * 4;
    device.queue.writeTexture({ texture: t }, u.data, { bytesPerRow }, [u.w, u.h]);
    u.proxy.textures[u.view] = t;
    u.proxy.texBytes += u.data.length;
    tryBind(u.proxy);
    spent += u.data.length;
  }
  stats.queuedUploads = uploads.length;
}

function evict(keep: Set<string>) {
  if (resident.size <= MAX_RESIDENT) return;
  const old = [...resident.values()].filter((r) => !keep.has(r.key) && r.state !== "loading").sort((a, b) => a.lastUsed - b.lastUsed);
  for (const r of old.slice(0, resident.size - MAX_RESIDENT)) {
    for (const p of r.proxies) {
      p.vbuf.destroy();
      p.uniform.destroy();
      p.textures.forEach((t) => t?.destroy());
    }
    resident.delete(r.key);
  }
}

// ---- frame ----

let last = performance.now();
let walk: CameraPath | null = null;
let walkStart: number | null = null;
const keys = new Set<string>();
let shownChain: string[] = [];

async function present() {
  await readBuf.mapAsync(GPUMapMode.READ);
  const src = new Uint8Array(readBuf.getMappedRange());
  const img = new ImageData(cam.width, cam.height);
  for (let y = 0; y < cam.height; y++) img.data.set(src.subarray(y * rowBytes, y * rowBytes + cam.width * 4), y * cam.width * 4);
  readBuf.unmap();
  ctx2d.putImageData(img, 0, 0);
}

async function frame(now: number) {
  if (stats.error) return;
  const dt = Math.min(0.1, (now - last) / 1000);
  stats.frameMs = now - last;
  stats.fps = stats.frames > 1 ? 0.9 * stats.fps + 0.1 * (1000 / Math.max(1e-3, now - last)) : 0;
  last = now;
  if (walk) {
    // The walk starts once its start cell is drawn and its neighbours' packs are in
    // (as the native player's walk starts with its prefetch ring loaded; a cold start
    // is timed apart), or 10 s after the first frame if they never come.
    if (stats.firstFrameMs !== null && walkStart === null && (ringResident() || now - stats.firstFrameMs > 10000)) walkStart = now;
    const p = walkPose(walk, walkStart === null ? 0 : (now - walkStart) / 1000);
    cam.eye = p.eye;
    cam.yaw = p.yaw;
    cam.pitch = 0;
    cam.fovYDeg = walk.fovYDeg;
    stats.walkDone = p.done;
  } else move(dt);
  let drawn: boolean;
  try {
    drawn = draw();
  } catch (e: any) {
    fail(`${e.message ?? e}`);
    return;
  }
  if (readback && drawn) {
    try {
      await present();
    } catch (e: any) {
      fail(`reading the frame back: ${e.message ?? e}`);
      return;
    }
  }
  if (drawn) stats.frames++;
  requestAnimationFrame(frame);
}

/** Whether the packs of the current cell's neighbours (and their groups) are in. */
function ringResident(): boolean {
  const cell = grid.cellAt(cam.eye[0], cam.eye[2]);
  if (cell === null) return true;
  return (index.cells.get(cell)?.neighbours ?? []).every((n) => chain(n).every((w) => resident.get(w.key)?.state === "ready"));
}

function move(dt: number) {
  const speed = (keys.has("ShiftLeft") ? 60 : 15) * dt;
  const d = dir(cam);
  const fwd = [Math.cos(cam.yaw), 0, Math.sin(cam.yaw)];
  const right = [-fwd[2], 0, fwd[0]];
  const step = (v: number[], s: number) => {
    cam.eye = [cam.eye[0] + v[0] * s, cam.eye[1], cam.eye[2] + v[2] * s];
  };
  void d;
  if (keys.has("KeyW")) step(fwd, speed);
  if (keys.has("KeyS")) step(fwd, -speed);
  if (keys.has("KeyD")) step(right, speed);
  if (keys.has("KeyA")) step(right, -speed);
  if (keys.has("KeyR")) cam.eye[1] = Math.min(base.grid.maxEye, cam.eye[1] + speed);
  if (keys.has("KeyF")) cam.eye[1] = Math.max(base.grid.minEye, cam.eye[1] - speed);
  if (keys.has("ArrowLeft")) cam.yaw -= dt;
  if (keys.has("ArrowRight")) cam.yaw += dt;
}

function installControls(canvas: HTMLCanvasElement) {
  addEventListener("keydown", (e) => keys.add(e.code));
  addEventListener("keyup", (e) => keys.delete(e.code));
  let drag = false;
  canvas.addEventListener("mousedown", () => (drag = true));
  addEventListener("mouseup", () => (drag = false));
  addEventListener("mousemove", (e) => {
    if (!drag) return;
    cam.yaw += e.movementX * 0.004;
    cam.pitch = Math.max(-1.4, Math.min(1.4, cam.pitch - e.movementY * 0.004));
  });
}

/** Draws a frame; `false` when it did not: during a cold start, until the start
 * cell's packs are in and settled (the CPU goes to fetching and decoding them, not
 * to drawing unfinished frames on SwiftShader). */
function draw(): boolean {
  const cell = grid.cellAt(cam.eye[0], cam.eye[2]);
  stats.cell = cell;
  if (cell !== null && stats.cellsVisited[stats.cellsVisited.length - 1] !== cell) stats.cellsVisited.push(cell);
  const want = cell !== null ? chain(cell) : [];
  const keep = new Set(want.map((w) => w.key));
  for (const w of want) request(w.key, w.entry, true);
  // Neighbours once the first frame is drawn: before it, the start cell has the
  // connection and the bytes to itself.
  if (prefetch && cell !== null && stats.firstFrameMs !== null) {
    for (const n of index.cells.get(cell)?.neighbours ?? []) {
      for (const w of chain(n)) {
        keep.add(w.key);
        request(w.key, w.entry, false);
      }
    }
  }
  runUploads();
  evict(keep);

  // What to draw (player/src/frame.rs `cell_list`, pending proxies as originals).
  let packs = want.map((w) => resident.get(w.key));
  const current = packs[0]?.state === "ready" && packs.slice(1).every((p) => p?.state === "ready");
  if (current) shownChain = want.map((w) => w.key);
  else if (shownChain.every((k) => resident.get(k)?.state === "ready")) {
    // Until the new cell's packs are in, the last cell drawn stands in (with none,
    // the ground and sky only: drawing every original instead, as the native
    // player's fallback does, takes seconds per frame on SwiftShader).
    packs = shownChain.map((k) => resident.get(k));
  }
  if (stats.firstFrameMs === null && !current) return false;
  const cellPack = packs[0]?.state === "ready" ? packs[0] : undefined;
  const farReady = packs.slice(1).every((p) => p?.state === "ready");
  const originals = new Set<number>();
  const proxies: GpuProxy[] = [];
  if (!cellPack) {
    // No pack of the cell nor a stand-in: ground and sky only.
  } else {
    for (const i of cellPack.pack!.originals) originals.add(i);
    const drawn = farReady ? (packs as Resident[]) : [cellPack];
    for (const r of drawn)
      for (const p of r.proxies) {
        if (p.bind && proxyPipe(proxySlot(p))) proxies.push(p);
        else for (const m of p.members) originals.add(m);
      }
    if (!farReady) {
      const proxied = new Set<number>();
      for (const p of cellPack.proxies) for (const m of p.members) proxied.add(m);
      for (let i = 0; i < base.instances.length; i++) if (!proxied.has(i)) originals.add(i);
    }
  }
  const waiting = packs.reduce((s, r) => s + (r?.proxies.length ?? 0), 0) - proxies.length;
  if (stats.firstFrameMs !== null && cell !== null && !current) stats.standInFrames++;
  if (stats.firstFrameMs !== null && current && waiting > 0) stats.pendingFrames++;
  const drawnCell = cellPack?.pack?.id ?? -1;
  if (walk && walkStart !== null && stats.walkLog.length < 100000) stats.walkLog.push([cell ?? -1, drawnCell, farReady ? 1 : 0, waiting]);
  if (cellPack) mark("first frame with a cell pack");
  stats.settled = current && !!cellPack && farReady && proxies.length === packs.reduce((s, r) => s + (r?.proxies.length ?? 0), 0);
  // A cold start draws nothing until it is settled: on SwiftShader a frame costs
  // ≈ 100 ms that the packs' last pipelines and uploads would wait behind.
  if (stats.firstFrameMs === null && !stats.settled) return false;
  if (stats.firstFrameMs === null && stats.settled) {
    stats.firstFrameMs = performance.now();
    stats.firstFrameBytes = stats.fetched;
    // Without derived files, the rest of base.pack in the background (the next
    // cells' proxies need their models' vertices; with them, each pack brings its own).
    if (!derivedFiles) baseStream.ensureAll().catch((e) => fail(`${e.message ?? e}`));
    // And the proxy pipelines no pack has asked for yet (the next cells' ones).
    for (let slot = 0; slot <= MAX_VIEWS; slot++) proxyPipe(slot);
    (stats as any).firstFrameNo = stats.frames;
  }

  const clip = clipFromWorld(cam);
  const fr = planes(clip);
  // Instances by model (ascending, as the native BTreeMap), then the ground's.
  const byModel = new Map<number, number[]>();
  for (const i of [...originals].sort((a, b) => a - b)) {
    const m = base.instances[i].model;
    // A model whose base.pack ranges are still out is not drawn (only stand-ins
    // and proxies waiting for textures draw instances their packs do not list).
    if (!gpuModel(m) || !inside(fr, bounds(i))) continue;
    if (!byModel.has(m)) byModel.set(m, []);
    byModel.get(m)!.push(i);
  }
  const order = [...byModel.keys()].sort((a, b) => a - b);
  const shown = order.reduce((n, m) => n + byModel.get(m)!.length, 0);
  const instData = new ArrayBuffer(INSTANCE_RAW * (shown + 1));
  const idv = new DataView(instData);
  let at = 0;
  for (const m of order) for (const i of byModel.get(m)!) writeInstance(idv, INSTANCE_RAW * at++, base.instances[i].transform, base.instances[i].tint);
  const groundAt = at;
  writeInstance(idv, INSTANCE_RAW * at, [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1], [1, 1, 1]);
  device.queue.writeBuffer(instBuf, 0, instData);

  const gl = new ArrayBuffer(GLOBALS);
  const gdv = new DataView(gl);
  for (let k = 0; k < 16; k++) gdv.setFloat32(4 * k, clip[k], true);
  for (let k = 0; k < 3; k++) gdv.setFloat32(64 + 4 * k, cam.eye[k], true);
  gdv.setFloat32(76, 1, true);
  device.queue.writeBuffer(globalsBuf, 0, gl);

  const lin = (c: number) => {
    const x = c / 255;
    return x <= 0.04045 ? x / 12.92 : ((x + 0.055) / 1.055) ** 2.4;
  };
  const enc = device.createCommandEncoder();
  const pass = enc.beginRenderPass({
    colorAttachments: [
      {
        view: readback ? colourTex.createView() : ctx.getCurrentTexture().createView({ format: "rgba8unorm-srgb" }),
        clearValue: { r: lin(SKY[0]), g: lin(SKY[1]), b: lin(SKY[2]), a: 1 },
        loadOp: "clear",
        storeOp: "store",
      },
    ],
    depthStencilAttachment: { view: depthTex.createView(), depthClearValue: 1, depthLoadOp: "clear", depthStoreOp: "store" },
  });
  pass.setBindGroup(0, globalsBg);
  pass.setPipeline(pipes.ground);
  pass.setBindGroup(2, whiteBg);
  pass.setVertexBuffer(0, groundBuf);
  pass.setVertexBuffer(1, instBuf);
  pass.draw(6, 1, 0, groundAt);
  let tris = 2;
  pass.setPipeline(pipes.lit);
  let first = 0;
  for (const m of order) {
    const n = byModel.get(m)!.length;
    const g = models[m]!;
    if (g.indexCount > 0) {
      pass.setBindGroup(2, g.albedo);
      pass.setVertexBuffer(0, g.vbuf);
      pass.setIndexBuffer(g.ibuf, "uint32");
      pass.drawIndexed(g.indexCount, n, 0, 0, first);
      tris += g.tris * n;
    }
    first += n;
  }
  let bound: GPURenderPipeline | null = null;
  for (const p of proxies) {
    if (p.count === 0 || !inside(fr, p)) continue;
    const pl = proxyPipe(proxySlot(p))!; // only proxies with their pipeline are listed
    if (pl !== bound) pass.setPipeline((bound = pl));
    pass.setBindGroup(1, p.bind!);
    pass.setVertexBuffer(0, p.vbuf);
    pass.draw(p.count);
    tris += p.count / 3;
  }
  pass.end();
  if (readback) enc.copyTextureToBuffer({ texture: colourTex }, { buffer: readBuf, bytesPerRow: rowBytes }, [cam.width, cam.height]);
  device.queue.submit([enc.finish()]);

  stats.triangles = tris;
  stats.resident = [...resident.values()].filter((r) => r.state === "ready").length;
  stats.pose = [...cam.eye, (cam.yaw * 180) / Math.PI, (cam.pitch * 180) / Math.PI];
  if (stats.frames % 5 === 0 || stats.frames < 3) {
    const mib = (stats.fetched / (1 << 20)).toFixed(2);
    overlay.textContent =
      `FPS ${stats.fps.toFixed(1)}  frame ${stats.frameMs.toFixed(1)} ms  triangles ${tris}\n` +
      `cell ${cell ?? "-"} ${drawnCell === cell && farReady ? "drawn from its packs" : drawnCell >= 0 ? `stand-in: cell ${drawnCell}'s packs` : "not in yet"}` +
      `  resident packs ${stats.resident}  uploads queued ${stats.queuedUploads}\n` +
      `downloaded ${mib} MiB in ${stats.requests} requests  pose ${stats.pose.map((v) => v.toFixed(1)).join(",")}`;
  }
  return true;
}

init().catch((e) => fail(`${e?.message ?? e}`));
