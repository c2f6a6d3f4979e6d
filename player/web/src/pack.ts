// Pack files in the browser: header, section table, codecs 0–3 and the typed
// records of base, cell/group and index packs (format/README.md "Pack files",
// "base.pack", "cells/<id>.pack", "groups/<id>.pack", "index.pack"; paper 000 §3.2:
// the run-time reads the current cell's representation).
//
// zstd: `fzstd` (pure TypeScript, MIT, no wasm to fetch or instantiate: ~8 KB
// minified). The packs' zstd sections are small (a demo cell's largest is ~100 KB)
// and decoding is not the cold-start bottleneck (see README "Measurements").
// Not checked here (the native reader does): blake3 checksums and the content rules
// that need the base pack beyond index bounds. Every read is bounds-checked, so a
// truncated or hostile pack gives a PackError naming the file and section, never a
// crash or an out-of-range read.

import { decompress } from "fzstd";

export class PackError extends Error {}

const MAGIC = [0x48, 0x45, 0x58, 0x42, 0x41, 0x4b, 0x45, 0x00];
export const MAX_VERSION = 7;
export const KIND = { base: 1, cell: 2, index: 3, group: 4 } as const;

export interface Section {
  kind: number;
  codec: number;
  offset: number;
  stored: number;
  raw: number;
}

/** What `decodeBase` reads from: a whole pack (`PackFile`) or one whose sections
 * arrive by range (`base.ts`). */
export interface SectionSource {
  readonly name: string;
  readonly fileKind: number;
  has(kind: number): boolean;
  section(kind: number, optional?: boolean): Uint8Array;
}

/** A pack's header and section table, read from the first `64 + 64·n` bytes of the
 * file (`fileLen` is the header's, not checked against anything here): enough to
 * fetch single sections by HTTP range. */
export class PackHead {
  readonly version: number;
  readonly fileKind: number;
  readonly fileLen: number;
  /** Bytes the header and table take: a prefix at least this long parses. */
  readonly tableEnd: number;
  readonly sections = new Map<number, Section>();

  /** The length of prefix `PackHead` needs, from the first 64 bytes (≥ 64). */
  static need(name: string, head: Uint8Array): number {
    if (head.length < 64) throw new PackError(`${name}: ${head.length} bytes, shorter than a pack header (64)`);
    const n = new DataView(head.buffer, head.byteOffset, 64).getUint32(20, true);
    return 64 + 64 * Math.min(n, 4097);
  }

  constructor(
    readonly name: string,
    prefix: Uint8Array,
  ) {
    const fail = (what: string) => {
      throw new PackError(`${name}: ${what}`);
    };
    const bytes = prefix;
    if (bytes.length < 64) fail(`${bytes.length} bytes, shorter than a pack header (64)`);
    for (let i = 0; i < 8; i++) if (bytes[i] !== MAGIC[i]) fail("not a hexbake pack (bad magic)");
    const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    this.fileKind = dv.getUint32(8, true);
    this.version = dv.getUint32(12, true);
    if (this.version === 0 || this.version > MAX_VERSION)
      fail(`pack format version ${this.version} is not 1…${MAX_VERSION}`);
    const n = dv.getUint32(20, true);
    if (n > 4096) fail(`${n} sections (at most 4096)`);
    this.fileLen = Number(dv.getBigUint64(32, true));
    this.tableEnd = 64 + 64 * n;
    if (this.tableEnd > this.fileLen) fail("section table past the end");
    if (this.tableEnd > bytes.length) fail(`section table past the ${bytes.length} bytes read (truncated download?)`);
    for (let i = 0; i < n; i++) {
      const o = 64 + 64 * i;
      const s: Section = {
        kind: dv.getUint32(o, true),
        codec: dv.getUint32(o + 4, true),
        offset: Number(dv.getBigUint64(o + 8, true)),
        stored: Number(dv.getBigUint64(o + 16, true)),
        raw: Number(dv.getBigUint64(o + 24, true)),
      };
      if (s.offset + s.stored > this.fileLen || s.offset < this.tableEnd)
        fail(`section 0x${s.kind.toString(16)} out of bounds`);
      if (s.codec > 3) fail(`section 0x${s.kind.toString(16)}: unknown codec ${s.codec}`);
      if (s.codec === 0 && s.raw !== s.stored) fail(`section 0x${s.kind.toString(16)}: raw length mismatch`);
      if (s.raw > 1024 * Math.max(s.stored, 1) || s.raw > 0xffffffff)
        fail(`section 0x${s.kind.toString(16)}: raw length ${s.raw} too large`);
      this.sections.set(s.kind, s);
    }
  }

