// base.pack by HTTP range (issue 33, "first frame ≤ 2 MB"): the header and section
// table first, then the small sections every frame needs (base-meta, model-table,
// model-names, instances, albedo textures), and the models' vertex and triangle
// data only as the packs drawn need them (format/README.md "base.pack": a model's
// vertices and triangles follow those of the models before it, so one model is one
// byte range of each raw section). Sections stored compressed (codec ≥ 1) cannot be
// read by part and are fetched whole, once. The patch sections (0x010B–0x010D) are
// never fetched: the viewer does not cull by patch.
//
// A server that ignores `Range` (answers 200 with the whole file) still works: the
// whole pack is then decoded at once, as before.

import { decodeBase, PackError, PackFile, PackHead } from "./pack";
import type { Base, SectionSource, VertexSubset } from "./pack";

/** Fetches `url`, bytes `start..end` (end exclusive) or all of it: the bytes and
 * whether the server answered with the range (206) or the whole file (200). */
export type RangeFetch = (url: string, start: number, end: number) => Promise<{ bytes: Uint8Array; partial: boolean }>;

const POSITIONS = 0x0104;
const NORMALS = 0x0105;
const COLOURS = 0x0106;
const TRIANGLES = 0x0107;
const HEAVY = [POSITIONS, NORMALS, COLOURS, TRIANGLES];
const SMALL = [0x0101, 0x0102, 0x0103, 0x0108, 0x0109, 0x010a];
/** Bytes asked for first: the header, table and usually the sections right after. */
const FIRST = 16384;
/** Ranges closer than this are fetched as one. */
const MERGE_GAP = 4096;

export class BaseStream {
  readonly base: Base;
  /** Bytes of each heavy section per model (element size × count). */
  private per = new Map<number, number>();
  private loaded = new Map<number, boolean[]>(); // kind → per model
  private pending = new Map<string, Promise<void>>(); // `${kind}:${model}` or `${kind}:all`
  private buffers = new Map<number, Uint8Array>();
  private vertexStart: number[] = [];
  private triangleStart: number[] = [];
  private everything: Promise<void> | null = null;

  private constructor(
    private url: string,
    private fetchRange: RangeFetch,
    private head: PackHead | null,
    src: SectionSource,
    whole: boolean,
  ) {
    // A ranged stream's triangles are zeros until they arrive (`settle` checks them).
    this.base = decodeBase(src, whole);
    let v = 0;
    let t = 0;
    for (const m of this.base.models) {
      this.vertexStart.push(v);
      this.triangleStart.push(t);
      v += m.vertexCount;
      t += m.triangleCount;
    }
    this.per.set(POSITIONS, 12).set(NORMALS, 12).set(COLOURS, 4).set(TRIANGLES, 12);
    for (const k of HEAVY) this.loaded.set(k, new Array(this.base.models.length).fill(whole));
    if (head) {
      const want = [12 * v, 12 * v, 4 * v, 12 * t];
      HEAVY.forEach((k, i) => {
        if (head.sections.get(k)?.raw !== want[i])
          throw new PackError(`${head.label(k)}: ${head.sections.get(k)?.raw} bytes, the model table says ${want[i]}`);
      });
    }
  }

