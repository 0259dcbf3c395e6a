// The web build (target/web, scripts/build-web.sh) in a real browser: Debian's chromium,
// headless, with WebGPU on its own software adapter (SwiftShader), driven by puppeteer-core.
//
//   node tests/web/run.mjs --web target/web --native NATIVE.json --out DIR
//
// 1. The browser has a WebGPU adapter (else this fails saying so: no test is skipped).
// 2. A full ACMM run of the demo scene in the page (`?steps=all`) reports depth maps that
//    score like the native run's: NATIVE.json is `mvscope eval`'s eval.json of
//    `mvscope run` on the same demo scene; within 1% and 2% must agree within TOLERANCE.
// 3. A screenshot after `?steps=N&map=depth`: the page title becomes "mvscope: done", and the
//    depth map is the whole map (inside its pane) framed at its aspect, coloured.
// It writes the screenshots, the reports and the timings (wasm size, first frame, run time)
// to DIR/web.json. Console errors of the page (GPU validation errors, panics) fail the run.

import puppeteer from "puppeteer-core";
import http from "node:http";
import fs from "node:fs";
import path from "node:path";
import os from "node:os";
import zlib from "node:zlib";

// The Chromium flags, in one place. `--enable-unsafe-webgpu` gives WebGPU (compute included)
// where the GPU is not on the browser's allow list, here SwiftShader's software adapter; the
// Vulkan/SwiftShader/ANGLE ones make the canvas show in screenshots; the rest keep a
// headless browser on a machine without a network quiet.
export const CHROMIUM_FLAGS = [
  "--headless=new",
  "--no-sandbox",
  "--enable-unsafe-webgpu",
  "--enable-features=Vulkan",
  "--use-vulkan=swiftshader",
  "--use-angle=vulkan",
  "--disable-background-networking",
  "--disable-component-update",
  "--disable-sync",
  "--disable-quic",
  "--no-first-run",
];

// The demo the tests run: small, so that SwiftShader runs it in minutes.
const DEMO = { size: "96x72", views: 3 };
// Browser and native runs differ in the devices' f32 rounding (SwiftShader against lavapipe)
// and in the scene (generated in the page; written to files and read back natively, its
// cameras rounded to the text files' digits): measured 1.25 points apart within 1% and 0.63
// within 2% on this demo (README, "In the browser"), so 3 points apart is a miss.
const TOLERANCE = 0.03;

function args() {
  const a = process.argv.slice(2);
  const get = (k, d) => {
    const i = a.indexOf(k);
    return i >= 0 ? a[i + 1] : d;
  };
  return {
    web: get("--web", "target/web"),
    native: get("--native", null),
    out: get("--out", "target/web-test"),
    browser: get("--browser", "/usr/bin/chromium"),
    minutes: Number(get("--minutes", "20")),
  };
}

const TYPES = {
  ".html": "text/html",
  ".js": "text/javascript",
  ".wasm": "application/wasm",
  ".svg": "image/svg+xml",
};

export function serve(folder) {
  const dir = path.resolve(folder);
  return new Promise((resolve) => {
    const server = http.createServer((req, res) => {
      const url = new URL(req.url, "http://localhost");
      if (url.pathname === "/probe.html") {
        res.writeHead(200, { "content-type": "text/html" });
        res.end("<!DOCTYPE html><title>probe</title>");
        return;
      }
      const file = path.join(dir, url.pathname === "/" ? "index.html" : url.pathname);
      if (!file.startsWith(dir) || !fs.existsSync(file)) {
        res.writeHead(404);
        res.end("not found");
        return;
      }
      res.writeHead(200, { "content-type": TYPES[path.extname(file)] ?? "application/octet-stream" });
      fs.createReadStream(file).pipe(res);
    });
    server.listen(0, "127.0.0.1", () => resolve(server));
  });
}