  has(kind: number): boolean {
    return this.sections.has(kind);
  }

  label(kind: number): string {
    return `${this.name}: section 0x${kind.toString(16).padStart(4, "0")}`;
  }

  /** Section `kind`'s decoded bytes from its `stored` bytes. */
  decode(kind: number, stored: Uint8Array): Uint8Array {
    const s = this.sections.get(kind);
    if (!s) throw new PackError(`${this.label(kind)} missing`);
    return decodeStored(this.label(kind), s, stored);
  }
}

export class PackFile implements SectionSource {
  readonly version: number;
  readonly fileKind: number;
  readonly head: PackHead;

  constructor(
    readonly name: string,
    readonly bytes: Uint8Array,
  ) {
    this.head = new PackHead(name, bytes);
    this.version = this.head.version;
    this.fileKind = this.head.fileKind;
    if (this.head.fileLen !== bytes.length)
      throw new PackError(`${name}: header says ${this.head.fileLen} bytes, got ${bytes.length} (truncated download?)`);
  }

  has(kind: number): boolean {
    return this.head.has(kind);
  }

  /** Sections decoded so far: a pack's records are read before its textures
   * arrive (`packModels`, `proxyKinds`) and again by `decodeCell`. */
  private readonly decoded = new Map<number, Uint8Array>();

  /** The decoded bytes of section `kind` (empty when absent and `optional`). */
  section(kind: number, optional = false): Uint8Array {
    const s = this.head.sections.get(kind);
    if (!s) {
      if (optional) return new Uint8Array(0);
      throw new PackError(`${this.head.label(kind)} missing`);
    }
    let d = this.decoded.get(kind);
    if (!d) {
      d = decodeStored(this.head.label(kind), s, this.bytes.subarray(s.offset, s.offset + s.stored));
      this.decoded.set(kind, d);
    }
    return d;
  }
}

/** A section's content from its stored bytes (codecs 0–3). */
export function decodeStored(label: string, s: Section, stored: Uint8Array): Uint8Array {
  if (stored.length !== s.stored) throw new PackError(`${label}: ${stored.length} stored bytes, expected ${s.stored}`);
  if (s.codec === 0) return stored;
  let out: Uint8Array;
  try {
    // A frame may not announce more than the section's bound (raw_len, or 1.5 ·
    // raw_len pre-coded for codec 3), so a lying frame header cannot make the
    // decoder allocate more (fzstd allocates the announced content size).
    const announced = zstdContentSize(stored);
    const bound = s.codec === 3 ? Math.ceil(1.5 * s.raw) + 16 : s.raw;
    if (announced !== null && announced > bound)
      throw new PackError(`${label}: zstd frame announces ${announced} bytes, more than ${bound}`);
    out = decompress(stored);
  } catch (e) {
    throw new PackError(`${label}: zstd: ${e}`);
  }
  if (s.codec === 1) {
    if (out.length !== s.raw) throw new PackError(`${label}: decoded ${out.length} bytes, expected ${s.raw}`);
    return out;
  }
  if (s.codec === 2) return undelta(out, s.raw, label);
  return unmtf(out, s.raw, label);
}

/** The Frame_Content_Size of a zstd frame header (RFC 8878 §3.1.1.1), if present. */
function zstdContentSize(b: Uint8Array): number | null {
  if (b.length < 6 || b[0] !== 0x28 || b[1] !== 0xb5 || b[2] !== 0x2f || b[3] !== 0xfd) return null;
  const desc = b[4];
  const fcsFlag = desc >> 6;
  const single = (desc >> 5) & 1;
  const at = 5 + (single ? 0 : 1) + [0, 1, 2, 4][desc & 3];
  const size = [single ? 1 : 0, 2, 4, 8][fcsFlag];
  if (size === 0 || at + size > b.length) return null;
  let v = 0;
  for (let i = size - 1; i >= 0; i--) v = v * 256 + b[at + i];
  return size === 2 ? v + 256 : v;
}

/** Codec 2: byte planes → zig-zag → delta (format/README.md "Codecs"). */
function undelta(src: Uint8Array, raw: number, label: string): Uint8Array {
  if (raw % 4 !== 0 || src.length !== raw) throw new PackError(`${label}: delta-u32 length mismatch`);
  const m = raw / 4;
  const out = new Uint32Array(m);
  let prev = 0;
  for (let i = 0; i < m; i++) {
    const z = (src[i] | (src[m + i] << 8) | (src[2 * m + i] << 16) | (src[3 * m + i] << 24)) >>> 0;
    const d = (z >>> 1) ^ -(z & 1);
    prev = (prev + d) >>> 0;
    out[i] = prev;
  }
  return new Uint8Array(out.buffer);
}