  /** Opens base.pack at `url`: one range request (two if its table is long), then
   * the small sections not in it. */
  static async open(url: string, fetchRange: RangeFetch): Promise<BaseStream> {
    // The file's name in messages: `base-<h>.pack` of a format-7 index, else base.pack.
    const name = url.slice(url.lastIndexOf("/") + 1) || "base.pack";
    const first = await fetchRange(url, 0, FIRST);
    if (!first.partial) return new BaseStream(url, fetchRange, null, new PackFile(name, first.bytes), true);
    let prefix = first.bytes;
    const need = PackHead.need(name, prefix);
    if (need > prefix.length) {
      const more = await fetchRange(url, prefix.length, need);
      const joined = new Uint8Array(prefix.length + more.bytes.length);
      joined.set(prefix);
      joined.set(more.bytes, prefix.length);
      prefix = joined;
    }
    const head = new PackHead(name, prefix);
    if (head.fileLen <= prefix.length) return new BaseStream(url, fetchRange, null, new PackFile(name, prefix.subarray(0, head.fileLen)), true);
    const small = new Map<number, Uint8Array>();
    await Promise.all(
      SMALL.filter((k) => head.has(k)).map(async (k) => {
        const s = head.sections.get(k)!;
        const stored =
          s.offset + s.stored <= prefix.length ? prefix.subarray(s.offset, s.offset + s.stored) : await exact(fetchRange, url, s.offset, s.offset + s.stored, head.label(k));
        small.set(k, head.decode(k, stored));
      }),
    );
    // The heavy sections start as zeros of their decoded length; the models'
    // arrays are views into them, filled as their ranges arrive.
    const buffers = new Map<number, Uint8Array>();
    for (const k of HEAVY) {
      const s = head.sections.get(k);
      if (!s) throw new PackError(`${head.label(k)} missing`);
      buffers.set(k, new Uint8Array(s.raw));
    }
    const src: SectionSource = {
      name,
      fileKind: head.fileKind,
      has: (k) => head.has(k),
      section: (k, optional) => {
        const b = small.get(k) ?? buffers.get(k);
        if (b) return b;
        if (optional) return new Uint8Array(0);
        throw new PackError(`${head.label(k)} missing`);
      },
    };
    const stream = new BaseStream(url, fetchRange, head, src, false);
    stream.buffers = buffers;
    return stream;
  }

  /** Whether model `m`'s vertices (and its triangles, with `triangles`) are in. */
  ready(m: number, triangles = false): boolean {
    return this.loaded.get(POSITIONS)![m] && this.loaded.get(NORMALS)![m] && this.loaded.get(COLOURS)![m] && (!triangles || this.loaded.get(TRIANGLES)![m]);
  }

  /** Fetches what models `vertices` (positions, normals, colours) and `full` (those
   * and triangles) still lack: per section, one request per run of adjacent models
   * (raw sections) or the whole section once (compressed ones). */
  ensure(vertices: Iterable<number>, full: Iterable<number> = []): Promise<void> {
    const want = new Map<number, Set<number>>(HEAVY.map((k) => [k, new Set<number>()]));
    for (const m of vertices) for (const k of [POSITIONS, NORMALS, COLOURS]) want.get(k)!.add(m);
    for (const m of full) for (const k of HEAVY) want.get(k)!.add(m);
    const jobs: Promise<void>[] = [];
    for (const [k, models] of want) jobs.push(this.ensureSection(k, [...models].sort((a, b) => a - b)));
    return Promise.all(jobs).then(() => {});
  }

  /** Writes a pack's vertex subset (`<pack>.vertices`) into the vertex sections:
   * enough for its proxies, though no model is marked in by it (originals need the
   * whole model). Nothing to do when the whole pack was read at once. */
  scatter(s: VertexSubset, name: string) {
    const total = this.vertexStart.length ? this.vertexStart[this.vertexStart.length - 1] + this.base.models[this.base.models.length - 1].vertexCount : 0;
    if (s.ids.length && s.ids[s.ids.length - 1] >= total) throw new PackError(`${name}: vertex id ${s.ids[s.ids.length - 1]}, base.pack has ${total}`);
    const [pos, nrm, col] = [POSITIONS, NORMALS, COLOURS].map((k) => this.buffers.get(k));
    if (!pos || !nrm || !col) return;
    // As 32-bit words (the buffers and the subset's arrays start 4-byte aligned).
    const words = (b: Uint8Array) => new Uint32Array(b.buffer, b.byteOffset, b.length >> 2);
    const [P, N, C] = [words(pos), words(nrm), words(col)];
    const [sp, sn, sc] = [words(s.positions), words(s.normals), words(s.colours)];
    for (let i = 0; i < s.ids.length; i++) {
      const id = s.ids[i];
      P[3 * id] = sp[3 * i];
      P[3 * id + 1] = sp[3 * i + 1];
      P[3 * id + 2] = sp[3 * i + 2];
      N[3 * id] = sn[3 * i];
      N[3 * id + 1] = sn[3 * i + 1];
      N[3 * id + 2] = sn[3 * i + 2];
      C[id] = sc[i];
    }
  }

