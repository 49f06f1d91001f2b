#!/usr/bin/env node
// End-to-end test of `penumbra view` (docs/viewer.md): starts the server on a scene, drives
// the page in headless Chromium through puppeteer-core, and checks what a user sees:
//   1. the server starts and prints its address
//   2. the first frame is drawn and is not uniform
//   3. the final method's refinement finishes
//   4. dragging the light handle gives previews of the method the auto choice names (measured on
//      the device: preview_choice.h), shown on the page with its measured frame time; median
//      latency <= 100 ms on the first device, <= 3 x the first device's median on the others
//   5. the refined frame after the drag differs from step 3's and equals /api/frame's PNG
//      (progressive refinement == --frames K) within 2/255 on >= 99.9% of pixels
//   6. key `2` switches the final method
//   7. compare = reference, then `d`: a diff layer arrives
//   8. every scene file (with --scenes DIR and --scene-format FILE): each scene of DIR at 64x64
//      and a set of scene files generated from the format's own list of optional keys
//      (docs/scene-format.md's tables), each leaving one of them out (and one leaving out all):
//      the server serves it, a first frame is drawn, no page error, no error line (issue 32:
//      a camera without "up" once gave a black canvas)
//
//   node viewer_e2e.mjs --penumbra build/penumbra --scene scenes/bunny.json \
//        --chromium /usr/bin/chromium [--screenshots DIR] [--port 18421] [--web DIR] \
//        [--scenes scenes --scene-format docs/scene-format.md] [--devices cpu,gpu] [--every-scene-only]
//
// --devices: steps 1-7 once per device (`penumbra view --device D`), in order; the page must show
// the device. Step 8 runs on the first device.
// --every-scene-only: step 8 alone (CTest's viewer_e2e_scenes: it measures no latency, so it need
// not run alone on the machine as steps 1-7 do).
//
// Exit 0: pass; 77: skipped (puppeteer-core or Chromium missing); else: failed, with one
// line per failed check. `--penumbra mock_server.mjs` runs it against the mock server.

import { spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import zlib from 'node:zlib';

const SKIP = 77;
const argv = process.argv.slice(2);
const opt = (name, dflt) => { const i = argv.indexOf(name); return i >= 0 && i + 1 < argv.length ? argv[i + 1] : dflt; };
const penumbra = opt('--penumbra'), scene = opt('--scene'), chromium = opt('--chromium', '/usr/bin/chromium');
const shots = opt('--screenshots', null), port = opt('--port', '18421');
// --web DIR: serve the page from DIR (the source tree) instead of the copy compiled into the
// server, to test page edits without rebuilding penumbra. Only the three page files are
// intercepted; the API goes to the server untouched.
const webDir = opt('--web', null);
// Step 8's inputs: a folder of scene files, and the scene format's page whose tables list the
// optional keys.
const scenesDir = opt('--scenes', null), sceneFormat = opt('--scene-format', null);
const devices = opt('--devices', 'cpu').split(',').filter((d) => d);
const everySceneOnly = argv.includes('--every-scene-only');
if (!penumbra || !scene || (everySceneOnly && !(scenesDir && sceneFormat))) {
  console.error('usage: node viewer_e2e.mjs --penumbra PATH --scene PATH --chromium PATH [--screenshots DIR] ' +
    '[--scenes DIR --scene-format FILE [--every-scene-only]]');
  process.exit(2);
}

let puppeteer;
try { puppeteer = (await import('puppeteer-core')).default; }
catch (_) { console.log('SKIP: puppeteer-core is not installed (cd src/penumbra/viewer/e2e && npm ci)'); process.exit(SKIP); }
try { fs.accessSync(chromium, fs.constants.X_OK); }
catch (_) { console.log(`SKIP: no Chromium at ${chromium}`); process.exit(SKIP); }
if (shots) fs.mkdirSync(shots, { recursive: true });

const failures = [];
const fail = (msg) => { failures.push(msg); console.log(`FAIL: ${msg}`); };
const t0 = performance.now();
const secs = (since) => `${((performance.now() - since) / 1000).toFixed(2)} s`;
const median = (xs) => { const s = [...xs].sort((a, b) => a - b); const n = s.length; return n % 2 ? s[(n - 1) / 2] : (s[n / 2 - 1] + s[n / 2]) / 2; };

// ---- the server: started here, always killed at the end ------------------------------------
let server = null;
const serverLog = [];
// Ctrl-C (SIGINT) as a user would, SIGKILL when it has not exited within 3 s.
async function killServer() {
  const s = server;
  if (!s || s.exitCode !== null || s.signalCode !== null) return;
  const exited = new Promise((r) => s.once('exit', r));
  try { s.kill('SIGINT'); } catch (_) { /* gone */ }
  const t = setTimeout(() => { try { s.kill('SIGKILL'); } catch (_) { /* gone */ } }, 3000);
  await exited;
  clearTimeout(t);
}
process.on('exit', () => { if (server && server.exitCode === null) try { server.kill('SIGKILL'); } catch (_) { /* gone */ } });
for (const sig of ['SIGINT', 'SIGTERM']) process.on(sig, () => { killServer(); process.exit(1); });

function startServer(sceneFile = scene, extra = []) {
  serverLog.length = 0;
  return new Promise((resolve, reject) => {
    server = spawn(penumbra, ['view', sceneFile, '--no-browser', '--port', port, ...extra], { stdio: ['ignore', 'pipe', 'pipe'] });
    let out = '';
    const timer = setTimeout(() => reject(new Error('the server printed no "serving" line within 60 s')), 60000);
    const keep = (d) => { for (const l of String(d).split('\n')) if (l.trim()) { serverLog.push(l); if (serverLog.length > 40) serverLog.shift(); } };
    server.stdout.on('data', (d) => {
      keep(d);
      out += d;
      const m = out.match(/penumbra view: serving (http:\/\/\S+)/);
      if (m) { clearTimeout(timer); resolve(m[1]); }
    });
    server.stderr.on('data', keep);
    server.on('error', (e) => { clearTimeout(timer); reject(new Error(`cannot start ${penumbra}: ${e.message}`)); });
    server.on('exit', (code, sig) => { clearTimeout(timer); reject(new Error(`the server exited (${code ?? sig}) before serving`)); });
  });
}

// ---- in-page helpers -------------------------------------------------------------------------
const V = 'window.penumbraViewer';
// The final method's refinement of the current view is complete.
const refinedJS = `(() => { const v = ${V}; const f = v && v.lastMainFrame;
  return !!(f && v.state && f.kind === 'final' && f.frame === f.frames && f.generation === v.state.generation); })()`;

let browser = null, page = null;
let pageContext = '';  // step 8: the scene a page error belongs to
// JPEG: the page's screenshots for docs/viewer.md, a quarter of the PNG's size.
async function shot(name) {
  if (!shots) return;
  await page.screenshot({ path: path.join(shots, name), type: 'jpeg', quality: 85 });
}
async function waitFor(js, timeoutMs, what) {
  try { await page.waitForFunction(js, { timeout: timeoutMs, polling: 10 }); }
  catch (e) { throw new Error(`${what}: not within ${timeoutMs / 1000} s`); }
}

// A new page in the one browser (launched on first use), reporting its errors; with --web DIR
// its three files come from DIR.
async function openPage(url) {
  if (!browser) browser = await puppeteer.launch({
    executablePath: chromium, headless: true,
    args: ['--no-sandbox', '--disable-gpu', '--disable-dev-shm-usage', '--window-size=1280,800'],
  });
  if (page) await page.close().catch(() => {});
  page = await browser.newPage();
  await page.setViewport({ width: 1280, height: 800 });
  if (webDir) {
    const cdp = await page.createCDPSession();
    const files = { '/': 'index.html', '/index.html': 'index.html', '/viewer.js': 'viewer.js', '/viewer.css': 'viewer.css' };
    const types = { html: 'text/html; charset=utf-8', js: 'text/javascript; charset=utf-8', css: 'text/css; charset=utf-8' };
    await cdp.send('Fetch.enable', { patterns: [{ urlPattern: url }, { urlPattern: `${url}index.html` }, { urlPattern: `${url}viewer.js` }, { urlPattern: `${url}viewer.css` }] });
    cdp.on('Fetch.requestPaused', async ({ requestId, request }) => {
      const f = files[new URL(request.url).pathname];
      if (!f) return cdp.send('Fetch.continueRequest', { requestId }).catch(() => {});
      const body = fs.readFileSync(path.join(webDir, f)).toString('base64');
      await cdp.send('Fetch.fulfillRequest', { requestId, responseCode: 200, body,
        responseHeaders: [{ name: 'Content-Type', value: types[f.split('.').pop()] }, { name: 'Cache-Control', value: 'no-store' }] }).catch(() => {});
    });
    console.log(`        (the page comes from ${webDir}, not from the server)`);
  }
  page.on('pageerror', (e) => fail(`${pageContext}page error: ${String(e.message || e).split('\n')[0]}`));
}

// Steps 1-7 on `device`; returns step 4's median latency. `boundMs`: step 4's latency bound.
async function run(device, boundMs, withEveryScene) {
  // 1. server
  let t = performance.now();
  // lavapipe traces a few hundred thousand rays a second: the GPU session renders a small view
  // (its auto preview measures every method there, step 3b: 81 s at 96 x 96, 2026-12-06).
  const url = await startServer(scene, ['--device', device, ...(device === 'cpu' ? [] : ['--resolution', '64'])]);
  console.log(`[${device}] step 1 server: ${url} (${secs(t)})`);
  await openPage(url);

  // 2. first frame, not uniform
  t = performance.now();
  await page.goto(url, { waitUntil: 'domcontentloaded' });
  await waitFor(`${V} && ${V}.frameCount > 0`, 60000, 'step 2: first main frame');
  const stats = await page.evaluate(() => {
    const p = window.penumbraViewer.canvasPixels();
    let s = 0, s2 = 0; const seen = new Set();
    const n = p.width * p.height;
    for (let i = 0; i < n; i++) {
      const y = 0.2126 * p.data[4 * i] + 0.7152 * p.data[4 * i + 1] + 0.0722 * p.data[4 * i + 2];
      s += y; s2 += y * y; seen.add(p.data[4 * i] << 16 | p.data[4 * i + 1] << 8 | p.data[4 * i + 2]);
    }
    const mean = s / n;
    return { w: p.width, h: p.height, std: Math.sqrt(Math.max(0, s2 / n - mean * mean)), mean, colours: seen.size, frame: window.penumbraViewer.lastMainFrame };
  });
  console.log(`step 2 first frame: ${stats.frame.method} (${stats.frame.kind}) ${stats.w}x${stats.h}, luma mean ${stats.mean.toFixed(1)} std ${stats.std.toFixed(1)}, ${stats.colours} colours (${secs(t)})`);
  const shownDevice = await page.$eval('#device', (e) => e.textContent);
  console.log(`step 2 device shown: "${shownDevice}"`);
  if (!(device === 'cpu' ? shownDevice === 'CPU' : shownDevice.startsWith('GPU: ')))
    fail(`[${device}] step 2: the page shows the device as "${shownDevice}"`);
  if (!(stats.std > 5 && stats.colours > 32)) fail(`step 2: the first frame is (nearly) uniform: luma std ${stats.std.toFixed(2)}, ${stats.colours} colours`);

  // 3. refinement done
  t = performance.now();
  await waitFor(refinedJS, 120000, 'step 3: final refinement');
  const f3 = await page.evaluate(() => { const v = window.penumbraViewer; window.__e2eStep3 = v.canvasPixels(); return v.lastMainFrame; });
  console.log(`step 3 refined: ${f3.method} frame ${f3.frame}/${f3.frames} ${f3.width}x${f3.height} generation ${f3.generation} (${secs(t)})`);
  await shot('viewer-bunny.jpg');

  // 3b. the auto preview measures its candidates on this device while the view is still
  // (preview_choice.h): wait until it has, so the drag below previews with a measured choice.
  t = performance.now();
  let calib = null;
  for (;;) {
    const st = await page.evaluate(async () => (await (await fetch('/api/state')).json()));
    calib = st.status.calibration;
    if (st.status.phase === 'done' && calib) break;
    if (performance.now() - t > 180000) throw new Error('step 3b: the auto preview did not finish measuring within 180 s');
    await new Promise((r) => setTimeout(r, 250));
  }
  const measured = Object.entries(calib).filter(([, m]) => !m.failed && m.error != null);
  console.log(`[${device}] step 3b measured: ${measured.map(([n, m]) => `${n} ${m.light_ms.toFixed(0)}/${m.camera_ms.toFixed(0)} ms |dV| ${m.error.toFixed(3)}`).join(', ')} (${secs(t)})`);
  if (!measured.length) fail(`[${device}] step 3b: no candidate measured`);

  // 4. drag the light handle: 8 moves of 10 px, each timed from the page's pointermove to
  // the next preview frame of a newer generation drawn.
  t = performance.now();
  const h = await page.evaluate(() => window.penumbraViewer.lightHandle(0));
  if (!h) throw new Error('step 4: no light handle');
  const box = await page.$eval('#view', (c) => { const r = c.getBoundingClientRect(); return { l: r.left, t: r.top, r: r.right, b: r.bottom }; });
  if (!(h.x >= box.l && h.x <= box.r && h.y >= box.t && h.y <= box.b))
    throw new Error(`step 4: the light handle (${h.x.toFixed(0)}, ${h.y.toFixed(0)}) is outside the canvas`);
  await page.mouse.move(h.x, h.y);
  await page.mouse.down();
  const lat = [], methods = [], autos = [];
  for (let k = 1; k <= 8; k++) {
    const genBefore = await page.evaluate(() => window.penumbraViewer.lastMainFrame.generation);
    await page.mouse.move(h.x + 10 * k, h.y, { steps: 1 });
    const moveAt = await page.evaluate(() => window.penumbraViewer.lastLightMoveAt);
    await waitFor(`(() => { const f = ${V}.lastMainFrame; return f.kind === 'preview' && f.generation > ${genBefore} && f.drawnAt >= ${moveAt}; })()`,
      10000, `step 4: preview frame after move ${k}`);
    const f = await page.evaluate(() => window.penumbraViewer.lastMainFrame);
    lat.push(f.drawnAt - moveAt);
    methods.push(`${f.method}@${f.width}x${f.height}`);
    autos.push({ method: f.method, auto: f.auto, shown: await page.$eval('#auto-choice', (e) => (e.hidden ? '' : e.textContent)) });
  }
  await shot('viewer-preview.jpg');
  await page.mouse.up();
  const med = median(lat);
  console.log(`[${device}] step 4 drag: latencies ${lat.map((x) => x.toFixed(1)).join(' ')} ms, median ${med.toFixed(1)} ms (bound ${boundMs.toFixed(1)}); previews ${[...new Set(methods)].join(', ')}; page: "${autos[autos.length - 1].shown}" (${secs(t)})`);
  if (med > boundMs) fail(`[${device}] step 4: median light-drag latency ${med.toFixed(1)} ms > ${boundMs.toFixed(1)} ms`);
  // The previews are the auto choice's, which the frame and the page name with what it measured.
  for (const a of autos) {
    if (!a.auto || a.auto.method !== a.method || a.auto.move !== 'light' || a.auto.ms == null)
      fail(`[${device}] step 4: a preview of ${a.method} whose auto choice is ${JSON.stringify(a.auto)} (measured on the device?)`);
    else if (!a.shown.includes(`auto → ${a.method}`)) fail(`[${device}] step 4: the page shows "${a.shown}" for the auto choice ${a.method}`);
  }

  // 5. refined again: differs from step 3, equals /api/frame's PNG
  t = performance.now();
  await waitFor(refinedJS, 120000, 'step 5: final refinement after the drag');
  const cmp3 = await page.evaluate(() => {
    const a = window.__e2eStep3, b = window.penumbraViewer.canvasPixels();
    if (a.width !== b.width || a.height !== b.height) return { changed: 1, size: true };
    let changed = 0;
    for (let i = 0; i < a.width * a.height; i++) {
      const d = Math.max(Math.abs(a.data[4 * i] - b.data[4 * i]), Math.abs(a.data[4 * i + 1] - b.data[4 * i + 1]), Math.abs(a.data[4 * i + 2] - b.data[4 * i + 2]));
      if (d > 4) changed++;
    }
    return { changed: changed / (a.width * a.height) };
  });
  if (!(cmp3.changed > 0.002)) fail(`step 5: the refined frame after moving the light is the same as before (${(100 * cmp3.changed).toFixed(3)}% of pixels changed)`);
  const settings = await page.evaluate(async () => (await (await fetch('/api/state')).json()).settings);
  const tf = performance.now();
  const ref = await page.evaluate(async (s) => {
    const q = `method=${encodeURIComponent(s.final)}&spp=${s.spp}&frames=${s.frames}&format=png`;
    const r = await fetch(`/api/frame?${q}`);
    if (!r.ok) return { error: `GET /api/frame?${q}: HTTP ${r.status} ${await r.text()}` };
    const bmp = await createImageBitmap(await r.blob(), { premultiplyAlpha: 'none', colorSpaceConversion: 'none' });
    const c = new OffscreenCanvas(bmp.width, bmp.height);
    const cx = c.getContext('2d');
    cx.drawImage(bmp, 0, 0);
    const png = cx.getImageData(0, 0, bmp.width, bmp.height);
    const mine = window.penumbraViewer.canvasPixels();
    if (png.width !== mine.width || png.height !== mine.height) return { error: `/api/frame is ${png.width}x${png.height}, the canvas ${mine.width}x${mine.height}` };
    let bad = 0, maxd = 0;
    for (let i = 0; i < png.width * png.height; i++) {
      let d = 0;
      for (let c2 = 0; c2 < 4; c2++) d = Math.max(d, Math.abs(png.data[4 * i + c2] - mine.data[4 * i + c2]));
      if (d > 2) bad++;
      maxd = Math.max(maxd, d);
    }
    return { query: q, match: 1 - bad / (png.width * png.height), maxd };
  }, settings);
  if (ref.error) fail(`step 5: ${ref.error}`);
  else {
    console.log(`step 5 refined after drag: ${(100 * cmp3.changed).toFixed(2)}% of pixels changed; /api/frame?${ref.query} in ${secs(tf)}: ${(100 * ref.match).toFixed(3)}% within 2/255 (max diff ${ref.maxd}) (${secs(t)})`);
    if (settings.final !== 'reference') fail(`step 5: the final method is ${settings.final}, expected the default reference`);
    if (!(ref.match >= 0.999)) fail(`step 5: the refined canvas matches /api/frame on ${(100 * ref.match).toFixed(3)}% of pixels (< 99.9%), max diff ${ref.maxd}`);
  }

  // 6. key 2: the second method in the list becomes the final method
  t = performance.now();
  const second = await page.evaluate(() => { document.activeElement && document.activeElement.blur(); return window.penumbraViewer.methods.filter((m) => m.available !== false)[1].name; });
  const count6 = await page.evaluate(() => window.penumbraViewer.frameCount);
  await page.keyboard.press('2');
  await waitFor(`${V}.lastMainFrame.method === ${JSON.stringify(second)} && ${V}.frameCount > ${count6}`, 120000, `step 6: a frame of ${second}`);
  const f6 = await page.evaluate(() => window.penumbraViewer.lastMainFrame);
  const sel6 = await page.$eval('#final-method', (s) => s.value);
  console.log(`step 6 key 2: ${f6.method} (${f6.kind}) frame ${f6.frame}/${f6.frames} drawn, final select = ${sel6} (${secs(t)})`);
  if (sel6 !== second) fail(`step 6: the final select shows ${sel6}, expected ${second}`);

  // 7. compare with the reference: split view, then `d` for the heat map
  t = performance.now();
  await page.select('#compare-method', 'reference');
  const compared = `(() => { const v = ${V}, f = v.lastMainFrame, c = v.layers.compare;
    return !!(c && f.kind === 'final' && f.frame === f.frames && c.generation === f.generation && f.generation === v.state.generation); })()`;
  await waitFor(compared, 120000, 'step 7: a compare layer of the current view');
  await shot('viewer-split.jpg');
  const tc = secs(t);
  await page.evaluate(() => document.activeElement && document.activeElement.blur());
  await page.keyboard.press('d');
  await waitFor(`(() => { const v = ${V}, d = v.layers.diff; return !!(d && d.generation === v.lastMainFrame.generation); })()`, 120000, 'step 7: a diff layer');
  await page.waitForFunction(() => !document.getElementById('diff-toggle') || document.getElementById('diff-toggle').checked, { timeout: 5000 }).catch(() => fail('step 7: `d` did not switch to the diff view'));
  await new Promise((r) => setTimeout(r, 100)); // let the diff draw before the screenshot
  await shot('viewer-diff.jpg');
  const d7 = await page.evaluate(() => ({ diff: window.penumbraViewer.layers.diff, legend: document.getElementById('legend').textContent }));
  console.log(`step 7 compare: compare layer after ${tc}; diff ${d7.diff.width}x${d7.diff.height} mean |ΔV| ${d7.diff.mean_dv}, legend "${d7.legend}" (${secs(t)})`);
  if (d7.diff.mean_dv == null) fail('step 7: the diff layer has no mean_dv');

  if (scenesDir && sceneFormat && withEveryScene) await everyScene();
  return med;
}

// ---- step 8: every scene file ------------------------------------------------------------------
// The rows `| \`key\` | ... |` of the first table after `heading` in the scene format's page, as
// arrays of cells (escaped pipes kept).
function tableAfter(md, heading) {
  const start = md.indexOf(heading);
  if (start < 0) throw new Error(`${sceneFormat}: no "${heading}"`);
  const rows = [];
  let inTable = false;
  for (const line of md.slice(start + heading.length).split('\n')) {
    if (line.startsWith('|')) {
      inTable = true;
      const cells = line.split(/(?<!\\)\|/).slice(1, -1).map((c) => c.trim());
      const m = cells[0].match(/^`([a-z_]+)`$/);
      if (m) rows.push([m[1], ...cells.slice(1)]);
    } else if (inTable) break;
  }
  if (!rows.length) throw new Error(`${sceneFormat}: no table of keys after "${heading}"`);
  return rows;
}
// The optional keys the format lists: where, key, and for a light the types that have it.
function optionalKeys(md) {
  const out = [];
  for (const [key, , required] of tableAfter(md, '## Top level')) if (!required.startsWith('yes')) out.push({ where: 'top', key });
  for (const [key, , dflt] of tableAfter(md, '## `camera`')) if (dflt !== 'required') out.push({ where: 'camera', key });
  for (const [key, types, , dflt] of tableAfter(md, '## `lights`')) {
    if (dflt === 'required') continue;
    const all = ['rect', 'disk', 'ellipsoid', 'sphere'];
    out.push({ where: 'light', key, types: types === 'all' ? all : all.filter((t) => types.includes(t)) });
  }
  for (const [key] of tableAfter(md, '### Common keys')) out.push({ where: 'object', key });
  for (const [key] of tableAfter(md, '`material` (only the given fields')) out.push({ where: 'material', key });
  return out;
}
// A w x h RGBA PNG (8-bit, unfiltered rows): an albedo texture with a disc of alpha, so that
// leaving out alpha_texture keeps a valid mask.
function writePng(file, w, h) {
  const crcTable = Array.from({ length: 256 }, (_, n) => {
    let c = n;
    for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
    return c >>> 0;
  });
  const crc = (buf) => { let c = 0xffffffff; for (const b of buf) c = crcTable[(c ^ b) & 0xff] ^ (c >>> 8); return (c ^ 0xffffffff) >>> 0; };
  const chunk = (type, data) => {
    const out = Buffer.alloc(12 + data.length);
    out.writeUInt32BE(data.length, 0); out.write(type, 4, 'latin1'); data.copy(out, 8);
    out.writeUInt32BE(crc(out.subarray(4, 8 + data.length)), 8 + data.length);
    return out;
  };
  const ihdr = Buffer.alloc(13);
  ihdr.writeUInt32BE(w, 0); ihdr.writeUInt32BE(h, 4); ihdr[8] = 8; ihdr[9] = 6;  // 8-bit RGBA
  const raw = Buffer.alloc(h * (1 + 4 * w));
  for (let y = 0; y < h; y++) for (let x = 0; x < w; x++) {
    const o = y * (1 + 4 * w) + 1 + 4 * x, inside = Math.hypot(x + 0.5 - w / 2, y + 0.5 - h / 2) < w * 0.4;
    raw[o] = 200; raw[o + 1] = 160 + (x % 2) * 40; raw[o + 2] = 40; raw[o + 3] = inside ? 255 : 0;
  }
  fs.writeFileSync(file, Buffer.concat([Buffer.from([137, 80, 78, 71, 13, 10, 26, 10]), chunk('IHDR', ihdr),
    chunk('IDAT', zlib.deflateSync(raw)), chunk('IEND', Buffer.alloc(0))]));
}
// A scene that gives every key the format lists (the lights one of each type), 48 x 48: the
// generated files each leave one optional key out of it. A key the format lists that this
// scene does not give fails the test: the generated set follows the format's page.
function fullScene(dir) {
  writePng(path.join(dir, 'leaf.png'), 16, 16);
  const glass = path.resolve(scenesDir, 'assets', 'stained_glass.png');
  return {
    description: 'every optional key given (viewer_e2e.mjs step 8)',
    camera: { eye: [0.3, 2.4, 3.4], target: [0, 0.3, 0], up: [0, 1, 0], fov_y: 40, resolution: [48, 48], samples_per_pixel: 1 },
    lights: [
      { type: 'rect', center: [-0.6, 2.6, 0.4], normal: [0.2, -1, -0.1], u: [1, 0, 0], size: [0.8, 0.6], radiance: [4, 4, 4], radiance_texture: glass },
      { type: 'disk', center: [0.7, 2.4, 0], normal: [0, -1, 0.2], u: [1, 0, 0], radius: 0.3, radiance: [3, 3, 3] },
      { type: 'ellipsoid', center: [0, 2.7, -0.6], normal: [0, -1, 0], u: [1, 0, 0], radii: [0.3, 0.2, 0.1], radiance: [3, 3, 3] },
      { type: 'sphere', center: [0.9, 2.2, 0.9], radius: 0.2, radiance: [2, 2, 2] },
    ],
    objects: [
      { shape: 'plane', size: [4, 4] },
      { shape: 'box', size: [0.6, 0.6, 0.6], name: 'card', scale: [1, 1, 0.2], rotate: [0, 30, 0], translate: [0, 0.35, 0],
        material: { albedo: [0.9, 0.8, 0.7], opacity: 1, two_sided: true, albedo_texture: 'leaf.png', alpha_texture: 'leaf.png',
                    alpha_mode: 'mask', alpha_cutoff: 0.5 } },
      { shape: 'sphere', radius: 0.2, segments: 16, translate: [-0.8, 0.2, 0.5] },
    ],
    methods: { pcss: { blocker_samples: 8 } },
    animation: { frames: 2, camera: { fov_y: [{ frame: 0, value: 40 }, { frame: 1, value: 42 }] } },
  };
}
// [name, document] of every generated scene: one per optional key left out (a light key once
// per light type that has it), and one leaving out all of them.
function generatedScenes(dir) {
  const full = fullScene(dir);
  const keys = optionalKeys(fs.readFileSync(sceneFormat, 'utf8'));
  // What holds key k in `doc`: the document, its camera, the textured card or its material, or
  // each light of a type that has the key.
  const holders = (doc, k) => (k.where === 'top' ? [doc] : k.where === 'camera' ? [doc.camera]
    : k.where === 'object' ? [doc.objects[1]] : k.where === 'material' ? [doc.objects[1].material]
      : doc.lights.filter((l) => k.types.includes(l.type))).filter(Boolean);
  const out = [];
  for (const k of keys) {
    const where = holders(full, k);
    if (!where.length || where.some((h) => !(k.key in h)))
      throw new Error(`${sceneFormat} lists the optional key ${k.where}.${k.key}, which the full scene of viewer_e2e.mjs does not give: add it`);
    where.forEach((_, i) => {
      const doc = structuredClone(full);
      const h = holders(doc, k)[i];
      delete h[k.key];
      out.push([`no-${k.where === 'light' ? `${h.type}-light` : k.where}-${k.key}`, doc]);
    });
  }
  const bare = structuredClone(full);
  for (const k of keys) for (const h of holders(bare, k)) delete h[k.key];
  for (const o of bare.objects) for (const k of keys) if (k.where === 'object') delete o[k.key];
  delete bare.objects[2].segments;  // the shapes' own optional key
  out.push(['bare', bare]);
  return out;
}
async function everyScene() {
  const t = performance.now();
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'penumbra-e2e-'));
  try {
    const cases = fs.readdirSync(scenesDir).filter((f) => f.endsWith('.json')).sort()
      .map((f) => ({ name: f, file: path.resolve(scenesDir, f), args: ['--resolution', '64'] }));
    for (const [name, doc] of generatedScenes(dir)) {
      const file = path.join(dir, `${name}.json`);
      fs.writeFileSync(file, JSON.stringify(doc, null, 1));
      cases.push({ name, file, args: [] });
    }
    const times = [];
    for (const c of cases) {
      const t1 = performance.now();
      pageContext = `step 8: ${c.name}: `;
      try {
        await killServer();
        const url = await startServer(c.file, [...c.args, '--idle-ms', '60000']);
        await page.goto(url, { waitUntil: 'domcontentloaded' });
        await waitFor(`${V} && ${V}.frameCount > 0`, 60000, 'a first frame');
        const err = await page.$eval('#error-line', (e) => (e.hidden ? '' : e.textContent));
        if (err) fail(`${pageContext}the page shows an error: ${err}`);
        times.push(performance.now() - t1);
      } catch (e) {
        fail(`${pageContext}${String(e.message || e).split('\n')[0]}`);
        if (serverLog.length) console.log(`  server output (last lines):\n    ${serverLog.slice(-5).join('\n    ')}`);
      }
    }
    pageContext = '';
    console.log(`step 8 every scene: ${cases.length} scene files (${cases.length - times.length} failed), ` +
      `a first frame each in at most ${(Math.max(0, ...times) / 1000).toFixed(2)} s (${secs(t)})`);
  } finally {
    await killServer();
    fs.rmSync(dir, { recursive: true, force: true });
  }
}

let code = 0;
try {
  // The first device's median drag latency bounds the others' (3x): lavapipe runs "GPU" frames
  // on the same CPU cores.
  let firstMedian = null;
  if (everySceneOnly) {
    await openPage(await startServer(scene, ['--resolution', '64']));
    await everyScene();
  }
  else for (let i = 0; i < devices.length; i++) {
    const bound = i === 0 ? 100 : 3 * firstMedian;
    const med = await run(devices[i], bound, i === 0);
    if (i === 0) firstMedian = med;
    await killServer();
  }
}
catch (e) {
  fail(String(e.message || e).split('\n')[0]);
  if (serverLog.length) console.log(`server output (last lines):\n  ${serverLog.slice(-10).join('\n  ')}`);
}
finally {
  if (browser) await browser.close().catch(() => {});
  await killServer();
}
if (failures.length) { code = 1; console.log(`viewer e2e: FAILED (${failures.length} check${failures.length > 1 ? 's' : ''}) in ${secs(t0)}`); }
else console.log(`viewer e2e: passed in ${secs(t0)}`);
process.exit(code);