/** Codec 3: move-to-front of the last 16 values + LEB128 zig-zag deltas. */
function unmtf(src: Uint8Array, raw: number, label: string): Uint8Array {
  if (raw % 4 !== 0) throw new PackError(`${label}: index-mtf length not a multiple of 4`);
  const m = raw / 4;
  if (src.length < m) throw new PackError(`${label}: index-mtf codes cut short`);
  const out = new Uint32Array(m);
  const list = new Uint32Array(16);
  let p = 0;
  let at = m;
  for (let i = 0; i < m; i++) {
    const code = src[i];
    let k: number;
    let v: number;
    if (code < 16) {
      k = code;
      v = list[k];
    } else if (code === 16) {
      let z = 0;
      let shift = 0;
      for (;;) {
        if (at >= src.length || shift > 28) throw new PackError(`${label}: index-mtf delta cut short or too long`);
        const b = src[at++];
        z += (b & 0x7f) * 2 ** shift;
        shift += 7;
        if ((b & 0x80) === 0) break;
      }
      z = z >>> 0;
      const d = (z >>> 1) ^ -(z & 1);
      v = (p + d) >>> 0;
      p = v;
      k = 15;
    } else {
      throw new PackError(`${label}: index-mtf code ${code} above 16`);
    }
    for (let j = k; j > 0; j--) list[j] = list[j - 1];
    list[0] = v;
    out[i] = v;
  }
  if (at !== src.length) throw new PackError(`${label}: ${src.length - at} bytes left over`);
  return new Uint8Array(out.buffer);
}

const LITTLE = new Uint8Array(new Uint32Array([1]).buffer)[0] === 1;

/** A bounds-checked little-endian reader over one section. */
export class Reader {
  private dv: DataView;
  constructor(
    readonly bytes: Uint8Array,
    readonly label: string,
  ) {
    this.dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  }
  need(off: number, len: number) {
    if (off < 0 || off + len > this.bytes.length)
      throw new PackError(`${this.label}: record at byte ${off} past the section's end (${this.bytes.length})`);
  }
  u32(off: number): number {
    this.need(off, 4);
    return this.dv.getUint32(off, true);
  }
  f32(off: number): number {
    this.need(off, 4);
    return this.dv.getFloat32(off, true);
  }
  u64(off: number): number {
    this.need(off, 8);
    return Number(this.dv.getBigUint64(off, true));
  }
  f32s(off: number, n: number): number[] {
    const a: number[] = [];
    for (let i = 0; i < n; i++) a.push(this.f32(off + 4 * i));
    return a;
  }
  /** `n` u32 values at `off`: a view when aligned (sections are 64-byte aligned in
   * a pack) on a little-endian host, else a copy. */
  u32array(off: number, n: number): Uint32Array {
    this.need(off, 4 * n);
    if (LITTLE && (this.bytes.byteOffset + off) % 4 === 0) return new Uint32Array(this.bytes.buffer, this.bytes.byteOffset + off, n);
    const a = new Uint32Array(n);
    for (let i = 0; i < n; i++) a[i] = this.dv.getUint32(off + 4 * i, true);
    return a;
  }
  f32array(off: number, n: number): Float32Array {
    this.need(off, 4 * n);
    if (LITTLE && (this.bytes.byteOffset + off) % 4 === 0) return new Float32Array(this.bytes.buffer, this.bytes.byteOffset + off, n);
    const a = new Float32Array(n);
    for (let i = 0; i < n; i++) a[i] = this.dv.getFloat32(off + 4 * i, true);
    return a;
  }
}

// ---- base.pack ----

export interface GridParams {
  groundMin: [number, number];
  groundMax: [number, number];
  cellSize: number;
  minEye: number;
  maxEye: number;
  nCols: number;
  nRows: number;
}

export interface Model {
  vertexCount: number;
  triangleCount: number;
  positions: Float32Array; // 3 per vertex
  normals: Float32Array;
  colours: Uint8Array; // 4 per vertex, sRGB8
  triangles: Uint32Array; // 3 per triangle
  uvs: Float32Array | null; // 2 per vertex, for a textured model (issue 18)
  texture: number | null; // index into Base.textures
}

/** An albedo texture (format/README.md "Optional albedo texture sections"). */
export interface AlbedoTexture {
  width: number;
  height: number;
  wrap: [number, number]; // 0 REPEAT, 1 MIRRORED_REPEAT, 2 CLAMP_TO_EDGE
  rgba: Uint8Array; // sRGB8, row 0 first
}