  /** Everything not fetched yet (after the first frame, in the background). */
  ensureAll(): Promise<void> {
    const all = this.base.models.map((_, m) => m);
    return (this.everything ??= this.ensure([], all));
  }

  private ensureSection(kind: number, models: number[]): Promise<void> {
    const loaded = this.loaded.get(kind)!;
    const todo = models.filter((m) => !loaded[m]);
    if (!todo.length) return Promise.resolve();
    const head = this.head!;
    const s = head.sections.get(kind)!;
    const waits: Promise<void>[] = [];
    if (s.codec !== 0) {
      const key = `${kind}:all`;
      let p = this.pending.get(key);
      if (!p) {
        p = exact(this.fetchRange, this.url, s.offset, s.offset + s.stored, head.label(kind)).then((stored) => {
          this.buffers.get(kind)!.set(head.decode(kind, stored));
          this.settle(kind, this.base.models.map((_, m) => m));
        });
        this.pending.set(key, p);
      }
      return p;
    }
    // Raw: byte ranges of the models not yet asked for, merged when close.
    const fresh: number[] = [];
    for (const m of todo) {
      const p = this.pending.get(`${kind}:${m}`);
      if (p) waits.push(p);
      else fresh.push(m);
    }
    const per = this.per.get(kind)!;
    const starts = kind === TRIANGLES ? this.triangleStart : this.vertexStart;
    const counts = this.base.models.map((m) => (kind === TRIANGLES ? m.triangleCount : m.vertexCount));
    let run: { lo: number; hi: number; models: number[] } | null = null;
    const runs: { lo: number; hi: number; models: number[] }[] = [];
    for (const m of fresh) {
      const lo = per * starts[m];
      const hi = lo + per * counts[m];
      if (run && lo - run.hi <= MERGE_GAP) {
        run.hi = Math.max(run.hi, hi);
        run.models.push(m);
      } else runs.push((run = { lo, hi, models: [m] }));
    }
    for (const r of runs) {
      const p =
        r.hi > r.lo
          ? exact(this.fetchRange, this.url, s.offset + r.lo, s.offset + r.hi, head.label(kind)).then((bytes) => {
              this.buffers.get(kind)!.set(bytes, r.lo);
              // A merged run also covers the models between its ends.
              const covered = this.base.models.map((_, m) => m).filter((m) => per * starts[m] >= r.lo && per * (starts[m] + counts[m]) <= r.hi);
              this.settle(kind, covered);
            })
          : Promise.resolve().then(() => this.settle(kind, r.models));
      for (const m of r.models) this.pending.set(`${kind}:${m}`, p);
      waits.push(p);
    }
    return Promise.all(waits).then(() => {});
  }

  /** Marks `models` of section `kind` in; a model's triangles are checked against
   * its vertex count (decodeBase checked zeros). */
  private settle(kind: number, models: number[]) {
    const loaded = this.loaded.get(kind)!;
    for (const m of models) {
      if (loaded[m]) continue;
      if (kind === TRIANGLES) {
        const model = this.base.models[m];
        let top = 0;
        for (let i = 0; i < model.triangles.length; i++) top = Math.max(top, model.triangles[i]);
        if (model.triangles.length && top >= model.vertexCount)
          throw new PackError(`base.pack: triangles: index ${top} ≥ model ${m}'s ${model.vertexCount} vertices`);
      }
      loaded[m] = true;
    }
  }
}

/** Bytes `start..end` of `url`, refusing a short or whole-file answer. */
async function exact(fetchRange: RangeFetch, url: string, start: number, end: number, label: string): Promise<Uint8Array> {
  const r = await fetchRange(url, start, end);
  let b = r.bytes;
  if (!r.partial) b = b.subarray(start, end); // the whole file after all
  if (b.length !== end - start) throw new PackError(`${label}: got ${b.length} bytes of ${end - start} (truncated download?)`);
  return b;
}
