// The browser's pack reader on the golden packs of tests/data (format/README.md
// "Compatibility policy": one per shipped version) and on hostile edits of them:
// every golden file decodes, and truncations and random byte edits give a PackError
// (or decode), never another exception. Run: npm test.
import { readFileSync } from "node:fs";
import { decodeBase, decodeCell, decodeIndex, decodeTextureBundle, decodeVertices, PackError, PackFile } from "../src/pack";

const data = new URL("../../../tests/data/", import.meta.url);
const read = (n: string) => new Uint8Array(readFileSync(new URL(n, data)));
let seed = 12345;
const rand = (n: number) => {
  seed = (seed * 1103515245 + 12345) >>> 0;
  return seed % n;
};
let failures = 0;
let checked = 0;
for (const v of [1, 2, 3, 4, 5]) {
  const base = decodeBase(new PackFile(`base-v${v}.pack`, read(`base-v${v}.pack`)));
  const kinds: [string, (f: PackFile) => unknown][] = [
    [`base-v${v}.pack`, decodeBase],
    [`index-v${v}.pack`, decodeIndex],
    [`cell-v${v}.pack`, (f) => decodeCell(f, base)],
  ];
  if (v >= 2) kinds.push([`group-v${v}.pack`, (f) => decodeCell(f, base)]);
  if (v >= 3) kinds.push([`cell-impostor-v${v}.pack`, (f) => decodeCell(f, base)]);
  for (const [name, decode] of kinds) {
    const bytes = read(name);
    decode(new PackFile(name, bytes)); // the golden file itself decodes
    for (let t = 0; t < 300; t++) {
      const b = new Uint8Array(bytes);
      let mutated = b;
      if (t % 3 === 0) mutated = b.subarray(0, rand(b.length));
      else for (let k = 0; k <= rand(4); k++) b[rand(b.length)] = rand(256);
      try {
        decode(new PackFile(name, mutated));
      } catch (e) {
        if (!(e instanceof PackError)) {
          failures++;
          console.error(`${name} edit ${t}: ${e}`);
        }
      }
      checked++;
    }
  }
}
// The derived files (format/README.md "Derived files for the browser"): the golden
// ones decode, and their edits give a PackError or decode.
const derived: [string, (name: string, b: Uint8Array) => unknown][] = [];
for (const p of ["cells-5.pack", "groups-1.pack"]) {
  derived.push([`web-v1/${p}.vertices`, decodeVertices], [`web-v1/${p}.textures`, decodeTextureBundle]);
}
for (const [name, decode] of derived) {
  const bytes = read(name);
  decode(name, bytes);
  for (let t = 0; t < 300; t++) {
    const b = new Uint8Array(bytes);
    let mutated = b;
    if (t % 3 === 0) mutated = b.subarray(0, rand(b.length));
    else for (let k = 0; k <= rand(4); k++) b[rand(Math.min(b.length, 64 + (t % 2) * b.length))] = rand(256);
    try {
      decode(name, mutated);
    } catch (e) {
      if (!(e instanceof PackError)) {
        failures++;
        console.error(`${name} edit ${t}: ${e}`);
      }
    }
    checked++;
  }
}
console.log(`pack-fuzz: ${checked} edits of the golden packs and derived files, ${failures} non-PackError exceptions`);
process.exit(failures ? 1 : 0);