export interface Instance {
  transform: Float32Array; // 16, column-major
  tint: [number, number, number];
  model: number;
}

export interface Base {
  grid: GridParams;
  models: Model[];
  instances: Instance[];
  textures: AlbedoTexture[];
}

export function decodeBase(file: SectionSource, checkTriangles = true): Base {
  if (file.fileKind !== KIND.base) throw new PackError(`${file.name}: file kind ${file.fileKind}, not a base pack`);
  const meta = new Reader(file.section(0x0101), `${file.name}: base-meta`);
  const grid: GridParams = {
    groundMin: [meta.f32(32), meta.f32(36)],
    groundMax: [meta.f32(40), meta.f32(44)],
    cellSize: meta.f32(48),
    minEye: meta.f32(52),
    maxEye: meta.f32(56),
    nCols: meta.u32(60),
    nRows: meta.u32(64),
  };
  const modelCount = meta.u32(68);
  const instanceCount = meta.u32(72);
  const table = new Reader(file.section(0x0102), `${file.name}: model-table`);
  table.need(0, 48 * modelCount);
  const pos = new Reader(file.section(0x0104), `${file.name}: positions`);
  const nor = new Reader(file.section(0x0105), `${file.name}: normals`);
  const col = file.section(0x0106);
  const tri = new Reader(file.section(0x0107), `${file.name}: triangles`);
  const models: Model[] = [];
  let v0 = 0;
  let t0 = 0;
  for (let m = 0; m < modelCount; m++) {
    const vc = table.u32(48 * m);
    const tc = table.u32(48 * m + 4);
    if (4 * (v0 + vc) > col.length) throw new PackError(`${file.name}: vertex-colours shorter than the models' vertices`);
    const triangles = tri.u32array(12 * t0, 3 * tc);
    let top = 0;
    if (checkTriangles) for (let i = 0; i < triangles.length; i++) top = Math.max(top, triangles[i]);
    if (triangles.length && top >= vc) throw new PackError(`${file.name}: triangles: index ${top} ≥ model ${m}'s ${vc} vertices`);
    models.push({
      vertexCount: vc,
      triangleCount: tc,
      positions: pos.f32array(12 * v0, 3 * vc),
      normals: nor.f32array(12 * v0, 3 * vc),
      colours: col.subarray(4 * v0, 4 * (v0 + vc)),
      triangles,
      uvs: null,
      texture: null,
    });
    v0 += vc;
    t0 += tc;
  }
  const inst = new Reader(file.section(0x0108), `${file.name}: instances`);
  const instances: Instance[] = [];
  for (let i = 0; i < instanceCount; i++) {
    const o = 80 * i;
    const model = inst.u32(o + 76);
    if (model >= modelCount) throw new PackError(`${file.name}: instance ${i} names model ${model} of ${modelCount}`);
    instances.push({
      transform: inst.f32array(o, 16),
      tint: [inst.f32(o + 64), inst.f32(o + 68), inst.f32(o + 72)],
      model,
    });
  }
  const textures = decodeAlbedo(file, models);
  return { grid, models, instances, textures };
}

/** Sections 0x0109 albedo-textures and 0x010A texcoords (both or neither). */
function decodeAlbedo(file: SectionSource, models: Model[]): AlbedoTexture[] {
  if (!file.has(0x0109) && !file.has(0x010a)) return [];
  if (!file.has(0x0109) || !file.has(0x010a))
    throw new PackError(`${file.name}: albedo-textures and texcoords must both be present or neither`);
  const t = new Reader(file.section(0x0109), `${file.name}: albedo-textures`);
  const count = t.u32(0);
  const textures: AlbedoTexture[] = [];
  let at = 8 + 16 * count;
  for (let i = 0; i < count; i++) {
    const [w, h, wu, wv] = [t.u32(8 + 16 * i), t.u32(12 + 16 * i), t.u32(16 + 16 * i), t.u32(20 + 16 * i)];
    if (w < 1 || h < 1 || w > 8192 || h > 8192 || wu > 2 || wv > 2) throw new PackError(`${t.label}: texture ${i}: ${w}×${h}, wrap ${wu}/${wv}`);
    t.need(at, 4 * w * h);
    textures.push({ width: w, height: h, wrap: [wu, wv], rgba: t.bytes.subarray(at, at + 4 * w * h) });
    at += 4 * w * h;
  }
  const c = new Reader(file.section(0x010a), `${file.name}: texcoords`);
  const n = c.u32(0);
  let uv = 8 + 8 * n;
  for (let i = 0; i < n; i++) {
    const [m, tex] = [c.u32(8 + 8 * i), c.u32(12 + 8 * i)];
    if (m >= models.length || tex >= textures.length) throw new PackError(`${c.label}: record ${i}: model ${m}, texture ${tex} out of range`);
    models[m].uvs = c.f32array(uv, 2 * models[m].vertexCount);
    models[m].texture = tex;
    uv += 8 * models[m].vertexCount;
  }
  return textures;
}

