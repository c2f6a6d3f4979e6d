// Camera, hex grid and the vertex records the player hands to the GPU, ported from
// the native player so that both draw the same frame (paper 000 §3.2; DESIGN.md
// "Space", "Hex grid"; player/src/camera.rs, format/src/grid.rs,
// player/src/vertex.rs, player/src/bake.rs `prepare_cell`).

import type { AlbedoTexture, Base, GridParams, Proxy } from "./pack";

export type Mat4 = Float64Array; // column-major

export function mul(a: Mat4, b: Mat4): Mat4 {
  const o = new Float64Array(16);
  for (let c = 0; c < 4; c++)
    for (let r = 0; r < 4; r++) {
      let s = 0;
      for (let k = 0; k < 4; k++) s += a[k * 4 + r] * b[c * 4 + k];
      o[c * 4 + r] = s;
    }
  return o;
}

export interface Camera {
  eye: [number, number, number];
  yaw: number; // radians, 0 = +x, π/2 = +z
  pitch: number;
  fovYDeg: number;
  width: number;
  height: number;
  near: number;
  far: number;
}

export function dir(c: Camera): [number, number, number] {
  return [Math.cos(c.yaw) * Math.cos(c.pitch), Math.sin(c.pitch), Math.sin(c.yaw) * Math.cos(c.pitch)];
}

const norm = (v: number[]) => {
  const l = Math.hypot(v[0], v[1], v[2]);
  return l > 0 ? v.map((x) => x / l) : v;
};
const cross = (a: number[], b: number[]) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const dot = (a: number[], b: number[]) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];

/** World → wgpu clip (Camera::clip_from_world_wgpu). */
export function clipFromWorld(c: Camera): Mat4 {
  const f = norm(dir(c));
  const s = norm(cross(f, [0, 1, 0]));
  const u = cross(s, f);
  const e = c.eye;
  const view = Float64Array.from([
    s[0], u[0], -f[0], 0,
    s[1], u[1], -f[1], 0,
    s[2], u[2], -f[2], 0,
    -dot(s, e), -dot(u, e), dot(f, e), 1,
  ]);
  const t = c.near * Math.tan((c.fovYDeg * Math.PI) / 180 / 2);
  const r = (t * c.width) / c.height;
  const [n, fa] = [c.near, c.far];
  const proj = Float64Array.from([
    n / r, 0, 0, 0,
    0, n / t, 0, 0,
    0, 0, -(fa + n) / (fa - n), -1,
    0, 0, (-2 * fa * n) / (fa - n), 0,
  ]);
  const toWgpu = Float64Array.from([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0.5, 0, 0, 0, 0.5, 1]);
  return mul(toWgpu, mul(proj, view));
}

// ---- hex grid (format/src/grid.rs) ----

const SQRT3 = Math.sqrt(3);

export class HexGrid {
  originX: number;
  originY: number;
  constructor(readonly g: GridParams) {
    const w = g.groundMax[0] - g.groundMin[0];
    const strip = (g.nCols - 1) * 1.5 * g.cellSize;
    this.originX = g.groundMin[0] + (w - strip) / 2;
    this.originY = g.groundMin[1];
  }
  get count() {
    return this.g.nCols * this.g.nRows;
  }
  id(col: number, row: number): number | null {
    if (col < 0 || row < 0 || col >= this.g.nCols || row >= this.g.nRows) return null;
    return row * this.g.nCols + col;
  }
  private offset(col: number) {
    return ((col % 2) + 2) % 2 === 1 ? (SQRT3 * this.g.cellSize) / 2 : 0;
  }
  lattice(col: number, row: number): [number, number] {
    const c = this.g.cellSize;
    return [this.originX + col * 1.5 * c, this.originY + row * SQRT3 * c + this.offset(col)];
  }
  centre(id: number): [number, number] {
    return this.lattice(id % this.g.nCols, Math.floor(id / this.g.nCols));
  }
  private nearest(x: number, z: number, clamp: boolean): [number, number] {
    const c = this.g.cellSize;
    const cg = Math.floor((x - this.originX) / (1.5 * c));
    let best: [number, number] = [Infinity, Infinity];
    let bestD = Infinity;
    let lo = cg - 1,
      hi = cg + 2;
    if (clamp) {
      lo = Math.min(Math.max(lo, 0), this.g.nCols - 1);
      hi = Math.min(Math.max(hi, 0), this.g.nCols - 1);
    }
    for (let col = lo; col <= hi; col++) {
      const rg = Math.round((z - this.originY - this.offset(col)) / (SQRT3 * c));
      let rlo = rg - 1,
        rhi = rg + 1;
      if (clamp) {
        rlo = Math.min(Math.max(rlo, 0), this.g.nRows - 1);
        rhi = Math.min(Math.max(rhi, 0), this.g.nRows - 1);
      }
      for (let row = rlo; row <= rhi; row++) {
        const [cx, cz] = this.lattice(col, row);
        const d = (cx - x) ** 2 + (cz - z) ** 2;
        if (d < bestD || (d === bestD && (row < best[1] || (row === best[1] && col < best[0])))) {
          bestD = d;
          best = [col, row];
        }
      }
    }
    return best;
  }
  /** The cell of (x, z), as HexGrid::cell_at. */
  cellAt(x: number, z: number): number | null {
    if (!Number.isFinite(x) || !Number.isFinite(z)) return null;
    const [col, row] = this.nearest(x, z, false);
    const id = this.id(col, row);
    if (id !== null) return id;
    const g = this.g;
    if (x >= g.groundMin[0] && x <= g.groundMax[0] && z >= g.groundMin[1] && z <= g.groundMax[1]) {
      const [c2, r2] = this.nearest(x, z, true);
      return this.id(c2, r2);
    }
    return null;
  }
}