// A minimal PNG reader (8-bit RGB/RGBA, not interlaced: what Chromium writes).
function readPng(buffer) {
  let pos = 8;
  let width = 0, height = 0, channels = 0;
  const idat = [];
  while (pos < buffer.length) {
    const len = buffer.readUInt32BE(pos);
    const type = buffer.toString("ascii", pos + 4, pos + 8);
    const data = buffer.subarray(pos + 8, pos + 8 + len);
    if (type === "IHDR") {
      width = data.readUInt32BE(0);
      height = data.readUInt32BE(4);
      if (data[8] !== 8 || data[12] !== 0) throw new Error("unsupported PNG");
      channels = { 2: 3, 6: 4 }[data[9]];
    } else if (type === "IDAT") {
      idat.push(data);
    }
    pos += 12 + len;
  }
  const raw = zlib.inflateSync(Buffer.concat(idat));
  const stride = width * channels;
  const out = Buffer.alloc(height * stride);
  for (let y = 0; y < height; y++) {
    const f = raw[y * (stride + 1)];
    const line = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    for (let x = 0; x < stride; x++) {
      const a = x >= channels ? out[y * stride + x - channels] : 0;
      const b = y > 0 ? out[(y - 1) * stride + x] : 0;
      const c = x >= channels && y > 0 ? out[(y - 1) * stride + x - channels] : 0;
      let v = line[x];
      if (f === 1) v += a;
      else if (f === 2) v += b;
      else if (f === 3) v += (a + b) >> 1;
      else if (f === 4) {
        const p = a + b - c, pa = Math.abs(p - a), pb = Math.abs(p - b), pc = Math.abs(p - c);
        v += pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
      }
      out[y * stride + x] = v & 255;
    }
  }
  return { width, height, channels, pixel: (x, y) => out.subarray((y * width + x) * channels, (y * width + x) * channels + 3) };
}

// One page for everything: SwiftShader's GPU process serves one page well, and closing a
// page that holds a WebGPU device could take the others' with it.
export async function openPage(page, base, query, minutes, name, out) {
  const log = [];
  const errors = [];
  const debug = !!process.env.MVSCOPE_WEB_DEBUG;
  const onConsole = (m) => {
    const text = m.text();
    if (debug) console.log(`[${name}] ${text.slice(0, 300)}`);
    log.push(text);
    if (m.type() === "error") errors.push(text);
  };
  const onError = (e) => errors.push(String(e));
  page.on("console", onConsole);
  page.on("pageerror", onError);
  page.on("error", onError);
  const t0 = Date.now();
  await page.goto(`${base}/?${query}`);
  if (debug) console.log(`[${name}] loaded ${base}/?${query}`);
  // Polls the title (the page's main thread is busy with the run for long stretches).
  let title = "";
  while (Date.now() - t0 < minutes * 60_000) {
    await new Promise((r) => setTimeout(r, 2000));
    title = await page.evaluate(() => document.title).catch((e) => `unreadable: ${e.message}`);
    if (debug) console.log(`[${name}] ${((Date.now() - t0) / 1000).toFixed(0)} s: ${title}`);
    if (title === "mvscope: done" || title === "mvscope: failed") break;
  }
  const wall = (Date.now() - t0) / 1000;
  const shot = path.join(out, `${name}.png`);
  await page.screenshot({ path: shot });
  const line = log.find((l) => l.startsWith("mvscope report "));
  const first = log.find((l) => l.startsWith("mvscope first frame at "));
  if (title === "mvscope: failed") {
    const why = log.filter((l) => /could not start|failed|adapter/i.test(l)).join("\n");
    throw new Error(`${name}: the browser found no WebGPU adapter to run on:\n${why}\nflags: ${CHROMIUM_FLAGS.join(" ")}`);
  }
  if (title !== "mvscope: done" || !line) {
    throw new Error(`${name}: the page did not finish (title "${title}"); console:\n${log.join("\n")}`);
  }
  if (errors.length) {
    throw new Error(`${name}: errors in the page's console:\n${errors.join("\n")}`);
  }
  const report = JSON.parse(line.slice("mvscope report ".length));
  report.first_frame_ms = first ? Number(first.match(/([\d.]+) ms/)[1]) : null;
  report.page_seconds = wall;
  report.screenshot = shot;
  page.off("console", onConsole);
  page.off("pageerror", onError);
  page.off("error", onError);
  return report;
}

function share(evalJson, threshold) {
  const e = JSON.parse(fs.readFileSync(evalJson, "utf8"));
  const hit = e.depth.overall.relative.find(([t]) => Math.abs(t - threshold) < 1e-9);
  if (!hit) throw new Error(`${evalJson}: no share at ${threshold}`);
  return hit[1];
}