// ---- index.pack ----

export interface IndexEntry {
  id: number;
  bytes: number;
  file: string;
  neighbours: number[];
  group: number; // far-field group / parent, or NONE
}

export const NONE = 0xffffffff;

export interface Index {
  cells: Map<number, IndexEntry>;
  groups: Map<number, IndexEntry>;
  /** The base pack this index names (version 7, `index-base`), else `base.pack`. */
  baseFile: string;
}

export function decodeIndex(file: PackFile): Index {
  if (file.fileKind !== KIND.index) throw new PackError(`${file.name}: file kind ${file.fileKind}, not an index pack`);
  const meta = new Reader(file.section(0x0301), `${file.name}: index-meta`);
  const cellCount = meta.u32(32);
  const groupCount = file.version >= 2 ? meta.u32(36) : 0;
  const rec = new Reader(file.section(0x0302), `${file.name}: index-cells`);
  const names = file.section(0x0303);
  const nbr = new Reader(file.section(0x0304), `${file.name}: index-neighbours`);
  const grec = new Reader(file.section(0x0305, true), `${file.name}: index-groups`);
  const cg = new Reader(file.section(0x0306, true), `${file.name}: index-cell-groups`);
  const dec = new TextDecoder("utf-8", { fatal: true });
  const entry = (r: Reader, i: number, nOff: number): [IndexEntry, number] => {
    const o = 88 * i;
    const nc = r.u32(o + 4);
    if (nc > 6) throw new PackError(`${r.label}: record ${i} has ${nc} neighbours`);
    const no = r.u32(o + 80);
    const nl = r.u32(o + 84);
    if (no + nl > names.length) throw new PackError(`${file.name}: index-file-names: name of record ${i} out of range`);
    const fileName = dec.decode(names.subarray(no, no + nl));
    if (fileName.split("/").some((c) => c === "" || c === "." || c === "..") || /[\\\0]/.test(fileName))
      throw new PackError(`${file.name}: bad file name ${JSON.stringify(fileName)}`);
    return [
      { id: r.u32(o), bytes: r.u64(o + 8), file: fileName, neighbours: Array.from(nbr.u32array(4 * nOff, nc)), group: NONE },
      nOff + nc,
    ];
  };
  const cells = new Map<number, IndexEntry>();
  let nOff = 0;
  for (let i = 0; i < cellCount; i++) {
    const [e, n] = entry(rec, i, nOff);
    nOff = n;
    if (cg.bytes.length >= 4 * (i + 1)) e.group = cg.u32(4 * i);
    cells.set(e.id, e);
  }
  const groups = new Map<number, IndexEntry>();
  for (let i = 0; i < groupCount; i++) {
    const [e] = entry(grec, i, 0);
    const at = 4 * (cellCount + i);
    if (file.version >= 5 && cg.bytes.length >= at + 4) e.group = cg.u32(at);
    groups.set(e.id, e);
  }
  // Version 7 (issue 32): the base pack of this generation, named by the index.
  let baseFile = "base.pack";
  if (file.version >= 7 && file.section(0x0307, true).length > 0) {
    const [e] = entry(new Reader(file.section(0x0307), `${file.name}: index-base`), 0, 0);
    baseFile = e.file;
  }
  return { cells, groups, baseFile };
}

// ---- cells/<id>.pack and groups/<id>.pack ----

export interface View {
  matrix: Float32Array; // 16, column-major, world → texture
  eye: [number, number, number];
  width: number;
  height: number;
  encoding: number; // 0 rgba8, 1 rgba8-left, 2 bc1, 3 bc3
  len: number; // bytes of its texture (the views record's)
  data: Uint8Array; // empty until `attachTextures`
}

export interface Member {
  instance: number;
  triangles: Uint32Array; // 3 per triangle
  masks: Uint8Array | null;
}

export interface Layers {
  cornerRays: number[][]; // 4 × 3
  layers: { depth: number; lo: number; hi: number }[];
}

export interface Proxy {
  kind: number; // 1 SvMesh, 2 Cluster, 3 MvMesh, 4 LayeredImpostor
  members: Member[];
  views: View[];
  layers: Layers | null;
}

export interface CellPack {
  id: number;
  farGroup: number;
  originals: Uint32Array;
  proxies: Proxy[];
}