// ---- vertex records (player/src/vertex.rs) ----

export const MODEL_VERTEX = 36;
export const INSTANCE_RAW = 128;
export const PROXY_VERTEX = 60;
// matrices, eyes, counts, then the atlas rectangles (zero here: the viewer draws
// every proxy with a texture per view, counts.z = counts.w = 0).
// View slots of the proxy uniform (player vertex.rs PROXY_SLOTS, shader.wgsl): the
// player batches proxies up to this many views; this viewer fills the first
// MAX_VIEWS of a lone proxy.
export const PROXY_SLOTS = 64;
export const PROXY_UNIFORM = 96 * PROXY_SLOTS + 16;
export const GLOBALS = 224;

/** Inverse-transpose of the 3×3 part (columns), or the part itself when singular. */
export function normalMatrix(t: ArrayLike<number>): number[] {
  const a = [t[0], t[1], t[2], t[4], t[5], t[6], t[8], t[9], t[10]]; // columns
  const [a0, a1, a2, b0, b1, b2, c0, c1, c2] = a;
  const det = a0 * (b1 * c2 - b2 * c1) - b0 * (a1 * c2 - a2 * c1) + c0 * (a1 * b2 - a2 * b1);
  if (Math.abs(det) <= 1e-30) return a;
  // cofactor matrix / det = inverse-transpose (columns: cofactors of rows)
  return [
    (b1 * c2 - b2 * c1) / det, (b2 * c0 - b0 * c2) / det, (b0 * c1 - b1 * c0) / det,
    (a2 * c1 - a1 * c2) / det, (a0 * c2 - a2 * c0) / det, (a1 * c0 - a0 * c1) / det,
    (a1 * b2 - a2 * b1) / det, (a2 * b0 - a0 * b2) / det, (a0 * b1 - a1 * b0) / det,
  ];
}

/** InstanceRaw::new into `dv` at `o`. */
export function writeInstance(dv: DataView, o: number, t: ArrayLike<number>, tint: ArrayLike<number>) {
  for (let i = 0; i < 16; i++) dv.setFloat32(o + 4 * i, t[i], true);
  const n = normalMatrix(t);
  for (let c = 0; c < 3; c++) {
    for (let r = 0; r < 3; r++) dv.setFloat32(o + 64 + 16 * c + 4 * r, n[3 * c + r], true);
    dv.setFloat32(o + 64 + 16 * c + 12, 0, true);
  }
  dv.setFloat32(o + 112, tint[0], true);
  dv.setFloat32(o + 116, tint[1], true);
  dv.setFloat32(o + 120, tint[2], true);
  dv.setFloat32(o + 124, 1, true);
}

/** A model's ModelVertex buffer (36 B per vertex, uv 0). */
export function modelVertices(m: Base["models"][number]): ArrayBuffer {
  const buf = new ArrayBuffer(Math.max(MODEL_VERTEX * m.vertexCount, MODEL_VERTEX));
  const dv = new DataView(buf);
  for (let v = 0; v < m.vertexCount; v++) {
    const o = MODEL_VERTEX * v;
    for (let k = 0; k < 3; k++) {
      dv.setFloat32(o + 4 * k, m.positions[3 * v + k], true);
      dv.setFloat32(o + 12 + 4 * k, m.normals[3 * v + k], true);
    }
    for (let k = 0; k < 4; k++) dv.setUint8(o + 24 + k, m.colours[4 * v + k]);
    if (m.uvs) {
      dv.setFloat32(o + 28, m.uvs[2 * v], true);
      dv.setFloat32(o + 32, m.uvs[2 * v + 1], true);
    }
  }
  return buf;
}