async function main() {
  const a = args();
  fs.mkdirSync(a.out, { recursive: true });
  const server = await serve(a.web);
  const base = `http://127.0.0.1:${server.address().port}`;
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), "mvscope-chromium-"));
  const browser = await puppeteer.launch({
    executablePath: a.browser,
    headless: true,
    protocolTimeout: 600_000,
    args: [...CHROMIUM_FLAGS, `--user-data-dir=${profile}`],
  });
  const results = { flags: CHROMIUM_FLAGS, wasm_bytes: fs.statSync(path.join(a.web, "mvscope_bg.wasm")).size };
  try {
    // 1. An adapter, or a message that says there is none: the page itself says so (its
    // title becomes "mvscope: failed" and the message is in its console).
    const page = await browser.newPage();
    await page.setViewport({ width: 1280, height: 800, deviceScaleFactor: 1 });

    // 2. A full ACMM run of the demo, scored like the native run.
    const run = await openPage(page, base,
      `steps=all&method=acmm&size=${DEMO.size}&views=${DEMO.views}&map=depth`, a.minutes, "acmm-run", a.out);
    results.run = run;
    results.adapter = run.adapter;
    console.log(`browser ACMM run: ${run.steps} steps in ${run.seconds.toFixed(1)} s, within 1% ${run.within_1.toFixed(4)}, within 2% ${run.within_2.toFixed(4)}; first frame at ${run.first_frame_ms} ms`);
    if (a.native) {
      const n1 = share(a.native, 0.01), n2 = share(a.native, 0.02);
      results.native = { within_1: n1, within_2: n2 };
      console.log(`native ACMM run: within 1% ${n1.toFixed(4)}, within 2% ${n2.toFixed(4)}`);
      for (const [what, b, n] of [["within 1%", run.within_1, n1], ["within 2%", run.within_2, n2]]) {
        if (!(Math.abs(b - n) <= TOLERANCE)) {
          throw new Error(`the browser's depth maps score ${what} ${b.toFixed(4)}, the native run's ${n.toFixed(4)}: more than ${TOLERANCE} apart`);
        }
      }
    }

    // 3. A screenshot after ?steps=N&map=depth: the whole map, framed at its aspect. The
    // pane's read-back is held back 12 frames (`hold`, as on a busy device): the page must
    // wait for it before it says it is done, or the picture shows no map.
    const shot = await openPage(page, base,
      `steps=40&map=depth&hold=12&size=${DEMO.size}&views=${DEMO.views}`, a.minutes, "steps-40-depth", a.out);
    results.screenshot = shot;
    const pane = shot.pane;
    if (!pane) throw new Error("the report has no pane geometry");
    const [px0, py0, px1, py1] = pane.rect;
    const [ix0, iy0, ix1, iy1] = pane.image;
    const [mw, mh] = pane.map;
    const aspect = (ix1 - ix0) / (iy1 - iy0);
    if (Math.abs(aspect / (mw / mh) - 1) > 0.02) {
      throw new Error(`the depth map is drawn at aspect ${aspect.toFixed(3)}, the map's is ${(mw / mh).toFixed(3)}`);
    }
    if (ix0 < px0 - 1 || iy0 < py0 - 1 || ix1 > px1 + 1 || iy1 > py1 + 1) {
      throw new Error(`the depth map ${pane.image} is not wholly inside its pane ${pane.rect}`);
    }
    if ((ix1 - ix0) < 0.9 * (px1 - px0) && (iy1 - iy0) < 0.9 * (py1 - py0)) {
      throw new Error(`the depth map ${pane.image} does not fill its pane ${pane.rect} along either side`);
    }
    // The pixels inside the map are the map's colours, not the pane's background.
    const png = readPng(fs.readFileSync(shot.screenshot));
    let coloured = 0, total = 0;
    for (let y = Math.ceil(iy0) + 2; y < Math.floor(iy1) - 2; y += 3) {
      for (let x = Math.ceil(ix0) + 2; x < Math.floor(ix1) - 2; x += 3) {
        const [r, g, b] = png.pixel(x, y);
        total++;
        if (Math.max(r, g, b) - Math.min(r, g, b) > 40) coloured++;
      }
    }
    results.screenshot.coloured = coloured / total;
    if (coloured / total < 0.5) {
      throw new Error(`only ${(100 * coloured / total).toFixed(1)}% of the depth map's pixels are coloured in ${shot.screenshot}`);
    }
    console.log(`screenshot ${shot.screenshot}: map ${mw}x${mh} drawn at aspect ${aspect.toFixed(3)}, ${(100 * coloured / total).toFixed(0)}% coloured`);
  } finally {
    fs.writeFileSync(path.join(a.out, "web.json"), JSON.stringify(results, null, 2));
    await browser.close();
    server.close();
  }
  console.log(`web test passed (wasm ${(results.wasm_bytes / 1048576).toFixed(1)} MiB); ${path.join(a.out, "web.json")}`);
}

if (import.meta.url === `file://${path.resolve(process.argv[1])}`) {
  main().catch((e) => {
    console.error(`web test FAILED: ${e.message}`);
    if (process.env.MVSCOPE_WEB_DEBUG) console.error(e.stack, e.cause);
    process.exit(1);
  });
}