/** Version 6 (format/README.md "textures/"): the 32-byte blake3 names of the
 * views' textures in the bake's store, in view order; `null` for a pack that keeps
 * them inline (section `textures`). */
export function textureRefs(file: PackFile): string[] | null {
  if (!file.has(0x020b)) return null;
  const refs = file.section(0x020b, true);
  if (refs.length % 32 !== 0) throw new PackError(`${file.name}: texture-refs: ${refs.length} bytes, not 32-byte references`);
  const out: string[] = [];
  for (let o = 0; o < refs.length; o += 32) out.push(hex(refs.subarray(o, o + 32)));
  return out;
}

const HEX = Array.from({ length: 256 }, (_, b) => b.toString(16).padStart(2, "0"));

/** Lower-case hex of `b`. */
function hex(b: Uint8Array): string {
  let s = "";
  for (let i = 0; i < b.length; i++) s += HEX[b[i]];
  return s;
}

/** The store path of a texture reference, relative to the bake folder. */
export function texturePath(ref: string): string {
  return `textures/${ref.slice(0, 2)}/${ref}.tex`;
}

/** A store file's encoded texture bytes (one zstd frame). Not hash-checked here:
 * the native reader does (module notes). */
export function decodeTextureFile(name: string, bytes: Uint8Array): Uint8Array {
  try {
    return decompress(bytes);
  } catch (e) {
    throw new PackError(`${name}: not a zstd frame: ${e}`);
  }
}

/** The models a cell or group pack draws with, read before its textures are in:
 * its proxies' members' (`vertices`: positions, normals, colours) and its
 * originals' (`full`: with triangles). Out-of-range instances are left out here;
 * `decodeCell` refuses them. */
export function packModels(file: PackFile, base: Base): { vertices: Set<number>; full: Set<number> } {
  const vertices = new Set<number>();
  const full = new Set<number>();
  const model = (i: number) => (i < base.instances.length ? base.instances[i].model : null);
  const meta = new Reader(file.section(0x0201), `${file.name}: cell-meta`);
  const originals = new Reader(file.section(0x0202), `${file.name}: originals`);
  for (let k = 0, n = Math.min(meta.u32(36), originals.bytes.length / 4); k < n; k++) {
    const m = model(originals.u32(4 * k));
    if (m !== null) full.add(m);
  }
  const mem = new Reader(file.section(0x0204), `${file.name}: members`);
  for (let k = 0, n = Math.min(meta.u32(44), mem.bytes.length / 16); k < n; k++) {
    const m = model(mem.u32(16 * k));
    if (m !== null) vertices.add(m);
  }
  return { vertices, full };
}

/** `textures`: the textures of a version-6 pack fetched from the store, concatenated
 * in view order (what its `textures` section would hold); omitted for inline packs. */
export function decodeCell(file: PackFile, base: Base, textures?: Uint8Array): CellPack {
  const pack = decodeCellRecords(file, base);
  attachTextures(file, pack, textures);
  return pack;
}

/** A pack's views' texture bytes from `textures` (as `decodeCell`'s), checked
 * against each view's size and encoding. */
export function attachTextures(file: PackFile, pack: CellPack, textures?: Uint8Array) {
  const tex = textures ?? file.section(0x0208);
  let to = 0;
  let vi = 0;
  for (const p of pack.proxies)
    for (const view of p.views) {
      if (to + view.len > tex.length) throw new PackError(`${file.name}: textures: view ${vi}'s ${view.len} bytes past the section's end`);
      view.data = tex.subarray(to, to + view.len);
      checkTexture(view, `${file.name}: textures: view ${vi}`);
      to += view.len;
      vi++;
    }
}

/** Everything of a cell or group pack but its textures (views' `data` stay empty
 * until `attachTextures`): decoded while the textures download. */