/** The ground rectangle (format::scene::Ground::mesh), de-indexed: 6 ModelVertex. */
export function groundVertices(g: GridParams): ArrayBuffer {
  const [x0, z0] = g.groundMin;
  const [x1, z1] = g.groundMax;
  const p = [
    [x0, z0],
    [x0, z1],
    [x1, z1],
    [x0, z0],
    [x1, z1],
    [x1, z0],
  ];
  const buf = new ArrayBuffer(6 * MODEL_VERTEX);
  const dv = new DataView(buf);
  p.forEach(([x, z], i) => {
    const o = i * MODEL_VERTEX;
    dv.setFloat32(o, x, true);
    dv.setFloat32(o + 4, 0, true);
    dv.setFloat32(o + 8, z, true);
    dv.setFloat32(o + 16, 1, true);
    [124, 132, 104, 255].forEach((c, k) => dv.setUint8(o + 24 + k, c)); // format::shading::GROUND
  });
  return buf;
}

/** How many vertices `proxyVertices` writes for `p`. */
export function proxyVertexCount(p: Proxy): number {
  let count = 0;
  if (p.kind === 4 && p.layers && p.views.length > 0) count += 6 * p.layers.layers.length;
  for (const m of p.members) count += m.triangles.length;
  return count;
}

/** A proxy's world-space triangle list (player/src/bake.rs `prepare_cell`), written
 * into `data` when given (at least `proxyVertexCount(p)` × PROXY_VERTEX bytes, e.g. a
 * GPU buffer mapped at creation: no copy), else into a new buffer. */
export function proxyVertices(base: Base, p: Proxy, into?: ArrayBuffer): { data: ArrayBuffer; count: number; min: number[]; max: number[] } {
  const count = proxyVertexCount(p);
  const data = into ?? new ArrayBuffer(Math.max(count, 1) * PROXY_VERTEX);
  const dv = new DataView(data);
  const min = [Infinity, Infinity, Infinity];
  const max = [-Infinity, -Infinity, -Infinity];
  let at = 0;
  const put = (pos: number[], n: number[], albedo: ArrayLike<number>, tint: ArrayLike<number>, mask: number, cen: number[], kind: number) => {
    const o = at * PROXY_VERTEX;
    for (let k = 0; k < 3; k++) {
      dv.setFloat32(o + 4 * k, pos[k], true);
      dv.setFloat32(o + 12 + 4 * k, n[k], true);
      dv.setFloat32(o + 28 + 4 * k, tint[k], true);
      dv.setFloat32(o + 44 + 4 * k, cen[k], true);
      min[k] = Math.min(min[k], pos[k]);
      max[k] = Math.max(max[k], pos[k]);
    }
    for (let k = 0; k < 4; k++) dv.setUint8(o + 24 + k, albedo[k]);
    dv.setUint32(o + 40, mask >>> 0, true);
    dv.setUint32(o + 56, kind, true);
    at++;
  };
  if (p.kind === 4 && p.layers && p.views.length > 0) {
    const eye = p.views[0].eye;
    const rays = p.layers.cornerRays;
    const axis = norm([0, 1, 2].map((k) => rays[0][k] + rays[1][k] + rays[2][k] + rays[3][k]));
    const nAxis = axis.map((x) => -x);
    for (const l of p.layers.layers) {
      const c = rays.map((r) => [0, 1, 2].map((k) => eye[k] + l.depth * r[k]));
      const cen = [0, 1, 2].map((k) => 0.25 * (c[0][k] + c[1][k] + c[2][k] + c[3][k]));
      const mask = l.lo | (l.hi << 8);
      for (const k of [0, 3, 2, 0, 2, 1]) put(c[k], nAxis, [255, 255, 255, 255], [1, 1, 1], mask, cen, 4);
    }
  }
  const defMask = p.views.length === 0 ? 0 : 1;
  // The members' triangles, written straight into typed views of the buffer (the
  // same values `put` writes: no arrays per vertex; ≈ 10× faster on park-2m cells).
  const f32 = new Float32Array(data);
  const u32 = new Uint32Array(data);
  const u8 = new Uint8Array(data);
  const W = PROXY_VERTEX / 4;
  for (const m of p.members) {
    const inst = base.instances[m.instance];
    const model = base.models[inst.model];
    const P = model.positions;
    const N = model.normals;
    const C = model.colours;
    const t = Float64Array.from(inst.transform);
    const nm = Float64Array.from(normalMatrix(t));
    const tint = inst.tint;
    const textured = model.uvs && model.texture !== null;
    const tri = m.triangles;
    const masks = p.kind === 3 ? (m.masks ?? []) : null;
    const w = new Float64Array(9);
    for (let k = 0; k < tri.length / 3; k++) {
      const mask = (masks ? masks[k] ?? 0 : defMask) >>> 0;
      for (let j = 0; j < 3; j++) {
        const v = tri[3 * k + j];
        const x = P[3 * v];
        const y = P[3 * v + 1];
        const z = P[3 * v + 2];
        w[3 * j] = Math.fround(t[0] * x + t[4] * y + t[8] * z + t[12]);
        w[3 * j + 1] = Math.fround(t[1] * x + t[5] * y + t[9] * z + t[13]);
        w[3 * j + 2] = Math.fround(t[2] * x + t[6] * y + t[10] * z + t[14]);
      }
      const cx = (w[0] + w[3] + w[6]) / 3;
      const cy = (w[1] + w[4] + w[7]) / 3;
      const cz = (w[2] + w[5] + w[8]) / 3;
      for (let j = 0; j < 3; j++) {
        const v = tri[3 * k + j];
        const o = at * W;
        for (let q = 0; q < 3; q++) {
          const c = w[3 * j + q];
          f32[o + q] = c;
          if (c < min[q]) min[q] = c;
          if (c > max[q]) max[q] = c;
        }
        const a = N[3 * v];
        const b = N[3 * v + 1];
        const c = N[3 * v + 2];
        const nx = nm[0] * a + nm[3] * b + nm[6] * c;
        const ny = nm[1] * a + nm[4] * b + nm[7] * c;
        const nz = nm[2] * a + nm[5] * b + nm[8] * c;
        const l = Math.sqrt(nx * nx + ny * ny + nz * nz);
        const s = l > 0 ? l : 1;
        f32[o + 3] = nx / s;
        f32[o + 4] = ny / s;
        f32[o + 5] = nz / s;
        if (textured) u8.set(vertexAlbedo(C.subarray(4 * v, 4 * v + 4), base.textures[model.texture!], model.uvs![2 * v], model.uvs![2 * v + 1]), 4 * o + 24);
        else {
          u8[4 * o + 24] = C[4 * v];
          u8[4 * o + 25] = C[4 * v + 1];
          u8[4 * o + 26] = C[4 * v + 2];
          u8[4 * o + 27] = C[4 * v + 3];
        }
        f32[o + 7] = tint[0];
        f32[o + 8] = tint[1];
        f32[o + 9] = tint[2];
        u32[o + 10] = mask;
        f32[o + 11] = cx;
        f32[o + 12] = cy;
        f32[o + 13] = cz;
        u32[o + 14] = p.kind;
        at++;
      }
    }
  }
  return { data, count, min, max };
}

