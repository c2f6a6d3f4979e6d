// Drives the viewer (paper 000 §3.2 run-time streaming; packs per format/README.md)
// in Debian's headless Chromium (playwright-core; flags from ../shared/WEB.md) for
// tests/web.rs and the measurements of player/web/README.md
// (issue 33). Usage:
//   node test/drive.mjs shot URL OUT.png [timeout_s]   frame at a pose, once settled
//   node test/drive.mjs walk URL [timeout_s]            a ?path= walk to its end
// Prints one JSON line: the viewer's stats (window.hexbake.stats), the page-load
// time, the bytes the page downloaded, and for `walk` the cells the overlay showed.
import { chromium } from "playwright-core";

const [mode, url, a3, a4] = process.argv.slice(2);
const timeoutS = Number((mode === "shot" ? a4 : a3) ?? 120);
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM ?? "/usr/bin/chromium",
  args: [
    "--no-sandbox", "--disable-gpu-sandbox", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--enable-unsafe-webgpu", "--enable-unsafe-swiftshader", "--use-webgpu-adapter=swiftshader",
    "--enable-features=Vulkan",
  ],
});
let result;
try {
  const page = await browser.newPage({ deviceScaleFactor: 1, viewport: { width: 1400, height: 1000 } });
  const logs = [];
  page.on("console", (m) => logs.push(`${m.type()}: ${m.text()}`));
  page.on("pageerror", (e) => logs.push(`pageerror: ${e.message}`));
  let bytes = 0;
  page.on("response", async (r) => {
    const len = Number(r.headers()["content-length"] ?? 0);
    bytes += len;
  });
  const t0 = Date.now();
  await page.goto(url, { waitUntil: "load" });
  const loadMs = Date.now() - t0;
  const stats = () => page.evaluate(() => window.hexbake?.stats ?? null);
  const deadline = Date.now() + timeoutS * 1000;
  let s = null;
  const overlayCells = [];
  for (;;) {
    s = await stats();
    if (s?.error) break;
    if (mode === "walk") {
      const text = await page.locator("#overlay").textContent();
      const m = /cell (\d+|-)/.exec(text ?? "");
      if (m && overlayCells[overlayCells.length - 1] !== m[1]) overlayCells.push(m[1]);
      if (s?.walkDone) break;
    } else if (s?.settled && s.frames >= 5 && s.queuedUploads === 0) {
      // Two more frames after settling, as the native player draws 30.
      const f = s.frames;
      while ((await stats()).frames < f + 2) await page.waitForTimeout(20);
      break;
    }
    if (Date.now() > deadline) break;
    await page.waitForTimeout(mode === "walk" ? 50 : 100);
  }
  if (mode === "shot" && s && !s.error) await page.locator("#view").screenshot({ path: a3 });
  s = await stats();
  result = { mode, loadMs, responseBytes: bytes, stats: s, overlayCells, timedOut: Date.now() > deadline, logs: logs.slice(-20) };
} finally {
  await browser.close();
}
console.log(JSON.stringify(result));
process.exit(result.stats && !result.stats.error && !result.timedOut ? 0 : 1);