export function decodeCellRecords(file: PackFile, base: Base): CellPack {
  if (file.fileKind !== KIND.cell && file.fileKind !== KIND.group)
    throw new PackError(`${file.name}: file kind ${file.fileKind}, not a cell or group pack`);
  const n = file.name;
  const meta = new Reader(file.section(0x0201), `${n}: cell-meta`);
  const id = meta.u32(32);
  const originalCount = meta.u32(36);
  const proxyCount = meta.u32(40);
  const memberCount = meta.u32(44);
  const viewCount = meta.u32(48);
  const farGroup = file.version >= 2 ? meta.u32(52) : NONE;
  const originals = new Reader(file.section(0x0202), `${n}: originals`).u32array(0, originalCount);
  for (const i of originals)
    if (i >= base.instances.length) throw new PackError(`${n}: originals: instance ${i} out of range`);
  const prox = new Reader(file.section(0x0203), `${n}: proxies`);
  const mem = new Reader(file.section(0x0204), `${n}: members`);
  const tris = new Reader(file.section(0x0205), `${n}: member-triangles`);
  const masks = file.section(0x0206);
  const views = new Reader(file.section(0x0207), `${n}: views`);
  const lay = new Reader(file.section(0x0209, true), `${n}: layered-impostors`);
  let mi = 0,
    ti = 0,
    ki = 0,
    vi = 0,
    lo = 0;
  const proxies: Proxy[] = [];
  for (let p = 0; p < proxyCount; p++) {
    const kind = prox.u32(16 * p);
    const nm = prox.u32(16 * p + 4);
    const nv = prox.u32(16 * p + 8);
    if (kind < 1 || kind > 4) throw new PackError(`${n}: proxies: proxy ${p} has unknown kind ${kind}`);
    if (nv > 8) throw new PackError(`${n}: proxies: proxy ${p} has ${nv} views (at most 8)`);
    if (mi + nm > memberCount || vi + nv > viewCount) throw new PackError(`${n}: proxies: counts past the members/views`);
    const members: Member[] = [];
    for (let m = 0; m < nm; m++, mi++) {
      const instance = mem.u32(16 * mi);
      const tc = mem.u32(16 * mi + 4);
      const mc = mem.u32(16 * mi + 8);
      if (instance >= base.instances.length) throw new PackError(`${n}: members: instance ${instance} out of range`);
      const triangles = tris.u32array(12 * ti, 3 * tc);
      const vc = base.models[base.instances[instance].model].vertexCount;
      for (const v of triangles) if (v >= vc) throw new PackError(`${n}: member-triangles: vertex ${v} out of range`);
      ti += tc;
      let mk: Uint8Array | null = null;
      if (mc > 0) {
        if (ki + mc > masks.length) throw new PackError(`${n}: view-masks past the section's end`);
        mk = masks.subarray(ki, ki + mc);
        ki += mc;
      }
      members.push({ instance, triangles, masks: mk });
    }
    const vs: View[] = [];
    for (let v = 0; v < nv; v++, vi++) {
      const o = 96 * vi;
      vs.push({
        matrix: views.f32array(o, 16),
        eye: [views.f32(o + 64), views.f32(o + 68), views.f32(o + 72)],
        width: views.u32(o + 76),
        height: views.u32(o + 80),
        encoding: views.u32(o + 84),
        len: views.u64(o + 88),
        data: new Uint8Array(0),
      });
    }
    let layers: Layers | null = null;
    if (kind === 4 && lay.bytes.length > 0) {
      const rays = [0, 1, 2, 3].map((k) => lay.f32s(lo + 12 * k, 3));
      const count = lay.u32(lo + 56);
      if (count < 1 || count > 64) throw new PackError(`${n}: layered-impostors: ${count} layers`);
      lo += 64;
      const ls = [];
      for (let l = 0; l < count; l++, lo += 16) ls.push({ depth: lay.f32(lo), lo: lay.u32(lo + 4), hi: lay.u32(lo + 8) });
      layers = { cornerRays: rays, layers: ls };
    }
    proxies.push({ kind, members, views: vs, layers });
  }
  return { id, farGroup, originals, proxies };
}

function checkTexture(v: View, label: string) {
  const { width: w, height: h } = v;
  if (w < 1 || h < 1 || w > 16384 || h > 16384) throw new PackError(`${label}: size ${w}×${h}`);
  const want = v.encoding <= 1 ? w * h * 4 : v.encoding === 2 ? (w * h) / 2 : v.encoding === 3 ? w * h : -1;
  if (want < 0) throw new PackError(`${label}: unknown texture encoding ${v.encoding}`);
  if (v.encoding >= 2 && (w % 4 !== 0 || h % 4 !== 0)) throw new PackError(`${label}: block texture ${w}×${h}`);
  if (v.data.length !== want) throw new PackError(`${label}: ${v.data.length} bytes, expected ${want}`);
}

/** RGBA8 texels of a lossless texture (encoding 0 or 1). */
export function rgba8(v: View): Uint8Array {
  if (v.encoding === 0) return v.data;
  const out = new Uint8Array(v.data);
  const row = v.width * 4;
  for (let y = 0; y < v.height; y++)
    for (let j = 4; j < row; j++) out[y * row + j] = (out[y * row + j] + out[y * row + j - 4]) & 0xff;
  return out;
}

// ---- files derived from a pack for the browser (format/README.md "Derived files
// for the browser"; format/src/pack/web.rs) ----