// ---- albedo textures (format/src/albedo.rs, format/src/srgb.rs) ----

const srgbToLinear = (c: number) => {
  const x = c / 255;
  return x <= 0.04045 ? x / 12.92 : ((x + 0.055) / 1.055) ** 2.4;
};
const linearToSrgb8 = (v: number) => {
  const x = Math.min(Math.max(v, 0), 1);
  const e = x <= 0.0031308 ? x * 12.92 : 1.055 * x ** (1 / 2.4) - 0.055;
  return Math.round(e * 255);
};

function wrapTexel(mode: number, i: number, n: number): number {
  if (mode === 0) return ((i % n) + n) % n;
  if (mode === 2) return Math.min(Math.max(i, 0), n - 1);
  const m = ((i % (2 * n)) + 2 * n) % (2 * n);
  return m < n ? m : 2 * n - 1 - m;
}

/** Texture::sample: bilinear in linear light, texel centres at +0.5. */
export function sampleAlbedo(t: AlbedoTexture, u: number, v: number): number[] {
  if (!Number.isFinite(u) || !Number.isFinite(v)) return [1, 1, 1];
  const x = u * t.width - 0.5;
  const y = v * t.height - 0.5;
  const [x0, y0] = [Math.floor(x), Math.floor(y)];
  const [fx, fy] = [Math.fround(x - x0), Math.fround(y - y0)];
  const texel = (i: number, j: number) => {
    const o = (wrapTexel(t.wrap[1], j, t.height) * t.width + wrapTexel(t.wrap[0], i, t.width)) * 4;
    return [0, 1, 2].map((k) => srgbToLinear(t.rgba[o + k]));
  };
  const lerp = (a: number[], b: number[], f: number) => a.map((x, k) => x + (b[k] - x) * f);
  return lerp(lerp(texel(x0, y0), texel(x0 + 1, y0), fx), lerp(texel(x0, y0 + 1), texel(x0 + 1, y0 + 1), fx), fy);
}

/** AlbedoMap::vertex_albedo: a textured vertex's colour × its texture, sRGB8. */
export function vertexAlbedo(c: ArrayLike<number>, t: AlbedoTexture, u: number, v: number): number[] {
  const s = sampleAlbedo(t, u, v);
  return [0, 1, 2].map((k) => linearToSrgb8(srgbToLinear(c[k]) * s[k])).concat([255]);
}
