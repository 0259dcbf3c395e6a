// Times the web page on a demo of a given size (README, "In the browser"):
//   node tests/web/time.mjs --web target/web --query "steps=all&method=acmm&size=320x240"
import puppeteer from "puppeteer-core";
import fs from "node:fs";
import os from "node:os";
import path from "node:path";
import { CHROMIUM_FLAGS, openPage, serve } from "./run.mjs";

const a = process.argv.slice(2);
const get = (k, d) => (a.indexOf(k) >= 0 ? a[a.indexOf(k) + 1] : d);
const web = get("--web", "target/web");
const query = get("--query", "steps=all&method=acmm&size=320x240");
const out = get("--out", "target/web-time");
fs.mkdirSync(out, { recursive: true });
const server = await serve(web);
const browser = await puppeteer.launch({
  executablePath: get("--browser", "/usr/bin/chromium"),
  headless: true,
  protocolTimeout: 3_600_000,
  args: [...CHROMIUM_FLAGS, `--user-data-dir=${fs.mkdtempSync(path.join(os.tmpdir(), "mvscope-"))}`],
});
try {
  const page = await browser.newPage();
  await page.setViewport({ width: 1280, height: 800, deviceScaleFactor: 1 });
  const r = await openPage(page, `http://127.0.0.1:${server.address().port}`, query, 60, "timed", out);
  console.log(JSON.stringify({ query, steps: r.steps, seconds: r.seconds, first_frame_ms: r.first_frame_ms, within_1: r.within_1, within_2: r.within_2 }));
} finally {
  await browser.close();
  server.close();
}