/** `<pack>.vertices`: the vertices a pack's proxies use, by global id (base.pack
 * vertex order), with their positions, normals and colours as raw bytes. */
export interface VertexSubset {
  ids: Uint32Array;
  positions: Uint8Array; // 12 B per vertex
  normals: Uint8Array; // 12 B per vertex
  colours: Uint8Array; // 4 B per vertex
}

const u32At = (b: Uint8Array, o: number) => (b[o] | (b[o + 1] << 8) | (b[o + 2] << 16) | (b[o + 3] << 24)) >>> 0;

function checkHead(name: string, b: Uint8Array, magic: string) {
  if (b.length < 12 || String.fromCharCode(b[0], b[1], b[2], b[3]) !== magic) throw new PackError(`${name}: byte 0: not a hexbake ${magic} file`);
  const version = u32At(b, 4);
  if (version !== 1) throw new PackError(`${name}: byte 4: version ${version}, this viewer knows 1`);
}

export function decodeVertices(name: string, b: Uint8Array): VertexSubset {
  checkHead(name, b, "HXVS");
  if (b.length < 16) throw new PackError(`${name}: byte ${b.length}: file ends inside the 16-byte head`);
  const n = u32At(b, 8);
  const streamEnd = 16 + u32At(b, 12);
  const data = Math.ceil(streamEnd / 4) * 4;
  if (b.length !== data + 28 * n) throw new PackError(`${name}: byte ${b.length}: ${n} vertices need ${data + 28 * n} bytes`);
  const ids = new Uint32Array(n);
  let o = 16;
  let prev = -1;
  for (let i = 0; i < n; i++) {
    let gap = 0;
    let scale = 1;
    for (;;) {
      if (o >= streamEnd || scale > 2 ** 28) throw new PackError(`${name}: byte ${o}: id gap cut short or longer than 32 bits`);
      const byte = b[o++];
      gap += (byte & 0x7f) * scale;
      scale *= 128;
      if (!(byte & 0x80)) break;
    }
    const id = prev + 1 + gap;
    if (id > 0xffffffff) throw new PackError(`${name}: byte ${o}: vertex id ${id} past u32`);
    ids[i] = prev = id;
  }
  if (o !== streamEnd) throw new PackError(`${name}: byte ${o}: bytes left over after the ids`);
  return {
    ids,
    positions: b.subarray(data, data + 12 * n),
    normals: b.subarray(data + 12 * n, data + 24 * n),
    colours: b.subarray(data + 24 * n, data + 28 * n),
  };
}

/** `<pack>.textures`: the encoded textures a pack names (distinct, first use
 * first), each with its reference as lower-case hex. */
export function decodeTextureBundle(name: string, b: Uint8Array): { ref: string; data: Uint8Array }[] {
  checkHead(name, b, "HXTB");
  const n = u32At(b, 8);
  const tableEnd = 12 + 36 * n;
  if (tableEnd > b.length) throw new PackError(`${name}: byte ${b.length}: ${n} records need ${tableEnd} bytes`);
  const out: { ref: string; data: Uint8Array }[] = [];
  let at = tableEnd;
  for (let k = 0; k < n; k++) {
    const o = 12 + 36 * k;
    const len = u32At(b, o + 32);
    if (at + len > b.length) throw new PackError(`${name}: byte ${at}: texture ${k} needs ${len} bytes, fewer are left`);
    const ref = hex(b.subarray(o, o + 32));
    out.push({ ref, data: b.subarray(at, at + len) });
    at += len;
  }
  if (at !== b.length) throw new PackError(`${name}: byte ${at}: bytes left over after the textures`);
  return out;
}

/** Each proxy's kind and view count, read from a cell or group pack's `proxies`
 * records before anything else is decoded (to compile the pipelines it needs while
 * its textures and vertices download). */
export function proxyKinds(file: PackFile): { kind: number; views: number }[] {
  const r = new Reader(file.section(0x0203, true), `${file.name}: proxies`);
  const out: { kind: number; views: number }[] = [];
  for (let o = 0; o + 16 <= r.bytes.length; o += 16) out.push({ kind: r.u32(o), views: r.u32(o + 8) });
  return out;
}

/** A derived file's bytes: as sent, or decoded when stored as one zstd frame
 * (`pipeline web-export` writes them so for static hosts). */
export function unframe(name: string, b: Uint8Array): Uint8Array {
  if (b.length < 4 || b[0] !== 0x28 || b[1] !== 0xb5 || b[2] !== 0x2f || b[3] !== 0xfd) return b;
  try {
    return decompress(b);
  } catch (e) {
    throw new PackError(`${name}: not a zstd frame: ${e}`);
  }
}
